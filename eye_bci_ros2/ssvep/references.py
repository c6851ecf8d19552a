"""Sine/cosine reference signals of SSVEP stimuli (the CCA templates of FBCCA)."""

from typing import Optional, Sequence

import numpy as np


def sine_cosine_references(frequencies: Sequence[float], rate: float, samples: int,
                           harmonics: int = 5, phases: Optional[Sequence[float]] = None,
                           start_s: float = 0.0) -> np.ndarray:
    """
    Build the references ``sin(2 pi h f t + h phi), cos(...)`` for each stimulus.

    :param frequencies: stimulus frequencies f_k, Hz, shape (K,).
    :param rate: sampling rate, Hz.
    :param samples: samples n per reference.
    :param harmonics: harmonics H (1 = fundamental only).
    :param phases: stimulus phases phi_k, rad, shape (K,); default 0.
    :param start_s: time of the first sample after the stimulus epoch, s.
    :returns: shape (K, n, 2H): columns sin h=1, cos h=1, sin h=2, ...
    """
    frequencies = np.asarray(frequencies, dtype=float).reshape(-1)
    if not np.all(np.isfinite(frequencies)) or np.any(frequencies <= 0):
        raise ValueError(f'stimulus frequencies must be positive, got {frequencies.tolist()}')
    if harmonics < 1:
        raise ValueError(f'need at least one harmonic, got {harmonics}')
    phases = (np.zeros_like(frequencies) if phases is None
              else np.asarray(phases, dtype=float).reshape(-1))
    t = start_s + np.arange(int(samples)) / float(rate)
    h = np.arange(1, int(harmonics) + 1, dtype=float)
    # angle[k, n, h] = h (2 pi f_k t_n + phi_k)
    angle = h[None, None, :] * (2 * np.pi * frequencies[:, None, None] * t[None, :, None]
                                + phases[:, None, None])
    out = np.empty((len(frequencies), len(t), 2 * len(h)))
    out[..., 0::2] = np.sin(angle)
    out[..., 1::2] = np.cos(angle)
    return out
