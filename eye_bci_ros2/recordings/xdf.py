"""
Gaze from an XDF file recorded by LabRecorder (the LSL ecosystem's recorder): pure loader.

An XDF file holds every stream LabRecorder saw (EEG, markers, gaze, ...).
:func:`load_xdf_gaze` picks the gaze stream and reads it with the layout of
the tracker application that sent it (a profile of
:mod:`eye_bci_ros2.gaze.profiles`, found from the stream's type and name, or
given), through the bridge's own conversion (:func:`~eye_bci_ros2.
gaze.profiles.convert`), into a :class:`~eye_bci_ros2.recordings.
gaze_recording.GazeRecording` in the ``screen`` frame.  Samples the bridge would drop
(lost eyes, low confidence, far off the screen) become NaN, so the
recording keeps every stamp.

Stamps are the recorded LSL stamps (no de-jittering: a replay sends them as
the tracker did), from 0 at the first sample.  An XDF file says nothing of
the screen or of targets: the screen is given (default
:data:`~eye_bci_ros2.projection.visual_angle.DEFAULT_VIEWING`) and the target schedule
is empty.

``pyxdf`` (PyPI) reads the file; it is imported only when an XDF file is loaded.
"""

import logging
from pathlib import Path
from typing import Dict, List, Optional, Sequence

import numpy as np

from eye_bci_ros2.gaze.profiles import (build_config, convert, PROFILE_NAMES, resolve_mapping,
                                        stream_matches)
from eye_bci_ros2.gaze.stream import is_gaze_type
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING, ScreenGeometry
from eye_bci_ros2.recordings.gaze_recording import (GazeRecording, PathLike, RecordingError,
                                                    TargetSchedule)


def _first(value, default=''):
    """Return a pyxdf header value: they are one-element lists (or None)."""
    if isinstance(value, list):
        return value[0] if value else default
    return default if value is None else value


def stream_labels(stream: Dict) -> List[str]:
    """
    Return the channel labels of a pyxdf stream ('' where a channel has none).

    :param stream: one stream as ``pyxdf.load_xdf`` returns it.
    """
    info = stream['info']
    count = int(_first(info.get('channel_count'), 0))
    desc = _first(info.get('desc'), None)
    labels: List[str] = []
    if isinstance(desc, dict):
        channels = _first(desc.get('channels'), None)
        if isinstance(channels, dict):
            labels = [str(_first(channel.get('label'))) if isinstance(channel, dict) else ''
                      for channel in channels.get('channel', [])]
    return (labels + [''] * count)[:count]


def profile_for(stream_type: str, stream_name: str) -> Optional[str]:
    """Return the first profile whose application advertises this type and name, or None."""
    for name in PROFILE_NAMES:
        config = build_config({'profile': name})
        if (config.stream_type or config.stream_name) and stream_matches(
                config, stream_type, stream_name, ''):
            return name
    return None


def _describe(streams: Sequence[Dict]) -> str:
    """Describe the streams of a file, for an error message."""
    return ', '.join(f"'{_first(s['info'].get('name'))}' ({_first(s['info'].get('type'))})"
                     for s in streams) or 'none'


def pick_gaze_stream(streams: Sequence[Dict], name: Optional[str] = None,
                     profile: Optional[str] = None) -> Dict:
    """
    Choose the gaze stream among an XDF file's streams.

    :param streams: as ``pyxdf.load_xdf`` returns them.
    :param name: the stream's name, when several could be gaze.
    :param profile: a profile: its application's streams count as gaze.
    :raises RecordingError: none or more than one candidate (the message lists the streams).
    """
    def is_gaze(stream: Dict) -> bool:
        stream_type = str(_first(stream['info'].get('type')))
        stream_name = str(_first(stream['info'].get('name')))
        if name is not None:
            return stream_name == name
        if profile is not None and stream_matches(build_config({'profile': profile}),
                                                  stream_type, stream_name, ''):
            return True
        return (is_gaze_type(stream_type)
                or profile_for(stream_type, stream_name) is not None)

    candidates = [stream for stream in streams if is_gaze(stream)]
    if len(candidates) == 1:
        return candidates[0]
    what = f"named '{name}'" if name is not None else 'of gaze'
    if not candidates:
        raise RecordingError(f'no stream {what} among: {_describe(streams)}; name one '
                             '(sim_gaze --xdf-stream NAME)')
    raise RecordingError(f'{len(candidates)} streams {what}: {_describe(candidates)}; name '
                         'one (sim_gaze --xdf-stream NAME)')


def gaze_from_stream(stream: Dict, profile: Optional[str] = None,
                     screen: ScreenGeometry = DEFAULT_VIEWING,
                     source_size: Optional[Sequence[int]] = None) -> np.ndarray:
    """
    Convert a stream's samples to screen points as the bridge would, NaN where it would drop.

    :param stream: one pyxdf stream (numeric).
    :param profile: the layout; default: found from the stream's type and name,
        else ``custom`` (channels 0 and 1, px of the screen).
    :param screen: the screen the gaze is mapped onto.
    :param source_size: (width, height) of the sender's screen for a layout in
        pixels (default: the profile's, else the screen's).
    :returns: (N, 2) screen px.
    :raises RecordingError: a layout the stream does not have.
    """
    info = stream['info']
    if profile is None:
        profile = profile_for(str(_first(info.get('type'))),
                              str(_first(info.get('name')))) or 'custom'
    values = {'profile': profile, 'screen_width': screen.width_px,
              'screen_height': screen.height_px}
    if source_size is not None:
        values.update(source_width=int(source_size[0]), source_height=int(source_size[1]))
    samples = np.asarray(stream['time_series'])
    try:
        if samples.ndim != 2 or not np.issubdtype(samples.dtype, np.number):
            raise ValueError(f'samples of shape {samples.shape} and type {samples.dtype} '
                             'are not numeric channels')
        mapping = resolve_mapping(build_config(values), stream_labels(stream), samples.shape[1])
        batch = convert(samples, mapping)
    except ValueError as error:
        raise RecordingError(f"stream '{_first(info.get('name'))}' as {profile}: "
                             f'{error}') from None
    points = np.full((len(samples), 2), np.nan)
    points[batch.keep] = batch.xy
    return points


def load_xdf_streams(path: PathLike) -> List[Dict]:
    """
    Load every stream of an XDF file as recorded (``pyxdf.load_xdf``, stamps not de-jittered).

    :raises RecordingError: pyxdf missing, or a file it cannot read (one line).
    """
    try:
        import pyxdf
    except ImportError:
        raise RecordingError(f'{path}: reading XDF needs pyxdf (pip install pyxdf)') from None
    # pyxdf logs what it repairs (clock segments, chopped chunks) as warnings on stderr; a
    # file it cannot read raises, and that is reported below in one line.
    pyxdf_log = logging.getLogger('pyxdf')
    level = pyxdf_log.level
    pyxdf_log.setLevel(logging.ERROR)
    try:
        streams, _ = pyxdf.load_xdf(str(path), dejitter_timestamps=False)
    except Exception as error:  # noqa: B902 - pyxdf raises anything on a bad file
        raise RecordingError(f'{path}: not a readable XDF file ({error})') from None
    finally:
        pyxdf_log.setLevel(level)
    return streams


def load_xdf_gaze(path: PathLike, stream_name: Optional[str] = None,
                  profile: Optional[str] = None, screen: ScreenGeometry = DEFAULT_VIEWING,
                  source_size: Optional[Sequence[int]] = None) -> GazeRecording:
    """
    Load the gaze stream of an XDF file (module doc).

    :param path: the ``.xdf`` (or ``.xdfz``) file.
    :param stream_name: the gaze stream's name, when the file has several.
    :param profile: the tracker application's layout (default: from the stream).
    :param screen: the person's screen.
    :param source_size: the sender's screen, px, for pixel layouts.
    :raises RecordingError: an unreadable file, no or several gaze streams,
        a layout the stream does not have, a stream without samples.
    """
    path = Path(path)
    stream = pick_gaze_stream(load_xdf_streams(path), stream_name, profile)
    stamps = np.asarray(stream['time_stamps'], dtype=float)
    if not len(stamps):
        raise RecordingError(f"{path}: stream '{_first(stream['info'].get('name'))}' has no "
                             'samples')
    points = gaze_from_stream(stream, profile, screen, source_size)
    order = np.argsort(stamps, kind='stable')
    stamps, points = stamps[order], points[order]
    empty = np.empty(0)
    name = path.name[:-len(''.join(path.suffixes))] if path.suffixes else path.name
    return GazeRecording(name=name, stamps=stamps - stamps[0], points=points, screen=screen,
                         targets=TargetSchedule(empty, empty, empty, np.empty((0, 2))),
                         tracker=f"XDF stream '{_first(stream['info'].get('name'))}'")
