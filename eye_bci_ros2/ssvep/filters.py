"""
Streaming EEG filters: band-pass, line-noise notch and the SSVEP filter bank.

Everything is causal second-order sections (``scipy.signal.sosfilt``) with
the state kept between chunks, so filtering a recording in chunks of any
size gives exactly what filtering it at once gives, and calibration and
live decoding see the same group delay.

The filter bank is Chen et al. 2015 (FBCCA, J. Neural Eng. 12 046008):
sub-band m (1-based) passes [8 m, 88] Hz (Chebyshev type I, 0.5 dB ripple,
stopband 2 Hz below the lower edge and at 100 Hz, both clipped under the
Nyquist frequency of slow amplifiers), and the sub-band scores are weighted
by ``m ** -1.25 + 0.25`` (:func:`filter_bank_weights`).
"""

from typing import Optional, Sequence, Tuple

import numpy as np
from scipy import signal

#: Chen 2015 sub-band weights w(m) = m^-a + b.
FB_WEIGHT_A = 1.25
FB_WEIGHT_B = 0.25
#: A filter has settled when the energy of its impulse response still to come is below
#: this share of the whole (-40 dB): a step or a gap's transient no longer shows in a score.
SETTLE_ENERGY = 1e-4
#: Longest impulse response looked at, s.
SETTLE_HORIZON_S = 10.0
#: Lower edge step of the sub-bands, Hz, and their common upper edge.
FB_STEP_HZ = 8.0
FB_UPPER_HZ = 88.0


def _check_rate(rate: float) -> None:
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f'sampling rate must be a positive number of Hz, got {rate!r}')


def preprocess_sos(rate: float, band: Sequence[float] = (6.0, 90.0),
                   notch_hz: float = 50.0, order: int = 4,
                   notch_q: float = 30.0) -> np.ndarray:
    """
    Design the band-pass (Butterworth) and notch of the raw EEG.

    :param rate: sampling rate, Hz.
    :param band: (low, high) pass band, Hz; high is clipped to 0.45 x rate.
    :param notch_hz: line frequency (50 or 60) to notch, Hz; 0 = none.
        Its harmonics below the clipped band edge are notched too.
    :param order: Butterworth order of each edge.
    :param notch_q: quality factor of each notch.
    :returns: sos, shape (S, 6).
    :raises ValueError: for a band that does not fit the rate.
    """
    _check_rate(rate)
    low, high = float(band[0]), min(float(band[1]), 0.45 * rate)
    if not 0.0 < low < high:
        raise ValueError(f'band ({band[0]:g}, {band[1]:g}) Hz does not fit a {rate:g} Hz '
                         f'stream (need 0 < low < high <= {0.45 * rate:g} Hz)')
    sections = [signal.butter(order, (low, high), btype='bandpass', fs=rate, output='sos')]
    if notch_hz and notch_hz > 0:
        line = float(notch_hz)
        while line < min(high + 5.0, 0.49 * rate):
            b, a = signal.iirnotch(line, notch_q, fs=rate)
            sections.append(signal.tf2sos(b, a))
            line += float(notch_hz)
    return np.concatenate(sections)


def filter_bank_sos(rate: float, bands: int = 5) -> Tuple[np.ndarray, ...]:
    """
    Design the Chen 2015 sub-band filters.

    :param rate: sampling rate, Hz.
    :param bands: number of sub-bands N (1-10); sub-bands whose lower edge
        does not fit under the Nyquist frequency raise.
    :returns: one sos array (S_m, 6) per sub-band.
    """
    _check_rate(rate)
    nyquist = 0.5 * rate
    upper = min(FB_UPPER_HZ, 0.8 * nyquist)
    stop_upper = min(100.0, 0.95 * nyquist)
    result = []
    for m in range(1, int(bands) + 1):
        low = FB_STEP_HZ * m
        if low + 4.0 >= upper:
            raise ValueError(f'sub-band {m} ({low:g} Hz and up) does not fit a {rate:g} Hz '
                             f'stream: use at most {m - 1} bands')
        passband = (low, upper)
        stopband = (max(low - 2.0, 1.0), stop_upper)
        order, wn = signal.cheb1ord(passband, stopband, 3, 40, fs=rate)
        result.append(signal.cheby1(order, 0.5, wn, btype='bandpass', fs=rate, output='sos'))
    return tuple(result)


def settle_time(sos: np.ndarray, rate: float) -> float:
    """
    Measured settle time of a causal filter, s.

    The time after which less than :data:`SETTLE_ENERGY` of the energy of
    the impulse response is still to come: started from rest (or restarted
    after a gap) the filter's output before then still carries the start-up
    transient.

    :param sos: second-order sections, (S, 6).
    """
    count = int(SETTLE_HORIZON_S * rate)
    impulse = np.zeros(count)
    impulse[0] = 1.0
    energy = signal.sosfilt(sos, impulse) ** 2
    remaining = np.cumsum(energy[::-1])[::-1]
    settled = np.flatnonzero(remaining <= SETTLE_ENERGY * remaining[0])
    return (settled[0] if len(settled) else count) / rate


def filter_bank_weights(bands: int) -> np.ndarray:
    """Chen 2015 sub-band weights ``m ** -1.25 + 0.25``, m = 1..bands, shape (bands,)."""
    m = np.arange(1, int(bands) + 1, dtype=float)
    return m ** -FB_WEIGHT_A + FB_WEIGHT_B


class StreamingFilterBank:
    """
    Band-pass + notch, then the filter bank, on chunks of a multichannel stream.

    :param rate: sampling rate, Hz.
    :param channels: number of channels C.
    :param bands: number of sub-bands B (0 = only the band-pass + notch,
        returned as one band).
    :param band: pass band of the preprocessing, Hz.
    :param notch_hz: line frequency, Hz (0 = none).
    """

    def __init__(self, rate: float, channels: int, bands: int = 5,
                 band: Sequence[float] = (6.0, 90.0), notch_hz: float = 50.0):
        if int(channels) < 1:
            raise ValueError(f'need at least one channel, got {channels}')
        self.rate = float(rate)
        self.channels = int(channels)
        self._pre = preprocess_sos(rate, band, notch_hz)
        self._bank = filter_bank_sos(rate, bands) if bands else ()
        self.bands = max(1, len(self._bank))
        #: Measured settle time of the slowest path (preprocessing + a sub-band), s.
        self.settle_s = max([settle_time(np.concatenate([self._pre, sos]), self.rate)
                             for sos in self._bank] or [settle_time(self._pre, self.rate)])
        self.reset()

    def reset(self) -> None:
        """Forget the filter state (a new stream, or after a gap)."""
        self._pre_zi = np.zeros((self._pre.shape[0], 2, self.channels))
        self._bank_zi = [np.zeros((sos.shape[0], 2, self.channels)) for sos in self._bank]

    def process(self, chunk: np.ndarray) -> np.ndarray:
        """
        Filter the next samples.

        :param chunk: raw EEG, shape (n, C), uV, in acquisition order.
        :returns: sub-band signals, shape (B, n, C), uV.
        """
        chunk = np.asarray(chunk, dtype=float)
        if chunk.ndim != 2 or chunk.shape[1] != self.channels:
            raise ValueError(f'expected a chunk of shape (n, {self.channels}), '
                             f'got {chunk.shape}')
        clean, self._pre_zi = signal.sosfilt(self._pre, chunk, axis=0, zi=self._pre_zi)
        if not self._bank:
            return clean[None]
        out = np.empty((len(self._bank),) + clean.shape)
        for index, sos in enumerate(self._bank):
            out[index], self._bank_zi[index] = signal.sosfilt(
                sos, clean, axis=0, zi=self._bank_zi[index])
        return out


def filter_recording(recording: np.ndarray, rate: float, bands: int = 5,
                     band: Sequence[float] = (6.0, 90.0),
                     notch_hz: Optional[float] = 50.0) -> np.ndarray:
    """
    Filter a whole recording as the live decoder would (causal, from rest).

    :param recording: raw EEG, shape (n, C), uV.
    :returns: shape (B, n, C).
    """
    recording = np.asarray(recording, dtype=float)
    bank = StreamingFilterBank(rate, recording.shape[1], bands, band, notch_hz or 0.0)
    return bank.process(recording)
