"""
Decide which on-screen region a person chose from their gaze: pure numpy, no rclpy.

Everything here works in the ``screen`` frame (px, x right, y down) and on
time stamps in seconds (any clock, as long as samples and regions share it).

A *round* is one question: the regions offered, the gaze samples that fall
after its start, and one decision.  Three rules are provided:

* ``mean`` (the original rule, DESIGN.md): drop the samples that are outside
  every region, average the rest, choose the region that contains the mean;
  no choice when no sample is in a region or the mean falls in none.
* ``vote``: the region (label) holding most in-region samples; a tie between
  the two leaders is no choice.  ``margin`` is the leader's share of the
  in-region samples minus the runner-up's.
* ``early`` (:class:`RoundEvidence` with a confidence): choose as soon as the
  evidence for one label is strong enough, before the window ends.

Evidence model of the early decision.  Samples outside every region carry no
information about the choice and are ignored.  An in-region sample falls on
the looked-at region with probability ``h`` (``hit_rate``) and otherwise
uniformly on one of the other ``R - 1`` offered regions.  With a uniform
prior, after ``n_r`` of ``N`` in-region samples fell on label ``r``::

    P(r | n) = h^n_r ((1 - h)/(R - 1))^(N - n_r) / sum_s (same for s)
             = 1 / sum_s exp(lambda (n_s - n_r)),  lambda = log(h (R - 1) / (1 - h))

so only count differences matter.  A *run* is a maximal sequence of
consecutive in-region samples on one label (out-of-region samples, e.g.
blinks, do not interrupt it; an in-region sample on another label ends it).

Fresh evidence.  Only a sample that can be a reaction to the round's display
is evidence for the early decision: no person reacts to a new display faster
than ``min_reaction_s`` (about 0.1 s for a saccade), so a run that began
before ``start + min_reaction_s`` is a gaze that was already there (typically
where the previous menu showed the option just chosen, and a target of the
new menu may now lie there).  Its samples are *stale*, even those after that
time, until the gaze leaves the region for another one: the next run is a new
fixation and is fresh.  Fresh samples are therefore exactly those of runs
starting at or after ``start + min_reaction_s``; the early decision weighs
only them (counts, posterior, ``min_samples``), and ``min_reaction_s`` 0
makes every sample fresh (the rule off).  The window-end rules (mean, vote)
always use every sample of the window, so ``mean`` stays the original rule
and a gaze that stays on a region it rested on from the start is decided by
it, at the window end: slower, never a hasty wrong choice.

A label is chosen early when, all at once: its posterior from the fresh
counts is >= ``confidence``; the round holds >= ``min_samples`` fresh
in-region samples; the label holds the most recent ``min_samples`` in-region
samples in one fresh run; and that run spans >= ``dwell_s`` of sample time.
The dwell keeps a saccade that crosses a region from triggering a choice at
any tracker rate (``min_samples`` counts samples: at 1200 Hz a saccade
crossing a region leaves several samples on it).
With one offered region the posterior is 1 and only the run, dwell and
freshness tests apply.  ``R`` counts every label offered during the round.

Regions may move during a round (the camera moves, the labels stay): every
sample is classified against the regions shown at its own time and evidence
is kept per label.  For the mean rule every in-region sample is carried along
with the region it fell in (translated by that region's centroid motion) to
the newest geometry, and the mean is tested there; with static regions this
is exactly the original mean.

Overlapping regions: a point inside several regions belongs to the one whose
area centroid is nearest to it (the first listed on an exact tie).

:class:`ChoiceTracker` runs rounds on a live stream (the choice_arbiter
node's logic without ROS): samples are classified the moment they arrive,
so a decision is made while handling the sample that completes it; regions
that arrive after samples stamped at or after them re-classify the open
round (see the class doc for when a decision is final).
"""

import bisect
from collections import deque
from dataclasses import dataclass, field, fields
import math
from typing import Callable, Deque, Dict, List, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.geometry import PolygonSet

#: Names of the decision rules, as the ``method`` field of a :class:`Decision`.
METHODS = ('mean', 'vote')

#: Default probability that an in-region sample falls on the looked-at region.
DEFAULT_HIT_RATE = 0.9

#: Default shortest reaction to a new display, s: faster gaze is not a reaction to it.
DEFAULT_MIN_REACTION_S = 0.1

#: Largest accepted ``min_reaction_s``, s.
MAX_REACTION_S = 2.0

#: Default bound on how far after its arrival a gaze sample may be stamped, s.
DEFAULT_MAX_FUTURE_S = 1.0

#: Largest accepted ``max_future_s``, s.
MAX_FUTURE_S = 60.0


@dataclass(frozen=True)
class Decision:
    """
    Outcome of a round (or of a batch of samples).

    :param label: the chosen region's label, or None when there is no choice.
    :param method: 'mean', 'vote' or 'early'.
    :param samples_used: samples considered, in and out of regions.
    :param in_region_samples: of those, samples inside some region.
    :param margin: (leader's count - runner-up's count) / in_region_samples,
        0 when there are no in-region samples.
    :param posterior: posterior probability of ``label`` (of the vote leader
        when ``label`` is None) under the evidence model; NaN without
        in-region samples.
    :param time_to_decision: s from the round start to the stamp of the last
        sample used; NaN when the samples had no stamps.
    :param counts: in-region samples per label.
    :param mean_point: mean of the in-region samples (screen px, motion
        compensated, see the module doc), shape (2,), or None.
    :param reason: why there is no choice ('' when there is one).
    :param fresh_samples: of the in-region samples, those that can be a
        reaction to the display (module doc); for an ``early`` decision
        ``margin`` and ``posterior`` are those of the fresh counts, the
        evidence it weighed.  -1 when not known (batch functions).
    """

    label: Optional[str]
    method: str
    samples_used: int
    in_region_samples: int
    margin: float
    posterior: float
    time_to_decision: float = math.nan
    counts: Dict[str, int] = field(default_factory=dict)
    mean_point: Optional[Tuple[float, float]] = None
    reason: str = ''
    fresh_samples: int = -1

    def summary(self) -> str:
        """One line for a log: the choice and how it was reached."""
        head = f"choice '{self.label}'" if self.label is not None \
            else f'no choice ({self.reason})'
        fresh = f' ({self.fresh_samples} fresh)' \
            if 0 <= self.fresh_samples < self.in_region_samples else ''
        return (f'{head} by {self.method}: {self.samples_used} samples, '
                f'{self.in_region_samples} in regions{fresh}, margin {self.margin:.2f}, '
                f'posterior {self.posterior:.3f}, '
                f'{self.time_to_decision:.3f} s after the round start')


def _points_array(points) -> np.ndarray:
    """Return ``points`` as a float array of shape (N, 2)."""
    array = np.asarray(points, dtype=float)
    if array.ndim == 1 and array.shape == (2,):
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f'gaze points must have shape (N, 2), got {array.shape}')
    return array


def _polygon_centroids(polygons: np.ndarray) -> np.ndarray:
    """Area centroids of polygons (R, K, 2) -> (R, 2); vertex mean if degenerate."""
    x, y = polygons[..., 0], polygons[..., 1]
    x_next, y_next = np.roll(x, -1, axis=1), np.roll(y, -1, axis=1)
    cross = x * y_next - x_next * y
    area = cross.sum(axis=1) / 2
    with np.errstate(divide='ignore', invalid='ignore'):
        cx = ((x + x_next) * cross).sum(axis=1) / (6 * area)
        cy = ((y + y_next) * cross).sum(axis=1) / (6 * area)
    centroids = np.stack([cx, cy], axis=1)
    flat = ~(np.abs(area) > 1e-12)
    centroids[flat] = polygons[flat].mean(axis=1)
    return centroids


def log_odds(hit_rate: float, region_count: int) -> float:
    """
    Return the evidence weight lambda of one in-region sample (see the module doc).

    :param hit_rate: probability h in (1/R, 1) that an in-region sample is on
        the looked-at region.
    :param region_count: R, the number of offered labels (>= 1).
    :returns: log(h (R - 1) / (1 - h)); +inf when R == 1.
    """
    check_hit_rate(hit_rate)
    if region_count <= 1:
        return math.inf
    return math.log(hit_rate * (region_count - 1) / (1 - hit_rate))


def check_hit_rate(hit_rate: float) -> None:
    """Raise ValueError unless 0.5 < hit_rate < 1."""
    if not 0.5 < hit_rate < 1.0:
        raise ValueError(f'hit_rate must be in (0.5, 1), got {hit_rate}: an in-region sample '
                         'must be more likely on the looked-at region than elsewhere')


def check_min_reaction(min_reaction_s: float) -> None:
    """Raise ValueError unless 0 <= min_reaction_s <= MAX_REACTION_S."""
    if not 0.0 <= min_reaction_s <= MAX_REACTION_S:
        raise ValueError(f'min_reaction_s must be in [0, {MAX_REACTION_S}] s, got '
                         f'{min_reaction_s}: it is the shortest time a person takes to react '
                         'to a new display (about 0.1 s)')


def posterior_from_counts(counts, hit_rate: float = DEFAULT_HIT_RATE) -> np.ndarray:
    """
    Compute the posterior probability of each label given its in-region counts.

    :param counts: shape (L,) or (M, L) in-region sample counts per label; L
        is the number of offered labels R.
    :param hit_rate: see :func:`log_odds`.
    :returns: same shape as ``counts``, rows sum to 1 (uniform without samples).
    """
    counts = np.asarray(counts, dtype=float)
    if counts.shape[-1] == 0:
        return counts.copy()
    weight = log_odds(hit_rate, counts.shape[-1])
    if math.isinf(weight):
        return np.ones_like(counts)
    exponent = weight * (counts - counts.max(axis=-1, keepdims=True))
    unnormalised = np.exp(exponent)
    return unnormalised / unnormalised.sum(axis=-1, keepdims=True)


class RegionSet:
    """
    The regions offered at one moment: labels and convex screen polygons.

    :param labels: R labels (a region's text, else ns/id); repeated labels are
        allowed and pool their evidence.
    :param polygons: shape (R, K, 2), screen px, convex, any winding; rows may
        repeat their last vertex as padding; NaN rows contain nothing.
    :param stamp: when these regions became what the screen shows, s.
    """

    def __init__(self, labels: Sequence[str], polygons, stamp: float = 0.0):
        """Prepare the regions for fast point tests."""
        labels = tuple(str(label) for label in labels)
        polygons = np.asarray(polygons, dtype=float)
        if polygons.size == 0 and not labels:
            polygons = np.zeros((0, 3, 2))
        if polygons.ndim != 3 or polygons.shape[2] != 2 or polygons.shape[1] < 3:
            raise ValueError(f'region polygons must have shape (R, K >= 3, 2), '
                             f'got {polygons.shape}')
        if len(labels) != len(polygons):
            raise ValueError(f'{len(labels)} labels for {len(polygons)} region polygons')
        if not math.isfinite(stamp):
            raise ValueError(f'region stamp must be finite, got {stamp}')
        self.labels = labels
        self.polygons = polygons
        self.stamp = float(stamp)
        self.centroids = _polygon_centroids(polygons)
        self._set = PolygonSet(polygons)

    def __len__(self) -> int:
        """Return the number of regions."""
        return len(self.labels)

    def __repr__(self) -> str:
        """Describe the set briefly."""
        return f'RegionSet({list(self.labels)}, stamp={self.stamp:.3f})'

    @property
    def label_set(self) -> frozenset:
        """Return the distinct labels offered."""
        return frozenset(self.labels)

    def classify(self, points) -> np.ndarray:
        """
        Find the region of each point.

        :param points: shape (N, 2), screen px; NaN points are in no region.
        :returns: shape (N,) int, the region index, -1 when in none; a point in
            several regions goes to the one with the nearest centroid.
        """
        points = _points_array(points)
        if not self.labels:
            return np.full(len(points), -1, dtype=np.intp)
        with np.errstate(invalid='ignore', over='ignore'):  # NaN, inf: in no region
            inside = self._set.contains(points)
        return self._resolve(points, inside)

    def classify_one(self, x: float, y: float) -> int:
        """Per-sample path of :meth:`classify`: region index of (x, y) px, or -1."""
        if not self.labels:
            return -1
        point = np.array([[x, y]], dtype=float)
        with np.errstate(invalid='ignore', over='ignore'):
            inside = self._set.contains(point)
        return int(self._resolve(point, inside)[0])

    def _resolve(self, points: np.ndarray, inside: np.ndarray) -> np.ndarray:
        """Pick one region per point from an (N, R) inside matrix."""
        hits = inside.sum(axis=1)
        result = np.where(hits > 0, inside.argmax(axis=1), -1)
        several = np.flatnonzero(hits > 1)
        if several.size:
            delta = points[several, None, :] - self.centroids[None, :, :]
            distance = np.einsum('nrk,nrk->nr', delta, delta)
            distance[~inside[several]] = np.inf
            result[several] = distance.argmin(axis=1)
        return result


def _counts_summary(counts: np.ndarray, hit_rate: float) -> Tuple[int, float, np.ndarray]:
    """Leader index, margin and posterior of per-label counts (L,), L >= 1."""
    total = counts.sum()
    posterior = posterior_from_counts(counts, hit_rate)
    leader = int(np.argmax(counts))
    ordered = np.sort(counts)[::-1]
    runner_up = ordered[1] if len(ordered) > 1 else 0
    margin = float((ordered[0] - runner_up) / total) if total else 0.0
    return leader, margin, posterior


def _label_counts(region_set: RegionSet, region: np.ndarray) -> Tuple[list, np.ndarray]:
    """Distinct labels of a set and the count of region indices per label."""
    distinct = sorted(region_set.label_set)
    index = {label: i for i, label in enumerate(distinct)}
    to_label = np.array([index[label] for label in region_set.labels] + [-1], dtype=np.intp)
    ids = to_label[region]
    counts = np.bincount(ids[ids >= 0], minlength=len(distinct))
    return distinct, counts


def decide_mean(points, region_set: RegionSet,
                hit_rate: float = DEFAULT_HIT_RATE) -> Decision:
    """
    Apply the original rule to one batch of samples and static regions.

    Drop the samples outside every region, average the rest, and choose the
    region that contains the mean.

    :param points: shape (N, 2), screen px.
    :param region_set: the regions shown.
    :param hit_rate: only for the reported posterior.
    :returns: the decision; ``label`` is None when no sample is in a region or
        the mean is in none.
    """
    points = _points_array(points)
    region = region_set.classify(points)
    inside = region >= 0
    used, in_region = len(points), int(inside.sum())
    if not in_region:
        return Decision(None, 'mean', used, 0, 0.0, math.nan, reason='no sample in any region')
    distinct, counts = _label_counts(region_set, region)
    _, margin, posterior = _counts_summary(counts, hit_rate)
    mean = points[inside].mean(axis=0)
    chosen = region_set.classify_one(mean[0], mean[1])
    counts_map = dict(zip(distinct, counts.tolist()))
    mean_point = (float(mean[0]), float(mean[1]))
    if chosen < 0:
        leader = int(np.argmax(counts))
        return Decision(None, 'mean', used, in_region, margin, float(posterior[leader]),
                        counts=counts_map, mean_point=mean_point,
                        reason=f'mean ({mean[0]:.1f}, {mean[1]:.1f}) px is in no region')
    label = region_set.labels[chosen]
    return Decision(label, 'mean', used, in_region, margin,
                    float(posterior[distinct.index(label)]), counts=counts_map,
                    mean_point=mean_point)


def decide_vote(points, region_set: RegionSet,
                hit_rate: float = DEFAULT_HIT_RATE) -> Decision:
    """
    Choose the majority of the in-region samples, on one batch and static regions.

    :param points: shape (N, 2), screen px.
    :param region_set: the regions shown.
    :param hit_rate: only for the reported posterior.
    :returns: the decision; ``label`` is None without in-region samples or on
        a tie between the two leading labels.
    """
    points = _points_array(points)
    region = region_set.classify(points)
    used, in_region = len(points), int((region >= 0).sum())
    if not in_region:
        return Decision(None, 'vote', used, 0, 0.0, math.nan, reason='no sample in any region')
    distinct, counts = _label_counts(region_set, region)
    leader, margin, posterior = _counts_summary(counts, hit_rate)
    mean = points[region >= 0].mean(axis=0)
    details = {'counts': dict(zip(distinct, counts.tolist())),
               'mean_point': (float(mean[0]), float(mean[1]))}
    if margin == 0.0:
        return Decision(None, 'vote', used, in_region, 0.0, float(posterior[leader]),
                        reason='tie between the leading regions', **details)
    return Decision(distinct[leader], 'vote', used, in_region, margin, float(posterior[leader]),
                    **details)


class RoundEvidence:
    """
    Incremental evidence of one round: O(1) state, batches processed vectorised.

    Feed samples in time order with :meth:`add` (each batch with the regions
    shown at those samples' time); ask :meth:`decide` at the window end.  With
    a ``confidence`` :meth:`add` stops at the first sample where the early
    test passes (module doc) and returns that decision.

    :param start: round start, s (the clock of the sample stamps).
    :param hit_rate: h of the evidence model, in (0.5, 1).
    :param min_samples: fresh in-region samples needed, and held by the
        leader in one fresh run, before an early decision (>= 1).
    :param dwell_s: sample time the leader's run must span before an early
        decision, s (>= 0).
    :param min_reaction_s: runs starting before ``start + min_reaction_s``
        are stale and not evidence for the early decision (module doc), s
        (>= 0; 0 = every sample is fresh).  A change applies to the samples
        added after it.
    """

    def __init__(self, start: float = 0.0, hit_rate: float = DEFAULT_HIT_RATE,
                 min_samples: int = 10, dwell_s: float = 0.0, min_reaction_s: float = 0.0):
        """Start an empty round."""
        check_hit_rate(hit_rate)
        if int(min_samples) < 1:
            raise ValueError(f'min_samples must be at least 1, got {min_samples}')
        if not dwell_s >= 0:
            raise ValueError(f'dwell_s must be >= 0, got {dwell_s}')
        check_min_reaction(min_reaction_s)
        self.start = float(start)
        self.hit_rate = float(hit_rate)
        self.min_samples = int(min_samples)
        self.dwell_s = float(dwell_s)
        self.min_reaction_s = float(min_reaction_s)
        self.labels: list = []
        self.samples = 0
        self.in_region = 0
        #: Fresh in-region samples (module doc).
        self.fresh = 0
        self.last_stamp = math.nan
        self.decision: Optional[Decision] = None
        self._label_index: Dict[str, int] = {}
        self._counts = np.zeros(0, dtype=np.int64)
        self._fresh_counts = np.zeros(0, dtype=np.int64)
        self._centroids = np.zeros((0, 2))
        self._offset_sum = np.zeros(2)
        self._latest: Optional[RegionSet] = None
        self._mapping: Dict[int, tuple] = {}
        # Current run of consecutive in-region samples on one label.
        self._run_label = -1
        self._run_count = 0
        self._run_start = math.nan

    @property
    def counts(self) -> Dict[str, int]:
        """In-region samples per offered label."""
        return dict(zip(self.labels, self._counts.tolist()))

    @property
    def fresh_counts(self) -> Dict[str, int]:
        """Fresh in-region samples per offered label (the early decision's evidence)."""
        return dict(zip(self.labels, self._fresh_counts.tolist()))

    @property
    def fresh_from(self) -> float:
        """Return the stamp from which a run is fresh, s (-inf when ``min_reaction_s`` is 0)."""
        return self.start + self.min_reaction_s if self.min_reaction_s > 0 else -math.inf

    def posterior(self) -> Dict[str, float]:
        """Posterior of each offered label (module doc)."""
        return dict(zip(self.labels, posterior_from_counts(self._counts, self.hit_rate).tolist()))

    def _label_ids(self, region_set: RegionSet) -> Tuple[np.ndarray, np.ndarray]:
        """
        Map each region of a set to its round label id; give each label's centroid.

        :returns: ``(ids, centroids)``: ids shape (R + 1,) with -1 last (for
            'no region'); centroids shape (L, 2) indexed by label id (a label
            offered twice takes its last region's centroid; NaN if absent).
        """
        cached = self._mapping.get(id(region_set))
        if cached is not None and cached[0] is region_set:
            return cached[1], cached[2]
        new = [label for label in dict.fromkeys(region_set.labels)
               if label not in self._label_index]
        if new:
            for label in new:
                self._label_index[label] = len(self.labels)
                self.labels.append(label)
            self._counts = np.concatenate([self._counts, np.zeros(len(new), dtype=np.int64)])
            self._fresh_counts = np.concatenate(
                [self._fresh_counts, np.zeros(len(new), dtype=np.int64)])
            self._centroids = np.concatenate([self._centroids, np.full((len(new), 2), np.nan)])
        ids = np.array([self._label_index[label] for label in region_set.labels] + [-1],
                       dtype=np.intp)
        centroids = np.full((len(self.labels), 2), np.nan)
        centroids[ids[:-1]] = region_set.centroids
        self._mapping[id(region_set)] = (region_set, ids, centroids)
        return ids, centroids

    def add(self, points, stamps, region_set: RegionSet,
            confidence: Optional[float] = None) -> Optional[Decision]:
        """
        Accumulate samples shown with ``region_set``, in time order.

        :param points: shape (N, 2), screen px.
        :param stamps: shape (N,), s, non-decreasing and after earlier batches.
        :param region_set: the regions shown at these samples' time.
        :param confidence: when given, in (0.5, 1): test the early decision
            after every in-region sample and stop at the first that passes.
        :returns: the early decision once made (later calls return it again
            and add nothing), else None.
        """
        if self.decision is not None:
            return self.decision
        points = _points_array(points)
        stamps = np.asarray(stamps, dtype=float).reshape(-1)
        if len(stamps) != len(points):
            raise ValueError(f'{len(points)} gaze points but {len(stamps)} stamps')
        if confidence is not None and not 0.5 < confidence < 1.0:
            raise ValueError(f'confidence must be in (0.5, 1), got {confidence}')
        ids, label_centroids = self._label_ids(region_set)
        if self._latest is None or region_set.stamp >= self._latest.stamp:
            self._latest = region_set
            # The newest geometry of each label, for the motion-compensated mean.
            self._centroids[ids[:-1]] = region_set.centroids
        if not len(points):
            return None
        region = region_set.classify(points)
        inside = np.flatnonzero(region >= 0)
        label = ids[region[inside]]
        run_count, run_start = self._runs(label, stamps[inside])
        fresh = run_start >= self.fresh_from
        stop = len(points)
        decided = None
        if confidence is not None and inside.size:
            decided = self._first_confident(label, stamps[inside], run_count, run_start,
                                            fresh, confidence)
            if decided is not None:
                stop = inside[decided] + 1
        taken = inside[inside < stop]
        kept = len(taken)
        if kept:
            self._counts += np.bincount(label[:kept], minlength=len(self.labels))
            fresh_label = label[:kept][fresh[:kept]]
            self._fresh_counts += np.bincount(fresh_label, minlength=len(self.labels))
            self.fresh += len(fresh_label)
            # Position relative to its label's centroid at the sample's time.
            offsets = points[taken] - label_centroids[label[:kept]]
            self._offset_sum += offsets.sum(axis=0)
            self._run_label = int(label[kept - 1])
            self._run_count = int(run_count[kept - 1])
            self._run_start = float(run_start[kept - 1])
        self.samples += int(stop)
        self.in_region += kept
        self.last_stamp = float(stamps[stop - 1])
        if decided is not None:
            self.decision = self._decision(self.labels[label[decided]], 'early')
        return self.decision

    def _runs(self, label: np.ndarray, stamps: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """Length and start stamp of the current run after each in-region sample (M,)."""
        count = len(label)
        previous = np.empty(count, dtype=np.intp)
        previous[:1] = self._run_label
        previous[1:] = label[:-1]
        new_run = label != previous
        run_id = np.cumsum(new_run)
        # Index of the sample that started each sample's run; -1: run began before.
        starts = np.concatenate([[-1], np.flatnonzero(new_run)])
        start_pos = starts[run_id]
        position = np.arange(count)
        continuing = start_pos < 0
        run_count = np.where(continuing, self._run_count + position + 1, position - start_pos + 1)
        run_start = np.where(continuing, self._run_start, stamps[np.maximum(start_pos, 0)])
        return run_count, run_start

    def _first_confident(self, label, stamps, run_count, run_start, fresh,
                         confidence) -> Optional[int]:
        """
        Find the first in-region sample after which the early test passes.

        All arguments have shape (M,), one entry per in-region sample of the
        batch: label id, stamp s, run length and run start s after it, and
        whether it is fresh.
        :returns: its index in those arrays, or None.
        """
        count, width = len(label), len(self.labels)
        # Fresh counts per label after each sample of the batch, (M, L).
        cumulative = np.zeros((count, width), dtype=np.int64)
        cumulative[np.arange(count), label] = fresh
        np.cumsum(cumulative, axis=0, out=cumulative)
        cumulative += self._fresh_counts
        leader = cumulative.argmax(axis=1)
        posterior = posterior_from_counts(cumulative, self.hit_rate)
        leader_posterior = posterior[np.arange(count), leader]
        total = self.fresh + np.cumsum(fresh)
        passed = (fresh & (leader_posterior >= confidence) & (total >= self.min_samples)
                  & (label == leader) & (run_count >= self.min_samples)
                  & (stamps - run_start >= self.dwell_s - 1e-9))
        hits = np.flatnonzero(passed)
        return int(hits[0]) if hits.size else None

    def early(self, confidence: float) -> Optional[Decision]:
        """Test the early decision on the evidence so far (no samples added)."""
        if self.decision is not None:
            return self.decision
        if not self.fresh:
            return None
        leader = int(np.argmax(self._fresh_counts))
        posterior = posterior_from_counts(self._fresh_counts, self.hit_rate)[leader]
        if (posterior >= confidence and self.fresh >= self.min_samples
                and self._run_label == leader and self._run_start >= self.fresh_from
                and self._run_count >= self.min_samples
                and self.last_stamp - self._run_start >= self.dwell_s - 1e-9):
            self.decision = self._decision(self.labels[leader], 'early')
        return self.decision

    def mean_point(self) -> Optional[np.ndarray]:
        """Motion-compensated mean of the in-region samples, shape (2,) px, or None."""
        if not self.in_region:
            return None
        used = self._counts > 0
        carried = (self._counts[used, None] * self._centroids[used]).sum(axis=0)
        return (self._offset_sum + carried) / self.in_region

    def decide(self, method: str = 'mean') -> Decision:
        """
        Decide at the window end (or return the early decision if made).

        :param method: 'mean' (original) or 'vote'.
        """
        if self.decision is not None:
            return self.decision
        if method not in METHODS:
            raise ValueError(f"unknown method '{method}': use one of {', '.join(METHODS)}")
        if not self.in_region:
            return self._decision(None, method, 'no sample in any region')
        leader, margin, _ = _counts_summary(self._counts, self.hit_rate)
        if method == 'vote':
            if margin == 0.0:
                return self._decision(None, method, 'tie between the leading regions')
            return self._decision(self.labels[leader], method)
        mean = self.mean_point()
        region = self._latest.classify_one(mean[0], mean[1]) if self._latest else -1
        if region < 0:
            return self._decision(
                None, method, f'mean ({mean[0]:.1f}, {mean[1]:.1f}) px is in no region')
        return self._decision(self._latest.labels[region], method)

    def _decision(self, label: Optional[str], method: str, reason: str = '') -> Decision:
        """Build a Decision from the current state (early: margin, posterior of fresh counts)."""
        weighed = self._fresh_counts if method == 'early' else self._counts
        if self.in_region:
            leader, margin, posterior = _counts_summary(weighed, self.hit_rate)
            chosen = self._label_index[label] if label is not None else leader
            probability = float(posterior[chosen])
            mean = self.mean_point()
            mean_point = (float(mean[0]), float(mean[1]))
        else:
            margin, probability, mean_point = 0.0, math.nan, None
        return Decision(label, method, self.samples, self.in_region, margin, probability,
                        time_to_decision=self.last_stamp - self.start, counts=self.counts,
                        mean_point=mean_point, reason=reason, fresh_samples=self.fresh)


#: A round holding this many samples closes at once (bounds memory on a runaway stream).
MAX_ROUND_SAMPLES = 1 << 21

#: Recent samples kept for a round that starts at a stamp in the past, at most.
MAX_RECENT_SAMPLES = 1 << 17

#: Extra time recent samples are kept beyond ``window_s``, s.
RECENT_MARGIN_S = 0.5

_EMPTY_REGIONS = RegionSet([], np.zeros((0, 3, 2)))


class SampleLog:
    """
    Growable log of gaze samples: stamps (N,) s and points (N, 2) screen px.

    Appending is amortised O(1); samples may come out of stamp order and are
    sorted (stable) only when :meth:`ordered` is asked for them.
    """

    def __init__(self, capacity: int = 1024):
        """Start empty with room for ``capacity`` samples."""
        capacity = max(int(capacity), 1)
        self._stamps = np.empty(capacity)
        self._points = np.empty((capacity, 2))
        self._size = 0
        self._sorted = True
        #: Largest stamp logged, s (-inf when empty).
        self.max_stamp = -math.inf

    def __len__(self) -> int:
        """Return the number of samples logged."""
        return self._size

    def append(self, stamp: float, x: float, y: float) -> None:
        """Log one sample: stamp s, point (x, y) px."""
        if self._size == len(self._stamps):
            self._stamps = np.concatenate([self._stamps, np.empty(self._size)])
            self._points = np.concatenate([self._points, np.empty((self._size, 2))])
        self._stamps[self._size] = stamp
        self._points[self._size, 0] = x
        self._points[self._size, 1] = y
        self._size += 1
        if stamp >= self.max_stamp:
            self.max_stamp = stamp
        else:
            self._sorted = False

    def ordered(self) -> Tuple[np.ndarray, np.ndarray]:
        """Return the samples in stamp order: stamps (N,) s, points (N, 2) px (views)."""
        stamps, points = self._stamps[:self._size], self._points[:self._size]
        if not self._sorted:
            order = np.argsort(stamps, kind='stable')
            stamps[:], points[:] = stamps[order], points[order]
            self._sorted = True
        return stamps, points


@dataclass
class ArbiterSettings:
    """
    Settings of a :class:`ChoiceTracker` (the choice_arbiter's parameters).

    :param method: decision rule at the window end, one of :data:`METHODS`.
    :param window_s: gaze collection time of a round, s of sample stamps (> 0).
    :param early_decision: decide before the window ends on strong evidence.
    :param confidence: posterior needed for an early decision, in (0.5, 1).
    :param min_samples: early decision: fresh in-region samples needed (>= 1).
    :param dwell_s: early decision: span of the leader's run, s (>= 0).
    :param min_reaction_s: early decision: a run starting earlier than this
        after the round start is not evidence (a gaze already there), s
        (0 to :data:`MAX_REACTION_S`; 0 = off).
    :param hit_rate: evidence model h, in (0.5, 1).
    :param reorder_s: longest wait of a decision for regions that may apply
        to its last samples, s (>= 0; 0 = decide at once).
    :param stall_timeout_s: close a round this long after its window when
        no later sample arrives, s of arrival time (>= 0).
    :param max_future_s: drop a sample stamped more than this after its
        arrival, s (0 to :data:`MAX_FUTURE_S`): acquisition cannot follow
        arrival, so only a clock offset or a corrupt stamp does that, and
        one such sample must not end a round (:class:`ChoiceTracker`).
    """

    method: str = 'mean'
    window_s: float = 1.0
    early_decision: bool = False
    # Early-decision defaults: the configuration bench/decision.py selects on its
    # tuning persons (90 Hz and 1200 Hz trackers, gaze off the menu or on another target).
    confidence: float = 0.95
    min_samples: int = 2
    dwell_s: float = 0.02
    min_reaction_s: float = DEFAULT_MIN_REACTION_S
    hit_rate: float = DEFAULT_HIT_RATE
    reorder_s: float = 0.0
    stall_timeout_s: float = 0.5
    max_future_s: float = DEFAULT_MAX_FUTURE_S

    def __post_init__(self):
        """Reject values no round can run with."""
        if self.method not in METHODS:
            raise ValueError(f"unknown method '{self.method}': use one of {', '.join(METHODS)}")
        if not self.window_s > 0:
            raise ValueError(f'window_s must be > 0 s, got {self.window_s}')
        if not 0.5 < self.confidence < 1.0:
            raise ValueError(f'confidence must be in (0.5, 1), got {self.confidence}')
        check_hit_rate(self.hit_rate)
        if int(self.min_samples) < 1:
            raise ValueError(f'min_samples must be at least 1, got {self.min_samples}')
        for name in ('dwell_s', 'reorder_s', 'stall_timeout_s'):
            if not getattr(self, name) >= 0:
                raise ValueError(f'{name} must be >= 0 s, got {getattr(self, name)}')
        check_min_reaction(self.min_reaction_s)
        if not 0.0 <= self.max_future_s <= MAX_FUTURE_S:
            raise ValueError(f'max_future_s must be in [0, {MAX_FUTURE_S}] s, got '
                             f'{self.max_future_s}: it bounds how far after its arrival a '
                             'gaze sample may be stamped (about 1 s)')

    def evidence(self, start: float) -> 'RoundEvidence':
        """Return an empty :class:`RoundEvidence` for a round starting at ``start`` s."""
        return RoundEvidence(start, hit_rate=self.hit_rate, min_samples=self.min_samples,
                             dwell_s=self.dwell_s, min_reaction_s=self.min_reaction_s)

    def replace(self, **changed) -> 'ArbiterSettings':
        """Return a copy with ``changed`` fields (unknown names are ignored)."""
        names = {item.name for item in fields(self)}
        values = {name: getattr(self, name) for name in names}
        values.update({name: value for name, value in changed.items() if name in names})
        return ArbiterSettings(**values)


class _Round:
    """State of the open round."""

    def __init__(self, start: float, settings: ArbiterSettings):
        self.start = start
        self.evidence = settings.evidence(start)
        # In-window samples as they arrived, for re-classification.
        self.log = SampleLog()
        self.window_closed = False
        # A decision made but not yet final (reorder_s > 0), and until when it may wait.
        self.pending: Optional[Decision] = None
        self.deadline = math.inf


#: ``on_log(level, key, text)``: level 'info' or 'warning'; key names the kind of message.
LogCallback = Callable[[str, str, str], None]


class ChoiceTracker:
    """
    Rounds of choices on a live stream of gaze samples and region sets.

    The choice_arbiter node's logic without ROS; every time is in s on one
    clock (sample stamps, region stamps and ``now``, the arrival time).

    Rounds.  :meth:`request` starts a round at ``now``; a region set whose
    labels differ from the offered ones starts one at its stamp (at ``now``
    when that stamp is more than ``window_s`` old).  Region sets with the same
    labels only move the regions.  A new round replaces an unfinished one
    without a choice.  A round uses the samples stamped in
    ``[start, start + window_s)`` and ends with one decision: when a sample
    stamped after the window arrives, when the early test passes (with
    ``early_decision``), or ``stall_timeout_s`` after the window on the
    arrival clock when the stream is quiet (:meth:`tick`).

    Stamps.  A sample stamped more than ``max_future_s`` after its arrival
    (``now``) is dropped: acquisition cannot follow arrival, so the stamp is
    corrupt or its clock wrong, and taken it would end the open round at once
    (or the next one, which takes recent samples) and lose the gaze that
    follows.  A sample stamped more than ``window_s`` before the open round's
    start (between rounds: before ``now - 2 window_s``, as a round may start
    ``window_s`` in the past) is dropped too: no round can use it.  Both are
    counted (:attr:`samples_from_future`, :attr:`samples_too_old`) and logged
    as warnings (keys ``gaze_future``, ``gaze_too_old``).  A NaN or infinite
    coordinate is taken as a sample in no region (it counts in
    ``samples_used``, never as evidence), counted (:attr:`samples_not_finite`)
    and logged (key ``gaze_not_finite``).

    Latency.  Each sample is classified on arrival against the region set
    shown at its stamp (the newest one in the steady state: O(1) work), so the
    decision is made inside the :meth:`add_sample` call that delivers the
    sample completing it; nothing waits for a timer.

    Regions late relative to gaze (they come on another topic, so a sample
    can arrive before the region set stamped just before it):

    * samples of the open round stamped at or after a region set that arrives
      later are classified again with the right sets (O(round), rare); a
      round that starts at a past stamp takes the recent samples stamped
      after its start;
    * with ``reorder_s == 0`` (default) a decision is final when made: the
      regions known then are taken as shown.  A region set that arrives
      later with a stamp at or before the decision's last sample cannot
      change it; it is logged as a warning (key ``late_regions``);
    * with ``reorder_s > 0`` a decision whose last sample is stamped after
      the newest known region set waits until a region set stamped at or
      after that sample arrives (then nothing older can come: region stamps
      never go back) or ``reorder_s`` passes; a set that arrives meanwhile
      re-classifies the round, which may change or delay the decision.

    :param settings: the round settings (may be replaced later with
        :meth:`configure`).
    :param on_decision: called with every finished round's decision
        (``label`` None when there is no choice).
    :param on_log: called with (level, key, text) for the log.
    """

    def __init__(self, settings: Optional[ArbiterSettings] = None,
                 on_decision: Optional[Callable[[Decision], None]] = None,
                 on_log: Optional[LogCallback] = None):
        """Start with no regions and no open round."""
        self.settings = settings if settings is not None else ArbiterSettings()
        self._on_decision = on_decision or (lambda decision: None)
        self._on_log = on_log or (lambda level, key, text: None)
        # Region sets by stamp (ascending), pruned to what the rounds may still need.
        self._history: List[RegionSet] = []
        self._history_stamps: List[float] = []
        self._offered = frozenset()
        # (stamp, x, y) of recent samples, arrival order, for rounds starting in the past.
        self._recent: Deque[Tuple[float, float, float]] = deque(maxlen=MAX_RECENT_SAMPLES)
        self._round: Optional[_Round] = None
        # Stamp of the last sample the last finished decision used.
        self._final_stamp = -math.inf
        #: The outcome of the last finished round.
        self.last_decision: Optional[Decision] = None
        #: Rounds started so far.
        self.rounds_started = 0
        #: Gaze samples received so far (dropped ones included).
        self.samples_received = 0
        #: Samples dropped for a stamp more than ``max_future_s`` after their arrival.
        self.samples_from_future = 0
        #: Samples dropped for a stamp too long before any round they could be part of.
        self.samples_too_old = 0
        #: Samples with a NaN or infinite coordinate (taken as in no region).
        self.samples_not_finite = 0

    @property
    def offered(self) -> frozenset:
        """Labels of the newest region set."""
        return self._offered

    @property
    def round_open(self) -> bool:
        """Whether a round is collecting gaze (or holding a decision)."""
        return self._round is not None

    @property
    def round_start(self) -> Optional[float]:
        """Return the open round's start, s (its window is ``[start, start + window_s)``)."""
        return self._round.start if self._round is not None else None

    def configure(self, **changed) -> None:
        """
        Change settings (names of :class:`ArbiterSettings`).

        The open round uses them from its next sample on (counts so far stay).
        """
        self.settings = self.settings.replace(**changed)
        if self._round is not None:
            evidence = self._round.evidence
            evidence.hit_rate = float(self.settings.hit_rate)
            evidence.min_samples = int(self.settings.min_samples)
            evidence.dwell_s = float(self.settings.dwell_s)
            evidence.min_reaction_s = float(self.settings.min_reaction_s)

    # -- inputs ---------------------------------------------------------------------------

    def add_sample(self, stamp: float, x: float, y: float, now: float) -> Optional[Decision]:
        """
        Take one gaze sample, in arrival order.

        Samples with an implausible stamp are dropped (class doc, "Stamps").

        :param stamp: acquisition time of the sample, s (finite).
        :param x: screen x, px (NaN or infinite: in no region).
        :param y: screen y, px (NaN or infinite: in no region).
        :param now: arrival time, s (finite).
        :returns: the decision this sample completed (also passed to
            ``on_decision``), else None.
        """
        if not (math.isfinite(stamp) and math.isfinite(now)):
            raise ValueError(f'gaze sample stamp {stamp} s and arrival time {now} s must be '
                             'finite')
        self.samples_received += 1
        if not self._plausible(stamp, now):
            return None
        if not (math.isfinite(x) and math.isfinite(y)):
            self.samples_not_finite += 1
            self._on_log('warning', 'gaze_not_finite',
                         f'gaze sample ({x}, {y}) px is NaN or infinite: taken as in no region '
                         f'({self.samples_not_finite} such samples so far)')
        recent = self._recent
        recent.append((stamp, x, y))
        horizon = now - self.settings.window_s - RECENT_MARGIN_S
        while recent and recent[0][0] < horizon:
            recent.popleft()
        round_ = self._round
        if round_ is None or stamp < round_.start:
            return None
        return self._take(round_, stamp, x, y, now)

    def _plausible(self, stamp: float, now: float) -> bool:
        """Tell whether a sample's stamp can be right and of use; count and log it if not."""
        settings = self.settings
        ahead = stamp - now
        if ahead > settings.max_future_s:
            self.samples_from_future += 1
            self._on_log('warning', 'gaze_future',
                         f'gaze sample stamped {ahead:.3f} s after its arrival dropped (more '
                         f'than max_future_s {settings.max_future_s} s: a corrupt stamp or a '
                         f'wrong clock); {self.samples_from_future} dropped so far')
            return False
        round_ = self._round
        # The earliest stamp a round can use: a round started by new choices begins at
        # most window_s in the past.
        earliest = round_.start if round_ is not None else now - settings.window_s
        behind = earliest - stamp
        if behind > settings.window_s:
            self.samples_too_old += 1
            what = 'the round start' if round_ is not None else 'any round start'
            self._on_log('warning', 'gaze_too_old',
                         f'gaze sample stamped {behind:.3f} s before {what} dropped (more '
                         f'than window_s {settings.window_s} s: delivered late, or a corrupt '
                         f'stamp); {self.samples_too_old} dropped so far')
            return False
        return True

    def add_regions(self, region_set: RegionSet, now: float) -> Optional[Decision]:
        """
        Take a new region set (the complete set shown from ``region_set.stamp`` on).

        :param now: arrival time, s.
        :returns: a decision this completed (a held one made final, or the
            round the new choices end), else None.
        """
        stamp = region_set.stamp
        # Checked first: only choices made before this message arrived can have missed it.
        late_by = self._final_stamp - stamp
        stamps = self._history_stamps
        out_of_order = bool(stamps) and stamp < stamps[-1]
        if out_of_order:
            # DDS may deliver a latched (older) set after a newer live one: it only
            # tells what was shown at its time, never what is offered now.
            self._on_log('warning', 'regions_order',
                         'regions message older than the previous one: used for the samples '
                         'of its time only; the newer set stays offered')
        changed = not out_of_order and region_set.label_set != self._offered
        index = bisect.bisect_right(stamps, stamp)
        self._history.insert(index, region_set)
        stamps.insert(index, stamp)
        decision = None
        round_ = self._round
        if changed:
            self._offered = region_set.label_set
            if round_ is not None:
                decision = self._close_for_new_choices(round_, stamp)
            if self._offered:
                start = stamp
                if stamp < now - self.settings.window_s:
                    start = now
                    self._on_log('warning', 'old_regions',
                                 f'regions stamp is {now - stamp:.2f} s old: the round starts '
                                 'at their arrival')
                decision = self._start_round(start, 'new choices', now, replay=True) \
                    or decision
        elif round_ is not None:
            if round_.pending is not None and round_.evidence.last_stamp < stamp:
                # Stamped after every sample the held decision used: it is final.
                decision = self._finish(round_.pending)
            elif round_.log.max_stamp >= stamp and not self._repeats(index):
                decision = self._reclassify(round_, now)
        if late_by >= 0:
            self._on_log('warning', 'late_regions',
                         f'a regions message arrived after the choice its stamp applies to '
                         f'(stamped {late_by:.3f} s before the last sample used): that '
                         'choice stands; set reorder_s to let choices wait for late regions')
        self._prune_history(now)
        return decision

    def _repeats(self, index: int) -> bool:
        """Tell whether history set ``index`` equals the one before it (same classification)."""
        if index == 0:
            return False
        new, old = self._history[index], self._history[index - 1]
        return new.labels == old.labels and np.array_equal(new.polygons, old.polygons,
                                                           equal_nan=True)

    def request(self, now: float) -> Optional[Decision]:
        """
        Start a round at ``now`` (a held decision of the open round is made final first).

        :returns: that held decision, if any.
        """
        decision = None
        round_ = self._round
        if round_ is not None:
            if round_.pending is not None:
                decision = self._finish(round_.pending)
            else:
                self._on_log('info', 'round', 'choice request: the unfinished round is replaced')
        return self._start_round(now, 'request', now, replay=False) or decision

    def tick(self, now: float) -> Optional[Decision]:
        """
        Close a held decision past its deadline or a round whose stream went quiet.

        Call it periodically (the node: every 20 ms).
        :returns: the decision made, if any.
        """
        round_ = self._round
        if round_ is None:
            return None
        if round_.pending is not None:
            return self._finish(round_.pending) if now >= round_.deadline else None
        if now >= round_.start + self.settings.window_s + self.settings.stall_timeout_s:
            round_.window_closed = True
            return self._finish(round_.evidence.decide(self.settings.method))
        return None

    # -- rounds ---------------------------------------------------------------------------

    def _take(self, round_: _Round, stamp: float, x: float, y: float,
              now: float) -> Optional[Decision]:
        """Add one sample stamped at or after the round start."""
        settings = self.settings
        if stamp >= round_.start + settings.window_s:
            if round_.window_closed:
                return None
            round_.window_closed = True
            if round_.pending is not None:
                return None
            return self._propose(round_, round_.evidence.decide(settings.method), now)
        log = round_.log
        if len(log) >= MAX_ROUND_SAMPLES:
            self._on_log('warning', 'round_full',
                         f'{len(log)} samples in one round: closing it now')
            round_.window_closed = True
            return self._finish(round_.evidence.decide(settings.method))
        in_order = not stamp < log.max_stamp
        log.append(stamp, x, y)
        if round_.pending is not None:
            return None
        if not in_order:
            return self._reclassify(round_, now)
        decision = round_.evidence.add(
            np.array([[x, y]]), np.array([stamp]), self._regions_at(stamp),
            settings.confidence if settings.early_decision else None)
        if decision is None:
            return None
        return self._propose(round_, decision, now)

    def _regions_at(self, stamp: float) -> RegionSet:
        """Return the region set shown at ``stamp`` (the newest in the steady state)."""
        stamps = self._history_stamps
        if not stamps:
            return _EMPTY_REGIONS
        if stamp >= stamps[-1]:
            return self._history[-1]
        return self._history[max(bisect.bisect_right(stamps, stamp) - 1, 0)]

    def _rebuild(self, round_: _Round, until: float = math.inf) -> Optional[Decision]:
        """
        Classify the round's samples stamped before ``until`` again, each with its regions.

        :returns: the decision they reach (early, or at the window end if it
            closed and ``until`` is past it), else None.
        """
        settings = self.settings
        evidence = settings.evidence(round_.start)
        stamps, points = round_.log.ordered()
        if until < math.inf:
            keep = np.searchsorted(stamps, until, side='left')
            stamps, points = stamps[:keep], points[:keep]
        confidence = settings.confidence if settings.early_decision else None
        if len(stamps):
            if self._history:
                shown = np.searchsorted(self._history_stamps, stamps, side='right') - 1
                np.maximum(shown, 0, out=shown)
            else:
                shown = np.full(len(stamps), -1)
            bounds = np.flatnonzero(np.diff(shown)) + 1
            for lo, hi in zip(np.r_[0, bounds], np.r_[bounds, len(stamps)]):
                regions = self._history[shown[lo]] if shown[lo] >= 0 else _EMPTY_REGIONS
                if evidence.add(points[lo:hi], stamps[lo:hi], regions, confidence) is not None:
                    break
        round_.evidence = evidence
        if evidence.decision is not None:
            return evidence.decision
        if round_.window_closed and until >= round_.start + settings.window_s:
            return evidence.decide(settings.method)
        return None

    def _reclassify(self, round_: _Round, now: float) -> Optional[Decision]:
        """Rebuild the open round's evidence and propose what it decides."""
        round_.pending = None
        decision = self._rebuild(round_)
        if decision is None:
            return None
        return self._propose(round_, decision, now)

    def _propose(self, round_: _Round, decision: Decision, now: float) -> Optional[Decision]:
        """Finish with ``decision`` now, or hold it for late regions (reorder_s)."""
        last = round_.evidence.last_stamp
        newest = self._history_stamps[-1] if self._history_stamps else -math.inf
        if self.settings.reorder_s <= 0 or not last > newest:
            return self._finish(decision)
        round_.pending = decision
        if round_.deadline == math.inf:
            round_.deadline = now + self.settings.reorder_s
        return None

    def _close_for_new_choices(self, round_: _Round, stamp: float) -> Optional[Decision]:
        """End the open round because new choices are shown from ``stamp`` on."""
        decision = None
        if round_.pending is not None:
            decision = round_.pending
            if round_.evidence.last_stamp >= stamp:
                # It used samples of the new question: decide on the old one's alone.
                decision = self._rebuild(round_, until=stamp)
        elif stamp >= round_.start + self.settings.window_s:
            # The window ended before the new question: decide on it.
            round_.window_closed = True
            decision = round_.evidence.decide(self.settings.method)
        if decision is not None:
            return self._finish(decision)
        self._round = None
        self._on_log('info', 'round', 'offered choices changed: the unfinished round is '
                                      'replaced without a choice')
        return None

    def _start_round(self, start: float, cause: str, now: float,
                     replay: bool) -> Optional[Decision]:
        """
        Open a round at ``start``.

        :param replay: take the recent samples stamped after ``start`` (they
            arrived before the regions that start the round).
        """
        round_ = self._round = _Round(start, self.settings)
        self.rounds_started += 1
        self._on_log('info', 'round',
                     f'round {self.rounds_started} ({cause}): offered {sorted(self._offered)}, '
                     f'window {self.settings.window_s} s')
        early = []
        # Newest first: usually none or a few.
        for sample in reversed(self._recent if replay else ()):
            if sample[0] < start:
                break
            early.append(sample)
        if not early:
            return None
        end = start + self.settings.window_s
        for stamp, x, y in reversed(early):
            if stamp >= end:
                round_.window_closed = True
            else:
                round_.log.append(stamp, x, y)
        return self._reclassify(round_, now)

    def _finish(self, decision: Decision) -> Decision:
        """Close the open round with ``decision`` and report it."""
        round_, self._round = self._round, None
        if round_ is not None and math.isfinite(round_.evidence.last_stamp):
            self._final_stamp = round_.evidence.last_stamp
        self.last_decision = decision
        self._on_decision(decision)  # first: the log line must not delay the choice
        counts = ', '.join(f'{label} {n}' for label, n in decision.counts.items())
        self._on_log('info', 'decision', f'{decision.summary()} [{counts}]')
        return decision

    def _prune_history(self, now: float) -> None:
        """Forget region sets no round can need any more."""
        # Future rounds start no earlier than now - window_s; keep the set shown then.
        cutoff = now - self.settings.window_s
        if self._round is not None:
            cutoff = min(cutoff, self._round.start)
        keep_from = bisect.bisect_right(self._history_stamps, cutoff) - 1
        if keep_from > 0:
            del self._history[:keep_from]
            del self._history_stamps[:keep_from]
