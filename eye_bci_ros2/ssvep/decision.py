"""
When a growing / sliding window of SSVEP scores is strong enough to choose.

Posterior: ``softmax(gain * s / max(s))`` of the K scores s, i.e. scores
relative to the best, so the same gain fits FBCCA (sum of rho^2) and TRCA
(sum of r) scores; all scores <= 0 give a uniform posterior.  A "rest" score
(FBCCA: the best score at decoy frequencies between the stimuli) joins the
softmax as a (K+1)-th class "nothing attended", which keeps noise from
looking confident when few options are offered.  Margin:
``(s_best - s_second) / s_best``.  A choice is made once the window is at
least ``min_window_s`` long and the rule's value reaches ``threshold``;
never from fewer than 2 options.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

RULES = ('posterior', 'margin')


def posterior(scores: np.ndarray, gain: float = 8.0) -> np.ndarray:
    """
    Turn K scores into probabilities that each option is attended.

    :param scores: shape (K,).
    :param gain: sharpness of the softmax over scores relative to the best.
    :returns: shape (K,), sums to 1.
    """
    scores = np.asarray(scores, dtype=float)
    if scores.size == 0:
        return scores
    best = scores.max()
    if not np.isfinite(best) or best <= 0:
        return np.full(scores.shape, 1.0 / scores.size)
    logits = gain * (scores / best - 1.0)
    weights = np.exp(logits)
    return weights / weights.sum()


def margin(scores: np.ndarray) -> float:
    """Relative lead of the best score over the second, in [0, 1] (0 for K < 2)."""
    scores = np.sort(np.asarray(scores, dtype=float))[::-1]
    if scores.size < 2 or not np.isfinite(scores[0]) or scores[0] <= 0:
        return 0.0
    return float(np.clip((scores[0] - scores[1]) / scores[0], 0.0, 1.0))


@dataclass(frozen=True)
class DecisionRule:
    """
    Evidence needed for a choice.

    :param rule: 'posterior' or 'margin'.
    :param threshold: value the rule must reach, in (0, 1].
    :param min_window_s: shortest window that may choose, s.
    :param gain: softmax gain of the posterior.
    """

    rule: str = 'posterior'
    threshold: float = 0.95
    min_window_s: float = 1.0
    gain: float = 8.0

    def __post_init__(self):
        """Reject a rule that cannot work, with a reason."""
        if self.rule not in RULES:
            raise ValueError(f"rule '{self.rule}' is not one of {', '.join(RULES)}")
        if not 0.0 < self.threshold <= 1.0:
            raise ValueError(f'threshold must be in (0, 1], got {self.threshold}')
        if self.min_window_s < 0:
            raise ValueError(f'min_window_s must be >= 0, got {self.min_window_s}')

    def probabilities(self, scores: np.ndarray, rest: Optional[float] = None) -> np.ndarray:
        """
        Posterior of each option, (K,).

        :param rest: score of "no stimulus attended" (e.g. the best score at
            decoy frequencies no option uses); it takes its share of the
            probability, so the options' posteriors then sum to less than 1.
        """
        scores = np.asarray(scores, dtype=float)
        if rest is None:
            return posterior(scores, self.gain)
        return posterior(np.append(scores, rest), self.gain)[:-1]

    def evidence(self, scores: np.ndarray, rest: Optional[float] = None) -> float:
        """Return the rule's value for these scores (and the rest score, if any)."""
        scores = np.asarray(scores, dtype=float)
        if self.rule == 'margin':
            return margin(scores if rest is None else np.append(scores, rest))
        probabilities = self.probabilities(scores, rest)
        return float(probabilities.max()) if probabilities.size else 0.0

    def decide(self, scores: np.ndarray, window_s: float,
               rest: Optional[float] = None) -> Optional[int]:
        """Return the chosen option's index, or None while the evidence is too weak."""
        scores = np.asarray(scores, dtype=float)
        if scores.size < 2 or window_s < self.min_window_s or not np.all(np.isfinite(scores)):
            return None
        if rest is not None and not rest < scores.max():
            return None
        if self.evidence(scores, rest) < self.threshold:
            return None
        return int(np.argmax(scores))
