"""The arbiter's copy of the options on ``choices``: RViz2's MarkerArray semantics."""

import math

from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.ros.conversions import cube_marker
from eye_bci_ros2.ros.feedback_markers import option_label, OptionMarkers


def _cube(ns, marker_id, text='', x=0.0, scale=(1.0, 1.0, 0.1)):
    return cube_marker(ns, marker_id, text, 'map', (x, 0.0, 0.0), (0, 0, 0, 1), scale)


def test_add_modify_delete_and_deleteall_per_namespace():
    options = OptionMarkers()
    assert options.apply(MarkerArray(markers=[
        _cube('rooms', 0, 'kitchen'), _cube('rooms', 1, 'office'), _cube('tables', 0)])) == []
    assert [option_label(m) for m in options.options] == ['kitchen', 'office', 'tables/0']
    # MODIFY (= ADD) replaces in place; DELETE removes one.
    options.apply(MarkerArray(markers=[_cube('rooms', 0, 'kitchen', x=3.0),
                                       Marker(ns='rooms', id=1, action=Marker.DELETE)]))
    assert options.get('kitchen').pose.position.x == 3.0 and options.get('office') is None
    # DELETEALL with an ns clears that ns only; markers after it in the array survive.
    options.apply(MarkerArray(markers=[Marker(ns='rooms', action=Marker.DELETEALL),
                                       _cube('rooms', 5, 'bedroom')]))
    assert [option_label(m) for m in options.options] == ['tables/0', 'bedroom']
    # DELETEALL without an ns clears everything.
    options.apply(MarkerArray(markers=[Marker(action=Marker.DELETEALL)]))
    assert options.options == []


def test_bad_markers_are_skipped_with_a_reason_and_the_rest_applied():
    options = OptionMarkers()
    flat = _cube('rooms', 0, 'flat', scale=(1.0, 0.0, 0.1))
    nan = _cube('rooms', 1, 'nan', x=math.nan)
    problems = options.apply(MarkerArray(markers=[flat, nan, _cube('rooms', 2, 'good')]))
    assert len(problems) == 2
    assert 'rooms/0' in problems[0] and 'scale' in problems[0]
    assert 'rooms/1' in problems[1] and 'NaN' in problems[1]
    assert [option_label(m) for m in options.options] == ['good']
