"""
Real LSL outlets laid out like each eye-tracker application, for tests and simulations.

Each profile of :mod:`eye_bci_ros2.gaze.profiles` names an application; the
outlets made here advertise the same stream type, channel count, channel
format, nominal rate and channel description (labels, eye, type, unit) as
that application, and :func:`sample_for` encodes a screen point the way the
application would send it.  Every outlet gets a unique source_id (and, by
default, a unique name) because several people run LSL tests on the same
machine at the same time.

Typical use::

    outlet, info = make_outlet('tobii_pro')
    node = graph.add(LslGazeBridge, parameter_overrides=[
        Parameter(k, value=v) for k, v in bridge_parameters('tobii_pro', info).items()])
    graph.spin_until(outlet.have_consumers, 10.0)
    outlet.push_chunk(sample_for('tobii_pro', [[960, 540], [10, 20]]).tolist())
"""

from typing import Any, Dict, Optional, Tuple
import uuid

import pylsl

from eye_bci_ros2.gaze.profiles import PROFILES
from eye_bci_ros2.sim.lsl_outlet import open_outlet
# The layouts live in the package (the replay uses them too); re-exported for the tests.
from eye_bci_ros2.sim.tracker_layout import (  # noqa: F401
    DEFAULT_SCREEN, encode as sample_for, profile_stream_info)


def unique_id(prefix: str = 'test') -> str:
    """Return a name nobody else on this machine uses, e.g. ``'test-1f0c...'``."""
    return f'{prefix}-{uuid.uuid4().hex}'


def make_outlet(profile: str, name: Optional[str] = None, source_id: Optional[str] = None,
                rate: Optional[float] = None, stream_type: Optional[str] = None,
                labelled: Optional[bool] = None, chunk_size: int = 0,
                max_buffered: int = 360) -> Tuple[pylsl.StreamOutlet, pylsl.StreamInfo]:
    """
    Open an LSL outlet laid out as the profile's application lays it out.

    :param profile: a name in :data:`eye_bci_ros2.gaze.profiles.PROFILES`.
    :param name: stream name; default: a unique name starting with the
        application's name (or the profile name when it has none).
    :param source_id: default: a unique id.  Reuse one to play an
        application that restarts.
    :param rate: nominal rate, Hz; default: what the application advertises
        (0 = irregular).  Samples pushed without a timestamp get
        ``local_clock()`` at the push (chunks are back-dated by 1/rate).
    :param stream_type: default: the type the application advertises.
    :param labelled: write channel labels into the description; default: as
        the application does (Tobii Stream Engine and the original sender do
        not).
    :param chunk_size: outlet chunk size, samples (0 = as pushed).
    :param max_buffered: outlet buffer, seconds (samples x100 when irregular).
    :returns: the outlet and its StreamInfo as advertised (with uid and
        created_at, and the channel description).
    """
    spec = PROFILES[profile]
    if name is None:
        name = unique_id(spec.stream_name or profile)
    if source_id is None:
        source_id = unique_id(f'{profile}-source')
    info = profile_stream_info(profile, name, source_id, rate, stream_type, labelled,
                               application=f'eye_bci_ros2 test outlet ({profile})')
    outlet = open_outlet(info, chunk_size, max_buffered)
    return outlet, outlet.get_info()


def bridge_parameters(profile: str, info: pylsl.StreamInfo, **overrides: Any) -> Dict[str, Any]:
    """
    Parameters that make ``lsl_gaze_bridge`` read exactly this outlet.

    :param profile: the outlet's profile.
    :param info: as returned by :func:`make_outlet`.
    :param overrides: more parameters (they win).
    :returns: ``{name: value}``; turn into rclpy ``Parameter`` objects for
        ``parameter_overrides=`` or pass to ``graph.set_parameters``.
    """
    values = {'profile': profile, 'stream_type': info.type() or '*',
              'stream_name': info.name(), 'source_id': info.source_id()}
    values.update(overrides)
    return values
