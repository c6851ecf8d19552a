"""
Simulated RViz view: a stand-in for RViz's animated view controller.

RViz itself cannot run here (no display, no Ogre), so this node mocks the
part of it the pipeline depends on: the camera.  It holds an RViz view
(eye, focus, up), moves to each goal on ``camera/goal`` over
``transition_time_s`` with the cosine ease of rviz_animated_view_controller
(see :mod:`eye_bci_ros2.projection.view_animation`), and publishes the camera pose on
``rviz/current_camera_pose`` in the Ogre convention (looks along -Z, +Y up),
as ports of that controller do: at ``publish_rate_hz`` while moving, once
when it arrives, and once at start-up (latched, so late subscribers get the
current pose).  Nothing is rendered: what the screen shows follows from
:meth:`SimRvizView.current_view` and the analytic RViz projection.

Topics:

* subscribes ``camera/goal`` geometry_msgs/PoseStamped (optical camera pose,
  frame ``world_frame``; latched);
* publishes ``rviz/current_camera_pose`` geometry_msgs/Pose (Ogre camera
  pose in ``world_frame``; latched).
"""

from typing import Any, Dict, Optional

from geometry_msgs.msg import Pose, PoseStamped
import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.view_animation import (as_view, ogre_pose, view_from_optical_pose,
                                                    ViewAnimation, ViewTuple)
from eye_bci_ros2.ros.conversions import arrays_to_pose, pose_to_arrays
from eye_bci_ros2.ros.log_throttle import WARN_PERIOD_S
from eye_bci_ros2.ros.parameters import check_frame_id, check_vector3
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.topics import CAMERA_GOAL_TOPIC, LATCHED_QOS, RVIZ_CAMERA_POSE_TOPIC

#: Initial view: the overview of the default config/scene.yaml.
DEFAULT_EYE = (10.0, -2.0, 17.0)
DEFAULT_FOCUS = (10.0, 6.0, 0.0)
DEFAULT_UP = (0.0, 0.0, 1.0)


def _check_view(values: Dict[str, Any]) -> Optional[str]:
    try:
        geometry.look_at(values['eye'], values['focus'], values['up'])
    except ValueError as error:
        return f'eye/focus/up: {error}'
    return None


PARAMETERS = (
    ParamSpec('eye', list(DEFAULT_EYE),
              'Initial camera position (x, y, z) in world_frame, m; setting it moves the '
              'view there at once', check=check_vector3, array_type='double_array'),
    ParamSpec('focus', list(DEFAULT_FOCUS),
              'Initial focus point (x, y, z) in world_frame, m; setting it moves the '
              'view at once', check=check_vector3, array_type='double_array'),
    ParamSpec('up', list(DEFAULT_UP),
              'Initial up vector (x, y, z) in world_frame; must not be along the view',
              check=check_vector3, array_type='double_array'),
    ParamSpec('transition_time_s', 1.0,
              'Duration of an animated move to a camera/goal, s (0 = jump)',
              value_range=(0.0, 60.0)),
    ParamSpec('publish_rate_hz', 30.0,
              'Rate of rviz/current_camera_pose while the camera moves, Hz',
              value_range=(1.0, 240.0)),
    ParamSpec('world_frame', geometry.WORLD_FRAME,
              'Fixed frame of the view; goals in another frame are ignored',
              check=check_frame_id),
)


class SimRvizView(Node):
    """Mock of RViz's animated view controller: eased moves, Ogre camera poses."""

    def __init__(self, animation_clock: Optional[Clock] = None, **kwargs):
        """
        Create the node.

        :param animation_clock: clock that times the moves (anything with
            ``now() -> rclpy.time.Time``); default a steady clock, as RViz
            animates on wall time.  Tests and simulations may pass their own.
        :param kwargs: passed to :class:`rclpy.node.Node`.
        """
        super().__init__('sim_rviz_view', **kwargs)
        self._steady = animation_clock or Clock(clock_type=ClockType.STEADY_TIME)
        values = declare_parameters(self, PARAMETERS, self._on_parameters,
                                    check_all=_check_view)
        self._world_frame = values['world_frame']
        self._transition_time_s = values['transition_time_s']
        self._rate_hz = values['publish_rate_hz']
        self._view: ViewTuple = as_view(values['eye'], values['focus'], values['up'])
        self._animation: Optional[ViewAnimation] = None
        self._publisher = self.create_publisher(Pose, RVIZ_CAMERA_POSE_TOPIC, LATCHED_QOS)
        self._timer = self.create_timer(1.0 / self._rate_hz, self._on_timer)
        self._timer.cancel()
        self.create_subscription(PoseStamped, CAMERA_GOAL_TOPIC, self._on_goal, LATCHED_QOS)
        self._publish(self._view)
        eye, focus, _ = self._view
        self.get_logger().info(
            'simulated RViz view: rviz/current_camera_pose from eye '
            f'{[round(float(v), 3) for v in eye]} looking at '
            f"{[round(float(v), 3) for v in focus]} in '{self._world_frame}'; moves to each "
            f'camera/goal in {self._transition_time_s:g} s')

    def current_view(self) -> ViewTuple:
        """
        Return the view the simulated RViz shows now (mid-move if moving).

        :returns: (eye, focus, up), each shape (3,), world frame, m.
        """
        if self._animation is not None:
            return self._animation.view_at(self._now())
        return tuple(v.copy() for v in self._view)

    def target_view(self) -> ViewTuple:
        """Return the view being moved to (the current view when still)."""
        if self._animation is not None:
            return tuple(v.copy() for v in self._animation.goal)
        return tuple(v.copy() for v in self._view)

    @property
    def moving(self) -> bool:
        """Tell whether an animated move is under way."""
        return self._animation is not None and not self._animation.finished_at(self._now())

    def _now(self) -> float:
        return self._steady.now().nanoseconds * 1e-9

    def _on_goal(self, message: PoseStamped) -> None:
        frame = message.header.frame_id
        if frame and frame != self._world_frame:
            self.get_logger().warning(
                f"ignoring camera/goal in frame '{frame}': this view is in "
                f"'{self._world_frame}' (no tf here)", throttle_duration_sec=WARN_PERIOD_S)
            return
        position, quaternion = pose_to_arrays(message.pose)
        now = self._now()
        start = self.current_view()
        try:
            distance = float(np.linalg.norm(start[1] - start[0]))
            goal = view_from_optical_pose(position, quaternion, fallback_distance=distance)
            self._animation = ViewAnimation(start, goal, now, self._transition_time_s)
        except ValueError as error:
            self.get_logger().warning(f'ignoring invalid camera/goal: {error}',
                                      throttle_duration_sec=WARN_PERIOD_S)
            return
        self._on_timer()
        if self._animation is not None:
            self._timer.reset()

    def _on_timer(self) -> None:
        if self._animation is None:
            self._timer.cancel()
            return
        now = self._now()
        view = self._animation.view_at(now)
        if self._animation.finished_at(now):
            self._view, self._animation = view, None
            self._timer.cancel()
        self._publish(view)

    def _publish(self, view: ViewTuple) -> None:
        self._publisher.publish(arrays_to_pose(*ogre_pose(*view)))

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        if 'world_frame' in changed:
            self._world_frame = changed['world_frame']
        if 'transition_time_s' in changed:
            self._transition_time_s = changed['transition_time_s']
        if 'publish_rate_hz' in changed:
            self._rate_hz = changed['publish_rate_hz']
            moving = self._animation is not None
            self.destroy_timer(self._timer)
            self._timer = self.create_timer(1.0 / self._rate_hz, self._on_timer)
            if not moving:
                self._timer.cancel()
        if {'eye', 'focus', 'up'} & changed.keys():
            # Like editing the view in RViz's Views panel: jump, no animation.
            values = {name: self.get_parameter(name).value for name in ('eye', 'focus', 'up')}
            self._view = as_view(values['eye'], values['focus'], values['up'])
            self._animation = None
            self._timer.cancel()
            self._publish(self._view)


def main(args=None):
    """Run the simulated RViz view."""
    spin_node(SimRvizView, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
