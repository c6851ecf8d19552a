"""
Node ``lsl_gaze_bridge``: eye-tracker gaze from an LSL stream to ROS 2.

Finds the LSL stream of an eye-tracker application (profile + stream type /
name / source_id), pulls its samples in chunks, converts them to points on
the ``screen`` (px, top-left origin; :mod:`eye_bci_ros2.gaze.profiles`) and
publishes

* every valid sample on ``gaze/samples`` (sensor_msgs/PointCloud2), one
  message per pulled chunk, each sample with its own acquisition time on the
  ROS clock (:mod:`eye_bci_ros2.ros.conversions`, "Gaze batches";
  :mod:`eye_bci_ros2.streams.lsl_connection` for the stamps), published serialized
  (:class:`eye_bci_ros2.ros.conversions.GazeCdr`): the cost follows the
  batches (below), not the tracker rate;
* the newest sample on ``gaze/point`` (geometry_msgs/PointStamped) at most
  ``point_rate_hz`` times a second, for people and simple tools;
* whether the newest sample is on the screen on ``gaze/on_screen``
  (std_msgs/Bool, latched): true when it is finite (a tracker that lost the
  eyes sends NaN), confident and within ``offscreen_margin_px`` of the screen,
  i.e. when the bridge publishes it; published when it changes and once when
  a stream starts sending, never per sample; false when the stream goes
  stale (nothing for ``stale_timeout_s``) or is lost.

Invalid samples (not finite: a blink, a tracker that lost the eyes; low
confidence; off the screen: the person looks away) are dropped and counted
per reason in the statistics line (INFO, every ``stats_period_s``); they are
normal, so a warning comes only when the user must act
(:mod:`eye_bci_ros2.gaze.invalid_watch`): no valid sample since the stream
started (a layout that does not describe the stream), or none for
``invalid_warn_s``; once per such stretch.

``gaze_correction`` (6 doubles, row-major 2 x 3 affine on screen px, or
12: those, then second-order terms; :func:`eye_bci_ros2.gaze.validation.as_matrix`;
:data:`eye_bci_ros2.gaze.validation.IDENTITY` = none) is applied to every sample
after the screen scaling and before the off-screen check
(:func:`eye_bci_ros2.gaze.validation.apply_correction`); ``gaze_validation``
fits it and sets it through the parameter service, and saves it as a
parameter file for ``--params-file``.  An implausible correction (scale,
rotation or shift anywhere on the screen beyond
:func:`eye_bci_ros2.gaze.validation.implausibility`'s limits) is refused with the reason.

The stream is found, kept or switched, and its samples stamped, by
:class:`eye_bci_ros2.streams.lsl_connection.StreamConnection` (the same connection
the SSVEP decoder uses; its module doc gives the rules) with the gaze profile
of :mod:`eye_bci_ros2.gaze.stream`: a stream is taken only when its channels
fit the profile (a Pupil Capture stream under ``xy_pixels`` is refused, with
``profile:=pupil_capture`` named), and of several fitting streams from
different sources none is taken until ``source_id`` or ``stream_name``
picks one.  Nothing blocks the executor for long: resolving runs in
liblsl's background, chunks are pulled with a zero timeout, and the only
waits are reading a stream's full description once (at most 0.2 s).

Batches.  Without a choice_arbiter the bridge pulls every ``poll_period_s``
(2 ms: a sample waits at most that long).  Once an arbiter announces when its
decision can next come (``choice/due``: a round's earliest early decision,
then its window end), it pulls every ``poll_period_s`` only from just before
that time until a sample stamped after it is published, and every
``idle_poll_period_s`` (40 ms) otherwise: at 1200 Hz with a round every
0.25 s about 35 batches a second instead of 500, while the sample a decision
waits for is still pulled within ``poll_period_s`` (``python -m
bench.lab_rate``).  One poll timer runs throughout; its period is changed in
place (``timer_period_ns``: rcl applies it from the tick after next, the next
one being scheduled already): the tick before a due time's span aims the tick
after it at the span's start, so the span begins with at most one early tick
and no run of empty 2 ms ticks; ``idle_poll_period_s`` again once the sample
after the due time is out.  Timers are never cancelled and reset per round
(rclpy's EventsExecutor has missed timers after a reset).  A due time
announced less than an idle period ahead is pulled for from the next tick (at
most ``idle_poll_period_s`` later).  Each wake-up of the executor costs about
0.1 ms of CPU whatever the callback does (``python -m bench.lab_rate``, part
``wake_up``): empty ticks are not free.

Bursts: a backlog (a sender that stalled and then pushed seconds of gaze at
once) waits in the inlet's buffer, which liblsl fills without loss up to
:data:`eye_bci_ros2.streams.lsl_connection.INLET_BUFFER_S` of gaze, and is published
in chunks of ``max_chunk`` samples, at most
:data:`eye_bci_ros2.streams.lsl_connection.MAX_PULLS_PER_POLL` chunks per poll.
Stamps stay acquisition times, so a drained backlog is exactly as old as it
is.  A quiet stream is kept while it is advertised (Tobii Stream Engine
sends nothing while it sees no eyes) and ``gaze/on_screen`` turns false.
"""

from dataclasses import replace
import math
import time
from typing import Any, Dict, Optional

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PointStamped
import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Bool

from eye_bci_ros2.gaze.invalid_watch import InvalidGazeWatch
from eye_bci_ros2.gaze.profiles import (ANY, build_config, convert, DEFAULT_PROFILE, DROP_REASONS,
                                        GazeConfig, GazeMapping, NO_CONFIDENCE, ORIGINS,
                                        PROFILE_NAMES, resolve_mapping, UNITS)
from eye_bci_ros2.gaze.stream import GazeStreamProfile
from eye_bci_ros2.gaze.validation import (as_matrix, correction_values, IDENTITY, implausibility,
                                          is_identity, PARAMETER as CORRECTION_PARAMETER)
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING
from eye_bci_ros2.ros.conversions import gaze_cdr, gaze_point_cdr, stamp_to_ns
from eye_bci_ros2.ros.log_throttle import log_at, WARN_PERIOD_S
from eye_bci_ros2.ros.lsl_adapter import LogReporter, PylslBackend
from eye_bci_ros2.ros.node_clock import NodeClock
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.topics import (DECISION_DUE_TOPIC, GAZE_ON_SCREEN_TOPIC, GAZE_POINT_TOPIC,
                                     GAZE_QOS, GAZE_SAMPLES_TOPIC, LATCHED_QOS, VIEW_QOS)
from eye_bci_ros2.streams.lsl_connection import (Chunk, ConnectionSettings, StreamConnection,
                                                 StreamDescription)

#: After a decision's due time, the short poll period is kept at most this long for a sample
#: stamped after it (a stream that stopped), s: longer than the arbiter's stall timeout.
PROMPT_LIMIT_S = 1.0

#: Counters kept and logged by the bridge.
COUNTERS = ('received', 'published') + DROP_REASONS + ('layout', 'bad_stamp')


def _one_of_or_empty(allowed):
    """Build a check: '' (profile default) or one of ``allowed``."""
    def check(value):
        if value in ('',) + tuple(allowed):
            return None
        return f"'{value}' is not one of: '' (profile default), {', '.join(allowed)}"
    return check


def _correction_shape(value):
    """Reject a gaze_correction that is not 6 or 12 finite numbers (as_matrix says why)."""
    try:
        as_matrix(value)
    except ValueError as error:
        return str(error).replace(f'{CORRECTION_PARAMETER} must', 'must', 1)
    return None


def _correction(values: Dict[str, Any]) -> Optional[np.ndarray]:
    """Return the (2, 6) correction of the parameters, or None for the identity (skipped)."""
    value = values.get(CORRECTION_PARAMETER) or IDENTITY
    return None if is_identity(value) else as_matrix(value)


def _channel_text(value):
    """Reject channel lists with empty entries early (build_config says why)."""
    if value and any(not token.strip() for token in str(value).split(',')):
        return f"'{value}' has an empty entry; separate labels or indices by single commas"
    return None


PARAMETERS = (
    ParamSpec('profile', DEFAULT_PROFILE,
              'eye-tracker application whose stream layout to expect; it sets the '
              'defaults of every parameter left empty/0/negative', choices=PROFILE_NAMES),
    ParamSpec('stream_type', '',
              f"LSL stream type to accept; '' = profile default, '{ANY}' = any",
              integer_as_text=True),
    ParamSpec('stream_name', '',
              f"LSL stream name to accept; '' = profile default, '{ANY}' = any",
              integer_as_text=True),
    ParamSpec('source_id', '', f"LSL source_id to accept; '' or '{ANY}' = any",
              integer_as_text=True),
    ParamSpec('x_channel', '',
              'channel of gaze x: label or 0-based index; several separated by commas '
              "(one per eye) are averaged over the valid eyes; '' = profile default",
              check=_channel_text, integer_as_text=True),
    ParamSpec('y_channel', '',
              'channel of gaze y, as x_channel (same number of entries); '
              "'' = profile default", check=_channel_text, integer_as_text=True),
    ParamSpec('units', '', 'units of x/y: pixels of the source screen or normalized '
              "(0..1); '' = profile default", check=_one_of_or_empty(UNITS)),
    ParamSpec('origin', '', 'corner of the source screen at x = y = 0; '
              "'' = profile default", check=_one_of_or_empty(ORIGINS)),
    ParamSpec('source_width', 0, 'width of the sender screen, px (pixels units); '
              '0 = profile default, else the screen width', value_range=(0, 16384)),
    ParamSpec('source_height', 0, 'height of the sender screen, px (pixels units); '
              '0 = profile default, else the screen height', value_range=(0, 16384)),
    ParamSpec('screen_width', DEFAULT_VIEWING.width_px,
              'width of the screen RViz is shown on, px', value_range=(1, 16384)),
    ParamSpec('screen_height', DEFAULT_VIEWING.height_px,
              'height of the screen RViz is shown on, px', value_range=(1, 16384)),
    ParamSpec('confidence_channel', '',
              f"label or index of a 0..1 confidence channel; '' = profile default, "
              f"'{NO_CONFIDENCE}' = no confidence check", check=_channel_text,
              integer_as_text=True),
    ParamSpec('min_confidence', -1.0,
              'drop samples whose confidence is below this; negative = profile default '
              '(0.6 for pupil_capture)', value_range=(-1.0, 1.0)),
    ParamSpec('offscreen_margin_px', 100.0,
              'drop samples more than this far outside the screen, px',
              value_range=(0.0, 10000.0)),
    ParamSpec('stale_timeout_s', 2.0,
              'warn when the stream sends nothing for this long, s; the bridge stays with it '
              'while it is advertised and switches only when it is gone',
              value_range=(0.05, 3600.0)),
    ParamSpec('poll_period_s', 0.002,
              'period of pulling samples from LSL, s; a sample waits up to this long in the '
              'inlet, so it bounds the added latency (docs/performance.md, "Performance")',
              value_range=(0.001, 1.0)),
    ParamSpec('idle_poll_period_s', 0.04,
              'period of pulling samples while no decision is due, s: once a '
              'choice_arbiter announces when its decisions can come (choice/due: the '
              'earliest early decision, the window end), samples are pulled every '
              'poll_period_s only from just before each such time until a sample stamped '
              'after it is published, and every idle_poll_period_s otherwise (the cost '
              'follows the batches; a decision at another time waits up to this long); '
              'without an arbiter always every poll_period_s; equal to poll_period_s: always',
              value_range=(0.001, 1.0)),
    ParamSpec('max_chunk', 1024, 'most samples pulled at once', value_range=(1, 65536)),
    ParamSpec('point_rate_hz', 30.0,
              'most gaze/point messages (the newest sample, for people and simple tools) '
              'per second; every sample is on gaze/samples whatever this is; 0 = none',
              value_range=(0.0, 1000.0)),
    ParamSpec('resolve_period_s', 0.5,
              'period of looking for the stream and checking its health, s',
              value_range=(0.05, 10.0)),
    ParamSpec('time_correction_period_s', 5.0,
              'period of refreshing the LSL clock offset to the sender, s',
              value_range=(0.1, 600.0)),
    ParamSpec(CORRECTION_PARAMETER, list(IDENTITY),
              'gaze correction from gaze_validation: 6 numbers, row-major 2x3 affine A on '
              'screen px, or 12: those, then row-major 2x3 second-order terms Q '
              '(corrected = A @ [x, y, 1] + Q @ [x^2, x*y, y^2]); applied after the screen '
              f'scaling; {list(IDENTITY)} = none; settable at run time; one that is '
              'implausible anywhere on the screen is refused',
              check=_correction_shape, array_type='double_array'),
    ParamSpec('invalid_warn_s', 10.0,
              'warn when the stream has sent no valid sample (finite, confident, on the '
              'screen) for this long, s, or none since it started: a wrong layout or a '
              'tracker that lost the eyes; shorter stretches (blinks, looking away) are only '
              'counted in the statistics line', value_range=(0.5, 3600.0)),
    ParamSpec('stats_period_s', 10.0,
              'period of logging sample counters when they change, s (0 = never)',
              value_range=(0.0, 3600.0)),
)


def _check_all(values: Dict[str, Any]) -> Optional[str]:
    """Reject parameter combinations build_config cannot use."""
    try:
        config = build_config(values)
    except ValueError as exc:
        return str(exc)
    correction = _correction(values)
    if correction is not None:
        reason = implausibility(correction, replace(
            DEFAULT_VIEWING, width_px=config.screen_width, height_px=config.screen_height))
        if reason:
            return f'{CORRECTION_PARAMETER}: {reason}'
    return None


def _settings(values: Dict[str, Any]) -> ConnectionSettings:
    """Return the connection's settings from the parameters."""
    return ConnectionSettings(stale_timeout_s=values['stale_timeout_s'],
                              time_correction_period_s=values['time_correction_period_s'],
                              max_chunk=values['max_chunk'])


class LslGazeBridge(Node):
    """Publish gaze points from an eye tracker's LSL stream on ``gaze``."""

    def __init__(self, **kwargs):
        """Declare parameters, start looking for the stream; ``kwargs`` go to Node."""
        super().__init__('lsl_gaze_bridge', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._on_parameters, _check_all)
        self._config: GazeConfig = build_config(self._params)
        self._batch_publisher = self.create_publisher(
            PointCloud2, GAZE_SAMPLES_TOPIC, GAZE_QOS)
        self._gaze_cdr = gaze_cdr()
        self._point_publisher = self.create_publisher(PointStamped, GAZE_POINT_TOPIC, VIEW_QOS)
        self._on_screen_publisher = self.create_publisher(Bool, GAZE_ON_SCREEN_TOPIC,
                                                          LATCHED_QOS)
        # The last gaze/on_screen published (None: none since the stream started).
        self._on_screen: Optional[bool] = None
        # gaze_correction as (2, 3), None = identity (nothing to do per sample).
        self._correction: Optional[np.ndarray] = _correction(self._params)
        # When gaze/point was last published (monotonic s).
        self._point_at = -math.inf
        self._counters = dict.fromkeys(COUNTERS, 0)
        self._logged_counters = dict(self._counters)
        self._counted_from = None       # the stream of the samples counted since the last stats
        # The channel mapping of the stream in use; None with the reason while it has none.
        self._mapping: Optional[GazeMapping] = None
        self._mapping_error = ''
        self._invalid = InvalidGazeWatch(self._params['invalid_warn_s'])
        self._poll_timer = None
        # Batches (module doc): the announced due time, ns on the ROS clock (None: no
        # arbiter announces: every tick pulls); the short period's span for it and the
        # last pull, s of time.monotonic().
        self._due_ns: Optional[int] = None
        self._prompt_from = self._prompt_until = -math.inf
        self._pulled_at = -math.inf
        # When the poll timer ticks next, s of time.monotonic() (set at each tick).
        self._next_tick = -math.inf
        # The poll timer's period now, ns (set in place by _pace).
        self._period_ns = 0
        self.create_subscription(Time, DECISION_DUE_TOPIC, self._on_due, LATCHED_QOS)
        self._resolve_timer = None
        self._stats_timer = None
        # Read a few times per chunk (stamps: the ROS-LSL clock pair), without a Time object.
        self._time = NodeClock(self)
        self._connection = StreamConnection(
            GazeStreamProfile(self._config), PylslBackend(), _settings(self._params),
            LogReporter(self.get_logger()),
            ros_now_ns=self._time.ns,
            on_connected=self._on_connected, on_quiet=lambda: self._publish_on_screen(False))
        self._make_timers(('poll_period_s', 'resolve_period_s', 'stats_period_s'))
        self.get_logger().info(
            f"profile '{self._config.profile}': looking for {self._config.describe_selection()}")

    # -- public state, for tests and tools ------------------------------------------

    @property
    def config(self) -> GazeConfig:
        """Return the effective settings (profile defaults with parameters applied)."""
        return self._config

    @property
    def connection(self) -> StreamConnection:
        """Give the LSL connection in use (stream, clock offset, measured rate, gaps)."""
        return self._connection

    @property
    def counters(self) -> Dict[str, int]:
        """Count samples received, published and dropped per reason since start."""
        return dict(self._counters)

    @property
    def stream(self) -> Optional[str]:
        """Describe the stream in use; None while looking."""
        stream = self._connection.stream
        return stream.describe() if stream else None

    @property
    def stream_uid(self) -> Optional[str]:
        """Return the LSL uid of the outlet in use; None while looking."""
        stream = self._connection.stream
        return stream.uid if stream else None

    @property
    def correction(self) -> Optional[np.ndarray]:
        """Return the gaze correction in use, (2, 6) screen px (``as_matrix``); None = none."""
        return None if self._correction is None else self._correction.copy()

    @property
    def on_screen(self) -> Optional[bool]:
        """Return the last ``gaze/on_screen`` published (None: none for this stream yet)."""
        return self._on_screen

    @property
    def stale(self) -> bool:
        """Tell whether the stream in use has sent nothing for ``stale_timeout_s``."""
        return self._connection.stale

    def destroy_node(self):
        """Close the inlet and the resolver, then destroy the node."""
        self._connection.close()
        return super().destroy_node()

    # -- parameters -----------------------------------------------------------------

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        """Apply accepted parameter changes at once."""
        self._params.update(changed)
        self._invalid.limit_s = self._params['invalid_warn_s']
        if CORRECTION_PARAMETER in changed:
            self._correction = _correction(self._params)
            self.get_logger().info(
                f'{CORRECTION_PARAMETER}: '
                f'{"none" if self._correction is None else correction_values(self._correction)}')
            if len(changed) == 1:
                return
        old, self._config = self._config, build_config(self._params)
        profile = GazeStreamProfile(self._config)
        if (old.selection, old.profile) != (self._config.selection, self._config.profile) \
                or 'max_chunk' in changed:
            self.get_logger().info(
                f'stream selection changed: now looking for {self._config.describe_selection()} '
                f"(profile '{self._config.profile}')")
            self._poll_timer.cancel()
            self._connection.reselect(profile, _settings(self._params))
        else:
            # Same streams: refused ones are judged again, the one in use is bound again.
            self._connection.refit(profile, _settings(self._params))
            if self._connection.stream is not None:
                self._bind(self._connection.stream)
        self._make_timers(changed)

    def _make_timers(self, changed) -> None:
        """(Re)create the timers whose period parameter is in ``changed``."""
        if 'poll_period_s' in changed:
            if self._poll_timer is not None:
                self.destroy_timer(self._poll_timer)
            self._poll_timer = self.create_timer(self._params['poll_period_s'], self._poll)
            self._period_ns = self._poll_timer.timer_period_ns
            if self._connection.stream is None:
                self._poll_timer.cancel()   # no wake-ups while there is nothing to read
        if 'resolve_period_s' in changed:
            if self._resolve_timer is not None:
                self.destroy_timer(self._resolve_timer)
            self._resolve_timer = self.create_timer(
                self._params['resolve_period_s'], self._maintain)
        if 'stats_period_s' in changed:
            if self._stats_timer is not None:
                self.destroy_timer(self._stats_timer)
                self._stats_timer = None
            if self._params['stats_period_s'] > 0:
                self._stats_timer = self.create_timer(
                    self._params['stats_period_s'], self._log_counters)

    # -- the stream -------------------------------------------------------------------

    def _maintain(self) -> None:
        """Let the connection find, keep or switch the stream (resolve timer)."""
        try:
            self._connection.maintain()
            if self._connection.stream is None:
                self._poll_timer.cancel()
        except Exception as exc:  # noqa: B902 - a node never dies on a stream
            self.get_logger().warning(f'LSL maintenance failed: {exc}',
                                      throttle_duration_sec=WARN_PERIOD_S)

    def _on_connected(self, stream: StreamDescription) -> None:
        """Bind a stream just opened, publish on_screen anew for it, start polling."""
        self._on_screen = None       # published once when this stream starts sending
        self._bind(stream)
        if self._poll_timer is not None:
            self._poll_timer.reset()

    def _bind(self, stream: StreamDescription) -> None:
        """Map the configuration onto the stream's channels, or say why it cannot."""
        self._invalid.reset()
        try:
            self._mapping = resolve_mapping(self._config, stream.labels or (),
                                            stream.channel_count)
            self._mapping_error = ''
        except ValueError as exc:
            self._mapping = None
            self._mapping_error = str(exc)
            self.get_logger().warning(
                f'stream {stream.describe()} does not fit profile '
                f"'{self._config.profile}': {exc}; its samples are dropped until the "
                f'parameters match it')

    # -- pulling and publishing ------------------------------------------------------

    def _poll(self) -> None:
        """Pull what the inlet holds, convert and publish it (when due: module doc)."""
        if self._due_ns is not None:
            # The next tick is already scheduled with the period in force (module doc).
            self._next_tick = time.monotonic() + self._period_ns * 1e-9
            due = self._pull_due()
            self._pace()
            if not due:
                return
        self._pulled_at = time.monotonic()
        try:
            for chunk in self._connection.acquire():
                self._publish_chunk(chunk, time.monotonic())
        except Exception as exc:  # noqa: B902 - a node never dies on a sample
            self.get_logger().warning(f'failed to publish gaze: {exc}',
                                      throttle_duration_sec=WARN_PERIOD_S)
        if self._connection.stream is None:
            self._poll_timer.cancel()

    # -- batches: the short poll period when a decision is due ---------------------------

    def _on_due(self, msg: Time) -> None:
        """Take when the arbiter's next decision can come (module doc, "Batches")."""
        if self._due_ns is None:
            self.get_logger().info(
                f'{DECISION_DUE_TOPIC} announced: pulling every '
                f"{self._params['idle_poll_period_s']:g} s, and every "
                f"{self._params['poll_period_s']:g} s when a decision is due")
        self._due_ns = stamp_to_ns(msg)
        # The ROS clock's due time on the monotonic clock the ticks read.
        due = time.monotonic() + (self._due_ns - self._time.ns()) * 1e-9
        # From two short periods before it until a sample stamped after it is out (or the
        # stream stopped): what a decision due then waits for.
        self._prompt_from = due - 2.0 * self._params['poll_period_s']
        self._prompt_until = due + PROMPT_LIMIT_S
        if self._poll_timer is not None:
            self._pace()

    def _pull_due(self) -> bool:
        """Tell whether this tick pulls: near the due time, or after idle_poll_period_s."""
        now = time.monotonic()
        if self._prompt_from <= now <= self._prompt_until:
            newest = self._connection.newest_stamp_ns
            if newest is None or newest < self._due_ns:
                return True
            self._prompt_until = -math.inf      # delivered
        # Half an idle period: the timer itself runs at idle_poll_period_s there, and a tick
        # a little early after a late one still pulls (not one idle period later).
        return now - self._pulled_at >= 0.5 * self._params['idle_poll_period_s']

    def _pace(self) -> None:
        """
        Set the poll timer's period for what is due (module doc, "Batches").

        A period set now applies from the tick after the next one, which is already
        scheduled: before the short span that tick's period is aimed at the span's start
        (between ``poll_period_s`` and ``idle_poll_period_s``), so the span starts with
        at most one early tick; ``poll_period_s`` in the span; ``idle_poll_period_s``
        otherwise.  Changed in place, never by cancel and reset (module doc).
        """
        short = self._params['poll_period_s']
        idle = max(short, self._params['idle_poll_period_s'])
        # Between ticks (a due time just announced) the next tick is at most that far; a
        # late one is imminent.
        following = max(self._next_tick, time.monotonic())
        if following > self._prompt_until:
            period = idle
        else:
            period = min(max(self._prompt_from - following, short), idle)
        period_ns = int(round(period * 1e9))
        if period_ns != self._period_ns:
            self._poll_timer.timer_period_ns = period_ns
            self._period_ns = period_ns

    def _publish_chunk(self, chunk: Chunk, now: float) -> None:
        """Convert and publish one stamped chunk; count what is dropped."""
        count = len(chunk.stamps_ns)
        self._counters['received'] += count
        self._counted_from = self._connection.stream
        if self._mapping is None:
            # Said once by _bind (with what to set); counted in the statistics line.
            self._counters['layout'] += count
            return
        samples, stamps_ns = chunk.samples, chunk.stamps_ns
        if not chunk.good.all():
            self._counters['bad_stamp'] += int(np.count_nonzero(~chunk.good))
            self.get_logger().warning(
                f'dropping gaze samples with unusable LSL timestamps from {self.stream}',
                throttle_duration_sec=WARN_PERIOD_S)
            samples, stamps_ns = samples[chunk.good], stamps_ns[chunk.good]

        batch = convert(samples, self._mapping, self._correction)
        if len(batch.keep):
            self._publish_on_screen(bool(batch.keep[-1]))
        # Blinks and glances away are normal: counted for the statistics line; a warning only
        # when the user must act (gaze.invalid_watch).
        for reason, number in batch.dropped.items():
            self._counters[reason] += number
        report = self._invalid.update(stamps_ns, batch.keep, batch.dropped)
        if report is not None:
            # One call site, two severities: log_at (rclpy's logger refuses that itself).
            log_at(self.get_logger(), report.warning, f'{report.text} (from {self.stream})')
        if not len(batch.xy):
            return
        stamps_ns = stamps_ns[batch.keep]
        # Serialized (conversions.GazeCdr): the same bytes as gaze_batch's message, built
        # without rclpy's Python message.
        self._batch_publisher.publish(self._gaze_cdr.build(stamps_ns, batch.xy))
        self._counters['published'] += len(batch.xy)
        rate = self._params['point_rate_hz']
        if rate > 0.0 and now - self._point_at >= 1.0 / rate:
            self._point_at = now
            self._point_publisher.publish(
                gaze_point_cdr(stamps_ns[-1], batch.xy[-1, 0], batch.xy[-1, 1]))

    def _publish_on_screen(self, on_screen: bool) -> None:
        """Publish ``gaze/on_screen`` when it changed (or first for this stream)."""
        if on_screen != self._on_screen:
            self._on_screen = on_screen
            self._on_screen_publisher.publish(Bool(data=on_screen))

    # -- reporting --------------------------------------------------------------------

    def _drop_totals(self) -> str:
        """Dropped-sample totals per reason, e.g. '3 nonfinite, 1 offscreen'."""
        totals = [f'{self._counters[key]} {key}' for key in COUNTERS[2:] if self._counters[key]]
        return ', '.join(totals) or 'none'

    def _log_counters(self) -> None:
        """Log the counters when they changed since the last report."""
        if self._counters == self._logged_counters:
            return
        received = self._counters['received'] - self._logged_counters['received']
        published = self._counters['published'] - self._logged_counters['published']
        self._logged_counters = dict(self._counters)
        # The stream the samples came from: it may be lost by now.
        counted, self._counted_from = self._counted_from, None
        source = counted.describe() if counted else self.stream
        self.get_logger().info(
            f'gaze: {received} received, {published} published in the last '
            f"{self._params['stats_period_s']:g} s from {source}; dropped since start: "
            f'{self._drop_totals()}')


def main(args=None):
    """Run the bridge until Ctrl-C."""
    spin_node(LslGazeBridge, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
