"""
Measure lsl_gaze_bridge at a Tobii Pro rate: CPU, loss and acquisition -> receipt latency.

Runs the bridge as its own process (as ``ros2 run`` would) on a private ROS
domain, feeds it a real LSL outlet laid out like the Tobii Pro app, and
listens on ``gaze`` in this process.  Not a test (no assertions); run::

    .venv/bin/python test/bench_lsl_gaze_bridge.py [--rate 1200] [--seconds 10]
"""

import argparse
import os
import subprocess
import sys
import time

from domain_coordinator import domain_id
from geometry_msgs.msg import PointStamped
# test/ is on sys.path when this file runs as a script.
from lsl_outlets import make_outlet, sample_for
import numpy as np
import psutil
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from eye_bci_ros2.nodes.topics import GAZE_QOS


def spin(executor, seconds, until=None):
    """Spin ``executor`` for ``seconds`` or until ``until()`` is true."""
    end = time.monotonic() + seconds
    while time.monotonic() < end and not (until and until()):
        executor.spin_once(timeout_sec=0.01)


def main():
    """Run the measurement and print one line of results."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--rate', type=float, default=1200.0, help='samples per second')
    parser.add_argument('--seconds', type=float, default=10.0, help='duration of the run')
    args = parser.parse_args()
    with domain_id() as domain:
        outlet, info = make_outlet('tobii_pro', rate=args.rate)
        bridge = subprocess.Popen(
            [sys.executable, '-m', 'eye_bci_ros2.nodes.lsl_gaze_bridge', '--ros-args',
             '-p', 'profile:=tobii_pro', '-p', f'stream_name:={info.name()}',
             '-p', f'source_id:={info.source_id()}', '--log-level', 'warn'],
            env=dict(os.environ, ROS_DOMAIN_ID=str(domain)))
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        node = Node('bench_gaze_listener', context=context)
        latencies_ms = []

        def on_gaze(message):
            stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
            latencies_ms.append((node.get_clock().now().nanoseconds - stamp) / 1e6)

        node.create_subscription(PointStamped, 'gaze', on_gaze, GAZE_QOS)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        try:
            spin(executor, 30.0, lambda: outlet.have_consumers()
                 and node.count_publishers('gaze') > 0)
            spin(executor, 2.0)   # clock sync in the bridge, endpoint matching
            process = psutil.Process(bridge.pid)
            rng = np.random.default_rng(1)
            cpu_before = process.cpu_times()
            start = time.monotonic()
            pushed = 0
            while time.monotonic() - start < args.seconds:
                due = int((time.monotonic() - start) * args.rate) - pushed
                if due > 0:
                    points = rng.uniform([0, 0], [1920, 1080], (due, 2))
                    outlet.push_chunk(sample_for('tobii_pro', points,
                                                 eye_offset_px=(5.0, 5.0)).tolist())
                    pushed += due
                spin(executor, 0.01)
            cpu_after = process.cpu_times()
            wall = time.monotonic() - start
            spin(executor, 3.0, lambda: len(latencies_ms) >= pushed)
        finally:
            bridge.terminate()
            bridge.wait(10)
            executor.shutdown()
            node.destroy_node()
            context.try_shutdown()
    cpu = (cpu_after.user + cpu_after.system - cpu_before.user - cpu_before.system) / wall
    latency = np.array(latencies_ms) if latencies_ms else np.array([np.nan])
    print(f'{pushed} samples pushed at {args.rate:g} Hz for {wall:.1f} s, '
          f'{len(latencies_ms)} received; bridge process CPU {100 * cpu:.1f}% of one core; '
          f'acquisition -> receipt latency ms: median {np.median(latency):.1f}, '
          f'p99 {np.percentile(latency, 99):.1f}, max {latency.max():.1f}')


if __name__ == '__main__':
    main()
