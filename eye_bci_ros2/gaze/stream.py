"""
Which LSL stream is an eye tracker's: the gaze ``StreamProfile`` (:mod:`~eye_bci_ros2.streams`).

The bridge (:mod:`eye_bci_ros2.nodes.lsl_gaze_bridge`) reads its stream through
:class:`eye_bci_ros2.streams.lsl_connection.StreamConnection` (stamps, keeping and
switching streams); what makes a stream a gaze stream of the configured
tracker application is here, pure: its type / name / source_id
(:func:`eye_bci_ros2.gaze.profiles.stream_matches`) and its channels
(:func:`misfit`).  A stream whose channels are another application's (a
Pupil Capture stream of type ``Gaze`` under the default ``xy_pixels``
profile) is refused with the profile that fits it, never read as pixels.
"""

from typing import List, Optional, Sequence

from eye_bci_ros2.gaze.profiles import (build_config, GazeConfig, parse_channels, PROFILE_NAMES,
                                        PROFILES, resolve_mapping, stream_matches, xpath_predicate)
# Re-exported for the layers above (recordings): what a stream carries lives in streams.
from eye_bci_ros2.streams.content_types import (  # noqa: F401
    is_gaze_type, not_gaze as not_gaze_type)
from eye_bci_ros2.streams.lsl_connection import StreamDescription

#: The profile that assumes nothing about the layout.
CUSTOM = 'custom'


def not_gaze(stream: StreamDescription) -> Optional[str]:
    """Say why a stream is no eye tracker's whatever the parameters (None: it may be one)."""
    return not_gaze_type(stream.stream_type)


def _layout_fits(profile_name: str, labels: Sequence[str], channel_count: int) -> bool:
    """Tell whether a stream carries the channels the profile's application sends."""
    profile = PROFILES[profile_name]
    if channel_count != len(profile.channel_labels):
        return False
    if not any(labels):
        return True   # unlabelled: the count is all there is to check
    if not profile.labelled:
        return True   # the application writes none; someone else's labels say nothing
    return tuple(labels[:channel_count]) == profile.channel_labels


def fitting_profiles(labels: Sequence[str], channel_count: int) -> List[str]:
    """List the profiles (not ``custom``) whose application sends exactly these channels."""
    return [name for name in PROFILE_NAMES
            if name != CUSTOM and _layout_fits(name, labels, channel_count)]


def _default_channels(config: GazeConfig) -> bool:
    """Tell whether the channels are the profile's own (no x/y/confidence parameter set)."""
    profile = PROFILES[config.profile]
    confidence = (parse_channels('confidence_channel', profile.confidence_channel)[0]
                  if profile.confidence_channel else None)
    return (config.x_channels == parse_channels('x_channel', profile.x_channel)
            and config.y_channels == parse_channels('y_channel', profile.y_channel)
            and config.confidence_channel == confidence)


def misfit(config: GazeConfig, labels: Sequence[str], channel_count: int) -> Optional[str]:
    """
    Say why a stream's channels do not fit the configuration (None: they fit).

    A profile that names an application (not ``custom``) whose channel
    parameters are left to it expects exactly that application's channels
    (count, and labels where both label them); otherwise the configured
    channels must exist (:func:`eye_bci_ros2.gaze.profiles.resolve_mapping`).
    The reason names the profile(s) the stream fits.

    :param labels: the stream's channel labels ('' where none).
    :param channel_count: channels per sample.
    """
    labels = list(labels)
    reason = None
    try:
        resolve_mapping(config, labels, channel_count)
    except ValueError as error:
        reason = str(error)
    if reason is None and config.profile != CUSTOM and _default_channels(config) \
            and not _layout_fits(config.profile, labels, channel_count):
        expected = PROFILES[config.profile].channel_labels
        shown = ', '.join(label or '?' for label in labels[:4]) or 'unlabelled'
        more = ', ...' if len(labels) > 4 else ''
        reason = (f'its {channel_count} channel(s) ({shown}{more}) are not the '
                  f"{len(expected)} of profile '{config.profile}' ({', '.join(expected)})")
    if reason is None:
        return None
    others = [name for name in fitting_profiles(labels, channel_count) if name != config.profile]
    fits = ' or '.join(f'profile:={name}' for name in others)
    hint = (f'; it fits {fits}' if others
            else '; set profile, x_channel and y_channel to its layout')
    return f"it does not fit profile '{config.profile}': {reason}{hint}"


def how_to_select(stream: StreamDescription, config: GazeConfig) -> str:
    """
    Say which parameters would make the bridge take a stream it does not match now.

    A profile whose stream type and name (where it names one) are the
    stream's is suggested first; otherwise ``stream_type`` / ``stream_name``.
    """
    for name in PROFILE_NAMES:
        profile = PROFILES[name]
        if profile.stream_type and profile.stream_type == stream.stream_type \
                and profile.stream_name in ('', stream.name) and name != config.profile:
            return f'profile:={name}'
    settings = []
    if config.stream_type and config.stream_type != stream.stream_type:
        settings.append(f"stream_type:='{stream.stream_type}'")
    if config.stream_name and config.stream_name != stream.name:
        settings.append(f"stream_name:='{stream.name}'")
    if config.source_id and config.source_id != stream.source_id:
        settings.append(f"source_id:='{stream.source_id}'")
    return ' '.join(settings) or 'nothing (it matches)'


class GazeStreamProfile:
    """A :class:`GazeConfig` as the connection's stream profile."""

    kind = 'gaze'

    def __init__(self, config: GazeConfig):
        """Select streams by ``config`` (type, name, source_id, channels)."""
        self.config = config

    @classmethod
    def from_parameters(cls, values) -> 'GazeStreamProfile':
        """Build from the bridge's parameter values (:func:`build_config`)."""
        return cls(build_config(values))

    def predicate(self) -> str:
        """Return the resolver predicate of the selection."""
        return xpath_predicate(self.config)

    def matches(self, stream: StreamDescription) -> bool:
        """Tell whether type, name and source_id are the selected ones."""
        return stream_matches(self.config, stream.stream_type, stream.name, stream.source_id)

    def misfit(self, stream: StreamDescription) -> Optional[str]:
        """Say why the stream is not gaze (:func:`not_gaze`) or its channels do not fit."""
        return not_gaze(stream) or misfit(self.config, stream.labels or (), stream.channel_count)

    def unusable(self, stream: StreamDescription) -> Optional[str]:
        """Say why no parameters would make the stream a gaze stream (:func:`not_gaze`)."""
        return not_gaze(stream)

    def describe(self) -> str:
        """Say which streams are selected."""
        return self.config.describe_selection()

    def how_to_select(self, stream: StreamDescription) -> str:
        """Say which parameters would select ``stream``."""
        return how_to_select(stream, self.config)
