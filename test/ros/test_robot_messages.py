"""Planar poses <-> Pose, PoseStamped, TF transforms and Path (ros/robot_messages)."""

import math

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose
import numpy as np
import pytest

from eye_bci_ros2.ros.robot_messages import (
    path_message, planar_pose, pose_message, pose_stamped, transform_stamped)


def test_a_planar_pose_goes_through_a_pose_message_and_back():
    for pose in ([1.5, -2.0, 0.3], [0.0, 0.0, -3.0], [4.0, 5.0, math.pi - 1e-9]):
        message = pose_message(np.array(pose))
        assert message.position.z == 0.0 and message.orientation.x == 0.0
        assert planar_pose(message) == pytest.approx(pose)


def test_a_rotation_that_is_no_rotation_has_no_yaw():
    zero = Pose()
    zero.orientation.w = 0.0
    assert math.isnan(planar_pose(zero)[2])
    unnormalised = Pose()
    unnormalised.orientation.z, unnormalised.orientation.w = 2.0, 2.0   # 90 deg, length 2.8
    assert planar_pose(unnormalised)[2] == pytest.approx(math.pi / 2)


def test_transform_and_path_carry_frames_stamps_and_every_heading():
    stamp = Time(sec=3, nanosec=5)
    transform = transform_stamped('map', 'odom', np.array([1.0, 2.0, 0.5]), stamp)
    assert (transform.header.frame_id, transform.child_frame_id) == ('map', 'odom')
    assert transform.header.stamp == stamp
    assert (transform.transform.translation.x, transform.transform.translation.y) == (1.0, 2.0)
    assert 2 * math.atan2(transform.transform.rotation.z,
                          transform.transform.rotation.w) == pytest.approx(0.5)
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 1.0], [1.0, 1.0, 2.0]])
    path = path_message(poses, 'map', stamp)
    assert path.header.frame_id == 'map' and len(path.poses) == 3
    assert all(p.header.frame_id == 'map' and p.header.stamp == stamp for p in path.poses)
    assert np.array([planar_pose(p.pose) for p in path.poses]) == pytest.approx(poses)
    assert pose_stamped(poses[1], 'odom').header.frame_id == 'odom'
    assert path_message(np.zeros((0, 3)), 'map', stamp).poses == []
