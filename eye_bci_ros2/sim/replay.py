"""
Replay recorded gaze over Lab Streaming Layer at its own rate, as the tracker sent it.

Any recording the loaders read (:func:`eye_bci_ros2.recordings.gaze.load_gaze`:
the X2-60 and ETDQualitizer files, a lab's CSV, LabRecorder's XDF) is sent
to the running nodes one sample at a time, each with its own stamp (the
recording's time from its first sample, on ``pylsl.local_clock()`` from the
start of the replay) and at the moment it is due, as tracker applications
push.  The stream has the layout of a chosen tracker application (a profile
of :mod:`eye_bci_ros2.gaze.profiles`, encoded by
:mod:`eye_bci_ros2.sim.tracker_layout`), so the bridge reads it with that
profile's defaults.  Lost samples go out as NaN (the bridge counts them as
'nonfinite'), except for ``tobii_stream_engine``, whose application sends
only valid points.

Pure pylsl + numpy::

    sim_gaze --replay human_samples_lookAtPoint_X260_ss1.txt.gz --profile tobii_pro
    sim_gaze --replay session.xdf --xdf-stream Tobii --profile tobii_pro
"""

import threading
from typing import Callable, Optional, Sequence

import numpy as np

from eye_bci_ros2.gaze.profiles import PROFILES
from eye_bci_ros2.recordings.gaze import GazeRecording
from eye_bci_ros2.sim.lsl_outlet import OutletThread
from eye_bci_ros2.sim.tracker_layout import encode, profile_stream_info

#: Source id of a replay unless given.
DEFAULT_SOURCE_ID = 'replay_gaze'
#: How often the replay wakes to push what is due, s (short: each sample goes out near its
#: own time, as a tracker application pushes).
PUSH_PERIOD_S = 0.002


class GazeReplayer(OutletThread):
    """
    A real LSL outlet that sends a recording's samples at their own times.

    :param recording: what to send (its points are in its screen's px).
    :param profile: the tracker application whose layout the stream has.
    :param name: stream name; default the application's (or ``replay_gaze``).
    :param stream_type: default the application's.
    :param source_id: LSL source id.
    :param source_size: the sender's screen, px, for pixel layouts (default
        the profile's, else the recording's screen).
    :param send_lost: send lost samples as NaN; default as the application does.
    :param on_sample: called in the streaming thread with (index, stamp) after
        each push, e.g. to record what went out.
    :param wait_s: after start(), wait up to this long for a consumer (the
        bridge) before the first sample is due, so none is sent into the void.
    """

    def __init__(self, recording: GazeRecording, profile: str = 'xy_pixels',
                 name: Optional[str] = None, stream_type: Optional[str] = None,
                 source_id: str = DEFAULT_SOURCE_ID,
                 source_size: Optional[Sequence[int]] = None,
                 send_lost: Optional[bool] = None,
                 on_sample: Optional[Callable[[int, float], None]] = None,
                 wait_s: float = 0.0):
        if profile not in PROFILES:
            raise ValueError(f"unknown profile '{profile}': use one of {', '.join(PROFILES)}")
        if not len(recording.stamps):
            raise ValueError(f'{recording.name}: no samples to replay')
        spec = PROFILES[profile]
        self.recording = recording
        self.profile = profile
        screen = recording.screen
        #: The samples as the application sends them, (N, channels).
        self.samples = encode(profile, recording.points, (screen.width_px, screen.height_px),
                              source_size)
        valid = np.isfinite(recording.points).all(axis=1)
        if send_lost is None:
            send_lost = profile != 'tobii_stream_engine'
        #: Indices of the samples that go out, in order.
        self.indices = np.arange(len(valid)) if send_lost else np.flatnonzero(valid)
        self.on_sample = on_sample
        rate = round(recording.rate_hz) if spec.nominal_srate > 0 else 0.0
        info = profile_stream_info(profile, name or spec.stream_name or DEFAULT_SOURCE_ID,
                                   source_id, rate=rate, stream_type=stream_type,
                                   application='eye_bci_ros2 replay')
        info.desc().child('acquisition').append_child_value('recording', recording.name)
        super().__init__(info, PUSH_PERIOD_S, 'gaze')
        #: Samples pushed so far.
        self.samples_pushed = 0
        self.wait_s = float(wait_s)
        self._next = 0
        self._begun = 0.0
        self._t0: Optional[float] = None
        self._done = threading.Event()

    def describe(self) -> str:
        """One line saying what is replayed."""
        recording = self.recording
        return (f"replaying '{recording.name}' ({recording.tracker}, {recording.rate_hz:.0f} "
                f'Hz, {recording.stamps[-1]:.1f} s, {len(self.indices)} samples, '
                f'{100 * recording.lost_share:.1f} % lost) as {self.profile}: LSL stream '
                f"'{self.info.name()}' type '{self.info.type()}' source_id "
                f"'{self.info.source_id()}'")

    @property
    def finished(self) -> bool:
        """Whether every sample has been pushed."""
        return self._done.is_set()

    def wait_finished(self, timeout: Optional[float] = None) -> bool:
        """Wait until every sample has been pushed (False after timeout s)."""
        return self._done.wait(timeout)

    @property
    def t0(self) -> Optional[float]:
        """Return the first sample's stamp, ``pylsl.local_clock()`` s (None before it is due)."""
        return self._t0

    def _begin(self, t0: float) -> None:
        """Start waiting for a consumer."""
        self._begun = t0
        self._t0 = None
        self._next = 0
        self.samples_pushed = 0
        self._done.clear()

    def _acquire(self, now: float) -> np.ndarray:
        """Return the indices of the samples due by now."""
        if self._t0 is None:
            if not (self._outlet.have_consumers() or now >= self._begun + self.wait_s):
                return self.indices[:0]
            self._t0 = now
        stamps = self.recording.stamps[self.indices]
        end = int(np.searchsorted(stamps, now - self._t0, side='right'))
        due = self.indices[self._next:end]
        self._next = max(self._next, end)
        return due

    def _push(self, due: np.ndarray) -> None:
        """Push each due sample on its own with its own stamp."""
        for index in due:
            stamp = self._t0 + float(self.recording.stamps[index])
            self._outlet.push_sample(self.samples[index].tolist(), stamp)
            self.samples_pushed += 1
            if self.on_sample is not None:
                self.on_sample(int(index), stamp)
        if self._next >= len(self.indices):
            self._done.set()
