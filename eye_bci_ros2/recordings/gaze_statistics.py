"""
What a person's gaze does after a target appears: statistics of any :class:`GazeRecording` (pure).

The same numbers are computed on real recordings and on the simulated person
(:func:`eye_bci_ros2.sim.person.record_schedule`) so the two can be compared
(``test/sim/test_person_realism.py``).  Angles are degrees of visual angle
(docs/DESIGN.md, ``screen`` frame and visual angles), times seconds.

Event detection, offline (:func:`detect_saccades`):

* Single-sample spikes are found first and set aside (:func:`find_spikes`): a
  sample more than ``SPIKE_DEG`` from both neighbours while the neighbours
  agree within ``SPIKE_DEG / 2`` is a tracker artefact, not an eye movement
  (no saccade goes out and back within two sample intervals).
* Velocity: a Savitzky-Golay first derivative over about 20 ms (Nystrom &
  Holmqvist 2010), at least 3 samples, so a 60 Hz tracker gets the central
  difference and a 1200 Hz one is smoothed over the same time; a lost sample
  makes the velocity around it unknown (never a saccade).
* Threshold adapted to the noise (Engbert & Kliegl 2003): per axis the
  median-based spread ``sigma = sqrt(median(v^2) - median(v)^2)`` and an
  elliptic threshold ``(vx / (LAMBDA sigma_x))^2 + (vy / (LAMBDA sigma_y))^2
  > 1``, never below ``MIN_VELOCITY_DEG_S`` (the I-VT threshold of Olsen 2012,
  so noiseless simulated gaze is not all "saccade").  A saccade is a run of
  samples above it whose end points lie at least ``MIN_SACCADE_DEG`` apart.

Why this and not a library: ``remodnav`` targets >= 250 Hz lab data,
``i2mc`` classifies fixations by clustering (no saccade onsets), and
``pymovements`` brings a dataframe stack for what is here 40 lines; the
velocity threshold adapted to the noise is the classic method, works from 60
to 2000 Hz with the window above, and is what an online rule can also do.

Per target step (:func:`measure_steps`; targets at least ``MIN_STEP_DEG``
from the previous one; the timing only for targets that jump into place,
the ``still`` time equal to the onset):

* *settled*: the median gaze ``SETTLED_WINDOW_S`` after the target is shown
  still at its place, cut at the next target but at least ``MIN_SETTLED_S``
  (where the eye rests once it has got there); its angle to the target is
  the settled error, the mean of the per-axis errors over a recording is the
  person's mean offset.
* *latency*: onset of the first saccade starting within ``LATENCY_WINDOW_S``
  of the target onset (NaN when none); under ``ANTICIPATION_S`` it counts as
  an anticipation.
* *first landing*: the median gaze in the ``LANDING_S`` after that saccade
  ends (before any next saccade); a *corrective* step has its first landing
  more than ``CORRECTIVE_DEG`` from the settled point.
* *primary gain* (steps whose first saccade is not an anticipation): how
  much of the way from the gaze before the saccade (median of its
  ``PRE_SACCADE_S``) to the settled point the first landing covers, along
  that line (1 = lands where the eye settles; 0.9 = 10 % short).  Measured
  gaze against measured gaze, so the tracker's offset cancels; the landing
  error relative to the amplitude is what puts a landing on a neighbouring
  option.  Its *landing error ratio* is the first landing's distance from the
  settled point over that same amplitude.
* *landing rest*: from the first saccade's end to the next saccade's onset
  when one starts before the settled window (the time the eye rests on its
  first landing before a corrective saccade).
* *settling time*: from the saccade's onset until the 3-sample running median
  of the gaze stays within ``SETTLE_DEG`` of the settled point up to the end of
  the settled window.
* *drift*: within the settled window, the distance between the medians of
  its first and last ``DRIFT_EDGE_S`` when no saccade lies in it.

Over a whole recording: spikes per 1000 valid samples, blinks (runs of lost
samples of ``BLINK_S`` duration) per minute and the share of samples lost.
"""

from dataclasses import dataclass, fields
import math
from typing import Dict, Iterable, List, Tuple
import warnings

import numpy as np

from eye_bci_ros2.projection.visual_angle import ScreenGeometry
from eye_bci_ros2.recordings.gaze import GazeRecording

#: A spike leaves both neighbours by more than this, deg.
SPIKE_DEG = 2.0
#: Velocity filter span, s (Nystrom & Holmqvist 2010: about 20 ms).
VELOCITY_SPAN_S = 0.020
#: Engbert & Kliegl's multiple of the median-based velocity spread.
LAMBDA = 6.0
#: Lowest velocity threshold, deg/s (I-VT, Olsen 2012).
MIN_VELOCITY_DEG_S = 30.0
#: Smallest saccade counted, deg (smaller ones are microsaccades or noise).
MIN_SACCADE_DEG = 1.0
#: Steps shorter than this are not measured, deg.
MIN_STEP_DEG = 3.0
#: Where the settled gaze is taken, s after the onset.
SETTLED_WINDOW_S = (0.5, 1.0)
#: A settled window cut short by the next target must still last this long, s.
MIN_SETTLED_S = 0.3
#: The first saccade after an onset is looked for within this time, s.
LATENCY_WINDOW_S = 0.6
#: A saccade this soon after the onset was started before the target could be seen, s.
ANTICIPATION_S = 0.080
#: Time after a saccade's end over which its landing is taken, s.
LANDING_S = 0.040
#: The gaze before a saccade is the median of this long before its onset, s.
PRE_SACCADE_S = 0.050
#: A first landing further than this from the settled point needed a correction, deg.
CORRECTIVE_DEG = 2.0
#: The gaze has settled once it stays within this of the settled point, deg.
SETTLE_DEG = 1.0
#: Share of steps whose landing takes longer than this is reported, s.
SLOW_LANDING_S = 0.100
#: Drift: the medians of the first and last this much of the settled window, s.
DRIFT_EDGE_S = 0.1
#: A run of lost samples this long is a blink, s (shorter: tracking loss; longer: looked away).
BLINK_S = (0.05, 0.5)


def gaze_angles_deg(screen: ScreenGeometry, points: np.ndarray) -> np.ndarray:
    """
    Screen points as the eye's horizontal and vertical angles (Fick), deg.

    :param points: (N, 2) screen px.
    :returns: (N, 2) deg: azimuth (right +), elevation (down +); NaN where a point is NaN.
    """
    rays = screen.rays(points)
    azimuth = np.arctan2(rays[:, 0], rays[:, 2])
    elevation = np.arctan2(rays[:, 1], np.hypot(rays[:, 0], rays[:, 2]))
    return np.degrees(np.stack([azimuth, elevation], axis=1))


def find_spikes(angles: np.ndarray) -> np.ndarray:
    """
    Single-sample spikes (module doc): a sample far from both neighbours that agree.

    :param angles: (N, 2) deg (:func:`gaze_angles_deg`).
    :returns: (N,) bool.
    """
    spikes = np.zeros(len(angles), dtype=bool)
    if len(angles) < 3:
        return spikes
    before, here, after = angles[:-2], angles[1:-1], angles[2:]
    out = np.hypot(*(here - before).T)
    back = np.hypot(*(here - after).T)
    agree = np.hypot(*(after - before).T)
    with np.errstate(invalid='ignore'):
        spikes[1:-1] = (out > SPIKE_DEG) & (back > SPIKE_DEG) & (agree < SPIKE_DEG / 2)
    return spikes


def _derivative_kernel(rate_hz: float) -> np.ndarray:
    """Savitzky-Golay (order 2) first-derivative weights over VELOCITY_SPAN_S, per sample."""
    half = max(1, int(round(VELOCITY_SPAN_S * rate_hz / 2)))
    offsets = np.arange(-half, half + 1, dtype=float)
    # For a quadratic fit the slope weights are those of a linear fit.
    return offsets / np.sum(offsets ** 2)


def velocities(stamps: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """
    Angular velocity per axis, deg/s (module doc); NaN near lost samples.

    :param stamps: (N,) s.
    :param angles: (N, 2) deg.
    :returns: (N, 2) deg/s.
    """
    steps = np.diff(stamps)
    steps = steps[steps > 0]
    rate = 1.0 / float(np.median(steps)) if steps.size else 1.0
    kernel = _derivative_kernel(rate)[::-1]
    out = np.full(angles.shape, np.nan)
    if len(angles) >= len(kernel):
        for axis in range(2):
            out[:, axis] = np.convolve(angles[:, axis], kernel, mode='same') * rate
        half = len(kernel) // 2
        out[:half] = np.nan
        out[len(out) - half:] = np.nan
    return out


def velocity_threshold(velocity: np.ndarray) -> np.ndarray:
    """
    Engbert & Kliegl's per-axis threshold, deg/s, shape (2,) (module doc).

    :param velocity: (N, 2) deg/s, NaN allowed.
    """
    finite = velocity[np.isfinite(velocity).all(axis=1)]
    if not len(finite):
        return np.full(2, MIN_VELOCITY_DEG_S)
    spread = np.sqrt(np.maximum(np.median(finite ** 2, axis=0)
                                - np.median(finite, axis=0) ** 2, 0.0))
    return np.maximum(LAMBDA * spread, MIN_VELOCITY_DEG_S)


@dataclass(frozen=True)
class Saccades:
    """
    Saccades found in a recording, in time order.

    :param onsets: (S,) s.
    :param offsets: (S,) s.
    :param start_index: (S,) first sample of each.
    :param end_index: (S,) last sample of each.
    :param amplitudes: (S,) deg between the gaze at onset and at offset.
    """

    onsets: np.ndarray
    offsets: np.ndarray
    start_index: np.ndarray
    end_index: np.ndarray
    amplitudes: np.ndarray


def detect_saccades(stamps: np.ndarray, angles: np.ndarray) -> Saccades:
    """
    Saccades by a velocity threshold adapted to the noise (module doc).

    :param stamps: (N,) s.
    :param angles: (N, 2) deg, spikes already removed.
    """
    velocity = velocities(stamps, angles)
    threshold = velocity_threshold(velocity)
    with np.errstate(invalid='ignore'):
        fast = np.sum((velocity / threshold) ** 2, axis=1) > 1.0
    edges = np.diff(np.concatenate([[0], fast.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    # The movement spans one sample either side of the fast run (a central difference).
    first = np.maximum(starts - 1, 0)
    last = np.minimum(ends + 1, len(stamps) - 1)
    amplitude = np.hypot(*(angles[last] - angles[first]).T) if len(first) else np.empty(0)
    keep = np.isfinite(amplitude) & (amplitude >= MIN_SACCADE_DEG)
    first, last = first[keep], last[keep]
    return Saccades(stamps[first], stamps[last], first, last, amplitude[keep])


@dataclass(frozen=True)
class StepMeasures:
    """
    What the gaze did after each measured target step (module doc); NaN = not measurable.

    All arrays have shape (K,), one entry per measured step.

    :param amplitude_deg: from the previous target to this one.
    :param latency_s: first saccade's onset after the target's onset.
    :param settle_s: from that onset until settled.
    :param first_landing_deg: first landing's distance from the settled point.
    :param settled_error_deg: settled gaze to the target.
    :param error_xy_deg: (K, 2) settled gaze minus target, (right, down) deg.
    :param drift_deg: displacement within the settled window.
    :param gain: primary gain (module doc).
    :param landing_ratio: first landing's distance from the settled point over
        the primary saccade's amplitude (module doc).
    :param rest_s: first saccade's end to the next saccade's onset, when one
        starts before the settled window.
    """

    amplitude_deg: np.ndarray
    latency_s: np.ndarray
    settle_s: np.ndarray
    first_landing_deg: np.ndarray
    settled_error_deg: np.ndarray
    error_xy_deg: np.ndarray
    drift_deg: np.ndarray
    gain: np.ndarray
    landing_ratio: np.ndarray
    rest_s: np.ndarray


def _median_point(angles: np.ndarray) -> np.ndarray:
    """Median of the valid rows of (M, 2), NaN when none."""
    valid = angles[np.isfinite(angles).all(axis=1)]
    return np.median(valid, axis=0) if len(valid) else np.full(2, np.nan)


def _running_median3(angles: np.ndarray) -> np.ndarray:
    """3-sample running median per axis (NaN-aware), same shape."""
    if len(angles) < 3:
        return angles.copy()
    stacked = np.stack([angles[:-2], angles[1:-1], angles[2:]])
    out = angles.copy()
    with warnings.catch_warnings():
        # All three lost: NaN is the answer, not a warning.
        warnings.simplefilter('ignore', RuntimeWarning)
        out[1:-1] = np.nanmedian(stacked, axis=0)
    return out


def clean_angles(recording: GazeRecording) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return a recording's gaze as angles with spikes replaced by their neighbours' mean.

    :returns: angles (N, 2) deg, spikes (N,) bool.
    """
    angles = gaze_angles_deg(recording.screen, recording.points)
    spikes = find_spikes(angles)
    index = np.flatnonzero(spikes)
    cleaned = angles.copy()
    cleaned[index] = (angles[index - 1] + angles[index + 1]) / 2.0
    return cleaned, spikes


def measure_steps(recording: GazeRecording) -> StepMeasures:
    """Measure every target step that jumps at least MIN_STEP_DEG (module doc)."""
    stamps = recording.stamps
    angles, _ = clean_angles(recording)
    saccades = detect_saccades(stamps, angles)
    schedule = recording.targets
    target_angles = gaze_angles_deg(recording.screen, schedule.places)
    rows: List[Tuple] = []
    for k in range(1, len(schedule)):
        onset, still = float(schedule.onsets[k]), float(schedule.still[k])
        amplitude = float(np.hypot(*(target_angles[k] - target_angles[k - 1])))
        end = min(still + SETTLED_WINDOW_S[1], float(schedule.ends[k]))
        if amplitude < MIN_STEP_DEG or end - still < SETTLED_WINDOW_S[0] + MIN_SETTLED_S:
            continue
        jump = math.isclose(still, onset, abs_tol=1e-6)
        rows.append((amplitude,) + _measure_one(stamps, angles, saccades, still, end,
                                                target_angles[k], jump))
    if not rows:
        empty = np.empty(0)
        return StepMeasures(empty, empty, empty, empty, empty, np.empty((0, 2)), empty, empty,
                            empty, empty)
    columns = list(zip(*rows))
    return StepMeasures(
        amplitude_deg=np.array(columns[0]), latency_s=np.array(columns[1]),
        settle_s=np.array(columns[2]), first_landing_deg=np.array(columns[3]),
        settled_error_deg=np.array(columns[4]), error_xy_deg=np.array(columns[5]),
        drift_deg=np.array(columns[6]), gain=np.array(columns[7]),
        landing_ratio=np.array(columns[8]), rest_s=np.array(columns[9]))


def _measure_one(stamps: np.ndarray, angles: np.ndarray, saccades: Saccades, onset: float,
                 end: float, target: np.ndarray, jump: bool) -> Tuple:
    """
    Measure one step (module doc).

    :returns: latency, settle, first landing, settled error, error (2,), drift,
        gain, landing ratio, rest.

    :param onset: when the target is shown still at its place, s.
    :param end: end of its settled window, s.
    :param jump: whether it jumped there (else it glided: no latency, landing or settling).
    """
    nan2 = np.full(2, np.nan)
    nan3 = (math.nan,) * 3
    low, high = np.searchsorted(stamps, [onset + SETTLED_WINDOW_S[0], end])
    window = angles[low:high]
    if np.isfinite(window).all(axis=1).sum() < max(3, (high - low) // 2):
        return (math.nan, math.nan, math.nan, math.nan, nan2, math.nan) + nan3
    settled = _median_point(window)
    error = settled - target
    # Drift: only when no saccade falls in the settled window.
    inside = (saccades.offsets >= stamps[low]) & (saccades.onsets <= stamps[high - 1])
    drift = math.nan
    if not inside.any():
        head = window[stamps[low:high] < stamps[low] + DRIFT_EDGE_S]
        tail = window[stamps[low:high] > stamps[high - 1] - DRIFT_EDGE_S]
        drift = float(np.hypot(*(_median_point(tail) - _median_point(head))))
    if not jump:
        return (math.nan, math.nan, math.nan, float(np.hypot(*error)), error, drift) + nan3
    # The first saccade after the onset.
    candidates = np.flatnonzero((saccades.onsets >= onset)
                                & (saccades.onsets < onset + LATENCY_WINDOW_S))
    if not len(candidates):
        return (math.nan, math.nan, math.nan, float(np.hypot(*error)), error, drift) + nan3
    first = candidates[0]
    latency = float(saccades.onsets[first] - onset)
    landing_end = saccades.offsets[first] + LANDING_S
    if first + 1 < len(saccades.onsets):
        landing_end = min(landing_end, saccades.onsets[first + 1])
    a = int(saccades.end_index[first])
    b = int(np.searchsorted(stamps, landing_end, side='right'))
    landing = _median_point(angles[a:max(b, a + 1)])
    first_landing = float(np.hypot(*(landing - settled)))
    # Settling: the last time the smoothed gaze is outside SETTLE_DEG before the window ends.
    start = int(saccades.start_index[first])
    smooth = _running_median3(angles[start:high])
    distance = np.hypot(*(smooth - settled).T)
    with np.errstate(invalid='ignore'):
        outside = np.flatnonzero(distance > SETTLE_DEG)
    settle = (float(stamps[start + outside[-1] + 1] - stamps[start]) if len(outside)
              and start + outside[-1] + 1 < high else 0.0)
    gain = ratio = rest = math.nan
    if latency >= ANTICIPATION_S:
        before = np.searchsorted(stamps, stamps[start] - PRE_SACCADE_S)
        way = settled - _median_point(angles[before:start + 1])
        amplitude = float(np.hypot(*way))
        if amplitude >= MIN_STEP_DEG:
            gain = float(np.dot(landing - settled + way, way)) / amplitude ** 2
            ratio = first_landing / amplitude
    if first + 1 < len(saccades.onsets) and \
            saccades.onsets[first + 1] < onset + SETTLED_WINDOW_S[0]:
        rest = float(saccades.onsets[first + 1] - saccades.offsets[first])
    return (latency, settle, first_landing, float(np.hypot(*error)), error, drift, gain, ratio,
            rest)


def blink_count(recording: GazeRecording) -> int:
    """Count the runs of lost samples lasting BLINK_S (module doc)."""
    lost = ~np.isfinite(recording.points).all(axis=1)
    edges = np.diff(np.concatenate([[0], lost.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)
    stamps = recording.stamps
    # A run's duration: from the last valid sample before it to the first one after.
    before = stamps[np.maximum(starts - 1, 0)]
    after = stamps[np.minimum(ends, len(stamps) - 1)]
    duration = after - before
    return int(np.count_nonzero((duration >= BLINK_S[0]) & (duration <= BLINK_S[1])))


@dataclass(frozen=True)
class GazeStatistics:
    """
    Summary of one or more recordings (module doc); NaN where nothing was measurable.

    :param steps: target steps measured.
    :param latency_median_ms: saccade latency after the onset, median.
    :param latency_p10_ms: its 10th percentile.
    :param latency_p90_ms: its 90th percentile.
    :param anticipation_share: share of steps whose first saccade started < 80 ms.
    :param settle_median_ms: saccade start to settled within 1 deg, median.
    :param slow_landing_share: share of steps whose landing takes > 100 ms.
    :param corrective_share: share of steps with a first landing > 2 deg from
        the settled point.
    :param error_median_deg: settled gaze to target, median.
    :param error_p90_deg: its 90th percentile.
    :param mean_offset_deg: per recording, the length of the mean error vector,
        the median over recordings.
    :param error_spread_deg: per recording, the RMS of the error vectors about
        their mean (how much the error varies over the screen), the median
        over recordings.
    :param drift_median_deg: drift within the settled window, median.
    :param gain_median: primary gain (first landing along the way to the
        settled point over that way), median.
    :param gain_p10: its 10th percentile.
    :param gain_p90: its 90th percentile.
    :param landing_ratio_median: first landing's distance from the settled
        point over the primary saccade's amplitude, median.
    :param landing_ratio_p90: its 90th percentile.
    :param rest_median_ms: first saccade's end to the next saccade's onset
        (before the settled window), median.
    :param rest_p90_ms: its 90th percentile.
    :param spikes_per_1000: single-sample spikes per 1000 valid samples.
    :param blinks_per_min: blinks per minute.
    :param lost_share: share of samples lost.
    """

    steps: int
    latency_median_ms: float
    latency_p10_ms: float
    latency_p90_ms: float
    anticipation_share: float
    settle_median_ms: float
    slow_landing_share: float
    corrective_share: float
    error_median_deg: float
    error_p90_deg: float
    mean_offset_deg: float
    error_spread_deg: float
    drift_median_deg: float
    gain_median: float
    gain_p10: float
    gain_p90: float
    landing_ratio_median: float
    landing_ratio_p90: float
    rest_median_ms: float
    rest_p90_ms: float
    spikes_per_1000: float
    blinks_per_min: float
    lost_share: float

    def as_dict(self) -> Dict[str, float]:
        """Return the fields by name."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def table(self) -> str:
        """One line per statistic, for a report."""
        return '\n'.join(f'{name:22s} {value:9.3f}' if isinstance(value, float)
                         else f'{name:22s} {value:9d}' for name, value in self.as_dict().items())


def _percentile(values: np.ndarray, q: float) -> float:
    """Percentile of the finite values, NaN when none."""
    values = values[np.isfinite(values)]
    return float(np.percentile(values, q)) if len(values) else math.nan


def _share(flags: np.ndarray, known: np.ndarray) -> float:
    """Share of flags among the known entries, NaN when none is known."""
    return float(np.mean(flags[known])) if np.any(known) else math.nan


def gaze_statistics(recordings: Iterable[GazeRecording]) -> GazeStatistics:
    """
    Pool the statistics of several recordings (a person or a group; module doc).

    Steps are pooled; the mean offset and its spread are per recording (one
    person each), then the median over recordings.
    """
    recordings = list(recordings)
    measures = [measure_steps(recording) for recording in recordings]
    latency = np.concatenate([m.latency_s for m in measures]) * 1e3
    settle = np.concatenate([m.settle_s for m in measures]) * 1e3
    landing = np.concatenate([m.first_landing_deg for m in measures])
    error = np.concatenate([m.settled_error_deg for m in measures])
    drift = np.concatenate([m.drift_deg for m in measures])
    gain = np.concatenate([m.gain for m in measures])
    ratio = np.concatenate([m.landing_ratio for m in measures])
    rest = np.concatenate([m.rest_s for m in measures]) * 1e3
    offsets, spreads = [], []
    for m in measures:
        vectors = m.error_xy_deg[np.isfinite(m.error_xy_deg).all(axis=1)]
        if len(vectors) >= 3:
            mean = vectors.mean(axis=0)
            offsets.append(float(np.hypot(*mean)))
            spreads.append(float(np.sqrt(np.mean(np.sum((vectors - mean) ** 2, axis=1)))))
    spikes = valid = blinks = 0
    samples = duration = 0.0
    lost = 0.0
    for recording in recordings:
        angles = gaze_angles_deg(recording.screen, recording.points)
        spikes += int(np.count_nonzero(find_spikes(angles)))
        valid += int(np.count_nonzero(np.isfinite(angles).all(axis=1)))
        blinks += blink_count(recording)
        duration += float(recording.stamps[-1] - recording.stamps[0]) if len(
            recording.stamps) else 0.0
        samples += len(recording.stamps)
        lost += recording.lost_share * len(recording.stamps)
    known_latency = np.isfinite(latency)
    with np.errstate(invalid='ignore'):
        return GazeStatistics(
            steps=int(sum(len(m.amplitude_deg) for m in measures)),
            latency_median_ms=_percentile(latency, 50),
            latency_p10_ms=_percentile(latency, 10),
            latency_p90_ms=_percentile(latency, 90),
            anticipation_share=_share(latency < ANTICIPATION_S * 1e3, known_latency),
            settle_median_ms=_percentile(settle, 50),
            slow_landing_share=_share(settle > SLOW_LANDING_S * 1e3, np.isfinite(settle)),
            corrective_share=_share(landing > CORRECTIVE_DEG, np.isfinite(landing)),
            error_median_deg=_percentile(error, 50),
            error_p90_deg=_percentile(error, 90),
            mean_offset_deg=float(np.median(offsets)) if offsets else math.nan,
            error_spread_deg=float(np.median(spreads)) if spreads else math.nan,
            drift_median_deg=_percentile(drift, 50),
            gain_median=_percentile(gain, 50),
            gain_p10=_percentile(gain, 10),
            gain_p90=_percentile(gain, 90),
            landing_ratio_median=_percentile(ratio, 50),
            landing_ratio_p90=_percentile(ratio, 90),
            rest_median_ms=_percentile(rest, 50),
            rest_p90_ms=_percentile(rest, 90),
            spikes_per_1000=1e3 * spikes / valid if valid else math.nan,
            blinks_per_min=60.0 * blinks / duration if duration > 0 else math.nan,
            lost_share=lost / samples if samples else math.nan)


def main(argv=None) -> int:
    """
    Print the statistics of recordings, each on its own, then all pooled.

    ``python -m eye_bci_ros2.recordings.gaze_statistics FILE_OR_FOLDER...``
    """
    import argparse
    from pathlib import Path

    from eye_bci_ros2.recordings.gaze import find_recordings, load_gaze, RecordingError

    parser = argparse.ArgumentParser(description='Statistics of recorded gaze.')
    parser.add_argument('paths', nargs='+', help='recordings or folders of them')
    args = parser.parse_args(argv)
    try:
        files = []
        for path in map(Path, args.paths):
            files += find_recordings(path) if path.is_dir() else [path]
        recordings = [load_gaze(path) for path in files]
    except RecordingError as error:
        parser.error(str(error))
    for recording in recordings:
        print(f'== {recording.name} ({recording.tracker}, {recording.rate_hz:.0f} Hz)')
        print(gaze_statistics([recording]).table())
    if len(recordings) > 1:
        print('== all')
        print(gaze_statistics(recordings).table())
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
