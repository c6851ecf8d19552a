"""The occupancy grid and the planner: reachable, unreachable, narrow doors, clear reasons."""

import math

import numpy as np
from paths import CONFIG
import pytest

from eye_bci_ros2.navigation.nav2_codes import (
    GOAL_OCCUPIED, GOAL_OUTSIDE_MAP, NO_VALID_PATH, START_OCCUPIED, START_OUTSIDE_MAP)
from eye_bci_ros2.navigation.occupancy import (
    Obstacles, OCCUPIED, rasterise, scene_grid, scene_obstacles)
from eye_bci_ros2.navigation.planner import NoPath, Plan, Planner
from eye_bci_ros2.task.scene import load_scene

SCENE = load_scene(CONFIG / 'scene.yaml')


def two_rooms(door_width):
    """Return a 6 m x 3 m box split at x = 3 by a wall with a door ``door_width`` wide."""
    half = door_width / 2
    walls = np.array([[0, 0, 6, 0], [6, 0, 6, 3], [6, 3, 0, 3], [0, 3, 0, 0],
                      [3, 0, 3, 1.5 - half], [3, 1.5 + half, 3, 3]], dtype=float)
    return Obstacles(walls=walls, wall_thickness=0.1, boxes=(), bounds=(-0.05, -0.05, 6.05, 3.05))


def samples(points, step=0.01):
    """Points every ``step`` m along a polyline."""
    pieces = [a + np.linspace(0, 1, max(2, int(np.hypot(*(b - a)) / step)))[:, None] * (b - a)
              for a, b in zip(points[:-1], points[1:])]
    return np.concatenate(pieces)


def test_the_grid_is_map_server_like_and_holds_walls_doors_and_tables():
    grid = scene_grid(SCENE)
    values = grid.values()
    assert values.dtype == np.int8 and set(np.unique(values)) == {0, OCCUPIED}
    assert values.size == grid.shape[0] * grid.shape[1]
    x0, y0, x1, y1 = grid.extent
    assert x0 <= -0.05 and y0 <= -0.05 and x1 >= 20.05 and y1 >= 12.05
    # Row 0 is the bottom: the cell of (5, 0) (south wall) is occupied, of (5, 0.5) free.
    assert not grid.is_free(np.array([[5.0, 0.0]]))[0] and grid.is_free(np.array([[5.0, 0.5]]))[0]
    walls_and_tables = np.array([[10.0, 3.0], [7.0, 6.0], [2.0, 10.0], [15.0, 4.0]])
    doors = np.array([door.center for door in SCENE.floor_plan.doors])
    assert not grid.is_free(walls_and_tables).any()
    assert grid.is_free(doors).all()
    assert not grid.is_free(np.array([[30.0, 5.0], [np.nan, 1.0]])).any()


@pytest.mark.parametrize('radius', [0.15, 0.25, 0.3])
def test_a_plan_across_the_scene_is_short_and_keeps_the_radius_from_everything(radius):
    planner = Planner(scene_grid(SCENE), radius)
    start, goal = np.array([2.0, 5.0]), np.array([18.0, 10.5])
    plan = planner.plan(start, goal)
    assert np.allclose(plan.points[0], start) and np.allclose(plan.points[-1], goal)
    clearance = scene_obstacles(SCENE).clearance(samples(plan.points))
    assert clearance.min() >= radius
    # Through the bedroom-office and office-living room doors: about the straight-line
    # length to the first door, then on; within a few percent of the corridor's length.
    via_doors = (np.hypot(*(np.array([10.0, 5.0]) - start))
                 + np.hypot(*(np.array([14.0, 6.0]) - [10.0, 5.0]))
                 + np.hypot(*(goal - [14.0, 6.0])))
    assert via_doors * 0.95 <= plan.length <= via_doors * 1.05


def test_a_narrow_door_passes_a_small_robot_and_stops_a_large_one():
    grid = rasterise(two_rooms(door_width=0.8))
    start, goal = np.array([1.0, 1.5]), np.array([5.0, 1.5])
    plan = Planner(grid, 0.25).plan(start, goal)
    assert two_rooms(0.8).clearance(samples(plan.points)).min() >= 0.25
    assert plan.length == pytest.approx(4.0, abs=0.05)
    # Radius 0.45 m: wider than the 0.8 m door.
    with pytest.raises(NoPath, match=r'not reachable from \(1.00, 1.50\): no passage wide '
                       r'enough for a robot of radius 0.45 m'):
        Planner(grid, 0.45).plan(start, goal)


def test_no_door_no_path():
    walls = two_rooms(0.8).walls[:4].tolist() + [[3.0, 0.0, 3.0, 3.0]]
    closed = Obstacles(walls=np.array(walls), wall_thickness=0.1, boxes=(),
                       bounds=(-0.05, -0.05, 6.05, 3.05))
    with pytest.raises(NoPath, match='not reachable'):
        Planner(rasterise(closed), 0.2).plan([1.0, 1.5], [5.0, 1.5])


@pytest.mark.parametrize('goal, reason, code', [
    ((10.0, 3.0), r'the goal \(10.00, 3.00\) is inside a wall or table', GOAL_OCCUPIED),
    ((5.0, 2.0), r'inside a wall or table', GOAL_OCCUPIED),  # bedroom/table_2
    ((30.0, 5.0), r'off the map \(x in \[-0.10, 20.10\], y in \[-0.10, 12.10\] m\)',
     GOAL_OUTSIDE_MAP),
    ((-3.0, -3.0), r'off the map', GOAL_OUTSIDE_MAP),
    ((math.nan, 5.0), r'not a finite position', GOAL_OUTSIDE_MAP),
    ((0.2, 0.2), r"closer to a wall or table than the robot's radius 0.3 m allows",
     GOAL_OCCUPIED),
])
def test_a_goal_that_cannot_be_reached_says_why_with_nav2s_code(goal, reason, code):
    with pytest.raises(NoPath, match=reason) as refused:
        Planner(scene_grid(SCENE), 0.3).plan([5.0, 5.0], goal)
    assert refused.value.code == code


def test_no_passage_is_nav2s_no_valid_path_and_a_bad_start_its_start_codes():
    grid = rasterise(two_rooms(door_width=0.8))
    with pytest.raises(NoPath) as refused:
        Planner(grid, 0.45).plan([1.0, 1.5], [5.0, 1.5])
    assert refused.value.code == NO_VALID_PATH
    planner = Planner(scene_grid(SCENE), 0.3)
    for start, code in (([10.0, 3.0], START_OCCUPIED), ([40.0, 3.0], START_OUTSIDE_MAP)):
        with pytest.raises(NoPath) as refused:
            planner.plan(start, [5.0, 5.0])
        assert refused.value.code == code


def test_plan_poses_head_along_each_segment_and_end_at_the_goals_heading():
    plan = Plan(points=np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 2.0], [0.0, 2.0]]))
    poses = plan.poses(goal_yaw=4.0)
    assert poses.shape == (5, 3) and np.allclose(poses[:, :2], plan.points)
    # East, (a repeated corner keeps east), north, west, then the goal's 4 rad wrapped.
    assert np.allclose(poses[:, 2], [0.0, 0.0, math.pi / 2, -math.pi, 4.0 - 2 * math.pi])


def test_the_batched_shortcut_keeps_the_greedy_walks_corners():
    """Each kept corner is the one before the first a straight segment cannot reach."""
    planner = Planner(scene_grid(SCENE), 0.3)
    cells = planner.plan([2.0, 5.0], [18.0, 10.5])
    dense = samples(cells.points, step=0.05)
    kept = planner.shortcut(dense)
    index, expected = 0, [0]
    while index < len(dense) - 1:
        reach = index + 1
        while reach + 1 < len(dense) and planner.segment_free(dense[index], dense[reach + 1]):
            reach += 1
        expected.append(reach)
        index = reach
    assert np.array_equal(kept, dense[expected])


def test_a_start_in_an_obstacle_is_refused_and_one_just_too_close_is_moved_out():
    planner = Planner(scene_grid(SCENE), 0.3)
    with pytest.raises(NoPath, match=r'the start \(10.00, 3.00\) is inside a wall or table'):
        planner.plan([10.0, 3.0], [5.0, 5.0])
    # 0.25 m from the south wall (closer than the radius): driven out of it, then on.
    plan = planner.plan([5.0, 0.3], [5.0, 5.0])
    assert np.allclose(plan.points[0], [5.0, 0.3]) and np.allclose(plan.points[-1], [5.0, 5.0])


def test_a_goal_where_the_robot_is_is_a_path_of_two_points():
    plan = Planner(scene_grid(SCENE), 0.3).plan([5.0, 5.0], [5.01, 5.0])
    assert plan.points.shape == (2, 2) and plan.length == pytest.approx(0.01)
