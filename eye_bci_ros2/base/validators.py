"""
The package's value checks, in one place: pure Python.

Every check here returns None when the value is fine, else the reason it is
not, as a phrase that follows the value's name ("must be in (0.5, 1), got
1.2"); :func:`require` turns a reason into a ``ValueError``.  The settings
declarations (:mod:`eye_bci_ros2.base.settings`) and the node parameter tables
(:mod:`eye_bci_ros2.ros.parameters`) both use them, so a value is refused
with the same words whether it comes from Python or from ``ros2 param set``.
"""

from dataclasses import dataclass
import math
import numbers
from typing import Any, Optional, Sequence


@dataclass(frozen=True)
class Interval:
    """
    A range of numbers, each end open or closed; infinite ends mean unbounded.

    :param low: lower end.
    :param high: upper end.
    :param low_open: ``low`` itself is outside.
    :param high_open: ``high`` itself is outside.
    """

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False

    def __contains__(self, value: Any) -> bool:
        """Tell whether the number ``value`` lies in the interval (NaN never does)."""
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return bool(above and below)

    def __str__(self) -> str:
        """Write it as a reader expects: '(0.5, 1)', '[0, 60]', '>= 0', '> 0'."""
        low, high = math.isfinite(self.low), math.isfinite(self.high)
        if low and not high:
            return f"{'>' if self.low_open else '>='} {_number(self.low)}"
        if high and not low:
            return f"{'<' if self.high_open else '<='} {_number(self.high)}"
        return (f"{'(' if self.low_open else '['}{_number(self.low)}, "
                f"{_number(self.high)}{')' if self.high_open else ']'}")

    @property
    def closure(self) -> Optional[tuple]:
        """
        Return (low, high) with both ends included, or None when an end is infinite.

        A ROS parameter range is always closed: the node declares the closure and
        refuses an open end itself (:func:`in_interval`).
        """
        if math.isfinite(self.low) and math.isfinite(self.high):
            return (self.low, self.high)
        return None

    @property
    def has_open_end(self) -> bool:
        """Tell whether a finite end is excluded (a closed ROS range cannot say so)."""
        return ((self.low_open and math.isfinite(self.low))
                or (self.high_open and math.isfinite(self.high)))


def _number(value: float) -> str:
    """Write a bound without a needless '.0' (1.0 -> '1', 0.5 -> '0.5')."""
    return f'{value:g}'


def is_number(value: Any) -> bool:
    """Tell whether ``value`` is a real number (True and False are not)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def in_interval(value: Any, interval: Interval, unit: str = '', why: str = '') -> Optional[str]:
    """
    Refuse anything but a number in ``interval``.

    :param unit: written after the interval ('s', 'deg', 'mm').
    :param why: what the value means, appended so the reader knows what to give.
    """
    if is_number(value) and value in interval:
        return None
    unit = f' {unit}' if unit else ''
    why = f': {why}' if why else ''
    return f'must be {_interval_words(interval)}{unit}, got {value!r}{why}'


def _interval_words(interval: Interval) -> str:
    text = str(interval)
    return text if text[0] in '<>' else f'in {text}'


def one_of(value: Any, choices: Sequence[str]) -> Optional[str]:
    """Refuse anything but one of ``choices``."""
    if value in choices:
        return None
    return f"'{value}' is not one of {', '.join(choices)}"


def frame_id(value: Any) -> Optional[str]:
    """Refuse an empty frame id or one with a leading slash (tf2 refuses both)."""
    if not str(value).strip():
        return 'must not be empty'
    if str(value).startswith('/'):
        return f"'{value}' must not start with '/'"
    return None


def vector3(value: Any) -> Optional[str]:
    """Refuse anything but 3 finite numbers (x, y, z)."""
    if value is None or len(value) != 3:
        count = 0 if value is None else len(value)
        return f'needs 3 finite numbers (x, y, z): exactly 3 numbers expected, got {count}'
    if not all(math.isfinite(v) for v in value):
        return 'needs 3 finite numbers (x, y, z): contains NaN or infinite values'
    return None


def require(name: str, reason: Optional[str]) -> None:
    """Raise ``ValueError('<name> <reason>')`` when there is a reason."""
    if reason:
        raise ValueError(f'{name} {reason}')


def ensure(condition: bool, message: str) -> None:
    """Raise ``ValueError(message)`` unless ``condition`` holds."""
    if not condition:
        raise ValueError(message)
