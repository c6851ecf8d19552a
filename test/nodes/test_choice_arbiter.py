"""The choice_arbiter node on a private ROS 2 graph, driven through its topics and parameters."""

import re

from arbiter_rig import ArbiterRig, to_time
from builtin_interfaces.msg import Time
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector, gaze_messages
from visualization_msgs.msg import Marker

from eye_bci_ros2.decision.rounds import ArbiterSettings, COUNT_RULE
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.ros.conversions import regions_to_marker_array, stamp_to_ns
from eye_bci_ros2.ros.topics import DECISION_DUE_TOPIC, LATCHED_QOS

pytestmark = pytest.mark.ros

RATE_HZ = 100.0
LEFT, RIGHT = (300.0, 500.0), (1500.0, 500.0)
#: A screen point off every region of the tests.
OFF = (900.0, 900.0)


class Rig(ArbiterRig):
    """The arbiter plus a driver node publishing regions, gaze and requests."""

    def __init__(self, graph, **parameters):
        super().__init__(graph, 'test_driver', 3, **parameters)

    def offer(self, layout, stamp=None, new_round=True):
        """
        Publish regions: ``layout`` maps label -> (x, y) centre of a 200 px square.

        :returns: the stamp used, s.
        """
        stamp = self.now() if stamp is None else stamp
        half = 100.0
        polygons = np.array([[[x - half, y - half], [x + half, y - half],
                              [x + half, y + half], [x - half, y + half]]
                             for x, y in layout.values()])
        sources = [Marker(ns='choices', id=i, text=label) for i, label in enumerate(layout)]
        rounds = self.arbiter.rounds_started
        self.regions.publish(regions_to_marker_array(polygons, sources, to_time(stamp)))
        if new_round:
            assert self.graph.spin_until(lambda: self.arbiter.rounds_started > rounds, 10.0)
        return stamp

    def looks(self, centre, count, spread=15.0):
        """Gaze positions around a screen point, shape (count, 2) px."""
        return self.rng.normal(centre, spread, (count, 2))

    def send(self, points, start, stamps=None):
        """
        Publish gaze samples all at once, stamped at RATE_HZ from ``start`` s.

        Stamps sit half a period off the grid so none lies on a window edge.
        :param stamps: explicit stamps (N,), s, instead.
        """
        if stamps is None:
            stamps = start + (np.arange(len(points)) + 0.5) / RATE_HZ
        for message in gaze_messages(points, stamps):
            self.gaze.publish(message)

    def wait_decision(self, rounds_done=1):
        """Spin until ``rounds_done`` rounds have finished; return the last decision."""
        decided = []

        def finished():
            decision = self.arbiter.last_decision
            if decision is not None and (not decided or decided[-1] is not decision):
                decided.append(decision)
            return len(decided) >= rounds_done
        assert self.graph.spin_until(finished, 10.0), 'no decision'
        return self.arbiter.last_decision


def test_mean_chooses_the_looked_at_region(graph):
    rig = Rig(graph)
    start = rig.offer({'kitchen': LEFT, 'bedroom': RIGHT})
    points = np.vstack([rig.looks(RIGHT, 100), rig.rng.uniform(0, 1900, (20, 2))])
    rig.send(points, start)
    decision = rig.wait_decision()
    assert decision.method == 'mean'
    assert decision.samples_used == 100  # the 1 s window at 100 Hz
    assert decision.in_region_samples == 100
    assert rig.choices_before_sentinel() == ['bedroom']


def test_vote_and_mean_differ_when_the_mean_falls_between(graph):
    rig = Rig(graph)
    start = rig.offer({'A': LEFT, 'B': RIGHT})
    # 60 % on A, 40 % on B, interleaved in time: the mean is in the gap between.
    between = np.vstack([rig.looks(LEFT, 60), rig.looks(RIGHT, 40)])[rig.rng.permutation(100)]
    rig.send(np.vstack([between, rig.looks(LEFT, 10)]), start)
    decision = rig.wait_decision()
    assert decision.label is None and 'no region' in decision.reason
    # The samples were stamped up to 1.1 s ahead of the clock; let the ones past the
    # window arrive before the next round, whose window they would otherwise fall in.
    assert graph.spin_until(lambda: rig.arbiter.samples_received == 110, 10.0)
    assert rig.labels == []

    result = graph.set_parameters('/choice_arbiter', {'method': 'vote'})
    assert result[0].successful
    start = rig.request()
    rig.send(np.vstack([between, rig.looks(LEFT, 10)]), start)
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    assert rig.labels == ['A']
    assert rig.arbiter.last_decision.method == 'vote'
    assert rig.arbiter.last_decision.margin == pytest.approx(0.2, abs=0.02)


def test_early_decision_chooses_before_the_window_ends(graph):
    rig = Rig(graph, early_decision=True, min_samples=5, dwell_s=0.05, confidence=0.95)
    start = rig.offer({'A': LEFT, 'B': RIGHT})
    # 15 samples (0.15 s) elsewhere first: a reaction, not a gaze already on B.
    gaze = np.vstack([rig.looks(OFF, 15), rig.looks(RIGHT, 100)])
    rig.send(gaze, start)
    early = rig.wait_decision()
    assert early.label == 'B' and early.method == 'early', early.summary()
    assert early.posterior >= 0.95
    # A 1 s window at 100 Hz holds 100 samples; the early choice needs a handful.
    assert early.in_region_samples < 15 and early.time_to_decision < 0.25
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    # Every sample taken before the next round (later ones would fall in its window).
    assert graph.spin_until(lambda: rig.arbiter.samples_received == len(gaze), 10.0)
    assert rig.labels == ['B']

    # The same gaze without early decision waits for the whole window.
    assert graph.set_parameters('/choice_arbiter', {'early_decision': False})[0].successful
    rig.send(gaze, rig.request())
    assert graph.spin_until(lambda: rig.arbiter.last_decision is not early, 10.0)
    window = rig.arbiter.last_decision
    assert window.label == 'B' and window.method == 'mean', window.summary()
    assert window.samples_used == 100 and window.time_to_decision > 0.9
    assert graph.spin_until(lambda: len(rig.choices.messages) > 1, 10.0)
    assert rig.labels == ['B', 'B']


def test_no_choice_when_every_sample_is_outside(graph):
    rig = Rig(graph)
    start = rig.offer({'A': LEFT, 'B': RIGHT})
    rig.send(rig.looks((900.0, 900.0), 120), start)
    decision = rig.wait_decision()
    assert decision.label is None
    assert decision.reason == 'no sample in any region'
    assert decision.samples_used == 100
    assert rig.choices_before_sentinel() == []


def test_round_without_gaze_closes_after_the_window(graph):
    rig = Rig(graph, window_s=0.3, stall_timeout_s=0.2)
    rig.offer({'A': LEFT, 'B': RIGHT})
    decision = rig.wait_decision()
    assert decision.label is None and decision.samples_used == 0
    assert rig.labels == []


def test_new_choices_start_a_round_but_moved_ones_do_not(graph):
    rig = Rig(graph)
    start = rig.offer({'room1': LEFT, 'room2': RIGHT})
    rig.send(rig.looks(LEFT, 110), start)
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    assert rig.labels == ['room1']

    # Same labels, moved by the camera: geometry only, no new round, no new choice.
    rig.offer({'room1': (400.0, 600.0), 'room2': (1400.0, 600.0)}, new_round=False)
    graph.spin_for(0.2)
    moved = rig.now()
    rig.send(rig.looks((400.0, 600.0), 110), moved)
    assert graph.spin_until(lambda: rig.arbiter.samples_received == 220, 10.0)
    graph.spin_for(0.2)
    assert rig.arbiter.rounds_started == 1
    assert rig.labels == ['room1']
    # The next menu comes after that gaze (a round started by new choices takes the
    # samples stamped after its start).
    assert graph.spin_until(lambda: rig.now() > moved + 1.1, 10.0)

    # A new menu (other labels) is a new question: no request needed.
    start = rig.offer({'table1': LEFT, 'table2': (900.0, 500.0), 'table3': RIGHT})
    assert rig.arbiter.rounds_started == 2
    rig.send(rig.looks((900.0, 500.0), 110), start)
    assert graph.spin_until(lambda: len(rig.choices.messages) > 1, 10.0)
    assert rig.labels == ['room1', 'table2']


def test_late_regions_reclassify_the_open_round(graph):
    # Default reorder_s (0): A and B swap places 0.3 s into the round; the gaze
    # samples after the swap arrive 0.2 s before the regions message that
    # announces it, and the window ends after that message.
    rig = Rig(graph)
    start = rig.offer({'A': LEFT, 'B': RIGHT})
    swap = start + 0.3
    rig.send(rig.looks(RIGHT, 60), swap)
    graph.spin_for(0.2)
    rig.offer({'A': RIGHT, 'B': LEFT}, stamp=swap, new_round=False)
    graph.spin_for(0.1)
    rig.send(rig.looks(RIGHT, 20), swap + 0.6)
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    assert rig.labels == ['A']
    assert rig.arbiter.last_decision.counts == {'A': 70, 'B': 0}


def test_samples_use_the_regions_shown_at_their_time(graph):
    # A and B swap places 0.3 s into the round, and the gaze samples after the
    # swap, including the one that ends the window, arrive 0.2 s before the
    # regions message that announces it: the decision waits for it.
    rig = Rig(graph, reorder_s=1.2)  # well beyond the 0.2 s the regions lag, even under load
    start = rig.offer({'A': LEFT, 'B': RIGHT})
    swap = start + 0.3
    rig.send(rig.looks(RIGHT, 80), swap)
    graph.spin_for(0.2)
    rig.offer({'A': RIGHT, 'B': LEFT}, stamp=swap, new_round=False)
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    assert rig.labels == ['A']
    assert rig.arbiter.rounds_started == 1
    assert rig.arbiter.last_decision.counts == {'A': 70, 'B': 0}


def test_bad_parameters_are_rejected_with_a_reason(graph):
    rig = Rig(graph)
    bad = {'window_s': 0.0, 'confidence': 1.0, 'hit_rate': 0.5, 'method': 'median'}
    for name, value in bad.items():
        result = graph.set_parameters('/choice_arbiter', {name: value})[0]
        assert not result.successful, name
        assert name in result.reason
    assert not graph.set_parameters('/choice_arbiter', {'confidence': 0.3})[0].successful
    assert not graph.set_parameters('/choice_arbiter', {'window_s': -1.0})[0].successful
    assert graph.get_parameters('/choice_arbiter', ['window_s', 'confidence', 'method']) == \
        [1.0, 0.95, 'mean']
    # The node still works after the rejections.
    start = rig.offer({'A': LEFT})
    rig.send(rig.looks(LEFT, 110), start)
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    assert rig.labels == ['A']


def test_early_decision_alone_does_not_choose_the_option_under_a_resting_gaze(graph):
    # The count rule's defaults apart from early_decision: the benchmarked configuration.
    rig = Rig(graph, early_decision=True)
    names = ['confidence', 'min_samples', 'dwell_s', 'min_reaction_s', 'hit_rate']
    defaults = ArbiterSettings(**COUNT_RULE)
    assert graph.get_parameters('/choice_arbiter', names) == \
        [getattr(defaults, name) for name in names]
    # The tables appear with the gaze still where the room was, on table1;
    # 0.2 s later the person looks at table2.
    start = rig.offer({'table1': LEFT, 'table2': RIGHT})
    rig.send(np.vstack([rig.looks(LEFT, 20), rig.looks(RIGHT, 30)]), start)
    decision = rig.wait_decision()
    assert decision.label == 'table2' and decision.method == 'early'
    assert 0.2 < decision.time_to_decision < 0.3
    assert rig.choices_before_sentinel() == ['table2']


def test_min_reaction_is_validated_against_its_range(graph):
    Rig(graph)
    for bad in (-0.1, 2.5):
        result = graph.set_parameters('/choice_arbiter', {'min_reaction_s': bad})[0]
        assert not result.successful and 'min_reaction_s' in result.reason, bad
    assert graph.get_parameters('/choice_arbiter', ['min_reaction_s']) == [0.1]
    assert graph.set_parameters('/choice_arbiter', {'min_reaction_s': 0.25})[0].successful
    assert graph.get_parameters('/choice_arbiter', ['min_reaction_s']) == [0.25]


def test_bad_parameter_override_fails_at_start(graph):
    with pytest.raises(ValueError, match='method'):
        graph.add(ChoiceArbiter, parameter_overrides=[Parameter('method', value='median')])


def test_a_sample_stamped_far_in_the_future_is_dropped_and_the_round_goes_on(graph, capfd):
    rig = Rig(graph, window_s=0.5, max_future_s=ArbiterSettings().max_future_s)
    start = rig.offer({'kitchen': LEFT, 'bedroom': RIGHT})
    # One corrupt stamp an hour ahead: taken, it would end the round with no gaze in it.
    rig.send([OFF], None, stamps=[rig.now() + 3600.0])
    assert graph.spin_until(lambda: rig.arbiter.samples_from_future == 1, 10.0)
    assert rig.arbiter.last_decision is None and rig.labels == []
    # The person's gaze that follows decides the round.
    rig.send(rig.looks(RIGHT, 60), start)
    decision = rig.wait_decision()
    assert decision.label == 'bedroom' and decision.samples_used == 50, decision.summary()
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    assert rig.labels == ['bedroom']
    assert graph.spin_until(lambda: rig.arbiter.samples_received == 61, 10.0)
    assert rig.arbiter.samples_from_future == 1 and rig.labels == ['bedroom']
    log = capfd.readouterr().err
    # Stamped an hour after the driver's clock: a little less after the arrival.
    assert re.search(r'choice_arbiter.*gaze sample stamped 3[56]\d\d\.\d+ s after its '
                     r'arrival dropped \(more than max_future_s 1\.0 s', log), log[-2000:]


def test_nan_and_infinite_gaze_is_never_evidence_and_is_reported_once(graph, capfd):
    rig = Rig(graph)
    start = rig.offer({'kitchen': LEFT, 'bedroom': RIGHT})
    bad = np.array([[np.nan, np.nan], [np.nan, 500.0], [np.inf, 500.0], [300.0, -np.inf]] * 10)
    # 40 bad samples among 60 on the kitchen (1 s window at 100 Hz), then one past the window.
    points = np.vstack([rig.looks(LEFT, 30), bad, rig.looks(LEFT, 31)])
    rig.send(points, start)
    decision = rig.wait_decision()
    assert decision.label == 'kitchen', decision.summary()
    assert decision.samples_used == 100 and decision.in_region_samples == 60
    assert rig.arbiter.samples_not_finite == 40
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    assert rig.labels == ['kitchen']
    # One warning for all 40 (throttled), with the count so far.
    log = capfd.readouterr().err
    warnings = re.findall(r'choice_arbiter.*gaze sample \(.*\) px is NaN or infinite: taken '
                          r'as in no region \((\d+) such samples so far\)', log)
    assert warnings == ['1'], log[-2000:]


def test_each_round_announces_when_its_decision_can_come(graph):
    """choice/due: the earliest early decision, then the window end (the bridge's batching)."""
    rig = Rig(graph, window_s=0.4, early_decision=True, dwell_s=0.1)
    ends = Collector(rig.driver, Time, DECISION_DUE_TOPIC, LATCHED_QOS)
    rig.offer({'a': (300.0, 300.0), 'b': (800.0, 300.0)})   # new choices start a round
    rig.request()
    start = rig.arbiter.round_start
    early_ns, end_ns = (int(round((start + offset) * 1e9)) for offset in (0.1, 0.4))
    # Without gaze the round stays open past its early time: then its window end is due.
    assert graph.spin_until(lambda: any(stamp_to_ns(m) == end_ns for m in ends.messages),
                            10.0), 'no window end announced'
    dues = [stamp_to_ns(m) for m in ends.messages]
    assert dues[dues.index(end_ns) - 1] == early_ns


def test_rounds_asked_again_on_the_same_options_are_logged_once_and_every_choice_always(
        graph, capfd):
    rig = Rig(graph, window_s=0.3)
    rig.offer({'kitchen': LEFT, 'bedroom': RIGHT})
    for rounds in range(1, 4):     # three choices, the same options asked again each time
        rig.send(rig.looks(RIGHT, 40), rig.request())
        rig.wait_decision()
        assert graph.spin_until(lambda: len(rig.choices.messages) == rounds, 10.0)
    rig.offer({'kitchen': LEFT, 'office': RIGHT})  # new options: news again
    log = capfd.readouterr().err
    opened = re.findall(r'\[choice_arbiter\]: round (\d+) \(([a-z ]+)\): offered', log)
    # Shown: the first round on the options, the first asked for, the first on new options.
    assert opened == [('1', 'new choices'), ('2', 'request'), ('5', 'new choices')], log[-3000:]
    assert len(re.findall(r"\[choice_arbiter\]: choice 'bedroom'", log)) == 3, log[-3000:]
