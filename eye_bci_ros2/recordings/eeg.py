"""
Recorded SSVEP EEG of people attending known stimuli: one loader into one form (pure).

A :class:`EegRecording` is what the real-EEG benchmark and the simulator's
check against real data read: raw EEG in uV, shape (n, C), its nominal rate,
channel labels, and the cued trials (cue time s from the first sample, the
attended stimulus frequency Hz, or None for "rest": the person looked at a
fixation point, nothing attended).

Format read: ``kalunga_sNN_<session>.npz`` (Kalunga et al. 2016 "SSVEP Exo",
CC0, see the data folder's README): ``eeg_uv`` float (n, C) uV, ``sfreq``,
``channels``, ``events`` int (T, 2) = (sample index of the cue, class code:
1 rest, 2 13 Hz, 3 21 Hz, 4 17 Hz).  Other files of the same keys with an
``event_hz`` array (class code -> Hz, 0 = rest) instead of the fixed codes
are read too.
"""

from dataclasses import dataclass
import os
from pathlib import Path
import re
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from eye_bci_ros2.recordings import find_data

PathLike = Union[str, os.PathLike]

#: Kalunga 2016 class codes: 1 = rest, 2 = 13 Hz, 3 = 21 Hz, 4 = 17 Hz.
KALUNGA_CLASSES: Dict[int, Optional[float]] = {1: None, 2: 13.0, 3: 21.0, 4: 17.0}
#: Where the shared recordings live beside a clone: ``<parent>/shared/data/<kind>``.
#: Environment variable naming the folder of real EEG recordings.
EEG_DATA_ENV = 'EYE_BCI_REAL_EEG'


@dataclass(frozen=True)
class EegRecording:
    """
    One recorded session.

    :param name: file stem.
    :param subject: subject identifier (e.g. 's01').
    :param eeg_uv: raw EEG, shape (n, C), uV.
    :param rate: nominal sampling rate, Hz.
    :param channels: channel labels, (C,).
    :param trials: (cue s from the first sample, attended Hz or None = rest), (T,).
    """

    name: str
    subject: str
    eeg_uv: np.ndarray
    rate: float
    channels: Tuple[str, ...]
    trials: Tuple[Tuple[float, Optional[float]], ...]

    @property
    def times(self) -> np.ndarray:
        """Sample times, s from the first sample, (n,)."""
        return np.arange(len(self.eeg_uv)) / self.rate

    @property
    def frequencies(self) -> Tuple[float, ...]:
        """Stimulus frequencies of the session, ascending, Hz."""
        return tuple(sorted({f for _, f in self.trials if f is not None}))


def load_eeg(path: PathLike) -> EegRecording:
    """
    Read one recording.

    :raises ValueError: for a file that is not such a recording, with why.
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            eeg = np.asarray(data['eeg_uv'], dtype=float)
            rate = float(data['sfreq'])
            channels = tuple(str(c) for c in data['channels'].tolist())
            events = np.asarray(data['events'], dtype=int)
            classes = KALUNGA_CLASSES
            if 'event_hz' in data:
                classes = {code: (float(hz) or None)
                           for code, hz in enumerate(np.asarray(data['event_hz'], float))}
    except (OSError, KeyError, ValueError, EOFError) as error:
        raise ValueError(f"cannot read EEG recording '{path}': {error}") from None
    if eeg.ndim != 2 or eeg.shape[1] != len(channels) or not rate > 0:
        raise ValueError(f"'{path}': eeg_uv {eeg.shape} does not match {len(channels)} "
                         f'channels, or rate {rate} is not positive')
    unknown = sorted(set(events[:, 1].tolist()) - set(classes))
    if unknown:
        raise ValueError(f"'{path}': unknown class codes {unknown}")
    trials = tuple((index / rate, classes[code]) for index, code in events)
    match = re.search(r'_s(\d+)_', path.name)
    subject = f's{int(match.group(1)):02d}' if match else path.stem
    return EegRecording(path.stem, subject, eeg, rate, channels, trials)


def find_eeg_recordings(folder: PathLike) -> List[Path]:
    """List the recordings in ``folder`` (``*.npz``), sorted by name."""
    return sorted(Path(folder).glob('*.npz'))


def by_subject(recordings: Sequence[EegRecording]) -> Dict[str, List[EegRecording]]:
    """Group recordings by subject, subjects in sorted order."""
    groups: Dict[str, List[EegRecording]] = {}
    for recording in sorted(recordings, key=lambda r: (r.subject, r.name)):
        groups.setdefault(recording.subject, []).append(recording)
    return groups


def eeg_data_dir() -> Optional[Path]:
    """Return the real-EEG folder: ``$EYE_BCI_REAL_EEG`` if set, else :func:`find_data`."""
    named = os.environ.get(EEG_DATA_ENV, '')
    if named:
        return Path(named) if Path(named).is_dir() else None
    return find_data('real_eeg')


#: Neighbours of a frequency whose amplitudes make the noise floor, Hz away (both sides).
NOISE_NEIGHBOURS_HZ = (1.0, 1.25, 1.5, 1.75, 2.0)


def _power(x: np.ndarray, rate: float, frequency: float) -> float:
    """Power of the sinusoid at ``frequency`` in ``x`` (least squares), uV^2."""
    t = np.arange(len(x)) / rate
    basis = np.column_stack([np.sin(2 * np.pi * frequency * t),
                             np.cos(2 * np.pi * frequency * t), np.ones_like(t)])
    coefficients = np.linalg.lstsq(basis, x, rcond=None)[0]
    return float(coefficients[0] ** 2 + coefficients[1] ** 2)


def _response(x: np.ndarray, rate: float, frequency: float) -> Tuple[float, float]:
    """(power at ``frequency``, mean power at its neighbours) of a window, uV^2."""
    noise = np.mean([_power(x, rate, frequency + sign * d)
                     for d in NOISE_NEIGHBOURS_HZ for sign in (-1, 1)])
    return _power(x, rate, frequency), float(noise)


def session_statistics(eeg_uv: np.ndarray, rate: float, channel: int,
                       trials: Sequence[Tuple[float, Optional[float]]]) -> Dict[str, float]:
    """
    Measure what a cued SSVEP session shows at one channel (e.g. Oz); the simulator matches it.

    :param eeg_uv: raw EEG, (n, C), uV; ``trials``: (cue s from the first
        sample, attended Hz or None = rest), each followed by >= 5 s of EEG.
    :returns: ``snr_db`` median SNR of the response 1.5-5 s after the cue
        (power at the attended frequency over the mean at 1-2 Hz either side);
        ``snr_iqr_db`` its interquartile range over the trials (how much the
        response varies from trial to trial); ``buildup`` the median share of
        the response's power above the noise 0-2 s after the cue of that 3-5 s
        after it (1 = at once, small = slow build-up); ``alpha_db`` the median
        power ratio of 8-12 Hz to 14-22 Hz in rest trials (how much the alpha
        rhythm stands out where stimuli and their sidebands lie).
    """
    from scipy import signal  # noqa: I100 - only this statistic needs it
    x = signal.sosfiltfilt(signal.butter(4, (3.0, 45.0), btype='bandpass', fs=rate,
                                         output='sos'), eeg_uv[:, channel])
    second = int(round(rate))
    snr, early, late, alpha = [], [], [], []
    for cue, hz in trials:
        start = int(round(cue * rate))
        if hz is None:
            f, p = signal.welch(x[start + second:start + 5 * second], rate, nperseg=second)
            alpha.append(10 * np.log10(p[(f >= 8) & (f <= 12)].mean()
                                       / p[(f >= 14) & (f <= 22)].mean()))
            continue
        power, noise = _response(x[start + int(1.5 * rate):start + 5 * second], rate, hz)
        snr.append(10 * np.log10(power / noise))
        for part, (a, b) in ((early, (0, 2)), (late, (3, 5))):
            power, noise = _response(x[start + a * second:start + b * second], rate, hz)
            part.append(power - noise)
    q1, median, q3 = np.percentile(snr, [25, 50, 75]) if snr else (np.nan,) * 3
    # Medians over the trials before the ratio: one trial's noise cannot blow it up.
    late_median = np.median(late) if late else np.nan
    return {'snr_db': float(median), 'snr_iqr_db': float(q3 - q1),
            'buildup': float(np.median(early) / late_median) if late_median > 0 else np.nan,
            'alpha_db': float(np.median(alpha)) if alpha else np.nan}
