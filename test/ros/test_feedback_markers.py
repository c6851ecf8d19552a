"""choices/feedback messages built from feedback content (no spinning)."""

from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.decision.feedback import build_feedback, STATE_COLOURS
from eye_bci_ros2.ros.conversions import cube_marker
from eye_bci_ros2.ros.feedback_markers import (feedback_to_marker_array, FeedbackMarkers,
                                               option_markers)


def _choices(labels, ns='rooms'):
    array = MarkerArray(markers=[Marker(action=Marker.DELETEALL)])
    for index, label in enumerate(labels):
        array.markers.append(cube_marker(ns, index, label, 'map', (index * 2.0, 1.0, 0.1),
                                         (0, 0, 0, 1), (1.0, 0.8, 0.05), (0.2, 0.4, 0.6, 1.0)))
    return array


def _colour(marker):
    return (marker.color.r, marker.color.g, marker.color.b, marker.color.a)


def test_one_halo_per_option_same_ns_id_frame_and_pose():
    options = option_markers(_choices(['kitchen', 'office']))
    feedback = build_feedback(['kitchen', 'office'], gazed='office', progress={'office': 0.5})
    array, keys = feedback_to_marker_array(feedback, options, options[0].header.stamp)
    assert keys == {('rooms', 0), ('rooms', 1)}
    kitchen, office = array.markers
    assert (kitchen.ns, kitchen.id, office.ns, office.id) == ('rooms', 0, 'rooms', 1)
    assert kitchen.header.frame_id == office.header.frame_id == 'map'
    assert kitchen.type == Marker.CUBE and kitchen.action == Marker.ADD
    assert office.pose.position.x == 2.0
    assert _colour(kitchen) == tuple(STATE_COLOURS['none'])
    assert _colour(office) == tuple(STATE_COLOURS['gazed'])
    # The gazed halo is larger (progress) and thinner than the option.
    assert office.scale.x > kitchen.scale.x > 1.0
    assert office.scale.z < 0.05


def test_chosen_is_green_and_options_no_longer_offered_are_deleted():
    builder = FeedbackMarkers()
    rooms = option_markers(_choices(['kitchen', 'office']))
    builder.update(build_feedback(['kitchen', 'office']), rooms, rooms[0].header.stamp)
    tables = option_markers(_choices(['table_1'], ns='tables'))
    array = builder.update(build_feedback(['table_1'], chosen='table_1'), tables,
                           tables[0].header.stamp)
    added = [m for m in array.markers if m.action == Marker.ADD]
    deleted = [(m.ns, m.id) for m in array.markers if m.action == Marker.DELETE]
    assert [(m.ns, m.id) for m in added] == [('tables', 0)]
    assert _colour(added[0]) == tuple(STATE_COLOURS['chosen'])
    assert deleted == [('rooms', 0), ('rooms', 1)]
    # Deleted once only; nothing offered and nothing shown: nothing to send.
    assert builder.update(build_feedback([]), [], tables[0].header.stamp).markers[0].action \
        == Marker.DELETE
    assert builder.update(build_feedback([]), [], tables[0].header.stamp) is None
