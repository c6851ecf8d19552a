"""
Node ``lsl_gaze_bridge``: eye-tracker gaze from an LSL stream to ``gaze`` on ROS 2.

Finds the LSL stream of an eye-tracker application (profile + stream type /
name / source_id), pulls its samples in chunks, converts them to points on
the ``screen`` (px, top-left origin; :mod:`eye_bci_ros2.gaze_profiles`) and
publishes each as a geometry_msgs/PointStamped whose stamp is the sample's
acquisition time on the ROS clock.

Nothing here blocks the executor for long: the stream is found by a
``pylsl.ContinuousResolver`` that a timer polls, chunks are pulled with a
zero timeout, and the clock offset to the sender is estimated by liblsl in
the background.  The only waits are fetching the full stream description
once per connection (at most 0.2 s, usually a few ms on a LAN).

Time stamps: ``t_ros = t_lsl + time_correction + (ros_now - local_clock())``
where ``t_lsl`` is the sender's timestamp (its LSL clock), the time
correction (refreshed every ``time_correction_period_s``) maps it to this
machine's LSL clock, and the last term, measured when the chunk is pulled,
maps this machine's LSL clock to the ROS clock.  Samples are held back until
the first time-correction estimate (about 0.7 s after connecting); if none
comes within 5 s (UDP time service unreachable) the bridge warns and stamps
with arrival time until one does.

Bursts: samples are published at most ``max_publish_rate_hz`` per second
(a token bucket refilled at that rate, holding at least
:data:`PUBLISH_BURST` samples): twice the live rate by default.  A backlog
(a sender that stalled and then pushed seconds of gaze at once, or samples
held while the executor was busy) stays in the inlet's buffer, which liblsl
fills without loss up to :data:`INLET_BUFFER_S` of gaze, and drains over a
few seconds: publishing it in one callback would overflow every subscriber
whose queue (``GAZE_QOS`` depth) is shorter than the burst, and a
subscriber on the same executor takes only one message per wait.  Stamps
stay acquisition times, so a drained backlog is exactly as old as it is.

Lost streams: inlets are created with ``recover=False``, so an outlet that
goes away raises ``LostError`` at once; the bridge then resolves again and
re-reads the channel labels, because a restarted application may advertise
a different layout (a lost stream is not reopened for
:data:`LOST_IGNORE_S`, while the resolver may still list it).  A stream
that sends nothing for ``stale_timeout_s`` is reported and kept while it
is still advertised (Tobii Stream Engine sends nothing while it sees no
eyes: switching then would hand control to another device's gaze); only
when it is gone does the bridge take the newest matching stream, with a
warning.  A further matching stream that appears while connected is
reported once and never used.
"""

from dataclasses import dataclass
import math
import time
from typing import Any, Dict, List, Optional, Tuple

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PointStamped
import numpy as np
import pylsl
from pylsl.util import LostError, TimeoutError as LslTimeoutError
from rclpy.node import Node
from std_msgs.msg import Header

from eye_bci_ros2.gaze_profiles import (
    ANY, build_config, convert, DEFAULT_PROFILE, DROP_REASONS, GazeConfig, GazeMapping,
    NO_CONFIDENCE, ORIGINS, PROFILE_NAMES, resolve_mapping, stream_matches, UNITS,
    xpath_predicate)
from eye_bci_ros2.nodes.conversions import SCREEN_FRAME
from eye_bci_ros2.nodes.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.nodes.qos import GAZE_QOS
from eye_bci_ros2.nodes.runner import spin_node

#: Inlet buffer, s of gaze; liblsl drops the oldest samples beyond it, uncounted.
INLET_BUFFER_S = 60
#: Rate assumed to size the inlet buffer of an irregular-rate stream, Hz.
IRREGULAR_BUFFER_RATE_HZ = 1200.0
#: Automatic publish limit: this many times the nominal rate ...
CATCH_UP_FACTOR = 2.0
#: ... and at least this, samples/s (irregular streams; apps that advertise a
#: placeholder rate, like App-TobiiPro's 600 Hz for a 1200 Hz tracker).  One
#: executor running the arbiter and a listener delivers about 3000 gaze
#: messages/s on a loaded 2-core machine (test_faults_gaze burst tests).
MIN_AUTO_PUBLISH_RATE_HZ = 2400.0
#: Most samples published in one poll after a pause (token bucket size, at least).
PUBLISH_BURST = 32
#: Report a backlog that takes at least this long to drain, s (not the one left
#: by the wait for the first clock offset, about 0.7 s of gaze).
BACKLOG_LOG_S = 0.5
#: Longest wait for a stream's full description when connecting, s.
INFO_TIMEOUT_S = 0.2
#: Without a time-correction estimate after this long, stamp by arrival, s.
CLOCK_SYNC_TIMEOUT_S = 5.0
#: A resolver forgets a stream this long after it stopped answering, s.
RESOLVER_FORGET_S = 2.0
#: A lost stream is not reopened for this long (the resolver may still list a dead
#: outlet); after it, a stream whose connection only broke can be used again, s.
LOST_IGNORE_S = 2.5 * RESOLVER_FORGET_S
#: Most chunks pulled per poll, so a huge backlog cannot hog the executor.
MAX_PULLS_PER_POLL = 8
#: Repeating warnings at most this often, s.
WARN_THROTTLE_S = 5.0
#: "Still looking" at most this often, s.
LOOKING_LOG_PERIOD_S = 10.0
#: Tries at reading the ROS and LSL clocks together, and a bracket good enough, s.
CLOCK_READS = 3
CLOCK_BRACKET_S = 20e-6
#: Stamps must fit builtin_interfaces/Time (int32 seconds).
_MAX_STAMP_S = 2.0 ** 31 - 1
#: Counters kept and logged by the bridge.
COUNTERS = ('received', 'published') + DROP_REASONS + ('layout', 'bad_stamp')


def _one_of_or_empty(allowed):
    """Build a check: '' (profile default) or one of ``allowed``."""
    def check(value):
        if value in ('',) + tuple(allowed):
            return None
        return f"'{value}' is not one of: '' (profile default), {', '.join(allowed)}"
    return check


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
    ParamSpec('screen_width', 1920, 'width of the screen RViz is shown on, px',
              value_range=(1, 16384)),
    ParamSpec('screen_height', 1080, 'height of the screen RViz is shown on, px',
              value_range=(1, 16384)),
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
              'inlet, so it bounds the added latency (2 ms: p99 LSL push -> choice about '
              '6 ms at 1200 Hz, see bench/latency.py; 10 ms: about 14 ms, at half the CPU)',
              value_range=(0.001, 1.0)),
    ParamSpec('max_chunk', 1024, 'most samples pulled at once', value_range=(1, 65536)),
    ParamSpec('max_publish_rate_hz', 0.0,
              'most gaze samples published per second; a backlog beyond it (a burst from '
              'the sender) waits in the LSL inlet buffer (60 s) and drains at this rate, so '
              'subscribers with a shorter queue lose nothing; it must not exceed what the '
              'slowest gaze subscriber takes; 0 = twice the nominal rate, at least 2400',
              value_range=(0.0, 1e6)),
    ParamSpec('resolve_period_s', 0.5,
              'period of looking for the stream and checking its health, s',
              value_range=(0.05, 10.0)),
    ParamSpec('time_correction_period_s', 5.0,
              'period of refreshing the LSL clock offset to the sender, s',
              value_range=(0.1, 600.0)),
    ParamSpec('stats_period_s', 10.0,
              'period of logging sample counters when they change, s (0 = never)',
              value_range=(0.0, 3600.0)),
)


def _check_all(values: Dict[str, Any]) -> Optional[str]:
    """Reject parameter combinations build_config cannot use."""
    try:
        build_config(values)
    except ValueError as exc:
        return str(exc)
    return None


def _channel_labels(info: pylsl.StreamInfo) -> List[str]:
    """Labels from desc/channels/channel/label, '' where a channel has none."""
    labels = []
    channel = info.desc().child('channels').child('channel')
    while not channel.empty():
        labels.append(channel.child_value('label').strip())
        channel = channel.next_sibling('channel')
    return labels


def _describe(info: pylsl.StreamInfo) -> str:
    """One line naming a stream for log messages."""
    rate = info.nominal_srate()
    rate_text = f'{rate:g} Hz' if rate > 0 else 'irregular rate'
    return (f"'{info.name()}' (type '{info.type()}', source_id '{info.source_id()}', "
            f'{info.channel_count()} ch, {rate_text}, host {info.hostname()})')


def _inlet_buflen(nominal_srate: float) -> int:
    """
    Return pylsl's ``max_buflen`` for :data:`INLET_BUFFER_S` of gaze.

    liblsl reads it as seconds for a stream with a nominal rate, but as
    hundreds of samples for an irregular one (nominal rate 0).
    """
    if nominal_srate > 0:
        return INLET_BUFFER_S
    return int(math.ceil(INLET_BUFFER_S * IRREGULAR_BUFFER_RATE_HZ / 100.0))


def _how_to_choose(info: pylsl.StreamInfo, current_source_id: str) -> str:
    """Tell the user how to select this stream instead (or why source_id cannot)."""
    if info.source_id() and info.source_id() != current_source_id:
        return f"To use it instead, set the parameter source_id to '{info.source_id()}'."
    return (f"It has the same source_id ('{info.source_id()}'): to use it instead, stop the "
            f'other sender or select it by stream_name.')


@dataclass
class _Connection:
    """One open inlet and what the bridge knows about its stream."""

    inlet: pylsl.StreamInlet
    uid: str
    source_id: str
    created_at: float
    description: str
    labels: List[str]
    buffer: np.ndarray
    connected_at: float
    nominal_srate: float
    mapping: Optional[GazeMapping] = None
    mapping_error: str = ''
    time_correction: Optional[float] = None
    time_correction_at: float = 0.0
    arrival_stamps: bool = False
    reading_since: Optional[float] = None
    last_sample_at: Optional[float] = None
    stale: bool = False
    #: Samples that may be published now (token bucket), and when it was last filled.
    tokens: float = float(PUBLISH_BURST)
    tokens_at: Optional[float] = None
    #: A backlog being drained: when it was noticed, and the 'received' count then.
    backlog_since: Optional[float] = None
    backlog_start_count: int = 0


class LslGazeBridge(Node):
    """Publish gaze points from an eye tracker's LSL stream on ``gaze``."""

    def __init__(self, **kwargs):
        """Declare parameters, start looking for the stream; ``kwargs`` go to Node."""
        super().__init__('lsl_gaze_bridge', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._on_parameters, _check_all)
        self._config: GazeConfig = build_config(self._params)
        self._publisher = self.create_publisher(PointStamped, 'gaze', GAZE_QOS)
        self._counters = dict.fromkeys(COUNTERS, 0)
        self._logged_counters = dict(self._counters)
        self._connection: Optional[_Connection] = None
        self._resolver: Optional[pylsl.ContinuousResolver] = None
        # Streams not to open: uid -> until when (monotonic s; inf = for good).
        self._ignored: Dict[str, float] = {}
        # Other matching streams already reported, so each is reported once.
        self._reported_uids = set()
        # (uid, description) of a stream that went away, until another one is opened.
        self._gone: Optional[Tuple[str, str]] = None
        self._last_looking_log = -LOOKING_LOG_PERIOD_S
        self._poll_timer = None
        self._resolve_timer = None
        self._stats_timer = None
        self._start_resolver()
        self._make_timers(('poll_period_s', 'resolve_period_s', 'stats_period_s'))
        self.get_logger().info(
            f"profile '{self._config.profile}': looking for {self._config.describe_selection()}")

    # -- public state, for tests and tools ------------------------------------------

    @property
    def config(self) -> GazeConfig:
        """Return the effective settings (profile defaults with parameters applied)."""
        return self._config

    @property
    def counters(self) -> Dict[str, int]:
        """Count samples received, published and dropped per reason since start."""
        return dict(self._counters)

    @property
    def stream(self) -> Optional[str]:
        """Describe the stream in use; None while looking."""
        return self._connection.description if self._connection else None

    @property
    def stream_uid(self) -> Optional[str]:
        """Return the LSL uid of the outlet in use; None while looking."""
        return self._connection.uid if self._connection else None

    @property
    def publish_rate_hz(self) -> Optional[float]:
        """Return the most samples published per second from the stream in use; None idle."""
        return self._publish_rate(self._connection) if self._connection else None

    @property
    def stale(self) -> bool:
        """Tell whether the stream in use has sent nothing for ``stale_timeout_s``."""
        return bool(self._connection and self._connection.stale)

    def destroy_node(self):
        """Close the inlet and the resolver, then destroy the node."""
        self._disconnect()
        self._resolver = None
        return super().destroy_node()

    # -- parameters -----------------------------------------------------------------

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        """Apply accepted parameter changes at once."""
        self._params.update(changed)
        old, self._config = self._config, build_config(self._params)
        if (old.selection, old.profile) != (self._config.selection, self._config.profile):
            self.get_logger().info(
                f'stream selection changed: now looking for {self._config.describe_selection()} '
                f"(profile '{self._config.profile}')")
            self._disconnect()
            self._ignored.clear()
            self._reported_uids.clear()
            self._gone = None
            self._start_resolver()
        elif self._connection is not None:
            if 'max_chunk' in changed:
                self._connection.buffer = self._make_buffer(self._connection.inlet)
            self._bind(self._connection)
        self._make_timers(changed)

    def _make_timers(self, changed) -> None:
        """(Re)create the timers whose period parameter is in ``changed``."""
        if 'poll_period_s' in changed:
            if self._poll_timer is not None:
                self.destroy_timer(self._poll_timer)
            self._poll_timer = self.create_timer(self._params['poll_period_s'], self._poll)
            if self._connection is None:
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

    # -- finding and opening the stream ----------------------------------------------

    def _start_resolver(self) -> None:
        """Resolve continuously (in liblsl's background thread) for the selection."""
        predicate = xpath_predicate(self._config)
        try:
            if predicate:
                self._resolver = pylsl.ContinuousResolver(
                    pred=predicate, forget_after=RESOLVER_FORGET_S)
            else:
                self._resolver = pylsl.ContinuousResolver(forget_after=RESOLVER_FORGET_S)
        except Exception as exc:  # noqa: B902 - liblsl errors must not kill the node
            self._resolver = None
            self.get_logger().error(f'cannot start the LSL resolver: {exc}')

    def _candidates(self) -> List[pylsl.StreamInfo]:
        """List the matching streams currently advertised (any uid), oldest first."""
        if self._resolver is None:
            self._start_resolver()
            if self._resolver is None:
                return []
        found = [info for info in self._resolver.results() if stream_matches(
            self._config, info.type(), info.name(), info.source_id())]
        return sorted(found, key=lambda info: info.created_at())

    def _maintain(self) -> None:
        """Connect when idle; refresh the clock offset; report other and quiet streams."""
        try:
            now = time.monotonic()
            connection = self._connection
            if connection is None:
                self._connect_newest(now)
                return
            if connection.time_correction is None or now - connection.time_correction_at >= \
                    self._params['time_correction_period_s']:
                self._refresh_time_correction(connection, now)
            candidates = self._candidates()
            self._report_others(connection, candidates)
            quiet_since = connection.last_sample_at or connection.reading_since
            if quiet_since is None or now - quiet_since < self._params['stale_timeout_s']:
                return  # still waiting for the clock offset, or not quiet
            if any(info.uid() == connection.uid for info in candidates):
                if not connection.stale:
                    connection.stale = True
                    self.get_logger().warning(
                        f'no gaze samples from {connection.description} for '
                        f'{now - quiet_since:.1f} s (no eyes detected?); it is still '
                        f'advertised, so the bridge stays with it and waits for it to resume')
                return
            # Quiet and no longer advertised: the sender is gone (a lost connection
            # usually raises LostError in _poll first).
            self.get_logger().warning(
                f'{connection.description} is no longer advertised; looking for another')
            self._drop_lost(connection)
            self._connect_newest(now)
        except Exception as exc:  # noqa: B902 - a node never dies on a stream
            self.get_logger().warning(f'LSL maintenance failed: {exc}',
                                      throttle_duration_sec=WARN_THROTTLE_S)

    def _report_others(self, connection: _Connection,
                       candidates: List[pylsl.StreamInfo]) -> None:
        """Warn once about each further matching stream: it is not used."""
        for info in candidates:
            uid = info.uid()
            if uid == connection.uid or uid in self._reported_uids \
                    or self._is_ignored(uid, time.monotonic()):
                continue
            self._reported_uids.add(uid)
            self.get_logger().warning(
                f'another LSL stream matches {self._config.describe_selection()}: '
                f"{_describe(info)}, uid '{uid}'; it is NOT used: the bridge stays with "
                f"{connection.description}, uid '{connection.uid}'. "
                f'{_how_to_choose(info, connection.source_id)}')

    def _drop_lost(self, connection: _Connection) -> None:
        """Forget a stream that went away; the next one opened is announced as its successor."""
        self._ignored[connection.uid] = time.monotonic() + LOST_IGNORE_S
        self._gone = (connection.uid, connection.description)
        self._disconnect()

    def _is_ignored(self, uid: str, now: float) -> bool:
        """Tell whether the stream ``uid`` must not be opened now."""
        until = self._ignored.get(uid)
        if until is None:
            return False
        if now < until:
            return True
        del self._ignored[uid]
        return False

    def _connect_newest(self, now: float) -> None:
        """Open the newest matching stream, if any."""
        candidates = [info for info in self._candidates()
                      if not self._is_ignored(info.uid(), now)]
        if not candidates:
            if now - self._last_looking_log >= LOOKING_LOG_PERIOD_S:
                self._last_looking_log = now
                self.get_logger().info(
                    f'looking for an LSL gaze stream: {self._config.describe_selection()}')
            return
        newest = candidates[-1]
        if len(candidates) > 1:
            others = '; '.join(_describe(info) for info in candidates[:-1])
            self.get_logger().warning(
                f'{len(candidates)} LSL streams match {self._config.describe_selection()}: '
                f'using the newest, {_describe(newest)} (also found: {others}); set '
                f'source_id to choose')
            self._reported_uids.update(info.uid() for info in candidates[:-1])
        if self._gone is not None:
            gone_uid, gone = self._gone
            if gone_uid == newest.uid():
                self.get_logger().info(f'{gone} is back (its connection broke); reconnecting')
            else:
                self.get_logger().warning(f'{gone} is gone: switching to the newest matching '
                                          f'stream, {_describe(newest)}')
        self._open(newest, now)

    def _open(self, info: pylsl.StreamInfo, now: float) -> None:
        """Create an inlet for ``info``, read its labels, start clock sync."""
        if info.channel_format() == pylsl.cf_string:
            self.get_logger().warning(f'ignoring {_describe(info)}: it carries strings, '
                                      f'not numbers')
            self._ignored[info.uid()] = math.inf
            return
        inlet = pylsl.StreamInlet(info, max_buflen=_inlet_buflen(info.nominal_srate()),
                                  recover=False)
        try:
            full = inlet.info(timeout=INFO_TIMEOUT_S)
        except LslTimeoutError:
            self.get_logger().warning(f'no description from {_describe(info)} yet; retrying',
                                      throttle_duration_sec=WARN_THROTTLE_S)
            return
        except LostError:
            self._ignored[info.uid()] = now + LOST_IGNORE_S
            return
        for call in (inlet.open_stream, inlet.time_correction):
            try:
                call(timeout=0.0)  # start in liblsl's background threads, do not wait
            except LslTimeoutError:
                pass
        connection = _Connection(
            inlet=inlet, uid=full.uid(), source_id=full.source_id(),
            created_at=full.created_at(),
            description=_describe(full), labels=_channel_labels(full),
            buffer=self._make_buffer(inlet), connected_at=now,
            nominal_srate=full.nominal_srate())
        self._connection = connection
        self._gone = None
        self._poll_timer.reset()
        labels = ', '.join(label or '?' for label in connection.labels) or 'no labels'
        self.get_logger().info(f'connected to LSL stream {connection.description}; '
                               f'channels: {labels}')
        self._bind(connection)

    def _make_buffer(self, inlet: pylsl.StreamInlet) -> np.ndarray:
        """Preallocated pull buffer, (max_chunk, channels) in the stream's dtype."""
        return np.empty((self._params['max_chunk'], inlet.channel_count), dtype=inlet.np_dtype)

    def _bind(self, connection: _Connection) -> None:
        """Map the configuration onto the stream's channels, or say why it cannot."""
        try:
            connection.mapping = resolve_mapping(
                self._config, connection.labels, connection.inlet.channel_count)
            connection.mapping_error = ''
        except ValueError as exc:
            connection.mapping = None
            connection.mapping_error = str(exc)
            self.get_logger().warning(
                f'stream {connection.description} does not fit profile '
                f"'{self._config.profile}': {exc}; its samples are dropped until the "
                f'parameters match it')

    def _disconnect(self) -> None:
        """Close the current inlet, if any."""
        connection, self._connection = self._connection, None
        if self._poll_timer is not None:
            self._poll_timer.cancel()
        if connection is not None:
            try:
                connection.inlet.close_stream()
            except Exception:  # noqa: B902 - closing a dead inlet may fail; nothing to do
                pass

    def _refresh_time_correction(self, connection: _Connection, now: float) -> bool:
        """Take liblsl's latest clock-offset estimate without waiting; True if known."""
        try:
            connection.time_correction = connection.inlet.time_correction(timeout=0.0)
        except LslTimeoutError:
            return connection.time_correction is not None
        connection.time_correction_at = now
        if connection.arrival_stamps:
            connection.arrival_stamps = False
            self.get_logger().info(f'clock offset to {connection.description} known again: '
                                   f'stamping samples with their acquisition time')
        return True

    # -- pulling and publishing ------------------------------------------------------

    def _poll(self) -> None:
        """Pull what the inlet holds, convert and publish it."""
        connection = self._connection
        if connection is None:
            return
        now = time.monotonic()
        if connection.time_correction is None and not connection.arrival_stamps:
            if not self._refresh_time_correction(connection, now):
                if now - connection.connected_at < CLOCK_SYNC_TIMEOUT_S:
                    return  # keep samples in the inlet until they can be stamped
                connection.arrival_stamps = True
                self.get_logger().warning(
                    f'no clock offset from {connection.description} after '
                    f'{CLOCK_SYNC_TIMEOUT_S:g} s (LSL time service unreachable?): stamping '
                    f'samples with their arrival time')
        if connection.reading_since is None:
            connection.reading_since = now
        rate = self._publish_rate(connection)
        if connection.tokens_at is not None:
            bucket = max(float(PUBLISH_BURST), rate * self._params['poll_period_s'])
            connection.tokens = min(bucket,
                                    connection.tokens + (now - connection.tokens_at) * rate)
        connection.tokens_at = now
        try:
            budget = int(connection.tokens)
            for _ in range(MAX_PULLS_PER_POLL):
                wanted = min(len(connection.buffer), budget)
                if wanted <= 0:
                    break
                samples, timestamps = connection.inlet.pull_chunk(
                    timeout=0.0, max_samples=wanted, dest_obj=connection.buffer,
                    as_numpy=True)
                count = len(timestamps)
                if count == 0:
                    break
                budget -= count
                connection.tokens -= count
                self._publish_chunk(connection, samples, timestamps, now)
                if count < wanted:
                    break
            if budget <= 0 or connection.backlog_since is not None:
                self._track_backlog(connection, now, rate)
        except LostError:
            self.get_logger().warning(f'lost LSL stream {connection.description} (sender '
                                      f'closed or connection broken); looking for a '
                                      f'matching stream')
            self._drop_lost(connection)
        except Exception as exc:  # noqa: B902 - a node never dies on a sample
            self.get_logger().warning(f'failed to read {connection.description}: {exc}',
                                      throttle_duration_sec=WARN_THROTTLE_S)

    def _publish_rate(self, connection: _Connection) -> float:
        """Return the most samples published per second from this stream."""
        if self._params['max_publish_rate_hz'] > 0.0:
            return self._params['max_publish_rate_hz']
        return max(CATCH_UP_FACTOR * connection.nominal_srate, MIN_AUTO_PUBLISH_RATE_HZ)

    def _track_backlog(self, connection: _Connection, now: float, rate: float) -> None:
        """Say when samples pile up in the inlet faster than they may be published."""
        waiting = connection.inlet.samples_available()
        if connection.backlog_since is None:
            if waiting < rate * BACKLOG_LOG_S:
                return
            connection.backlog_since = now
            connection.backlog_start_count = self._counters['received']
            self.get_logger().warning(
                f'draining a backlog of {waiting} gaze samples from {connection.description} '
                f'at up to {rate:g} samples/s (max_publish_rate_hz); their stamps are their '
                f'acquisition times, so they are published late, not lost',
                throttle_duration_sec=WARN_THROTTLE_S)
        elif waiting == 0:
            drained = self._counters['received'] - connection.backlog_start_count
            self.get_logger().info(f'backlog drained: {drained} gaze samples read in '
                                   f'{now - connection.backlog_since:.1f} s')
            connection.backlog_since = None

    def _clock_pair(self) -> Tuple[int, float]:
        """
        Read the ROS clock (ns) and this machine's LSL clock (s) at the same instant.

        The ROS reading is bracketed by two LSL readings and paired with their
        midpoint; of up to :data:`CLOCK_READS` tries the narrowest bracket wins, so
        a thread switch between the reads cannot shift a chunk's stamps.
        """
        best = None
        for _ in range(CLOCK_READS):
            before = pylsl.local_clock()
            ros_ns = self.get_clock().now().nanoseconds
            after = pylsl.local_clock()
            if best is None or after - before < best[0]:
                best = (after - before, ros_ns, 0.5 * (before + after))
            if best[0] <= CLOCK_BRACKET_S:
                break
        return best[1], best[2]

    def _publish_chunk(self, connection: _Connection, samples: np.ndarray,
                       timestamps: np.ndarray, now: float) -> None:
        """Stamp, convert and publish one chunk; count what is dropped."""
        count = len(timestamps)
        self._counters['received'] += count
        connection.last_sample_at = now
        if connection.stale:
            connection.stale = False
            self.get_logger().info(f'gaze samples from {connection.description} resumed')
        if connection.mapping is None:
            self._counters['layout'] += count
            self.get_logger().warning(
                f'dropping gaze samples: {connection.mapping_error}',
                throttle_duration_sec=WARN_THROTTLE_S)
            return

        # Map LSL time to the ROS clock at the moment of the pull (see module doc).
        ros_now_ns, lsl_now = self._clock_pair()
        if connection.arrival_stamps:
            delta_s = np.zeros(count)
        else:
            delta_s = np.asarray(timestamps, dtype=np.float64) \
                + connection.time_correction - lsl_now
        with np.errstate(invalid='ignore'):
            stamp_s = ros_now_ns * 1e-9 + delta_s
            good_stamp = np.isfinite(stamp_s) & (stamp_s >= 0.0) & (stamp_s < _MAX_STAMP_S)
        if not good_stamp.all():
            self._counters['bad_stamp'] += int(np.count_nonzero(~good_stamp))
            self.get_logger().warning(
                f'dropping gaze samples with unusable LSL timestamps from '
                f'{connection.description}', throttle_duration_sec=WARN_THROTTLE_S)
            samples, delta_s = samples[good_stamp], delta_s[good_stamp]

        batch = convert(samples, connection.mapping)
        dropped = sum(batch.dropped.values())
        if dropped:
            for reason, number in batch.dropped.items():
                self._counters[reason] += number
            reasons = ', '.join(f'{number} {reason}'
                                for reason, number in batch.dropped.items() if number)
            self.get_logger().warning(
                f'dropped invalid gaze samples ({reasons} in the last chunk; totals: '
                f'{self._drop_totals()})', throttle_duration_sec=WARN_THROTTLE_S)
        if not len(batch.xy):
            return
        stamps_ns = ros_now_ns + np.rint(delta_s[batch.keep] * 1e9).astype(np.int64)
        seconds, nanoseconds = np.divmod(stamps_ns, 1_000_000_000)
        for (x, y), sec, nanosec in zip(batch.xy.tolist(), seconds.tolist(),
                                        nanoseconds.tolist()):
            self._publisher.publish(PointStamped(
                header=Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=SCREEN_FRAME),
                point=Point(x=x, y=y, z=0.0)))
        self._counters['published'] += len(batch.xy)

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
        source = self.stream or 'no stream'
        self.get_logger().info(
            f'gaze: {received} received, {published} published in the last '
            f"{self._params['stats_period_s']:g} s from {source}; dropped since start: "
            f'{self._drop_totals()}')


def main(args=None):
    """Run the bridge until Ctrl-C."""
    spin_node(lambda: LslGazeBridge(), args)


if __name__ == '__main__':
    main()
