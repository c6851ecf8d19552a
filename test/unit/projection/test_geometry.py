"""Projection geometry checked against values worked out by hand (no ROS)."""

import itertools

import numpy as np
import pytest

from eye_bci_ros2.projection import geometry

SQRT2 = np.sqrt(2.0)

#: A simple pinhole: f = 450 px, principal point (320, 240), no skew.
K_SIMPLE = np.array([[450.0, 0.0, 320.0, 0.0],
                     [0.0, 450.0, 240.0, 0.0],
                     [0.0, 0.0, 1.0, 0.0]])

IDENTITY_XYZW = np.array([0.0, 0.0, 0.0, 1.0])


def quaternion_about(axis, angle_deg):
    """Return the quaternion (x, y, z, w) of a rotation by ``angle_deg`` about ``axis``."""
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    half = np.radians(angle_deg) / 2
    return np.append(axis * np.sin(half), np.cos(half))


def rotate(quaternion_xyzw, vectors):
    """Rotate vectors (N, 3) by q v q* (Hamilton product), independent of geometry.py."""
    q = np.asarray(quaternion_xyzw, dtype=float)
    q = q / np.linalg.norm(q)
    u, w = q[:3], q[3]
    v = np.asarray(vectors, dtype=float)
    return v + 2 * w * np.cross(u, v) + 2 * np.cross(u, np.cross(u, v))


def camera_frame(eye, focus, up):
    """Return forward, right and up-in-image unit vectors of a view, from first principles."""
    forward = np.subtract(focus, eye) / np.linalg.norm(np.subtract(focus, eye))
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    image_up = np.cross(right, forward)
    return forward, right, image_up


def random_view(rng):
    """Draw a random eye, focus and up, well away from degenerate."""
    eye = rng.uniform(-5, 5, 3)
    forward = rng.normal(size=3)
    forward /= np.linalg.norm(forward)
    focus = eye + forward * rng.uniform(1, 8)
    up = rng.normal(size=3)
    while np.linalg.norm(np.cross(up, forward)) < 0.3:
        up = rng.normal(size=3)
    return eye, focus, up


def cross2(o, a, b):
    """Return z of the cross product (a - o) x (b - o) in the plane."""
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def brute_force_hull(points):
    """
    Find the convex-hull vertices of 2-D points by exhaustion.

    A point is a hull vertex unless it lies in a closed triangle of three other
    points (Caratheodory).  Returns the indices in counter-clockwise order
    about their centroid (math orientation) and the hull's absolute area.
    """
    points = np.asarray(points, dtype=float)
    vertices = []
    for k, p in enumerate(points):
        others = [i for i in range(len(points)) if i != k]
        covered = False
        for a, b, c in itertools.combinations(others, 3):
            d = [cross2(points[a], points[b], p), cross2(points[b], points[c], p),
                 cross2(points[c], points[a], p)]
            if not (min(d) < 0 < max(d)):
                covered = True
                break
        if not covered:
            vertices.append(k)
    centre = points[vertices].mean(axis=0)
    angles = [np.arctan2(*(points[i] - centre)[::-1]) for i in vertices]
    ordered = [vertices[i] for i in np.argsort(angles)]
    loop = points[ordered]
    area = 0.5 * abs(np.sum(loop[:, 0] * np.roll(loop[:, 1], -1)
                            - np.roll(loop[:, 0], -1) * loop[:, 1]))
    return ordered, area


def distinct_rows(polygon):
    """Return the distinct vertices of a padded polygon, in order of first appearance."""
    _, first = np.unique(polygon, axis=0, return_index=True)
    return polygon[np.sort(first)]


def shoelace(polygon):
    """Return the signed area of a polygon in (u, v)."""
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


# --- look_at ---------------------------------------------------------------


def test_look_at_along_world_x_by_hand():
    # Looking along +x with z up: right is -y, down is -z, forward is +x.
    external = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    np.testing.assert_allclose(external, [[0, -1, 0, 0],
                                          [0, 0, -1, 0],
                                          [1, 0, 0, 0],
                                          [0, 0, 0, 1]], atol=1e-12)


def test_look_at_down_from_above_by_hand():
    # Eye at (1, 2, 3) looking straight down with +y up in the image:
    # right = +x, down = -y, forward = -z; t = -R P = (-1, 2, 3).
    external = geometry.look_at([1, 2, 3], [1, 2, 0], [0, 1, 0])
    np.testing.assert_allclose(external, [[1, 0, 0, -1],
                                          [0, -1, 0, 2],
                                          [0, 0, -1, 3],
                                          [0, 0, 0, 1]], atol=1e-12)


@pytest.mark.parametrize('seed', range(20))
def test_look_at_conventions_for_random_views(seed):
    rng = np.random.default_rng(seed)
    eye, focus, up = random_view(rng)
    external = geometry.look_at(eye, focus, up)
    rotation, translation = external[:3, :3], external[:3, 3]

    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(external[3], [0, 0, 0, 1])
    forward, right, image_up = camera_frame(eye, focus, up)
    np.testing.assert_allclose(rotation[2], forward, atol=1e-12)
    np.testing.assert_allclose(rotation[0], right, atol=1e-12)
    np.testing.assert_allclose(rotation[1], -image_up, atol=1e-12)
    np.testing.assert_allclose(translation, -rotation @ eye, atol=1e-12)
    # The eye maps to the camera origin, the focus onto the optical axis.
    np.testing.assert_allclose(external @ np.append(eye, 1), [0, 0, 0, 1], atol=1e-12)
    np.testing.assert_allclose((external @ np.append(focus, 1))[:3],
                               [0, 0, np.linalg.norm(focus - eye)], atol=1e-12)

    # What a user sees: `up` points up the screen (smaller v), x = y cross z to the right.
    step = 0.05 * np.linalg.norm(focus - eye)
    uv, depth = geometry.project_points(
        [focus, focus + step * up / np.linalg.norm(up), focus + step * right],
        K_SIMPLE, external)
    assert np.all(depth > 0)
    np.testing.assert_allclose(uv[0], [320, 240], atol=1e-9)
    assert uv[1, 1] < uv[0, 1]
    assert uv[2, 0] > uv[0, 0]
    assert uv[2, 1] == pytest.approx(uv[0, 1], abs=1e-9)


def test_look_at_up_need_not_be_perpendicular_or_unit():
    tilted = geometry.look_at([0, 0, 0], [1, 0, 0], [5, 0, 7])
    straight = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    np.testing.assert_allclose(tilted, straight, atol=1e-12)


@pytest.mark.parametrize('eye, focus, up, message', [
    ([1, 2, 3], [1, 2, 3], [0, 0, 1], 'equals focus'),
    ([0, 0, 0], [1, 1, 0], [-2, -2, 0], 'parallel'),
    ([0, 0, 0], [0, 0, 5], [0, 0, 1], 'parallel'),
    ([0, 0, 0], [1, 0, 0], [0, 0, 0], 'zero'),
    ([np.nan, 0, 0], [1, 0, 0], [0, 0, 1], 'NaN'),
    ([0, 0, 0], [np.inf, 0, 0], [0, 0, 1], 'NaN or infinite'),
    ([0, 0], [1, 0, 0], [0, 0, 1], 'shape'),
    ([0, 0, 0], [1, 0, 0, 0], [0, 0, 1], 'shape'),
])
def test_look_at_rejects_degenerate_views(eye, focus, up, message):
    with pytest.raises(ValueError, match=message):
        geometry.look_at(eye, focus, up)


# --- project_points --------------------------------------------------------


def test_project_points_by_hand_camera_at_origin():
    external = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    # camera = (-y, -z, x): (2, 0, 0) -> (0, 0, 2) -> principal point;
    # (2, -0.5, 0.25) -> (0.5, -0.25, 2) -> u = 320 + 450 * 0.25, v = 240 - 450 * 0.125;
    # (4, 1, -2) -> (-1, 2, 4) -> u = 320 - 112.5, v = 240 + 225.
    uv, depth = geometry.project_points(
        [[2, 0, 0], [2, -0.5, 0.25], [4, 1, -2]], K_SIMPLE, external)
    np.testing.assert_allclose(uv, [[320, 240], [432.5, 183.75], [207.5, 465]], atol=1e-9)
    np.testing.assert_allclose(depth, [2, 2, 4], atol=1e-12)


def test_project_points_by_hand_offset_eye_with_skew():
    # Eye (1, 2, 3) looking down -z (see test above): X -> (x - 1, 2 - y, 3 - z).
    external = geometry.look_at([1, 2, 3], [1, 2, 0], [0, 1, 0])
    intrinsic = np.array([[500.0, 10.0, 300.0, 0.0],
                          [0.0, 400.0, 200.0, 0.0],
                          [0.0, 0.0, 1.0, 0.0]])
    # (1.5, 2.5, 1) -> camera (0.5, -0.5, 2):
    # u = (500 * 0.5 + 10 * -0.5) / 2 + 300 = 422.5, v = 400 * -0.5 / 2 + 200 = 100.
    uv, depth = geometry.project_points(np.array([[1.5, 2.5, 1.0]]), intrinsic, external)
    np.testing.assert_allclose(uv, [[422.5, 100.0]], atol=1e-9)
    np.testing.assert_allclose(depth, [2.0], atol=1e-12)


def test_project_points_behind_and_at_the_eye_are_nan():
    external = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    uv, depth = geometry.project_points(
        [[-1, 0, 0], [0, 1, 0], [1, 0, 0], [-3, 2, 1]], K_SIMPLE, external)
    np.testing.assert_allclose(depth, [-1, 0, 1, -3], atol=1e-12)
    assert np.all(np.isnan(uv[[0, 1, 3]]))
    np.testing.assert_allclose(uv[2], [320, 240])


@pytest.mark.parametrize('points, intrinsic, external, message', [
    ([[1, 2]], K_SIMPLE, np.eye(4), 'points'),
    ([[1, np.nan, 2]], K_SIMPLE, np.eye(4), 'NaN'),
    ([[1, 2, 3]], np.eye(3), np.eye(4), 'intrinsic must be a 3x4'),
    ([[1, 2, 3]], K_SIMPLE, np.eye(4)[:3], 'external must be a 4x4'),
    ([[1, 2, 3]], K_SIMPLE * np.nan, np.eye(4), 'intrinsic contains NaN'),
])
def test_project_points_rejects_bad_input(points, intrinsic, external, message):
    with pytest.raises(ValueError, match=message):
        geometry.project_points(points, intrinsic, external)


# --- cube_corners ----------------------------------------------------------


def test_cube_corners_identity_by_hand():
    corners = geometry.cube_corners([1, 2, 3], IDENTITY_XYZW, [2, 4, 6])
    expected = [[x, y, z] for z in (0, 6) for y in (0, 4) for x in (0, 2)]
    np.testing.assert_allclose(corners, expected, atol=1e-12)
    # Corner order is documented: bit 0 is +x, bit 1 +y, bit 2 +z.
    np.testing.assert_allclose(corners[0], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(corners[1], [2, 0, 0], atol=1e-12)
    np.testing.assert_allclose(corners[6], [0, 4, 6], atol=1e-12)


def test_cube_corners_quarter_turn_about_z_swaps_extents():
    corners = geometry.cube_corners([0, 0, 0], quaternion_about([0, 0, 1], 90), [1, 3, 5])
    np.testing.assert_allclose(np.ptp(corners, axis=0), [3, 1, 5], atol=1e-12)
    # Local +x becomes world +y: corner 1 (+x, -y, -z) = (1.5, 0.5, -2.5) after the turn.
    np.testing.assert_allclose(corners[1], [1.5, 0.5, -2.5], atol=1e-12)


def test_cube_corners_eighth_turn_about_z_by_hand():
    corners = geometry.cube_corners([10, 0, 0], quaternion_about([0, 0, 1], 45), [2, 2, 2])
    # Local (+-1, +-1) turns into the diamond (0, -r), (r, 0), (-r, 0), (0, r), r = sqrt 2.
    diamond = [[10, -SQRT2], [10 + SQRT2, 0], [10 - SQRT2, 0], [10, SQRT2]]
    np.testing.assert_allclose(corners[:4, :2], diamond, atol=1e-12)
    np.testing.assert_allclose(corners[4:, :2], diamond, atol=1e-12)
    np.testing.assert_allclose(corners[:, 2], [-1] * 4 + [1] * 4, atol=1e-12)


def test_cube_corners_normalises_quaternion():
    q = quaternion_about([1, 2, 3], 70)
    np.testing.assert_allclose(geometry.cube_corners([1, 1, 1], 7.5 * q, [1, 2, 3]),
                               geometry.cube_corners([1, 1, 1], q, [1, 2, 3]), atol=1e-12)


def test_cube_corners_batch_matches_single_and_rotation_reference():
    rng = np.random.default_rng(3)
    positions = rng.normal(size=(5, 3))
    quaternions = rng.normal(size=(5, 4))
    scales = rng.uniform(0.1, 2, (5, 3))
    batch = geometry.cube_corners_batch(positions, quaternions, scales)
    assert batch.shape == (5, 8, 3)
    for m in range(5):
        np.testing.assert_allclose(
            batch[m], geometry.cube_corners(positions[m], quaternions[m], scales[m]))
        local = geometry.CORNER_SIGNS * scales[m] / 2
        np.testing.assert_allclose(batch[m], positions[m] + rotate(quaternions[m], local),
                                   atol=1e-12)


@pytest.mark.parametrize('position, quaternion, scale, message', [
    ([0, 0, 0], [0, 0, 0, 0], [1, 1, 1], 'zero length'),
    ([0, 0, 0], IDENTITY_XYZW, [1, 0, 1], 'positive'),
    ([0, 0, 0], IDENTITY_XYZW, [1, -2, 1], 'positive'),
    ([0, 0], IDENTITY_XYZW, [1, 1, 1], 'position'),
    ([0, 0, 0], [0, 0, 1], [1, 1, 1], 'quaternion'),
    ([0, 0, 0], IDENTITY_XYZW, [1, 1], 'scale'),
    ([0, 0, np.nan], IDENTITY_XYZW, [1, 1, 1], 'NaN'),
])
def test_cube_corners_rejects_bad_input(position, quaternion, scale, message):
    with pytest.raises(ValueError, match=message):
        geometry.cube_corners(position, quaternion, scale)


def test_cube_corners_batch_rejects_mismatched_counts():
    with pytest.raises(ValueError, match='one of each per marker'):
        geometry.cube_corners_batch(np.zeros((2, 3)), np.tile(IDENTITY_XYZW, (3, 1)),
                                    np.ones((2, 3)))


# --- box_silhouettes -------------------------------------------------------


def silhouettes(positions, quaternions, scales, external, intrinsic=K_SIMPLE):
    """Call box_silhouettes with (M, ...) arrays built from lists."""
    return geometry.box_silhouettes(np.reshape(positions, (-1, 3)),
                                    np.reshape(quaternions, (-1, 4)),
                                    np.reshape(scales, (-1, 3)), intrinsic, external)


def test_face_on_cube_shows_its_front_square():
    external = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    polygons, visible = silhouettes([5, 0, 0], IDENTITY_XYZW, [1, 1, 1], external)
    assert polygons.shape == (1, 6, 2)
    assert visible.tolist() == [True]
    # Front face x = 4.5, y, z = +-0.5: u = 320 -+ 450 * 0.5 / 4.5 = 320 -+ 50, same for v.
    square = distinct_rows(polygons[0])
    assert len(square) == 4
    assert sorted(map(tuple, square)) == [(270, 190), (270, 290), (370, 190), (370, 290)]
    # Counter-clockwise as a person sees it: negative shoelace area in (u, v).
    assert shoelace(square) == pytest.approx(-100 * 100)
    # The padding repeats the last vertex.
    np.testing.assert_array_equal(polygons[0, 4:], polygons[0, [3, 3]])


@pytest.mark.parametrize('eye', [[3, 3, 3], [-4, 2.5, 3.5], [2, -3, -2.5]])
def test_cube_seen_from_a_corner_is_a_hexagon(eye):
    external = geometry.look_at(eye, [0, 0, 0], [0, 0, 1])
    polygons, visible = silhouettes([0, 0, 0], IDENTITY_XYZW, [1, 1, 1], external)
    assert visible.tolist() == [True]
    assert len(distinct_rows(polygons[0])) == 6
    assert shoelace(polygons[0]) < 0


def test_cube_seen_along_an_edge_is_a_hexagon():
    external = geometry.look_at([3, 3, 0.1], [0, 0, 0], [0, 0, 1])
    polygons, _ = silhouettes([0, 0, 0], IDENTITY_XYZW, [1, 1, 1], external)
    assert len(distinct_rows(polygons[0])) == 6


def random_boxes_in_view(rng, eye, focus, count):
    """Scatter boxes around the view direction; some straddle the eye plane."""
    forward = (focus - eye) / np.linalg.norm(focus - eye)
    directions = forward + rng.normal(scale=0.5, size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    positions = eye + directions * rng.uniform(0.3, 12, (count, 1))
    return positions, rng.normal(size=(count, 4)), rng.uniform(0.05, 3, (count, 3))


def test_outline_is_the_true_convex_hull_for_random_boxes_and_cameras():
    rng = np.random.default_rng(2024)
    checked = hidden = 0
    for _ in range(25):
        eye, focus, up = random_view(rng)
        external = geometry.look_at(eye, focus, up)
        fx, fy, skew, cx, cy = rng.uniform([300, 300, -20, 0, 0], [900, 900, 20, 800, 600])
        intrinsic = np.array([[fx, skew, cx, 0], [0, fy, cy, 0], [0, 0, 1, 0]])
        positions, quaternions, scales = random_boxes_in_view(rng, eye, focus, 12)
        polygons, visible = geometry.box_silhouettes(positions, quaternions, scales,
                                                     intrinsic, external)
        forward = (focus - eye) / np.linalg.norm(focus - eye)
        for m in range(len(positions)):
            local = geometry.CORNER_SIGNS * scales[m] / 2
            corners = positions[m] + rotate(quaternions[m], local)
            eye_local = rotate(quaternions[m] * [-1, -1, -1, 1], [eye - positions[m]])[0]
            contains_eye = np.all(np.abs(eye_local) <= scales[m] / 2)
            in_front = np.all((corners - eye) @ forward > 1e-6)
            assert visible[m] == (in_front and not contains_eye)
            if not visible[m]:
                assert np.all(np.isnan(polygons[m]))
                hidden += 1
                continue
            checked += 1
            uv, _ = geometry.project_points(corners, intrinsic, external)
            outline = distinct_rows(polygons[m])
            # Every outline vertex is one of the projected corners ...
            gaps = np.linalg.norm(outline[:, None] - uv[None], axis=2).min(axis=1)
            assert np.all(gaps < 1e-6 * (1 + np.abs(uv).max()))
            # ... and they are exactly the hull's vertices, in a convex loop.
            hull, hull_area = brute_force_hull(uv)
            assert len(outline) == len(hull)
            nearest = np.linalg.norm(uv[hull][:, None] - outline[None], axis=2).min(axis=1)
            assert np.all(nearest < 1e-6 * (1 + np.abs(uv).max()))
            assert -shoelace(outline) == pytest.approx(hull_area, rel=1e-9)
            # All corners inside or on the outline.
            slack = 1e-9 * (1 + np.abs(uv).max()) ** 2
            inside = geometry.points_in_convex_polygons(uv, polygons[m:m + 1], tolerance=slack)
            assert inside.all()
    # The random scene exercised both branches.
    assert checked >= 100 and hidden >= 10


def test_boxes_behind_or_around_the_eye_are_invisible():
    external = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    positions = [[5, 0, 0],      # in front
                 [0.2, 2, 0],    # straddles the eye plane, beside the eye
                 [-5, 0, 0],     # wholly behind
                 [0, 0, 0],      # contains the eye
                 [0.5, 0, 0]]    # contains the eye, mostly in front
    polygons, visible = silhouettes(positions, np.tile(IDENTITY_XYZW, (5, 1)),
                                    np.tile([1.0, 1.0, 1.0], (5, 1)) * [[1], [1], [1], [2], [2]],
                                    external)
    assert visible.tolist() == [True, False, False, False, False]
    assert np.all(np.isfinite(polygons[0]))
    assert np.all(np.isnan(polygons[1:]))


def test_mirrored_intrinsic_keeps_screen_winding():
    # A calibrated intrinsic can flip an axis (fy < 0); the outline still winds image-CCW.
    mirrored = K_SIMPLE * [[1], [-1], [1]]
    external = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    polygons, visible = silhouettes([5, 0, 0], IDENTITY_XYZW, [1, 1, 1], external, mirrored)
    assert visible.tolist() == [True]
    assert shoelace(polygons[0]) == pytest.approx(-100 * 100)
    np.testing.assert_array_equal(polygons[0, 4:], polygons[0, [3, 3]])


def test_box_silhouettes_accepts_lists_and_checks_shapes():
    external = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    polygons, visible = geometry.box_silhouettes([[5, 0, 0]], [[0, 0, 0, 1]], [[1, 1, 1]],
                                                 K_SIMPLE.tolist(), external.tolist())
    assert visible.tolist() == [True]
    with pytest.raises(ValueError, match='external'):
        geometry.box_silhouettes([[5, 0, 0]], [[0, 0, 0, 1]], [[1, 1, 1]], K_SIMPLE,
                                 external[:3])
    with pytest.raises(ValueError, match='positive'):
        geometry.box_silhouettes([[5, 0, 0]], [[0, 0, 0, 1]], [[1, 0, 1]], K_SIMPLE, external)
    with pytest.raises(ValueError, match='one of each per marker'):
        geometry.box_silhouettes([[5, 0, 0], [6, 0, 0]], [[0, 0, 0, 1]], [[1, 1, 1]] * 2,
                                 K_SIMPLE, external)


# --- PolygonSet / points_in_convex_polygons --------------------------------

SQUARE = [[0, 0], [10, 0], [10, 10], [0, 10]]
TRIANGLE = [[0, 0], [4, 0], [0, 4]]


def padded(polygon, size=6):
    """Repeat the last vertex up to ``size`` vertices."""
    return list(polygon) + [polygon[-1]] * (size - len(polygon))


@pytest.mark.parametrize('reverse', [False, True])
def test_point_in_square_both_windings(reverse):
    square = SQUARE[::-1] if reverse else SQUARE
    points = [[5, 5], [10, 5], [0, 0], [10, 10], [11, 5], [-0.001, 5], [5, 10.001]]
    inside = geometry.points_in_convex_polygons(points, [square])
    assert inside[:, 0].tolist() == [True, True, True, True, False, False, False]


@pytest.mark.parametrize('reverse', [False, True])
def test_point_in_triangle_both_windings(reverse):
    triangle = TRIANGLE[::-1] if reverse else TRIANGLE
    points = [[1, 1], [2, 2], [2.01, 2.01], [3, -0.1], [0, 4], [-0.1, 1]]
    inside = geometry.PolygonSet([triangle]).contains(points)
    assert inside[:, 0].tolist() == [True, True, False, False, True, False]


def test_padded_polygons_and_nan_polygon_and_nan_point():
    polygons = np.array([padded(SQUARE), padded(TRIANGLE), padded(TRIANGLE[::-1]),
                         np.full((6, 2), np.nan)])
    points = [[1, 1], [8, 8], [np.nan, 1], [0, 0]]
    inside = geometry.PolygonSet(polygons).contains(points)
    assert inside.tolist() == [[True, True, True, False],
                               [True, False, False, False],
                               [False, False, False, False],
                               [True, True, True, False]]
    np.testing.assert_array_equal(inside,
                                  geometry.points_in_convex_polygons(points, polygons))


def test_one_point_test_matches_the_batch_test_on_edges_nan_and_padding():
    # The per-sample path (contains_one) answers as contains does for the same point.
    rng = np.random.default_rng(7)
    polygons = np.array([padded(SQUARE), padded(TRIANGLE), padded(TRIANGLE[::-1]),
                         np.full((6, 2), np.nan), padded([[2, 2], [12, 2], [12, 12], [2, 12]])])
    points = np.concatenate([rng.uniform(-2, 14, (400, 2)),
                             [[0, 5], [10, 10], [2, 2], [4, 0], [2, 2.0000001], [np.nan, 1],
                              [np.inf, 0], [-np.inf, np.inf]]])
    prepared = geometry.PolygonSet(polygons)
    with np.errstate(invalid='ignore', over='ignore'):
        batch = prepared.contains(points)
    one = [prepared.contains_one(x, y) for x, y in points.tolist()]
    np.testing.assert_array_equal(batch, one)
    assert batch.any(axis=0).tolist() == [True, True, True, False, True]


def test_polygon_set_rejects_wrong_shapes():
    with pytest.raises(ValueError, match='polygons'):
        geometry.PolygonSet(np.zeros((4, 2)))
    with pytest.raises(ValueError, match='points'):
        geometry.PolygonSet([SQUARE]).contains(np.zeros((4, 3)))


def test_polygon_set_matches_silhouettes_of_visible_boxes():
    # The regions the arbiter tests gaze against.  The cube at world y = 2 (to the
    # left) shows its front face at u in 320 - 450 * [2.5, 1.5] / 4.5 = [70, 170].
    external = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    polygons, _ = silhouettes([[5, 0, 0], [5, 2, 0]], np.tile(IDENTITY_XYZW, (2, 1)),
                              np.ones((2, 3)), external)
    inside = geometry.PolygonSet(polygons).contains([[320, 240], [120, 240], [0, 0]])
    assert inside.tolist() == [[True, False], [False, True], [False, False]]


# --- back_project ----------------------------------------------------------


CALIBRATED = np.array([[610.0, 3.0, 330.0, 12.0],
                       [0.0, 590.0, 250.0, -7.0],
                       [0.0, 0.0, 1.0, 0.05]])


@pytest.mark.parametrize('intrinsic', [K_SIMPLE, CALIBRATED], ids=['analytic', 'calibrated'])
def test_back_project_round_trip(intrinsic):
    rng = np.random.default_rng(7)
    eye, focus, up = random_view(rng)
    external = geometry.look_at(eye, focus, up)
    pixels = rng.uniform([0, 0], [640, 480], (20, 2))
    origin, directions = geometry.back_project(pixels, intrinsic, external)
    assert directions.shape == (20, 3)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1, atol=1e-12)
    if intrinsic is K_SIMPLE:
        np.testing.assert_allclose(origin, eye, atol=1e-9)
    for t in (0.5, 3.0, 40.0):
        uv, depth = geometry.project_points(origin + t * directions, intrinsic, external)
        assert np.all(depth > 0)
        np.testing.assert_allclose(uv, pixels, atol=1e-6)


def test_back_project_principal_point_looks_at_focus():
    eye, focus = np.array([1.0, -2.0, 0.5]), np.array([4.0, 2.0, 1.5])
    external = geometry.look_at(eye, focus, [0, 0, 1])
    origin, directions = geometry.back_project([[320, 240]], K_SIMPLE, external)
    np.testing.assert_allclose(origin, eye, atol=1e-12)
    np.testing.assert_allclose(directions[0], (focus - eye) / np.linalg.norm(focus - eye),
                               atol=1e-12)


def test_back_project_rejects_bad_input():
    external = geometry.look_at([0, 0, 0], [1, 0, 0], [0, 0, 1])
    with pytest.raises(ValueError, match='pixels'):
        geometry.back_project([[1, 2, 3]], K_SIMPLE, external)
    with pytest.raises(ValueError, match='singular'):
        geometry.back_project([[1, 2]], np.zeros((3, 4)), external)
    with pytest.raises(ValueError, match='intrinsic'):
        geometry.back_project([[1, 2]], np.eye(3), external)


# --- external_from_pose / quaternions --------------------------------------


@pytest.mark.parametrize('seed', range(5))
def test_external_from_pose_matches_look_at(seed):
    rng = np.random.default_rng(100 + seed)
    eye, focus, up = random_view(rng)
    external = geometry.look_at(eye, focus, up)
    quaternion = geometry.matrix_to_quaternion(external[:3, :3].T)
    assert quaternion[3] >= 0
    np.testing.assert_allclose(geometry.external_from_pose(eye, quaternion), external,
                               atol=1e-12)
    # Columns of the camera-to-world rotation are the camera axes, as rotate() sees them.
    np.testing.assert_allclose(rotate(quaternion, np.eye(3)), external[:3, :3], atol=1e-12)


@pytest.mark.parametrize('angle', [0, 90, 179.9, 180, 270])
@pytest.mark.parametrize('axis', [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, -2, 0.5]])
def test_quaternion_matrix_round_trip(axis, angle):
    q = quaternion_about(axis, angle)
    q = q if q[3] >= 0 else -q
    back = geometry.matrix_to_quaternion(geometry.quaternion_to_matrix(q))
    # q and -q are the same rotation; at w == 0 both signs are valid.
    assert np.allclose(back, q, atol=1e-9) or np.allclose(back, -q, atol=1e-9)
