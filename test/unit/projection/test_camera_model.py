"""The RViz camera model against hand-computed values (pure, no ROS)."""

import numpy as np
import pytest

from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import (clip_polygons, look_at_pose,
                                                  ogre_pose_from_optical, optical_pose_from_ogre,
                                                  parse_intrinsic, rviz_intrinsic, RvizCamera)

#: Focal length of a 720 px high panel at RViz's 45 degree vertical FOV, px.
F_720 = 360.0 / np.tan(np.radians(22.5))

IDENTITY = [0.0, 0.0, 0.0, 1.0]


def axes(quaternion_xyzw):
    """Return the frame's x, y, z axes in the world frame (columns of R)."""
    rotation = geometry.quaternion_to_matrix(quaternion_xyzw)
    return rotation[:, 0], rotation[:, 1], rotation[:, 2]


def distinct_vertices(polygon):
    """Return the vertices of a padded outline without repeats, as a sorted list."""
    return sorted({(round(u, 6), round(v, 6)) for u, v in polygon})


def test_ogre_identity_camera_looks_down_world_minus_z():
    # Ogre identity: looks along world -Z, +Y up, +X right.
    position, quaternion = optical_pose_from_ogre([1.0, 2.0, 3.0], IDENTITY)
    x, y, z = axes(quaternion)
    assert position.tolist() == [1.0, 2.0, 3.0]
    np.testing.assert_allclose(z, [0, 0, -1], atol=1e-12)   # forward
    np.testing.assert_allclose(y, [0, -1, 0], atol=1e-12)   # image down = -up
    np.testing.assert_allclose(x, [1, 0, 0], atol=1e-12)    # right
    np.testing.assert_allclose(quaternion, [1, 0, 0, 0], atol=1e-12)


def test_ogre_camera_looking_along_x_matches_look_at():
    # An RViz camera at the origin looking along world +X with world +Z up:
    # Ogre -Z = +X, Ogre +Y = +Z, so Ogre +X = Y x Z = -Y.
    ogre_rotation = np.column_stack([[0, -1, 0], [0, 0, 1], [-1, 0, 0]]).astype(float)
    ogre_quaternion = geometry.matrix_to_quaternion(ogre_rotation)
    _, quaternion = optical_pose_from_ogre([0, 0, 0], ogre_quaternion)
    x, y, z = axes(quaternion)
    np.testing.assert_allclose(z, [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(y, [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(x, [0, -1, 0], atol=1e-12)
    _, expected = look_at_pose([0, 0, 0], [5, 0, 0], [0, 0, 1])
    np.testing.assert_allclose(quaternion, expected, atol=1e-12)


def test_ogre_conversion_is_a_half_turn_about_camera_x_for_any_pose():
    rng = np.random.default_rng(3)
    for quaternion in rng.normal(size=(50, 4)):
        _, optical = optical_pose_from_ogre([0, 0, 0], 3.0 * quaternion)  # non-unit is fine
        np.testing.assert_allclose(
            geometry.quaternion_to_matrix(optical),
            geometry.quaternion_to_matrix(quaternion) @ np.diag([1.0, -1.0, -1.0]), atol=1e-12)
        _, back = ogre_pose_from_optical([0, 0, 0], optical)
        np.testing.assert_allclose(geometry.quaternion_to_matrix(back),
                                   geometry.quaternion_to_matrix(quaternion), atol=1e-12)


@pytest.mark.parametrize('position, quaternion, message', [
    ([0, 0, 0], [0, 0, 0, 0], 'zero length'),
    ([0, 0, 0], [0, 0, np.nan, 1], 'NaN'),
    ([0, np.inf, 0], IDENTITY, 'NaN or infinite'),
])
def test_ogre_conversion_rejects_bad_poses(position, quaternion, message):
    with pytest.raises(ValueError, match=message):
        optical_pose_from_ogre(position, quaternion)


def test_look_at_pose_of_a_camera_straight_above():
    position, quaternion = look_at_pose([0, 0, 10], [0, 0, 0], [0, 1, 0])
    x, y, z = axes(quaternion)
    assert position.tolist() == [0, 0, 10]
    np.testing.assert_allclose(z, [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(y, [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(x, [1, 0, 0], atol=1e-12)


@pytest.mark.parametrize('eye, focus, up, message', [
    ([1, 2, 3], [1, 2, 3], [0, 0, 1], 'equals focus'),
    ([0, 0, 5], [0, 0, 0], [0, 0, 1], 'parallel'),
    ([0, 0, 5], [0, 0, 0], [0, 0, 0], 'zero'),
    ([0, np.nan, 5], [0, 0, 0], [0, 1, 0], 'NaN'),
])
def test_look_at_pose_rejects_degenerate_views(eye, focus, up, message):
    with pytest.raises(ValueError, match=message):
        look_at_pose(eye, focus, up)


def test_parse_intrinsic_accepts_12_numbers_row_major():
    values = [900.0, 0.5, 650.0, 0.0, 0.0, 905.0, 355.0, 0.0, 0.0, 0.0, 1.0, 0.0]
    np.testing.assert_array_equal(parse_intrinsic(values), np.reshape(values, (3, 4)))


@pytest.mark.parametrize('values, message', [
    ([1.0] * 7, 'exactly 12 numbers.*got 7'),
    ([900, 0, 640, 0, 0, 900, 360, 0, 0, 0, 1, np.nan], 'NaN'),
    ([-900, 0, 640, 0, 0, 900, 360, 0, 0, 0, 1, 0], 'focal terms must be positive'),
    ([900, 0, 640, 0, 0, 0, 360, 0, 0, 0, 1, 0], 'focal terms must be positive'),
    ([900, 0, 640, 0, 0, 900, 360, 0, 0, 0, 2, 0], 'last row'),
    ([900, 0, 640, 0, 0, 900, 360, 0, 0.5, 0, 1, 0], 'last row'),
])
def test_parse_intrinsic_rejects_with_reason(values, message):
    with pytest.raises(ValueError, match=message):
        parse_intrinsic(values)


def overhead_camera(screen_offset=(0.0, 0.0)):
    """Return a camera 10 m above the origin looking down, world +y up on screen, 1280x720."""
    return RvizCamera.from_look_at([0, 0, 10], [0, 0, 0], [0, 1, 0], image_size=(1280, 720),
                                   screen_offset=screen_offset)


def test_project_points_by_hand():
    camera = overhead_camera()
    # Default: the analytic RViz intrinsic, f = (720 / 2) / tan(22.5 deg) = 869.12 px.
    assert F_720 == pytest.approx(869.1168824543142)
    np.testing.assert_allclose(camera.intrinsic, [[F_720, 0, 640, 0], [0, F_720, 360, 0],
                                                  [0, 0, 1, 0]])
    uv, depth = camera.project([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 20]])
    np.testing.assert_allclose(uv[:3], [[640, 360], [640 + F_720 / 10, 360],
                                        [640, 360 - F_720 / 10]])
    np.testing.assert_allclose(depth, [10, 10, 10, -10])
    assert np.all(np.isnan(uv[3]))
    np.testing.assert_allclose(camera.eye, [0, 0, 10], atol=1e-12)


def test_to_screen_adds_the_panel_offset():
    camera = overhead_camera(screen_offset=(320, 90))
    np.testing.assert_allclose(camera.to_screen([[0, 0], [1280, 720]]), [[320, 90], [1600, 810]])
    np.testing.assert_allclose(camera.to_image(camera.to_screen([[12.5, 7.0]])), [[12.5, 7.0]])


def test_flat_cube_seen_from_above_is_a_square_at_hand_computed_pixels():
    camera = overhead_camera(screen_offset=(100, 50))
    polygons, visible = camera.box_regions([[0, 0, 0]], [IDENTITY], [[2, 2, 0.01]])
    # The top face (z = 0.005) is 9.995 m in front; its half side spans f * 1 / 9.995 px.
    half = F_720 / 9.995
    expected = sorted((round(100 + 640 + sx * half, 6), round(50 + 360 + sy * half, 6))
                      for sx in (-1, 1) for sy in (-1, 1))
    assert visible.tolist() == [True]
    assert distinct_vertices(polygons[0]) == expected
    # Counter-clockwise as the person sees it (v down): negative shoelace area.
    assert geometry.polygon_signed_area(polygons[0]) < 0


def test_rotated_quaternion_turns_the_square():
    camera = overhead_camera()
    eighth_turn_z = [0, 0, np.sin(np.pi / 8), np.cos(np.pi / 8)]  # 45 degrees about z
    polygons, visible = camera.box_regions([[0, 0, 0]], [eighth_turn_z], [[2, 2, 0.01]])
    radius = np.sqrt(2) * F_720 / 9.995  # corners now on the axes
    vertices = np.array(distinct_vertices(polygons[0]))
    assert visible.all()
    np.testing.assert_allclose(np.sort(np.abs(vertices - [640, 360]).max(axis=1)),
                               [radius] * 4, rtol=1e-8)


def test_boxes_behind_across_or_around_the_camera_have_no_region():
    camera = overhead_camera()
    polygons, visible = camera.box_regions(
        [[0, 0, 20], [3, 0, 10], [0, 0, 10], [0, 0, 0]], [IDENTITY] * 4,
        [[1, 1, 1], [1, 1, 0.5], [4, 4, 4], [1, 1, 1]])
    # Behind, straddling the eye's depth, containing the eye, in front.
    assert visible.tolist() == [False, False, False, True]
    assert np.all(np.isnan(polygons[:3]))


def test_regions_are_cut_to_the_render_panel():
    camera = overhead_camera(screen_offset=(10, 20))
    # Half width of the view at 9.995 m is 640 / f * 9.995 = 7.36 m.
    polygons, visible = camera.box_regions(
        [[7.5, 0, 0], [30, 0, 0]], [IDENTITY] * 2, [[2, 2, 0.01], [2, 2, 0.01]])
    assert visible.tolist() == [True, False]
    inside = polygons[0]
    assert inside[:, 0].max() == pytest.approx(10 + 1280)
    # Off-axis, the box's inner side face shows: its left edge is the bottom face's
    # (z = -0.005, 10.005 m deep).
    assert inside[:, 0].min() == pytest.approx(10 + 640 + 6.5 * F_720 / 10.005)
    unclipped, visible = camera.box_regions(
        [[7.5, 0, 0], [30, 0, 0]], [IDENTITY] * 2, [[2, 2, 0.01], [2, 2, 0.01]], clip=False)
    assert visible.tolist() == [True, True]
    assert unclipped[0, :, 0].max() > 10 + 1280


def test_clip_polygons_keeps_exactly_the_part_on_the_panel():
    rng = np.random.default_rng(7)
    camera = RvizCamera.from_look_at([0, -6, 8], [0, 0, 0], [0, 0, 1], image_size=(640, 480))
    count = 200
    positions = rng.uniform(-8, 8, size=(count, 3)) * [1, 1, 0.2]
    quaternions = rng.normal(size=(count, 4))
    scales = rng.uniform(0.2, 4.0, size=(count, 3))
    hulls, seen = camera.box_regions(positions, quaternions, scales, clip=False)
    clipped, on_panel = clip_polygons(hulls, 640, 480)
    assert seen.sum() > 100 and on_panel.sum() > 50
    assert not np.any(on_panel & ~seen)
    points = rng.uniform([-100, -100], [740, 580], size=(4000, 2))
    in_panel = (points[:, 0] >= 0) & (points[:, 0] <= 640) & \
        (points[:, 1] >= 0) & (points[:, 1] <= 480)
    expected = geometry.points_in_convex_polygons(points, hulls, 1e-6) & in_panel[:, None]
    got = geometry.points_in_convex_polygons(points, clipped, 1e-6)
    np.testing.assert_array_equal(got, expected)
    finite = clipped[on_panel]
    assert finite[..., 0].min() >= -1e-9 and finite[..., 0].max() <= 640 + 1e-9
    assert finite[..., 1].min() >= -1e-9 and finite[..., 1].max() <= 480 + 1e-9
    assert np.all(geometry.polygon_signed_area(finite) < 0)


def test_many_markers_at_once_match_one_at_a_time():
    rng = np.random.default_rng(11)
    camera = overhead_camera()
    positions = rng.uniform(-5, 5, size=(30, 3)) * [1, 1, 0.1]
    quaternions = rng.normal(size=(30, 4))
    scales = rng.uniform(0.1, 1.0, size=(30, 3))
    together, visible = camera.box_regions(positions, quaternions, scales)
    for row in range(30):
        alone, alone_visible = camera.box_regions(positions[row:row + 1],
                                                  quaternions[row:row + 1], scales[row:row + 1])
        assert alone_visible[0] == visible[row]
        if visible[row]:
            assert distinct_vertices(alone[0]) == distinct_vertices(together[row])


def test_pose_and_look_at_give_the_same_camera():
    position, quaternion = look_at_pose([3, -4, 5], [1, 1, 0], [0, 0, 1])
    by_pose = RvizCamera.from_pose(position, quaternion, image_size=(1280, 720))
    by_look_at = RvizCamera.from_look_at([3, -4, 5], [1, 1, 0], [0, 0, 1], image_size=(1280, 720))
    np.testing.assert_allclose(by_pose.projection, by_look_at.projection, atol=1e-9)
    moved = by_pose.with_look_at([0, 0, 10], [0, 0, 0], [0, 1, 0])
    np.testing.assert_allclose(moved.project([[1, 0, 0]])[0], [[640 + F_720 / 10, 360]])


@pytest.mark.parametrize('kwargs, message', [
    ({'image_size': (0, 720)}, 'image size'),
    ({'screen_offset': (np.nan, 0)}, 'screen offset'),
    ({'external': np.diag([2.0, 1.0, 1.0, 1.0])}, 'rigid'),
])
def test_camera_rejects_bad_parts(kwargs, message):
    with pytest.raises(ValueError, match=message):
        RvizCamera(rviz_intrinsic(1280, 720), **kwargs)
