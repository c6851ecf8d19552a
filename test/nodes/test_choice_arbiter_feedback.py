"""choices/feedback from the choice_arbiter: what the person sees while the selection happens."""

from arbiter_rig import ArbiterRig, to_time
from builtin_interfaces.msg import Time
import numpy as np
import pytest
from ros_harness import Collector, gaze_messages
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.decision.feedback import STATE_COLOURS
from eye_bci_ros2.ros.conversions import cube_marker, regions_to_marker_array
from eye_bci_ros2.ros.topics import CHOICES_QOS, FEEDBACK_QOS, FEEDBACK_TOPIC

pytestmark = pytest.mark.ros

#: The options: label -> (world position m, screen centre px of its 200 px region).
OPTIONS = {'kitchen': ((2.0, 6.0, 0.05), (500.0, 500.0)),
           'bedroom': ((8.0, 6.0, 0.05), (1400.0, 500.0))}
KEYS = {('rooms', 0), ('rooms', 1)}
TRACKER_HZ = 1200.0
CHUNK = 24   # samples per gaze/samples message: 20 ms at 1200 Hz


def seconds(stamp: Time) -> float:
    """Float s of a builtin_interfaces/Time."""
    return stamp.sec + stamp.nanosec * 1e-9


def colour(marker):
    """Return a marker's (r, g, b, a)."""
    return tuple(round(v, 3) for v in (marker.color.r, marker.color.g, marker.color.b,
                                       marker.color.a))


def state_of(marker):
    """Return the feedback state a halo's colour shows."""
    return next(state for state, rgba in STATE_COLOURS.items()
                if tuple(round(v, 3) for v in rgba) == colour(marker))


class Rig(ArbiterRig):
    """The arbiter; a driver publishing the options (world), their regions (screen) and gaze."""

    def __init__(self, graph, **parameters):
        super().__init__(graph, 'feedback_driver', 5, **parameters)

    def setup(self):
        """Add the options (``choices``) and the feedback collector."""
        self.choices_pub = self.driver.create_publisher(MarkerArray, 'choices', CHOICES_QOS)
        self.feedback = Collector(self.driver, MarkerArray, FEEDBACK_TOPIC, FEEDBACK_QOS)
        self.publishers.append(self.choices_pub)
        self.awaited.append(FEEDBACK_TOPIC)

    def offer(self):
        """Publish the options (as the menu does) and their screen regions (as the projector)."""
        array = MarkerArray(markers=[Marker(ns='rooms', action=Marker.DELETEALL)])
        for index, (label, (position, _)) in enumerate(OPTIONS.items()):
            array.markers.append(cube_marker('rooms', index, label, 'map', position,
                                             (0.0, 0.0, 0.0, 1.0), (1.5, 1.0, 0.1),
                                             (0.2, 0.4, 0.8, 1.0)))
        self.choices_pub.publish(array)
        polygons = np.array([[[x - 100, y - 100], [x + 100, y - 100], [x + 100, y + 100],
                              [x - 100, y + 100]] for _, (x, y) in OPTIONS.values()])
        sources = [Marker(ns='rooms', id=i, text=label) for i, label in enumerate(OPTIONS)]
        rounds = self.arbiter.rounds_started
        self.regions.publish(regions_to_marker_array(polygons, sources, to_time(self.now())))
        assert self.graph.spin_until(lambda: self.arbiter.rounds_started > rounds, 10.0)

    def stream(self, seconds, target):
        """
        Stream gaze in real time at 1200 Hz, one 24-sample message per 20 ms.

        :param target: the option label to look at, or a function of the message index
            giving it.
        """
        index = 0
        end = self.now() + seconds
        while self.now() < end:
            label = target(index) if callable(target) else target
            start = self.now()
            stamps = start + np.arange(CHUNK) / TRACKER_HZ
            points = self.rng.normal(OPTIONS[label][1], 10.0, (CHUNK, 2))
            for message in gaze_messages(points, stamps, chunk=CHUNK):
                self.gaze.publish(message)
            index += 1
            self.graph.spin_for(max(0.0, start + CHUNK / TRACKER_HZ - self.now()))

    def states(self):
        """Per feedback message: {(ns, id): state} of its halos (ADD markers)."""
        return [{(m.ns, m.id): state_of(m) for m in message.markers if m.action == Marker.ADD}
                for message in self.feedback.messages]


def test_feedback_halos_carry_the_options_ns_id_and_show_gazed_then_chosen(graph):
    rig = Rig(graph, feedback_confirm_s=0.6)
    rig.offer()
    assert graph.spin_until(lambda: rig.feedback.messages, 5.0), 'no feedback'
    first = rig.feedback.messages[0]
    assert {(m.ns, m.id) for m in first.markers} == KEYS
    assert {m.header.frame_id for m in first.markers} == {'map'}
    assert {m.type for m in first.markers} == {Marker.CUBE}
    # Each halo sits on its option.
    xs = {(m.ns, m.id): m.pose.position.x for m in first.markers}
    assert xs == {('rooms', 0): 2.0, ('rooms', 1): 8.0}

    rig.stream(1.5, 'bedroom')            # the 1 s window ends within it: a choice
    assert graph.spin_until(lambda: rig.choices.messages, 5.0)
    assert [m.data for m in rig.choices.messages] == ['bedroom']
    states = [s.get(('rooms', 1)) for s in rig.states()]
    gazed = states.index('gazed')
    chosen = states.index('chosen')
    assert gazed < chosen, states
    # While gazed the halo grows with the window's progress.
    sizes = [max(m.scale.x for m in message.markers if (m.ns, m.id) == ('rooms', 1))
             for message in rig.feedback.messages[gazed:chosen]]
    assert sizes[-1] > sizes[0]
    assert all(s.get(('rooms', 0)) == 'none' for s in rig.states())
    # The confirmation ends after feedback_confirm_s.
    assert graph.spin_until(lambda: rig.states()[-1].get(('rooms', 1)) != 'chosen', 3.0)


def test_feedback_is_at_most_about_30_messages_per_second_at_1200_hz(graph):
    rig = Rig(graph, window_s=30.0)
    rig.offer()
    assert graph.spin_until(lambda: rig.feedback.messages, 5.0)
    start = rig.now()
    # The gaze jumps between the options every message (50 changes per second).
    rig.stream(2.0, lambda index: 'kitchen' if index % 2 else 'bedroom')
    end = rig.now()
    graph.spin_for(0.3)
    stamps = [seconds(m.markers[0].header.stamp) for m in rig.feedback.messages]
    during = [t for t in stamps if start + 0.1 <= t <= end]
    rate = len(during) / (end - start - 0.1)
    assert rate <= 33.0, rate
    # It does update while the gaze moves (sampled at 30 Hz, a 25 Hz alternation is seen
    # changing about 10 times a second).
    assert rate >= 5.0, rate
    # Both options were shown gazed.
    shown = {state for s in rig.states() for key, state in s.items()}
    assert 'gazed' in shown


def test_feedback_rate_zero_withdraws_the_halos_and_sends_nothing(graph):
    rig = Rig(graph)
    rig.offer()
    assert graph.spin_until(lambda: rig.feedback.messages, 5.0)
    result = graph.set_parameters('/choice_arbiter', {'feedback_rate_hz': 0})[0]
    assert result.successful, result.reason
    assert graph.spin_until(lambda: any(
        m.action == Marker.DELETE for m in rig.feedback.messages[-1].markers), 5.0)
    assert {(m.ns, m.id) for m in rig.feedback.messages[-1].markers} == KEYS
    count = len(rig.feedback.messages)
    rig.stream(0.5, 'kitchen')
    # A bad rate is refused with a reason; on again it resumes.
    bad = graph.set_parameters('/choice_arbiter', {'feedback_rate_hz': -5.0})[0]
    assert not bad.successful and bad.reason
    enabled = rig.now()
    assert graph.set_parameters('/choice_arbiter', {'feedback_rate_hz': 30})[0].successful
    rig.stream(0.3, 'kitchen')
    assert graph.spin_until(lambda: len(rig.feedback.messages) > count, 5.0)
    # Nothing was sent while it was off: the feedback published in order, every message
    # since the halos were withdrawn is from after it was on again.
    sent = [seconds(m.markers[0].header.stamp) for m in rig.feedback.messages[count:]]
    assert min(sent) >= enabled, (sent, enabled)
