"""
Soak test: the real pipeline under a 1200 Hz LSL gaze stream for minutes (``make soak``).

Run as a lab runs the tracker: a separate process pushes every gaze sample on
its own (``push_sample``, each with its own acquisition stamp, at 1200 Hz),
as App-TobiiPro and the EyeLink and Pupil relays forward each SDK callback
(:class:`eye_bci_ros2.sim.gaze_outlet.GazeStreamer` in per-sample mode; the
person is :data:`~eye_bci_ros2.sim.person.PRO_TRACKER` with the ideal eye:
offset, jitter, drift, blinks and lost samples sent as NaN, saccade latency,
but no landing errors or spikes).  This process runs lsl_gaze_bridge,
camera_tracker, marker_projector and choice_arbiter on one executor (as
``eye_bci`` does), on a private ROS domain, with the arbiter's defaults, and a
driver node that shows three options on ``choices`` and asks for rounds back
to back, as ``choice_menu`` asks (:mod:`eye_bci_ros2.task.menu`): after a choice
the person looks at the next option and the next ``choice/request`` goes out
as soon as the gaze has left the option just chosen (by the menu's
``look_away_margin_px``, or after its ``look_away_s``); after
``choice/none`` it is asked again at once.  After every pass over the
options the person looks at nothing (a point off every option) for
:data:`REST_ROUNDS` rounds, which must end in ``choice/none``, then turns to
the first option again.  So a round is nearly always open.

Measured, and written to ``soak_results.json``:

* samples: valid samples pushed into LSL from the first one the bridge
  received (found by its position: a jittered sample is unique) vs samples in
  the ``gaze/samples`` batches received on the ROS side (a subscriber on the
  same executor): none may be lost; the bridge's counters beside them;
* rounds: each must end in the looked-at label or in ``choice/none``; a
  different label is a wrong round, more than one outcome a broken round;
  duration request -> outcome, and the share of the time a round was open;
* memory: resident set size of this process (the nodes) and of the pusher
  every ``--sample-period`` s, and each one's growth (least-squares slope
  after the first minute, or after the first half of a short run, MB/min);
* CPU: each process's use over each sample period (100 % = one core).

Usage::

    python -m bench.soak [--minutes 10] [--rate 1200] [--push sample|chunk]
                         [--output soak_results.json]

Not part of CI: it takes minutes and its numbers depend on the machine.
"""

import argparse
import datetime
import json
import math
import multiprocessing
import statistics
import sys
import time
from typing import Dict, List, Optional
import uuid

from domain_coordinator import domain_id
import numpy as np
import psutil
import rclpy
from rclpy.context import Context
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from bench.timing import machine_info
from eye_bci_ros2.decision.rounds import ArbiterSettings
from eye_bci_ros2.decision.tolerance import polygon_distances
from eye_bci_ros2.nodes.camera_tracker import CameraTracker
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.projection.camera_model import RvizCamera
from eye_bci_ros2.ros.conversions import cube_marker, gaze_batch_arrays
from eye_bci_ros2.ros.runner import executor_kind, make_executor, spin_until
from eye_bci_ros2.ros.startup import quiet_liblsl
from eye_bci_ros2.ros.topics import (CHOICE_TOPIC, CHOICES_TOPIC, EVENT_QOS, GAZE_QOS,
                                     GAZE_SAMPLES_TOPIC, LATCHED_QOS, NO_CHOICE_TOPIC,
                                     REQUEST_TOPIC)
from eye_bci_ros2.sim.gaze_outlet import GazeStreamer, SOURCE_SIZE
from eye_bci_ros2.sim.person import IDEAL_EYE, PRO_TRACKER
from eye_bci_ros2.task.menu import ProtocolSettings

#: Static RViz view of the soak (world frame ``map``, m).
EYE, FOCUS, UP = [0.0, -8.0, 12.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]

#: The options shown: label -> (x, y) of a 1.5 m flat cube on the floor.
MENU = {'kitchen': (-3.0, 0.0), 'bedroom': (0.0, 1.0), 'bathroom': (3.0, 0.0)}

#: Where the person looks before the first round and between passes: screen px, off every
#: option.
REST_PX = (40.0, 40.0)

#: Rounds the person looks at nothing after each pass over the options (each must end in
#: ``choice/none``: the menu asks again).
REST_ROUNDS = 2

#: Valid samples the pusher keeps from its start to find the first one the bridge received
#: (the bridge connects within seconds; 50 s at 1200 Hz).
HEAD_SAMPLES = 60_000

#: After the last push, the pusher keeps its outlet this long so that LSL sends everything
#: (closing it at once drops what is still in its send buffer), s.
FLUSH_S = 2.0

#: A received point is the pushed one when they agree this closely, source px (float32 on
#: the wire; jitter makes neighbouring samples differ by far more).
MATCH_PX = 0.01
#: How many of the first samples received locate them among those pushed (_expected).
FIRST_RUN = 4

#: Push period of ``--push chunk``, ms (a tracker SDK delivering 10 ms chunks).
CHUNK_MS = 10.0

#: Growth of resident memory below which a process counts as flat, MB/min (a leak of one
#: gaze sample's message a round would exceed it within the run).
FLAT_MB_PER_MIN = 0.5

#: Memory is judged only on at least this long after the warm-up, s (shorter: still settling).
MIN_JUDGED_S = 120.0


def menu_markers() -> MarkerArray:
    """Build a DELETEALL and one CUBE per option, as a menu publishes them."""
    clear = Marker(action=Marker.DELETEALL)
    clear.header.frame_id = 'map'
    array = MarkerArray(markers=[clear])
    for index, (label, (x, y)) in enumerate(MENU.items()):
        array.markers.append(cube_marker('soak', index, label, 'map', [x, y, 0.0],
                                         [0.0, 0.0, 0.0, 1.0], [1.5, 1.5, 0.05]))
    return array


def screen_regions() -> Dict[str, np.ndarray]:
    """Screen region (K, 2) px of every option in the static view."""
    camera = RvizCamera.from_look_at(EYE, FOCUS, UP)
    positions = np.array([[x, y, 0.0] for x, y in MENU.values()])
    polygons, visible = camera.box_regions(
        positions, np.tile([0.0, 0.0, 0.0, 1.0], (len(MENU), 1)),
        np.tile([1.5, 1.5, 0.05], (len(MENU), 1)))
    assert visible.all(), 'a soak option is off the screen'
    return dict(zip(MENU, polygons))


def push_gaze(conn, name: str, source_id: str, rate: float, per_sample: bool,
              seed: int) -> None:
    """
    Pusher process: stream the simulated person until told to stop.

    Commands on ``conn``: ``('target', (x, y))`` (person's screen px) and
    ``('stop',)``; answers ``'ready'`` once streaming, and at the end the
    counts and the first :data:`HEAD_SAMPLES` valid samples (source px) pushed.
    """
    params = PRO_TRACKER.with_changes(rate_hz=rate, **IDEAL_EYE)
    head = np.full((HEAD_SAMPLES, 2), np.nan)   # allocated once: the pusher's RSS stays flat
    kept = [0]

    def keep(chunk) -> None:   # runs in the streaming thread after each push
        if kept[0] < HEAD_SAMPLES:
            valid = chunk.xy[chunk.valid][:HEAD_SAMPLES - kept[0]]
            head[kept[0]:kept[0] + len(valid)] = valid
            kept[0] += len(valid)

    streamer = GazeStreamer(params=params, seed=seed, name=name, source_id=source_id,
                            per_sample=per_sample, chunk_ms=CHUNK_MS, initial_xy=REST_PX,
                            on_chunk=keep)
    streamer.set_target(REST_PX)
    streamer.start()
    conn.send('ready')
    while True:
        command = conn.recv()
        if command[0] == 'target':
            streamer.set_target(command[1])
        elif command[0] == 'stop':
            break
    outlet = streamer.outlet   # kept open until LSL has sent what was pushed
    streamer.stop()
    time.sleep(FLUSH_S)
    del outlet
    conn.send({'pushed': streamer.samples_pushed, 'nan': streamer.samples_lost,
               'head': streamer.to_source(head[:kept[0]]),
               'error': None if streamer.error is None else repr(streamer.error)})


class Round:
    """One question of the soak: when it was asked, what was looked at, what came."""

    def __init__(self, index: int, target: Optional[str], requested_at: float):
        """Record a round asked at ``requested_at`` (monotonic s); target None = nothing."""
        self.index = index
        self.target = target
        self.requested_at = requested_at
        self.outcomes: List[Optional[str]] = []   # labels; None = choice/none
        self.ended_at: Optional[float] = None


class Soak:
    """The pipeline, the pusher, the driver and the measurements."""

    def __init__(self, args: argparse.Namespace, context: Context):
        """Start the pusher process and create the nodes."""
        self.args = args
        tag = uuid.uuid4().hex
        self.settings = ArbiterSettings()
        spawn = multiprocessing.get_context('spawn')   # no rclpy state inherited
        self.conn, child = spawn.Pipe()
        self.pusher = spawn.Process(
            target=push_gaze, name='soak_pusher', daemon=True,
            args=(child, f'soak_gaze_{tag}', f'soak-{tag}', args.rate,
                  args.push == 'sample', args.seed))
        self.pusher.start()
        if not self.conn.poll(60.0) or self.conn.recv() != 'ready':
            raise RuntimeError('the gaze pusher did not start')
        bridge = {'source_id': f'soak-{tag}', 'stream_name': f'soak_gaze_{tag}',
                  'stats_period_s': 0.0}
        self.nodes = [
            LslGazeBridge(context=context, parameter_overrides=_parameters(bridge)),
            CameraTracker(context=context, parameter_overrides=_parameters(
                {'eye': EYE, 'focus': FOCUS, 'up': UP})),
            MarkerProjector(context=context, parameter_overrides=_parameters(
                {'screen_offset_x': 0, 'screen_offset_y': 0})),
            ChoiceArbiter(context=context),   # the defaults a user gets
        ]
        self.bridge = self.nodes[0]
        self.driver = rclpy.create_node('soak_driver', context=context)
        self.executor = make_executor(context=context)
        for node in self.nodes + [self.driver]:
            self.executor.add_node(node)
        self.choices_pub = self.driver.create_publisher(MarkerArray, CHOICES_TOPIC, LATCHED_QOS)
        self.request_pub = self.driver.create_publisher(Empty, REQUEST_TOPIC, EVENT_QOS)
        self.gaze_received = 0
        # Screen px of the first FIRST_RUN samples received: where the count starts (_expected).
        self.first_points = np.zeros((0, 2))
        self.driver.create_subscription(PointCloud2, GAZE_SAMPLES_TOPIC, self._on_gaze, GAZE_QOS)
        self.driver.create_subscription(String, CHOICE_TOPIC,
                                        lambda m: self._on_outcome(m.data), EVENT_QOS)
        self.driver.create_subscription(String, NO_CHOICE_TOPIC,
                                        lambda m: self._on_outcome(None), EVENT_QOS)
        self.regions = screen_regions()
        self.targets = {label: np.unique(polygon, axis=0).mean(axis=0)
                        for label, polygon in self.regions.items()}
        self.protocol = ProtocolSettings()
        self.target: Optional[str] = None   # the option the person looks at; None: nothing
        self.resting = 0   # rounds asked while the person looks at nothing
        self.rounds: List[Round] = []
        self.asking = False
        #: After a choice: (region of the option chosen (1, K, 2), when chosen); the next
        #: round is asked once the gaze has left it.
        self.leaving: Optional[tuple] = None
        self.processes = {'nodes': psutil.Process(), 'pusher': psutil.Process(self.pusher.pid)}
        self.samples: List[Dict[str, float]] = []

    def _on_gaze(self, message: PointCloud2) -> None:
        if len(self.first_points) < FIRST_RUN or self.leaving is not None:
            xy = gaze_batch_arrays(message)[1]
            if len(self.first_points) < FIRST_RUN:
                self.first_points = np.concatenate(
                    [self.first_points, xy[:FIRST_RUN - len(self.first_points)]])
            if self.leaving is not None and np.any(
                    polygon_distances(xy, self.leaving[0]) > self.protocol.look_away_margin_px):
                self.leaving = None
                self.ask()
        self.gaze_received += message.width * message.height

    def _on_outcome(self, label: Optional[str]) -> None:
        if not self.rounds:
            return
        current = self.rounds[-1]
        current.outcomes.append(label)
        if current.ended_at is not None:
            return
        current.ended_at = time.monotonic()
        if not self.asking:
            return
        labels = list(MENU)
        if label is None:   # asked again at once
            if current.target is None and self.resting >= REST_ROUNDS:
                self.look_at(labels[0])   # the rest is over: the next pass
            self.ask()
            return
        # The person turns to the next option (or to nothing after the last); asked once
        # the gaze has left the option chosen.
        self.leaving = (self.regions[label][None], current.ended_at)
        following = labels.index(label) + 1 if current.target is None else \
            labels.index(current.target) + 1
        self.look_at(labels[following] if following < len(labels) else None)

    def spin_until(self, predicate, timeout: float) -> bool:
        """Spin until ``predicate()`` holds; return whether it did."""
        return spin_until(self.executor, predicate, timeout)

    def look_at(self, label: Optional[str]) -> None:
        """Make the person look at option ``label`` from now on (None: at nothing)."""
        self.target = label
        self.resting = 0
        xy = REST_PX if label is None else self.targets[label]
        self.conn.send(('target', tuple(float(v) for v in xy)))

    def ask(self) -> None:
        """Ask for a round (``choice/request``) now."""
        self.rounds.append(Round(len(self.rounds), self.target, time.monotonic()))
        self.resting += self.target is None
        self.request_pub.publish(Empty())

    def sample(self, started: float) -> None:
        """Record memory and CPU of both processes now."""
        row = {'t_s': round(time.monotonic() - started, 2)}
        for name, process in self.processes.items():
            row[f'{name}_rss_mb'] = round(process.memory_info().rss / 2 ** 20, 2)
            row[f'{name}_cpu_percent'] = round(process.cpu_percent(None), 1)
        self.samples.append(row)

    def progress(self, started: float, duration: float) -> None:
        """Print one line: how far, rounds, samples, memory and CPU now."""
        row = self.samples[-1]
        wrong = sum(1 for r in self.rounds if any(o not in (None, r.target)
                                                  for o in r.outcomes))
        print(f'  {row["t_s"]:6.0f} / {duration:.0f} s  rounds {len(self.rounds)} '
              f'({wrong} wrong)  gaze on ROS {self.gaze_received}  RSS nodes '
              f'{row["nodes_rss_mb"]:.1f} MB, pusher {row["pusher_rss_mb"]:.1f} MB  CPU nodes '
              f'{row["nodes_cpu_percent"]:.0f} %, pusher {row["pusher_cpu_percent"]:.0f} %',
              flush=True)

    def run(self) -> dict:
        """Warm up, run for the configured time, drain, and return the results."""
        duration = 60.0 * self.args.minutes
        self.choices_pub.publish(menu_markers())
        if not self.spin_until(lambda: self.gaze_received > 0, 30.0):
            raise RuntimeError('no gaze reached ROS: the bridge never connected')
        self.spin_until(lambda: False, 2.0)   # regions flow, the clock offset settles
        print(f'soak: {duration:.0f} s, {self.args.rate:g} Hz gaze pushed '
              f'{"one sample at a time" if self.args.push == "sample" else "in 10 ms chunks"}'
              f' from a separate process, rounds back to back (arbiter defaults: '
              f'{self.settings.method}, window {self.settings.window_s:g} s)', flush=True)
        started = time.monotonic()
        for process in self.processes.values():
            process.cpu_percent(None)
        self.sample(started)
        self.asking = True
        self.look_at(list(MENU)[0])
        self.ask()
        next_sample = started + self.args.sample_period
        next_progress = started + self.args.progress_period
        while time.monotonic() - started < duration:
            now = time.monotonic()
            if self.leaving is not None and \
                    now - self.leaving[1] > self.protocol.look_away_s:
                self.leaving = None   # the menu asks at the latest after look_away_s
                self.ask()
            elif self.leaving is None and self.rounds[-1].ended_at is None and \
                    now - self.rounds[-1].requested_at > 5 * self.settings.window_s:
                self.ask()   # no outcome at all: counted, and asked again
            if now >= next_sample:
                self.sample(started)
                next_sample += self.args.sample_period
            if now >= next_progress:
                self.progress(started, duration)
                next_progress += self.args.progress_period
            self.executor.spin_once(timeout_sec=0.005)
        elapsed = time.monotonic() - started
        self.asking = False
        # Let the open round end and everything in flight arrive, then stop the tracker.
        self.spin_until(lambda: self.rounds[-1].ended_at is not None,
                        self.settings.window_s + 1.0)
        self.sample(started)
        self.conn.send(('stop',))
        # Spin while the pusher flushes: the bridge pulls the last samples before the
        # stream closes.
        if not self.spin_until(self.conn.poll, 30.0):
            raise RuntimeError('the gaze pusher did not stop')
        pushed = self.conn.recv()
        self.pusher.join(10.0)
        expected = self._expected(pushed)
        self.spin_until(lambda: expected is not None and self.gaze_received >= expected, 10.0)
        self.spin_until(lambda: False, 0.5)   # anything beyond the expected count
        return self.results(elapsed, pushed, expected)

    def _expected(self, pushed: dict) -> Optional[int]:
        """Count the valid samples pushed from the first the bridge received (None: not found)."""
        head = pushed['head'].astype(float)
        if len(self.first_points) < FIRST_RUN or not len(head):
            return None
        # By a run of samples, not one: among 60 000 samples of a fixation another one
        # often lies within MATCH_PX of any given sample (a run of FIRST_RUN never does).
        first = self.first_points * np.asarray(SOURCE_SIZE) / self._screen_size()
        starts = np.flatnonzero(np.abs(head - first[0]).max(axis=1) <= MATCH_PX)
        matches = [int(start) for start in starts if start + FIRST_RUN <= len(head)
                   and np.abs(head[start:start + FIRST_RUN] - first).max() <= MATCH_PX]
        if len(matches) != 1:
            return None
        return pushed['pushed'] - pushed['nan'] - matches[0]

    def _screen_size(self) -> np.ndarray:
        """Return the bridge's screen, px (it scales source px to it)."""
        width = self.bridge.get_parameter('screen_width').value
        height = self.bridge.get_parameter('screen_height').value
        return np.array([width, height], dtype=float)

    def results(self, elapsed: float, pushed: dict, expected: Optional[int]) -> dict:
        """Summarise the run."""
        rounds = self.rounds
        ended = [r for r in rounds if r.ended_at is not None]
        right = [r for r in ended if r.outcomes == [r.target] and r.target is not None]
        rest = [r for r in ended if r.outcomes == [None] and r.target is None]
        none = [r for r in ended if r.outcomes == [None] and r.target is not None]
        wrong = [r for r in ended if any(o not in (None, r.target) for o in r.outcomes)]
        repeated = [r for r in ended if len(r.outcomes) > 1]
        unanswered = [r for r in rounds if r.ended_at is None]
        durations = [r.ended_at - r.requested_at for r in ended]
        open_share = sum(durations) / elapsed if elapsed > 0 else math.nan
        memory, cpu = {}, {}
        for name in self.processes:
            series = np.array([[s['t_s'], s[f'{name}_rss_mb']] for s in self.samples])
            late = series[series[:, 0] >= min(60.0, elapsed / 2)]
            slope = float(np.polyfit(late[:, 0] / 60.0, late[:, 1], 1)[0]) \
                if len(late) >= 3 else math.nan
            judged = len(late) >= 3 and late[-1, 0] - late[0, 0] >= MIN_JUDGED_S
            memory[name] = {'rss_start_mb': float(series[0, 1]),
                            'rss_end_mb': float(series[-1, 1]),
                            'rss_max_mb': float(series[:, 1].max()),
                            'rss_growth_mb_per_min': round(slope, 3),
                            # None: too short a run to tell a leak from settling
                            'flat': bool(abs(slope) <= FLAT_MB_PER_MIN) if judged else None}
            cpu[name] = _stats([s[f'{name}_cpu_percent'] for s in self.samples[1:-1]])
        return {
            'date': datetime.datetime.now().isoformat(timespec='seconds'),
            'command': 'python -m bench.soak ' + ' '.join(sys.argv[1:]),
            'machine': machine_info(),
            'config': {'duration_s': round(elapsed, 1), 'rate_hz': self.args.rate,
                       'push': ('push_sample, one call and stamp per sample'
                                if self.args.push == 'sample' else
                                f'push_chunk every {CHUNK_MS:g} ms'),
                       'person': f'{PRO_TRACKER.name} with the ideal eye, seed {self.args.seed}',
                       'rounds': 'back to back: a request as soon as the previous round ended',
                       'arbiter': {'method': self.settings.method,
                                   'window_s': self.settings.window_s,
                                   'early_decision': self.settings.early_decision},
                       'executor': f'{executor_kind()}, 4 pipeline nodes + driver'},
            'samples': {'pushed_total': pushed['pushed'], 'pushed_nan': pushed['nan'],
                        'expected_on_ros': expected, 'gaze_received': self.gaze_received,
                        'lost': None if expected is None else expected - self.gaze_received,
                        'bridge_counters': self.bridge.counters,
                        'pusher_error': pushed['error']},
            'rounds': {'asked': len(rounds), 'right_choice': len(right),
                       'no_choice_looking_at_nothing': len(rest),
                       'no_choice': len(none), 'wrong_choice': len(wrong),
                       'more_than_one_outcome': len(repeated), 'unanswered': len(unanswered),
                       'first_failures': [{'round': r.index, 'target': r.target,
                                           'outcomes': r.outcomes}
                                          for r in (wrong + repeated + unanswered)[:10]],
                       'duration_s': _stats(durations),
                       'open_fraction': round(open_share, 3)},
            'memory': memory,
            'cpu_percent': cpu,
            'series': self.samples,
        }

    def close(self) -> None:
        """Stop the pusher, destroy the nodes and the executor."""
        if self.pusher.is_alive():
            self.pusher.terminate()
            self.pusher.join(5.0)
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


def passed(results: dict) -> bool:
    """Nothing lost, no wrong or broken round, every round answered, memory flat (if judged)."""
    samples, rounds = results['samples'], results['rounds']
    return (samples['lost'] == 0 and not samples['pusher_error']
            and not (rounds['wrong_choice'] or rounds['more_than_one_outcome']
                     or rounds['unanswered'])
            and all(m['flat'] is not False for m in results['memory'].values()))


def summary_lines(results: dict) -> List[str]:
    """Human-readable summary of :meth:`Soak.results`."""
    samples, rounds, config = results['samples'], results['rounds'], results['config']
    lost = 'not counted: the first received sample was not found among those pushed' \
        if samples['lost'] is None else f"{samples['lost']} lost"
    lines = [
        f"soak: {config['duration_s']:.0f} s at {config['rate_hz']:g} Hz ({config['push']}),"
        f" rounds back to back, arbiter {config['arbiter']['method']} with window "
        f"{config['arbiter']['window_s']:g} s",
        f"  gaze samples: {samples['pushed_total']} pushed ({samples['pushed_nan']} NaN: "
        f"blinks and lost), {samples['expected_on_ros']} valid from the first the bridge "
        f"received, {samples['gaze_received']} received on ROS: {lost}",
        f"  rounds: {rounds['asked']} asked, {rounds['right_choice']} right choices, "
        f"{rounds['no_choice_looking_at_nothing']} 'no choice' looking at nothing (right), "
        f"{rounds['no_choice']} 'no choice' looking at an option, "
        f"{rounds['wrong_choice']} wrong, "
        f"{rounds['more_than_one_outcome']} with more than one outcome, "
        f"{rounds['unanswered']} unanswered",
    ]
    duration = rounds['duration_s']
    if duration['count']:
        lines.append('  round duration (request -> outcome): median '
                     f"{duration['median'] * 1e3:.0f} ms, p95 {duration['p95'] * 1e3:.0f} ms, "
                     f"max {duration['max'] * 1e3:.0f} ms; a round open "
                     f"{100 * rounds['open_fraction']:.0f} % of the time")
    for name, memory in results['memory'].items():
        cpu = results['cpu_percent'][name]
        cpu_text = f", CPU median {cpu['median']:.0f} %, p95 {cpu['p95']:.0f} % of one core" \
            if cpu['count'] else ''
        lines.append(f"  {name} process: RSS {memory['rss_start_mb']:.1f} -> "
                     f"{memory['rss_end_mb']:.1f} MB (max {memory['rss_max_mb']:.1f}), growth "
                     f"{memory['rss_growth_mb_per_min']:+.2f} MB/min after the warm-up"
                     + cpu_text)
    judged = all(m['flat'] is not None for m in results['memory'].values())
    lines.append('  verdict: ' + (('no sample lost, no wrong round, memory flat' if judged else
                                   'no sample lost, no wrong round (too short a run to judge '
                                   'memory)') if passed(results) else 'FAILED: see above'))
    return lines


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line parser."""
    parser = argparse.ArgumentParser(prog='python -m bench.soak', description=__doc__.split(
        '\n\n')[0].strip(), formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--minutes', type=float, default=10.0,
                        help='duration (default 10; e.g. 1 for a check)')
    parser.add_argument('--rate', type=float, default=1200.0, help='gaze rate, Hz (1200)')
    parser.add_argument('--push', choices=('sample', 'chunk'), default='sample',
                        help='one push_sample per sample (default, as tracker apps do) or '
                             f'{CHUNK_MS:g} ms chunks')
    parser.add_argument('--seed', type=int, default=1, help="the person's seed (1)")
    parser.add_argument('--sample-period', type=float, default=5.0,
                        help='seconds between memory/CPU samples (default 5)')
    parser.add_argument('--progress-period', type=float, default=30.0,
                        help='seconds between progress lines (default 30)')
    parser.add_argument('--output', default='soak_results.json', help='results file')
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    """Run the soak; 0 when nothing was lost, no round was wrong and memory stayed flat."""
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    parser = build_parser()
    args = parser.parse_args(argv)
    if not (args.rate > 0 and args.minutes > 0 and args.sample_period > 0
            and args.progress_period > 0):
        parser.error('--rate, --minutes, --sample-period and --progress-period must be '
                     'positive')
    with domain_id() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        soak = None
        try:
            soak = Soak(args, context)
            results = soak.run()
        except RuntimeError as error:
            print(f'soak: {error}', file=sys.stderr)
            return 1
        finally:
            if soak is not None:
                soak.close()
            context.try_shutdown()
    with open(args.output, 'w', encoding='utf-8') as stream:
        json.dump(results, stream, indent=1)
    print('\n'.join(summary_lines(results)))
    print(f'wrote {args.output}')
    return 0 if passed(results) else 1


if __name__ == '__main__':
    sys.exit(main())
