"""Tolerant gaze classification and visual angle, on hand-made geometry (no ROS)."""

import math

import numpy as np
import pytest

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.tolerance import (classify_tolerant, extend_to_nearby, GazeErrorModel,
                                             polygon_distances, TolerantRegions)
from eye_bci_ros2.projection.visual_angle import (DEFAULT_VIEWING, degrees_to_px, px_per_degree_at,
                                                  ScreenGeometry)


def square(cx, cy, side=100.0, pad=0):
    """Square polygon around (cx, cy) px, optionally padded with NaN vertices (4 + pad, 2)."""
    h = side / 2
    corners = [[cx - h, cy - h], [cx + h, cy - h], [cx + h, cy + h], [cx - h, cy + h]]
    return np.array(corners + [[np.nan, np.nan]] * pad)


# Two squares side by side: A spans x 100..200, B spans x 300..400, both y 100..200.
A, B = square(150, 150), square(350, 150)
TWO = np.stack([A, B])


def test_default_viewing_is_a_24_inch_screen_at_65_cm():
    assert DEFAULT_VIEWING.width_mm == pytest.approx(531.3, abs=0.1)
    assert DEFAULT_VIEWING.height_mm == pytest.approx(298.8, abs=0.1)
    assert math.hypot(DEFAULT_VIEWING.width_mm, DEFAULT_VIEWING.height_mm) == pytest.approx(
        24 * 25.4, abs=0.2)
    assert DEFAULT_VIEWING.distance_mm == 650.0


def test_px_per_degree_at_the_centre_is_the_one_degree_size():
    centre = DEFAULT_VIEWING.centre_px
    # 2 D tan(0.5 deg) mm at 1920 / 531.3 px/mm: 41.0 px.
    expected = 2 * 650 * math.tan(math.radians(0.5)) * 1920 / DEFAULT_VIEWING.width_mm
    assert px_per_degree_at(centre) == pytest.approx(expected, rel=2e-3)
    assert px_per_degree_at(centre) == pytest.approx(DEFAULT_VIEWING.px_per_degree(), rel=2e-3)


def test_a_degree_covers_more_pixels_towards_the_corner():
    corner = px_per_degree_at([[0.0, 0.0]])[0]
    centre = px_per_degree_at(DEFAULT_VIEWING.centre_px)
    # r = sqrt(265.6^2 + 149.4^2 + 650^2) = 717.9 mm: (r / D)^1.5 = 1.161.
    assert corner / centre == pytest.approx((717.9 / 650.0) ** 1.5, rel=2e-3)


def test_px_per_degree_matches_the_simulated_persons_angles_off_centre():
    screen = ScreenGeometry()
    point = np.array([[200.0, 900.0]])
    scale = px_per_degree_at(point, screen)[0]
    # Turning the gaze by 0.5 deg right and 0.5 deg down moves it by about 0.707 deg.
    moved = screen.rotate_gaze(point, [0.5, 0.5])
    step = np.hypot(*(moved - point)[0])
    assert step / scale == pytest.approx(math.hypot(0.5, 0.5), rel=0.06)


def test_degrees_to_px_scales_with_the_angle_and_rejects_negative():
    points = np.array([[960.0, 540.0], [100.0, 100.0]])
    np.testing.assert_allclose(degrees_to_px(2.0, points), 2 * px_per_degree_at(points))
    with pytest.raises(ValueError, match='>= 0'):
        degrees_to_px(-1.0, points)


def test_error_model_tolerance_in_degrees_and_px():
    model = GazeErrorModel(accuracy_deg=0.8, precision_deg=0.3, k_sigma=2.0)
    assert model.tolerance_deg == pytest.approx(2 * math.sqrt(0.64 + 0.18))
    px = model.tolerance_px([[960.0, 540.0], [0.0, 0.0]])
    assert px[0] == pytest.approx(model.tolerance_deg * px_per_degree_at([960.0, 540.0]))
    assert px[1] > px[0]
    with pytest.raises(ValueError, match='accuracy_deg'):
        GazeErrorModel(accuracy_deg=-1.0)


def test_distances_inside_outside_and_to_a_corner():
    d = polygon_distances([[150, 150], [90, 150], [250, 150], [90, 90]], TWO)
    np.testing.assert_allclose(d[:, 0], [0.0, 10.0, 50.0, math.hypot(10, 10)])
    np.testing.assert_allclose(d[:, 1], [150.0, 210.0, 50.0, math.hypot(210, 10)])


def test_inside_counts_whatever_the_tolerance():
    region = classify_tolerant([[150, 150], [350, 199]], TWO, tolerance_px=0.0, ratio=0.5)
    np.testing.assert_array_equal(region, [0, 1])


def test_near_counts_for_the_nearest_within_tolerance():
    # 20 px left of A, 220 px from B: within 30 px and clearly nearer.
    region = classify_tolerant([[80, 150], [150, 225]], TWO, tolerance_px=30.0, ratio=0.5)
    np.testing.assert_array_equal(region, [0, 0])


def test_midway_between_two_counts_for_neither():
    # The gap is x 200..300: 250 is 50 px from both, 240 is 40 vs 60 (ratio 0.67).
    points = [[250, 150], [240, 150], [225, 150]]
    region = classify_tolerant(points, TWO, tolerance_px=100.0, ratio=0.5)
    # 225: 25 vs 75 px, ratio 0.33: clearly nearer A.
    np.testing.assert_array_equal(region, [-1, -1, 0])


def test_far_counts_for_none():
    region = classify_tolerant([[150, 400], [-100, 150]], TWO, tolerance_px=50.0, ratio=0.5)
    np.testing.assert_array_equal(region, [-1, -1])


def test_one_option_only_needs_the_tolerance_alone():
    one = A[None]
    region = classify_tolerant([[230, 150], [260, 150]], one, tolerance_px=40.0, ratio=0.1)
    np.testing.assert_array_equal(region, [0, -1])


def test_nan_points_count_for_none():
    region = classify_tolerant([[np.nan, 150], [np.nan, np.nan], [150, 150]], TWO,
                               tolerance_px=np.inf, ratio=1.0)
    np.testing.assert_array_equal(region, [-1, -1, 0])


def test_nan_padded_and_empty_polygons():
    padded = np.stack([square(150, 150, pad=2), square(350, 150, pad=2),
                       np.full((6, 2), np.nan)])
    region = classify_tolerant([[80, 150], [350, 150], [420, 150], [1000, 1000]], padded,
                               tolerance_px=25.0, ratio=0.5)
    np.testing.assert_array_equal(region, [0, 1, 1, -1])


def test_overlapping_regions_go_to_the_nearest_centroid():
    overlap = np.stack([square(150, 150), square(190, 150)])
    region = classify_tolerant([[160, 150], [185, 150]], overlap, tolerance_px=0.0, ratio=0.5)
    np.testing.assert_array_equal(region, [0, 1])


def test_per_sample_tolerance():
    region = classify_tolerant([[80, 150], [80, 150]], TWO, tolerance_px=[10.0, 30.0],
                               ratio=0.5)
    np.testing.assert_array_equal(region, [-1, 0])


def test_no_regions():
    region = classify_tolerant([[1, 2]], np.zeros((0, 4, 2)), tolerance_px=10.0, ratio=0.5)
    np.testing.assert_array_equal(region, [-1])


def test_extend_to_nearby_keeps_inside_decisions():
    points = np.array([[150, 150], [80, 150], [250, 150]])
    out = extend_to_nearby(np.array([1, -1, -1]), points, TWO, tolerance_px=30.0, ratio=0.5)
    np.testing.assert_array_equal(out, [1, 0, -1])


def test_bad_rule_parameters_say_why():
    with pytest.raises(ValueError, match='ratio'):
        classify_tolerant([[0, 0]], TWO, tolerance_px=10.0, ratio=1.5)
    with pytest.raises(ValueError, match='tolerance_px'):
        classify_tolerant([[0, 0]], TWO, tolerance_px=-1.0, ratio=0.5)
    with pytest.raises(ValueError, match='shape'):
        classify_tolerant([[0, 0, 0]], TWO, tolerance_px=1.0, ratio=0.5)


def test_many_points_match_one_by_one():
    rng = np.random.default_rng(3)
    points = rng.uniform(0, 500, size=(5000, 2))
    batch = classify_tolerant(points, TWO, tolerance_px=40.0, ratio=0.5)
    single = [classify_tolerant(p[None], TWO, tolerance_px=40.0, ratio=0.5)[0]
              for p in points[:200]]
    np.testing.assert_array_equal(batch[:200], single)
    assert {-1, 0, 1} == set(batch.tolist())


def test_one_point_path_matches_the_batch_for_both_rules():
    # classify_one (a highlight, a fixation's place) answers as classify does: inside,
    # near, midway, far, overlapping regions (nearest centroid), NaN, padded polygons
    # (a repeated last vertex; a NaN row contains nothing).
    rng = np.random.default_rng(11)
    overlapping = square(180, 160)
    polygons = np.stack([np.concatenate([A, A[-1:], A[-1:]]), square(350, 150, pad=2),
                         np.concatenate([overlapping, overlapping[-1:], overlapping[-1:]])])
    points = np.concatenate([rng.uniform(0, 500, (600, 2)), [[np.nan, 150.0], [150.0, 100.0]]])
    for regions in (RegionSet(['a', 'b', 'c'], polygons),
                    TolerantRegions(['a', 'b', 'c'], polygons, ratio=0.5),
                    TolerantRegions(['a', 'b', 'c'], polygons, size_aware=True)):
        batch = regions.classify(points)
        assert [regions.classify_one(x, y) for x, y in points.tolist()] == batch.tolist()
        assert {-1, 0, 2} <= set(batch.tolist())


def test_size_aware_tolerance_counts_from_the_centre():
    # A is 100 px: half size 50.  With 60 px tolerance only 10 px beyond its edge count.
    points = [[95, 150], [85, 150]]
    np.testing.assert_array_equal(
        classify_tolerant(points, TWO, tolerance_px=60.0, ratio=0.5, size_aware=True), [0, -1])
    np.testing.assert_array_equal(
        classify_tolerant(points, TWO, tolerance_px=60.0, ratio=0.5), [0, 0])
    # A 4 px option gets almost the whole tolerance.
    tiny = square(150, 150, side=4.0)[None]
    np.testing.assert_array_equal(
        classify_tolerant([[150, 200]], tiny, tolerance_px=60.0, ratio=0.5, size_aware=True),
        [0])
    out = extend_to_nearby(np.array([-1, -1]), np.array(points, dtype=float), TWO, 60.0, 0.5,
                           size_aware=True)
    np.testing.assert_array_equal(out, [0, -1])
