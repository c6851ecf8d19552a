"""
Stream a simulated person's gaze over Lab Streaming Layer, as the original sender did.

The original system sent gaze from a Tobii 4C on a Windows machine (a
1366x768 screen) to the Linux machine showing RViz (1920x1080) over LSL.  The
stream made here has the ``xy_pixels`` layout the bridge's default profile
reads (:mod:`eye_bci_ros2.gaze.profiles`): type ``Gaze``, 2 float32 channels
x, y in pixels of the 1366x768 source screen, top-left origin.  The bridge
scales them back to the 1920x1080 screen.  Samples the tracker lost (blinks,
dropouts) are sent as NaN, which the bridge drops, unless ``send_lost`` is
off.  Each sample's LSL timestamp is its acquisition time on
``pylsl.local_clock()``; it is pushed ``delay_ms`` later.

Pure pylsl + numpy: runs without ROS, e.g. on the tracker machine::

    sim_gaze --target 960,540 --offset-deg 0.5 --duration 10
    sim_gaze --script targets.yaml --seed 3
    sim_gaze --preset original_tobii_4c --follow validation/target   # gaze_validation
    sim_gaze --replay recording.xdf --profile tobii_pro   # a recorded person instead

``--replay FILE`` sends a recording (any format :func:`~eye_bci_ros2.
recordings.gaze.load_gaze` reads, LabRecorder's XDF included) at its own
rate in the layout of ``--profile`` (:mod:`eye_bci_ros2.sim.replay`); the
person options do not apply then.

``--follow TOPIC`` makes the person look wherever a ROS topic
(geometry_msgs/PointStamped, screen px, e.g. ``gaze_validation``'s
``validation/target``) says (:mod:`eye_bci_ros2.sim.target_follower`; it
needs rclpy).

A script (YAML) lists timed targets in the person's screen px, seconds from
the start; ``null`` = nothing to look at; optional ``repeat_s`` loops it::

    targets:
      - {t: 0.0, xy: [960, 540]}
      - {t: 2.0, xy: [300, 200]}
      - {t: 4.0, xy: null}
    repeat_s: 6.0
"""

import argparse
import math
import sys
import time
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np
import pylsl
import yaml

from eye_bci_ros2.gaze.profiles import DEFAULT_PROFILE, PROFILES
from eye_bci_ros2.ros.startup import quiet_liblsl
from eye_bci_ros2.sim.lsl_outlet import OutletThread, stream_info
from eye_bci_ros2.sim.person import (CONSUMER_TRACKER, GazeParams, GazeSimulator, GazeTrace,
                                     IDEAL_EYE, PRESETS, Target)

#: The original sender's screen (the Windows machine), px.
SOURCE_SIZE = (1366, 768)
#: Stream type the bridge's ``xy_pixels`` profile selects.
STREAM_TYPE = 'Gaze'
#: Stream name: the original sender's repository name (its real stream name
#: is undocumented; the ``xy_pixels`` profile accepts any name).
STREAM_NAME = 'eye_tracking_device'
DEFAULT_SOURCE_ID = 'sim_gaze'


class GazeStreamer(OutletThread):
    """
    A real LSL outlet fed by a :class:`GazeSimulator` from a background thread.

    Every ``chunk_ms`` (:class:`~eye_bci_ros2.sim.lsl_outlet.OutletThread`'s
    fixed grid) it pushes every sample acquired up to ``now - delay_ms``, as one
    chunk; with ``per_sample`` it wakes once per sample period instead and
    pushes each sample with its own ``push_sample`` call and stamp.

    :param simulator: the person; default ``GazeSimulator(params, seed)``.
    :param params: used when ``simulator`` is None.
    :param seed: used when ``simulator`` is None.
    :param name: LSL stream name.
    :param stream_type: LSL stream type.
    :param source_id: LSL source id (give each test its own).
    :param source_size: (width, height) px of the sender's screen; the
        person's screen px are scaled into it.
    :param nominal_rate: advertised rate, Hz; default the tracker's rate
        (0 = irregular).
    :param chunk_ms: push period, ms (unused with ``per_sample``).
    :param per_sample: push every sample on its own (``push_sample``, its own
        stamp), waking once per sample period: what tracker applications that
        forward each SDK callback do (App-TobiiPro, the EyeLink and Pupil
        relays).  A late wake-up pushes the samples due since, still one call
        each.  Default False: chunks, as the original sender did.
    :param send_lost: push lost samples as NaN (True) or leave them out.
    :param initial_xy: where the eye points until the first target, person's
        screen px (default: screen centre).
    :param on_chunk: called in the streaming thread with each
        :class:`GazeTrace` (person's screen px) right after it was pushed,
        e.g. to record what was sent.
    """

    def __init__(self, simulator: Optional[GazeSimulator] = None, *,
                 params: GazeParams = CONSUMER_TRACKER, seed: int = 0,
                 name: str = STREAM_NAME, stream_type: str = STREAM_TYPE,
                 source_id: str = DEFAULT_SOURCE_ID,
                 source_size: Sequence[int] = SOURCE_SIZE,
                 nominal_rate: Optional[float] = None, chunk_ms: float = 20.0,
                 send_lost: bool = True, initial_xy: Target = None,
                 on_chunk: Optional[Callable[[GazeTrace], None]] = None,
                 per_sample: bool = False):
        self.simulator = simulator if simulator is not None else GazeSimulator(params, seed)
        tracker = self.simulator.params.tracker
        screen = self.simulator.params.person.screen
        source = np.asarray(source_size, dtype=float)
        if source.shape != (2,) or not np.all(source > 0):
            raise ValueError(f'source_size must be (width, height) > 0 px, got {source_size!r}')
        if not (math.isfinite(chunk_ms) and 1.0 <= chunk_ms <= 1000.0):
            raise ValueError(f'chunk_ms must be in [1, 1000], got {chunk_ms}')
        rate = tracker.rate_hz if nominal_rate is None else float(nominal_rate)
        if not rate >= 0:
            raise ValueError(f'nominal_rate must be >= 0 Hz, got {nominal_rate}')
        if not name or not source_id:
            raise ValueError('the stream needs a non-empty name and source_id')
        #: Person's screen px -> source px, per axis.
        self.scale = source / screen.size_px
        self.source_size = (int(source[0]), int(source[1]))
        self.delay_s = tracker.delay_ms / 1e3
        self.send_lost = bool(send_lost)
        self.on_chunk = on_chunk
        self.per_sample = bool(per_sample)
        self._initial_xy = initial_xy
        self._pending_target: Optional[Tuple[Target, Optional[float]]] = None
        period_s = 1.0 / tracker.rate_hz if self.per_sample else chunk_ms / 1e3
        super().__init__(self._stream_info(name, stream_type, rate, source_id), period_s,
                         'gaze')
        #: Samples pushed, and samples the tracker lost (sent as NaN or left
        #: out), since start().
        self.samples_pushed = 0
        self.samples_lost = 0
        #: Last measured sample (t, (x, y) person's screen px), or None.
        self.last_sample: Optional[Tuple[float, np.ndarray]] = None

    def _stream_info(self, name: str, stream_type: str, rate: float,
                     source_id: str) -> pylsl.StreamInfo:
        """Describe the stream: channels, screen and simulation settings."""
        info = stream_info(name, stream_type, 2, rate, source_id,
                           application='eye_bci_ros2 sim_gaze', labels=('x', 'y'),
                           unit='pixels', types=('ScreenX', 'ScreenY'))
        screen = info.desc().append_child('screen')
        screen.append_child_value('width', str(self.source_size[0]))
        screen.append_child_value('height', str(self.source_size[1]))
        screen.append_child_value('origin', 'top_left')
        acquisition = info.desc().child('acquisition')
        acquisition.append_child_value('preset', self.simulator.params.name)
        acquisition.append_child_value('seed', str(self.simulator.seed))
        return info

    def describe(self) -> str:
        """One line saying what is streamed."""
        person = self.simulator.params.person
        tracker = self.simulator.params.tracker
        screen = person.screen
        return (f"LSL stream '{self.info.name()}' type '{self.info.type()}' source_id "
                f"'{self.info.source_id()}': x, y float32 px of a {self.source_size[0]}x"
                f'{self.source_size[1]} screen, {tracker.rate_hz:g} Hz; person '
                f'({self.simulator.params.name}, seed {self.simulator.seed}) on a '
                f'{screen.width_px}x{screen.height_px} screen at {screen.distance_mm:g} mm '
                f'({screen.px_per_degree():.1f} px/deg), offset {person.offset_deg:g} deg, '
                f'jitter {person.jitter_deg:g} deg, expected loss '
                f'{100 * person.lost_fraction:.1f}%')

    def to_source(self, xy) -> np.ndarray:
        """Person's screen px (N, 2) -> the sender's screen px (N, 2), float32."""
        return (np.asarray(xy, dtype=float) * self.scale).astype(np.float32)

    def _begin(self, t0: float) -> None:
        """Start the person at ``t0`` with the target given before start(), if any."""
        self.samples_pushed = self.samples_lost = 0
        self.last_sample = None
        self.simulator.start(t0, self._initial_xy)
        if self._pending_target is not None:
            xy, t = self._pending_target
            self.simulator.set_target(xy, t0 if t is None else max(t, t0))

    def _acquire(self, now: float) -> GazeTrace:
        """Return the samples acquired up to ``now - delay_ms`` (the tracker's latency)."""
        return self.simulator.next_chunk(now - self.delay_s)

    def set_target(self, xy: Target, t: Optional[float] = None) -> None:
        """
        Make the person look at ``xy`` (person's screen px), or at nothing (None).

        Thread-safe.  The person reacts after their saccade latency.

        :param xy: target (x, y) px on the person's screen, or None.
        :param t: when the target appeared, ``pylsl.local_clock()`` seconds;
            default now.  Before start() the latest target is kept for it.
        :raises ValueError: a malformed target.
        """
        if xy is not None:
            xy = np.asarray(xy, dtype=float)
            if xy.shape != (2,) or not np.all(np.isfinite(xy)):
                raise ValueError(f'target must be None or a finite (x, y) px, got {xy!r}')
        with self._lock:
            if self._thread is None:
                self._pending_target = (xy, t)
                return
            self.simulator.set_target(xy, pylsl.local_clock() if t is None else t)

    def _push(self, chunk: GazeTrace) -> None:
        """Push one chunk with its acquisition timestamps."""
        if not len(chunk):
            return
        lost = ~chunk.valid
        t, xy = chunk.t, chunk.xy
        if not self.send_lost:
            t, xy = t[~lost], xy[~lost]
        if len(t) and self.per_sample:
            push = self._outlet.push_sample
            for values, stamp in zip(self.to_source(xy).tolist(), t.tolist()):
                push(values, stamp)
        elif len(t):
            self._outlet.push_chunk(self.to_source(xy), t.tolist())
        self.samples_pushed += len(t)
        self.samples_lost += int(np.count_nonzero(lost))
        if np.any(~lost):
            last = np.flatnonzero(~lost)[-1]
            self.last_sample = (float(chunk.t[last]), chunk.xy[last].copy())
        if self.on_chunk is not None:
            self.on_chunk(chunk)


def parse_script(data) -> Tuple[List[Tuple[float, Target]], Optional[float]]:
    """
    Read a target script: ``{'targets': [...], 'repeat_s': s}`` or a bare list.

    Each target is ``{t: seconds, xy: [x, y] or null}`` or ``[t, [x, y] or null]``.

    :returns: ([(t, xy or None), ...] in time order, repeat period or None).
    :raises ValueError: a malformed script, with the entry at fault.
    """
    repeat = None
    if isinstance(data, dict):
        unknown = set(data) - {'targets', 'repeat_s'}
        if unknown:
            raise ValueError(f"unknown script keys {sorted(unknown)}: use 'targets', 'repeat_s'")
        repeat = data.get('repeat_s')
        data = data.get('targets')
    if not isinstance(data, list) or not data:
        raise ValueError('a script needs a non-empty list of targets')
    entries = []
    for index, entry in enumerate(data):
        try:
            t, xy = (entry['t'], entry['xy']) if isinstance(entry, dict) else entry
            t = float(t)
            if xy is not None:
                xy = tuple(float(v) for v in xy)
                if len(xy) != 2 or not all(math.isfinite(v) for v in xy):
                    raise ValueError
            if not (math.isfinite(t) and t >= 0):
                raise ValueError
        except (KeyError, TypeError, ValueError):
            raise ValueError(f'script target {index}: {entry!r} is not '
                             '{t: seconds >= 0, xy: [x, y] or null}') from None
        entries.append((t, xy))
    if any(a[0] > b[0] for a, b in zip(entries, entries[1:])):
        raise ValueError('script targets must be in time order')
    if repeat is not None:
        repeat = float(repeat)
        if not repeat > entries[-1][0]:
            raise ValueError(f'repeat_s ({repeat}) must be after the last target '
                             f'({entries[-1][0]} s)')
    return entries, repeat


def load_script(path: str) -> Tuple[List[Tuple[float, Target]], Optional[float]]:
    """Read a YAML target script (see :func:`parse_script`)."""
    try:
        with open(path) as stream:
            data = yaml.safe_load(stream)
    except (OSError, yaml.YAMLError) as exc:
        raise ValueError(f'cannot read script {path}: {exc}') from None
    return parse_script(data)


def _pair(text: str, kind=float) -> Tuple:
    """Parse 'a,b' or 'AxB' into two numbers for argparse."""
    parts = text.replace('x', ',').split(',')
    try:
        if len(parts) != 2:
            raise ValueError
        return tuple(kind(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected two numbers like '960,540', got '{text}'")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options of ``sim_gaze``."""
    parser = argparse.ArgumentParser(
        prog='sim_gaze', description=__doc__.strip().split('\n\n')[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument('--preset', choices=sorted(PRESETS), default=CONSUMER_TRACKER.name,
                        help='person and tracker model')
    parser.add_argument('--seed', type=int, default=0, help='random seed')
    parser.add_argument('--rate', type=float, help='tracker rate, Hz (default: preset)')
    parser.add_argument('--offset-deg', type=float, help='accuracy: constant error, deg')
    parser.add_argument('--offset-direction-deg', type=float,
                        help='direction of the error (0 right, 90 down); default from seed')
    parser.add_argument('--jitter-deg', type=float, help='precision: noise SD per axis, deg')
    parser.add_argument('--drift-deg', type=float, help='slow drift RMS per axis, deg')
    parser.add_argument('--ideal-eye', action='store_true',
                        help='an eye that lands on the target at once, with only the offset, '
                             'jitter and drift as error (no landing errors, error varying '
                             'over the screen, wander, spikes or pursuit)')
    parser.add_argument('--field-deg', type=float,
                        help='error varying over the screen, RMS per axis, deg')
    parser.add_argument('--spike-prob', type=float,
                        help='probability that a sample is a 2-6 deg spike')
    parser.add_argument('--loss-prob', type=float, help='probability of losing a sample')
    parser.add_argument('--blink-rate', type=float, help='blinks per minute')
    parser.add_argument('--latency-ms', type=float, help='mean saccade latency, ms')
    parser.add_argument('--delay-ms', type=float, help='acquisition to sending, ms')
    where = parser.add_mutually_exclusive_group()
    where.add_argument('--target', type=_pair, metavar='X,Y',
                       help='fixed target, person screen px (default: screen centre)')
    where.add_argument('--script', metavar='YAML', help='timed targets (see module doc)')
    where.add_argument('--follow', metavar='TOPIC',
                       help='look where this ROS topic says (PointStamped, screen px), e.g. '
                            'validation/target')
    parser.add_argument('--duration', type=float, default=0.0,
                        help='seconds to stream; 0 = until Ctrl-C')
    where.add_argument('--replay', metavar='FILE',
                       help='send this recording at its own rate instead of a simulated '
                            'person (see module doc)')
    parser.add_argument('--profile', choices=sorted(PROFILES), default=DEFAULT_PROFILE,
                        help='--replay: the tracker application whose stream layout to send')
    parser.add_argument('--xdf-stream', metavar='NAME',
                        help='--replay of an XDF file with several gaze streams: which one')
    parser.add_argument('--wait-s', type=float, default=10.0,
                        help='--replay: wait this long for a consumer before the first '
                             'sample is due')
    parser.add_argument('--name', help=f"LSL stream name (default '{STREAM_NAME}'; "
                                       "--replay: the application's)")
    parser.add_argument('--type', help=f"LSL stream type (default '{STREAM_TYPE}'; "
                                       "--replay: the application's)")
    parser.add_argument('--source-id', default=DEFAULT_SOURCE_ID, help='LSL source id')
    parser.add_argument('--source-size', type=lambda s: _pair(s, int), metavar='WxH',
                        default=SOURCE_SIZE, help="sender's screen, px")
    parser.add_argument('--screen-size', type=lambda s: _pair(s, int), metavar='WxH',
                        help="person's screen, px (default 1920x1080)")
    parser.add_argument('--screen-mm', type=_pair, metavar='WxH',
                        help="person's screen, mm (default 527x296)")
    parser.add_argument('--distance-mm', type=float, help='eye to screen, mm (default 600)')
    parser.add_argument('--omit-lost', action='store_true',
                        help='leave lost samples out instead of sending NaN')
    parser.add_argument('--status-s', type=float, default=1.0,
                        help='print a status line this often, s (0 = never)')
    return parser


def params_from_args(args: argparse.Namespace) -> GazeParams:
    """Apply the command-line overrides to the chosen preset."""
    changes = {key: value for key, value in (
        ('rate_hz', args.rate), ('offset_deg', args.offset_deg),
        ('offset_direction_deg', args.offset_direction_deg), ('jitter_deg', args.jitter_deg),
        ('drift_deg', args.drift_deg), ('loss_prob', args.loss_prob),
        ('field_deg', args.field_deg), ('spike_prob', args.spike_prob),
        ('blink_rate_per_min', args.blink_rate), ('latency_ms', args.latency_ms),
        ('delay_ms', args.delay_ms), ('distance_mm', args.distance_mm)) if value is not None}
    if args.ideal_eye:
        changes = {**IDEAL_EYE, **changes}
    if args.screen_size is not None:
        changes.update(width_px=args.screen_size[0], height_px=args.screen_size[1])
    if args.screen_mm is not None:
        changes.update(width_mm=args.screen_mm[0], height_mm=args.screen_mm[1])
    return PRESETS[args.preset].with_changes(**changes)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run ``sim_gaze``: stream until --duration or Ctrl-C; returns the exit code."""
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.replay:
        return replay(args, parser)
    try:
        params = params_from_args(args)
        script, repeat = load_script(args.script) if args.script else (None, None)
        if args.duration < 0 or args.status_s < 0:
            raise ValueError('--duration and --status-s must be >= 0')
        streamer = GazeStreamer(
            params=params, seed=args.seed, name=args.name or STREAM_NAME,
            stream_type=args.type or STREAM_TYPE,
            source_id=args.source_id, source_size=args.source_size,
            send_lost=not args.omit_lost)
    except ValueError as exc:
        parser.error(str(exc))
    screen = params.person.screen
    target = args.target if args.target is not None else tuple(screen.centre_px)
    if args.follow:
        print(f'following the targets on {args.follow}', flush=True)
    elif script is None:
        streamer.set_target(target)
        print(f'target: ({target[0]:g}, {target[1]:g}) px', flush=True)
    else:
        looping = f', repeating every {repeat:g} s' if repeat else ''
        print(f'script: {len(script)} targets{looping}', flush=True)
    print(streamer.describe(), flush=True)
    events = _script_times(script, repeat)
    streamer.start()
    unfollow = None
    if args.follow:
        from eye_bci_ros2.sim.target_follower import follow_in_background
        unfollow = follow_in_background(streamer, args.follow)
    start = pylsl.local_clock()
    end = start + args.duration if args.duration > 0 else math.inf
    next_status = start + args.status_s if args.status_s > 0 else math.inf
    next_event = next(events, None)
    try:
        while streamer.running:
            now = pylsl.local_clock()
            while next_event is not None and start + next_event[0] <= now:
                streamer.set_target(next_event[1], start + next_event[0])
                print(f'{next_event[0]:8.2f} s  target {_format_xy(next_event[1])}', flush=True)
                next_event = next(events, None)
            if now >= next_status:
                print(_status(streamer, now - start), flush=True)
                next_status += args.status_s
            if now >= end:
                break
            wake = min(end, next_status, start + next_event[0] if next_event else math.inf)
            time.sleep(min(max(wake - now, 0.0), 0.5))
    except KeyboardInterrupt:
        pass
    finally:
        if unfollow is not None:
            unfollow()
        streamer.stop()
    print(_status(streamer, pylsl.local_clock() - start) + ' (stopped)', flush=True)
    if streamer.error is not None:
        print(f'error: {streamer.error}', file=sys.stderr)
        return 1
    return 0


def replay(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """Run ``sim_gaze --replay``: send the recording once, then stop; returns the exit code."""
    from eye_bci_ros2.recordings.gaze import load_gaze, RecordingError
    from eye_bci_ros2.recordings.xdf import load_xdf_gaze
    from eye_bci_ros2.sim.replay import GazeReplayer

    try:
        if args.xdf_stream:
            recording = load_xdf_gaze(args.replay, stream_name=args.xdf_stream)
        else:
            recording = load_gaze(args.replay)
        if args.source_id == DEFAULT_SOURCE_ID:
            args.source_id = 'replay_gaze'
        replayer = GazeReplayer(recording, args.profile, name=args.name,
                                stream_type=args.type, source_id=args.source_id,
                                send_lost=False if args.omit_lost else None,
                                wait_s=max(args.wait_s, 0.0))
    except (RecordingError, ValueError) as error:
        parser.error(str(error))
    print(replayer.describe(), flush=True)
    replayer.start()
    start = pylsl.local_clock()
    end = start + args.duration if args.duration > 0 else math.inf
    next_status = start + args.status_s if args.status_s > 0 else math.inf
    try:
        while replayer.running and not replayer.wait_finished(0.1):
            now = pylsl.local_clock()
            if now >= end:
                break
            if now >= next_status and replayer.t0 is not None:
                print(f'{now - replayer.t0:8.2f} s  {replayer.samples_pushed} samples',
                      flush=True)
                next_status += args.status_s
    except KeyboardInterrupt:
        pass
    finally:
        replayer.stop()
    print(f'{replayer.samples_pushed} of {len(replayer.indices)} samples sent (stopped)',
          flush=True)
    if replayer.error is not None:
        print(f'error: {replayer.error}', file=sys.stderr)
        return 1
    return 0


def _script_times(script, repeat):
    """Yield (seconds from start, target) for a script, repeated if asked."""
    if not script:
        return
    cycle = 0
    while True:
        for t, xy in script:
            yield cycle * repeat + t if repeat else t, xy
        if not repeat:
            return
        cycle += 1


def _format_xy(xy) -> str:
    """Format a target for printing."""
    return 'none' if xy is None else f'({xy[0]:.0f}, {xy[1]:.0f}) px'


def _status(streamer: GazeStreamer, elapsed: float) -> str:
    """One status line: counts, rate and the latest sample."""
    pushed = streamer.samples_pushed
    lost = streamer.samples_lost
    line = (f'{elapsed:8.2f} s  {pushed} samples ({pushed / max(elapsed, 1e-9):.1f}/s), '
            f'{lost} lost')
    if streamer.last_sample is not None:
        xy = streamer.last_sample[1]
        src = streamer.to_source(xy[None])[0]
        line += (f', last gaze ({xy[0]:.0f}, {xy[1]:.0f}) screen px = '
                 f'({src[0]:.0f}, {src[1]:.0f}) source px')
    return line


if __name__ == '__main__':
    sys.exit(main())
