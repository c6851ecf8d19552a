"""
The validation set-up through the real nodes: simulated person -> LSL -> bridge -> gaze_validation.

A :class:`~eye_bci_ros2.sim.gaze_outlet.GazeStreamer` (a real LSL outlet) is
read by a real ``lsl_gaze_bridge``; ``gaze_validation`` shows its targets,
and the simulated person looks at each (:class:`TargetFollower`, or a test's
own rule).  A plain node publishes the RViz camera pose as camera_tracker
would (latched, optical convention), since no RViz runs here.
"""

from dataclasses import dataclass
from typing import Any, Dict, Optional

from geometry_msgs.msg import PoseStamped
from lsl_outlets import unique_id
from rclpy.parameter import Parameter
from ros_harness import Collector
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.nodes.gaze_validation import GazeValidation
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.ros.conversions import arrays_to_pose
from eye_bci_ros2.ros.topics import (EVENT_QOS, LATCHED_QOS, VALIDATION_RESULT_TOPIC,
                                     VALIDATION_TARGETS_TOPIC)
from eye_bci_ros2.sim.gaze_outlet import GazeStreamer
from eye_bci_ros2.sim.person import GazeParams, ORIGINAL_TOBII_4C
from eye_bci_ros2.sim.target_follower import TargetFollower

#: The RViz view the targets are placed in: looking down at the map from 6 m.
VIEW = ((0.0, -4.0, 6.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))


@dataclass
class Rig:
    """What a test drives and checks."""

    streamer: GazeStreamer
    bridge: LslGazeBridge
    results: Collector
    markers: Collector
    follower: Optional[TargetFollower]

    def start_validation(self, graph, **params) -> GazeValidation:
        """Start gaze_validation with the person's screen geometry and ``params``."""
        screen = self.streamer.simulator.params.person.screen
        values: Dict[str, Any] = {
            'screen_width_mm': float(screen.width_mm), 'screen_height_mm': float(screen.height_mm),
            'viewing_distance_mm': float(screen.distance_mm), 'camera_wait_s': 5.0,
            'target_s': 1.2, 'settle_s': 0.5, 'projector_node': ''}
        values.update(params)
        return graph.add(GazeValidation, parameter_overrides=[
            Parameter(name, value=value) for name, value in values.items()])


def camera_pose(view=VIEW, frame: str = 'map') -> PoseStamped:
    """Return the latched camera/pose camera_tracker publishes for ``view`` (eye, focus, up)."""
    message = PoseStamped()
    message.header.frame_id = frame
    message.pose = arrays_to_pose(*look_at_pose(*view))
    return message


def make_rig(graph, person: GazeParams = ORIGINAL_TOBII_4C, seed: int = 0, follow: bool = True,
             bridge_params: Optional[Dict[str, Any]] = None) -> Rig:
    """Start the person's outlet, the bridge on it, the camera pose and the listeners."""
    streamer = GazeStreamer(params=person, seed=seed, source_id=unique_id('sim-validation'),
                            name=unique_id('sim_validation'))
    streamer.start()
    values = {'stream_name': streamer.info.name(), 'source_id': streamer.info.source_id()}
    values.update(bridge_params or {})
    bridge = graph.add(LslGazeBridge, parameter_overrides=[
        Parameter(name, value=value) for name, value in values.items()])
    helper = graph.node('validation_probe')
    pose = helper.create_publisher(PoseStamped, 'camera/pose', LATCHED_QOS)
    pose.publish(camera_pose())
    results = Collector(helper, String, VALIDATION_RESULT_TOPIC, EVENT_QOS)
    markers = Collector(helper, MarkerArray, VALIDATION_TARGETS_TOPIC, LATCHED_QOS)
    follower = graph.add(TargetFollower, streamer) if follow else None
    assert graph.spin_until(lambda: bridge.counters['published'] > 50, 15.0), \
        'no gaze through the bridge'
    return Rig(streamer, bridge, results, markers, follower)
