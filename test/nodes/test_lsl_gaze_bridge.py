"""The lsl_gaze_bridge node with real LSL outlets on a private ROS 2 graph."""

import gc
import time

from fault_rig import LogTap
from geometry_msgs.msg import PointStamped
from lsl_outlets import bridge_parameters, make_outlet, sample_for, unique_id
import numpy as np
import pylsl
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector, GazeCollector

from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.ros.topics import GAZE_POINT_TOPIC, VIEW_QOS

pytestmark = [pytest.mark.ros, pytest.mark.lsl]

NAN = float('nan')
#: Stamps are compared to the ROS time taken when pushing (a correctness check).
STAMP_TOLERANCE_NS = 50_000_000
WAIT_S = 10.0


def start_bridge(graph, **params):
    """Add the bridge with ``params`` and a collector on ``gaze/samples``."""
    node = graph.add(LslGazeBridge, parameter_overrides=[
        Parameter(name, value=value) for name, value in params.items()])
    return node, GazeCollector(graph.node('gaze_listener'))


def connect(graph, outlet):
    """Wait until the bridge's inlet is attached to ``outlet``."""
    assert graph.spin_until(outlet.have_consumers, WAIT_S), 'bridge never connected'


def ros_now_ns(graph):
    """Return ROS time now on the graph's clock, ns."""
    return graph.nodes[0].get_clock().now().nanoseconds


def wait_for(graph, collector, count):
    """Spin until ``count`` gaze samples arrived; return their points (N, 2)."""
    assert graph.spin_until(lambda: collector.count >= count, WAIT_S), \
        f'expected {count} gaze samples, got {collector.count}'
    return collector.samples()[1]


def stamps_ns(collector):
    """Return the stamps of every gaze sample received, ns (N,)."""
    return collector.samples()[0] * 1e9


def test_default_profile_scales_original_sender_pixels_with_acquisition_stamps(graph):
    outlet, info = make_outlet('xy_pixels')
    # Only the stream identity: everything else is the default xy_pixels profile.
    node, gaze = start_bridge(graph, stream_name=info.name(), source_id=info.source_id())
    assert node.config.profile == 'xy_pixels'
    connect(graph, outlet)
    pushed_at = ros_now_ns(graph)
    outlet.push_chunk([[683.0, 384.0], [0.0, 0.0], [1366.0, 768.0], [100.0, 700.0]])
    points = wait_for(graph, gaze, 4)
    # 1920/1366 and 1080/768: 100 -> 140.556..., 700 -> 984.375
    np.testing.assert_allclose(points, [[960, 540], [0, 0], [1920, 1080],
                                        [140.5563689604685, 984.375]], atol=1e-9)
    for message in gaze.messages:
        assert message.header.frame_id == 'screen'
        assert [field.name for field in message.fields] == ['x', 'y', 't']
    assert np.all(np.abs(stamps_ns(gaze) - pushed_at) < STAMP_TOLERANCE_NS)
    assert node.counters['published'] == 4


# Raw samples as each application sends them, and the screen points they mean (1920x1080).
_PUPIL = np.full((3, 22), NAN)
_PUPIL[:, :3] = [[0.9, 0.25, 0.75],    # confidence, norm_pos_x, norm_pos_y -> (480, 270)
                 [0.3, 0.5, 0.5],      # confidence below 0.6: dropped
                 [0.8, 0.1, 0.0]]      # bottom edge -> (192, 1080)
CASES = {
    'tobii_pro': ([[0.25, 0.5, 3.0, 0.35, 0.5, 3.0],     # mean of the eyes (0.3, 0.5)
                   [NAN, NAN, NAN, 0.5, 0.25, 3.1],      # left lost: right eye
                   [NAN] * 6,                            # both lost: dropped
                   [0.1, 0.9, 2.9, NAN, NAN, NAN]],      # right lost: left eye
                  [[576, 540], [960, 270], [192, 972]], 'nonfinite'),
    'tobii_stream_engine': ([[0.5, 0.5], [0.1, 0.2], [NAN, 0.3], [1.0, 1.0]],
                            [[960, 540], [192, 216], [1920, 1080]], 'nonfinite'),
    'pupil_capture': (_PUPIL.tolist(), [[480, 270], [192, 1080]], 'low_confidence'),
}


@pytest.mark.parametrize('profile', sorted(CASES))
def test_profile_samples_arrive_as_exact_screen_points(graph, profile):
    samples, expected, dropped_as = CASES[profile]
    outlet, info = make_outlet(profile)
    node, gaze = start_bridge(graph, **bridge_parameters(profile, info))
    connect(graph, outlet)
    outlet.push_chunk(samples)
    points = wait_for(graph, gaze, len(expected))
    # float32 apps (Tobii) quantise 0.3 etc.; the double Pupil relay is exact.
    np.testing.assert_allclose(points, expected, atol=1e-3)
    graph.spin_for(0.1)
    assert gaze.count == len(expected)
    assert node.counters[dropped_as] == 1
    assert node.counters['received'] == len(samples)


def test_invalid_samples_are_dropped_and_counted(graph):
    outlet, info = make_outlet('custom')   # x, y in screen px
    node, gaze = start_bridge(graph, **bridge_parameters('custom', info,
                                                         offscreen_margin_px=50.0))
    connect(graph, outlet)
    outlet.push_chunk([[10.0, 20.0],
                       [NAN, 5.0], [5.0, float('inf')],   # not finite
                       [-51.0, 100.0], [100.0, 1131.0],   # beyond the 50 px margin
                       [-50.0, 1130.0],                   # at the margin: kept
                       [30.0, 40.0]])
    points = wait_for(graph, gaze, 3)
    np.testing.assert_allclose(points, [[10, 20], [-50, 1130], [30, 40]])
    counters = node.counters
    assert (counters['nonfinite'], counters['offscreen'], counters['published']) == (2, 2, 3)


def push_seconds(outlet, points, rate=120.0):
    """Push screen points (N, 2) as one chunk stamped ``rate`` Hz back from now, LSL s."""
    stamps = pylsl.local_clock() - np.arange(len(points))[::-1] / rate
    outlet.push_chunk(np.asarray(points, float).tolist(), stamps.tolist())


def bridge_warnings(text):
    """Return the bridge's WARN lines in a log."""
    return [line for line in text.splitlines() if 'WARN' in line and 'lsl_gaze_bridge' in line]


def test_blinks_and_glances_away_are_counted_in_the_statistics_not_warned(graph, capfd):
    outlet, info = make_outlet('custom')   # x, y in screen px
    log = LogTap(capfd)
    node, gaze = start_bridge(graph, **bridge_parameters('custom', info, invalid_warn_s=1.0,
                                                         stats_period_s=0.5))
    connect(graph, outlet)
    # 6 s at 120 Hz: a person reading the screen, blinking (0.25 s of NaN) and glancing
    # away (0.75 s off the screen) again and again, never longer than invalid_warn_s.
    second = [[960.0, 540.0]] * 60 + [[NAN, NAN]] * 30 + [[960.0, 540.0]] * 60 \
        + [[4000.0, 540.0]] * 90
    for _ in range(3):
        push_seconds(outlet, second * 2)
    assert log.wait_for(graph, r'lsl_gaze_bridge.*gaze: \d+ received, \d+ published .*'
                               r'dropped since start: 180 nonfinite, 540 offscreen')
    assert gaze.count == 720
    assert bridge_warnings(log.read()) == []


def test_a_layout_yielding_only_invalid_samples_gets_one_warning_with_the_reason(
        graph, capfd):
    outlet, info = make_outlet('custom')   # x, y in screen px, read as normalized: off-screen
    log = LogTap(capfd)
    node, gaze = start_bridge(graph, **bridge_parameters('custom', info, units='normalized',
                                                         invalid_warn_s=1.0,
                                                         stats_period_s=0.5))
    connect(graph, outlet)
    for pushed in (240, 480, 720):
        push_seconds(outlet, [[960.0, 540.0]] * 240)
        assert graph.spin_until(lambda: node.counters['offscreen'] >= pushed, WAIT_S)
    assert log.wait_for(graph, r'lsl_gaze_bridge.*dropped since start: 720 offscreen')
    warnings = bridge_warnings(log.read())
    assert len(warnings) == 1, warnings
    assert 'no valid gaze sample since the stream started' in warnings[0]
    assert 'offscreen' in warnings[0] and 'units' in warnings[0]
    assert gaze.count == 0


def test_a_stream_without_the_channels_is_not_taken_until_the_parameters_fit(graph, capfd):
    outlet, info = make_outlet('custom')   # 2 channels
    log = LogTap(capfd)
    node, gaze = start_bridge(graph, **bridge_parameters('custom', info, x_channel='2',
                                                         y_channel='1'))
    assert log.wait_for(graph, r"lsl_gaze_bridge.*not taking .*does not fit profile 'custom': "
                               r'x_channel: channel index 2 is out of range')
    assert node.stream is None and not outlet.have_consumers()
    result, = graph.set_parameters('/lsl_gaze_bridge', {'x_channel': 'x'})
    assert result.successful, result.reason
    connect(graph, outlet)
    outlet.push_sample([5.0, 6.0])
    np.testing.assert_allclose(wait_for(graph, gaze, 1), [[5, 6]])


def test_wrong_layout_set_while_connected_is_counted_and_fixed(graph):
    outlet, info = make_outlet('custom')   # 2 channels
    node, gaze = start_bridge(graph, **bridge_parameters('custom', info))
    connect(graph, outlet)
    outlet.push_sample([1.0, 2.0])
    wait_for(graph, gaze, 1)
    result, = graph.set_parameters('/lsl_gaze_bridge', {'x_channel': '2'})
    assert result.successful, result.reason
    outlet.push_chunk([[1.0, 2.0], [3.0, 4.0]])
    assert graph.spin_until(lambda: node.counters['layout'] == 2, WAIT_S)
    assert gaze.count == 1
    result, = graph.set_parameters('/lsl_gaze_bridge', {'x_channel': 'x'})
    assert result.successful, result.reason
    outlet.push_sample([5.0, 6.0])
    np.testing.assert_allclose(wait_for(graph, gaze, 2)[1], [5, 6])


def test_stamps_are_sample_times_not_arrival_times(graph):
    outlet, info = make_outlet('custom')
    node, gaze = start_bridge(graph, **bridge_parameters('custom', info))
    connect(graph, outlet)
    pushed_at = ros_now_ns(graph)
    lsl_now = pylsl.local_clock()
    outlet.push_sample([1.0, 1.0], timestamp=lsl_now - 0.5)
    outlet.push_sample([2.0, 2.0], timestamp=lsl_now - 0.2)
    wait_for(graph, gaze, 2)
    ages = (pushed_at - stamps_ns(gaze)) / 1e9
    np.testing.assert_allclose(ages, [0.5, 0.2], atol=STAMP_TOLERANCE_NS / 1e9)


def test_restarted_outlet_with_same_identity_is_picked_up_again(graph):
    name, source_id = unique_id('restart'), unique_id('restart-source')
    outlet, _ = make_outlet('xy_pixels', name=name, source_id=source_id)
    node, gaze = start_bridge(graph, stream_name=name, source_id=source_id)
    connect(graph, outlet)
    outlet.push_sample([683.0, 384.0])
    wait_for(graph, gaze, 1)
    first_uid = node.stream_uid

    del outlet   # the application quits
    gc.collect()
    assert graph.spin_until(lambda: node.stream_uid is None, WAIT_S), 'loss not noticed'
    outlet, _ = make_outlet('xy_pixels', name=name, source_id=source_id)
    connect(graph, outlet)
    outlet.push_sample([0.0, 768.0])
    np.testing.assert_allclose(wait_for(graph, gaze, 2)[1], [0, 1080])
    assert node.stream_uid not in (None, first_uid)


def test_newest_of_two_outlets_of_one_source_is_used(graph):
    """Two streams of one source_id are one device (an application that restarted)."""
    name, source_id = unique_id('twin'), unique_id('twin-source')
    old, _ = make_outlet('xy_pixels', name=name, source_id=source_id)
    time.sleep(0.05)   # created_at has to differ
    new, new_info = make_outlet('xy_pixels', name=name, source_id=source_id)
    # Slow first look so the resolver has heard from both outlets; no switching on silence.
    node, gaze = start_bridge(graph, stream_name=name, resolve_period_s=1.0,
                              stale_timeout_s=60.0)
    connect(graph, new)
    old.push_sample([0.0, 0.0])
    new.push_sample([1366.0, 768.0])
    np.testing.assert_allclose(wait_for(graph, gaze, 1), [[1920, 1080]])
    # A sentinel on the new stream: the bridge forwards in order, so had it read the old
    # stream's sample, that would arrive before this one.
    new.push_sample([683.0, 384.0])
    assert graph.spin_until(lambda: np.allclose(gaze.samples()[1][-1], [960, 540]), WAIT_S)
    np.testing.assert_allclose(gaze.samples()[1], [[1920, 1080], [960, 540]])
    assert not old.have_consumers()
    assert node.stream_uid == new_info.uid()


def test_parameter_changes_apply_at_run_time_and_reselect_the_stream(graph):
    first, first_info = make_outlet('xy_pixels')
    second, second_info = make_outlet('xy_pixels')
    node, gaze = start_bridge(graph, stream_name='*', source_id=first_info.source_id())
    connect(graph, first)
    results = graph.set_parameters('/lsl_gaze_bridge', {'screen_width': 1366,
                                                        'screen_height': 768})
    assert all(result.successful for result in results)
    first.push_sample([100.0, 700.0])
    np.testing.assert_allclose(wait_for(graph, gaze, 1), [[100, 700]])   # 1:1 now

    result, = graph.set_parameters('/lsl_gaze_bridge', {'source_id': second_info.source_id()})
    assert result.successful, result.reason
    connect(graph, second)
    assert node.stream_uid == second_info.uid()
    second.push_sample([200.0, 300.0])
    np.testing.assert_allclose(wait_for(graph, gaze, 2)[1], [200, 300])


def test_quiet_stream_is_reported_and_resumes(graph):
    outlet, info = make_outlet('custom')
    node, gaze = start_bridge(graph, **bridge_parameters(
        'custom', info, stale_timeout_s=0.3, resolve_period_s=0.1))
    connect(graph, outlet)
    outlet.push_sample([1.0, 2.0])
    wait_for(graph, gaze, 1)
    assert graph.spin_until(lambda: node.stale, WAIT_S), 'quiet stream not reported'
    outlet.push_sample([3.0, 4.0])
    np.testing.assert_allclose(wait_for(graph, gaze, 2)[1], [3, 4])
    assert not node.stale
    assert node.stream_uid == info.uid()


def test_quiet_stream_is_kept_while_advertised_and_replaced_once_gone(graph, capfd):
    name = unique_id('hung')
    hung, hung_info = make_outlet('custom', name=name)
    node, gaze = start_bridge(graph, profile='custom', stream_name=name, stale_timeout_s=0.3,
                              resolve_period_s=0.1)
    log = LogTap(capfd)
    connect(graph, hung)
    replacement, replacement_info = make_outlet('custom', name=name)
    # The bridge has seen the newer stream and says so, but stays with the quiet one.
    assert log.wait_for(graph, f'lsl_gaze_bridge.*another LSL stream .*{replacement_info.uid()}')
    assert graph.spin_until(lambda: node.stale, WAIT_S), 'quiet stream not reported'
    assert node.stream_uid == hung_info.uid() and not replacement.have_consumers()
    # The application restarts: its old outlet goes away, the new one is picked up.
    gone = log.mark()
    del hung
    gc.collect()
    connect(graph, replacement)
    assert node.stream_uid == replacement_info.uid()
    # Only now: the bridge logs each stream it connects to, in order; a switch while the
    # quiet stream was still advertised would be logged before its outlet went.
    connected = f"connected to gaze LSL stream '{name}'"
    assert log.read()[:gone].count(connected) == 1
    assert log.wait_for(graph, connected, gone)
    replacement.push_sample([7.0, 8.0])
    np.testing.assert_allclose(wait_for(graph, gaze, 1), [[7, 8]])


def test_a_burst_arrives_whole_in_batches_with_acquisition_stamps(graph):
    outlet, info = make_outlet('custom', rate=1200.0)
    node, gaze = start_bridge(graph, **bridge_parameters('custom', info), max_chunk=500)
    connect(graph, outlet)
    outlet.push_sample([1.0, 1.0])
    wait_for(graph, gaze, 1)   # clock offset known: samples are published as they come

    points = np.random.default_rng(3).uniform([0, 0], [1920, 1080], (3000, 2))
    stamps = pylsl.local_clock() - 3.0 + np.arange(3000) / 1200.0
    first_message = len(gaze.messages)
    outlet.push_chunk(points.tolist(), stamps.tolist())
    received = wait_for(graph, gaze, 3001)[1:]
    np.testing.assert_allclose(received, points, atol=1e-3)   # float32 stream
    # One message per pulled chunk of at most max_chunk samples.
    widths = [message.width for message in gaze.messages[first_message:]]
    assert sum(widths) == 3000 and max(widths) <= 500
    # Published at once, stamped when they were taken.
    offsets = stamps_ns(gaze)[1:] * 1e-9
    np.testing.assert_allclose(np.diff(offsets), 1 / 1200.0, atol=1e-4)
    age_s = ros_now_ns(graph) * 1e-9 - offsets[0]
    assert age_s > 3.0


def test_gaze_point_shows_the_newest_sample_at_most_point_rate_hz(graph):
    outlet, info = make_outlet('custom', rate=1200.0)
    node, gaze = start_bridge(graph, **bridge_parameters('custom', info), point_rate_hz=20.0)
    view = Collector(graph.node('cursor'), PointStamped, GAZE_POINT_TOPIC, VIEW_QOS)
    connect(graph, outlet)
    outlet.push_sample([1.0, 1.0])
    wait_for(graph, gaze, 1)
    start = time.monotonic()
    for k in range(600):   # 0.5 s of a 1200 Hz tracker, pushed in real time
        outlet.push_sample([100.0 + k, 200.0])
        graph.spin_for(1 / 1200.0)
    wait_for(graph, gaze, 601)
    elapsed = time.monotonic() - start
    graph.spin_for(0.1)
    # Every sample on gaze/samples, a few on gaze/point, each a real sample in px.
    assert 2 <= len(view.messages) <= 20.0 * elapsed + 2
    sent = set(100.0 + np.arange(600)) | {1.0}
    for message in view.messages:
        assert message.header.frame_id == 'screen' and message.point.z == 0.0
        assert message.point.x in sent
    result, = graph.set_parameters('/lsl_gaze_bridge', {'point_rate_hz': 0.0})
    assert result.successful, result.reason
    count = len(view.messages)
    outlet.push_sample([5.0, 5.0])
    wait_for(graph, gaze, 602)
    graph.spin_for(0.1)
    assert len(view.messages) == count


def test_bad_parameter_values_are_rejected_with_a_reason(graph):
    start_bridge(graph, source_id=unique_id('nothing'))
    name = '/lsl_gaze_bridge'
    result, = graph.set_parameters(name, {'profile': 'eyelink'})
    assert not result.successful and 'eyelink' in result.reason
    result, = graph.set_parameters(name, {'screen_width': 0})
    assert not result.successful and 'screen_width' in result.reason
    result, = graph.set_parameters(name, {'x_channel': 'left_x,right_x'})
    assert not result.successful and 'x_channel lists 2' in result.reason
    result, = graph.set_parameters(name, {'units': 'inches'})
    assert not result.successful and 'inches' in result.reason
    assert graph.get_parameters(name, ['profile', 'screen_width', 'x_channel', 'units']) == \
        ['xy_pixels', 1920, '', '']


def test_sample_for_outlets_reach_the_screen_point(graph):
    """The shared test outlets (lsl_outlets) encode screen points as the bridge decodes them."""
    outlet, info = make_outlet('tobii_pro')
    node, gaze = start_bridge(graph, **bridge_parameters('tobii_pro', info))
    connect(graph, outlet)
    points = [[960.0, 540.0], [100.0, 1000.0], [1800.0, 30.0]]
    outlet.push_chunk(sample_for('tobii_pro', points, eye_offset_px=(20.0, 10.0)).tolist())
    outlet.push_sample(sample_for('tobii_pro', [500.0, 600.0], lost_eye='left').tolist())
    np.testing.assert_allclose(wait_for(graph, gaze, 4), points + [[500, 600]], atol=1e-3)


def test_gaze_coming_back_after_a_long_look_away_is_published_and_logged(graph, capfd):
    # Issue 39: the warning and the "valid gaze again" line came from one call site at two
    # severities; rclpy refuses that ("Logger severity cannot be changed between calls"),
    # and the chunk that brought valid gaze back was lost.
    outlet, info = make_outlet('custom')   # x, y in screen px
    log = LogTap(capfd)
    node, gaze = start_bridge(graph, **bridge_parameters('custom', info, invalid_warn_s=0.5))
    connect(graph, outlet)
    push_seconds(outlet, [[960.0, 540.0]] * 60)             # looking at the screen
    wait_for(graph, gaze, 60)
    for back_at, point in ((60, [100.0, 200.0]), (108, [300.0, 400.0])):
        away = log.mark()
        push_seconds(outlet, [[NAN, NAN]] * 120)            # 1 s away: longer than 0.5 s
        assert log.wait_for(graph, r'WARN.*lsl_gaze_bridge.*no valid gaze for', away), \
            log.since(away)
        push_seconds(outlet, [[NAN, NAN]] * 12 + [point] * 48)   # and back
        points = wait_for(graph, gaze, back_at + 48)
        np.testing.assert_allclose(points[back_at:], [point] * 48)
        assert log.wait_for(graph, r'INFO.*lsl_gaze_bridge.*valid gaze again after', away), \
            log.since(away)
    assert 'failed to publish gaze' not in log.read()
    assert node.counters['published'] == 156
