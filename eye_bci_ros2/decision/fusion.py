"""
Input modes of an experiment: gaze, SSVEP, or both (hybrid), and how they make a choice.

- ``gaze``: the gaze decision is the choice (the original system).
- ``ssvep``: the SSVEP decoder's choice (``ssvep/choice``) is the choice, if
  it names an offered option; gaze is ignored.
- ``hybrid``: gaze alone never chooses.  The gaze decision only nominates a
  *candidate*; it becomes the choice when SSVEP confirms it: the decoder
  chose the same option, or its evidence that the candidate is attended
  rather than nothing (:func:`confirmation`) stayed at or above
  ``confirm_threshold`` in every scoring step (``ssvep/scores``) over
  ``hold_s`` (as the decoder holds its own choices,
  :class:`eye_bci_ros2.ssvep.decision.HeldDecision`: one step's excursion is
  noise), within ``max_lag_s`` of the gaze candidate (either may come
  first).  The gaze has already said which option the person looks at, so
  the EEG answers "is this one attended, or nothing?" (a detection of one
  stimulus against rest), not "which of the K?": the posterior is
  conditioned on the two hypotheses left, ``p_c / (p_c + p_rest)``, and the
  candidate must lead the posterior (strong evidence for another option
  means the gaze, not the EEG, is wrong).  A gaze decision is a candidate
  only when the gaze stayed on it: its margin (leader's share of the
  in-region gaze minus the runner-up's) is at least ``min_gaze_margin``.
  Gaze narrows the options and SSVEP, which needs sustained attention to a
  flickering option, supplies the intent: looking over the options (the
  "Midas touch") nominates candidates but never confirms one.  (Sequential
  gaze-then-SSVEP confirmation as in Stawicki et al. 2017 and the sequential
  mode of Guo et al. 2023.)

At most one choice per round; a round starts with :meth:`ChoiceFusion.new_round`
(new options or a request).  Times are seconds on one clock (the node clock).
"""

from dataclasses import dataclass
from typing import Dict, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.base.settings import check_settings, Setting
from eye_bci_ros2.base.validators import Interval
from eye_bci_ros2.ssvep.decision import DEFAULT_HOLD_S

#: The input modes, the one place they are named (the ``input_mode`` parameter's choices).
INPUT_MODES = ('gaze', 'ssvep', 'hybrid')
GAZE, SSVEP, HYBRID = INPUT_MODES


#: A posterior whose options leave less than this to "nothing attended" carries no rest
#: share (a decoder without that hypothesis, or one option overwhelmingly attended).
NO_REST_SHARE = 1e-9


def confirmation(posterior: Sequence[float]) -> np.ndarray:
    """
    Return each option's evidence that it, looked at, is attended rather than nothing.

    With the gaze on option ``c`` the hypotheses left are "c is attended" and
    "nothing is attended"; their posterior is ``p_c / (p_c + p_rest)`` with
    ``p_rest = 1 - sum(p)`` (the decoder's "nothing attended" share,
    :func:`eye_bci_ros2.ssvep.decision.posterior`), which is the decoder's
    one-stimulus detection against rest: ``exp(gain z_c) / (exp(gain z_c) +
    exp(gain rest_z))``.  An option that another one leads gets 0 (the EEG
    says the person attends something else).  Without a rest share (a decoder
    that has no "nothing attended" hypothesis) the posterior itself.  Values
    that are not finite count as 0.

    :param posterior: the ``ssvep/scores`` posterior of the options, (K,).
    :returns: (K,), in [0, 1].
    """
    p = np.asarray(posterior, dtype=float).reshape(-1)
    p = np.clip(np.where(np.isfinite(p), p, 0.0), 0.0, 1.0)
    if not p.size:
        return p
    rest = 1.0 - float(p.sum())
    value = p / np.maximum(p + rest, 1e-300) if rest > NO_REST_SHARE else p.copy()
    value[p < p.max()] = 0.0
    return value


class Timed(NamedTuple):
    """A label and when it came, s (the node clock)."""

    label: str
    t: float


@dataclass(frozen=True)
class FusionOutcome:
    """
    What a gaze decision leads to (:meth:`ChoiceFusion.gaze_outcome`).

    :param choice: the label to publish as the choice, or None.
    :param no_choice: why the round can lead to no choice (for ``choice/none``:
        a menu may ask again), or None while a choice may still come.
    """

    choice: Optional[str] = None
    no_choice: Optional[str] = None


@dataclass(frozen=True)
class FusionSettings:
    """
    How gaze and SSVEP combine: the choice_arbiter's input-mode parameters.

    Each field is declared once (:class:`eye_bci_ros2.base.settings.Setting`);
    ``input_mode`` is one of :data:`INPUT_MODES`.
    """

    input_mode: str = Setting(
        'gaze', 'What chooses: gaze (the gaze decision), ssvep (ssvep/choice of the '
        'ssvep_decoder) or hybrid (a gaze decision is only a candidate; it is chosen '
        'when SSVEP confirms it, see eye_bci_ros2.decision.fusion)', choices=INPUT_MODES).field()
    confirm_threshold: float = Setting(
        0.9, 'hybrid: SSVEP posterior (ssvep/scores) that the gaze candidate is attended '
        'rather than nothing (it must also lead the options) that confirms it',
        interval=Interval(0.01, 1.0)).field()
    max_lag_s: float = Setting(
        5.0, 'hybrid: longest time between the gaze candidate and the SSVEP evidence that '
        'confirms it, s', interval=Interval(0.0, 60.0), unit='s').field()
    min_gaze_margin: float = Setting(
        0.5, 'hybrid: a gaze decision is a candidate only with at least this margin (share '
        "of in-region gaze on it minus the runner-up's): the gaze stayed on it",
        interval=Interval(0.0, 1.0)).field()
    hold_s: float = Setting(
        DEFAULT_HOLD_S, "hybrid: how long the candidate's SSVEP posterior must stay at or above "
        'confirm_threshold to confirm it, s (as the ssvep_decoder holds its choices)',
        interval=Interval(0.0, 10.0), unit='s').field()

    def __post_init__(self):
        """Reject settings that cannot work, with a reason (each field's declaration)."""
        check_settings(self)


class ChoiceFusion:
    """
    Turn gaze decisions and SSVEP output into at most one choice per round.

    Each input method returns the label to publish as the choice, or None.
    """

    def __init__(self, settings: FusionSettings = FusionSettings()):
        """Start with no options offered."""
        self.settings = settings
        self._options: Tuple[str, ...] = ()
        self.new_round(())

    def configure(self, settings: FusionSettings) -> None:
        """Change the settings (the open round keeps its evidence)."""
        self.settings = settings

    @property
    def candidate(self) -> Optional[str]:
        """Return the gaze candidate waiting for SSVEP confirmation (hybrid), or None."""
        return self._candidate.label if self._candidate else None

    @property
    def chosen(self) -> bool:
        """Return whether this round's choice has been made."""
        return self._chosen

    def new_round(self, options: Optional[Sequence[str]] = None) -> None:
        """Start a round (with new ``options``, or the same ones when None)."""
        if options is not None:
            self._options = tuple(options)
        self._candidate: Optional[Timed] = None
        self._ssvep_choice: Optional[Timed] = None
        #: Per label: since when its posterior has been at or above the threshold.
        self._above: Dict[str, float] = {}
        #: Per label: when its posterior last completed a hold.
        self._held: Dict[str, float] = {}
        self._chosen = False

    def gaze(self, label: Optional[str], t: float, margin: float = 1.0) -> Optional[str]:
        """
        Take the gaze decision of a round (None = no choice) at time ``t``.

        :param margin: the decision's gaze margin (hybrid: below
            ``min_gaze_margin`` it nominates no candidate).
        """
        mode = self.settings.input_mode
        if mode == GAZE:
            return self._choose(label)
        if mode == SSVEP or self._chosen:
            return None
        steady = margin >= self.settings.min_gaze_margin
        self._candidate = Timed(label, t) if label in self._options and steady else None
        return self._confirm()

    def gaze_outcome(self, label: Optional[str], t: float, margin: float = 1.0,
                     reason: Optional[str] = None) -> FusionOutcome:
        """
        Take the gaze decision of a round (:meth:`gaze`) and say what it leads to.

        No choice can come of the round when gaze chose nothing (mode gaze) or
        nominated no candidate while none was chosen (hybrid); mode ssvep never
        ends a round on gaze.

        :param reason: why the decision chose nothing (its ``reason``), if it did not.
        """
        choice = self.gaze(label, t, margin)
        if choice is not None:
            return FusionOutcome(choice=choice)
        mode = self.settings.input_mode
        if (mode == GAZE and label is None) or (
                mode == HYBRID and self._candidate is None and not self._chosen):
            return FusionOutcome(
                no_choice=reason or f"gaze on '{label}' too unsteady for a candidate")
        return FusionOutcome()

    def ssvep_choice(self, label: str, t: float) -> Optional[str]:
        """Take the SSVEP decoder's choice at time ``t``."""
        if label not in self._options or self._chosen:
            return None
        if self.settings.input_mode == SSVEP:
            return self._choose(label)
        if self.settings.input_mode == HYBRID:
            self._ssvep_choice = Timed(label, t)
            return self._confirm()
        return None

    def ssvep_scores(self, labels: Sequence[str], posterior: Sequence[float],
                     t: float) -> Optional[str]:
        """Take one SSVEP scoring step (posterior per label) at time ``t``."""
        if self.settings.input_mode != HYBRID or self._chosen:
            return None
        for label, probability in zip(labels, confirmation(posterior)):
            if label not in self._options:
                continue
            if probability < self.settings.confirm_threshold:
                self._above.pop(label, None)
                continue
            since = self._above.setdefault(label, t)
            if t - since >= self.settings.hold_s - 1e-6:
                self._held[label] = t
        for label in set(self._above) - set(labels):  # not scored in this step
            del self._above[label]
        return self._confirm()

    def _confirm(self) -> Optional[str]:
        """Hybrid: choose the gaze candidate if SSVEP evidence close in time confirms it."""
        if self._candidate is None:
            return None
        label, t_gaze = self._candidate
        lag = self.settings.max_lag_s
        if self._ssvep_choice is not None:
            chosen, t = self._ssvep_choice
            if chosen == label and abs(t - t_gaze) <= lag:
                return self._choose(label)
        held = self._held.get(label)
        if held is not None and abs(held - t_gaze) <= lag:
            return self._choose(label)
        return None

    def _choose(self, label: Optional[str]) -> Optional[str]:
        if label is None or self._chosen:
            return None
        if self.settings.input_mode != GAZE:
            self._chosen = True
        return label
