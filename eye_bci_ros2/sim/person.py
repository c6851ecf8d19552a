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

Model, per sample (see :class:`PersonParams` for the numbers and where they come from):

1. Eye: fixates the current target.  When the target appears or moves by more
   than ``retarget_deg`` the eye starts a saccade after a latency
   (``latency_min_ms`` + gamma, mean ``latency_ms``).  With probability
   ``anticipation_prob`` the person also makes an anticipatory saccade of a
   few degrees in a random direction within 80 ms of the onset, before the
   target can have been seen (regular timing invites them).  A pending
   saccade is skipped when a later target change would set off no later (the
   eye then goes straight to the newer place); a target that moves in small
   steps is followed with about one latency of lag by small catch-up
   saccades.  Saccades are ballistic (a new one waits for the current one to
   land), last ``saccade_base_ms + saccade_ms_per_deg * amplitude`` (the main
   sequence, Carpenter 1988: about 30-60 ms for 5-20 deg) and follow a
   minimum-jerk profile along the straight screen line (a great circle of the
   eye, since a plane shows great circles as straight lines).
2. Landing: a primary saccade covers ``saccade_gain`` of the way (people
   undershoot by 5-10 % of the amplitude, Becker 1989; Harris 1995) with a
   scatter of ``landing_sd`` of the amplitude along its direction and 60 % of
   that across (van Opstal & van Gisbergen 1989); a landing further than
   ``correction_min_deg`` from the target is followed,
   ``correction_interval_ms`` later (Becker 1989: 100-150 ms), by a
   corrective saccade with half that scatter.  How long the eye rests on a
   landing short of the target matters as much as how far short it is: a
   rest longer than a decision rule's dwell on a neighbouring option is a
   wrong choice.  Smaller
   landing errors stay: where the eye rests differs from fixation to
   fixation.  After every saccade the measured eye overshoots and rings back
   (post-saccadic oscillation of video trackers, Nystrom & Holmqvist 2010;
   Hooge et al. 2015): a damped 20 Hz oscillation along the saccade of
   ``pso_fraction`` of its amplitude.
3. Tracker error, added as a rotation of the gaze ray: a constant per-person
   offset (accuracy, ``offset_deg`` in a direction fixed by the seed); an
   error that varies smoothly over the screen (``field_deg`` RMS per axis, a
   random second-order polynomial of the gaze position per person: the
   residual of a calibration, larger towards the edges, Hornof & Halverson
   2002, Cerrolaza et al. 2012); a wander that changes within a fixation
   (an Ornstein-Uhlenbeck process, ``wander_deg`` RMS per axis, correlation
   time ``wander_tau_s``: fixational drift of the eye and the tracker's
   coloured noise, Niehorster et al. 2021); an optional slow drift (sum of two
   sinusoids per axis, RMS ``drift_deg``); white Gaussian jitter (precision,
   ``jitter_deg`` standard deviation per axis); and single-sample spikes
   (probability ``spike_prob`` per sample, 2-6 deg in a random direction:
   a glint or pupil mistaken for one sample).  The error is in degrees, so it
   covers more pixels towards the screen edges, as on a real tracker.
4. Lost samples: blinks (a renewal process, ``blink_rate_per_min``, each
   lasting ``blink_min_ms``..``blink_max_ms``) and independent losses with
   probability ``loss_prob``.  Lost samples are NaN: an LSL sender emits
   them as NaN, which the bridge drops ('nonfinite'), like trackers that flag
   invalid gaze with NaN.

5. Smooth pursuit of a target that moves (a callable schedule): the eye moves
   at ``pursuit_gain`` times the target's speed ``pursuit_latency_ms`` late;
   motion faster than 40 deg/s is a jump; catch-up saccades when the eye falls
   1.5 deg behind; a correction when the target stops with the eye off it
   (:meth:`GazeSimulator._pursue`).  Targets set one at a time (a list
   schedule, :meth:`GazeSimulator.set_target` while streaming) are jumps:
   a target that moves in small steps is followed by catch-up saccades.

Microsaccades are part of the wander, not separate events.

:func:`record_schedule` runs the person on a recording's target schedule and
screen and returns a :class:`~eye_bci_ros2.recordings.gaze.GazeRecording`,
so real and simulated gaze go through the very same code.

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

from eye_bci_ros2.base.validators import ensure
from eye_bci_ros2.projection.visual_angle import ScreenGeometry
from eye_bci_ros2.recordings import gaze as recorded

#: A target: screen px (x, y), or None when there is nothing to look at.
Target = Optional[Sequence[float]]
#: A script of targets: ``[(t_start_s, target), ...]`` in time order, or a
#: callable ``target(t (N,)) -> (N, 2)`` screen px with NaN rows for "none".
TargetSchedule = Union[Sequence[Tuple[float, Target]], Callable[[np.ndarray], np.ndarray]]


#: An anticipatory saccade starts within this of the onset, s (before a target can be
#: seen: visually guided saccades take at least 80-100 ms, Fischer & Ramsperger 1984).
ANTICIPATION_S = 0.080
#: Amplitude range of an anticipatory saccade, deg.
ANTICIPATION_DEG = (1.0, 5.0)
#: Post-saccadic oscillation of video trackers: frequency, Hz, and decay time, s (about
#: 20 Hz, gone within 40-50 ms: Nystrom & Holmqvist 2010; Hooge et al. 2015).
PSO_HZ = 20.0
PSO_DECAY_S = 0.015
#: Size range of a single-sample spike, deg.
SPIKE_DEG = (2.0, 6.0)
#: Smooth pursuit: faster target motion is a jump (pursuit saturates at 30-40 deg/s,
#: Meyer, Lasker & Robinson 1985), deg/s.
PURSUIT_MAX_DEG_S = 40.0
#: A catch-up saccade when the eye falls this far behind a pursued target, deg (de Brouwer
#: et al. 2002: position errors of 1-2 deg set them off).
CATCH_UP_DEG = 1.5
#: Time step of the pursuit, s (the eye's path is linear in between).
PURSUIT_STEP_S = 0.01
#: A target slower than this is still, deg/s.
STILL_DEG_S = 0.5


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
    :param anticipation_prob: probability of an anticipatory saccade (1-5 deg,
        random direction, within 80 ms) when a target appears: a few per cent
        in tasks with regular timing (Kowler 1990; Wenban-Smith & Findlay
        1991).
    :param saccade_gain: share of the way a primary saccade covers (Becker
        1989, Harris 1995: 0.90-0.95; 1 = lands on the target).
    :param landing_sd: scatter of a primary saccade's landing along its
        direction, as a fraction of the amplitude (van Opstal & van Gisbergen
        1989: 5-10 %); across: 60 % of it.
    :param correction_min_deg: a landing further than this from the target is
        corrected by a second saccade (smaller errors stay).
    :param correction_interval_ms: mean time from a landing to the corrective
        saccade (Becker 1989: 100-150 ms; gamma, SD a quarter of the mean,
        at least 60 ms).  The default is the lower end: the X2-60 recordings
        (``python -m eye_bci_ros2.sim.realism``, ``rest_median_ms``) show
        no longer rests, and longer ones made the simulated person choose
        a neighbouring option far more often than real people.
    :param pso_fraction: post-saccadic oscillation: first overshoot as a
        fraction of the saccade's amplitude (0 = none).
    :param field_deg: RMS per axis of the error that varies over the screen
        (a per-person second-order polynomial of the gaze position).
    :param wander_deg: RMS per axis of the error that wanders within
        fixations (Ornstein-Uhlenbeck).
    :param wander_tau_s: correlation time of that wander, s.
    :param spike_prob: probability that a sample is a spike of 2-6 deg.
    :param pursuit_gain: smooth pursuit of a target that moves (a callable
        schedule): eye speed over target speed, about 0.9 up to 30-40 deg/s
        (Meyer, Lasker & Robinson 1985); 0 = no pursuit, catch-up saccades only.
    :param pursuit_latency_ms: the pursuit follows the target's motion this
        late (about 100-130 ms, Carl & Gellman 1987).
    :param blink_rate_per_min: mean blinks per minute (0 = none); people
        blink about 17 times a minute at rest but 4-5 while reading or
        watching a screen closely (Bentivoglio et al. 1997).
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
    anticipation_prob: float = 0.05
    saccade_gain: float = 0.95
    landing_sd: float = 0.08
    correction_min_deg: float = 0.5
    correction_interval_ms: float = 100.0
    pso_fraction: float = 0.04
    field_deg: float = 0.0
    wander_deg: float = 0.0
    wander_tau_s: float = 0.5
    spike_prob: float = 0.0
    pursuit_gain: float = 0.9
    pursuit_latency_ms: float = 100.0
    blink_rate_per_min: float = 5.0
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
            ensure(isinstance(value, Real) and math.isfinite(value) and value >= 0,
                   f'{f.name} must be a finite number >= 0, got {value!r}')
        if self.offset_direction_deg is not None:
            ensure(math.isfinite(self.offset_direction_deg),
                   f'offset_direction_deg must be finite, got {self.offset_direction_deg}')
        ensure(self.offset_deg < 30 and self.jitter_deg < 30 and self.drift_deg < 30,
               'offset_deg, jitter_deg and drift_deg must be below 30 degrees')
        ensure(self.latency_ms >= self.latency_min_ms,
               f'latency_ms ({self.latency_ms}) must be >= latency_min_ms '
               f'({self.latency_min_ms})')
        ensure(self.drift_period_s > 0, 'drift_period_s must be > 0')
        ensure(self.wander_tau_s > 0, 'wander_tau_s must be > 0')
        ensure(self.field_deg < 30 and self.wander_deg < 30,
               'field_deg and wander_deg must be below 30 degrees')
        ensure(0 < self.saccade_gain <= 1.5,
               f'saccade_gain must be in (0, 1.5], got {self.saccade_gain}')
        ensure(self.pursuit_gain <= 1.2, f'pursuit_gain must be <= 1.2, got {self.pursuit_gain}')
        ensure(self.landing_sd < 1, f'landing_sd must be < 1, got {self.landing_sd}')
        ensure(self.pso_fraction < 0.5, f'pso_fraction must be < 0.5, got {self.pso_fraction}')
        for name in ('anticipation_prob', 'spike_prob'):
            ensure(getattr(self, name) < 1, f'{name} must be < 1, got {getattr(self, name)}')
        ensure(self.saccade_max_ms > 0, 'saccade_max_ms must be > 0')
        ensure(0 < self.blink_min_ms <= self.blink_max_ms,
               f'need 0 < blink_min_ms <= blink_max_ms, got {self.blink_min_ms}, '
               f'{self.blink_max_ms}')
        ensure(self.blink_rate_per_min * (self.blink_min_ms + self.blink_max_ms) / 2 < 60000,
               'blinks would take up all the time: lower blink_rate_per_min or the durations')
        ensure(self.loss_prob < 1, f'loss_prob must be < 1, got {self.loss_prob}')
        ensure(isinstance(self.screen, ScreenGeometry), 'screen must be a ScreenGeometry')

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
        ensure(isinstance(self.rate_hz, Real) and 0 < self.rate_hz <= 10000,
               f'rate_hz must be in (0, 10000], got {self.rate_hz!r}')
        for name in ('timing_jitter_ms', 'delay_ms'):
            value = getattr(self, name)
            ensure(isinstance(value, Real) and math.isfinite(value) and value >= 0,
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


#: How people move their eyes to a target that jumps, whatever the tracker: latency of
#: regular saccades to a step without a gap, median about 150-200 ms, SD 25-40 ms, none
#: visually guided below about 100 ms (Fischer & Ramsperger 1984; Carpenter & Williams
#: 1995); blinks while watching a screen (Bentivoglio et al. 1997).
_PERSON = {'latency_ms': 180.0, 'latency_min_ms': 100.0, 'latency_sd_ms': 30.0,
           'blink_rate_per_min': 5.0}

#: A consumer remote tracker (Tobii 4C/5 class): 90 Hz.  Its spatial error is what remote
#: trackers of this class give people in real sessions, taken from the Tobii X2-60
#: recordings of Niehorster et al. (2020) (``../shared/data/real_gaze``): settled error
#: against the target median about 0.9 deg, p90 1.8 deg, a mean offset of 0-0.9 deg
#: that varies over the screen by about as much, about 1 % single-sample spikes;
#: precision 0.3 deg (Tobii's specification for the class).  The benchmarks use it.
CONSUMER_TRACKER = GazeParams(
    person=PersonParams(offset_deg=0.5, jitter_deg=0.3, field_deg=0.6, wander_deg=0.3,
                        spike_prob=0.01, loss_prob=0.005, **_PERSON),
    tracker=TrackerParams(rate_hz=90.0, timing_jitter_ms=0.3, delay_ms=10.0),
    name='consumer_tracker')

#: The original set-up: Tobii 4C at the measured ~87 Hz, calibrated on the
#: Linux screen by imagining the Windows calibration points, so a larger
#: offset and a little drift are assumed (the report gives no accuracy
#: figure in degrees); otherwise the consumer tracker's errors.
ORIGINAL_TOBII_4C = GazeParams(
    person=PersonParams(offset_deg=0.8, jitter_deg=0.3, drift_deg=0.1, field_deg=0.6,
                        wander_deg=0.3, spike_prob=0.01, loss_prob=0.02, **_PERSON),
    tracker=TrackerParams(rate_hz=87.0, timing_jitter_ms=0.5, delay_ms=20.0),
    name='original_tobii_4c')

#: A 1200 Hz research tracker (Tobii Pro Spectrum class, chin rest): accuracy median
#: 0.3-0.4 deg, worst of 9 targets 1.2-1.3 deg, in the ETDQualitizer validations
#: (``../shared/data/real_gaze``); precision 0.05 deg RMS (Spectrum specification, and
#: Holmqvist 2017); few spikes, few losses, 3 ms to sending.
PRO_TRACKER = GazeParams(
    person=PersonParams(offset_deg=0.35, jitter_deg=0.05, field_deg=0.35, wander_deg=0.1,
                        spike_prob=0.0001, loss_prob=0.002, **_PERSON),
    tracker=TrackerParams(rate_hz=1200.0, timing_jitter_ms=0.05, delay_ms=3.0),
    name='pro_tracker_1200hz')

#: Changes (for :meth:`GazeParams.with_changes`) that leave only the simple model: an
#: eye that lands on the target at once, a constant offset, white jitter and the slow
#: drift.  For tests of one mechanism at a time, and to compare with that model.
IDEAL_EYE = {'anticipation_prob': 0.0, 'saccade_gain': 1.0, 'landing_sd': 0.0,
             'pso_fraction': 0.0, 'field_deg': 0.0, 'wander_deg': 0.0, 'spike_prob': 0.0,
             'pursuit_gain': 0.0}

#: Presets by name (the ``sim_gaze --preset`` choices).
PRESETS = {p.name: p for p in (CONSUMER_TRACKER, ORIGINAL_TOBII_4C, PRO_TRACKER)}


@dataclass
class GazeTrace:
    """
    Simulated samples.

    :param t: acquisition times, s, shape (N,).
    :param xy: measured gaze, screen px, shape (N, 2); NaN where lost.
    :param eye_xy: where the eye really pointed (no tracker error), shape (N, 2).
    :param blink: sample falls in a blink, shape (N,).
    :param dropped: sample lost by the tracker (independent losses), shape (N,).
    :param spike: sample is a single-sample spike, shape (N,) (None: none made).
    """

    t: np.ndarray
    xy: np.ndarray
    eye_xy: np.ndarray
    blink: np.ndarray
    dropped: np.ndarray
    spike: Optional[np.ndarray] = None

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
    ensure(array.shape == (2,) and bool(np.all(np.isfinite(array))),
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
        self.rng_saccade = np.random.default_rng(seeds[6])
        self.rng_anticipation = np.random.default_rng(seeds[7])
        self.rng_wander = np.random.default_rng(seeds[8])
        self.rng_spike = np.random.default_rng(seeds[9])
        # The wander's state (deg, per axis), drawn from its stationary distribution.
        self.wander = self.rng_wander.standard_normal(2) * person.wander_deg
        start = _as_target(initial_xy, 'initial_xy')
        if start is None:
            start = person.screen.centre_px
        # Saccade records: onset s, duration s, start px, goal px.
        self.onsets: List[float] = [-math.inf]
        self.durations: List[float] = [0.0]
        self.starts: List[np.ndarray] = [start]
        self.goals: List[np.ndarray] = [start]
        # Whether each record is a saccade (minimum jerk, then ringing) or pursuit (linear).
        self.saccadic: List[bool] = [True]
        # Pending saccades, in insertion order: (time, goal or None, onset, kind), kind
        # 'target' (to a target shown), 'anticipation' or 'correction'.
        self.pending: List[Tuple[float, Optional[np.ndarray], float, str]] = []
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

    def add_target(self, xy: Target, t: float, anticipate: bool = True) -> None:
        """
        Show a target (or none) from time t on; earlier times are moved to now.

        :param anticipate: whether an anticipatory saccade may come first (a target that
            appears; not a catch-up saccade during pursuit).
        """
        xy = _as_target(xy, 'target')
        ensure(math.isfinite(t), f'target time must be finite, got {t}')
        t = max(float(t), self.last_event_t, self.t_last)
        if xy is None:
            if self.aimed is None and self.has_event:
                return
        elif self.aimed is not None and np.hypot(*(xy - self.aimed)) < self.retarget_px:
            return
        self.aimed = xy
        self.has_event = True
        self.last_event_t = t
        latency = self._latency_s()
        person = self.person
        if (xy is not None and anticipate and person.anticipation_prob > 0
                and self.rng_anticipation.random() < person.anticipation_prob):
            early = self.rng_anticipation.uniform(0.0, ANTICIPATION_S)
            self.pending.append((t, None, t + early, 'anticipation'))
        self.pending.append((t, xy, t + latency, 'target'))

    def _cancelled(self) -> List[bool]:
        """
        Which pending saccades will not happen.

        A target's (or an anticipation's) saccade is cancelled by any later
        target whose saccade sets off no later; a correction, by any target
        whose saccade sets off no later (the eye goes to the new target).
        """
        out = []
        for i, (_, _, onset, kind) in enumerate(self.pending):
            later = self.pending if kind == 'correction' else self.pending[i + 1:]
            out.append(any(k == 'target' and o <= onset for _, _, o, k in later))
        return out

    def _plan(self, t_end: float) -> None:
        """Commit the saccades whose onset is at or before t_end, earliest first."""
        while self.pending:
            cancelled = self._cancelled()
            self.pending = [p for p, c in zip(self.pending, cancelled) if not c]
            due = [p for p in self.pending if p[2] <= t_end]
            if not due:
                return
            entry = min(due, key=lambda p: p[2])
            self.pending.remove(entry)
            self._commit(*entry[1:])

    def _commit(self, goal: Optional[np.ndarray], onset: float, kind: str) -> None:
        """Add one saccade: where it lands, and a correction when it lands far off."""
        person = self.person
        screen = person.screen
        start = self.goals[-1]
        if kind == 'anticipation':
            goal = self._anticipation_goal(start)
        if goal is None or np.array_equal(goal, start):
            return
        # Saccades are ballistic: a new one waits for the current one to land.
        onset = max(onset, self.onsets[-1] + self.durations[-1])
        aim = goal
        if kind != 'anticipation':
            scatter = person.landing_sd * (0.5 if kind == 'correction' else 1.0)
            gain = 1.0 if kind == 'correction' else person.saccade_gain
            step = goal - start
            normal = np.array([-step[1], step[0]])
            along, across = self.rng_saccade.standard_normal(2) * scatter * np.array([1.0, 0.6])
            # No clipping to the screen: a person can look away from it.
            goal = start + step * (gain + along) + normal * across
        amplitude = float(screen.angle_between_deg(start, goal))
        duration = min(person.saccade_base_ms + person.saccade_ms_per_deg * amplitude,
                       person.saccade_max_ms) / 1e3
        self.onsets.append(onset)
        self.durations.append(duration)
        self.starts.append(start)
        self.goals.append(goal)
        self.saccadic.append(True)
        if kind == 'target' and float(screen.angle_between_deg(goal, aim)) > \
                person.correction_min_deg:
            mean = person.correction_interval_ms / 1e3
            shape = 16.0    # SD = mean / 4
            interval = max(self.rng_saccade.gamma(shape, mean / shape), 0.06)
            self.pending.append((onset, aim, onset + duration + interval, 'correction'))

    def pursue(self, t_from: float, t_to: float, shift: np.ndarray) -> None:
        """Move the eye smoothly by ``shift`` px from t_from to t_to (after any saccade)."""
        t_from = max(t_from, self.onsets[-1] + self.durations[-1])
        if t_to <= t_from or not np.any(shift):
            return
        start = self.goals[-1]
        self.onsets.append(t_from)
        self.durations.append(t_to - t_from)
        self.starts.append(start)
        self.goals.append(start + shift)
        self.saccadic.append(False)

    def _anticipation_goal(self, start: np.ndarray) -> np.ndarray:
        """Where an anticipatory saccade goes: 1-5 deg from start, random direction, on screen."""
        screen = self.person.screen
        angle = self.rng_anticipation.uniform(0.0, 2.0 * math.pi)
        size = self.rng_anticipation.uniform(*ANTICIPATION_DEG)
        direction = np.array([[math.cos(angle), math.sin(angle)]])
        goal = screen.rotate_gaze(start[None], size * direction)[0]
        return np.clip(goal, 0.0, screen.size_px)

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

    def _oscillation(self, t: np.ndarray, onsets: np.ndarray) -> np.ndarray:
        """Post-saccadic oscillation of the latest saccade at times t, px (N, 2)."""
        fraction = self.person.pso_fraction
        if fraction <= 0:
            return np.zeros((len(t), 2))
        saccades = np.flatnonzero(self.saccadic)
        index = saccades[np.maximum(np.searchsorted(onsets[saccades], t, side='right') - 1, 0)]
        since = t - (onsets[index] + np.array(self.durations)[index])
        # Before the first saccade (onset -inf) nothing rings.
        since = np.where(np.isfinite(since) & (since > 0), since, 0.0)
        step = np.array(self.goals)[index] - np.array(self.starts)[index]
        ringing = np.exp(-since / PSO_DECAY_S) * np.sin(2.0 * math.pi * PSO_HZ * since)
        # sin peaks at a quarter period, where the decay has already taken its share.
        peak = math.exp(-0.25 / PSO_HZ / PSO_DECAY_S)
        return step * (fraction / peak) * ringing[:, None]

    def _wander(self, n: int) -> np.ndarray:
        """Draw the next n samples of the wander (Ornstein-Uhlenbeck at the tracker rate), deg."""
        person = self.person
        if person.wander_deg <= 0:
            return np.zeros((n, 2))
        a = math.exp(-1.0 / (self.sim.params.tracker.rate_hz * person.wander_tau_s))
        noise = self.rng_wander.standard_normal((n, 2)) * person.wander_deg * math.sqrt(1 - a * a)
        # The AR(1) recursion sample by sample: exact whatever the chunking (and no scipy
        # import, which costs a simulated tracker seconds at start-up).
        x, y = float(self.wander[0]), float(self.wander[1])
        out = np.empty((n, 2))
        for i, (nx, ny) in enumerate(noise.tolist()):
            x = a * x + nx
            y = a * y + ny
            out[i, 0] = x
            out[i, 1] = y
        self.wander = out[-1].copy()
        return out

    def _spikes(self, n: int) -> Tuple[np.ndarray, np.ndarray]:
        """Which of n samples are spikes, and their errors (N, 2) deg."""
        person = self.person
        if person.spike_prob <= 0:
            return np.zeros(n, dtype=bool), np.zeros((n, 2))
        # Three draws per sample, in sample order, so chunking does not change them.
        draws = self.rng_spike.random((n, 3))
        spike = draws[:, 0] < person.spike_prob
        angle = 2.0 * math.pi * draws[:, 1]
        size = SPIKE_DEG[0] + (SPIKE_DEG[1] - SPIKE_DEG[0]) * draws[:, 2]
        error = np.where(spike[:, None], size[:, None] * np.stack(
            [np.cos(angle), np.sin(angle)], axis=1), 0.0)
        return spike, error

    def emit(self, t: np.ndarray) -> GazeTrace:
        """Generate the samples at times t (sorted, after every earlier sample)."""
        person = self.person
        n = len(t)
        if n == 0:
            empty = np.empty((0, 2))
            return GazeTrace(np.empty(0), empty, empty.copy(), np.zeros(0, bool),
                             np.zeros(0, bool), np.zeros(0, bool))
        ensure(bool(np.all(np.isfinite(t))), 'sample times must be finite')
        ensure(bool(np.all(np.diff(t) >= 0)), 'sample times must be in increasing order')
        ensure(t[0] >= self.t_last, 'sample times must come after the samples already made')
        self._plan(t[-1])
        onsets = np.array(self.onsets)
        index = np.searchsorted(onsets, t, side='right') - 1
        durations = np.maximum(np.array(self.durations)[index], 1e-9)
        tau = np.clip((t - onsets[index]) / durations, 0.0, 1.0)
        starts = np.array(self.starts)[index]
        goals = np.array(self.goals)[index]
        saccadic = np.array(self.saccadic)[index]
        share = np.where(saccadic, _minimum_jerk(tau), tau)
        eye = starts + (goals - starts) * share[:, None]
        eye = eye + self._oscillation(t, onsets)

        error = (self.sim.offset_vector_deg + self.sim.field_error_deg(eye)
                 + self.sim.drift_deg(t) + self._wander(n))
        error = error + self.rng_jitter.standard_normal((n, 2)) * person.jitter_deg
        spike, spike_error = self._spikes(n)
        xy = person.screen.rotate_gaze(eye, error + spike_error)

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
        # ... and the latest saccade before them, whose ringing may still show.
        keep = min(keep, max((i for i in range(keep + 1) if self.saccadic[i]), default=0))
        del self.onsets[:keep], self.durations[:keep], self.starts[:keep], self.goals[:keep]
        del self.saccadic[:keep]
        alive = self.blink_ends > self.t_last
        self.blink_starts, self.blink_ends = self.blink_starts[alive], self.blink_ends[alive]
        return GazeTrace(t=np.array(t, dtype=float), xy=xy, eye_xy=eye, blink=blink,
                         dropped=dropped, spike=spike & ~(blink | dropped))


def _field_basis(uv: np.ndarray) -> np.ndarray:
    """Second-order polynomial terms of screen positions in [-1, 1]^2, (N, 2) -> (N, 5)."""
    u, v = uv[:, 0], uv[:, 1]
    return np.stack([u, v, u * v, u * u - 1.0 / 3.0, v * v - 1.0 / 3.0], axis=1)


#: The basis on a grid over the whole screen, to scale a person's field (G, 5).
_FIELD_GRID = _field_basis(np.stack([a.ravel() for a in np.meshgrid(
    np.linspace(-1, 1, 21), np.linspace(-1, 1, 21))], axis=1))


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
        ensure(isinstance(params, GazeParams),
               f'params must be a GazeParams (e.g. CONSUMER_TRACKER), got {type(params)}')
        ensure(isinstance(seed, (int, np.integer)) and seed >= 0,
               f'seed must be an integer >= 0, got {seed!r}')
        self.params = params
        self.seed = int(seed)
        root = np.random.SeedSequence(self.seed)
        self._seeds = root.spawn(11)
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
        self._field = self._draw_field(np.random.default_rng(self._seeds[10]))
        self._run: Optional[_Run] = None

    def _draw_field(self, rng: np.random.Generator) -> np.ndarray:
        """
        Draw this person's error over the screen: polynomial coefficients (5, 2), deg.

        Scaled so the error's RMS over the screen is ``field_deg`` per axis.
        """
        amplitude = self.params.person.field_deg
        coefficients = rng.standard_normal((len(_FIELD_GRID[0]), 2))
        if amplitude == 0:
            return np.zeros_like(coefficients)
        values = _FIELD_GRID @ coefficients                    # (G, 2)
        rms = np.sqrt(np.mean(values ** 2, axis=0))
        return coefficients * (amplitude / rms)

    def field_error_deg(self, xy) -> np.ndarray:
        """
        Return the error that varies over the screen at screen points xy, (right, down) deg.

        :param xy: screen px, shape (N, 2).
        :returns: shape (N, 2).
        """
        xy = np.asarray(xy, dtype=float)
        if self.params.person.field_deg == 0:
            return np.zeros(xy.shape)
        screen = self.params.person.screen
        uv = (xy - screen.centre_px) / screen.centre_px
        return _field_basis(uv) @ self._field

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
        ensure(math.isfinite(duration_s) and duration_s >= 0,
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
        ensure(t.ndim == 1, f't must have shape (N,), got {t.shape}')
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
        ensure(all(a <= b for a, b in zip(times, times[1:])),
               'schedule entries must be in time order')
        for time, target in entries:
            run.add_target(target, time)

    @staticmethod
    def _add_callable_schedule(run: _Run, t: np.ndarray, target: Callable) -> None:
        """Turn target(t) into saccades, and pursuit of smooth motion when the person has it."""
        if len(t) == 0:
            return
        goals = np.asarray(target(t), dtype=float)
        ensure(goals.shape == (len(t), 2),
               f'target(t) must return shape ({len(t)}, 2), got {goals.shape}')
        if run.person.pursuit_gain > 0:
            GazeSimulator._pursue(run, t, target)
            return
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

    @staticmethod
    def _pursue(run: _Run, t: np.ndarray, target: Callable) -> None:
        """
        Follow target(t) with saccades to jumps and smooth pursuit of motion.

        Every PURSUIT_STEP_S the eye moves by ``pursuit_gain`` times the target's
        motion ``pursuit_latency_ms`` earlier; motion faster than PURSUIT_MAX_DEG_S,
        an appearing or vanishing target are jumps (a saccade after its latency);
        when the eye falls CATCH_UP_DEG behind, a catch-up saccade goes to where the
        target will be one mean latency later (people predict a steady motion, de
        Brouwer et al. 2002).
        """
        person = run.person
        screen = person.screen
        grid = np.arange(t[0], t[-1] + PURSUIT_STEP_S, PURSUIT_STEP_S)
        now = np.asarray(target(grid), dtype=float)
        before = np.asarray(target(grid - person.pursuit_latency_ms / 1e3), dtype=float)
        ensure(now.shape == (len(grid), 2) and before.shape == (len(grid), 2),
               f'target(t) must return shape (N, 2), got {now.shape}')
        shown = np.isfinite(now).all(axis=1)
        with np.errstate(invalid='ignore'):
            speed_now = screen.angle_between_deg(now[:-1], now[1:]) / PURSUIT_STEP_S
            speed_before = screen.angle_between_deg(before[:-1], before[1:]) / PURSUIT_STEP_S
        ahead = int(round(person.latency_ms / 1e3 / PURSUIT_STEP_S))
        run.add_target(now[0] if shown[0] else None, float(t[0]))
        for k in range(1, len(grid)):
            a, b = float(grid[k - 1]), float(grid[k])
            run._plan(b)
            if shown[k] != shown[k - 1] or (shown[k] and not speed_now[k - 1]
                                            <= PURSUIT_MAX_DEG_S):
                run.add_target(now[k] if shown[k] else None, b)
                continue
            if not shown[k]:
                continue
            if speed_before[k - 1] <= PURSUIT_MAX_DEG_S:
                run.pursue(a, b, person.pursuit_gain * (before[k] - before[k - 1]))
            # Behind a moving target: a catch-up saccade; off a target that has stopped
            # (and the pursuit with it): a correction, as after any landing.
            still = speed_now[k - 1] < STILL_DEG_S and not speed_before[k - 1] >= STILL_DEG_S
            limit = person.correction_min_deg if still else CATCH_UP_DEG
            if (not run.pending and b >= run.onsets[-1] + run.durations[-1]
                    and screen.angle_between_deg(run.goals[-1], now[k]) > limit):
                aim = now[min(k + ahead, len(grid) - 1)]
                run.add_target(aim if np.isfinite(aim).all() else now[k], b, anticipate=False)

    # Streaming ---------------------------------------------------------------

    def start(self, t0: float, initial_xy: Target = None) -> None:
        """
        Start (or restart) real-time generation: the first sample is acquired at t0.

        :param t0: time on the caller's steady clock, s.
        :param initial_xy: where the eye points until the first target, px
            (default: screen centre).
        """
        ensure(math.isfinite(t0), f't0 must be finite, got {t0}')
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


def record_schedule(targets: recorded.TargetSchedule, screen: ScreenGeometry,
                    params: GazeParams = CONSUMER_TRACKER, rate_hz: Optional[float] = None,
                    seed: int = 0, duration_s: Optional[float] = None,
                    name: str = 'simulated') -> recorded.GazeRecording:
    """
    Record the simulated person on a recording's target schedule and screen.

    The person sees what the recorded person saw: each target from its onset;
    a target that glides into place (``still`` after ``onset``) moves in a
    straight line from the previous place at constant speed until ``still``
    (and is pursued).  Before the first onset the eye rests on the first target.

    :param targets: a :class:`~eye_bci_ros2.recordings.gaze.TargetSchedule`.
    :param screen: the recording's screen and viewing distance.
    :param params: the person and tracker; its screen is replaced by ``screen``.
    :param rate_hz: the tracker's rate, e.g. the recording's (default: the params').
    :param seed: the person's seed.
    :param duration_s: how long to record, s from 0; default: until the
        last target ends.
    :param name: the recording's name.
    :returns: a :class:`~eye_bci_ros2.recordings.gaze.GazeRecording` of the
        same form as the loaders give (stamps from 0 s, NaN where lost).
    """
    if rate_hz is not None:
        params = params.with_changes(rate_hz=float(rate_hz))
    params = params.with_changes(**{f.name: getattr(screen, f.name) for f in fields(screen)})
    sim = GazeSimulator(params, seed=seed)
    if duration_s is None:
        duration_s = float(targets.ends[-1]) if len(targets) else 0.0
    t = sim.sample_times(duration_s)
    t = t[t >= 0.0]
    onsets, still = np.asarray(targets.onsets), np.asarray(targets.still)
    places = np.asarray(targets.places, dtype=float)
    if targets.jumps:
        schedule = [(float(onset), tuple(place)) for onset, place in zip(onsets, places)]
    else:
        def schedule(times: np.ndarray) -> np.ndarray:
            k = np.clip(np.searchsorted(onsets, times, side='right') - 1, 0, len(onsets) - 1)
            previous = places[np.maximum(k - 1, 0)]
            span = np.maximum(still[k] - onsets[k], 1e-9)
            share = np.clip((times - onsets[k]) / span, 0.0, 1.0)[:, None]
            return previous + (places[k] - previous) * share
    trace = sim.trace(t, schedule, initial_xy=tuple(places[0]) if len(places) else None)
    return recorded.GazeRecording(name=name, stamps=trace.t, points=trace.xy, screen=screen,
                                  targets=targets, tracker=f'simulated {params.name}')
