"""A choice_arbiter with a driver node: what the arbiter's node tests share."""

from builtin_interfaces.msg import Time
import numpy as np
from rclpy.parameter import Parameter
from ros_harness import Collector, gaze_messages
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.decision.rounds import COUNT_RULE
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.ros.conversions import ns_to_stamp, regions_to_marker_array
from eye_bci_ros2.ros.topics import (CHOICE_TOPIC, EVENT_QOS, GAZE_QOS, GAZE_SAMPLES_TOPIC,
                                     LATCHED_QOS, REQUEST_TOPIC)

#: The tests publish a round's gaze at once, stamped up to ~1 s ahead of the clock.
MAX_FUTURE_S = 5.0
#: The tests' gaze of a round ends at most this long after its window, s.
SENT_AFTER_WINDOW_S = 0.5


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

    #: The label of :meth:`choices_before_sentinel`'s option; no test offers it.
    SENTINEL = 'sentinel'

    def choices_before_sentinel(self, centre=(960.0, 540.0), rate_hz: float = 100.0,
                                timeout: float = 10.0):
        """
        Return the choices received before one more choice that must come.

        Offers a new option, :data:`SENTINEL` (a 200 px square at ``centre``), rests
        the gaze on it and waits for its choice.  The arbiter publishes its choices
        in order on one topic, so a late choice of anything before arrives ahead of
        this one: a check that nothing (else) was chosen sees it, where a fixed wait
        may end before it comes.
        """
        window = self.arbiter.settings.window_s
        # Past every stamp of the gaze sent before (at most a window and a bit after its
        # round's start), so that none of it lands in the sentinel's window.
        last = self.arbiter.last_decision
        if last is not None and last.round_start is not None:
            clear = last.round_start + window + SENT_AFTER_WINDOW_S
            assert self.graph.spin_until(lambda: self.now() > clear, timeout + window)
        x, y = centre
        square = np.array([[[x - 100, y - 100], [x + 100, y - 100], [x + 100, y + 100],
                            [x - 100, y + 100]]], dtype=float)
        rounds = self.arbiter.rounds_started
        start = self.now()   # new options: a round starts at their stamp
        self.regions.publish(regions_to_marker_array(
            square, [Marker(ns='sentinel', id=0, text=self.SENTINEL)], to_time(start)))
        assert self.graph.spin_until(lambda: self.arbiter.rounds_started > rounds, timeout)
        count = int(round((window + 0.2) * rate_hz))
        stamps = start + (np.arange(count) + 0.5) / rate_hz
        for message in gaze_messages(self.rng.normal(centre, 10.0, (count, 2)), stamps):
            self.gaze.publish(message)
        assert self.graph.spin_until(lambda: self.SENTINEL in self.labels, timeout), \
            f'the sentinel was not chosen: {self.labels}'
        return self.labels[:self.labels.index(self.SENTINEL)]
