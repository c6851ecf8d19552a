"""camera_tracker on a real ROS 2 graph: static view, RViz poses, bad input."""

from geometry_msgs.msg import Pose, PoseStamped
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector

from eye_bci_ros2.nodes.camera_tracker import CameraTracker, DEFAULT_EYE, DEFAULT_FOCUS, DEFAULT_UP
from eye_bci_ros2.projection import geometry
from eye_bci_ros2.ros.conversions import arrays_to_pose, pose_to_arrays
from eye_bci_ros2.ros.topics import LATCHED_QOS, RVIZ_POSE_QOS

pytestmark = pytest.mark.ros

DEFAULTS = {'world_frame': 'map', 'eye': DEFAULT_EYE, 'focus': DEFAULT_FOCUS, 'up': DEFAULT_UP}


def optical_axes(message: PoseStamped):
    """Return (position, right, down, forward) of a camera/pose message, world frame."""
    position, quaternion = pose_to_arrays(message.pose)
    rotation = geometry.quaternion_to_matrix(quaternion)
    return position, rotation[:, 0], rotation[:, 1], rotation[:, 2]


def start(graph, **overrides):
    """Start a tracker with parameter overrides and a late camera/pose collector."""
    tracker = graph.add(CameraTracker, parameter_overrides=[
        Parameter(name, value=value) for name, value in overrides.items()])
    helper = graph.node('tracker_test')
    rviz = helper.create_publisher(Pose, 'rviz/current_camera_pose', RVIZ_POSE_QOS)
    poses = Collector(helper, PoseStamped, 'camera/pose', LATCHED_QOS)
    return tracker, rviz, poses


def send(graph, rviz, poses, position, quaternion_xyzw, expect_new=True):
    """Publish an Ogre camera pose; wait for the tracker's answer if one is expected."""
    before = len(poses.messages)
    assert graph.spin_until(lambda: rviz.get_subscription_count() > 0, 10.0)
    rviz.publish(arrays_to_pose(position, quaternion_xyzw))
    if expect_new:
        assert graph.spin_until(lambda: len(poses.messages) > before, 10.0)


def test_static_view_is_latched_for_a_late_subscriber(graph):
    graph.add(CameraTracker, parameter_overrides=[
        Parameter('eye', value=[0.0, -8.0, 12.0]), Parameter('focus', value=[1.0, 2.0, 0.0])])
    graph.spin_for(0.3)  # published before anyone listened
    late = Collector(graph.node('late'), PoseStamped, 'camera/pose', LATCHED_QOS)
    assert graph.spin_until(lambda: late.messages, 10.0)
    message = late.last
    position, right, down, forward = optical_axes(message)
    assert message.header.frame_id == 'map'
    np.testing.assert_allclose(position, [0, -8, 12])
    direction = np.array([1.0, 10.0, -12.0])
    np.testing.assert_allclose(forward, direction / np.linalg.norm(direction), atol=1e-9)
    assert right[2] == pytest.approx(0.0, abs=1e-9)   # no roll: x stays horizontal
    assert down[2] < 0                                # world up points up on the screen


def test_ogre_pose_becomes_optical(graph):
    _, rviz, poses = start(graph, world_frame='odom')
    assert graph.spin_until(lambda: poses.messages, 10.0)
    # Ogre identity at (1, 2, 3): looks down world -Z with +Y up on the screen.
    send(graph, rviz, poses, [1.0, 2.0, 3.0], [0.0, 0.0, 0.0, 1.0])
    position, right, down, forward = optical_axes(poses.last)
    assert poses.last.header.frame_id == 'odom'
    np.testing.assert_allclose(position, [1, 2, 3])
    np.testing.assert_allclose(forward, [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(down, [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(right, [1, 0, 0], atol=1e-12)
    # Ogre yawed 90 degrees about world Z, not normalised: looks the same way,
    # but screen right is now world +Y.
    send(graph, rviz, poses, [0.0, 0.0, 5.0], [0.0, 0.0, 2.0, 2.0])
    _, right, down, forward = optical_axes(poses.last)
    np.testing.assert_allclose(forward, [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(right, [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(down, [1, 0, 0], atol=1e-12)


@pytest.mark.parametrize('values, reason', [
    ({'eye': DEFAULT_FOCUS}, 'equals focus'),
    ({'eye': [DEFAULT_FOCUS[0], DEFAULT_FOCUS[1], 9.0]}, 'parallel'),
    ({'up': [0.0, 0.0, 0.0]}, 'zero'),
    ({'eye': [0.0, float('nan'), 9.0]}, 'NaN'),
    ({'focus': [1.0, 2.0]}, 'exactly 3 numbers'),
    ({'world_frame': ''}, 'empty'),
])
def test_degenerate_view_parameters_are_rejected_and_the_old_view_kept(graph, values, reason):
    _, _, poses = start(graph)
    assert graph.spin_until(lambda: poses.messages, 10.0)
    results = graph.set_parameters('/camera_tracker', values)
    assert not results[0].successful
    assert reason in results[0].reason
    name = next(iter(values))
    kept = graph.get_parameters('/camera_tracker', [name])[0]
    assert (kept if name == 'world_frame' else list(kept)) == DEFAULTS[name]
    graph.spin_for(0.3)
    assert len(poses.messages) == 1
    np.testing.assert_allclose(optical_axes(poses.last)[0], DEFAULT_EYE)


def test_view_parameters_apply_at_once_until_rviz_publishes(graph):
    _, rviz, poses = start(graph, focus=[0.0, 0.0, 0.0])
    assert graph.spin_until(lambda: poses.messages, 10.0)
    results = graph.set_parameters('/camera_tracker', {'eye': [5.0, 0.0, 5.0]})
    assert results[0].successful
    assert graph.spin_until(lambda: len(poses.messages) == 2, 10.0)
    position, _, _, forward = optical_axes(poses.last)
    np.testing.assert_allclose(position, [5, 0, 5])
    np.testing.assert_allclose(forward, [-np.sqrt(0.5), 0, -np.sqrt(0.5)], atol=1e-12)
    # Once RViz has published, its pose wins over the static view.
    send(graph, rviz, poses, [1.0, 1.0, 1.0], [0.0, 0.0, 0.0, 1.0])
    count = len(poses.messages)
    assert graph.set_parameters('/camera_tracker', {'eye': [7.0, 0.0, 5.0]})[0].successful
    graph.spin_for(0.3)
    assert len(poses.messages) == count
    # ... but a new world_frame is republished with the live pose.
    assert graph.set_parameters('/camera_tracker', {'world_frame': 'odom'})[0].successful
    assert graph.spin_until(lambda: len(poses.messages) == count + 1, 10.0)
    assert poses.last.header.frame_id == 'odom'
    np.testing.assert_allclose(optical_axes(poses.last)[0], [1, 1, 1])


def test_bad_rviz_poses_are_ignored_and_the_last_good_one_kept(graph):
    tracker, rviz, poses = start(graph)
    assert graph.spin_until(lambda: poses.messages, 10.0)
    send(graph, rviz, poses, [1.0, 2.0, 3.0], [0.0, 0.0, 0.0, 1.0])
    send(graph, rviz, poses, [float('nan'), 0.0, 3.0], [0.0, 0.0, 0.0, 1.0], expect_new=False)
    send(graph, rviz, poses, [1.0, 2.0, 3.0], [0.0, 0.0, 0.0, 0.0], expect_new=False)
    send(graph, rviz, poses, [1.0, 2.0, 3.0], [0.0, float('inf'), 0.0, 1.0], expect_new=False)
    # Messages arrive in order: the next good pose comes right after the first one.
    send(graph, rviz, poses, [4.0, 5.0, 6.0], [0.0, 0.0, 0.0, 1.0])
    positions = [optical_axes(message)[0].tolist() for message in poses.messages]
    assert positions == [DEFAULT_EYE, [1, 2, 3], [4, 5, 6]]
    assert tracker.context.ok()
