"""
gaze_validation lays its targets out in the running projector's panel, not in its own copy.

A screen offset set on ``marker_projector`` (find_panel's panel.yaml, ``ros2
param set``) but not on ``gaze_validation`` would otherwise be "corrected"
into the gaze.  No gaze and no bridge here: the first target's screen point
on ``validation/target`` shows which panel the validation used.
"""

import math

from fault_rig import LogTap
from geometry_msgs.msg import PointStamped, PoseStamped
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from validation_rig import camera_pose

from eye_bci_ros2.gaze.validation import target_layout
from eye_bci_ros2.nodes.gaze_validation import GazeValidation
from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.ros.topics import LATCHED_QOS, VALIDATION_TARGET_TOPIC

pytestmark = pytest.mark.ros

WAIT_S = 15.0
#: The projector's panel: not the validation's defaults (1280x720 at 320, 180).
PANEL = {'image_width': 800, 'image_height': 600, 'screen_offset_x': 64.5,
         'screen_offset_y': 40.0}
#: Validation settings that end quickly: no gaze or bridge to wait for, nothing saved.
QUICK = {'gaze_wait_s': 0.0, 'bridge_timeout_s': 0.1, 'output': '', 'target_s': 0.5,
         'settle_s': 0.1, 'camera_wait_s': 5.0, 'arbiter_node': '', 'validate_again': False}


def first_target(graph, **params):
    """Start gaze_validation with ``params``; return its first target's screen point, px."""
    probe = graph.node('probe')
    probe.create_publisher(PoseStamped, 'camera/pose', LATCHED_QOS).publish(camera_pose())
    targets = Collector(probe, PointStamped, VALIDATION_TARGET_TOPIC, LATCHED_QOS)
    values = dict(QUICK, **params)
    graph.add(GazeValidation, parameter_overrides=[
        Parameter(name, value=value) for name, value in values.items()])
    shown = lambda: [m for m in targets.messages if not math.isnan(m.point.x)]  # noqa: E731
    assert graph.spin_until(lambda: shown(), WAIT_S), 'no target shown'
    return np.array([shown()[0].point.x, shown()[0].point.y])


def test_the_targets_are_in_the_projectors_panel(graph, capfd):
    log = LogTap(capfd)
    graph.add(MarkerProjector, parameter_overrides=[
        Parameter(name, value=value) for name, value in PANEL.items()])
    point = first_target(graph)
    expected = target_layout(9, 800, 600, 0.1)[0] + (64.5, 40.0)
    np.testing.assert_allclose(point, expected, atol=1e-6)
    assert 'panel geometry from /marker_projector: 800x600 px at screen offset (64.5, 40) px' \
        in log.read()


def test_without_a_projector_it_says_so_and_uses_its_own_panel(graph, capfd):
    log = LogTap(capfd)
    point = first_target(graph, image_width=1000, image_height=500)
    expected = target_layout(9, 1000, 500, 0.1)[0] + (320.0, 180.0)
    np.testing.assert_allclose(point, expected, atol=1e-6)
    assert 'cannot read the panel geometry of /marker_projector' in log.read()
