"""
A simulated person looking at a screen through an eye tracker: pure numpy, no ROS, no LSL.

The person looks at a *target* given by a script (where the experiment wants
them to look), never at the system's decisions.  Frames and units:

* screen: the display the person looks at; origin top-left, x right, y down,
  pixels (1920x1080 by default, the RViz machine of the original report).
* Visual angles are in degrees.  The eye sits on the perpendicular through the
  screen centre at ``distance_mm``; a screen point (x, y) px is the ray
  ``(x_mm, y_mm, distance_mm)`` from the eye (eye frame: x right, y down,
  z towards the screen, like an optical camera).
* Times are seconds on any steady clock (``pylsl.local_clock`` when streaming).

Model, per sample (see :class:`PersonParams` for the numbers):

1. Eye: fixates the current target.  When the target appears or moves by more
   than ``retarget_deg`` the eye starts a saccade after a latency
   (``latency_min_ms`` + gamma, mean ``latency_ms``).  A pending saccade is
   skipped when a later target change would set off no later (the eye then
   goes straight to the newer place); a target that moves in small steps is
   followed with about one latency of lag by small catch-up saccades.
   Saccades are ballistic (a new one waits for the current one to land), last
   ``saccade_base_ms + saccade_ms_per_deg * amplitude`` (the main sequence,
   Carpenter 1988: about 30-60 ms for 5-20 deg) and follow a minimum-jerk
   profile along the straight screen line (a great circle of the eye, since a
   plane shows great circles as straight lines).
2. Tracker error, added as a rotation of the gaze ray: a constant per-person
   offset (accuracy, ``offset_deg`` in a direction fixed by the seed), an
   optional slow drift (sum of two sinusoids per axis, RMS ``drift_deg``) and
   white Gaussian jitter (precision, ``jitter_deg`` standard deviation per
   axis).  The error is in degrees, so it covers more pixels towards the
   screen edges, as on a real tracker.
3. Lost samples: blinks (a renewal process, ``blink_rate_per_min``, each
   lasting ``blink_min_ms``..``blink_max_ms``) and independent losses with
   probability ``loss_prob``.  Lost samples are NaN: an LSL sender emits
   them as NaN, which the bridge drops ('nonfinite'), like trackers that flag
   invalid gaze with NaN.

Microsaccades and the correlated (coloured) part of real tracker noise are
not modelled.

Seeds: every random process has its own stream derived from the seed, so a
run is reproducible and the same samples come out whether a run is generated
at once (:meth:`GazeSimulator.simulate`) or chunk by chunk in real time
(:meth:`GazeSimulator.next_chunk`) with the same targets set at the same times.
"""

from dataclasses import dataclass, field, fields, replace
import math
from numbers import Real
from typing import Callable, List, Optional, Sequence, Tuple, Union

import numpy as np

from eye_bci_ros2.visual_angle import ScreenGeometry

#: A target: screen px (x, y), or None when there is nothing to look at.
Target = Optional[Sequence[float]]
#: A script of targets: ``[(t_start_s, target), ...]`` in time order, or a
#: callable ``target(t (N,)) -> (N, 2)`` screen px with NaN rows for "none".
TargetSchedule = Union[Sequence[Tuple[float, Target]], Callable[[np.ndarray], np.ndarray]]


def _check(condition: bool, message: str) -> None:
    """Raise ValueError(message) unless condition holds."""
    if not condition:
        raise ValueError(message)


@dataclass(frozen=True)
class PersonParams:
    """
    How the simulated person moves their eyes and how well the tracker measures them.

    Angles in degrees of visual angle, times in ms unless named otherwise.

    :param offset_deg: accuracy: constant gaze error of this person after
        calibration (magnitude).
    :param offset_direction_deg: direction of that error on the screen
        (0 = right, 90 = down); None = drawn uniformly from the seed.
    :param jitter_deg: precision: standard deviation of white Gaussian noise,
        per axis.
    :param drift_deg: RMS per axis of a slow drift of the error (0 = none).
    :param drift_period_s: typical period of the drift, s.
    :param latency_ms: mean saccade latency after a target appears or moves.
    :param latency_min_ms: shortest latency (express saccades are ~100 ms).
    :param latency_sd_ms: standard deviation of the latency (gamma
        distributed above the minimum; 0 = constant).
    :param saccade_base_ms: saccade duration for a zero amplitude (main sequence).
    :param saccade_ms_per_deg: extra duration per degree of amplitude.
    :param saccade_max_ms: longest saccade.
    :param retarget_deg: the eye only re-targets when the target moves at
        least this far from the place it last aimed for.
    :param blink_rate_per_min: mean blinks per minute (0 = none).
    :param blink_min_ms: shortest blink (samples lost).
    :param blink_max_ms: longest blink (uniform in between).
    :param loss_prob: probability that the tracker loses any one sample.
    :param screen: the person's screen and viewing distance.
    """

    offset_deg: float = 0.5
    offset_direction_deg: Optional[float] = None
    jitter_deg: float = 0.3
    drift_deg: float = 0.0
    drift_period_s: float = 8.0
    latency_ms: float = 200.0
    latency_min_ms: float = 120.0
    latency_sd_ms: float = 40.0
    saccade_base_ms: float = 21.0
    saccade_ms_per_deg: float = 2.2
    saccade_max_ms: float = 100.0
    retarget_deg: float = 0.5
    blink_rate_per_min: float = 15.0
    blink_min_ms: float = 100.0
    blink_max_ms: float = 300.0
    loss_prob: float = 0.01
    screen: ScreenGeometry = field(default_factory=ScreenGeometry)

    def __post_init__(self):
        """Reject values a person cannot have, saying which and why."""
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in ('screen', 'offset_direction_deg'):
                continue
            _check(isinstance(value, Real) and math.isfinite(value) and value >= 0,
                   f'{f.name} must be a finite number >= 0, got {value!r}')
        if self.offset_direction_deg is not None:
            _check(math.isfinite(self.offset_direction_deg),
                   f'offset_direction_deg must be finite, got {self.offset_direction_deg}')
        _check(self.offset_deg < 30 and self.jitter_deg < 30 and self.drift_deg < 30,
               'offset_deg, jitter_deg and drift_deg must be below 30 degrees')
        _check(self.latency_ms >= self.latency_min_ms,
               f'latency_ms ({self.latency_ms}) must be >= latency_min_ms '
               f'({self.latency_min_ms})')
        _check(self.drift_period_s > 0, 'drift_period_s must be > 0')
        _check(self.saccade_max_ms > 0, 'saccade_max_ms must be > 0')
        _check(0 < self.blink_min_ms <= self.blink_max_ms,
               f'need 0 < blink_min_ms <= blink_max_ms, got {self.blink_min_ms}, '
               f'{self.blink_max_ms}')
        _check(self.blink_rate_per_min * (self.blink_min_ms + self.blink_max_ms) / 2 < 60000,
               'blinks would take up all the time: lower blink_rate_per_min or the durations')
        _check(self.loss_prob < 1, f'loss_prob must be < 1, got {self.loss_prob}')
        _check(isinstance(self.screen, ScreenGeometry), 'screen must be a ScreenGeometry')

    @property
    def blink_fraction(self) -> float:
        """Return the expected fraction of time spent blinking."""
        return self.blink_rate_per_min / 60.0 * (self.blink_min_ms + self.blink_max_ms) / 2e3

    @property
    def lost_fraction(self) -> float:
        """Return the expected fraction of samples lost to blinks or tracking loss."""
        return 1.0 - (1.0 - self.blink_fraction) * (1.0 - self.loss_prob)


@dataclass(frozen=True)
class TrackerParams:
    """
    Timing of the eye tracker.

    :param rate_hz: sampling rate, Hz.
    :param timing_jitter_ms: standard deviation of each sample's acquisition
        time around its nominal grid point, ms (clipped to 0.45 periods so the
        order never changes).
    :param delay_ms: acquisition to sending (tracker processing and
        transport), ms; used by the LSL streamer.
    """

    rate_hz: float = 90.0
    timing_jitter_ms: float = 0.3
    delay_ms: float = 10.0

    def __post_init__(self):
        """Reject impossible timing."""
        _check(isinstance(self.rate_hz, Real) and 0 < self.rate_hz <= 10000,
               f'rate_hz must be in (0, 10000], got {self.rate_hz!r}')
        for name in ('timing_jitter_ms', 'delay_ms'):
            value = getattr(self, name)
            _check(isinstance(value, Real) and math.isfinite(value) and value >= 0,
                   f'{name} must be a finite number >= 0, got {value!r}')


@dataclass(frozen=True)
class GazeParams:
    """
    A simulated person with a tracker: what :class:`GazeSimulator` takes.

    :param person: eye movements and measurement error.
    :param tracker: sampling.
    :param name: label for reports.
    """

    person: PersonParams = field(default_factory=PersonParams)
    tracker: TrackerParams = field(default_factory=TrackerParams)
    name: str = 'custom'

    def with_changes(self, **changes) -> 'GazeParams':
        """
        Return a copy with fields of the person, tracker or screen replaced.

        Example: ``CONSUMER_TRACKER.with_changes(offset_deg=1.0, rate_hz=60)``.

        :raises ValueError: an unknown field name or an invalid value.
        """
        groups = {'person': {}, 'tracker': {}, 'screen': {}, 'self': {}}
        names = {
            'person': {f.name for f in fields(PersonParams)} - {'screen'},
            'tracker': {f.name for f in fields(TrackerParams)},
            'screen': {f.name for f in fields(ScreenGeometry)},
            'self': {'name'},
        }
        for key, value in changes.items():
            group = next((g for g, known in names.items() if key in known), None)
            if group is None:
                raise ValueError(f"unknown gaze parameter '{key}'; known: "
                                 f"{', '.join(sorted(set().union(*names.values())))}")
            groups[group][key] = value
        screen = replace(self.person.screen, **groups['screen'])
        person = replace(self.person, screen=screen, **groups['person'])
        return replace(self, person=person, tracker=replace(self.tracker, **groups['tracker']),
                       **groups['self'])


#: A consumer remote tracker (Tobii 4C/5 class): 90 Hz, 0.5 deg accuracy,
#: 0.3 deg precision.  The benchmarks use this preset.
CONSUMER_TRACKER = GazeParams(
    person=PersonParams(offset_deg=0.5, jitter_deg=0.3, loss_prob=0.01),
    tracker=TrackerParams(rate_hz=90.0, timing_jitter_ms=0.3, delay_ms=10.0),
    name='consumer_tracker')

#: The original set-up: Tobii 4C at the measured ~87 Hz, calibrated on the
#: Linux screen by imagining the Windows calibration points, so a larger
#: offset and a little drift are assumed (the report gives no accuracy
#: figure in degrees).
ORIGINAL_TOBII_4C = GazeParams(
    person=PersonParams(offset_deg=0.8, jitter_deg=0.3, drift_deg=0.1, loss_prob=0.02),
    tracker=TrackerParams(rate_hz=87.0, timing_jitter_ms=0.5, delay_ms=20.0),
    name='original_tobii_4c')

#: Presets by name (the ``sim_gaze --preset`` choices).
PRESETS = {p.name: p for p in (CONSUMER_TRACKER, ORIGINAL_TOBII_4C)}


@dataclass
class GazeTrace:
    """
    Simulated samples.

    :param t: acquisition times, s, shape (N,).
    :param xy: measured gaze, screen px, shape (N, 2); NaN where lost.
    :param eye_xy: where the eye really pointed (no tracker error), shape (N, 2).
    :param blink: sample falls in a blink, shape (N,).
    :param dropped: sample lost by the tracker (independent losses), shape (N,).
    """

    t: np.ndarray
    xy: np.ndarray
    eye_xy: np.ndarray
    blink: np.ndarray
    dropped: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        """Return which samples hold a measurement, shape (N,)."""
        return ~(self.blink | self.dropped)

    def __len__(self) -> int:
        """Return the number of samples."""
        return len(self.t)


def _minimum_jerk(tau: np.ndarray) -> np.ndarray:
    """Fraction of a saccade's path covered at normalised time tau in [0, 1]."""
    return tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)


def _as_target(xy: Target, what: str) -> Optional[np.ndarray]:
    """Validate a target: None or finite (x, y) px."""
    if xy is None:
        return None
    array = np.asarray(xy, dtype=float)
    _check(array.shape == (2,) and bool(np.all(np.isfinite(array))),
           f'{what} must be None or a finite (x, y) in screen px, got {xy!r}')
    return array


class _Run:
    """
    One simulation run: random streams, pending targets, committed saccades, blinks.

    Times only move forward.  Saccades are committed once their onset is
    covered by emitted samples; no later target can cancel them because every
    later saccade starts at least ``latency_min_ms`` after the latest sample.
    """

    def __init__(self, sim: 'GazeSimulator', t0: float, initial_xy: Target):
        person = sim.params.person
        self.sim = sim
        self.person = person
        self.t0 = float(t0)
        seeds = sim._seeds
        self.rng_timing = np.random.default_rng(seeds[0])
        self.rng_latency = np.random.default_rng(seeds[1])
        self.rng_jitter = np.random.default_rng(seeds[2])
        self.rng_loss = np.random.default_rng(seeds[3])
        self.rng_blink = np.random.default_rng(seeds[4])
        start = _as_target(initial_xy, 'initial_xy')
        if start is None:
            start = person.screen.centre_px
        # Saccade records: onset s, duration s, start px, goal px.
        self.onsets: List[float] = [-math.inf]
        self.durations: List[float] = [0.0]
        self.starts: List[np.ndarray] = [start]
        self.goals: List[np.ndarray] = [start]
        # Pending targets, in insertion order: (time, target or None, onset).
        self.pending: List[Tuple[float, Optional[np.ndarray], float]] = []
        self.aimed: Optional[np.ndarray] = None
        self.has_event = False
        self.last_event_t = -math.inf
        self.t_last = -math.inf
        self.n_emitted = 0
        self.retarget_px = person.screen.visual_angle_px(person.retarget_deg)
        self.blink_starts = np.empty(0)
        self.blink_ends = np.empty(0)
        mean_gap = self._mean_blink_gap()
        self.next_blink = (self.t0 + self.rng_blink.exponential(mean_gap)
                           if person.blink_rate_per_min > 0 else math.inf)

    def _mean_blink_gap(self) -> float:
        """Mean time from the end of a blink to the next one, s."""
        person = self.person
        if person.blink_rate_per_min <= 0:
            return math.inf
        return 60.0 / person.blink_rate_per_min - (person.blink_min_ms
                                                   + person.blink_max_ms) / 2e3

    def _latency_s(self) -> float:
        """Draw one saccade latency, s."""
        person = self.person
        excess = (person.latency_ms - person.latency_min_ms) / 1e3
        sd = person.latency_sd_ms / 1e3
        if excess <= 0 or sd <= 0:
            return person.latency_min_ms / 1e3 + excess
        shape = (excess / sd) ** 2
        return person.latency_min_ms / 1e3 + self.rng_latency.gamma(shape, excess / shape)

    def add_target(self, xy: Target, t: float) -> None:
        """Show a target (or none) from time t on; earlier times are moved to now."""
        xy = _as_target(xy, 'target')
        _check(math.isfinite(t), f'target time must be finite, got {t}')
        t = max(float(t), self.last_event_t, self.t_last)
        if xy is None:
            if self.aimed is None and self.has_event:
                return
        elif self.aimed is not None and np.hypot(*(xy - self.aimed)) < self.retarget_px:
            return
        self.aimed = xy
        self.has_event = True
        self.last_event_t = t
        self.pending.append((t, xy, t + self._latency_s()))

    def _plan(self, t_end: float) -> None:
        """Commit the saccades whose onset is at or before t_end."""
        if not self.pending:
            return
        onsets = np.array([p[2] for p in self.pending])
        # An event is cancelled by any later event that sets off no later.
        suffix_min = np.minimum.accumulate(onsets[::-1])[::-1]
        later_min = np.append(suffix_min[1:], math.inf)
        kept = [p for p, cancelled in zip(self.pending, onsets >= later_min) if not cancelled]
        self.pending = [p for p in kept if p[2] > t_end]
        screen = self.person.screen
        for _, goal, onset in (p for p in kept if p[2] <= t_end):
            previous_end = self.onsets[-1] + self.durations[-1]
            start = self.goals[-1]
            if goal is None or np.array_equal(goal, start):
                continue
            # Saccades are ballistic: a new one waits for the current one to land.
            onset = max(onset, previous_end)
            amplitude = float(screen.angle_between_deg(start, goal))
            duration = min(self.person.saccade_base_ms
                           + self.person.saccade_ms_per_deg * amplitude,
                           self.person.saccade_max_ms) / 1e3
            self.onsets.append(onset)
            self.durations.append(duration)
            self.starts.append(start)
            self.goals.append(goal)

    def _ensure_blinks(self, t_end: float) -> None:
        """Draw blinks up to t_end (one at a time, so chunking does not matter)."""
        person = self.person
        starts, ends = [], []
        while self.next_blink <= t_end:
            duration = self.rng_blink.uniform(person.blink_min_ms, person.blink_max_ms) / 1e3
            starts.append(self.next_blink)
            ends.append(self.next_blink + duration)
            self.next_blink += duration + self.rng_blink.exponential(self._mean_blink_gap())
        if starts:
            self.blink_starts = np.append(self.blink_starts, starts)
            self.blink_ends = np.append(self.blink_ends, ends)

    def nominal_times(self, first: int, count: int) -> np.ndarray:
        """Acquisition times of samples first..first+count-1 on the tracker's clock."""
        tracker = self.sim.params.tracker
        period = 1.0 / tracker.rate_hz
        jitter = self.rng_timing.standard_normal(count) * (tracker.timing_jitter_ms / 1e3)
        jitter = np.clip(jitter, -0.45 * period, 0.45 * period)
        return self.t0 + (first + np.arange(count)) * period + jitter

    def emit(self, t: np.ndarray) -> GazeTrace:
        """Generate the samples at times t (sorted, after every earlier sample)."""
        person = self.person
        n = len(t)
        if n == 0:
            empty = np.empty((0, 2))
            return GazeTrace(np.empty(0), empty, empty.copy(), np.zeros(0, bool),
                             np.zeros(0, bool))
        _check(bool(np.all(np.isfinite(t))), 'sample times must be finite')
        _check(bool(np.all(np.diff(t) >= 0)), 'sample times must be in increasing order')
        _check(t[0] >= self.t_last, 'sample times must come after the samples already made')
        self._plan(t[-1])
        onsets = np.array(self.onsets)
        index = np.searchsorted(onsets, t, side='right') - 1
        durations = np.maximum(np.array(self.durations)[index], 1e-9)
        tau = np.clip((t - onsets[index]) / durations, 0.0, 1.0)
        starts = np.array(self.starts)[index]
        goals = np.array(self.goals)[index]
        eye = starts + (goals - starts) * _minimum_jerk(tau)[:, None]

        error = self.sim.offset_vector_deg + self.sim.drift_deg(t)
        error = error + self.rng_jitter.standard_normal((n, 2)) * person.jitter_deg
        xy = person.screen.rotate_gaze(eye, error)

        dropped = self.rng_loss.random(n) < person.loss_prob
        self._ensure_blinks(t[-1])
        blink = np.zeros(n, dtype=bool)
        if len(self.blink_starts):
            k = np.searchsorted(self.blink_starts, t, side='right') - 1
            blink = (k >= 0) & (t < self.blink_ends[np.maximum(k, 0)])
        xy[blink | dropped] = np.nan

        self.t_last = float(t[-1])
        # Keep only the saccade and blinks that later samples can still fall in.
        keep = max(int(index[-1]), 0)
        del self.onsets[:keep], self.durations[:keep], self.starts[:keep], self.goals[:keep]
        alive = self.blink_ends > self.t_last
        self.blink_starts, self.blink_ends = self.blink_starts[alive], self.blink_ends[alive]
        return GazeTrace(t=np.array(t, dtype=float), xy=xy, eye_xy=eye, blink=blink,
                         dropped=dropped)


class GazeSimulator:
    """
    A seeded simulated person with an eye tracker.

    Batch use::

        sim = GazeSimulator(CONSUMER_TRACKER, seed=3)
        trace = sim.simulate(10.0, [(0.0, (960, 540)), (2.0, (300, 200))])
        xy = sim.samples(t, schedule)          # (N, 2) px, NaN = lost

    Streaming use (times on one steady clock, e.g. ``pylsl.local_clock()``)::

        sim.start(now)
        sim.set_target((300, 200), now)
        chunk = sim.next_chunk(later)          # samples acquired up to ``later``

    :param params: the person and tracker (:data:`CONSUMER_TRACKER` by default).
    :param seed: random seed; the same seed and targets give the same samples.
    """

    def __init__(self, params: GazeParams = CONSUMER_TRACKER, seed: int = 0):
        _check(isinstance(params, GazeParams),
               f'params must be a GazeParams (e.g. CONSUMER_TRACKER), got {type(params)}')
        _check(isinstance(seed, (int, np.integer)) and seed >= 0,
               f'seed must be an integer >= 0, got {seed!r}')
        self.params = params
        self.seed = int(seed)
        root = np.random.SeedSequence(self.seed)
        self._seeds = root.spawn(6)
        person_rng = np.random.default_rng(self._seeds[5])
        person = params.person
        direction = person.offset_direction_deg
        if direction is None:
            direction = person_rng.uniform(0.0, 360.0)
        angle = math.radians(direction)
        #: The person's constant error (right, down), degrees, shape (2,).
        self.offset_vector_deg = person.offset_deg * np.array([math.cos(angle), math.sin(angle)])
        # Drift: two sinusoids per axis with amplitude drift_deg each, which gives
        # an RMS of drift_deg per axis.
        self._drift_omega = 2 * np.pi / (person.drift_period_s
                                         * person_rng.uniform(0.7, 1.6, size=(2, 2)))
        self._drift_phase = person_rng.uniform(0, 2 * np.pi, size=(2, 2))
        self._run: Optional[_Run] = None

    def drift_deg(self, t) -> np.ndarray:
        """
        Slow drift of the error at times t, (right, down) degrees, shape (N, 2).

        :param t: times, s, shape (N,).
        """
        t = np.asarray(t, dtype=float)
        amplitude = self.params.person.drift_deg
        if amplitude == 0:
            return np.zeros(t.shape + (2,))
        phase = t[:, None, None] * self._drift_omega + self._drift_phase
        return amplitude * np.sin(phase).sum(axis=-1)

    # Batch -------------------------------------------------------------------

    def sample_times(self, duration_s: float, start_s: float = 0.0) -> np.ndarray:
        """
        Acquisition times of the tracker's samples in [start_s, start_s + duration_s).

        :returns: shape (N,), N = ceil(duration_s * rate_hz), seconds, with the
            tracker's timing jitter.
        """
        _check(math.isfinite(duration_s) and duration_s >= 0,
               f'duration_s must be >= 0, got {duration_s}')
        count = int(math.ceil(duration_s * self.params.tracker.rate_hz - 1e-9))
        return _Run(self, start_s, None).nominal_times(0, count)

    def trace(self, t, schedule: TargetSchedule, initial_xy: Target = None) -> GazeTrace:
        """
        Simulate the samples at given times with everything recorded.

        :param t: acquisition times, s, shape (N,), increasing.
        :param schedule: ``[(t_start, (x, y) or None), ...]`` in time order
            (times on the clock of ``t``), or a callable ``target(t (N,)) ->
            (N, 2)`` px with NaN rows when there is no target.  The eye starts
            at ``initial_xy`` (default: screen centre) and looks at a new
            target after its saccade latency.
        :param initial_xy: where the eye points before the first saccade, px.
        :raises ValueError: unsorted times, malformed schedule.
        """
        return self._trace(t, schedule, initial_xy, None)

    def _trace(self, t, schedule: TargetSchedule, initial_xy: Target,
               t0: Optional[float]) -> GazeTrace:
        """Run :meth:`trace` with blinks counted from t0 (default: the first sample)."""
        t = np.asarray(t, dtype=float)
        _check(t.ndim == 1, f't must have shape (N,), got {t.shape}')
        if t0 is None:
            t0 = t[0] if len(t) else 0.0
        run = _Run(self, t0, initial_xy)
        if callable(schedule):
            self._add_callable_schedule(run, t, schedule)
        else:
            self._add_list_schedule(run, schedule)
        return run.emit(t)

    def samples(self, t, schedule: TargetSchedule, initial_xy: Target = None) -> np.ndarray:
        """Measured gaze at times t (s, shape (N,)): screen px (N, 2), NaN where lost."""
        return self.trace(t, schedule, initial_xy).xy

    def simulate(self, duration_s: float, schedule: TargetSchedule, start_s: float = 0.0,
                 initial_xy: Target = None) -> GazeTrace:
        """Simulate ``duration_s`` seconds of tracker samples from ``start_s`` on."""
        return self._trace(self.sample_times(duration_s, start_s), schedule, initial_xy,
                           start_s)

    @staticmethod
    def _add_list_schedule(run: _Run, schedule) -> None:
        """Feed a [(t_start, target), ...] script to a run."""
        try:
            entries = [(float(time), target) for time, target in schedule]
        except (TypeError, ValueError):
            raise ValueError('schedule must be a list of (t_start_s, (x, y) or None) '
                             'or a callable target(t)') from None
        times = [time for time, _ in entries]
        _check(all(a <= b for a, b in zip(times, times[1:])),
               'schedule entries must be in time order')
        for time, target in entries:
            run.add_target(target, time)

    @staticmethod
    def _add_callable_schedule(run: _Run, t: np.ndarray, target: Callable) -> None:
        """Turn target(t) into discrete target changes (catch-up saccades on motion)."""
        if len(t) == 0:
            return
        goals = np.asarray(target(t), dtype=float)
        _check(goals.shape == (len(t), 2),
               f'target(t) must return shape ({len(t)}, 2), got {goals.shape}')
        shown = np.all(np.isfinite(goals), axis=1)
        i = 0
        # One iteration per re-targeting event, each a vectorised scan.
        while True:
            run.add_target(goals[i] if shown[i] else None, t[i])
            aimed = run.aimed
            rest = slice(i + 1, None)
            if aimed is None:
                moved = shown[rest]
            else:
                distance = np.hypot(*(goals[rest] - aimed).T)
                moved = ~shown[rest] | (distance >= run.retarget_px)
            hits = np.flatnonzero(moved)
            if not len(hits):
                return
            i += 1 + int(hits[0])

    # Streaming ---------------------------------------------------------------

    def start(self, t0: float, initial_xy: Target = None) -> None:
        """
        Start (or restart) real-time generation: the first sample is acquired at t0.

        :param t0: time on the caller's steady clock, s.
        :param initial_xy: where the eye points until the first target, px
            (default: screen centre).
        """
        _check(math.isfinite(t0), f't0 must be finite, got {t0}')
        self._run = _Run(self, t0, initial_xy)

    def set_target(self, xy: Target, t: float) -> None:
        """
        Show the person a new target (or none) from time t on.

        Times before the latest target or the latest generated sample are
        moved forward to it (the past cannot change).  A move smaller than
        ``retarget_deg`` is ignored.  Starts the run at t if not started.
        """
        if self._run is None:
            self.start(t)
        self._run.add_target(xy, t)

    def next_chunk(self, now: float) -> GazeTrace:
        """
        All samples acquired since the last call, up to ``now``.

        A sample is released once half a period has passed after its nominal
        time, so no returned time lies after ``now``.  Starts the run at ``now``
        (returning nothing) if not started.
        """
        if self._run is None:
            self.start(now)
        run = self._run
        rate = self.params.tracker.rate_hz
        available = int(math.floor((now - run.t0) * rate - 0.5)) + 1
        count = max(available - run.n_emitted, 0)
        t = run.nominal_times(run.n_emitted, count)
        run.n_emitted += count
        return run.emit(t)
