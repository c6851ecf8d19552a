"""marker_projector on a real ROS 2 graph, against hand-computed regions."""

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.ros.conversions import (arrays_to_pose, CAMERA_VIEW_NS,
                                          marker_array_to_regions, regions_camera_view)
from eye_bci_ros2.ros.topics import LATCHED_QOS

pytestmark = pytest.mark.ros

#: Focal length of the default 1280x720 panel at 45 degrees vertical FOV, px.
F = 360.0 / np.tan(np.radians(22.5))
#: Half side, px, of a 2 m flat cube's top face (9.995 m deep) seen from 10 m above.
HALF = F / 9.995


class Rig:
    """A projector plus a test node that plays the menu and the camera tracker."""

    def __init__(self, graph, **overrides):
        self.graph = graph
        # Hand-computed pixels below are image px unless a test sets an offset.
        overrides = {'screen_offset_x': 0, 'screen_offset_y': 0, **overrides}
        self.node = graph.add(MarkerProjector, parameter_overrides=[
            Parameter(name, value=value) for name, value in overrides.items()])
        helper = graph.node('projector_test')
        self.choices = helper.create_publisher(MarkerArray, 'choices', LATCHED_QOS)
        self.camera = helper.create_publisher(PoseStamped, 'camera/pose', LATCHED_QOS)
        self.regions = Collector(helper, MarkerArray, 'choices/regions', LATCHED_QOS)

    def look(self, eye, focus, up, frame='map', stamp=None):
        """Publish an optical camera pose looking from eye at focus."""
        message = PoseStamped()
        message.header.frame_id = frame
        if stamp is not None:
            message.header.stamp = stamp
        message.pose = arrays_to_pose(*look_at_pose(eye, focus, up))
        self.camera.publish(message)

    def look_down(self, x=0.0, y=0.0, stamp=None):
        """Put the camera 10 m above (x, y, 0) looking down, world +y up on the screen."""
        self.look([x, y, 10.0], [x, y, 0.0], [0.0, 1.0, 0.0], stamp=stamp)

    def send(self, *markers):
        """Publish a MarkerArray of ``markers``."""
        self.choices.publish(MarkerArray(markers=list(markers)))

    def next_regions(self, action, timeout=10.0):
        """Run ``action`` and return the (labels -> polygon) of the next regions message."""
        before = len(self.regions.messages)
        action()
        assert self.graph.spin_until(lambda: len(self.regions.messages) > before, timeout), \
            'no choices/regions published'
        return self.current()

    def current(self):
        """Return the newest regions as {label: polygon (K, 2) screen px}."""
        labels, polygons = marker_array_to_regions(self.regions.last)
        return dict(zip(labels, polygons))

    def settle(self, seconds=0.3):
        """Spin so anything in flight arrives."""
        self.graph.spin_for(seconds)


def cube(ns, marker_id, position, scale=(2.0, 2.0, 0.01), frame='map', text='',
         quaternion=(0.0, 0.0, 0.0, 1.0), action=Marker.ADD, marker_type=Marker.CUBE):
    """Build a marker message."""
    marker = Marker()
    marker.header.frame_id = frame
    marker.ns, marker.id, marker.text = ns, marker_id, text
    marker.type, marker.action = marker_type, action
    marker.pose = arrays_to_pose(position, quaternion)
    marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in scale)
    return marker


def square(cx, cy, half=HALF):
    """Return the sorted corners of an axis-aligned square region, screen px."""
    return sorted((round(cx + sx * half, 6), round(cy + sy * half, 6))
                  for sx in (-1, 1) for sy in (-1, 1))


def extent(polygon):
    """Return (u min, u max, v min, v max) of a region, screen px."""
    return (polygon[:, 0].min(), polygon[:, 0].max(), polygon[:, 1].min(), polygon[:, 1].max())


def corners(polygon):
    """Return the sorted distinct vertices of a region."""
    return sorted({(round(u, 6), round(v, 6)) for u, v in polygon})


def test_square_region_at_hand_computed_pixels_once_the_camera_is_known(graph):
    rig = Rig(graph, screen_offset_x=100, screen_offset_y=50)
    rig.send(cube('rooms', 0, [0, 0, 0], text='kitchen'), cube('rooms', 1, [3, 0, 0]))
    rig.settle(0.5)
    assert rig.regions.messages == []  # no camera pose yet: nothing published
    regions = rig.next_regions(rig.look_down)
    assert sorted(regions) == ['kitchen', 'rooms/1']
    assert corners(regions['kitchen']) == square(100 + 640, 50 + 360)
    message = rig.regions.last
    first = message.markers[0]
    assert (first.ns, first.id, first.text) == ('rooms', 0, 'kitchen')
    assert first.header.frame_id == 'screen' and first.type == Marker.LINE_STRIP
    assert first.points[0] == first.points[-1]  # closed
    # Off-axis the thin cube shows a sliver of its side: its top face spans
    # 2..4 m, i.e. u from 640 + 2 f / 9.995 to 640 + 4 f / 9.995.
    u = regions['rooms/1'][:, 0]
    assert u.max() == pytest.approx(100 + 640 + 4 * HALF)
    assert u.min() == pytest.approx(100 + 640 + 2 * F / 10.005)


def test_late_subscriber_gets_the_latched_regions(graph):
    rig = Rig(graph)
    rig.send(cube('rooms', 0, [0, 0, 0]))
    rig.next_regions(rig.look_down)
    late = Collector(graph.node('late'), MarkerArray, 'choices/regions', LATCHED_QOS)
    assert graph.spin_until(lambda: late.messages, 10.0)
    # The region, and the camera view it was projected with (decision.camera_view).
    assert [m.type for m in late.last.markers] == [Marker.LINE_STRIP, Marker.ARROW]
    np.testing.assert_allclose(regions_camera_view(late.last), [
        0, 0, 10, *look_at_pose([0, 0, 10], [0, 0, 0], [0, 1, 0])[1]], atol=1e-12)


def test_screen_offset_change_shifts_every_region_exactly(graph):
    rig = Rig(graph, screen_offset_x=10)
    rig.send(cube('t', 0, [0, 0, 0]), cube('t', 1, [-3, 2, 0.5], scale=(1, 1, 1)),
             cube('t', 2, [2, -2, 0], quaternion=(0, 0, 0.38268343, 0.92387953)))
    before = rig.next_regions(rig.look_down)
    assert len(before) == 3
    results = []
    after = rig.next_regions(lambda: results.extend(
        graph.set_parameters('/marker_projector', {'screen_offset_x': 74})))
    assert results[0].successful
    assert sorted(after) == sorted(before)
    for label in before:
        np.testing.assert_allclose(after[label], before[label] + [64.0, 0.0], atol=1e-9)
    after_y = rig.next_regions(
        lambda: graph.set_parameters('/marker_projector', {'screen_offset_y': -20}))
    for label in before:
        np.testing.assert_allclose(after_y[label], before[label] + [64.0, -20.0], atol=1e-9)


@pytest.mark.parametrize('values, reason', [
    ({'image_width': 0}, 'out of range'),
    ({'intrinsic_matrix': [900.0, 0.0, 640.0, 0.0, 900.0, 360.0, 1.0]},
     'exactly 12 numbers'),
    ({'intrinsic_matrix': [-900.0, 0.0, 640.0, 0.0, 0.0, 900.0, 360.0, 0.0,
                           0.0, 0.0, 1.0, 0.0]},
     'focal terms must be positive'),
    ({'fov_y_deg': 180.0}, 'out of range'),
    ({'world_frame': ''}, 'empty'),
])
def test_invalid_parameters_are_rejected_with_a_reason_and_the_old_value_kept(
        graph, values, reason):
    rig = Rig(graph)
    rig.send(cube('rooms', 0, [0, 0, 0]))
    before = rig.next_regions(rig.look_down)
    count = len(rig.regions.messages)
    name = next(iter(values))
    old = graph.get_parameters('/marker_projector', [name])  # [] while unset
    result = graph.set_parameters('/marker_projector', values)[0]
    assert not result.successful
    assert result.reason and reason in result.reason
    assert graph.get_parameters('/marker_projector', [name]) == old
    rig.settle()
    assert len(rig.regions.messages) == count
    assert corners(rig.current()['rooms/0']) == corners(before['rooms/0'])


def test_calibrated_intrinsic_and_image_size_take_effect(graph):
    rig = Rig(graph)
    rig.send(cube('rooms', 0, [0, 0, 0]))
    rig.next_regions(rig.look_down)
    doubled = [2 * F, 0.0, 640.0, 0.0, 0.0, 2 * F, 360.0, 0.0, 0.0, 0.0, 1.0, 0.0]
    regions = rig.next_regions(
        lambda: graph.set_parameters('/marker_projector', {'intrinsic_matrix': doubled}))
    assert corners(regions['rooms/0']) == square(640, 360, 2 * HALF)
    # Back to the analytic intrinsic of a 1000x500 panel.
    regions = rig.next_regions(lambda: graph.set_parameters(
        '/marker_projector', {'intrinsic_matrix': Parameter(
            'intrinsic_matrix', Parameter.Type.DOUBLE_ARRAY, []),
            'image_width': 1000, 'image_height': 500}))
    assert corners(regions['rooms/0']) == square(500, 250, 250 / np.tan(np.radians(22.5)) / 9.995)


def test_add_modify_delete_and_deleteall(graph):
    rig = Rig(graph)
    rig.send(cube('a', 0, [0, 0, 0]), cube('a', 1, [3, 0, 0]), cube('b', 0, [-3, 0, 0]))
    assert sorted(rig.next_regions(rig.look_down)) == ['a/0', 'a/1', 'b/0']
    # MODIFY (= ADD) of an existing (ns, id) replaces it.
    regions = rig.next_regions(lambda: rig.send(cube('a', 0, [0, 2, 0])))
    assert sorted(regions) == ['a/0', 'a/1', 'b/0']
    # Top face spans y = 1..3 m; the near side face shows below it (10.005 m deep).
    assert extent(regions['a/0']) == pytest.approx(
        (640 - HALF, 640 + HALF, 360 - 3 * HALF, 360 - F / 10.005))
    regions = rig.next_regions(lambda: rig.send(cube('a', 1, [0, 0, 0], action=Marker.DELETE)))
    assert sorted(regions) == ['a/0', 'b/0']
    assert corners(regions['b/0']) == corners(rig.current()['b/0'])
    # DELETE of an unknown marker changes nothing.
    regions = rig.next_regions(lambda: rig.send(cube('zz', 9, [0, 0, 0], action=Marker.DELETE)))
    assert sorted(regions) == ['a/0', 'b/0']
    # DELETEALL clears what came before it, in this array too.
    regions = rig.next_regions(lambda: rig.send(
        cube('c', 0, [0, 0, 0]), cube('', 0, [0, 0, 0], action=Marker.DELETEALL),
        cube('d', 0, [0, -2, 0])))
    assert sorted(regions) == ['d/0']
    regions = rig.next_regions(lambda: rig.send(cube('', 0, [0, 0, 0], action=Marker.DELETEALL)))
    assert regions == {}
    assert [m.ns for m in rig.regions.last.markers] == [CAMERA_VIEW_NS]


def test_other_frames_bad_data_and_markers_behind_are_left_out(graph):
    rig = Rig(graph)
    rig.send(
        cube('ok', 0, [0, 0, 0]),
        cube('ok', 1, [3, 0, 0], frame=''),                      # empty frame = world_frame
        cube('ok', 2, [-3, 0, 0], quaternion=(0, 0, 0, 5.0)),    # non-unit: normalised
        cube('ok', 3, [0, 3, 0], quaternion=(0, 0, 0, 0)),       # all zero: identity, as RViz
        cube('skip', 0, [0, 0, 0], frame='base_link'),           # other frame: no tf2
        cube('skip', 1, [0, 0, 0], scale=(2, 0, 0.01)),          # zero scale
        cube('skip', 2, [0, 0, 0], scale=(2, -1, 0.01)),         # negative scale
        cube('skip', 3, [float('nan'), 0, 0]),                   # NaN pose
        cube('skip', 4, [0, 0, 20]),                             # behind the camera
        cube('skip', 5, [3, 3, 10], scale=(1, 1, 1)),            # across the camera plane
        cube('skip', 6, [0, 0, 9], scale=(3, 3, 3)),             # contains the camera
        cube('skip', 7, [60, 0, 0]),                             # beside the render panel
    )
    regions = rig.next_regions(rig.look_down)
    assert sorted(regions) == ['ok/0', 'ok/1', 'ok/2', 'ok/3']
    # (-3, 0, 0) mirrors (3, 0, 0) about the image centre: same shape, normalised.
    mirrored = sorted((round(1280 - u, 6), v) for u, v in corners(regions['ok/1']))
    assert corners(regions['ok/2']) == mirrored
    assert regions['ok/2'][:, 0].min() == pytest.approx(640 - 4 * HALF)
    # Zero quaternion = identity: axis-aligned top face spanning y = 2..4 m.
    assert extent(regions['ok/3']) == pytest.approx(
        (640 - HALF, 640 + HALF, 360 - 4 * HALF, 360 - 2 * F / 10.005))
    assert rig.node.context.ok()


def test_camera_move_reprojects_and_a_bad_camera_is_ignored(graph):
    rig = Rig(graph)
    rig.send(cube('rooms', 0, [0, 0, 0]), cube('rooms', 1, [2, 0, 0]))
    first = rig.next_regions(rig.look_down)
    assert corners(first['rooms/0']) == square(640, 360)
    # Regions carry the stamp of the camera pose that moved them (when the screen changed).
    moved_at = rig.node.get_clock().now().to_msg()
    moved = rig.next_regions(lambda: rig.look_down(x=2.0, stamp=moved_at))
    assert rig.regions.last.markers[0].header.stamp == moved_at
    # Now right above rooms/1; rooms/0 spans x = -3..-1 m from the camera and
    # shows its near side face (bottom edge 10.005 m deep).
    assert corners(moved['rooms/1']) == square(640, 360)
    assert extent(moved['rooms/0']) == pytest.approx(
        (640 - 3 * HALF, 640 - F / 10.005, 360 - HALF, 360 + HALF))
    count = len(rig.regions.messages)
    nan_pose = PoseStamped()
    nan_pose.header.frame_id = 'map'
    nan_pose.pose = arrays_to_pose([float('nan'), 0.0, 10.0], [1.0, 0.0, 0.0, 0.0])
    rig.camera.publish(nan_pose)                                     # NaN pose
    rig.settle()  # depth-1 latched topic: let each bad pose arrive on its own
    rig.look([0, 0, 10], [0, 0, 0], [0, 1, 0], frame='base_link')  # wrong frame
    rig.settle(0.5)
    assert len(rig.regions.messages) == count
    # A pose stamped in the past does not send region stamps backwards.
    rig.next_regions(lambda: rig.look_down(x=2.0, stamp=Time(sec=1)))
    assert rig.regions.last.markers[0].header.stamp == moved_at
    # Behind the camera once it looks up: everything is left out.
    regions = rig.next_regions(lambda: rig.look([0, 0, 10], [0, 0, 20], [0, 1, 0]))
    assert regions == {}


def test_regions_are_cut_at_the_panel_edge_unless_clipping_is_off(graph):
    rig = Rig(graph, screen_offset_x=30)
    # Half the panel width is 640 px = 7.36 m at 10 m: this cube sticks out on the right.
    rig.send(cube('edge', 0, [7.5, 0, 0]))
    regions = rig.next_regions(rig.look_down)
    assert regions['edge/0'][:, 0].max() == pytest.approx(30 + 1280)
    regions = rig.next_regions(
        lambda: graph.set_parameters('/marker_projector', {'clip_to_image': False}))
    assert regions['edge/0'][:, 0].max() == pytest.approx(30 + 640 + 8.5 * HALF)


def test_world_frame_change_reprojects_markers_of_that_frame(graph):
    rig = Rig(graph)
    rig.send(cube('m', 0, [0, 0, 0]), cube('m', 1, [0, 0, 0], frame='odom'))
    assert sorted(rig.next_regions(rig.look_down)) == ['m/0']
    # The camera pose is still in 'map': no regions until one in 'odom' arrives.
    regions = rig.next_regions(
        lambda: graph.set_parameters('/marker_projector', {'world_frame': 'odom'}))
    assert regions == {}
    regions = rig.next_regions(lambda: rig.look([0, 0, 10], [0, 0, 0], [0, 1, 0], 'odom'))
    assert sorted(regions) == ['m/1']
    assert corners(regions['m/1']) == square(640, 360)
