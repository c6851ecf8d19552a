"""Approach poses: in front of each table, facing it, where the robot fits and can get to."""

import math

import numpy as np
from paths import CONFIG
import pytest

from eye_bci_ros2.navigation.approach import (
    approach_from_marker, DEFAULT_STANDOFF_M, scene_goals)
from eye_bci_ros2.navigation.occupancy import marker_box, scene_grid, scene_obstacles
from eye_bci_ros2.navigation.planner import Planner
from eye_bci_ros2.navigation.robot_settings import RobotSettings
from eye_bci_ros2.task.scene import load_scene, parse_scene

SCENE = load_scene(CONFIG / 'scene.yaml')
RADIUS = RobotSettings().radius_m


@pytest.fixture(scope='module')
def goals():
    return scene_goals(SCENE, RADIUS)


def tables():
    return [(room, table) for room in SCENE.rooms for table in room.tables]


def test_every_table_has_a_goal_under_its_label(goals):
    assert sorted(goals) == sorted(t.marker.text for _, t in tables())
    for pose in goals.values():
        assert pose.shape == (3,) and np.all(np.isfinite(pose))
        assert -math.pi <= pose[2] < math.pi


def test_the_robot_stands_free_at_the_standoff_and_faces_the_table(goals):
    obstacles = scene_obstacles(SCENE)
    for room, table in tables():
        pose = goals[table.marker.text]
        box = marker_box(table.marker)
        # The footprint clears every wall and table by at least the radius ...
        assert obstacles.clearance(pose[:2])[0] >= RADIUS
        # ... and its edge is the standoff from this table's edge.
        gap = box.distance(pose[None, :2])[0] - RADIUS
        assert gap == pytest.approx(DEFAULT_STANDOFF_M, abs=1e-9)
        # Facing it: the heading points at the table's centre.
        to_table = box.center - pose[:2]
        heading = np.array([math.cos(pose[2]), math.sin(pose[2])])
        assert heading @ to_table / np.linalg.norm(to_table) > math.cos(math.radians(1))
        # In the table's room.
        x0, y0, x1, y1 = room.area
        assert x0 < pose[0] < x1 and y0 < pose[1] < y1


def test_every_goal_is_reachable_from_every_room(goals):
    planner = Planner(scene_grid(SCENE), RADIUS)
    start = np.array([5.0, 5.0])  # bedroom, near its north wall
    for label, pose in goals.items():
        plan = planner.plan(start, pose[:2])
        assert np.allclose(plan.points[-1], pose[:2]), label


def test_a_table_with_no_free_side_is_named():
    # A robot of radius 1.5 m does not fit between any table and the walls.
    with pytest.raises(ValueError, match=r'kitchen/table_\d: no side of the table where a robot '
                       r'of radius 1.5 m fits'):
        scene_goals(SCENE, 1.5)


def test_the_side_facing_the_room_centre_comes_first_when_free(goals):
    # kitchen/table_3 at (8, 10): the room centre (5, 9) lies to its -x side.
    pose = goals['kitchen/table_3']
    assert pose[0] < 8.0 and pose[2] == pytest.approx(0.0)


def test_approach_from_a_markers_pose():
    # A 1 m square marker at (2, 1), turned 90 deg: its +x side points to +y.
    pose = approach_from_marker([2.0, 1.0, math.pi / 2], [1.0, 1.0], radius_m=0.25,
                                standoff_m=0.1)
    assert pose == pytest.approx([2.0, 1.0 + 0.5 + 0.1 + 0.25, -math.pi / 2])
    toward = approach_from_marker([2.0, 1.0, 0.0], [1.0, 2.0], radius_m=0.25, standoff_m=0.1,
                                  toward_xy=[2.0, -5.0])
    assert toward == pytest.approx([2.0, 1.0 - 1.0 - 0.1 - 0.25, math.pi / 2])


def test_a_scene_without_a_floor_plan_still_has_goals():
    text = (CONFIG / 'scene.yaml').read_text()
    open_floor = parse_scene(text[:text.index('\nfloor_plan:')])
    assert open_floor.floor_plan is None
    assert sorted(scene_goals(open_floor, RADIUS)) == sorted(t.marker.text for _, t in tables())
