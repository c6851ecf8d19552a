"""
The evidence of one round and the decision rules: pure numpy.

Everything here works in the ``screen`` frame (px, x right, y down) and on
time stamps in seconds (any clock, as long as samples and regions share it); regions are
:class:`eye_bci_ros2.decision.regions.RegionSet`.

A *round* is one question: the regions offered, the gaze samples that fall
after its start, and one decision.  Three rules are provided:

* ``mean`` (the original rule, docs/DESIGN.md): drop the samples that are outside
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
makes every sample fresh (the rule off).  The same holds while the options
move (the camera still on its way when the question is asked): a region set
with the same labels whose outlines moved by more than :data:`MOVED_PX` is a
new display, so runs starting before its stamp + ``min_reaction_s`` are stale
too (an option sliding under a resting gaze is not a choice of it).  And a
gaze that rests *near* an option (outside it, where a tolerant rule counts
it, flickering between that option and none or a neighbour with the
tracker's noise) starts new runs without a reaction: so while the gaze stays
within :data:`REST_RADIUS_PX` of where it rested before ``start +
min_reaction_s`` (the mean of those samples), no run is fresh; fresh runs
start at or after the first sample farther than that (the saccade).  A round
without samples before that time has no resting gaze to hold.  The
window-end rules (mean, vote)
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

Share test (``min_share`` > 0; 0 = off, the original).  A sample counted for
an option by a tolerant classification (:mod:`eye_bci_ros2.decision.tolerance`) need
not be inside it, and a gaze resting between two options leaves a few such
samples on each: so a choice also needs a share of *all* the samples, in and
out of regions.  At the window end the chosen label must hold at least
``min_share`` of the window's valid samples (finite and within
:data:`SCREEN_MARGIN_PX` of the screen when it is known: tracker garbage is
not gaze); an early decision is made only at a sample whose label holds at
least :data:`EARLY_SHARE` of the valid samples stamped in the last
:data:`EARLY_SHARE_S` up to it (the early test is made at those samples
only).  ``bench/tolerance.py`` (its ``/s`` rules) measures what it buys.

Regions may move during a round (the camera moves, the labels stay): every
sample is classified against the regions shown at its own time and evidence
is kept per label.  For the mean rule every in-region sample is carried along
with the region it fell in (translated by that region's centroid motion) to
the newest geometry, and the mean is tested there; with static regions this
is exactly the original mean.

:class:`eye_bci_ros2.decision.rounds.RoundScheduler` runs rounds of this evidence on a
live stream (the choice_arbiter node's logic without ROS).
"""

from dataclasses import dataclass, field
import math
from typing import Callable, Dict, Mapping, Optional, Tuple

import numpy as np

from eye_bci_ros2.base.settings import Setting
from eye_bci_ros2.base.validators import Interval
from eye_bci_ros2.decision.regions import points_array, RegionSet
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING, px_per_degree_at

#: Names of the decision rules, as the ``method`` field of a :class:`Decision`.
METHODS = ('mean', 'vote')

#: Default probability that an in-region sample falls on the looked-at region.
DEFAULT_HIT_RATE = 0.9

#: Default shortest reaction to a new display, s: faster gaze is not a reaction to it.
DEFAULT_MIN_REACTION_S = 0.1

#: A gaze within this of where it rested at the round start has not moved (module doc), px:
#: 1.5 degrees at the centre of the default screen, five times the sample noise of a
#: consumer tracker and less than the pitch of any two options a person can tell apart.
REST_RADIUS_PX = 1.5 * float(px_per_degree_at(np.asarray(DEFAULT_VIEWING.centre_px, dtype=float)
                                              .reshape(1, 2), DEFAULT_VIEWING)[0])

#: Outlines that moved by more than this (any vertex, px) are a moving display (module doc).
MOVED_PX = 2.0

#: Largest accepted ``min_reaction_s``, s.
MAX_REACTION_S = 2.0

# The evidence settings, declared once (eye_bci_ros2.base.settings): the fields of
# eye_bci_ros2.decision.rounds.ArbiterSettings and the choice_arbiter's parameters, checked here
# too when a rule's evidence is made without them.

#: A probability more likely than not, short of certainty: (0.5, 1).
MORE_LIKELY_THAN_NOT = Interval(0.5, 1.0, low_open=True, high_open=True)
#: ``confidence``: posterior probability of the leading option a choice needs.
CONFIDENCE = Setting(
    0.9, 'Posterior probability of the leading option a choice needs (fixation: early '
    'and at the window end; mean/vote: the early decision)',
    interval=MORE_LIKELY_THAN_NOT, name='confidence',
    why='a choice needs the leader more likely than all the others together')
#: ``min_samples``: samples a deciding fixation or an early run must hold.
MIN_SAMPLES = Setting(
    2, 'Samples a deciding fixation must hold (fixation); fresh in-region samples an '
    'early decision needs, the most recent ones on the leader without interruption '
    '(mean/vote)', interval=Interval(1, 100000), name='min_samples')
#: ``dwell_s``: time a deciding fixation (or early run) must last, s.  A fixation must
#: outlast the transient landing of a saccade before its corrective saccade (mostly
#: < 150 ms; bench/real_gaze.py).
DWELL_S = Setting(
    0.15, 'Time a fixation must last before it decides (fixation: longer than the '
    'transient landing before a corrective saccade), or the early run on the leader '
    'must span (mean/vote), s', interval=Interval(0.0, 10.0), unit='s', name='dwell_s')
#: ``min_reaction_s``: shortest reaction to a new display, s.
MIN_REACTION = Setting(
    DEFAULT_MIN_REACTION_S,
    'Shortest reaction to a new display, s: gaze resting on or near an option from '
    'before round start + min_reaction_s is not a reaction and counts only after '
    'the gaze has moved away (fixation: never chooses; mean/vote: the early '
    'decision only, the window end uses every sample); 0 = off',
    interval=Interval(0.0, MAX_REACTION_S), unit='s', name='min_reaction_s',
    why='it is the shortest time a person takes to react to a new display (about 0.1 s)')
#: ``hit_rate``: the evidence model's h.
HIT_RATE = Setting(
    DEFAULT_HIT_RATE,
    'Evidence model: probability that an in-region sample is on the looked-at region',
    interval=MORE_LIKELY_THAN_NOT, name='hit_rate',
    why='an in-region sample must be more likely on the looked-at region than elsewhere')
#: ``min_share``: the share test (module doc).
MIN_SHARE = Setting(
    0.5, "Share test: a choice at the window end needs this fraction of the window's "
    'valid gaze samples on it, an early choice 0.8 of the samples of the last 0.1 s; '
    '0 = off (the original rule)', interval=Interval(0.0, 1.0), name='min_share',
    why="the share of all the window's samples a choice needs (0 = off, the original rule)")

#: Share test of the early decision (module doc): the samples of the last EARLY_SHARE_S s ...
EARLY_SHARE_S = 0.1
#: ... must be at least this fraction on the deciding sample's label.
EARLY_SHARE = 0.8

#: Gaze farther than this outside the screen is not a valid sample for the share test, px
#: (the bridge's default ``offscreen_margin_px``: it drops such samples itself).
SCREEN_MARGIN_PX = 100.0

#: Label id of a sample in no region, and of a sample that is not finite (not valid).
_NO_REGION = -1
_NOT_VALID = -2


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
    :param round_start: the round's start, s (the clock of the stamps); the
        samples used are those stamped from it to ``round_start +
        time_to_decision``.  NaN when not known (batch functions).
    :param weighed_stamps: the fixation rule: the stamps of the fixation that
        decided (or was judged at the window end), s; () for the count rules
        (they weigh every sample of the round).
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
    round_start: float = math.nan
    weighed_stamps: Tuple[float, ...] = ()

    def summary(self) -> str:
        """One line for a log: the choice and how it was reached."""
        head = f"choice '{self.label}'" if self.label is not None \
            else f'no choice ({self.reason})'
        if self.samples_used == 0:
            return f'{head} by {self.method}: no gaze sample in the window'
        fresh = f' ({self.fresh_samples} fresh)' \
            if 0 <= self.fresh_samples < self.in_region_samples else ''
        return (f'{head} by {self.method}: {self.samples_used} samples, '
                f'{self.in_region_samples} in regions{fresh}, margin {self.margin:.2f}, '
                f'posterior {self.posterior:.3f}, '
                f'{self.time_to_decision:.3f} s after the round start')


def log_odds(hit_rate: float, region_count: int) -> float:
    """
    Return the evidence weight lambda of one in-region sample (see the module doc).

    :param hit_rate: probability h in (1/R, 1) that an in-region sample is on
        the looked-at region.
    :param region_count: R, the number of offered labels (>= 1).
    :returns: log(h (R - 1) / (1 - h)); +inf when R == 1.
    """
    HIT_RATE.check(hit_rate)
    if region_count <= 1:
        return math.inf
    return math.log(hit_rate * (region_count - 1) / (1 - hit_rate))


def options_moved(old: RegionSet, new: RegionSet) -> bool:
    """Tell whether ``new`` shows the same options as ``old`` moved by more than MOVED_PX."""
    if new is old or new.labels != old.labels or new.polygons.shape != old.polygons.shape:
        return False
    with np.errstate(invalid='ignore'):
        shift = np.abs(new.polygons - old.polygons)
    return bool(np.nanmax(shift, initial=0.0) > MOVED_PX)


def checked_batch(points, stamps, confidence: Optional[float]
                  ) -> Tuple[np.ndarray, np.ndarray]:
    """
    Check a batch for a round's evidence (every rule's ``add``).

    :returns: points (N, 2) and stamps (N,) as float arrays.
    :raises ValueError: mismatched lengths, or a confidence outside (0.5, 1).
    """
    points = points_array(points)
    stamps = np.asarray(stamps, dtype=float).reshape(-1)
    if len(stamps) != len(points):
        raise ValueError(f'{len(points)} gaze points but {len(stamps)} stamps')
    if confidence is not None:
        CONFIDENCE.check(confidence)
    return points, stamps


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


def counts_summary(counts: np.ndarray, hit_rate: float) -> Tuple[int, float, np.ndarray]:
    """Leader index, margin and posterior of per-label counts (L,), L >= 1."""
    total = counts.sum()
    posterior = posterior_from_counts(counts, hit_rate)
    leader = int(np.argmax(counts))
    ordered = np.sort(counts)[::-1]
    runner_up = ordered[1] if len(ordered) > 1 else 0
    margin = float((ordered[0] - runner_up) / total) if total else 0.0
    return leader, margin, posterior


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
    :param min_share: the share test (module doc): a window-end choice needs
        this fraction of the valid samples on its label, and an early one
        :data:`EARLY_SHARE` of the last :data:`EARLY_SHARE_S`; in [0, 1], 0 =
        off (the original rule).  Fixed for the round.
    :param classifier: turns each region set given to :meth:`add` into the
        one that classifies the samples (and the window-end mean), e.g.
        :meth:`eye_bci_ros2.decision.rounds.ArbiterSettings.regions` (the tolerant
        rule); once per set.  None: the sets as given.
    :param screen_px: (width, height) of the screen, px: gaze far off it is not
        a valid sample (module doc, share test); None: every finite sample is.
    """

    def __init__(self, start: float = 0.0, hit_rate: float = DEFAULT_HIT_RATE,
                 min_samples: int = 10, dwell_s: float = 0.0, min_reaction_s: float = 0.0,
                 min_share: float = 0.0,
                 classifier: Optional[Callable[[RegionSet], RegionSet]] = None,
                 screen_px: Optional[Tuple[float, float]] = None):
        """Start an empty round."""
        for setting, value in ((HIT_RATE, hit_rate), (MIN_SHARE, min_share),
                               (MIN_SAMPLES, min_samples), (DWELL_S, dwell_s),
                               (MIN_REACTION, min_reaction_s)):
            setting.check(value)
        self.start = float(start)
        self.hit_rate = float(hit_rate)
        self.min_samples = int(min_samples)
        self.dwell_s = float(dwell_s)
        self.min_reaction_s = float(min_reaction_s)
        self.min_share = float(min_share)
        self.screen_px = None if screen_px is None else np.asarray(screen_px, dtype=float)
        self._classifier = classifier
        self._classified: Dict[int, tuple] = {}
        self.labels: list = []
        self.samples = 0
        #: Of those, valid samples (the share test's denominator, module doc).
        self.valid = 0
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
        # Stamp of the last region set that moved the options (module doc, fresh evidence).
        self._moved_at = -math.inf
        # Where the gaze rested before start + min_reaction_s (sum, count), and the stamp of
        # the first sample after it that left it (inf: not yet; -inf: no resting gaze).
        self._rest_sum = np.zeros(2)
        self._rest_count = 0
        self._gaze_moved_at = math.inf if self.min_reaction_s > 0 else -math.inf
        self._mapping: Dict[int, tuple] = {}
        # Current run of consecutive in-region samples on one label.
        self._run_label = -1
        self._run_count = 0
        self._run_start = math.nan
        # Label id of the newest sample (-1: no region, -2: not finite).
        self._last_label = _NO_REGION
        # Stamps and label ids of the samples of the last EARLY_SHARE_S (share test only).
        self._recent_stamps = np.zeros(0)
        self._recent_labels = np.zeros(0, dtype=np.intp)

    # -- read-only state (feedback, tools) ---------------------------------------------------

    @property
    def run_label(self) -> Optional[str]:
        """Return the label of the current run (consecutive in-region samples), or None."""
        return self.labels[self._run_label] if self._run_label >= 0 else None

    @property
    def run_count(self) -> int:
        """Return the number of samples in the current run."""
        return self._run_count if self._run_label >= 0 else 0

    @property
    def run_start(self) -> float:
        """Return the stamp of the current run's first sample, s (NaN without a run)."""
        return self._run_start if self._run_label >= 0 else math.nan

    @property
    def run_fresh(self) -> bool:
        """Tell whether the current run is fresh evidence for the early decision (module doc)."""
        return self._run_label >= 0 and self._run_start >= self.fresh_from

    @property
    def last_label(self) -> Optional[str]:
        """Return the label the newest sample counted for, or None (in no region)."""
        return self.labels[self._last_label] if self._last_label >= 0 else None

    @property
    def elapsed(self) -> float:
        """Return the sample time from the round start to the newest sample, s (0 without)."""
        return self.last_stamp - self.start if self.samples else 0.0

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
        if not self.min_reaction_s > 0:
            return -math.inf
        return max(max(self.start, self._moved_at) + self.min_reaction_s, self._gaze_moved_at)

    def posterior(self) -> Dict[str, float]:
        """Posterior of each offered label (module doc)."""
        return dict(zip(self.labels, posterior_from_counts(self._counts, self.hit_rate).tolist()))

    def regions_for(self, region_set: RegionSet) -> RegionSet:
        """Return ``region_set`` as this round classifies it (its ``classifier``)."""
        if self._classifier is None or not len(region_set):
            return region_set
        cached = self._classified.get(id(region_set))
        if cached is None or cached[0] is not region_set:
            cached = self._classified[id(region_set)] = (region_set,
                                                         self._classifier(region_set))
        return cached[1]

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
        points, stamps = checked_batch(points, stamps, confidence)
        region_set = self.regions_for(region_set)
        ids, label_centroids = self._label_ids(region_set)
        if self._latest is None or region_set.stamp >= self._latest.stamp:
            if self._latest is not None and options_moved(self._latest, region_set):
                self._moved_at = max(self._moved_at, region_set.stamp)
            self._latest = region_set
            # The newest geometry of each label, for the motion-compensated mean.
            self._centroids[ids[:-1]] = region_set.centroids
        if not len(points):
            return None
        region = region_set.classify(points)
        inside = np.flatnonzero(region >= 0)
        label = ids[region[inside]]
        finite = np.isfinite(points).all(axis=1)
        self._track_rest(points, stamps, finite)
        valid = finite    # the share test's samples (module doc)
        if self.screen_px is not None:
            with np.errstate(invalid='ignore'):
                valid = finite & np.all((points >= -SCREEN_MARGIN_PX)
                                        & (points <= self.screen_px + SCREEN_MARGIN_PX), axis=1)
        run_count, run_start = self._runs(label, stamps[inside])
        fresh = run_start >= self.fresh_from
        stop = len(points)
        decided = None
        every = None
        if self.min_share > 0:
            # Label id of every sample of the batch, for the early share test.
            every = np.where(valid, _NO_REGION, _NOT_VALID)
            every[inside] = label
        if confidence is not None and inside.size:
            share_ok = None if every is None else \
                self._early_shares(every, stamps, inside) >= EARLY_SHARE - 1e-12
            decided = self._first_confident(label, stamps[inside], run_count, run_start,
                                            fresh, confidence, share_ok)
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
        self.valid += int(np.count_nonzero(valid[:stop]))
        self.in_region += kept
        self.last_stamp = float(stamps[stop - 1])
        last = int(region[stop - 1])
        self._last_label = int(ids[last]) if last >= 0 else (
            _NO_REGION if valid[stop - 1] else _NOT_VALID)
        if every is not None:
            self._remember(stamps[:stop], every[:stop])
        if decided is not None:
            self.decision = self._decision(self.labels[label[decided]], 'early')
        return self.decision

    def _track_rest(self, points: np.ndarray, stamps: np.ndarray, finite: np.ndarray) -> None:
        """Update the resting gaze and when it was left (module doc, fresh evidence)."""
        if self._gaze_moved_at != math.inf:
            return
        reaction = self.start + self.min_reaction_s
        resting = finite & (stamps < reaction)
        if resting.any():
            self._rest_sum += points[resting].sum(axis=0)
            self._rest_count += int(np.count_nonzero(resting))
        later = np.flatnonzero(finite & (stamps >= reaction))
        if not later.size:
            return
        if not self._rest_count:
            self._gaze_moved_at = -math.inf    # no resting gaze to hold
            return
        rest = self._rest_sum / self._rest_count
        away = later[np.hypot(*(points[later] - rest).T) > REST_RADIUS_PX]
        if away.size:
            self._gaze_moved_at = float(stamps[away[0]])

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
                         confidence, share_ok=None) -> Optional[int]:
        """
        Find the first in-region sample after which the early test passes.

        All arguments have shape (M,), one entry per in-region sample of the
        batch: label id, stamp s, run length and run start s after it,
        whether it is fresh, and (None: no share test) whether it passes the
        early share test.
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
        if share_ok is not None:
            passed &= share_ok
        hits = np.flatnonzero(passed)
        return int(hits[0]) if hits.size else None

    def _early_shares(self, every: np.ndarray, stamps: np.ndarray,
                      inside: np.ndarray) -> np.ndarray:
        """
        Share of each in-region sample's label in the valid samples of the last EARLY_SHARE_S.

        :param every: label id of every sample of the batch (N,): >= 0, or -1
            (no region) and -2 (not finite, not counted).
        :param stamps: (N,) s.
        :param inside: indices (M,) of the in-region samples of the batch.
        :returns: (M,): over the samples stamped in ``(t - EARLY_SHARE_S, t]``
            up to each one (earlier batches' included), those on its label /
            the valid ones.  O(history + N log N): the history holds
            EARLY_SHARE_S of samples.
        """
        held = len(self._recent_stamps)
        all_stamps = np.concatenate([self._recent_stamps, stamps])
        all_labels = np.concatenate([self._recent_labels, every])
        count = len(all_stamps)
        at = held + inside
        first = np.searchsorted(all_stamps, all_stamps[at] - EARLY_SHARE_S, side='right')
        valid = np.concatenate([[0], np.cumsum(all_labels != _NOT_VALID)])
        total = valid[at + 1] - valid[first]
        # Samples on a label, keyed (label, position) in order: a range count per sample.
        position = np.arange(count)
        on = all_labels >= 0
        keys = all_labels[on] * count + position[on]       # ascending within each label
        keys.sort()
        mine = all_labels[at] * count
        same = (np.searchsorted(keys, mine + at, side='right')
                - np.searchsorted(keys, mine + first, side='left'))
        return same / np.maximum(total, 1)

    def _remember(self, stamps: np.ndarray, every: np.ndarray) -> None:
        """Keep the samples a later sample's EARLY_SHARE_S may reach (share test)."""
        all_stamps = np.concatenate([self._recent_stamps, stamps])
        keep = all_stamps > all_stamps[-1] - EARLY_SHARE_S
        self._recent_stamps = all_stamps[keep]
        self._recent_labels = np.concatenate([self._recent_labels, every])[keep]

    def _recent_share(self) -> float:
        """Share of the current run's label in the valid samples of the last EARLY_SHARE_S."""
        labels = self._recent_labels
        valid = np.count_nonzero(labels != _NOT_VALID)
        return float(np.count_nonzero(labels == self._run_label) / valid) if valid else 0.0

    def early(self, confidence: float) -> Optional[Decision]:
        """Test the early decision on the evidence so far (no samples added)."""
        if self.decision is not None:
            return self.decision
        if not self.fresh:
            return None
        if self.min_share > 0 and not (self._last_label == self._run_label
                                       and self._recent_share() >= EARLY_SHARE - 1e-12):
            return None
        leader = int(np.argmax(self._fresh_counts))
        posterior = posterior_from_counts(self._fresh_counts, self.hit_rate)[leader]
        if (posterior >= confidence and self.fresh >= self.min_samples
                and self._run_label == leader and self._run_start >= self.fresh_from
                and self._run_count >= self.min_samples
                and self.last_stamp - self._run_start >= self.dwell_s - 1e-9):
            self.decision = self._decision(self.labels[leader], 'early')
        return self.decision

    def configure(self, settings) -> None:
        """Take the evidence settings of an :class:`ArbiterSettings` from the next sample on."""
        self.hit_rate = float(settings.hit_rate)
        self.min_samples = int(settings.min_samples)
        self.dwell_s = float(settings.dwell_s)
        self.min_reaction_s = float(settings.min_reaction_s)

    def next_due(self) -> Optional[float]:
        """Return when the current run can first decide early, s: the count rules say none."""
        return None

    def progress(self, settings) -> Dict[str, float]:
        """
        Return the progress towards each label seen, 0..1 (feedback).

        The window rule's (:func:`eye_bci_ros2.decision.evidence.window_progress`, over
        the valid samples so far) and, with ``settings.early_decision``, the
        larger of it and the early decision's
        (:func:`eye_bci_ros2.decision.evidence.early_progress`; a stale run gives none).
        """
        counts = self.counts
        out = window_progress(counts, self.valid, self.elapsed, settings.window_s)
        if settings.early_decision:
            fresh = self.fresh_counts
            run = self.run_label if self.run_fresh else None
            early = early_progress(fresh, settings.hit_rate, settings.confidence, run,
                                   self.run_count, settings.min_samples,
                                   self.last_stamp - self.run_start if run else 0.0,
                                   settings.dwell_s)
            out = {label: max(value, early.get(label, 0.0)) for label, value in out.items()}
        return out

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
        leader, margin, _ = counts_summary(self._counts, self.hit_rate)
        if method == 'vote':
            if margin == 0.0:
                return self._decision(None, method, 'tie between the leading regions')
            return self._shared(self.labels[leader], method)
        mean = self.mean_point()
        region = self._latest.classify_one(mean[0], mean[1]) if self._latest else -1
        if region < 0:
            return self._decision(
                None, method, f'mean ({mean[0]:.1f}, {mean[1]:.1f}) px is in no region')
        return self._shared(self._latest.labels[region], method)

    def _shared(self, label: str, method: str) -> Decision:
        """Decide ``label`` at the window end if it passes the share test (module doc)."""
        held = int(self._counts[self._label_index[label]])
        if self.min_share > 0 and held < self.min_share * max(self.valid, 1):
            return self._decision(
                None, method, f"only {held} of the window's {self.valid} samples count for "
                f"'{label}' (min_share {self.min_share:g}): the gaze was mostly elsewhere")
        return self._decision(label, method)

    def _decision(self, label: Optional[str], method: str, reason: str = '') -> Decision:
        """Build a Decision from the current state (early: margin, posterior of fresh counts)."""
        weighed = self._fresh_counts if method == 'early' else self._counts
        if self.in_region:
            leader, margin, posterior = counts_summary(weighed, self.hit_rate)
            chosen = self._label_index[label] if label is not None else leader
            probability = float(posterior[chosen])
            mean = self.mean_point()
            mean_point = (float(mean[0]), float(mean[1]))
        else:
            margin, probability, mean_point = 0.0, math.nan, None
        return Decision(label, method, self.samples, self.in_region, margin, probability,
                        time_to_decision=self.last_stamp - self.start, counts=self.counts,
                        mean_point=mean_point, reason=reason, fresh_samples=self.fresh,
                        round_start=self.start)


def clip01(value: float) -> float:
    """Clip a progress to [0, 1]; NaN gives 0."""
    return float(min(max(value, 0.0), 1.0)) if math.isfinite(value) else (
        1.0 if value == math.inf else 0.0)


def early_progress(fresh_counts: Mapping[str, int], hit_rate: float, confidence: float,
                   run_label: Optional[str], run_count: int, min_samples: int,
                   run_span_s: float, dwell_s: float) -> Dict[str, float]:
    """
    Progress of the early decision towards each label (:meth:`RoundEvidence.progress`).

    :param fresh_counts: fresh in-region samples per offered label (every
        offered label, zeros included: R = its length).
    :param hit_rate: h of the evidence model.
    :param confidence: posterior needed.
    :param run_label: label of the current run, or None.
    :param run_count: samples in that run.
    :param min_samples: run samples needed.
    :param run_span_s: sample time the run spans, s.
    :param dwell_s: span needed, s.
    :returns: label -> progress 0..1.
    """
    labels = list(fresh_counts)
    if not labels:
        return {}
    counts = np.array([fresh_counts[label] for label in labels], dtype=float)
    region_count = len(labels)
    if region_count == 1:
        posterior_progress = np.ones(1)
    else:
        weight = math.log(hit_rate * (region_count - 1) / (1.0 - hit_rate))
        exponent = weight * (counts - counts.max())
        posterior = np.exp(exponent) / np.exp(exponent).sum()
        chance = 1.0 / region_count
        posterior_progress = np.clip((posterior - chance) / (confidence - chance), 0.0, 1.0)
    out = {}
    for label, value in zip(labels, posterior_progress):
        if label != run_label:
            out[label] = 0.0
            continue
        run = clip01(run_count / max(min_samples, 1))
        dwell = 1.0 if dwell_s <= 0 else clip01(run_span_s / dwell_s)
        out[label] = float(min(value, run, dwell))
    return out


def window_progress(counts: Mapping[str, int], samples: int, elapsed_s: float,
                    window_s: float) -> Dict[str, float]:
    """
    Progress of a window rule (mean, vote) towards each label (:meth:`RoundEvidence.progress`).

    :param counts: samples per offered label so far (in-region, or tolerant).
    :param samples: every sample of the window so far (in and out of regions).
    :param elapsed_s: time since the round start, s.
    :param window_s: the window, s (> 0).
    """
    if not window_s > 0:
        raise ValueError(f'window_s must be > 0 s, got {window_s}')
    time_part = clip01(elapsed_s / window_s)
    return {label: time_part * (count / samples if samples > 0 else 0.0)
            for label, count in counts.items()}
