"""
A differential-drive (unicycle) robot that follows a plan: the simulated robot's motion.

The robot moves forward at speed ``v`` (m/s) and turns at rate ``w`` (rad/s),
both limited (:class:`eye_bci_ros2.navigation.robot_settings.RobotSettings`) and
changed at most at the set accelerations.  It follows a path of corners
(:class:`eye_bci_ros2.navigation.planner.Plan`): it steers for a point a short
lookahead ahead on the current segment (never past its corner), slows to stop at
sharp corners (where it turns in place) and at the goal, where it turns to the
goal's heading.  A stop brakes to standstill at the set accelerations.

Pose ``[x, y, yaw]``: metres and radians in the map frame.  Pure Python + numpy.
"""

import enum
import math

import numpy as np

from eye_bci_ros2.navigation.frames import wrap
from eye_bci_ros2.navigation.robot_settings import RobotSettings

#: The robot steers for a point this far ahead along its segment, m.
LOOKAHEAD_M = 0.3
#: A corner turning more than this is taken standing: stop, turn in place, go, rad.
SHARP_TURN_RAD = math.radians(35.0)
#: At a gentle corner the robot moves on to the next segment this far before it, m: about
#: where an arc at top speed and turn rate leaves the first segment (well inside the
#: planner's margin, INFLATION_MARGIN_CELLS).
GENTLE_SWITCH_M = 0.15
#: The robot has reached a corner it stops at, or the goal's position, this close, m.
REACHED_M = 0.03
#: The goal's heading is reached this close, rad.
ALIGNED_RAD = math.radians(1.5)
#: Steering gain: turn rate per heading error, 1/s (before the limits).
STEER_GAIN = 3.0
#: Longest integration step, s: a caller's longer step (a faster-than-real-time
#: simulation) is split into steps this long.
MAX_STEP_S = 0.02


class Mode(enum.Enum):
    """What the robot is doing."""

    IDLE = 'idle'          # standing, no goal (or arrived)
    DRIVING = 'driving'    # following the path
    ALIGNING = 'aligning'  # at the goal's position, turning to its heading
    STOPPING = 'stopping'  # braking to standstill


class Drive:
    """
    The robot's motion: its pose and speeds, a path to follow, steps in time.

    :param settings: speeds, accelerations (and radius, unused here).
    :param pose: start pose [x, y, yaw], m, rad.
    """

    def __init__(self, settings: RobotSettings, pose: np.ndarray):
        """Stand still at ``pose``."""
        self.settings = settings
        #: [x, y, yaw], m, rad (yaw in [-pi, pi)).
        self.pose = np.array([pose[0], pose[1], wrap(pose[2])], dtype=float)
        #: Forward speed, m/s, and turn rate, rad/s.
        self.v = 0.0
        self.w = 0.0
        self.mode = Mode.IDLE
        #: Whether the last goal was reached (False while driving to one, or after a stop).
        self.arrived = False
        self._path = np.zeros((0, 2))
        self._corner = 0
        self._goal_yaw = 0.0

    def follow(self, points: np.ndarray, goal_yaw: float) -> None:
        """
        Drive along ``points`` (corners, shape (n, 2), m; the first is where the robot is).

        A path replaces the one being followed; the robot keeps its speeds.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        self._path = points if len(points) >= 2 else np.concatenate([points, points])
        self._corner = 1
        self._goal_yaw = wrap(goal_yaw)
        self.arrived = False
        self.mode = Mode.DRIVING

    def stop(self) -> None:
        """Brake to standstill at the set accelerations and forget the path."""
        self.arrived = False
        self._path = np.zeros((0, 2))
        self.mode = Mode.STOPPING if self.moving else Mode.IDLE

    @property
    def moving(self) -> bool:
        """Tell whether the robot moves or turns."""
        return self.v != 0.0 or self.w != 0.0

    def distance_left(self) -> float:
        """Return the length of the path still ahead, m (0 with no path)."""
        if self.mode is not Mode.DRIVING:
            return 0.0
        ahead = self._path[self._corner:]
        return float(np.hypot(*(ahead[0] - self.pose[:2])) + np.sum(
            np.hypot(*np.diff(ahead, axis=0).T)))

    def step(self, dt: float) -> None:
        """Advance the robot by ``dt`` s (split into steps of at most MAX_STEP_S)."""
        count = max(1, int(math.ceil(dt / MAX_STEP_S - 1e-9)))
        for _ in range(count):
            self._step(dt / count)

    def _step(self, dt: float) -> None:
        v_want, w_want = self._command()
        s = self.settings
        self.v += float(np.clip(v_want - self.v, -s.linear_accel * dt, s.linear_accel * dt))
        self.w += float(np.clip(w_want - self.w, -s.angular_accel * dt, s.angular_accel * dt))
        # Unicycle, integrated along the arc's mean heading.
        heading = self.pose[2] + self.w * dt / 2
        self.pose[0] += self.v * dt * math.cos(heading)
        self.pose[1] += self.v * dt * math.sin(heading)
        self.pose[2] = wrap(self.pose[2] + self.w * dt)
        if self.mode is Mode.ALIGNING and self.v == 0.0 and self.w == 0.0 and abs(
                wrap(self._goal_yaw - self.pose[2])) <= ALIGNED_RAD:
            self.mode, self.arrived = Mode.IDLE, True
        elif self.mode is Mode.STOPPING and self.v == 0.0 and self.w == 0.0:
            self.mode = Mode.IDLE

    def _command(self):
        """Return the wanted (v, w) for the mode."""
        if self.mode is Mode.DRIVING:
            return self._drive_command()
        if self.mode is Mode.ALIGNING:
            error = wrap(self._goal_yaw - self.pose[2])
            return 0.0, self._turn_rate(error) if abs(error) > ALIGNED_RAD else 0.0
        return 0.0, 0.0

    def _drive_command(self):
        position = self.pose[:2]
        last = len(self._path) - 1
        # Move on past corners already reached.
        while self._corner < last:
            to_corner = float(np.hypot(*(self._path[self._corner] - position)))
            passed = self._along(position) >= self._segment_length()
            reach = REACHED_M if self._sharp(self._corner) else GENTLE_SWITCH_M
            if to_corner > reach and not passed:
                break
            self._corner += 1
        if np.hypot(*(self._path[last] - position)) <= REACHED_M and self._corner == last:
            self.mode = Mode.ALIGNING
            return self._command()
        start, end = self._path[self._corner - 1], self._path[self._corner]
        length = self._segment_length()
        direction = (end - start) / length if length > 0 else np.zeros(2)
        carrot = start + direction * min(self._along(position) + LOOKAHEAD_M, length)
        if np.hypot(*(carrot - position)) < REACHED_M:
            carrot = end
        error = wrap(math.atan2(carrot[1] - position[1], carrot[0] - position[0]) - self.pose[2])
        if abs(error) > SHARP_TURN_RAD:
            return 0.0, self._turn_rate(error)
        # Brake in time for the next stop: a sharp corner or the goal.
        brake = float(np.hypot(*(end - position)))
        corner = self._corner
        while corner < last and not self._sharp(corner):
            brake += float(np.hypot(*(self._path[corner + 1] - self._path[corner])))
            corner += 1
        s = self.settings
        speed = min(s.max_speed, math.sqrt(2.0 * s.linear_accel * max(brake - REACHED_M, 0.0)))
        return speed * math.cos(error) ** 2, self._turn_rate(error)

    def _turn_rate(self, error: float) -> float:
        """Return the turn rate towards a heading ``error`` rad away, braking in time."""
        s = self.settings
        rate = min(s.max_turn_rate, STEER_GAIN * abs(error),
                   math.sqrt(2.0 * s.angular_accel * abs(error)))
        return math.copysign(rate, error)

    def _segment_length(self) -> float:
        return float(np.hypot(*(self._path[self._corner] - self._path[self._corner - 1])))

    def _along(self, position: np.ndarray) -> float:
        """Return how far along the current segment ``position`` projects, m."""
        start, end = self._path[self._corner - 1], self._path[self._corner]
        length = self._segment_length()
        return 0.0 if length == 0 else float((position - start) @ (end - start) / length)

    def _sharp(self, corner: int) -> bool:
        """Tell whether the path turns sharply at corner index ``corner``."""
        before = self._path[corner] - self._path[corner - 1]
        after = self._path[corner + 1] - self._path[corner]
        turn = abs(wrap(math.atan2(after[1], after[0]) - math.atan2(before[1], before[0])))
        return turn > SHARP_TURN_RAD


def heading_error(pose: np.ndarray, goal: np.ndarray) -> float:
    """Return |goal yaw - pose yaw| wrapped, rad (poses [x, y, yaw])."""
    return abs(wrap(float(goal[2]) - float(pose[2])))


def pose_error(pose: np.ndarray, goal: np.ndarray) -> float:
    """Return the distance between two poses' positions, m."""
    return float(np.hypot(goal[0] - pose[0], goal[1] - pose[1]))
