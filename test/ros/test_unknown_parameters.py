"""A parameter name that no node declares is named, with the name that was probably meant."""

import pytest
from rclpy.parameter import Parameter

from eye_bci_ros2.nodes.camera_tracker import CameraTracker
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.ros.parameters import unknown_overrides

pytestmark = pytest.mark.ros


def test_a_mistyped_override_is_named_with_the_closest_declared_name(graph):
    node = graph.add(MarkerProjector, parameter_overrides=[
        Parameter('screen_ofset_x', value=64.0), Parameter('image_width', value=800),
        Parameter('zzz', value=1)])
    found = unknown_overrides([node])
    assert sorted(found) == ['screen_ofset_x', 'zzz']
    assert "did you mean 'screen_offset_x'?" in found['screen_ofset_x']
    assert 'ros2 param list' in found['zzz']          # nothing close: where to look
    assert node.get_parameter('image_width').value == 800


def test_in_one_process_a_name_any_node_declares_is_known(graph):
    # eye_bci gives every node the same command line: rviz_config is camera_tracker's and the
    # projector's, screen_offset_x only the projector's; neither is a mistake.
    overrides = [Parameter('screen_offset_x', value=64.0), Parameter('pose_convention',
                                                                     value='ogre')]
    nodes = [graph.add(CameraTracker, parameter_overrides=overrides),
             graph.add(MarkerProjector, parameter_overrides=overrides)]
    assert unknown_overrides(nodes) == {}
    assert 'pose_convention' in unknown_overrides(nodes[1:])


def test_the_dump_of_a_node_with_an_empty_array_names_every_parameter(graph):
    graph.add(MarkerProjector)
    names = ['intrinsic_matrix', 'screen_offset_x']
    values = graph.get_parameters('marker_projector', names)
    # A parameter left "not set" made GetParameters return nothing at all (an empty dump).
    assert len(values) == 2


def test_another_nodes_parameter_is_named_as_that_nodes(graph):
    # Issue 39: on the bridge, -p screen_ofset_x:=64 suggested 'screen_height'.
    node = graph.add(LslGazeBridge, parameter_overrides=[
        Parameter('screen_ofset_x', value=64.0), Parameter('rviz_config', value='')])
    found = unknown_overrides([node])
    assert found['screen_ofset_x'] == (
        "unknown parameter 'screen_ofset_x' ignored: did you mean 'screen_offset_x'? That is "
        'a parameter of marker_projector and gaze_validation, not of this node')
    assert 'it is a parameter of camera_tracker and marker_projector' in found['rviz_config']


def test_the_answer_to_param_set_of_an_unknown_name_carries_the_hint(graph):
    # What ros2 param set prints: the set-parameters service's result reason.
    graph.add(MarkerProjector)
    result, = graph.set_parameters('marker_projector', {'screen_ofset_x': 64.0})
    assert not result.successful
    assert result.reason == ("unknown parameter 'screen_ofset_x' ignored: did you mean "
                             "'screen_offset_x'?")
    result, = graph.set_parameters('marker_projector', {'profile': 'tobii_pro'})
    assert result.reason == ("unknown parameter 'profile' ignored: it is a parameter of "
                             'lsl_gaze_bridge, not of this node')
    result, = graph.set_parameters('marker_projector', {'screen_offset_x': 64.0})
    assert result.successful
