"""
The LSL gaze stream's pure logic: stamps on the ROS clock, stream reports: no pylsl.

The bridge node (:mod:`eye_bci_ros2.nodes.lsl_gaze_bridge`) does the I/O;
what it decides is here, tested without liblsl.  A *stream* is anything with
pylsl's ``StreamInfo`` accessors (``name()``, ``type()``, ``source_id()``,
``channel_count()``, ``nominal_srate()``, ``hostname()``).

Time stamps.  A sample's acquisition time on the ROS clock is::

    t_ros = t_lsl + time_correction + (ros_now - lsl_now)

where ``t_lsl`` is the sender's timestamp (its LSL clock), the time
correction (liblsl's estimate, refreshed every few seconds) maps it to this
machine's LSL clock, and ``ros_now - lsl_now``, read when the chunk is
pulled (:func:`acquisition_stamps_ns`), maps this machine's LSL clock to the
ROS clock.
"""

import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.gaze_profiles import GazeConfig, PROFILE_NAMES, PROFILES

#: Inlet buffer, s of gaze (a 100 000-sample burst of a 1200 Hz tracker is 83 s); liblsl
#: drops the oldest samples beyond it, uncounted.
INLET_BUFFER_S = 120
#: Rate assumed to size the inlet buffer of an irregular-rate stream, Hz
#: (EyeLink-class trackers send 2000 Hz).
IRREGULAR_BUFFER_RATE_HZ = 2000.0
#: Stamps must fit builtin_interfaces/Time (int32 seconds).
MAX_STAMP_S = 2.0 ** 31 - 1


def inlet_buflen(nominal_srate: float) -> int:
    """
    Return pylsl's ``max_buflen`` for :data:`INLET_BUFFER_S` of gaze.

    liblsl reads it as seconds for a stream with a nominal rate, but as
    hundreds of samples for an irregular one (nominal rate 0).
    """
    if nominal_srate > 0:
        return INLET_BUFFER_S
    return int(math.ceil(INLET_BUFFER_S * IRREGULAR_BUFFER_RATE_HZ / 100.0))


def acquisition_stamps_ns(timestamps: np.ndarray, time_correction: Optional[float],
                          ros_now_ns: int, lsl_now: float) -> Tuple[np.ndarray, np.ndarray]:
    """
    Map the LSL timestamps of a chunk to acquisition times on the ROS clock (module doc).

    :param timestamps: shape (N,), s on the sender's LSL clock.
    :param time_correction: sender clock -> this machine's LSL clock, s; None
        when unknown: every sample is then stamped with its arrival time
        (``ros_now_ns``).
    :param ros_now_ns: the ROS clock, ns, read together with ``lsl_now``.
    :param lsl_now: this machine's LSL clock, s.
    :returns: ``(stamps_ns, good)``: shape (N,) int64 ns (0 where not good)
        and (N,) bool, false for a stamp that is not finite or does not fit
        builtin_interfaces/Time (a corrupt LSL timestamp).
    """
    timestamps = np.asarray(timestamps, dtype=np.float64).reshape(-1)
    if time_correction is None:
        delta_s = np.zeros(len(timestamps))
    else:
        delta_s = timestamps + time_correction - lsl_now
    with np.errstate(invalid='ignore', over='ignore'):
        stamp_s = ros_now_ns * 1e-9 + delta_s
        good = np.isfinite(stamp_s) & (stamp_s >= 0.0) & (stamp_s < MAX_STAMP_S)
    stamps_ns = np.zeros(len(timestamps), dtype=np.int64)
    stamps_ns[good] = ros_now_ns + np.rint(delta_s[good] * 1e9).astype(np.int64)
    return stamps_ns, good


def describe_stream(info) -> str:
    """Name a stream in one line for log messages."""
    rate = info.nominal_srate()
    rate_text = f'{rate:g} Hz' if rate > 0 else 'irregular rate'
    return (f"'{info.name()}' (type '{info.type()}', source_id '{info.source_id()}', "
            f'{info.channel_count()} ch, {rate_text}, host {info.hostname()})')


def channel_labels(info) -> List[str]:
    """
    Return a stream's channel labels (desc/channels/channel/label), '' where a channel has none.

    Any LSL stream (gaze or EEG): ``info`` is a full ``StreamInfo`` (from an
    inlet's ``info()``), whose ``desc()`` holds what the application wrote.
    """
    labels = []
    channel = info.desc().child('channels').child('channel')
    while not channel.empty():
        labels.append(channel.child_value('label').strip())
        channel = channel.next_sibling('channel')
    return labels


def how_to_choose(info, current_source_id: str) -> str:
    """Tell the user how to select this stream instead of the one in use."""
    if info.source_id() and info.source_id() != current_source_id:
        return f"To use it instead, set the parameter source_id to '{info.source_id()}'."
    return (f"It has the same source_id ('{info.source_id()}'): to use it instead, stop the "
            f'other sender or select it by stream_name.')


def how_to_select(info, config: GazeConfig) -> str:
    """
    Say which parameters would make the bridge take a stream it does not match now.

    A profile whose stream type and name (where it names one) are the
    stream's is suggested first; otherwise ``stream_type`` / ``stream_name``.
    """
    for name in PROFILE_NAMES:
        profile = PROFILES[name]
        if profile.stream_type and profile.stream_type == info.type() \
                and profile.stream_name in ('', info.name()) and name != config.profile:
            return f'profile:={name}'
    settings = []
    if config.stream_type and config.stream_type != info.type():
        settings.append(f"stream_type:='{info.type()}'")
    if config.stream_name and config.stream_name != info.name():
        settings.append(f"stream_name:='{info.name()}'")
    if config.source_id and config.source_id != info.source_id():
        settings.append(f"source_id:='{info.source_id()}'")
    return ' '.join(settings) or 'nothing (it matches)'


def report_unmatched(streams: Sequence, config: GazeConfig, limit: int = 8) -> str:
    """
    List the LSL streams seen while none matches, each with how to select it.

    :param streams: every stream the resolver sees (any type).
    :param limit: most streams listed; the rest are counted.
    """
    if not streams:
        return 'no LSL stream at all is visible (is the sender running, on this network?)'
    lines = [f'{describe_stream(info)}: select with {how_to_select(info, config)}'
             for info in streams[:limit]]
    more = f'; and {len(streams) - limit} more' if len(streams) > limit else ''
    return 'LSL streams seen: ' + '; '.join(lines) + more
