"""A choice_arbiter with a driver node: what the arbiter's node tests share."""

from builtin_interfaces.msg import Time
import numpy as np
from rclpy.parameter import Parameter
from ros_harness import Collector
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.decision.rounds import COUNT_RULE
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.ros.conversions import ns_to_stamp
from eye_bci_ros2.ros.topics import (CHOICE_TOPIC, EVENT_QOS, GAZE_QOS, GAZE_SAMPLES_TOPIC,
                                     LATCHED_QOS, REQUEST_TOPIC)

#: The tests publish a round's gaze at once, stamped up to ~1 s ahead of the clock.
MAX_FUTURE_S = 5.0


def to_time(seconds: float) -> Time:
    """Return the builtin_interfaces/Time of a float stamp, s."""
    return ns_to_stamp(int(round(seconds * 1e9)))


class ArbiterRig:
    """
    The arbiter plus a driver publishing regions, gaze and requests and collecting ``choice``.

    Subclasses add what their tests need in :meth:`setup` (more publishers go in
    :attr:`publishers`, topics the driver must see published in :attr:`awaited`).

    :param driver: the driver node's name.
    :param seed: seeds :attr:`rng`.
    :param parameters: the arbiter's parameter overrides (``max_future_s`` defaults to
        :data:`MAX_FUTURE_S`; the rule to the count rule, :data:`COUNT_RULE`, whose
        mechanics these tests check with gaze on an option from the round start).
    """

    def __init__(self, graph, driver: str = 'test_driver', seed: int = 3, **parameters):
        """Start the arbiter and the driver and wait until their topics connect."""
        self.graph = graph
        parameters = {'max_future_s': MAX_FUTURE_S, **COUNT_RULE, **parameters}
        self.arbiter = graph.add(ChoiceArbiter, parameter_overrides=[
            Parameter(name, value=value) for name, value in parameters.items()])
        self.driver = graph.node(driver)
        self.regions = self.driver.create_publisher(MarkerArray, 'choices/regions', LATCHED_QOS)
        self.gaze = self.driver.create_publisher(PointCloud2, GAZE_SAMPLES_TOPIC, GAZE_QOS)
        self.request_pub = self.driver.create_publisher(Empty, REQUEST_TOPIC, EVENT_QOS)
        self.choices = Collector(self.driver, String, CHOICE_TOPIC, EVENT_QOS)
        self.publishers = [self.regions, self.gaze, self.request_pub]
        self.awaited = [CHOICE_TOPIC]
        self.rng = np.random.default_rng(seed)
        self.setup()
        assert graph.spin_until(
            lambda: all(p.get_subscription_count() > 0 for p in self.publishers)
            and all(self.driver.count_publishers(t) > 0 for t in self.awaited),
            10.0), 'topics did not connect'

    def setup(self) -> None:
        """Add the publishers and collectors a test file needs (before connecting)."""

    @property
    def labels(self):
        """Return the choices received so far."""
        return [message.data for message in self.choices.messages]

    def now(self) -> float:
        """Return the ROS clock, s."""
        return self.driver.get_clock().now().nanoseconds * 1e-9

    def request(self) -> float:
        """
        Ask for a choice; return the round's start, s (ROS clock).

        The arbiter's own start, not the clock when the test sees it: gaze stamped from it
        fills the window however late this process spins (a loaded machine).
        """
        rounds = self.arbiter.rounds_started
        self.request_pub.publish(Empty())
        assert self.graph.spin_until(lambda: self.arbiter.rounds_started > rounds, 10.0)
        return self.arbiter.round_start
