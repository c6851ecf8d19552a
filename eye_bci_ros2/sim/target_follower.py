"""
The simulated person looks where a ROS topic says: ``validation/target`` by default.

Part of the simulated person (:mod:`eye_bci_ros2.sim.person`): a real person
looks at the target RViz shows; the simulated one is told its screen point.
:class:`TargetFollower` subscribes a geometry_msgs/PointStamped topic (frame
``screen``, px of the screen RViz is shown on, which is the person's screen;
NaN = nothing to look at; latched) and makes a
:class:`eye_bci_ros2.sim.gaze_outlet.GazeStreamer` look there, from the time
in the message's stamp (ROS clock; translated to the LSL clock as "that long
ago"), so the saccade latency counts from when the target appeared.

``sim_gaze --follow validation/target`` runs it next to the outlet (in a
background thread with its own rclpy context); :func:`follow_in_background`
is that helper.
"""

import math
import threading
from typing import Callable, Optional, Protocol, Tuple

from geometry_msgs.msg import PointStamped
import pylsl
import rclpy
from rclpy.context import Context
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node

from eye_bci_ros2.ros.conversions import SCREEN_FRAME, stamp_to_ns
from eye_bci_ros2.ros.log_throttle import WARN_PERIOD_S
from eye_bci_ros2.ros.runner import make_executor
from eye_bci_ros2.ros.topics import LATCHED_QOS, VALIDATION_TARGET_TOPIC


class Looker(Protocol):
    """What the follower moves: a simulated person told where to look (``GazeStreamer``)."""

    def set_target(self, xy: Optional[Tuple[float, float]], t: Optional[float] = None) -> None:
        """Look at screen point ``xy`` (px; None: nothing) from LSL time ``t`` (None: now)."""


class TargetFollower(Node):
    """
    Make a simulated person (a :class:`Looker`) look at the points of a topic.

    :param streamer: the simulated person's outlet.
    :param topic: PointStamped topic, screen px.
    """

    def __init__(self, streamer: Looker, topic: str = VALIDATION_TARGET_TOPIC,
                 **kwargs):
        """Subscribe ``topic``; ``kwargs`` go to :class:`rclpy.node.Node`."""
        super().__init__('sim_person', **kwargs)
        self.streamer = streamer
        #: Targets taken (for tests and the status line).
        self.targets = 0
        self._topic = topic
        # Latched, as gaze_validation publishes it (the current target at once); a publisher
        # that is not (a plain `ros2 topic pub`) never connects: say how to make it.
        self.create_subscription(
            PointStamped, topic, self._on_target, LATCHED_QOS,
            event_callbacks=SubscriptionEventCallbacks(incompatible_qos=self._on_incompatible))

    def _on_incompatible(self, _event) -> None:
        self.get_logger().warning(
            f'a publisher of {self._topic} is not latched (durability volatile), so its '
            'targets never arrive here: publish with transient_local durability, e.g. ros2 '
            f'topic pub --qos-durability transient_local --qos-reliability reliable '
            f"{self._topic} geometry_msgs/msg/PointStamped '{{point: {{x: 960, y: 540}}}}'",
            throttle_duration_sec=WARN_PERIOD_S)

    def _on_target(self, message: PointStamped) -> None:
        if message.header.frame_id not in ('', SCREEN_FRAME):
            self.get_logger().warning(f"target in frame '{message.header.frame_id}' ignored: "
                                      f"expected '{SCREEN_FRAME}'",
                                      throttle_duration_sec=WARN_PERIOD_S)
            return
        x, y = message.point.x, message.point.y
        xy = (x, y) if math.isfinite(x) and math.isfinite(y) else None
        stamp_ns = stamp_to_ns(message.header.stamp)
        age_s = 0.0
        if stamp_ns:
            age_s = max(0.0, (self.get_clock().now().nanoseconds - stamp_ns) * 1e-9)
        try:
            self.streamer.set_target(xy, pylsl.local_clock() - age_s)
        except ValueError as error:
            self.get_logger().warning(f'target ignored: {error}',
                                      throttle_duration_sec=WARN_PERIOD_S)
            return
        self.targets += 1


def follow_in_background(streamer: Looker,
                         topic: str = VALIDATION_TARGET_TOPIC) -> Callable[[], None]:
    """
    Run a :class:`TargetFollower` for ``streamer`` in a daemon thread.

    Uses its own rclpy context (domain from ``ROS_DOMAIN_ID``).

    :returns: a function that stops the thread and shuts the context down.
    """
    context = Context()
    rclpy.init(context=context)
    executor = make_executor(context=context)
    node = TargetFollower(streamer, topic, context=context)
    executor.add_node(node)
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set() and context.ok():
            executor.spin_once(timeout_sec=0.1)

    thread = threading.Thread(target=spin, name='sim_person_ros', daemon=True)
    thread.start()

    def close(timeout: Optional[float] = 5.0) -> None:
        stop.set()
        thread.join(timeout)
        executor.shutdown()
        node.destroy_node()
        context.try_shutdown()

    return close
