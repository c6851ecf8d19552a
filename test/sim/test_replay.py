"""The replay of a recording over real LSL (no ROS): every sample, its own stamp, the layout."""

import time
import uuid

import numpy as np
import pylsl
import pytest

from eye_bci_ros2.gaze.profiles import build_config, convert, resolve_mapping
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING
from eye_bci_ros2.recordings.gaze import TargetSchedule
from eye_bci_ros2.sim import gaze_outlet as sim_gaze
from eye_bci_ros2.sim.person import CONSUMER_TRACKER, record_schedule
from eye_bci_ros2.sim.replay import GazeReplayer

#: Generous waits, s (2 shared cores; never a timing assertion).
WAIT_S = 20.0


def simulated_recording(seconds: float = 1.0):
    """Record a short stretch of the simulated person (with lost samples) on two targets."""
    onsets = np.array([0.0, 0.5])
    places = np.array([[400.0, 300.0], [1500.0, 800.0]])
    targets = TargetSchedule(onsets, onsets, np.array([0.5, seconds]), places)
    params = CONSUMER_TRACKER.with_changes(loss_prob=0.1)
    return record_schedule(targets, DEFAULT_VIEWING, params, seed=3)


def pull_all(inlet: pylsl.StreamInlet, count: int):
    """Pull until ``count`` samples arrived (or WAIT_S passed); samples and stamps."""
    rows, stamps = [], []
    give_up = time.monotonic() + WAIT_S
    while len(stamps) < count and time.monotonic() < give_up:
        data, ts = inlet.pull_chunk(timeout=0.2)
        rows.extend(data)
        stamps.extend(ts)
    return np.array(rows, dtype=float), np.array(stamps)


@pytest.mark.lsl
@pytest.mark.parametrize('profile, send_lost', [('tobii_pro', True),
                                                ('tobii_stream_engine', False)])
def test_every_sample_goes_out_with_its_own_stamp_in_the_applications_layout(
        profile, send_lost):
    recording = simulated_recording()
    source_id = f'replay-test-{uuid.uuid4().hex}'
    replayer = GazeReplayer(recording, profile, name=f'replay-{uuid.uuid4().hex}',
                            source_id=source_id, wait_s=WAIT_S)
    valid = np.isfinite(recording.points).all(axis=1)
    sent = np.arange(len(valid)) if send_lost else np.flatnonzero(valid)
    assert np.count_nonzero(~valid) > 0
    with replayer:
        found = pylsl.resolve_byprop('source_id', source_id, 1, WAIT_S)
        assert found, 'the replay was not advertised'
        assert found[0].type() == build_config({'profile': profile}).stream_type
        inlet = pylsl.StreamInlet(found[0], max_buflen=30, recover=False)
        inlet.open_stream(WAIT_S)
        samples, stamps = pull_all(inlet, len(sent))
        assert replayer.wait_finished(WAIT_S)
        description = inlet.info(WAIT_S)
    assert len(stamps) == len(sent)
    # The recording's own stamps from the moment the first was due.
    np.testing.assert_allclose(stamps - replayer.t0, recording.stamps[sent], atol=1e-6)
    # Read back as the bridge reads the application's stream: the recorded points.
    labels = []
    channel = description.desc().child('channels').child('channel')
    while not channel.empty():
        labels.append(channel.child_value('label'))
        channel = channel.next_sibling()
    mapping = resolve_mapping(build_config({'profile': profile}), labels, samples.shape[1])
    batch = convert(samples, mapping)
    np.testing.assert_array_equal(batch.keep, valid[sent])
    np.testing.assert_allclose(batch.xy, recording.points[sent][valid[sent]], atol=1e-3)


def test_a_replay_of_a_file_that_is_not_a_recording_is_one_clear_line(tmp_path, capsys):
    path = tmp_path / 'notes.txt'
    path.write_text('hello')
    with pytest.raises(SystemExit) as stop:
        sim_gaze.main(['--replay', str(path)])
    assert stop.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert 'not a known gaze recording' in error[-1] and 'Traceback' not in '\n'.join(error)
