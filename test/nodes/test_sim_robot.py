"""
sim_robot through nav2's interface: NavigateToPose goals, feedback, cancels, preemption, TF.

Every test runs the real node on a private graph; the robot drives at real speed (time_scale
1) unless a test says why not.  A client sends goals as the menu (or ``ros2 action
send_goal``) does and reads the robot's pose through TF (map -> odom -> base_link), as a nav2
user does.
"""

import math
import time

from action_msgs.msg import GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal
from geometry_msgs.msg import PoseStamped
from nav2_msgs.action import NavigateToPose
from nav_msgs.msg import OccupancyGrid, Odometry, Path
import numpy as np
import pytest
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import Collector
from scipy import ndimage
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.navigation import nav2_codes
from eye_bci_ros2.navigation.frames import BASE_FRAME, compose, MAP_FRAME, ODOM_FRAME, wrap
from eye_bci_ros2.navigation.robot_settings import RobotSettings
from eye_bci_ros2.ros.robot_messages import planar_pose, pose_stamped
from eye_bci_ros2.ros.topics import (
    GOAL_POSE_TOPIC, GOAL_QOS, MAP_QOS, MAP_TOPIC, NAVIGATE_TO_POSE_ACTION, ODOM_QOS,
    ODOM_TOPIC, PLAN_QOS, PLAN_TOPIC, ROBOT_MARKER_QOS, ROBOT_MARKER_TOPIC, TF_QOS, TF_TOPIC)
from eye_bci_ros2.sim.robot import DEFAULT_START_POSE, SimRobot

pytestmark = pytest.mark.ros

SETTINGS = RobotSettings()
#: Simulated seconds per wall second where a test only needs the robot somewhere (preemption,
#: goal_pose); every cancel, the cross-room goal and the refusals run at real speed.
FAST = 10.0
#: Deadline for a drive across the map at real speed, wall s (about 35 s on an idle machine).
DRIVE_S = 150.0
#: A stop must leave the robot standing this soon after the cancel is sent, s (the issue).
STAND_WITHIN_S = 1.5


def stamp_s(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


class Rig:
    """
    sim_robot and a client node: goals, feedback, results, odom, /tf, map, plan.

    Its log lines are checked by test_ros2_cli_robot (a process's output is read whole;
    /rosout in-process was seen to miss lines).
    """

    def __init__(self, graph, time_scale: float = 1.0, **parameters):
        self.graph = graph
        overrides = [Parameter('time_scale', value=time_scale)] + [
            Parameter(name, value=value) for name, value in parameters.items()]
        self.robot = graph.add(SimRobot, parameter_overrides=overrides)
        node = graph.node('tester')
        self.node = node
        self.odom = Collector(node, Odometry, ODOM_TOPIC, ODOM_QOS)
        self.tf = Collector(node, TFMessage, TF_TOPIC, TF_QOS)
        self.map = Collector(node, OccupancyGrid, MAP_TOPIC, MAP_QOS)
        self.plan = Collector(node, Path, PLAN_TOPIC, PLAN_QOS)
        self.markers = Collector(node, MarkerArray, ROBOT_MARKER_TOPIC, ROBOT_MARKER_QOS)
        self.client = ActionClient(node, NavigateToPose, NAVIGATE_TO_POSE_ACTION)
        self.goal_topic = node.create_publisher(PoseStamped, GOAL_POSE_TOPIC, GOAL_QOS)
        assert graph.spin_until(lambda: self.map.last is not None and self.tf.messages
                                and self.client.server_is_ready()
                                and self.goal_topic.get_subscription_count() == 1, 30.0)

    # -- goals -------------------------------------------------------------------------

    def send(self, x, y, yaw, frame=MAP_FRAME, behavior_tree=''):
        """Send a goal; return (goal handle, result future, feedback list) once accepted."""
        goal = NavigateToPose.Goal(behavior_tree=behavior_tree)
        goal.pose = pose_stamped(np.array([x, y, yaw]), frame,
                                 self.node.get_clock().now().to_msg())
        feedback = []
        future = self.client.send_goal_async(goal, feedback_callback=lambda m: feedback.append(
            m.feedback))
        handle = self.graph.wait_future(future, 30.0)
        assert handle.accepted, 'sim_robot accepts every goal, as bt_navigator does'
        return handle, handle.get_result_async(), feedback

    def result(self, future, timeout=DRIVE_S):
        """Wait for a goal's end; return (status, result message)."""
        response = self.graph.wait_future(future, timeout)
        return response.status, response.result

    # -- where the robot is ------------------------------------------------------------

    def transforms(self, message=None):
        """Return (stamp s, map -> odom, odom -> base_link) of a /tf message."""
        message = message or self.tf.last
        found = {(t.header.frame_id, t.child_frame_id): t for t in message.transforms}
        pair = []
        for key in ((MAP_FRAME, ODOM_FRAME), (ODOM_FRAME, BASE_FRAME)):
            t = found[key].transform
            q = t.rotation
            pair.append(np.array([t.translation.x, t.translation.y,
                                  2 * math.atan2(q.z, q.w)]))
        return stamp_s(message.transforms[0].header.stamp), pair[0], pair[1]

    def pose(self, message=None):
        """Return the robot's pose in the map through TF (map -> odom -> base_link)."""
        _, map_odom, odom_base = self.transforms(message)
        return compose(map_odom, odom_base)

    @staticmethod
    def still(message):
        twist = message.twist.twist
        return twist.linear.x == 0.0 and twist.angular.z == 0.0

    def wait_odom(self, count):
        """Spin until ``count`` more odometry messages came; return them."""
        first = len(self.odom.messages)
        assert self.graph.spin_until(lambda: len(self.odom.messages) >= first + count, 30.0)
        return self.odom.messages[first:]

    def free_cell_near(self, x, y, clearance):
        """Return the free cell centre nearest (x, y) with clearance m of free space."""
        grid = self.map.last
        info = grid.info
        cells = np.array(grid.data, dtype=np.int16).reshape(info.height, info.width)
        room = ndimage.distance_transform_edt(cells == 0) * info.resolution
        rows, cols = np.nonzero(room >= clearance)
        centres = np.stack([cols + 0.5, rows + 0.5], axis=1) * info.resolution + [
            info.origin.position.x, info.origin.position.y]
        return centres[np.argmin(np.hypot(*(centres - [x, y]).T))]


def angle_between(a, b):
    return abs(wrap(a - b))


def within_tolerance(pose, goal):
    return (np.hypot(*(pose[:2] - goal[:2])) <= SETTINGS.goal_tolerance_m
            and angle_between(pose[2], goal[2]) <= SETTINGS.goal_tolerance_rad)


def test_a_cross_room_goal_at_real_speed_with_feedback_tf_and_drifting_odometry(graph):
    rig = Rig(graph)
    grid = rig.map.last
    assert grid.header.frame_id == MAP_FRAME and set(np.unique(np.array(grid.data))) == {0, 100}
    # At start: TF puts the robot at its start pose; odom starts at its own origin.
    assert rig.pose() == pytest.approx(DEFAULT_START_POSE, abs=1e-6)
    first = rig.wait_odom(1)[0]
    assert (first.header.frame_id, first.child_frame_id) == (ODOM_FRAME, BASE_FRAME)
    assert planar_pose(first.pose.pose) == pytest.approx([0.0, 0.0, 0.0], abs=1e-9)
    # To the living room, two rooms away, through two doors: about 12 m at 0.5 m/s.
    x, y = rig.free_cell_near(15.0, 8.0, clearance=0.5)
    goal = np.array([x, y, math.radians(100.0)])
    handle, done, feedback = rig.send(*goal)
    status, result = rig.result(done)
    assert status == GoalStatus.STATUS_SUCCEEDED
    assert (result.error_code, result.error_msg) == (nav2_codes.NONE, '')
    # Arrived within the goal checker's tolerance, standing.
    assert within_tolerance(rig.pose(), goal) and rig.still(rig.wait_odom(3)[-1])
    # The plan: from the start to the goal, a heading on every pose along its segment.
    plan = [m for m in rig.plan.messages if m.poses][-1]
    poses = np.array([planar_pose(p.pose) for p in plan.poses])
    assert plan.header.frame_id == MAP_FRAME and len(poses) >= 3
    assert poses[0, :2] == pytest.approx(DEFAULT_START_POSE[:2], abs=0.05)
    assert poses[-1] == pytest.approx(goal, abs=1e-6)
    along = np.arctan2(*np.diff(poses[:, :2], axis=0).T[::-1])
    assert all(angle_between(a, b) < 1e-6 for a, b in zip(poses[:-1, 2], along))
    # Feedback: at >= 5 Hz of the robot's own clock, in the map frame, distance falling.
    times = np.array([stamp_s(f.navigation_time) for f in feedback])
    assert len(feedback) / (times[-1] - times[0]) >= 5.0
    assert all(f.current_pose.header.frame_id == MAP_FRAME for f in feedback)
    distance = np.array([f.distance_remaining for f in feedback])
    length = np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T))
    assert distance[0] == pytest.approx(length, abs=0.3) and distance[-1] < 0.3
    # Never up (a few mm where the robot switches to a corner's next segment), and down by
    # the path's length.
    assert np.max(np.diff(distance)) <= 0.02, np.max(np.diff(distance))
    assert max(stamp_s(f.estimated_time_remaining) for f in feedback) > 10.0
    # TF: map -> odom -> base_link is the pose feedback reports, at the same instants.
    by_stamp = {stamp_s(f.current_pose.header.stamp): planar_pose(f.current_pose.pose)
                for f in feedback}
    matched = 0
    for message in rig.tf.messages:
        stamp, map_odom, odom_base = rig.transforms(message)
        if stamp in by_stamp:
            matched += 1
            assert compose(map_odom, odom_base) == pytest.approx(by_stamp[stamp], abs=1e-6)
    assert matched >= len(feedback) // 2
    # The odometry drifted (map -> odom moved off the start pose) and odom is not the map
    # pose: whoever reads odom as the map pose is metres off.
    _, map_odom, odom_base = rig.transforms()
    assert np.hypot(*(map_odom[:2] - DEFAULT_START_POSE[:2])) > 0.02
    assert angle_between(map_odom[2], DEFAULT_START_POSE[2]) > math.radians(1.0)
    assert np.hypot(*(odom_base[:2] - rig.pose()[:2])) > 1.0
    odom_pose = planar_pose(rig.odom.last.pose.pose)
    assert odom_pose == pytest.approx(odom_base, abs=1e-6)
    # The robot is drawn in base_link, where TF puts it.
    assert {m.header.frame_id for m in rig.markers.last.markers} == {BASE_FRAME}


@pytest.mark.parametrize('goal, frame, behavior_tree, code, text', [
    ((10.0, 3.0, 0.0), MAP_FRAME, '', nav2_codes.GOAL_OCCUPIED, 'inside a wall or table'),
    ((15.0, 4.0, 0.0), MAP_FRAME, '', nav2_codes.GOAL_OCCUPIED, 'inside a wall or table'),
    ((30.0, 5.0, 0.0), MAP_FRAME, '', nav2_codes.GOAL_OUTSIDE_MAP, 'off the map'),
    ((math.nan, 5.0, 0.0), MAP_FRAME, '', nav2_codes.GOAL_OUTSIDE_MAP, 'not a finite'),
    ((6.0, 5.0, 0.0), 'world', '', nav2_codes.TF_ERROR, "frame_id 'world'"),
    ((6.0, 5.0, 0.0), '', '', nav2_codes.TF_ERROR, "frame_id ''"),
    ((6.0, 5.0, 0.0), MAP_FRAME, 'my_tree.xml', nav2_codes.FAILED_TO_LOAD_BEHAVIOR_TREE,
     'Error loading: my_tree.xml'),
    (None, MAP_FRAME, '', nav2_codes.NO_VALID_PATH, 'not reachable'),
])
def test_a_goal_it_cannot_reach_ends_aborted_with_nav2s_code_and_it_stays(
        graph, goal, frame, behavior_tree, code, text):
    if goal is None:
        # A robot 1 m wide does not pass the 0.9 m doors: the living room is out of reach.
        rig = Rig(graph, radius_m=0.5)
        goal = (*rig.free_cell_near(15.0, 8.0, clearance=0.9), 0.0)
    else:
        rig = Rig(graph)
    before = rig.pose()
    _, done, _ = rig.send(*goal, frame=frame, behavior_tree=behavior_tree)
    status, result = rig.result(done, 30.0)
    assert status == GoalStatus.STATUS_ABORTED
    assert result.error_code == code and text in result.error_msg, result.error_msg
    assert '\n' not in result.error_msg
    after = rig.wait_odom(20)
    assert all(rig.still(m) for m in after) and rig.pose() == pytest.approx(before, abs=1e-9)
    assert not [m for m in rig.plan.messages if m.poses]


def test_a_goal_in_odom_or_base_link_is_taken_through_tf(graph):
    rig = Rig(graph, time_scale=FAST)
    # One metre ahead of the robot, in its own frame: 1 m east of the start.
    _, done, _ = rig.send(1.0, 0.0, 0.0, frame=BASE_FRAME)
    assert rig.result(done)[0] == GoalStatus.STATUS_SUCCEEDED
    assert within_tolerance(rig.pose(), np.array([6.0, 5.0, 0.0]))
    # Back to where odom started (its origin): the start pose in the map, drift and all.
    _, done, _ = rig.send(0.0, 0.0, 0.0, frame=ODOM_FRAME)
    assert rig.result(done)[0] == GoalStatus.STATUS_SUCCEEDED
    _, map_odom, _ = rig.transforms()
    assert within_tolerance(rig.pose(), map_odom)


#: Longest a cancel takes from the client to the robot's next tick, s (three odometry periods).
CANCEL_LATENCY_S = 0.15


def braking_bound(speed, accel, top):
    """
    Return how far (m or rad) a robot at ``speed`` goes after a cancel is sent, at most.

    While the cancel is on its way it may still speed up (``accel``, up to ``top``); then
    it brakes at ``accel``: speed^2 / (2 accel) (RobotSettings.stop_distance_m from top speed).
    """
    reached = min(top, speed + accel * CANCEL_LATENCY_S)
    return (speed + reached) / 2 * CANCEL_LATENCY_S + reached ** 2 / (2 * accel)


def drive_state(rig, state):
    """Send a goal and spin until the robot is in ``state``; return the goal's parts."""
    if state == 'turning':
        # A goal behind the robot (it faces east): it turns on the spot first.
        sent = rig.send(3.0, 5.0, math.pi)
    else:
        sent = rig.send(15.0, 8.5, 0.0)
    reached = {'turning': lambda m: abs(m.twist.twist.angular.z) > 0.5
               and m.twist.twist.linear.x == 0,
               'accelerating': lambda m: 0.1 < m.twist.twist.linear.x < 0.35,
               'cruising': lambda m: m.twist.twist.linear.x > 0.49,
               'preempted': lambda m: m.twist.twist.linear.x > 0.49}[state]
    assert rig.graph.spin_until(lambda: rig.odom.messages and reached(rig.odom.last), 60.0), \
        state
    if state == 'preempted':
        # A new goal (the first ends ABORTED, preempted), cancelled at once: the stop comes
        # while the robot still drives the first goal's path.
        sent = rig.send(*rig.free_cell_near(15.0, 10.5, clearance=0.5), 0.0)
    return sent


@pytest.mark.parametrize('state', ['accelerating', 'cruising', 'turning', 'preempted'])
def test_a_cancel_stands_the_robot_within_1_5_s_and_never_farther_than_braking_allows(
        graph, state):
    rig = Rig(graph)
    handle, done, _ = drive_state(rig, state)
    at_cancel = rig.pose()
    speed = rig.odom.last.twist.twist
    sent = rig.node.get_clock().now().nanoseconds * 1e-9
    rig.graph.wait_future(handle.cancel_goal_async(), 10.0)
    status, result = rig.result(done, 30.0)
    assert status == GoalStatus.STATUS_CANCELED and result.error_code == nav2_codes.NONE
    # Standing when the goal ended: every later message still, at the same pose.
    standing = rig.wait_odom(20)
    assert all(rig.still(m) for m in standing)
    stood_at = min(stamp_s(m.header.stamp) for m in rig.odom.messages
                   if stamp_s(m.header.stamp) >= sent and rig.still(m))
    assert stood_at - sent <= STAND_WITHIN_S
    held = rig.pose()
    assert all(rig.pose(m) == pytest.approx(held, abs=1e-9) for m in rig.tf.messages[-10:])
    # Braking from the settings, after what the robot drove while the cancel was on its way
    # (CANCEL_LATENCY_S, still speeding up at most at its acceleration).
    s = SETTINGS
    assert np.hypot(*(held[:2] - at_cancel[:2])) <= braking_bound(
        abs(speed.linear.x), s.linear_accel, s.max_speed) + 0.01
    assert angle_between(held[2], at_cancel[2]) <= braking_bound(
        abs(speed.angular.z), s.angular_accel, s.max_turn_rate) + math.radians(1)
    assert held == pytest.approx(rig.pose(), abs=1e-9)
    assert rig.plan.last.poses == []


def test_a_new_goal_preempts_the_old_one_which_ends_aborted_without_an_error(graph):
    rig = Rig(graph, time_scale=FAST)
    _, first, _ = rig.send(15.0, 8.5, 0.0)
    assert graph.spin_until(lambda: rig.odom.messages
                            and rig.odom.last.twist.twist.linear.x > 0.2, 30.0)
    second_goal = np.array([*rig.free_cell_near(3.0, 1.5, clearance=0.5), math.pi])
    _, second, _ = rig.send(*second_goal)
    # nav2's SimpleActionServer aborts the preempted goal with an empty result.
    status, result = rig.result(first, 30.0)
    assert status == GoalStatus.STATUS_ABORTED
    assert (result.error_code, result.error_msg) == (nav2_codes.NONE, '')
    assert rig.result(second)[0] == GoalStatus.STATUS_SUCCEEDED
    assert within_tolerance(rig.pose(), second_goal)
    assert max(rig.pose(m)[0] for m in rig.tf.messages) < 10.0   # never left the bedroom
    end = planar_pose(rig.plan.last.poses[-1].pose)
    assert end[:2] == pytest.approx(second_goal[:2], abs=1e-6)
    assert angle_between(end[2], second_goal[2]) < 1e-6


def test_goal_pose_becomes_an_action_goal_that_a_cancel_stops(graph):
    rig = Rig(graph, time_scale=FAST)
    statuses = []
    rig.node.create_subscription(
        GoalStatusArray, NAVIGATE_TO_POSE_ACTION + '/_action/status',
        lambda m: statuses.append([s.status for s in m.status_list]),
        QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                   durability=DurabilityPolicy.TRANSIENT_LOCAL))
    rig.goal_topic.publish(pose_stamped(np.array([15.0, 8.5, 0.0]), MAP_FRAME))
    assert graph.spin_until(lambda: any(GoalStatus.STATUS_EXECUTING in s for s in statuses)
                            and rig.odom.last.twist.twist.linear.x > 0.2, 30.0)
    # Cancel every goal (a zero goal id and stamp), as a menu that did not send it can.
    cancel = rig.node.create_client(CancelGoal, NAVIGATE_TO_POSE_ACTION + '/_action/cancel_goal')
    assert graph.spin_until(cancel.service_is_ready, 10.0)
    response = graph.wait_future(cancel.call_async(CancelGoal.Request()), 10.0)
    assert response.return_code == CancelGoal.Response.ERROR_NONE
    assert graph.spin_until(lambda: statuses and GoalStatus.STATUS_CANCELED in statuses[-1],
                            30.0)
    assert all(rig.still(m) for m in rig.wait_odom(10))


def test_odometry_keeps_its_rate_while_plans_are_computed(graph):
    """
    A burst of goals on a fine map (each plan a few tenths of a second) costs no odometry.

    The reference is the odometry rate in the same run just before the burst: planning in
    the timer's thread would silence odometry for the whole burst.
    """
    rig = Rig(graph, map_resolution=0.02)
    # The first plan on a new map builds its graph: wait until one goal was planned.
    _, done, _ = rig.send(6.0, 5.0, 0.0)
    assert rig.result(done)[0] == GoalStatus.STATUS_SUCCEEDED
    before = rig.wait_odom(40)
    quiet_rate = (len(before) - 1) / (stamp_s(before[-1].header.stamp)
                                      - stamp_s(before[0].header.stamp))
    first = len(rig.odom.messages)
    plans = len(rig.plan.messages)
    sent = []
    started = time.monotonic()
    for index in range(8):
        sent.append(rig.send(18.0 - 0.2 * index, 10.5, 0.0))
    # Until the last goal's plan is published, and at least a second (a fast machine plans
    # the burst in less: the window still holds all of it).
    assert graph.spin_until(lambda: len(rig.plan.messages) > plans and rig.plan.last.poses
                            and planar_pose(rig.plan.last.poses[-1].pose)[0] == pytest.approx(
                                18.0 - 0.2 * 7), 120.0)
    graph.spin_for(max(0.0, 1.0 - (time.monotonic() - started)))
    during = rig.odom.messages[first:]
    stamps = np.array([stamp_s(message.header.stamp) for message in during])
    span = stamps[-1] - stamps[0]
    assert span > 0.3, 'the burst was too short to measure'
    assert (len(during) - 1) / span >= 0.7 * quiet_rate
    # No silence while a plan is computed: a plan in the timer's thread leaves a gap as long.
    assert np.max(np.diff(stamps)) < 4.0 / quiet_rate, np.max(np.diff(stamps))
    rig.graph.wait_future(sent[-1][0].cancel_goal_async(), 10.0)
