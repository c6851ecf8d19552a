"""
Node choice_arbiter: decide from gaze which offered region the person chose.

Subscribes ``gaze/samples`` (sensor_msgs/PointCloud2 batches, frame
``screen``, px, every sample with its acquisition stamp; see
:mod:`eye_bci_ros2.nodes.conversions`), ``choices/regions``
(visualization_msgs/MarkerArray, latched) and ``choice/request``
(std_msgs/Empty); publishes ``choice`` (std_msgs/String, the region's label:
its text if set, else ``ns/id``) and ``choice/none`` (std_msgs/String, why a
round ended without a choice; input mode gaze), so a menu can ask again.

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

from rclpy.node import Node
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.evidence import Decision, MAX_REACTION_S, METHODS
from eye_bci_ros2.fusion import ChoiceFusion, FusionSettings, INPUT_MODES
from eye_bci_ros2.nodes.conversions import gaze_batch_arrays, marker_array_to_regions
from eye_bci_ros2.nodes.log_throttle import KeyedWarnings
from eye_bci_ros2.nodes.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.nodes.runner import spin_node
from eye_bci_ros2.nodes.topics import (CHOICE_TOPIC, EVENT_QOS, GAZE_QOS, GAZE_SAMPLES_TOPIC,
                                       LATCHED_QOS, NO_CHOICE_TOPIC, REQUEST_TOPIC, SCORES_QOS,
                                       SSVEP_CHOICE_TOPIC, SSVEP_SCORES_TOPIC)
from eye_bci_ros2.regions import RegionSet
from eye_bci_ros2.rounds import ArbiterSettings, MAX_FUTURE_S, RoundScheduler

#: Period of the timer that closes quiet rounds and releases held decisions, s.
TICK_S = 0.02


def _positive(value) -> Optional[str]:
    return None if value > 0 else f'must be > 0 s, got {value}'


def _open_unit_half(value) -> Optional[str]:
    return None if 0.5 < value < 1.0 else f'must be in the open interval (0.5, 1), got {value}'


#: The defaults: those of the rounds' settings (one home).
DEFAULTS = ArbiterSettings()

PARAMETERS = (
    ParamSpec('method', DEFAULTS.method,
              'Decision rule at the window end: mean = the original rule (mean of the '
              'in-region samples must lie in a region), vote = region with most samples',
              choices=METHODS),
    ParamSpec('window_s', DEFAULTS.window_s,
              'Gaze collection time of a round, s of sample stamps from the round start',
              value_range=(0.0, 60.0), check=_positive),
    ParamSpec('early_decision', DEFAULTS.early_decision,
              'Decide before the window ends once the fresh evidence for one region reaches '
              'confidence (and min_samples / dwell_s / min_reaction_s hold); the defaults of '
              'those are the configuration bench/decision.py selects'),
    ParamSpec('confidence', DEFAULTS.confidence,
              'Posterior probability of the leading region needed for an early decision',
              value_range=(0.5, 1.0), check=_open_unit_half),
    ParamSpec('min_samples', DEFAULTS.min_samples,
              'Early decision: fresh in-region samples needed, and the most recent ones the '
              'leading region must hold without interruption',
              value_range=(1, 100000)),
    ParamSpec('dwell_s', DEFAULTS.dwell_s,
              'Early decision: sample time the uninterrupted run on the leading region must '
              'span, s (keeps a saccade that crosses a region from choosing it, at any '
              'tracker rate)',
              value_range=(0.0, 10.0)),
    ParamSpec('min_reaction_s', DEFAULTS.min_reaction_s,
              'Early decision: shortest reaction to a new display, s; gaze on a region from '
              'before round start + min_reaction_s (a gaze already resting there) counts '
              'only after it has moved to another region; 0 = off. The window-end rule '
              'always uses every sample',
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
        self._config = declare_parameters(self, PARAMETERS, self._on_parameters)
        self._warnings = KeyedWarnings(self.get_logger())
        self._tracker = RoundScheduler(ArbiterSettings(**self._config), self._publish, self._log)
        self._publisher = self.create_publisher(String, CHOICE_TOPIC, EVENT_QOS)
        self._none_publisher = self.create_publisher(String, NO_CHOICE_TOPIC, EVENT_QOS)
        self.create_subscription(PointCloud2, GAZE_SAMPLES_TOPIC, self._on_gaze, GAZE_QOS)
        self.create_subscription(MarkerArray, 'choices/regions', self._on_regions, LATCHED_QOS)
        self.create_subscription(Empty, REQUEST_TOPIC, self._on_request, EVENT_QOS)
        self._timer = self.create_timer(TICK_S, self._on_tick)
        self._init_fusion()
        self.get_logger().info(
            f"choice_arbiter: method {self._config['method']}, window "
            f"{self._config['window_s']} s, early decision "
            f"{'on' if self._config['early_decision'] else 'off'}")

    # -- public state, for tests and tools ---------------------------------------------------

    @property
    def last_decision(self) -> Optional[Decision]:
        """Return the outcome of the last finished round."""
        return self._tracker.last_decision

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

    def _on_gaze(self, msg: PointCloud2) -> None:
        try:
            stamps, points = gaze_batch_arrays(msg)
        except ValueError as error:
            self._log('warning', 'gaze_bad', str(error))
            return
        try:
            now = self._now()
            if not (msg.header.stamp.sec or msg.header.stamp.nanosec):
                stamps = stamps + now   # unstamped: taken as arriving now (offsets kept)
            self._tracker.add_samples(stamps, points, now)
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
        self._fusion_options(labels)

    def _on_request(self, msg: Empty) -> None:
        self._fusion.new_round()
        try:
            self._tracker.request(self._now())
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'request_error', f'failed to start a round: {error}')

    def _on_tick(self) -> None:
        try:
            self._tracker.tick(self._now())
        except Exception as error:  # noqa: B902 - a node never dies on a timer
            self._log('warning', 'tick_error', f'failed to close a round: {error}')

    # -- outputs ----------------------------------------------------------------------------

    def _publish(self, decision: Decision) -> None:
        # Input mode 'gaze' (default): the decision's label, as before.
        label = self._fusion.gaze(decision.label, self._now(), decision.margin)
        if label is not None:
            self._publisher.publish(String(data=label))
            return
        # A round that cannot lead to a choice: no gaze choice (gaze), no candidate (hybrid).
        mode = self._fusion.settings.mode
        if (mode == 'gaze' and decision.label is None) or (
                mode == 'hybrid' and self._fusion.candidate is None
                and not self._fusion.chosen):
            reason = decision.reason or f"gaze on '{decision.label}' too unsteady for a candidate"
            self._none_publisher.publish(String(data=reason))

    def _log(self, level: str, key: str, text: str) -> None:
        """Log ``text``; warnings of one ``key`` at most once per WARN_PERIOD_S."""
        if level != 'warning':
            self.get_logger().info(text)
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
                self._publisher.publish(String(data=label))
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
                self._publisher.publish(String(data=label))
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'ssvep_error', f'SSVEP scores ignored: {error}')


def main(args=None):
    """Run the choice_arbiter node."""
    spin_node(ChoiceArbiter, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
