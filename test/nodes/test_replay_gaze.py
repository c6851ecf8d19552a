"""A recording replayed over real LSL into the real bridge: every sample reaches gaze/samples."""

from dataclasses import replace

from lsl_outlets import bridge_parameters, sample_for, unique_id
import numpy as np
import pylsl
import pytest
from rclpy.parameter import Parameter
from ros_harness import GazeCollector

from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.gaze import find_recordings, GazeRecording, load_gaze
from eye_bci_ros2.sim.replay import GazeReplayer

pytestmark = [pytest.mark.ros, pytest.mark.lsl]

REAL_GAZE = find_data('real_gaze')
#: Seconds of the recording replayed (real time: the replay keeps the recording's rate).
REPLAY_S = 2.0
#: Generous wait for everything to arrive, s (2 shared cores; never a timing assertion).
WAIT_S = 30.0
#: The sentinel sample's stamp ahead of the clock, s (past every replayed sample's).
SENTINEL_AHEAD_S = 1.0


def first_seconds(recording: GazeRecording, seconds: float) -> GazeRecording:
    """Cut the recording to its first ``seconds`` (the replay sends only gaze)."""
    keep = recording.stamps < seconds
    return replace(recording, stamps=recording.stamps[keep], points=recording.points[keep])


@pytest.mark.skipif(REAL_GAZE is None, reason='no real_gaze recordings (../shared/data/'
                    'real_gaze beside the repository, or $EYE_BCI_DATA/real_gaze)')
@pytest.mark.parametrize('profile', ['tobii_pro', 'xy_pixels'])
def test_replayed_real_gaze_reaches_gaze_samples_with_every_sample(graph, profile):
    files = [path for path in find_recordings(REAL_GAZE) if 'X260' in path.name]
    if not files:
        pytest.skip(f'no X2-60 recording in {REAL_GAZE}')
    recording = first_seconds(load_gaze(files[0]), REPLAY_S)
    valid = np.isfinite(recording.points).all(axis=1)
    assert 0 < np.count_nonzero(~valid), 'the stretch should hold lost samples too'
    replayer = GazeReplayer(recording, profile, name=unique_id(profile),
                            source_id=unique_id('replay'), wait_s=WAIT_S)
    bridge = graph.add(LslGazeBridge, parameter_overrides=[
        Parameter(name, value=value)
        for name, value in bridge_parameters(profile, replayer.info).items()])
    gaze = GazeCollector(graph.node('gaze_listener'))
    with replayer:
        assert graph.spin_until(lambda: gaze.count >= np.count_nonzero(valid)
                                and replayer.finished, WAIT_S + REPLAY_S * 3), \
            f'{gaze.count} of {np.count_nonzero(valid)} samples arrived'
        # A sentinel sample after the replay, stamped a second ahead: the bridge forwards
        # samples in order, so anything extra of the replay arrives before it.
        sentinel_s = bridge.get_clock().now().nanoseconds * 1e-9 + SENTINEL_AHEAD_S - 0.5
        replayer.outlet.push_sample(sample_for(profile, [[100.0, 100.0]])[0].tolist(),
                                    pylsl.local_clock() + SENTINEL_AHEAD_S)
        assert graph.spin_until(lambda: gaze.count and gaze.samples()[0][-1] > sentinel_s,
                                WAIT_S), 'the sentinel sample never arrived'
    stamps, points = (part[:-1] for part in gaze.samples())
    # Every valid sample, once, at its place; the lost ones were sent and counted.
    assert len(points) == np.count_nonzero(valid)
    np.testing.assert_allclose(points, recording.points[valid], atol=0.01)
    assert bridge.counters['nonfinite'] == np.count_nonzero(~valid)
    # Each with its own stamp: the recording's own intervals (LSL stamps are the replay's).
    np.testing.assert_allclose(stamps - stamps[0],
                               recording.stamps[valid] - recording.stamps[valid][0],
                               atol=1e-4)
