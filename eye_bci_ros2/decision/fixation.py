"""
The fixation rule: choose the option a settled fixation lands on, clearly (pure numpy).

Why a rule of its own.  Real gaze does not go to an option and stay: the
first landing of a saccade is often short of the goal or beyond it and a
corrective saccade follows 100-200 ms later (Becker 1989; about 40 % of the
steps of the X2-60 recordings in ``../shared/data/real_gaze``); the tracker
adds single-sample spikes, drift and an error that varies over the screen
(median about 1 deg, p90 about 1.8 deg for remote trackers in real use,
Holmqvist & Andersson 2017).  A rule that counts samples on an option fires
on the transient landing; a rule that asks where a *fixation* settled, and
whether that place is clearly one option's, does not.

Events (online, causal, any rate).  A fixation is a run of valid samples
that stay within :data:`FIXATION_RADIUS_DEG` of the run's mean (a dispersion
detector, the I-DT family of Salvucci & Goldberg 2000, run online: at 60 Hz a
velocity threshold sees a saccade in one or two samples and cannot tell it
from noise; a dispersion test can, at every rate).  A sample farther than
that from the mean is held back: when held-back samples keep within the
radius of each other for :data:`SETTLE_S`, a new fixation begins at the first
of them (the eye moved and landed; one sample far from them is a spike unless
the next one joins it); held-back samples followed by one back
near the mean were a spike and are dropped, and a fixation shorter than four
times that after which the gaze lands back on the one before was an
excursion (a binocular tracker switching eyes, a burst of noise): the
earlier fixation goes on.  Samples moving fast (a saccade)
never keep within the radius of each other, so they start no fixation.  Lost
samples (NaN, blinks) neither end nor extend a fixation.

Decision.  A fixation's place is the mean of its samples.  The person meant
option *i* with a likelihood from a 2-D normal error around the option's
centre: the tracker's error (``sigma_gaze_deg``: accuracy and precision of
the error model combined, degrees) and where within the option people look
(:data:`OBJECT_SPREAD` of its size), per axis, in degrees at that place
(:func:`eye_bci_ros2.projection.visual_angle.px_per_degree_at`).  With a uniform prior
the posterior of the nearest option must reach ``confidence`` and the place
must lie within :data:`MAX_SIGMAS` of it (farther, the person looks at
something else).  A fixation decides once it has lasted ``dwell_s`` (sample
time from its first to its last sample) and holds ``min_samples`` samples:
long enough for the corrective saccade that follows most transient landings.

Fresh fixations only.  A fixation is a reaction to the options when it began
at least ``min_reaction_s`` after they appeared on the screen where they are
(the round's start, or, for a question about options already shown unmoved,
since when they have been: ``shown_since``) and after they last moved.  One
that began earlier (a gaze resting there when they appeared), and a later one
within :data:`REST_RADIUS_DEG` of such a resting place before the gaze has
left it (a fixation farther away), is not, and never chooses, early or at the
window end: a gaze resting near an option (looking at something else)
measures inside it as often as the tracker's error reaches across its edge,
so a choice needs the eye to move to the option.  The round ends without a
choice, with that reason, and the menu asks again.  A question asked about
options that have been on the screen for a while (the menu asks when the
camera has arrived; it asks again after a round without a choice) takes a
fixation on one as a reaction to them: a person looks at what they want
before they are asked.

Urgent options (``urgent``: the robot's 'stop').  Resting never chooses
because a choice must not come from a gaze that was already there; but an
option whose choice only ever makes things safer must not wait for the gaze
to look away and back.  While one is offered, a resting fixation on it
chooses as a fresh one does: once it has lasted ``dwell_s`` within the round
(its samples from the round start), so a gaze resting on 'stop' when it is
offered stops the robot as fast as a gaze that lands on it.  Only the urgent
options: a resting fixation on any other option still chooses nothing.

Second looks (``second_look``: the menu's 'go' and 'send').  An option the
menu places where the gaze was not, offered as the confirmation of a choice
just made, is chosen by a new saccade onto a target that just appeared
elsewhere: that saccade is itself evidence of intent, so a fresh fixation on
one decides after ``second_look_dwell_s`` instead of ``dwell_s`` (fresh
only: a resting gaze still never chooses it; the other options keep
``dwell_s``).  The price in choices of an idle gaze is measured with the
menu's: ``python -m bench.confirmation --midas`` (docs/selection.md).

Still fixations only.  An eye following a moving thing (smooth pursuit) drags
a dispersion window along; a fixation decides only while the means of the
first and second halves of its last ``dwell_s`` lie within
:data:`STILL_DEG` of each other plus :data:`STILL_SIGMAS` standard errors of
that distance from the samples' own scatter (pursuit moves at 5-30 deg/s,
fixational drift well under 1 deg/s; a noisy 60 Hz tracker cannot tell slow
pursuit from a fixation within a dwell, a quiet fast one can).

The rule's figures on real and simulated gaze come from
``python -m bench.real_gaze`` (docs/selection.md).
"""

import bisect
import math
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np

from eye_bci_ros2.decision.evidence import checked_batch, clip01, Decision, options_moved
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.projection.visual_angle import px_per_degree_at, ScreenGeometry

#: Samples within this of a fixation's mean belong to it, degrees: above the noise of
#: remote trackers (0.2-0.5 deg RMS) and their drift within a fixation (about 0.4 deg),
#: below the smallest corrective saccade that moves the gaze to another option.
FIXATION_RADIUS_DEG = 1.0

#: Held-back samples that keep together this long start a new fixation, s: a landing,
#: not a spike (one or two samples) nor a saccade in flight (it leaves the radius in
#: ~10 ms).  It costs no time: the new fixation's time counts from its first sample.
SETTLE_S = 0.04

#: A fixation within this of where the gaze rested at the round start is still the
#: resting gaze, degrees: re-fixations and drift corrections around a point are mostly
#: under 2 deg (the smallest pitch of options a consumer tracker can tell apart is larger).
REST_RADIUS_DEG = 2.0

#: A fixation whose last dwell_s moved more than this (between its halves' means) is an
#: eye in pursuit, degrees (module doc).
STILL_DEG = 0.5

#: ... beyond what the samples' own noise explains, in standard errors.
STILL_SIGMAS = 2.0

#: Spread of where a person looks within an option, per axis, as a share of its size
#: (a uniform spread over a square is 0.29; people look nearer the centre).
OBJECT_SPREAD = 0.25

#: A fixation farther than this many standard deviations from every option looks at
#: something else (99 % of the fixations on an option lie within 3 sigma).
MAX_SIGMAS = 3.0


class _Fixation:
    """
    A fixation under way: first and last stamp, running sums of its points, count.

    Python floats, not numpy: it takes a 1200 Hz tracker's samples one at a time
    where a run of them cannot be taken at once (:meth:`FixationEvidence._join_run`),
    and a numpy operation on two numbers costs more than the arithmetic.
    """

    __slots__ = ('first', 'last', 'count', 'fresh', 'stamps', 'sums_x', 'sums_y', 'squares')

    def __init__(self, samples: List[Tuple[float, np.ndarray]], fresh: bool):
        self.first, self.last = samples[0][0], samples[0][0]
        self.count = 0
        self.fresh = fresh
        # Stamps and running sums of its points (the stillness test over its last dwell_s).
        self.stamps: List[float] = []
        self.sums_x: List[float] = []
        self.sums_y: List[float] = []
        self.squares: List[float] = []
        for stamp, point in samples:
            self.add(stamp, float(point[0]), float(point[1]))

    def add(self, stamp: float, x: float, y: float) -> None:
        """Take one more sample: stamp s, point (x, y) px."""
        self.count += 1
        self.last = stamp
        self.stamps.append(stamp)
        started = bool(self.sums_x)
        self.sums_x.append(x + (self.sums_x[-1] if started else 0.0))
        self.sums_y.append(y + (self.sums_y[-1] if started else 0.0))
        self.squares.append(x * x + y * y + (self.squares[-1] if started else 0.0))

    def extend(self, stamps: List[float], sums: np.ndarray) -> None:
        """
        Take more samples at once: their stamps (M,) s and running sums (3, M).

        The sums continue :attr:`sums_x`, :attr:`sums_y` and :attr:`squares` (rows in that
        order), added as :meth:`add` adds them.
        """
        self.count += len(stamps)
        self.last = stamps[-1]
        self.stamps.extend(stamps)
        for column, values in zip((self.sums_x, self.sums_y, self.squares), sums.tolist()):
            column.extend(values)

    def movement(self, span: float) -> Tuple[float, float]:
        """
        How far its last ``span`` s moved, and what noise alone would give, px.

        :returns: the distance between the means of the two halves of the
            span, and the standard error of that distance from the samples'
            own scatter about their mean (per axis).
        """
        stamps = self.stamps
        first = bisect.bisect_left(stamps, self.last - span)
        middle = bisect.bisect_left(stamps, self.last - span / 2)
        last = len(stamps) - 1
        if not first < middle <= last:
            return 0.0, 0.0
        sums_x, sums_y = self.sums_x, self.sums_y
        before_x = sums_x[first - 1] if first else 0.0
        before_y = sums_y[first - 1] if first else 0.0
        older, newer = middle - first, last - middle + 1
        moved_x = ((sums_x[last] - sums_x[middle - 1]) / newer
                   - (sums_x[middle - 1] - before_x) / older)
        moved_y = ((sums_y[last] - sums_y[middle - 1]) / newer
                   - (sums_y[middle - 1] - before_y) / older)
        count = last - first + 1
        mean_x, mean_y = (sums_x[last] - before_x) / count, (sums_y[last] - before_y) / count
        squares = self.squares[last] - (self.squares[first - 1] if first else 0.0)
        scatter = max(squares / count - (mean_x * mean_x + mean_y * mean_y), 0.0) / 2.0  # px^2
        error = math.sqrt(scatter * (1.0 / older + 1.0 / newer))
        return math.hypot(moved_x, moved_y), error

    @property
    def centre_xy(self) -> Tuple[float, float]:
        """Mean of its samples, (x, y) px."""
        return self.sums_x[-1] / self.count, self.sums_y[-1] / self.count

    @property
    def centre(self) -> np.ndarray:
        """Mean of its samples, px (2,)."""
        return np.array(self.centre_xy)

    @property
    def duration(self) -> float:
        """Sample time it spans, s."""
        return self.last - self.first


class FixationEvidence:
    """
    The evidence of one round under the fixation rule (module doc).

    Same interface as :class:`eye_bci_ros2.decision.evidence.RoundEvidence` where
    :class:`eye_bci_ros2.decision.rounds.RoundScheduler` and
    :func:`eye_bci_ros2.experiments.trials.decide_trial` use it: :meth:`add`
    (samples in time order, early decision), :meth:`decide` (window end),
    :meth:`progress` (feedback), :meth:`configure`.

    :param start: round start, s (the clock of the stamps).
    :param screen: the person's screen (degrees <-> px).
    :param sigma_gaze_deg: the tracker's error per axis, degrees (> 0).
    :param dwell_s: a fixation decides once it spans this, s (>= 0).
    :param min_samples: ... and holds this many samples (>= 1).
    :param min_reaction_s: fixations starting earlier after the start (or
        after the options moved) are not fresh, s (>= 0).
    :param shown_since: since when the options shown at the start have been on
        the screen unmoved, s (None: ``start``): a question asked about options
        long shown takes a fixation on one as a reaction to them (module doc).
    :param confidence: posterior a choice needs, in (0.5, 1).
    :param classifier: maps a region set to the one whose outlines count
        (module doc: only the outline test of a resting fixation uses it);
        None: the set as given.
    :param urgent: labels a resting gaze chooses too (module doc, "Urgent options").
    """

    def __init__(self, start: float, screen: ScreenGeometry, sigma_gaze_deg: float,
                 dwell_s: float, min_samples: int = 1, min_reaction_s: float = 0.1,
                 shown_since: Optional[float] = None,
                 confidence: float = 0.95,
                 classifier: Optional[Callable[[RegionSet], RegionSet]] = None,
                 urgent: Tuple[str, ...] = (), second_look: Tuple[str, ...] = (),
                 second_look_dwell_s: Optional[float] = None):
        """Start an empty round."""
        if not sigma_gaze_deg > 0:
            raise ValueError(f'the gaze error must be > 0 deg, got {sigma_gaze_deg}')
        self.start = float(start)
        shown_since = self.start if shown_since is None else float(shown_since)
        self.shown_since = min(shown_since, self.start)
        self.screen = screen
        self.sigma_gaze_deg = float(sigma_gaze_deg)
        self.dwell_s = float(dwell_s)
        self.min_samples = max(int(min_samples), 1)
        self.min_reaction_s = float(min_reaction_s)
        self.confidence = float(confidence)
        self._classifier = classifier
        self.urgent = frozenset(label for label in urgent if label)
        self.second_look = frozenset(label for label in second_look if label)
        self.second_look_dwell_s = self.dwell_s if second_look_dwell_s is None else float(
            second_look_dwell_s)
        # Whether a second-look option is offered now: its dwell may be the shorter one.
        self._second_shown = False
        # Whether an urgent option is offered now: a resting fixation may decide then.
        self._urgent_shown = False
        centre_scale = float(px_per_degree_at(screen.centre_px.reshape(1, 2), screen)[0])
        self._radius_px = FIXATION_RADIUS_DEG * centre_scale
        self._still_px = STILL_DEG * centre_scale
        self._rest_px = REST_RADIUS_DEG * centre_scale
        self.labels: List[str] = []
        self.samples = 0
        self.valid = 0
        self.last_stamp = math.nan
        self.decision: Optional[Decision] = None
        self._counts: Dict[str, int] = {}
        self._current: Optional[_Fixation] = None
        self._held: List[Tuple[float, np.ndarray]] = []
        # A held-back sample far from the others: a spike if the next one does not join it.
        self._stray: Optional[Tuple[float, np.ndarray]] = None
        self._done: List[Tuple[_Fixation, RegionSet]] = []
        self._rest: Optional[np.ndarray] = None
        self._latest: Optional[RegionSet] = None
        self._moved_at = -math.inf
        self._classified: Dict[int, RegionSet] = {}
        self._options: Dict[int, tuple] = {}
        # The newest test of the current fixation per asker ('decision', 'feedback'):
        # (fixation, region set, its centre then, the result), not repeated while neither
        # moved.  Apart, so the feedback's timing never changes what the decision sees.
        self._judged: Dict[str, tuple] = {}

    # -- the interface of a round's evidence ------------------------------------------------

    def configure(self, settings) -> None:
        """Take the timing settings of an :class:`ArbiterSettings` from the next sample on."""
        self.dwell_s = float(settings.dwell_s)
        self.second_look_dwell_s = float(settings.second_look_dwell_s)
        self.min_samples = max(int(settings.min_samples), 1)
        self.min_reaction_s = float(settings.min_reaction_s)
        self.confidence = float(settings.confidence)

    @property
    def fresh_from(self) -> float:
        """Fixations starting before this stamp are not fresh (module doc), s."""
        return max(self.shown_since, self._moved_at) + self.min_reaction_s

    @property
    def elapsed(self) -> float:
        """Sample time since the round start, s (0 before any sample)."""
        return max(self.last_stamp - self.start, 0.0) if math.isfinite(self.last_stamp) else 0.0

    @property
    def counts(self) -> Dict[str, int]:
        """Count the samples of the round's settled fixations per label they pointed to."""
        return dict(self._counts)

    def regions_for(self, region_set: RegionSet) -> RegionSet:
        """Return ``region_set`` under the classifier (once per set)."""
        if self._classifier is None:
            return region_set
        key = id(region_set)
        if key not in self._classified:
            self._classified[key] = self._classifier(region_set)
        return self._classified[key]

    def add(self, points, stamps, region_set: RegionSet,
            confidence: Optional[float] = None) -> Optional[Decision]:
        """
        Take samples shown with ``region_set``, in time order.

        :param points: (N, 2) screen px (NaN: lost).
        :param stamps: (N,) s, non-decreasing and after earlier batches.
        :param region_set: the options shown at these samples' time.
        :param confidence: given (in (0.5, 1)): decide at the first sample
            where a fresh fixation passes (module doc) and return that.
        :returns: the early decision once made (then nothing more is added).
        """
        if self.decision is not None:
            return self.decision
        points, stamps = checked_batch(points, stamps, confidence)
        if self._latest is None or region_set.stamp >= self._latest.stamp:
            if self._latest is not None and options_moved(self._latest, region_set):
                self._moved_at = max(self._moved_at, region_set.stamp)
            self._latest = region_set
            self._urgent_shown = bool(self.urgent) and not self.urgent.isdisjoint(
                region_set.labels)
            self._second_shown = bool(self.second_look) and not self.second_look.isdisjoint(
                region_set.labels)
        for label in region_set.labels:
            if label not in self._counts:
                self._counts[label] = 0
                self.labels.append(label)
        finite = np.isfinite(points).all(axis=1)
        self.samples += len(points)
        self.valid += int(np.count_nonzero(finite))
        if len(stamps):
            self.last_stamp = float(stamps[-1])
        # Python floats: the samples are taken one at a time (see _Fixation), but for runs
        # that join the current fixation before it can decide (_join_run).
        all_x, all_y, all_stamps = points[:, 0].tolist(), points[:, 1].tolist(), stamps.tolist()
        indices = np.flatnonzero(finite).tolist()
        # The valid samples as arrays (views when all are valid), for _join_run.
        valid = ((points, stamps) if len(indices) == len(points)
                 else (points[finite], stamps[finite]))
        position = 0
        while position < len(indices):
            joined = self._join_run(*valid, position, confidence)
            if joined:
                position += joined
                continue
            index = indices[position]
            position += 1
            stamp = all_stamps[index]
            if not self._take(stamp, all_x[index], all_y[index], region_set):
                continue
            current = self._current
            if confidence is None or not self._may_decide(current) \
                    or not self._settled(current, self._first_dwell):
                continue
            label, posterior, margin = self._judge_current(current, region_set, 'decision')
            if label is not None and posterior >= confidence and (
                    current.fresh or label in self.urgent) and (
                    self._dwell_for(label) <= self._first_dwell
                    or self._settled(current, self._dwell_for(label))):
                self.last_stamp = stamp
                # As one at a time: the samples after the deciding one are not taken.
                self.samples -= len(points) - index - 1
                self.valid -= int(np.count_nonzero(finite[index + 1:]))
                self.decision = self._decision(label, 'early', current, posterior, margin)
                return self.decision
        return None

    def _join_run(self, points: np.ndarray, stamps: np.ndarray, position: int,
                  confidence: Optional[float]) -> int:
        """
        Add at once the valid samples from ``position`` on that join the current fixation.

        What one sample at a time would do, in the same floating-point operations (the
        running sums are sequential: ``np.cumsum``), for the run of samples that each lie
        within the radius of the fixation's centre so far and after which it cannot yet
        decide (:meth:`_settled`'s span and count); a distance within a rounding error of
        the radius is left to :meth:`_take` (``np.hypot`` and ``math.hypot`` may differ in
        the last bit).  The first sample is tested in Python first: a saccade's samples go
        one by one without numpy work.

        :param points: the batch's valid samples (M, 2) px, in time order.
        :param stamps: their stamps (M,) s.
        :returns: how many samples it added (0: none; :meth:`_take` takes the next).
        """
        current = self._current
        if current is None or len(stamps) - position < 2:
            return 0
        x, y = float(points[position, 0]), float(points[position, 1])
        centre_x, centre_y = current.centre_xy
        limit = self._radius_px - 1e-9 * max(self._radius_px, 1.0)
        if math.hypot(x - centre_x, y - centre_y) > limit:
            return 0
        run = len(stamps) - position
        if confidence is not None and self._may_decide(current):
            # Stamps rise: the samples after which it cannot settle yet are a prefix (by
            # span), or as many as min_samples still needs.
            before_dwell = int(np.count_nonzero(
                stamps[position:] - current.first < self._first_dwell - 1e-6))
            run = min(run, max(before_dwell, self.min_samples - current.count - 1))
            if run < 1:
                return 0
        xs, ys = points[position:position + run, 0], points[position:position + run, 1]
        sums = np.empty((3, run + 1))
        sums[:, 0] = current.sums_x[-1], current.sums_y[-1], current.squares[-1]
        sums[0, 1:], sums[1, 1:] = xs, ys
        sums[2, 1:] = xs * xs + ys * ys
        np.cumsum(sums, axis=1, out=sums)
        counts = np.arange(current.count, current.count + run)
        joins = np.hypot(xs - sums[0, :-1] / counts, ys - sums[1, :-1] / counts) <= limit
        count = run if joins.all() else int(np.argmin(joins))
        if not count:
            return 0
        current.extend(stamps[position:position + count].tolist(), sums[:, 1:count + 1])
        self._joined()
        return count

    def _joined(self) -> None:
        """Note that a sample joined the current fixation: what was held back was a spike."""
        if self._held:
            self._held.clear()
        self._stray = None

    def next_due(self) -> Optional[float]:
        """
        Return the stamp at which the current fixation can first decide early, s, or None.

        Its first sample + ``dwell_s``, while it is fresh and nothing is decided: the
        choice_arbiter announces it (``choice/due``) so that the gaze of that moment is
        pulled promptly.
        """
        current = self._current
        if self.decision is not None or current is None or not self._may_decide(current):
            return None
        return current.first + self._first_dwell

    @property
    def _first_dwell(self) -> float:
        """Return the shortest dwell an option offered now needs, s ("Second looks")."""
        if self._second_shown:
            return min(self.dwell_s, self.second_look_dwell_s)
        return self.dwell_s

    def _dwell_for(self, label: str) -> float:
        """Return the dwell a fixation on this option needs, s."""
        return self.second_look_dwell_s if label in self.second_look else self.dwell_s

    def _may_decide(self, fixation: _Fixation) -> bool:
        """Whether a fixation may choose: fresh, or any while an urgent option is offered."""
        return fixation.fresh or self._urgent_shown

    def early(self, confidence: float) -> Optional[Decision]:
        """Return the early decision if made (samples are tested as they arrive)."""
        return self.decision

    def decide(self, method: str = 'fixation') -> Decision:
        """
        Decide at the window end (or return the early decision).

        The latest fixation that lasted ``dwell_s``, if it is fresh and
        passes the posterior test (module doc).

        :param method: the rule's name, for the decision ('fixation').
        """
        confidence = self.confidence
        if self.decision is not None:
            return self.decision
        candidates = list(self._done)
        if self._current is not None and self._latest is not None:
            candidates.append((self._current, self._latest))
        reason = f'no fixation of {self.dwell_s:g} s' if self.valid else 'no valid gaze sample'
        best = None
        settled = [(fixation, region_set) for fixation, region_set in candidates
                   if self._settled(fixation, self._first_dwell)]
        if settled:
            # Only where the gaze last settled: an earlier fixation the person left is not
            # their answer (the resting gaze they moved away from, a transient landing).
            fixation, region_set = settled[-1]
            label, posterior, margin, inside = self._judge(fixation.centre, region_set)
            where = f'the fixation at ({fixation.centre[0]:.0f}, {fixation.centre[1]:.0f}) px'
            if label is None:
                reason = f'{where} is on no option'
            elif posterior < confidence:
                reason = (f"{where} is not clearly on one option ('{label}' posterior "
                          f'{posterior:.2f})')
            elif not fixation.fresh and label not in self.urgent:
                reason = (f"the gaze rested {'on' if inside else 'near'} '{label}' from the "
                          'round start: look away and back to choose it')
            elif not self._settled(fixation, self._dwell_for(label)):
                reason = f"no fixation of {self._dwell_for(label):g} s on '{label}'"
            else:
                best = (label, fixation, posterior, margin)
        if best is None:
            return self._decision(None, method, self._current, math.nan, 0.0, reason)
        label, fixation, posterior, margin = best
        return self._decision(label, method, fixation, posterior, margin)

    def progress(self, settings=None) -> Dict[str, float]:
        """
        Progress towards each offered label, 0..1 (feedback).

        The current fixation's option: the share of ``dwell_s`` it has lasted
        times how far its posterior has come from chance to ``confidence``.

        :param settings: not needed (the rule's settings are its own).
        """
        confidence = self.confidence
        out = dict.fromkeys(self.labels, 0.0)
        current = self._current
        if current is None or self._latest is None or not self._may_decide(current):
            return out
        # Cached as the early decision's test is: the feedback asks ~30 times a second,
        # and a fixation's centre settles within a few samples.
        label, posterior, _ = self._judge_current(current, self._latest, 'feedback')
        if label is None:
            return out
        chance = 1.0 / max(len(self._latest.label_set), 1)
        belief = 1.0 if confidence <= chance else (posterior - chance) / (confidence - chance)
        dwell = self._dwell_for(label)
        time_part = 1.0 if dwell <= 0 else current.duration / dwell
        out[label] = clip01(belief) * clip01(time_part)
        return out

    # -- events and the spatial test ----------------------------------------------------------

    def _take(self, stamp: float, x: float, y: float, region_set: RegionSet) -> bool:
        """Add one valid sample (stamp s, x, y px); True when it joined the current fixation."""
        current = self._current
        if current is not None:
            centre_x, centre_y = current.centre_xy
            if math.hypot(x - centre_x, y - centre_y) <= self._radius_px:
                current.add(stamp, x, y)
                self._joined()
                return True
        point = np.array([x, y])
        if current is None:
            self._current = self._new_fixation([(stamp, point)])
            return True
        held, sample = self._held, (stamp, point)
        if not held or math.hypot(*(point - held[0][1])) <= self._radius_px:
            held.append(sample)
            self._stray = None
        elif self._stray is not None and math.hypot(*(point - self._stray[1])) <= self._radius_px:
            held[:] = [self._stray, sample]     # the eye moved on: a new landing
            self._stray = None
        else:
            self._stray = sample                # a spike, or a saccade in flight: wait
            return False
        if held[-1][0] - held[0][0] < SETTLE_S:
            return False
        landing = np.mean([p for _, p in held], axis=0)
        previous = self._done[-1][0] if self._done else None
        if (previous is not None and current.duration < SETTLE_S * 4
                and math.hypot(*(landing - previous.centre)) <= self._radius_px):
            # Back where the gaze was before a short excursion (a tracker switching eyes,
            # a burst of noise): the earlier fixation goes on, the excursion is dropped.
            self._done.pop()
            for held_stamp, held_point in held:
                previous.add(held_stamp, float(held_point[0]), float(held_point[1]))
            self._current = previous
        else:
            if self._latest is not None:
                self._done.append((current, self._latest))
                del self._done[:-64]   # the window-end rule looks back a few fixations
            self._current = self._new_fixation(list(held))
        held.clear()
        self._stray = None
        return True

    def _new_fixation(self, samples: List[Tuple[float, np.ndarray]]) -> _Fixation:
        """Make a fixation of these samples; fresh unless it is a resting gaze (module doc)."""
        fixation = _Fixation(samples, fresh=samples[0][0] >= self.fresh_from)
        if not fixation.fresh:
            self._rest = fixation.centre if self._rest is None else self._rest
        elif self._rest is not None:
            if math.hypot(*(fixation.centre - self._rest)) <= self._rest_px:
                fixation.fresh = False
            else:
                self._rest = None     # the gaze left its resting place: it reacts from now on
        return fixation

    def _settled(self, fixation: _Fixation, dwell: Optional[float] = None) -> bool:
        """Whether a fixation lasted ``dwell`` (dwell_s) with min_samples and held still."""
        dwell = self.dwell_s if dwell is None else dwell
        if fixation.duration < dwell - 1e-6 or fixation.count < self.min_samples:
            return False
        moved, noise = fixation.movement(dwell)
        return moved <= self._still_px + STILL_SIGMAS * noise

    def _judge_current(self, current: _Fixation, region_set: RegionSet, asker: str
                       ) -> Tuple[Optional[str], float, float]:
        """
        Judge the current fixation, again only when it or the options moved (0.5 px).

        :param asker: whose cached test: 'decision' or 'feedback' (kept apart).
        """
        centre = current.centre_xy
        cached = self._judged.get(asker)
        if (cached is not None and cached[0] is current and cached[1] is region_set
                and abs(cached[2][0] - centre[0]) + abs(cached[2][1] - centre[1]) < 0.5):
            return cached[3]
        label, posterior, margin, _ = self._judge(np.array(centre), region_set)
        self._judged[asker] = (current, region_set, centre, (label, posterior, margin))
        return label, posterior, margin

    def _option_geometry(self, region_set: RegionSet) -> tuple:
        """
        Return what :meth:`_judge` needs of a set's options (once per set).

        :returns: centres (R, 2) px, sizes (R,) px, usable (R,) bool (finite centre),
            the labels (R,) array, and the usable regions' labels in order when no label
            is shown twice (else None: their likelihoods are pooled per label).
        """
        key = id(region_set)
        if key not in self._options:
            polygons = region_set.polygons
            centres = region_set.centroids
            x, y = polygons[..., 0], polygons[..., 1]
            area = 0.5 * np.abs(np.nansum(x * np.roll(y, -1, axis=1)
                                          - np.roll(x, -1, axis=1) * y, axis=1))
            usable = np.isfinite(centres).all(axis=1)
            labels = [region_set.labels[index] for index in np.flatnonzero(usable)]
            distinct = labels if len(set(labels)) == len(labels) else None
            self._options[key] = (region_set, centres, np.sqrt(area), usable,
                                  np.array(region_set.labels), distinct)
        return self._options[key][1:]

    def _judge(self, centre: np.ndarray, region_set: RegionSet
               ) -> Tuple[Optional[str], float, float, bool]:
        """
        Test a fixation's place against the options (module doc).

        :returns: the label it points to (None: none within :data:`MAX_SIGMAS`
            or nothing offered), that label's posterior, its margin over the
            runner-up, and whether the place is inside that option's outline
            (under the classifier).
        """
        if not len(region_set):
            return None, 0.0, 0.0, False
        centres, sizes, usable, label_array, distinct = self._option_geometry(region_set)
        if not usable.any():
            return None, 0.0, 0.0, False
        scale = float(px_per_degree_at(centre.reshape(1, 2), self.screen)[0])
        distance = np.hypot(*(centres - centre).T) / scale
        sigma = np.sqrt(self.sigma_gaze_deg ** 2 + (OBJECT_SPREAD * sizes / scale) ** 2)
        sigmas = distance / sigma
        log_like = np.where(usable, -0.5 * sigmas ** 2 - 2.0 * np.log(sigma), -np.inf)
        if distinct is not None:
            names, values = distinct, log_like[usable]
        else:
            # Regions with one label pool their likelihood (a label shown twice is one
            # option); each label's first term is its own (logaddexp with -inf: exact).
            labels = region_set.labels
            per_label: Dict[str, float] = {}
            for index in np.flatnonzero(usable):
                per_label[labels[index]] = np.logaddexp(per_label.get(labels[index], -np.inf),
                                                        log_like[index])
            names = list(per_label)
            values = np.array([per_label[name] for name in names])
        posterior = np.exp(values - values.max())
        posterior /= posterior.sum()
        order = np.argsort(posterior)[::-1]
        leader = names[order[0]]
        margin = float(posterior[order[0]] - (posterior[order[1]] if len(order) > 1 else 0.0))
        nearest = int(np.argmin(np.where(usable & (label_array == leader), sigmas, np.inf)))
        if sigmas[nearest] > MAX_SIGMAS:
            return None, float(posterior[order[0]]), margin, False
        outlines = self.regions_for(region_set)
        hit = outlines.classify_one(float(centre[0]), float(centre[1]))
        inside = hit >= 0 and outlines.labels[hit] == leader
        return leader, float(posterior[order[0]]), margin, bool(inside)

    def _decision(self, label: Optional[str], method: str, fixation: Optional[_Fixation],
                  posterior: float, margin: float, reason: str = '') -> Decision:
        """Build a Decision (counts: samples of the settled fixations per label)."""
        used = fixation.count if fixation is not None else 0
        mean_point = None if fixation is None else tuple(float(v) for v in fixation.centre)
        if label is not None:
            self._counts[label] = self._counts.get(label, 0) + used
        elapsed = (self.last_stamp - self.start) if math.isfinite(self.last_stamp) else math.nan
        return Decision(label, method, self.samples, used, margin, posterior,
                        time_to_decision=elapsed, counts=dict(self._counts),
                        mean_point=mean_point, reason=reason,
                        fresh_samples=used if fixation is not None and fixation.fresh else 0,
                        round_start=self.start,
                        weighed_stamps=() if fixation is None else tuple(fixation.stamps))
