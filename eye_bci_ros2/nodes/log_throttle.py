"""
Warnings a node may repeat at every message, logged at most once per period.

The one home of the warning throttle: :data:`WARN_PERIOD_S` is the period every
node uses (also with rclpy's own ``throttle_duration_sec``, which throttles
per call site), and :class:`KeyedWarnings` throttles per kind of problem, so
one bad message stream cannot hide another's warning.
"""

import time
from typing import Callable, Dict

#: At most one warning of a kind per this many seconds (wall clock).
WARN_PERIOD_S = 5.0

#: Kinds remembered before the long-silent ones are forgotten (keys may carry text).
MAX_KINDS = 100


class KeyedWarnings:
    """
    Log a warning of each kind at most once per ``period_s``.

    :param logger: an rclpy logger (``node.get_logger()``).
    :param period_s: throttle period, s.
    :param clock: monotonic clock, s (for tests).
    """

    def __init__(self, logger, period_s: float = WARN_PERIOD_S,
                 clock: Callable[[], float] = time.monotonic):
        """Start with nothing warned."""
        self._logger = logger
        self.period_s = float(period_s)
        self._clock = clock
        self._last: Dict[str, float] = {}

    def warn(self, key: str, text: str) -> bool:
        """Log ``text`` unless a warning of kind ``key`` was logged in the last period."""
        now = self._clock()
        last = self._last.get(key)
        if last is not None and now - last < self.period_s:
            return False
        if len(self._last) >= MAX_KINDS:
            self._last = {kind: at for kind, at in self._last.items()
                          if now - at < self.period_s}
        self._last[key] = now
        self._logger.warning(text)
        return True
