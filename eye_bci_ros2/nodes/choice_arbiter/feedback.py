"""
The choice_arbiter's feedback: what the person sees of a decision while it happens.

:class:`FeedbackPublisher` takes the node it serves (as tf2's
``TransformListener(buffer, node)`` does) and the node's rounds, and owns its
part of the node: the feedback parameters
(:class:`eye_bci_ros2.decision.feedback.FeedbackSettings`), the ``choices``
subscription (the options, visualization_msgs/MarkerArray, as RViz reads
them) and the ``choices/feedback`` publisher (one halo per option with its ns and
id, :mod:`eye_bci_ros2.ros.feedback_markers`).  It shows the
option the newest gaze sample counts for under the round's rule ('gazed'), the
progress of the decision (:meth:`eye_bci_ros2.decision.rounds.RoundScheduler.progress`)
as the halo's growth, and the option just chosen green for
``feedback_confirm_s``; at most ``feedback_rate_hz`` messages per second, only
when something changed (:class:`eye_bci_ros2.decision.feedback.FeedbackThrottle`; 0 = off).

It has no timer of its own: the node calls :meth:`FeedbackPublisher.update`
after each gaze batch (the gaze is shown as soon as it arrives), after a choice
and on its own tick (a highlight that goes stale, a confirmation that ends).  A
timer's wake-up costs about 0.1 ms of CPU whatever it does (``python -m
bench.lab_rate``, part ``wake_up``), and the gaze batches come as often as a
feedback timer would tick.  An update works out what to show only when
something it shows may have changed (the rounds' answers:
:attr:`eye_bci_ros2.decision.rounds.RoundScheduler.changes`; the newest gaze
point; the confirmation; their ageing), and then at most twice per message
period (``feedback_rate_hz``; a choice's confirmation at once): the ticks
between gaze batches, and the batches that come 2 ms apart while a decision is
due, cost next to nothing.
"""

import math
from typing import Callable, List, NamedTuple, Optional, Tuple

from rclpy.node import Node
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.decision.feedback import (build_feedback, Feedback, FeedbackSettings,
                                            FeedbackThrottle)
from eye_bci_ros2.decision.rounds import RoundScheduler
from eye_bci_ros2.ros.feedback_markers import FeedbackMarkers, option_label, OptionMarkers
from eye_bci_ros2.ros.parameters import param_specs, SettingsParameters
from eye_bci_ros2.ros.topics import CHOICES_QOS, CHOICES_TOPIC, FEEDBACK_QOS, FEEDBACK_TOPIC

#: The feedback parameters (one per FeedbackSettings field, declared there).
FEEDBACK_PARAMETERS = param_specs(FeedbackSettings)

#: choices/feedback shows at most this many options (one halo each, ~30 times a second).
MAX_FEEDBACK_OPTIONS = 256

#: A gaze sample older than this (node clock) no longer highlights an option, s.
GAZED_STALE_S = 0.25

#: ``log(level, key, text)``, as :data:`eye_bci_ros2.decision.rounds.LogCallback`.
Log = Callable[[str, str, str], None]


class GazePoint(NamedTuple):
    """The newest gaze sample: screen px and its arrival, s (node clock)."""

    x: float
    y: float
    arrived: float


class Confirmed(NamedTuple):
    """The option just chosen, shown confirmed until ``until`` s (node clock)."""

    label: str
    until: float
    marker: Optional[Marker]


class FeedbackPublisher:
    """
    The arbiter's ``choices/feedback`` (module doc).

    :param node: the node it declares its parameters and topics on.
    :param rounds: the node's rounds (read only: which option the gaze counts
        for, the progress).
    :param log: the node's keyed log.
    """

    def __init__(self, node: Node, rounds: RoundScheduler, log: Log):
        """Declare the feedback parameters, subscribe the options."""
        self._node = node
        self._rounds = rounds
        self._log = log
        self.parameters = SettingsParameters(node, FeedbackSettings, self._on_parameters)
        self._options = OptionMarkers()
        self._halos = FeedbackMarkers()
        self._newest: Optional[GazePoint] = None
        self._chosen: Optional[Confirmed] = None
        self._options_changed = False
        self._publisher = node.create_publisher(MarkerArray, FEEDBACK_TOPIC, FEEDBACK_QOS)
        node.create_subscription(MarkerArray, CHOICES_TOPIC, self._on_choices, CHOICES_QOS)
        self._throttle: Optional[FeedbackThrottle] = None
        self._sent_at = -math.inf
        # What the last look at the feedback depended on (_inputs), and when it was.
        self._looked: Optional[tuple] = None
        self._looked_at = -math.inf
        self._set_rate(self.parameters.settings.feedback_rate_hz)

    # -- what the node tells it --------------------------------------------------------------

    def gaze_at(self, x: float, y: float, now: float) -> None:
        """Note the newest gaze sample, (x, y) screen px, arrived at ``now`` s."""
        self._newest = GazePoint(x, y, now)

    def confirm(self, label: str, now: float) -> None:
        """Show ``label`` chosen (green) for ``feedback_confirm_s`` from ``now`` s."""
        self._chosen = Confirmed(label, now + self.parameters.settings.feedback_confirm_s,
                                 self._options.get(label))
        self.update(now, at_once=True)

    # -- parameters, inputs ---------------------------------------------------------------

    def _on_parameters(self, settings: FeedbackSettings, changed: dict) -> None:
        if 'feedback_rate_hz' in changed:
            self._set_rate(settings.feedback_rate_hz)

    def _set_rate(self, rate_hz: float) -> None:
        """Send at most ``rate_hz`` messages a second (0: none, and withdraw the halos)."""
        self._looked = None
        if rate_hz > 0:
            self._throttle = FeedbackThrottle(max_rate_hz=rate_hz)
            return
        self._throttle = None
        if self._halos.shown:
            node = self._node
            withdrawn = self._halos.update(Feedback(()), [], node.get_clock().now().to_msg())
            if withdrawn is not None:
                self._publisher.publish(withdrawn)

    def _on_choices(self, msg: MarkerArray) -> None:
        try:
            problems = self._options.apply(msg)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            problems = [f'choices message ignored: {error}']
        if problems:
            self._log('warning', 'choices_bad', 'choices: ' + '; '.join(problems[:5]))
        self._options_changed = True

    # -- output ---------------------------------------------------------------------------

    def current(self, now: float) -> Tuple[Feedback, List[Marker]]:
        """
        Return what choices/feedback shows at ``now`` (node clock, s): (Feedback, options).

        The options are the ``choices`` markers, plus the option just chosen while it is
        shown confirmed even if the menu has withdrawn it.
        """
        options = self._options.options
        chosen = None
        if self._chosen is not None:
            if now < self._chosen.until:
                chosen = self._chosen.label
                marker = self._chosen.marker
                keys = {(m.ns, m.id) for m in options}
                if marker is not None and (marker.ns, marker.id) not in keys:
                    options = options + [marker]
            else:
                self._chosen = None
        gazed = None
        newest = self._newest
        if newest is not None and now - newest.arrived <= GAZED_STALE_S:
            gazed = self._rounds.label_at(newest.x, newest.y)
        feedback = build_feedback([option_label(m) for m in options], gazed=gazed,
                                  chosen=chosen, progress=self._rounds.progress(),
                                  stamp=now)
        return feedback, options

    def _inputs(self, now: float) -> tuple:
        """
        Return everything :meth:`current` depends on at ``now``.

        The rounds' answers (their change count), the newest gaze point and whether it is
        fresh, the confirmed option and whether it is still shown; the options are flagged
        apart (``_options_changed``).
        """
        newest, chosen = self._newest, self._chosen
        return (self._rounds.changes, newest,
                newest is not None and now - newest.arrived <= GAZED_STALE_S,
                chosen, chosen is not None and now < chosen.until)

    def update(self, now: float, at_once: bool = False) -> None:
        """
        Send what choices/feedback shows at ``now`` (node clock, s), if it is due.

        :param at_once: look now even if the last look was less than a feedback period
            ago (a choice: its confirmation is shown without delay).
        """
        throttle = self._throttle
        if throttle is None:
            return
        # At most feedback_rate_hz messages whatever changes (a gaze that jumps between
        # options every batch included), and at most two looks per message period: a look
        # costs about 0.3 ms, and while a decision is due the gaze batches come every 2 ms.
        # Two, not one: sampled once a period, a change could wait a whole period more.
        # What is held back goes out with the next update (the node's next tick at the latest).
        urgent = at_once or self._options_changed
        if not urgent and (now - self._sent_at < throttle.period
                           or now - self._looked_at < 0.5 * throttle.period):
            return
        inputs = self._inputs(now)
        if (inputs == self._looked and not urgent
                and now - self._sent_at < throttle.keepalive):
            return      # what it shows is as at the last look, which was not worth sending
        self._looked, self._looked_at = inputs, now
        try:
            count = len(self._options.options)
            if count > MAX_FEEDBACK_OPTIONS:
                # No menu a person chooses from by gaze has that many: do not flood RViz.
                self._log('warning', 'feedback_options',
                          f'choices/feedback paused: {count} options offered, more than '
                          f'{MAX_FEEDBACK_OPTIONS}')
                return
            feedback, options = self.current(now)
            if not (throttle.due(feedback, now) or self._options_changed):
                return
            self._options_changed = False
            message = self._halos.update(feedback, options,
                                         self._node.get_clock().now().to_msg())
            if message is not None:
                self._publisher.publish(message)
                self._sent_at = now
        except Exception as error:  # noqa: B902 - a node never dies on feedback
            self._log('warning', 'feedback_error', f'feedback not sent: {error}')
