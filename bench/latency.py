"""
Benchmark: LSL push -> ``choice`` latency at 1200 Hz on a real ROS 2 graph.

Four processes on a private ROS domain (``domain_coordinator``):

* the *pusher* (``multiprocessing``, spawn): a real pylsl outlet laid out as
  the ``xy_pixels`` profile (the original C# sender: x, y px of a 1366x768
  screen) pushing one sample every 1/1200 s, paced by absolute deadlines;
  every sample lies off all regions except one marked sample per round;
* the *bridge*: ``lsl_gaze_bridge`` through its own ``main`` (as
  ``ros2 run`` starts it) in a subprocess, with its default parameters
  apart from the stream selection.  Its CPU share is that process's user +
  system CPU time over the measured rounds divided by their wall time
  (psutil; 100 % = one core), so it counts every bridge thread (executor,
  liblsl, DDS) and nothing else;
* the *view*: camera_tracker (static default view) and marker_projector on
  one executor (spawn); they work only when the view or the menu changes;
* this process: choice_arbiter and a driver node on one
  SingleThreadedExecutor, as lean as ``ros2 run choice_arbiter`` plus the
  node that consumes ``choice``; the driver publishes three cube markers on
  ``choices``, requests rounds and receives ``choice``.  Its CPU share is
  reported as ``arbiter_process_cpu_percent``.

A round: the driver publishes ``choice/request`` and waits until the arbiter
has opened the round; it then asks the pusher to make the first sample due
a random 0-25 ms later the marked one (so it falls at any phase of the
bridge's poll timer), aimed at the vertex mean of one region (taken from
``choices/regions``; the target changes every round).  The arbiter decides
early on one in-region sample (``min_samples`` 1, ``dwell_s`` 0,
``confidence`` 0.8 < the 0.9 posterior of one sample among three regions;
``min_reaction_s`` 0 because the marked sample comes sooner after the request
than a person could react, and the arbiter would otherwise not count it;
the original inside-only rule without the share test, which would wait for
more samples),
so the marked sample is the sample that decides the round; a round counts
only if the arbiter's decision is the target with exactly one in-region
sample.  Latency = receipt of ``choice`` in the driver's callback minus the
push of the marked sample, both on ``pylsl.local_clock()`` (CLOCK_MONOTONIC:
one clock for every process on the machine).  It includes the LSL transfer,
the bridge's poll period (it pulls chunks on a timer), two DDS hops (gaze,
choice) and the arbiter's work.

Usage::

    python -m bench.latency [--quick] [--rounds N] [--poll-period S]
"""

import argparse
import json
import math
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time
from typing import Dict, List, Optional, Sequence, Tuple
import uuid

from domain_coordinator import domain_id
import numpy as np
import psutil
import pylsl
import rclpy
from rclpy.context import Context
from rclpy.logging import LoggingSeverity
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.decision.rounds import COUNT_RULE, ORIGINAL_RULE
from eye_bci_ros2.gaze.profiles import PROFILES
from eye_bci_ros2.nodes import lsl_gaze_bridge
from eye_bci_ros2.nodes.camera_tracker import CameraTracker
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.ros.conversions import cube_marker, marker_array_to_regions
from eye_bci_ros2.ros.runner import make_executor, spin_for, spin_until
from eye_bci_ros2.ros.startup import quiet_liblsl
from eye_bci_ros2.ros.topics import (CHOICE_TOPIC, CHOICES_TOPIC, EVENT_QOS, LATCHED_QOS,
                                     REGIONS_TOPIC, REQUEST_TOPIC)
from eye_bci_ros2.sim.lsl_outlet import open_outlet, stream_info

#: Push rate of the simulated tracker, Hz.
RATE_HZ = 1200.0
#: Rounds measured (quick mode: QUICK_ROUNDS).
ROUNDS = 200
QUICK_ROUNDS = 20
#: The goal: p99 push -> choice at most this, ms, at every rate measured.
GOAL_P99_MS = 3.0
#: Tracker rates measured by run(): a Tobii Pro, an EyeLink-class tracker, Hz.
RATES_HZ = (1200.0, 2000.0)
#: Cube markers (label, position in map, m) in view of camera_tracker's default static view.
MARKERS = (('kitchen', (7.0, 6.0, 0.0)), ('bedroom', (10.0, 6.0, 0.0)),
           ('bathroom', (13.0, 6.0, 0.0)))
MARKER_SCALE = (1.5, 1.5, 0.05)
#: Where the gaze rests between marked samples: screen px outside the render panel.
OFF_REGION_PX = (60.0, 60.0)
#: Arbiter settings that make the first in-region sample decide a round (the inside
#: classification without the share test: one sample among off-region ones must decide).
ARBITER_PARAMETERS = {**COUNT_RULE, 'early_decision': True, 'min_samples': 1, 'dwell_s': 0.0,
                      'min_reaction_s': 0.0, 'confidence': 0.8, 'window_s': 30.0,
                      **ORIGINAL_RULE}
#: Waits, s.
SETUP_TIMEOUT_S = 30.0
ROUND_TIMEOUT_S = 3.0
WARMUP_S = 1.0
#: Pause between rounds, s.
PAUSE_S = (0.01, 0.02)
#: The marked sample is pushed this long after the pusher gets the command
#: (random in this range, longer than the bridge's poll period: any phase of its timer), s.
MARK_DELAY_S = (0.0, 0.025)


def encode_xy_pixels(screen_xy: Sequence[float]) -> List[float]:
    """Screen px (1920x1080) -> what the original sender sends (px of its 1366x768 screen)."""
    spec = PROFILES['xy_pixels']
    return [screen_xy[0] * spec.source_width / 1920.0,
            screen_xy[1] * spec.source_height / 1080.0]


def make_outlet(name: str, source_id: str, rate: float) -> pylsl.StreamOutlet:
    """Open an LSL outlet laid out as the ``xy_pixels`` profile (2 float32 channels)."""
    spec = PROFILES['xy_pixels']
    return open_outlet(stream_info(name, spec.stream_type, len(spec.channel_labels), rate,
                                   source_id, spec.channel_format))


def push_loop(conn, name: str, source_id: str, rate: float) -> None:
    """
    Push gaze at ``rate`` until told to stop (the pusher process).

    Protocol on ``conn``: in, ``(round, x, y, delay_s)`` = make the first
    sample due ``delay_s`` after now the marked one, at screen px (x, y), or
    None = stop; out, ``('ready',)`` once
    the outlet exists, ``(round, push_time)`` per marked sample
    (``pylsl.local_clock()`` just before the push, also its LSL timestamp),
    and ``('done', samples, seconds)`` at the end.
    """
    outlet = make_outlet(name, source_id, rate)
    off = encode_xy_pixels(OFF_REGION_PX)
    conn.send(('ready',))
    period = 1.0 / rate
    start = pylsl.local_clock()
    pushed = 0
    marked, marked_from = None, math.inf
    while True:
        due = start + pushed * period
        delay = due - pylsl.local_clock()
        if delay > 0:
            time.sleep(delay)
        if conn.poll():
            command = conn.recv()
            if command is None:
                break
            marked, marked_from = command[:3], pylsl.local_clock() + command[3]
        if marked is not None and due >= marked_from:
            round_id, x, y = marked
            marked, marked_from = None, math.inf
            pushed_at = pylsl.local_clock()
            outlet.push_sample(encode_xy_pixels((x, y)), pushed_at)
            conn.send((round_id, pushed_at))
        else:
            outlet.push_sample(off, pylsl.local_clock())
        pushed += 1
    conn.send(('done', pushed, pylsl.local_clock() - start))


def view_nodes_loop(domain: int, stop) -> None:
    """
    Run camera_tracker and marker_projector on one executor until ``stop`` is set.

    They work only when the view or the menu changes, but every node on an
    rclpy executor adds to the cost of each wait: running them here keeps
    the process of the arbiter as lean as ``ros2 run choice_arbiter`` is.
    """
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    executor = make_executor(context=context)
    nodes = [CameraTracker(context=context), MarkerProjector(context=context)]
    try:
        for node in nodes:
            node.get_logger().set_level(LoggingSeverity.WARN)
            executor.add_node(node)
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)
    finally:
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        context.try_shutdown()


class Driver(Node):
    """Publish the menu and round requests; timestamp every ``choice`` on arrival."""

    def __init__(self, **kwargs):
        """Create the publishers and subscriptions."""
        super().__init__('latency_bench_driver', **kwargs)
        self.choices_pub = self.create_publisher(MarkerArray, CHOICES_TOPIC, LATCHED_QOS)
        self.request_pub = self.create_publisher(Empty, REQUEST_TOPIC, EVENT_QOS)
        self.received: List[Tuple[float, str]] = []
        self.regions: Optional[MarkerArray] = None
        self.create_subscription(String, CHOICE_TOPIC, self._on_choice, EVENT_QOS)
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)

    def _on_choice(self, message: String) -> None:
        self.received.append((pylsl.local_clock(), message.data))

    def _on_regions(self, message: MarkerArray) -> None:
        self.regions = message

    def publish_menu(self) -> None:
        """Publish the cube markers of :data:`MARKERS`."""
        markers = [cube_marker('bench', index, label, 'map', position, (0.0, 0.0, 0.0, 1.0),
                               MARKER_SCALE)
                   for index, (label, position) in enumerate(MARKERS)]
        self.choices_pub.publish(MarkerArray(markers=markers))

    def targets(self) -> Dict[str, Tuple[float, float]]:
        """Return label -> vertex mean of its region, screen px (from choices/regions)."""
        labels, polygons = marker_array_to_regions(self.regions)
        return {label: tuple(polygon.mean(axis=0)) for label, polygon in zip(labels, polygons)}


def _cpu_seconds(process: psutil.Process) -> float:
    times = process.cpu_times()
    return times.user + times.system


def _bridge_command(name: str, source_id: str, poll_period_s: Optional[float]) -> List[str]:
    # The marked sample decides at a time the arbiter cannot announce (choice/due): the
    # bridge pulls every poll_period_s throughout, the path a due decision takes.
    poll = default_poll_period() if poll_period_s is None else poll_period_s
    command = [sys.executable, '-m', 'eye_bci_ros2.nodes.lsl_gaze_bridge', '--ros-args',
               '-p', 'profile:=xy_pixels', '-p', f'stream_name:={name}',
               '-p', f'source_id:={source_id}', '-p', 'stats_period_s:=0.0',
               '-p', f'idle_poll_period_s:={poll!r}']
    if poll_period_s is not None:
        command += ['-p', f'poll_period_s:={poll_period_s!r}']
    return command + ['--log-level', 'warn']


def default_poll_period() -> float:
    """Return the bridge's default ``poll_period_s``, s."""
    return next(spec.default for spec in lsl_gaze_bridge.PARAMETERS
                if spec.name == 'poll_period_s')


def measure(rounds: int, poll_period_s: Optional[float] = None, rate: float = RATE_HZ,
            seed: int = 5, log=sys.stderr) -> Dict[str, object]:
    """
    Run the three processes and measure ``rounds`` rounds.

    :param poll_period_s: the bridge's poll period, s (None: its default).
    :returns: the latency section (see :func:`run`).
    """
    rng = np.random.default_rng(seed)
    name = f'latency-bench-{uuid.uuid4().hex}'
    source_id = f'latency-bench-source-{uuid.uuid4().hex}'
    spawn = multiprocessing.get_context('spawn')
    here, there = spawn.Pipe()
    pusher = spawn.Process(target=push_loop, args=(there, name, source_id, rate), daemon=True)
    stop_view = spawn.Event()
    view, bridge = None, None
    bridge_log = tempfile.TemporaryFile(mode='w+')
    with domain_id() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        executor = make_executor(context=context)
        nodes = []
        try:
            nodes = [ChoiceArbiter(context=context, parameter_overrides=[
                         Parameter(key, value=value)
                         for key, value in ARBITER_PARAMETERS.items()]),
                     Driver(context=context)]
            arbiter, driver = nodes
            view = spawn.Process(target=view_nodes_loop, args=(domain, stop_view), daemon=True)
            view.start()
            for node in nodes:
                # One log line per round would cost time inside the measured callbacks.
                node.get_logger().set_level(LoggingSeverity.WARN)
                executor.add_node(node)
            driver.publish_menu()
            if not spin_until(executor, lambda: driver.regions is not None
                              and len(driver.regions.markers) == len(MARKERS),
                              SETUP_TIMEOUT_S):
                raise RuntimeError('marker_projector published no regions for the menu')
            targets = driver.targets()

            pusher.start()
            started = time.monotonic()
            while not here.poll(0.1):
                if not pusher.is_alive() or time.monotonic() - started > SETUP_TIMEOUT_S:
                    raise RuntimeError('the LSL pusher process did not start')
            here.recv()
            bridge = subprocess.Popen(
                _bridge_command(name, source_id, poll_period_s),
                env=dict(os.environ, ROS_DOMAIN_ID=str(domain)),
                stdout=subprocess.DEVNULL, stderr=bridge_log)
            if not spin_until(executor, lambda: arbiter.samples_received > 0, SETUP_TIMEOUT_S):
                raise RuntimeError('no gaze reached the arbiter (bridge log: '
                                   f'{_tail(bridge_log)})')
            spin_for(executor, WARMUP_S)

            bridge_process, own_process = psutil.Process(bridge.pid), psutil.Process()
            cpu_start = (_cpu_seconds(bridge_process), _cpu_seconds(own_process))
            wall_start, samples_start = time.monotonic(), arbiter.samples_received
            latencies, invalid, lost = [], 0, 0
            labels = list(targets)
            for round_id in range(rounds):
                label = labels[round_id % len(labels)]
                opened = arbiter.rounds_started
                driver.request_pub.publish(Empty())
                if not spin_until(executor, lambda: arbiter.rounds_started > opened,
                                  ROUND_TIMEOUT_S):
                    lost += 1
                    continue
                spin_for(executor, rng.uniform(*PAUSE_S))
                received = len(driver.received)
                # A random delay in the pusher makes the marked sample independent of
                # this loop's timing, which follows the bridge's poll timer.
                here.send((round_id, *targets[label], rng.uniform(*MARK_DELAY_S)))
                got = spin_until(executor, lambda: len(driver.received) > received,
                                 ROUND_TIMEOUT_S)
                pushed_at = _pushed_at(here, round_id)
                if not got or pushed_at is None:
                    lost += 1
                    continue
                received_at, chosen = driver.received[received]
                decision = arbiter.last_decision
                if chosen != label or decision.in_region_samples != 1:
                    invalid += 1
                    continue
                latencies.append((received_at - pushed_at) * 1e3)
            wall = time.monotonic() - wall_start
            bridge_cpu = _cpu_seconds(bridge_process) - cpu_start[0]
            own_cpu = _cpu_seconds(own_process) - cpu_start[1]
            gaze_rate = (arbiter.samples_received - samples_start) / wall
        finally:
            if pusher.is_alive():
                here.send(None)
            pushed = _finish_pusher(here, pusher)
            if view is not None:
                stop_view.set()
                view.join(10.0)
                if view.is_alive():
                    view.terminate()
                    view.join()
            if bridge is not None:
                bridge.terminate()
                try:
                    bridge.wait(5.0)
                except subprocess.TimeoutExpired:
                    bridge.kill()
                    bridge.wait()
            executor.shutdown()
            for node in nodes:
                node.destroy_node()
            context.try_shutdown()
            bridge_log.close()
    return _summary(latencies, invalid, lost, rounds, pushed, gaze_rate,
                    100.0 * bridge_cpu / wall, 100.0 * own_cpu / wall,
                    default_poll_period() if poll_period_s is None else poll_period_s, rate)


def _pushed_at(conn, round_id: int) -> Optional[float]:
    """Push time of round ``round_id``'s marked sample, from the pusher."""
    while conn.poll(ROUND_TIMEOUT_S):
        message = conn.recv()
        if message[0] == round_id:
            return message[1]
    return None


def _finish_pusher(conn, pusher) -> Tuple[int, float]:
    """Wait for the pusher's final count; return (samples pushed, seconds)."""
    result = (0, math.nan)
    while pusher.is_alive() or conn.poll():
        if not conn.poll(5.0):
            break
        message = conn.recv()
        if message[0] == 'done':
            result = (message[1], message[2])
            break
    pusher.join(5.0)
    if pusher.is_alive():
        pusher.terminate()
        pusher.join()
    return result


def _tail(stream, size: int = 2000) -> str:
    stream.flush()
    stream.seek(0)
    return stream.read()[-size:].strip() or 'empty'


def _summary(latencies: List[float], invalid: int, lost: int, rounds: int,
             pushed: Tuple[int, float], gaze_rate: float, bridge_cpu: float,
             arbiter_cpu: float, poll_period_s: float, rate: float) -> Dict[str, object]:
    """Build the result section."""
    values = np.asarray(latencies, dtype=float)

    def percentile(q: float) -> float:
        return round(float(np.percentile(values, q)), 3) if len(values) else math.nan

    samples, seconds = pushed
    p99 = percentile(99)
    return {
        'p50_ms': percentile(50),
        'p90_ms': percentile(90),
        'p99_ms': p99,
        'max_ms': round(float(values.max()), 3) if len(values) else math.nan,
        'min_ms': round(float(values.min()), 3) if len(values) else math.nan,
        'mean_ms': round(float(values.mean()), 3) if len(values) else math.nan,
        'bridge_cpu_percent': round(bridge_cpu, 1),
        'arbiter_process_cpu_percent': round(arbiter_cpu, 1),
        'rounds': len(values),
        'rounds_requested': rounds,
        'rounds_wrong_choice': invalid,
        'rounds_lost': lost,
        'push_rate_hz': round(samples / seconds, 1) if seconds > 0 else math.nan,
        'target_rate_hz': rate,
        'gaze_rate_at_arbiter_hz': round(gaze_rate, 1),
        'bridge_poll_period_s': poll_period_s,
        'goal_p99_ms': GOAL_P99_MS,
        'meets_goal': bool(len(values) == rounds and p99 <= GOAL_P99_MS),
    }


def run(quick: bool = False, rounds: int = 0) -> Dict[str, object]:
    """
    Measure push -> choice latency with the bridge's default poll period at each of RATES_HZ.

    :param quick: QUICK_ROUNDS rounds instead of ROUNDS.
    :param rounds: rounds per rate (0: ROUNDS, or QUICK_ROUNDS when quick).
    :returns: ``{'1200': {...}, '2000': {...}}``, each ``{'p50_ms', 'p90_ms', 'p99_ms',
        'max_ms', 'mean_ms', 'bridge_cpu_percent', 'arbiter_process_cpu_percent',
        'rounds', ..., 'push_rate_hz', 'gaze_rate_at_arbiter_hz', 'bridge_poll_period_s',
        'goal_p99_ms', 'meets_goal'}``; CPU in % of one core: the bridge process, and
        this process (choice_arbiter and the driver).
    """
    rounds = rounds or (QUICK_ROUNDS if quick else ROUNDS)
    return {f'{rate:g}': measure(rounds, rate=rate) for rate in RATES_HZ}


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the benchmark and print ``{"latency": {...}}``; 1 if the goal is missed."""
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    parser = argparse.ArgumentParser(prog='python -m bench.latency',
                                     description=__doc__.strip().splitlines()[0])
    parser.add_argument('--quick', action='store_true', help=f'{QUICK_ROUNDS} rounds')
    parser.add_argument('--rounds', type=int, default=0, help=f'rounds (default {ROUNDS})')
    parser.add_argument('--poll-period', type=float, default=None, metavar='S',
                        help="the bridge's poll_period_s (default: the bridge's default, "
                             f'{default_poll_period()} s)')
    parser.add_argument('--rate', type=float, default=RATE_HZ, help='push rate, Hz')
    args = parser.parse_args(argv)
    rounds = args.rounds or (QUICK_ROUNDS if args.quick else ROUNDS)
    section = measure(rounds, args.poll_period, args.rate)
    print(json.dumps({'latency': section}, indent=2))
    return 0 if section['meets_goal'] else 1


if __name__ == '__main__':
    sys.exit(main())
