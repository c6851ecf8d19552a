"""
Fit a TRCA model from one or several calibration recordings.

A calibration recording is continuous EEG, shape (n, C) uV with sample
times (n,) s, plus labelled trials: (onset s, option label), each the time
the option's stimulus started (its phase at the onset is the map's phase:
the stimulus epoch of that trial) while the person attended it, or
(onset s, None): a rest trial, nobody attending any stimulus (the person
looks at a fixation point), which the model's rest model learns from.
Each recording is filtered causally from its start, exactly as the live
decoder filters a stream, then cut into trials of ``trial_s`` from each onset.
"""

from typing import Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.ssvep.decoders import TrcaModel
from eye_bci_ros2.ssvep.filters import filter_recording
from eye_bci_ros2.ssvep.stimuli import StimulusMap

Trial = Tuple[float, Optional[str]]


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
    if not len(starts):
        return np.zeros((0,) + (filtered.shape[0], length, filtered.shape[2]))
    return np.stack([filtered[:, start:start + length] for start in starts])


def fit_trca(samples, times, trials, stimuli: StimulusMap, rate: float,
             channels: Sequence[str], trial_s: float = 2.0, bands: int = 5, band=(6.0, 90.0),
             notch_hz: float = 50.0, ensemble: bool = True,
             min_window_s: float = 0.5, require_repeat: bool = True,
             onset_s: float = 0.0) -> TrcaModel:
    """
    Fit a (ensemble) TRCA model and its rest model from labelled calibration recordings.

    :param samples: raw EEG of the decoded channels, (n, C), uV; or a list of
        such recordings (several sessions of the same person and set-up).
    :param times: sample times, s, (n,); a list with several recordings.
    :param trials: (onset s, label or None for rest) per trial; a list of
        such lists with several recordings; every label in ``stimuli``.
    :param stimuli: the map used during calibration (frequencies, phases).
    :param rate: sampling rate, Hz.
    :param channels: names of the C channels.
    :param trial_s: template length, s (the longest window of the model).
    :param onset_s: the templates start this long after each onset (the
        response's build-up left out, as the decoder's ``onset_s`` leaves it
        out of its windows), s; a trial must last ``onset_s + trial_s``.
    :param min_window_s: shortest window its rest model is measured at, s.
    :param require_repeat: see :meth:`TrcaModel.fit`.
    :returns: the fitted model (labels in the map's order).
    :raises ValueError: unknown labels, too few trials, or trials that do not
        repeat (:meth:`TrcaModel.fit`).
    """
    if isinstance(samples, np.ndarray) and samples.ndim == 2:
        samples, times, trials = [samples], [times], [trials]
    if not len(samples) == len(times) == len(trials):
        raise ValueError(f'{len(samples)} recordings with {len(times)} time arrays and '
                         f'{len(trials)} trial lists')
    everything = [trial for listed in trials for trial in listed]
    unknown = sorted({label for _, label in everything
                      if label is not None and label not in stimuli.labels})
    if unknown:
        raise ValueError(f"calibration trials of {', '.join(unknown)} have no stimulus in "
                         f'the map ({", ".join(stimuli.labels)})')
    length = int(round(trial_s * rate))
    epochs, targets, rest = [], [], []
    for recording, stamps, listed in zip(samples, times, trials):
        filtered = filter_recording(recording, rate, bands, band, notch_hz)
        stamps = np.asarray(stamps, dtype=float)
        attended = [(t, label) for t, label in listed if label is not None]
        epochs.append(cut_epochs(filtered, stamps, [t + onset_s for t, _ in attended],
                                 length))
        targets += [stimuli.labels.index(label) for _, label in attended]
        rest.append(cut_epochs(filtered, stamps,
                               [t + onset_s for t, label in listed if label is None], length))
    rest_epochs = np.concatenate(rest)
    return TrcaModel.fit(np.concatenate(epochs), targets, stimuli.labels, stimuli.frequencies,
                         stimuli.phases, rate, channels, ensemble=ensemble,
                         rest_epochs=rest_epochs if len(rest_epochs) else None,
                         min_window_s=min_window_s, require_repeat=require_repeat,
                         band=tuple(band), notch_hz=notch_hz, template_start_s=onset_s)
