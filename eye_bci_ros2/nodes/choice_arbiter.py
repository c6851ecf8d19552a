"""
Node choice_arbiter: decide from gaze which offered region the person chose.

Subscribes ``gaze/samples`` (sensor_msgs/PointCloud2 batches, frame
``screen``, px, every sample with its acquisition stamp; see
:mod:`eye_bci_ros2.nodes.conversions`), ``choices/regions``
(visualization_msgs/MarkerArray, latched) and ``choice/request``
(std_msgs/Empty); publishes ``choice`` (std_msgs/String, the region's label:
its text if set, else ``ns/id``) and ``choice/none`` (std_msgs/String, why a
round ended without a choice; input mode gaze), so a menu can ask again; and
``choice/due`` (builtin_interfaces/Time, latched): when the open round's
decision can next come (round start + ``dwell_s``, then the window end), so
the bridge pulls gaze promptly then and in bigger batches otherwise.

The rounds (when they start and end, which samples and regions they weigh,
when a decision is final, what is dropped as implausible) are
:class:`eye_bci_ros2.rounds.RoundScheduler`, the rules
:mod:`eye_bci_ros2.evidence`: this node converts messages and keeps the
clock.  Each gaze batch is weighed in its own callback, so ``choice`` is
published from the callback of the batch that completes the decision; a
50 Hz timer only closes rounds whose gaze stream went quiet and releases
decisions held by ``reorder_s``.  Bad input is counted
(:attr:`ChoiceArbiter.samples_from_future`, ``samples_too_old``,
``samples_not_finite``) and logged at most once per 5 s of each kind.

Rule (``classification`` and the share test ``min_share``; eye_bci_ros2.rounds
ArbiterSettings).  Default: the size-aware tolerant rule (a sample near an option counts
for it when it is clearly nearer to it than to any other, by a gaze-error model in
degrees on the person's screen, ``accuracy_deg``, ``precision_deg``, ``k_sigma``,
``screen_*``) with the share test, for the window-end and early decisions alike.
``classification:=inside min_share:=0.0`` (with ``method:=mean``) is the original rule.
A change of the rule applies from the next round on.

Feedback.  Subscribes ``choices`` (the options, visualization_msgs/MarkerArray, as RViz
reads them) and publishes ``choices/feedback`` (MarkerArray, one halo per option with its
ns and id, :mod:`eye_bci_ros2.nodes.feedback_markers`): the option the newest gaze sample
counts for under the round's rule highlighted ('gazed'), the progress of the decision
(:meth:`eye_bci_ros2.rounds.RoundScheduler.progress`) as the halo's growth, and the option
just chosen (the published ``choice``) green for ``feedback_confirm_s``; at most
``feedback_rate_hz`` messages per second, only when something changed
(:class:`eye_bci_ros2.feedback.FeedbackThrottle`; 0 = off).

Input modes (parameter ``input_mode``, :mod:`eye_bci_ros2.fusion`).  ``gaze``
(default): as above.  ``ssvep``: ``choice`` is the ``ssvep/choice`` of the
ssvep_decoder (std_msgs/String) when it names an offered option, once per
round; the gaze decision is not published.  ``hybrid``: gaze alone never
chooses: a round's gaze decision with a margin of at least
``min_gaze_margin`` is a candidate, published as ``choice`` only when SSVEP
confirms it within ``max_lag_s`` (``ssvep/choice`` of the same label, or
``ssvep/scores`` (sensor_msgs/JointState, position = posterior) of at least
``confirm_threshold`` for it).
"""

from typing import Optional

from builtin_interfaces.msg import Time
from rclpy.node import Node
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.evidence import Decision, MAX_REACTION_S
from eye_bci_ros2.feedback import build_feedback, Feedback, FeedbackThrottle
from eye_bci_ros2.fusion import ChoiceFusion, FusionSettings, INPUT_MODES
from eye_bci_ros2.nodes.conversions import gaze_cdr, marker_array_to_regions, ns_to_stamp
from eye_bci_ros2.nodes.feedback_markers import FeedbackMarkers, option_label, OptionMarkers
from eye_bci_ros2.nodes.graph_watch import GraphWatch
from eye_bci_ros2.nodes.log_throttle import KeyedWarnings, QuietRepeats
from eye_bci_ros2.nodes.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.nodes.runner import spin_node
from eye_bci_ros2.nodes.screen_parameters import person_screen_parameters
from eye_bci_ros2.nodes.topics import (CHOICE_TOPIC, CHOICES_QOS, CHOICES_TOPIC,
                                       DECISION_DUE_TOPIC, EVENT_QOS, FEEDBACK_QOS,
                                       FEEDBACK_TOPIC, GAZE_QOS, GAZE_SAMPLES_TOPIC, LATCHED_QOS,
                                       NO_CHOICE_TOPIC, REGIONS_TOPIC, REQUEST_TOPIC, SCORES_QOS,
                                       SSVEP_CHOICE_TOPIC, SSVEP_SCORES_TOPIC)
from eye_bci_ros2.regions import RegionSet
from eye_bci_ros2.rounds import ArbiterSettings, MAX_FUTURE_S, METHODS, RoundScheduler
from eye_bci_ros2.tolerance import CLASSIFICATIONS

#: choices/feedback shows at most this many options (one halo each, ~30 times a second).
MAX_FEEDBACK_OPTIONS = 256

#: Period of the timer that closes quiet rounds and releases held decisions, s.
TICK_S = 0.02


def _positive(value) -> Optional[str]:
    return None if value > 0 else f'must be > 0 s, got {value}'


def _open_unit_half(value) -> Optional[str]:
    return None if 0.5 < value < 1.0 else f'must be in the open interval (0.5, 1), got {value}'


def _settings_problem(values: dict) -> Optional[str]:
    """Return why the parameters make no valid ArbiterSettings (a combination), or None."""
    try:
        ArbiterSettings(**values)
    except ValueError as error:
        return str(error)
    return None


#: The defaults: those of the rounds' settings (one home).
DEFAULTS = ArbiterSettings()

PARAMETERS = (
    ParamSpec('method', DEFAULTS.method,
              'Decision rule: fixation = the option a still fixation of dwell_s clearly '
              'lands on (posterior from the gaze-error model, fresh fixations only; holds on '
              'real gaze: docs/selection.md); mean = the original rule (mean of the in-region '
              'samples must lie in a region); vote = region with most samples',
              choices=METHODS),
    ParamSpec('window_s', DEFAULTS.window_s,
              'Gaze collection time of a round, s of sample stamps from the round start',
              value_range=(0.0, 60.0), check=_positive),
    ParamSpec('early_decision', DEFAULTS.early_decision,
              'Decide before the window ends, as soon as the evidence for one option reaches '
              'confidence (fixation: a fresh still fixation of dwell_s on it; mean/vote: '
              'fresh in-region samples, min_samples / dwell_s / min_reaction_s); else at '
              'the window end'),
    ParamSpec('confidence', DEFAULTS.confidence,
              'Posterior probability of the leading option a choice needs (fixation: early '
              'and at the window end; mean/vote: the early decision)',
              value_range=(0.5, 1.0), check=_open_unit_half),
    ParamSpec('min_samples', DEFAULTS.min_samples,
              'Samples a deciding fixation must hold (fixation); fresh in-region samples an '
              'early decision needs, the most recent ones on the leader without interruption '
              '(mean/vote)',
              value_range=(1, 100000)),
    ParamSpec('dwell_s', DEFAULTS.dwell_s,
              'Time a fixation must last before it decides (fixation: longer than the '
              'transient landing before a corrective saccade), or the early run on the leader '
              'must span (mean/vote), s',
              value_range=(0.0, 10.0)),
    ParamSpec('min_reaction_s', DEFAULTS.min_reaction_s,
              'Shortest reaction to a new display, s: gaze resting on or near an option from '
              'before round start + min_reaction_s is not a reaction and counts only after '
              'the gaze has moved away (fixation: never chooses; mean/vote: the early '
              'decision only, the window end uses every sample); 0 = off',
              value_range=(0.0, MAX_REACTION_S)),
    ParamSpec('hit_rate', DEFAULTS.hit_rate,
              'Evidence model: probability that an in-region sample is on the looked-at region',
              value_range=(0.5, 1.0), check=_open_unit_half),
    ParamSpec('reorder_s', DEFAULTS.reorder_s,
              'Longest time a decision waits for a regions message that may apply to its '
              'last gaze samples (regions lagging gaze while the camera moves), s; 0 = '
              'decide at once (lowest latency); the wait ends as soon as regions stamped '
              'after those samples arrive',
              value_range=(0.0, 2.0)),
    ParamSpec('stall_timeout_s', DEFAULTS.stall_timeout_s,
              'When no gaze sample stamped after the window arrives, close the round this '
              'long after the window end (node clock), s',
              value_range=(0.0, 10.0)),
    ParamSpec('max_future_s', DEFAULTS.max_future_s,
              'Drop gaze samples stamped more than this after their arrival (node clock), s: '
              'only a corrupt stamp or a wrong clock does that, and one such sample would '
              'end the round at once; raise it only for a tracker clock known to run ahead',
              value_range=(0.0, MAX_FUTURE_S)),
    # The rule (eye_bci_ros2.rounds ArbiterSettings; a change applies from the next round).
    ParamSpec('classification', DEFAULTS.classification,
              'Which option a gaze sample counts for: tolerant = inside it, or near it (by the '
              'gaze-error model below) when clearly nearer to it than to any other option; '
              'inside = the original rule (inside only). With min_share 0 and method mean, '
              'inside gives the original decisions', choices=CLASSIFICATIONS),
    ParamSpec('accuracy_deg', DEFAULTS.accuracy_deg,
              "Gaze-error model: the tracker's accuracy for this person, degrees of visual "
              'angle (a validation measures it); with precision_deg the error the fixation '
              'rule and the tolerant classification expect', value_range=(0.0, 10.0)),
    ParamSpec('precision_deg', DEFAULTS.precision_deg,
              "Gaze-error model: the tracker's precision (sample-to-sample noise per axis), "
              'degrees', value_range=(0.0, 10.0)),
    ParamSpec('k_sigma', DEFAULTS.k_sigma,
              'Tolerant rule: tolerance in standard deviations of the radial gaze error '
              '(k_sigma x sqrt(accuracy^2 + 2 precision^2), below 30 deg)',
              value_range=(0.0, 10.0)),
    ParamSpec('ratio', DEFAULTS.ratio,
              'Tolerant rule: a sample outside every option counts for the nearest only when '
              'it is at most ratio times as far as the second nearest (gaze between two '
              'options counts for neither)', value_range=(0.0, 1.0),
              check=lambda v: None if v > 0 else f'must be in (0, 1], got {v}'),
    ParamSpec('size_aware', DEFAULTS.size_aware,
              "Tolerant rule: count the tolerance from the option's centre (none for options "
              'larger than the gaze error); false = from its edge'),
    ParamSpec('min_share', DEFAULTS.min_share,
              "Share test: a choice at the window end needs this fraction of the window's "
              'valid gaze samples on it, an early choice 0.8 of the samples of the last 0.1 s; '
              '0 = off (the original rule)', value_range=(0.0, 1.0)),
    # The person's screen: one table with gaze_validation's.
) + person_screen_parameters()

#: A gaze sample older than this (node clock) no longer highlights an option, s.
GAZED_STALE_S = 0.25

#: What the person is shown (choices/feedback), declared apart from the decision's settings.
FEEDBACK_PARAMETERS = (
    ParamSpec('feedback_rate_hz', 30.0,
              'choices/feedback: most messages per second (sent only when the highlight or '
              'the progress changed, and once a second); 0 = no feedback',
              value_range=(0.0, 240.0)),
    ParamSpec('feedback_confirm_s', 1.0,
              'choices/feedback: how long the chosen option is shown confirmed (green), s',
              value_range=(0.0, 60.0)),
)


#: Input modes (issue 11), declared apart from the gaze parameters (own table and callbacks).
FUSION_PARAMETERS = (
    ParamSpec('input_mode', 'gaze',
              'What chooses: gaze (the gaze decision), ssvep (ssvep/choice of the '
              'ssvep_decoder) or hybrid (a gaze decision is only a candidate; it is chosen '
              'when SSVEP confirms it, see eye_bci_ros2.fusion)', choices=INPUT_MODES),
    ParamSpec('confirm_threshold', 0.9,
              'hybrid: SSVEP posterior (ssvep/scores) of the gaze candidate that confirms it',
              value_range=(0.01, 1.0)),
    ParamSpec('max_lag_s', 5.0,
              'hybrid: longest time between the gaze candidate and the SSVEP evidence that '
              'confirms it, s', value_range=(0.0, 60.0)),
    ParamSpec('min_gaze_margin', 0.5,
              'hybrid: a gaze decision is a candidate only with at least this margin (share '
              "of in-region gaze on it minus the runner-up's): the gaze stayed on it",
              value_range=(0.0, 1.0)),
)


def _seconds(stamp) -> float:
    """builtin_interfaces/Time -> float s."""
    return stamp.sec + stamp.nanosec * 1e-9


class ChoiceArbiter(Node):
    """Turn gaze samples and the offered regions into one ``choice`` per round."""

    def __init__(self, **kwargs):
        """Declare parameters, topics and the round timer."""
        super().__init__('choice_arbiter', **kwargs)
        self._config = declare_parameters(self, PARAMETERS, self._on_parameters,
                                          _settings_problem)
        self._warnings = KeyedWarnings(self.get_logger())
        # Rounds that end without a choice, again and again, are not logged each (log_throttle).
        self._quiet = QuietRepeats(self.get_logger())
        self._tracker = RoundScheduler(ArbiterSettings(**self._config), self._publish, self._log)
        self._publisher = self.create_publisher(String, CHOICE_TOPIC, EVENT_QOS)
        self._none_publisher = self.create_publisher(String, NO_CHOICE_TOPIC, EVENT_QOS)
        # When the open round's decision can next come, for the bridge's batching
        # (topics.DECISION_DUE_TOPIC): (round start, due) last announced.
        self._due_publisher = self.create_publisher(Time, DECISION_DUE_TOPIC, LATCHED_QOS)
        self._announced: Optional[tuple] = None
        # Taken serialized and read with numpy (conversions.GazeCdr): no Python message.
        self._gaze_cdr = gaze_cdr()
        self.create_subscription(PointCloud2, GAZE_SAMPLES_TOPIC, self._on_gaze, GAZE_QOS,
                                 raw=True)
        # Says so when a second pipeline shares this graph (two eye_bci on one domain).
        self.graph_watch = GraphWatch(self, outputs=[CHOICE_TOPIC], inputs=[GAZE_SAMPLES_TOPIC])
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)
        self.create_subscription(Empty, REQUEST_TOPIC, self._on_request, EVENT_QOS)
        self._timer = self.create_timer(TICK_S, self._on_tick)
        self._init_fusion()
        self._init_feedback()
        config = self._config
        self.get_logger().info(
            f"choice_arbiter: method {config['method']}, window {config['window_s']} s, "
            f"early decision {'on' if config['early_decision'] else 'off'}, classification "
            f"{config['classification']}, min_share {config['min_share']}")

    # -- public state, for tests and tools ---------------------------------------------------

    @property
    def last_decision(self) -> Optional[Decision]:
        """Return the outcome of the last finished round."""
        return self._tracker.last_decision

    @property
    def settings(self) -> ArbiterSettings:
        """Return the decision settings in use (the rule; read them, never change them)."""
        return self._tracker.settings

    @property
    def rounds_started(self) -> int:
        """Return the number of rounds started since the node started."""
        return self._tracker.rounds_started

    @property
    def samples_received(self) -> int:
        """Return the number of gaze samples taken since the node started."""
        return self._tracker.samples_received

    @property
    def round_start(self) -> Optional[float]:
        """Return the open round's start, s on the node clock (None when none is open)."""
        return self._tracker.round_start

    @property
    def samples_from_future(self) -> int:
        """Return the number of gaze samples dropped for a stamp after max_future_s."""
        return self._tracker.samples_from_future

    @property
    def samples_too_old(self) -> int:
        """Return the number of gaze samples dropped for a stamp too old for any round."""
        return self._tracker.samples_too_old

    @property
    def samples_not_finite(self) -> int:
        """Return the number of NaN or infinite gaze samples (taken as in no region)."""
        return self._tracker.samples_not_finite

    # -- parameters -------------------------------------------------------------------------

    def _on_parameters(self, changed: dict) -> None:
        self._config.update(changed)
        self._tracker.configure(**changed)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- inputs -----------------------------------------------------------------------------

    def _on_gaze(self, data: bytes) -> None:
        try:
            stamps, points, stamped = self._gaze_cdr.read(data)
        except ValueError as error:
            self._log('warning', 'gaze_bad', str(error))
            return
        try:
            now = self._now()
            if not stamped:
                stamps = stamps + now   # unstamped: taken as arriving now (offsets kept)
            if len(points):
                self._newest = (float(points[-1, 0]), float(points[-1, 1]), now)
            self._tracker.add_samples(stamps, points, now)
            self._announce_due(now)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'gaze_error', f'gaze batch ignored: {error}')

    def _on_regions(self, msg: MarkerArray) -> None:
        try:
            now = self._now()
            labels, polygons = marker_array_to_regions(msg)
            stamp = _seconds(msg.markers[0].header.stamp) if msg.markers else 0.0
            region_set = RegionSet(labels, polygons, stamp or now)
        except (ValueError, IndexError, AttributeError) as error:
            self._log('warning', 'regions_bad', f'regions message ignored: {error}')
            return
        try:
            self._tracker.add_regions(region_set, now)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'regions_error', f'failed to apply regions: {error}')
        self._announce_due()
        self._fusion_options(labels)

    def _on_request(self, msg: Empty) -> None:
        self._fusion.new_round()
        try:
            self._tracker.request(self._now())
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'request_error', f'failed to start a round: {error}')
        self._announce_due()

    def _announce_due(self, now: Optional[float] = None) -> None:
        """
        Publish when the open round's decision can next come (choice/due), if that changed.

        With the early decision: the earliest one (round start + dwell_s: every rule's
        deciding run or fixation spans dwell_s) until the node clock passes it, and the
        time the current fixation can first decide (the fixation rule's ``next_due``)
        while no sample stamped after it has come; else the window end.
        """
        start = self._tracker.round_start
        if start is None:
            return
        settings = self._tracker.settings
        due = start + settings.window_s
        if settings.early_decision:
            early = start + settings.dwell_s
            if now is None or now < early:
                due = min(due, early)
            evidence = self._tracker.evidence
            next_due = getattr(evidence, 'next_due', None)
            fixation_due = next_due() if next_due is not None else None
            if fixation_due is not None and fixation_due > evidence.last_stamp:
                due = min(due, fixation_due)
        if (start, due) != self._announced:
            self._announced = (start, due)
            self._due_publisher.publish(ns_to_stamp(int(round(due * 1e9))))

    def _on_tick(self) -> None:
        try:
            now = self._now()
            self._tracker.tick(now)
            self._announce_due(now)
        except Exception as error:  # noqa: B902 - a node never dies on a timer
            self._log('warning', 'tick_error', f'failed to close a round: {error}')

    # -- outputs ----------------------------------------------------------------------------

    def _publish(self, decision: Decision) -> None:
        # Input mode 'gaze' (default): the decision's label, as before.
        label = self._fusion.gaze(decision.label, self._now(), decision.margin)
        if label is not None:
            self._choose(label)
            return
        # A round that cannot lead to a choice: no gaze choice (gaze), no candidate (hybrid).
        mode = self._fusion.settings.mode
        if (mode == 'gaze' and decision.label is None) or (
                mode == 'hybrid' and self._fusion.candidate is None
                and not self._fusion.chosen):
            reason = decision.reason or f"gaze on '{decision.label}' too unsteady for a candidate"
            self._none_publisher.publish(String(data=reason))

    def _choose(self, label: str) -> None:
        """Publish ``choice`` and show it confirmed on choices/feedback."""
        self._publisher.publish(String(data=label))
        self._chosen = (label, self._now() + self._feedback_values['feedback_confirm_s'],
                        self._options.get(label))

    def _log(self, level: str, key: str, text: str) -> None:
        """Log ``text``; warnings of one ``key`` at most once per WARN_PERIOD_S."""
        if level != 'warning':
            if text.startswith('choice '):
                self._quiet.reset()      # a choice is news: the rounds after it are shown again
            self._quiet.info(text)
            return
        self._warnings.warn(key, text)

    # -- input modes: gaze / ssvep / hybrid (issue 11; eye_bci_ros2.fusion) -------------------

    def _init_fusion(self) -> None:
        """Declare the input-mode parameters and subscribe the SSVEP decoder's output."""
        values = declare_parameters(self, FUSION_PARAMETERS, self._on_fusion_parameters,
                                    self._check_fusion)
        self._fusion_values = dict(values)
        self._fusion = ChoiceFusion(self._fusion_settings(values))
        self._fusion_labels = None
        self.create_subscription(String, SSVEP_CHOICE_TOPIC, self._on_ssvep_choice, EVENT_QOS)
        self.create_subscription(JointState, SSVEP_SCORES_TOPIC, self._on_ssvep_scores,
                                 SCORES_QOS)
        if values['input_mode'] != 'gaze':
            self.get_logger().info(f"input mode {values['input_mode']}: "
                                   + ('the SSVEP choice chooses' if values['input_mode'] ==
                                      'ssvep' else 'gaze candidates need SSVEP confirmation'))

    @staticmethod
    def _fusion_settings(values: dict) -> FusionSettings:
        return FusionSettings(values['input_mode'], values['confirm_threshold'],
                              values['max_lag_s'], values['min_gaze_margin'])

    def _check_fusion(self, values: dict) -> Optional[str]:
        try:
            self._fusion_settings(values)
        except ValueError as error:
            return str(error)
        return None

    def _on_fusion_parameters(self, changed: dict) -> None:
        self._fusion_values.update(changed)
        self._fusion.configure(self._fusion_settings(self._fusion_values))

    def _fusion_options(self, labels) -> None:
        """Start a new fusion round when the set of offered labels changes."""
        labels = tuple(labels)
        if labels != self._fusion_labels:
            self._fusion_labels = labels
            self._fusion.new_round(labels)

    def _on_ssvep_choice(self, msg: String) -> None:
        try:
            label = self._fusion.ssvep_choice(msg.data, self._now())
            if label is not None:
                self._choose(label)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'ssvep_error', f'SSVEP choice ignored: {error}')

    def _on_ssvep_scores(self, msg: JointState) -> None:
        try:
            if len(msg.name) != len(msg.position):
                self._log('warning', 'ssvep_scores', 'ssvep/scores ignored: name and '
                          'position (posterior) differ in length')
                return
            label = self._fusion.ssvep_scores(list(msg.name), list(msg.position), self._now())
            if label is not None:
                self._choose(label)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'ssvep_error', f'SSVEP scores ignored: {error}')

    # -- feedback: choices/feedback (eye_bci_ros2.feedback, nodes/feedback_markers) --------

    def _init_feedback(self) -> None:
        """Declare the feedback parameters, subscribe the options, start the feedback timer."""
        self._feedback_values = dict(declare_parameters(
            self, FEEDBACK_PARAMETERS, self._on_feedback_parameters))
        self._options = OptionMarkers()
        self._halos = FeedbackMarkers()
        self._newest: Optional[tuple] = None     # (x, y, arrival s) of the newest sample
        self._chosen: Optional[tuple] = None     # (label, shown until s, option marker)
        self._options_changed = False
        self._feedback_pub = self.create_publisher(MarkerArray, FEEDBACK_TOPIC, FEEDBACK_QOS)
        self.create_subscription(MarkerArray, CHOICES_TOPIC, self._on_choices, CHOICES_QOS)
        self._feedback_timer = None
        self._throttle = FeedbackThrottle()
        self._start_feedback(self._feedback_values['feedback_rate_hz'])

    def _start_feedback(self, rate_hz: float) -> None:
        """(Re)start the feedback timer at ``rate_hz`` (0: stop, withdraw the halos)."""
        if self._feedback_timer is not None:
            self.destroy_timer(self._feedback_timer)
            self._feedback_timer = None
        if rate_hz > 0:
            # The timer sets the rate; the throttle's own period is shorter, so its timer
            # jitter never halves it, and the throttle decides only whether anything changed.
            self._throttle = FeedbackThrottle(max_rate_hz=2.0 * rate_hz)
            self._feedback_timer = self.create_timer(1.0 / rate_hz, self._on_feedback_timer)
        elif self._halos.shown:
            withdrawn = self._halos.update(Feedback(()), [], self.get_clock().now().to_msg())
            if withdrawn is not None:
                self._feedback_pub.publish(withdrawn)

    def _on_feedback_parameters(self, changed: dict) -> None:
        self._feedback_values.update(changed)
        if 'feedback_rate_hz' in changed:
            self._start_feedback(changed['feedback_rate_hz'])

    def _on_choices(self, msg: MarkerArray) -> None:
        try:
            problems = self._options.apply(msg)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            problems = [f'choices message ignored: {error}']
        if problems:
            self._log('warning', 'choices_bad', 'choices: ' + '; '.join(problems[:5]))
        self._options_changed = True

    def current_feedback(self, now: float) -> tuple:
        """
        Return what choices/feedback shows at ``now`` (node clock, s): (Feedback, options).

        The options are the ``choices`` markers, plus the option just chosen while it is
        shown confirmed even if the menu has withdrawn it.
        """
        options = self._options.options
        chosen = None
        if self._chosen is not None:
            label, until, marker = self._chosen
            if now < until:
                chosen = label
                keys = {(m.ns, m.id) for m in options}
                if marker is not None and (marker.ns, marker.id) not in keys:
                    options = options + [marker]
            else:
                self._chosen = None
        gazed = None
        if self._newest is not None and now - self._newest[2] <= GAZED_STALE_S:
            gazed = self._tracker.label_at(self._newest[0], self._newest[1])
        feedback = build_feedback([option_label(m) for m in options], gazed=gazed,
                                  chosen=chosen, progress=self._tracker.progress(),
                                  stamp=now)
        return feedback, options

    def _on_feedback_timer(self) -> None:
        try:
            count = len(self._options.options)
            if count > MAX_FEEDBACK_OPTIONS:
                # No menu a person chooses from by gaze has that many: do not flood RViz.
                self._log('warning', 'feedback_options',
                          f'choices/feedback paused: {count} options offered, more than '
                          f'{MAX_FEEDBACK_OPTIONS}')
                return
            now = self._now()
            feedback, options = self.current_feedback(now)
            if not (self._throttle.due(feedback, now) or self._options_changed):
                return
            self._options_changed = False
            message = self._halos.update(feedback, options, self.get_clock().now().to_msg())
            if message is not None:
                self._feedback_pub.publish(message)
        except Exception as error:  # noqa: B902 - a node never dies on a timer
            self._log('warning', 'feedback_error', f'feedback not sent: {error}')


def main(args=None):
    """Run the choice_arbiter node."""
    spin_node(ChoiceArbiter, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
