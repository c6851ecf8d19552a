"""
A simulated EEG amplifier on a simulated person attending SSVEP stimuli (pure numpy/scipy).

Each channel, in uV, is the sum of

- the SSVEP of the attended option: harmonics h = 1..3 of its frequency f,
  phase-locked to the stimulus (``sin(h (2 pi f (t - epoch - latency) + phase)
  + psi_h)``), amplitude ``ssvep_uv x harmonic_ratios[h-1]`` at Oz scaled by
  the channel's occipital weight, with a small seeded phase offset per channel;
  it starts ``delay_s + latency_s`` after attention is asked for, grows over
  ``buildup_s`` and drifts slowly in size (``drift``) (none while nothing is
  attended);
- background EEG: 1/f ("pink") noise, partly common to all channels, of RMS
  ``background_uv``, plus 8-12 Hz alpha of RMS ``alpha_uv`` over the back of
  the head, in bursts (``alpha_bursts``) and smaller while attending
  (``alpha_block``);
- line noise at ``line_hz`` (50 or 60) of amplitude ``line_uv`` (varying per
  channel);
- blinks (Poisson, ``blink_rate_hz``): 0.3 s bumps of ``blink_uv`` at Fp,
  falling off towards the back;
- faults on request: railed channels (stuck at the amplifier's full scale)
  and flat channels (0 uV).

The subjects (:data:`SUBJECTS`) span the SSVEP signal-to-noise ratios the
literature reports: narrow-band SNR at the fundamental (power at f over the
mean of the 10 neighbouring 0.1 Hz bins, Chen et al. 2015) from about 5 dB
to 20 dB at Oz, as in the Tsinghua benchmark dataset (Wang et al. 2017,
IEEE TNSRE 25(10)), where FBCCA with 1 s windows ranges from chance to ~100 %
across subjects.  ``bench/ssvep.py`` prints the SNR each subject gets.

Everything is generated chunk by chunk with carried filter state and one
random stream per source, so a recording made in chunks of any size equals
the one made at once (the outlet and the tests rely on it).

Batch use::

    sim = EegSimulator(SUBJECTS[3], layout='generic', seed=1)
    t, x = sim.simulate(4.0, [(0.0, 'kitchen'), (2.0, None)], stimuli)

Streaming use (times on one steady clock, e.g. ``pylsl.local_clock()``)::

    sim.start(now, stimuli)
    sim.set_attended('kitchen', now)
    times, chunk = sim.next_chunk(later)
"""

import bisect
from dataclasses import dataclass
import re
from typing import List, Optional, Sequence, Tuple

import numpy as np
from scipy import signal

from eye_bci_ros2.ssvep.layouts import EegLayout, LAYOUTS
from eye_bci_ros2.ssvep.stimuli import StimulusMap

#: Electrodes of the generic layout by default (a typical 8-channel SSVEP cap).
GENERIC_LABELS = ('PO7', 'PO3', 'POz', 'PO4', 'PO8', 'O1', 'Oz', 'O2')

#: SSVEP weight relative to Oz, by electrode position.
_OCCIPITAL_WEIGHT = {'oz': 1.0, 'o1': 0.9, 'o2': 0.9, 'poz': 0.85, 'po3': 0.75, 'po4': 0.75,
                     'po7': 0.65, 'po8': 0.65, 'iz': 0.8, 'pz': 0.5, 'p3': 0.4, 'p4': 0.4,
                     'p7': 0.35, 'p8': 0.35}
#: SSVEP / alpha / blink weight by the position's leading letters.
_REGION_WEIGHT = {'fp': (0.02, 0.1, 1.0), 'af': (0.03, 0.1, 0.8), 'f': (0.05, 0.2, 0.5),
                  'ft': (0.05, 0.2, 0.4), 'fc': (0.08, 0.2, 0.35), 'c': (0.15, 0.3, 0.2),
                  't': (0.1, 0.3, 0.15), 'cp': (0.25, 0.5, 0.1), 'tp': (0.15, 0.4, 0.1),
                  'p': (0.4, 0.8, 0.05), 'po': (0.7, 1.0, 0.03), 'o': (0.9, 1.0, 0.02),
                  'i': (0.8, 1.0, 0.02)}
#: Paul Kellet's pink-noise filter (1/f within 1 % from 0.0009 to 0.4 of the rate).
_PINK_B = np.array([0.049922035, -0.095993537, 0.050612699, -0.004408786])
_PINK_A = np.array([1.0, -2.494956002, 2.017265875, -0.522189400])
#: Where a railed channel of a layout without a known range sticks, uV (a +-500 uV
#: amplifier such as the g.Mobilab+).
UNKNOWN_RAIL_UV = 500.0
#: Time constants of the SSVEP's drift and of the alpha bursts, s.
DRIFT_TAU_S = 2.0
ALPHA_TAU_S = 0.5
#: Longest extra rest between calibration trials, s (uniform from 0).
REST_JITTER_S = 0.5
#: Blink length, s.
BLINK_S = 0.3


@dataclass(frozen=True)
class EegSubject:
    """
    One simulated person.

    :param name: short name.
    :param ssvep_uv: amplitude of the SSVEP fundamental at Oz, uV.
    :param harmonic_ratios: amplitude of harmonics 1, 2, 3 relative to it.
    :param latency_s: visual latency, s (typically 0.13-0.15).
    :param background_uv: RMS of the 1/f background per channel, uV.
    :param alpha_uv: RMS of alpha over the occiput, uV.
    :param alpha_hz: alpha peak, Hz.
    :param line_uv: line noise amplitude, uV.
    :param blink_rate_hz: blinks per second.
    :param blink_uv: blink amplitude at Fp, uV.
    :param buildup_s: the SSVEP grows from nothing to its full size over this
        long after the latency (a raised-cosine ramp), s; 0 = at once.
    :param delay_s: attention reaches the option this long after it is asked
        for (a cue heard, the gaze moving), s.
    :param drift: standard deviation of the slow random change of the SSVEP's
        size (natural log of its amplitude, time constant :data:`DRIFT_TAU_S`):
        attention waxes and wanes; 0 = a steady response.
    :param alpha_bursts: the same for the alpha rhythm's envelope (time
        constant :data:`ALPHA_TAU_S`): alpha comes in bursts.
    :param alpha_block: alpha's size while an option is attended, relative to rest.
    """

    name: str
    ssvep_uv: float
    harmonic_ratios: Tuple[float, ...] = (1.0, 0.55, 0.3)
    latency_s: float = 0.14
    background_uv: float = 12.0
    alpha_uv: float = 2.5
    alpha_hz: float = 10.0
    line_uv: float = 15.0
    blink_rate_hz: float = 0.25
    blink_uv: float = 150.0
    buildup_s: float = 0.0
    delay_s: float = 0.0
    drift: float = 0.0
    alpha_bursts: float = 0.0
    alpha_block: float = 1.0


#: Seeded subjects from weak to strong responders (see the module doc).
SUBJECTS = (
    EegSubject('s1', 3.0, alpha_uv=4.0),
    EegSubject('s2', 3.5, alpha_uv=3.5),
    EegSubject('s3', 4.2, latency_s=0.15),
    EegSubject('s4', 5.0, alpha_uv=2.0),
    EegSubject('s5', 6.0, latency_s=0.13),
    EegSubject('s6', 7.0, alpha_uv=2.0),
    EegSubject('s7', 8.5, latency_s=0.15),
    EegSubject('s8', 10.0, alpha_uv=1.5),
)

#: Subjects like the people of real recordings (Kalunga et al. 2016, 256 Hz LEDs): a
#: response 1-2 uV at Oz that builds up over ~1 s after a cue and drifts from trial to
#: trial, alpha in bursts that competes with it.  Matched to the recordings'
#: statistics (:func:`eye_bci_ros2.recordings.eeg.session_statistics`; the test
#: ``test/sim/test_sim_eeg_real.py`` holds them within stated tolerances); the bench's
#: simulated figures use them.
REALISTIC_SUBJECTS = tuple(
    EegSubject(f'r{index + 1}', uv, alpha_uv=alpha, alpha_hz=hz, buildup_s=0.8, delay_s=0.7,
               drift=0.45, alpha_bursts=0.6, alpha_block=0.7)
    for index, (uv, alpha, hz) in enumerate(
        ((0.8, 4.0, 10.5), (0.95, 5.0, 9.5), (1.1, 3.5, 11.0), (1.3, 4.5, 10.0),
         (1.5, 4.0, 10.5), (1.8, 5.5, 9.0), (2.1, 3.5, 11.5), (2.5, 4.5, 10.0))))


def _weights(position: str) -> Tuple[float, float, float]:
    """(SSVEP, alpha, blink) weight of an electrode position ('' = not EEG)."""
    key = position.strip().lower()
    match = re.fullmatch(r'([a-y]{1,3})(z|[0-9]{1,2})', key)
    if match is None or match.group(1) not in _REGION_WEIGHT:
        return 0.0, 0.0, 0.0  # not a 10-10 position: accelerometer, counter, ...
    ssvep, alpha, blink = _REGION_WEIGHT[match.group(1)]
    return _OCCIPITAL_WEIGHT.get(key, ssvep), alpha, blink


class EegSimulator:
    """
    A seeded EEG amplifier on one subject.

    :param subject: the person.
    :param layout: amplifier layout name (:data:`eye_bci_ros2.ssvep.layouts.LAYOUTS`).
    :param rate: sampling rate, Hz (default: the layout's).
    :param labels: channel labels (generic layout only; default
        :data:`GENERIC_LABELS`).
    :param seed: random seed.
    :param railed: labels of channels stuck at full scale.
    :param flat: labels of channels reading 0 uV.
    :param line_hz: line frequency, Hz.
    """

    def __init__(self, subject: EegSubject, layout: str = 'generic',
                 rate: Optional[float] = None, labels: Optional[Sequence[str]] = None,
                 seed: int = 0, railed: Sequence[str] = (), flat: Sequence[str] = (),
                 line_hz: float = 50.0):
        if layout not in LAYOUTS:
            raise ValueError(f"unknown layout '{layout}' (one of {', '.join(LAYOUTS)})")
        self.subject = subject
        self.layout: EegLayout = LAYOUTS[layout]
        self.rate = float(rate or self.layout.nominal_srate)
        if layout == 'generic':
            self.labels: Tuple[str, ...] = tuple(labels or GENERIC_LABELS)
        elif labels is not None:
            raise ValueError(f"layout '{layout}' has fixed channels; labels are for 'generic'")
        else:
            self.labels = self.layout.channel_labels
        self.positions = self.layout.positions(list(self.labels))
        count = len(self.labels)
        weights = np.array([_weights(p) for p in self.positions])
        self._ssvep_w, self._alpha_w, self._blink_w = weights.T
        self._eeg = self._ssvep_w + self._alpha_w + self._blink_w > 0
        unknown = [name for name in tuple(railed) + tuple(flat) if name not in self.labels
                   and name not in self.positions]
        if unknown:
            raise ValueError(f"no channel {', '.join(unknown)} in {self.labels}")
        self._railed = np.array([lab in railed or pos in railed
                                 for lab, pos in zip(self.labels, self.positions)])
        self._flat = np.array([lab in flat or pos in flat
                               for lab, pos in zip(self.labels, self.positions)])
        self.line_hz = float(line_hz)
        root = np.random.SeedSequence(int(seed))
        seeds = root.spawn(5)
        # The person's response pattern is theirs (seeded by name, the same in every
        # recording, which is what TRCA learns); the noise is the recording's.
        person = np.random.default_rng(list(subject.name.encode()))
        self._channel_phase = person.normal(0.0, 0.25, count)
        self._harmonic_phase = person.uniform(-np.pi, np.pi, len(subject.harmonic_ratios))
        fixed = np.random.default_rng(seeds[0])
        self._line_gain = fixed.uniform(0.5, 1.5, count)
        self._line_phase = fixed.uniform(0, 2 * np.pi, count)
        self._noise_rng = np.random.default_rng(seeds[1])
        self._alpha_rng = np.random.default_rng(seeds[2])
        self._blink_seed = int(seeds[3].generate_state(1)[0])
        # Slow log-normal modulations: the SSVEP's drift and the alpha bursts (AR(1)).
        self._drift_rng = np.random.default_rng(seeds[4])
        taus = np.array([DRIFT_TAU_S, ALPHA_TAU_S])
        self._drift_a = np.exp(-1.0 / (taus * self.rate))
        self._drift_sd = np.array([subject.drift, subject.alpha_bursts])
        self._drift_state = self._drift_rng.standard_normal(2) * self._drift_sd
        # Pink noise: 60 % common, 40 % own, normalised to background_uv RMS.
        self._pink_sos = signal.tf2sos(_PINK_B, _PINK_A)
        self._pink_gain = subject.background_uv / self._pink_rms()
        low, high = subject.alpha_hz - 1.5, subject.alpha_hz + 1.5
        self._alpha_sos = signal.butter(2, (low, high), btype='bandpass', fs=self.rate,
                                        output='sos')
        self._alpha_gain = subject.alpha_uv * np.sqrt(self.rate / (2 * (high - low)))
        self._pink_zi = np.zeros((self._pink_sos.shape[0], 2, count + 1))
        self._alpha_zi = np.zeros((self._alpha_sos.shape[0], 2, count))
        self._index = 0
        self._start = 0.0
        self._stimuli: Optional[StimulusMap] = None
        self._schedule: List[Tuple[float, Optional[str]]] = []
        self._blinks = {}

    def _pink_rms(self) -> float:
        """RMS of the pink filter's steady output for unit white noise."""
        rng = np.random.default_rng(0)
        out = signal.sosfilt(self._pink_sos, rng.standard_normal(20000))
        return float(np.std(out[5000:]))

    # -- streaming ----------------------------------------------------------------------------

    def start(self, now: float, stimuli: Optional[StimulusMap] = None) -> None:
        """Start the recording at ``now`` (s), sample 0 acquired then."""
        self._start = float(now)
        self._index = 0
        self._stimuli = stimuli
        self._schedule = []

    def set_stimuli(self, stimuli: Optional[StimulusMap]) -> None:
        """Show a new stimulus map (its epoch on the simulator's clock)."""
        self._stimuli = stimuli

    def set_attended(self, label: Optional[str], now: float) -> None:
        """Attend the stimulus of option ``label`` (None = none) from ``now`` on."""
        bisect.insort(self._schedule, (float(now), label), key=lambda item: item[0])

    @property
    def sample_count(self) -> int:
        """Return the samples generated so far."""
        return self._index

    def next_chunk(self, until: float) -> Tuple[np.ndarray, np.ndarray]:
        """
        Generate the samples acquired up to ``until`` (s, the simulator's clock).

        :returns: ``(times (n,), samples (n, C))``, s and uV.
        """
        end = int(np.floor((until - self._start) * self.rate)) + 1
        count = max(0, end - self._index)
        return self._generate(count)

    # -- batch --------------------------------------------------------------------------------

    def simulate(self, duration_s: float, schedule: Sequence[Tuple[float, Optional[str]]],
                 stimuli: StimulusMap, start_s: float = 0.0) -> Tuple[np.ndarray, np.ndarray]:
        """
        Record ``duration_s`` of EEG from ``start_s`` on.

        :param schedule: (time s, attended label or None) in time order.
        :param stimuli: the stimulus map (its ``epoch_s`` on the same clock).
        :returns: ``(times (n,), samples (n, C))``.
        """
        self.start(start_s, stimuli)
        for time_s, label in schedule:
            self.set_attended(label, time_s)
        return self._generate(int(round(duration_s * self.rate)))

    # -- generation ---------------------------------------------------------------------------

    def _generate(self, count: int) -> Tuple[np.ndarray, np.ndarray]:
        index = self._index + np.arange(count)
        self._index += count
        t = self._start + index / self.rate
        channels = len(self.labels)
        if count == 0:
            return t, np.zeros((0, channels))
        white = self._noise_rng.standard_normal((count, channels + 1))
        pink, self._pink_zi = signal.sosfilt(self._pink_sos, white, axis=0, zi=self._pink_zi)
        pink *= self._pink_gain
        background = 0.775 * pink[:, :1] + 0.632 * pink[:, 1:]
        alpha, self._alpha_zi = signal.sosfilt(
            self._alpha_sos, self._alpha_rng.standard_normal((count, channels)), axis=0,
            zi=self._alpha_zi)
        drift = self._modulation(count)
        bursts = np.exp(drift[:, 1] - 0.5 * self.subject.alpha_bursts ** 2)  # unit mean power
        attending = np.isfinite(self._attended_stimulus(t)[0])
        alpha *= (bursts * np.where(attending, self.subject.alpha_block, 1.0))[:, None]
        out = background + self._alpha_gain * alpha * self._alpha_w
        out += self.subject.line_uv * self._line_gain * np.sin(
            2 * np.pi * self.line_hz * t[:, None] + self._line_phase)
        out += self._ssvep_channels(t) * np.exp(drift[:, :1])
        out += self._blink_wave(t)[:, None] * self._blink_w
        out[:, ~self._eeg] = 0.0
        out[:, self._flat] = 0.0
        out[:, self._railed] = self.layout.rail_uv or UNKNOWN_RAIL_UV
        return t, out

    def _modulation(self, count: int) -> np.ndarray:
        """Log-amplitude of the SSVEP drift and the alpha envelope per sample, (n, 2)."""
        noise = self._drift_rng.standard_normal((count, 2)) * self._drift_sd \
            * np.sqrt(1 - self._drift_a ** 2)
        out = np.empty((count, 2))
        for column in range(2):
            out[:, column], state = signal.lfilter(
                [1.0], [1.0, -self._drift_a[column]], noise[:, column],
                zi=[self._drift_a[column] * self._drift_state[column]])
            self._drift_state[column] = out[-1, column] if count else self._drift_state[column]
        return out

    def _attended_stimulus(self, t: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """
        Return the stimulus driving the EEG at t: frequency (NaN = none), phase, how long.

        :returns: ``(frequency, phase, since)``, each (n,); ``since``: s since
            the response to it began.
        """
        frequency = np.full(t.shape, np.nan)
        phase = np.zeros(t.shape)
        since = np.zeros(t.shape)
        if self._stimuli is None or not self._schedule:
            return frequency, phase, since
        times = np.array([s[0] for s in self._schedule])
        # Attention reaches the option delay_s after it is asked for; the visual system
        # answers latency_s later.
        lagged = t - self.subject.latency_s - self.subject.delay_s
        which = np.searchsorted(times, lagged, side='right') - 1
        for row, (start, label) in enumerate(self._schedule):
            if label is None or label not in self._stimuli.labels:
                continue
            mask = which == row
            if mask.any():
                frequency[mask], phase[mask] = self._stimuli.stimulus(label)
                since[mask] = lagged[mask] - start
        return frequency, phase, since

    def _ssvep_channels(self, t: np.ndarray) -> np.ndarray:
        """SSVEP per channel, (n, C), uV."""
        frequency, phase, since = self._attended_stimulus(t)
        on = np.isfinite(frequency)
        out = np.zeros((len(t), len(self.labels)))
        if not on.any():
            return out
        epoch = self._stimuli.epoch_s
        base = (2 * np.pi * frequency[on] * (t[on] - epoch - self.subject.latency_s)
                + phase[on])
        wave = np.zeros((int(on.sum()), len(self.labels)))
        for h, ratio in enumerate(self.subject.harmonic_ratios, start=1):
            wave += ratio * np.sin(h * (base[:, None] + self._channel_phase[None, :])
                                   + self._harmonic_phase[h - 1])
        ramp = np.ones(int(on.sum()))
        if self.subject.buildup_s > 0:
            ramp = 0.5 * (1 - np.cos(np.pi * np.clip(since[on] / self.subject.buildup_s,
                                                     0.0, 1.0)))
        out[on] = self.subject.ssvep_uv * wave * self._ssvep_w * ramp[:, None]
        return out

    def _blink_wave(self, t: np.ndarray) -> np.ndarray:
        """Blink potential at Fp, uV, (n,): onsets drawn per whole second of the run."""
        wave = np.zeros(t.shape)
        if self.subject.blink_rate_hz <= 0:
            return wave
        first = int(np.floor(t[0] - self._start - BLINK_S))
        last = int(np.floor(t[-1] - self._start))
        for second in range(max(first, 0), last + 1):
            onsets = self._blinks.get(second)
            if onsets is None:
                rng = np.random.default_rng([self._blink_seed, second])
                onsets = second + rng.uniform(0, 1, rng.poisson(self.subject.blink_rate_hz))
                self._blinks[second] = onsets
                self._blinks.pop(second - 3, None)
            for onset in onsets:
                phase = (t - self._start - onset) / BLINK_S
                inside = (phase >= 0) & (phase < 1)
                wave[inside] += self.subject.blink_uv * 0.5 * (
                    1 - np.cos(2 * np.pi * phase[inside]))
        return wave


def narrowband_snr_db(x: np.ndarray, rate: float, frequency: float,
                      neighbours: int = 10) -> float:
    """
    SSVEP SNR of one channel: power at ``frequency`` over the mean of its neighbours.

    :param x: one channel, shape (n,), several seconds.
    :param neighbours: bins on each side / 2 (Chen et al. 2015 use 10 bins in all).
    :returns: dB, at 0.1 Hz resolution (zero padded to 10 s).
    """
    n = max(len(x), int(10 * rate))
    spectrum = np.abs(np.fft.rfft(x - np.mean(x), n)) ** 2
    freqs = np.fft.rfftfreq(n, 1.0 / rate)
    k = int(np.argmin(np.abs(freqs - frequency)))
    side = neighbours // 2
    around = np.r_[spectrum[k - side:k], spectrum[k + 1:k + 1 + side]]
    return float(10 * np.log10(spectrum[k] / around.mean()))


def calibration_session(simulator: EegSimulator, stimuli: StimulusMap, trials_per_option: int,
                        trial_s: float = 2.0, rest_s: float = 1.0, seed: int = 0,
                        rest_trials: int = 0, phase_locked: bool = True,
                        ) -> Tuple[np.ndarray, np.ndarray, List[Tuple[float, Optional[str]]]]:
    """
    Record a cue-guided calibration: each option attended ``trials_per_option`` times.

    Trials come in a seeded random order; each starts its stimuli at the
    onset (the stimulus epoch of that trial), lasts ``trial_s`` and is
    followed by ``rest_s`` (plus up to :data:`REST_JITTER_S`) with nothing
    attended.  The first trial starts after ``rest_s``.  With ``phase_locked``
    False the stimuli keep flickering from the session's start (LEDs): their
    phase at an onset is whatever it is.  ``rest_trials`` more trials (label None) show the
    stimuli while the person attends none of them (a fixation point).

    :returns: ``(times (n,), samples (n, C), trials [(onset s, label or None)])``.
    """
    order = np.repeat(np.arange(len(stimuli.labels) + 1),
                      [int(trials_per_option)] * len(stimuli.labels) + [int(rest_trials)])
    rng = np.random.default_rng(seed)
    rng.shuffle(order)
    simulator.start(0.0, None)
    times, chunks, trials = [], [], []
    now = float(rest_s)
    t, x = simulator.next_chunk(now - 0.5 / simulator.rate)
    times.append(t)
    chunks.append(x)
    for target in order:
        label = stimuli.labels[target] if target < len(stimuli.labels) else None
        simulator.set_stimuli(StimulusMap(stimuli.labels, stimuli.frequencies, stimuli.phases,
                                          now if phase_locked else 0.0))
        simulator.set_attended(label, now)
        trials.append((now, label))
        end = now + trial_s
        simulator.set_attended(None, end)
        # A person takes a varying time to be ready for the next cue: trials are not
        # locked to the mains (whose residue TRCA would otherwise learn as a response).
        now = end + rest_s + rng.uniform(0.0, REST_JITTER_S)
        t, x = simulator.next_chunk(now - 0.5 / simulator.rate)
        times.append(t)
        chunks.append(x)
    return np.concatenate(times), np.concatenate(chunks), trials


def cued_recording(subject: EegSubject, seed: int = 0, frequencies=(13.0, 17.0, 21.0),
                   per_class: int = 8, rate: float = 256.0, trial_s: float = 5.0,
                   rest_s: float = 1.5):
    """
    Simulate a session of the real recordings' protocol (Kalunga et al. 2016).

    ``per_class`` cued trials of ``trial_s`` per stimulus and as many rest
    trials (nothing attended), in a seeded order, on the generic layout's 8
    occipital channels; the stimuli flicker freely (their phase at a cue is
    whatever it is, as LEDs).

    :returns: an :class:`eye_bci_ros2.recordings.eeg.EegRecording`.
    """
    from eye_bci_ros2.recordings.eeg import EegRecording  # noqa: I100 - sim -> loader form
    labels = tuple(f'{f:g} Hz' for f in frequencies)
    stimuli = StimulusMap(labels, tuple(frequencies), (0.0,) * len(labels))
    simulator = EegSimulator(subject, rate=rate, seed=seed)
    times, samples, trials = calibration_session(simulator, stimuli, per_class, trial_s,
                                                 rest_s, seed, rest_trials=per_class,
                                                 phase_locked=False)
    cues = tuple((cue - times[0], None if label is None else frequencies[labels.index(label)])
                 for cue, label in trials)
    return EegRecording(f'sim_{subject.name}_{seed}', subject.name, samples, rate,
                        tuple(simulator.labels), cues)
