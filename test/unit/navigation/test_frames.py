"""Planar poses: composing, inverting, the frame names, and the drifting odometry's chain."""

import math

import numpy as np
import pytest

from eye_bci_ros2.navigation.drive import Drive
from eye_bci_ros2.navigation.frames import (
    BASE_FRAME, between, compose, inverse, MAP_FRAME, ODOM_FRAME, wrap, yaw_quaternion)
from eye_bci_ros2.navigation.odometry import DriftingOdometry
from eye_bci_ros2.navigation.planner import Plan
from eye_bci_ros2.navigation.robot_settings import RobotSettings


def test_rep105_names():
    assert (MAP_FRAME, ODOM_FRAME, BASE_FRAME) == ('map', 'odom', 'base_link')


def test_compose_moves_a_point_of_the_child_frame_into_the_parent():
    parent = np.array([1.0, 2.0, math.pi / 2])
    # One metre ahead in a frame facing +y is one metre up in the parent.
    assert compose(parent, np.array([1.0, 0.0, 0.0])) == pytest.approx([1.0, 3.0, math.pi / 2])
    assert compose(parent, np.array([0.0, 1.0, math.pi])) == pytest.approx(
        [0.0, 2.0, wrap(1.5 * math.pi)])


def test_inverse_and_between_undo_compose():
    rng = np.random.default_rng(3)
    for a, b in rng.uniform(-5, 5, (20, 2, 3)):
        assert compose(a, inverse(a)) == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
        assert compose(a, between(a, b)) == pytest.approx(
            [b[0], b[1], wrap(b[2])], abs=1e-12)


def test_yaw_quaternion_is_a_unit_rotation_about_z():
    q = yaw_quaternion(2.0)
    assert q == pytest.approx([0.0, 0.0, math.sin(1.0), math.cos(1.0)])
    assert 2 * math.atan2(q[2], q[3]) == pytest.approx(2.0)


def drive_across(odometry, start):
    """Drive a real Drive along an L, updating ``odometry`` every step; return the drive."""
    drive = Drive(RobotSettings(), start)
    plan = Plan(points=np.array([start[:2], start[:2] + [6.0, 0.0], start[:2] + [6.0, 4.0]]))
    drive.follow(plan.points, math.pi / 2)
    for _ in range(3000):
        drive.step(0.05)
        odometry.update(drive.pose)
    return drive


def test_the_chain_map_odom_base_is_the_true_pose_while_odom_alone_drifts_away():
    start = np.array([5.0, 5.0, 0.3])
    odometry = DriftingOdometry(start)
    # At start: odom is at its origin, map -> odom is where the robot started.
    assert odometry.pose == pytest.approx([0.0, 0.0, 0.0])
    assert odometry.map_to_odom() == pytest.approx(start)
    drive = drive_across(odometry, start)
    chain = compose(odometry.map_to_odom(), odometry.pose)
    assert chain == pytest.approx(drive.pose, abs=1e-9)
    # 10 m driven: the odometry errs by about 1.5 % and 0.5 deg per metre: a few cm,
    # a few degrees, relative to where it started; not zero, and not large.
    assert odometry.distance_m == pytest.approx(10.0, abs=0.3)
    truth = between(start, drive.pose)
    error = odometry.pose - truth
    assert 0.05 < math.hypot(error[0], error[1]) < 0.6
    assert math.radians(2) < abs(wrap(error[2])) < math.radians(10)
    # So map -> odom is far from identity and from where it started.
    assert np.linalg.norm(odometry.map_to_odom()[:2] - start[:2]) > 0.02


def test_drift_grows_only_while_the_robot_moves_and_a_relocation_keeps_odom_continuous():
    odometry = DriftingOdometry(np.zeros(3))
    odometry.update(np.array([1.0, 0.0, 0.0]))
    before = odometry.pose.copy()
    for _ in range(10):
        odometry.update(np.array([1.0, 0.0, 0.0]))
    assert odometry.pose == pytest.approx(before)
    odometry.relocate(np.array([3.0, 4.0, 1.0]))
    assert odometry.pose == pytest.approx(before)
    assert compose(odometry.map_to_odom(), odometry.pose) == pytest.approx([3.0, 4.0, 1.0])


def test_no_drift_gives_an_odometry_equal_to_the_motion():
    start = np.array([2.0, 1.0, -0.5])
    odometry = DriftingOdometry(start, scale_error=0.0, yaw_drift_rad_per_m=0.0)
    drive = drive_across(odometry, start)
    assert odometry.pose == pytest.approx(between(start, drive.pose), abs=1e-9)
    assert odometry.map_to_odom() == pytest.approx(start, abs=1e-9)


def test_braking_bounds_follow_the_settings():
    settings = RobotSettings()
    assert settings.stop_distance_m == pytest.approx(0.5 ** 2 / (2 * 0.5))
    assert settings.stop_time_s == pytest.approx(max(0.5 / 0.5, 1.0 / 2.0))
    drive = Drive(settings, np.zeros(3))
    drive.follow(np.array([[0.0, 0.0], [20.0, 0.0]]), 0.0)
    while drive.v < settings.max_speed:
        drive.step(0.02)
    where = drive.pose.copy()
    drive.stop()
    steps = 0
    while drive.moving:
        drive.step(0.02)
        steps += 1
    assert np.hypot(*(drive.pose[:2] - where[:2])) <= settings.stop_distance_m + 1e-9
    assert steps * 0.02 <= settings.stop_time_s + 0.02
