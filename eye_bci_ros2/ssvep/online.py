"""
Online SSVEP decoding of a stream: filtering, channel health, rounds, decisions.

:class:`OnlineDecoder` takes raw EEG chunks with their sample times (s, on
one clock, e.g. ROS time), filters them as they come (state kept), keeps the
last ``window_s`` + 1 s of filter-bank output in a ring buffer, and on
:meth:`OnlineDecoder.step` scores the window of the current round and says
whether the evidence is enough for a choice (:mod:`eye_bci_ros2.ssvep.decision`).

Rounds.  A round starts at a time (the stimulus epoch, a change of offered
options, a request); its window grows from the round start up to
``window_s`` and then slides (the newest ``window_s``).  At most one choice
per round; with ``keep_scoring`` the window is still scored after it (the
hybrid mode confirms a gaze candidate with these scores).

Junk never chooses:

- a non-finite sample or one at the amplifier's rail (``rail_uv``) is zeroed
  before filtering (so the filter state stays finite) and its channel is
  left out of every window that overlaps it or the ``settle_s`` after it
  (the filters ring);
- a channel whose filtered signal has a standard deviation below
  ``flat_uv`` in the window (disconnected, shorted) is left out;
- FBCCA decodes the remaining channels; TRCA needs all its channels;
- a stream whose sample times show a rate more than ``rate_tolerance`` off
  the nominal rate (over the last >= 1 s) decodes nothing, nor does one whose
  rate is not yet measured (the first second after connecting or a gap);
  after a gap in the sample times the filters restart and their first
  ``settle_s`` is left out;
- a stimulus map that lacks an offered option, fewer than 2 options, or a
  TRCA model without the options' stimuli decode nothing.

Each refusal is a :attr:`OnlineResult.problem` string the node logs.
"""

from collections import deque
from dataclasses import dataclass, field
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.ssvep.decision import DecisionRule
from eye_bci_ros2.ssvep.decoders import DECODERS, FbccaDecoder, TrcaModel
from eye_bci_ros2.ssvep.filters import StreamingFilterBank
from eye_bci_ros2.ssvep.stimuli import StimulusMap

#: Sample times further apart than this many sample periods are a gap.
GAP_PERIODS = 20
#: Span of sample times over which the rate is measured, s.
RATE_SPAN_S = 1.0


@dataclass(frozen=True)
class OnlineSettings:
    """
    Settings of the online decoder (the node's parameters of the same names).

    :param decoder: 'fbcca', 'trca' or 'ensemble_trca'.
    :param window_s: longest window, s (then it slides).
    :param min_window_s: shortest window that may choose, s.
    :param threshold: evidence needed (posterior or margin).
    :param rule: 'posterior' or 'margin'.
    :param gain: softmax gain of the posterior.
    :param bands: FBCCA sub-bands; ``harmonics`` in its references.
    :param band: preprocessing pass band, Hz; ``notch_hz`` line notch (0 = none).
    :param rail_uv: amplitude at which a sample counts as railed, uV.
    :param flat_uv: filtered standard deviation below which a channel is flat, uV.
    :param settle_s: how long a channel stays out after a bad sample, s.
    :param rate_tolerance: largest relative error of the measured rate.
    :param keep_scoring: after the round's choice keep scoring its window
        (no further choice): the hybrid mode's SSVEP evidence.
    """

    decoder: str = 'fbcca'
    window_s: float = 2.0
    min_window_s: float = 1.0
    threshold: float = 0.95
    rule: str = 'posterior'
    gain: float = 8.0
    bands: int = 5
    harmonics: int = 5
    band: Tuple[float, float] = (6.0, 90.0)
    notch_hz: float = 50.0
    rail_uv: float = 187500.0
    flat_uv: float = 0.1
    settle_s: float = 1.0
    rate_tolerance: float = 0.05
    keep_scoring: bool = False

    def __post_init__(self):
        """Reject settings that cannot work, with a reason."""
        if self.decoder not in DECODERS:
            raise ValueError(f"decoder '{self.decoder}' is not one of {', '.join(DECODERS)}")
        if not 0 < self.min_window_s <= self.window_s:
            raise ValueError(f'need 0 < min_window_s ({self.min_window_s}) <= window_s '
                             f'({self.window_s})')
        DecisionRule(self.rule, self.threshold, self.min_window_s, self.gain)


@dataclass
class OnlineResult:
    """
    What one step found.

    :param labels: the offered options, (K,).
    :param scores: decoder scores, (K,) (empty when nothing was decoded).
    :param posterior: (K,) probabilities (empty when nothing was decoded); with
        a rest score they sum to less than 1 (the rest: nothing attended).
    :param rest: FBCCA's best score at decoy frequencies, or None.
    :param window_s: length of the window scored, s.
    :param end_s: time of the window's last sample, s.
    :param choice: the chosen label, or None.
    :param problem: why nothing could be decoded, or None.
    :param excluded: channels left out of this window, with why.
    """

    labels: Tuple[str, ...]
    scores: np.ndarray = field(default_factory=lambda: np.zeros(0))
    posterior: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rest: Optional[float] = None
    window_s: float = 0.0
    end_s: float = 0.0
    choice: Optional[str] = None
    problem: Optional[str] = None
    excluded: List[str] = field(default_factory=list)


def decoy_frequencies(frequencies: np.ndarray) -> np.ndarray:
    """
    Frequencies no option uses, to score "nothing attended" (FBCCA).

    Halfway between neighbouring stimulus frequencies, and half the smallest
    spacing below the lowest and above the highest, Hz.
    """
    ordered = np.unique(np.asarray(frequencies, dtype=float))
    spacing = np.diff(ordered).min() if len(ordered) > 1 else 1.0
    return np.concatenate([[ordered[0] - spacing / 2], (ordered[1:] + ordered[:-1]) / 2,
                           [ordered[-1] + spacing / 2]])


class OnlineDecoder:
    """
    Decode SSVEP choices from a live EEG stream.

    :param rate: nominal sampling rate, Hz.
    :param channels: names of the C decoded channels.
    :param settings: see :class:`OnlineSettings`.
    :param model: a TRCA model (needed for 'trca' / 'ensemble_trca'); its
        rate, channels and filter settings must match.
    """

    def __init__(self, rate: float, channels: Sequence[str],
                 settings: OnlineSettings = OnlineSettings(),
                 model: Optional[TrcaModel] = None):
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f'the EEG stream needs a regular sampling rate, got {rate:g} Hz')
        self.rate = float(rate)
        self.channels = tuple(channels)
        self.settings = settings
        self.rule = DecisionRule(settings.rule, settings.threshold, settings.min_window_s,
                                 settings.gain)
        if settings.decoder != 'fbcca':
            if model is None:
                raise ValueError(f"decoder '{settings.decoder}' needs a TRCA model "
                                 f'(model_file; record one with ssvep_calibrate)')
            if abs(model.rate - self.rate) > 1e-6:
                raise ValueError(f'the TRCA model was fitted at {model.rate:g} Hz, the stream '
                                 f'runs at {self.rate:g} Hz')
            if tuple(model.channels) != self.channels:
                raise ValueError('the TRCA model was fitted on channels '
                                 f"{', '.join(model.channels)}, the decoder reads "
                                 f"{', '.join(self.channels)}")
            model.ensemble = settings.decoder == 'ensemble_trca'
            bands, band, notch = model.bands, model.band, model.notch_hz
        else:
            bands, band, notch = settings.bands, settings.band, settings.notch_hz
        self.model = model
        self._bank = StreamingFilterBank(self.rate, len(self.channels), bands, band, notch)
        self._capacity = int(math.ceil((settings.window_s + 1.0) * self.rate)) + 1
        self._data = np.zeros((self._bank.bands, 2 * self._capacity, len(self.channels)))
        self._times = np.zeros(2 * self._capacity)
        self._written = 0
        self._bad_until = np.full(len(self.channels), -np.inf)
        self._bad_why = [''] * len(self.channels)
        self._arrivals = deque()
        self._rate_problem: Optional[str] = None
        #: The rate was measured over RATE_SPAN_S since the last reset.
        self._rate_known = False
        #: The filters start from rest: the first settle_s are left out.
        self._settling = True
        self._fbcca_key = None
        self._fbcca_decoder: Optional[FbccaDecoder] = None
        self._round: Optional[Tuple[float, Tuple[str, ...], Optional[StimulusMap]]] = None
        self._done = False
        #: Counts of zeroed samples by reason since start.
        self.counters = {'nonfinite': 0, 'railed': 0, 'gaps': 0}

    # -- input ------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the signal (a new stream or a gap): filters and buffer restart."""
        self._bank.reset()
        self._written = 0
        self._arrivals.clear()
        self._rate_problem = None
        self._rate_known = False
        self._settling = True

    def add(self, times: np.ndarray, raw: np.ndarray) -> None:
        """
        Take the next samples.

        :param times: sample times, s, (n,), increasing.
        :param raw: samples of the decoded channels, (n, C), uV.
        """
        times = np.asarray(times, dtype=float)
        raw = np.array(raw, dtype=float)
        if raw.ndim != 2 or raw.shape != (len(times), len(self.channels)):
            raise ValueError(f'expected samples of shape ({len(times)}, {len(self.channels)}),'
                             f' got {raw.shape}')
        if not len(times):
            return
        last = self._times[(self._written - 1) % self._capacity] if self._written else None
        if last is not None and (times[0] - last > GAP_PERIODS / self.rate or times[0] < last):
            self.counters['gaps'] += 1
            self.reset()
        self._track_rate(times)
        if self._settling:
            self._settling = False
            self._bad_until[:] = np.maximum(self._bad_until, times[0] + self.settings.settle_s)
            self._bad_why = ['filters settling' if until == times[0] + self.settings.settle_s
                             else why for until, why in zip(self._bad_until, self._bad_why)]
        nonfinite = ~np.isfinite(raw)
        railed = np.zeros_like(nonfinite)
        railed[~nonfinite] = np.abs(raw[~nonfinite]) >= 0.99 * self.settings.rail_uv
        bad = nonfinite | railed
        if bad.any():
            self.counters['nonfinite'] += int(nonfinite.sum())
            self.counters['railed'] += int(railed.sum())
            raw[bad] = 0.0
            for channel in np.flatnonzero(bad.any(axis=0)):
                self._bad_until[channel] = times[-1] + self.settings.settle_s
                self._bad_why[channel] = ('NaN/inf samples' if nonfinite[:, channel].any()
                                          else 'railed')
        self._write(times, self._bank.process(raw))

    def _track_rate(self, times: np.ndarray) -> None:
        """Compare the rate the sample times show with the nominal rate."""
        self._arrivals.append((times[-1], len(times)))
        while len(self._arrivals) > 2 and self._arrivals[-1][0] - self._arrivals[1][0] \
                >= RATE_SPAN_S:
            self._arrivals.popleft()
        span = self._arrivals[-1][0] - self._arrivals[0][0]
        if span < RATE_SPAN_S:
            return
        count = sum(n for _, n in list(self._arrivals)[1:])
        measured = count / span
        self._rate_known = True
        if abs(measured / self.rate - 1.0) > self.settings.rate_tolerance:
            self._rate_problem = (f'the stream advertises {self.rate:g} Hz but its sample '
                                  f'times show {measured:.1f} Hz: decoding stopped (wrong '
                                  f'rate setting in the amplifier app, or lost samples)')
        else:
            self._rate_problem = None

    def _write(self, times: np.ndarray, filtered: np.ndarray) -> None:
        """Append to the doubled ring buffer (every window is one contiguous slice)."""
        n = len(times)
        if n >= self._capacity:
            times, filtered, n = times[-self._capacity:], filtered[:, -self._capacity:], \
                self._capacity
        start = self._written % self._capacity
        first = min(n, self._capacity - start)
        for offset in (0, self._capacity):
            self._times[offset + start:offset + start + first] = times[:first]
            self._data[:, offset + start:offset + start + first] = filtered[:, :first]
            if first < n:
                self._times[offset:offset + n - first] = times[first:]
                self._data[:, offset:offset + n - first] = filtered[:, first:]
        self._written += n

    # -- rounds -----------------------------------------------------------------------------

    def start_round(self, start_s: float, labels: Sequence[str],
                    stimuli: Optional[StimulusMap]) -> None:
        """Start a round at ``start_s`` among ``labels`` with these stimuli."""
        self._round = (float(start_s), tuple(labels), stimuli)
        self._done = False

    @property
    def round_open(self) -> bool:
        """Return whether a round is waiting for its choice."""
        return self._round is not None and not self._done

    def _window(self, start_s: float) -> Tuple[np.ndarray, np.ndarray]:
        """Filter-bank output of the round so far (at most window_s), and its times."""
        held = min(self._written, self._capacity)
        if not held:
            return np.zeros((self._bank.bands, 0, len(self.channels))), np.zeros(0)
        end = self._written % self._capacity + self._capacity
        times = self._times[end - held:end]
        keep = times >= start_s
        first = int(np.argmax(keep)) if keep.any() else held
        first = max(first, held - int(round(self.settings.window_s * self.rate)))
        return self._data[:, end - held + first:end], times[first:]

    def step(self) -> Optional[OnlineResult]:
        """Score the open round's window; None when no round is open."""
        if self._round is None or (self._done and not self.settings.keep_scoring):
            return None
        start_s, labels, stimuli = self._round
        result = OnlineResult(labels)
        if self._rate_problem:
            result.problem = self._rate_problem
            return result
        if not self._rate_known:
            return result  # the rate is checked over the first RATE_SPAN_S of samples
        if len(labels) < 2:
            result.problem = f'{len(labels)} option(s) offered: SSVEP needs at least 2'
            return result
        if stimuli is None:
            result.problem = 'no stimulus map yet (ssvep/stimuli)'
            return result
        mismatch = stimuli.mismatch(labels)
        if mismatch:
            result.problem = f'stimulus map does not match the options: {mismatch}'
            return result
        window, times = self._window(start_s)
        if len(times) < 2:
            return result
        result.window_s = len(times) / self.rate
        result.end_s = float(times[-1])
        if result.window_s < self.settings.min_window_s:
            return result
        good = self._bad_until < times[0]
        spread = window[0].std(axis=0)
        flat = spread < self.settings.flat_uv
        result.excluded = [f'{self.channels[c]} ({self._bad_why[c]})'
                           for c in np.flatnonzero(~good)]
        result.excluded += [f'{self.channels[c]} (flat)' for c in np.flatnonzero(good & flat)]
        good &= ~flat
        if not good.any():
            result.problem = f"no usable EEG channel: {', '.join(result.excluded)}"
            return result
        frequencies = np.array([stimuli.stimulus(label)[0] for label in labels])
        rest = None
        if self.model is None:
            decoder = self._fbcca(frequencies)
            all_scores = decoder.scores(window[:, :, good])
            scores, rest = all_scores[:len(labels)], float(all_scores[len(labels):].max())
        else:
            if not good.all():
                result.problem = (f"TRCA needs all its channels: {', '.join(result.excluded)}")
                return result
            problem = self._model_problem(labels, stimuli)
            if problem:
                result.problem = problem
                return result
            epoch = stimuli.epoch_s or start_s
            all_scores = self.model.scores(window, float(times[0]) - epoch)
            scores = all_scores[[self.model.labels.index(label) for label in labels]]
        result.scores = scores
        result.rest = rest
        result.posterior = self.rule.probabilities(scores, rest)
        index = self.rule.decide(scores, result.window_s, rest)
        if index is not None and not self._done:
            result.choice = labels[index]
            self._done = True
        return result

    def _fbcca(self, frequencies: np.ndarray) -> FbccaDecoder:
        """FBCCA of these stimuli plus their decoys (kept while the stimuli stay)."""
        key = tuple(frequencies.tolist())
        if self._fbcca_key != key:
            self._fbcca_key = key
            self._fbcca_decoder = FbccaDecoder(
                np.append(frequencies, decoy_frequencies(frequencies)), self.rate,
                self._bank.bands, self.settings.harmonics)
        return self._fbcca_decoder

    def _model_problem(self, labels: Sequence[str], stimuli: StimulusMap) -> Optional[str]:
        """Say why the TRCA model cannot score these options, or None."""
        missing = [label for label in labels if label not in self.model.labels]
        if missing:
            return (f"the TRCA model has no template for {', '.join(map(repr, missing))} "
                    f"(it knows {', '.join(map(repr, self.model.labels))}); calibrate again")
        for label in labels:
            index = self.model.labels.index(label)
            frequency, phase = stimuli.stimulus(label)
            if (abs(self.model.frequencies[index] - frequency) > 1e-6
                    or abs(math.remainder(self.model.phases[index] - phase, 2 * math.pi))
                    > 1e-6):
                return (f"'{label}' flickers at {frequency:g} Hz / {phase:g} rad but the TRCA "
                        f'model learnt it at {self.model.frequencies[index]:g} Hz / '
                        f'{self.model.phases[index]:g} rad')
        return None
