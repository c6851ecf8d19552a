"""The simulated RViz view: eased moves to camera goals, Ogre poses out."""

import math

from geometry_msgs.msg import Pose, PoseStamped
import numpy as np
import pytest
from rclpy.time import Time
from ros_harness import Collector

from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.projection.view_animation import as_view, ogre_pose
from eye_bci_ros2.ros.conversions import arrays_to_pose, pose_to_arrays
from eye_bci_ros2.ros.topics import LATCHED_QOS
from eye_bci_ros2.sim.rviz_view import SimRvizView

pytestmark = pytest.mark.ros

OVERVIEW = as_view([10.0, -2.0, 17.0], [10.0, 6.0, 0.0], [0.0, 0.0, 1.0])
KITCHEN = as_view([5.0, 4.0, 6.5], [5.0, 9.3, 0.0], [0.0, 0.0, 1.0])


class ManualClock:
    """Animation clock the test moves by hand (no wall-clock assertions)."""

    def __init__(self):
        self.seconds = 1000.0

    def now(self) -> Time:
        return Time(nanoseconds=int(round(self.seconds * 1e9)))


def goal_message(view, frame='map') -> PoseStamped:
    message = PoseStamped()
    message.header.frame_id = frame
    message.pose = arrays_to_pose(*look_at_pose(*view))
    return message


def same_pose(message: Pose, position, quaternion, atol=1e-9) -> bool:
    if message is None:
        return False
    p, q = pose_to_arrays(message)
    return bool(np.allclose(p, position, atol=atol) and (
        np.allclose(q, quaternion, atol=atol) or np.allclose(q, -np.asarray(quaternion),
                                                             atol=atol)))


def eye_progress(message: Pose, start, goal) -> float:
    """Where a pose's eye lies on the line start -> goal (checks it is on it)."""
    eye, _ = pose_to_arrays(message)
    direction = goal[0] - start[0]
    s = float(np.dot(eye - start[0], direction) / np.dot(direction, direction))
    np.testing.assert_allclose(eye, start[0] + s * direction, atol=1e-9)
    return s


def make_view(graph, **overrides):
    from rclpy.parameter import Parameter
    clock = ManualClock()
    node = graph.add(SimRvizView, animation_clock=clock, parameter_overrides=[
        Parameter(name, value=value) for name, value in overrides.items()])
    probe = graph.node('probe')
    poses = Collector(probe, Pose, 'rviz/current_camera_pose', LATCHED_QOS)
    goals = probe.create_publisher(PoseStamped, 'camera/goal', LATCHED_QOS)
    assert graph.spin_until(lambda: poses.messages and goals.get_subscription_count() > 0, 10.0)
    return node, clock, poses, goals


def test_publishes_initial_view_latched(graph):
    node, _, poses, _ = make_view(graph)
    assert same_pose(poses.messages[0], *ogre_pose(*OVERVIEW))
    rotation = geometry.quaternion_to_matrix(pose_to_arrays(poses.messages[0])[1])
    forward = (OVERVIEW[1] - OVERVIEW[0]) / np.linalg.norm(OVERVIEW[1] - OVERVIEW[0])
    np.testing.assert_allclose(rotation @ [0, 0, -1], forward, atol=1e-9)
    for a, b in zip(node.current_view(), OVERVIEW):
        np.testing.assert_array_equal(a, b)
    graph.spin_for(0.3)
    assert len(poses.messages) == 1  # still: nothing more


def test_moves_to_goal_with_cosine_ease_and_ends_exactly(graph):
    node, clock, poses, goals = make_view(graph, transition_time_s=2.0)
    goals.publish(goal_message(KITCHEN))
    assert graph.spin_until(lambda: len(poses.messages) >= 2, 10.0)
    assert node.moving
    assert same_pose(poses.messages[1], *ogre_pose(*OVERVIEW))  # progress 0 at the start

    for elapsed in (0.5, 1.0, 1.5):
        clock.seconds += 0.5
        expected = (1 - math.cos(math.pi * elapsed / 2.0)) / 2
        # A pose computed before the clock step may still be on its way: wait for the new one.
        assert graph.spin_until(lambda: abs(eye_progress(poses.last, OVERVIEW, KITCHEN)
                                            - expected) < 1e-9, 10.0)
        np.testing.assert_allclose(node.current_view()[0],
                                   (1 - expected) * OVERVIEW[0] + expected * KITCHEN[0],
                                   atol=1e-9)

    clock.seconds += 0.5
    assert graph.spin_until(lambda: not node.moving and same_pose(
        poses.last, *ogre_pose(*KITCHEN)), 10.0)
    eye, focus, up = node.current_view()
    np.testing.assert_array_equal(eye, KITCHEN[0])
    np.testing.assert_allclose(focus, KITCHEN[1], atol=1e-9)  # the floor point it looks at
    np.testing.assert_allclose(geometry.look_at(eye, focus, up), geometry.look_at(*KITCHEN),
                               atol=1e-12)
    count = len(poses.messages)
    graph.spin_for(0.3)
    assert len(poses.messages) == count  # arrived: publishing stops


def test_new_goal_mid_move_starts_from_where_it_is(graph):
    node, clock, poses, goals = make_view(graph, transition_time_s=1.0)
    goals.publish(goal_message(KITCHEN))
    assert graph.spin_until(lambda: node.moving, 10.0)
    clock.seconds += 0.5
    graph.spin_until(lambda: False, 0.2)
    middle = node.current_view()
    goals.publish(goal_message(OVERVIEW))
    assert graph.spin_until(lambda: np.array_equal(node.target_view()[0], OVERVIEW[0]), 10.0)
    # Restarted from the middle: a quarter of the new move is eased to 14.6 %.
    clock.seconds += 0.25
    s = (1 - math.cos(math.pi / 4)) / 2
    expected = (1 - s) * middle[0] + s * OVERVIEW[0]
    assert graph.spin_until(lambda: np.allclose(pose_to_arrays(poses.last)[0], expected,
                                                atol=1e-9), 10.0)
    clock.seconds += 0.75
    assert graph.spin_until(lambda: same_pose(poses.last, *ogre_pose(*OVERVIEW)), 10.0)


def test_invalid_goals_are_ignored(graph):
    node, clock, poses, goals = make_view(graph, transition_time_s=0.0)
    bad = goal_message(KITCHEN)
    bad.pose.orientation.x = bad.pose.orientation.y = 0.0
    bad.pose.orientation.z = bad.pose.orientation.w = 0.0
    goals.publish(bad)
    goals.publish(goal_message(KITCHEN, frame='odom'))
    graph.spin_for(0.5)
    np.testing.assert_array_equal(node.current_view()[0], OVERVIEW[0])
    goals.publish(goal_message(KITCHEN))  # still alive: a good goal (T = 0 jumps)
    assert graph.spin_until(lambda: same_pose(poses.last, *ogre_pose(*KITCHEN)), 10.0)
    assert not node.moving


def test_parameters_validate_and_apply(graph):
    node, _, poses, _ = make_view(graph)
    results = graph.set_parameters('/sim_rviz_view', {'eye': [10.0, 6.0, 0.0]})
    assert not results[0].successful and 'equals focus' in results[0].reason
    results = graph.set_parameters('/sim_rviz_view', {'eye': [1.0, 2.0]})
    assert not results[0].successful and '3 finite numbers' in results[0].reason
    results = graph.set_parameters('/sim_rviz_view', {'transition_time_s': -1.0})
    assert not results[0].successful
    np.testing.assert_array_equal(node.current_view()[0], OVERVIEW[0])

    results = graph.set_parameters('/sim_rviz_view', {'eye': [10.0, -4.0, 20.0]})
    assert results[0].successful
    expected = ogre_pose([10.0, -4.0, 20.0], OVERVIEW[1], OVERVIEW[2])
    assert graph.spin_until(lambda: same_pose(poses.last, *expected), 10.0)
    assert graph.set_parameters('/sim_rviz_view', {'publish_rate_hz': 60.0})[0].successful
