"""
The whole pipeline in-process on a private graph, fed by a real LSL outlet.

LSL outlet (xy_pixels, the original sender's layout) -> lsl_gaze_bridge ->
``gaze``; camera_tracker (static default view) -> ``camera/pose``; cube
markers on ``choices`` -> marker_projector -> ``choices/regions``;
choice_arbiter -> ``choice``.  The gaze is aimed at a marker through the
analytic projection of docs/DESIGN.md (computed here from geometry.look_at and
calibration.rviz_intrinsic, not by the nodes' code path).
"""

import time

from lsl_outlets import bridge_parameters, make_outlet, sample_for
import numpy as np
import pylsl
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from std_msgs.msg import Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.decision.rounds import ArbiterSettings
from eye_bci_ros2.nodes.camera_tracker import CameraTracker, DEFAULT_EYE, DEFAULT_FOCUS, DEFAULT_UP
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.nodes.marker_projector import DEFAULT_SCREEN_OFFSET, MarkerProjector
from eye_bci_ros2.projection.camera_model import rviz_intrinsic
from eye_bci_ros2.projection.geometry import look_at, project_points
from eye_bci_ros2.ros.conversions import arrays_to_pose
from eye_bci_ros2.ros.topics import EVENT_QOS, LATCHED_QOS

pytestmark = [pytest.mark.ros, pytest.mark.lsl]

#: Marker text -> centre in the map frame, m: a row across the default view.
ROOMS = {'kitchen': (7.0, 6.0, 0.0), 'bedroom': (10.0, 6.0, 0.0), 'bathroom': (13.0, 6.0, 0.0)}
CUBE_SCALE = (1.5, 1.5, 0.05)
#: The projector's default render panel, px.
PANEL = (1280, 720)
WINDOW_S = 1.0
#: The gaze rests off every marker this long after a question before it moves to the option, s.
LOOK_AWAY_S = 0.25
GAZE_RATE_HZ = 100.0
WAIT_S = 10.0
#: Where the gaze rests off every marker: the screen's bottom-left corner, px.
AWAY_PX = (30.0, 1050.0)


def aim(position):
    """Screen px where a world point (map, m) appears in the default static view."""
    external = look_at(DEFAULT_EYE, DEFAULT_FOCUS, DEFAULT_UP)
    uv, depth = project_points(np.array([position]), rviz_intrinsic(*PANEL), external)
    assert depth[0] > 0
    return uv[0] + np.array(DEFAULT_SCREEN_OFFSET, dtype=float)


def menu():
    """Cube markers of ROOMS, labelled by their text."""
    markers = []
    for index, (text, position) in enumerate(ROOMS.items()):
        marker = Marker()
        marker.header.frame_id = 'map'
        marker.ns, marker.id, marker.text = 'rooms', index, text
        marker.type, marker.action = Marker.CUBE, Marker.ADD
        marker.pose = arrays_to_pose(position, (0.0, 0.0, 0.0, 1.0))
        marker.scale.x, marker.scale.y, marker.scale.z = CUBE_SCALE
        marker.color.a = 1.0
        markers.append(marker)
    return MarkerArray(markers=markers)


class Pipeline:
    """The four pipeline nodes, an LSL outlet and a test node playing the menu."""

    def __init__(self, graph):
        self.graph = graph
        self.outlet, info = make_outlet('xy_pixels', rate=GAZE_RATE_HZ)
        self.pushed = 0     # samples pushed so far
        self.bridge = graph.add(LslGazeBridge, parameter_overrides=[
            Parameter(name, value=value)
            for name, value in bridge_parameters('xy_pixels', info).items()])
        graph.add(CameraTracker)
        graph.add(MarkerProjector)
        self.arbiter = graph.add(ChoiceArbiter, parameter_overrides=[
            Parameter('window_s', value=WINDOW_S)])
        self.driver = graph.node('menu')
        self.choices = self.driver.create_publisher(MarkerArray, 'choices', LATCHED_QOS)
        self.request_pub = self.driver.create_publisher(Empty, 'choice/request', EVENT_QOS)
        self.chosen = Collector(self.driver, String, 'choice', EVENT_QOS)
        self.rng = np.random.default_rng(11)
        assert graph.spin_until(self.outlet.have_consumers, WAIT_S), 'bridge never connected'

    @property
    def labels(self):
        """Return the choices received so far."""
        return [message.data for message in self.chosen.messages]

    def offer_rooms(self):
        """Publish the menu; return once the arbiter opened a round on its regions."""
        self.choices.publish(menu())
        assert self.graph.spin_until(lambda: self.arbiter.rounds_started >= 1, WAIT_S), \
            'the arbiter never saw the regions of the menu'

    def request(self):
        """Ask for a choice; return once the arbiter opened the round."""
        rounds = self.arbiter.rounds_started
        self.request_pub.publish(Empty())
        assert self.graph.spin_until(lambda: self.arbiter.rounds_started > rounds, WAIT_S)

    def look_until_chosen(self, screen_xy):
        """
        Look away for 0.3 s, then at ``screen_xy`` (px), over LSL until a new choice arrives.

        As a person does when asked: the gaze moves to the option after the question
        (the default rule weighs a reaction, not a gaze resting there before).
        """
        before = len(self.chosen.messages)
        # Every sample due at GAZE_RATE_HZ, stamped with its due time, however slowly this
        # loop runs on a loaded machine (it catches up in bursts, as a tracker's buffer does).
        start = pylsl.local_clock()
        end = time.monotonic() + WAIT_S
        pushed = 0
        while len(self.chosen.messages) == before and time.monotonic() < end:
            due = int((pylsl.local_clock() - start) * GAZE_RATE_HZ) + 1
            for index in range(pushed, due):
                looking = index / GAZE_RATE_HZ > LOOK_AWAY_S
                point = self.rng.normal(screen_xy if looking else AWAY_PX, 4.0)
                self.outlet.push_sample(sample_for('xy_pixels', point).tolist(),
                                        start + index / GAZE_RATE_HZ)
            pushed = max(pushed, due)
            self.graph.spin_for(1.0 / GAZE_RATE_HZ)
        assert len(self.chosen.messages) > before, 'no choice from the gaze'
        # The samples still in flight arrive while no round is open.
        self.pushed += pushed
        assert self.graph.spin_until(
            lambda: self.bridge.counters['received'] >= self.pushed, WAIT_S), \
            f"{self.bridge.counters['received']} of {self.pushed} samples pulled"


def test_gaze_on_a_marker_chooses_it_and_another_marker_another(graph):
    pipeline = Pipeline(graph)
    pipeline.offer_rooms()
    pipeline.look_until_chosen(aim(ROOMS['bathroom']))
    assert pipeline.labels == ['bathroom']
    decision = pipeline.arbiter.last_decision
    assert decision.method == 'early'     # the default rule: a settled fixation decides
    # The deciding fixation lasted dwell_s: that many samples of the tracker at least.
    assert decision.counts['bathroom'] == decision.in_region_samples >= 0.8 * \
        ArbiterSettings().dwell_s * GAZE_RATE_HZ

    pipeline.request()
    pipeline.look_until_chosen(aim(ROOMS['kitchen']))
    assert pipeline.labels == ['bathroom', 'kitchen']
    assert pipeline.arbiter.last_decision.counts['kitchen'] > 0
    assert pipeline.bridge.counters['published'] > 0
