"""
Simulated robot: nav2 and a robot, by nav2's rules, on the scene's floor plan.

What nav2 and a robot give the rest of the system, this node gives from the
scene file (a robot and nav2 cannot run here; this is the mock, as sim_gaze is
for the tracker): the map, a NavigateToPose action server, a plan, a robot that
drives it, odometry and TF (:mod:`eye_bci_ros2.navigation`).  docs/robot.md
has the whole interface and how a real nav2 takes its place.

* action ``navigate_to_pose`` (nav2_msgs/action/NavigateToPose), served as
  nav2's bt_navigator serves it: every goal is accepted; a new goal preempts the
  one being driven to (which ends ABORTED with an empty result, as nav2's
  SimpleActionServer does); a goal it cannot reach ends ABORTED with nav2's
  error code and a one-line reason (:mod:`eye_bci_ros2.navigation.nav2_codes`:
  a frame it has no transform for TF_ERROR, off the map or not finite
  GOAL_OUTSIDE_MAP, in or too near a wall or table GOAL_OCCUPIED, no way there
  NO_VALID_PATH, a ``behavior_tree`` FAILED_TO_LOAD_BEHAVIOR_TREE); feedback at
  ``odom_rate_hz`` (``current_pose`` in the map frame, ``distance_remaining``
  along the rest of the plan, times); a cancel brakes at ``linear_accel`` and
  ``angular_accel`` and the goal ends CANCELED once the robot stands; SUCCEEDED
  (error_code NONE) when it stands within ``goal_tolerance_m`` and
  ``goal_tolerance_deg`` of the goal.
* subscribes ``goal_pose`` geometry_msgs/PoseStamped: each message is sent as a
  NavigateToPose goal to its own server, as bt_navigator does (so it can be
  seen on the action's status and cancelled like any goal).
* publishes ``/tf`` (tf2_msgs/TFMessage): map -> odom (a perfect localiser) and
  odom -> base_link (the odometry), at ``odom_rate_hz``; ``odom``
  (nav_msgs/Odometry, frame ``odom``, child ``base_link``: wheel odometry that
  drifts a little with every metre, :mod:`eye_bci_ros2.navigation.odometry`);
  ``map`` (nav_msgs/OccupancyGrid, transient local, as map_server); ``plan``
  (nav_msgs/Path, every pose with its heading; empty when no goal is driven to);
  ``robot/marker`` (visualization_msgs/MarkerArray in ``base_link``: RViz draws
  the robot where TF puts it).

Plans are computed in a thread of their own
(:class:`eye_bci_ros2.navigation.plan_worker.PlanWorker`): odometry and TF keep
their rate while a plan is computed; the robot goes on along its old path
until the new plan is there.

Time: the robot moves ``time_scale`` simulated seconds per wall-clock second
(1, real speed, by default; the demo's pictures run it faster); stamps are the
node's clock.
"""

import array
from dataclasses import dataclass
import itertools
import math
import time
from typing import Any, Dict, Optional, Tuple

from geometry_msgs.msg import Point, PoseStamped
from nav2_msgs.action import NavigateToPose
from nav_msgs.msg import OccupancyGrid, Odometry, Path
import numpy as np
from rclpy.action import ActionClient, ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.duration import Duration
from rclpy.node import Node
from std_msgs.msg import ColorRGBA
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.navigation import nav2_codes
from eye_bci_ros2.navigation.drive import Drive, heading_error, Mode, pose_error
from eye_bci_ros2.navigation.frames import BASE_FRAME, compose, ODOM_FRAME
from eye_bci_ros2.navigation.occupancy import DEFAULT_RESOLUTION_M, scene_grid
from eye_bci_ros2.navigation.odometry import DriftingOdometry
from eye_bci_ros2.navigation.plan_worker import PlanWorker
from eye_bci_ros2.navigation.planner import NoPath, Planner
from eye_bci_ros2.navigation.robot_settings import RobotSettings
from eye_bci_ros2.ros.conversions import arrays_to_pose
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec, SettingsParameters
from eye_bci_ros2.ros.robot_messages import (
    path_message, planar_pose, pose_message, pose_stamped, transform_stamped)
from eye_bci_ros2.ros.runner import GOAL_EXECUTE_EVENT, spin_node
from eye_bci_ros2.ros.topics import (
    GOAL_POSE_TOPIC, GOAL_QOS, MAP_QOS, MAP_TOPIC, NAVIGATE_TO_POSE_ACTION, ODOM_QOS,
    ODOM_TOPIC, PLAN_QOS, PLAN_TOPIC, ROBOT_MARKER_QOS, ROBOT_MARKER_TOPIC, TF_QOS, TF_TOPIC)
from eye_bci_ros2.task.scene import load_scene, Scene

#: Default start: in the bedroom, facing east (config/scene.yaml).
DEFAULT_START_POSE = (5.0, 5.0, 0.0)
#: Drawn height of the robot's body, m.
BODY_HEIGHT_M = 0.4
#: Below this speed the estimated time remaining is 0, and below this distance left (as
#: bt_navigator computes its feedback), m/s and m.
ETA_MIN_SPEED = 0.01
ETA_MIN_DISTANCE_M = 0.1


def _check_pose(value: Any) -> Optional[str]:
    if value is None or len(value) != 3 or not all(math.isfinite(v) for v in value):
        return f'needs 3 finite numbers (x m, y m, yaw rad), got {list(value or [])!r}'
    return None


PARAMETERS = (
    ParamSpec('scene_file', '',
              'Scene YAML whose floor_plan and tables make the map (empty = the installed '
              'config/scene.yaml); setting it rebuilds the map and aborts the goal'),
    ParamSpec('start_pose', list(DEFAULT_START_POSE),
              "The robot's pose at start-up [x m, y m, yaw rad] in the map frame, on a free "
              'place; setting it puts the robot there, standing (map -> odom jumps, odom '
              'stays continuous)', check=_check_pose, array_type='double_array'),
    ParamSpec('map_resolution', DEFAULT_RESOLUTION_M,
              'Size of a map cell, m (the planner plans on these cells)',
              value_range=(0.01, 0.5)),
    ParamSpec('odom_rate_hz', 20.0,
              'Rate of odom, /tf, robot/marker and the action feedback, Hz (wall clock)',
              value_range=(1.0, 200.0)),
    ParamSpec('time_scale', 1.0,
              'Simulated seconds per wall-clock second (1: real speed; > 1: the robot drives '
              "faster than real time, e.g. for the demo's pictures)", value_range=(0.1, 100.0)),
)


@dataclass(eq=False)
class Navigation:
    """
    One NavigateToPose goal being served.

    :ivar handle: its goal handle.
    :ivar goal: [x, y, yaw] in the map frame.
    :ivar started: when it was accepted (node clock).
    :ivar key: its tag for the planning worker.
    :ivar state: ``planning``, ``driving`` or ``stopping`` (cancelled, braking).
    """

    handle: ServerGoalHandle
    goal: np.ndarray
    started: Any
    key: int
    state: str = 'planning'


class SimRobot(Node):
    """A simulated differential-drive robot with a map, a planner and nav2's interface."""

    def __init__(self, **kwargs):
        """Create the node; ``kwargs`` go to :class:`rclpy.node.Node`."""
        super().__init__('sim_robot', **kwargs)
        self._candidate: Optional[Tuple[Tuple[str, float], Scene, Any]] = None
        self._worker = PlanWorker(name='sim_robot planner')
        self._robot = SettingsParameters(self, RobotSettings, self._on_robot_settings)
        values = declare_parameters(self, PARAMETERS, self._on_parameters,
                                    check_all=self._check_all)
        self._rate_hz = values['odom_rate_hz']
        self._time_scale = values['time_scale']
        self._map_pub = self.create_publisher(OccupancyGrid, MAP_TOPIC, MAP_QOS)
        self._odom_pub = self.create_publisher(Odometry, ODOM_TOPIC, ODOM_QOS)
        self._tf_pub = self.create_publisher(TFMessage, TF_TOPIC, TF_QOS)
        self._plan_pub = self.create_publisher(Path, PLAN_TOPIC, PLAN_QOS)
        self._marker_pub = self.create_publisher(MarkerArray, ROBOT_MARKER_TOPIC,
                                                 ROBOT_MARKER_QOS)
        self._use_map(values['scene_file'], values['map_resolution'])
        start = np.array(values['start_pose'], dtype=float)
        self.drive = Drive(self._robot.settings, start)
        self.odometry = DriftingOdometry(start)
        self._navigation: Optional[Navigation] = None
        self._keys = itertools.count(1)
        self._last_tick = time.monotonic()
        # Goals run from the timer: accepted, made EXECUTING and started in one callback,
        # ended (state and result) by _end; no coroutine waits meanwhile (runner's
        # GOAL_EXECUTE_EVENT says why).
        self._server = ActionServer(
            self, NavigateToPose, NAVIGATE_TO_POSE_ACTION,
            execute_callback=lambda _handle: NavigateToPose.Result(),  # replaced per goal
            goal_callback=lambda _goal: GoalResponse.ACCEPT,
            handle_accepted_callback=self._on_accepted,
            cancel_callback=self._on_cancel_request)
        # goal_pose becomes an action goal, as bt_navigator's own client sends it.  The client
        # is made at the first goal_pose: it takes every feedback message, a cost that an
        # action client of its own (the menu) does not need.
        self._self_client: Optional[ActionClient] = None
        self._goal_pose: Optional[PoseStamped] = None
        self.create_subscription(PoseStamped, GOAL_POSE_TOPIC, self._on_goal_pose, GOAL_QOS)
        self._timer = self.create_timer(1.0 / self._rate_hz, self._on_timer)
        self._publish_state()
        pose = self.drive.pose
        self.get_logger().info(
            f'simulated robot (radius {self._robot.settings.radius_m:g} m) at '
            f'({pose[0]:.2f}, {pose[1]:.2f}, {math.degrees(pose[2]):.0f} deg) on the map of '
            f"{self._scene.source} in '{self.frame_id}'; action {NAVIGATE_TO_POSE_ACTION}, "
            f'goals on {GOAL_POSE_TOPIC}, time x{self._time_scale:g}')

    @property
    def frame_id(self) -> str:
        """Return the map frame (the scene's ``frame_id``)."""
        return self._scene.frame_id

    def destroy_node(self):
        """End the planning thread, the action server and its own client, then the node."""
        self._worker.close()
        # rclpy's destroy_node leaves action servers and clients alive: a later graph on the
        # same domain would still see this server and its goals' latched status.
        self._server.destroy()
        if self._self_client is not None:
            self._self_client.destroy()
        return super().destroy_node()

    # -- the map -----------------------------------------------------------------------

    def _load(self, scene_file: str, resolution: float):
        """Return (scene, grid) for a scene_file value, from the check's cache when there."""
        key = (scene_file, resolution)
        if self._candidate is not None and self._candidate[0] == key:
            return self._candidate[1:]
        scene = load_scene(scene_file if scene_file.strip() else default_scene_path())
        return scene, scene_grid(scene, resolution)

    def _use_map(self, scene_file: str, resolution: float) -> None:
        self._scene, self._grid = self._load(scene_file, resolution)
        self._candidate = None
        self._planner = Planner(self._grid, self._robot.settings.radius_m)
        self._worker.warm(self._planner)
        self._publish_map()

    def _check_all(self, values: Dict[str, Any]) -> Optional[str]:
        key = (values['scene_file'], values['map_resolution'])
        try:
            scene, grid = self._load(*key)
        except ValueError as error:
            return f'scene_file: {error}'
        self._candidate = (key, scene, grid)
        x, y, _ = values['start_pose']
        if not grid.is_free(np.array([x, y]))[0]:
            return (f'start_pose: ({x:g}, {y:g}) is off the map or inside a wall or table of '
                    f'{scene.source}')
        return None

    def _publish_map(self) -> None:
        grid = self._grid
        message = OccupancyGrid()
        message.header.frame_id = self.frame_id
        message.header.stamp = self.get_clock().now().to_msg()
        message.info.map_load_time = message.header.stamp
        message.info.resolution = float(grid.resolution)
        message.info.height, message.info.width = grid.shape
        message.info.origin = arrays_to_pose([grid.origin[0], grid.origin[1], 0.0],
                                             [0.0, 0.0, 0.0, 1.0])
        message.data = array.array('b', grid.values().tobytes())
        self._map_pub.publish(message)

    # -- goals -------------------------------------------------------------------------

    def _on_goal_pose(self, message: PoseStamped) -> None:
        """Send a goal_pose as a NavigateToPose goal to this server (bt_navigator's way)."""
        if self._self_client is None:
            self._self_client = ActionClient(self, NavigateToPose, NAVIGATE_TO_POSE_ACTION)
        # Sent once the client has found the server (at once after the first goal_pose); a
        # newer goal_pose replaces one not sent yet.
        self._goal_pose = message
        self._send_goal_pose()

    def _send_goal_pose(self) -> None:
        if self._goal_pose is not None and self._self_client.server_is_ready():
            self._self_client.send_goal_async(NavigateToPose.Goal(pose=self._goal_pose))
            self._goal_pose = None

    def _on_cancel_request(self, handle: ServerGoalHandle) -> CancelResponse:
        """Accept a cancel of an active goal (nav2's SimpleActionServer does the same)."""
        return CancelResponse.ACCEPT if handle.is_active else CancelResponse.REJECT

    def _on_accepted(self, handle: ServerGoalHandle) -> None:
        """Start one goal: refuse it at once, or make it the one driven to."""
        handle._update_state(GOAL_EXECUTE_EVENT)
        goal, code, reason = self._goal_in_map(handle.request)
        if code != nav2_codes.NONE:
            # As bt_navigator: a goal it cannot take ends at once; one being driven to
            # goes on.
            self.get_logger().warning(f'goal aborted: {nav2_codes.describe(code, reason)}')
            self._finish(handle, 'abort', NavigateToPose.Result(error_code=code,
                                                                error_msg=reason))
            return
        previous = self._navigation
        if previous is not None:
            # nav2's SimpleActionServer aborts the goal it preempts, with an empty result.
            self.get_logger().info(f'goal {_pose_text(previous.goal)} preempted by a new goal')
            self._end(previous, 'abort', NavigateToPose.Result())
        navigation = Navigation(handle=handle, goal=goal, started=self.get_clock().now(),
                                key=next(self._keys))
        self._navigation = navigation
        self._worker.request(navigation.key, self._planner, self.drive.pose, goal)

    def _goal_in_map(self, request) -> Tuple[np.ndarray, int, str]:
        """Return the goal in the map frame, and nav2's code and reason when it is refused."""
        if request.behavior_tree:
            return (np.full(3, np.nan), nav2_codes.FAILED_TO_LOAD_BEHAVIOR_TREE,
                    f'Error loading: {request.behavior_tree}. Navigation canceled. '
                    '(sim_robot runs no behaviour tree: leave behavior_tree empty)')
        frame = request.pose.header.frame_id.lstrip('/')
        pose = planar_pose(request.pose.pose)
        transforms = {self.frame_id: np.zeros(3), ODOM_FRAME: self.odometry.map_to_odom(),
                      BASE_FRAME: self.drive.pose.copy()}
        if frame not in transforms:
            return (pose, nav2_codes.TF_ERROR,
                    f"Failed to transform a goal pose provided with frame_id '{frame}' to the "
                    f"global frame '{self.frame_id}' (sim_robot knows "
                    f"{', '.join(transforms)})")
        if math.isnan(pose[2]) and np.all(np.isfinite(pose[:2])):
            return (pose, nav2_codes.UNKNOWN,
                    "the goal's orientation is not a rotation (a zero or not finite "
                    'quaternion)')
        if not np.all(np.isfinite(pose[:2])):
            return (pose, nav2_codes.GOAL_OUTSIDE_MAP,
                    f'the goal ({pose[0]:.2f}, {pose[1]:.2f}) is not a finite position')
        return compose(transforms[frame], pose), nav2_codes.NONE, ''

    def _finish(self, handle: ServerGoalHandle, how: str,
                result: NavigateToPose.Result) -> None:
        """Put a goal in its final state (``how``: succeed, abort, canceled); send its result."""
        if handle.is_active:
            getattr(handle, how)()
            # rclpy answers the result request when a goal's execute callback returns: this
            # one returns the result at once.
            self._server.notify_execute(handle, lambda _handle: result)

    def _end(self, navigation: Navigation, how: str, result: NavigateToPose.Result) -> None:
        """End the goal driven to: its final state, its result, its plan request."""
        self._finish(navigation.handle, how, result)
        self._worker.withdraw(navigation.key)
        if self._navigation is navigation:
            self._navigation = None

    # -- motion ------------------------------------------------------------------------

    def _on_timer(self) -> None:
        now = time.monotonic()
        elapsed, self._last_tick = now - self._last_tick, now
        # A late tick (a loaded machine) moves the robot by what it missed, up to a second.
        self.drive.step(min(elapsed, 1.0) * self._time_scale)
        self.odometry.update(self.drive.pose)
        # One stamp for the tick: feedback, odometry and TF describe the same instant.
        stamp = self.get_clock().now()
        self._send_goal_pose()
        self._serve(stamp)
        self._publish_state(stamp.to_msg())

    def _serve(self, now) -> None:
        """Take plans, follow cancels, end the goal when it is reached or the robot stands."""
        for outcome in self._worker.take():
            navigation = self._navigation
            if navigation is None or outcome.key != navigation.key:
                continue
            if isinstance(outcome.result, NoPath):
                self.get_logger().warning(
                    f'goal {_pose_text(navigation.goal)} aborted: {outcome.result}')
                self.drive.stop()
                self._publish_plan(np.zeros((0, 3)))
                self._end(navigation, 'abort', NavigateToPose.Result(
                    error_code=outcome.result.code, error_msg=str(outcome.result)))
                return
            plan = outcome.result
            self.drive.follow(plan.points, navigation.goal[2])
            self._publish_plan(plan.poses(navigation.goal[2]))
            navigation.state = 'driving'
            self.get_logger().info(f'goal {_pose_text(navigation.goal)}: path '
                                   f'{plan.length:.2f} m')
        navigation = self._navigation
        if navigation is None:
            return
        if not navigation.handle.is_active:     # ended elsewhere (the server's clean-up)
            self._navigation = None
            return
        if navigation.handle.is_cancel_requested and navigation.state != 'stopping':
            navigation.state = 'stopping'
            self._worker.withdraw(navigation.key)
            self.drive.stop()
            self._publish_plan(np.zeros((0, 3)))
            self.get_logger().info(f'goal {_pose_text(navigation.goal)} cancelled: braking')
        if navigation.state == 'stopping' and not self.drive.moving:
            self.get_logger().info('cancelled goal: the robot stands')
            self._end(navigation, 'canceled', NavigateToPose.Result())
            return
        if (navigation.state == 'driving' and self.drive.mode is Mode.IDLE
                and self.drive.arrived and not self.drive.moving):
            s = self._robot.settings
            distance = pose_error(self.drive.pose, navigation.goal)
            heading = heading_error(self.drive.pose, navigation.goal)
            if distance <= s.goal_tolerance_m and heading <= s.goal_tolerance_rad:
                self.get_logger().info(
                    f'arrived at {_pose_text(navigation.goal)}: {distance:.3f} m, '
                    f'{math.degrees(heading):.1f} deg off')
                self._end(navigation, 'succeed', NavigateToPose.Result())
                return
        if navigation.state != 'planning':
            self._publish_feedback(navigation, now)

    def _publish_feedback(self, navigation: Navigation, now) -> None:
        """Feedback once there is a plan: its distance left, as bt_navigator measures it."""
        distance = self.drive.distance_left() if navigation.state == 'driving' else (
            pose_error(self.drive.pose, navigation.goal))
        speed = abs(self.drive.v)
        remaining = (distance / speed if speed > ETA_MIN_SPEED and distance > ETA_MIN_DISTANCE_M
                     else 0.0)
        feedback = NavigateToPose.Feedback(
            current_pose=pose_stamped(self.drive.pose, self.frame_id, now.to_msg()),
            navigation_time=(now - navigation.started).to_msg(),
            estimated_time_remaining=Duration(seconds=remaining / self._time_scale).to_msg(),
            number_of_recoveries=0, distance_remaining=float(distance))
        navigation.handle.publish_feedback(feedback)

    def _publish_state(self, stamp=None) -> None:
        stamp = stamp or self.get_clock().now().to_msg()
        v, w = self.odometry.twist(self.drive.v, self.drive.w)
        odom = Odometry()
        odom.header.stamp = stamp
        odom.header.frame_id = ODOM_FRAME
        odom.child_frame_id = BASE_FRAME
        odom.pose.pose = pose_message(self.odometry.pose)
        odom.twist.twist.linear.x = v
        odom.twist.twist.angular.z = w
        self._odom_pub.publish(odom)
        self._tf_pub.publish(TFMessage(transforms=[
            transform_stamped(self.frame_id, ODOM_FRAME, self.odometry.map_to_odom(), stamp),
            transform_stamped(ODOM_FRAME, BASE_FRAME, self.odometry.pose, stamp)]))
        self._marker_pub.publish(self._markers(stamp))

    def _markers(self, stamp) -> MarkerArray:
        """Return the robot drawn in ``base_link``: RViz puts it where TF says it is."""
        radius = self._robot.settings.radius_m
        body = Marker(ns='robot', id=0, type=Marker.CYLINDER, action=Marker.ADD)
        body.pose = arrays_to_pose([0.0, 0.0, BODY_HEIGHT_M / 2], [0.0, 0.0, 0.0, 1.0])
        body.scale.x = body.scale.y = 2 * radius
        body.scale.z = BODY_HEIGHT_M
        body.color = ColorRGBA(r=0.2, g=0.2, b=0.25, a=0.9)
        heading = Marker(ns='robot', id=1, type=Marker.ARROW, action=Marker.ADD)
        heading.pose = arrays_to_pose([0.0, 0.0, BODY_HEIGHT_M + 0.02], [0.0, 0.0, 0.0, 1.0])
        heading.scale.x, heading.scale.y, heading.scale.z = 1.2 * radius, 0.08, 0.08
        heading.color = ColorRGBA(r=1.0, g=0.9, b=0.1, a=1.0)
        footprint = Marker(ns='robot', id=2, type=Marker.LINE_STRIP, action=Marker.ADD)
        footprint.pose = arrays_to_pose([0.0, 0.0, 0.01], [0.0, 0.0, 0.0, 1.0])
        footprint.scale.x = 0.03
        footprint.color = ColorRGBA(r=1.0, g=0.3, b=0.1, a=1.0)
        footprint.points = [Point(x=radius * math.cos(a), y=radius * math.sin(a))
                            for a in np.linspace(0.0, 2 * math.pi, 33)]
        markers = MarkerArray(markers=[body, heading, footprint])
        for marker in markers.markers:
            marker.header.stamp = stamp
            marker.header.frame_id = BASE_FRAME
            # A newer message replaces it; the frame's latest transform draws it.
            marker.frame_locked = True
        return markers

    def _publish_plan(self, poses: np.ndarray) -> None:
        self._plan_pub.publish(path_message(poses, self.frame_id,
                                            self.get_clock().now().to_msg()))

    # -- parameters --------------------------------------------------------------------

    def _on_robot_settings(self, settings: RobotSettings, changed: Dict[str, Any]) -> None:
        self.drive.settings = settings
        if 'radius_m' in changed:
            self._planner = Planner(self._grid, settings.radius_m)
            self._worker.warm(self._planner)

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        if 'time_scale' in changed:
            self._time_scale = changed['time_scale']
        if 'odom_rate_hz' in changed:
            self._rate_hz = changed['odom_rate_hz']
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / self._rate_hz, self._on_timer)
        if {'scene_file', 'map_resolution'} & changed.keys():
            self._use_map(self.get_parameter('scene_file').value,
                          self.get_parameter('map_resolution').value)
            self._stand(self.drive.pose)
        if 'start_pose' in changed:
            self._stand(np.array(changed['start_pose'], dtype=float))

    def _stand(self, pose: np.ndarray) -> None:
        """Put the robot at ``pose``, standing, its goal aborted (a teleport, as a simulator)."""
        if self._navigation is not None:
            self._end(self._navigation, 'abort', NavigateToPose.Result(
                error_code=nav2_codes.UNKNOWN,
                error_msg='the simulated robot was moved or its map changed'))
        self.drive = Drive(self._robot.settings, pose)
        self.odometry.relocate(pose)
        self._publish_plan(np.zeros((0, 3)))
        self._publish_state()


def _pose_text(pose: np.ndarray) -> str:
    return f'({pose[0]:.2f}, {pose[1]:.2f}, {math.degrees(pose[2]):.0f} deg)'


def main(args=None):
    """Run the simulated robot."""
    spin_node(SimRobot, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
