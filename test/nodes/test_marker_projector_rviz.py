"""marker_projector as RViz2 sees things: marker semantics, TopDownOrtho, .rviz files."""

from builtin_interfaces.msg import Duration
from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.nodes.camera_tracker import CameraTracker
from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.projection.rviz_config import encode_window_state
from eye_bci_ros2.ros.conversions import arrays_to_pose, marker_array_to_regions
from eye_bci_ros2.ros.topics import CHOICES_QOS
from eye_bci_ros2.ros.topics import LATCHED_QOS

pytestmark = pytest.mark.ros


def marker(ns, marker_id, position, action=Marker.ADD, scale=(2.0, 2.0, 0.01), lifetime_s=0.0):
    message = Marker(ns=ns, id=marker_id, type=Marker.CUBE, action=action)
    message.header.frame_id = 'map'
    message.pose = arrays_to_pose(position, [0.0, 0.0, 0.0, 1.0])
    message.scale.x, message.scale.y, message.scale.z = scale
    message.color.a = 1.0
    message.lifetime = Duration(sec=int(lifetime_s), nanosec=int(lifetime_s % 1 * 1e9))
    return message


class Rig:
    """A projector (and optionally a tracker), a menu publisher and a regions collector."""

    def __init__(self, graph, tracker=None, **overrides):
        self.graph = graph
        overrides = {'screen_offset_x': 0, 'screen_offset_y': 0, **overrides}
        self.node = graph.add(MarkerProjector, parameter_overrides=[
            Parameter(name, value=value) for name, value in overrides.items()])
        if tracker is not None:
            graph.add(CameraTracker, parameter_overrides=[
                Parameter(name, value=value) for name, value in tracker.items()])
        helper = graph.node('projector_test')
        self.choices = helper.create_publisher(MarkerArray, 'choices', CHOICES_QOS)
        self.camera = helper.create_publisher(PoseStamped, 'camera/pose', LATCHED_QOS)
        self.regions = Collector(helper, MarkerArray, 'choices/regions', LATCHED_QOS)

    def look_down(self):
        message = PoseStamped()
        message.header.frame_id = 'map'
        message.pose = arrays_to_pose(*look_at_pose([0, 0, 10], [0, 0, 0], [0, 1, 0]))
        self.camera.publish(message)

    def send(self, *markers):
        before = len(self.regions.messages)
        self.choices.publish(MarkerArray(markers=list(markers)))
        assert self.graph.spin_until(lambda: len(self.regions.messages) > before, 10.0)
        return self.labels()

    def labels(self):
        return sorted(marker_array_to_regions(self.regions.last)[0])

    def polygons(self):
        labels, polygons = marker_array_to_regions(self.regions.last)
        return dict(zip(labels, polygons))


def extent(polygon):
    return (polygon[:, 0].min(), polygon[:, 0].max(), polygon[:, 1].min(), polygon[:, 1].max())


def rviz_file(tmp_path, view, fixed_frame='map', panel=None):
    text = (f'Visualization Manager:\n  Global Options:\n    Fixed Frame: {fixed_frame}\n'
            f'  Views:\n    Current:\n' + ''.join(f'      {line}\n' for line in view))
    if panel is not None:
        state = encode_window_state({0: [('Displays', panel[1])]}, panel, {0: 300})
        text += f'Window Geometry:\n  QMainWindow State: {state}\n'
    path = tmp_path / 'view.rviz'
    path.write_text(text)
    return str(path)


# -- RViz2 marker semantics (marker_common.cpp) ----------------------------------------------

def test_deleteall_with_a_namespace_deletes_only_that_namespace(graph):
    rig = Rig(graph)
    rig.look_down()
    assert rig.send(marker('rooms', 0, [-3, 0, 0]), marker('rooms', 1, [3, 0, 0]),
                    marker('tables', 0, [0, 3, 0])) == ['rooms/0', 'rooms/1', 'tables/0']
    assert rig.send(marker('rooms', 0, [0, 0, 0], action=Marker.DELETEALL)) == ['tables/0']


def test_markers_after_a_deleteall_in_the_same_array_survive(graph):
    rig = Rig(graph)
    rig.look_down()
    rig.send(marker('rooms', 0, [-3, 0, 0]), marker('tables', 0, [0, 3, 0]))
    labels = rig.send(marker('rooms', 0, [0, 0, 0], action=Marker.DELETEALL),
                      marker('rooms', 5, [3, 0, 0]), marker('', 0, [0, 0, 0],
                                                            action=Marker.DELETEALL),
                      marker('rooms', 7, [0, -3, 0]))
    assert labels == ['rooms/7']   # the empty-ns DELETEALL cleared tables/0 and rooms/5 too


def test_a_delete_with_nan_values_is_ignored_as_rviz_does(graph):
    rig = Rig(graph)
    rig.look_down()
    rig.send(marker('rooms', 0, [-3, 0, 0]), marker('rooms', 1, [3, 0, 0]))
    broken = marker('rooms', 0, [float('nan'), 0, 0], action=Marker.DELETE)
    assert rig.send(broken) == ['rooms/0', 'rooms/1']
    broken_all = marker('rooms', 0, [0, 0, 0], action=Marker.DELETEALL, scale=(1, float('inf'), 1))
    assert rig.send(broken_all) == ['rooms/0', 'rooms/1']
    assert rig.send(marker('rooms', 0, [0, 0, 0], action=Marker.DELETE)) == ['rooms/1']


def test_a_marker_with_a_lifetime_expires(graph):
    rig = Rig(graph)
    rig.look_down()
    assert rig.send(marker('flash', 0, [-3, 0, 0], lifetime_s=0.4),
                    marker('rooms', 0, [3, 0, 0])) == ['flash/0', 'rooms/0']
    assert graph.spin_until(lambda: rig.labels() == ['rooms/0'], 10.0)
    # Re-added without a lifetime it stays; an ADD with a lifetime replaces a permanent one.
    rig.send(marker('flash', 0, [-3, 0, 0]))
    graph.spin_for(0.6)
    assert rig.labels() == ['flash/0', 'rooms/0']
    rig.send(marker('rooms', 0, [3, 0, 0], lifetime_s=0.2))
    assert graph.spin_until(lambda: rig.labels() == ['flash/0'], 10.0)


# -- orthographic projection (TopDownOrtho) --------------------------------------------------

def test_top_down_ortho_file_drives_tracker_and_projector(graph, tmp_path):
    path = rviz_file(tmp_path, ['Class: rviz_default_plugins/TopDownOrtho', 'Angle: 0',
                                'Scale: 40', 'X: 10', 'Y: 6'], panel=(1000, 600))
    rig = Rig(graph, tracker={'rviz_config': path}, rviz_config=path,
              screen_offset_x=100, screen_offset_y=50)
    assert rig.node.camera.kind == 'orthographic'
    assert rig.node.camera.image_size == (1000, 600)
    rig.send(marker('rooms', 0, [10, 6, 0], scale=(2.0, 1.0, 0.5)),
             marker('rooms', 1, [12, 7, 3.0], scale=(1.0, 1.0, 1.0)))
    regions = rig.polygons()
    # 40 px per m around the panel centre (500, 300), + (100, 50) on the screen; height
    # does not change the size under a parallel projection.
    np.testing.assert_allclose(extent(regions['rooms/0']), (560, 640, 330, 370), atol=1e-9)
    np.testing.assert_allclose(extent(regions['rooms/1']), (660, 700, 290, 330), atol=1e-9)


def test_orthographic_by_parameters_and_the_scale_parameter_wins(graph, tmp_path):
    rig = Rig(graph, projection='orthographic', ortho_scale=25.0)
    rig.look_down()   # any optical pose works: 10 m above the origin, +y up
    rig.send(marker('rooms', 0, [2, 0, 0]))
    np.testing.assert_allclose(extent(rig.polygons()['rooms/0']),
                               (640 + 25, 640 + 75, 360 - 25, 360 + 25), atol=1e-9)
    bad = graph.set_parameters('/marker_projector', {'intrinsic_matrix': [
        800.0, 0.0, 640.0, 0.0, 0.0, 800.0, 360.0, 0.0, 0.0, 0.0, 1.0, 0.0]})[0]
    assert not bad.successful and 'perspective calibration' in bad.reason
    # Back to perspective at run time: the same box is now seen at its perspective size.
    assert graph.set_parameters('/marker_projector', {'projection': 'perspective'})[0].successful
    assert graph.spin_until(lambda: rig.node.camera.kind == 'perspective', 10.0)


# -- .rviz files -----------------------------------------------------------------------------

def test_panel_size_from_the_file_unless_given(graph, tmp_path):
    path = rviz_file(tmp_path, ['Class: rviz_default_plugins/Orbit'], panel=(1000, 600))
    rig = Rig(graph, rviz_config=path)
    assert rig.node.camera.kind == 'perspective'
    assert rig.node.camera.image_size == (1000, 600)
    focal = 300.0 / np.tan(np.radians(22.5))
    np.testing.assert_allclose(rig.node.camera.intrinsic[:2, :3],
                               [[focal, 0, 500], [0, focal, 300]])
    other = Rig(graph, rviz_config=path, image_width=800, image_height=450)
    assert other.node.camera.image_size == (800, 450)


def test_projection_parameter_overrides_the_files_controller(graph, tmp_path):
    path = rviz_file(tmp_path, ['Class: rviz_default_plugins/TopDownOrtho', 'Scale: 40'])
    assert Rig(graph, rviz_config=path, projection='perspective').node.camera.kind == \
        'perspective'


@pytest.mark.parametrize('view, fixed_frame, reason', [
    (['Class: rviz_default_plugins/Orbit', 'Target Frame: base_link'], 'map',
     "Target Frame 'base_link'"),
    (['Class: rviz_default_plugins/Orbit'], 'odom', "Fixed Frame 'odom' but world_frame"),
    (['Class: nav2_rviz_plugins/Fancy'], 'map', 'unknown view controller class'),
])
def test_unusable_file_stops_the_projector_with_a_reason(graph, tmp_path, view, fixed_frame,
                                                         reason):
    path = rviz_file(tmp_path, view, fixed_frame=fixed_frame)
    with pytest.raises(ValueError, match=reason):
        graph.add(MarkerProjector, parameter_overrides=[Parameter('rviz_config', value=path)])
