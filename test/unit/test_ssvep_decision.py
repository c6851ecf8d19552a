"""Posterior, margin and the decision rule."""

import numpy as np
import pytest

from eye_bci_ros2.ssvep.decision import DecisionRule, margin, posterior


def test_posterior_and_margin():
    p = posterior(np.array([1.0, 0.5, 0.5]), gain=10.0)
    assert p.sum() == pytest.approx(1.0)
    assert p[0] == pytest.approx(1 / (1 + 2 * np.exp(-5.0)))
    np.testing.assert_allclose(posterior(np.array([0.0, -1.0])), [0.5, 0.5])
    assert margin(np.array([0.5, 1.0, 0.8])) == pytest.approx(0.2)
    assert margin(np.array([1.0])) == 0.0


def test_decision_needs_the_window_and_the_evidence():
    rule = DecisionRule('posterior', threshold=0.9, min_window_s=1.0, gain=20.0)
    strong = np.array([0.2, 1.0, 0.3])
    assert rule.decide(strong, 0.9) is None
    assert rule.decide(strong, 1.0) == 1
    assert rule.decide(np.array([0.98, 1.0]), 2.0) is None
    assert rule.decide(np.array([1.0]), 2.0) is None
    assert rule.decide(np.array([np.nan, 1.0]), 2.0) is None
    assert DecisionRule('margin', 0.3, 0.5).decide(np.array([0.6, 1.0]), 1.0) == 1
    with pytest.raises(ValueError, match='rule'):
        DecisionRule('vote')


def test_a_rest_score_takes_its_share_and_vetoes():
    rule = DecisionRule('posterior', threshold=0.9, min_window_s=0.5, gain=10.0)
    scores = np.array([1.0, 0.3])
    assert rule.decide(scores, 1.0) == 0
    assert rule.decide(scores, 1.0, rest=1.2) is None  # a decoy scores higher: nothing seen
    p = rule.probabilities(scores, rest=0.9)
    assert p.sum() < 1.0 and rule.decide(scores, 1.0, rest=0.9) is None
