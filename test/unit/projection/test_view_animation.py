"""Animated RViz views: cosine ease, interpolation, Ogre and optical poses."""

import math

import numpy as np
import pytest

from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.projection.view_animation import (as_view, ease_progress, interpolate_view,
                                                    ogre_pose, view_from_optical_pose,
                                                    ViewAnimation)

OVERVIEW = as_view([10.0, -2.0, 17.0], [10.0, 6.0, 0.0], [0.0, 0.0, 1.0])
KITCHEN = as_view([5.0, 4.0, 6.5], [5.0, 9.3, 0.0], [0.0, 0.0, 1.0])


def assert_valid(view):
    """Check the view makes a camera; return its unit forward and up-across-view."""
    external = geometry.look_at(*view)
    return external[2, :3], -external[1, :3]


def test_ease_endpoints_middle_and_slope():
    duration = 1.7
    assert ease_progress(0.0, duration) == 0.0
    assert ease_progress(duration, duration) == 1.0
    assert ease_progress(-1.0, duration) == 0.0 and ease_progress(5.0, duration) == 1.0
    assert ease_progress(duration / 2, duration) == pytest.approx(0.5, abs=1e-15)
    # Zero speed at both ends: progress grows like (pi^2 / 4) (t / T)^2.
    h = 1e-4 * duration
    assert ease_progress(h, duration) == pytest.approx(math.pi ** 2 / 4 * 1e-8, rel=1e-6)
    assert 1.0 - ease_progress(duration - h, duration) == pytest.approx(
        math.pi ** 2 / 4 * 1e-8, rel=1e-6)
    # Fastest in the middle, pi / (2 T).
    slope = (ease_progress(duration / 2 + h, duration)
             - ease_progress(duration / 2 - h, duration)) / (2 * h)
    assert slope == pytest.approx(math.pi / (2 * duration), rel=1e-6)
    times = np.linspace(0, duration, 101)
    assert np.all(np.diff([ease_progress(t, duration) for t in times]) > 0)


def test_zero_duration_jumps():
    assert ease_progress(0.0, 0.0) == 1.0
    animation = ViewAnimation(OVERVIEW, KITCHEN, 10.0, 0.0)
    assert animation.finished_at(10.0)
    for a, b in zip(animation.view_at(10.0), KITCHEN):
        np.testing.assert_array_equal(a, b)


def test_interpolation_endpoints_exact_and_linear_between():
    start = as_view([0.1, 0.2, 0.3], [1.7, -2.9, 0.0], [0.0, 0.3, 1.0])
    goal = as_view([3.3, 1.1, 0.7], [0.1, 0.1, 0.1], [0.0, 0.0, 1.0])
    for a, b in zip(interpolate_view(start, goal, 0.0), start):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(interpolate_view(start, goal, 1.0), goal):
        np.testing.assert_array_equal(a, b)
    for a, b, c in zip(interpolate_view(start, goal, 0.25), start, goal):
        np.testing.assert_allclose(a, 0.75 * b + 0.25 * c, atol=1e-15)


def test_animation_follows_the_cosine_ease():
    animation = ViewAnimation(OVERVIEW, KITCHEN, start_time_s=100.0, duration_s=2.0)
    eye, focus, _ = animation.view_at(101.0)
    np.testing.assert_allclose(eye, (OVERVIEW[0] + KITCHEN[0]) / 2, atol=1e-12)
    np.testing.assert_allclose(focus, (OVERVIEW[1] + KITCHEN[1]) / 2, atol=1e-12)
    s = (1 - math.cos(math.pi / 4)) / 2
    np.testing.assert_allclose(animation.view_at(100.5)[0],
                               (1 - s) * OVERVIEW[0] + s * KITCHEN[0], atol=1e-12)
    assert not animation.finished_at(101.999)
    assert animation.finished_at(102.0)
    for a, b in zip(animation.view_at(102.0), KITCHEN):
        np.testing.assert_array_equal(a, b)


def test_up_stays_valid_when_turning_upside_down():
    # Linear up passes through zero half-way (RViz would break there).
    start = as_view([0, 0, 10], [0, 0, 0], [0, 1, 0])
    goal = as_view([0, 0, 10], [0, 0, 0], [0, -1, 0])
    ups = []
    for s in np.linspace(0, 1, 201):
        view = interpolate_view(start, goal, s)
        forward, up = assert_valid(view)
        ups.append(up)
    np.testing.assert_allclose(ups[0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(ups[-1], [0, -1, 0], atol=1e-12)


def test_view_stays_valid_when_eye_passes_through_focus():
    start = as_view([0, 0, 5], [0, 0, 0], [0, 1, 0])
    goal = as_view([0, 0, 0], [0, 0, 5], [0, 1, 0])
    middle = interpolate_view(start, goal, 0.5)
    forward, up = assert_valid(middle)
    assert abs(np.dot(forward, [0, 0, 1])) < 1e-9  # half-way round from down to up
    for s in np.linspace(0, 1, 101):
        assert_valid(interpolate_view(start, goal, s))


def test_up_along_the_view_falls_back():
    # Half-way, RViz's linear up (0.5, 0, -0.5) lies along the view (5, 0, -5).
    start = as_view([0, 0, 10], [0, 0, 0], [0, 1, 0])
    goal = as_view([0, 0, 10], [10, 0, 10], [1, -1, -1])
    linear = [(a + b) / 2 for a, b in zip(start, goal)]
    with pytest.raises(ValueError, match='parallel'):
        geometry.look_at(*linear)
    eye, focus, up = interpolate_view(start, goal, 0.5)
    np.testing.assert_array_equal(eye, linear[0])
    np.testing.assert_array_equal(focus, linear[1])
    assert_valid((eye, focus, up))
    for s in np.linspace(0, 1, 101):
        assert_valid(interpolate_view(start, goal, s))


def test_ogre_pose_looks_along_minus_z_with_y_up():
    position, quaternion = ogre_pose(*KITCHEN)
    np.testing.assert_array_equal(position, KITCHEN[0])
    rotation = geometry.quaternion_to_matrix(quaternion)
    forward = (KITCHEN[1] - KITCHEN[0]) / np.linalg.norm(KITCHEN[1] - KITCHEN[0])
    np.testing.assert_allclose(rotation @ [0, 0, -1], forward, atol=1e-12)
    up = rotation @ [0, 1, 0]
    assert abs(np.dot(up, forward)) < 1e-12 and up[2] > 0  # world +z shows as up
    right = rotation @ [1, 0, 0]
    np.testing.assert_allclose(right, [1, 0, 0], atol=1e-12)  # looking north: east is right
    _, optical = look_at_pose(*KITCHEN)
    np.testing.assert_allclose(geometry.quaternion_to_matrix(optical),
                               rotation @ np.diag([1, -1, -1]), atol=1e-12)


def test_optical_pose_round_trip_recovers_a_floor_focus():
    for view in (OVERVIEW, KITCHEN):
        eye, focus, up = view_from_optical_pose(*look_at_pose(*view))
        np.testing.assert_allclose(eye, view[0], atol=1e-12)
        np.testing.assert_allclose(focus, view[1], atol=1e-9)
        np.testing.assert_allclose(geometry.look_at(eye, focus, up), geometry.look_at(*view),
                                   atol=1e-12)


def test_pose_that_misses_the_floor_uses_the_fallback_distance():
    looking_up = as_view([0, 0, 1], [0, 3, 2], [0, 0, 1])
    _, focus, _ = view_from_optical_pose(*look_at_pose(*looking_up), fallback_distance=2.0)
    direction = np.array([0, 3, 1]) / np.sqrt(10)
    np.testing.assert_allclose(focus, [0, 0, 1] + 2.0 * direction, atol=1e-12)
    with pytest.raises(ValueError, match='zero length'):
        view_from_optical_pose([0, 0, 1], [0, 0, 0, 0])


def test_invalid_views_are_rejected():
    with pytest.raises(ValueError, match='equals focus'):
        as_view([1, 2, 3], [1, 2, 3], [0, 0, 1])
    with pytest.raises(ValueError, match='parallel'):
        ViewAnimation(OVERVIEW, ([0, 0, 5], [0, 0, 0], [0, 0, 1]), 0.0, 1.0)
