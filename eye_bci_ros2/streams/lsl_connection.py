"""
One LSL stream connection, pure and clock-injected: both LSL nodes read their stream through it.

:class:`StreamConnection` finds the stream a :class:`StreamProfile` asks for,
keeps it or switches, pulls its samples and stamps them on the ROS clock; the
gaze bridge (:mod:`eye_bci_ros2.nodes.lsl_gaze_bridge`) and the SSVEP decoder
(:mod:`eye_bci_ros2.nodes.ssvep_decoder`) only turn its chunks into messages.
No pylsl here: liblsl sits behind the small :class:`Lsl` / :class:`Inlet`
interfaces, implemented with pylsl by :mod:`eye_bci_ros2.ros.lsl_adapter`,
so the pure rules are tested alone (``test/unit/streams/``) and every rule
with real liblsl and real outlets (``test/streams/test_lsl_connection.py``,
and the node tests).  The model is mne-lsl's ``StreamLSL`` (connect / acquire /
disconnect), with the I/O apart as in tf2's Buffer and listener.

Rules (docs/DESIGN.md, "LSL streams"):

* **Which stream.**  A stream is a candidate when the profile matches its
  type / name / source_id; it is taken only when it carries numbers and its
  channels fit the profile (:meth:`StreamProfile.misfit`); a refused stream
  is named once with the reason.  Of several fitting streams the newest of
  the source last used (an application that restarted) is taken, else the
  newest when they all share one non-empty source_id (one device), else
  *none*: they may be different people's devices, so the connection names
  them and how to pick one, and waits.
* **Keep or switch.**  A quiet stream (nothing for ``stale_timeout_s``) is
  reported and kept while it is advertised (a tracker sends nothing while it
  sees no eyes); only a stream that is lost or no longer advertised is
  replaced, by the rule above, with a warning.  A lost stream is ignored for
  :data:`LOST_IGNORE_S` (the resolver may still list it); the ignore-list
  expires.
* **Time.**  ``t_ros = t_lsl + time_correction + (ros_now - lsl_now)``
  (:func:`acquisition_stamps_ns`); ``ros_now`` and ``lsl_now`` are read
  together by :func:`clock_pair` at each pull.  No clock offset yet: samples
  wait in the inlet up to :data:`CLOCK_SYNC_TIMEOUT_S`; then, with a warning,
  each chunk is placed so that its newest sample is at its arrival time (the
  spacing inside a chunk kept) until an offset arrives.
* **Health.**  Gaps in a regular-rate stream (:func:`find_gaps`) are counted
  and reported; the rate the sample times show between gaps is measured
  (:attr:`StreamConnection.measured_rate_hz`).
"""

from dataclasses import dataclass, field
import math
import time
from typing import Callable, Dict, List, Optional, Protocol, Sequence, Tuple

import numpy as np

#: Longest wait for a stream's full description (its channel labels), s.
INFO_TIMEOUT_S = 0.2
#: Without a clock offset after this long, chunks are placed by their arrival time, s.
CLOCK_SYNC_TIMEOUT_S = 5.0
#: A resolver forgets a stream this long after it stopped answering, s.
RESOLVER_FORGET_S = 2.0
#: A lost stream is not reopened for this long (the resolver may still list a dead
#: outlet); after it, a stream whose connection only broke can be used again, s.
LOST_IGNORE_S = 2.5 * RESOLVER_FORGET_S
#: Most chunks pulled per poll, so a huge backlog cannot hog the executor (8 chunks of
#: 1024 samples per 2 ms poll drain a burst at 4 million samples/s).
MAX_PULLS_PER_POLL = 8
#: "Still looking" at most this often, s.
LOOKING_LOG_PERIOD_S = 10.0
#: The first "still looking" report (naming the streams seen) this long after looking began, s.
FIRST_REPORT_S = 1.5
#: Tries at reading the ROS and LSL clocks together, and a bracket good enough, s.
CLOCK_READS = 3
CLOCK_BRACKET_S = 20e-6
#: Inlet buffer, s of samples (a 100 000-sample burst of a 1200 Hz tracker is 83 s); liblsl
#: drops the oldest samples beyond it, uncounted.
INLET_BUFFER_S = 120
#: Rate assumed to size the inlet buffer of an irregular-rate stream, Hz
#: (EyeLink-class trackers send 2000 Hz).
IRREGULAR_BUFFER_RATE_HZ = 2000.0
#: Stamps must fit builtin_interfaces/Time (int32 seconds).
MAX_STAMP_S = 2.0 ** 31 - 1
#: A regular-rate stream has a gap where two samples are more than this many nominal
#: periods apart, and at least :data:`GAP_MIN_S` (sender jitter is not a gap).
GAP_PERIODS = 5.0
GAP_MIN_S = 0.1
#: The measured rate is taken over at least this span of sample times, s.
RATE_SPAN_S = 2.0


class StreamLost(Exception):
    """The stream's sender went away or the connection broke (liblsl's LostError)."""


class NotReady(Exception):
    """The stream did not answer in time (liblsl's TimeoutError); try again later."""


@dataclass(frozen=True)
class StreamDescription:
    """
    What the LSL network says about one stream (pylsl's ``StreamInfo``, as plain data).

    :param labels: channel labels from the full description ('' where a
        channel has none); None until the description was read.
    """

    uid: str
    name: str
    stream_type: str
    source_id: str
    hostname: str
    channel_count: int
    nominal_srate: float
    created_at: float
    numeric: bool = True
    labels: Optional[Tuple[str, ...]] = None
    #: The adapter's own object for this stream (pylsl's StreamInfo), opaque here.
    handle: object = field(default=None, compare=False, repr=False)

    def describe(self) -> str:
        """Name the stream in one line for log messages."""
        rate = self.nominal_srate
        rate_text = f'{rate:g} Hz' if rate > 0 else 'irregular rate'
        return (f"'{self.name}' (type '{self.stream_type}', source_id '{self.source_id}', "
                f'{self.channel_count} ch, {rate_text}, host {self.hostname})')


class Inlet(Protocol):
    """One open inlet (the adapter's pylsl ``StreamInlet``, ``recover=False``)."""

    def start(self) -> None:
        """Connect (briefly), open the data stream, start the clock offset; may raise."""

    def time_correction(self) -> Optional[float]:
        """Return liblsl's latest offset sender -> this machine's LSL clock, s; None if unknown."""

    def pull(self) -> Tuple[np.ndarray, np.ndarray]:
        """Pull at most one buffer: samples (N, C), LSL stamps (N,) s; raise StreamLost."""

    def close(self) -> None:
        """Close the data stream (never raises)."""


class Resolver(Protocol):
    """A continuous resolver (liblsl's background thread)."""

    def results(self) -> List[StreamDescription]:
        """Return the streams advertised now (no labels)."""


class Lsl(Protocol):
    """liblsl, as the connection uses it (:mod:`eye_bci_ros2.ros.lsl_adapter`)."""

    def local_clock(self) -> float:
        """Return this machine's LSL clock, s."""

    def resolver(self, predicate: str) -> Resolver:
        """Resolve streams matching an XPath ``predicate`` ('' = all); raise on failure."""

    def describe(self, stream: StreamDescription) -> StreamDescription:
        """Return ``stream`` with its labels; raise NotReady or StreamLost."""

    def open_inlet(self, stream: StreamDescription, max_chunk: int) -> Inlet:
        """Open an inlet pulling at most ``max_chunk`` samples at once."""


class StreamProfile(Protocol):
    """Which streams a node wants (:mod:`eye_bci_ros2.gaze.stream`, ``ssvep.eeg_stream``)."""

    #: What the stream carries, for log lines ('gaze', 'EEG').
    kind: str

    def predicate(self) -> str:
        """Return the XPath that liblsl's resolver filters by ('' = all streams)."""

    def matches(self, stream: StreamDescription) -> bool:
        """Tell whether type, name and source_id are the selected ones."""

    def misfit(self, stream: StreamDescription) -> Optional[str]:
        """Say why a matching stream's channels do not fit (None: they fit); labels known."""

    def describe(self) -> str:
        """Say which streams are selected, e.g. "type 'Gaze', source_id 'x'"."""

    def how_to_select(self, stream: StreamDescription) -> str:
        """Say which parameters would select a stream that does not match now."""

    def unusable(self, stream: StreamDescription) -> Optional[str]:
        """Say why no parameters would make ``stream`` one of this kind (None: they may)."""


class Reporter(Protocol):
    """Where the connection's log lines go (the node's logger and warning throttle)."""

    def info(self, text: str) -> None:
        """Log once."""

    def warning(self, text: str) -> None:
        """Warn once."""

    def throttled(self, key: str, text: str) -> None:
        """Warn at most once per throttle period for this kind ``key``."""


@dataclass(frozen=True)
class ConnectionSettings:
    """
    How a connection behaves (the node's parameters).

    :param stale_timeout_s: report a stream that sent nothing for this long, s.
    :param time_correction_period_s: refresh the clock offset this often, s.
    :param max_chunk: most samples per pull.
    """

    stale_timeout_s: float = 2.0
    time_correction_period_s: float = 5.0
    max_chunk: int = 1024


@dataclass
class Chunk:
    """
    Samples of one pull, stamped on the ROS clock.

    :param samples: shape (N, C), the stream's dtype.
    :param stamps_ns: shape (N,), int64 acquisition times, ns (0 where not ``good``).
    :param good: shape (N,), bool: false for an unusable LSL stamp.
    """

    samples: np.ndarray
    stamps_ns: np.ndarray
    good: np.ndarray


def inlet_buflen(nominal_srate: float) -> int:
    """
    Return pylsl's ``max_buflen`` for :data:`INLET_BUFFER_S` of samples.

    liblsl reads it as seconds for a stream with a nominal rate, but as
    hundreds of samples for an irregular one (nominal rate 0).
    """
    if nominal_srate > 0:
        return INLET_BUFFER_S
    return int(math.ceil(INLET_BUFFER_S * IRREGULAR_BUFFER_RATE_HZ / 100.0))


def clock_pair(ros_now_ns: Callable[[], int], lsl_now: Callable[[], float]) -> Tuple[int, float]:
    """
    Read the ROS clock (ns) and this machine's LSL clock (s) at the same instant.

    The ROS reading is bracketed by two LSL readings and paired with their
    midpoint; of up to :data:`CLOCK_READS` tries the narrowest bracket wins, so
    a thread switch between the reads cannot shift a chunk's stamps.
    """
    best = None
    for _ in range(CLOCK_READS):
        before = lsl_now()
        ros_ns = ros_now_ns()
        after = lsl_now()
        if best is None or after - before < best[0]:
            best = (after - before, ros_ns, 0.5 * (before + after))
        if best[0] <= CLOCK_BRACKET_S:
            break
    return best[1], best[2]


def acquisition_stamps_ns(timestamps: np.ndarray, time_correction: Optional[float],
                          ros_now_ns: int, lsl_now: float) -> Tuple[np.ndarray, np.ndarray]:
    """
    Map the LSL timestamps of a chunk to acquisition times on the ROS clock (module doc).

    :param timestamps: shape (N,), s on the sender's LSL clock.
    :param time_correction: sender clock -> this machine's LSL clock, s; None
        when unknown: the chunk is then placed so that its newest finite
        sample is at ``ros_now_ns`` (arrival), keeping the spacing inside it.
    :param ros_now_ns: the ROS clock, ns, read together with ``lsl_now``.
    :param lsl_now: this machine's LSL clock, s.
    :returns: ``(stamps_ns, good)``: shape (N,) int64 ns (0 where not good)
        and (N,) bool, false for a stamp that is not finite or does not fit
        builtin_interfaces/Time (a corrupt LSL timestamp).
    """
    timestamps = np.asarray(timestamps, dtype=np.float64).reshape(-1)
    with np.errstate(invalid='ignore', over='ignore'):
        if time_correction is None:
            finite = timestamps[np.isfinite(timestamps)]
            newest = finite.max() if len(finite) else 0.0
            delta_s = timestamps - newest
        else:
            delta_s = timestamps + time_correction - lsl_now
        stamp_s = ros_now_ns * 1e-9 + delta_s
        if len(stamp_s) and 0.0 <= stamp_s.min() and stamp_s.max() < MAX_STAMP_S:
            # Every stamp usable (a NaN fails the test): the common case, in fewer steps.
            return (ros_now_ns + np.rint(delta_s * 1e9).astype(np.int64),
                    np.ones(len(stamp_s), dtype=bool))
        good = np.isfinite(stamp_s) & (stamp_s >= 0.0) & (stamp_s < MAX_STAMP_S)
    stamps_ns = np.zeros(len(timestamps), dtype=np.int64)
    stamps_ns[good] = ros_now_ns + np.rint(delta_s[good] * 1e9).astype(np.int64)
    return stamps_ns, good


def find_gaps(stamps: np.ndarray, nominal_srate: float,
              previous: Optional[float] = None) -> np.ndarray:
    """
    Find gaps in the sample times of a regular-rate stream.

    :param stamps: the chunk's finite sample times (N,), LSL s, in arrival order (the
        caller drops the non-finite ones once, for this and the rate).
    :param nominal_srate: Hz; 0 (irregular) has no gaps by definition.
    :param previous: the stamp of the sample before this chunk, s, or None.
    :returns: the length of each gap, s, shape (G,).
    """
    stamps = np.asarray(stamps, dtype=np.float64)
    if nominal_srate <= 0 or not len(stamps):
        return np.zeros(0)
    limit = max(GAP_PERIODS / nominal_srate, GAP_MIN_S)
    # The step from the previous chunk's last sample, then the steps within this one.
    first = float(stamps[0]) - previous if previous is not None else 0.0
    steps = stamps[1:] - stamps[:-1]
    gaps = steps[steps > limit]
    return np.concatenate([[first], gaps]) if first > limit else gaps


@dataclass
class _RateMeter:
    """The rate the sample times show, gaps left out, over spans of at least RATE_SPAN_S."""

    first: Optional[float] = None
    intervals: int = 0
    gap_s: float = 0.0
    rate_hz: Optional[float] = None

    def add(self, finite: np.ndarray, gaps: np.ndarray) -> None:
        """Take a chunk's finite sample times (N,) s and its gaps (:func:`find_gaps`)."""
        if not len(finite):
            return
        if self.first is None:
            self.first, self.intervals, self.gap_s = float(finite[0]), -1, 0.0
        self.intervals += len(finite) - len(gaps)
        self.gap_s += float(gaps.sum())
        span = float(finite[-1]) - self.first - self.gap_s
        if span >= RATE_SPAN_S and self.intervals > 0:
            self.rate_hz = self.intervals / span
            self.first, self.intervals, self.gap_s = float(finite[-1]), 0, 0.0


@dataclass
class _Open:
    """The stream in use and what the connection knows about it."""

    stream: StreamDescription
    inlet: Inlet
    connected_at: float
    time_correction: Optional[float] = None
    time_correction_at: float = -math.inf
    arrival_stamps: bool = False
    reading_since: Optional[float] = None
    last_sample_at: Optional[float] = None
    last_stamp: Optional[float] = None
    stale: bool = False
    rate: _RateMeter = field(default_factory=_RateMeter)


class StreamConnection:
    """
    The stream a profile selects: find it, keep or switch it, pull and stamp its samples.

    Call :meth:`maintain` every ``resolve_period_s`` (finds, checks, refreshes
    the clock offset) and :meth:`acquire` every poll (zero-timeout pulls).

    :param profile: which streams to take.
    :param lsl: liblsl (the pylsl adapter).
    :param settings: timeouts and chunk size.
    :param report: where log lines go.
    :param ros_now_ns: the node's ROS clock, ns.
    :param clock: a monotonic clock, s (for timeouts).
    :param on_connected: called with the stream just opened.
    :param on_quiet: called when the stream went quiet or was lost.
    """

    def __init__(self, profile: StreamProfile, lsl: Lsl, settings: ConnectionSettings,
                 report: Reporter, ros_now_ns: Callable[[], int],
                 clock: Callable[[], float] = time.monotonic,
                 on_connected: Callable[[StreamDescription], None] = lambda stream: None,
                 on_quiet: Callable[[], None] = lambda: None):
        """Start looking for the stream."""
        self.profile = profile
        self.settings = settings
        self._lsl = lsl
        self._report = report
        self._ros_now_ns = ros_now_ns
        self._clock = clock
        self._on_connected = on_connected
        self._on_quiet = on_quiet
        self._open: Optional[_Open] = None
        self._resolver: Optional[Resolver] = None
        self._all_streams: Optional[Resolver] = None
        # Streams not to open: uid -> until when (clock s; inf = for good).
        self._ignored: Dict[str, float] = {}
        # Full descriptions by uid (a uid's description never changes).
        self._described: Dict[str, StreamDescription] = {}
        # uid -> why it does not fit; reported once per uid and profile.
        self._refused: Dict[str, str] = {}
        # Further matching streams already reported while connected.
        self._reported_uids = set()
        # The set of uids last reported as "several match" (reported once per set).
        self._ambiguous: frozenset = frozenset()
        # The stream that went away, until another one is opened.
        self._gone: Optional[StreamDescription] = None
        # source_id of the stream last used ('' = none yet): preferred after a loss.
        self._last_source = ''
        self._looking_since: Optional[float] = None
        self._last_looking_log = -math.inf
        #: Gaps found in the stream(s) read, and their total length, s.
        self.gaps = 0
        self.gap_s = 0.0
        #: The ROS time of the newest sample pulled (None before any), ns.
        self.newest_stamp_ns: Optional[int] = None
        self._start_resolver()

    # -- state ------------------------------------------------------------------------------

    @property
    def stream(self) -> Optional[StreamDescription]:
        """Return the stream in use (with its labels); None while looking."""
        return self._open.stream if self._open else None

    @property
    def stale(self) -> bool:
        """Tell whether the stream in use has sent nothing for ``stale_timeout_s``."""
        return bool(self._open and self._open.stale)

    @property
    def measured_rate_hz(self) -> Optional[float]:
        """Return the rate the stream's sample times show, Hz (None until measured)."""
        return self._open.rate.rate_hz if self._open else None

    @property
    def clock_offset(self) -> Optional[float]:
        """Return the clock offset in use, s (None: unknown, or chunks placed by arrival)."""
        if self._open is None or self._open.arrival_stamps:
            return None
        return self._open.time_correction

    # -- connect / disconnect ---------------------------------------------------------------

    def reselect(self, profile: StreamProfile, settings: Optional[ConnectionSettings] = None):
        """Take a new profile: close the stream and look again, forgetting past refusals."""
        self.profile = profile
        if settings is not None:
            self.settings = settings
        self.disconnect()
        self._ignored.clear()
        self._refused.clear()
        self._reported_uids.clear()
        self._ambiguous = frozenset()
        self._gone = None
        self._last_source = ''
        self._start_resolver()

    def refit(self, profile: StreamProfile, settings: Optional[ConnectionSettings] = None):
        """Take a profile with the same selection: refused streams are judged again."""
        self.profile = profile
        if settings is not None:
            self.settings = settings
        self._refused.clear()
        self._ambiguous = frozenset()

    def disconnect(self) -> None:
        """Close the inlet, if any (it stays closed until :meth:`maintain` finds a stream)."""
        opened, self._open = self._open, None
        if opened is not None:
            opened.inlet.close()

    def close(self) -> None:
        """Close the inlet and stop resolving."""
        self.disconnect()
        self._resolver = None
        self._all_streams = None

    def _start_resolver(self) -> None:
        try:
            self._resolver = self._lsl.resolver(self.profile.predicate())
        except Exception as error:  # noqa: B902 - liblsl errors must not kill the node
            self._resolver = None
            self._report.throttled('resolver', f'cannot start the LSL resolver: {error}; '
                                               'retrying')

    def _is_ignored(self, uid: str, now: float) -> bool:
        until = self._ignored.get(uid)
        if until is None:
            return False
        if now < until:
            return True
        del self._ignored[uid]
        return False

    def _candidates(self, now: float) -> List[StreamDescription]:
        """List the matching streams advertised now that are not ignored, oldest first."""
        if self._resolver is None:
            self._start_resolver()
            if self._resolver is None:
                return []
        advertised = self._resolver.results()
        # Descriptions of streams gone from the network are dropped (uids never come back).
        seen = {stream.uid for stream in advertised}
        self._described = {uid: full for uid, full in self._described.items() if uid in seen}
        found = [stream for stream in advertised
                 if self.profile.matches(stream) and not self._is_ignored(stream.uid, now)]
        return sorted(found, key=lambda stream: stream.created_at)

    # -- maintain: find, keep or switch -----------------------------------------------------

    def maintain(self) -> None:
        """Connect when idle; refresh the clock offset; report other and quiet streams."""
        now = self._clock()
        opened = self._open
        if opened is None:
            self._connect(now)
            return
        if now - opened.time_correction_at >= self.settings.time_correction_period_s:
            self._refresh_time_correction(opened, now)
        candidates = self._candidates(now)
        self._report_others(opened, candidates)
        quiet_since = opened.last_sample_at or opened.reading_since
        if quiet_since is None or now - quiet_since < self.settings.stale_timeout_s:
            return  # still waiting for the clock offset, or not quiet
        if any(stream.uid == opened.stream.uid for stream in candidates):
            if not opened.stale:
                opened.stale = True
                self._on_quiet()
                self._report.warning(
                    f'no {self.profile.kind} samples from {opened.stream.describe()} for '
                    f'{now - quiet_since:.1f} s; it is still advertised, so it is kept and '
                    f'waited for')
            return
        # Quiet and no longer advertised: the sender is gone (a lost connection usually
        # raises StreamLost in acquire first).
        self._report.warning(f'{opened.stream.describe()} is no longer advertised; looking '
                             f'for another')
        self._drop_lost(opened, now)
        self._connect(now)

    def _report_others(self, opened: _Open, candidates: List[StreamDescription]) -> None:
        """Warn once about each further matching stream: it is not used."""
        for stream in candidates:
            if stream.uid == opened.stream.uid or stream.uid in self._reported_uids:
                continue
            self._reported_uids.add(stream.uid)
            if self.profile.unusable(stream) or stream.uid in self._refused:
                continue   # never this profile's (an EEG stream for gaze): not suggested
            self._report.warning(
                f'another LSL stream matches {self.profile.describe()}: {stream.describe()}, '
                f"uid '{stream.uid}'; it is NOT used: staying with {opened.stream.describe()}, "
                f"uid '{opened.stream.uid}'. {how_to_choose(stream, opened.stream)}")

    def _describe(self, stream: StreamDescription, now: float) -> Optional[StreamDescription]:
        """Return the stream with its labels (cached), or None when it cannot be read now."""
        known = self._described.get(stream.uid)
        if known is not None:
            return known
        try:
            full = self._lsl.describe(stream)
        except NotReady:
            self._report.throttled('describe', f'no description from {stream.describe()} yet; '
                                               'retrying')
            return None
        except StreamLost:
            self._ignored[stream.uid] = now + LOST_IGNORE_S
            return None
        self._described[stream.uid] = full
        return full

    def _refusal(self, stream: StreamDescription) -> Optional[str]:
        """Why a matching stream is not taken (None: it fits); said once per uid."""
        if stream.uid in self._refused:
            return self._refused[stream.uid]
        if not stream.numeric:
            reason = 'it carries strings, not numbers'
        else:
            reason = self.profile.misfit(stream)
        if reason is not None:
            self._refused[stream.uid] = reason
            self._report.warning(f'not taking {stream.describe()}: {reason}')
        return reason

    def _connect(self, now: float) -> None:
        """Open the stream the rules choose among the fitting candidates, if any."""
        if self._looking_since is None:
            self._looking_since = now
        fitting = []
        for stream in self._candidates(now):
            full = stream if not stream.numeric else self._describe(stream, now)
            if full is not None and self._refusal(full) is None:
                fitting.append(full)
        chosen = self._choose(fitting)
        if chosen is None:
            self._report_looking(now, fitting)
            return
        self._all_streams = None
        if self._gone is not None:
            if self._gone.uid == chosen.uid:
                self._report.info(f'{self._gone.describe()} is back (its connection broke); '
                                  'reconnecting')
            elif self._gone.describe() == chosen.describe():
                # Its sender restarted (a new uid): the same stream to the user, no switch.
                self._report.info(f'{chosen.describe()} is back (its sender restarted); '
                                  'reconnecting')
            else:
                self._report.warning(f'{self._gone.describe()} is gone: switching to the '
                                     f'matching stream {chosen.describe()}')
        self._start(chosen, now)

    def _choose(self, fitting: List[StreamDescription]) -> Optional[StreamDescription]:
        """Pick a stream by the rule of the module doc; None while none or several sources fit."""
        if not fitting:
            return None
        if len(fitting) == 1:
            return fitting[0]
        same = [stream for stream in fitting if stream.source_id == self._last_source]
        if self._last_source and same:
            return same[-1]
        sources = {stream.source_id for stream in fitting}
        if len(sources) == 1 and '' not in sources:
            return fitting[-1]
        uids = frozenset(stream.uid for stream in fitting)
        if uids != self._ambiguous:
            self._ambiguous = uids
            listed = '; '.join(f'{stream.describe()}: select with '
                               f'{how_to_pick(stream, fitting)}' for stream in fitting)
            self._report.warning(
                f'{len(fitting)} LSL streams match {self.profile.describe()} and may be '
                f'different devices: taking none until one is chosen. {listed}')
        return None

    def _report_looking(self, now: float, fitting: List[StreamDescription]) -> None:
        """Every LOOKING_LOG_PERIOD_S: what is looked for and which streams exist."""
        if fitting:
            return  # several fit: said when the set changed
        if self._all_streams is None:
            try:
                self._all_streams = self._lsl.resolver('')
            except Exception:  # noqa: B902 - only for the report
                self._all_streams = None
            # The first report once that resolver has heard the network (~1 s).
            self._last_looking_log = now - LOOKING_LOG_PERIOD_S + FIRST_REPORT_S
        if now - self._last_looking_log < LOOKING_LOG_PERIOD_S:
            return
        self._last_looking_log = now
        seen = self._all_streams.results() if self._all_streams is not None else []
        self._report.info(f'looking for an LSL {self.profile.kind} stream: '
                          f'{self.profile.describe()}; {self._report_seen(seen)}')

    def _report_seen(self, streams: Sequence[StreamDescription], limit: int = 8) -> str:
        """List the LSL streams seen while none is taken, each with why or how to select it."""
        if not streams:
            return 'no LSL stream at all is visible (is the sender running, on this network?)'
        lines = []
        for stream in streams[:limit]:
            reason = self._refused.get(stream.uid) or self.profile.unusable(stream)
            if reason:
                lines.append(f'{stream.describe()}: not taken, {reason}')
            else:
                lines.append(f'{stream.describe()}: select with '
                             f'{self.profile.how_to_select(stream)}')
        more = f'; and {len(streams) - limit} more' if len(streams) > limit else ''
        return 'LSL streams seen: ' + '; '.join(lines) + more

    def _start(self, stream: StreamDescription, now: float) -> None:
        """Open an inlet on ``stream`` and start its clock offset."""
        try:
            inlet = self._lsl.open_inlet(stream, self.settings.max_chunk)
            inlet.start()
        except NotReady:
            self._report.throttled('describe', f'no answer from {stream.describe()} yet; '
                                               'retrying')
            return
        except StreamLost:
            self._ignored[stream.uid] = now + LOST_IGNORE_S
            return
        self._open = _Open(stream=stream, inlet=inlet, connected_at=now)
        self._gone = None
        self._looking_since = None
        self._ambiguous = frozenset()
        self._last_source = stream.source_id
        labels = ', '.join(label or '?' for label in stream.labels or ()) or 'no labels'
        self._report.info(f'connected to {self.profile.kind} LSL stream {stream.describe()}; '
                          f'channels: {labels}')
        self._on_connected(stream)

    def _drop_lost(self, opened: _Open, now: float) -> None:
        """Forget a stream that went away; the next one opened is announced as its successor."""
        self._ignored[opened.stream.uid] = now + LOST_IGNORE_S
        self._gone = opened.stream
        self.disconnect()
        self._on_quiet()

    # -- acquire: pull and stamp ------------------------------------------------------------

    def _refresh_time_correction(self, opened: _Open, now: float) -> bool:
        """Take liblsl's latest clock-offset estimate without waiting; True if known."""
        value = opened.inlet.time_correction()
        if value is None:
            return opened.time_correction is not None
        opened.time_correction, opened.time_correction_at = value, now
        if opened.arrival_stamps:
            opened.arrival_stamps = False
            self._report.info(f'clock offset to {opened.stream.describe()} known again: '
                              'stamping samples with their acquisition time')
        return True

    def acquire(self) -> List[Chunk]:
        """Pull what the inlet holds (zero timeout), stamped; [] while waiting or looking."""
        opened = self._open
        if opened is None:
            return []
        now = self._clock()
        if opened.time_correction is None and not opened.arrival_stamps:
            if not self._refresh_time_correction(opened, now):
                if now - opened.connected_at < CLOCK_SYNC_TIMEOUT_S:
                    return []  # keep samples in the inlet until they can be stamped
                opened.arrival_stamps = True
                self._report.warning(
                    f'no clock offset from {opened.stream.describe()} after '
                    f'{CLOCK_SYNC_TIMEOUT_S:g} s (LSL time service unreachable?): placing '
                    'each chunk at its arrival time')
        if opened.reading_since is None:
            opened.reading_since = now
        chunks = []
        try:
            for _ in range(MAX_PULLS_PER_POLL):
                samples, stamps = opened.inlet.pull()
                if not len(stamps):
                    break
                chunks.append(self._stamp(opened, samples, stamps, now))
                if len(stamps) < self.settings.max_chunk:
                    break
        except StreamLost:
            self._report.warning(f'lost {self.profile.kind} stream {opened.stream.describe()} '
                                 '(LSL sender closed or connection broken); looking for a '
                                 'matching stream')
            self._drop_lost(opened, now)
        except Exception as error:  # noqa: B902 - a node never dies on a sample
            self._report.throttled('read', f'failed to read {opened.stream.describe()}: {error}')
        return chunks

    def _stamp(self, opened: _Open, samples: np.ndarray, stamps: np.ndarray,
               now: float) -> Chunk:
        """Stamp one pulled chunk on the ROS clock; note gaps, rate and life."""
        stamps = np.asarray(stamps, dtype=np.float64).reshape(-1)
        opened.last_sample_at = now
        if opened.stale:
            opened.stale = False
            self._report.info(f'{self.profile.kind} samples from {opened.stream.describe()} '
                              'resumed')
        finite = stamps[np.isfinite(stamps)]
        gaps = find_gaps(finite, opened.stream.nominal_srate, opened.last_stamp)
        if len(gaps):
            self.gaps += len(gaps)
            self.gap_s += float(gaps.sum())
            self._report.throttled(
                'gap', f'{len(gaps)} gap(s) in {opened.stream.describe()}, longest '
                       f'{gaps.max():.3f} s ({self.gaps} since start, {self.gap_s:.1f} s in all)')
        if len(finite):
            opened.last_stamp = float(finite[-1])
        opened.rate.add(finite, gaps)
        ros_now_ns, lsl_now = clock_pair(self._ros_now_ns, self._lsl.local_clock)
        stamps_ns, good = acquisition_stamps_ns(
            stamps, None if opened.arrival_stamps else opened.time_correction,
            ros_now_ns, lsl_now)
        if good.any():
            self.newest_stamp_ns = int(stamps_ns[good].max())
        return Chunk(samples=samples, stamps_ns=stamps_ns, good=good)


def how_to_choose(stream: StreamDescription, current: StreamDescription) -> str:
    """Tell the user how to select ``stream`` instead of the one in use."""
    if stream.source_id and stream.source_id != current.source_id:
        return f"To use it instead, set the parameter source_id to '{stream.source_id}'."
    return (f"It has the same source_id ('{stream.source_id}'): to use it instead, stop the "
            'other sender or select it by stream_name.')


def how_to_pick(stream: StreamDescription, fitting: Sequence[StreamDescription]) -> str:
    """Name the parameter that picks ``stream`` out of ``fitting``: source_id, else name."""
    same_source = [other for other in fitting if other.source_id == stream.source_id]
    if stream.source_id and len(same_source) == 1:
        return f"source_id:='{stream.source_id}'"
    same_name = [other for other in fitting if other.name == stream.name]
    if len(same_name) == 1:
        return f"stream_name:='{stream.name}'"
    return 'nothing (same source_id and name: stop the other sender)'
