"""
Parameters take what a person types, through ``ros2 param set`` and ``--ros-args -p``.

YAML makes ``1`` an INTEGER and ``[10, -2, 17]`` an INTEGER_ARRAY; ``ros2 param
set NODE p "[]"`` sends an empty BOOL_ARRAY.  Each set below goes through the
parameter services (what ``ros2 param set`` calls), each start-up value
through a real rcl command line or ``parameter_overrides``; the values read
back over the services must have the declared type, and what is still wrong
must still be refused with a reason.
"""

from contextlib import contextmanager

from domain_coordinator import domain_id
from geometry_msgs.msg import PoseStamped
from lsl_outlets import unique_id
import numpy as np
import pytest
from rcl_interfaces.msg import ParameterType, SetParametersResult
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter
from ros_harness import Collector
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.nodes.camera_tracker import CameraTracker
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.ros.conversions import arrays_to_pose, marker_array_to_regions
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec, quote_param_rules
from eye_bci_ros2.ros.topics import LATCHED_QOS

pytestmark = pytest.mark.ros


def set_one(graph, node, name, value):
    """Set one parameter over the services; return (result, value read back)."""
    result, = graph.set_parameters(node, {name: value})
    value, = graph.get_parameters(node, [name])
    return result, value


def declared_type(node_object, name):
    """Return the type the node advertises for ``name`` (``ros2 param describe``)."""
    return node_object.describe_parameter(name).type


def test_integer_for_a_double_is_taken_as_that_double(graph):
    arbiter = graph.add(ChoiceArbiter)
    result, value = set_one(graph, '/choice_arbiter', 'window_s', Parameter('window_s', value=2))
    assert result.successful, result.reason
    assert value == 2.0 and isinstance(value, float)
    assert declared_type(arbiter, 'window_s') == ParameterType.PARAMETER_DOUBLE


def test_integer_for_a_double_is_still_range_checked_and_validated(graph):
    graph.add(ChoiceArbiter)
    result, value = set_one(graph, '/choice_arbiter', 'window_s', 100)
    assert not result.successful and 'out of range' in result.reason
    result, value = set_one(graph, '/choice_arbiter', 'window_s', 0)
    assert not result.successful and 'window_s' in result.reason
    assert value == 1.0
    result, value = set_one(graph, '/choice_arbiter', 'window_s', 'one')
    assert not result.successful and 'type' in result.reason
    result, value = set_one(graph, '/choice_arbiter', 'window_s', True)
    assert not result.successful and value == 1.0


class Projector:
    """A marker_projector with one 2 m cube under a camera looking straight down."""

    def __init__(self, graph, **overrides):
        self.graph = graph
        self.node = graph.add(MarkerProjector, parameter_overrides=[
            Parameter(name, value=value) for name, value in overrides.items()])
        helper = graph.node('typing_test')
        self.regions = Collector(helper, MarkerArray, 'choices/regions', LATCHED_QOS)
        choices = helper.create_publisher(MarkerArray, 'choices', LATCHED_QOS)
        camera = helper.create_publisher(PoseStamped, 'camera/pose', LATCHED_QOS)
        marker = Marker(ns='t', id=0, type=Marker.CUBE, action=Marker.ADD, text='box')
        marker.header.frame_id = 'map'
        marker.pose = arrays_to_pose([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])
        marker.scale.x, marker.scale.y, marker.scale.z = 2.0, 2.0, 0.01
        choices.publish(MarkerArray(markers=[marker]))
        pose = PoseStamped()
        pose.header.frame_id = 'map'
        pose.pose = arrays_to_pose(*look_at_pose([0, 0, 10.0], [0, 0, 0.0], [0, 1.0, 0]))
        camera.publish(pose)
        assert graph.spin_until(lambda: self.regions.messages, 10.0), 'no regions'

    def corner(self):
        """Return the region's smallest (x, y) corner, screen px."""
        _, polygons = marker_array_to_regions(self.regions.last)
        return polygons[0].min(axis=0)

    def change(self, name, value):
        """Set a parameter and wait for the regions it causes; return the result."""
        before = len(self.regions.messages)
        result, = self.graph.set_parameters('/marker_projector', {name: value})
        if result.successful:
            assert self.graph.spin_until(lambda: len(self.regions.messages) > before, 10.0)
        return result


def test_screen_offsets_take_whole_and_half_pixels_and_shift_regions_by_them(graph):
    projector = Projector(graph, screen_offset_x=0, screen_offset_y=0)
    origin = projector.corner()
    assert projector.change('screen_offset_x', 64).successful
    assert projector.change('screen_offset_y', 64.5).successful
    assert projector.corner() - origin == pytest.approx([64.0, 64.5], abs=1e-9)
    assert graph.get_parameters('/marker_projector', ['screen_offset_x', 'screen_offset_y']) \
        == [64.0, 64.5]
    assert not projector.change('screen_offset_y', 'top').successful
    assert not projector.change('screen_offset_y', 20000).successful
    assert projector.corner() - origin == pytest.approx([64.0, 64.5], abs=1e-9)


def test_integer_array_for_a_double_array_and_empty_list_for_any_array(graph):
    tracker = graph.add(CameraTracker)
    result, value = set_one(graph, '/camera_tracker', 'eye', [1, -9, 11])
    assert result.successful, result.reason
    assert value == [1.0, -9.0, 11.0] and all(isinstance(v, float) for v in value)
    assert declared_type(tracker, 'eye') == ParameterType.PARAMETER_DOUBLE_ARRAY
    result, _ = set_one(graph, '/camera_tracker', 'eye', [1, 2])
    assert not result.successful and 'eye' in result.reason
    projector = graph.add(MarkerProjector)
    result, = graph.set_parameters('/marker_projector', {
        'intrinsic_matrix': [869, 0, 640, 0, 0, 869, 360, 0, 0, 0, 1, 0]})
    assert result.successful, result.reason
    assert projector.camera.intrinsic[0, 0] == 869.0
    # `ros2 param set /marker_projector intrinsic_matrix "[]"` sends an empty BOOL_ARRAY.
    result, value = set_one(graph, '/marker_projector', 'intrinsic_matrix',
                            Parameter('intrinsic_matrix', Parameter.Type.BOOL_ARRAY, []))
    assert result.successful, result.reason
    assert value == []
    assert projector.camera.intrinsic[0, 0] == pytest.approx(360.0 / np.tan(np.radians(22.5)))


def test_channel_index_and_numeric_names_as_integers(graph):
    graph.add(LslGazeBridge, parameter_overrides=[
        Parameter('source_id', value=unique_id('no-such-tracker'))])
    result, value = set_one(graph, '/lsl_gaze_bridge', 'x_channel', 0)
    assert result.successful, result.reason
    assert value == '0'
    result, value = set_one(graph, '/lsl_gaze_bridge', 'y_channel', 1)
    assert result.successful and value == '1'
    result, value = set_one(graph, '/lsl_gaze_bridge', 'source_id', 30109306184)
    assert result.successful and value == '30109306184'
    # Still refused: a fractional index, a number for a choice, a frame that is a number.
    result, value = set_one(graph, '/lsl_gaze_bridge', 'x_channel', 0.5)
    assert not result.successful and value == '0'
    result, value = set_one(graph, '/lsl_gaze_bridge', 'units', 1)
    assert not result.successful and value == ''
    graph.add(CameraTracker)
    result, value = set_one(graph, '/camera_tracker', 'world_frame', 42)
    assert not result.successful and value == 'map'


@contextmanager
def node_from_command_line(node_class, *rules):
    """Start ``node_class`` on a context initialised from ``--ros-args -p rule ...``."""
    args = ['exe', '--ros-args']
    for rule in rules:
        args += ['-p', rule]
    with domain_id() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain, args=quote_param_rules(args))
        node = None
        try:
            node = node_class(context=context)
            yield node
        finally:
            if node is not None:
                node.destroy_node()
            context.try_shutdown()


def test_command_line_overrides_get_the_same_conversions():
    with node_from_command_line(ChoiceArbiter, 'window_s:=1') as arbiter:
        value = arbiter.get_parameter('window_s').value
        assert value == 1.0 and isinstance(value, float)
    with node_from_command_line(MarkerProjector, 'screen_offset_x:=64',
                                'screen_offset_y:=64.5', 'intrinsic_matrix:=[]') as projector:
        assert projector.camera.screen_offset.tolist() == [64.0, 64.5]
        assert projector.get_parameter('screen_offset_x').type_ == Parameter.Type.DOUBLE
    with node_from_command_line(CameraTracker, 'eye:=[1, -9, 11]') as tracker:
        assert list(tracker.get_parameter('eye').value) == [1.0, -9.0, 11.0]
    with node_from_command_line(LslGazeBridge, 'x_channel:=0', 'y_channel:=1',
                                'stream_name:=*', f"source_id:={unique_id('cli')}") as bridge:
        assert bridge.get_parameter('x_channel').value == '0'
        assert bridge.get_parameter('stream_name').value == '*'


def test_parameter_overrides_argument_gets_the_same_conversions(graph):
    arbiter = graph.add(ChoiceArbiter, parameter_overrides=[Parameter('window_s', value=2)])
    assert graph.get_parameters('/choice_arbiter', ['window_s']) == [2.0]
    assert arbiter.get_parameter('window_s').type_ == Parameter.Type.DOUBLE


@pytest.mark.parametrize('rule, reason', [
    ('image_width:=abc', "image_width: expected an integer, got a text (string) 'abc'"),
    ('screen_offset_x:=true', 'screen_offset_x: expected a number, got true or false True'),
    ('image_width:=1280.5', 'image_width: expected an integer, got a number 1280.5'),
])
def test_command_line_overrides_of_a_wrong_type_are_refused_with_a_reason(rule, reason):
    with pytest.raises(ValueError, match='invalid parameter override') as raised:
        with node_from_command_line(MarkerProjector, rule):
            pass
    assert reason in str(raised.value)


def test_out_of_range_integer_override_for_a_double_is_refused():
    with pytest.raises(Exception, match='window_s'):
        with node_from_command_line(ChoiceArbiter, 'window_s:=100'):
            pass


@pytest.mark.parametrize('typed, sent', [
    (['-p', 'stream_name:=*'], ['-p', "stream_name:='*'"]),
    (['--param', 'lsl_gaze_bridge:stream_type:=*'],
     ['--param', "lsl_gaze_bridge:stream_type:='*'"]),
    (['-p', "n:=*it's"], ['-p', "n:='*it''s'"]),
    (['-p', 'n:=0'], ['-p', 'n:=0']),
    (['-p', "n:='*'"], ['-p', "n:='*'"]),
    (['-p', 'n:=[1, 2]'], ['-p', 'n:=[1, 2]']),
    (['-r', '__node:=*x'], ['-r', '__node:=*x']),
])
def test_quote_param_rules_quotes_only_values_rcl_cannot_read(typed, sent):
    assert quote_param_rules(['exe', '--ros-args'] + typed) == ['exe', '--ros-args'] + sent
    # Outside --ros-args nothing is a parameter rule.
    assert quote_param_rules(['exe'] + typed) == ['exe'] + typed


class TwoTables(Node):
    """A node that declares two ParamSpec tables (as a node with an optional part may)."""

    def __init__(self, **kwargs):
        super().__init__('two_tables', **kwargs)
        self.changes = []
        declare_parameters(self, [ParamSpec('gain', 1.0, 'a double', value_range=(0.0, 10.0))],
                           self.changes.append)
        declare_parameters(self, [ParamSpec('channel', '', 'a channel', integer_as_text=True)],
                           self.changes.append)
        self.seen = []
        self.add_on_set_parameters_callback(self._record)

    def _record(self, parameters):
        self.seen.append([(p.name, p.value) for p in parameters])
        return SetParametersResult(successful=True)


def test_two_tables_on_one_node_convert_each_set_once(graph):
    node = graph.add(TwoTables, parameter_overrides=[Parameter('gain', value=2)])
    assert node.get_parameter('gain').value == 2.0
    result, value = set_one(graph, '/two_tables', 'gain', 3)
    assert result.successful and value == 3.0
    result, value = set_one(graph, '/two_tables', 'channel', 4)
    assert result.successful and value == '4'
    # Each set reached the node once, converted (not once per table).
    assert node.seen == [[('gain', 3.0)], [('channel', '4')]]
    assert node.changes == [{'gain': 3.0}, {'channel': '4'}]
