"""
Real LSL outlets laid out like each eye-tracker application, for tests and simulations.

Each profile of :mod:`eye_bci_ros2.gaze_profiles` names an application; the
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

from typing import Any, Dict, Optional, Sequence, Tuple
import uuid

import numpy as np
import pylsl

from eye_bci_ros2.gaze_profiles import PROFILES
from eye_bci_ros2.sim.lsl_outlet import open_outlet, stream_info

#: Screen the bridge maps gaze onto by default, px.
DEFAULT_SCREEN = (1920, 1080)

_EYES = ('left', 'right', 'both')


def unique_id(prefix: str = 'test') -> str:
    """Return a name nobody else on this machine uses, e.g. ``'test-1f0c...'``."""
    return f'{prefix}-{uuid.uuid4().hex}'


def _describe_channels(info: pylsl.StreamInfo, profile: str) -> None:
    """Write the channel description the application writes."""
    labels = PROFILES[profile].channel_labels
    channels = info.desc().append_child('channels')
    for label in labels:
        channel = channels.append_child('channel')
        channel.append_child_value('label', label)
        if profile == 'tobii_pro':
            eye = label.split('_')[0]
            kind = {'x': 'ScreenX', 'y': 'ScreenY', 'pupil': 'pupilsize'}[label.split('_')[1]]
            channel.append_child_value('eye', eye)
            channel.append_child_value('type', kind)
            if kind != 'pupilsize':
                channel.append_child_value('unit', 'screencoords')
        elif profile == 'pupil_capture':
            channel.append_child_value('eye', 'both')
            unit = 'normalized' if label in ('confidence', 'norm_pos_x', 'norm_pos_y') else 'mm'
            channel.append_child_value('unit', unit)
        else:
            channel.append_child_value('type', 'Screen' + label.upper())
            channel.append_child_value('unit', 'pixels')


def make_outlet(profile: str, name: Optional[str] = None, source_id: Optional[str] = None,
                rate: Optional[float] = None, stream_type: Optional[str] = None,
                labelled: Optional[bool] = None, chunk_size: int = 0,
                max_buffered: int = 360) -> Tuple[pylsl.StreamOutlet, pylsl.StreamInfo]:
    """
    Open an LSL outlet laid out as the profile's application lays it out.

    :param profile: a name in :data:`eye_bci_ros2.gaze_profiles.PROFILES`.
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
    info = stream_info(
        name, spec.stream_type if stream_type is None else stream_type,
        len(spec.channel_labels), spec.nominal_srate if rate is None else rate, source_id,
        spec.channel_format, application=f'eye_bci_ros2 test outlet ({profile})')
    if (spec.labelled if labelled is None else labelled):
        _describe_channels(info, profile)
    outlet = open_outlet(info, chunk_size, max_buffered)
    return outlet, outlet.get_info()


def sample_for(profile: str, screen_xy: Sequence, screen_size: Sequence[int] = DEFAULT_SCREEN,
               source_size: Optional[Sequence[int]] = None, confidence: float = 1.0,
               lost_eye: Optional[str] = None, eye_offset_px: Sequence[float] = (0.0, 0.0),
               pupil_mm: float = 3.0) -> np.ndarray:
    """
    Encode screen points as the profile's application would send them.

    The inverse of the bridge's conversion with default parameters:
    ``convert(sample_for(p, xy)) == xy``.

    :param profile: a name in ``PROFILES``.
    :param screen_xy: gaze point(s) on the ``screen``, px, top-left origin,
        shape (2,) or (N, 2).
    :param screen_size: (width, height) of the screen the bridge maps to, px.
    :param source_size: (width, height) of the sender's screen for pixel
        units; default: the profile's (1366x768 for xy_pixels), else the
        screen's.
    :param confidence: value of the confidence channel (pupil_capture).
    :param lost_eye: 'left', 'right' or 'both': that eye's gaze point is sent
        as NaN, as the Tobii Pro app does for an invalid eye.  Single-point
        layouts send NaN x, y for any value.
    :param eye_offset_px: two-eye layouts: the left eye looks at
        ``xy - offset`` and the right at ``xy + offset`` (screen px), so their
        average is ``xy``.
    :param pupil_mm: value of pupil-size channels.
    :returns: samples, shape (C,) or (N, C), float64; channels the bridge
        does not read are NaN unless the application fills them (pupils).
    """
    spec = PROFILES[profile]
    if lost_eye is not None and lost_eye not in _EYES:
        raise ValueError(f"lost_eye must be one of {', '.join(_EYES)}, got {lost_eye!r}")
    points = np.asarray(screen_xy, dtype=float)
    single = points.ndim == 1
    points = np.atleast_2d(points)
    if points.shape[1] != 2:
        raise ValueError(f'screen_xy must have shape (2,) or (N, 2), got {points.shape}')
    width, height = screen_size
    if source_size is None:
        source_size = (spec.source_width or width, spec.source_height or height)

    def encode(xy: np.ndarray) -> np.ndarray:
        if spec.units == 'normalized':
            out = xy / np.array([width, height], dtype=float)
            span = 1.0
        else:
            out = xy * np.array([source_size[0] / width, source_size[1] / height])
            span = float(source_size[1])
        if spec.origin == 'bottom_left':
            out[:, 1] = span - out[:, 1]
        return out

    labels = spec.channel_labels
    samples = np.full((len(points), len(labels)), np.nan)
    column = {label: i for i, label in enumerate(labels)}
    if profile == 'tobii_pro':
        offset = np.asarray(eye_offset_px, dtype=float)
        for eye, sign in (('left', -1.0), ('right', 1.0)):
            if lost_eye in (eye, 'both'):
                continue
            xy = encode(points + sign * offset)
            samples[:, column[f'{eye}_x']] = xy[:, 0]
            samples[:, column[f'{eye}_y']] = xy[:, 1]
            samples[:, column[f'{eye}_pupil']] = pupil_mm
    else:
        xy = encode(points)
        x_label, y_label = (('norm_pos_x', 'norm_pos_y') if profile == 'pupil_capture'
                            else labels[:2])
        if lost_eye is None:
            samples[:, column[x_label]] = xy[:, 0]
            samples[:, column[y_label]] = xy[:, 1]
        if 'confidence' in column:
            samples[:, column['confidence']] = confidence
        for label in labels:
            if label.startswith('diameter'):
                samples[:, column[label]] = pupil_mm
    return samples[0] if single else samples


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
