"""
Watch eye_bci_ros2 from a terminal: gaze stream, offered options, decisions.

For the PyPI set-up, where there is no ``ros2`` command (``ros2 topic echo``,
``ros2 topic hz``).  An rclpy node that listens to

* ``gaze/samples`` (sensor_msgs/PointCloud2 batches from ``lsl_gaze_bridge``:
  fields x, y float32 screen px and t float64 s after ``header.stamp``; one
  message per LSL chunk): samples per second, messages per second, total,
  gaps (more than ``--gap`` s between consecutive sample stamps: blinks, lost
  eyes, a stalled stream) and the newest point;
* ``choices/regions`` (visualization_msgs/MarkerArray): the options on offer,
  by label (the marker's text, else ``ns/id``), and which one the newest gaze
  point is in;
* ``choice`` (std_msgs/String): the decisions;
* the pipeline's nodes on the graph (``eye_bci``'s and its menu's, in the
  monitor's namespace) and what each is waiting for, read from the graph
  and the latched state the nodes publish anyway (no status protocol of its
  own): the bridge for a gaze stream (nothing on ``gaze/samples`` and
  ``gaze/on_screen``), camera_tracker for RViz's camera (it subscribes to
  the pose topic once a publisher exists: until then the static view),
  marker_projector for options (``choices``) and a camera pose
  (``camera/pose``), the arbiter for options on screen (``choices/regions``)
  and gaze, the menu as its ``choice_menu/state`` says;
* ``choice_menu/progress`` (std_msgs/String, latched): what the robot the menu
  sent is doing, in the menu's words (driving and the distance left, arrived,
  stopped); ``-`` before the menu sent one.

On a terminal it redraws a few status lines in place; when stdout is not a
terminal (a pipe, a log file) it prints one plain ``key=value`` line per
period and one line per decision.  ``--once`` listens for at least one
period, until the pipeline's nodes are discovered and their latched state
has arrived (at most ``--wait`` s: discovery takes a few seconds), and
prints once; ``--duration S`` stops after S seconds.  Topic names are
relative: remap or push a namespace with ``--ros-args`` as for any node.

Usage::

    monitor
    monitor --once
    monitor --duration 30 > run.log
    monitor --ros-args -r __ns:=/robot1
"""

import argparse
from collections import deque
from dataclasses import dataclass, field
import signal
import sys
import threading
import time
from typing import Any, Deque, Dict, List, Optional, Sequence, Tuple

from geometry_msgs.msg import PoseStamped
import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Bool, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.projection.geometry import points_in_convex_polygons
from eye_bci_ros2.ros.conversions import gaze_batch_arrays, marker_array_to_regions
from eye_bci_ros2.ros.registry import menu, pipeline
from eye_bci_ros2.ros.runner import make_executor
from eye_bci_ros2.ros.topics import (CAMERA_POSE_TOPIC, CHOICE_TOPIC, CHOICES_QOS, CHOICES_TOPIC,
                                     EVENT_QOS, GAZE_ON_SCREEN_TOPIC, GAZE_SAMPLES_TOPIC,
                                     LATCHED_QOS, LISTENER_QOS, MENU_PROGRESS_TOPIC,
                                     MENU_STATE_TOPIC, REGIONS_TOPIC)

#: Rates are counted over the last this many seconds of arrivals.
RATE_WINDOW_S = 2.0
#: Default: an interval between consecutive sample stamps longer than this is a gap, s.
DEFAULT_GAP_S = 0.1
#: Default refresh period, s.
DEFAULT_PERIOD_S = 1.0
#: Gaze is "not arriving" after this long without a message, s.
STALE_S = 1.0
#: Decisions shown.
DECISIONS_SHOWN = 3
#: Options named in the status (the rest are counted).
OPTIONS_SHOWN = 8
#: The pipeline's nodes the status names: ``eye_bci``'s, then its menu's (the registry's).
PIPELINE_NODES = tuple(name for name, _, _ in pipeline()) + (menu()[0],)
#: ``--once``: default longest wait for the pipeline's nodes and their latched state, s.
DEFAULT_WAIT_S = 5.0
#: ``--once``: the status is complete when nothing new (a node, a latched message) came for
#: this long after the first pipeline node was seen, s.
SETTLED_S = 1.0
#: How often the graph is looked at for the pipeline's nodes, s.
GRAPH_PERIOD_S = 0.25
#: Topics every node has, which say nothing of what it waits for.
_INFRASTRUCTURE = ('/parameter_events', '/rosout', '/clock')


@dataclass
class GazeStats:
    """
    Counters of the gaze batches seen so far (no rclpy; times in s).

    The sample rate is the tracker's, from the sample stamps of the batches
    that arrived in the last :data:`RATE_WINDOW_S` (gaps lower it); the
    message rate is from their arrival times.
    """

    gap_s: float = DEFAULT_GAP_S
    samples: int = 0
    messages: int = 0
    bad_messages: int = 0
    gaps: int = 0
    longest_gap_s: float = 0.0
    newest_xy: Optional[np.ndarray] = None
    last_stamp: Optional[float] = None
    last_arrival: Optional[float] = None
    #: (arrival s, samples, first stamp, last stamp) of recent batches.
    recent: Deque[Tuple[float, int, float, float]] = field(default_factory=deque)

    def add(self, xy: np.ndarray, stamps: np.ndarray, arrival: float) -> None:
        """
        Count one batch.

        :param xy: shape (N, 2), screen px.
        :param stamps: shape (N,), s (ROS clock).
        :param arrival: when it arrived, s (monotonic).
        """
        self.messages += 1
        self.last_arrival = arrival
        if not len(stamps):
            return
        self.samples += len(stamps)
        self.recent.append((arrival, len(stamps), float(stamps.min()), float(stamps.max())))
        previous = [] if self.last_stamp is None else [self.last_stamp]
        intervals = np.diff(np.concatenate([previous, stamps]))
        long = intervals[intervals > self.gap_s]
        self.gaps += len(long)
        if len(long):
            self.longest_gap_s = max(self.longest_gap_s, float(long.max()))
        self.last_stamp = max(float(stamps[-1]), -np.inf if self.last_stamp is None
                              else self.last_stamp)
        finite = np.all(np.isfinite(xy), axis=1)
        if finite.any():
            self.newest_xy = xy[np.flatnonzero(finite)[-1]]

    def rates(self, now: float) -> Tuple[Optional[float], Optional[float]]:
        """
        Return (samples/s, messages/s) over the batches of the last RATE_WINDOW_S.

        None while there is too little to measure (fewer than 2 samples, or
        fewer than 2 messages, in the window).
        """
        while self.recent and self.recent[0][0] < now - RATE_WINDOW_S:
            self.recent.popleft()
        if not self.recent:
            return 0.0, 0.0
        batches = np.array(self.recent)
        count = batches[:, 1].sum()
        span = batches[:, 3].max() - batches[:, 2].min()
        sample_rate = (count - 1) / span if count > 1 and span > 0 else None
        arrival_span = batches[-1, 0] - batches[0, 0]
        message_rate = (len(batches) - 1) / arrival_span if arrival_span > 0 else None
        return sample_rate, message_rate


class Monitor(Node):
    """Listen to gaze, options and decisions, and keep what the status shows."""

    def __init__(self, gap_s: float = DEFAULT_GAP_S, on_choice=None, **kwargs):
        """
        Subscribe to ``gaze/samples``, ``choices/regions`` and ``choice``.

        :param gap_s: gap threshold between sample stamps, s.
        :param on_choice: called with (wall time s, text) for each decision.
        """
        super().__init__('eye_bci_monitor', **kwargs)
        self.gaze = GazeStats(gap_s=gap_s)
        self.labels: List[str] = []
        self.polygons = np.zeros((0, 3, 2))
        self.regions_at: Optional[float] = None
        self.decisions: Deque[Tuple[float, str]] = deque(maxlen=100)
        self.problem = ''
        self._on_choice = on_choice
        self.create_subscription(PointCloud2, GAZE_SAMPLES_TOPIC, self._on_gaze, LISTENER_QOS)
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)
        self.create_subscription(String, CHOICE_TOPIC, self._on_decision, EVENT_QOS)
        # The latched state the pipeline's nodes publish anyway: {topic: the last message}.
        self.latched: Dict[str, Any] = {}
        for message_type, topic, qos in ((PoseStamped, CAMERA_POSE_TOPIC, LATCHED_QOS),
                                         (MarkerArray, CHOICES_TOPIC, CHOICES_QOS),
                                         (Bool, GAZE_ON_SCREEN_TOPIC, LATCHED_QOS),
                                         (String, MENU_STATE_TOPIC, LATCHED_QOS),
                                         (String, MENU_PROGRESS_TOPIC, LATCHED_QOS)):
            self.create_subscription(message_type, topic, self._latch(topic), qos)
        #: The pipeline's nodes seen on the graph, and when what the status shows last changed
        #: (a node seen or gone, a latched message; monotonic s).
        self.nodes: Tuple[str, ...] = ()
        self.changed_at = time.monotonic()
        self._options_offered = False

    def _latch(self, topic: str):
        def keep(message) -> None:
            if topic == CHOICES_TOPIC:
                # Incremental: options are offered once any array added a marker.
                self._options_offered |= any(m.action == Marker.ADD for m in message.markers)
            self.latched[topic] = message
            self.changed_at = time.monotonic()
        return keep

    def look_at_graph(self) -> Tuple[str, ...]:
        """Find the pipeline's nodes in this node's namespace; return them in pipeline order."""
        namespace = self.get_namespace()
        present = {name for name, ns in self.get_node_names_and_namespaces()
                   if ns == namespace}
        nodes = tuple(name for name in PIPELINE_NODES if name in present)
        if nodes != self.nodes:
            self.nodes, self.changed_at = nodes, time.monotonic()
        return nodes

    def settled(self, now: float) -> bool:
        """Tell whether pipeline nodes were seen and nothing new came for SETTLED_S."""
        return bool(self.nodes) and now - self.changed_at >= SETTLED_S

    def _reads_a_published_topic(self, name: str) -> bool:
        """Tell whether node ``name`` subscribes to a topic that has a publisher (graph)."""
        try:
            topics = self.get_subscriber_names_and_types_by_node(name, self.get_namespace())
        except Exception:  # noqa: B902 - the node left the graph meanwhile
            return False
        return any(self.count_publishers(topic) for topic, _ in topics
                   if not topic.startswith(_INFRASTRUCTURE))

    def waiting(self, now: float) -> Dict[str, List[Tuple[str, str]]]:
        """
        Say what each pipeline node seen waits for: {node: [(key, text)]}, [] = nothing.

        From the graph and the latched state (module doc); the key is a short word for the
        plain line, the text is for people.
        """
        gaze_on = self.gaze.last_arrival is not None and now - self.gaze.last_arrival < STALE_S
        on_screen = self.latched.get(GAZE_ON_SCREEN_TOPIC)
        if gaze_on:
            gaze = []
        elif on_screen is None and self.gaze.last_arrival is None:
            gaze = [('gaze_stream', 'a gaze stream (no tracker on LSL yet?)')]
        else:
            gaze = [('gaze', 'gaze (its stream quiet or lost)')]
        needs: Dict[str, List[Tuple[str, str]]] = {
            'lsl_gaze_bridge': gaze,
            'camera_tracker': [] if self._reads_a_published_topic('camera_tracker') else [
                ('rviz_camera', "RViz's camera pose (its static view meanwhile)")],
            'marker_projector': ([] if self._options_offered else [
                ('options', f'options (nothing on {CHOICES_TOPIC})')]) + (
                [] if CAMERA_POSE_TOPIC in self.latched else [
                    ('camera_pose', f'a camera pose (nothing on {CAMERA_POSE_TOPIC})')]),
            'choice_arbiter': ([] if self.labels else [
                ('regions', f'options on screen (none on {REGIONS_TOPIC})')]) + [
                ('gaze', 'gaze') for _ in gaze],
        }
        state = self.latched.get(MENU_STATE_TOPIC)
        needs['choice_menu'] = [] if state is None or not state.data.startswith('waiting') \
            else [(state.data, state.data.replace('_', ' ').replace('waiting for ', ''))]
        return {name: needs.get(name, []) for name in self.nodes}

    def _on_gaze(self, message: PointCloud2) -> None:
        try:
            stamps, xy = gaze_batch_arrays(message)
        except ValueError as error:
            self.gaze.bad_messages += 1
            self.problem = f'unreadable gaze/samples message: {error}'
            return
        self.gaze.add(xy, stamps, time.monotonic())

    def _on_regions(self, message: MarkerArray) -> None:
        self.labels, self.polygons = marker_array_to_regions(message)
        self.regions_at = time.monotonic()

    def _on_decision(self, message: String) -> None:
        self.decisions.append((time.time(), message.data))
        if self._on_choice is not None:
            self._on_choice(*self.decisions[-1])

    def gaze_region(self) -> Optional[str]:
        """Return the label of the option the newest gaze point is in, '' if none."""
        if self.gaze.newest_xy is None:
            return None
        if not self.labels:
            return ''
        inside = points_in_convex_polygons(self.gaze.newest_xy[None, :], self.polygons)[0]
        hits = np.flatnonzero(inside)
        return self.labels[hits[0]] if len(hits) else ''

    def status(self, now: Optional[float] = None) -> dict:
        """Return what the status shows, as plain values (for the renderers and tests)."""
        now = time.monotonic() if now is None else now
        sample_rate, message_rate = self.gaze.rates(now)
        age = None if self.gaze.last_arrival is None else now - self.gaze.last_arrival
        return {
            'sample_rate': sample_rate, 'message_rate': message_rate,
            'samples': self.gaze.samples, 'messages': self.gaze.messages,
            'bad_messages': self.gaze.bad_messages, 'gaps': self.gaze.gaps,
            'longest_gap_s': self.gaze.longest_gap_s, 'gaze_age_s': age,
            'gaze_xy': None if self.gaze.newest_xy is None else self.gaze.newest_xy.tolist(),
            'gaze_region': self.gaze_region(), 'options': list(self.labels),
            'decisions': [text for _, text in self.decisions], 'problem': self.problem,
            'nodes': self.waiting(now), 'robot': self.robot(),
        }

    def robot(self) -> Optional[str]:
        """Return what the robot the menu sent is doing (``choice_menu/progress``), or None."""
        progress = self.latched.get(MENU_PROGRESS_TOPIC)
        return progress.data if progress is not None and progress.data else None


def _rate(value: Optional[float]) -> str:
    return '    ?  ' if value is None else f'{value:7.1f}'


def _clock(wall_s: float) -> str:
    return time.strftime('%H:%M:%S', time.localtime(wall_s))


def status_lines(status: dict, decisions: Sequence[Tuple[float, str]] = ()) -> List[str]:
    """Render the terminal status block (a few lines)."""
    age = status['gaze_age_s']
    if age is None:
        gaze = 'gaze     nothing on gaze/samples yet'
    else:
        state = 'ok' if age < STALE_S else f'NOTHING for {age:.1f} s'
        gaze = (f"gaze     {_rate(status['sample_rate'])} samples/s in "
                f"{_rate(status['message_rate'])} msg/s, {status['samples']} samples, "
                f"{status['gaps']} gaps" +
                (f" (longest {status['longest_gap_s']:.2f} s)" if status['gaps'] else '') +
                f', {state}')
    if status['gaze_xy'] is None:
        where = 'looking  -'
    else:
        x, y = status['gaze_xy']
        region = status['gaze_region']
        inside = f"in '{region}'" if region else 'in no option'
        where = f'looking  ({x:.1f}, {y:.1f}) px, {inside}'
    options = status['options']
    shown = ', '.join(options[:OPTIONS_SHOWN]) + \
        (f', and {len(options) - OPTIONS_SHOWN} more' if len(options) > OPTIONS_SHOWN else '')
    offered = f'options  {len(options)}: {shown}' if options else 'options  none offered'
    recent = [f"'{text}' {_clock(at)}" for at, text in list(decisions)[-DECISIONS_SHOWN:]]
    chosen = 'choice   ' + ('; '.join(reversed(recent)) if recent else '-')
    robot = 'robot    ' + (status['robot'] or '-')
    lines = [gaze, where, offered, chosen, robot] + node_lines(status['nodes'])
    if status['problem']:
        lines.append(f"problem  {status['problem']} ({status['bad_messages']} so far)")
    return lines


def node_lines(nodes: Dict[str, List[Tuple[str, str]]]) -> List[str]:
    """Render the pipeline's nodes seen and what each waits for, one line each."""
    if not nodes:
        return ["nodes    none of the pipeline's seen (is eye_bci running, with this "
                'ROS_DOMAIN_ID and namespace?)']
    width = max(len(name) for name in nodes)
    return [('nodes    ' if index == 0 else ' ' * 9) + f'{name:<{width}}  ' +
            ('waiting for ' + ', '.join(text for _, text in waits) if waits else 'ok')
            for index, (name, waits) in enumerate(nodes.items())]


def status_line(status: dict, elapsed_s: float) -> str:
    """Render one plain ``key=value`` line (stdout not a terminal)."""
    xy = status['gaze_xy']
    fields = [
        f't={elapsed_s:.1f}',
        f"gaze_rate={_rate(status['sample_rate']).strip()}",
        f"msg_rate={_rate(status['message_rate']).strip()}",
        f"samples={status['samples']}",
        f"gaps={status['gaps']}",
        f"longest_gap_s={status['longest_gap_s']:.3f}",
        'gaze=' + ('-' if xy is None else f'{xy[0]:.1f},{xy[1]:.1f}'),
        'region=' + (status['gaze_region'] or '-'),
        'options=' + ('|'.join(status['options']) or '-'),
        'last_choice=' + (status['decisions'][-1] if status['decisions'] else '-'),
        # The menu's words, one field: "driving to 'table_2': 1.4 m left" -> robot=driving_to_...
        'robot=' + ('_'.join((status['robot'] or '-').split())),
        # Each node seen, with what it waits for: lsl_gaze_bridge(gaze_stream),choice_arbiter
        'nodes=' + (','.join(name + (f"({'+'.join(key for key, _ in waits)})" if waits else '')
                             for name, waits in status['nodes'].items()) or '-'),
    ]
    if status['bad_messages']:
        fields.append(f"bad_messages={status['bad_messages']}")
    return ' '.join(fields)


class Screen:
    """Write the status: redrawn in place on a terminal, appended lines elsewhere."""

    def __init__(self, stream, terminal: Optional[bool] = None):
        """Write to ``stream``; ``terminal`` None = ask the stream (isatty)."""
        self.stream = stream
        self.terminal = stream.isatty() if terminal is None else terminal
        self._drawn = 0
        self._started = time.monotonic()

    def show(self, monitor: Monitor) -> None:
        """Write the current status."""
        status = monitor.status()
        if self.terminal:
            lines = [f'eye_bci monitor {_clock(time.time())} (Ctrl-C to quit)'] + \
                status_lines(status, monitor.decisions)
            # Up over the last block, clear to the end of the screen, redraw.
            prefix = f'\x1b[{self._drawn}F\x1b[J' if self._drawn else ''
            self.stream.write(prefix + '\n'.join(lines) + '\n')
            self._drawn = len(lines)
        else:
            self.stream.write(status_line(status, time.monotonic() - self._started) + '\n')
        self.stream.flush()

    def choice(self, wall_s: float, text: str) -> None:
        """Report a decision as it happens (plain output only; the block shows it)."""
        if not self.terminal:
            self.stream.write(f'{_clock(wall_s)} choice {text}\n')
            self.stream.flush()


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float('nan')
    if not value > 0 or value == float('inf'):
        raise argparse.ArgumentTypeError(f"'{text}' is not a positive number of seconds")
    return value


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line parser."""
    parser = argparse.ArgumentParser(
        prog='monitor', description=__doc__.split('\n\n')[0].strip(),
        epilog='Listens to gaze/samples (PointCloud2), choices/regions (MarkerArray), '
               'choice and choice_menu/progress (String). ROS arguments go after --ros-args.')
    when = parser.add_mutually_exclusive_group()
    when.add_argument('--once', action='store_true',
                      help="listen for at least one --period, until the pipeline's nodes are "
                      'discovered (at most --wait s), print the status once and exit')
    when.add_argument('--duration', type=_positive, metavar='S',
                      help='exit after S seconds (default: until Ctrl-C)')
    parser.add_argument('--period', type=_positive, default=DEFAULT_PERIOD_S, metavar='S',
                        help='refresh period, s; default %(default)s')
    parser.add_argument('--wait', type=_positive, default=DEFAULT_WAIT_S, metavar='S',
                        help="--once: wait at most S s for the pipeline's nodes to be "
                        'discovered; default %(default)s')
    parser.add_argument('--gap', type=_positive, default=DEFAULT_GAP_S, metavar='S',
                        help='count a gap when consecutive gaze samples are more than S s '
                        'apart; default %(default)s')
    return parser


def run(args: argparse.Namespace, context=None, stream=None,
        terminal: Optional[bool] = None, stop: Optional[threading.Event] = None) -> int:
    """
    Run the monitor on an initialised ``context`` until ``stop`` is set or the duration ends.

    :returns: the exit status (0).
    """
    stop = stop or threading.Event()
    screen = Screen(stream or sys.stdout, terminal)
    monitor = Monitor(gap_s=args.gap, on_choice=screen.choice, context=context)
    executor = make_executor(context=context)
    executor.add_node(monitor)
    start = time.monotonic()
    next_show = start + (args.period if args.once else 0.0)
    next_look = start

    def done(now: float) -> bool:
        if args.once:
            # Discovery takes seconds: one period is too short to see a running pipeline.
            return now - start >= args.period and (monitor.settled(now)
                                                   or now - start >= args.wait)
        return args.duration is not None and now - start >= args.duration

    try:
        while not stop.is_set() and not done(time.monotonic()):
            executor.spin_once(timeout_sec=min(0.05, args.period))
            now = time.monotonic()
            if now >= next_look:
                monitor.look_at_graph()
                next_look = now + GRAPH_PERIOD_S
            if now >= next_show and not args.once:
                screen.show(monitor)
                next_show += args.period
        monitor.look_at_graph()
        screen.show(monitor)
    finally:
        executor.shutdown()
        monitor.destroy_node()
    return 0


def main(argv: Optional[List[str]] = None) -> int:
    """
    Run ``monitor``; return the exit status.

    Ctrl-C and SIGTERM only ask the loop to stop (no KeyboardInterrupt), and
    are ignored once it stops, so a second Ctrl-C cannot break the clean-up.
    """
    argv = sys.argv if argv is None else argv
    args = build_parser().parse_args(remove_ros_args(argv)[1:])
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    try:
        return run(args, stop=stop)
    except ExternalShutdownException:
        return 0
    finally:
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, signal.SIG_IGN)
        rclpy.try_shutdown()


if __name__ == '__main__':
    sys.exit(main())
