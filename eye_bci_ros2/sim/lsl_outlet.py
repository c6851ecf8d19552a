"""
Real LSL outlets for the stand-ins: the one outlet builder and the one streaming thread.

The simulated tracker (:mod:`eye_bci_ros2.sim.gaze_outlet`), the simulated
amplifier (:mod:`eye_bci_ros2.sim.eeg_outlet`), the benchmarks and the test
outlets open their streams with :func:`open_outlet`; the two simulators push
from :class:`OutletThread`.  Stamps are ``pylsl.local_clock()`` s.
"""

import logging
import threading
from typing import Any, Optional, Sequence

import pylsl

_LOG = logging.getLogger(__name__)

#: Outlet buffer, s (samples x100 for an irregular stream): enough for any consumer pause.
MAX_BUFFERED_S = 360

#: pylsl channel formats by name.
CHANNEL_FORMATS = {'float32': pylsl.cf_float32, 'double64': pylsl.cf_double64}


def stream_info(name: str, stream_type: str, channels: int, rate: float, source_id: str,
                channel_format: str = 'float32', application: str = '',
                labels: Sequence[str] = (), unit: str = '',
                types: Optional[Sequence[str]] = None) -> pylsl.StreamInfo:
    """
    Describe a stream as a tracker's or amplifier's application does.

    :param channels: channel count.
    :param rate: nominal rate, Hz (0 = irregular).
    :param channel_format: a key of :data:`CHANNEL_FORMATS`.
    :param application: written to ``desc/acquisition/application`` when given.
    :param labels: channel labels written to ``desc/channels`` (none: no
        channel description, as Tobii Stream Engine and the OpenBCI GUI send).
    :param unit: each labelled channel's unit.
    :param types: each labelled channel's type (default none written).
    """
    info = pylsl.StreamInfo(name, stream_type, int(channels), float(rate),
                            CHANNEL_FORMATS[channel_format], source_id)
    if labels:
        described = info.desc().append_child('channels')
        for index, label in enumerate(labels):
            channel = described.append_child('channel')
            channel.append_child_value('label', label)
            if unit:
                channel.append_child_value('unit', unit)
            if types is not None:
                channel.append_child_value('type', types[index])
    if application:
        info.desc().append_child('acquisition').append_child_value('application', application)
    return info


def open_outlet(info: pylsl.StreamInfo, chunk_size: int = 0,
                max_buffered: int = MAX_BUFFERED_S) -> pylsl.StreamOutlet:
    """Open a real outlet for ``info`` (chunk_size 0 = as pushed)."""
    return pylsl.StreamOutlet(info, chunk_size, max_buffered)


class OutletThread:
    """
    A real LSL outlet fed from a background thread (base of the simulated streams).

    The thread wakes every ``chunk_s`` on a fixed grid of the steady LSL clock
    (no cumulative drift; a late wake-up catches up in one bigger chunk),
    takes what was acquired up to now under the lock (:meth:`_acquire`) and
    pushes it outside the lock (:meth:`_push`).  A failure stops the thread
    and is kept in :attr:`error` (and logged), never lost silently.

    :param info: the stream.
    :param chunk_s: push period, s.
    :param kind: what streams, for the thread name and messages ('gaze', 'EEG').
    """

    def __init__(self, info: pylsl.StreamInfo, chunk_s: float, kind: str):
        """Prepare the stream; nothing is advertised before :meth:`start`."""
        self.info = info
        self.chunk_s = float(chunk_s)
        self.kind = kind
        #: The exception that stopped the streaming thread, if any.
        self.error: Optional[BaseException] = None
        self._outlet: Optional[pylsl.StreamOutlet] = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None

    # -- what a subclass provides --------------------------------------------------------------

    def _begin(self, t0: float) -> None:
        """Start the simulation at ``t0`` (called under the lock before the thread starts)."""

    def _acquire(self, now: float) -> Any:
        """Return what was acquired up to ``now`` (called under the lock)."""
        raise NotImplementedError

    def _push(self, data: Any) -> None:
        """Push ``data`` from :meth:`_acquire` to the outlet."""
        raise NotImplementedError

    # -- the stream ----------------------------------------------------------------------------

    @property
    def running(self) -> bool:
        """Whether the streaming thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def outlet(self) -> Optional[pylsl.StreamOutlet]:
        """Return the LSL outlet while streaming, else None."""
        return self._outlet

    def start(self) -> 'OutletThread':
        """Open the outlet and start streaming; returns self."""
        if self.running:
            raise RuntimeError(f'the {self.kind} streamer is already running')
        self._outlet = open_outlet(self.info)
        self._stop.clear()
        self.error = None
        with self._lock:
            t0 = pylsl.local_clock()
            self._begin(t0)
        self._thread = threading.Thread(target=self._loop, args=(t0,),
                                        name=f'sim_{self.kind.lower()}', daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the thread, join it and close the outlet (the stream disappears)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            if self._thread.is_alive():
                raise RuntimeError(f'the {self.kind} streaming thread did not stop within '
                                   f'{timeout} s')
        self._thread = None
        self._outlet = None

    def wait_for_consumers(self, timeout: float) -> bool:
        """Wait until an inlet is connected (False after timeout s)."""
        outlet = self._outlet
        return outlet is not None and outlet.wait_for_consumers(timeout)

    def _loop(self, t0: float) -> None:
        """Push what was acquired on a fixed grid of wake-ups until stop()."""
        k = 1
        try:
            while not self._stop.wait(max(0.0, t0 + k * self.chunk_s - pylsl.local_clock())):
                now = pylsl.local_clock()
                with self._lock:
                    data = self._acquire(now)
                self._push(data)
                k = max(k + 1, int((now - t0) / self.chunk_s) + 1)
        except Exception as exc:  # noqa: B902 - report any failure instead of dying silently
            self.error = exc
            _LOG.error('%s streaming stopped: %s', self.kind, exc)

    def __enter__(self) -> 'OutletThread':
        """Start streaming."""
        return self.start()

    def __exit__(self, *exc) -> None:
        """Stop streaming."""
        self.stop()
