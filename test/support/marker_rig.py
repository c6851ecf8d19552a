"""
The session's marker stream read by a real pylsl inlet, and a real pipeline that chooses.

:class:`MarkerInlet` resolves one ``session_markers`` stream by its source_id and keeps
every marker (JSON parsed) with its LSL stamp.  :class:`ChoosingRig` is a real gaze
outlet (the ``xy_pixels`` layout: x, y in screen px), the real lsl_gaze_bridge,
choice_arbiter (its default rule) and session_markers in a namespace of their own,
and a driver that offers two options and asks; a pusher thread plays the person:
the gaze rests below the options and moves onto the one asked for 0.3 s after each
question, every sample stamped on this machine's LSL clock as a tracker does.
"""

import threading
from typing import Any, Dict, List, Tuple
import uuid

from lsl_outlets import bridge_parameters, make_outlet, sample_for
import numpy as np
import pylsl
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Empty
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.nodes.session_markers import SessionMarkers
from eye_bci_ros2.recordings.session_markers import MARKER_TYPE, parse_marker
from eye_bci_ros2.ros.conversions import regions_to_marker_array
from eye_bci_ros2.ros.topics import EVENT_QOS, LATCHED_QOS, REGIONS_TOPIC, REQUEST_TOPIC

WAIT_S = 30.0


def unique_namespace() -> str:
    """Return a namespace no other test on this machine uses (its marker stream is ours)."""
    return f'/markers_{uuid.uuid4().hex[:12]}'


class MarkerInlet:
    """A real pylsl inlet on the marker stream of ``source_id``; :attr:`markers` as read."""

    def __init__(self, source_id: str, timeout_s: float = WAIT_S):
        found = pylsl.resolve_byprop('source_id', source_id, 1, timeout_s)
        assert found, f'no LSL stream with source_id {source_id}'
        self.info = found[0]
        assert self.info.type() == MARKER_TYPE and self.info.channel_count() == 1
        assert self.info.channel_format() == pylsl.cf_string
        assert self.info.nominal_srate() == pylsl.IRREGULAR_RATE
        self.inlet = pylsl.StreamInlet(self.info)
        self.inlet.open_stream(timeout_s)
        #: (marker as parsed, its LSL stamp), in arrival order.
        self.markers: List[Tuple[Dict[str, Any], float]] = []
        self.texts: List[str] = []
        #: The LSL clock when each marker was taken, s.
        self.arrived: List[float] = []

    def pull(self) -> List[Tuple[Dict[str, Any], float]]:
        """Take what has arrived (no wait); return all markers so far."""
        samples, stamps = self.inlet.pull_chunk(timeout=0.0)
        now = pylsl.local_clock()
        for sample, stamp in zip(samples, stamps):
            self.arrived.append(now)
            self.texts.append(sample[0])
            self.markers.append((parse_marker(sample[0]), stamp))
        return self.markers

    def of(self, event: str) -> List[Tuple[Dict[str, Any], float]]:
        """Return the markers of one event."""
        return [(body, stamp) for body, stamp in self.pull() if body['event'] == event]

    def wait(self, graph, event: str, count: int = 1, timeout: float = WAIT_S) -> List:
        """Spin until ``count`` markers of ``event`` arrived; return them."""
        assert graph.spin_until(lambda: len(self.of(event)) >= count, timeout), \
            f"{len(self.of(event))} of {count} '{event}' markers arrived: {self.texts[-5:]}"
        return self.of(event)

    def close(self) -> None:
        """Close the inlet."""
        self.inlet.close_stream()


def square(cx: float, cy: float, half: float) -> np.ndarray:
    """Return a square region, (4, 2) screen px."""
    return np.array([[cx - half, cy - half], [cx + half, cy - half], [cx + half, cy + half],
                     [cx - half, cy + half]])


#: The two options of the rig (label -> centre, screen px) and where the gaze rests.
OPTIONS = {'left': (500.0, 400.0), 'right': (1400.0, 400.0)}
REST = (960.0, 900.0)
HALF_PX = 100.0


#: The rig's tracker stamps each sample this long before it pushes it (a real tracker's
#: acquisition-to-send latency), s: a marker stamped on its sample is at least this old
#: when it arrives, one stamped on arrival is not.
TRACKER_LAG_S = 0.05


class GazePusher(threading.Thread):
    """A tracker application: each sample pushed as due, stamped TRACKER_LAG_S earlier."""

    def __init__(self, outlet, rate_hz: float, rng: np.random.Generator):
        super().__init__(daemon=True)
        self.outlet, self.rate_hz, self.rng = outlet, rate_hz, rng
        self.target = REST
        self.stop = threading.Event()
        self.error = None
        self.start_stamp = None

    def stamp_near(self, stamp: float) -> float:
        """Return the pushed sample's stamp nearest ``stamp`` (LSL s)."""
        first = self.start_stamp - TRACKER_LAG_S
        return first + max(0, round((stamp - first) * self.rate_hz)) / self.rate_hz

    def run(self):
        try:
            start = self.start_stamp = pylsl.local_clock()
            pushed = 0
            while not self.stop.is_set():
                due = int((pylsl.local_clock() - start) * self.rate_hz) + 1
                if due > pushed:
                    xy = np.asarray(self.target) + self.rng.normal(0.0, 3.0, (due - pushed, 2))
                    stamps = start + np.arange(pushed, due) / self.rate_hz - TRACKER_LAG_S
                    for sample, stamp in zip(sample_for('xy_pixels', xy), stamps):
                        self.outlet.push_sample(sample.tolist(), float(stamp))
                    pushed = due
                self.stop.wait(0.002)
        except Exception as error:  # noqa: B902 - kept for the test to report
            self.error = error


class ChoosingRig:
    """A real gaze outlet, bridge, arbiter and session_markers; a driver that asks (module doc)."""

    def __init__(self, graph, rate_hz: float = 600.0, seed: int = 5):
        self.graph = graph
        self.namespace = unique_namespace()
        self.rate_hz = rate_hz
        self.outlet, self.gaze_info = make_outlet('xy_pixels', rate=rate_hz)
        self.bridge = graph.add(LslGazeBridge, namespace=self.namespace, parameter_overrides=[
            Parameter(name, value=value) for name, value in bridge_parameters(
                'xy_pixels', self.gaze_info, stats_period_s=0.0).items()])
        self.arbiter = graph.add(ChoiceArbiter, namespace=self.namespace)
        self.markers_node = graph.add(SessionMarkers, namespace=self.namespace)
        self.driver = graph.add(Node, 'marker_test_driver', namespace=self.namespace)
        self.regions_pub = self.driver.create_publisher(MarkerArray, REGIONS_TOPIC, LATCHED_QOS)
        self.request_pub = self.driver.create_publisher(Empty, REQUEST_TOPIC, EVENT_QOS)
        self.pusher = GazePusher(self.outlet, rate_hz, np.random.default_rng(seed))
        assert graph.spin_until(
            lambda: self.regions_pub.get_subscription_count() >= 2
            and self.request_pub.get_subscription_count() >= 2, WAIT_S), 'topics not connected'

    def offer(self) -> None:
        """Publish the two options' regions (ns ``rig``), stamped now."""
        sources = [Marker(ns='rig', id=index, text=label)
                   for index, label in enumerate(OPTIONS)]
        polygons = np.stack([square(*OPTIONS[label], HALF_PX) for label in OPTIONS])
        stamp = self.driver.get_clock().now().to_msg()
        self.regions_pub.publish(regions_to_marker_array(polygons, sources, stamp))

    def start(self) -> None:
        """Start the person's gaze and wait until the bridge reads it."""
        self.pusher.start()
        assert self.graph.spin_until(self.outlet.have_consumers, WAIT_S), 'bridge never connected'

    def ask(self, label: str) -> None:
        """Rest the gaze, ask, and look at ``label`` 0.3 s later (the person's reaction)."""
        self.pusher.target = REST
        self.graph.spin_for(0.3)
        self.request_pub.publish(Empty())
        self.graph.spin_for(0.3)
        self.pusher.target = OPTIONS[label]

    def close(self) -> None:
        """Stop the person's gaze."""
        self.pusher.stop.set()
        self.pusher.join(5.0)
        assert self.pusher.error is None, self.pusher.error
