"""
Wheel odometry that drifts, and the map -> odom correction a localiser publishes.

The simulated robot knows its true pose in the map.  A real robot does not: its
wheel odometry integrates what the wheels measure, in the ``odom`` frame
(REP-105: continuous, starting where the robot started), and errs a little
with every metre driven; a localiser (amcl, SLAM) publishes map -> odom so
that map -> odom -> base_link is the robot's pose in the map.
:class:`DriftingOdometry` does both from the true motion: the odometry sees
each step's distance too long by ``scale_error`` and its turn off by
``yaw_drift_rad_per_m`` per metre driven (a slightly larger wheel, slightly
unequal wheels), so the ``odom`` pose departs from the map pose slowly and
only while the robot drives; the map -> odom it returns is exact (a perfect
localiser), so the chain gives the true pose.  Whoever reads ``odom`` as the
map pose is off from the start (the odometry starts at 0, 0, 0) and ever more.

Poses ``[x, y, yaw]``, m, rad (:mod:`eye_bci_ros2.navigation.frames`).
"""

import math
from typing import Tuple

import numpy as np

from eye_bci_ros2.navigation.frames import between, compose, inverse

#: The odometry measures each step this much too long (1.5 %).
SCALE_ERROR = 0.015
#: ... and turns this much per metre driven more than the robot did (0.5 deg/m).
YAW_DRIFT_RAD_PER_M = math.radians(0.5)


class DriftingOdometry:
    """
    Dead reckoning from the true motion with a small systematic error (module doc).

    :param true_pose: the robot's pose in the map at start [x, y, yaw]: where the
        ``odom`` frame's origin lies.
    """

    def __init__(self, true_pose: np.ndarray, scale_error: float = SCALE_ERROR,
                 yaw_drift_rad_per_m: float = YAW_DRIFT_RAD_PER_M):
        """Start the odometry at the origin of ``odom``, where the robot stands."""
        self.scale_error = float(scale_error)
        self.yaw_drift_rad_per_m = float(yaw_drift_rad_per_m)
        #: The odometry's pose of base_link in ``odom``, [x, y, yaw].
        self.pose = np.zeros(3)
        #: Metres driven so far (what the drift grows with).
        self.distance_m = 0.0
        self._true = np.array(true_pose, dtype=float)

    def update(self, true_pose: np.ndarray) -> np.ndarray:
        """
        Integrate the motion from the last true pose to ``true_pose``; return the odom pose.

        Call it at every step of the simulation (a step is short: a straight move and a
        turn).  A robot put elsewhere (a teleport) must call :meth:`relocate` instead.
        """
        true_pose = np.asarray(true_pose, dtype=float)
        step = between(self._true, true_pose)
        length = math.hypot(step[0], step[1])
        seen = np.array([step[0] * (1.0 + self.scale_error),
                         step[1] * (1.0 + self.scale_error),
                         step[2] + self.yaw_drift_rad_per_m * length])
        self.pose = compose(self.pose, seen)
        self.distance_m += length
        self._true = true_pose.copy()
        return self.pose

    def twist(self, v: float, w: float) -> Tuple[float, float]:
        """Return the speeds the odometry measures for true ones (v m/s, w rad/s)."""
        return v * (1.0 + self.scale_error), w + self.yaw_drift_rad_per_m * abs(v)

    def relocate(self, true_pose: np.ndarray) -> None:
        """Put the robot at ``true_pose`` without moving the odometry (map -> odom jumps)."""
        self._true = np.array(true_pose, dtype=float)

    def map_to_odom(self) -> np.ndarray:
        """Return the transform map -> odom, [x, y, yaw]: map -> odom . odom -> base = true."""
        return compose(self._true, inverse(self.pose))
