"""
What the person sees of a decision while it happens: the content of ``choices/feedback``.

Pure Python and numpy.  Per offered option (by label): a highlight state
(:data:`NONE`, :data:`GAZED`: the gaze is on it now, :data:`CHOSEN`: it was
just chosen) and the progress of the decision towards it, 0..1.  The node side
(:mod:`eye_bci_ros2.ros.feedback_markers`) turns it into RViz markers; the
arbiter side builds it with :func:`build_feedback` from its round state.

Progress: each rule's ``progress`` (the count rules':
:func:`eye_bci_ros2.decision.evidence.early_progress` and
:func:`~eye_bci_ros2.decision.evidence.window_progress`; the fixation rule's in
:mod:`eye_bci_ros2.decision.fixation`), passed to :func:`build_feedback`.

Rate (:class:`FeedbackThrottle`): a person sees ~30 Hz as smooth; feedback is
sent when its highlight changes (at once), when a progress moved by at least
``min_step`` (at most ``max_rate_hz``), and otherwise at ``keepalive_hz``, so an
idle screen costs almost nothing on the graph.
"""

from dataclasses import dataclass
import math
from typing import Mapping, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.base.settings import check_settings, Setting
from eye_bci_ros2.base.validators import Interval
from eye_bci_ros2.decision.evidence import clip01

#: Highlight states.
NONE = 'none'
GAZED = 'gazed'
CHOSEN = 'chosen'
STATES = (NONE, GAZED, CHOSEN)

#: Colour (r, g, b, a) of each state's halo.
STATE_COLOURS = {
    NONE: (0.6, 0.6, 0.6, 0.25),
    GAZED: (1.0, 0.85, 0.0, 0.85),
    CHOSEN: (0.1, 0.9, 0.2, 0.95),
}
#: Halo: border around the option at progress 0 and the growth at progress 1, as fractions of
#: the option's in-plane size; its thin side, as a fraction of the option's.
HALO_BORDER = 0.12
HALO_GROWTH = 0.4
HALO_THICKNESS = 0.5


@dataclass(frozen=True)
class OptionFeedback:
    """
    Feedback of one option.

    :param label: the option's label (its marker's text, else ns/id).
    :param state: one of :data:`STATES`.
    :param progress: progress of the decision towards this option, 0..1.
    """

    label: str
    state: str = NONE
    progress: float = 0.0

    def __post_init__(self):
        """Reject an unknown state or a progress outside 0..1."""
        if self.state not in STATES:
            raise ValueError(f"feedback state must be one of {', '.join(STATES)}, got "
                             f'{self.state!r}')
        if not 0.0 <= self.progress <= 1.0:
            raise ValueError(f'feedback progress must be in [0, 1], got {self.progress!r}')


@dataclass(frozen=True)
class Feedback:
    """
    The feedback of every offered option at one moment.

    :param options: one entry per offered label, in offer order.
    :param stamp: when it applies, s (the arbiter's clock).
    """

    options: Tuple[OptionFeedback, ...]
    stamp: float = 0.0

    def get(self, label: str) -> Optional[OptionFeedback]:
        """Return the entry of ``label``, or None."""
        return next((option for option in self.options if option.label == label), None)

    @property
    def labels(self) -> Tuple[str, ...]:
        """Return the offered labels."""
        return tuple(option.label for option in self.options)


@dataclass(frozen=True)
class FeedbackSettings:
    """What the person is shown: the choice_arbiter's feedback parameters (declared once)."""

    feedback_rate_hz: float = Setting(
        30.0, 'choices/feedback: most messages per second (sent only when the highlight or '
        'the progress changed, and once a second); 0 = no feedback',
        interval=Interval(0.0, 240.0), unit='Hz').field()
    feedback_confirm_s: float = Setting(
        1.0, 'choices/feedback: how long the chosen option is shown confirmed (green), s',
        interval=Interval(0.0, 60.0), unit='s').field()

    def __post_init__(self):
        """Reject values the feedback cannot run with (each field's declaration)."""
        check_settings(self)


def build_feedback(offered: Sequence[str], gazed: Optional[str] = None,
                   chosen: Optional[str] = None,
                   progress: Optional[Mapping[str, float]] = None,
                   stamp: float = 0.0) -> Feedback:
    """
    Assemble the feedback of the offered options.

    :param offered: labels offered now (duplicates are listed once).
    :param gazed: label the gaze is on now (recent samples), or None.
    :param chosen: label just chosen, or None; it wins over ``gazed`` and its
        progress is 1.
    :param progress: per label, 0..1 (missing = 0; clipped).
    :param stamp: s.
    """
    progress = progress or {}
    options = []
    for label in dict.fromkeys(str(label) for label in offered):
        if label == chosen:
            options.append(OptionFeedback(label, CHOSEN, 1.0))
            continue
        state = GAZED if label == gazed else NONE
        options.append(OptionFeedback(label, state, clip01(progress.get(label, 0.0))))
    return Feedback(tuple(options), float(stamp))


def halo_scale(scale, progress: float) -> np.ndarray:
    """
    Side lengths of an option's feedback halo (module doc), m.

    The option's thin side (smallest scale) is thinned to
    :data:`HALO_THICKNESS` of it so the option shows through; the other two
    grow by :data:`HALO_BORDER` + :data:`HALO_GROWTH` x progress.

    :param scale: the option marker's full side lengths (3,), m.
    :param progress: 0..1.
    :returns: shape (3,), m.
    """
    scale = np.asarray(scale, dtype=float).reshape(3)
    if not np.all(np.isfinite(scale) & (scale >= 0)):
        raise ValueError(f'marker scale must be 3 finite lengths >= 0, got {scale.tolist()}')
    out = scale * (1.0 + HALO_BORDER + HALO_GROWTH * clip01(progress))
    thin = int(np.argmin(scale))
    out[thin] = scale[thin] * HALO_THICKNESS
    return out


class FeedbackThrottle:
    """
    Decide when feedback is worth sending (module doc).

    :param max_rate_hz: at most this often for progress changes (> 0).
    :param min_step: smallest progress change worth sending.
    :param keepalive_hz: resend unchanged feedback this often (0 = never).
    """

    def __init__(self, max_rate_hz: float = 30.0, min_step: float = 0.02,
                 keepalive_hz: float = 1.0):
        """Start with nothing sent."""
        if not max_rate_hz > 0:
            raise ValueError(f'max_rate_hz must be > 0, got {max_rate_hz}')
        if not (min_step >= 0 and keepalive_hz >= 0):
            raise ValueError('min_step and keepalive_hz must be >= 0')
        self.period = 1.0 / max_rate_hz
        self.min_step = min_step
        self.keepalive = 1.0 / keepalive_hz if keepalive_hz > 0 else math.inf
        self._sent: Optional[Feedback] = None
        self._sent_at = -math.inf

    def due(self, feedback: Feedback, now: float) -> bool:
        """Tell whether to send ``feedback`` at ``now`` (s); if so it counts as sent."""
        send = self._decide(feedback, now)
        if send:
            self._sent, self._sent_at = feedback, now
        return send

    def _decide(self, feedback: Feedback, now: float) -> bool:
        sent = self._sent
        if sent is None or sent.labels != feedback.labels:
            return True
        old = {o.label: o for o in sent.options}
        if any(old[o.label].state != o.state for o in feedback.options):
            return True
        elapsed = now - self._sent_at
        if elapsed >= self.keepalive:
            return True
        moved = max((abs(old[o.label].progress - o.progress) for o in feedback.options),
                    default=0.0)
        return elapsed >= self.period and moved >= self.min_step and moved > 0
