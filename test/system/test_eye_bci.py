"""The composed pipeline: every node on one executor, with the simulated RViz view."""

import uuid

import numpy as np
import pytest
from ros_harness import Collector
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.nodes.eye_bci import make_pipeline_nodes, NODE_NAMES
from eye_bci_ros2.projection import geometry
from eye_bci_ros2.ros.conversions import marker_array_to_regions
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.ros.topics import EVENT_QOS, LATCHED_QOS
from eye_bci_ros2.sim.rviz_view import SimRvizView
from eye_bci_ros2.task.scene import load_scene

pytestmark = pytest.mark.ros

SCENE = load_scene(default_scene_path())
WIDTH, HEIGHT, X0, Y0 = 1280, 720, 320, 180
FOCAL = (HEIGHT / 2) / np.tan(np.radians(45.0) / 2)
INTRINSIC = np.array([[FOCAL, 0, WIDTH / 2, 0], [0, FOCAL, HEIGHT / 2, 0], [0, 0, 1, 0]])


def expected_boxes(view, markers):
    """Screen bounding boxes (x_min, y_min, x_max, y_max) from the analytic projection."""
    polygons, _ = geometry.box_silhouettes(
        [m.position for m in markers], [m.orientation for m in markers],
        [m.scale for m in markers], INTRINSIC, view.external())
    polygons = polygons + [X0, Y0]
    return np.concatenate([np.nanmin(polygons, axis=1), np.nanmax(polygons, axis=1)], axis=1)


def region_boxes(array):
    labels, polygons = marker_array_to_regions(array)
    return labels, np.concatenate([polygons.min(axis=1), polygons.max(axis=1)], axis=1)


def matches(array, view, markers, atol=0.5):
    if array is None:
        return False
    labels, boxes = region_boxes(array)
    return labels == [m.text for m in markers] and np.allclose(
        boxes, expected_boxes(view, markers), atol=atol)


def test_unknown_node_name_is_rejected():
    with pytest.raises(ValueError, match='no pipeline node named rviz'):
        make_pipeline_nodes(overrides={'rviz': {}})


def test_eye_bci_is_the_four_pipeline_nodes_and_the_menu_only_when_asked(graph):
    assert NODE_NAMES == ('lsl_gaze_bridge', 'camera_tracker', 'marker_projector',
                          'choice_arbiter', 'session_markers')
    source = {'lsl_gaze_bridge': {'source_id': f'no-such-tracker-{uuid.uuid4()}'}}
    nodes = make_pipeline_nodes(graph.context, overrides=source)
    try:
        assert [node.get_name() for node in nodes] == list(NODE_NAMES)
    finally:
        for node in nodes:
            node.destroy_node()
    with pytest.raises(ValueError, match='no pipeline node named choice_menu'):
        make_pipeline_nodes(graph.context, overrides={'choice_menu': {}})


def test_pipeline_follows_the_menu_through_the_simulated_view(graph):
    nodes = make_pipeline_nodes(graph.context, overrides={
        # A source no other test's outlet has: this test needs no gaze.
        'lsl_gaze_bridge': {'source_id': f'no-such-tracker-{uuid.uuid4()}'},
        'choice_menu': {'repeat': False, 'back_option': False},
    }, with_menu=True)
    for node in nodes:
        graph.nodes.append(node)
        graph.executor.add_node(node)
    assert [node.get_name() for node in nodes] == list(NODE_NAMES) + ['choice_menu']
    assert nodes[-1].get_parameter('repeat').value is False
    view = graph.add(SimRvizView)
    probe = graph.node('probe')
    regions = Collector(probe, MarkerArray, 'choices/regions', LATCHED_QOS)
    requests = Collector(probe, Empty, 'choice/request', EVENT_QOS)
    choose = probe.create_publisher(String, 'choice', EVENT_QOS)

    rooms = [room.marker for room in SCENE.rooms]
    assert graph.spin_until(lambda: matches(regions.last, SCENE.overview, rooms), 10.0), \
        regions.last and region_boxes(regions.last)

    # The menu asks once the camera is there; as if the arbiter had then decided,
    # it zooms into the kitchen, the simulated RViz eases there, the projector follows.
    assert graph.spin_until(lambda: requests.messages, 10.0), 'the menu never asked'
    assert graph.spin_until(lambda: choose.get_subscription_count() > 0, 10.0)
    graph.spin_for(0.3)   # an answer, not a choice made before the question (min_answer_s)
    choose.publish(String(data='kitchen'))
    kitchen = SCENE.room('kitchen')
    tables = [table.marker for table in kitchen.tables]
    assert graph.spin_until(lambda: matches(regions.last, kitchen.view, tables), 10.0), \
        regions.last and region_boxes(regions.last)
    assert not view.moving
