"""
Rounds of choices on a live stream of gaze samples and region sets: pure numpy.

:class:`RoundScheduler` is the choice_arbiter node's logic without ROS: when
rounds start and end, which samples and which regions each round weighs, and
when its decision is final.  The evidence and the rules are in
:mod:`eye_bci_ros2.decision.evidence`, the regions in :mod:`eye_bci_ros2.decision.regions`.
"""

import bisect
from collections import deque
import dataclasses
from dataclasses import dataclass, fields
import math
from typing import Callable, Deque, Dict, List, NamedTuple, Optional, Tuple

import numpy as np

from eye_bci_ros2.base.settings import check_settings, flagged, Setting
from eye_bci_ros2.base.validators import Interval
from eye_bci_ros2.decision.evidence import (CONFIDENCE, Decision, DWELL_S, HIT_RATE,
                                            METHODS as COUNT_METHODS, MIN_REACTION, MIN_SAMPLES,
                                            MIN_SHARE, options_moved, RoundEvidence)
from eye_bci_ros2.decision.fixation import FixationEvidence
from eye_bci_ros2.decision.regions import points_array, RegionSet
from eye_bci_ros2.decision.tolerance import (CLASSIFICATIONS, DEFAULT_RATIO, GazeErrorModel,
                                             TolerantRegions)
from eye_bci_ros2.projection.visual_angle import (SCREEN_HEIGHT, SCREEN_HEIGHT_MM, SCREEN_WIDTH,
                                                  SCREEN_WIDTH_MM, ScreenGeometry,
                                                  VIEWING_DISTANCE)

#: Default bound on how far after its arrival a gaze sample may be stamped, s.
DEFAULT_MAX_FUTURE_S = 1.0

#: Largest accepted ``max_future_s``, s.
MAX_FUTURE_S = 60.0

#: A round holding this many samples closes at once (bounds memory on a runaway stream).
MAX_ROUND_SAMPLES = 1 << 21
#: A batch out of stamp order rebuilds a round holding at least this many samples once
#: the batches stop coming (no batch for LAZY_QUIET_S at a tick), not at once: a backlog
#: that arrives in many batches (a stalled sender's burst, max_chunk samples each) then
#: costs one rebuild, not one per batch.  Ordinary rounds (2 s of a 2000 Hz tracker) stay
#: below it and are rebuilt at once.
LAZY_REBUILD_SAMPLES = 4096
LAZY_QUIET_S = 0.01
#: While such a backlog is still arriving the stream has not stalled: the stall timeout
#: waits for it, at most this much longer, s.
BACKLOG_LIMIT_S = 10.0

#: Recent samples kept for a round that starts at a stamp in the past, at most.
MAX_RECENT_SAMPLES = 1 << 17

#: Extra time recent samples are kept beyond ``window_s``, s.
RECENT_MARGIN_S = 0.5

#: The fixation rule's dwell on an option that appeared where the gaze was not, s
#: (``second_look_dwell_s``): the landing has settled (SETTLE_S, 0.04 s, and a sample) and,
#: with the two options 6 deg or more apart, a transient landing short of or beyond the
#: target is still nearer it than the other.  On real gaze the most intended 'go' within
#: 1.5 s with the Midas bound kept under 0.0017 per minute; chosen so leave-one-person-out:
#: 97.6 % within 1.5 s (docs/selection.md, "Looking around without intent").
SECOND_LOOK_DWELL_S = 0.05

_EMPTY_REGIONS = RegionSet([], np.zeros((0, 3, 2)))

_DEFAULT_MODEL = GazeErrorModel()


def _fixation_evidence(settings: 'ArbiterSettings', start: float,
                       shown_since: Optional[float]) -> FixationEvidence:
    """Make the fixation rule's evidence of a round (:mod:`eye_bci_ros2.decision.fixation`)."""
    return FixationEvidence(start, settings.screen, settings.sigma_gaze_deg,
                            shown_since=shown_since,
                            dwell_s=settings.dwell_s, min_samples=settings.min_samples,
                            min_reaction_s=settings.min_reaction_s,
                            confidence=settings.confidence, classifier=settings.regions,
                            urgent=(settings.urgent_label,),
                            second_look=tuple(settings.second_look_labels.split()),
                            second_look_dwell_s=settings.second_look_dwell_s)


def _count_evidence(settings: 'ArbiterSettings', start: float,
                    shown_since: Optional[float]) -> RoundEvidence:
    """Make the count rules' evidence of a round (:mod:`~eye_bci_ros2.decision.evidence`)."""
    return RoundEvidence(start, hit_rate=settings.hit_rate, min_samples=settings.min_samples,
                         dwell_s=settings.dwell_s, min_reaction_s=settings.min_reaction_s,
                         min_share=settings.min_share, classifier=settings.regions,
                         screen_px=(settings.screen_width, settings.screen_height))


#: The decision rules, the one place they are registered: ``method`` -> the evidence a round
#: of it keeps (:meth:`ArbiterSettings.evidence`).  Each evidence takes samples in time order
#: (``add``, with the early decision), decides at the window end (``decide``), reports
#: progress for the feedback (``progress``) and takes new timing settings (``configure``).
#: The fixation rule is the default; 'mean' is the original report's.
RULE_EVIDENCE: Dict[str, Callable[['ArbiterSettings', float, Optional[float]], object]] = {
    'fixation': _fixation_evidence,
    **{method: _count_evidence for method in COUNT_METHODS},
}

#: The names of the decision rules (the ``method`` parameter's choices).
METHODS = tuple(RULE_EVIDENCE)

#: The settings that make the original rule (docs/DESIGN.md, "The mathematics"): samples count
#: only inside an option, no share test; with ``method`` 'mean' (and no early decision)
#: every decision is the original report's.
ORIGINAL_RULE = {'classification': 'inside', 'min_share': 0.0}

#: The tolerant sample-count rule as the node ran it before the fixation rule became the
#: default (window-end mean with the share test; its early decision, when switched on,
#: needed a 0.95 posterior and a 20 ms run): ``ArbiterSettings(**COUNT_RULE)``.
COUNT_RULE = {'method': 'mean', 'early_decision': False, 'confidence': 0.95, 'dwell_s': 0.02}


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
        self.extend(np.array([stamp]), np.array([[x, y]]))

    def extend(self, stamps: np.ndarray, points: np.ndarray) -> None:
        """Log samples: stamps (N,) s, points (N, 2) px, in arrival order."""
        count = len(stamps)
        if not count:
            return
        if self._size + count > len(self._stamps):
            grow = max(self._size, count)
            self._stamps = np.concatenate([self._stamps, np.empty(grow)])
            self._points = np.concatenate([self._points, np.empty((grow, 2))])
        end = self._size + count
        self._stamps[self._size:end] = stamps
        self._points[self._size:end] = points
        self._size = end
        newest = float(stamps.max())
        if self._sorted and (stamps[0] < self.max_stamp
                             or (count > 1 and np.any(np.diff(stamps) < 0))):
            self._sorted = False
        self.max_stamp = max(self.max_stamp, newest)

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
    Settings of a :class:`RoundScheduler` (the choice_arbiter's parameters).

    Each field is declared once (:class:`eye_bci_ros2.base.settings.Setting`: default,
    range, unit, meaning); the choice_arbiter declares its parameters from them
    and docs/parameters.md lists them.  Fields declared with ``rule=True`` make
    up a round's rule (:data:`RULE_FIELDS`: a change applies from the next
    round on; :data:`ORIGINAL_RULE` restores the original).  The decision rule
    ``method`` is one of :data:`METHODS`: 'fixation' (default: the option a
    settled fixation clearly lands on, :mod:`eye_bci_ros2.decision.fixation`), 'mean'
    (the original) or 'vote' (sample counts, :mod:`eye_bci_ros2.decision.evidence`).
    The classification 'tolerant' (default: inside, or near it by the
    gaze-error model when clearly nearer to it than to any other,
    :mod:`eye_bci_ros2.decision.tolerance`) or 'inside' (the original) applies to every
    sample and to the window-end mean, early and window-end decisions alike.
    ``max_future_s`` bounds how far after its arrival a sample may be stamped:
    acquisition cannot follow arrival, so only a clock offset or a corrupt
    stamp does that, and one such sample must not end a round
    (:class:`RoundScheduler`).

    Defaults: :class:`eye_bci_ros2.decision.tolerance.GazeErrorModel` and
    :data:`eye_bci_ros2.projection.visual_angle.DEFAULT_VIEWING` (a 24-inch 16:9
    screen at 650 mm), the size-aware tolerant rule with the share test:
    ``bench/tolerance.py``'s ``size_mean/s``.
    """

    method: str = Setting(
        'fixation',
        'Decision rule: fixation = the option a still fixation of dwell_s clearly '
        'lands on (posterior from the gaze-error model, fresh fixations only; holds on '
        'real gaze: docs/selection.md); mean = the original rule (mean of the in-region '
        'samples must lie in a region); vote = region with most samples',
        choices=METHODS).field()
    window_s: float = Setting(
        1.0, 'Gaze collection time of a round, s of sample stamps from the round start',
        interval=Interval(0.0, 60.0, low_open=True), unit='s').field()
    early_decision: bool = Setting(
        True, 'Decide before the window ends, as soon as the evidence for one option reaches '
        'confidence (fixation: a fresh still fixation of dwell_s on it; mean/vote: '
        'fresh in-region samples, min_samples / dwell_s / min_reaction_s); else at '
        'the window end').field()
    # Early-decision defaults: the configuration bench/decision.py selects on its
    # tuning persons (90 Hz and 1200 Hz trackers, gaze off the menu or on another target).
    confidence: float = CONFIDENCE.field()
    min_samples: int = MIN_SAMPLES.field()
    dwell_s: float = DWELL_S.field()
    min_reaction_s: float = MIN_REACTION.field()
    hit_rate: float = HIT_RATE.field()
    reorder_s: float = Setting(
        0.0, 'Longest time a decision waits for a regions message that may apply to its '
        'last gaze samples (regions lagging gaze while the camera moves), s; 0 = '
        'decide at once (lowest latency); the wait ends as soon as regions stamped '
        'after those samples arrive', interval=Interval(0.0, 2.0), unit='s').field()
    stall_timeout_s: float = Setting(
        0.5, 'When no gaze sample stamped after the window arrives, close the round this '
        'long after the window end (node clock), s', interval=Interval(0.0, 10.0),
        unit='s').field()
    max_future_s: float = Setting(
        DEFAULT_MAX_FUTURE_S,
        'Drop gaze samples stamped more than this after their arrival (node clock), s: '
        'only a corrupt stamp or a wrong clock does that, and one such sample would '
        'end the round at once; raise it only for a tracker clock known to run ahead',
        interval=Interval(0.0, MAX_FUTURE_S), unit='s',
        why='it bounds how far after its arrival a gaze sample may be stamped (about 1 s)'
    ).field()
    # The rule: a change applies from the next round on (RULE_FIELDS).
    classification: str = Setting(
        'tolerant',
        'Which option a gaze sample counts for: tolerant = inside it, or near it (by the '
        'gaze-error model below) when clearly nearer to it than to any other option; '
        'inside = the original rule (inside only). With min_share 0 and method mean, '
        'inside gives the original decisions', choices=CLASSIFICATIONS).field(rule=True)
    accuracy_deg: float = Setting(
        _DEFAULT_MODEL.accuracy_deg,
        "Gaze-error model: the tracker's accuracy for this person, degrees of visual "
        'angle (a validation measures it); with precision_deg the error the fixation '
        'rule and the tolerant classification expect', interval=Interval(0.0, 10.0),
        unit='deg').field(rule=True)
    precision_deg: float = Setting(
        _DEFAULT_MODEL.precision_deg,
        "Gaze-error model: the tracker's precision (sample-to-sample noise per axis), "
        'degrees', interval=Interval(0.0, 10.0), unit='deg').field(rule=True)
    k_sigma: float = Setting(
        _DEFAULT_MODEL.k_sigma,
        'Tolerant rule: tolerance in standard deviations of the radial gaze error '
        '(k_sigma x sqrt(accuracy^2 + 2 precision^2), below 30 deg)',
        interval=Interval(0.0, 10.0)).field(rule=True)
    ratio: float = Setting(
        DEFAULT_RATIO,
        'Tolerant rule: a sample outside every option counts for the nearest only when '
        'it is at most ratio times as far as the second nearest (gaze between two '
        'options counts for neither)', interval=Interval(0.0, 1.0, low_open=True),
        why='the nearest option must be at most ratio times as far as the second'
    ).field(rule=True)
    size_aware: bool = Setting(
        True, "Tolerant rule: count the tolerance from the option's centre (none for options "
        'larger than the gaze error); false = from its edge').field(rule=True)
    min_share: float = MIN_SHARE.field(rule=True)
    urgent_label: str = Setting(
        'stop', "Fixation rule: the option a gaze already resting on it chooses (the menu's "
        "'stop': a stop must not wait for the gaze to look away and back), as fast as a "
        "fresh look; '' = none").field(rule=True)
    second_look_labels: str = Setting(
        'go send', "Fixation rule: options that appear where the gaze was not (the menu's "
        "'go' and 'send'), separated by spaces; a fresh fixation on one chooses after "
        "second_look_dwell_s; '' = none").field(rule=True)
    second_look_dwell_s: float = Setting(
        SECOND_LOOK_DWELL_S, 'Fixation rule: the dwell a fresh fixation on a '
        'second_look_labels option needs (a new saccade onto a target that just appeared '
        'elsewhere is itself evidence), s', interval=Interval(0.0, 10.0),
        unit='s').field(rule=True)
    # The person's screen: one declaration with gaze_validation's.
    screen_width: int = SCREEN_WIDTH.field(rule=True)
    screen_height: int = SCREEN_HEIGHT.field(rule=True)
    screen_width_mm: float = SCREEN_WIDTH_MM.field(rule=True)
    screen_height_mm: float = SCREEN_HEIGHT_MM.field(rule=True)
    viewing_distance_mm: float = VIEWING_DISTANCE.field(rule=True)

    def __post_init__(self):
        """Reject values no round can run with (each field's declaration, then the whole)."""
        check_settings(self)
        # Both raise ValueError with a reason: an error model no tracker has, or no screen.
        self.error_model  # noqa: B018
        self.screen  # noqa: B018

    @property
    def error_model(self) -> GazeErrorModel:
        """Return the gaze-error model of the tolerant rule, degrees."""
        return GazeErrorModel(accuracy_deg=float(self.accuracy_deg),
                              precision_deg=float(self.precision_deg),
                              k_sigma=float(self.k_sigma))

    @property
    def screen(self) -> ScreenGeometry:
        """Return the person's screen and viewing distance."""
        return ScreenGeometry(width_px=self.screen_width, height_px=self.screen_height,
                              width_mm=self.screen_width_mm, height_mm=self.screen_height_mm,
                              distance_mm=self.viewing_distance_mm)

    def describe(self) -> str:
        """Name the rule in one line (logs, the demo's pictures)."""
        if self.method == 'fixation':
            when = 'as soon as one does' if self.early_decision else \
                f'at the end of a {float(self.window_s):g} s window'
            return (f'fixation rule: a still fixation of {float(self.dwell_s):g} s clearly on '
                    f'one option ({self.sigma_gaze_deg:.2f} deg gaze error, confidence '
                    f'{float(self.confidence):g}), {when}')
        if self.classification == 'tolerant':
            where = (f"tolerant ({'size-aware, ' if self.size_aware else ''}"
                     f'{self.error_model.tolerance_deg:.2f} deg gaze error, ratio '
                     f'{float(self.ratio):g})')
        else:
            where = 'inside the outlines'
        share = f', share test {float(self.min_share):g}' if self.min_share > 0 else ''
        early = ', early decision' if self.early_decision else ''
        return (f'gaze counted {where}{share}; {self.method} at the end of a '
                f'{float(self.window_s):g} s window{early}')

    def regions(self, region_set: RegionSet) -> RegionSet:
        """
        Return the classifier a round uses for ``region_set`` (labels, polygons, stamp).

        'tolerant': a :class:`eye_bci_ros2.decision.tolerance.TolerantRegions`; 'inside':
        a plain :class:`RegionSet` (``region_set`` itself when it is one).
        """
        if self.classification == 'inside':
            if type(region_set) is RegionSet:
                return region_set
            return RegionSet(region_set.labels, region_set.polygons, region_set.stamp)
        rule = {'model': self.error_model, 'ratio': float(self.ratio), 'screen': self.screen,
                'size_aware': bool(self.size_aware)}
        return region_set.under(('tolerant',) + tuple(rule.values()),
                                lambda regions: TolerantRegions.of(regions, **rule))

    @property
    def sigma_gaze_deg(self) -> float:
        """Return the gaze error per axis the fixation rule expects, degrees."""
        return math.hypot(float(self.accuracy_deg), float(self.precision_deg))

    def evidence(self, start: float, shown_since: Optional[float] = None):
        """
        Make the empty evidence of the rule ``method`` for a round starting at ``start`` s.

        ``shown_since``: since when the round's options have been on the screen,
        unmoved, s (None: since ``start``); the fixation rule takes a fixation
        from ``min_reaction_s`` after it as a reaction to them.

        A :class:`~eye_bci_ros2.decision.fixation.FixationEvidence` for 'fixation', a
        :class:`~eye_bci_ros2.decision.evidence.RoundEvidence` for the count rules; both
        weigh with the whole rule (every region set given to them classified by
        :meth:`regions`, once per set; the count rules' share test).
        """
        return RULE_EVIDENCE[self.method](self, start, shown_since)

    def replace(self, **changed) -> 'ArbiterSettings':
        """Return a checked copy with ``changed`` fields (unknown names are ignored)."""
        names = {item.name for item in fields(self)}
        return dataclasses.replace(
            self, **{name: value for name, value in changed.items() if name in names})


#: Settings that make up a round's rule (classification, error model, share test, screen:
#: declared with ``rule=True``): a change applies from the next round on
#: (:meth:`RoundScheduler.configure`).
RULE_FIELDS = flagged(ArbiterSettings, 'rule')


class _Round:
    """State of the open round."""

    def __init__(self, start: float, settings: ArbiterSettings, shown_since: float):
        self.start = start
        # Since when the options of the round's start have been shown, unmoved (a question
        # asked about options long on screen: a gaze on one can be a reaction to them).
        self.shown_since = shown_since
        # The settings the round weighs with: its rule (RULE_FIELDS) stays for the round.
        self.settings = settings
        self.evidence = settings.evidence(start, shown_since)
        # In-window samples as they arrived, for re-classification.
        self.log = SampleLog()
        self.window_closed = False
        # A decision made but not yet final (reorder_s > 0), and until when it may wait.
        self.pending: Optional[Decision] = None
        self.deadline = math.inf
        # The evidence lacks samples logged since: rebuilt by a tick (LAZY_REBUILD_SAMPLES);
        # when the last batch arrived (s).
        self.stale = False
        self.arrived = -math.inf


class _Classifier(NamedTuple):
    """A region set, the settings, and the classifier they make of it (kept between rounds)."""

    regions: RegionSet
    settings: ArbiterSettings
    classifier: RegionSet


#: ``on_log(level, key, text)``: level 'info' or 'warning'; key names the kind of message.
LogCallback = Callable[[str, str, str], None]


class RoundScheduler:
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
        # The newest region set's classifier under the settings, between rounds.
        self._classifier: Optional[_Classifier] = None
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
        #: Samples of a batch whose stamp was NaN or infinite (dropped).
        self.samples_bad_stamp = 0
        #: Counts the changes to what :meth:`progress`, :meth:`label_at` and
        #: :attr:`classifier` answer (every input, rebuilt or finished round): unchanged,
        #: asking again gives the same answers (the feedback asks ~30 times a second).
        self.changes = 0

    @property
    def offered(self) -> frozenset:
        """Labels of the newest region set."""
        return self._offered

    @property
    def newest_regions(self) -> Optional[RegionSet]:
        """Return the newest region set (None before the first)."""
        return self._history[-1] if self._history else None

    @property
    def round_open(self) -> bool:
        """Whether a round is collecting gaze (or holding a decision)."""
        return self._round is not None

    @property
    def round_start(self) -> Optional[float]:
        """Return the open round's start, s (its window is ``[start, start + window_s)``)."""
        return self._round.start if self._round is not None else None

    @property
    def evidence(self):
        """Return the open round's evidence, or None; read it, never change it."""
        return self._round.evidence if self._round is not None else None

    def next_due(self, now: Optional[float] = None) -> Optional[float]:
        """
        Return when the open round's decision can next come, s, or None without a round.

        With the early decision: the earliest one (round start + dwell_s: every rule's
        deciding run or fixation spans dwell_s) until ``now`` (the node clock; None: not
        yet known) passes it, and the time the rule's current run can first decide (its
        evidence's ``next_due``) while no sample stamped after it has come; else the
        window end.  The choice_arbiter announces it (``choice/due``) for the bridge's
        batching.
        """
        round_ = self._round
        if round_ is None:
            return None
        settings = self.settings
        due = round_.start + settings.window_s
        if settings.early_decision:
            early = round_.start + settings.dwell_s
            if now is None or now < early:
                due = min(due, early)
            evidence = round_.evidence
            run_due = evidence.next_due()
            if run_due is not None and run_due > evidence.last_stamp:
                due = min(due, run_due)
        return due

    @property
    def classifier(self) -> Optional[RegionSet]:
        """
        Return the newest region set under the rule of the open round (else the settings').

        None before any region set arrived.
        """
        if not self._history:
            return None
        newest = self._history[-1]
        if self._round is not None:
            return self._round.evidence.regions_for(newest)
        cached = self._classifier
        if cached is None or cached.regions is not newest or cached.settings != self.settings:
            cached = self._classifier = _Classifier(newest, self.settings,
                                                    self.settings.regions(newest))
        return cached.classifier

    def label_at(self, x: float, y: float) -> Optional[str]:
        """
        Return the label a sample at (x, y) screen px counts for now (:attr:`classifier`).

        None when it counts for none, is not finite, or no regions are known.
        """
        regions = self.classifier
        if regions is None or not len(regions) or not (math.isfinite(x) and math.isfinite(y)):
            return None
        index = regions.classify_one(x, y)
        return regions.labels[index] if index >= 0 else None

    def progress(self) -> Dict[str, float]:
        """
        Return the open round's progress towards each offered label, 0..1 (feedback).

        The window rule's (:func:`eye_bci_ros2.decision.evidence.window_progress`, over
        the valid samples so far) and, with ``early_decision``, the larger of
        it and the early decision's (:func:`eye_bci_ros2.decision.evidence.early_progress`;
        a stale run gives none).  Empty without an open round.
        """
        round_ = self._round
        if round_ is None:
            return {}
        progress = round_.evidence.progress(self.settings)
        return {label: progress.get(label, 0.0) for label in sorted(self._offered)}

    def configure(self, **changed) -> None:
        """
        Change settings (names of :class:`ArbiterSettings`).

        The open round uses them from its next sample on (counts so far stay),
        except the rule (:data:`RULE_FIELDS`: classification, error model,
        screen, share test): it applies from the next round on, so no round
        mixes two rules.
        """
        self.changes += 1
        self.settings = self.settings.replace(**changed)
        if self._round is not None:
            self._round.settings = self._round.settings.replace(
                **{name: value for name, value in changed.items() if name not in RULE_FIELDS})
            self._round.evidence.configure(self.settings)

    # -- inputs ---------------------------------------------------------------------------

    def add_sample(self, stamp: float, x: float, y: float, now: float) -> Optional[Decision]:
        """
        Take one gaze sample (:meth:`add_samples` of one).

        :param stamp: acquisition time of the sample, s (finite).
        :param x: screen x, px (NaN or infinite: in no region).
        :param y: screen y, px (NaN or infinite: in no region).
        :param now: arrival time, s (finite).
        :returns: the decision this sample completed (also passed to
            ``on_decision``), else None.
        :raises ValueError: a stamp or ``now`` that is not finite.
        """
        if not (math.isfinite(stamp) and math.isfinite(now)):
            raise ValueError(f'gaze sample stamp {stamp} s and arrival time {now} s must be '
                             'finite')
        return self.add_samples(np.array([stamp]), np.array([[x, y]]), now)

    def add_samples(self, stamps, points, now: float) -> Optional[Decision]:
        """
        Take a batch of gaze samples (one ``gaze/samples`` message), in arrival order.

        Samples with an implausible stamp are dropped (class doc, "Stamps"; a
        NaN or infinite stamp too, counted in :attr:`samples_bad_stamp`).  In
        the steady state (the batch in stamp order after everything before it,
        regions older than its first sample) the batch is classified and
        weighed at once, and the decision is the one its first confident
        sample makes, as one by one.  Otherwise the round is rebuilt once from
        all its samples in stamp order, so the decision weighs every sample
        that has arrived.

        :param stamps: shape (N,), acquisition times, s.
        :param points: shape (N, 2), screen px (NaN or infinite: in no region).
        :param now: arrival time of the batch, s (finite).
        :returns: the decision a sample of the batch completed (also passed
            to ``on_decision``), else None.
        :raises ValueError: ``now`` not finite, or stamps and points of
            different lengths.
        """
        self.changes += 1
        stamps = np.asarray(stamps, dtype=float).reshape(-1)
        points = points_array(points)
        if len(stamps) != len(points):
            raise ValueError(f'{len(points)} gaze points but {len(stamps)} stamps')
        if not math.isfinite(now):
            raise ValueError(f'arrival time {now} s must be finite')
        if not len(stamps):
            return None
        self.samples_received += len(stamps)
        keep = self._plausible(stamps, now)
        if keep is not None:
            stamps, points = stamps[keep], points[keep]
            if not len(stamps):
                return None
        finite = np.isfinite(points).all(axis=1)
        if not finite.all():
            # Named: the batch's first such sample, counted up to it (as one at a time).
            x, y = points[np.argmin(finite)]
            self._on_log('warning', 'gaze_not_finite',
                         f'gaze sample ({x}, {y}) px is NaN or infinite: taken as in no region '
                         f'({self.samples_not_finite + 1} such samples so far)')
            self.samples_not_finite += int(np.count_nonzero(~finite))
        self._remember(stamps, points, now)
        round_ = self._round
        if round_ is None:
            return None
        if stamps.min() < round_.start:
            later = stamps >= round_.start
            stamps, points = stamps[later], points[later]
        if not len(stamps):
            return None
        if self._steady(round_, stamps):
            return self._take_batch(round_, stamps, points, now)
        return self._take_unsteady(round_, stamps, points, now)

    def _remember(self, stamps: np.ndarray, points: np.ndarray, now: float) -> None:
        """Keep recent samples for a round that starts at a past stamp."""
        recent = self._recent
        recent.extend(zip(stamps.tolist(), points[:, 0].tolist(), points[:, 1].tolist()))
        horizon = now - self.settings.window_s - RECENT_MARGIN_S
        while recent and recent[0][0] < horizon:
            recent.popleft()

    def _plausible(self, stamps: np.ndarray, now: float) -> Optional[np.ndarray]:
        """
        Tell which stamps can be right and of use; count and log the others.

        :returns: (N,) bool, or None when all can (the common case, told by the
            newest and oldest stamp alone: a NaN fails that test).
        """
        settings = self.settings
        round_ = self._round
        # The earliest stamp a round can use: a round started by new choices begins at
        # most window_s in the past.
        earliest = round_.start if round_ is not None else now - settings.window_s
        if (stamps.max() - now <= settings.max_future_s
                and earliest - stamps.min() <= settings.window_s):
            return None
        with np.errstate(invalid='ignore'):
            bad_stamp = ~np.isfinite(stamps)
            ahead = stamps - now
            future = (ahead > settings.max_future_s) & ~bad_stamp
            behind = earliest - stamps
            too_old = (behind > settings.window_s) & ~bad_stamp
        if bad_stamp.any():
            self.samples_bad_stamp += int(np.count_nonzero(bad_stamp))
            self._on_log('warning', 'gaze_bad_stamp',
                         f'gaze samples with a NaN or infinite stamp dropped; '
                         f'{self.samples_bad_stamp} dropped so far')
        if future.any():
            self.samples_from_future += int(np.count_nonzero(future))
            self._on_log('warning', 'gaze_future',
                         f'gaze sample stamped {ahead[future].max():.3f} s after its arrival '
                         f'dropped (more than max_future_s {settings.max_future_s} s: a corrupt '
                         f'stamp or a wrong clock); {self.samples_from_future} dropped so far')
        if too_old.any():
            self.samples_too_old += int(np.count_nonzero(too_old))
            what = 'the round start' if round_ is not None else 'any round start'
            self._on_log('warning', 'gaze_too_old',
                         f'gaze sample stamped {behind[too_old].max():.3f} s before {what} '
                         f'dropped (more than window_s {settings.window_s} s: delivered late, '
                         f'or a corrupt stamp); {self.samples_too_old} dropped so far')
        return ~(bad_stamp | future | too_old)

    def _steady(self, round_: _Round, stamps: np.ndarray) -> bool:
        """Tell whether a batch can be weighed at once (:meth:`add_samples`)."""
        history = self._history_stamps
        return (round_.pending is None and not round_.window_closed and not round_.stale
                and stamps[0] >= round_.log.max_stamp
                and (not history or stamps[0] >= history[-1])
                and len(round_.log) + len(stamps) < MAX_ROUND_SAMPLES
                and (len(stamps) == 1 or bool(np.all(np.diff(stamps) >= 0))))

    def _take_batch(self, round_: _Round, stamps: np.ndarray, points: np.ndarray,
                    now: float) -> Optional[Decision]:
        """Add a steady batch (:meth:`_steady`) stamped at or after the round start."""
        settings = self.settings
        inside = int(np.searchsorted(stamps, round_.start + settings.window_s, side='left'))
        closes = inside < len(stamps)
        decision = None
        if inside:
            round_.log.extend(stamps[:inside], points[:inside])
            decision = round_.evidence.add(
                points[:inside], stamps[:inside], self._regions_at(stamps[0]),
                settings.confidence if settings.early_decision else None)
        if decision is not None:
            decision = self._propose(round_, decision, now)
            if closes and self._round is round_:
                round_.window_closed = True   # held for late regions; the window is over
            return decision
        if closes:
            round_.window_closed = True
            return self._propose(round_, round_.evidence.decide(settings.method), now)
        return None

    def add_regions(self, region_set: RegionSet, now: float) -> Optional[Decision]:
        """
        Take a new region set (the complete set shown from ``region_set.stamp`` on).

        :param now: arrival time, s.
        :returns: a decision this completed (a held one made final, or the
            round the new choices end), else None.
        """
        self.changes += 1
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
        self.changes += 1
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

        A round left stale by a backlog (:data:`LAZY_REBUILD_SAMPLES`) is rebuilt first,
        once no batch came for :data:`LAZY_QUIET_S`; while its batches keep coming the
        stream has not stalled (at most :data:`BACKLOG_LIMIT_S` past the stall timeout).

        Call it periodically (the node: every TICK_S, 40 ms).
        :returns: the decision made, if any.
        """
        round_ = self._round
        if round_ is None:
            return None
        stall_at = round_.start + self.settings.window_s + self.settings.stall_timeout_s
        if round_.stale and round_.pending is None and not round_.window_closed:
            if now - round_.arrived < LAZY_QUIET_S and now < stall_at + BACKLOG_LIMIT_S:
                return None     # a backlog is arriving: not stalled, not yet rebuilt
            decision = self._reclassify(round_, now)
            if decision is not None or self._round is not round_:
                return decision
        if round_.pending is not None:
            return self._finish(round_.pending) if now >= round_.deadline else None
        if now >= stall_at:
            round_.window_closed = True
            return self._finish(round_.evidence.decide(self.settings.method))
        return None

    # -- rounds ---------------------------------------------------------------------------

    def _take_unsteady(self, round_: _Round, stamps: np.ndarray, points: np.ndarray,
                       now: float) -> Optional[Decision]:
        """
        Add a batch that is not steady: out of stamp order, or regions may be late.

        The round's in-window samples are logged and its evidence rebuilt once from the
        whole log in stamp order (O(round) per batch, not per sample), so a burst of
        late samples costs one rebuild.
        """
        settings = self.settings
        inside = stamps < round_.start + settings.window_s
        log = round_.log
        if len(log) + int(np.count_nonzero(inside)) >= MAX_ROUND_SAMPLES:
            self._on_log('warning', 'round_full',
                         f'{len(log)} samples in one round: closing it now')
            round_.window_closed = True
            return self._finish(round_.evidence.decide(settings.method))
        log.extend(stamps[inside], points[inside])
        closes = not inside.all()
        if round_.pending is not None or round_.window_closed:
            round_.window_closed = round_.window_closed or closes
            return None   # held for late regions, or already decided at the window end
        round_.window_closed = closes
        if not closes and len(log) >= LAZY_REBUILD_SAMPLES:
            round_.stale, round_.arrived = True, now    # rebuilt by tick() once drained
            return None
        return self._reclassify(round_, now)

    def _shown_since(self, stamp: float) -> float:
        """Return since when the options shown at ``stamp`` have been shown unmoved, s."""
        stamps = self._history_stamps
        if not stamps:
            return stamp
        index = max(bisect.bisect_right(stamps, stamp) - 1, 0)
        while index > 0:
            new, old = self._history[index], self._history[index - 1]
            if new.labels != old.labels or options_moved(old, new):
                break
            index -= 1
        return min(float(stamps[index]), stamp)

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
        evidence = round_.settings.evidence(round_.start, round_.shown_since)
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
        round_.stale = False
        if evidence.decision is not None:
            return evidence.decision
        if round_.window_closed and until >= round_.start + settings.window_s:
            return evidence.decide(settings.method)
        return None

    def _reclassify(self, round_: _Round, now: float) -> Optional[Decision]:
        """Rebuild the open round's evidence and propose what it decides."""
        self.changes += 1
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
        round_ = self._round = _Round(start, self.settings, self._shown_since(start))
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
        self.changes += 1
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
