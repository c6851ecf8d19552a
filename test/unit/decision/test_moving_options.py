"""The early decision while the options still move (the camera on its way): no hasty choice."""

import numpy as np

from eye_bci_ros2.decision.evidence import RoundEvidence
from eye_bci_ros2.decision.regions import RegionSet


def square(x, y, size=80.0):
    half = size / 2
    return [[x - half, y - half], [x + half, y - half], [x + half, y + half],
            [x - half, y + half]]


def sliding_sets(until=0.5, step=0.02):
    """Option 'a' slides from x 200 to x 960 px by ``until``; 'b' stays at x 1400."""
    sets = []
    for t in np.arange(0.0, until + step / 2, step):
        x = 200.0 + (960.0 - 200.0) * min(t / until, 1.0)
        sets.append(RegionSet(['a', 'b'], [square(x, 540.0), square(1400.0, 540.0)], t))
    return sets


def feed(evidence, sets, stamps, points):
    """Add samples batch by batch, each with the set shown at its stamp; return the decision."""
    shown = np.maximum(np.searchsorted([s.stamp for s in sets], stamps, side='right') - 1, 0)
    for index in range(len(stamps)):
        made = evidence.add(points[index:index + 1], stamps[index:index + 1],
                            sets[shown[index]], confidence=0.95)
        if made is not None:
            return made
    return None


def test_an_option_sliding_under_a_resting_gaze_is_not_chosen_early():
    stamps = np.arange(0.0, 0.6, 1 / 120)
    points = np.tile([960.0, 540.0], (len(stamps), 1))   # the gaze rests where 'a' arrives
    moving = feed(RoundEvidence(0.0, min_samples=2, min_reaction_s=0.1), sliding_sets(),
                  stamps, points)
    assert moving is None
    # One jump of the outlines is a moved display too: the option now under the gaze was
    # not looked at.
    jumped = [RegionSet(['a', 'b'], [square(200.0, 540.0), square(1400.0, 540.0)], 0.0),
              RegionSet(['a', 'b'], [square(960.0, 540.0), square(1400.0, 540.0)], 0.3)]
    assert feed(RoundEvidence(0.0, min_samples=2, min_reaction_s=0.1), jumped, stamps,
                points) is None
    # Control: the options stand still and the gaze moves onto 'a' at 0.3 s: chosen early.
    still = [RegionSet(['a', 'b'], [square(960.0, 540.0), square(1400.0, 540.0)], 0.0)]
    looked = points.copy()
    looked[stamps < 0.3] = [100.0, 100.0]
    made = feed(RoundEvidence(0.0, min_samples=2, min_reaction_s=0.1), still, stamps, looked)
    assert made is not None and made.label == 'a' and made.method == 'early'


def test_after_the_options_stop_a_new_fixation_decides_early():
    sets = sliding_sets()
    stamps = np.arange(0.0, 1.0, 1 / 120)
    points = np.tile([960.0, 540.0], (len(stamps), 1))
    points[stamps >= 0.7] = [1400.0, 540.0]                # a saccade to 'b' after the move
    made = feed(RoundEvidence(0.0, min_samples=2, min_reaction_s=0.1), sets, stamps, points)
    assert made is not None and made.label == 'b' and made.method == 'early'
    assert made.time_to_decision >= 0.7


def test_small_jitter_of_the_outlines_is_not_motion():
    stamps = np.arange(0.0, 0.6, 1 / 120)
    points = np.tile([960.0, 540.0], (len(stamps), 1))
    points[stamps < 0.2] = [100.0, 100.0]                  # looks at 'a' from 0.2 s
    jitter = [RegionSet(['a', 'b'], [square(960.0 + 0.5 * (k % 2), 540.0),
                                     square(1400.0, 540.0)], 0.02 * k) for k in range(30)]
    made = feed(RoundEvidence(0.0, min_samples=2, min_reaction_s=0.1), jitter, stamps, points)
    assert made is not None and made.label == 'a' and made.time_to_decision < 0.3


def test_a_gaze_resting_between_two_options_is_not_a_choice_until_it_moves():
    """Noise flips a resting gaze between two neighbours: no new fixation, no early choice."""
    regions = [RegionSet(['a', 'b', 'c'], [square(960.0, 540.0, 60.0),
                                           square(1040.0, 540.0, 60.0),
                                           square(1400.0, 540.0, 60.0)], 0.0)]
    stamps = np.arange(0.0, 1.0, 1 / 120)
    points = np.tile([1000.0, 540.0], (len(stamps), 1))
    points[:, 0] += np.where(np.arange(len(stamps)) % 6 < 3, -12.0, 12.0)  # a, a, a, b, b, b
    held = feed(RoundEvidence(0.0, min_samples=2, min_reaction_s=0.1), regions, stamps,
                points)
    assert held is None
    points[stamps >= 0.6] = [1400.0, 540.0]          # the saccade to 'c'
    made = feed(RoundEvidence(0.0, min_samples=2, min_reaction_s=0.1), regions, stamps, points)
    assert made is not None and made.label == 'c' and made.time_to_decision >= 0.6
