"""The tolerance benchmark's pieces (bench/tolerance.py), on hand-made cases and a few trials."""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))

from bench import decision, tolerance  # noqa: E402
from eye_bci_ros2.gaze_model import ScreenGeometry  # noqa: E402

SCREEN = ScreenGeometry()


def _regions():
    # Three 100 px squares at x 810..910, 960 +- 50, 1010..1110 (pitch 150 px).
    return decision.region_set(3, 100)


def test_tolerant_regions_count_near_samples_and_not_midway():
    regions = tolerance.TolerantRegions.of(_regions(), screen=SCREEN, ratio=0.5)
    centres = decision.layout(3, 100)
    near = centres[0] + [0.0, 70.0]            # 20 px below the first square
    midway = (centres[0] + centres[1]) / 2     # 25 px from both
    np.testing.assert_array_equal(_regions().classify(np.array([near, midway])), [-1, -1])
    np.testing.assert_array_equal(regions.classify(np.array([near, midway])), [0, -1])
    assert regions.classify_one(*near) == 0


def test_share_test_refuses_a_choice_on_a_few_samples():
    centres = decision.layout(3, 100)
    stamps = np.arange(90) / 90.0
    points = np.repeat([(centres[0] + centres[1]) / 2], 90, axis=0)
    points[::10] = centres[0]                  # 10 % of the samples on option 0
    config = decision.EarlyConfig()
    assert tolerance._decide('mean', points, stamps, _regions(), config, SCREEN) == '0'
    assert tolerance._decide('mean/s', points, stamps, _regions(), config, SCREEN) is None
    assert tolerance._decide('early/s', points, stamps, _regions(), config, SCREEN) is None


def test_tolerant_rule_chooses_smaller_markers_than_the_mean():
    found = tolerance.smallest(rules=('mean', 'tol_mean'), trials=4)
    assert found['tol_mean']['threshold_px'] < found['mean']['threshold_px']
