"""
Online SSVEP decoding of a stream: filtering, channel health, rounds, decisions.

:class:`OnlineDecoder` takes raw EEG chunks with their sample times (s, on
one clock, e.g. ROS time), filters them as they come (state kept), keeps the
last ``window_s`` + 1 s of filter-bank output in a ring buffer, and on
:meth:`OnlineDecoder.step` scores the window of the current round and says
whether the evidence is enough for a choice (:mod:`eye_bci_ros2.ssvep.decision`).

Rounds.  A round starts at a time (the stimulus epoch, a change of offered
options, a request); its window starts ``onset_s`` later (the gaze reaching
the option and the SSVEP building up: what comes before would only dilute
the response), grows up to ``window_s`` and then slides (the newest
``window_s``).  Each option's evidence is measured against a rest model (the
null: nobody attends it), so a round where nobody attends ends without a
choice (:mod:`eye_bci_ros2.ssvep.decision`).  At most one choice
per round; with ``keep_scoring`` the window is still scored after it (the
hybrid mode confirms a gaze candidate with these scores).

Junk never chooses:

- a non-finite sample or one at the amplifier's rail (``rail_uv``) is zeroed
  before filtering (so the filter state stays finite) and its channel is
  left out of every window that overlaps it or the ``settle_s`` after it
  (the filters ring);
- at the start and after a gap the filters restart: windows start
  ``settle_s`` (measured from the filters) after it;
- a channel whose filtered signal has a standard deviation below
  ``flat_uv`` in the window (disconnected, shorted) is left out;
- FBCCA decodes the remaining channels; TRCA needs all its channels;
- the true rate is measured from the sample times (least squares over the
  last 10 s): a stream more than ``rate_tolerance`` off its nominal rate
  (lost samples, a wrong setting) decodes nothing, nor does one whose rate is
  not yet measured (the first second after connecting or a gap); one off by
  more than the stimuli's precision (:meth:`OnlineDecoder.rate_precision`:
  a 256 Hz stream advertised as 250 Hz) is decoded at the measured rate
  (FBCCA, one note) or refused (a TRCA model fitted at another rate);
- a stimulus map that lacks an offered option, fewer than 2 options, or a
  TRCA model without the options' stimuli decode nothing.
- FBCCA decides nothing until its null for the decoded channels, rate and
  stimuli is measured (``background_null``: off the decision path, once per
  process and settings, when they are first seen).

Each refusal is a :attr:`OnlineResult.problem` string the node logs.
"""

from collections import deque
from dataclasses import dataclass, field
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.ssvep.decision import (DecisionRule, DEFAULT_GAIN, DEFAULT_HOLD_S,
                                         DEFAULT_REST_Z, HeldDecision, RestModel)
from eye_bci_ros2.ssvep.decoders import (DECODERS, fbcca_null, fbcca_null_soon, FbccaDecoder,
                                         null_windows, sideband_hz, sideband_statistic, TrcaModel,
                                         with_sidebands)
from eye_bci_ros2.ssvep.filters import StreamingFilterBank
from eye_bci_ros2.ssvep.stimuli import StimulusMap

#: Default start of a round's window after the round, s: a gaze shift to the option
#: (:data:`eye_bci_ros2.experiments.metrics.GAZE_SHIFT_S`, 0.5 s) and the SSVEP's build-up
#: to steady state (about 0.5 s, more for some people).
DEFAULT_ONSET_S = 1.0
#: A clipped stretch (unknown rail): this many identical samples in a row ...
STUCK_SAMPLES = 4
#: ... at least this far from zero, uV.
STUCK_MIN_UV = 100.0
#: Sample times further apart than this many sample periods are a gap.
GAP_PERIODS = 20
#: Shortest span of sample times over which the rate is measured before decoding, s.
RATE_SPAN_S = 1.0
#: The rate is measured over the last this many seconds of sample times, s.
RATE_WINDOW_S = 10.0
#: Shortest span before the measured rate may replace the advertised one (stamp jitter of
#: a few ms then moves it by well under the precision needed), s.
RATE_PRECISE_SPAN_S = 5.0
#: Share of the frequency resolution a rate error may shift the decoded components.
RATE_RESOLUTION_SHARE = 0.25
#: Decimals of an adopted rate, Hz.
RATE_DECIMALS = 2
#: Samples are filtered at each step, or once this much is waiting, s.
FILTER_BATCH_S = 0.1


@dataclass(frozen=True)
class OnlineSettings:
    """
    Settings of the online decoder (the node's parameters of the same names).

    :param decoder: 'fbcca', 'trca' or 'ensemble_trca'.
    :param window_s: longest window, s (then it slides).
    :param min_window_s: shortest window that may choose, s.
    :param threshold: evidence needed (posterior or margin).
    :param rule: 'posterior' or 'margin'.
    :param gain: the posterior's gain (expected evidence z of an attended option).
    :param rest_z: evidence z at which "nothing attended" is as likely as one
        option (:mod:`eye_bci_ros2.ssvep.decision`).
    :param hold_s: an option is chosen once it has qualified in every step
        over this long, s (:class:`eye_bci_ros2.ssvep.decision.HeldDecision`).
    :param onset_s: the window of a round starts this long after the round:
        the person's gaze reaching the option and the SSVEP building up, s.
    :param bands: FBCCA sub-bands; ``harmonics`` in its references.
    :param band: preprocessing pass band, Hz; ``notch_hz`` line notch (0 = none).
    :param rail_uv: amplitude at which a sample counts as railed, uV; 0 = the
        amplifier's range is unknown: a clipped stretch counts (see ``_railed``).
    :param flat_uv: filtered standard deviation below which a channel is flat, uV.
    :param settle_s: how long a channel stays out after a bad sample, a
        start or a gap, s; 0 = the filters' measured settle time
        (:func:`eye_bci_ros2.ssvep.filters.settle_time`).
    :param rate_tolerance: largest relative error of the measured rate.
    :param keep_scoring: after the round's choice keep scoring its window
        (no further choice): the hybrid mode's SSVEP evidence.
    """

    decoder: str = 'fbcca'
    window_s: float = 2.0
    min_window_s: float = 1.0
    threshold: float = 0.95
    rule: str = 'posterior'
    gain: float = DEFAULT_GAIN
    rest_z: float = DEFAULT_REST_Z
    hold_s: float = DEFAULT_HOLD_S
    onset_s: float = DEFAULT_ONSET_S
    bands: int = 5
    harmonics: int = 5
    band: Tuple[float, float] = (6.0, 90.0)
    notch_hz: float = 50.0
    rail_uv: float = 0.0
    flat_uv: float = 0.1
    settle_s: float = 0.0
    rate_tolerance: float = 0.05
    keep_scoring: bool = False

    def __post_init__(self):
        """Reject settings that cannot work, with a reason."""
        if self.decoder not in DECODERS:
            raise ValueError(f"decoder '{self.decoder}' is not one of {', '.join(DECODERS)}")
        if not 0 < self.min_window_s <= self.window_s:
            raise ValueError(f'need 0 < min_window_s ({self.min_window_s}) <= window_s '
                             f'({self.window_s})')
        self.decision_rule()
        if not 0 <= self.onset_s <= 10.0:
            raise ValueError(f'onset_s must be in [0, 10] s, got {self.onset_s}')

    def decision_rule(self) -> DecisionRule:
        """Return the decision rule these settings make (checked by it)."""
        return DecisionRule(self.rule, self.threshold, self.min_window_s, self.gain,
                            self.rest_z, self.hold_s)


@dataclass
class OnlineResult:
    """
    What one step found.

    :param labels: the offered options, (K,).
    :param scores: decoder scores, (K,) (empty when nothing was decoded).
    :param posterior: (K,) probabilities (empty when nothing was decoded); with
        a rest score they sum to less than 1 (the rest: nothing attended).
    :param evidence: each option's evidence z against the rest model, (K,).
    :param rest: the posterior of "nothing attended" (1 - the options' sum), or None.
    :param window_s: length of the window scored, s.
    :param end_s: time of the window's last sample, s.
    :param choice: the chosen label, or None.
    :param problem: why nothing could be decoded, or None.
    :param excluded: channels left out of this window, with why.
    """

    labels: Tuple[str, ...]
    scores: np.ndarray = field(default_factory=lambda: np.zeros(0))
    posterior: np.ndarray = field(default_factory=lambda: np.zeros(0))
    evidence: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rest: Optional[float] = None
    window_s: float = 0.0
    end_s: float = 0.0
    choice: Optional[str] = None
    problem: Optional[str] = None
    excluded: List[str] = field(default_factory=list)


class OnlineDecoder:
    """
    Decode SSVEP choices from a live EEG stream.

    :param rate: nominal sampling rate, Hz.
    :param channels: names of the C decoded channels.
    :param settings: see :class:`OnlineSettings`.
    :param model: a TRCA model (needed for 'trca' / 'ensemble_trca'); its
        rate, channels and filter settings must match.
    :param background_null: measure the FBCCA null (seconds of CPU at 1000 Hz x
        32 channels) in the background when a count of usable channels or a set
        of stimuli is first seen, and decide nothing until it is there (a live
        stream: no step ever waits for it);
        False = measure it in the step that first needs it (offline replay,
        where steps stand for stream time, not wall time).
    """

    def __init__(self, rate: float, channels: Sequence[str],
                 settings: OnlineSettings = OnlineSettings(),
                 model: Optional[TrcaModel] = None, background_null: bool = False):
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f'the EEG stream needs a regular sampling rate, got {rate:g} Hz')
        self.rate = float(rate)
        self.channels = tuple(channels)
        self.settings = settings
        self.rule = settings.decision_rule()
        self._held = HeldDecision(self.rule)
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
        self._filter_settings = (bands, band, notch)
        self._background_null = background_null
        #: The rate the stream advertises, Hz; :attr:`rate` is the one decoded at.
        self.nominal_rate = self.rate
        #: The rate the sample times show (None until measured), Hz.
        self.measured_rate: Optional[float] = None
        self._rate_span = 0.0
        self._arrivals = deque()
        #: Running sums of the rate's least squares: n, t, count, t^2, t count (from _origin).
        self._sums = np.zeros(5)
        self._origin = (0.0, 0)
        self._counted = 0
        self._bad_until = np.full(len(self.channels), -np.inf)
        self._bad_why = [''] * len(self.channels)
        self._stuck = np.zeros(len(self.channels), dtype=int)
        self._previous = np.full(len(self.channels), np.nan)
        self._rate_problem: Optional[str] = None
        #: The rate was measured over RATE_SPAN_S since the last reset.
        self._rate_known = False
        self._round: Optional[Tuple[float, Tuple[str, ...], Optional[StimulusMap]]] = None
        self._done = False
        #: Time from which the filters' output is settled, s.
        self._settled_at = math.inf
        #: Counts of zeroed samples by reason since start.
        self.counters = {'nonfinite': 0, 'railed': 0, 'gaps': 0}
        #: One-line notes for the user (e.g. the rate adopted), to log and clear.
        self.notes: List[str] = []
        self._build(self.rate)

    def _build(self, rate: float) -> None:
        """Build filters and buffer at ``rate`` (at start; when the measured rate is adopted)."""
        self.rate = float(rate)
        bands, band, notch = self._filter_settings
        self._bank = StreamingFilterBank(self.rate, len(self.channels), bands, band, notch)
        #: How long filter output stays out after a start, a gap or a bad sample, s.
        self.settle_s = self.settings.settle_s or self._bank.settle_s
        self._capacity = int(math.ceil((self.settings.window_s + 1.0) * self.rate)) + 1
        self._data = np.zeros((self._bank.bands, 2 * self._capacity, len(self.channels)))
        self._times = np.zeros(2 * self._capacity)
        self._fbcca_key = None
        self._fbcca_decoder: Optional[FbccaDecoder] = None
        self._restart()

    # -- input ------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the signal (a new stream or a gap): filters, buffer and rate restart."""
        self._arrivals.clear()
        self._sums[:] = 0.0
        self._rate_problem = None
        self._rate_known = False
        self._rate_span = 0.0
        self._restart()

    def _restart(self) -> None:
        """Restart the filters from rest and empty the buffer (the rate stays measured)."""
        self._bank.reset()
        self._pending = []
        self._pending_count = 0
        self._written = 0
        self._previous[:] = np.nan
        self._stuck[:] = 0
        #: The filters start from rest: their first settle_s are left out.
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
        last = None
        if self._pending:
            last = self._pending[-1][0][-1]
        elif self._written:
            last = self._times[(self._written - 1) % self._capacity]
        if last is not None and (times[0] - last > GAP_PERIODS / self.rate or times[0] < last):
            self.counters['gaps'] += 1
            self.reset()
        self._track_rate(times)
        if self._settling:
            # The filters' start-up transient: every window starts after it.
            self._settling = False
            self._settled_at = float(times[0]) + self.settle_s
        nonfinite = ~np.isfinite(raw)
        railed = self._railed(raw, nonfinite)
        bad = nonfinite | railed
        if bad.any():
            self.counters['nonfinite'] += int(nonfinite.sum())
            self.counters['railed'] += int(railed.sum())
            raw[bad] = 0.0
            for channel in np.flatnonzero(bad.any(axis=0)):
                self._bad_until[channel] = times[-1] + self.settle_s
                self._bad_why[channel] = ('NaN/inf samples' if nonfinite[:, channel].any()
                                          else 'railed')
        # Filtered when a step needs them: one filter call per step instead of per chunk
        # (the filters give the same output in any chunking; the calls' overhead was most
        # of the decoder's CPU at 0.02 s chunks).
        self._pending.append((times, raw))
        self._pending_count += len(times)
        if self._pending_count >= FILTER_BATCH_S * self.rate:  # no step for a while
            self._flush()

    def _flush(self) -> None:
        """Filter the samples taken since the last step and buffer them."""
        if not self._pending:
            return
        times = np.concatenate([t for t, _ in self._pending])
        raw = np.concatenate([r for _, r in self._pending])
        self._pending, self._pending_count = [], 0
        self._write(times, self._bank.process(raw))

    def _railed(self, raw: np.ndarray, nonfinite: np.ndarray) -> np.ndarray:
        """
        Mark the samples at the amplifier's rail, (n, C) bool.

        At or beyond 99 % of ``rail_uv`` when the amplifier's range is known;
        else (``rail_uv`` 0) a clipped stretch: :data:`STUCK_SAMPLES` or more
        identical samples in a row at least :data:`STUCK_MIN_UV` from zero
        (EEG never repeats a value that far out; a clipping ADC does).
        """
        finite = np.where(nonfinite, 0.0, raw)
        if self.settings.rail_uv > 0:
            return ~nonfinite & (np.abs(finite) >= 0.99 * self.settings.rail_uv)
        railed = np.zeros(raw.shape, dtype=bool)
        previous = np.vstack([self._previous, finite])
        same = (previous[1:] == previous[:-1]) & (np.abs(finite) >= STUCK_MIN_UV)
        for channel in np.flatnonzero(same.any(axis=0)):
            run = self._stuck[channel]
            for index in range(len(finite)):
                run = run + 1 if same[index, channel] else 0
                railed[index, channel] = run >= STUCK_SAMPLES - 1
            self._stuck[channel] = run
        self._stuck[~same.any(axis=0)] = 0
        if len(finite):
            self._previous = np.where(nonfinite[-1], np.nan, finite[-1])
        return railed

    def _track_rate(self, times: np.ndarray) -> None:
        """
        Measure the stream's true rate from its sample times (least squares).

        Over the last :data:`RATE_WINDOW_S` of chunks: the slope of the samples
        counted against the stamps of the chunks' last samples, so neither
        chunking nor per-chunk stamp jitter biases it.
        """
        if not self._arrivals:
            self._origin = (float(times[0]), self._counted)
        self._counted += len(times)
        point = (float(times[-1]) - self._origin[0], float(self._counted - self._origin[1]))
        self._arrivals.append(point)
        self._sums += (1.0, point[0], point[1], point[0] ** 2, point[0] * point[1])
        while len(self._arrivals) > 2 and \
                self._arrivals[-1][0] - self._arrivals[1][0] >= RATE_WINDOW_S:
            t, c = self._arrivals.popleft()
            self._sums -= (1.0, t, c, t * t, t * c)
        span = self._arrivals[-1][0] - self._arrivals[0][0]
        if span < RATE_SPAN_S or len(self._arrivals) < 2:
            return
        n, st, sc, stt, stc = self._sums
        measured = float((n * stc - st * sc) / (n * stt - st * st))
        self.measured_rate, self._rate_span = measured, span
        self._rate_known = True
        if abs(measured / self.nominal_rate - 1.0) > self.settings.rate_tolerance:
            self._rate_problem = (f'the stream advertises {self.nominal_rate:g} Hz but its '
                                  f'sample times show {measured:.1f} Hz: decoding stopped '
                                  f'(wrong rate setting in the amplifier app, or lost samples)')
        else:
            self._rate_problem = None

    def rate_precision(self, frequencies: Sequence[float]) -> float:
        """
        Largest relative rate error the decoder tolerates for these stimuli.

        A rate off by e shifts a component at f by f e in the decoder's eyes;
        the second harmonic of the highest stimulus (FBCCA's and TRCA's
        strongest component after the fundamental) must stay within a quarter
        of the frequency resolution 1 / window_s.
        """
        top = 2.0 * max(frequencies)
        return RATE_RESOLUTION_SHARE / (top * self.settings.window_s)

    def _rate_mismatch(self, frequencies: Sequence[float]) -> Optional[str]:
        """
        Adopt the measured rate when it is off the one in use beyond the precision (FBCCA).

        A TRCA model was fitted at one rate: a stream at another is refused.
        :returns: the refusal, or None.
        """
        if self._rate_span < RATE_PRECISE_SPAN_S or self.measured_rate is None:
            return None
        error = self.measured_rate / self.rate - 1.0
        if abs(error) <= self.rate_precision(frequencies):
            return None
        if self.model is not None:
            return (f'the stream runs at {self.measured_rate:.2f} Hz by its sample times, not '
                    f'{self.rate:g} Hz as the TRCA model was fitted ({100 * error:+.1f} %, '
                    f'more than the {100 * self.rate_precision(frequencies):.2f} % these '
                    "stimuli allow): fix the amplifier app's rate or calibrate again")
        adopted = round(self.measured_rate, RATE_DECIMALS)
        self.notes.append(f'the stream advertises {self.nominal_rate:g} Hz but its sample '
                          f'times show {adopted:g} Hz: decoding at {adopted:g} Hz')
        self._build(adopted)
        return None

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
        self._held.interrupt()
        if self.model is None and self._background_null and stimuli is not None:
            # Start measuring this stimulus set's rest model now (every channel usable, as
            # usual): it runs while the window's onset and shortest length pass, instead of
            # from the first decision step on.
            try:
                self._null(len(self.channels),
                           np.array([stimuli.stimulus(label)[0] for label in labels]))
            except (KeyError, ValueError):
                pass  # an option without a stimulus: the step says so

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
        keep = times >= max(start_s + self.settings.onset_s, self._settled_at)
        first = int(np.argmax(keep)) if keep.any() else held
        first = max(first, held - int(round(self.settings.window_s * self.rate)))
        return self._data[:, end - held + first:end], times[first:]

    def step(self) -> Optional[OnlineResult]:
        """Score the open round's window; None when no round is open."""
        if self._round is None or (self._done and not self.settings.keep_scoring):
            return None
        self._flush()
        result = self._step()
        if not len(result.evidence):  # nothing scored: the evidence no longer holds
            self._held.interrupt()
        return result

    def _step(self) -> OnlineResult:
        """Score the open round's window (:meth:`step`)."""
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
        problem = self._rate_mismatch(frequencies)
        if problem or not self._written:  # refused, or restarted at the measured rate
            result.problem = problem
            return result
        if self.model is None:
            null = self._null(int(good.sum()), frequencies)
            if null is None:
                result.problem = (f'measuring the FBCCA rest model for {int(good.sum())} '
                                  f'channels at {self.rate:g} Hz and these stimuli (up to a few '
                                  'seconds, once)')
                return result
            all_scores = self._fbcca(frequencies).scores(window[:, :, good])
            scores = all_scores[:len(labels)]
            statistic = sideband_statistic(all_scores)
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
            scores = statistic = all_scores[[self.model.labels.index(label) for label in labels]]
            null = self.model.rest
        result.scores = scores
        result.evidence = null.z(statistic, result.window_s)
        result.posterior = self.rule.probabilities(result.evidence)
        result.rest = float(1.0 - result.posterior.sum())
        index = self._held.update(result.evidence, result.window_s, result.end_s)
        if index is not None and not self._done:
            result.choice = labels[index]
            self._done = True
        return result

    def _fbcca(self, frequencies: np.ndarray) -> FbccaDecoder:
        """FBCCA of these stimuli and their sidebands (kept while they stay)."""
        key = (tuple(frequencies.tolist()), self.rate)
        if self._fbcca_key != key:
            self._fbcca_key = key
            self._fbcca_decoder = FbccaDecoder(
                with_sidebands(frequencies, sideband_hz(self.settings.min_window_s)),
                self.rate, self._bank.bands, self.settings.harmonics)
        return self._fbcca_decoder

    def _null(self, channels: int, frequencies: np.ndarray) -> Optional[RestModel]:
        """
        Return the FBCCA null for this many decoded channels and these stimuli at this rate.

        None while it is measured in the background (``background_null``).
        """
        bands, band, notch = self._filter_settings
        key = (self.rate, channels, bands, self.settings.harmonics, tuple(band), notch,
               null_windows(self.settings.min_window_s, self.settings.window_s),
               sideband_hz(self.settings.min_window_s), tuple(frequencies.tolist()))
        return fbcca_null_soon(*key) if self._background_null else fbcca_null(*key)

    def _model_problem(self, labels: Sequence[str], stimuli: StimulusMap) -> Optional[str]:
        """Say why the TRCA model cannot score these options, or None."""
        if self.model.rest is None:
            return ('the TRCA model has no rest model (its scores cannot be told from '
                    'nobody attending); calibrate again with ssvep_calibrate')
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
