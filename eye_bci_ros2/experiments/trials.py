"""
Decide a simulated trial with the choice_arbiter's own decision code: the one trial runner.

The accuracy test (:mod:`eye_bci_ros2.experiments.accuracy_test`),
``bench/decision.py`` and ``bench/tolerance.py`` simulate a person on
simulated time and decide every trial with :func:`decide_trial`, which does
what :class:`eye_bci_ros2.decision.rounds.RoundScheduler` does inside one round:
a :class:`~eye_bci_ros2.decision.evidence.RoundEvidence` made by
:meth:`ArbiterSettings.evidence`, the valid samples of the window in stamp
order, the early decision when ``settings.early_decision`` is on (stopping at
the first sample that passes), else ``settings.method`` at the window end.
A rule is therefore an :class:`~eye_bci_ros2.decision.rounds.ArbiterSettings`: the
node's parameters, one home.

Times are s of sample stamps; the round starts at ``start`` (0 in the
benchmarks, where the options appear at t = 0).
"""

from dataclasses import dataclass
from typing import Optional, Sequence, Union

import numpy as np

from eye_bci_ros2.decision.evidence import Decision
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, ORIGINAL_RULE

#: Rule names the experiments accept: the original rule, the node's window rules and its
#: early decision (the node's classification: tolerant by default).
RULES = ('original', 'mean', 'vote', 'early')

#: The original system's rule: mean of the in-region samples at the end of a 1 s window
#: (inside-only classification, no share test).
ORIGINAL = ArbiterSettings(method='mean', early_decision=False, **ORIGINAL_RULE)


def settings_for(rule: str, base: Optional[ArbiterSettings] = None) -> ArbiterSettings:
    """
    Return ``base`` (default: the node's defaults) set to decide by ``rule``.

    :param rule: 'original' (:data:`ORIGINAL`: inside-only mean at the window
        end), 'mean' or 'vote' (window end) or 'early' (early decision,
        ``base.method`` at the window end when it does not fire).
    :raises ValueError: an unknown rule.
    """
    base = ArbiterSettings() if base is None else base
    if rule == 'original':
        return base.replace(method='mean', early_decision=False, **ORIGINAL_RULE)
    if rule == 'early':
        return base.replace(early_decision=True)
    if rule in ('mean', 'vote'):
        return base.replace(method=rule, early_decision=False)
    raise ValueError(f"unknown rule {rule!r}: use {', '.join(RULES)}")


@dataclass(frozen=True)
class Outcome:
    """
    How a trial was decided.

    :param label: the chosen label, None for no choice.
    :param time_s: when the decision was made, s: the deciding sample's stamp
        for an early decision, else the window end (``start + window_s``).
    :param decision: the node's :class:`Decision` (counts, margin, reason).
    """

    label: Optional[str]
    time_s: float
    decision: Decision


def decide_trial(points, stamps, regions: Union[RegionSet, Sequence[RegionSet]],
                 settings: ArbiterSettings, start: float = 0.0,
                 chunk: Optional[int] = None, shown_since: Optional[float] = None) -> Outcome:
    """
    Decide one round of valid gaze samples as the choice_arbiter does (module doc).

    :param points: measured gaze, screen px, shape (N, 2) (lost samples removed).
    :param stamps: their acquisition stamps, s, shape (N,), non-decreasing.
    :param regions: the options shown during the round: one set, or the sets
        shown one after the other (stamps ascending, e.g. while the camera
        moves): each sample is weighed with the set shown at its stamp, as
        the node does (a sample before the first set takes the first).
    :param settings: the node's settings (the rule).
    :param start: the round start, s.
    :param chunk: feed the samples in batches of this many (as the bridge's
        chunks arrive); None = all at once, which decides the same because
        the early decision stops at the first sample that passes.
    :param shown_since: since when the options have been on the screen unmoved,
        s (None: ``start``): a question asked again about options already shown,
        as the menu asks after a round without a choice.
    """
    stamps = np.asarray(stamps, dtype=float).reshape(-1)
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    in_window = stamps < start + settings.window_s
    stamps, points = stamps[in_window], points[in_window]
    history = [regions] if isinstance(regions, RegionSet) else list(regions)
    shown = np.maximum(np.searchsorted([r.stamp for r in history], stamps, side='right') - 1,
                       0)
    evidence = settings.evidence(start, shown_since)
    confidence = settings.confidence if settings.early_decision else None
    step = max(len(stamps) if chunk is None else int(chunk), 1)
    for segment in np.split(np.arange(len(stamps)), np.flatnonzero(np.diff(shown)) + 1):
        if not segment.size:
            continue
        region_set = history[shown[segment[0]]]
        for low in range(0, len(segment), step):
            rows = segment[low:low + step]
            made = evidence.add(points[rows], stamps[rows], region_set, confidence)
            if made is not None:
                return Outcome(made.label, start + made.time_to_decision, made)
    if not len(stamps):   # no sample: the round still knows what was offered
        evidence.add(points, stamps, history[-1])
    made = evidence.decide(settings.method)
    return Outcome(made.label, start + settings.window_s, made)
