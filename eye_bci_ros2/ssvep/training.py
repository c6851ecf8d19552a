"""
Fit a TRCA model from a calibration recording.

A calibration recording is continuous EEG, shape (n, C) uV with sample
times (n,) s, plus labelled trials: (onset s, option label), each the time
the option's stimulus started (its phase at the onset is the map's phase:
the stimulus epoch of that trial) while the person attended it.  The
recording is filtered causally from its start, exactly as the live decoder
filters a stream, then cut into trials of ``trial_s`` from each onset.
"""

from typing import Sequence, Tuple

import numpy as np

from eye_bci_ros2.ssvep.decoders import TrcaModel
from eye_bci_ros2.ssvep.filters import filter_recording
from eye_bci_ros2.ssvep.stimuli import StimulusMap


def cut_epochs(filtered: np.ndarray, times: np.ndarray, onsets: Sequence[float],
               length: int) -> np.ndarray:
    """
    Cut trials out of a filtered recording.

    :param filtered: shape (B, n, C).
    :param times: sample times, s, (n,), increasing.
    :param onsets: trial onsets, s, (T,).
    :param length: samples per trial L.
    :returns: shape (T, B, L, C).
    :raises ValueError: when a trial runs past the recording.
    """
    starts = np.searchsorted(times, np.asarray(onsets, dtype=float), side='left')
    if np.any(starts + length > filtered.shape[1]):
        raise ValueError('a calibration trial runs past the end of the recording')
    return np.stack([filtered[:, start:start + length] for start in starts])


def fit_trca(samples: np.ndarray, times: np.ndarray, trials: Sequence[Tuple[float, str]],
             stimuli: StimulusMap, rate: float, channels: Sequence[str],
             trial_s: float = 2.0, bands: int = 5, band=(6.0, 90.0), notch_hz: float = 50.0,
             ensemble: bool = True) -> TrcaModel:
    """
    Fit a (ensemble) TRCA model from a labelled calibration recording.

    :param samples: raw EEG of the decoded channels, (n, C), uV.
    :param times: sample times, s, (n,).
    :param trials: (onset s, label) per trial; every label in ``stimuli``.
    :param stimuli: the map used during calibration (frequencies, phases).
    :param rate: sampling rate, Hz.
    :param channels: names of the C channels.
    :param trial_s: trial length used, s (the longest window of the model).
    :returns: the fitted model (labels in the map's order).
    """
    unknown = sorted({label for _, label in trials if label not in stimuli.labels})
    if unknown:
        raise ValueError(f"calibration trials of {', '.join(unknown)} have no stimulus in "
                         f'the map ({", ".join(stimuli.labels)})')
    filtered = filter_recording(samples, rate, bands, band, notch_hz)
    epochs = cut_epochs(filtered, np.asarray(times, dtype=float), [t for t, _ in trials],
                        int(round(trial_s * rate)))
    targets = [stimuli.labels.index(label) for _, label in trials]
    return TrcaModel.fit(epochs, targets, stimuli.labels, stimuli.frequencies, stimuli.phases,
                         rate, channels, ensemble=ensemble, band=tuple(band),
                         notch_hz=notch_hz)
