"""
camera_tracker: publish where the RViz camera is, in the optical convention.

Subscribes ``pose_topic`` and publishes ``camera/pose`` (geometry_msgs/PoseStamped,
optical convention: z forward, y down; frame ``world_frame``; latched).

RViz2 itself publishes no camera pose; a view controller plugin does:

* the Jazzy port of the animated view controller (``rviz_plugin_view_animated``,
  weraleiso/ias_rviz_plugins) publishes geometry_msgs/PoseStamped on
  ``rviz_plugin_view_animated_<N>/pose`` (N counts the controller instances RViz
  created, from 1), frame_id = RViz's fixed frame, x forward, z up
  (``pose_convention: x_forward``), only while its "Pose Publish Enabled"
  property is on;
* the ROS 1 ``rviz_animated_view_controller`` (and this package's simulated
  RViz) publish geometry_msgs/Pose on ``rviz/current_camera_pose`` in the Ogre
  convention (forward -Z, up +Y; ``pose_convention: ogre``), the default.

The message type is taken from the graph: until a publisher of ``pose_topic``
appears the node polls the graph, then subscribes with that publisher's type
(Pose or PoseStamped).  A PoseStamped in another frame than ``world_frame`` is
refused with a reason (there is no tf2 here).

Until the first live pose arrives it publishes the static view: the
``eye``/``focus``/``up`` parameters, or the current view of the ``rviz_config``
file (see :func:`static_view`).  Once a live pose has arrived, it wins: RViz
publishes only when the view moves, so a static view set later would contradict
what the screen shows; changing ``eye``/``focus``/``up`` then only updates the
stored fallback.
"""

from typing import Any, Dict, List, Optional, Tuple

from geometry_msgs.msg import Pose, PoseStamped
import numpy as np
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.validate_topic_name import validate_topic_name

from eye_bci_ros2.projection.camera_model import look_at_pose, optical_pose_from, POSE_CONVENTIONS
from eye_bci_ros2.projection.geometry import WORLD_FRAME
from eye_bci_ros2.ros.conversions import arrays_to_pose, pose_to_arrays
from eye_bci_ros2.ros.log_throttle import WARN_PERIOD_S
from eye_bci_ros2.ros.parameters import check_frame_id, check_vector3
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.rviz_file import at_default, rviz_config_spec, rviz_view
from eye_bci_ros2.ros.topics import (CAMERA_POSE_TOPIC, LATCHED_QOS, RVIZ_CAMERA_POSE_TOPIC,
                                     RVIZ_POSE_QOS)

#: Default static view: the overview of the default scene (config/scene.yaml,
#: a 20 m x 12 m map), from 17 m up and 8 m south of the map centre (10, 6, 0),
#: looking at it (65 degrees below the horizon); the same as sim_rviz_view's
#: initial view, so start-up order does not matter in the demo.
DEFAULT_EYE = [10.0, -2.0, 17.0]
DEFAULT_FOCUS = [10.0, 6.0, 0.0]
DEFAULT_UP = [0.0, 0.0, 1.0]

#: Pose topic of the first instance of the Jazzy port (PoseStamped, x forward).
PORT_POSE_TOPIC = 'rviz_plugin_view_animated_1/pose'

#: Message types camera_tracker reads, by their graph names.
POSE_TYPES = {'geometry_msgs/msg/Pose': Pose, 'geometry_msgs/msg/PoseStamped': PoseStamped}

#: How often the graph is polled for the pose topic's type, s: until a
#: publisher is found, then (to follow a publisher that changes type).
DISCOVERY_PERIOD_S = 0.2
WATCH_PERIOD_S = 1.0


def static_view(values: Dict[str, Any]) -> Tuple[List[float], List[float], List[float], str]:
    """
    Return the static view camera_tracker publishes until a live pose arrives.

    Precedence: ``eye``/``focus``/``up`` are one group.  If any of them differs
    from its built-in default (set on the command line, in a params file or by
    ``ros2 param set``), the three parameters are the view.  Otherwise, if
    ``rviz_config`` names a file, its current view is the view.  Otherwise the
    built-in default view (see :mod:`eye_bci_ros2.ros.rviz_file`).

    :param values: the node's parameter values.
    :returns: ``(eye, focus, up, source)`` where source says where it came from.
    :raises ValueError: an unreadable or unusable ``rviz_config`` (see
        :func:`eye_bci_ros2.projection.rviz_config.read_rviz_config`), or one whose fixed
        frame is not ``world_frame``.
    """
    view = rviz_view(values)
    if view is None or not at_default(values, PARAMETERS, 'eye', 'focus', 'up'):
        return values['eye'], values['focus'], values['up'], 'parameters eye/focus/up'
    return (view.eye.tolist(), view.focus.tolist(), view.up.tolist(),
            f"rviz_config ({view.controller.split('/')[-1]} view)")


def _view_problem(values: Dict[str, Any]) -> Optional[str]:
    """Reject an eye/focus/up combination (or rviz_config) that defines no camera."""
    try:
        eye, focus, up, source = static_view(values)
    except ValueError as error:
        return str(error)
    try:
        look_at_pose(eye, focus, up)
    except ValueError as error:
        return f'eye/focus/up: {error}'
    return None


def _check_topic(value: Any) -> Optional[str]:
    try:
        validate_topic_name(str(value))
    except Exception as error:  # rclpy raises its own InvalidTopicNameException
        return f"'{value}' is not a valid topic name: {' '.join(str(error).split())}"
    return None


PARAMETERS: List[ParamSpec] = [
    ParamSpec('world_frame', WORLD_FRAME,
              'Frame of camera/pose: the RViz fixed frame the markers are in.',
              check=check_frame_id),
    ParamSpec('pose_topic', RVIZ_CAMERA_POSE_TOPIC,
              'Where the RViz camera pose comes from (Pose or PoseStamped, type taken from '
              f'the graph): {RVIZ_CAMERA_POSE_TOPIC} (ROS 1 controller, simulated RViz) or '
              '/rviz_plugin_view_animated_<N>/pose (Jazzy rviz_plugin_view_animated; N counts '
              'its instances from 1).',
              check=_check_topic),
    ParamSpec('pose_convention', 'ogre',
              'Camera axes of the incoming pose: ogre (forward -Z, up +Y), x_forward (x = view '
              'direction, z = up: rviz_plugin_view_animated) or optical (z forward, y down).',
              choices=POSE_CONVENTIONS),
    ParamSpec('eye', DEFAULT_EYE,
              'Static view: camera position (x, y, z) in world_frame, m. Used until '
              'the first live pose arrives; any of eye/focus/up off its default wins over '
              'rviz_config.',
              check=check_vector3, array_type='double_array'),
    ParamSpec('focus', DEFAULT_FOCUS,
              'Static view: point the camera looks at (x, y, z) in world_frame, m.',
              check=check_vector3, array_type='double_array'),
    ParamSpec('up', DEFAULT_UP,
              'Static view: world direction that appears up on the screen; not '
              'parallel to focus - eye.',
              check=check_vector3, array_type='double_array'),
    rviz_config_spec('its current view is the static view while eye, focus and up are all at '
                     'their defaults'),
]


class CameraTracker(Node):
    """Turn the RViz camera pose into an optical ``camera/pose`` (latched)."""

    def __init__(self, **kwargs):
        """Declare parameters, publish the static view, look for the pose publisher."""
        super().__init__('camera_tracker', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._on_parameters,
                                          check_all=_view_problem)
        self._live = False
        self._pose: Tuple[np.ndarray, np.ndarray] = self._static_pose()
        self._subscription = None
        self._subscribed_type = None
        self._graph_note: Optional[str] = None
        self._publisher = self.create_publisher(PoseStamped, CAMERA_POSE_TOPIC, LATCHED_QOS)
        self._publish()
        eye, focus, up, source = static_view(self._params)
        self.get_logger().info(
            f'publishing the static view from {source} (eye {np.round(eye, 4).tolist()}, focus '
            f'{np.round(focus, 4).tolist()}, up {np.round(up, 4).tolist()}) in '
            f"'{self._params['world_frame']}' until {self._params['pose_topic']} arrives "
            f"({self._params['pose_convention']} convention)")
        self._timer = self.create_timer(DISCOVERY_PERIOD_S, self._discover)
        self._discover()

    @property
    def pose_type(self):
        """Return the message class subscribed on ``pose_topic`` (None until found)."""
        return self._subscribed_type

    def _static_pose(self) -> Tuple[np.ndarray, np.ndarray]:
        eye, focus, up, _ = static_view(self._params)
        return look_at_pose(eye, focus, up)

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        self._params.update(changed)
        if 'pose_topic' in changed:
            self._unsubscribe()
            self._timer.timer_period_ns = int(DISCOVERY_PERIOD_S * 1e9)
            self._timer.reset()
            self.get_logger().info(f"pose_topic is now '{changed['pose_topic']}': "
                                   'looking for its publisher')
            self._discover()
        if changed.keys() & {'eye', 'focus', 'up'}:
            if self._live:
                self.get_logger().info(
                    'static view updated, but a live RViz camera pose is in use: '
                    'camera/pose keeps following RViz')
            else:
                self._pose = self._static_pose()
        if not self._live or 'world_frame' in changed:
            self._publish()

    def _discover(self) -> None:
        """Subscribe to ``pose_topic`` with the type its publishers use."""
        topic = self.resolve_topic_name(self._params['pose_topic'])
        publishers = self.get_publishers_info_by_topic(topic)
        types = sorted({info.topic_type for info in publishers})
        note = None
        if not types:
            note = f'no publisher on {topic} yet: waiting (polling the graph)'
        elif len(types) > 1:
            note = (f'publishers of different types on {topic} ({", ".join(types)}): '
                    'listening to none until one type is left')
        elif types[0] not in POSE_TYPES:
            note = (f'{topic} has type {types[0]}; camera_tracker reads '
                    f'{" or ".join(POSE_TYPES)}: not subscribed')
        if note is not None:
            if note != self._graph_note and types:
                self.get_logger().warning(note)
            elif note != self._graph_note:
                self.get_logger().info(note)
            self._graph_note = note
            return
        message_type = POSE_TYPES[types[0]]
        if message_type is self._subscribed_type:
            return
        self._unsubscribe()
        best_effort = any(info.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
                          for info in publishers)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=RVIZ_POSE_QOS.depth,
                         reliability=(ReliabilityPolicy.BEST_EFFORT if best_effort
                                      else ReliabilityPolicy.RELIABLE),
                         durability=DurabilityPolicy.VOLATILE)
        callback = self._on_pose if message_type is Pose else self._on_pose_stamped
        self._subscription = self.create_subscription(message_type, topic, callback, qos)
        self._subscribed_type = message_type
        self._graph_note = None
        self.get_logger().info(f'listening to {topic} ({types[0]}, '
                               f"{self._params['pose_convention']} convention)")
        self._timer.timer_period_ns = int(WATCH_PERIOD_S * 1e9)
        self._timer.reset()

    def _unsubscribe(self) -> None:
        if self._subscription is not None:
            self.destroy_subscription(self._subscription)
        self._subscription = None
        self._subscribed_type = None

    def _on_pose_stamped(self, message: PoseStamped) -> None:
        frame = message.header.frame_id or self._params['world_frame']
        if frame.lstrip('/') != self._params['world_frame']:
            self.get_logger().warning(
                f"ignoring {self._params['pose_topic']}: pose in frame '{frame}', expected "
                f"world_frame '{self._params['world_frame']}' (no tf2 here: set world_frame "
                "or RViz's Fixed Frame so they agree); keeping the last good pose",
                throttle_duration_sec=WARN_PERIOD_S)
            return
        self._on_pose(message.pose)

    def _on_pose(self, message: Pose) -> None:
        try:
            position, quaternion = optical_pose_from(
                self._params['pose_convention'], *pose_to_arrays(message))
        except ValueError as error:
            self.get_logger().warning(
                f"ignoring {self._params['pose_topic']}: {error}; keeping the last good pose",
                throttle_duration_sec=WARN_PERIOD_S)
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
    spin_node(CameraTracker, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
