"""
view_animated_bridge: move the real RViz2 camera to each ``camera/goal``.

Subscribes ``camera/goal`` (geometry_msgs/PoseStamped, optical camera pose in
``world_frame``, latched: what choice_menu publishes) and publishes, for each
goal, a one-movement ``rviz_plugin_view_animated_msgs/ViewTrajectory`` on
``trajectory_topic``: the topic the Jazzy port of the animated view controller
(``rviz_plugin_view_animated``, weraleiso/ias_rviz_plugins) listens on,
``rviz_plugin_view_animated_<N>/trajectory``.  The port animates from the
current view to the movement's eye/focus/up (ORBIT mode) in
``transition_time_s``; see ``cb_sub_vtr_view_trajectory`` and ``update`` in its
rviz_plugin_view_animated/source/rviz_plugin_view_animated.cpp.

A movement also sets the port's properties (``UpdateViewPose``): this bridge
keeps "Pose Publish Enabled" and mouse control on, so camera_tracker keeps
following the camera while it moves.

The message package is not part of ROS 2 Jazzy's binaries: on a ROS machine build
``rviz_plugin_view_animated_msgs`` with colcon in a workspace (docs/hardware.md,
"The camera in Jazzy") and source it first; without it the node refuses to start with that
reason.  The PyPI set-up (``make``) builds it into the venv (``interfaces/``).
"""

import importlib
from typing import Any, Dict, List

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from eye_bci_ros2.projection.geometry import WORLD_FRAME
from eye_bci_ros2.projection.view_animation import view_from_optical_pose
from eye_bci_ros2.ros.conversions import pose_to_arrays
from eye_bci_ros2.ros.log_throttle import WARN_PERIOD_S
from eye_bci_ros2.ros.parameters import check_frame_id, declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.topics import CAMERA_GOAL_TOPIC, LATCHED_QOS

#: The port's speed profiles (ViewMovement.msg constants), by name.
SPEED_PROFILES = ('DECLINING', 'RISING', 'WAVE', 'FULL', 'QUADRATIC', 'EXPONENTIAL')

#: Where the first instance of the port listens (it subscribes with depth 1, reliable).
DEFAULT_TRAJECTORY_TOPIC = '/rviz_plugin_view_animated_1/trajectory'

TRAJECTORY_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=10,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

PARAMETERS: List[ParamSpec] = [
    ParamSpec('world_frame', WORLD_FRAME,
              "RViz's fixed frame: goals must be in it (no tf2 here).", check=check_frame_id),
    ParamSpec('trajectory_topic', DEFAULT_TRAJECTORY_TOPIC,
              'ViewTrajectory topic of rviz_plugin_view_animated (N = its instance, from 1).',
              read_only=True),
    ParamSpec('transition_time_s', 2.0, 'Duration of each camera move, s (the port: >= 0.1).',
              value_range=(0.1, 60.0)),
    ParamSpec('speed_profile', 'WAVE', 'Speed profile of each move.', choices=SPEED_PROFILES),
    ParamSpec('target_fps', 20.0, "The port's frame rate property during a move.",
              value_range=(1.0, 240.0)),
    ParamSpec('fallback_distance_m', 10.0,
              'Orbit focus distance when the view ray misses the floor z = 0, m.',
              value_range=(0.01, 1000.0)),
]


def load_messages():
    """
    Import the port's message classes.

    :returns: ``(ViewTrajectory, ViewMovement)``.
    :raises ValueError: the package is not installed (with what to do).
    """
    try:
        module = importlib.import_module('rviz_plugin_view_animated_msgs.msg')
    except ImportError as error:
        raise ValueError(
            f'rviz_plugin_view_animated_msgs is not available ({error}): build it with '
            'colcon in a workspace and source its install/setup.bash (docs/hardware.md, '
            '"The camera in Jazzy")') from None
    return module.ViewTrajectory, module.ViewMovement


class ViewAnimatedBridge(Node):
    """Turn each ``camera/goal`` into a ViewTrajectory for rviz_plugin_view_animated."""

    def __init__(self, **kwargs):
        """Check the message package, declare parameters, subscribe to goals."""
        super().__init__('view_animated_bridge', **kwargs)
        self._trajectory_type, self._movement_type = load_messages()
        self._params = declare_parameters(self, PARAMETERS, self._params_changed)
        self._publisher = self.create_publisher(
            self._trajectory_type, self._params['trajectory_topic'], TRAJECTORY_QOS)
        self.create_subscription(PoseStamped, CAMERA_GOAL_TOPIC, self._on_goal, LATCHED_QOS)
        self.get_logger().info(f"moving the RViz camera on {self._params['trajectory_topic']} "
                               f"for each camera/goal in '{self._params['world_frame']}'")

    def _params_changed(self, changed: Dict[str, Any]) -> None:
        self._params.update(changed)

    def movement(self, eye, focus, up):
        """Build the ViewMovement to (eye, focus, up), world frame, with this node's settings."""
        frame = self._params['world_frame']
        movement = self._movement_type()
        movement.view_tf_frame = frame
        movement.view_mode = self._movement_type.ORBIT
        movement.view_speed_profile = SPEED_PROFILES.index(self._params['speed_profile'])
        movement.view_duration.data = float(self._params['transition_time_s'])
        movement.view_target_fps.data = float(self._params['target_fps'])
        movement.view_frame_by_frame_enabled = False
        movement.view_vector_up_lock_enabled = True
        movement.view_pose_enabled = True      # camera_tracker keeps following the move
        movement.view_live_enabled = False
        movement.view_mouse_enabled = True
        for stamped, value in ((movement.view_eye, eye), (movement.view_focus, focus)):
            stamped.header.frame_id = frame
            stamped.point.x, stamped.point.y, stamped.point.z = (float(v) for v in value)
        movement.view_up.header.frame_id = frame
        (movement.view_up.vector.x, movement.view_up.vector.y,
         movement.view_up.vector.z) = (float(v) for v in up)
        return movement

    def _on_goal(self, message: PoseStamped) -> None:
        frame = message.header.frame_id or self._params['world_frame']
        if frame != self._params['world_frame']:
            self.get_logger().warning(
                f"ignoring camera/goal in frame '{frame}': expected "
                f"'{self._params['world_frame']}' (no tf2 here)",
                throttle_duration_sec=WARN_PERIOD_S)
            return
        try:
            eye, focus, up = view_from_optical_pose(
                *pose_to_arrays(message.pose), self._params['fallback_distance_m'])
        except ValueError as error:
            self.get_logger().warning(f'ignoring camera/goal: {error}',
                                      throttle_duration_sec=WARN_PERIOD_S)
            return
        self._publisher.publish(self._trajectory_type(
            view_trajectory=[self.movement(eye, focus, up)]))


def main(args=None):
    """Run the view_animated_bridge node."""
    spin_node(ViewAnimatedBridge, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
