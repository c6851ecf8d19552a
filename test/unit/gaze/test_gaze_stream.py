"""Which LSL streams the gaze profile refuses, and what it tells the user to do instead."""

import pytest

from eye_bci_ros2.gaze.profiles import build_config
from eye_bci_ros2.gaze.stream import GazeStreamProfile
from eye_bci_ros2.streams.lsl_connection import StreamDescription


def described(stream_type: str, name: str = 'LiveAmp', channels: int = 8) -> StreamDescription:
    """Describe a stream as the network advertises it."""
    return StreamDescription(uid='u', name=name, stream_type=stream_type, source_id='amp-1',
                             hostname='host', channel_count=channels, nominal_srate=250.0,
                             created_at=1.0, labels=('',) * channels)


@pytest.mark.parametrize('stream_type', ['EEG', 'eeg', 'Markers', 'Audio'])
def test_a_stream_that_is_never_gaze_is_said_to_be_so_with_what_to_do(stream_type):
    profile = GazeStreamProfile(build_config({}))
    stream = described(stream_type)
    reason = profile.unusable(stream)
    assert reason == (f'it is an {stream_type} stream, not gaze (a gaze bridge cannot use it): '
                      "start the eye tracker's LSL sender (sim_gaze to try without one)")
    # Never suggested as a parameter to set; selected all the same, it is refused.
    assert profile.how_to_select(stream) and profile.misfit(stream) == reason
    selected = GazeStreamProfile(build_config({'stream_type': stream_type}))
    assert selected.matches(stream) and selected.misfit(stream) == reason


@pytest.mark.parametrize('stream_type', ['Gaze', 'gaze', 'Eyetracker', 'custom-type'])
def test_a_stream_that_may_be_gaze_is_left_to_the_selection(stream_type):
    profile = GazeStreamProfile(build_config({}))
    assert profile.unusable(described(stream_type, channels=2)) is None
