"""Camera pose conventions: ogre, x_forward (the Jazzy port), optical (pure, no ROS)."""

import numpy as np
import pytest

from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import (look_at_pose, optical_pose_from,
                                                  optical_pose_from_ogre, POSE_CONVENTIONS,
                                                  pose_from_optical)


def quaternion_product(a, b):
    """Hamilton product of x, y, z, w quaternions (tf2's operator*)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


def tf2_set_rpy(roll, pitch, yaw):
    """tf2::Quaternion::setRPY: Rz(yaw) * Ry(pitch) * Rx(roll), as x, y, z, w."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.array([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
                     cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy])


def random_quaternions(count, seed=3):
    q = np.random.default_rng(seed).normal(size=(count, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def same_rotation(q1, q2):
    np.testing.assert_allclose(geometry.quaternion_to_matrix(q1),
                               geometry.quaternion_to_matrix(q2), atol=1e-9)


@pytest.mark.parametrize('q_ogre', random_quaternions(20))
def test_x_forward_is_what_the_port_publishes_for_the_same_ogre_camera(q_ogre):
    # The port: pose orientation = Ogre orientation * RPY(0, pi/2, pi/2) (PublishViewPose).
    q_port = quaternion_product(q_ogre, tf2_set_rpy(0.0, np.pi / 2, np.pi / 2))
    position = np.array([1.0, -2.0, 3.0])
    from_port = optical_pose_from('x_forward', position, q_port)
    from_ogre = optical_pose_from_ogre(position, q_ogre)
    np.testing.assert_allclose(from_port[0], position)
    same_rotation(from_port[1], from_ogre[1])


def test_x_forward_pose_x_is_the_view_direction_and_z_is_up():
    eye, focus, up = [0.0, -8.0, 12.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]
    _, optical = look_at_pose(eye, focus, up)
    _, q_port = pose_from_optical('x_forward', eye, optical)
    rotation = geometry.quaternion_to_matrix(q_port)
    forward = np.subtract(focus, eye) / np.linalg.norm(np.subtract(focus, eye))
    np.testing.assert_allclose(rotation[:, 0], forward, atol=1e-12)
    assert rotation[2, 2] > 0.5          # pose z is the camera's up: tilted, but upward
    assert abs(rotation[2, 1]) < 1e-12   # pose y (left) stays horizontal: no roll


@pytest.mark.parametrize('convention', POSE_CONVENTIONS)
def test_round_trip_through_each_convention(convention):
    for q in random_quaternions(10, seed=7):
        position, there = pose_from_optical(convention, [4.0, 5.0, 6.0], q)
        back = optical_pose_from(convention, position, there)
        np.testing.assert_allclose(back[0], [4.0, 5.0, 6.0])
        same_rotation(back[1], q)


def test_optical_convention_is_the_identity_and_ogre_the_half_turn():
    q = random_quaternions(1, seed=11)[0]
    same_rotation(optical_pose_from('optical', [0, 0, 0], q)[1], q)
    ogre = optical_pose_from_ogre([0, 0, 0], q)[1]
    same_rotation(optical_pose_from('ogre', [0, 0, 0], q)[1], ogre)


def test_unknown_convention_and_bad_numbers_are_refused():
    with pytest.raises(ValueError, match='unknown pose convention'):
        optical_pose_from('ros', [0, 0, 0], [0, 0, 0, 1])
    with pytest.raises(ValueError, match='zero length'):
        optical_pose_from('x_forward', [0, 0, 0], [0, 0, 0, 0])
    with pytest.raises(ValueError, match='NaN'):
        optical_pose_from('optical', [np.nan, 0, 0], [0, 0, 0, 1])
