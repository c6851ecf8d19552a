"""
Node choice_arbiter: decide from gaze which offered region the person chose.

Subscribes ``gaze/samples`` (sensor_msgs/PointCloud2 batches, frame
``screen``, px, every sample with its acquisition stamp; see
:mod:`eye_bci_ros2.ros.conversions`), ``choices/regions``
(visualization_msgs/MarkerArray, latched) and ``choice/request``
(std_msgs/Empty); publishes ``choice`` (std_msgs/String, the region's label:
its text if set, else ``ns/id``) and ``choice/none`` (std_msgs/String, why a
round ended without a choice; input mode gaze), so a menu can ask again; and
``choice/due`` (builtin_interfaces/Time, latched): when the open round's
decision can next come (round start + ``dwell_s``, then the window end), so
the bridge pulls gaze promptly then and in bigger batches otherwise.

The rounds (when they start and end, which samples and regions they weigh,
when a decision is final, what is dropped as implausible) are
:class:`eye_bci_ros2.decision.rounds.RoundScheduler`, the rules
:mod:`eye_bci_ros2.decision.evidence`: this node converts messages and keeps the
clock.  Each gaze batch is weighed in its own callback, so ``choice`` is
published from the callback of the batch that completes the decision; a
50 Hz timer only closes rounds whose gaze stream went quiet and releases
decisions held by ``reorder_s``.  Bad input is counted
(:attr:`ChoiceArbiter.samples_from_future`, ``samples_too_old``,
``samples_not_finite``) and logged at most once per 5 s of each kind.

Rule (``classification`` and the share test ``min_share``; eye_bci_ros2.decision.rounds
ArbiterSettings).  Default: the size-aware tolerant rule (a sample near an option counts
for it when it is clearly nearer to it than to any other, by a gaze-error model in
degrees on the person's screen, ``accuracy_deg``, ``precision_deg``, ``k_sigma``,
``screen_*``) with the share test, for the window-end and early decisions alike.
``classification:=inside min_share:=0.0`` (with ``method:=mean``) is the original rule.
A change of the rule applies from the next round on.

The node is composed of two adapters that take it and own their part
(parameters, topics, state): :class:`~eye_bci_ros2.nodes.choice_arbiter.feedback.FeedbackPublisher`
(``choices`` -> ``choices/feedback``: the gazed option, the progress, the choice
confirmed) and :class:`~eye_bci_ros2.nodes.choice_arbiter.fusion.FusionInput` (parameter
``input_mode`` and the ssvep_decoder's ``ssvep/choice`` and ``ssvep/scores``,
:mod:`eye_bci_ros2.decision.fusion`).  Input modes: ``gaze`` (default): as above.
``ssvep``: ``choice`` is the ``ssvep/choice`` of the ssvep_decoder
(std_msgs/String) when it names an offered option, once per round; the gaze
decision is not published.  ``hybrid``: gaze alone never chooses: a round's
gaze decision with a margin of at least ``min_gaze_margin`` is a candidate,
published as ``choice`` only when SSVEP confirms it within ``max_lag_s``
(``ssvep/choice`` of the same label, or ``ssvep/scores`` (sensor_msgs/JointState,
position = posterior) of at least ``confirm_threshold`` for it).
"""

from typing import Optional

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.decision.camera_view import ViewGate
from eye_bci_ros2.decision.evidence import Decision
from eye_bci_ros2.decision.fusion import FusionOutcome, HYBRID
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, RoundScheduler
from eye_bci_ros2.nodes.choice_arbiter.feedback import FEEDBACK_PARAMETERS, FeedbackPublisher
from eye_bci_ros2.nodes.choice_arbiter.fusion import FUSION_PARAMETERS, FusionInput
from eye_bci_ros2.recordings.session_markers import decision_detail
from eye_bci_ros2.ros.conversions import (gaze_cdr, marker_array_to_regions, ns_to_stamp,
                                          pose_view, regions_camera_view)
from eye_bci_ros2.ros.graph_watch import GraphWatch
from eye_bci_ros2.ros.log_throttle import KeyedWarnings, QuietRepeats
from eye_bci_ros2.ros.node_clock import NodeClock
from eye_bci_ros2.ros.parameters import param_specs, SettingsParameters
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.topics import (CAMERA_POSE_TOPIC, CHOICE_DETAIL_TOPIC, CHOICE_TOPIC,
                                     DECISION_DUE_TOPIC, EVENT_QOS, GAZE_QOS,
                                     GAZE_SAMPLES_TOPIC, LATCHED_QOS, NO_CHOICE_TOPIC,
                                     REGIONS_TOPIC, REQUEST_TOPIC)

#: Period of the timer that closes quiet rounds, releases held decisions and updates the
#: feedback between gaze batches (the feedback module's doc), s: a round
#: whose stream went quiet closes up to this long after its stall timeout, a held decision
#: up to this long after ``reorder_s``.  Every decision that gaze completes is made when
#: that gaze arrives, never on a tick; each tick's wake-up costs about 0.1 ms of CPU
#: (``python -m bench.lab_rate``, part ``wake_up``), so the tick is no faster than needed.
TICK_S = 0.04

#: The decision's parameters: one per ArbiterSettings field, declared there (one home).
DECISION_PARAMETERS = param_specs(ArbiterSettings)

#: Every parameter of the node, in declaration order (help text, tools): the decision's,
#: then those of its adapters (input modes, feedback).
PARAMETERS = DECISION_PARAMETERS + FUSION_PARAMETERS + FEEDBACK_PARAMETERS


def _seconds(stamp) -> float:
    """builtin_interfaces/Time -> float s."""
    return stamp.sec + stamp.nanosec * 1e-9


class ChoiceArbiter(Node):
    """Turn gaze samples and the offered regions into one ``choice`` per round."""

    def __init__(self, **kwargs):
        """Declare parameters, topics and the round timer."""
        super().__init__('choice_arbiter', **kwargs)
        # Read several times per gaze batch, without a Time object.
        self._time = NodeClock(self)
        self._decision = SettingsParameters(self, ArbiterSettings, self._on_parameters)
        self._warnings = KeyedWarnings(self.get_logger())
        # Rounds that end without a choice, again and again, are not logged each (log_throttle).
        self._quiet = QuietRepeats(self.get_logger())
        # A round's opening line repeats at every question while the options stay the same:
        # after the first it goes to DEBUG, across choices too (a choice ends the run of the
        # other lines, not this one); new options are news again. An INFO line costs about
        # 1.3 ms of Python in rclpy (docs/performance.md).
        self._round_lines = QuietRepeats(self.get_logger())
        self._rounds = RoundScheduler(self._decision.settings, self._publish, self._log)
        self._publisher = self.create_publisher(String, CHOICE_TOPIC, EVENT_QOS)
        self._none_publisher = self.create_publisher(String, NO_CHOICE_TOPIC, EVENT_QOS)
        # Each outcome in full for the session's markers (topics.CHOICE_DETAIL_TOPIC): the
        # gaze decision being handed to the input modes, whose outcome it may be, and the
        # round's last gaze decision with a label (hybrid: the candidate SSVEP may confirm).
        self._detail_publisher = self.create_publisher(String, CHOICE_DETAIL_TOPIC, EVENT_QOS)
        self._deciding: Optional[Decision] = None
        self._gaze_choice: Optional[Decision] = None
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
        self._views: ViewGate[MarkerArray] = ViewGate()
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)
        self.create_subscription(PoseStamped, CAMERA_POSE_TOPIC, self._on_camera, LATCHED_QOS)
        self.create_subscription(Empty, REQUEST_TOPIC, self._on_request, EVENT_QOS)
        self._timer = self.create_timer(TICK_S, self._on_tick)
        self._fusion = FusionInput(self, self._on_outcome, self._log, self._now)
        self._feedback = FeedbackPublisher(self, self._rounds, self._log)
        config = self._decision.settings
        self.get_logger().info(
            f'choice_arbiter: method {config.method}, window {config.window_s} s, '
            f"early decision {'on' if config.early_decision else 'off'}, classification "
            f'{config.classification}, min_share {config.min_share}')

    # -- public state, for tests and tools ---------------------------------------------------

    @property
    def last_decision(self) -> Optional[Decision]:
        """Return the outcome of the last finished round."""
        return self._rounds.last_decision

    @property
    def settings(self) -> ArbiterSettings:
        """Return the decision settings in use (the rule; read them, never change them)."""
        return self._rounds.settings

    @property
    def rounds_started(self) -> int:
        """Return the number of rounds started since the node started."""
        return self._rounds.rounds_started

    @property
    def regions(self) -> Optional[RegionSet]:
        """Return the newest regions in use (None before the first)."""
        return self._rounds.newest_regions

    @property
    def regions_ignored(self) -> int:
        """Return the number of regions messages ignored: made for another camera view."""
        return self._views.ignored

    @property
    def samples_received(self) -> int:
        """Return the number of gaze samples taken since the node started."""
        return self._rounds.samples_received

    @property
    def round_start(self) -> Optional[float]:
        """Return the open round's start, s on the node clock (None when none is open)."""
        return self._rounds.round_start

    @property
    def samples_from_future(self) -> int:
        """Return the number of gaze samples dropped for a stamp after max_future_s."""
        return self._rounds.samples_from_future

    @property
    def samples_too_old(self) -> int:
        """Return the number of gaze samples dropped for a stamp too old for any round."""
        return self._rounds.samples_too_old

    @property
    def samples_not_finite(self) -> int:
        """Return the number of NaN or infinite gaze samples (taken as in no region)."""
        return self._rounds.samples_not_finite

    # -- parameters -------------------------------------------------------------------------

    def _on_parameters(self, settings: ArbiterSettings, changed: dict) -> None:
        self._rounds.configure(**changed)

    def _now(self) -> float:
        return self._time.seconds()

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
                self._feedback.gaze_at(float(points[-1, 0]), float(points[-1, 1]), now)
            self._rounds.add_samples(stamps, points, now)
            self._announce_due(now)
            self._feedback.update(now)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'gaze_error', f'gaze batch ignored: {error}')

    def _on_camera(self, msg: PoseStamped) -> None:
        """Take the camera view on screen; use the regions held for it, if any."""
        held = self._views.camera(pose_view(msg.pose))
        if held is not None:
            self._use_regions(held)

    def _on_regions(self, msg: MarkerArray) -> None:
        # Only regions made for the camera view on camera/pose (decision.camera_view): a
        # second pipeline's projector on this graph shows another view.
        try:
            view = regions_camera_view(msg)
        except AttributeError as error:
            self._log('warning', 'regions_bad', f'regions message ignored: {error}')
            return
        if self._views.offer(view, msg, self._now()):
            self._use_regions(msg)

    def _use_regions(self, msg: MarkerArray) -> None:
        try:
            now = self._now()
            labels, polygons = marker_array_to_regions(msg)
            stamp = _seconds(msg.markers[0].header.stamp) if msg.markers else 0.0
            region_set = RegionSet(labels, polygons, stamp or now)
        except (ValueError, IndexError, AttributeError) as error:
            self._log('warning', 'regions_bad', f'regions message ignored: {error}')
            return
        if region_set.label_set != self._rounds.offered:
            self._round_lines.reset()
        try:
            self._rounds.add_regions(region_set, now)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'regions_error', f'failed to apply regions: {error}')
        self._announce_due()
        self._fusion.offered(labels)

    def _on_request(self, msg: Empty) -> None:
        self._gaze_choice = None
        self._fusion.new_round()
        try:
            self._rounds.request(self._now())
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'request_error', f'failed to start a round: {error}')
        self._announce_due()

    def _announce_due(self, now: Optional[float] = None) -> None:
        """Publish when the open round's decision can next come (choice/due), if that changed."""
        start = self._rounds.round_start
        due = self._rounds.next_due(now)
        if due is None:
            return
        if (start, due) != self._announced:
            self._announced = (start, due)
            self._due_publisher.publish(ns_to_stamp(int(round(due * 1e9))))

    def _on_tick(self) -> None:
        try:
            now = self._now()
            for view in self._views.expired(now):
                self._log('warning', 'regions_other_view',
                          'regions projected from another camera view '
                          f'({", ".join(f"{value:.3g}" for value in view[:3])}) than '
                          f'{CAMERA_POSE_TOPIC} shows are ignored: another pipeline on this '
                          'graph? Give each its own namespace (__ns:=/name) or ROS_DOMAIN_ID')
            self._rounds.tick(now)
            self._announce_due(now)
            self._feedback.update(now)
        except Exception as error:  # noqa: B902 - a node never dies on a timer
            self._log('warning', 'tick_error', f'failed to close a round: {error}')

    # -- outputs ----------------------------------------------------------------------------

    def _publish(self, decision: Decision) -> None:
        """Hand a round's gaze decision to the input modes (they choose, or end the round)."""
        self._deciding = decision
        if decision.label is not None:
            self._gaze_choice = decision
        try:
            self._fusion.gaze(decision)
        finally:
            self._deciding = None

    def _on_outcome(self, outcome: FusionOutcome) -> None:
        """Publish what the input modes decided: ``choice``, or why none (``choice/none``)."""
        mode = self._fusion.parameters.settings.input_mode
        decision = self._deciding
        if decision is None and mode == HYBRID and self._gaze_choice is not None \
                and self._gaze_choice.label == outcome.choice:
            decision = self._gaze_choice      # SSVEP confirmed this gaze candidate
        self._detail_publisher.publish(String(data=decision_detail(
            decision, outcome.choice, outcome.no_choice, mode, self.settings.method,
            self._time.ns())))
        if outcome.choice is not None:
            self._publisher.publish(String(data=outcome.choice))
            self._feedback.confirm(outcome.choice, self._now())
        elif outcome.no_choice is not None:
            self._none_publisher.publish(String(data=outcome.no_choice))

    def current_feedback(self, now: float) -> tuple:
        """Return what choices/feedback shows at ``now`` (node clock, s): (Feedback, options)."""
        return self._feedback.current(now)

    def _log(self, level: str, key: str, text: str) -> None:
        """Log ``text``; warnings of one ``key`` at most once per WARN_PERIOD_S."""
        if level != 'warning':
            if key == 'round':
                self._round_lines.info(text)
                return
            if text.startswith('choice '):
                self._quiet.reset()      # a choice is news: the rounds after it are shown again
            self._quiet.info(text)
            return
        self._warnings.warn(key, text)


def main(args=None):
    """Run the choice_arbiter node."""
    spin_node(ChoiceArbiter, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
