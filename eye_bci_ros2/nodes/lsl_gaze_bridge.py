"""
Node ``lsl_gaze_bridge``: eye-tracker gaze from an LSL stream to ROS 2.

Finds the LSL stream of an eye-tracker application (profile + stream type /
name / source_id), pulls its samples in chunks, converts them to points on
the ``screen`` (px, top-left origin; :mod:`eye_bci_ros2.gaze_profiles`) and
publishes

* every valid sample on ``gaze/samples`` (sensor_msgs/PointCloud2), one
  message per pulled chunk, each sample with its own acquisition time on the
  ROS clock (:mod:`eye_bci_ros2.nodes.conversions`, "Gaze batches";
  :mod:`eye_bci_ros2.gaze_stream` for the stamps): the cost follows the poll
  rate, not the tracker rate;
* the newest sample on ``gaze/point`` (geometry_msgs/PointStamped) at most
  ``point_rate_hz`` times a second, for people and simple tools;
* whether the newest sample is on the screen on ``gaze/on_screen``
  (std_msgs/Bool, latched): true when it is finite (a tracker that lost the
  eyes sends NaN), confident and within ``offscreen_margin_px`` of the screen,
  i.e. when the bridge publishes it; published when it changes and once when
  a stream starts sending, never per sample; false when the stream goes
  stale (nothing for ``stale_timeout_s``) or is lost.

``gaze_correction`` (6 doubles, row-major 2 x 3 affine on screen px, or
12: those, then second-order terms; :func:`eye_bci_ros2.validation.as_matrix`;
:data:`eye_bci_ros2.validation.IDENTITY` = none) is applied to every sample
after the screen scaling and before the off-screen check
(:func:`eye_bci_ros2.validation.apply_correction`); ``gaze_validation``
fits it and sets it through the parameter service, and saves it as a
parameter file for ``--params-file``.  An implausible correction (scale,
rotation or shift anywhere on the screen beyond
:func:`eye_bci_ros2.validation.implausibility`'s limits) is refused with the reason.

Nothing here blocks the executor for long: the stream is found by a
``pylsl.ContinuousResolver`` that a timer polls, chunks are pulled with a
zero timeout, and the clock offset to the sender is estimated by liblsl in
the background.  The only waits are fetching the full stream description
once per connection (at most 0.2 s, usually a few ms on a LAN).  Samples are
held back until the first time-correction estimate (about 0.7 s after
connecting); if none comes within 5 s (UDP time service unreachable) the
bridge warns and stamps with arrival time until one does.

Bursts: a backlog (a sender that stalled and then pushed seconds of gaze at
once, or samples held while the executor was busy) waits in the inlet's
buffer, which liblsl fills without loss up to ``INLET_BUFFER_S`` of gaze, and
is published in chunks of ``max_chunk`` samples, at most
:data:`MAX_PULLS_PER_POLL` chunks per poll so the executor keeps serving
other callbacks.  Stamps stay acquisition times, so a drained backlog is
exactly as old as it is.

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
reported once and never used.  While no stream matches, the bridge names
the streams it does see and the parameters that would select each.
"""

from dataclasses import dataclass, replace
import math
import time
from typing import Any, Dict, List, Optional, Tuple

from geometry_msgs.msg import PointStamped
import numpy as np
import pylsl
from pylsl.util import LostError, TimeoutError as LslTimeoutError
from rclpy.node import Node
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Bool

from eye_bci_ros2.gaze_profiles import (
    ANY, build_config, convert, DEFAULT_PROFILE, DROP_REASONS, GazeConfig, GazeMapping,
    NO_CONFIDENCE, ORIGINS, PROFILE_NAMES, resolve_mapping, stream_matches, UNITS,
    xpath_predicate)
from eye_bci_ros2.gaze_stream import (acquisition_stamps_ns, channel_labels, describe_stream,
                                      how_to_choose, inlet_buflen, report_unmatched)
from eye_bci_ros2.nodes.conversions import gaze_batch, gaze_point
from eye_bci_ros2.nodes.log_throttle import WARN_PERIOD_S
from eye_bci_ros2.nodes.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.nodes.runner import spin_node
from eye_bci_ros2.nodes.topics import (GAZE_ON_SCREEN_TOPIC, GAZE_POINT_TOPIC, GAZE_QOS,
                                       GAZE_SAMPLES_TOPIC, LATCHED_QOS, VIEW_QOS)
from eye_bci_ros2.validation import (as_matrix, correction_values, IDENTITY, implausibility,
                                     is_identity, PARAMETER as CORRECTION_PARAMETER)
from eye_bci_ros2.visual_angle import DEFAULT_VIEWING

#: Longest wait for a stream's full description when connecting, s.
INFO_TIMEOUT_S = 0.2
#: Without a time-correction estimate after this long, stamp by arrival, s.
CLOCK_SYNC_TIMEOUT_S = 5.0
#: A resolver forgets a stream this long after it stopped answering, s.
RESOLVER_FORGET_S = 2.0
#: A lost stream is not reopened for this long (the resolver may still list a dead
#: outlet); after it, a stream whose connection only broke can be used again, s.
LOST_IGNORE_S = 2.5 * RESOLVER_FORGET_S
#: Most chunks pulled per poll, so a huge backlog cannot hog the executor (8 chunks of
#: the default 1024 samples per 2 ms poll drain a burst at 4 million samples/s).
MAX_PULLS_PER_POLL = 8
#: "Still looking" at most this often, s.
LOOKING_LOG_PERIOD_S = 10.0
#: The first "still looking" report (naming the streams seen) this long after looking began, s.
FIRST_REPORT_S = 1.5
#: Tries at reading the ROS and LSL clocks together, and a bracket good enough, s.
CLOCK_READS = 3
CLOCK_BRACKET_S = 20e-6
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
              'inlet, so it bounds the added latency (see the README, Performance)',
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


def _resolver(predicate: str) -> Optional[pylsl.ContinuousResolver]:
    """Resolve streams matching an XPath ``predicate`` ('' = all) in liblsl's background."""
    try:
        if predicate:
            return pylsl.ContinuousResolver(pred=predicate, forget_after=RESOLVER_FORGET_S)
        return pylsl.ContinuousResolver(forget_after=RESOLVER_FORGET_S)
    except Exception:  # noqa: B902 - liblsl errors must not kill the node
        return None


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


class LslGazeBridge(Node):
    """Publish gaze points from an eye tracker's LSL stream on ``gaze``."""

    def __init__(self, **kwargs):
        """Declare parameters, start looking for the stream; ``kwargs`` go to Node."""
        super().__init__('lsl_gaze_bridge', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._on_parameters, _check_all)
        self._config: GazeConfig = build_config(self._params)
        self._batch_publisher = self.create_publisher(
            PointCloud2, GAZE_SAMPLES_TOPIC, GAZE_QOS)
        self._point_publisher = self.create_publisher(PointStamped, GAZE_POINT_TOPIC, VIEW_QOS)
        self._on_screen_publisher = self.create_publisher(Bool, GAZE_ON_SCREEN_TOPIC,
                                                          LATCHED_QOS)
        # The last gaze/on_screen published (None: none since the stream started).
        self._on_screen: Optional[bool] = None
        # gaze_correction as (2, 3), None = identity (nothing to do per sample).
        self._correction: Optional[np.ndarray] = _correction(self._params)
        # When gaze/point was last published (monotonic s).
        self._point_at = -math.inf
        # Every stream on the network, resolved only while none matches (for the report).
        self._all_streams: Optional[pylsl.ContinuousResolver] = None
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
        return bool(self._connection and self._connection.stale)

    def destroy_node(self):
        """Close the inlet and the resolver, then destroy the node."""
        self._disconnect()
        self._resolver = None
        self._all_streams = None
        return super().destroy_node()

    # -- parameters -----------------------------------------------------------------

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        """Apply accepted parameter changes at once."""
        self._params.update(changed)
        if CORRECTION_PARAMETER in changed:
            self._correction = _correction(self._params)
            self.get_logger().info(
                f'{CORRECTION_PARAMETER}: '
                f'{"none" if self._correction is None else correction_values(self._correction)}')
            if len(changed) == 1:
                return
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
        self._resolver = _resolver(xpath_predicate(self._config))
        if self._resolver is None:
            self.get_logger().error('cannot start the LSL resolver (liblsl failed); retrying')

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
                    self._publish_on_screen(False)
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
                                      throttle_duration_sec=WARN_PERIOD_S)

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
                f"{describe_stream(info)}, uid '{uid}'; it is NOT used: the bridge stays with "
                f"{connection.description}, uid '{connection.uid}'. "
                f'{how_to_choose(info, connection.source_id)}')

    def _drop_lost(self, connection: _Connection) -> None:
        """Forget a stream that went away; the next one opened is announced as its successor."""
        self._ignored[connection.uid] = time.monotonic() + LOST_IGNORE_S
        self._gone = (connection.uid, connection.description)
        self._disconnect()
        self._publish_on_screen(False)

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
            if self._all_streams is None:
                self._all_streams = _resolver('')
                # The first report once that resolver has heard the network (~1 s).
                self._last_looking_log = now - LOOKING_LOG_PERIOD_S + FIRST_REPORT_S
            if now - self._last_looking_log >= LOOKING_LOG_PERIOD_S:
                self._last_looking_log = now
                seen = self._all_streams.results() if self._all_streams is not None else []
                self.get_logger().info(
                    f'looking for an LSL gaze stream: {self._config.describe_selection()}; '
                    f'{report_unmatched(seen, self._config)}')
            return
        self._all_streams = None
        newest = candidates[-1]
        if len(candidates) > 1:
            others = '; '.join(describe_stream(info) for info in candidates[:-1])
            self.get_logger().warning(
                f'{len(candidates)} LSL streams match {self._config.describe_selection()}: '
                f'using the newest, {describe_stream(newest)} (also found: {others}); set '
                f'source_id to choose')
            self._reported_uids.update(info.uid() for info in candidates[:-1])
        if self._gone is not None:
            gone_uid, gone = self._gone
            if gone_uid == newest.uid():
                self.get_logger().info(f'{gone} is back (its connection broke); reconnecting')
            else:
                self.get_logger().warning(f'{gone} is gone: switching to the newest matching '
                                          f'stream, {describe_stream(newest)}')
        self._open(newest, now)

    def _open(self, info: pylsl.StreamInfo, now: float) -> None:
        """Create an inlet for ``info``, read its labels, start clock sync."""
        if info.channel_format() == pylsl.cf_string:
            self.get_logger().warning(f'ignoring {describe_stream(info)}: it carries strings, '
                                      f'not numbers')
            self._ignored[info.uid()] = math.inf
            return
        inlet = pylsl.StreamInlet(info, max_buflen=inlet_buflen(info.nominal_srate()),
                                  recover=False)
        try:
            full = inlet.info(timeout=INFO_TIMEOUT_S)
        except LslTimeoutError:
            self.get_logger().warning(f'no description from {describe_stream(info)} yet; retrying',
                                      throttle_duration_sec=WARN_PERIOD_S)
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
            description=describe_stream(full), labels=channel_labels(full),
            buffer=self._make_buffer(inlet), connected_at=now,
            nominal_srate=full.nominal_srate())
        self._connection = connection
        self._gone = None
        self._on_screen = None       # published once when this stream starts sending
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
        try:
            for _ in range(MAX_PULLS_PER_POLL):
                samples, timestamps = connection.inlet.pull_chunk(
                    timeout=0.0, max_samples=len(connection.buffer),
                    dest_obj=connection.buffer, as_numpy=True)
                count = len(timestamps)
                if count == 0:
                    break
                self._publish_chunk(connection, samples, timestamps, now)
                if count < len(connection.buffer):
                    break
        except LostError:
            self.get_logger().warning(f'lost LSL stream {connection.description} (sender '
                                      f'closed or connection broken); looking for a '
                                      f'matching stream')
            self._drop_lost(connection)
        except Exception as exc:  # noqa: B902 - a node never dies on a sample
            self.get_logger().warning(f'failed to read {connection.description}: {exc}',
                                      throttle_duration_sec=WARN_PERIOD_S)

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
                throttle_duration_sec=WARN_PERIOD_S)
            return

        # Map LSL time to the ROS clock at the moment of the pull (gaze_stream).
        ros_now_ns, lsl_now = self._clock_pair()
        stamps_ns, good_stamp = acquisition_stamps_ns(
            timestamps, None if connection.arrival_stamps else connection.time_correction,
            ros_now_ns, lsl_now)
        if not good_stamp.all():
            self._counters['bad_stamp'] += int(np.count_nonzero(~good_stamp))
            self.get_logger().warning(
                f'dropping gaze samples with unusable LSL timestamps from '
                f'{connection.description}', throttle_duration_sec=WARN_PERIOD_S)
            samples, stamps_ns = samples[good_stamp], stamps_ns[good_stamp]

        batch = convert(samples, connection.mapping, self._correction)
        if len(batch.keep):
            self._publish_on_screen(bool(batch.keep[-1]))
        dropped = sum(batch.dropped.values())
        if dropped:
            for reason, number in batch.dropped.items():
                self._counters[reason] += number
            reasons = ', '.join(f'{number} {reason}'
                                for reason, number in batch.dropped.items() if number)
            self.get_logger().warning(
                f'dropped invalid gaze samples ({reasons} in the last chunk; totals: '
                f'{self._drop_totals()})', throttle_duration_sec=WARN_PERIOD_S)
        if not len(batch.xy):
            return
        stamps_ns = stamps_ns[batch.keep]
        self._batch_publisher.publish(gaze_batch(stamps_ns, batch.xy))
        self._counters['published'] += len(batch.xy)
        rate = self._params['point_rate_hz']
        if rate > 0.0 and now - self._point_at >= 1.0 / rate:
            self._point_at = now
            self._point_publisher.publish(
                gaze_point(stamps_ns[-1], batch.xy[-1, 0], batch.xy[-1, 1]))

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
        source = self.stream or 'no stream'
        self.get_logger().info(
            f'gaze: {received} received, {published} published in the last '
            f"{self._params['stats_period_s']:g} s from {source}; dropped since start: "
            f'{self._drop_totals()}')


def main(args=None):
    """Run the bridge until Ctrl-C."""
    spin_node(LslGazeBridge, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
