"""
Benchmark: ``session_record`` keeps up with 1200 Hz gaze (issue 40).

The ``session_record`` executable in a process of its own records
``gaze/samples`` while this process publishes 1200 samples a second for
``seconds``: ``per_sample``, one sensor_msgs/PointCloud2 per sample (1200
messages/s, the worst a tracker relay could send; ``lsl_gaze_bridge`` batches
what it pulls), and ``chunks_12``, 12 samples per message (100 messages/s, a
10 ms chunk).  Measured: the recorder's CPU time over the wall time while it
records (psutil; 100 % = one core), the messages in the closed bag against
those published (``lost``; read back with rosbags), and the bag's size.

Reference in the same run: a process with one rclpy node whose raw
subscription to ``gaze/samples`` only counts (:data:`REFERENCE_NODE`: the floor
of receiving these messages in Python).  ``ratio`` = recorder CPU / reference
CPU.  Target: nothing lost and at most :data:`TARGET_PERCENT` % of a core at
1200 messages/s (``meets_target``): what a 2-core lab PC running the pipeline
and RViz can give it.
"""

import os
import signal
import subprocess
import sys
import tempfile
import time
from typing import Dict

from domain_coordinator import domain_id
import numpy as np
import psutil
import rclpy
from rclpy.context import Context
from rclpy.duration import Duration
from rosbags.rosbag2 import Reader
from sensor_msgs.msg import PointCloud2

from eye_bci_ros2.ros.conversions import gaze_batch
from eye_bci_ros2.ros.runner import make_executor, spin_for, spin_until
from eye_bci_ros2.ros.topics import GAZE_QOS, GAZE_SAMPLES_TOPIC

#: Metrics shown in the printed table (the JSON has them all).
TABLE_COLUMNS = ('messages_per_s', 'sent', 'recorded', 'lost', 'cpu_percent',
                 'reference_cpu_percent', 'ratio', 'bag_mb', 'target', 'meets_target')
#: Gaze rate, Hz.
RATE_HZ = 1200
#: Recorder CPU at 1200 messages/s, % of one core, at most.
TARGET_PERCENT = 25.0
#: Seconds recorded per case (quick: QUICK_SECONDS).
SECONDS = 10.0
QUICK_SECONDS = 2.0
#: Samples per message of each case.
CASES = {'per_sample': 1, 'chunks_12': 12}
#: The reference: one node that receives gaze/samples raw and counts.
REFERENCE_NODE = """
import signal, sys, rclpy
from sensor_msgs.msg import PointCloud2
from eye_bci_ros2.ros.topics import GAZE_QOS, GAZE_SAMPLES_TOPIC
from eye_bci_ros2.ros.runner import make_executor
from rclpy.signals import SignalHandlerOptions
stop = []
signal.signal(signal.SIGINT, lambda *_: stop.append(1))
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
node = rclpy.create_node('gaze_counter')
count = [0]
node.create_subscription(PointCloud2, GAZE_SAMPLES_TOPIC,
                         lambda m: count.__setitem__(0, count[0] + 1), GAZE_QOS, raw=True)
executor = make_executor()
executor.add_node(node)
print('ready', flush=True)
while not stop:
    executor.spin_once(timeout_sec=0.1)
print(f'received {count[0]}', flush=True)
"""


def _publish(graph_node, publisher, per_message: int, seconds: float, executor) -> int:
    """Publish RATE_HZ samples a second in messages of ``per_message``; return how many."""
    period = per_message / RATE_HZ
    points = np.full((per_message, 2), 500.0)
    start = time.monotonic()
    sent = 0
    while True:
        due = start + sent * period
        now = time.monotonic()
        if now - start >= seconds:
            return sent
        if now < due:
            spin_for(executor, min(due - now, 0.005))
            continue
        first = graph_node.get_clock().now().nanoseconds
        stamps = first + (np.arange(per_message) * 1e9 / RATE_HZ).astype(np.int64)
        publisher.publish(gaze_batch(stamps, points))
        sent += 1


def _case(per_message: int, seconds: float, domain: int, folder: str) -> Dict[str, object]:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    executor = make_executor(context=context)
    node = rclpy.create_node('gaze_publisher', context=context)
    executor.add_node(node)
    publisher = node.create_publisher(PointCloud2, GAZE_SAMPLES_TOPIC, GAZE_QOS)
    row: Dict[str, object] = {'messages_per_s': RATE_HZ / per_message}
    try:
        for kind in ('reference', 'recorder'):
            bag = os.path.join(folder, f'bag_{per_message}')
            command = ([sys.executable, '-c', REFERENCE_NODE] if kind == 'reference' else
                       [sys.executable, '-m', 'eye_bci_ros2.tools.session_record', '-o', bag])
            process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE,
                                       stderr=subprocess.STDOUT, text=True)
            try:
                if not spin_until(executor, lambda: publisher.get_subscription_count() > 0,
                                  60.0):
                    raise RuntimeError(f'the {kind} never subscribed to {GAZE_SAMPLES_TOPIC}')
                spin_for(executor, 0.5)
                measured = psutil.Process(process.pid)
                before = measured.cpu_times()
                started = time.monotonic()
                sent = _publish(node, publisher, per_message, seconds, executor)
                # Reliable: every message delivered (acknowledged) before the stop.
                publisher.wait_for_all_acked(Duration(seconds=10.0))
                spin_for(executor, 0.3)     # and taken from the reader's queue
                after = measured.cpu_times()
                wall = time.monotonic() - started
                cpu = 100.0 * ((after.user - before.user) + (after.system - before.system)) / wall
            finally:
                process.send_signal(signal.SIGINT)
                output, _ = process.communicate(timeout=60)
            if process.returncode != 0:
                raise RuntimeError(f'the {kind} ended with status {process.returncode}: '
                                   f'{output.strip()[-500:]}')
            if kind == 'reference':
                row['reference_cpu_percent'] = round(cpu, 1)
                row['reference_sent'] = sent
                row['reference_received'] = int(output.split('received')[-1])
                continue
            with Reader(bag) as reader:
                recorded = sum(c.msgcount for c in reader.connections
                               if c.topic == '/' + GAZE_SAMPLES_TOPIC)
            size = sum(os.path.getsize(os.path.join(bag, f)) for f in os.listdir(bag))
            row.update(sent=sent, recorded=recorded, lost=sent - recorded,
                       cpu_percent=round(cpu, 1), bag_mb=round(size / 1e6, 2))
    finally:
        executor.shutdown()
        node.destroy_node()
        context.try_shutdown()
    row['ratio'] = round(row['cpu_percent'] / max(row['reference_cpu_percent'], 0.1), 2)
    return row


def run(quick: bool = False, seconds: float = 0.0) -> Dict[str, Dict[str, object]]:
    """Return ``{case: {metric: value}}`` (module doc)."""
    seconds = seconds or (QUICK_SECONDS if quick else SECONDS)
    section = {}
    with domain_id() as domain, tempfile.TemporaryDirectory() as folder:
        for name, per_message in CASES.items():
            row = _case(per_message, seconds, domain, folder)
            if per_message == 1:
                row['target'] = f'none lost, <= {TARGET_PERCENT:g} % of a core'
                row['meets_target'] = row['lost'] == 0 and row['cpu_percent'] <= TARGET_PERCENT
            else:
                row['target'] = 'none lost'
                row['meets_target'] = row['lost'] == 0
            section[name] = row
    return section


if __name__ == '__main__':
    for case, values in run().items():
        print(case, values)
