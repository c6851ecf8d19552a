"""
The robot's frames (REP-105) and the algebra of planar poses: the one home of both.

REP-105 names three frames: ``map`` (world-fixed; where a goal is given and the
plan lies; on a real robot amcl or a SLAM node publishes map -> odom),
``odom`` (where the robot's odometry integrates its wheels: continuous, no
jumps, but it drifts) and ``base_link`` (the robot's body; the odometry
publishes odom -> base_link).  The robot's pose in the map is the chain
map -> odom -> base_link, never the odometry's pose alone.

A planar pose (or rigid transform) is ``[x, y, yaw]``: metres and radians;
``compose(a, b)`` is b expressed in a's frame taken into a's parent (a . b),
``inverse(a)`` undoes a.  Pure Python + numpy.
"""

import math

import numpy as np

#: The world-fixed frame of the map, the plan and goals (REP-105; the scene's ``frame_id``
#: is the map frame sim_robot uses, ``map`` in the shipped scene).
MAP_FRAME = 'map'
#: The odometry's frame (REP-105): continuous, drifting.
ODOM_FRAME = 'odom'
#: The robot's body frame (REP-105), the odometry's child frame.
BASE_FRAME = 'base_link'


def wrap(angle: float) -> float:
    """Return ``angle`` in [-pi, pi), rad."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """
    Return a . b: pose ``b`` (in a's child frame) in a's parent frame, shape (3,).

    :param a: [x, y, yaw] of a child frame in its parent, m, rad.
    :param b: [x, y, yaw] in that child frame, m, rad.
    """
    cos, sin = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + cos * b[0] - sin * b[1], a[1] + sin * b[0] + cos * b[1],
                     wrap(float(a[2]) + float(b[2]))])


def inverse(a: np.ndarray) -> np.ndarray:
    """Return the transform that undoes ``a`` (a composed with it is the identity), shape (3,)."""
    cos, sin = math.cos(a[2]), math.sin(a[2])
    return np.array([-cos * a[0] - sin * a[1], sin * a[0] - cos * a[1], wrap(-float(a[2]))])


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return ``b`` seen from ``a`` (inverse(a) . b): the motion from pose a to pose b."""
    return compose(inverse(a), b)


def yaw_quaternion(yaw: float) -> np.ndarray:
    """Return the quaternion (x, y, z, w) of a rotation by ``yaw`` rad about z, shape (4,)."""
    return np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])
