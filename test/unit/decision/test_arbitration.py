"""Decision rules of eye_bci_ros2.decision.rounds on crafted gaze samples (no ROS)."""

from dataclasses import replace
import math

from batch_rules import decide_mean, decide_vote
import numpy as np
import pytest

from eye_bci_ros2.decision.evidence import posterior_from_counts, RoundEvidence
from eye_bci_ros2.decision.regions import RegionSet

RATE_HZ = 100.0


def square(cx, cy, half=50.0):
    """Axis-aligned square region around (cx, cy) px, as a (4, 2) polygon."""
    return [[cx - half, cy - half], [cx + half, cy - half],
            [cx + half, cy + half], [cx - half, cy + half]]


def two_regions(stamp=0.0, a=(200.0, 300.0), b=(800.0, 300.0)):
    """Regions A and B far apart on a 1920x1080 screen."""
    return RegionSet(['A', 'B'], [square(*a), square(*b)], stamp)


def around(centre, count, rng, spread=10.0):
    """Gaze samples scattered around a screen point, shape (count, 2) px."""
    return rng.normal(centre, spread, (count, 2))


def stamps(count, start=0.0):
    """Sample stamps at RATE_HZ from ``start``, shape (count,) s."""
    return start + np.arange(count) / RATE_HZ


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def test_classify_regions_and_outside():
    regions = two_regions()
    points = [[200, 300], [800, 340], [500, 300], [np.nan, 300], [249.0, 251.0]]
    assert regions.classify(points).tolist() == [0, 1, -1, -1, 0]
    assert [regions.classify_one(x, y) for x, y in points] == [0, 1, -1, -1, 0]


def test_overlap_goes_to_nearest_centroid():
    # Two overlapping squares centred at x = 0 and x = 60: a point in both
    # goes to the region whose centroid is nearer.
    regions = RegionSet(['left', 'right'], [square(0, 0, 100), square(60, 0, 50)])
    assert regions.classify([[70, 0], [40, 0], [15, 0], [-50, 0], [105, 0]]).tolist() == \
        [1, 1, 0, 0, 1]
    assert regions.classify_one(15, 0) == 0
    assert regions.classify_one(40, 0) == 1
    # An exact tie goes to the first listed.
    assert regions.classify_one(30, 0) == 0


def test_padded_polygon_centroid_is_area_centroid():
    # A triangle padded to 6 vertices (as the projector pads) keeps its area centroid.
    triangle = [[0, 0], [90, 0], [0, 90], [0, 90], [0, 90], [0, 90]]
    regions = RegionSet(['t'], [triangle])
    assert np.allclose(regions.centroids[0], [30, 30])


def test_empty_region_set_contains_nothing():
    regions = RegionSet([], np.zeros((0, 3, 2)))
    assert regions.classify([[1, 2], [3, 4]]).tolist() == [-1, -1]
    assert decide_mean([[1, 2]], regions).label is None


def test_bad_regions_and_points_raise():
    with pytest.raises(ValueError, match='labels'):
        RegionSet(['A'], [square(0, 0), square(5, 5)])
    with pytest.raises(ValueError, match='shape'):
        RegionSet(['A'], [[0, 0], [1, 1]])
    with pytest.raises(ValueError, match=r'\(N, 2\)'):
        two_regions().classify([[1, 2, 3]])
    with pytest.raises(ValueError, match='hit_rate'):
        RoundEvidence(hit_rate=0.4)
    with pytest.raises(ValueError, match='method'):
        RoundEvidence().decide('median')


def test_mean_and_vote_choose_the_looked_at_region(rng):
    regions = two_regions()
    points = np.vstack([around((800, 300), 80, rng), rng.uniform(0, 1920, (20, 2))])
    for decide in (decide_mean, decide_vote):
        decision = decide(points, regions)
        assert decision.label == 'B'
        assert decision.samples_used == 100
        assert decision.in_region_samples >= 80
        assert decision.margin > 0.8


def test_mean_between_regions_is_no_choice_but_vote_picks_the_majority(rng):
    # 60 % of the gaze on A and 40 % on B, far apart: the mean lies between them.
    regions = two_regions()
    points = np.vstack([around((200, 300), 60, rng), around((800, 300), 40, rng)])
    mean = decide_mean(points, regions)
    vote = decide_vote(points, regions)
    assert mean.label is None
    assert 'no region' in mean.reason
    assert 400 < mean.mean_point[0] < 600
    assert vote.label == 'A'
    assert vote.margin == pytest.approx(0.2)
    assert vote.counts == {'A': 60, 'B': 40}


def test_no_choice_without_in_region_samples(rng):
    regions = two_regions()
    outside = around((500, 700), 50, rng)
    for decide in (decide_mean, decide_vote):
        decision = decide(outside, regions)
        assert decision.label is None
        assert decision.in_region_samples == 0
        assert decision.reason == 'no sample in any region'
    evidence = RoundEvidence(0.0, min_samples=3)
    assert evidence.add(outside, stamps(50), regions, confidence=0.9) is None
    assert evidence.decide('vote').label is None
    assert evidence.decide('mean').label is None


def test_vote_tie_is_no_choice(rng):
    regions = two_regions()
    points = np.vstack([around((200, 300), 30, rng), around((800, 300), 30, rng)])
    assert decide_vote(points, regions).label is None


def test_mean_and_vote_are_order_invariant(rng):
    regions = two_regions()
    points = np.vstack([around((200, 300), 70, rng, spread=40), around((800, 300), 30, rng),
                        rng.uniform(0, 1920, (30, 2))])
    shuffled = rng.permutation(points)
    for decide in (decide_mean, decide_vote):
        one, other = decide(points, regions), decide(shuffled, regions)
        assert (one.label, one.counts, one.margin) == (other.label, other.counts, other.margin)
    assert np.allclose(decide_mean(points, regions).mean_point,
                       decide_mean(shuffled, regions).mean_point)


def test_round_evidence_matches_batch_rules_on_static_regions(rng):
    regions = two_regions()
    points = np.vstack([around((200, 300), 60, rng), around((800, 300), 40, rng),
                        rng.uniform(0, 1920, (20, 2))])
    evidence = RoundEvidence(0.0)
    for chunk in np.array_split(np.arange(len(points)), 7):
        evidence.add(points[chunk], stamps(len(points))[chunk], regions)
    for method, decide in (('mean', decide_mean), ('vote', decide_vote)):
        round_decision, batch = evidence.decide(method), decide(points, regions)
        assert round_decision.label == batch.label
        assert round_decision.counts == batch.counts
        assert np.allclose(round_decision.mean_point, batch.mean_point)
    assert evidence.decide('vote').time_to_decision == pytest.approx(119 / RATE_HZ)


def test_posterior_follows_the_hit_rate_model():
    counts = np.array([7, 3, 1])
    h, r = 0.8, len(counts)
    likelihood = h ** counts * ((1 - h) / (r - 1)) ** (counts.sum() - counts)
    assert np.allclose(posterior_from_counts(counts, h), likelihood / likelihood.sum())
    assert np.allclose(posterior_from_counts([0, 0], 0.9), [0.5, 0.5])
    assert posterior_from_counts([5], 0.9).tolist() == [1.0]


def test_early_decision_uses_fewer_samples_than_the_window(rng):
    regions = two_regions()
    window = int(RATE_HZ)  # 1 s of samples
    points = around((800, 300), window, rng)
    evidence = RoundEvidence(0.0, hit_rate=0.9, min_samples=10, dwell_s=0.2)
    decision = evidence.add(points, stamps(window), regions, confidence=0.99)
    assert decision is not None and decision.label == 'B' and decision.method == 'early'
    assert decision.samples_used < window / 2
    assert decision.posterior >= 0.99
    assert decision.time_to_decision < 1.0
    # The dwell is what bounds it here: 0.2 s of samples at 100 Hz.
    assert decision.samples_used == 21
    # Once decided the round keeps its decision.
    assert evidence.add(points, stamps(window, 1.0), regions, 0.99) is decision
    assert evidence.decide('mean') is decision


def test_early_decision_is_the_same_in_chunks_and_per_sample(rng):
    regions = two_regions()
    # A look at A, a wander, then B with every third sample elsewhere.
    points = np.vstack([around((200, 300), 8, rng), rng.uniform(0, 1000, (10, 2)),
                        around((800, 300), 60, rng)])
    points[20::3] = rng.uniform(0, 1920, (len(points[20::3]), 2))
    times = stamps(len(points))
    whole = RoundEvidence(0.0, min_samples=8, dwell_s=0.1)
    expected = whole.add(points, times, regions, confidence=0.99)
    assert expected.label == 'B' and 30 < expected.samples_used < len(points)
    for split in (1, 3, 11):
        evidence = RoundEvidence(0.0, min_samples=8, dwell_s=0.1)
        decision = None
        for chunk in np.array_split(np.arange(len(points)), len(points) // split):
            decision = evidence.add(points[chunk], times[chunk], regions, confidence=0.99)
            if decision is not None:
                break
        # Same choice at the same sample; sums may differ in the last bits.
        assert replace(decision, mean_point=None) == replace(expected, mean_point=None)
        assert np.allclose(decision.mean_point, expected.mean_point)


def test_saccade_across_a_region_does_not_choose_it(rng):
    # The gaze rests 0.15 s on B (where the previous menu was), crosses the
    # screen, then settles on A: a dwell of 0.2 s keeps B from being chosen.
    regions = two_regions()
    points = np.vstack([around((800, 300), 15, rng), [[600, 300], [400, 300]],
                        around((200, 300), 80, rng)])
    evidence = RoundEvidence(0.0, min_samples=5, dwell_s=0.2)
    decision = evidence.add(points, stamps(len(points)), regions, confidence=0.95)
    assert decision is not None and decision.label == 'A'
    # Without the dwell B's early lead would have chosen it.
    hasty = RoundEvidence(0.0, min_samples=5, dwell_s=0.0)
    assert hasty.add(points, stamps(len(points)), regions, confidence=0.95).label == 'B'


def test_out_of_region_samples_do_not_break_the_dwell(rng):
    regions = two_regions()
    points = around((200, 300), 40, rng)
    points[1::4] = [1000, 900]  # every fourth sample a blink or off-region glance
    evidence = RoundEvidence(0.0, min_samples=20, dwell_s=0.0)
    decision = evidence.add(points, stamps(40), regions, confidence=0.99)
    assert decision.label == 'A'
    assert decision.in_region_samples == 20
    assert decision.samples_used == 27


def test_moving_regions_classify_each_sample_with_its_own_regions(rng):
    # The camera pans: A and B slide 400 px left half-way through the round,
    # and the gaze follows A.  Evidence stays with the label.
    before = two_regions(0.0, a=(600, 300), b=(1200, 300))
    after = two_regions(0.5, a=(200, 300), b=(800, 300))
    first, second = around((600, 300), 50, rng), around((200, 300), 50, rng)
    evidence = RoundEvidence(0.0)
    evidence.add(first, stamps(50), before)
    evidence.add(second, stamps(50, 0.5), after)
    assert evidence.counts == {'A': 100, 'B': 0}
    assert evidence.decide('vote').label == 'A'
    mean = evidence.decide('mean')
    assert mean.label == 'A'
    # Carried with A, the mean lies in A's newest place, not between its two places.
    assert np.allclose(mean.mean_point, (200, 300), atol=5)
    # The naive mean of the raw positions lies between A's two places, in no region.
    naive = np.vstack([first, second]).mean(axis=0)
    assert after.classify_one(*naive) == -1 and before.classify_one(*naive) == -1


def test_batch_classification_is_fast_enough_for_the_benchmark(rng):
    # Vectorised path: a million samples classify without a Python loop per sample.
    regions = two_regions()
    points = rng.uniform(0, 1920, (1_000_000, 2))
    region = regions.classify(points)
    inside_a = (np.abs(points - (200, 300)) <= 50).all(axis=1)
    assert np.array_equal(region == 0, inside_a)
    assert math.isfinite(decide_vote(points, regions).margin)


def resting_on_b_then_a(rng, latency_s=0.2):
    """Gaze on B from the round start, a saccade after ``latency_s``, then on A."""
    resting = int(round(latency_s * RATE_HZ))
    return np.vstack([around((800, 300), resting, rng), [[500, 300]],
                      around((200, 300), 60, rng)])


def early_settings(**changed):
    """Return the node's default early-decision settings with ``changed`` ones."""
    settings = {'min_samples': 2, 'dwell_s': 0.02, 'min_reaction_s': 0.1, 'hit_rate': 0.9}
    settings.update(changed)
    return settings


def test_gaze_resting_on_a_target_at_the_start_is_not_chosen_early(rng):
    # The new menu appears with the gaze on B (where the previous menu was);
    # 200 ms later the person looks at A, the option they want.
    regions = two_regions()
    points = resting_on_b_then_a(rng)
    evidence = RoundEvidence(0.0, **early_settings())
    decision = evidence.add(points, stamps(len(points)), regions, confidence=0.95)
    assert decision is not None and decision.label == 'A' and decision.method == 'early'
    # Chosen on the first fresh samples on A: the saccade lands at 0.21 s,
    # 3 samples at 100 Hz span the 0.02 s dwell.
    assert decision.time_to_decision == pytest.approx(0.23)
    assert decision.fresh_samples == 3 and decision.in_region_samples == 23
    assert decision.counts == {'A': 3, 'B': 20}
    assert decision.posterior >= 0.95  # of the fresh evidence it weighed
    assert evidence.fresh_counts == {'A': 3, 'B': 0}


def test_min_reaction_zero_restores_the_old_rule_that_takes_the_resting_target(rng):
    regions = two_regions()
    points = resting_on_b_then_a(rng)
    old = RoundEvidence(0.0, **early_settings(min_reaction_s=0.0))
    decision = old.add(points, stamps(len(points)), regions, confidence=0.95)
    assert decision.label == 'B' and decision.time_to_decision < 0.1
    # Exactly the rule without the fresh-evidence test: same sample, same evidence.
    assert decision.fresh_samples == decision.in_region_samples == 3


def test_resting_target_counts_again_once_the_gaze_came_back_to_it(rng):
    # On B from the start, a glance at A too short for the dwell, back to B:
    # the return to B is a new fixation, a reaction to the menu.
    regions = two_regions()
    points = np.vstack([around((800, 300), 20, rng), around((200, 300), 1, rng),
                        around((800, 300), 40, rng)])
    evidence = RoundEvidence(0.0, **early_settings())
    decision = evidence.add(points, stamps(len(points)), regions, confidence=0.95)
    assert decision.label == 'B' and decision.time_to_decision == pytest.approx(0.23)


def test_gaze_staying_on_the_resting_target_is_decided_at_the_window_end(rng):
    # Never left B: no fresh evidence, no early choice; the window rule, on
    # every sample, still chooses B.
    regions = two_regions()
    points = around((800, 300), 100, rng)
    evidence = RoundEvidence(0.0, **early_settings())
    assert evidence.add(points, stamps(100), regions, confidence=0.95) is None
    assert evidence.fresh == 0 and evidence.in_region == 100
    assert evidence.early(0.95) is None
    without_rule = RoundEvidence(0.0, **early_settings(min_reaction_s=0.0))
    without_rule.add(points, stamps(100), regions)
    assert without_rule.early(0.95).label == 'B'
    assert evidence.decide('mean').label == 'B'
    assert evidence.decide('mean').posterior > 0.99


def test_window_rules_use_every_sample_whatever_min_reaction(rng):
    regions = two_regions()
    points = resting_on_b_then_a(rng, latency_s=0.45)  # 46 samples near B, 60 on A
    decided = []
    for min_reaction_s in (0.0, 0.1, 2.0):
        for method in ('mean', 'vote'):
            evidence = RoundEvidence(0.0, min_reaction_s=min_reaction_s)
            evidence.add(points, stamps(len(points)), regions)
            decision = evidence.decide(method)
            decided.append((method, decision.label, decision.counts, decision.posterior))
    assert decided[:2] == decided[2:4] == decided[4:]
    assert decided[1][1] == 'A' and decided[1][2] == {'A': 60, 'B': 45}


def test_min_reaction_must_be_between_zero_and_two_seconds():
    for bad in (-0.01, 2.5, math.nan):
        with pytest.raises(ValueError, match='min_reaction_s'):
            RoundEvidence(0.0, min_reaction_s=bad)
