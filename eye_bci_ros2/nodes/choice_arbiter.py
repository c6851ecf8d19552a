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
(see :mod:`eye_bci_ros2.arbitration`).  The next round starts on the next
request or change of the offered labels.

Ordering.  Gaze and regions come on separate topics, so a sample can arrive
before the regions message stamped just before it.  Each sample is held
``reorder_s`` after its arrival (less when a regions message stamped after it
has already come) and then classified against the regions shown at its own
stamp, from a short history of region sets.  Work per message is O(1);
samples are classified in vectorised batches on a 50 Hz timer.
"""

import bisect
from collections import deque
import math
from typing import Deque, List, Optional, Tuple

from geometry_msgs.msg import PointStamped
import numpy as np
from rclpy.node import Node
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.arbitration import Decision, METHODS, RegionSet, RoundEvidence
from eye_bci_ros2.nodes.conversions import marker_array_to_regions, SCREEN_FRAME
from eye_bci_ros2.nodes.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.nodes.qos import EVENT_QOS, GAZE_QOS, LATCHED_QOS
from eye_bci_ros2.nodes.runner import spin_node

#: Period of the timer that classifies buffered samples and closes rounds, s.
TICK_S = 0.02

#: Buffered samples beyond this are classified at once (a stuck clock must not grow memory).
MAX_BUFFER = 100000

#: Throttle period of repeatable warnings, s.
WARN_PERIOD_S = 5.0

_EMPTY_REGIONS = RegionSet([], np.zeros((0, 3, 2)))


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
              'Decide before the window ends once the evidence for one region reaches '
              'confidence (and min_samples / dwell_s hold)'),
    ParamSpec('confidence', 0.95,
              'Posterior probability of the leading region needed for an early decision',
              value_range=(0.5, 1.0), check=_open_unit_half),
    ParamSpec('min_samples', 10,
              'Early decision: in-region samples needed, and the most recent ones the '
              'leading region must hold without interruption',
              value_range=(1, 100000)),
    ParamSpec('dwell_s', 0.2,
              'Early decision: sample time the uninterrupted run on the leading region must '
              'span, s (keeps saccades and a gaze still on the old menu from choosing)',
              value_range=(0.0, 10.0)),
    ParamSpec('hit_rate', 0.9,
              'Evidence model: probability that an in-region sample is on the looked-at region',
              value_range=(0.5, 1.0), check=_open_unit_half),
    ParamSpec('reorder_s', 0.05,
              'How long a gaze sample waits after arrival for a regions message stamped '
              'before it, s',
              value_range=(0.0, 2.0)),
    ParamSpec('stall_timeout_s', 0.5,
              'When no gaze sample stamped after the window arrives, close the round this '
              'long after the window end (node clock), s',
              value_range=(0.0, 10.0)),
)


def _seconds(stamp) -> float:
    """builtin_interfaces/Time -> float s."""
    return stamp.sec + stamp.nanosec * 1e-9


class ChoiceArbiter(Node):
    """Turn gaze samples and the offered regions into one ``choice`` per round."""

    def __init__(self, **kwargs):
        """Declare parameters, topics and the classification timer."""
        super().__init__('choice_arbiter', **kwargs)
        self._config = declare_parameters(self, PARAMETERS, self._on_parameters)
        # Region sets by stamp (ascending), pruned to what pending samples may need.
        self._history: List[RegionSet] = []
        self._history_stamps: List[float] = []
        self._offered = frozenset()
        # (arrival s, stamp s, x px, y px) in arrival order.
        self._buffer: Deque[Tuple[float, float, float, float]] = deque()
        self._round: Optional[RoundEvidence] = None
        #: The outcome of the last finished round (for logs and tests).
        self.last_decision: Optional[Decision] = None
        #: Rounds started since the node started.
        self.rounds_started = 0
        self._publisher = self.create_publisher(String, 'choice', EVENT_QOS)
        self.create_subscription(PointStamped, 'gaze', self._on_gaze, GAZE_QOS)
        self.create_subscription(MarkerArray, 'choices/regions', self._on_regions, LATCHED_QOS)
        self.create_subscription(Empty, 'choice/request', self._on_request, EVENT_QOS)
        self._timer = self.create_timer(TICK_S, self._on_tick)
        self.get_logger().info(
            f"choice_arbiter: method {self._config['method']}, window "
            f"{self._config['window_s']} s, early decision "
            f"{'on' if self._config['early_decision'] else 'off'}")

    # -- parameters -------------------------------------------------------------------------

    def _on_parameters(self, changed: dict) -> None:
        self._config.update(changed)
        if self._round is not None:
            # The open round follows the new evidence settings at once.
            self._round.hit_rate = float(self._config['hit_rate'])
            self._round.min_samples = int(self._config['min_samples'])
            self._round.dwell_s = float(self._config['dwell_s'])

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- inputs -----------------------------------------------------------------------------

    def _on_gaze(self, msg: PointStamped) -> None:
        try:
            frame = msg.header.frame_id
            if frame not in ('', SCREEN_FRAME):
                self.get_logger().warning(
                    f"gaze in frame '{frame}' ignored: expected '{SCREEN_FRAME}' (px)",
                    throttle_duration_sec=WARN_PERIOD_S)
                return
            now = self._now()
            stamp = _seconds(msg.header.stamp) or now
            self._buffer.append((now, stamp, float(msg.point.x), float(msg.point.y)))
            if len(self._buffer) > MAX_BUFFER:
                self._settle(math.inf)
        except Exception as error:
            self.get_logger().warning(f'gaze sample ignored: {error}',
                                      throttle_duration_sec=WARN_PERIOD_S)

    def _on_regions(self, msg: MarkerArray) -> None:
        try:
            now = self._now()
            labels, polygons = marker_array_to_regions(msg)
            stamp = _seconds(msg.markers[0].header.stamp) if msg.markers else 0.0
            region_set = RegionSet(labels, polygons, stamp or now)
        except (ValueError, IndexError, AttributeError) as error:
            self.get_logger().warning(f'regions message ignored: {error}',
                                      throttle_duration_sec=WARN_PERIOD_S)
            return
        try:
            self._add_regions(region_set, now)
        except Exception as error:
            self.get_logger().error(f'failed to apply regions: {error}')

    def _on_request(self, msg: Empty) -> None:
        try:
            now = self._now()
            # Samples from before the request still belong to the open round.
            self._settle(now, before=now)
            if self._round is not None:
                self.get_logger().info('choice request: the unfinished round is replaced')
            self._start_round(now, 'request')
        except Exception as error:
            self.get_logger().error(f'failed to start a round: {error}')

    def _on_tick(self) -> None:
        try:
            now = self._now()
            self._settle(now)
            if self._round is not None:
                end = self._round.start + self._config['window_s']
                if now >= end + self._config['stall_timeout_s']:
                    self._settle(now, before=end)
                    if self._round is not None:
                        self._finish(self._round.decide(self._config['method']))
        except Exception as error:
            self.get_logger().error(f'failed to process gaze: {error}',
                                    throttle_duration_sec=WARN_PERIOD_S)

    # -- regions history --------------------------------------------------------------------

    def _add_regions(self, region_set: RegionSet, now: float) -> None:
        stamp = region_set.stamp
        if self._history_stamps and stamp < self._history_stamps[-1]:
            self.get_logger().warning(
                'regions message older than the previous one: gaze samples already '
                'classified keep their regions (raise reorder_s if this repeats)',
                throttle_duration_sec=WARN_PERIOD_S)
        changed = region_set.label_set != self._offered
        if changed:
            # Finish with the samples of the old question before asking the new one.
            self._settle(now, before=stamp)
        index = bisect.bisect_right(self._history_stamps, stamp)
        self._history.insert(index, region_set)
        self._history_stamps.insert(index, stamp)
        if changed:
            self._offered = region_set.label_set
            if self._round is not None:
                self.get_logger().info('offered choices changed: the unfinished round is '
                                       'replaced without a choice')
                self._round = None
            if self._offered:
                start = stamp
                if stamp < now - self._config['window_s']:
                    start = now
                    self.get_logger().warning(
                        f'regions stamp is {now - stamp:.2f} s old: the round starts at '
                        'their arrival', throttle_duration_sec=WARN_PERIOD_S)
                self._start_round(start, 'new choices')
        self._prune_history(now)

    def _prune_history(self, now: float) -> None:
        # Future rounds start no earlier than now - window_s; keep the set shown then.
        cutoff = now - self._config['window_s']
        if self._round is not None:
            cutoff = min(cutoff, self._round.start)
        if self._buffer:
            cutoff = min(cutoff, self._buffer[0][1])
        keep_from = bisect.bisect_right(self._history_stamps, cutoff) - 1
        if keep_from > 0:
            del self._history[:keep_from]
            del self._history_stamps[:keep_from]

    # -- rounds -----------------------------------------------------------------------------

    def _start_round(self, start: float, cause: str) -> None:
        self._round = RoundEvidence(start, hit_rate=self._config['hit_rate'],
                                    min_samples=self._config['min_samples'],
                                    dwell_s=self._config['dwell_s'])
        self.rounds_started += 1
        self.get_logger().info(
            f'round {self.rounds_started} ({cause}): offered {sorted(self._offered)}, '
            f"window {self._config['window_s']} s")

    def _settle(self, now: float, before: Optional[float] = None) -> None:
        """
        Classify the buffered samples whose regions are now known.

        A sample is due when it has waited ``reorder_s`` since arrival, when a
        regions message stamped at or after it has come, or when it is stamped
        before ``before``.
        """
        buffer = self._buffer
        if not buffer:
            return
        due_arrival = now - self._config['reorder_s']
        known = self._history_stamps[-1] if self._history_stamps else -math.inf
        if before is not None:
            known = max(known, math.nextafter(before, -math.inf))
        taken = []
        while buffer and (buffer[0][0] <= due_arrival or buffer[0][1] <= known):
            taken.append(buffer.popleft())
        if taken and self._round is not None:
            samples = np.array(taken)
            self._process(samples[:, 1], samples[:, 2:4])

    def _process(self, stamps: np.ndarray, points: np.ndarray) -> None:
        """Add settled samples, stamps (N,) s and points (N, 2) px, to the open round."""
        evidence = self._round
        order = np.argsort(stamps, kind='stable')
        stamps, points = stamps[order], points[order]
        end = evidence.start + self._config['window_s']
        first = np.searchsorted(stamps, evidence.start, side='left')
        last = np.searchsorted(stamps, end, side='left')
        window_done = last < len(stamps)
        stamps, points = stamps[first:last], points[first:last]
        if len(stamps):
            # Group consecutive samples by the region set shown at their stamps.
            shown = np.searchsorted(self._history_stamps, stamps, side='right') - 1
            bounds = np.flatnonzero(np.diff(shown)) + 1
            confidence = self._config['confidence'] if self._config['early_decision'] else None
            for lo, hi in zip(np.r_[0, bounds], np.r_[bounds, len(stamps)]):
                index = shown[lo]
                regions = self._history[max(index, 0)] if self._history else _EMPTY_REGIONS
                decision = evidence.add(points[lo:hi], stamps[lo:hi], regions, confidence)
                if decision is not None:
                    self._finish(decision)
                    return
        if window_done:
            self._finish(evidence.decide(self._config['method']))

    def _finish(self, decision: Decision) -> None:
        self._round = None
        self.last_decision = decision
        if decision.label is not None:
            self._publisher.publish(String(data=decision.label))
        counts = ', '.join(f'{label} {n}' for label, n in decision.counts.items())
        self.get_logger().info(f'{decision.summary()} [{counts}]')


def main(args=None):
    """Run the choice_arbiter node."""
    spin_node(lambda: ChoiceArbiter(), args)


if __name__ == '__main__':
    main()
