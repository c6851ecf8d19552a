"""The bridge's gaze_correction (parameter service, params file) and gaze/on_screen (real LSL)."""

from lsl_outlets import bridge_parameters, make_outlet
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector, GazeCollector
from std_msgs.msg import Bool

from eye_bci_ros2.gaze.validation import correction_values, IDENTITY, save_correction
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.ros.topics import GAZE_ON_SCREEN_TOPIC, LATCHED_QOS

pytestmark = [pytest.mark.ros, pytest.mark.lsl]

NAN = float('nan')
WAIT_S = 10.0
#: A plausible correction: 1 % scale, a shift of (-20, 12) px.
SHIFT = [1.01, 0.0, -20.0, 0.0, 1.01, 12.0]
#: A plausible second-order one: x + 1e-5 x^2, y - 1e-5 y^2 (at most 37 px, at the right edge).
BEND = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1e-5, 0.0, 0.0, 0.0, 0.0, -1e-5]


def start(graph, outlet_profile='custom', cli_args=None, **params):
    """Start an outlet and a bridge reading it; return (outlet, bridge, gaze collector)."""
    outlet, info = make_outlet(outlet_profile)
    bridge = graph.add(LslGazeBridge, cli_args=cli_args, parameter_overrides=[
        Parameter(name, value=value)
        for name, value in bridge_parameters(outlet_profile, info, **params).items()])
    gaze = GazeCollector(graph.node('gaze_listener'))
    assert graph.spin_until(outlet.have_consumers, WAIT_S), 'bridge never connected'
    return outlet, bridge, gaze


def push_and_wait(graph, outlet, gaze, points):
    """Push screen points (custom profile: screen px) and return what the bridge published."""
    first = gaze.count
    outlet.push_chunk([list(map(float, p)) for p in points])
    assert graph.spin_until(lambda: gaze.count >= first + len(points), WAIT_S), \
        f'expected {len(points)} samples, got {gaze.count - first}'
    return gaze.samples(first)[1]


def test_a_correction_set_through_the_parameter_service_applies_to_the_next_samples(graph):
    outlet, bridge, gaze = start(graph)
    assert bridge.correction is None
    np.testing.assert_allclose(push_and_wait(graph, outlet, gaze, [[100, 200]]), [[100, 200]])

    result, = graph.set_parameters('/lsl_gaze_bridge', {'gaze_correction': SHIFT})
    assert result.successful, result.reason
    points = push_and_wait(graph, outlet, gaze, [[100, 200], [960, 540]])
    np.testing.assert_allclose(points, [[81, 214], [949.6, 557.4]], atol=1e-3)
    assert graph.get_parameters('/lsl_gaze_bridge', ['gaze_correction']) == [SHIFT]

    # What `ros2 param set /lsl_gaze_bridge gaze_correction "[1, 0, 0, 0, 1, 0]"` sends: integers.
    result, = graph.set_parameters('/lsl_gaze_bridge', {'gaze_correction': [1, 0, 0, 0, 1, 0]})
    assert result.successful, result.reason
    assert bridge.correction is None
    np.testing.assert_allclose(push_and_wait(graph, outlet, gaze, [[100, 200]]), [[100, 200]])


def test_a_second_order_correction_is_set_applied_and_read_back_as_12_numbers(
        graph, tmp_path):
    outlet, bridge, gaze = start(graph)
    result, = graph.set_parameters('/lsl_gaze_bridge', {'gaze_correction': BEND})
    assert result.successful, result.reason
    np.testing.assert_allclose(push_and_wait(graph, outlet, gaze, [[100, 200], [960, 540]]),
                               [[100.1, 199.6], [969.216, 537.084]], atol=1e-3)
    # What `ros2 param get` / `ros2 param dump` read, and a saved file read by --params-file.
    assert graph.get_parameters('/lsl_gaze_bridge', ['gaze_correction']) == [BEND]
    path = save_correction(str(tmp_path / 'bend.yaml'), BEND)
    outlet, bridge, gaze = start(graph, cli_args=['--ros-args', '--params-file', path])
    assert correction_values(bridge.correction) == BEND


@pytest.mark.parametrize('value, reason', [
    ([2.0, 0.0, 0.0, 0.0, 2.0, 0.0], 'scales the gaze'),
    ([1.0, 0.0, 600.0, 0.0, 1.0, 0.0], 'moves the gaze'),
    ([-1.0, 0.0, 1920.0, 0.0, 1.0, 0.0], 'mirrors'),
    ([1.0, 0.0, 0.0], '6 finite numbers'),
    ([1.0, 0.0, NAN, 0.0, 1.0, 0.0], '6 finite numbers'),
    (SHIFT + [0.0, 0.0], 'or 12'),
    # Turns back at x = 833 px: folds the right of the screen onto the middle.
    (SHIFT + [-6e-4, 0.0, 0.0, 0.0, 0.0, 0.0], 'mirrors'),
])
def test_an_implausible_or_malformed_correction_is_refused_and_the_old_one_kept(
        graph, value, reason):
    outlet, bridge, gaze = start(graph, gaze_correction=SHIFT)
    result, = graph.set_parameters('/lsl_gaze_bridge', {'gaze_correction': value})
    assert not result.successful
    assert reason in result.reason and 'gaze_correction' in result.reason
    assert '\n' not in result.reason
    np.testing.assert_allclose(correction_values(bridge.correction), SHIFT)
    np.testing.assert_allclose(push_and_wait(graph, outlet, gaze, [[100, 200]]), [[81, 214]],
                               atol=1e-3)


def test_a_saved_correction_file_is_read_by_params_file(graph, tmp_path):
    path = save_correction(str(tmp_path / 'correction.yaml'), SHIFT)
    # The rcl path of `--ros-args --params-file correction.yaml`.
    outlet, bridge, gaze = start(graph, cli_args=['--ros-args', '--params-file', path])
    np.testing.assert_allclose(correction_values(bridge.correction), SHIFT)
    np.testing.assert_allclose(push_and_wait(graph, outlet, gaze, [[100, 200]]), [[81, 214]],
                               atol=1e-3)


def test_the_correction_comes_before_the_off_screen_check(graph):
    # -130 px is beyond the 100 px margin; corrected by +40 px it is -90: kept.
    outlet, bridge, gaze = start(graph, gaze_correction=[1.0, 0.0, 40.0, 0.0, 1.0, 0.0])
    np.testing.assert_allclose(push_and_wait(graph, outlet, gaze, [[-130, 500]]), [[-90, 500]])


def test_on_screen_is_published_on_change_for_nan_off_screen_and_stale(graph):
    outlet, bridge, gaze = start(graph, stale_timeout_s=0.4, resolve_period_s=0.1)
    flags = Collector(graph.node('on_screen_listener'), Bool, GAZE_ON_SCREEN_TOPIC, LATCHED_QOS)

    def states():
        return [message.data for message in flags.messages]

    def push_until(points, expected):
        outlet.push_chunk([list(map(float, p)) for p in points])
        assert graph.spin_until(lambda: states() == expected, WAIT_S), states()

    push_until([[100, 100]] * 5, [True])                        # start of the stream
    push_until([[200, 100]] * 5, [True])                        # unchanged: nothing new
    push_until([[200, 100], [NAN, NAN]], [True, False])         # lost the eyes: NaN
    push_until([[300, 300]], [True, False, True])
    push_until([[300, 300], [2500, 300]], [True, False, True, False])   # beyond the margin
    push_until([[-50, 1130]], [True, False, True, False, True])         # within the margin
    # Nothing for stale_timeout_s: false, once.
    assert graph.spin_until(lambda: bridge.stale, WAIT_S)
    assert graph.spin_until(lambda: states()[-1] is False, WAIT_S), states()
    graph.spin_for(0.5)
    assert states() == [True, False, True, False, True, False]
    push_until([[500, 500]], [True, False, True, False, True, False, True])   # resumed

    # Latched: a late joiner gets the current state at once.
    late = Collector(graph.node('late_listener'), Bool, GAZE_ON_SCREEN_TOPIC, LATCHED_QOS)
    assert graph.spin_until(lambda: late.messages, WAIT_S)
    assert [m.data for m in late.messages] == [True]


def test_a_lost_stream_says_off_screen(graph):
    outlet, bridge, gaze = start(graph)
    flags = Collector(graph.node('on_screen_listener'), Bool, GAZE_ON_SCREEN_TOPIC, LATCHED_QOS)
    outlet.push_chunk([[100.0, 100.0]])
    assert graph.spin_until(lambda: [m.data for m in flags.messages] == [True], WAIT_S)
    del outlet
    assert graph.spin_until(lambda: [m.data for m in flags.messages] == [True, False], WAIT_S)
    assert bridge.stream is None


def test_identity_is_the_default(graph):
    outlet, bridge, gaze = start(graph)
    assert graph.get_parameters('/lsl_gaze_bridge', ['gaze_correction']) == [list(IDENTITY)]
