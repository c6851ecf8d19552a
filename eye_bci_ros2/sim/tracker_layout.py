"""
Gaze as each eye-tracker application lays it out on LSL: stream description and samples.

Each profile of :mod:`eye_bci_ros2.gaze.profiles` names an application;
:func:`profile_stream_info` describes a stream as that application does (type,
channel count and format, nominal rate, channel labels with eye, type and
unit) and :func:`encode` turns screen points into the samples it would send.
The replay of recorded gaze (:mod:`eye_bci_ros2.sim.replay`) and the test
outlets (``test/support/lsl_outlets.py``) use them, so the bridge reads the
same layouts everywhere.  ``encode`` is the inverse of the bridge's
conversion with default parameters: ``convert(encode(p, xy)) == xy``.
"""

from typing import Optional, Sequence

import numpy as np
import pylsl

from eye_bci_ros2.gaze.profiles import PROFILES
from eye_bci_ros2.sim.lsl_outlet import stream_info

#: Screen the bridge maps gaze onto by default, px.
DEFAULT_SCREEN = (1920, 1080)

#: Values of ``lost_eye`` in :func:`encode`.
EYES = ('left', 'right', 'both')


def profile_stream_info(profile: str, name: str, source_id: str, rate: Optional[float] = None,
                        stream_type: Optional[str] = None, labelled: Optional[bool] = None,
                        application: str = '') -> pylsl.StreamInfo:
    """
    Describe a stream as the profile's application does.

    :param profile: a name in :data:`eye_bci_ros2.gaze.profiles.PROFILES`.
    :param name: stream name.
    :param source_id: source id.
    :param rate: nominal rate, Hz; default: what the application advertises
        (0 = irregular).
    :param stream_type: default: the type the application advertises.
    :param labelled: write channel labels into the description; default: as
        the application does (Tobii Stream Engine and the original sender do
        not).
    :param application: written to ``desc/acquisition/application``.
    """
    spec = PROFILES[profile]
    info = stream_info(
        name, spec.stream_type if stream_type is None else stream_type,
        len(spec.channel_labels), spec.nominal_srate if rate is None else rate, source_id,
        spec.channel_format, application=application)
    if (spec.labelled if labelled is None else labelled):
        describe_channels(info, profile)
    return info


def describe_channels(info: pylsl.StreamInfo, profile: str) -> None:
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


def encode(profile: str, screen_xy: Sequence, screen_size: Sequence[int] = DEFAULT_SCREEN,
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
    if lost_eye is not None and lost_eye not in EYES:
        raise ValueError(f"lost_eye must be one of {', '.join(EYES)}, got {lost_eye!r}")
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
