"""
A node's clock read as numbers, without rclpy's ``Time`` object.

``node.get_clock().now()`` builds a ``rclpy.time.Time`` on every read: about
4 us in a loop, and 20-40 us in a node woken between callbacks.  The gaze path
reads the clock a few times per batch, dozens of batches a second
(:mod:`eye_bci_ros2.nodes.lsl_gaze_bridge` pairs it with the LSL clock three
times per chunk when a read is slow).  While simulated time is off, the ROS
clock *is* the system clock (rcl reads ``CLOCK_REALTIME``, as
:func:`time.time_ns` does), so :class:`NodeClock` reads that directly; when
``use_sim_time`` turns simulated time on (or off again), rcl's clock-change
jump callback tells it, and it reads the node's clock (``/clock``) instead.
"""

import time

from rclpy.clock import ClockChange, ClockType, JumpThreshold, TimeJump
from rclpy.node import Node


class NodeClock:
    """
    The time of ``node.get_clock()``, as int ns or float s.

    :param node: the node whose clock (ROS time, or simulated time with
        ``use_sim_time``) it reads.
    """

    def __init__(self, node: Node):
        """Follow the node's clock, and be told when simulated time turns on or off."""
        self._clock = node.get_clock()
        self._system = self._clock.clock_type == ClockType.SYSTEM_TIME or (
            self._clock.clock_type == ClockType.ROS_TIME and not self._clock.ros_time_is_active)
        # Kept: the callback lives as long as its handle.
        self._jumps = self._clock.create_jump_callback(
            JumpThreshold(min_forward=None, min_backward=None, on_clock_change=True),
            post_callback=self._on_jump)

    def _on_jump(self, jump: TimeJump) -> None:
        if jump.clock_change == ClockChange.ROS_TIME_ACTIVATED:
            self._system = False
        elif jump.clock_change == ClockChange.ROS_TIME_DEACTIVATED:
            self._system = True

    @property
    def system_time(self) -> bool:
        """Tell whether the clock is the system clock now (simulated time is off)."""
        return self._system

    def ns(self) -> int:
        """Return the node clock's time now in ns, as ``get_clock().now()`` holds it."""
        if self._system:
            return time.time_ns()
        return self._clock.now().nanoseconds

    def seconds(self) -> float:
        """Return the node clock's time now, s."""
        return self.ns() * 1e-9
