"""
Soak test: the real pipeline under a 1200 Hz LSL gaze stream for minutes (``make soak``).

Runs lsl_gaze_bridge, camera_tracker, marker_projector and choice_arbiter in
this process on one executor (as ``eye_bci`` does: the EventsExecutor), on a
private ROS domain, fed by a real LSL outlet whose samples a background thread
pushes at the nominal rate (12 every 10 ms at 1200 Hz) with exact sample
times.  Every ``--round-period`` seconds a driver node offers the other of two
menus (three rooms, three tables; a new set of labels starts a round) and the
simulated person looks at one of its choices, a different one each round.

Measured, and written to ``soak_results.json``:

* memory: resident set size every ``--sample-period`` s, and its growth
  (least-squares slope after the first minute, or the first half of a short
  run, MB/min);
* CPU: this process's CPU use over each sample period (100 % = one core);
* samples: pushed into LSL (from the moment the bridge connected) vs samples
  in the ``gaze/samples`` batches received on the ROS side (a subscriber on
  the same executor): none may be lost;
* rounds: every round had gaze on a region, so each must end in exactly one
  ``choice``, the looked-at label: rounds without a choice and wrong choices
  are counted; decision latency = choice arrival minus the round's window end.

Usage::

    python -m bench.soak [--minutes 10 | --quick] [--rate 1200] [--output soak_results.json]

Not part of CI: it takes minutes and its numbers depend on the machine.
"""

import argparse
import datetime
import json
import math
import statistics
import sys
import threading
import time
from typing import Dict, List, Optional
import uuid

from domain_coordinator import domain_id
import numpy as np
import psutil
import pylsl
import rclpy
from rclpy.context import Context
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from bench.timing import machine_info
from eye_bci_ros2.nodes.camera_tracker import CameraTracker
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.conversions import cube_marker
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.nodes.runner import executor_kind, make_executor, spin_until
from eye_bci_ros2.nodes.topics import (CHOICE_TOPIC, CHOICES_TOPIC, EVENT_QOS, GAZE_QOS,
                                       GAZE_SAMPLES_TOPIC, LATCHED_QOS)
from eye_bci_ros2.projection.camera_model import RvizCamera
from eye_bci_ros2.sim.lsl_outlet import open_outlet, stream_info

#: Static RViz view of the soak (world frame ``map``, m).
EYE, FOCUS, UP = [0.0, -8.0, 12.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]

#: The two menus offered in turn: label -> (x, y) of a 1.5 m flat cube on the floor.
MENUS = (
    {'kitchen': (-3.0, 0.0), 'bedroom': (0.0, 1.0), 'bathroom': (3.0, 0.0)},
    {'table 1': (-2.0, -2.0), 'table 2': (0.5, -1.5), 'table 3': (3.0, -2.5)},
)

#: Decision window of the arbiter, s (rounds are ``--round-period`` apart).
WINDOW_S = 0.6

#: Gaze scatter around the looked-at point, px (fixational jitter plus tracker noise).
GAZE_NOISE_PX = 8.0

#: Samples pushed per chunk: one chunk per 10 ms, as a tracker SDK delivers them.
PUSH_PERIOD_S = 0.01


def menu_markers(menu: Dict[str, tuple], ns: str) -> MarkerArray:
    """Build a DELETEALL and one CUBE per choice, as the menu publishes them."""
    clear = Marker(action=Marker.DELETEALL)
    clear.header.frame_id = 'map'
    array = MarkerArray(markers=[clear])
    for index, (label, (x, y)) in enumerate(menu.items()):
        array.markers.append(cube_marker(ns, index, label, 'map', [x, y, 0.0],
                                         [0.0, 0.0, 0.0, 1.0], [1.5, 1.5, 0.05]))
    return array


def screen_targets() -> Dict[str, np.ndarray]:
    """Screen px (2,) of the centre of every choice's region in the static view."""
    camera = RvizCamera.from_look_at(EYE, FOCUS, UP)
    targets = {}
    for menu in MENUS:
        positions = np.array([[x, y, 0.0] for x, y in menu.values()])
        polygons, visible = camera.box_regions(
            positions, np.tile([0.0, 0.0, 0.0, 1.0], (len(menu), 1)),
            np.tile([1.5, 1.5, 0.05], (len(menu), 1)))
        assert visible.all(), 'a soak menu choice is off the screen'
        for label, polygon in zip(menu, polygons):
            targets[label] = np.unique(polygon, axis=0).mean(axis=0)
    return targets


class GazePusher(threading.Thread):
    """Push gaze samples at ``rate`` Hz into an LSL outlet, looking at ``target``."""

    def __init__(self, outlet: pylsl.StreamOutlet, rate: float, seed: int = 1):
        """Prepare; call :meth:`start`, set :attr:`target`, :meth:`stop` at the end."""
        super().__init__(daemon=True)
        self.outlet = outlet
        self.rate = rate
        self.target = np.array([20.0, 20.0])   # screen px; off every region
        self.pushed = 0
        self._halt = threading.Event()
        self._rng = np.random.default_rng(seed)

    def run(self) -> None:
        """Push every sample that is due, each stamped with its own sample time."""
        start = pylsl.local_clock()
        while not self._halt.is_set():
            due = int((pylsl.local_clock() - start) * self.rate) + 1
            count = due - self.pushed
            if count > 0:
                stamps = start + (self.pushed + np.arange(count)) / self.rate
                points = self._rng.normal(self.target, GAZE_NOISE_PX, (count, 2))
                self.outlet.push_chunk(points.tolist(), stamps.tolist())
                self.pushed += count
            self._halt.wait(PUSH_PERIOD_S)

    def stop(self) -> None:
        """Stop pushing and wait for the thread."""
        self._halt.set()
        self.join()


class Round:
    """One question of the soak: what was offered, looked at, and chosen."""

    def __init__(self, index: int, target: str, offered_at: float):
        """Record a round offered at ``offered_at`` (ROS time, s)."""
        self.index = index
        self.target = target
        self.offered_at = offered_at
        self.choices: List[str] = []
        self.latencies: List[float] = []


class Soak:
    """The pipeline, the driver and the measurements."""

    def __init__(self, args: argparse.Namespace, context: Context):
        """Create the nodes and the LSL outlet."""
        self.args = args
        stream_id = uuid.uuid4().hex
        info = stream_info(f'soak-{stream_id}', f'soak-gaze-{stream_id}', 2, args.rate,
                           f'soak-source-{stream_id}')
        self.outlet = open_outlet(info)
        bridge = {'profile': 'custom', 'stream_type': info.type(), 'stream_name': info.name(),
                  'source_id': info.source_id(), 'stats_period_s': 0.0}
        self.nodes = [
            LslGazeBridge(context=context, parameter_overrides=_parameters(bridge)),
            CameraTracker(context=context, parameter_overrides=_parameters(
                {'eye': EYE, 'focus': FOCUS, 'up': UP})),
            MarkerProjector(context=context, parameter_overrides=_parameters(
                {'screen_offset_x': 0, 'screen_offset_y': 0})),
            ChoiceArbiter(context=context, parameter_overrides=_parameters(
                {'window_s': WINDOW_S, 'stall_timeout_s': 0.2})),
        ]
        self.bridge, self.arbiter = self.nodes[0], self.nodes[3]
        self.driver = rclpy.create_node('soak_driver', context=context)
        self.executor = make_executor(context=context)
        for node in self.nodes + [self.driver]:
            self.executor.add_node(node)
        self.choices_pub = self.driver.create_publisher(MarkerArray, CHOICES_TOPIC, LATCHED_QOS)
        self.gaze_received = 0
        self.driver.create_subscription(PointCloud2, GAZE_SAMPLES_TOPIC, self._on_gaze, GAZE_QOS)
        self.driver.create_subscription(String, CHOICE_TOPIC, self._on_choice, EVENT_QOS)
        self.targets = screen_targets()
        self.pusher = GazePusher(self.outlet, args.rate)
        self.rounds: List[Round] = []
        self.process = psutil.Process()
        self.samples: List[Dict[str, float]] = []

    def _now(self) -> float:
        return self.driver.get_clock().now().nanoseconds * 1e-9

    def _on_gaze(self, message: PointCloud2) -> None:
        self.gaze_received += message.width * message.height

    def _on_choice(self, message: String) -> None:
        if self.rounds:
            current = self.rounds[-1]
            current.choices.append(message.data)
            current.latencies.append(self._now() - (current.offered_at + WINDOW_S))

    def spin_until(self, predicate, timeout: float) -> bool:
        """Spin until ``predicate()`` holds; return whether it did."""
        return spin_until(self.executor, predicate, timeout)

    def offer(self, index: int) -> None:
        """Offer the next menu and look at one of its choices."""
        menu = MENUS[index % len(MENUS)]
        labels = list(menu)
        target = labels[(index // len(MENUS)) % len(labels)]
        self.rounds.append(Round(index, target, self._now()))
        self.pusher.target = self.targets[target]
        self.choices_pub.publish(menu_markers(menu, f'menu{index % len(MENUS)}'))

    def sample(self, started: float) -> None:
        """Record memory and CPU now."""
        cpu = self.process.cpu_percent(None)
        rss_mb = self.process.memory_info().rss / 2 ** 20
        self.samples.append({'t_s': round(time.monotonic() - started, 2),
                             'rss_mb': round(rss_mb, 2), 'cpu_percent': round(cpu, 1)})
        if self.args.verbose:
            print(f'  t {self.samples[-1]["t_s"]:7.1f} s  RSS {rss_mb:7.1f} MB  CPU '
                  f'{cpu:5.1f} %  rounds {len(self.rounds)}  gaze {self.gaze_received}',
                  flush=True)

    def run(self) -> dict:
        """Warm up, run for the configured time, drain, and return the results."""
        duration = 30.0 if self.args.quick else 60.0 * self.args.minutes
        # Warm-up: the bridge connects and its clock offset is known, regions flow.
        assert self.spin_until(self.outlet.have_consumers, 30.0), 'bridge never connected'
        self.offer(0)
        self.rounds.clear()
        self.pusher.start()
        assert self.spin_until(lambda: self.gaze_received > 0, 30.0), 'no gaze reached ROS'
        self.spin_until(lambda: False, 1.0)
        print(f'soak: {duration:.0f} s, {self.args.rate:g} Hz gaze, a round every '
              f'{self.args.round_period:g} s', flush=True)

        started = time.monotonic()
        self.process.cpu_percent(None)
        next_round, next_sample, index = started, started + self.args.sample_period, 1
        while time.monotonic() - started < duration:
            now = time.monotonic()
            if now >= next_round:
                self.offer(index)
                index += 1
                next_round += self.args.round_period
            if now >= next_sample:
                self.sample(started)
                next_sample += self.args.sample_period
            self.executor.spin_once(timeout_sec=0.005)
        elapsed = time.monotonic() - started
        # Stop the tracker and let everything in flight arrive.
        self.pusher.target = np.array([20.0, 20.0])
        self.spin_until(lambda: False, WINDOW_S + 0.5)
        self.pusher.stop()
        # Every sample since the pusher started (after the bridge connected) must arrive.
        pushed = self.pusher.pushed
        self.spin_until(lambda: self.gaze_received >= pushed, 10.0)
        self.sample(started)
        return self.results(elapsed, pushed, self.gaze_received)

    def results(self, elapsed: float, pushed: int, received: int) -> dict:
        """Summarise the run."""
        rounds = [r for r in self.rounds if r.index > 0]
        complete = [r for r in rounds if r.offered_at + self.args.round_period
                    <= self.rounds[-1].offered_at + 1e-9]   # the last may be cut short
        right = sum(r.choices == [r.target] for r in complete)
        wrong = [r for r in complete if any(c != r.target for c in r.choices)]
        missed = [r for r in complete if not r.choices]
        repeated = [r for r in complete if len(r.choices) > 1]
        latencies = [lat for r in complete for lat in r.latencies[:1]]
        rss = np.array([[s['t_s'], s['rss_mb']] for s in self.samples])
        # Growth after the warm-up (the first minute, or half of a short run).
        late = rss[rss[:, 0] >= min(60.0, elapsed / 2)]
        slope = float(np.polyfit(late[:, 0] / 60.0, late[:, 1], 1)[0]) if len(late) >= 3 \
            else math.nan
        cpu = [s['cpu_percent'] for s in self.samples[:-1]]
        counters = self.bridge.counters
        return {
            'date': datetime.datetime.now().isoformat(timespec='seconds'),
            'machine': machine_info(),
            'config': {'duration_s': round(elapsed, 1), 'rate_hz': self.args.rate,
                       'round_period_s': self.args.round_period, 'window_s': WINDOW_S,
                       'executor': f'{executor_kind()}, 4 pipeline nodes + driver'},
            'samples': {'pushed': pushed, 'gaze_received': received,
                        'lost': pushed - received, 'bridge_counters': counters},
            'rounds': {'offered': len(complete), 'right_choice': right,
                       'wrong_choice': len(wrong), 'no_choice': len(missed),
                       'more_than_one_choice': len(repeated),
                       'first_failures': [{'round': r.index, 'target': r.target,
                                           'choices': r.choices}
                                          for r in (wrong + missed + repeated)[:10]]},
            'decision_latency_s': _stats(latencies),
            'memory': {'rss_start_mb': float(rss[0, 1]), 'rss_end_mb': float(rss[-1, 1]),
                       'rss_max_mb': float(rss[:, 1].max()),
                       'rss_growth_mb_per_min': round(slope, 3)},
            'cpu_percent': _stats(cpu),
            'series': self.samples,
        }

    def close(self) -> None:
        """Destroy the nodes and the executor."""
        if self.pusher.is_alive():
            self.pusher.stop()
        self.executor.shutdown()
        for node in self.nodes + [self.driver]:
            node.destroy_node()


def _parameters(values: Dict) -> List[Parameter]:
    return [Parameter(name, value=value) for name, value in values.items()]


def _stats(values: List[float]) -> Dict[str, Optional[float]]:
    """Count, median, 95th percentile and maximum (None when empty)."""
    if not values:
        return {'count': 0, 'median': None, 'p95': None, 'max': None}
    return {'count': len(values), 'median': round(statistics.median(values), 4),
            'p95': round(float(np.percentile(values, 95)), 4), 'max': round(max(values), 4)}


def summary_lines(results: dict) -> List[str]:
    """Human-readable summary of :meth:`Soak.results`."""
    samples, rounds = results['samples'], results['rounds']
    memory, cpu = results['memory'], results['cpu_percent']
    latency = results['decision_latency_s']
    config = results['config']
    lines = [
        f"soak: {config['duration_s']:.0f} s at {config['rate_hz']:g} Hz, a round every "
        f"{config['round_period_s']:g} s ({config['window_s']:g} s window)",
        f"  gaze samples: {samples['pushed']} pushed into LSL, {samples['gaze_received']} "
        f"received on ROS, {samples['lost']} lost",
        f"  rounds: {rounds['offered']} with gaze on a region, {rounds['right_choice']} right "
        f"choices, {rounds['wrong_choice']} wrong, {rounds['no_choice']} without a choice, "
        f"{rounds['more_than_one_choice']} with more than one",
    ]
    if latency['count']:
        lines.append('  decision latency after the window end: median '
                     f"{latency['median'] * 1e3:.0f} ms, p95 {latency['p95'] * 1e3:.0f} ms, "
                     f"max {latency['max'] * 1e3:.0f} ms")
    lines.append(f"  memory (RSS): {memory['rss_start_mb']:.1f} MB -> {memory['rss_end_mb']:.1f}"
                 f" MB (max {memory['rss_max_mb']:.1f}), growth "
                 f"{memory['rss_growth_mb_per_min']:+.2f} MB/min after the warm-up")
    if cpu['count']:
        lines.append(f"  CPU: median {cpu['median']:.0f} %, p95 {cpu['p95']:.0f} %, max "
                     f"{cpu['max']:.0f} % of one core")
    ok = samples['lost'] == 0 and rounds['wrong_choice'] == 0 and rounds['no_choice'] == 0 \
        and rounds['more_than_one_choice'] == 0
    lines.append('  verdict: ' + ('no sample lost, every round decided right' if ok else
                                  'FAILED: see above'))
    return lines


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line parser."""
    parser = argparse.ArgumentParser(prog='python -m bench.soak', description=__doc__.split(
        '\n\n')[0].strip(), formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--minutes', type=float, default=10.0, help='duration (default 10)')
    parser.add_argument('--quick', action='store_true', help='30 s instead of --minutes')
    parser.add_argument('--rate', type=float, default=1200.0, help='gaze rate, Hz')
    parser.add_argument('--round-period', type=float, default=1.0,
                        help='seconds between rounds (default 1)')
    parser.add_argument('--sample-period', type=float, default=5.0,
                        help='seconds between memory/CPU samples (default 5)')
    parser.add_argument('--output', default='soak_results.json', help='results file')
    parser.add_argument('--verbose', '-v', action='store_true',
                        help='print every memory/CPU sample')
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    """Run the soak; return 0 when nothing was lost and every round was decided right."""
    args = build_parser().parse_args(argv)
    if args.round_period <= WINDOW_S + 0.2 or args.rate <= 0 or args.minutes <= 0:
        print(f'soak: --round-period must exceed {WINDOW_S + 0.2:g} s; --rate and --minutes '
              'must be positive', file=sys.stderr)
        return 2
    with domain_id() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        soak = Soak(args, context)
        try:
            results = soak.run()
        finally:
            soak.close()
            context.try_shutdown()
    with open(args.output, 'w', encoding='utf-8') as stream:
        json.dump(results, stream, indent=1)
    print('\n'.join(summary_lines(results)))
    print(f'wrote {args.output}')
    samples, rounds = results['samples'], results['rounds']
    return 0 if samples['lost'] == 0 and not (rounds['wrong_choice'] or rounds['no_choice']
                                              or rounds['more_than_one_choice']) else 1


if __name__ == '__main__':
    sys.exit(main())
