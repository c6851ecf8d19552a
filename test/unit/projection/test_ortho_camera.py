"""Orthographic camera (RViz2 TopDownOrtho): projection, regions, rays, report (pure)."""

import numpy as np
import pytest

from eye_bci_ros2.projection import calibration, geometry
from eye_bci_ros2.projection.camera_model import OrthographicCamera, RvizCamera, top_down_external

W, H = 1280, 720
IDENTITY = [0.0, 0.0, 0.0, 1.0]


def top_down(x=10.0, y=6.0, angle=0.0, scale=40.0, offset=(0.0, 0.0)):
    return OrthographicCamera.top_down(x, y, angle, scale, (W, H), offset)


def hull_area(points):
    """Area of the convex hull of 2-D points, by the monotone chain (independent of the model)."""
    index = geometry._convex_hull_indices(points.tolist())
    return abs(geometry.polygon_signed_area(points[index]))


def test_top_down_view_maps_metres_to_scale_pixels_around_the_centre():
    camera = top_down(angle=0.0, scale=40.0)
    uv, depth = camera.project([[10.0, 6.0, 0.0], [11.0, 6.0, 0.0], [10.0, 7.0, 0.0],
                                [10.0, 6.0, 3.0]])
    np.testing.assert_allclose(uv, [[640, 360], [680, 360], [640, 320], [640, 360]])
    np.testing.assert_allclose(depth, [500, 500, 500, 497])   # camera 500 m above the target
    np.testing.assert_allclose(camera.eye, [10.0, 6.0, 500.0])


def test_angle_turns_the_map_about_z():
    # Angle pi/2: the camera's right is world +y, its up world -x.
    camera = top_down(angle=np.pi / 2, scale=10.0)
    uv, _ = camera.project([[10.0, 7.0, 0.0], [9.0, 6.0, 0.0]])
    np.testing.assert_allclose(uv, [[650, 360], [640, 350]], atol=1e-9)


def test_points_above_the_camera_plane_are_not_drawn():
    uv, depth = top_down().project([[10.0, 6.0, 600.0]])
    assert depth[0] < 0 and np.all(np.isnan(uv))


def test_flat_box_region_is_its_rectangle_in_screen_px():
    camera = top_down(scale=40.0, offset=(100.0, 50.0))
    polygons, visible = camera.box_regions([[10.0, 6.0, 0.0]], [IDENTITY], [[2.0, 1.0, 0.1]])
    assert visible.tolist() == [True]
    corners = {(round(u, 9), round(v, 9)) for u, v in polygons[0]}
    assert corners == {(700.0, 390.0), (780.0, 390.0), (780.0, 430.0), (700.0, 430.0)}
    assert geometry.polygon_signed_area(polygons[0]) < 0   # counter-clockwise on the screen


@pytest.mark.parametrize('seed', range(5))
def test_region_is_the_convex_hull_of_the_projected_corners(seed):
    rng = np.random.default_rng(seed)
    # Any orthographic pose, not only top-down: tilted, turned.
    q_camera = rng.normal(size=4)
    q_camera /= np.linalg.norm(q_camera)
    rotation = geometry.quaternion_to_matrix(q_camera)
    camera = OrthographicCamera(25.0, (W, H), (0, 0)).with_pose(
        -rotation[:, 2] * 100.0, q_camera)   # 100 m behind the origin along its own axis
    positions = rng.uniform(-4, 4, size=(30, 3))
    quaternions = rng.normal(size=(30, 4))
    scales = rng.uniform(0.2, 3.0, size=(30, 3))
    polygons, visible = camera.box_regions(positions, quaternions, scales, clip=False)
    assert visible.all()
    corners = geometry.cube_corners_batch(
        positions, quaternions / np.linalg.norm(quaternions, axis=1, keepdims=True), scales)
    uv, _ = camera.project(corners.reshape(-1, 3))
    uv = uv.reshape(30, 8, 2)
    for row in range(30):
        assert abs(geometry.polygon_signed_area(polygons[row])) == pytest.approx(
            hull_area(uv[row]), rel=1e-9)
        inside = geometry.points_in_convex_polygons(uv[row], polygons[row:row + 1], 1e-6)
        assert inside.all()


def test_regions_are_clipped_to_the_panel_and_off_panel_boxes_vanish():
    camera = top_down(scale=10.0)
    # Centre on the left edge (u = 0 at x = 10 - 64), and one wholly off the panel.
    polygons, visible = camera.box_regions(
        [[10.0 - 64.0, 6.0, 0.0], [10.0 - 200.0, 6.0, 0.0]], [IDENTITY, IDENTITY],
        [[4.0, 4.0, 0.1], [4.0, 4.0, 0.1]])
    assert visible.tolist() == [True, False]
    assert np.nanmin(polygons[0][:, 0]) == pytest.approx(0.0)
    assert np.nanmax(polygons[0][:, 0]) == pytest.approx(20.0)
    assert np.all(np.isnan(polygons[1]))


def test_a_box_through_the_camera_plane_has_no_region():
    _, visible = top_down().box_regions([[10.0, 6.0, 500.0]], [IDENTITY], [[1.0, 1.0, 1.0]])
    assert visible.tolist() == [False]


def test_back_projection_rays_are_parallel_and_hit_their_pixels():
    camera = top_down(angle=0.7, scale=33.0)
    pixels = np.array([[0.0, 0.0], [640.0, 360.0], [1279.0, 719.0], [100.5, 600.25]])
    origins, directions = camera.back_project(pixels)
    np.testing.assert_allclose(directions, np.tile([0.0, 0.0, -1.0], (4, 1)), atol=1e-12)
    np.testing.assert_allclose(origins[:, 2], 500.0)
    for t in (1.0, 250.0, 499.0):
        uv, depth = camera.project(origins + t * directions)
        np.testing.assert_allclose(uv, pixels, atol=1e-9)
        np.testing.assert_allclose(depth, t)


def test_perspective_back_projection_round_trips_too():
    camera = RvizCamera.from_look_at([10, -2, 17], [10, 6, 0], [0, 0, 1])
    pixels = np.array([[0.0, 0.0], [640.0, 360.0], [1000.0, 700.0]])
    origins, directions = camera.back_project(pixels)
    uv, depth = camera.project(origins + 5.0 * directions)
    np.testing.assert_allclose(uv, pixels, atol=1e-9)
    assert np.all(depth > 0)


def test_calibration_report_reads_the_orthographic_projection():
    camera = top_down(angle=0.3, scale=20.0)
    points = np.random.default_rng(1).uniform([0, 0, 0], [20, 12, 2], size=(12, 3))
    pixels, _ = camera.project(points)
    report = calibration.residuals(camera.projection, points, pixels)
    assert report.maximum == pytest.approx(0.0, abs=1e-9)
    shifted = calibration.residuals(camera.projection, points, pixels + [3.0, 4.0])
    assert shifted.rms == pytest.approx(5.0)


def test_orthographic_fit_recovers_scale_and_centre_from_three_points():
    external = top_down_external(10.0, 6.0, 0.4)
    truth = OrthographicCamera(17.5, (W, H), (0, 0), external)
    points = np.array([[9.0, 5.0, 0.0], [12.0, 5.5, 0.3], [10.0, 9.0, 0.0]])
    pixels, _ = truth.project(points)
    fitted = calibration.fit_orthographic(points, pixels + [2.0, -1.0], external)
    np.testing.assert_allclose(fitted, [[17.5, 0, 0, 642.0], [0, 17.5, 0, 359.0], [0, 0, 0, 1]],
                               atol=1e-9)


def test_bad_orthographic_cameras_are_refused():
    with pytest.raises(ValueError, match='positive'):
        OrthographicCamera(0.0, (W, H))
    with pytest.raises(ValueError, match='finite'):
        top_down(x=np.nan)
    with pytest.raises(ValueError, match='orthographic intrinsic'):
        geometry.project_points_orthographic([[0, 0, 0]], np.eye(3, 4), np.eye(4))
