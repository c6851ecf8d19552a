"""Choose among RViz markers by looking at them: gaze over LSL, projection, arbitration."""

import os
import signal
import sys
import tempfile
import threading
import time


def _interrupted(error: BaseException) -> bool:
    """
    Tell whether ``error`` is a Ctrl-C, or what one became.

    A C extension interrupted while it initialises (rclpy's) reports an
    ImportError raised from the KeyboardInterrupt.
    """
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, KeyboardInterrupt):
            return True
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return False


def _quiet_interrupt(kind, value, traceback, _previous=sys.excepthook):
    """
    End an executable quietly on a Ctrl-C that arrives before it handles signals.

    ``ros2 launch`` sends SIGINT to every node on Ctrl-C, also to those still
    importing rclpy and numpy (the first seconds): Python would print a
    KeyboardInterrupt traceback for each.  Nothing was started yet, so there
    is nothing to report: the process ends with status 0, as a node stopped
    by Ctrl-C does (:mod:`eye_bci_ros2.ros.runner`).  Other errors, and an
    interactive session, keep Python's report.
    """
    if _interrupted(value) and not hasattr(sys, 'ps1'):
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (AttributeError, OSError, ValueError):
                pass
        os._exit(0)
    _previous(kind, value, traceback)


#: A SIGINT this soon after the one that interrupted an executable is the same Ctrl-C, s: the
#: terminal sends it to the whole process group, and ``ros2 launch`` forwards its own to every
#: node within milliseconds.
SAME_CTRL_C_S = 1.0


def _once_per_ctrl_c(signum, frame, _last=[None]) -> None:
    """
    Raise KeyboardInterrupt for a Ctrl-C once: the same Ctrl-C arriving again is ignored.

    Before an executable handles signals itself (it is still importing), the
    second SIGINT of one Ctrl-C (launch's, after the terminal's) could land
    while the first unwinds or inside :func:`_quiet_interrupt`: Python then
    prints "Error in sys.excepthook" with both tracebacks, and the process
    ends by the signal.  A Ctrl-C later than :data:`SAME_CTRL_C_S` interrupts
    as usual.  The runner replaces this handler once the node handles signals
    (:mod:`eye_bci_ros2.ros.runner`).
    """
    now = time.monotonic()
    if _last[0] is not None and now - _last[0] < SAME_CTRL_C_S:
        return
    _last[0] = now
    raise KeyboardInterrupt


def _running_an_executable() -> bool:
    """Tell whether this process is one of the package's executables (``ros2 run``, launch)."""
    from eye_bci_ros2.ros.registry import EXECUTABLES   # standard library only
    name = os.path.basename(sys.argv[0]) if sys.argv else ''
    return any(executable.name == name for executable in EXECUTABLES)


#: liblsl's own configuration files, in the order it looks for them (when $LSLAPICFG is unset).
LSL_CONFIG_FILES = ('lsl_api.cfg', '~/lsl_api/lsl_api.cfg', '/etc/lsl_api/lsl_api.cfg')
#: Our liblsl configuration: fatal errors only.  Its INFO lines are build details, and its
#: errors are about connections the nodes report themselves, in their own words and once
#: (a tracker that stops: "lost gaze stream ...", not liblsl's "ERR| Stream transmission
#: broke off" from its receiver thread).  A ``[log] file`` would keep them in a file, but
#: liblsl then says "Logging to ..." on the terminal at each start.  A user's own
#: configuration (below) brings them back.
LSL_QUIET_CONFIG = '[log]\nlevel = -3\n'


def _quiet_liblsl() -> None:
    """
    Keep liblsl's own lines (INFO at start, its receiver threads' errors) out of every output.

    Only when the user has no liblsl configuration of their own ($LSLAPICFG or
    one of :data:`LSL_CONFIG_FILES`): theirs may hold a lab's network settings
    and is left alone.  Must run before pylsl loads liblsl.
    """
    if 'LSLAPICFG' in os.environ or any(os.path.exists(os.path.expanduser(path))
                                        for path in LSL_CONFIG_FILES):
        return
    path = os.path.join(tempfile.gettempdir(), f'eye_bci_ros2_lsl_api_{os.getuid()}.cfg')
    try:
        with open(path) as stream:
            current = stream.read()
    except OSError:
        current = None
    try:
        if current != LSL_QUIET_CONFIG:
            # Whole or not at all: other executables may read it at this moment.
            partial = f'{path}.{os.getpid()}'
            with open(partial, 'w') as stream:
                stream.write(LSL_QUIET_CONFIG)
            os.replace(partial, path)
    except OSError:
        return      # liblsl then prints its lines: harmless
    os.environ['LSLAPICFG'] = path


# On import: the package is the first thing every console script imports.
if sys.excepthook is sys.__excepthook__:
    sys.excepthook = _quiet_interrupt
if (threading.current_thread() is threading.main_thread() and _running_an_executable()
        and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
    signal.signal(signal.SIGINT, _once_per_ctrl_c)
_quiet_liblsl()
