"""
Node choice_arbiter: decide from gaze which offered region the person chose.

Subscribes ``gaze`` (geometry_msgs/PointStamped, frame ``screen``, px),
``choices/regions`` (visualization_msgs/MarkerArray, latched) and
``choice/request`` (std_msgs/Empty); publishes ``choice`` (std_msgs/String,
the region's label: its text if set, else ``ns/id``).

Rounds.  A round starts on ``choice/request`` (at the node clock's now) or
when the *set* of offered labels changes (at the regions' header stamp; a
stamp older than ``window_s`` is taken as the arrival time).  Regions that
only move (same labels, new geometry) update the round's geometry.  A new
round replaces an unfinished one without a choice.  The round uses the gaze
samples stamped in ``[start, start + window_s)``: like the original, which
collected gaze for a fixed time after the question, the window is fixed and
measured on the samples' stamps from the round start (not from the first
in-region sample, so a person who never looks at a region still gets an
answer, "no choice", on time).  It ends when a sample stamped after the
window arrives, or ``stall_timeout_s`` after the window on the node clock if
the gaze stream goes quiet, and publishes at most one ``choice`` (none when
no sample fell in a region, or the mean fell in none).  With
``early_decision`` it ends as soon as the evidence passes ``confidence``
(see :mod:`eye_bci_ros2.arbitration`).  That evidence is only *fresh* gaze:
gaze that was on a region before the round start + ``min_reaction_s``
(sooner than any person reacts to the new display) counts only once it has
moved to another region, so the option that lies where the gaze rested on
the previous menu is not chosen by accident; a gaze that never leaves it is
decided at the window end by ``method``, on every sample.  The next round
starts on the next request or change of the offered labels.

Bad gaze.  A sample stamped more than ``max_future_s`` after it arrived
(node clock) is dropped: a corrupt stamp or a wrong clock, which would
otherwise end the round at once and lose the gaze that follows.  A sample
stamped more than ``window_s`` before the round start (between rounds,
before now - 2 ``window_s``) is dropped as no round can use it.  A NaN or
infinite gaze point is a sample in no region, never evidence.  Each is
counted (:attr:`ChoiceArbiter.samples_from_future`,
:attr:`ChoiceArbiter.samples_too_old`,
:attr:`ChoiceArbiter.samples_not_finite`) and logged as a warning at most
once per 5 s of each kind.

Latency.  Each gaze sample is classified in its own callback against the
regions shown at its stamp (the newest set in the steady state, O(1) work),
so the ``choice`` is published from the callback of the sample that
completes the decision; a 50 Hz timer only closes rounds whose gaze stream
went quiet and releases decisions held by ``reorder_s``.

Ordering.  Gaze and regions come on separate topics, so a sample can arrive
before the regions message stamped just before it.  Such a message
re-classifies the open round's samples stamped after it (rare, O(round)),
and a round started by new choices at a past stamp takes the samples
stamped after that which arrived first.
With ``reorder_s`` 0 (default) a decision is final when made: a regions
message that comes later with a stamp before the decision's last sample is
logged as a warning and does not change it.  With ``reorder_s`` > 0 a
decision whose last sample is newer than the newest regions waits until
regions stamped after that sample arrive, or ``reorder_s``, whichever is
first (see :class:`eye_bci_ros2.arbitration.ChoiceTracker`).

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

import time
from typing import Dict, Optional

from geometry_msgs.msg import PointStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.arbitration import (ArbiterSettings, ChoiceTracker, Decision,
                                      DEFAULT_MAX_FUTURE_S, MAX_FUTURE_S,
                                      MAX_REACTION_S, METHODS, RegionSet)
from eye_bci_ros2.fusion import ChoiceFusion, FusionSettings, INPUT_MODES
from eye_bci_ros2.nodes.conversions import marker_array_to_regions, SCREEN_FRAME
from eye_bci_ros2.nodes.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.nodes.qos import EVENT_QOS, GAZE_QOS, LATCHED_QOS
from eye_bci_ros2.nodes.runner import spin_node

#: Period of the timer that closes quiet rounds and releases held decisions, s.
TICK_S = 0.02

#: Throttle period of repeatable warnings, s.
WARN_PERIOD_S = 5.0


def _positive(value) -> Optional[str]:
    return None if value > 0 else f'must be > 0 s, got {value}'


def _open_unit_half(value) -> Optional[str]:
    return None if 0.5 < value < 1.0 else f'must be in the open interval (0.5, 1), got {value}'


PARAMETERS = (
    ParamSpec('method', 'mean',
              'Decision rule at the window end: mean = the original rule (mean of the '
              'in-region samples must lie in a region), vote = region with most samples',
              choices=METHODS),
    ParamSpec('window_s', 1.0,
              'Gaze collection time of a round, s of sample stamps from the round start',
              value_range=(0.0, 60.0), check=_positive),
    ParamSpec('early_decision', False,
              'Decide before the window ends once the fresh evidence for one region reaches '
              'confidence (and min_samples / dwell_s / min_reaction_s hold); the defaults of '
              'those are the configuration bench/decision.py selects'),
    ParamSpec('confidence', 0.95,
              'Posterior probability of the leading region needed for an early decision',
              value_range=(0.5, 1.0), check=_open_unit_half),
    ParamSpec('min_samples', 2,
              'Early decision: fresh in-region samples needed, and the most recent ones the '
              'leading region must hold without interruption',
              value_range=(1, 100000)),
    ParamSpec('dwell_s', 0.02,
              'Early decision: sample time the uninterrupted run on the leading region must '
              'span, s (keeps a saccade that crosses a region from choosing it, at any '
              'tracker rate)',
              value_range=(0.0, 10.0)),
    ParamSpec('min_reaction_s', 0.1,
              'Early decision: shortest reaction to a new display, s; gaze on a region from '
              'before round start + min_reaction_s (a gaze already resting there) counts '
              'only after it has moved to another region; 0 = off. The window-end rule '
              'always uses every sample',
              value_range=(0.0, MAX_REACTION_S)),
    ParamSpec('hit_rate', 0.9,
              'Evidence model: probability that an in-region sample is on the looked-at region',
              value_range=(0.5, 1.0), check=_open_unit_half),
    ParamSpec('reorder_s', 0.0,
              'Longest time a decision waits for a regions message that may apply to its '
              'last gaze samples (regions lagging gaze while the camera moves), s; 0 = '
              'decide at once (lowest latency); the wait ends as soon as regions stamped '
              'after those samples arrive',
              value_range=(0.0, 2.0)),
    ParamSpec('stall_timeout_s', 0.5,
              'When no gaze sample stamped after the window arrives, close the round this '
              'long after the window end (node clock), s',
              value_range=(0.0, 10.0)),
    ParamSpec('max_future_s', DEFAULT_MAX_FUTURE_S,
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
        self._warned: Dict[str, float] = {}
        self._tracker = ChoiceTracker(ArbiterSettings(**self._config), self._publish, self._log)
        self._publisher = self.create_publisher(String, 'choice', EVENT_QOS)
        self.create_subscription(PointStamped, 'gaze', self._on_gaze, GAZE_QOS)
        self.create_subscription(MarkerArray, 'choices/regions', self._on_regions, LATCHED_QOS)
        self.create_subscription(Empty, 'choice/request', self._on_request, EVENT_QOS)
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

    def _on_gaze(self, msg: PointStamped) -> None:
        try:
            frame = msg.header.frame_id
            if frame not in ('', SCREEN_FRAME):
                self._log('warning', 'gaze_frame',
                          f"gaze in frame '{frame}' ignored: expected '{SCREEN_FRAME}' (px)")
                return
            now = self._now()
            stamp = _seconds(msg.header.stamp) or now
            self._tracker.add_sample(stamp, msg.point.x, msg.point.y, now)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'gaze_error', f'gaze sample ignored: {error}')

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

    def _log(self, level: str, key: str, text: str) -> None:
        """Log ``text``; warnings of one ``key`` at most once per WARN_PERIOD_S."""
        if level != 'warning':
            self.get_logger().info(text)
            return
        now = time.monotonic()
        if now - self._warned.get(key, -WARN_PERIOD_S) < WARN_PERIOD_S:
            return
        self._warned[key] = now
        self.get_logger().warning(text)

    # -- input modes: gaze / ssvep / hybrid (issue 11; eye_bci_ros2.fusion) -------------------

    def _init_fusion(self) -> None:
        """Declare the input-mode parameters and subscribe the SSVEP decoder's output."""
        values = declare_parameters(self, FUSION_PARAMETERS, self._on_fusion_parameters,
                                    self._check_fusion)
        self._fusion_values = dict(values)
        self._fusion = ChoiceFusion(self._fusion_settings(values))
        self._fusion_labels = None
        self.create_subscription(String, 'ssvep/choice', self._on_ssvep_choice, EVENT_QOS)
        self.create_subscription(JointState, 'ssvep/scores', self._on_ssvep_scores, 10)
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
    spin_node(lambda: ChoiceArbiter(), args)


if __name__ == '__main__':
    main()
