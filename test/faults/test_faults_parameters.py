"""
Every parameter of every executable, set to a wrong type, out of range and inconsistent values.

The nodes are those of the registry (:func:`eye_bci_ros2.ros.registry.parameter_nodes`:
every executable that runs a node with parameters), so a node added there is
covered here, and must say here which good change it accepts afterwards
(``GOOD_CHANGE``).  A node whose creation needs what this machine lacks (a
display, a message package built apart) is skipped with the reason.  The
parameters are enumerated from the running node (``node._parameters`` and
its descriptors), so a parameter added later is covered without editing this
file: each gets two wrong-type values for its declared type, values just
outside its declared range, NaN and infinities when it holds doubles, and an
unknown choice when its description lists choices.  Values that only a
node's own rules reject (inconsistent views, malformed matrices, frames,
channel lists, scene files) are listed per node below.

Every set goes through the parameter services, as ``ros2 param set`` does;
each must be refused with a reason, leave the old value in place (read back
over the services), and leave the node answering and accepting a good
change.  Custom rejections must also be logged by the node.
"""

import importlib
import math
import re
from typing import Any, Dict, List, Tuple

from fault_rig import LogTap
from lsl_outlets import unique_id
import numpy as np
import pytest
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import Parameter

from eye_bci_ros2.ros.registry import DISPLAY, missing, parameter_nodes

pytestmark = pytest.mark.ros

NAN, INF = math.nan, math.inf

#: Two values of another type for each declared parameter type.
WRONG_TYPES = {
    ParameterType.PARAMETER_BOOL: ['yes', 1],
    ParameterType.PARAMETER_INTEGER: ['ten', 2.5],
    ParameterType.PARAMETER_DOUBLE: ['fast', True],
    ParameterType.PARAMETER_STRING: [42, [1.0, 2.0]],
    ParameterType.PARAMETER_BYTE_ARRAY: ['bytes', 3],
    ParameterType.PARAMETER_BOOL_ARRAY: [['yes', 'no'], True],
    ParameterType.PARAMETER_INTEGER_ARRAY: [['one', 'two'], 7],
    ParameterType.PARAMETER_DOUBLE_ARRAY: [['a', 'b', 'c'], 3.0],
    ParameterType.PARAMETER_STRING_ARRAY: [[1, 2], 'single'],
}

#: Wrong-type values that are what a person types and mean the declared type, so
#: they are accepted (see eye_bci_ros2.ros.parameters and test_param_typing.py):
#: an integer for a string parameter that holds a channel index or a stream
#: name/type/id (``-p x_channel:=0``).  Integers for doubles are not in
#: WRONG_TYPES; every other wrong type above is still refused.
TYPED_AS_TEXT = {
    'lsl_gaze_bridge': {'stream_type', 'stream_name', 'source_id', 'x_channel', 'y_channel',
                        'confidence_channel'},
}

#: Reasons rclpy itself gives (type, range, read-only checks); the node need not log these.
RCLPY_REASONS = re.compile(r'Wrong parameter type|out of range|read-only|read only', re.I)


def _bad_scene(tmp_path) -> str:
    path = tmp_path / 'broken_scene.yaml'
    path.write_text('frame_id: map\nrooms: [{name: hall, marker: {position: [0, 0\n')
    return str(path)


def _matrix(fx=869.0, fy=869.0, w=1.0) -> List[float]:
    """Return a row-major 3x4 intrinsic as 12 doubles."""
    return [fx, 0.0, 640.0, 0.0, 0.0, fy, 360.0, 0.0, 0.0, 0.0, w, 0.0]


#: Values only the node's own rules reject: (value or callable(node, tmp_path), kind).
SPECIFIC = {
    'camera_tracker': {
        'world_frame': [('', 'empty frame'), ('/map', 'leading slash')],
        'eye': [([1.0, 2.0], '2 numbers'), ([1.0, 2.0, 3.0, 4.0], '4 numbers'),
                (lambda node, _: np.asarray(node.get_parameter('focus').value).tolist(),
                 'inconsistent: eye == focus')],
        'focus': [(lambda node, _: np.asarray(node.get_parameter('eye').value).tolist(),
                   'inconsistent: focus == eye')],
        'up': [([0.0, 0.0, 0.0], 'zero vector'),
               (lambda node, _: (np.subtract(node.get_parameter('focus').value,
                                             node.get_parameter('eye').value)).tolist(),
                'inconsistent: up along the view')],
    },
    'marker_projector': {
        'world_frame': [('', 'empty frame'), ('/map', 'leading slash')],
        'intrinsic_matrix': [([800.0] * 11, '11 numbers'),
                             (_matrix(fx=0.0), 'zero fx'), (_matrix(fy=-869.0), 'negative fy'),
                             (_matrix(w=2.0), 'bad last row')],
    },
    'choice_arbiter': {
        'window_s': [(0.0, 'zero window')],
        'confidence': [(0.5, 'excluded bound 0.5'), (1.0, 'excluded bound 1')],
        'hit_rate': [(0.5, 'excluded bound 0.5'), (1.0, 'excluded bound 1')],
    },
    'lsl_gaze_bridge': {
        'x_channel': [('left_x,right_x', 'inconsistent: 2 x channels, 1 y channel'),
                      ('x,,y', 'empty entry')],
        'y_channel': [(',', 'empty entries')],
        'confidence_channel': [('conf,', 'empty entry')],
        'units': [('inches', 'unknown units')],
        'origin': [('centre', 'unknown origin')],
    },
    'choice_menu': {
        'scene_file': [('/nonexistent/scene.yaml', 'missing file'),
                       (lambda _, tmp_path: _bad_scene(tmp_path), 'malformed YAML')],
        'world_frame': [('', 'empty frame'), ('odom', "inconsistent with the scene's frame")],
        'robot_radius_m': [(1.0, 'inconsistent: no table where a robot this large fits')],
        'confirm_rounds': [(0, 'no round to answer in')],
        'send_rounds': [(-1, 'negative rounds')],
    },
    'gaze_validation': {
        'targets': [(7, 'neither 5 nor 9')],
        'settle_s': [(lambda node, _: node.get_parameter('target_s').value,
                      'inconsistent: settle_s == target_s')],
        'bridge_node': [('', 'empty node name')],
        'world_frame': [('', 'empty frame'), ('/map', 'leading slash')],
        'intrinsic_matrix': [([800.0] * 11, '11 numbers'), (_matrix(fx=0.0), 'zero fx')],
    },
    'ssvep_decoder': {
        'band': [([6.0], '1 number'), ([90.0, 6.0], 'low above high')],
        'channels': [('O1,,O2', 'empty entry')],
        'decoder': [('trca', 'inconsistent: trca without model_file')],
        'min_window_s': [(lambda node, _: node.get_parameter('window_s').value + 1.0,
                          'inconsistent: longer than window_s')],
    },
    'ssvep_stimulus_map': {
        'frequencies': [([8.0, 8.0], 'a frequency twice'), ([0.0, 9.0], 'zero Hz')],
    },
    'view_animated_bridge': {
        'world_frame': [('', 'empty frame'), ('/map', 'leading slash')],
    },
    'sim_rviz_view': {
        'world_frame': [('', 'empty frame'), ('/map', 'leading slash')],
        'eye': [([1.0, 2.0], '2 numbers'),
                (lambda node, _: list(node.get_parameter('focus').value),
                 'inconsistent: eye == focus')],
        'up': [([0.0, 0.0, 0.0], 'zero vector')],
    },
    'sim_robot': {
        'scene_file': [('/nonexistent/scene.yaml', 'missing file'),
                       (lambda _, tmp_path: _bad_scene(tmp_path), 'malformed YAML')],
        'start_pose': [([1.0, 2.0], '2 numbers'), ([5.0, NAN, 0.0], 'NaN'),
                       ([10.0, 3.0, 0.0], 'inside a wall'), ([30.0, 5.0, 0.0], 'off the map')],
    },
}

#: One good change per node, to show it still accepts one after all the bad ones (None: every
#: parameter is read-only).
GOOD_CHANGE = {
    'camera_tracker': ('eye', [1.0, -9.0, 11.0]),
    'marker_projector': ('screen_offset_x', 64),
    'choice_arbiter': ('window_s', 1.5),
    'lsl_gaze_bridge': ('screen_width', 2560),
    'choice_menu': ('robot_radius_m', 0.25),
    'gaze_validation': ('target_s', 2.0),
    'ssvep_decoder': ('threshold', 0.9),
    'ssvep_stimulus_map': ('lead_s', 0.2),
    'ssvep_stimulus': None,
    'view_animated_bridge': ('transition_time_s', 3.0),
    'sim_rviz_view': ('transition_time_s', 2.0),
    'sim_robot': ('max_speed', 0.8),
}

#: Parameters a node is started with here: the LSL readers look for streams nobody
#: publishes; gaze_validation waits for a request instead of running at once;
#: ssvep_stimulus refuses to start without the flicker opt-in (a small window on Xvfb).
OVERRIDES = {
    'lsl_gaze_bridge': {'source_id': unique_id('no-such-tracker')},
    'ssvep_decoder': {'source_id': unique_id('no-such-eeg')},
    'gaze_validation': {'on_request': True},
    'ssvep_stimulus': {'accept_flicker': True, 'width': 320, 'height': 240, 'vsync': False},
}

#: Every executable's node with parameters, from the registry.
NODES = {entry.name: entry for entry in parameter_nodes()}


def test_every_registered_node_is_covered_here():
    assert set(GOOD_CHANGE) == set(NODES), 'each node of the registry needs a GOOD_CHANGE'
    assert set(SPECIFIC) | set(OVERRIDES) <= set(NODES), 'entries for unregistered nodes'


def generated_values(name: str, descriptor, as_text: bool = False) -> List[Tuple[Any, str]]:
    """Bad values for a parameter from its descriptor: wrong types, range, NaN, choices."""
    values = [(value, f'wrong type {type(value).__name__}')
              for value in WRONG_TYPES.get(descriptor.type, [])
              if not (as_text and type(value) is int)]
    for bounds in descriptor.integer_range:
        low, high = sorted((bounds.from_value, bounds.to_value))
        values += [(low - 1, 'below range'), (high + 1, 'above range'),
                   (high * 1000 + 1000, 'far above range')]
    for bounds in descriptor.floating_point_range:
        low, high = sorted((bounds.from_value, bounds.to_value))
        span = max(high - low, 1.0)
        values += [(low - 0.01 * span, 'below range'), (high + 0.01 * span, 'above range')]
    if descriptor.type == ParameterType.PARAMETER_DOUBLE:
        values += [(NAN, 'NaN'), (INF, '+inf'), (-INF, '-inf')]
    if descriptor.type == ParameterType.PARAMETER_DOUBLE_ARRAY:
        values += [([NAN] * 3, 'NaN array'), ([1.0, INF, 0.0], 'inf in array')]
    choices = re.search(r'\(one of: ([^)]*)\)', descriptor.description)
    if choices and descriptor.type == ParameterType.PARAMETER_STRING:
        values += [('no_such_choice', 'unknown choice'), ('', 'empty choice')]
    return values


def same(first, second) -> bool:
    """Compare parameter values, NaN-safe, arrays as lists."""
    arrays = (list, tuple, np.ndarray)
    if isinstance(first, arrays) or isinstance(second, arrays):
        return np.array_equal(np.asarray(first, dtype=object), np.asarray(second, dtype=object))
    return first == second or (isinstance(first, float) and isinstance(second, float)
                               and math.isnan(first) and math.isnan(second))


@pytest.mark.parametrize('node_name', sorted(NODES))
def test_every_parameter_rejects_bad_values_and_keeps_the_old_one(graph, capfd, fault,
                                                                  tmp_path, request, node_name):
    entry = NODES[node_name]
    if entry.requires == DISPLAY:
        # Always a private Xvfb (it skips, naming the package, where there is none): the
        # case runs the same on a desktop, on CI, and after another test set DISPLAY.
        request.getfixturevalue('xvfb')
    elif missing(entry):
        # Only a module built apart (an RViz plugin's messages); the reason names it.
        pytest.skip(f'{node_name}: {missing(entry)}')
    node_class = getattr(importlib.import_module(entry.module), entry.node_class)
    node = graph.add(node_class, parameter_overrides=[
        Parameter(key, value=value) for key, value in OVERRIDES.get(node_name, {}).items()])
    log = LogTap(capfd)
    service = f'/{node_name}'
    names = sorted(node._parameters)
    descriptors = dict(zip(names, node.describe_parameters(names)))
    specific = SPECIFIC.get(node_name, {})
    assert set(specific) <= set(names), f'stale SPECIFIC entries: {set(specific) - set(names)}'
    tried: Dict[str, int] = {}
    for name in names:
        cases = generated_values(name, descriptors[name],
                                 as_text=name in TYPED_AS_TEXT.get(node_name, ()))
        cases += [(value(node, tmp_path) if callable(value) else value, kind)
                  for value, kind in specific.get(name, [])]
        assert cases, f'{node_name}.{name}: no bad value to try'
        tried[name] = len(cases)
        for value, kind in cases:
            with fault('parameters', f'{node_name}.{name} = {value!r} ({kind})'):
                old = graph.get_parameters(service, [name])
                mark = log.mark()
                result, = graph.set_parameters(service, {name: Parameter(name, value=value)})
                assert not result.successful, f'{name} accepted {value!r} ({kind})'
                assert result.reason.strip(), f'{name} = {value!r} rejected without a reason'
                assert same(graph.get_parameters(service, [name]), old), \
                    f'{name} changed although {value!r} was rejected'
                if not RCLPY_REASONS.search(result.reason):
                    # The node's own rules: it must say so in its log too.
                    assert log.wait_for(graph, f'{node_name}.*rejected parameter', mark, 5.0), \
                        f'{name} = {value!r} rejected ({result.reason}) but nothing logged'
    # Still alive, still listening to good changes.
    if GOOD_CHANGE[node_name] is not None:
        name, value = GOOD_CHANGE[node_name]
        result, = graph.set_parameters(service, {name: value})
        assert result.successful, result.reason
        assert same(graph.get_parameters(service, [name]), [value])
    assert graph.get_parameters(service, ['use_sim_time']) == [False]
