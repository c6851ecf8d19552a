"""The drive model: reaches goals within tolerance, within its limits, stops in time."""

import math

import numpy as np
from paths import CONFIG
import pytest

from eye_bci_ros2.navigation.approach import scene_goals
from eye_bci_ros2.navigation.drive import Drive, heading_error, Mode, pose_error
from eye_bci_ros2.navigation.occupancy import scene_grid, scene_obstacles
from eye_bci_ros2.navigation.planner import Planner
from eye_bci_ros2.navigation.robot_settings import RobotSettings
from eye_bci_ros2.task.scene import load_scene

SCENE = load_scene(CONFIG / 'scene.yaml')
SETTINGS = RobotSettings()
#: The odometry period of sim_robot at 20 Hz, s.
DT = 0.05


def run(drive, seconds, record):
    """Step ``drive`` for up to ``seconds`` (simulated) until it is idle; record the states."""
    for _ in range(int(seconds / DT)):
        drive.step(DT)
        record.append((drive.pose.copy(), drive.v, drive.w))
        if drive.mode is Mode.IDLE:
            break


def test_it_drives_to_every_table_within_tolerance_limits_and_clearance():
    planner = Planner(scene_grid(SCENE), SETTINGS.radius_m)
    obstacles = scene_obstacles(SCENE)
    drive = Drive(SETTINGS, [5.0, 5.0, 0.0])
    for label, goal in scene_goals(SCENE, SETTINGS.radius_m).items():
        plan = planner.plan(drive.pose[:2], goal[:2])
        drive.follow(plan.points, goal[2])
        assert drive.distance_left() == pytest.approx(plan.length, abs=0.01)
        states = []
        run(drive, 200.0, states)
        assert drive.mode is Mode.IDLE and drive.arrived, label
        assert pose_error(drive.pose, goal) <= SETTINGS.goal_tolerance_m, label
        assert heading_error(drive.pose, goal) <= SETTINGS.goal_tolerance_rad, label
        poses = np.array([s[0] for s in states])
        v = np.array([0.0] + [s[1] for s in states])
        w = np.array([0.0] + [s[2] for s in states])
        # Within the speed and acceleration limits (a step's change over DT).
        assert np.all(v >= 0.0) and np.all(v <= SETTINGS.max_speed + 1e-9)
        assert np.all(np.abs(w) <= SETTINGS.max_turn_rate + 1e-9)
        assert np.all(np.abs(np.diff(v)) <= SETTINGS.linear_accel * DT + 1e-9)
        assert np.all(np.abs(np.diff(w)) <= SETTINGS.angular_accel * DT + 1e-9)
        # The footprint never touched a wall or table.
        assert obstacles.clearance(poses[:, :2]).min() >= SETTINGS.radius_m, label
        # Drove about the plan's length, not a detour.
        driven = np.sum(np.hypot(*np.diff(poses[:, :2], axis=0).T))
        assert driven <= plan.length * 1.1 + 0.1, label


def test_a_stop_at_top_speed_stands_still_within_1_5_s():
    drive = Drive(SETTINGS, [1.0, 1.0, 0.0])
    drive.follow(np.array([[1.0, 1.0], [9.0, 1.0]]), 0.0)
    states = []
    run(drive, 4.0, states)
    assert drive.v == pytest.approx(SETTINGS.max_speed)
    drive.stop()
    stopped_at = drive.pose.copy()
    elapsed = 0.0
    while drive.moving:
        drive.step(DT)
        elapsed += DT
    assert elapsed <= 1.5 and drive.mode is Mode.IDLE and not drive.arrived
    braking = SETTINGS.max_speed ** 2 / (2 * SETTINGS.linear_accel)
    assert pose_error(drive.pose, stopped_at) == pytest.approx(braking, abs=0.03)
    held = drive.pose.copy()
    drive.step(5.0)
    assert np.array_equal(drive.pose, held) and drive.distance_left() == 0.0


def test_a_goal_behind_it_is_turned_to_in_place_first():
    drive = Drive(SETTINGS, [1.0, 1.0, 0.0])
    drive.follow(np.array([[1.0, 1.0], [-1.0, 1.0]]), math.pi / 2)
    states = []
    run(drive, 30.0, states)
    poses = np.array([s[0] for s in states])
    turning = np.array([abs(s[2]) > 0 and s[1] == 0 for s in states])
    assert turning[:10].all() and np.allclose(poses[:10, :2], [1.0, 1.0])
    assert drive.arrived and pose_error(drive.pose, [-1.0, 1.0, 0]) <= 0.05
    assert heading_error(drive.pose, [0, 0, math.pi / 2]) <= math.radians(2)


def test_a_long_step_is_split_and_lands_where_short_steps_do():
    coarse, fine = (Drive(SETTINGS, [1.0, 1.0, 0.0]) for _ in range(2))
    for drive in (coarse, fine):
        drive.follow(np.array([[1.0, 1.0], [3.0, 1.0], [3.0, 2.0]]), 0.0)
    coarse.step(2.0)
    for _ in range(100):
        fine.step(0.02)
    assert np.allclose(coarse.pose, fine.pose)
