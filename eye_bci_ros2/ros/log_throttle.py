"""
Warnings a node may repeat at every message, logged at most once per period.

The one home of the warning throttle: :data:`WARN_PERIOD_S` is the period every
node uses (also with rclpy's own ``throttle_duration_sec``, which throttles
per call site), and :class:`KeyedWarnings` throttles per kind of problem, so
one bad message stream cannot hide another's warning.
"""

import os
import re
import sys
import time
from typing import Callable, Dict

from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.impl.logging_severity import LoggingSeverity
from rclpy.impl.rcutils_logger import RcutilsLogger

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


#: A run of the same INFO line (numbers aside) is summed up once per this many seconds.
REPEAT_PERIOD_S = 30.0


class QuietRepeats:
    """
    Log an INFO line, but not the same line again and again.

    While the person does not choose, the arbiter and the menu go round and
    round ("round 7 (request) ...", "no choice ...: asking again"): several
    lines a second that bury everything else.  A line whose text differs from
    a line of the run only in its numbers and quoted names is a repeat: the first is logged,
    the repeats go to DEBUG, and once per ``period_s`` one line says how many
    were held back.  A different line ends the run.

    :param logger: an rclpy logger (``node.get_logger()``).
    :param period_s: at most one summary line per run and period, s.
    :param clock: monotonic clock, s (for tests).
    """

    def __init__(self, logger, period_s: float = REPEAT_PERIOD_S,
                 clock: Callable[[], float] = time.monotonic):
        """Start with no run."""
        self._logger = logger
        self.period_s = float(period_s)
        self._clock = clock
        self._shapes: Dict[str, int] = {}     # shape of a line in the run -> repeats held
        self._since = 0.0

    def info(self, text: str) -> bool:
        """Log ``text`` at INFO unless it repeats a line of the current run; return whether."""
        shape = _DIGITS.sub('#', text)
        now = self._clock()
        if shape not in self._shapes:
            if len(self._shapes) >= RUN_SHAPES:
                self._shapes = {}
            self._shapes[shape] = 0
            if len(self._shapes) == 1:
                self._since = now
            log_info(self._logger, text)
            return True
        self._shapes[shape] += 1
        self._logger.debug(text)
        if now - self._since >= self.period_s:
            held = sum(self._shapes.values())
            log_info(self._logger,
                     f'(the last {len(self._shapes)} kind(s) of line repeated {held} '
                     f'time(s) in {now - self._since:.0f} s; ros2 run ... --ros-args '
                     '--log-level debug shows each)')
            self._shapes = dict.fromkeys(self._shapes, 0)
            self._since = now
        return False

    def reset(self) -> None:
        """End the run (something happened: the next lines are news again)."""
        self._shapes = {}


#: What rclpy's logger calls once it has found its caller (rclpy 7, Jazzy); None: use info.
_RCUTILS_LOG = getattr(rclpy_implementation, 'rclpy_logging_rcutils_log', None)


def log_info(logger, text: str) -> None:
    """
    Log ``text`` at INFO as ``logger.info`` does, without rclpy's search for the caller.

    rclpy's logger finds the calling file and line on every call
    (``inspect.getframeinfo`` and ``os.path.realpath`` for each frame up the
    stack): 0.3-1 ms a line on this machine, the executor held meanwhile,
    where the line itself takes about 10 us (a choice's line is logged as it
    is made).  This hands the line to rcutils as ``logger.info`` finally does,
    with the caller read from the frame: the same console line, ``/rosout``
    message and log file.  A logger that is not rclpy's (a test's) gets
    ``info``.
    """
    _emit(logger, LoggingSeverity.INFO, text, sys._getframe(1))


def log_at(logger, warning: bool, text: str) -> None:
    """
    Log ``text`` at WARN when ``warning``, else at INFO, from one line of the caller's.

    rclpy's logger keeps a context per call site (file, function, line) and
    raises ``ValueError('Logger severity cannot be changed between calls.')``
    when one site logs at another severity than the first time (rclpy's
    ``RcutilsLogger.log``), so ``(log.warning if bad else log.info)(text)``
    fails on its second kind of line, after the first has passed every test
    that saw only one kind.  This hands the line to rcutils as :func:`log_info`
    does, with no per-site context: any severity, any order.
    """
    severity = LoggingSeverity.WARN if warning else LoggingSeverity.INFO
    _emit(logger, severity, text, sys._getframe(1))


def _emit(logger, severity: LoggingSeverity, text: str, caller) -> None:
    """Hand ``text`` to rcutils at ``severity`` as from ``caller`` (a frame)."""
    emit = _RCUTILS_LOG
    if emit is None or not isinstance(logger, RcutilsLogger):
        # One call site per severity: an rclpy logger refuses a site whose severity changes.
        if severity == LoggingSeverity.WARN:
            logger.warning(text)
        else:
            logger.info(text)
        return
    if logger.is_enabled_for(severity):
        code = caller.f_code
        emit(severity, logger.name, text, code.co_name,
             os.path.abspath(code.co_filename), caller.f_lineno)


#: Digits, decimal numbers and quoted names (the option looked at), replaced to compare
#: lines by their shape: "not clearly on one option ('kitchen' ...)" and "('bedroom' ...)"
#: are one kind of line, or a person looking around made a new kind every round.
_DIGITS = re.compile(r"-?\d+(\.\d+)?|nan|inf|'[^']*'")
#: A run is a cycle of at most this many kinds of line (round, each reason for no choice,
#: asking again, ...).
RUN_SHAPES = 12
