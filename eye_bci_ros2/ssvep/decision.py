"""
When the SSVEP evidence of a window is strong enough to choose, and when nobody attends.

Every decoder gives each of the K options an *evidence statistic* (FBCCA: the
log ratio of the option's score to its sidebands' geometric mean,
:func:`eye_bci_ros2.ssvep.decoders.sideband_statistic`; TRCA: its score).  A
:class:`RestModel` says how that statistic is distributed for an option nobody
attends (mean, standard deviation, by window length): the *null*.  Evidence is
measured against it, ``z = (statistic - mean) / std``, so noise, whatever its
size, stays near 0.

Posterior (rule 'posterior'): K + 1 hypotheses, "option k is attended" and
"nothing is attended".  If z of an attended option were normal with mean
``gain`` and unit variance (null: mean 0), the likelihood ratio of "k" against
"nothing" would be ``exp(gain z_k - gain^2 / 2)``; with the prior odds of
nothing attended folded into ``rest_z``:

    P(k) = exp(gain z_k) / (exp(gain rest_z) + sum_j exp(gain z_j))

so the posterior depends on how large the evidence is, not only on which
option leads: all z near 0 (nobody attends, the alpha rhythm included: the
statistic is relative to the option's own neighbourhood) give "nothing".
Rule 'margin': the lead of the best z over the second and over ``rest_z``,
mapped to (0, 1) as ``1 - exp(-gain lead)``.  An option *qualifies* in a
step once the window is at least ``min_window_s`` long and the rule's value
for it reaches ``threshold`` (never from fewer than 2 options); it is
*chosen* once it has qualified in every step over ``hold_s`` of EEG
(:class:`HeldDecision`): an SSVEP lasts, while noise crosses the threshold
in brief excursions of the overlapping windows' statistic.  Holding the
evidence lets a lower ``rest_z`` choose more attended options for the same
false choices (docs/ssvep.md).
"""

from dataclasses import dataclass
from typing import Dict, Optional, Sequence

import numpy as np

RULES = ('posterior', 'margin')
#: Expected z of an attended option, the posterior's gain (see the module doc).
DEFAULT_GAIN = 3.0
#: z at which "nothing attended" is as likely as one option, in null standard deviations:
#: the value the leave-subject-out evaluation of ``python -m bench.ssvep_real`` picks
#: (from 1-4, with :data:`DEFAULT_HOLD_S`) for every held-out subject of the development
#: recordings (docs/ssvep.md).
DEFAULT_REST_Z = 1.5
#: How long an option's evidence must hold before it is chosen, s: half the default
#: shortest window (1 s), so that over the hold at least half of the window's EEG is
#: new (a chance crossing of the overlapping windows' statistic is mostly replaced).
DEFAULT_HOLD_S = 0.5


@dataclass(frozen=True)
class RestModel:
    """
    The evidence statistic of an option nobody attends, by window length.

    :param windows_s: window lengths, s, ascending, (L,).
    :param mean: its mean at each length, (L,).
    :param std: its standard deviation at each length, (L,), > 0.
    :param source: where it was measured (e.g. 'white noise', 'calibration rest').
    :param option_means: optional, the mean of each of K options at each
        length, (L, K) (the statistic's mean can depend on the option's
        frequency through the filters); used instead of ``mean`` when given.
    """

    windows_s: tuple
    mean: tuple
    std: tuple
    source: str = ''
    option_means: tuple = ()

    def __post_init__(self):
        """Check the table."""
        w, m, s = (np.asarray(v, dtype=float) for v in (self.windows_s, self.mean, self.std))
        if not (w.ndim == 1 and len(w) >= 1 and w.shape == m.shape == s.shape
                and np.all(np.diff(w) > 0) and np.all(s > 0) and np.all(np.isfinite(m))):
            raise ValueError(f'inconsistent rest model: windows {w}, mean {m}, std {s}')
        if len(self.option_means):
            o = np.asarray(self.option_means, dtype=float)
            if not (o.ndim == 2 and o.shape[0] == len(w) and np.all(np.isfinite(o))):
                raise ValueError(f'inconsistent rest model: option means of shape {o.shape} '
                                 f'for {len(w)} window lengths')

    def z(self, statistic: np.ndarray, window_s: float) -> np.ndarray:
        """Evidence of each statistic against the null at this window length, (K,)."""
        if len(self.option_means):
            table = np.asarray(self.option_means, dtype=float)
            mean = np.array([np.interp(window_s, self.windows_s, column) for column in table.T])
        else:
            mean = np.interp(window_s, self.windows_s, self.mean)
        std = np.interp(window_s, self.windows_s, self.std)
        return (np.asarray(statistic, dtype=float) - mean) / std

    def as_arrays(self, prefix: str = 'rest_') -> Dict[str, np.ndarray]:
        """Arrays to save beside a model (``np.savez``)."""
        return {f'{prefix}windows_s': np.asarray(self.windows_s, float),
                f'{prefix}mean': np.asarray(self.mean, float),
                f'{prefix}std': np.asarray(self.std, float),
                f'{prefix}source': np.array(self.source)}

    @classmethod
    def from_arrays(cls, data, prefix: str = 'rest_') -> 'RestModel':
        """Read what :meth:`as_arrays` wrote."""
        return cls(tuple(np.asarray(data[f'{prefix}windows_s'], float).tolist()),
                   tuple(np.asarray(data[f'{prefix}mean'], float).tolist()),
                   tuple(np.asarray(data[f'{prefix}std'], float).tolist()),
                   str(data[f'{prefix}source']))

    @classmethod
    def measure(cls, windows_s: Sequence[float], samples: Sequence[np.ndarray],
                source: str) -> 'RestModel':
        """
        Fit from null statistics measured at each window length.

        :param samples: per window length, the statistics of unattended options.
        :raises ValueError: with fewer than 10 values at a length.
        """
        means, stds = [], []
        for length, values in zip(windows_s, samples):
            values = np.asarray(values, dtype=float)
            values = values[np.isfinite(values)]
            if len(values) < 10:
                raise ValueError(f'{len(values)} rest values at {length:g} s: need at least '
                                 '10 to measure the null (record more trials or rest trials)')
            means.append(float(values.mean()))
            stds.append(max(float(values.std(ddof=1)), 1e-9))
        return cls(tuple(float(w) for w in windows_s), tuple(means), tuple(stds), source)


def posterior(z: np.ndarray, gain: float = DEFAULT_GAIN,
              rest_z: Optional[float] = DEFAULT_REST_Z) -> np.ndarray:
    """
    Probability that each option is attended, from its evidence against the null.

    :param z: shape (K,).
    :param gain: expected z of an attended option.
    :param rest_z: z at which "nothing attended" equals one option (None = no
        such hypothesis: the options' posteriors then sum to 1).
    :returns: shape (K,); with ``rest_z`` they sum to less than 1.
    """
    z = np.asarray(z, dtype=float)
    if z.size == 0:
        return z
    logits = gain * (z if rest_z is None else np.append(z, rest_z))
    logits = np.where(np.isfinite(logits), logits, -np.inf)
    top = logits.max()
    if not np.isfinite(top):
        return np.zeros(z.shape)
    weights = np.exp(logits - top)
    return (weights / weights.sum())[:z.size]


def margin(z: np.ndarray, gain: float = DEFAULT_GAIN,
           rest_z: Optional[float] = DEFAULT_REST_Z) -> float:
    """Lead of the best z over the runner-up and ``rest_z``, as ``1 - exp(-gain lead)``."""
    ordered = np.sort(np.asarray(z, dtype=float))[::-1]
    if ordered.size < 2 or not np.isfinite(ordered[0]):
        return 0.0
    rival = ordered[1] if rest_z is None else max(ordered[1], rest_z)
    return float(max(0.0, 1.0 - np.exp(-gain * (ordered[0] - rival))))


@dataclass(frozen=True)
class DecisionRule:
    """
    Evidence needed for a choice.

    :param rule: 'posterior' or 'margin'.
    :param threshold: value the rule must reach, in (0, 1].
    :param min_window_s: shortest window that may choose, s.
    :param gain: expected z of an attended option (the posterior's gain).
    :param rest_z: z at which "nothing attended" is as likely as one option.
    :param hold_s: how long an option must qualify in every step before it is
        chosen, s (:class:`HeldDecision`; 0 = at the first step).
    """

    rule: str = 'posterior'
    threshold: float = 0.95
    min_window_s: float = 1.0
    gain: float = DEFAULT_GAIN
    rest_z: float = DEFAULT_REST_Z
    hold_s: float = DEFAULT_HOLD_S

    def __post_init__(self):
        """Reject a rule that cannot work, with a reason."""
        if self.rule not in RULES:
            raise ValueError(f"rule '{self.rule}' is not one of {', '.join(RULES)}")
        if not 0.0 < self.threshold <= 1.0:
            raise ValueError(f'threshold must be in (0, 1], got {self.threshold}')
        if self.min_window_s < 0:
            raise ValueError(f'min_window_s must be >= 0, got {self.min_window_s}')
        if not self.gain > 0:
            raise ValueError(f'gain must be > 0, got {self.gain}')
        if not 0.0 <= self.hold_s <= 10.0:
            raise ValueError(f'hold_s must be in [0, 10] s, got {self.hold_s}')

    def probabilities(self, z: np.ndarray) -> np.ndarray:
        """Posterior of each option, (K,); the rest (nothing attended) is 1 - their sum."""
        return posterior(z, self.gain, self.rest_z)

    def evidence(self, z: np.ndarray) -> float:
        """Return the rule's value for these z."""
        if self.rule == 'margin':
            return margin(z, self.gain, self.rest_z)
        probabilities = self.probabilities(z)
        return float(probabilities.max()) if probabilities.size else 0.0

    def decide(self, z: np.ndarray, window_s: float) -> Optional[int]:
        """Return the index of the option that qualifies in this step, or None."""
        z = np.asarray(z, dtype=float)
        if z.size < 2 or window_s < self.min_window_s or not np.all(np.isfinite(z)):
            return None
        if self.evidence(z) < self.threshold:
            return None
        return int(np.argmax(z))


class HeldDecision:
    """
    A choice once the same option has qualified in every step over ``hold_s`` of EEG.

    Feed every step of a round in order (:meth:`update`); a step that could not
    be scored (:meth:`interrupt`) or in which no option or another one qualifies
    starts the hold again.
    """

    def __init__(self, rule: DecisionRule):
        self.rule = rule
        self.interrupt()

    def interrupt(self) -> None:
        """Forget the hold (a new round, or a step without evidence)."""
        self._index: Optional[int] = None
        self._since = 0.0

    def update(self, z: np.ndarray, window_s: float, end_s: float) -> Optional[int]:
        """
        Take one step's evidence; return the chosen option's index, or None.

        :param z: evidence of each option, (K,).
        :param window_s: the step's window length, s.
        :param end_s: time of the window's last sample, s (the hold is measured on it).
        """
        index = self.rule.decide(z, window_s)
        if index is None:
            self.interrupt()
            return None
        if index != self._index:
            self._index, self._since = index, float(end_s)
        # A hundredth of a step's tolerance: sample times are sums of sample periods.
        return index if end_s - self._since >= self.rule.hold_s - 1e-6 else None
