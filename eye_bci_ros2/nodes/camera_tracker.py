"""
camera_tracker: publish where the RViz camera is, in the optical convention.

Subscribes ``rviz/current_camera_pose`` (geometry_msgs/Pose in the Ogre camera
convention: forward = -Z, up = +Y, as RViz animated view controllers publish
it whenever the view moves) and publishes ``camera/pose``
(geometry_msgs/PoseStamped, optical convention: z forward, y down; frame
``world_frame``; latched).

Until the first live pose arrives it publishes the static view given by the
``eye``, ``focus`` and ``up`` parameters (the original system's fixed RViz
view).  Once a live pose has arrived, it wins: RViz publishes only when the
view moves, so a static view set later would contradict what the screen shows;
changing ``eye``/``focus``/``up`` then only updates the stored fallback.
"""

from typing import Any, Dict, List, Optional, Tuple

from geometry_msgs.msg import Pose, PoseStamped
import numpy as np
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from eye_bci_ros2.camera_model import look_at_pose, optical_pose_from_ogre
from eye_bci_ros2.nodes.conversions import arrays_to_pose, pose_to_arrays
from eye_bci_ros2.nodes.parameters import check_frame_id, check_vector3
from eye_bci_ros2.nodes.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.nodes.runner import spin_node
from eye_bci_ros2.nodes.topics import LATCHED_QOS

#: What RViz view-controller ports publish with: reliable, volatile, depth 10.
RVIZ_POSE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=10,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: Default static view: the overview of the default scene (config/scene.yaml,
#: a 20 m x 12 m map), from 17 m up and 8 m south of the map centre (10, 6, 0),
#: looking at it (65 degrees below the horizon); the same as sim_rviz_view's
#: initial view, so start-up order does not matter in the demo.
DEFAULT_EYE = [10.0, -2.0, 17.0]
DEFAULT_FOCUS = [10.0, 6.0, 0.0]
DEFAULT_UP = [0.0, 0.0, 1.0]


def _view_problem(values: Dict[str, Any]) -> Optional[str]:
    """Reject an eye/focus/up combination that defines no camera."""
    try:
        look_at_pose(values['eye'], values['focus'], values['up'])
    except ValueError as error:
        return f'eye/focus/up: {error}'
    return None


PARAMETERS: List[ParamSpec] = [
    ParamSpec('world_frame', 'map',
              'Frame of camera/pose: the RViz fixed frame the markers are in.',
              check=check_frame_id),
    ParamSpec('eye', DEFAULT_EYE,
              'Static view: camera position (x, y, z) in world_frame, m. Used until '
              'the first rviz/current_camera_pose arrives.',
              check=check_vector3, array_type='double_array'),
    ParamSpec('focus', DEFAULT_FOCUS,
              'Static view: point the camera looks at (x, y, z) in world_frame, m.',
              check=check_vector3, array_type='double_array'),
    ParamSpec('up', DEFAULT_UP,
              'Static view: world direction that appears up on the screen; not '
              'parallel to focus - eye.',
              check=check_vector3, array_type='double_array'),
]


class CameraTracker(Node):
    """Turn the RViz camera pose into an optical ``camera/pose`` (latched)."""

    def __init__(self, **kwargs):
        """Declare parameters, publish the static view, listen for RViz."""
        super().__init__('camera_tracker', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._on_parameters,
                                          check_all=_view_problem)
        self._live = False
        self._pose: Tuple[np.ndarray, np.ndarray] = self._static_pose()
        self._publisher = self.create_publisher(PoseStamped, 'camera/pose', LATCHED_QOS)
        self.create_subscription(Pose, 'rviz/current_camera_pose', self._on_rviz_pose,
                                 RVIZ_POSE_QOS)
        self._publish()
        self.get_logger().info(
            f'publishing the static view (eye {self._params["eye"]}, focus '
            f'{self._params["focus"]}, up {self._params["up"]}) in '
            f"'{self._params['world_frame']}' until rviz/current_camera_pose arrives")

    def _static_pose(self) -> Tuple[np.ndarray, np.ndarray]:
        return look_at_pose(self._params['eye'], self._params['focus'], self._params['up'])

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        self._params.update(changed)
        if changed.keys() & {'eye', 'focus', 'up'}:
            if self._live:
                self.get_logger().info(
                    'static view updated, but a live RViz camera pose is in use: '
                    'camera/pose keeps following RViz')
            else:
                self._pose = self._static_pose()
        if not self._live or 'world_frame' in changed:
            self._publish()

    def _on_rviz_pose(self, message: Pose) -> None:
        try:
            position, quaternion = optical_pose_from_ogre(*pose_to_arrays(message))
        except ValueError as error:
            self.get_logger().warning(
                f'ignoring rviz/current_camera_pose: {error}; keeping the last good pose',
                throttle_duration_sec=5.0)
            return
        if not self._live:
            self.get_logger().info('live RViz camera pose received: following it')
        self._live = True
        self._pose = (position, quaternion)
        self._publish()

    def _publish(self) -> None:
        message = PoseStamped()
        message.header.frame_id = self._params['world_frame']
        message.header.stamp = self.get_clock().now().to_msg()
        message.pose = arrays_to_pose(*self._pose)
        self._publisher.publish(message)


def main(args=None):
    """Run the camera_tracker node."""
    spin_node(lambda: CameraTracker(), args)


if __name__ == '__main__':
    main()
