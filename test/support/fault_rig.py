"""
The real pipeline on a private graph, for fault tests: inject bad input, then check.

:class:`Pipeline` runs camera_tracker, marker_projector and choice_arbiter
(and optionally lsl_gaze_bridge) with a driver node that plays RViz, the menu
and the eye tracker, and collects ``camera/pose``, ``choices/regions`` and
``choice``.  :class:`LogTap` reads what the nodes log (rcutils writes to
stderr; pytest's ``capfd`` captures it).  After every fault a test checks
what a user would: the node still answers, it kept what it had, its log
says what was wrong, and no ``choice`` appeared that the gaze did not
support (:meth:`Pipeline.choose` runs a real round and checks its outcome).
"""

import re
from typing import Dict, List, Optional, Sequence
import zlib

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseStamped
import numpy as np
import rclpy.logging
from rclpy.logging import LoggingSeverity
from rclpy.parameter import Parameter
from ros_harness import Collector, gaze_messages, GazeCollector
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.decision.rounds import COUNT_RULE
from eye_bci_ros2.nodes.camera_tracker import CameraTracker
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.projection.camera_model import RvizCamera
from eye_bci_ros2.ros.conversions import arrays_to_pose, marker_array_to_regions
from eye_bci_ros2.ros.topics import (EVENT_QOS, GAZE_QOS, GAZE_SAMPLES_TOPIC, LATCHED_QOS,
                                     RVIZ_POSE_QOS)

#: Generous wait for anything to arrive, s (2 shared cores; never a timing assertion).
WAIT_S = 10.0

#: :attr:`Pipeline._before_request` when no request is waiting for its round's end.
_NO_REQUEST = object()

#: Gaze rate of the simulated tracker, Hz.
RATE_HZ = 1200.0

#: Arbiter settings that keep rounds short: 0.4 s windows, closed 0.2 s after a quiet end.
#: :meth:`Pipeline.gaze` publishes recorded gaze at once, stamped up to ``count / rate``
#: ahead of the clock (8.3 s for a burst of 10 000), so the arbiter must take stamps that
#: far ahead (its default ``max_future_s`` is 1 s).
FAST_ARBITER = {**COUNT_RULE, 'window_s': 0.4, 'stall_timeout_s': 0.2, 'reorder_s': 0.05,
                'max_future_s': 10.0}

#: Arbiter settings for tests that end every round themselves (:meth:`Pipeline.close_window`,
#: a request or new choices): a stall timeout longer than any hold-up of this process, so no
#: round closes before its gaze is taken.
SELF_CLOSED_ROUNDS = {'stall_timeout_s': 3.0}

#: Loggers of the nodes the rig runs (the fault checks read their INFO lines).
NODE_LOGGERS = ('camera_tracker', 'marker_projector', 'choice_arbiter', 'lsl_gaze_bridge')

#: Where :meth:`Pipeline.close_window` looks: the top-left screen corner, in no region.
CORNER = (1.0, 1.0)

#: Static view of the rig's camera_tracker (world frame ``map``, m): 8 m back, 12 m up.
EYE, FOCUS, UP = [0.0, -8.0, 12.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]

#: The menu: three flat cubes on the floor, well apart in the default static view.
ROOMS = {'kitchen': (-3.0, 0.0), 'bedroom': (0.0, 1.0), 'bathroom': (3.0, 0.0)}


def cube(label: str, position, scale=(1.5, 1.5, 0.05), marker_id: Optional[int] = None,
         quaternion=(0.0, 0.0, 0.0, 1.0), frame: str = 'map', ns: str = 'rooms',
         action: int = Marker.ADD) -> Marker:
    """Build a CUBE marker labelled ``label`` (its text)."""
    marker = Marker()
    marker.header.frame_id = frame
    marker.ns = ns
    marker.id = zlib.crc32(label.encode()) % 100000 if marker_id is None else marker_id
    marker.text = label
    marker.type = Marker.CUBE
    marker.action = action
    marker.pose = arrays_to_pose(position, quaternion)
    marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in scale)
    marker.color.a = 1.0
    return marker


def room_markers() -> List[Marker]:
    """Build the three room cubes of :data:`ROOMS`."""
    return [cube(label, (x, y, 0.0), marker_id=i)
            for i, (label, (x, y)) in enumerate(ROOMS.items())]


def to_time(seconds: float) -> Time:
    """builtin_interfaces/Time of a stamp in s."""
    sec = int(seconds // 1)
    return Time(sec=sec, nanosec=min(int(round((seconds - sec) * 1e9)), 999_999_999))


def static_camera() -> RvizCamera:
    """Return the camera of the rig's static view (1280x720 panel, no screen offset)."""
    return RvizCamera.from_look_at(EYE, FOCUS, UP)


class LogTap:
    """What the nodes have logged so far (stderr, captured by ``capfd``)."""

    def __init__(self, capfd):
        """Read through pytest's ``capfd`` fixture."""
        self._capfd = capfd
        self.text = ''

    def read(self) -> str:
        """Return everything logged since the test started."""
        self.text += self._capfd.readouterr().err
        return self.text

    def mark(self) -> int:
        """Return a position; :meth:`since` gives what was logged after it."""
        return len(self.read())

    def since(self, mark: int) -> str:
        """Return the log after ``mark``."""
        return self.read()[mark:]

    def wait_for(self, graph, pattern: str, mark: int = 0, timeout: float = WAIT_S) -> bool:
        """Spin until the log after ``mark`` matches the regular expression ``pattern``."""
        return graph.spin_until(lambda: re.search(pattern, self.since(mark)) is not None,
                                timeout)


class Pipeline:
    """camera_tracker + marker_projector + choice_arbiter and a driver node."""

    def __init__(self, graph, tracker: bool = True, arbiter: bool = True,
                 projector_parameters: Optional[Dict] = None,
                 arbiter_parameters: Optional[Dict] = None,
                 bridge_parameters: Optional[Dict] = None):
        """
        Start the nodes and connect the driver.

        :param tracker: run camera_tracker (else the driver publishes ``camera/pose``).
        :param arbiter: run choice_arbiter.
        :param bridge_parameters: run lsl_gaze_bridge with these parameters
            (else the driver publishes ``gaze``).
        """
        self.graph = graph
        # Logger levels are process-wide in rcutils, and another test in this process (the
        # demo runs quiet) may have raised them: the checks here read INFO lines.
        for name in NODE_LOGGERS:
            rclpy.logging.set_logger_level(name, LoggingSeverity.INFO)
        self._current_source = None
        self._current: Dict = {}
        self._before_request = _NO_REQUEST
        # Choices the test has seen accounted for (by finish_round); see choose.
        self._accounted = 0
        self.bridge = None
        if bridge_parameters is not None:
            self.bridge = graph.add(LslGazeBridge,
                                    parameter_overrides=_overrides(bridge_parameters))
        self.tracker = graph.add(CameraTracker, parameter_overrides=_overrides(
            {'eye': EYE, 'focus': FOCUS, 'up': UP})) if tracker else None
        self.projector = graph.add(MarkerProjector, parameter_overrides=_overrides(
            {'screen_offset_x': 0, 'screen_offset_y': 0, **(projector_parameters or {})}))
        self.arbiter = graph.add(ChoiceArbiter, parameter_overrides=_overrides(
            {**FAST_ARBITER, **(arbiter_parameters or {})})) if arbiter else None
        self.driver = graph.node('fault_driver')
        driver = self.driver
        self.choices_pub = driver.create_publisher(MarkerArray, 'choices', LATCHED_QOS)
        self.rviz_pub = driver.create_publisher(Pose, 'rviz/current_camera_pose', RVIZ_POSE_QOS)
        self.camera_pub = None if tracker else driver.create_publisher(
            PoseStamped, 'camera/pose', LATCHED_QOS)
        self.gaze_pub = driver.create_publisher(PointCloud2, GAZE_SAMPLES_TOPIC, GAZE_QOS)
        self.request_pub = driver.create_publisher(Empty, 'choice/request', EVENT_QOS)
        self.poses = Collector(driver, PoseStamped, 'camera/pose', LATCHED_QOS)
        self.regions = Collector(driver, MarkerArray, 'choices/regions', LATCHED_QOS)
        self.choices = Collector(driver, String, 'choice', EVENT_QOS)
        self.gazes = GazeCollector(driver)
        publishers = [self.choices_pub]
        if tracker:
            publishers.append(self.rviz_pub)
        if arbiter:
            publishers += [self.gaze_pub, self.request_pub]
        assert graph.spin_until(lambda: all(p.get_subscription_count() > 0 for p in publishers),
                                WAIT_S), 'pipeline topics did not connect'
        if tracker:
            assert graph.spin_until(lambda: self.poses.messages, WAIT_S), 'no static view'
        self.rng = np.random.default_rng(11)

    # -- driving ----------------------------------------------------------------------------

    def now(self) -> float:
        """Return the ROS clock, s."""
        return self.driver.get_clock().now().nanoseconds * 1e-9

    def offer(self, markers: Sequence[Marker], expect: Optional[Sequence[str]] = None,
              timeout: float = WAIT_S) -> Dict:
        """
        Publish ``markers`` and wait for the regions of the ``expect`` labels.

        :returns: the regions, {label: polygon (K, 2) screen px}.
        """
        self.choices_pub.publish(MarkerArray(markers=list(markers)))
        if expect is None:
            expect = [m.text for m in markers if m.action == Marker.ADD]
        assert self.graph.spin_until(lambda: sorted(self.current()) == sorted(expect),
                                     timeout), \
            f'regions {sorted(self.current())[:10]}... never became {sorted(expect)}'
        return self.current()

    def offer_rooms(self) -> Dict:
        """Offer the three rooms and wait for their regions and a round."""
        rounds = self.arbiter.rounds_started if self.arbiter else 0
        regions = self.offer(room_markers())
        if self.arbiter is not None:
            assert self.graph.spin_until(lambda: self.arbiter.rounds_started > rounds, WAIT_S)
        return regions

    def current(self) -> Dict:
        """Return the newest regions, {label: polygon (K, 2) screen px} ({} before any)."""
        last = self.regions.last
        if last is None:
            return {}
        if last is not self._current_source:
            # Converted once per message: a test may poll this on 100 000 regions.
            labels, polygons = marker_array_to_regions(last)
            self._current, self._current_source = dict(zip(labels, polygons)), last
        return dict(self._current)

    def centre(self, label: str) -> np.ndarray:
        """Return the vertex mean of a region now shown, screen px (2,)."""
        polygon = self.current()[label]
        return np.unique(polygon, axis=0).mean(axis=0)

    def publish_rviz_pose(self, position, quaternion_xyzw) -> None:
        """Publish an Ogre camera pose as RViz does (no checks: faults go through here)."""
        pose = Pose()
        (pose.position.x, pose.position.y, pose.position.z) = (float(v) for v in position)
        (pose.orientation.x, pose.orientation.y, pose.orientation.z,
         pose.orientation.w) = (float(v) for v in quaternion_xyzw)
        self.rviz_pub.publish(pose)

    def publish_camera(self, position, quaternion_xyzw, frame: str = 'map') -> None:
        """Publish an optical ``camera/pose`` (pipeline without camera_tracker)."""
        message = PoseStamped()
        message.header.frame_id = frame
        message.header.stamp = self.driver.get_clock().now().to_msg()
        pose = message.pose
        (pose.position.x, pose.position.y, pose.position.z) = (float(v) for v in position)
        (pose.orientation.x, pose.orientation.y, pose.orientation.z,
         pose.orientation.w) = (float(v) for v in quaternion_xyzw)
        self.camera_pub.publish(message)

    def gaze(self, points, start: Optional[float] = None, rate: float = RATE_HZ,
             stamps=None, frame: str = 'screen') -> float:
        """
        Publish gaze samples at once, stamped ``start + (k + 0.5) / rate``.

        :param points: shape (N, 2), screen px (anything, NaN included).
        :param stamps: explicit stamps (N,), s, instead.
        :returns: the stamp after the last sample, s.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        start = self.now() if start is None else start
        if stamps is None:
            stamps = start + (np.arange(len(points)) + 0.5) / rate
        for message in gaze_messages(points, stamps, frame):
            self.gaze_pub.publish(message)
        return start + len(points) / rate

    def look_at_region(self, label: str, count: int = 240, spread: float = 5.0) -> np.ndarray:
        """Gaze points (count, 2) around the centre of a shown region."""
        return self.rng.normal(self.centre(label), spread, (count, 2))

    def request(self, timeout: float = WAIT_S) -> None:
        """Start a fresh round and wait (at most ``timeout`` s) until the arbiter has."""
        asked = self.now()
        self.request_pub.publish(Empty())

        def started() -> bool:
            # The round of this request starts at its arrival, after ``asked``; a round
            # that regions still on their way start (new choices) is stamped before it.
            start = self.arbiter.round_start
            return start is not None and start >= asked
        assert self.graph.spin_until(started, timeout), 'the request started no round'
        # The round may end while the test waits for something else (a log line): the next
        # finish_round then waits past the decision before this round, not a later one.
        self._before_request = self.arbiter.last_decision

    def window_s(self) -> float:
        """Return the arbiter's ``window_s`` now, s."""
        return self.arbiter.get_parameter('window_s').value

    def round_start(self) -> float:
        """Return the start of the arbiter's open round, s (now when none is open)."""
        start = self.arbiter.round_start
        return self.now() if start is None else start

    def gaze_in_round(self, points) -> float:
        """
        Publish gaze samples stamped from the open round's start (:meth:`gaze`).

        Every sample of 0.2 s of gaze is then in the round's window, however
        long this process was held up since the round started.
        :returns: the stamp after the last sample, s.
        """
        return self.gaze(points, start=self.round_start())

    def close_window(self) -> None:
        """
        End the open round now: publish one sample stamped past its window (in no region).

        A round ends when a sample stamped after its window arrives; without
        one it waits ``stall_timeout_s`` past the window on the clock.
        Published after the round's gaze (same publisher, reliable), it
        arrives after it.  It must be less than the arbiter's
        ``max_future_s`` ahead of the clock (:data:`FAST_ARBITER`).  Like
        every sample, it stays among the recent samples a round started by
        new choices in the next ``window_s`` takes (as a sample in no region).
        """
        self.gaze([CORNER], stamps=[self.round_start() + self.window_s() + 0.01])

    def finish_round(self, timeout: float = WAIT_S, before=False):
        """
        Wait until the open round ends (its window and stall timeout pass); return its Decision.

        Also waits for the ``choice`` it publishes, if any.
        :param before: the Decision to wait past (default: the last one before the round
            :meth:`request` started, when this is the first call since; else the last one now).
        """
        if before is False:
            before = self._before_request
            if before is _NO_REQUEST:
                before = self.arbiter.last_decision
        self._before_request = _NO_REQUEST
        published = len(self.choices.messages)
        assert self.graph.spin_until(lambda: self.arbiter.last_decision is not before,
                                     timeout), 'the round never ended'
        decision = self.arbiter.last_decision
        if decision.label is not None:
            self.graph.spin_until(lambda: len(self.choices.messages) > published, WAIT_S)
        # A second, late choice arrives after this: the next :meth:`choose` sees it (it
        # asserts that every choice since this one is its own).
        self._accounted = len(self.choices.messages)
        return decision

    def choose(self, label: Optional[str], new_round: bool = True, timeout: float = WAIT_S):
        """
        Run a round looking at ``label`` (None: at nothing) and check the outcome.

        The gaze is stamped from the round's start and the round ended by
        :meth:`close_window` (no wait for its stall timeout).  Asserts
        exactly the supported choice (or none) is published since the last
        round :meth:`finish_round` ended: a late choice of anything before
        arrives ahead of this one, so a test ending with a choice sees it.
        :param timeout: longest wait for the round's start and end, s (a hang: a test
            whose nodes have far more to do than usual scales it to what it measured).
        :returns: the arbiter's Decision.
        """
        # Aim first: the round's window runs from the request.
        if label is None:
            points = self.rng.uniform([0, 0], [50, 50], (240, 2))  # a corner, no region
        else:
            points = self.look_at_region(label)
        if new_round:
            self.request(timeout)
        since = self._accounted
        self.gaze_in_round(points)
        self.close_window()
        decision = self.finish_round(timeout)
        # Every choice since the last round this rig finished: a late one of that round
        # (published in order on the same topic, before this one) shows here.
        new = [message.data for message in self.choices.messages[since:]]
        assert decision.label == label, decision.summary()
        assert new == ([] if label is None else [label]), new
        return decision

    def published_choices(self) -> List[str]:
        """Return every choice published so far."""
        return [message.data for message in self.choices.messages]

    def answers(self, node_name: str, timeout: float = WAIT_S) -> bool:
        """Tell whether a node still answers a parameter get (``ros2 param get``)."""
        return self.graph.get_parameters(node_name, ['use_sim_time'], timeout) == [False]


def _overrides(values: Dict) -> List[Parameter]:
    return [value if isinstance(value, Parameter) else Parameter(name, value=value)
            for name, value in values.items()]
