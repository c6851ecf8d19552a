"""The tolerant rule and the share test in the arbiter's core (RoundEvidence, RoundScheduler)."""

import math

from batch_rules import decide_mean
import numpy as np
import pytest

from bench import decision, tolerance
from eye_bci_ros2.decision.evidence import EARLY_SHARE_S, RoundEvidence
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, COUNT_RULE, ORIGINAL_RULE, RoundScheduler
from eye_bci_ros2.decision.tolerance import TolerantRegions
from eye_bci_ros2.sim.person import ORIGINAL_TOBII_4C

RATE_HZ = 100.0
#: Two small (16 px) options 300 px apart near the centre of the default screen, where
#: the default tolerance is 74 px (66 px beyond the edge of a 16 px option, size-aware).
SMALL, OTHER = (960.0, 540.0), (1260.0, 540.0)
#: 30 px beyond SMALL's right edge: within the tolerance, far nearer SMALL than OTHER.
JUST_OUTSIDE = (960.0 + 8.0 + 30.0, 540.0)
#: Two small options 100 px apart and the point midway between them (42 px from each edge).
LEFT_PAIR, RIGHT_PAIR = (960.0, 540.0), (1060.0, 540.0)
MIDWAY = (1010.0, 540.0)
FAR = (200.0, 900.0)


def squares(layout, stamp=0.0, side=16.0):
    """Region set: ``layout`` maps label -> (x, y) centre of a ``side`` px square."""
    half = side / 2.0
    polygons = [[[x - half, y - half], [x + half, y - half], [x + half, y + half],
                 [x - half, y + half]] for x, y in layout.values()]
    return RegionSet(list(layout), polygons, stamp)


def near(point, count, rng, spread=3.0):
    """``count`` samples around a screen point (px)."""
    return rng.normal(point, spread, (count, 2))


def run_round(points, layout, start=10.0, **settings):
    """One round of a scheduler opened by ``layout``; return its decision."""
    decisions = []
    scheduler = RoundScheduler(ArbiterSettings(**{**COUNT_RULE, **settings}), decisions.append)
    scheduler.add_regions(squares(layout, start), now=start)
    stamps = start + (np.arange(len(points)) + 0.5) / RATE_HZ
    scheduler.add_samples(stamps, points, now=stamps[-1])
    scheduler.tick(now=start + 10.0)
    assert len(decisions) == 1
    return decisions[0]


def test_default_is_the_size_aware_tolerant_rule_with_the_share_test():
    settings = ArbiterSettings()
    assert (settings.classification, settings.size_aware, settings.ratio,
            settings.min_share) == ('tolerant', True, 0.5, 0.5)
    assert (settings.accuracy_deg, settings.precision_deg, settings.k_sigma) == (0.8, 0.3, 2.0)
    assert (settings.screen_width, settings.screen_height) == (1920, 1080)
    assert settings.screen.distance_mm == 650.0
    assert isinstance(settings.regions(squares({'a': SMALL})), TolerantRegions)
    original = ArbiterSettings(**ORIGINAL_RULE)
    plain = squares({'a': SMALL})
    assert original.regions(plain) is plain
    assert type(original.regions(settings.regions(plain))) is RegionSet


def test_a_sample_just_outside_a_small_option_counts_for_it():
    layout = {'small': SMALL, 'other': OTHER}
    tolerant = ArbiterSettings().regions(squares(layout))
    inside = ArbiterSettings(**ORIGINAL_RULE).regions(squares(layout))
    assert tolerant.classify_one(*JUST_OUTSIDE) == 0
    assert inside.classify_one(*JUST_OUTSIDE) == -1
    # Beyond the tolerance it counts for none.
    assert tolerant.classify_one(960.0 + 8.0 + 90.0, 540.0) == -1


def test_a_sample_midway_between_two_options_counts_for_none():
    tolerant = ArbiterSettings().regions(squares({'l': LEFT_PAIR, 'r': RIGHT_PAIR}))
    assert tolerant.classify_one(*MIDWAY) == -1
    # Clearly nearer one of them (10 px from its edge, 74 from the other's): counts for it.
    assert tolerant.classify_one(LEFT_PAIR[0] + 18.0, 540.0) == 0


@pytest.mark.parametrize('early', [False, True])
def test_early_and_window_end_decisions_are_both_tolerant(early):
    rng = np.random.default_rng(1)
    # A reaction (0.2 s off the options), then the gaze rests just outside the small option.
    points = np.vstack([near(FAR, 20, rng), near(JUST_OUTSIDE, 100, rng)])
    layout = {'small': SMALL, 'other': OTHER}
    decision = run_round(points, layout, early_decision=early)
    assert decision.label == 'small', decision.summary()
    assert decision.method == ('early' if early else 'mean')
    if early:
        assert decision.time_to_decision < 0.5
    original = run_round(points, layout, early_decision=early, **ORIGINAL_RULE)
    assert original.label is None and original.reason == 'no sample in any region'


@pytest.mark.parametrize('early', [False, True])
def test_gaze_resting_midway_between_two_options_chooses_nothing(early):
    rng = np.random.default_rng(2)
    decision = run_round(near(MIDWAY, 110, rng, spread=6.0),
                         {'l': LEFT_PAIR, 'r': RIGHT_PAIR}, early_decision=early)
    assert decision.label is None, decision.summary()


def test_the_share_test_refuses_a_window_whose_gaze_was_mostly_elsewhere():
    rng = np.random.default_rng(3)
    # 30 % of the window on the option, 70 % off every option (interleaved in time).
    points = np.vstack([near(SMALL, 30, rng), near(FAR, 70, rng)])[rng.permutation(100)]
    layout = {'small': SMALL, 'other': OTHER}
    refused = run_round(np.vstack([points, near(FAR, 5, rng)]), layout)
    assert refused.label is None
    assert 'min_share 0.5' in refused.reason and "'small'" in refused.reason, refused.reason
    assert refused.counts == {'small': 30, 'other': 0}
    # The same window without the share test chooses the option (as the original does).
    assert run_round(points, layout, min_share=0.0).label == 'small'
    assert run_round(points, layout, **ORIGINAL_RULE).label == 'small'
    # With 60 % on the option it passes.
    most = np.vstack([near(SMALL, 60, rng), near(FAR, 40, rng)])[rng.permutation(100)]
    assert run_round(most, layout).label == 'small'


def test_the_early_share_test_waits_for_the_recent_samples_to_be_on_the_option():
    rng = np.random.default_rng(4)
    layout = {'small': SMALL, 'other': OTHER}
    points = np.vstack([near(FAR, 20, rng), near(SMALL, 80, rng)])
    with_share = run_round(points, layout, early_decision=True)
    without = run_round(points, layout, early_decision=True, min_share=0.0)
    assert with_share.label == without.label == 'small'
    assert with_share.method == without.method == 'early'
    # dwell_s 0.02 at 100 Hz decides 2 samples after arrival; the share test needs 0.8 of
    # the last 0.1 s (8 of 10 samples) on the option.
    assert without.time_to_decision == pytest.approx(0.225, abs=1e-9)
    assert with_share.time_to_decision == pytest.approx(0.275, abs=1e-9)


def test_the_early_share_test_is_the_same_in_any_batches():
    rng = np.random.default_rng(5)
    regions = ArbiterSettings().regions(squares({'small': SMALL, 'other': OTHER}))
    points = np.vstack([near(FAR, 45, rng), near(OTHER, 3, rng), near(JUST_OUTSIDE, 60, rng)])
    points[60:65] = np.nan          # a blink: not valid, not counted in the share
    stamps = (np.arange(len(points)) + 0.5) / 300.0
    made = []
    for chunk in (len(points), 7, 1):
        evidence = RoundEvidence(0.0, min_samples=2, dwell_s=0.02, min_reaction_s=0.1,
                                 min_share=0.5)
        decision = None
        for lo in range(0, len(points), chunk):
            decision = evidence.add(points[lo:lo + chunk], stamps[lo:lo + chunk], regions, 0.95)
            if decision is not None:
                break
        assert decision is not None and decision.label == 'small'
        made.append(decision.time_to_decision)
        # The history it keeps spans at most the share window.
        assert np.ptp(evidence._recent_stamps) < EARLY_SHARE_S
    assert made[0] == made[1] == made[2]


def test_the_original_rule_decides_as_the_batch_rule():
    rng = np.random.default_rng(6)
    layout = {'a': (300.0, 500.0), 'b': (1500.0, 500.0)}
    big = squares(layout, 10.0, side=200.0)
    for trial in range(20):
        share = rng.uniform(0.2, 0.8)
        count = int(100 * share)
        points = np.vstack([near(layout['a'], count, rng, 40.0),
                            near(layout['b'], 100 - count, rng, 40.0),
                            rng.uniform(0, 1900, (10, 2))])[:100]
        points = points[rng.permutation(len(points))]
        expected = decide_mean(points, big)
        decisions = []
        scheduler = RoundScheduler(ArbiterSettings(**COUNT_RULE, **ORIGINAL_RULE),
                                   decisions.append)
        scheduler.add_regions(big, now=10.0)
        stamps = 10.0 + (np.arange(100) + 0.5) / RATE_HZ
        scheduler.add_samples(stamps, points, now=11.0)
        scheduler.add_sample(11.5, math.nan, math.nan, now=11.5)
        assert decisions[0].label == expected.label, trial
        assert decisions[0].counts == expected.counts


def test_a_rule_change_applies_from_the_next_round_on():
    rng = np.random.default_rng(7)
    decisions = []
    scheduler = RoundScheduler(ArbiterSettings(**COUNT_RULE, window_s=0.5), decisions.append)
    scheduler.add_regions(squares({'small': SMALL, 'other': OTHER}, 10.0), now=10.0)
    stamps = 10.0 + (np.arange(30) + 0.5) / RATE_HZ
    scheduler.add_samples(stamps, near(JUST_OUTSIDE, 30, rng), now=10.3)
    scheduler.configure(classification='inside', window_s=0.4)
    # The open round keeps its rule (tolerant) but takes the new window.
    assert scheduler.add_sample(10.45, *JUST_OUTSIDE, now=10.45).label == 'small'
    assert decisions[-1].samples_used == 30
    scheduler.request(now=11.0)
    stamps = 11.0 + (np.arange(50) + 0.5) / RATE_HZ
    scheduler.add_samples(stamps, near(JUST_OUTSIDE, 50, rng), now=11.5)
    assert decisions[-1].label is None and len(decisions) == 2
    assert scheduler.classifier.classify_one(*JUST_OUTSIDE) == -1


def test_feedback_state_label_at_and_progress():
    rng = np.random.default_rng(8)
    scheduler = RoundScheduler(ArbiterSettings(**dict(COUNT_RULE, window_s=1.0)))
    assert scheduler.label_at(*JUST_OUTSIDE) is None and scheduler.progress() == {}
    scheduler.add_regions(squares({'small': SMALL, 'other': OTHER}, 10.0), now=10.0)
    assert scheduler.label_at(*JUST_OUTSIDE) == 'small'
    between = ((SMALL[0] + OTHER[0]) / 2.0, 540.0)
    assert scheduler.label_at(*between) is None and scheduler.label_at(math.nan, 1.0) is None
    # 0.2 s off the options (a reaction), then 0.5 s just outside the small one.
    stamps = 10.0 + (np.arange(70) + 0.5) / RATE_HZ
    scheduler.add_samples(stamps, np.vstack([near(FAR, 20, rng), near(JUST_OUTSIDE, 50, rng)]),
                          now=10.7)
    evidence = scheduler.evidence
    assert evidence.run_label == 'small' and evidence.run_count == 50 and evidence.run_fresh
    assert evidence.run_start == pytest.approx(10.205) and evidence.last_label == 'small'
    assert evidence.elapsed == pytest.approx(0.695)
    # Window rules: the time elapsed times the share of the samples so far.
    progress = scheduler.progress()
    assert progress['small'] == pytest.approx(0.695 * 50 / 70) and progress['other'] == 0.0
    # With the early decision on, its progress (the run towards min_samples) shows.
    scheduler.configure(early_decision=True, min_samples=60, dwell_s=0.1)
    assert scheduler.progress()['small'] == pytest.approx(50 / 60)
    assert scheduler.progress()['other'] == 0.0


@pytest.mark.parametrize('changed, name', [
    ({'classification': 'near'}, 'classification'), ({'ratio': 0.0}, 'ratio'),
    ({'min_share': 1.5}, 'min_share'), ({'k_sigma': 40.0}, 'k_sigma'),
    ({'k_sigma': 10.0, 'accuracy_deg': 10.0}, 'tolerance'),
    ({'accuracy_deg': -1.0}, 'accuracy_deg'), ({'viewing_distance_mm': 0.0}, 'distance_mm'),
    ({'screen_width': 0}, 'screen_width')])
def test_bad_rule_settings_raise_with_a_reason(changed, name):
    with pytest.raises(ValueError, match=name):
        ArbiterSettings(**changed)


def test_the_count_rule_is_the_benchmarks_size_mean_share_rule():
    bench_rule = tolerance.settings_for('size_mean/s', decision.COUNT_EARLY, ORIGINAL_TOBII_4C)
    default = ArbiterSettings(**COUNT_RULE)
    for name in ('classification', 'ratio', 'size_aware', 'min_share', 'k_sigma', 'method'):
        assert getattr(bench_rule, name) == getattr(default, name), name
    original = tolerance.settings_for('mean', decision.COUNT_EARLY, ORIGINAL_TOBII_4C)
    assert {name: getattr(original, name) for name in ORIGINAL_RULE} == ORIGINAL_RULE


def test_a_menu_is_classified_once_for_every_round_and_anew_when_the_rule_changes():
    """The tolerant classifier of a shown menu is reused by later rounds, never a stale one."""
    regions = squares({'a': SMALL, 'b': OTHER})
    settings = ArbiterSettings()
    first = settings.regions(regions)
    assert isinstance(first, TolerantRegions)
    assert settings.regions(regions) is first
    assert ArbiterSettings().regions(regions) is first     # the same rule, another round
    wider = ArbiterSettings(accuracy_deg=settings.accuracy_deg * 3.0)
    assert wider.regions(regions) is not first
    # 30 px beyond SMALL's edge counts for it under the default rule; under 'inside' not.
    assert first.classify_one(*JUST_OUTSIDE) == 0
    inside = ArbiterSettings(classification='inside').regions(regions)
    assert inside.classify_one(*JUST_OUTSIDE) == -1
    assert settings.regions(squares({'a': SMALL, 'b': OTHER})) is not first
