"""A second pipeline on the same graph is noticed and named, and changes no decision."""

from fault_rig import LogTap
from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from ros_harness import Collector
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.decision.camera_view import same_view
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.ros.conversions import (arrays_to_pose, cube_marker, marker_array_to_regions,
                                          pose_view, regions_camera_view)
from eye_bci_ros2.ros.topics import (CAMERA_POSE_TOPIC, CHOICES_QOS, CHOICES_TOPIC, LATCHED_QOS,
                                     REGIONS_TOPIC)

pytestmark = pytest.mark.ros

WAIT_S = 10.0


def test_a_lone_arbiter_sees_no_other_pipeline(graph):
    arbiter = graph.add(ChoiceArbiter)
    # Its own publisher and subscription are discovered first: then nothing else is there.
    assert graph.spin_until(
        lambda: len(arbiter.get_publishers_info_by_topic('/choice')) == 1
        and len(arbiter.get_subscriptions_info_by_topic('/gaze/samples')) == 1, WAIT_S)
    assert arbiter.graph_watch.check() == {}


def test_a_second_arbiter_is_named_with_the_fix_and_its_leaving_is_told(graph, capfd):
    log = LogTap(capfd)
    first = graph.add(ChoiceArbiter)
    second = graph.add(ChoiceArbiter)
    assert graph.spin_until(lambda: '/choice' in first.graph_watch.check(), WAIT_S)
    problems = first.graph_watch.problems
    assert 'another /choice_arbiter reads /gaze/samples' in problems['/gaze/samples']
    assert '2 publishers of /choice' in problems['/choice']
    assert '__ns:=' in problems['/choice']     # says how to separate them
    assert log.wait_for(graph, r'WARN.*2 publishers of /choice')
    graph.nodes.remove(second)
    graph.executor.remove_node(second)
    second.destroy_node()
    assert graph.spin_until(lambda: first.graph_watch.check() == {}, WAIT_S)
    assert log.wait_for(graph, r'/choice: the other pipeline is gone')


#: The first pipeline's view of the kitchen, and the second's overview (eye, focus, up).
KITCHEN_VIEW = ((0.0, -4.0, 3.0), (0.5, 0.5, 0.0), (0.0, 0.0, 1.0))
OVERVIEW = ((0.0, -8.0, 12.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))


def pose_of(view, x_shift=0.0):
    """Return the latched camera/pose message camera_tracker publishes for ``view``."""
    eye, focus, up = view
    message = PoseStamped()
    message.header.frame_id = 'map'
    message.pose = arrays_to_pose(*look_at_pose(np.add(eye, (x_shift, 0.0, 0.0)), focus, up))
    return message


def test_a_second_projector_showing_another_view_never_moves_the_first_arbiters_regions(
        graph, capfd):
    # Issue 39: a second pipeline (same domain, no namespace) whose camera still shows the
    # overview published the kitchen tables projected from there on the shared
    # choices/regions, and the first arbiter decided on them until the warning came.
    log = LogTap(capfd)
    driver = graph.node('menu_and_cameras')
    choices = driver.create_publisher(MarkerArray, CHOICES_TOPIC, CHOICES_QOS)
    camera = driver.create_publisher(PoseStamped, CAMERA_POSE_TOPIC, LATCHED_QOS)
    overview = driver.create_publisher(PoseStamped, 'overview/camera/pose', LATCHED_QOS)
    seen = Collector(driver, MarkerArray, REGIONS_TOPIC, LATCHED_QOS)
    tables = MarkerArray(markers=[
        cube_marker('tables', index, f'table_{index}', 'map', position, (0, 0, 0, 1),
                    (0.8, 0.8, 0.8)) for index, position in enumerate(
                        [(-1.0, 0.0, 0.4), (1.5, 1.0, 0.4), (0.5, 2.5, 0.4)], start=1)])
    choices.publish(tables)
    camera.publish(pose_of(KITCHEN_VIEW))
    graph.add(MarkerProjector)                 # the first pipeline's projector
    arbiter = graph.add(ChoiceArbiter)
    kitchen = pose_view(pose_of(KITCHEN_VIEW).pose)

    def ours(message):
        return same_view(regions_camera_view(message), kitchen)

    assert graph.spin_until(lambda: arbiter.regions is not None and len(arbiter.regions), WAIT_S)
    mine = [m for m in seen.messages if ours(m)]
    assert mine, 'the first projector published nothing'
    labels, expected = marker_array_to_regions(mine[-1])
    in_use = []

    def record():
        regions = arbiter.regions
        in_use.append((tuple(regions.labels), regions.polygons.copy()))
        return False

    # The second pipeline's projector: its camera is on the overview.
    overview.publish(pose_of(OVERVIEW))
    graph.add(MarkerProjector, cli_args=['--ros-args', '-r', '__node:=second_projector',
                                         '-r', 'camera/pose:=overview/camera/pose'])
    for step in range(1, 4):
        graph.spin_until(lambda: record() or any(not ours(m) for m in seen.messages), WAIT_S)
        overview.publish(pose_of(OVERVIEW, x_shift=0.1 * step))   # the second one moves
        choices.publish(tables)                                   # both reproject
        graph.spin_until(record, 0.5)
    theirs = [m for m in seen.messages if not ours(m)]
    assert len(theirs) >= 3, 'the second projector published nothing'
    _, other = marker_array_to_regions(theirs[-1])
    assert not np.allclose(other, expected, atol=50.0)      # another view indeed
    graph.spin_until(record, 0.5)
    # Not even for a moment: every regions set the arbiter decided on was the first's.
    assert len(in_use) > 10
    for used_labels, polygons in in_use:
        assert used_labels == tuple(labels)
        np.testing.assert_allclose(polygons, expected)
    assert graph.spin_until(lambda: arbiter.regions_ignored >= 3, WAIT_S)
    assert log.wait_for(graph, r'WARN.*choice_arbiter.*regions projected from another camera '
                               r'view .* are ignored: another pipeline')
