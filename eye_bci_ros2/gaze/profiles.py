"""
Map eye-tracker LSL samples to gaze points on the screen: pure numpy, no rclpy, no pylsl.

Every supported tracker application is a :class:`Profile`: how it names and
types its LSL stream, which channels hold the gaze point, their units and
origin.  A profile only supplies defaults; the bridge's parameters override
each of them (:func:`build_config`).  The result is converted against the
labels of the stream actually found (:func:`resolve_mapping`) and applied to
whole chunks of samples at once (:func:`convert`).

Output frame ``screen``: origin at the top-left of the display the person
looks at, x right, y down, pixels.  Coordinates are continuous: a gaze point
at the right edge of a 1366 px wide source screen maps to x = 1920 on a
1920 px wide screen.

Layouts of the tracker applications (checked against their sources):

``tobii_pro``
    labstreaminglayer/App-TobiiPro (``mainwindow.cpp``): stream name ``Tobii``,
    type ``Eyetracker``, 6 float32 channels labelled ``left_x, left_y,
    left_pupil, right_x, right_y, right_pupil``; x/y are the gaze point on the
    display area, normalised 0..1 from the top-left corner; an eye whose gaze
    point is invalid is sent as NaN.  Nominal rate 600 Hz (the app's
    placeholder; Pro trackers run at 60..1200 Hz).  The bridge averages the
    eyes that are valid and drops a sample when both are lost.
``tobii_stream_engine``
    labstreaminglayer/App-TobiiStreamEngine (consumer trackers such as the
    4C): stream name ``TobiiStreamEngine`` (editable in the app), type
    ``gaze`` (lower case), 2 float32 channels without labels: x, y of
    ``tobii_gaze_point_t.position_xy``, normalised 0..1 from the top-left of
    the display; irregular rate (nominal_srate 0); only valid points are sent.
``pupil_capture``
    labstreaminglayer/App-PupilLabs, Pupil Capture LSL relay: stream name
    ``pupil_capture``, type ``Gaze``, 22 double channels labelled
    (``confidence``, ``norm_pos_x``, ``norm_pos_y``, ``gaze_point_3d_x`` ...);
    ``norm_pos`` is normalised 0..1 with the origin at the BOTTOM-left, in the
    scene camera image (map it to the display with Pupil's surface tracker or
    by framing the display with the scene camera); confidence 0..1,
    samples below 0.6 are dropped by default (Pupil Labs' usual threshold).
``xy_pixels``
    the original system's sender (CRLab ``eye_tracking_device``, C#, Tobii
    4C on a Windows machine): 2 channels x, y in pixels of the 1366x768
    Windows screen, top-left origin, scaled to the 1920x1080 screen RViz is
    shown on.  Its stream type and name are not documented; the profile
    assumes type ``Gaze`` and any name: set ``stream_type``/``stream_name``
    to what your sender advertises.
``custom``
    nothing assumed: channels 0 and 1, pixels of the screen itself, top-left
    origin, any stream; set the parameters.
"""

from dataclasses import dataclass, field
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from eye_bci_ros2.gaze.validation import apply_correction
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING

#: Profile names, in the order the parameter description lists them.
PROFILE_NAMES = ('tobii_pro', 'tobii_stream_engine', 'pupil_capture', 'xy_pixels', 'custom')
DEFAULT_PROFILE = 'xy_pixels'
UNITS = ('pixels', 'normalized')
ORIGINS = ('top_left', 'bottom_left')
#: Stream-selection value meaning "any", overriding a profile's default.
ANY = '*'
#: confidence_channel value meaning "no confidence check", overriding a profile's default.
NO_CONFIDENCE = 'none'
#: Drop reasons counted by :func:`convert`, in the order they are tested.
DROP_REASONS = ('nonfinite', 'low_confidence', 'offscreen')

ChannelSpec = Union[int, str]

_PUPIL_CAPTURE_LABELS = (
    ('confidence', 'norm_pos_x', 'norm_pos_y')
    + tuple(f'gaze_point_3d_{a}' for a in 'xyz')
    + tuple(f'eye_center{e}_3d_{a}' for e in range(2) for a in 'xyz')
    + tuple(f'gaze_normal{e}_{a}' for e in range(2) for a in 'xyz')
    + ('diameter0_2d', 'diameter1_2d', 'diameter0_3d', 'diameter1_3d'))


@dataclass(frozen=True)
class Profile:
    """
    How one tracker application lays out its LSL stream (defaults only).

    :param name: profile name (parameter ``profile``).
    :param description: one line for humans.
    :param stream_type: LSL ``type`` it advertises ('' = any).
    :param stream_name: LSL ``name`` it advertises ('' = any).
    :param x_channel: channel(s) holding x, as the ``x_channel`` parameter
        spells them: a label or a 0-based index, several separated by commas
        (one per eye, averaged over the valid eyes).
    :param y_channel: the same for y, same number of entries as x.
    :param units: 'pixels' or 'normalized' (0..1 across the source screen).
    :param origin: 'top_left' or 'bottom_left' corner of the source screen.
    :param source_width: source screen width, px (pixels units); 0 = the
        screen itself.
    :param source_height: source screen height, px; 0 = the screen itself.
    :param confidence_channel: label/index of a 0..1 confidence channel, ''
        for none.
    :param min_confidence: samples below this confidence are dropped.
    :param channel_labels: the channels the application sends, in order;
        used when a stream carries no labels and has exactly this many
        channels, and by the test outlets.
    :param channel_format: 'float32' or 'double64', as the application sends.
    :param nominal_srate: nominal rate the application advertises, Hz (0 =
        irregular).
    :param labelled: whether the application writes channel labels into
        the stream description.
    """

    name: str
    description: str
    stream_type: str
    stream_name: str
    x_channel: str
    y_channel: str
    units: str
    origin: str
    source_width: int = 0
    source_height: int = 0
    confidence_channel: str = ''
    min_confidence: float = 0.0
    channel_labels: Tuple[str, ...] = field(default_factory=tuple)
    channel_format: str = 'float32'
    nominal_srate: float = 0.0
    labelled: bool = True


PROFILES: Dict[str, Profile] = {p.name: p for p in (
    Profile(
        name='tobii_pro', description='Tobii Pro LSL app (App-TobiiPro)',
        stream_type='Eyetracker', stream_name='Tobii',
        x_channel='left_x,right_x', y_channel='left_y,right_y',
        units='normalized', origin='top_left',
        channel_labels=('left_x', 'left_y', 'left_pupil', 'right_x', 'right_y', 'right_pupil'),
        channel_format='float32', nominal_srate=600.0),
    Profile(
        name='tobii_stream_engine',
        description='Tobii Stream Engine LSL app for consumer trackers (App-TobiiStreamEngine)',
        stream_type='gaze', stream_name='TobiiStreamEngine',
        x_channel='0', y_channel='1', units='normalized', origin='top_left',
        channel_labels=('x', 'y'), channel_format='float32', nominal_srate=0.0,
        labelled=False),
    Profile(
        name='pupil_capture', description='Pupil Capture LSL relay (App-PupilLabs)',
        stream_type='Gaze', stream_name='pupil_capture',
        x_channel='norm_pos_x', y_channel='norm_pos_y', units='normalized',
        origin='bottom_left', confidence_channel='confidence', min_confidence=0.6,
        channel_labels=_PUPIL_CAPTURE_LABELS, channel_format='double64', nominal_srate=0.0),
    Profile(
        name='xy_pixels',
        description='original CRLab C# sender: x, y px of a 1366x768 Windows screen',
        stream_type='Gaze', stream_name='', x_channel='0', y_channel='1',
        units='pixels', origin='top_left', source_width=1366, source_height=768,
        channel_labels=('x', 'y'), channel_format='float32', nominal_srate=0.0,
        labelled=False),
    Profile(
        name='custom', description='everything from parameters',
        stream_type='', stream_name='', x_channel='0', y_channel='1',
        units='pixels', origin='top_left', channel_labels=('x', 'y')),
)}


@dataclass(frozen=True)
class GazeConfig:
    """
    Effective bridge settings: profile defaults with the parameters applied.

    Stream selection strings are '' when any value matches.  Channel specs are
    tuples of labels (str) or 0-based indices (int), one entry per eye.
    """

    profile: str
    stream_type: str
    stream_name: str
    source_id: str
    x_channels: Tuple[ChannelSpec, ...]
    y_channels: Tuple[ChannelSpec, ...]
    units: str
    origin: str
    source_width: int
    source_height: int
    screen_width: int
    screen_height: int
    confidence_channel: Optional[ChannelSpec]
    min_confidence: float
    offscreen_margin_px: float

    @property
    def selection(self) -> Tuple[str, str, str]:
        """(stream_type, stream_name, source_id) that pick the stream ('' = any)."""
        return (self.stream_type, self.stream_name, self.source_id)

    def describe_selection(self) -> str:
        """Say which streams this configuration accepts, for log messages."""
        parts = [f"{key} '{value}'" for key, value in (
            ('type', self.stream_type), ('name', self.stream_name),
            ('source_id', self.source_id)) if value]
        return ', '.join(parts) if parts else 'any stream'


@dataclass(frozen=True)
class GazeMapping:
    """
    A :class:`GazeConfig` bound to the channel layout of one stream.

    :param channel_count: channels per sample of the stream.
    :param x_index: column of x for each eye, shape (k,).
    :param y_index: column of y for each eye, shape (k,).
    :param confidence_index: column of the confidence, or None.
    :param min_confidence: drop samples below this confidence.
    :param scale: source units -> screen px for x and y, shape (2,).
    :param flip_span: source height to flip y about (bottom-left origin), or
        None for a top-left origin; in source units.
    :param screen_size: (width, height) of the screen, px.
    :param margin: accepted distance outside the screen, px.
    """

    channel_count: int
    x_index: np.ndarray
    y_index: np.ndarray
    confidence_index: Optional[int]
    min_confidence: float
    scale: np.ndarray
    flip_span: Optional[float]
    screen_size: Tuple[int, int]
    margin: float


@dataclass
class GazeBatch:
    """
    Result of converting one chunk.

    :param xy: accepted gaze points in ``screen`` px, shape (M, 2), float64.
    :param keep: which input samples were accepted, shape (N,), bool;
        ``xy`` holds the samples where ``keep`` is true, in order.
    :param dropped: number of samples dropped per reason (:data:`DROP_REASONS`).
    """

    xy: np.ndarray
    keep: np.ndarray
    dropped: Dict[str, int]


def parse_channels(name: str, text: str) -> Tuple[ChannelSpec, ...]:
    """
    Parse a channel parameter: labels or 0-based indices separated by commas.

    A token made only of digits is an index; anything else is a label.

    :param name: parameter name, for the error message.
    :param text: e.g. ``'norm_pos_x'``, ``'0'`` or ``'left_x,right_x'``.
    :returns: one entry per eye.
    :raises ValueError: empty list or empty entry.
    """
    tokens = [token.strip() for token in str(text).split(',')]
    if not tokens or any(not token for token in tokens):
        raise ValueError(f"{name}: '{text}' must list channel labels or 0-based indices "
                         f"separated by commas, e.g. 'left_x,right_x' or '0'")
    return tuple(int(token) if token.isdigit() else token for token in tokens)


def _check_distinct(x_channels: Sequence[Any], y_channels: Sequence[Any],
                    kind: str = 'channel') -> None:
    """
    Refuse x and y channels that name the same channel (every point would lie on x == y).

    :param x_channels: the x channel of each eye (specs, or resolved column indices).
    :param y_channels: the y channel of each eye, likewise.
    :param kind: what they are, for the reason: 'channel' (as given) or 'column' (resolved).
    :raises ValueError: with the shared channel(s).
    """
    shared = [spec for spec in dict.fromkeys(x_channels) if spec in set(y_channels)]
    if shared:
        named = ', '.join(f"'{spec}'" if kind == 'channel' else str(spec) for spec in shared)
        raise ValueError(f'x_channel and y_channel both name {kind} {named}: x and y must be '
                         'two different channels of the stream')


def build_config(values: Mapping[str, Any]) -> GazeConfig:
    """
    Combine a profile's defaults with explicit parameter values.

    Precedence: an explicit value wins over the profile's default.  "Not
    set" is '' for strings, 0 for ``source_width``/``source_height`` and a
    negative ``min_confidence``.  ``'*'`` in ``stream_type``, ``stream_name``
    or ``source_id`` means any value; ``'none'`` in ``confidence_channel``
    turns the profile's confidence check off.

    :param values: parameter name -> value (missing names take defaults).
    :raises ValueError: unknown profile, unit or origin, malformed or
        mismatched channel lists, non-positive screen size, negative margin.
    """
    profile_name = values.get('profile') or DEFAULT_PROFILE
    profile = PROFILES.get(profile_name)
    if profile is None:
        raise ValueError(f"unknown profile '{profile_name}': use one of "
                         f"{', '.join(PROFILE_NAMES)}")

    def pick(key: str, default: Any) -> Any:
        value = values.get(key)
        return default if value is None or value == '' else value

    def selection(key: str, default: str) -> str:
        value = str(pick(key, default)).strip()
        return '' if value == ANY else value

    x_channels = parse_channels('x_channel', pick('x_channel', profile.x_channel))
    y_channels = parse_channels('y_channel', pick('y_channel', profile.y_channel))
    if len(x_channels) != len(y_channels):
        raise ValueError(f'x_channel lists {len(x_channels)} channel(s) but y_channel lists '
                         f'{len(y_channels)}: give one x and one y per eye')
    _check_distinct(x_channels, y_channels)
    units = pick('units', profile.units)
    if units not in UNITS:
        raise ValueError(f"units '{units}' is not one of {', '.join(UNITS)}")
    origin = pick('origin', profile.origin)
    if origin not in ORIGINS:
        raise ValueError(f"origin '{origin}' is not one of {', '.join(ORIGINS)}")
    screen_width = int(values.get('screen_width', DEFAULT_VIEWING.width_px))
    screen_height = int(values.get('screen_height', DEFAULT_VIEWING.height_px))
    if screen_width <= 0 or screen_height <= 0:
        raise ValueError(f'screen size must be positive, got {screen_width}x{screen_height}')
    source_width = int(values.get('source_width') or profile.source_width or screen_width)
    source_height = int(values.get('source_height') or profile.source_height or screen_height)
    if source_width <= 0 or source_height <= 0:
        raise ValueError(f'source size must be positive, got {source_width}x{source_height}')
    confidence = str(pick('confidence_channel', profile.confidence_channel)).strip()
    confidence_channel = None
    if confidence and confidence != NO_CONFIDENCE:
        confidence_channel = parse_channels('confidence_channel', confidence)
        if len(confidence_channel) != 1:
            raise ValueError(f"confidence_channel '{confidence}' must name one channel")
        confidence_channel = confidence_channel[0]
    min_confidence = values.get('min_confidence')
    if min_confidence is None or min_confidence < 0:
        min_confidence = profile.min_confidence
    margin = float(values.get('offscreen_margin_px', 100.0))
    if not margin >= 0:
        raise ValueError(f'offscreen_margin_px must be >= 0, got {margin}')
    return GazeConfig(
        profile=profile_name,
        stream_type=selection('stream_type', profile.stream_type),
        stream_name=selection('stream_name', profile.stream_name),
        source_id=selection('source_id', ''),
        x_channels=x_channels, y_channels=y_channels, units=units, origin=origin,
        source_width=source_width, source_height=source_height,
        screen_width=screen_width, screen_height=screen_height,
        confidence_channel=confidence_channel, min_confidence=float(min_confidence),
        offscreen_margin_px=margin)


def stream_matches(config: GazeConfig, stream_type: str, stream_name: str,
                   source_id: str) -> bool:
    """Whether a stream with these properties is one the configuration selects."""
    return all(not wanted or wanted == actual for wanted, actual in zip(
        config.selection, (stream_type, stream_name, source_id)))


def xpath_predicate(config: GazeConfig) -> str:
    """
    LSL resolver predicate (XPath 1.0) for the selection; '' selects all.

    A value holding both quote characters cannot be an XPath literal: it is
    left out here, so callers must still filter with :func:`stream_matches`.
    """
    terms = []
    for key, value in zip(('type', 'name', 'source_id'), config.selection):
        if not value:
            continue
        if "'" not in value:
            terms.append(f"{key}='{value}'")
        elif '"' not in value:
            terms.append(f'{key}="{value}"')
    return ' and '.join(terms)


def _channel_index(name: str, spec: ChannelSpec, labels: Sequence[str],
                   channel_count: int, fallback: Sequence[str]) -> int:
    """Column of one channel spec in a stream, or a ValueError saying why not."""
    if isinstance(spec, int):
        if spec >= channel_count:
            raise ValueError(f'{name}: channel index {spec} is out of range, the stream has '
                             f'{channel_count} channel(s)')
        return spec
    if spec in labels:
        return list(labels).index(spec)
    if not any(labels) and spec in fallback and len(fallback) == channel_count:
        # Unlabelled stream with exactly the application's layout.
        return list(fallback).index(spec)
    known = ', '.join(label for label in labels if label) or 'none'
    raise ValueError(f"{name}: the stream has no channel labelled '{spec}' "
                     f'(its {channel_count} channel labels: {known})')


def resolve_mapping(config: GazeConfig, labels: Sequence[str],
                    channel_count: int) -> GazeMapping:
    """
    Bind a configuration to the channel layout of a stream.

    :param config: effective settings.
    :param labels: channel labels from the stream description, in channel
        order ('' or a shorter list where the stream has none).
    :param channel_count: channels per sample of the stream.
    :raises ValueError: a channel that the stream does not have.
    """
    if channel_count < 1:
        raise ValueError(f'the stream has {channel_count} channels')
    labels = list(labels)[:channel_count]
    fallback = PROFILES[config.profile].channel_labels
    x_index = np.array([_channel_index('x_channel', spec, labels, channel_count, fallback)
                        for spec in config.x_channels], dtype=np.intp)
    y_index = np.array([_channel_index('y_channel', spec, labels, channel_count, fallback)
                        for spec in config.y_channels], dtype=np.intp)
    # A label and an index (or two labels) can still name one column.
    _check_distinct(x_index.tolist(), y_index.tolist(), 'column')
    confidence_index = None
    if config.confidence_channel is not None:
        confidence_index = _channel_index('confidence_channel', config.confidence_channel,
                                          labels, channel_count, fallback)
    if config.units == 'normalized':
        scale = np.array([config.screen_width, config.screen_height], dtype=float)
        span = 1.0
    else:
        scale = np.array([config.screen_width / config.source_width,
                          config.screen_height / config.source_height])
        span = float(config.source_height)
    return GazeMapping(
        channel_count=channel_count, x_index=x_index, y_index=y_index,
        confidence_index=confidence_index, min_confidence=config.min_confidence,
        scale=scale, flip_span=span if config.origin == 'bottom_left' else None,
        screen_size=(config.screen_width, config.screen_height),
        margin=config.offscreen_margin_px)


def convert(samples: np.ndarray, mapping: GazeMapping,
            correction: Optional[np.ndarray] = None) -> GazeBatch:
    """
    Convert a chunk of samples to screen points, dropping the invalid ones.

    Per sample: the eyes whose x and y are both finite are averaged and
    scaled to the screen, then ``correction`` (a validation's affine or
    second-order map, :func:`eye_bci_ros2.gaze.validation.apply_correction`; None = none) moves the
    point; no finite eye -> dropped as 'nonfinite'.  Confidence below the minimum (or not
    finite) -> 'low_confidence'.  More than the margin outside the screen ->
    'offscreen'.  Each dropped sample is counted once, under the first
    reason in that order.

    :param samples: shape (N, channel_count), any real dtype.
    :param mapping: from :func:`resolve_mapping`.
    :param correction: shape (2, 6) (or (2, 3) affine) screen px map
        (:func:`eye_bci_ros2.gaze.validation.as_matrix`), or None.
    :returns: the accepted points in ``screen`` px and the drop counts.
    :raises ValueError: samples whose channel count differs from the stream's.
    """
    samples = np.asarray(samples)
    if samples.ndim != 2 or samples.shape[1] != mapping.channel_count:
        raise ValueError(f'expected samples of shape (N, {mapping.channel_count}), '
                         f'got {samples.shape}')
    # One errstate for the whole batch, and the average over the eyes without masking when
    # every eye is tracked (the common case): the cost is per call at tracker rates (a batch
    # every poll), so few numpy calls, whatever the batch's size.
    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        x_eyes = samples[:, mapping.x_index].astype(np.float64)
        y_eyes = samples[:, mapping.y_index].astype(np.float64)
        valid = np.isfinite(x_eyes) & np.isfinite(y_eyes)
        if valid.all():
            finite = np.ones(len(samples), dtype=bool)
            xy = np.empty((len(samples), 2))
            np.sum(x_eyes, axis=1, out=xy[:, 0])
            np.sum(y_eyes, axis=1, out=xy[:, 1])
            xy /= x_eyes.shape[1]
        else:
            eyes = valid.sum(axis=1)
            finite = eyes > 0
            xy = np.stack([np.where(valid, x_eyes, 0.0).sum(axis=1),
                           np.where(valid, y_eyes, 0.0).sum(axis=1)], axis=1) / eyes[:, None]
        if mapping.flip_span is not None:
            xy[:, 1] = mapping.flip_span - xy[:, 1]
        xy *= mapping.scale
        if correction is not None:
            xy = apply_correction(xy, correction)
        # The averaged point can still overflow to inf from huge finite inputs.
        finite &= np.isfinite(xy).all(axis=1)

        confident = None
        if mapping.confidence_index is not None:
            confidence = samples[:, mapping.confidence_index].astype(np.float64)
            confident = confidence >= mapping.min_confidence

        width, height = mapping.screen_size
        margin = mapping.margin
        onscreen = ((xy[:, 0] >= -margin) & (xy[:, 0] <= width + margin)
                    & (xy[:, 1] >= -margin) & (xy[:, 1] <= height + margin))

    keep = finite & onscreen if confident is None else finite & confident & onscreen
    if keep.all():
        dropped = {'nonfinite': 0, 'low_confidence': 0, 'offscreen': 0}
        return GazeBatch(xy=xy, keep=keep, dropped=dropped)
    if confident is None:
        confident = np.ones(len(samples), dtype=bool)
    dropped = {
        'nonfinite': int(np.count_nonzero(~finite)),
        'low_confidence': int(np.count_nonzero(finite & ~confident)),
        'offscreen': int(np.count_nonzero(finite & confident & ~onscreen)),
    }
    return GazeBatch(xy=xy[keep], keep=keep, dropped=dropped)
