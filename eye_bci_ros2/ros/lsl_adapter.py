"""
liblsl (pylsl) behind :mod:`~eye_bci_ros2.streams.lsl_connection`'s ``Lsl`` and ``Inlet``.

The only module of the nodes that calls pylsl for reading: resolving, the full
description, inlets (``recover=False``: a lost outlet raises at once), the
clock offset and zero-timeout pulls into a preallocated buffer.  Every decision
is in the pure connection; this module only translates (``LostError`` ->
``StreamLost``, ``TimeoutError`` -> ``NotReady``, ``StreamInfo`` ->
``StreamDescription``).
"""

from dataclasses import replace
from typing import List, Optional, Tuple

import numpy as np
import pylsl
from pylsl.util import LostError, TimeoutError as LslTimeoutError

from eye_bci_ros2.ros.log_throttle import KeyedWarnings
from eye_bci_ros2.streams.lsl_connection import (INFO_TIMEOUT_S, inlet_buflen, NotReady,
                                                 RESOLVER_FORGET_S, StreamDescription, StreamLost)


def channel_labels(info: pylsl.StreamInfo) -> Tuple[str, ...]:
    """
    Return a stream's channel labels (desc/channels/channel/label), '' where a channel has none.

    ``info`` is a full ``StreamInfo`` (from an inlet's ``info()``), whose
    ``desc()`` holds what the application wrote.
    """
    labels = []
    channel = info.desc().child('channels').child('channel')
    while not channel.empty():
        labels.append(channel.child_value('label').strip())
        channel = channel.next_sibling('channel')
    return tuple(labels)


def description(info: pylsl.StreamInfo,
                labels: Optional[Tuple[str, ...]] = None) -> StreamDescription:
    """Return pylsl's ``StreamInfo`` as a :class:`StreamDescription` (handle: ``info``)."""
    return StreamDescription(
        uid=info.uid(), name=info.name(), stream_type=info.type(), source_id=info.source_id(),
        hostname=info.hostname(), channel_count=info.channel_count(),
        nominal_srate=info.nominal_srate(), created_at=info.created_at(),
        numeric=info.channel_format() != pylsl.cf_string, labels=labels, handle=info)


class _Resolver:
    """A pylsl ``ContinuousResolver`` whose results are descriptions."""

    def __init__(self, predicate: str):
        if predicate:
            self._resolver = pylsl.ContinuousResolver(pred=predicate,
                                                      forget_after=RESOLVER_FORGET_S)
        else:
            self._resolver = pylsl.ContinuousResolver(forget_after=RESOLVER_FORGET_S)

    def results(self) -> List[StreamDescription]:
        return [description(info) for info in self._resolver.results()]


class PylslInlet:
    """One ``pylsl.StreamInlet`` pulling into a preallocated (max_chunk, C) buffer."""

    def __init__(self, info: pylsl.StreamInfo, max_chunk: int):
        """Create the inlet (no network wait)."""
        self._inlet = pylsl.StreamInlet(info, max_buflen=inlet_buflen(info.nominal_srate()),
                                        recover=False)
        self._buffer = np.empty((max_chunk, info.channel_count()), dtype=self._inlet.np_dtype)

    def start(self) -> None:
        """Connect (at most INFO_TIMEOUT_S), then open the stream and the clock offset."""
        try:
            # Without this connection, liblsl's first pull would wait for it, blocking.
            self._inlet.info(timeout=INFO_TIMEOUT_S)
        except LslTimeoutError as error:
            raise NotReady(str(error)) from error
        except LostError as error:
            raise StreamLost(str(error)) from error
        for call in (self._inlet.open_stream, self._inlet.time_correction):
            try:
                call(timeout=0.0)
            except LslTimeoutError:
                pass
            except LostError as error:
                raise StreamLost(str(error)) from error

    def time_correction(self) -> Optional[float]:
        """Return the latest clock offset without waiting, or None."""
        try:
            return self._inlet.time_correction(timeout=0.0)
        except LslTimeoutError:
            return None
        except LostError:
            return None   # the next pull says so

    def pull(self) -> Tuple[np.ndarray, np.ndarray]:
        """Pull at most one buffer, zero timeout."""
        try:
            samples, stamps = self._inlet.pull_chunk(
                timeout=0.0, max_samples=len(self._buffer), dest_obj=self._buffer,
                as_numpy=True)
        except LostError as error:
            raise StreamLost(str(error)) from error
        # A copy: the buffer is reused by the next pull of the same poll.
        return np.array(samples), np.asarray(stamps, dtype=np.float64)

    def close(self) -> None:
        """Close the data stream; a dead inlet may fail to, which changes nothing."""
        try:
            self._inlet.close_stream()
        except Exception:  # noqa: B902 - closing a dead inlet may fail; nothing to do
            pass


class PylslBackend:
    """liblsl for :class:`eye_bci_ros2.streams.lsl_connection.StreamConnection`."""

    @staticmethod
    def local_clock() -> float:
        """Return this machine's LSL clock, s."""
        return pylsl.local_clock()

    def resolver(self, predicate: str) -> _Resolver:
        """Start resolving streams matching ``predicate`` in liblsl's background."""
        return _Resolver(predicate)

    def describe(self, stream: StreamDescription) -> StreamDescription:
        """Read the full description (labels); at most INFO_TIMEOUT_S."""
        inlet = pylsl.StreamInlet(stream.handle, recover=False)
        try:
            full = inlet.info(timeout=INFO_TIMEOUT_S)
        except LslTimeoutError as error:
            raise NotReady(str(error)) from error
        except LostError as error:
            raise StreamLost(str(error)) from error
        finally:
            del inlet
        # The resolver's StreamInfo keeps the sender's address; the full one may not.
        return replace(description(full, channel_labels(full)), handle=stream.handle)

    def open_inlet(self, stream: StreamDescription, max_chunk: int) -> PylslInlet:
        """Open an inlet on ``stream``."""
        return PylslInlet(stream.handle, max_chunk)


class LogReporter:
    """The connection's log lines on a node's logger; repeated ones through KeyedWarnings."""

    def __init__(self, logger):
        """Log on ``logger`` (``node.get_logger()``)."""
        self._logger = logger
        self._warnings = KeyedWarnings(logger)

    def info(self, text: str) -> None:
        """Log once at INFO."""
        self._logger.info(text)

    def warning(self, text: str) -> None:
        """Log once at WARN."""
        self._logger.warning(text)

    def throttled(self, key: str, text: str) -> None:
        """Warn at most once per WARN_PERIOD_S for this kind."""
        self._warnings.warn(key, text)
