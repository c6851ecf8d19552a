"""
An executable's start-up: what the package's programs do to their process, and only they.

Importing the package changes nothing in the process (a notebook that imports
``eye_bci_ros2.projection`` keeps its excepthook, its SIGINT handler, its
environment, and no file is written).  The executables (``ros2 run``,
``ros2 launch``, ``.venv/bin/<name>``) start here instead: setuptools'
console scripts are ``<name> = eye_bci_ros2.ros.startup:<name>``
(:func:`eye_bci_ros2.ros.registry.console_scripts`), so the script imports
this module (standard library only), which prepares the process
(:func:`prepare_process`) *before* the executable's module, rclpy and numpy
are imported, then runs its ``main``:

* **Ctrl-C while importing.**  ``ros2 launch`` sends SIGINT to every node on
  Ctrl-C, also to those still importing rclpy and numpy (the first seconds,
  longer under load), and one Ctrl-C under launch is two SIGINTs (the
  terminal's, then launch's).  The first interrupts the imports, every later
  one is ignored (:func:`_once_per_ctrl_c`), and the process ends quietly with
  status 0 (:func:`_quiet_interrupt`), as a node stopped by Ctrl-C does
  (:mod:`eye_bci_ros2.ros.runner`), also when an import turned the Ctrl-C into
  an error of its own; the runner does not start a node after a Ctrl-C an
  import swallowed (:func:`ctrl_c_pending`).
* **liblsl's own lines** are kept off the terminal (:func:`quiet_liblsl`).

An executable started as ``python -m eye_bci_ros2.<module>`` has already
imported its module when its ``main`` runs: the runner (and each ``main`` that
opens an LSL stream without it) calls :func:`quiet_liblsl` first, which is in
time, since liblsl reads its configuration when the first stream is made, not
when pylsl loads it.
"""

import importlib
import os
import signal
import sys
import tempfile
import threading
from typing import Callable, Optional

from eye_bci_ros2.ros.registry import EXECUTABLES   # standard library only


def _interrupted(error: Optional[BaseException]) -> bool:
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


def _quiet_interrupt(kind, value, traceback, _previous=sys.__excepthook__):
    """
    End an executable quietly on a Ctrl-C that arrives before it handles signals.

    Nothing was started yet, so there is nothing to report: the process ends
    with status 0.  Once a Ctrl-C has interrupted start-up
    (:func:`ctrl_c_pending`), any error that ends the process is what the
    Ctrl-C became: an import that catches the KeyboardInterrupt and raises its
    own error without the chain (numpy's C-extensions: an ImportError
    "...the C-extensions failed...", seen under load) ends it quietly too.
    Other errors, and an interactive session, keep Python's report.
    """
    if (_interrupted(value) or _CTRL_C.is_set()) and not hasattr(sys, 'ps1'):
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (AttributeError, OSError, ValueError):
                pass
        os._exit(0)
    _previous(kind, value, traceback)


#: Set by the first Ctrl-C before the executable handles signals itself.
_CTRL_C = threading.Event()


def ctrl_c_pending() -> bool:
    """Tell whether a Ctrl-C interrupted this executable before it handled signals itself."""
    return _CTRL_C.is_set()


def _once_per_ctrl_c(signum, frame) -> None:
    """
    Raise KeyboardInterrupt for the first Ctrl-C; ignore every later SIGINT.

    Before an executable handles signals itself (it is still importing), a
    loaded machine can hold launch's SIGINT back for seconds.  Raised again,
    it would land while the first unwinds, inside :func:`_quiet_interrupt`
    ("Error in sys.excepthook", both tracebacks, the process ended by the
    signal) or inside an import that turns it into an error of its own.  The
    first is enough: the process is ending, and its end is quiet.  An import
    that swallows the KeyboardInterrupt does not start the node either: the
    runner sees :func:`ctrl_c_pending` and exits 0, and replaces this handler
    otherwise (:mod:`eye_bci_ros2.ros.runner`).
    """
    if _CTRL_C.is_set():
        return
    _CTRL_C.set()
    raise KeyboardInterrupt


#: liblsl's own configuration files, in the order it looks for them (when $LSLAPICFG is unset).
LSL_CONFIG_FILES = ('lsl_api.cfg', '~/lsl_api/lsl_api.cfg', '/etc/lsl_api/lsl_api.cfg')
#: Our liblsl configuration: fatal errors only.  Its INFO lines are build details, and its
#: errors are about connections the nodes report themselves, in their own words and once
#: (a tracker that stops: "lost gaze stream ...", not liblsl's "ERR| Stream transmission
#: broke off" from its receiver thread).  A ``[log] file`` would keep them in a file, but
#: liblsl then says "Logging to ..." on the terminal at each start.  A user's own
#: configuration (below) brings them back.
LSL_QUIET_CONFIG = '[log]\nlevel = -3\n'


def quiet_liblsl() -> None:
    """
    Keep liblsl's own lines (INFO at start, its receiver threads' errors) out of every output.

    Only when the user has no liblsl configuration of their own ($LSLAPICFG or
    one of :data:`LSL_CONFIG_FILES`): theirs may hold a lab's network settings
    and is left alone.  Writes the configuration to the temporary folder and
    points ``$LSLAPICFG`` at it; must run before the process's first LSL
    stream (resolve, inlet or outlet).
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


def prepare_process() -> None:
    """
    Prepare an executable's process before it imports anything heavy (module doc).

    The quiet end of a Ctrl-C (excepthook), the first-Ctrl-C-only SIGINT
    handler (main thread only, and only over Python's default one) and the
    quiet liblsl.
    """
    if sys.excepthook is sys.__excepthook__:
        sys.excepthook = _quiet_interrupt
    if (threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
        signal.signal(signal.SIGINT, _once_per_ctrl_c)
    quiet_liblsl()


def launcher(module: str) -> Callable[[], object]:
    """Return the console-script entry of an executable: prepare the process, run ``main``."""
    def start():
        prepare_process()
        return importlib.import_module(module).main()
    start.__qualname__ = start.__name__ = module.rsplit('.', 1)[-1]
    start.executable_module = module    # what it runs (a check imports it without running)
    return start


def __getattr__(name: str) -> Callable[[], object]:
    """Give ``eye_bci_ros2.ros.startup:<name>`` for each registered executable (PEP 562)."""
    for executable in EXECUTABLES:
        if executable.name == name:
            return launcher(executable.module)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
