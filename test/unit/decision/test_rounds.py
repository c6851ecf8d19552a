"""RoundScheduler: rounds on a live stream of gaze and regions, with explicit times (no ROS)."""

import numpy as np
import pytest

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, COUNT_RULE, ORIGINAL_RULE, RoundScheduler

RATE_HZ = 100.0
LEFT, RIGHT = (300.0, 500.0), (1500.0, 500.0)


def squares(layout, stamp):
    """Region set: ``layout`` maps label -> (x, y) centre of a 200 px square."""
    polygons = [[[x - 100, y - 100], [x + 100, y - 100], [x + 100, y + 100], [x - 100, y + 100]]
                for x, y in layout.values()]
    return RegionSet(list(layout), polygons, stamp)


class Recorder:
    """A RoundScheduler plus what it decided and logged."""

    def __init__(self, **settings):
        self.decisions = []
        self.logs = []
        self.rounds = RoundScheduler(ArbiterSettings(**{**COUNT_RULE, **settings}),
                                     self.decisions.append,
                                     lambda level, key, text: self.logs.append((level, key)))

    @property
    def labels(self):
        """Return the labels of the decisions so far (None: no choice)."""
        return [decision.label for decision in self.decisions]

    def feed(self, points, start, now=None):
        """
        Give samples stamped at RATE_HZ from ``start`` (half a period off the grid).

        :param now: arrival time of every sample (default: its stamp).
        :returns: index of the sample whose call returned a decision, else None.
        """
        decided = None
        for k, (x, y) in enumerate(points):
            stamp = start + (k + 0.5) / RATE_HZ
            arrival = stamp if now is None else now
            if self.rounds.add_sample(stamp, x, y, arrival) is not None and decided is None:
                decided = k
        return decided


def at(point, count):
    """``count`` samples exactly on a screen point, shape (count, 2) px."""
    return np.tile(point, (count, 1))


def test_window_end_is_decided_by_the_first_sample_after_it():
    rec = Recorder(window_s=0.5)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    assert rec.rounds.rounds_started == 1
    # 50 samples fill the 0.5 s window; the 51st is the first stamped after it.
    decided = rec.feed(at(RIGHT, 60), 10.0)
    assert decided == 50
    assert rec.labels == ['B']
    assert rec.decisions[0].samples_used == 50
    assert not rec.rounds.round_open


def test_early_decision_is_made_by_the_deciding_sample_without_a_tick():
    rec = Recorder(early_decision=True, min_samples=3, dwell_s=0.0, confidence=0.9,
                   **ORIGINAL_RULE)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    # Off-region for 0.15 s (longer than min_reaction_s), then on A.
    points = np.vstack([at((900.0, 900.0), 15), at(LEFT, 10)])
    decided = rec.feed(points, 10.0)
    # Three samples on A are needed: the 3rd in-region sample (index 17) decides.
    assert decided == 17
    assert rec.labels == ['A']
    assert rec.decisions[0].method == 'early'
    assert rec.decisions[0].in_region_samples == 3


def test_quiet_stream_closes_the_round_on_tick_after_the_stall_timeout():
    rec = Recorder(window_s=0.5, stall_timeout_s=0.2)
    rec.rounds.add_regions(squares({'A': LEFT}, 10.0), now=10.0)
    rec.feed(at(LEFT, 20), 10.0)  # 0.2 s of gaze, then nothing
    assert rec.rounds.tick(10.69) is None and rec.labels == []
    assert rec.rounds.tick(10.71).label == 'A'
    assert rec.decisions[0].samples_used == 20


def test_regions_arriving_after_their_samples_reclassify_the_open_round():
    # A and B swap 0.3 s into the round; the samples after the swap arrive
    # before the regions message announcing it, and before the window ends.
    rec = Recorder()
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    rec.feed(at(RIGHT, 60), 10.3, now=10.9)
    rec.rounds.add_regions(squares({'A': RIGHT, 'B': LEFT}, 10.3), now=10.95)
    assert rec.labels == []
    decided = rec.feed(at(RIGHT, 20), 10.9, now=11.0)
    assert decided == 10  # the first sample stamped after the 1 s window
    assert rec.labels == ['A']
    assert rec.decisions[0].counts == {'A': 70, 'B': 0}
    assert rec.rounds.rounds_started == 1


def test_without_reorder_a_decision_is_final_and_late_regions_are_reported():
    rec = Recorder(window_s=0.5)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    rec.feed(at(RIGHT, 60), 10.0, now=10.6)
    assert rec.labels == ['B']
    # The swap stamped inside the finished window comes too late to change it.
    rec.rounds.add_regions(squares({'A': RIGHT, 'B': LEFT}, 10.3), now=10.65)
    assert rec.labels == ['B']
    assert ('warning', 'late_regions') in rec.logs


def test_reorder_holds_a_decision_until_regions_newer_than_its_samples_arrive():
    rec = Recorder(window_s=0.5, reorder_s=0.5, method='vote')
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    rec.feed(at(RIGHT, 60), 10.0, now=10.6)
    assert rec.labels == [] and rec.rounds.round_open  # held: regions may be late
    # A late swap stamped inside the window changes the held decision from B to A.
    assert rec.rounds.add_regions(squares({'A': RIGHT, 'B': LEFT}, 10.1), now=10.65) is None
    # Regions stamped after the last sample used make it final at once.
    decision = rec.rounds.add_regions(squares({'A': RIGHT, 'B': LEFT}, 10.6), now=10.7)
    assert decision is not None and rec.labels == ['A']
    assert decision.counts == {'A': 40, 'B': 10}
    assert ('warning', 'late_regions') not in rec.logs


def test_reorder_wait_ends_at_its_deadline():
    rec = Recorder(window_s=0.5, reorder_s=0.3)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    rec.feed(at(LEFT, 60), 10.0, now=10.6)
    assert rec.rounds.tick(10.89) is None
    assert rec.rounds.tick(10.91).label == 'A'
    assert rec.labels == ['A']


def test_new_choices_take_the_samples_that_arrived_before_them():
    rec = Recorder(window_s=0.5)
    rec.rounds.add_regions(squares({'room1': LEFT, 'room2': RIGHT}, 10.0), now=10.0)
    rec.feed(at(LEFT, 51), 10.0)
    assert rec.labels == ['room1']
    # The table menu is shown at 11.0, but its regions arrive 0.2 s later,
    # after the gaze samples stamped from 11.0 on.
    rec.feed(at(RIGHT, 20), 11.0, now=11.2)
    rec.rounds.add_regions(squares({'table1': LEFT, 'table2': RIGHT}, 11.0), now=11.2)
    assert rec.rounds.rounds_started == 2
    rec.feed(at(RIGHT, 40), 11.2)
    assert rec.labels == ['room1', 'table2']
    assert rec.decisions[1].samples_used == 50


def test_lagging_new_menu_without_reorder_old_round_decides_on_new_gaze():
    # The gaze moves to the new menu before its regions arrive.  Without
    # reorder_s the open round decides at once on those samples (final, and
    # reported when the new regions show it was late); the new round then
    # takes the same samples and decides too (min_reaction_s 0: the gaze is
    # taken as moving with the menu, to test the rounds, not the reaction rule).
    rec = Recorder(early_decision=True, min_samples=5, dwell_s=0.0, window_s=5.0,
                   min_reaction_s=0.0)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    rec.feed(at(RIGHT, 10), 11.0, now=11.2)
    assert rec.labels == ['B']
    decision = rec.rounds.add_regions(squares({'t1': LEFT, 't2': RIGHT}, 11.0), now=11.2)
    assert decision is not None and rec.labels == ['B', 't2']
    assert rec.logs.count(('warning', 'late_regions')) == 1


def test_lagging_new_menu_with_reorder_the_old_round_makes_no_choice():
    rec = Recorder(early_decision=True, min_samples=5, dwell_s=0.0, reorder_s=0.5,
                   window_s=5.0, min_reaction_s=0.0)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    rec.feed(at(RIGHT, 10), 11.0, now=11.2)
    assert rec.labels == []  # held: regions newer than 10.0 may still come
    rec.rounds.add_regions(squares({'t1': LEFT, 't2': RIGHT}, 11.0), now=11.2)
    # The old round had no sample before 11.0: replaced without a choice; the
    # new round decided on the samples and waits for regions newer than them.
    assert rec.labels == [] and rec.rounds.rounds_started == 2
    assert rec.rounds.tick(11.71).label == 't2'
    assert rec.labels == ['t2']
    assert ('warning', 'late_regions') not in rec.logs


def test_out_of_order_samples_decide_as_in_order_ones():
    rng = np.random.default_rng(5)
    points = np.vstack([rng.normal(LEFT, 20, (30, 2)), rng.normal(RIGHT, 20, (20, 2))])
    outcomes = []
    for order in (np.arange(50), rng.permutation(50)):
        rec = Recorder(window_s=0.5, method='vote')
        rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
        for k in order:
            rec.rounds.add_sample(10.0 + (k + 0.5) / RATE_HZ, *points[k], now=10.5)
        rec.rounds.add_sample(10.6, 0.0, 0.0, now=10.6)
        outcomes.append((rec.labels, rec.decisions[0].counts, rec.decisions[0].samples_used))
    assert outcomes[0] == outcomes[1] == (['A'], {'A': 30, 'B': 20}, 50)


def test_new_choices_replace_an_unfinished_round_without_a_choice():
    rec = Recorder()
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    rec.feed(at(LEFT, 30), 10.0)
    rec.rounds.add_regions(squares({'C': LEFT}, 10.4), now=10.4)
    assert rec.labels == [] and rec.rounds.rounds_started == 2
    rec.feed(at(LEFT, 101), 10.4)
    assert rec.labels == ['C']


def test_request_starts_a_round_and_settings_change_the_open_round():
    rec = Recorder(early_decision=True, min_samples=50, dwell_s=0.0, min_reaction_s=0.0)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    rec.feed(at(LEFT, 5), 10.0)
    rec.rounds.configure(min_samples=8)
    assert rec.feed(at(LEFT, 5), 10.05) == 2  # the 8th sample on A
    rec.rounds.request(now=11.0)
    assert rec.rounds.rounds_started == 2 and rec.rounds.round_open
    assert rec.feed(at(RIGHT, 10), 11.0) == 7
    assert rec.labels == ['A', 'B']


def test_bad_settings_raise():
    with pytest.raises(ValueError, match='method'):
        ArbiterSettings(method='median')
    with pytest.raises(ValueError, match='window_s'):
        ArbiterSettings(window_s=0.0)
    with pytest.raises(ValueError, match='reorder_s'):
        RoundScheduler().configure(reorder_s=-1.0)


def test_early_decision_defaults_ignore_a_gaze_resting_on_an_option_of_the_new_menu():
    # The real task: the room was chosen on the left; the tables appear and
    # one of them (t1) lies where the gaze still rests.  The person reacts
    # after 200 ms and looks at t2.  early_decision alone, defaults otherwise.
    outcomes = {}
    for min_reaction_s in (ArbiterSettings().min_reaction_s, 0.0):
        rec = Recorder(early_decision=True, min_reaction_s=min_reaction_s, **ORIGINAL_RULE)
        rec.rounds.add_regions(squares({'t1': LEFT, 't2': RIGHT}, 20.0), now=20.0)
        decided = rec.feed(np.vstack([at(LEFT, 20), at(RIGHT, 30)]), 20.0)
        outcomes[min_reaction_s] = (rec.labels, decided)
    assert ArbiterSettings().min_reaction_s == pytest.approx(0.1)
    # Decided on t2 by the third sample there (0.02 s dwell at 100 Hz).
    assert outcomes[0.1] == (['t2'], 22)
    # Without the rule the resting gaze chooses t1 within two samples.
    assert outcomes[0.0] == (['t1'], 2)


def test_min_reaction_setting_is_validated():
    with pytest.raises(ValueError, match='min_reaction_s'):
        ArbiterSettings(min_reaction_s=-0.1)
    with pytest.raises(ValueError, match='min_reaction_s'):
        RoundScheduler().configure(min_reaction_s=2.5)


# -- implausible stamps and values -------------------------------------------------------------


def test_one_sample_stamped_far_in_the_future_does_not_end_the_round():
    rec = Recorder(window_s=0.5)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    # A corrupt stamp an hour ahead, then the person looks at B.
    assert rec.rounds.add_sample(3610.0, *LEFT, now=10.01) is None
    assert rec.rounds.round_open and rec.labels == []
    assert rec.rounds.samples_from_future == 1
    assert ('warning', 'gaze_future') in rec.logs
    assert rec.feed(at(RIGHT, 60), 10.0) == 50
    assert rec.labels == ['B'] and rec.decisions[0].samples_used == 50
    # Nor does it end the next round, which takes the recent samples stamped after its start.
    rec.rounds.add_regions(squares({'C': LEFT, 'D': RIGHT}, 10.6), now=10.6)
    assert rec.rounds.round_open
    assert rec.feed(at(LEFT, 60), 10.6) == 50
    assert rec.labels == ['B', 'C']


def test_a_stamp_a_little_ahead_of_arrival_is_taken():
    # Within max_future_s (a tracker clock slightly ahead): the sample is gaze like any other.
    rec = Recorder(window_s=0.5, max_future_s=0.3)
    rec.rounds.add_regions(squares({'A': LEFT}, 10.0), now=10.0)
    rec.rounds.add_sample(10.25, *LEFT, now=10.0)
    rec.rounds.add_sample(10.31, *LEFT, now=10.0)
    assert rec.rounds.samples_from_future == 1
    assert rec.rounds.add_sample(10.6, *LEFT, now=10.6).samples_used == 1


def test_samples_stamped_long_before_the_round_start_are_dropped_and_counted():
    rec = Recorder(window_s=1.0)
    rec.rounds.add_regions(squares({'A': LEFT}, 10.0), now=10.0)
    # Just before the round (a little late): ignored as before, not an error.
    rec.rounds.add_sample(9.5, *LEFT, now=10.1)
    assert rec.rounds.samples_too_old == 0 and rec.logs.count(('warning', 'gaze_too_old')) == 0
    # More than window_s before the round start: no round can use it.
    rec.rounds.add_sample(8.9, *LEFT, now=10.1)
    rec.rounds.add_sample(-1e6, *LEFT, now=10.1)
    assert rec.rounds.samples_too_old == 2 and ('warning', 'gaze_too_old') in rec.logs
    assert rec.rounds.samples_received == 3
    assert rec.feed(at(LEFT, 101), 10.0) == 100
    assert rec.labels == ['A'] and rec.decisions[0].samples_used == 100
    # Between rounds the bound is two windows before now (a round may start one in the past).
    rec.rounds.add_sample(9.95, *LEFT, now=12.0)
    rec.rounds.add_sample(10.05, *LEFT, now=12.0)
    assert rec.rounds.samples_too_old == 3


def test_nan_and_infinite_gaze_are_counted_and_never_evidence():
    rec = Recorder(window_s=0.5, method='vote', **ORIGINAL_RULE)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    bad = [(np.nan, np.nan), (np.nan, 500.0), (np.inf, 500.0), (300.0, -np.inf)] * 5
    points = np.vstack([at(LEFT, 10), bad, at(RIGHT, 5), at((900.0, 900.0), 16)])
    assert rec.feed(points, 10.0) == 50
    decision = rec.decisions[0]
    assert decision.label == 'A'
    assert decision.samples_used == 50 and decision.in_region_samples == 15
    assert decision.counts == {'A': 10, 'B': 5}
    assert rec.rounds.samples_not_finite == 20
    assert rec.logs.count(('warning', 'gaze_not_finite')) == 20  # the node throttles them
    # NaN alone chooses nothing.
    rec.rounds.request(now=11.0)
    rec.feed(np.vstack([at((np.nan, np.nan), 50), at(LEFT, 1)]), 11.0)
    assert rec.labels == ['A', None] and rec.decisions[1].samples_used == 50


def test_non_finite_stamps_and_max_future_are_validated():
    rounds = RoundScheduler()
    with pytest.raises(ValueError, match='finite'):
        rounds.add_sample(np.nan, 1.0, 1.0, now=10.0)
    with pytest.raises(ValueError, match='finite'):
        rounds.add_sample(10.0, 1.0, 1.0, now=np.inf)
    assert rounds.samples_received == 0
    with pytest.raises(ValueError, match='max_future_s'):
        ArbiterSettings(max_future_s=-0.1)
    with pytest.raises(ValueError, match='max_future_s'):
        rounds.configure(max_future_s=1e6)


def test_an_older_regions_set_arriving_late_does_not_withdraw_the_offered_choices():
    """DDS can deliver a latched older set after a newer one: the newer set stays offered."""
    rec = Recorder(window_s=0.5)
    rec.rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    rec.rounds.add_regions(squares({}, 9.0), now=10.01)
    assert rec.rounds.rounds_started == 1 and rec.rounds.round_open
    assert ('warning', 'regions_order') in rec.logs
    rec.feed(at(RIGHT, 60), 10.0)
    assert rec.labels == ['B']


def test_the_change_count_moves_with_every_input_and_not_with_questions():
    # The feedback asks progress() and label_at() again only when it moved.
    rec = Recorder(window_s=0.5, stall_timeout_s=0.2)
    rounds = rec.rounds
    seen = [rounds.changes]

    def moved():
        seen.append(rounds.changes)
        return seen[-1] != seen[-2]

    rounds.add_regions(squares({'A': LEFT, 'B': RIGHT}, 10.0), now=10.0)
    assert moved()
    rec.feed(at(LEFT, 10), start=10.0)
    assert moved()
    rounds.progress(), rounds.label_at(*LEFT), rounds.next_due(10.2), rounds.tick(10.2)
    assert not moved()
    # The stream goes quiet: the tick that closes the round moves it, the next does not.
    assert rounds.tick(10.8) is not None and moved()
    rounds.tick(10.9)
    assert not moved()
    rounds.request(now=11.0)
    assert moved()
    rounds.configure(window_s=0.4)
    assert moved()
