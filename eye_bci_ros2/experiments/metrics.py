"""
Metrics of a selection experiment.

Wolpaw information transfer rate (Wolpaw et al., "Brain-computer interface
technology: a review of the first international meeting", IEEE Trans.
Rehab. Eng. 8(2), 2000): with N equally likely choices, accuracy P and the
errors spread evenly over the N - 1 other choices, each selection carries

    B = log2 N + P log2 P + (1 - P) log2((1 - P) / (N - 1))  bits.

Bits per minute = B x selections per minute (including any pause between
selections, which the caller accounts for).
"""

import math
from typing import Sequence

import numpy as np

#: Time a benchmark counts between selections besides the decision: the cue and the gaze
#: shift to the next option, s (Nakanishi et al. 2018's 0.5 s; bench/decision, bench/ssvep).
GAZE_SHIFT_S = 0.5


def wolpaw_bits(choices: int, accuracy: float) -> float:
    """
    Return the Wolpaw bits per selection for ``choices`` options at ``accuracy``.

    :param choices: number of options N (>= 2 for any information).
    :param accuracy: fraction of correct selections P, in [0, 1].
    :returns: bits per selection; 0 when P <= 1/N (no better than chance),
        log2 N when P = 1.
    :raises ValueError: for N < 1 or P outside [0, 1].
    """
    if int(choices) != choices or choices < 1:
        raise ValueError(f'choices must be a whole number >= 1, got {choices!r}')
    if not 0.0 <= accuracy <= 1.0:
        raise ValueError(f'accuracy must be in [0, 1], got {accuracy!r}')
    n = int(choices)
    p = float(accuracy)
    if n < 2 or p <= 1.0 / n:
        return 0.0
    if p >= 1.0:
        return math.log2(n)
    return math.log2(n) + p * math.log2(p) + (1.0 - p) * math.log2((1.0 - p) / (n - 1))


def itr_bits_per_minute(offered_counts: Sequence[int], accuracy: float,
                        mean_time_s: float) -> float:
    """
    Information transfer rate, bits/min, of selections with the given choice counts.

    Wolpaw's bits per selection are averaged over the selections (each with
    its own N), at the overall accuracy P, and divided by the mean time per
    selection T.
    """
    if not offered_counts or not mean_time_s > 0:
        return 0.0
    bits = np.mean([wolpaw_bits(n, accuracy) for n in offered_counts])
    return float(bits * 60.0 / mean_time_s)
