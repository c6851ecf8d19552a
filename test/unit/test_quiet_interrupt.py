"""A Ctrl-C before an executable handles signals ends it quietly, also inside an import."""

import threading

import pytest

from eye_bci_ros2 import _interrupted


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
    import eye_bci_ros2
    monkeypatch.setattr(eye_bci_ros2, '_CTRL_C', threading.Event())
    assert not eye_bci_ros2.ctrl_c_pending()
    with pytest.raises(KeyboardInterrupt):
        eye_bci_ros2._once_per_ctrl_c(2, None)
    assert eye_bci_ros2.ctrl_c_pending()
    for _ in range(3):
        eye_bci_ros2._once_per_ctrl_c(2, None)      # ignored: the process is ending


def test_an_error_an_import_made_of_the_ctrl_c_ends_quietly(monkeypatch):
    """An ImportError made of a Ctrl-C without the chain (numpy's C-extensions) ends quietly."""
    import eye_bci_ros2
    exits, reported = [], []

    def end(status):
        exits.append(status)
        raise SystemExit(status)   # os._exit does not return

    def report(kind, value, traceback):
        reported.append(kind)

    monkeypatch.setattr(eye_bci_ros2.os, '_exit', end)
    monkeypatch.setattr(eye_bci_ros2, '_CTRL_C', threading.Event())
    error = ImportError('Importing the numpy C-extensions failed.')
    assert not eye_bci_ros2._interrupted(error)
    eye_bci_ros2._quiet_interrupt(ImportError, error, None, report)
    assert exits == [] and reported == [ImportError]     # no Ctrl-C: Python's report
    with pytest.raises(KeyboardInterrupt):
        eye_bci_ros2._once_per_ctrl_c(2, None)
    with pytest.raises(SystemExit):
        eye_bci_ros2._quiet_interrupt(ImportError, error, None, report)
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

    import eye_bci_ros2
    exits = []
    monkeypatch.setattr(eye_bci_ros2.os, '_exit', exits.append)
    monkeypatch.setattr(eye_bci_ros2, '_CTRL_C', threading.Event())
    told = eye_bci_ros2._interrupted

    def interrupted_again(error):
        os.kill(os.getpid(), signal.SIGINT)   # launch forwards the terminal's Ctrl-C
        return told(error)

    monkeypatch.setattr(eye_bci_ros2, '_interrupted', interrupted_again)
    previous = signal.signal(signal.SIGINT, eye_bci_ros2._once_per_ctrl_c)
    try:
        with pytest.raises(KeyboardInterrupt):  # the terminal's SIGINT interrupted the import
            os.kill(os.getpid(), signal.SIGINT)
            signal.sigtimedwait([], 30.0)        # not reached: the handler raises first
        eye_bci_ros2._quiet_interrupt(KeyboardInterrupt, KeyboardInterrupt(), None)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert exits == [0]
