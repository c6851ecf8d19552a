"""An executable's start-up: a Ctrl-C before it handles signals ends it quietly."""

import threading

import pytest

from eye_bci_ros2.ros import startup
from eye_bci_ros2.ros.startup import _interrupted


def _raised(make):
    try:
        make()
    except BaseException as error:  # noqa: B902 - the test looks at what was raised
        return error
    raise AssertionError('nothing raised')


def _import_interrupted():
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt:
        raise ImportError('initialization failed')   # what rclpy's C extension reports


@pytest.mark.parametrize('make, expected', [
    (lambda: (_ for _ in ()).throw(KeyboardInterrupt), True),
    (_import_interrupted, True),
    (lambda: (_ for _ in ()).throw(ImportError('no module named x')), False),
    (lambda: 1 / 0, False),
])
def test_a_ctrl_c_is_told_from_other_errors(make, expected):
    assert _interrupted(_raised(make)) is expected


def test_the_first_ctrl_c_interrupts_and_every_later_sigint_is_ignored(monkeypatch):
    """The terminal's SIGINT, launch's, and one held back seconds by load: one interrupt."""
    monkeypatch.setattr(startup, '_CTRL_C', threading.Event())
    assert not startup.ctrl_c_pending()
    with pytest.raises(KeyboardInterrupt):
        startup._once_per_ctrl_c(2, None)
    assert startup.ctrl_c_pending()
    for _ in range(3):
        startup._once_per_ctrl_c(2, None)      # ignored: the process is ending


def test_an_error_an_import_made_of_the_ctrl_c_ends_quietly(monkeypatch):
    """An ImportError made of a Ctrl-C without the chain (numpy's C-extensions) ends quietly."""
    exits, reported = [], []

    def end(status):
        exits.append(status)
        raise SystemExit(status)   # os._exit does not return

    def report(kind, value, traceback):
        reported.append(kind)

    monkeypatch.setattr(startup.os, '_exit', end)
    monkeypatch.setattr(startup, '_CTRL_C', threading.Event())
    error = ImportError('Importing the numpy C-extensions failed.')
    assert not startup._interrupted(error)
    startup._quiet_interrupt(ImportError, error, None, report)
    assert exits == [] and reported == [ImportError]     # no Ctrl-C: Python's report
    with pytest.raises(KeyboardInterrupt):
        startup._once_per_ctrl_c(2, None)
    with pytest.raises(SystemExit):
        startup._quiet_interrupt(ImportError, error, None, report)
    assert exits == [0] and reported == [ImportError]


def test_launchs_sigint_inside_the_quiet_exit_cannot_break_it(monkeypatch):
    """
    The second SIGINT of one Ctrl-C lands while the hook decides: it still ends quietly.

    (With Python's own handler that SIGINT raised a KeyboardInterrupt inside the
    hook: "Error in sys.excepthook", both tracebacks, and the process ended by
    the signal; seen under ``ros2 launch`` on a loaded machine.)
    """
    import os
    import signal

    exits = []
    monkeypatch.setattr(startup.os, '_exit', exits.append)
    monkeypatch.setattr(startup, '_CTRL_C', threading.Event())
    told = startup._interrupted

    def interrupted_again(error):
        os.kill(os.getpid(), signal.SIGINT)   # launch forwards the terminal's Ctrl-C
        return told(error)

    monkeypatch.setattr(startup, '_interrupted', interrupted_again)
    previous = signal.signal(signal.SIGINT, startup._once_per_ctrl_c)
    try:
        with pytest.raises(KeyboardInterrupt):  # the terminal's SIGINT interrupted the import
            os.kill(os.getpid(), signal.SIGINT)
            signal.sigtimedwait([], 30.0)        # not reached: the handler raises first
        startup._quiet_interrupt(KeyboardInterrupt, KeyboardInterrupt(), None)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert exits == [0]


def test_every_console_script_enters_through_the_start_up():
    """setup.py's scripts name the start-up, which runs each registered executable's main."""
    from eye_bci_ros2.ros.registry import console_scripts, EXECUTABLES
    for entry, executable in zip(console_scripts(), EXECUTABLES):
        name, target = (part.strip() for part in entry.split('='))
        assert target == f'eye_bci_ros2.ros.startup:{executable.name}'
        assert getattr(startup, name).executable_module == executable.module
    with pytest.raises(AttributeError, match='no_such_executable'):
        startup.no_such_executable
