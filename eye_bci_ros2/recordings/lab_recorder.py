"""
Record a session's LSL streams into one XDF file with the real LabRecorder.

What a lab does with LabRecorder's window, from Python: find the session's
streams (the tracker's gaze, the amplifier's EEG, the pipeline's markers of
``session_markers``), record them into an XDF file, stop.  The recorder is
LabRecorder itself (``labrecorder`` on PyPI: its C++ recording class with Python
bindings), so the file is what a lab's own LabRecorder writes, clock offsets
included; ``pyxdf.load_xdf`` reads it.  Typical use::

    from eye_bci_ros2.recordings.lab_recorder import record_session
    with record_session('session.xdf', namespace='/') as recording:
        ...                       # the session
    print(recording.streams)      # what was recorded

Which streams (:func:`select_session_streams`): the marker stream of the pipeline
in ``namespace`` (by its name and, unless ``host=''``, this machine in its source_id,
:func:`~eye_bci_ros2.recordings.session_markers.stream_identity`), every stream of a
gaze type (:func:`~eye_bci_ros2.streams.content_types.is_gaze_type`) and of type EEG;
``gaze_source_id`` / ``eeg_source_id`` narrow them to one device when several send
(several people's streams on one network).

``pylsl`` and ``labrecorder`` are imported only when a recording starts: the module
is part of the pure core (it loads neither on import).
"""

from pathlib import Path
import socket
from typing import Any, List, Optional, Sequence, Union

from eye_bci_ros2.gaze.stream import is_gaze_type
from eye_bci_ros2.recordings.session_markers import MARKER_TYPE, stream_identity

#: The LSL type an amplifier's EEG stream has (the XDF and LSL convention).
EEG_TYPE = 'eeg'
#: How long to look for the session's streams, s (LSL answers within about a second).
RESOLVE_S = 2.0


def _wanted(source_id: str, wanted: str) -> bool:
    return not wanted or source_id == wanted


def select_session_streams(infos: Sequence[Any], namespace: str = '/', gaze_source_id: str = '',
                           eeg_source_id: str = '', markers: bool = True,
                           host: str = '') -> List[Any]:
    """
    Pick the session's streams out of resolved ones (module doc).

    :param infos: streams as LSL resolves them (anything with ``type()``, ``name()``
        and ``source_id()``, such as ``pylsl.StreamInfo``).
    :param namespace: the pipeline's ROS namespace, whose marker stream to take.
    :param gaze_source_id: take only the gaze stream of this source ('' = every one).
    :param eeg_source_id: take only the EEG stream of this source ('' = every one).
    :param markers: take the pipeline's marker stream.
    :param host: the machine the pipeline runs on (its marker stream's source_id says it);
        '' = any (then two machines' pipelines of one namespace are both taken).
    :returns: the chosen ones, in the order given.
    """
    marker_name, marker_source = stream_identity(namespace, host)
    chosen = []
    for info in infos:
        kind = info.type().lower()
        if kind == MARKER_TYPE.lower():
            take = markers and info.name() == marker_name and (
                not host or info.source_id() == marker_source)
        elif is_gaze_type(kind):
            take = _wanted(info.source_id(), gaze_source_id)
        elif kind == EEG_TYPE:
            take = _wanted(info.source_id(), eeg_source_id)
        else:
            take = False
        if take:
            chosen.append(info)
    return chosen


def describe(info: Any) -> str:
    """Name a stream in one short phrase: ``'name' (type, source_id)``."""
    return f"'{info.name()}' ({info.type()}, {info.source_id() or 'no source_id'})"


class LabRecording:
    """
    A running LabRecorder recording of ``streams`` into ``path`` (XDF).

    :param path: the XDF file to write (its folder must exist).
    :param streams: the streams (``pylsl.StreamInfo``) to record.
    :raises ValueError: no streams, or a stream that was not resolved (LabRecorder
        needs a stream's uid and host: what ``pylsl.resolve_streams`` or an outlet's
        ``get_info()`` gives; an info made by hand would crash it).
    :raises OSError: the file cannot be written.
    """

    def __init__(self, path: Union[str, Path], streams: Sequence[Any]):
        """Start recording at once (LabRecorder connects to each stream in the background)."""
        if not streams:
            raise ValueError('nothing to record: no gaze, EEG or marker stream found')
        for info in streams:
            if not info.uid():
                raise ValueError(f'cannot record {describe(info)}: not a resolved stream (no '
                                 'uid); pass what pylsl.resolve_streams gives')
        self.path = Path(path)
        if not self.path.parent.is_dir():
            raise OSError(f'cannot write {self.path}: {self.path.parent} is not a folder')
        # A file LabRecorder cannot create fails late, in its own thread: try it here.
        self.path.open('ab').close()
        import labrecorder   # noqa: I100 - the C++ recorder, loaded only to record
        self.streams = list(streams)
        self._recording: Optional[Any] = labrecorder.Recording(str(self.path), self.streams)

    def stop(self) -> Path:
        """Stop, write the footers and close the file (a few seconds); return its path."""
        recording, self._recording = self._recording, None
        if recording is not None:
            recording.stop()
            # The file is closed when the recorder is destroyed (its threads joined).
            del recording
        return self.path

    def __enter__(self) -> 'LabRecording':
        """Return the running recording."""
        return self

    def __exit__(self, *exc_info) -> None:
        """Stop the recording, whatever ended the block."""
        self.stop()


def resolve_session_streams(namespace: str = '/', gaze_source_id: str = '',
                            eeg_source_id: str = '', wait_s: float = RESOLVE_S,
                            markers: bool = True, host: Optional[str] = None) -> List[Any]:
    """
    Resolve the LSL streams on the network and pick the session's (module doc).

    :param host: the pipeline's machine (None: this one; '' any): see
        :func:`select_session_streams`.
    """
    import pylsl   # noqa: I100 - liblsl, loaded only to record
    return select_session_streams(
        pylsl.resolve_streams(wait_s), namespace, gaze_source_id, eeg_source_id, markers,
        socket.gethostname() if host is None else host)


def record_session(path: Union[str, Path], namespace: str = '/', gaze_source_id: str = '',
                   eeg_source_id: str = '', wait_s: float = RESOLVE_S,
                   markers: bool = True, host: Optional[str] = None) -> LabRecording:
    """Find the session's streams and start recording them into ``path`` (module doc)."""
    return LabRecording(path, resolve_session_streams(namespace, gaze_source_id,
                                                      eeg_source_id, wait_s, markers, host))
