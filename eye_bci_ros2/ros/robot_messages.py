"""
Planar poses <-> the robot's messages: Pose, PoseStamped, TransformStamped, nav_msgs/Path.

A planar pose is ``[x, y, yaw]`` (m, rad; :mod:`eye_bci_ros2.navigation.frames`);
z is 0 and the rotation is about z.  sim_robot publishes with these, and a
client of NavigateToPose reads its feedback's ``current_pose`` with
:func:`planar_pose`.
"""

import math
from typing import Optional

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose, PoseStamped, TransformStamped
from nav_msgs.msg import Path
import numpy as np

from eye_bci_ros2.navigation.frames import yaw_quaternion
from eye_bci_ros2.navigation.occupancy import yaw_of
from eye_bci_ros2.ros.conversions import arrays_to_pose, pose_to_arrays


def planar_pose(pose: Pose) -> np.ndarray:
    """
    Return ``[x, y, yaw]`` of a Pose (its rotation's yaw), shape (3,).

    yaw is NaN when the quaternion is not finite or is zero (no rotation can be read).
    """
    position, quaternion = pose_to_arrays(pose)
    norm = float(np.linalg.norm(quaternion))
    yaw = (yaw_of(quaternion / norm) if np.all(np.isfinite(quaternion)) and norm > 1e-9
           else math.nan)
    return np.array([position[0], position[1], yaw])


def pose_message(pose: np.ndarray) -> Pose:
    """Return the Pose of a planar pose ``[x, y, yaw]`` (z 0, rotation about z)."""
    return arrays_to_pose([float(pose[0]), float(pose[1]), 0.0], yaw_quaternion(float(pose[2])))


def pose_stamped(pose: np.ndarray, frame_id: str, stamp: Optional[Time] = None) -> PoseStamped:
    """Return a PoseStamped of a planar pose in ``frame_id``."""
    message = PoseStamped(pose=pose_message(pose))
    message.header.frame_id = frame_id
    if stamp is not None:
        message.header.stamp = stamp
    return message


def transform_stamped(parent: str, child: str, pose: np.ndarray, stamp: Time) -> TransformStamped:
    """Return the TF transform parent -> child of a planar pose (child's pose in parent)."""
    message = TransformStamped()
    message.header.frame_id = parent
    message.header.stamp = stamp
    message.child_frame_id = child
    translation, rotation = message.transform.translation, message.transform.rotation
    translation.x, translation.y = float(pose[0]), float(pose[1])
    rotation.x, rotation.y, rotation.z, rotation.w = (float(v) for v in yaw_quaternion(
        float(pose[2])))
    return message


def path_message(poses: np.ndarray, frame_id: str, stamp: Time) -> Path:
    """Return a nav_msgs/Path of planar poses, shape (n, 3), every pose with its heading."""
    path = Path()
    path.header.frame_id = frame_id
    path.header.stamp = stamp
    path.poses = [pose_stamped(pose, frame_id, stamp) for pose in np.reshape(poses, (-1, 3))]
    return path
