"""view_animated_bridge: camera/goal -> rviz_plugin_view_animated ViewTrajectory."""

import importlib

from fault_rig import LogTap
from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector

from eye_bci_ros2.nodes import view_animated_bridge
from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.ros.conversions import arrays_to_pose
from eye_bci_ros2.ros.topics import LATCHED_QOS

pytestmark = pytest.mark.ros

TOPIC = '/rviz_plugin_view_animated_1/trajectory'


def port_messages():
    """Return the port's message classes (make's set-up builds them into the venv)."""
    return view_animated_bridge.load_messages()


def goal(eye, focus, up, frame='map'):
    message = PoseStamped(pose=arrays_to_pose(*look_at_pose(eye, focus, up)))
    message.header.frame_id = frame
    return message


def test_without_the_message_package_the_bridge_says_how_to_build_it(monkeypatch):
    def missing(name, *args):
        raise ImportError(f'No module named {name!r}')
    monkeypatch.setattr(importlib, 'import_module', missing)
    with pytest.raises(ValueError, match='build it with colcon'):
        view_animated_bridge.load_messages()


def test_each_goal_becomes_a_movement_that_shows_the_same_view(graph):
    trajectory_type, movement_type = port_messages()
    graph.add(view_animated_bridge.ViewAnimatedBridge, parameter_overrides=[
        Parameter('transition_time_s', value=1.5), Parameter('speed_profile', value='FULL')])
    helper = graph.node('menu')
    goals = helper.create_publisher(PoseStamped, 'camera/goal', LATCHED_QOS)
    rviz = Collector(graph.node('rviz2'), trajectory_type, TOPIC, 1)
    goals.publish(goal([10.0, -2.0, 17.0], [10.0, 6.0, 0.0], [0.0, 0.0, 1.0]))
    assert graph.spin_until(lambda: rviz.messages, 10.0)
    (movement,) = rviz.last.view_trajectory
    assert movement.view_tf_frame == 'map' and movement.view_mode == movement_type.ORBIT
    assert movement.view_speed_profile == movement_type.FULL
    assert movement.view_duration.data == pytest.approx(1.5)
    assert movement.view_pose_enabled and movement.view_mouse_enabled   # tracker keeps up
    assert {movement.view_eye.header.frame_id, movement.view_focus.header.frame_id,
            movement.view_up.header.frame_id} == {'map'}
    eye = [movement.view_eye.point.x, movement.view_eye.point.y, movement.view_eye.point.z]
    focus = [movement.view_focus.point.x, movement.view_focus.point.y,
             movement.view_focus.point.z]
    up = [movement.view_up.vector.x, movement.view_up.vector.y, movement.view_up.vector.z]
    np.testing.assert_allclose(eye, [10, -2, 17])
    np.testing.assert_allclose(focus, [10, 6, 0], atol=1e-9)       # where the view meets z = 0
    shown = geometry.quaternion_to_matrix(look_at_pose(eye, focus, up)[1])
    wanted = geometry.quaternion_to_matrix(look_at_pose([10, -2, 17], [10, 6, 0], [0, 0, 1])[1])
    np.testing.assert_allclose(shown, wanted, atol=1e-9)


def test_a_goal_in_another_frame_is_refused(graph, capfd):
    trajectory_type, _ = port_messages()
    log = LogTap(capfd)
    graph.add(view_animated_bridge.ViewAnimatedBridge)
    goals = graph.node('menu').create_publisher(PoseStamped, 'camera/goal', LATCHED_QOS)
    rviz = Collector(graph.node('rviz2'), trajectory_type, TOPIC, 1)
    goals.publish(goal([0.0, -8.0, 12.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0], frame='odom'))
    assert log.wait_for(graph, r"ignoring camera/goal in frame 'odom': expected 'map'")
    assert rviz.messages == []
