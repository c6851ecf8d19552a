"""
Which LSL stream the nodes take, with real outlets: by channels, never one of several sources.

Also the one time rule: the gaze bridge and the SSVEP decoder stamp the same
LSL time as the same ROS time (both read through
:class:`eye_bci_ros2.streams.lsl_connection.StreamConnection`).
"""

from fault_rig import LogTap
from lsl_outlets import make_outlet, sample_for, unique_id
import numpy as np
import pylsl
import pytest
from rclpy.parameter import Parameter
from ros_harness import GazeCollector

from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.nodes.ssvep_decoder import SsvepDecoder
from eye_bci_ros2.sim.lsl_outlet import open_outlet, stream_info

pytestmark = [pytest.mark.ros, pytest.mark.lsl]

WAIT_S = 30.0


def start_bridge(graph, **params):
    """Add the bridge with ``params`` and a collector on ``gaze/samples``."""
    node = graph.add(LslGazeBridge, parameter_overrides=[
        Parameter(name, value=value) for name, value in params.items()])
    return node, GazeCollector(graph.node('gaze_listener'))


def test_a_pupil_stream_is_refused_under_the_default_profile_with_the_profile_that_fits(
        graph, capfd):
    # A Pupil Capture relay (type Gaze, 22 channels) where the default xy_pixels sender is
    # expected: reading confidence and norm_pos_x as pixels would be a silent wrong gaze.
    stream_type = unique_id('Gaze')
    pupil, info = make_outlet('pupil_capture', stream_type=stream_type)
    log = LogTap(capfd)
    node, gaze = start_bridge(graph, stream_type=stream_type)   # default profile xy_pixels
    assert node.config.profile == 'xy_pixels'
    assert log.wait_for(graph, rf"lsl_gaze_bridge.*not taking '{info.name()}'.*does not fit "
                               r"profile 'xy_pixels'.*confidence, norm_pos_x.*"
                               r'it fits profile:=pupil_capture')
    pupil.push_chunk(sample_for('pupil_capture', [[960.0, 540.0]] * 5).tolist())
    graph.spin_for(0.5)
    assert node.stream is None and not pupil.have_consumers() and gaze.count == 0
    # The profile it names takes it (the name: this test outlet's own, unique one).
    results = graph.set_parameters('/lsl_gaze_bridge', {'profile': 'pupil_capture',
                                                        'stream_name': info.name()})
    assert all(result.successful for result in results), results
    assert graph.spin_until(pupil.have_consumers, WAIT_S)
    pupil.push_chunk(sample_for('pupil_capture', [[960.0, 540.0]] * 5).tolist())
    assert graph.spin_until(lambda: gaze.count >= 5, WAIT_S)
    np.testing.assert_allclose(gaze.samples()[1], [[960, 540]] * 5, atol=1e-6)


def test_of_two_trackers_none_is_taken_until_one_is_chosen(graph, capfd):
    # Two people's trackers of the same kind on one network: neither may be guessed.
    stream_type = unique_id('Gaze')
    mine, mine_info = make_outlet('xy_pixels', stream_type=stream_type)
    theirs, theirs_info = make_outlet('xy_pixels', stream_type=stream_type)
    log = LogTap(capfd)
    node, gaze = start_bridge(graph, stream_type=stream_type, resolve_period_s=0.2)
    assert log.wait_for(graph, r'lsl_gaze_bridge.*2 LSL streams match .* taking none until '
                               r'one is chosen')
    text = log.read()
    for info in (mine_info, theirs_info):
        assert f"select with source_id:='{info.source_id()}'" in text
    graph.spin_for(0.5)
    assert node.stream is None
    assert not mine.have_consumers() and not theirs.have_consumers()
    # The user picks one by the source_id the line named.
    result, = graph.set_parameters('/lsl_gaze_bridge', {'source_id': mine_info.source_id()})
    assert result.successful, result.reason
    assert graph.spin_until(mine.have_consumers, WAIT_S)
    assert node.stream_uid == mine_info.uid() and not theirs.have_consumers()


def test_eeg_and_gaze_stamps_agree_for_the_same_lsl_time(graph):
    gaze_outlet, gaze_info = make_outlet('custom')
    bridge, gaze = start_bridge(graph, profile='custom', stream_name=gaze_info.name(),
                                source_id=gaze_info.source_id())
    eeg_source = unique_id('eeg')
    labels = ('PO7', 'PO3', 'POz', 'PO4', 'PO8', 'O1', 'Oz', 'O2')
    eeg_outlet = open_outlet(stream_info(unique_id('amp'), 'EEG', len(labels), 250.0,
                                         eeg_source, labels=labels))
    decoder = graph.add(SsvepDecoder, parameter_overrides=[
        Parameter('layout', value='generic'), Parameter('source_id', value=eeg_source)])
    try:
        assert graph.spin_until(lambda: gaze_outlet.have_consumers()
                                and eeg_outlet.have_consumers(), WAIT_S)
        # A first sample of each has come through, and both clock offsets are known (a
        # loaded machine can take longer than CLOCK_SYNC_TIMEOUT_S for them: the samples
        # are placed by their arrival until then, which this test is not about).
        gaze_outlet.push_sample([1.0, 1.0])
        eeg_outlet.push_sample([0.0] * len(labels))
        assert graph.spin_until(lambda: gaze.count == 1
                                and decoder.connection.newest_stamp_ns is not None
                                and bridge.connection.clock_offset is not None
                                and decoder.connection.clock_offset is not None, WAIT_S)
        first_eeg_ns = decoder.connection.newest_stamp_ns
        # One instant on this machine's LSL clock, 0.25 s ago, sent by both.
        lsl_time = pylsl.local_clock() - 0.25
        gaze_outlet.push_sample([2.0, 2.0], timestamp=lsl_time)
        eeg_times = lsl_time - np.arange(25)[::-1] / 250.0   # its newest sample at lsl_time
        eeg_outlet.push_chunk(np.zeros((25, len(labels))).tolist(), eeg_times.tolist())
        # The chunk is in when the newest EEG stamp changed (it can be older than the first).
        assert graph.spin_until(lambda: gaze.count == 2 and
                                decoder.connection.newest_stamp_ns != first_eeg_ns, WAIT_S)
        gaze_ns = gaze.samples()[0][1] * 1e9
        eeg_ns = decoder.connection.newest_stamp_ns
        # The same mapping read at two pulls: equal up to clock-reading jitter (< 2 ms).
        assert abs(gaze_ns - eeg_ns) < 2e6, (gaze_ns - eeg_ns) / 1e6
    finally:
        decoder.close_stream()
