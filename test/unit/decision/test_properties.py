"""
Property-based tests (hypothesis) of the pure core: geometry, camera model, arbitration.

Properties that must hold for every camera, marker and gaze stream, not only
the hand-picked ones of the unit tests:

* projecting a back-projected pixel returns it;
* a screen offset (X0, Y0) moves every region by exactly (X0, Y0), and shifting
  regions and gaze together never changes a decision;
* the decision rules do not depend on the order of the samples;
* a silhouette contains every projected corner of its box.

Exactness: decision tests use pixel coordinates that are multiples of 1/8 px
(what a 12-bit sub-pixel tracker can report), so every sum and half-plane
test is exact in float64 and a shift or a reordering cannot flip a sample
that lies exactly on an edge.  Where a quantity involves a division (a mean
over a count that is not a power of two, a centroid), the test assumes the
decisive point is more than 1e-6 px from every region edge.
"""

import math

from batch_rules import decide_mean, decide_vote
from hypothesis import assume, given, HealthCheck, settings, strategies as st
import numpy as np

from eye_bci_ros2.decision.evidence import RoundEvidence
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, ORIGINAL_RULE, RoundScheduler
from eye_bci_ros2.projection.camera_model import rviz_intrinsic, RvizCamera
from eye_bci_ros2.projection.geometry import (back_project, box_silhouettes, cube_corners_batch,
                                              look_at, MIN_DEPTH, polygon_signed_area,
                                              project_points)

SETTINGS = settings(max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

#: Screen of the regions in the decision properties, px.
SCREEN = (1920, 1080)

coordinate = st.floats(-20.0, 20.0, allow_nan=False)
vector3 = st.tuples(coordinate, coordinate, coordinate).map(np.array)


@st.composite
def views(draw):
    """Draw an eye, focus and up that define a camera (eye != focus, up not along the view)."""
    eye = draw(vector3)
    focus = draw(vector3)
    up = draw(st.tuples(*[st.floats(-1.0, 1.0)] * 3).map(np.array))
    forward = focus - eye
    assume(np.linalg.norm(forward) > 0.1 and np.linalg.norm(up) > 0.1)
    sine = np.linalg.norm(np.cross(forward / np.linalg.norm(forward), up / np.linalg.norm(up)))
    assume(sine > 0.05)
    return eye, focus, up


@st.composite
def intrinsics(draw):
    """Draw an intrinsic and its panel size: the analytic RViz one, or one with skew."""
    width = draw(st.integers(64, 4096))
    height = draw(st.integers(64, 4096))
    if draw(st.booleans()):
        return rviz_intrinsic(width, height, draw(st.floats(10.0, 120.0))), (width, height)
    fx, fy = draw(st.floats(100.0, 5000.0)), draw(st.floats(100.0, 5000.0))
    skew = draw(st.floats(-50.0, 50.0))
    cx, cy = draw(st.floats(0.0, width)), draw(st.floats(0.0, height))
    return np.array([[fx, skew, cx, 0.0], [0.0, fy, cy, 0.0], [0.0, 0.0, 1.0, 0.0]]), \
        (width, height)


@st.composite
def boxes_in_view(draw, eye, forward, right, down, count):
    """Positions (M, 3), unit quaternions (M, 4) and scales (M, 3) of boxes ahead of the eye."""
    rows = []
    for _ in range(count):
        depth = draw(st.floats(1.0, 40.0))
        lateral = draw(st.floats(-0.6, 0.6)) * depth
        vertical = draw(st.floats(-0.4, 0.4)) * depth
        quaternion = np.array(draw(st.tuples(*[st.floats(-1.0, 1.0)] * 4)))
        assume(np.linalg.norm(quaternion) > 0.1)
        scale = draw(st.tuples(*[st.floats(0.01, 3.0)] * 3))
        rows.append((eye + depth * forward + lateral * right + vertical * down,
                     quaternion / np.linalg.norm(quaternion), scale))
    positions, quaternions, scales = (np.array(column, dtype=float) for column in zip(*rows))
    return positions, quaternions, scales


# -- projection ------------------------------------------------------------------------------


@SETTINGS
@given(view=views(), camera=intrinsics(), data=st.data())
def test_projecting_a_back_projected_pixel_returns_it(view, camera, data):
    intrinsic, (width, height) = camera
    external = look_at(*view)
    count = data.draw(st.integers(1, 20))
    pixels = np.array(data.draw(st.lists(
        st.tuples(st.floats(0.0, width), st.floats(0.0, height)),
        min_size=count, max_size=count)))
    distances = np.array(data.draw(st.lists(st.floats(0.05, 200.0), min_size=count,
                                            max_size=count)))
    origin, directions = back_project(pixels, intrinsic, external)
    np.testing.assert_allclose(origin, view[0], atol=1e-9 * max(1.0, np.abs(view[0]).max()))
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-12)
    uv, depth = project_points(origin + distances[:, None] * directions, intrinsic, external)
    assert np.all(depth > 0), 'a back-projected ray points behind the camera'
    np.testing.assert_allclose(uv, pixels, atol=1e-6)


# -- silhouettes -----------------------------------------------------------------------------


def _edge_distances(polygon: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Return how far (px) points (N, 2) lie inside a convex polygon: min over its edges."""
    start = polygon
    edge = np.roll(polygon, -1, axis=0) - start
    length = np.linalg.norm(edge, axis=1)
    keep = length > 1e-9
    start, edge, length = start[keep], edge[keep], length[keep]
    # Image-CCW loops (negative area in u, v) have their inside where cross(edge, p - s) <= 0.
    cross = edge[None, :, 0] * (points[:, None, 1] - start[None, :, 1]) \
        - edge[None, :, 1] * (points[:, None, 0] - start[None, :, 0])
    return (-cross / length[None, :]).min(axis=1)


@SETTINGS
@given(view=views(), camera=intrinsics(), data=st.data())
def test_silhouettes_contain_every_projected_corner(view, camera, data):
    intrinsic, _ = camera
    external = look_at(*view)
    right, down, forward = external[:3, :3]
    count = data.draw(st.integers(1, 6))
    positions, quaternions, scales = data.draw(
        boxes_in_view(view[0], forward, right, down, count))
    polygons, visible = box_silhouettes(positions, quaternions, scales, intrinsic, external)
    corners = cube_corners_batch(positions, quaternions, scales)
    uv, depth = project_points(corners.reshape(-1, 3), intrinsic, external)
    uv, depth = uv.reshape(count, 8, 2), depth.reshape(count, 8)
    for row in range(count):
        if not visible[row]:
            # Invisible only when a corner is not in front (boxes here never hold the eye).
            assert np.any(depth[row] <= MIN_DEPTH)
            assert np.all(np.isnan(polygons[row]))
            continue
        polygon = polygons[row]
        size = max(1.0, np.ptp(uv[row], axis=0).max())
        assert polygon_signed_area(polygon) < 0, 'outline not counter-clockwise on screen'
        assert _edge_distances(polygon, uv[row]).min() >= -1e-7 * size
        # Every outline vertex is one of the box's corners.
        gaps = np.linalg.norm(polygon[:, None, :] - uv[row][None, :, :], axis=2).min(axis=1)
        assert gaps.max() <= 1e-9 * size


@SETTINGS
@given(view=views(), data=st.data(),
       offset=st.tuples(st.integers(-4000, 4000), st.integers(-4000, 4000)),
       clip=st.booleans())
def test_screen_offset_moves_every_region_by_exactly_the_offset(view, data, offset, clip):
    camera = RvizCamera.from_look_at(*view, image_size=(1280, 720))
    shifted = camera.replace(screen_offset=offset)
    right, down, forward = camera.external[:3, :3]
    boxes = data.draw(boxes_in_view(view[0], forward, right, down, data.draw(st.integers(1, 6))))
    polygons, visible = camera.box_regions(*boxes, clip=clip)
    moved, moved_visible = shifted.box_regions(*boxes, clip=clip)
    np.testing.assert_array_equal(visible, moved_visible)
    np.testing.assert_allclose(moved[visible], polygons[visible] + np.array(offset), atol=1e-9)
    assert np.all(np.isnan(moved[~visible]))
    if clip and visible.any():
        # Clipped regions stay on the render panel (in screen px: shifted by the offset).
        inside = moved[visible] - np.array(offset)
        assert inside.min() >= -1e-6
        assert np.all(inside.max(axis=(0, 1)) <= np.array([1280, 720]) + 1e-6)


# -- decisions -------------------------------------------------------------------------------


def eighths(low, high):
    """Multiples of 1/8 px in [low, high]."""
    return st.integers(int(low * 8), int(high * 8)).map(lambda v: v / 8.0)


@st.composite
def region_sets(draw):
    """Disjoint convex regions (one per cell of a grid), vertices on the 1/8 px grid."""
    columns, rows = draw(st.integers(1, 4)), draw(st.integers(1, 3))
    cell_w, cell_h = SCREEN[0] / columns, SCREEN[1] / rows
    cells = draw(st.lists(st.tuples(st.integers(0, columns - 1), st.integers(0, rows - 1)),
                          min_size=1, max_size=columns * rows, unique=True))
    labels, polygons = [], []
    for index, (column, row) in enumerate(cells):
        left, top = column * cell_w + 4, row * cell_h + 4
        right, bottom = left + cell_w - 8, top + cell_h - 8
        if draw(st.booleans()):
            # A quadrilateral with one vertex on each side of the cell is convex.
            polygon = [[left, draw(eighths(top, bottom))], [draw(eighths(left, right)), top],
                       [right, draw(eighths(top, bottom))], [draw(eighths(left, right)), bottom]]
        else:
            x0, x1 = sorted(draw(st.lists(eighths(left, right), min_size=2, max_size=2,
                                          unique=True)))
            y0, y1 = sorted(draw(st.lists(eighths(top, bottom), min_size=2, max_size=2,
                                          unique=True)))
            polygon = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
        labels.append(draw(st.sampled_from(['kitchen', 'bedroom', 'table 1', 'table 2']))
                      + f' {index}')
        polygons.append(np.floor(np.array(polygon) * 8) / 8)
    return labels, np.array(polygons)


@st.composite
def gaze_samples(draw, polygons, count=None):
    """
    Gaze points (N, 2) on the 1/8 px grid: mostly in regions, some anywhere, some NaN (blinks).

    Drawn from a seeded generator: hypothesis picks the count and the seed,
    which keeps hundreds of samples per example fast.
    """
    if count is None:
        count = draw(st.integers(1, 200))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    chosen = polygons[rng.integers(0, len(polygons), count)]
    low, high = chosen.min(axis=1), chosen.max(axis=1)
    points = low + rng.random((count, 2)) * (high - low)
    anywhere = rng.random(count) < 0.2
    points[anywhere] = rng.uniform([-100, -100], [SCREEN[0] + 100, SCREEN[1] + 100],
                                   (int(anywhere.sum()), 2))
    points = np.round(points * 8) / 8
    points[rng.random(count) < 0.05] = math.nan
    return points


def same_decision(first, second):
    """Assert two decisions agree on what a user sees: label, counts and mean point."""
    assert first.label == second.label, (first, second)
    # Labels without samples may be listed with 0 or left out.
    assert {k: n for k, n in first.counts.items() if n} == \
        {k: n for k, n in second.counts.items() if n}
    assert first.in_region_samples == second.in_region_samples
    assert first.samples_used == second.samples_used


def edge_margin(region_set: RegionSet, point) -> float:
    """Smallest distance (px) from ``point`` to any region edge (inf without a point)."""
    if point is None:
        return math.inf
    point = np.asarray(point, dtype=float)[None, :]
    return min(abs(_edge_distances(polygon, point)[0]) for polygon in region_set.polygons)


@SETTINGS
@given(regions=region_sets(), data=st.data(),
       offset=st.tuples(st.integers(-4000, 4000), st.integers(-4000, 4000)))
def test_shifting_regions_and_gaze_together_keeps_every_decision(regions, data, offset):
    labels, polygons = regions
    points = data.draw(gaze_samples(polygons))
    offset = np.array(offset, dtype=float)
    here = RegionSet(labels, polygons)
    there = RegionSet(labels, polygons + offset)
    # The vote only counts exact half-plane tests: always the same.
    same_decision(decide_vote(points, here), decide_vote(points + offset, there))
    first, second = decide_mean(points, here), decide_mean(points + offset, there)
    if first.mean_point is not None:
        np.testing.assert_allclose(np.add(first.mean_point, offset), second.mean_point,
                                   rtol=0, atol=1e-9)
    # The mean divides by the count: the same region unless it lies on an edge.
    assume(edge_margin(here, first.mean_point) > 1e-6)
    same_decision(first, second)


@SETTINGS
@given(regions=region_sets(), data=st.data(),
       offset=st.tuples(st.integers(-4000, 4000), st.integers(-4000, 4000)))
def test_round_evidence_decides_as_the_batch_rules_and_ignores_the_offset(regions, data,
                                                                          offset):
    labels, polygons = regions
    points = data.draw(gaze_samples(polygons))
    stamps = np.arange(len(points)) / 1200.0
    offset = np.array(offset, dtype=float)
    here = RegionSet(labels, polygons)
    there = RegionSet(labels, polygons + offset)
    batch_mean = decide_mean(points, here)
    assume(edge_margin(here, batch_mean.mean_point) > 1e-6)
    for region_set, shift in ((here, 0.0), (there, offset)):
        evidence = RoundEvidence(0.0)
        cut = data.draw(st.integers(0, len(points)))
        # Two batches in time order, as the node feeds them.
        evidence.add(points[:cut] + shift, stamps[:cut], region_set)
        evidence.add(points[cut:] + shift, stamps[cut:], region_set)
        same_decision(evidence.decide('mean'), batch_mean)
        same_decision(evidence.decide('vote'), decide_vote(points, here))


@SETTINGS
@given(regions=region_sets(), data=st.data())
def test_decisions_do_not_depend_on_the_order_of_the_samples(regions, data):
    labels, polygons = regions
    points = data.draw(gaze_samples(polygons))
    order = np.array(data.draw(st.permutations(range(len(points)))))
    region_set = RegionSet(labels, polygons)
    for rule in (decide_mean, decide_vote):
        first, second = rule(points, region_set), rule(points[order], region_set)
        same_decision(first, second)
        # 1/8 px samples: the sums are exact in any order.
        assert first.mean_point == second.mean_point
    # The incremental rules: samples of one instant, in any order.
    assume(edge_margin(region_set, decide_mean(points, region_set).mean_point) > 1e-6)
    decisions = []
    for sequence in (points, points[order]):
        evidence = RoundEvidence(0.0)
        evidence.add(sequence, np.zeros(len(sequence)), region_set)
        decisions.append((evidence.decide('mean'), evidence.decide('vote')))
    for first, second in zip(*decisions):
        same_decision(first, second)


@SETTINGS
@given(regions=region_sets(), data=st.data(), method=st.sampled_from(['mean', 'vote']))
def test_live_rounds_decide_the_same_whatever_order_the_samples_arrive(regions, data, method):
    """The node's rounds, fed one sample at a time in any order, decide as the batch rule."""
    labels, polygons = regions
    points = data.draw(gaze_samples(polygons))
    stamps = 0.1 + np.arange(len(points)) / 1200.0   # all inside the 1 s window
    rule = decide_mean if method == 'mean' else decide_vote
    expected = rule(points, RegionSet(labels, polygons))
    assume(method == 'vote' or edge_margin(RegionSet(labels, polygons),
                                           expected.mean_point) > 1e-6)
    order = np.array(data.draw(st.permutations(range(len(points)))))
    for sequence in (np.arange(len(points)), order):
        rounds = RoundScheduler(ArbiterSettings(method=method, window_s=1.0, early_decision=False,
                                                **ORIGINAL_RULE))
        rounds.add_regions(RegionSet(labels, polygons, 0.0), now=0.0)
        for k in sequence.tolist():
            assert rounds.add_sample(stamps[k], points[k, 0], points[k, 1], now=0.5) is None
        # The first sample after the window closes the round.
        decision = rounds.add_sample(1.5, math.nan, math.nan, now=1.5)
        assert decision is not None and decision is rounds.last_decision
        assert decision.label == expected.label, (decision.summary(), expected.summary())
        assert {k: n for k, n in decision.counts.items() if n} == \
            {k: n for k, n in expected.counts.items() if n}
