"""Calibration core: analytic RViz intrinsic, DLT, direct fits, residuals, diagnoses."""

import math

import numpy as np
import pytest

from bench.calibration_protocol import run_protocol
from eye_bci_ros2.projection import calibration
from eye_bci_ros2.projection.geometry import look_at, project_points

K_720 = calibration.rviz_intrinsic(1280, 720)
EXTERNAL = look_at([-7.0, -6.0, 8.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
SECOND = look_at([6.0, -8.0, 5.5], [1.0, 0.5, 0.0], [0.0, 0.0, 1.0])


def scene(count=10, max_height=2.0, seed=1):
    """Map points around the origin, heights in [0, max_height] m, and their exact pixels."""
    rng = np.random.default_rng(seed)
    points = np.column_stack([rng.uniform(-3.0, 3.0, (count, 2)),
                              rng.uniform(0.0, max_height, count)])
    pixels, depth = project_points(points, K_720, EXTERNAL)
    assert np.all(depth > 0)
    return points, pixels


def test_rviz_intrinsic_is_the_ogre_pinhole():
    intrinsic = calibration.rviz_intrinsic(1280, 720)
    assert intrinsic.shape == (3, 4)
    # (720 / 2) / tan(22.5 deg) = 869.1169 px.
    np.testing.assert_allclose(intrinsic, [[869.1168824543, 0, 640, 0],
                                           [0, 869.1168824543, 360, 0],
                                           [0, 0, 1, 0]], rtol=1e-10)
    assert calibration.rviz_intrinsic(1920, 1080)[0, 0] == pytest.approx(1303.6753, abs=1e-3)
    # At 90 deg the focal length is half the height.
    assert calibration.rviz_intrinsic(800, 600, 90.0)[1, 1] == pytest.approx(300.0)


@pytest.mark.parametrize('args', [(0, 720), (1280, -1), (math.nan, 720), (1280, 720, 0.0),
                                  (1280, 720, 180.0)])
def test_rviz_intrinsic_rejects_bad_panels(args):
    with pytest.raises(ValueError, match='positive|fov_y_deg'):
        calibration.rviz_intrinsic(*args)


def test_dlt_is_exact_on_noiseless_points():
    points, pixels = scene()
    projection = calibration.fit_projection(points, pixels)
    assert projection[2, 3] == 1.0
    true = K_720 @ EXTERNAL
    np.testing.assert_allclose(projection, true / true[2, 3], rtol=1e-8, atol=1e-8)
    assert calibration.pixel_errors(projection, points, pixels).max() < 1e-6
    np.testing.assert_allclose(calibration.intrinsic_from_projection(projection, EXTERNAL),
                               K_720, atol=1e-6)


@pytest.mark.parametrize('scale', [1.0, 1e-3, -2.5])
def test_intrinsic_from_projection_reproduces_the_intrinsic(scale):
    intrinsic = np.array([[900.0, 1.5, 630.0, 0.0], [0.0, 880.0, 370.0, 0.0], [0, 0, 1, 0]])
    recovered = calibration.intrinsic_from_projection(scale * intrinsic @ EXTERNAL, EXTERNAL)
    np.testing.assert_allclose(recovered, intrinsic, atol=1e-9)
    # Normalised so depths are positive: usable by geometry.project_points.
    _, depth = project_points(scene()[0], recovered, EXTERNAL)
    assert np.all(depth > 0)


@pytest.mark.parametrize('model', ['rviz', 'full'])
def test_fit_intrinsic_with_three_points(model):
    points, pixels = scene(count=3)
    np.testing.assert_allclose(calibration.fit_intrinsic(points, pixels, EXTERNAL, model),
                               K_720, atol=1e-6)


@pytest.mark.parametrize('model', ['rviz', 'full'])
def test_fit_intrinsic_on_a_flat_map(model):
    points, pixels = scene(count=6, max_height=0.0)
    assert np.all(points[:, 2] == 0.0)
    np.testing.assert_allclose(calibration.fit_intrinsic(points, pixels, EXTERNAL, model),
                               K_720, atol=1e-6)


def test_fits_recover_the_intrinsic_from_noisy_readings():
    points, pixels = scene(count=40, seed=3)
    noisy = pixels + np.random.default_rng(4).normal(0.0, 1.0, pixels.shape)
    rviz = calibration.intrinsic_parameters(calibration.fit_intrinsic(points, noisy, EXTERNAL))
    assert rviz['fx'] == rviz['fy'] == pytest.approx(869.117, rel=0.01)
    assert (rviz['cx'], rviz['cy']) == (pytest.approx(640, abs=2), pytest.approx(360, abs=2))
    full = calibration.intrinsic_parameters(
        calibration.fit_intrinsic(points, noisy, EXTERNAL, 'full'))
    assert full['fx'] == pytest.approx(869.117, rel=0.02)
    assert full['fy'] == pytest.approx(869.117, rel=0.02)
    assert abs(full['skew']) < 10
    dlt = calibration.intrinsic_parameters(calibration.intrinsic_from_projection(
        calibration.fit_projection(points, noisy), EXTERNAL))
    assert dlt['fy'] == pytest.approx(869.117, rel=0.05)
    assert (dlt['cx'], dlt['cy']) == (pytest.approx(640, abs=20), pytest.approx(360, abs=20))


@pytest.mark.parametrize('method', ['rviz', 'full', 'dlt'])
def test_calibrate_reports_fit_and_held_out_residuals(method):
    points, pixels = scene(count=20, seed=5)
    noisy = pixels + np.random.default_rng(6).normal(0.0, 1.0, pixels.shape)
    mask = np.arange(20) < 14
    result = calibration.calibrate(points, noisy, EXTERNAL, method, mask)
    assert result.method == method
    assert (result.fit.count, result.held_out.count) == (14, 6)
    np.testing.assert_array_equal(result.fit.errors, result.errors[mask])
    # Residuals are at the reading-noise level (2-D, sigma 1 px per axis).
    assert 0.3 < result.fit.rms < 2.5
    assert result.held_out.maximum < 8.0
    assert result.fit.maximum == pytest.approx(result.errors[mask].max())
    second, _ = project_points(points, K_720, SECOND)
    assert result.evaluate(points, second, SECOND).rms < 5.0


def test_residual_helpers():
    points, pixels = scene(count=4)
    shifted = pixels + np.array([[3.0, 4.0], [0.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    errors = calibration.pixel_errors(K_720 @ EXTERNAL, points, shifted)
    np.testing.assert_allclose(errors, [5.0, 0.0, 1.0, 0.0], atol=1e-9)
    stats = calibration.residuals(K_720 @ EXTERNAL, points, shifted)
    assert stats.maximum == pytest.approx(5.0)
    assert stats.rms == pytest.approx(math.sqrt(26.0 / 4))
    assert math.isnan(calibration.Residuals(np.zeros(0)).rms)
    # Any scale or sign of the projection gives the same pixels.
    np.testing.assert_allclose(calibration.project(-0.01 * K_720 @ EXTERNAL, points), pixels)


def _points_on_a_line(count):
    return np.column_stack([np.arange(count), 2.0 * np.arange(count), np.ones(count)])


POINTS, PIXELS = scene()
FLAT_POINTS, FLAT_PIXELS = scene(max_height=0.0)
DUPLICATED = np.vstack([POINTS[:7], POINTS[2:3]])
# The camera turned 90 deg about its x axis.
TURNED = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])


@pytest.mark.parametrize('call, message', [
    (lambda: calibration.fit_projection(POINTS[:5], PIXELS[:5]), 'at least 6 points'),
    (lambda: calibration.fit_projection(FLAT_POINTS, FLAT_PIXELS), 'coplanar'),
    (lambda: calibration.fit_projection(_points_on_a_line(8), PIXELS[:8]), 'collinear'),
    (lambda: calibration.fit_projection(np.where(np.eye(10, 3) > 0, np.nan, POINTS), PIXELS),
     'NaN'),
    (lambda: calibration.fit_projection(POINTS, np.where(np.eye(10, 2) > 0, np.inf, PIXELS)),
     'NaN or infinite'),
    (lambda: calibration.fit_projection(POINTS, PIXELS[:9]), '10 points but 9 pixels'),
    (lambda: calibration.fit_projection(POINTS[:, :2], PIXELS), r'shape \(N, 3\)'),
    (lambda: calibration.fit_projection(DUPLICATED, PIXELS[:8]), 'points 2 and 7 are the same'),
    (lambda: calibration.fit_intrinsic(DUPLICATED, PIXELS[:8], EXTERNAL), 'same world point'),
    (lambda: calibration.fit_intrinsic(POINTS, PIXELS, look_at([0, 0, 5], [0, 0, 9], [0, 1, 0])),
     'behind the camera'),
    (lambda: calibration.fit_intrinsic(POINTS[:2], PIXELS[:2], EXTERNAL), 'at least 3 points'),
    (lambda: calibration.fit_intrinsic(POINTS[:2], PIXELS[:2], EXTERNAL, 'full'),
     'at least 3 points'),
    (lambda: calibration.fit_intrinsic(POINTS, PIXELS, EXTERNAL, 'affine'), 'model must be'),
    (lambda: calibration.fit_intrinsic(
        np.array([[1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [3.0, 3.0, 3.0]]), PIXELS[:3],
        look_at([0, 0, 0], [1, 1, 1], [0, 0, 1])), 'one ray'),
    (lambda: calibration.fit_intrinsic(
        np.array([[1.0, 0.0, 5.0], [2.0, 0.0, 7.0], [-1.0, 0.0, 9.0]]), PIXELS[:3],
        np.eye(4), 'full'), 'one straight line'),
    (lambda: calibration.fit_intrinsic(POINTS, PIXELS, 2 * EXTERNAL), 'homogeneous transform'),
    (lambda: calibration.fit_intrinsic(POINTS, PIXELS, EXTERNAL * [[1], [1], [3], [1]]),
     'proper rotation'),
    (lambda: calibration.intrinsic_from_projection(K_720 @ EXTERNAL, TURNED @ EXTERNAL),
     'disagree on the viewing direction by 90 deg'),
    (lambda: calibration.intrinsic_from_projection(np.ones((4, 4)), EXTERNAL), r'shape \(3, 4\)'),
    (lambda: calibration.calibrate(POINTS, PIXELS, EXTERNAL, 'rviz', [True] * 3), 'fit_mask'),
])
def test_bad_input_raises_a_clear_value_error(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_flatness_tells_a_flat_map_from_a_3d_cloud():
    assert calibration.flatness(FLAT_POINTS) < 1e-12
    assert calibration.flatness(scene(max_height=0.01)[0]) < 0.01
    assert calibration.flatness(np.random.default_rng(0).uniform(-1, 1, (20, 3))) > 0.3


def test_the_analytic_intrinsic_agrees_with_itself():
    comparison = calibration.compare_with_rviz(K_720, 1280, 720)
    assert comparison.warnings == []
    assert comparison.focal_ratio == pytest.approx(1.0)


def test_hidpi_scaling_is_diagnosed():
    # Pixels read on a 2x HiDPI screenshot but the panel size given in logical px.
    comparison = calibration.compare_with_rviz(calibration.rviz_intrinsic(2560, 1440), 1280, 720)
    assert comparison.focal_ratio == pytest.approx(2.0)
    assert len(comparison.warnings) == 1
    assert 'HiDPI' in comparison.warnings[0]
    assert '2560x1440' in comparison.warnings[0]


def test_wrong_panel_height_is_diagnosed():
    comparison = calibration.compare_with_rviz(calibration.rviz_intrinsic(1280, 800), 1280, 720)
    text = ' '.join(comparison.warnings)
    assert 'about 800 px high' in text and 'image_height' in text
    assert '1280x800' in text


def test_screen_offset_and_width_errors_are_diagnosed():
    shifted = K_720.copy()
    shifted[:2, 2] += [64.0, 30.0]
    (warning,) = calibration.compare_with_rviz(shifted, 1280, 720).warnings
    assert 'X0 +64, Y0 +30' in warning
    wide = calibration.compare_with_rviz(calibration.rviz_intrinsic(1400, 720), 1280, 720)
    assert 'image_width is wrong: a 1400 px wide panel' in wide.warnings[0]
    # Within tolerance: no warning.
    near = K_720.copy()
    near[[0, 1], [0, 1]] *= 1.01
    near[:2, 2] += 2.0
    assert calibration.compare_with_rviz(near, 1280, 720).warnings == []


def test_non_square_pixels_and_skew_are_diagnosed():
    sheared = K_720.copy()
    sheared[0, 0] *= 1.1
    sheared[0, 1] = 40.0
    text = ' '.join(calibration.compare_with_rviz(sheared, 1280, 720).warnings)
    assert 'non-square pixels' in text and 'skew' in text


def test_report_protocol_default_fit_stays_within_1_2_px():
    """The original report's protocol: 10 points, 6 fit, 1 px noise, worst of 10 in view 2."""
    results = run_protocol(trials=200, seed=0)
    for case, by_method in results.items():
        assert by_method['rviz']['median_px'] <= 1.2, case
        assert by_method['rviz']['failures'] == 0, case
    flat, tall = results.values()
    # The 11-parameter DLT cannot use a flat map; with heights it works, but worse.
    assert flat['dlt']['median_px'] > 50.0
    assert tall['rviz']['median_px'] < tall['dlt']['median_px'] < 200.0
