"""
The robot's one home for its size, speeds, accelerations and goal tolerances.

Defaults are those of a small indoor differential-drive robot (about nav2's
defaults for a TurtleBot-class base, with a larger footprint for a robot that
carries things to a person): 0.5 m/s, 1 rad/s, and a goal counts as reached
within 0.2 m and 15 deg, standing (inside nav2's SimpleGoalChecker defaults: 0.25 m,
0.25 rad).  A stop (a cancel) brakes at ``linear_accel`` and ``angular_accel``:
:attr:`RobotSettings.stop_distance_m` and :attr:`RobotSettings.stop_time_s` bound it.
"""

from dataclasses import dataclass
import math

from eye_bci_ros2.base.settings import check_settings, Setting
from eye_bci_ros2.base.validators import Interval

#: What "arrived" means: position within this distance of the goal, m.
GOAL_TOLERANCE_M = 0.2
#: ... and heading within this angle of the goal's, deg.
GOAL_TOLERANCE_DEG = 15.0


@dataclass(frozen=True)
class RobotSettings:
    """The robot's footprint and motion limits (sim_robot's parameters of the same names)."""

    radius_m: float = Setting(
        0.3, "radius of the robot's circular footprint, m: the planner keeps it this far "
        'from walls and tables', interval=Interval(0.05, 2.0), unit='m').field()
    max_speed: float = Setting(
        0.5, 'top forward speed, m/s', interval=Interval(0.01, 5.0), unit='m/s').field()
    max_turn_rate: float = Setting(
        1.0, 'top turn rate, rad/s', interval=Interval(0.05, 10.0), unit='rad/s').field()
    linear_accel: float = Setting(
        0.5, 'largest forward acceleration and braking, m/s^2 (a stop from max_speed takes '
        'max_speed / linear_accel s)', interval=Interval(0.05, 10.0), unit='m/s^2').field()
    angular_accel: float = Setting(
        2.0, 'largest angular acceleration and braking, rad/s^2',
        interval=Interval(0.1, 50.0), unit='rad/s^2').field()
    goal_tolerance_m: float = Setting(
        GOAL_TOLERANCE_M, 'a goal is reached (standing) within this distance, m',
        interval=Interval(0.01, 2.0), unit='m').field()
    goal_tolerance_deg: float = Setting(
        GOAL_TOLERANCE_DEG, "a goal is reached within this angle of the goal's heading, deg",
        interval=Interval(0.5, 180.0), unit='deg').field()

    def __post_init__(self):
        """Refuse settings that cannot work, with a reason (each field's declaration)."""
        check_settings(self)

    @property
    def stop_distance_m(self) -> float:
        """Return the longest way a stop from top speed brakes, m: v^2 / (2 a)."""
        return self.max_speed ** 2 / (2.0 * self.linear_accel)

    @property
    def stop_time_s(self) -> float:
        """Return the longest a stop takes from top speed and turn rate, s."""
        return max(self.max_speed / self.linear_accel, self.max_turn_rate / self.angular_accel)

    @property
    def goal_tolerance_rad(self) -> float:
        """Return the heading tolerance, rad."""
        return math.radians(self.goal_tolerance_deg)
