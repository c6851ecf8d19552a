"""sim_robot through its topics: its map, a goal reached, bad goals refused, a stop, a new goal."""

import math

from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid, Odometry, Path
import numpy as np
import pytest
from rcl_interfaces.msg import Log
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import Collector
from scipy import ndimage
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.navigation.robot_settings import GOAL_TOLERANCE_DEG, GOAL_TOLERANCE_M
from eye_bci_ros2.ros.topics import (
    GOAL_POSE_TOPIC, GOAL_QOS, MAP_QOS, MAP_TOPIC, ODOM_QOS, ODOM_TOPIC, PLAN_QOS, PLAN_TOPIC,
    ROBOT_MARKER_QOS, ROBOT_MARKER_TOPIC)
from eye_bci_ros2.sim.robot import DEFAULT_START_POSE, SimRobot

pytestmark = pytest.mark.ros

#: Simulated seconds per wall second in these tests (the stop test runs in real time).
FAST = 10.0
#: Deadline for a drive across the map at FAST, wall s (about 4 s on an idle machine).
DRIVE_S = 90.0


class Rig:
    """sim_robot and a test node that sends goals and reads odom, map, plan, markers, logs."""

    def __init__(self, graph, time_scale: float = FAST):
        self.graph = graph
        self.robot = graph.add(SimRobot, parameter_overrides=[
            Parameter('time_scale', value=time_scale)])
        node = graph.node('tester')
        self.node = node
        self.odom = Collector(node, Odometry, ODOM_TOPIC, ODOM_QOS)
        self.map = Collector(node, OccupancyGrid, MAP_TOPIC, MAP_QOS)
        self.plan = Collector(node, Path, PLAN_TOPIC, PLAN_QOS)
        self.markers = Collector(node, MarkerArray, ROBOT_MARKER_TOPIC, ROBOT_MARKER_QOS)
        self.logs = []
        node.create_subscription(
            Log, '/rosout', lambda m: self.logs.append(m) if m.name == 'sim_robot' else None,
            QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL))
        self.goals = node.create_publisher(PoseStamped, GOAL_POSE_TOPIC, GOAL_QOS)
        assert graph.spin_until(lambda: self.map.last is not None and len(self.odom.messages)
                                and self.goals.get_subscription_count() == 1, 30.0)

    def send(self, x, y, yaw, frame='map'):
        goal = PoseStamped()
        goal.header.frame_id = frame
        goal.header.stamp = self.node.get_clock().now().to_msg()
        goal.pose.position.x, goal.pose.position.y = float(x), float(y)
        goal.pose.orientation.z, goal.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        self.goals.publish(goal)

    def pose(self, message=None):
        message = message or self.odom.last
        p, q = message.pose.pose.position, message.pose.pose.orientation
        return np.array([p.x, p.y, 2 * math.atan2(q.z, q.w)])

    @staticmethod
    def still(message):
        twist = message.twist.twist
        return twist.linear.x == 0.0 and twist.angular.z == 0.0

    def lines(self, text):
        return [m.msg for m in self.logs if text in m.msg]

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
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi)


def arrived_at(rig, goal):
    message = rig.odom.last
    pose = rig.pose(message)
    return (rig.still(message) and np.hypot(*(pose[:2] - goal[:2])) <= GOAL_TOLERANCE_M
            and angle_between(pose[2], goal[2]) <= math.radians(GOAL_TOLERANCE_DEG))


def test_the_map_is_latched_and_a_goal_on_a_free_cell_of_it_is_reached(graph):
    rig = Rig(graph)
    grid = rig.map.last
    assert grid.header.frame_id == 'map' and grid.info.resolution == pytest.approx(0.05)
    assert set(np.unique(np.array(grid.data))) == {0, 100}
    # Start pose and odometry at >= 20 Hz of the node's clock.
    assert np.allclose(rig.pose(), DEFAULT_START_POSE, atol=1e-6)
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in rig.wait_odom(20)]
    assert len(stamps) == 20 and rig.odom.last.header.frame_id == 'map'
    # In the living room, two rooms away: through two doors.
    x, y = rig.free_cell_near(15.0, 8.0, clearance=0.5)
    goal = np.array([x, y, math.radians(100.0)])
    rig.send(*goal)
    assert graph.spin_until(lambda: rig.plan.last is not None and rig.plan.last.poses, 10.0)
    path = rig.plan.last
    assert path.header.frame_id == 'map'
    end = path.poses[-1].pose.position
    assert (end.x, end.y) == pytest.approx((x, y))
    assert graph.spin_until(lambda: arrived_at(rig, goal), DRIVE_S)
    assert rig.lines('arrived at')
    # It moved at no more than its top speed and drew itself where it is.
    speeds = [m.twist.twist.linear.x for m in rig.odom.messages]
    assert max(speeds) == pytest.approx(0.5, abs=1e-6) and min(speeds) >= 0.0
    body = rig.markers.last.markers[0]
    assert (body.pose.position.x, body.pose.position.y) == pytest.approx(
        tuple(rig.pose()[:2]), abs=0.2)


@pytest.mark.parametrize('goal, frame, reason', [
    ((10.0, 3.0, 0.0), 'map', 'inside a wall or table'),
    ((30.0, 5.0, 0.0), 'map', 'off the map'),
    ((math.nan, 5.0, 0.0), 'map', 'not a finite pose'),
    ((6.0, 5.0, 0.0), 'odom', "in frame 'odom'"),
    ((15.0, 4.0, 0.0), 'map', 'inside a wall or table'),  # office/table_2
])
def test_a_goal_it_cannot_reach_is_refused_in_one_line_and_it_stays(graph, goal, frame, reason):
    rig = Rig(graph)
    before = rig.pose()
    rig.send(*goal, frame=frame)
    assert graph.spin_until(lambda: rig.lines('refused goal'), 10.0)
    after = rig.wait_odom(20)
    assert all(rig.still(m) and np.allclose(rig.pose(m), before) for m in after)
    refused = rig.lines('refused goal')
    assert len(refused) == 1 and reason in refused[0] and '\n' not in refused[0]
    assert rig.plan.last is None


def test_a_stop_brakes_and_it_stands_still_within_1_5_s(graph):
    rig = Rig(graph, time_scale=1.0)
    rig.send(15.0, 8.5, 0.0)
    assert graph.spin_until(lambda: rig.odom.last.twist.twist.linear.x >= 0.45, 30.0)
    # The menu's stop: a goal at the pose the robot reported.
    stop = rig.pose()
    sent = rig.node.get_clock().now().nanoseconds * 1e-9
    rig.send(*stop)
    assert graph.spin_until(lambda: rig.still(rig.odom.last), 30.0)
    standing = rig.odom.last.header.stamp
    assert standing.sec + standing.nanosec * 1e-9 - sent <= 1.5
    held = rig.pose()
    # Beyond the stop pose by no more than the braking distance (0.5 m/s at 0.5 m/s^2: 0.25 m)
    # and what it drove while the stop was on its way (a few odometry periods).
    assert np.hypot(*(held[:2] - stop[:2])) <= 0.25 + 0.5 * 0.2
    # It stays: no motion afterwards, the plan cleared.
    assert all(rig.still(m) and np.allclose(rig.pose(m), held) for m in rig.wait_odom(20))
    assert rig.plan.last.poses == [] and rig.lines('stop:')


def test_a_new_goal_replaces_the_one_being_driven_to(graph):
    rig = Rig(graph)
    rig.send(15.0, 8.5, 0.0)
    assert graph.spin_until(lambda: rig.odom.last.twist.twist.linear.x > 0.2, 30.0)
    second = np.array([*rig.free_cell_near(3.0, 1.5, clearance=0.5), math.pi])
    rig.send(*second)
    assert graph.spin_until(lambda: arrived_at(rig, second), DRIVE_S)
    assert max(rig.pose(m)[0] for m in rig.odom.messages) < 10.0  # never left the bedroom
    end = rig.plan.last.poses[-1].pose.position
    assert (end.x, end.y) == pytest.approx(tuple(second[:2]))
