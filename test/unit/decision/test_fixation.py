"""The fixation rule (eye_bci_ros2.decision.fixation) on gaze shaped as real gaze is: pure."""

import math

import numpy as np
import pytest

from eye_bci_ros2.decision.fixation import FixationEvidence, REST_RADIUS_DEG
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, RoundScheduler
from eye_bci_ros2.experiments.trials import decide_trial
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING

SETTINGS = ArbiterSettings()
PPD = DEFAULT_VIEWING.px_per_degree()
SIZE = 100.0
CENTRES = {'left': np.array([760.0, 540.0]), 'middle': np.array([910.0, 540.0]),
           'right': np.array([1060.0, 540.0])}


def options(stamp=0.0, centres=CENTRES, size=SIZE):
    """Square options of ``size`` px around ``centres``."""
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float) * size / 2
    labels = list(centres)
    return RegionSet(labels, np.array([centres[label] + corners for label in labels]), stamp)


def path(segments, rate=60.0, noise_deg=0.3, seed=0):
    """
    Gaze of a person: ``segments`` of (duration s, start px, end px) joined in time.

    A segment with start == end is a fixation; otherwise the eye moves linearly
    (a saccade when short, pursuit when long).  Gaussian noise per axis.
    """
    rng = np.random.default_rng(seed)
    stamps, points, t = [], [], 0.0
    for duration, start, end in segments:
        count = max(int(round(duration * rate)), 1)
        share = (np.arange(count) + 0.5) / count
        stamps.append(t + share * duration)
        start, end = np.asarray(start, float), np.asarray(end, float)
        points.append(start + share[:, None] * (end - start))
        t += duration
    stamps, points = np.concatenate(stamps), np.concatenate(points)
    return stamps, points + rng.normal(0.0, noise_deg * PPD, points.shape)


def decide(stamps, points, settings=SETTINGS, regions=None, start=0.0):
    """Decide one round starting at ``start`` as the node does."""
    return decide_trial(points, stamps, regions or options(start), settings, start=start)


AWAY = np.array([400.0, 200.0])


def test_a_settled_fixation_on_an_option_is_chosen_once_it_lasted_dwell_s():
    stamps, points = path([(0.2, AWAY, AWAY), (0.04, AWAY, CENTRES['left']),
                           (0.7, CENTRES['left'], CENTRES['left'])])
    outcome = decide(stamps, points)
    assert outcome.label == 'left'
    assert outcome.decision.method == 'early'
    landed = 0.24
    assert landed + SETTINGS.dwell_s - 0.02 <= outcome.time_s <= landed + SETTINGS.dwell_s + 0.05


def test_a_transient_landing_on_a_neighbour_is_not_chosen_the_corrected_goal_is():
    # The saccade lands on 'middle' (overshoot) for 100 ms, then a corrective saccade
    # takes the eye to 'left': the count rule chose the transient landing.
    stamps, points = path([(0.2, AWAY, AWAY), (0.04, AWAY, CENTRES['middle']),
                           (0.1, CENTRES['middle'], CENTRES['middle']),
                           (0.02, CENTRES['middle'], CENTRES['left']),
                           (0.6, CENTRES['left'], CENTRES['left'])])
    for rate in (60.0, 1200.0):
        stamps, points = path([(0.2, AWAY, AWAY), (0.04, AWAY, CENTRES['middle']),
                               (0.1, CENTRES['middle'], CENTRES['middle']),
                               (0.02, CENTRES['middle'], CENTRES['left']),
                               (0.6, CENTRES['left'], CENTRES['left'])], rate=rate)
        assert decide(stamps, points).label == 'left', rate
        count_rule = SETTINGS.replace(method='mean', confidence=0.95, dwell_s=0.02)
        assert decide(stamps, points, count_rule).label == 'middle', rate


def test_a_gaze_resting_near_or_on_an_option_from_the_start_is_no_choice():
    near = CENTRES['left'] - [SIZE / 2 + 0.5 * PPD, 0.0]      # 0.5 deg outside its edge
    for where in (near, CENTRES['left']):
        stamps, points = path([(1.0, where, where)], seed=3)
        for early in (True, False):
            outcome = decide(stamps, points, SETTINGS.replace(early_decision=early))
            assert outcome.label is None, (where, early)
            assert 'rested' in outcome.decision.reason


def test_a_resting_gaze_that_moves_away_and_back_chooses():
    other = CENTRES['left'] + [0.0, 4 * PPD]
    stamps, points = path([(0.3, CENTRES['left'], CENTRES['left']),
                           (0.04, CENTRES['left'], other), (0.3, other, other),
                           (0.04, other, CENTRES['left']),
                           (0.5, CENTRES['left'], CENTRES['left'])])
    outcome = decide(stamps, points, SETTINGS.replace(window_s=1.2))
    assert outcome.label == 'left' and outcome.time_s > 0.68


def test_small_refixations_near_the_resting_place_are_still_the_resting_gaze():
    near = CENTRES['left'] - [SIZE / 2 + 0.3 * PPD, 0.0]
    shifted = near + [0.0, (REST_RADIUS_DEG - 0.5) * PPD]
    stamps, points = path([(0.4, near, near), (0.03, near, shifted), (0.6, shifted, shifted)])
    assert decide(stamps, points).label is None


def test_gaze_midway_between_two_options_or_far_from_all_is_no_choice():
    midway = (CENTRES['left'] + CENTRES['middle']) / 2
    far = CENTRES['right'] + [6 * PPD, 0.0]
    for target in (midway, far):
        stamps, points = path([(0.2, AWAY, AWAY), (0.04, AWAY, target),
                               (0.7, target, target)])
        outcome = decide(stamps, points)
        assert outcome.label is None, target


def test_spikes_and_a_tracker_switching_eyes_do_not_restart_or_move_the_fixation():
    stamps, points = path([(0.2, AWAY, AWAY), (0.04, AWAY, CENTRES['left']),
                           (0.7, CENTRES['left'], CENTRES['left'])], noise_deg=0.1)
    clean = decide(stamps, points)
    dirty = points.copy()
    landed = np.flatnonzero(stamps > 0.26)
    dirty[landed[2]] = CENTRES['right']                      # one-sample spike on another option
    dirty[landed[4]:landed[6]] += [0.0, 2.0 * PPD]          # two samples from the other eye
    outcome = decide(stamps, dirty)
    assert outcome.label == clean.label == 'left'
    assert outcome.time_s == pytest.approx(clean.time_s, abs=0.02)


def test_pursuit_across_an_option_is_not_a_choice_on_a_quiet_tracker():
    # The eye follows a thing moving at 15 deg/s through 'middle' (1200 Hz, 0.05 deg noise).
    start = CENTRES['middle'] - [8 * PPD, 2 * PPD]
    end = CENTRES['middle'] + [8 * PPD, 2 * PPD]
    stamps, points = path([(0.2, start, start), (16.5 / 15.0, start, end)], rate=1200.0,
                          noise_deg=0.05)
    assert decide(stamps, points, SETTINGS.replace(window_s=1.3)).label is None


def test_the_decision_does_not_depend_on_how_the_samples_are_batched():
    stamps, points = path([(0.2, AWAY, AWAY), (0.04, AWAY, CENTRES['right']),
                           (0.7, CENTRES['right'], CENTRES['right'])], rate=300.0, seed=5)
    whole = decide(stamps, points)
    for chunk in (1, 3, 17):
        split = decide_trial(points, stamps, options(), SETTINGS, chunk=chunk)
        assert (split.label, split.time_s) == (whole.label, whole.time_s), chunk


@pytest.mark.parametrize('confidence', [None, SETTINGS.confidence])
def test_batches_take_their_samples_exactly_as_one_at_a_time(confidence):
    # Runs of samples that join the fixation are added at once (FixationEvidence._join_run):
    # the decisions, the progress and every running sum are those of one sample at a time,
    # bit for bit, through spikes, lost samples, saccades and a decision.
    stamps, points = path([(0.3, AWAY, AWAY), (0.04, AWAY, CENTRES['middle']),
                           (0.15, CENTRES['middle'], CENTRES['middle']),
                           (0.03, CENTRES['middle'], CENTRES['left']),
                           (0.8, CENTRES['left'], CENTRES['left'])], rate=1200.0, seed=9)
    points[[50, 400, 401, 700]] = CENTRES['right']
    points[[90, 91, 650]] = np.nan
    rng = np.random.default_rng(4)

    def evidence():
        return FixationEvidence(0.0, DEFAULT_VIEWING, SETTINGS.sigma_gaze_deg, SETTINGS.dwell_s,
                                SETTINGS.min_samples, SETTINGS.min_reaction_s,
                                confidence=SETTINGS.confidence)

    def state(rule):
        current = rule._current
        return repr((rule.decision, rule.samples, rule.valid, rule.progress(),
                     [(f.first, f.last, f.count, f.fresh, f.stamps, f.sums_x, f.sums_y,
                       f.squares) for f in [current] + [d for d, _ in rule._done]]))

    single, batched = evidence(), evidence()
    start, runs = 0, 0
    while start < len(stamps):
        end = start + int(rng.integers(2, 90))
        for index in range(start, min(end, len(stamps))):
            single.add(points[index:index + 1], stamps[index:index + 1], options(), confidence)
        batched.add(points[start:end], stamps[start:end], options(), confidence)
        assert state(batched) == state(single), start
        start, runs = end, runs + 1
    assert repr(batched.decide()) == repr(single.decide())
    assert single.decide().label == 'left' and runs > 20


def test_a_label_shown_twice_pools_its_likelihood():
    twice = {'a': CENTRES['left'], 'a ': CENTRES['middle']}
    regions = RegionSet(['a', 'a'], options(centres=twice).polygons)
    midway = (CENTRES['left'] + CENTRES['middle']) / 2
    stamps, points = path([(0.2, AWAY, AWAY), (0.04, AWAY, midway), (0.7, midway, midway)])
    assert decide(stamps, points, regions=regions).label == 'a'


def test_the_node_scheduler_decides_with_the_fixation_rule_and_reports_progress():
    decisions = []
    scheduler = RoundScheduler(ArbiterSettings(), decisions.append)
    scheduler.add_regions(options(10.0), now=10.0)
    scheduler.request(now=10.0)
    stamps, points = path([(0.2, AWAY, AWAY), (0.04, AWAY, CENTRES['middle']),
                           (0.7, CENTRES['middle'], CENTRES['middle'])], rate=90.0)
    stamps = stamps + 10.0
    halfway = np.searchsorted(stamps, 10.3)
    scheduler.add_samples(stamps[:halfway], points[:halfway], now=stamps[halfway - 1])
    progress = scheduler.progress()
    assert set(progress) == set(CENTRES)
    assert 0.0 < progress['middle'] < 1.0 and progress['left'] == progress['right'] == 0.0
    scheduler.add_samples(stamps[halfway:], points[halfway:], now=stamps[-1])
    assert [d.label for d in decisions] == ['middle']


def test_the_rule_refuses_a_gaze_error_model_without_error():
    with pytest.raises(ValueError, match='gaze error'):
        FixationEvidence(0.0, DEFAULT_VIEWING, 0.0, dwell_s=0.1)


def test_settings_name_the_fixation_rule_and_its_error():
    assert SETTINGS.method == 'fixation' and SETTINGS.early_decision
    assert SETTINGS.sigma_gaze_deg == pytest.approx(math.hypot(0.8, 0.3))


def test_a_question_about_options_long_shown_takes_the_fixation_already_on_one():
    # The options appear at 10 s, the person looks at 'right' from 10.4 s; the menu asks
    # at 12 s (the camera has arrived): the gaze on 'right' is a reaction to the options.
    decisions = []
    scheduler = RoundScheduler(ArbiterSettings(), decisions.append)
    scheduler.add_regions(options(10.0), now=10.0)
    stamps, points = path([(0.4, AWAY, AWAY), (0.04, AWAY, CENTRES['right']),
                           (2.0, CENTRES['right'], CENTRES['right'])], rate=90.0)
    stamps = stamps + 10.0
    asked = int(np.searchsorted(stamps, 12.0))
    scheduler.add_samples(stamps[:asked], points[:asked], now=12.0)
    decisions.clear()     # the first round (the options' appearance) is not the question
    scheduler.request(now=12.0)
    scheduler.add_samples(stamps[asked:], points[asked:], now=stamps[-1])
    assert decisions and decisions[-1].label == 'right'


def test_options_that_appear_under_a_resting_gaze_are_not_chosen_when_asked_at_once():
    decisions = []
    scheduler = RoundScheduler(ArbiterSettings(window_s=0.8), decisions.append)
    stamps, points = path([(1.5, CENTRES['right'], CENTRES['right'])], rate=90.0)
    stamps = stamps + 10.0
    scheduler.add_samples(stamps[:40], points[:40], now=stamps[39])
    scheduler.add_regions(options(stamps[40]), now=stamps[40])   # a new menu: a round opens
    scheduler.add_samples(stamps[40:], points[40:], now=stamps[-1])
    scheduler.tick(now=stamps[-1] + 5.0)
    assert decisions and decisions[-1].label is None


def test_next_due_is_when_the_current_fresh_fixation_can_first_decide():
    """What the arbiter announces on choice/due: the fixation's first sample + dwell_s."""
    stamps, points = path([(0.3, AWAY, AWAY), (0.04, AWAY, CENTRES['left']),
                           (0.1, CENTRES['left'], CENTRES['left'])], rate=600.0)
    evidence = SETTINGS.evidence(0.0)
    evidence.add(points, stamps, options(), SETTINGS.confidence)
    due = evidence.next_due()
    # The landing on 'left' began after the saccade (0.34 s) and lasted 0.1 s < dwell_s.
    assert due is not None and 0.3 + SETTINGS.dwell_s < due < 0.36 + SETTINGS.dwell_s
    more_stamps, more_points = path([(0.3, CENTRES['left'], CENTRES['left'])], rate=600.0)
    decision = evidence.add(more_points, more_stamps + stamps[-1], options(),
                            SETTINGS.confidence)
    assert decision is not None and decision.label == 'left'
    assert evidence.next_due() is None          # decided: nothing more is due


def test_a_resting_gaze_is_never_due():
    stamps, points = path([(0.5, CENTRES['left'], CENTRES['left'])], rate=600.0)
    evidence = SETTINGS.evidence(0.0)
    evidence.add(points, stamps, options(), SETTINGS.confidence)
    assert evidence.next_due() is None


def _stop_options(stamp=0.0):
    """Return the drive step's one option, 'stop' (the arbiter's urgent_label)."""
    return options(stamp, {'stop': CENTRES['left']})


def test_a_gaze_resting_on_stop_chooses_it_as_fast_as_a_fresh_look():
    # Resting on 'stop' from before the round: chosen dwell_s into the round (the samples
    # since its start), as a look that lands on it at the start would be.
    resting = decide(*path([(1.0, CENTRES['left'], CENTRES['left'])]),
                     regions=_stop_options())
    assert resting.label == 'stop'
    fresh = decide(*path([(0.1, AWAY, AWAY), (0.04, AWAY, CENTRES['left']),
                          (0.86, CENTRES['left'], CENTRES['left'])]),
                   regions=_stop_options())
    assert fresh.label == 'stop'
    landed = 0.14   # when the fresh look's fixation began
    assert resting.time_s <= SETTINGS.dwell_s + 2 / 60 + 1e-9
    assert resting.time_s - 0.0 <= fresh.time_s - landed + 1e-9
    # At the window end too (early decision off), and only 'stop': another option waits.
    late = ArbiterSettings(early_decision=False)
    assert decide(*path([(1.0, CENTRES['left'], CENTRES['left'])]), late,
                  regions=_stop_options()).label == 'stop'
    other = decide(*path([(1.0, CENTRES['left'], CENTRES['left'])]),
                   regions=options(0.0, {'go': CENTRES['left']}))
    assert other.label is None and 'rested' in other.decision.reason
    # urgent_label '' restores "look away and back" for every option.
    none = decide(*path([(1.0, CENTRES['left'], CENTRES['left'])]),
                  ArbiterSettings(urgent_label=''), regions=_stop_options())
    assert none.label is None


def test_a_fresh_look_at_a_second_look_option_chooses_after_its_shorter_dwell():
    """'send' appears where the gaze was not: a fresh fixation on it decides sooner."""
    quick = ArbiterSettings(second_look_dwell_s=0.06)
    send_and_back = {'send': CENTRES['left'], 'back': CENTRES['right']}
    look = path([(0.2, AWAY, AWAY), (0.04, AWAY, CENTRES['left']),
                 (0.7, CENTRES['left'], CENTRES['left'])], rate=600.0)
    landed = 0.24
    second = decide(*look, quick, regions=options(0.0, send_and_back))
    assert second.label == 'send'
    assert landed + 0.06 - 0.02 <= second.time_s <= landed + 0.06 + 0.02
    # Any other option keeps dwell_s (a room, a table, 'back').
    other = decide(*look, quick, regions=options(0.0, {'table': CENTRES['left'],
                                                       'back': CENTRES['right']}))
    assert other.label == 'table' and other.time_s >= landed + quick.dwell_s - 0.02
    # A fixation on 'send' shorter than its dwell is no choice, at the window end too.
    short = path([(0.2, AWAY, AWAY), (0.04, AWAY, CENTRES['left']),
                  (0.04, CENTRES['left'], CENTRES['left']), (0.72, AWAY, AWAY)], rate=600.0)
    late = quick.replace(early_decision=False)
    assert decide(*short, late, regions=options(0.0, send_and_back)).label is None
    # A resting gaze on it still never chooses (a second look is a fresh one).
    resting = decide(*path([(1.0, CENTRES['left'], CENTRES['left'])]), quick,
                     regions=options(0.0, send_and_back))
    assert resting.label is None and 'rested' in resting.decision.reason
    # The default: 'go' and 'send' are the second looks.
    assert ArbiterSettings().second_look_labels.split() == ['go', 'send']
