"""
Simulated robot: a stand-in for nav2 + a (Gazebo) robot, on the scene's floor plan.

What nav2 and a robot give the rest of the system, this node gives from the
scene file (RViz, a robot and nav2 cannot run here; this is the mock, as
sim_gaze is for the tracker): the map, a plan to a goal and a robot that
drives it (:mod:`eye_bci_ros2.navigation`).

Topics (names and QoS: :mod:`eye_bci_ros2.ros.topics`):

* publishes ``map`` nav_msgs/OccupancyGrid (walls, doors and tables of
  ``scene_file``; 0 free / 100 occupied; transient local, as map_server);
* subscribes ``goal_pose`` geometry_msgs/PoseStamped (the goal in the map
  frame, the scene's ``frame_id``; an empty frame_id means that frame);
* publishes ``odom`` nav_msgs/Odometry at ``odom_rate_hz`` (pose in the map
  frame, child frame ``base_link``, twist in ``base_link``), ``plan``
  nav_msgs/Path (the path to the goal; empty after a stop) and ``robot/marker``
  visualization_msgs/MarkerArray (the robot: body, heading and footprint).

A goal replaces the one being driven to.  A goal at a pose the robot was at in
the last :data:`STOP_MEMORY_S` s (within ``goal_tolerance_m`` and
``goal_tolerance_deg``: what a stop sends, the pose from ``odom``, and what nav2
users send) stops it: it brakes at ``linear_accel``/``angular_accel`` and
stands.  A goal it cannot reach (off the map, in a wall or table, too close to
one for its radius, not reachable, not finite, in another frame: no tf here) is
refused with one log line saying why, and the robot goes on as before.

Time: the robot moves ``time_scale`` simulated seconds per wall-clock second
(a demo may run it faster than real time); odometry stamps are the node's
clock.
"""

import array
import math
import time
from typing import Any, Dict, Optional, Tuple

from geometry_msgs.msg import Point, PoseStamped
from nav_msgs.msg import OccupancyGrid, Odometry, Path
import numpy as np
from rclpy.node import Node
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.navigation.drive import Drive, heading_error, Mode, pose_error
from eye_bci_ros2.navigation.occupancy import DEFAULT_RESOLUTION_M, scene_grid, yaw_of
from eye_bci_ros2.navigation.planner import NoPath, Planner
from eye_bci_ros2.navigation.robot_settings import RobotSettings
from eye_bci_ros2.ros.conversions import arrays_to_pose, pose_to_arrays
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec, SettingsParameters
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.topics import (
    GOAL_POSE_TOPIC, GOAL_QOS, MAP_QOS, MAP_TOPIC, ODOM_QOS, ODOM_TOPIC, PLAN_QOS, PLAN_TOPIC,
    ROBOT_MARKER_QOS, ROBOT_MARKER_TOPIC)
from eye_bci_ros2.task.scene import load_scene, Scene

#: The robot's own frame (REP 105), the odometry's child frame.
BASE_FRAME = 'base_link'
#: A goal at a pose the robot was at this long ago or less is a stop, s of wall time: the
#: menu sends the pose it last read from ``odom``, which the robot has left since.
STOP_MEMORY_S = 1.0
#: Default start: in the bedroom, facing east (config/scene.yaml).
DEFAULT_START_POSE = (5.0, 5.0, 0.0)
#: Drawn height of the robot's body, m.
BODY_HEIGHT_M = 0.4


def _check_pose(value: Any) -> Optional[str]:
    if value is None or len(value) != 3 or not all(math.isfinite(v) for v in value):
        return f'needs 3 finite numbers (x m, y m, yaw rad), got {list(value or [])!r}'
    return None


PARAMETERS = (
    ParamSpec('scene_file', '',
              'Scene YAML whose floor_plan and tables make the map (empty = the installed '
              'config/scene.yaml); setting it rebuilds the map and stops the robot'),
    ParamSpec('start_pose', list(DEFAULT_START_POSE),
              "The robot's pose at start-up [x m, y m, yaw rad] in the map frame, on a free "
              'place; setting it puts the robot there, standing', check=_check_pose,
              array_type='double_array'),
    ParamSpec('map_resolution', DEFAULT_RESOLUTION_M,
              'Size of a map cell, m (the planner plans on these cells)',
              value_range=(0.01, 0.5)),
    ParamSpec('odom_rate_hz', 20.0, 'Rate of odom and robot/marker, Hz (wall clock)',
              value_range=(1.0, 200.0)),
    ParamSpec('time_scale', 1.0,
              'Simulated seconds per wall-clock second (> 1: the robot drives faster than '
              'real time, e.g. for a quick demo)', value_range=(0.1, 100.0)),
)


class SimRobot(Node):
    """A simulated differential-drive robot with a map and a planner: nav2's topics."""

    def __init__(self, **kwargs):
        """Create the node; ``kwargs`` go to :class:`rclpy.node.Node`."""
        super().__init__('sim_robot', **kwargs)
        self._candidate: Optional[Tuple[Tuple[str, float], Scene, Any]] = None
        self._robot = SettingsParameters(self, RobotSettings, self._on_robot_settings)
        values = declare_parameters(self, PARAMETERS, self._on_parameters,
                                    check_all=self._check_all)
        self._rate_hz = values['odom_rate_hz']
        self._time_scale = values['time_scale']
        self._map_pub = self.create_publisher(OccupancyGrid, MAP_TOPIC, MAP_QOS)
        self._odom_pub = self.create_publisher(Odometry, ODOM_TOPIC, ODOM_QOS)
        self._plan_pub = self.create_publisher(Path, PLAN_TOPIC, PLAN_QOS)
        self._marker_pub = self.create_publisher(MarkerArray, ROBOT_MARKER_TOPIC,
                                                 ROBOT_MARKER_QOS)
        self._use_map(values['scene_file'], values['map_resolution'])
        self.drive = Drive(self._robot.settings, np.array(values['start_pose']))
        # (wall time, pose) of recent odometry: a goal at one of these poses is a stop.
        self._recent = []
        self._last_tick = time.monotonic()
        self._goal: Optional[np.ndarray] = None
        self.create_subscription(PoseStamped, GOAL_POSE_TOPIC, self._on_goal, GOAL_QOS)
        self._timer = self.create_timer(1.0 / self._rate_hz, self._on_timer)
        self._publish_state()
        pose = self.drive.pose
        self.get_logger().info(
            f'simulated robot (radius {self._robot.settings.radius_m:g} m) at '
            f'({pose[0]:.2f}, {pose[1]:.2f}, {math.degrees(pose[2]):.0f} deg) on the map of '
            f"{self._scene.source} in '{self.frame_id}'; goals on {GOAL_POSE_TOPIC}, "
            f'time x{self._time_scale:g}')

    @property
    def frame_id(self) -> str:
        """Return the map frame (the scene's ``frame_id``)."""
        return self._scene.frame_id

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

    def _on_goal(self, message: PoseStamped) -> None:
        position, quaternion = pose_to_arrays(message.pose)
        goal = np.array([position[0], position[1], np.nan])
        if np.all(np.isfinite(quaternion)) and np.linalg.norm(quaternion) > 1e-9:
            goal[2] = yaw_of(quaternion / np.linalg.norm(quaternion))
        frame = message.header.frame_id
        if frame and frame != self.frame_id:
            self._refuse(goal, f"it is in frame '{frame}', the map is '{self.frame_id}' "
                         '(no tf here)')
            return
        if not np.all(np.isfinite(goal)):
            self._refuse(goal, 'it is not a finite pose (x, y and a non-zero quaternion)')
            return
        if self._is_stop(goal):
            self.drive.stop()
            self._goal = None
            self._publish_plan(np.zeros((0, 2)))
            self.get_logger().info('stop: the goal is where the robot is; braking')
            return
        try:
            plan = self._planner.plan(self.drive.pose[:2], goal[:2])
        except NoPath as error:
            self._refuse(goal, str(error))
            return
        self._goal = goal
        self.drive.follow(plan.points, goal[2])
        self._publish_plan(plan.points)
        self.get_logger().info(f'goal {_pose_text(goal)}: path {plan.length:.2f} m')

    def _is_stop(self, goal: np.ndarray) -> bool:
        s = self._robot.settings
        return any(pose_error(pose, goal) <= s.goal_tolerance_m
                   and heading_error(pose, goal) <= s.goal_tolerance_rad
                   for _, pose in self._recent + [(None, self.drive.pose)])

    def _refuse(self, goal: np.ndarray, reason: str) -> None:
        self.get_logger().warning(f'refused goal {_pose_text(goal)}: {reason}; the robot goes '
                                  'on as before')

    # -- motion ------------------------------------------------------------------------

    def _on_timer(self) -> None:
        now = time.monotonic()
        elapsed, self._last_tick = now - self._last_tick, now
        was_driving = self.drive.mode is not Mode.IDLE
        # A late tick (a loaded machine) moves the robot by what it missed, up to a second.
        self.drive.step(min(elapsed, 1.0) * self._time_scale)
        if was_driving and self.drive.mode is Mode.IDLE and self.drive.arrived:
            goal = self._goal
            self.get_logger().info(
                f'arrived at {_pose_text(goal)}: {pose_error(self.drive.pose, goal):.3f} m, '
                f'{math.degrees(heading_error(self.drive.pose, goal)):.1f} deg off')
        self._recent = [(t, p) for t, p in self._recent if now - t <= STOP_MEMORY_S]
        self._recent.append((now, self.drive.pose.copy()))
        self._publish_state()

    def _publish_state(self) -> None:
        stamp = self.get_clock().now().to_msg()
        x, y, yaw = self.drive.pose
        quaternion = [0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)]
        odom = Odometry()
        odom.header.stamp = stamp
        odom.header.frame_id = self.frame_id
        odom.child_frame_id = BASE_FRAME
        odom.pose.pose = arrays_to_pose([x, y, 0.0], quaternion)
        odom.twist.twist.linear.x = float(self.drive.v)
        odom.twist.twist.angular.z = float(self.drive.w)
        self._odom_pub.publish(odom)
        self._marker_pub.publish(self._markers(stamp, x, y, quaternion))

    def _markers(self, stamp, x: float, y: float, quaternion) -> MarkerArray:
        radius = self._robot.settings.radius_m
        body = Marker(ns='robot', id=0, type=Marker.CYLINDER, action=Marker.ADD)
        body.pose = arrays_to_pose([x, y, BODY_HEIGHT_M / 2], quaternion)
        body.scale.x = body.scale.y = 2 * radius
        body.scale.z = BODY_HEIGHT_M
        body.color = ColorRGBA(r=0.2, g=0.2, b=0.25, a=0.9)
        heading = Marker(ns='robot', id=1, type=Marker.ARROW, action=Marker.ADD)
        heading.pose = arrays_to_pose([x, y, BODY_HEIGHT_M + 0.02], quaternion)
        heading.scale.x, heading.scale.y, heading.scale.z = 1.2 * radius, 0.08, 0.08
        heading.color = ColorRGBA(r=1.0, g=0.9, b=0.1, a=1.0)
        footprint = Marker(ns='robot', id=2, type=Marker.LINE_STRIP, action=Marker.ADD)
        footprint.pose = arrays_to_pose([x, y, 0.01], [0.0, 0.0, 0.0, 1.0])
        footprint.scale.x = 0.03
        footprint.color = ColorRGBA(r=1.0, g=0.3, b=0.1, a=1.0)
        footprint.points = [Point(x=radius * math.cos(a), y=radius * math.sin(a))
                            for a in np.linspace(0.0, 2 * math.pi, 33)]
        markers = MarkerArray(markers=[body, heading, footprint])
        for marker in markers.markers:
            marker.header.stamp = stamp
            marker.header.frame_id = self.frame_id
        return markers

    def _publish_plan(self, points: np.ndarray) -> None:
        path = Path()
        path.header.stamp = self.get_clock().now().to_msg()
        path.header.frame_id = self.frame_id
        for (x, y) in points:
            pose = PoseStamped()
            pose.header = path.header
            pose.pose.position.x, pose.pose.position.y = float(x), float(y)
            pose.pose.orientation.w = 1.0
            path.poses.append(pose)
        self._plan_pub.publish(path)

    # -- parameters --------------------------------------------------------------------

    def _on_robot_settings(self, settings: RobotSettings, changed: Dict[str, Any]) -> None:
        self.drive.settings = settings
        if 'radius_m' in changed:
            self._planner = Planner(self._grid, settings.radius_m)

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
        """Put the robot at ``pose``, standing, with no goal (a teleport, as in a simulator)."""
        self.drive = Drive(self._robot.settings, pose)
        self._goal = None
        self._recent = []
        self._publish_plan(np.zeros((0, 2)))
        self._publish_state()


def _pose_text(pose: np.ndarray) -> str:
    return f'({pose[0]:.2f}, {pose[1]:.2f}, {math.degrees(pose[2]):.0f} deg)'


def main(args=None):
    """Run the simulated robot."""
    spin_node(SimRobot, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
