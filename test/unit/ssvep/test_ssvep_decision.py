"""Posterior against the null, margin, the rest model and the decision rule."""

import numpy as np
import pytest

from eye_bci_ros2.ssvep.decision import DecisionRule, HeldDecision, margin, posterior, RestModel


def test_the_posterior_is_the_likelihood_ratio_against_nothing_attended():
    p = posterior(np.array([5.0, 0.0, 0.0]), gain=2.0, rest_z=3.0)
    # exp(2 z) over exp(2 rest_z) + sum: the rest keeps exp(6) of the weight.
    total = np.exp(10.0) + 2 + np.exp(6.0)
    np.testing.assert_allclose(p, [np.exp(10.0) / total, 1 / total, 1 / total])
    assert p.sum() < 1.0
    # Without a rest hypothesis the options share everything.
    assert posterior(np.array([1.0, 1.0]), rest_z=None).sum() == pytest.approx(1.0)


def test_the_same_ranking_with_small_evidence_is_not_a_choice():
    """Relative scores alone made [-0.004, 0.016, 0.044] a 0.99 posterior; the null does not."""
    rule = DecisionRule()
    small = np.array([-0.1, 0.4, 1.1])  # z: well inside the null
    # "Nothing attended" keeps most of the posterior (0.74 at the default rest_z).
    assert rule.probabilities(small).sum() < 0.3
    assert rule.decide(small, 2.0) is None
    large = small + 5.0  # the same differences, but far out of the null
    assert rule.decide(np.array([-0.1, 0.4, 7.0]), 2.0) == 2
    assert rule.probabilities(large).sum() > 0.9


def test_margin_counts_the_lead_over_the_runner_up_and_the_rest():
    assert margin(np.array([0.0, 8.0, 6.0]), gain=1.0, rest_z=4.0) == pytest.approx(
        1 - np.exp(-2.0))
    assert margin(np.array([0.0, 5.0]), gain=1.0, rest_z=4.0) == pytest.approx(1 - np.exp(-1))
    assert margin(np.array([3.0, 2.0]), rest_z=4.0) == 0.0
    assert margin(np.array([1.0])) == 0.0


def test_decision_needs_the_window_and_two_finite_options():
    rule = DecisionRule('posterior', threshold=0.9, min_window_s=1.0)
    strong = np.array([0.2, 8.0, 0.3])
    assert rule.decide(strong, 0.9) is None
    assert rule.decide(strong, 1.0) == 1
    assert rule.decide(np.array([7.9, 8.0]), 2.0) is None  # two options equally strong
    assert rule.decide(np.array([8.0]), 2.0) is None
    assert rule.decide(np.array([np.nan, 8.0]), 2.0) is None
    assert DecisionRule('margin', 0.9, 0.5).decide(np.array([0.0, 8.0]), 1.0) == 1
    with pytest.raises(ValueError, match='rule'):
        DecisionRule('vote')
    with pytest.raises(ValueError, match='gain'):
        DecisionRule(gain=0.0)


def test_rest_model_standardises_by_window_length_and_round_trips():
    rng = np.random.default_rng(0)
    model = RestModel.measure((1.0, 2.0), [rng.normal(1.0, 0.5, 400),
                                           rng.normal(0.0, 0.25, 400)], 'test')
    assert model.z(np.array([1.0]), 1.0)[0] == pytest.approx(0.0, abs=0.15)
    assert model.z(np.array([0.5]), 2.0)[0] == pytest.approx(2.0, abs=0.3)
    # Between the measured lengths the null is interpolated, beyond them held.
    assert model.z(np.array([0.5]), 1.5)[0] == pytest.approx(0.0, abs=0.2)
    assert model.z(np.array([0.5]), 5.0)[0] == pytest.approx(model.z(np.array([0.5]), 2.0)[0])
    again = RestModel.from_arrays(model.as_arrays())
    assert again == model
    with pytest.raises(ValueError, match='need at least 10'):
        RestModel.measure((1.0,), [np.zeros(3)], 'too few')
    with pytest.raises(ValueError, match='inconsistent'):
        RestModel((2.0, 1.0), (0.0, 0.0), (1.0, 1.0))


def test_a_choice_needs_the_evidence_to_hold():
    """A chance crossing of the threshold is brief; an SSVEP lasts: hold_s of steps."""
    held = HeldDecision(DecisionRule(hold_s=0.5))
    strong, weak = np.array([0.0, 6.0, 0.5]), np.array([0.0, 0.3, 0.5])
    # One crossing, then the evidence falls back: no choice.
    assert [held.update(z, 2.0, t) for z, t in ((strong, 0.0), (strong, 0.1), (weak, 0.2))] \
        == [None, None, None]
    # Held from 0.3 s: chosen at the step 0.5 s later, not before.
    steps = [held.update(strong, 2.0, 0.3 + 0.1 * k) for k in range(7)]
    assert steps == [None] * 5 + [1, 1]
    # Another option taking the lead starts the hold again.
    held.interrupt()
    other = np.array([6.0, 0.0, 0.5])
    steps = ((strong, 0.0), (other, 0.3), (other, 0.7), (other, 0.8))
    assert [held.update(z, 2.0, t) for z, t in steps] == [None, None, None, 0]
    # hold_s 0: the first qualifying step chooses (the rule alone).
    assert HeldDecision(DecisionRule(hold_s=0.0)).update(strong, 2.0, 0.0) == 1
    with pytest.raises(ValueError, match='hold_s'):
        DecisionRule(hold_s=-1.0)
