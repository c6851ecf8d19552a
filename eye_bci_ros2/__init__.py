"""Choose among RViz markers by looking at them: gaze over LSL, projection, arbitration."""

import os
import sys


def _quiet_interrupt(kind, value, traceback, _previous=sys.excepthook):
    """
    End an executable quietly on a Ctrl-C that arrives before it handles signals.

    ``ros2 launch`` sends SIGINT to every node on Ctrl-C, also to those still
    importing rclpy and numpy (the first seconds): Python would print a
    KeyboardInterrupt traceback for each.  Nothing was started yet, so there
    is nothing to report: the process ends with status 0, as a node stopped
    by Ctrl-C does (:mod:`eye_bci_ros2.nodes.runner`).  Other errors, and an
    interactive session, keep Python's report.
    """
    if issubclass(kind, KeyboardInterrupt) and not hasattr(sys, 'ps1'):
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (AttributeError, OSError, ValueError):
                pass
        os._exit(0)
    _previous(kind, value, traceback)


# Installed on import: the package is the first thing every console script imports.
if sys.excepthook is sys.__excepthook__:
    sys.excepthook = _quiet_interrupt
