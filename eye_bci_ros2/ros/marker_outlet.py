"""
The session's marker stream as a real LSL outlet (pylsl): the only pylsl calls that write markers.

One string channel, irregular rate, type ``Markers``
(:data:`eye_bci_ros2.recordings.session_markers.MARKER_TYPE`): what LabRecorder and every
XDF reader expect of events.  The stream's description says what wrote it and the marker
format's version, so a reader of the XDF knows how to parse the strings.
"""

import pylsl

from eye_bci_ros2.recordings.session_markers import FORMAT_VERSION, MARKER_TYPE

#: Markers kept for a consumer that pauses (an irregular stream's buffer counts samples x100,
#: so this is 36 000 markers): far more than a session's events.
MAX_BUFFERED = 360


class MarkerOutlet:
    """
    A real LSL outlet of JSON markers (one string channel, irregular rate).

    :param name: the stream's name; :param source_id: its source_id (both from
        :func:`eye_bci_ros2.recordings.session_markers.stream_identity`).
    :param pipeline: the ROS namespace of the pipeline, written into the description.
    """

    def __init__(self, name: str, source_id: str, pipeline: str):
        """Open the outlet: LSL advertises it at once."""
        info = pylsl.StreamInfo(name, MARKER_TYPE, 1, pylsl.IRREGULAR_RATE, pylsl.cf_string,
                                source_id)
        info.desc().append_child('channels').append_child('channel').append_child_value(
            'label', 'event')
        acquisition = info.desc().append_child('acquisition')
        acquisition.append_child_value('application', 'eye_bci_ros2 session_markers')
        acquisition.append_child_value('format', f'json v{FORMAT_VERSION}')
        acquisition.append_child_value('pipeline', pipeline)
        self.info = info
        self._outlet = pylsl.StreamOutlet(info, 0, MAX_BUFFERED)

    @staticmethod
    def local_clock() -> float:
        """Return this machine's LSL clock, s."""
        return pylsl.local_clock()

    def push(self, text: str, stamp: float) -> None:
        """Push one marker stamped ``stamp`` (s, this machine's LSL clock)."""
        self._outlet.push_sample([text], stamp)

    def have_consumers(self) -> bool:
        """Tell whether an inlet (LabRecorder, a viewer) is connected."""
        return self._outlet.have_consumers()

    def close(self) -> None:
        """Stop advertising the stream."""
        self._outlet = None
