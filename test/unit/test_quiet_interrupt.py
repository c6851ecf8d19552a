"""A Ctrl-C before an executable handles signals ends it quietly, also inside an import."""

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


def test_the_same_ctrl_c_interrupts_once(monkeypatch):
    """The terminal's SIGINT and launch's, milliseconds apart: one KeyboardInterrupt."""
    import eye_bci_ros2
    last = [None]
    clock = iter([100.0, 100.004, 100.9, 101.2])
    monkeypatch.setattr(eye_bci_ros2.time, 'monotonic', lambda: next(clock))
    with pytest.raises(KeyboardInterrupt):
        eye_bci_ros2._once_per_ctrl_c(2, None, last)
    eye_bci_ros2._once_per_ctrl_c(2, None, last)   # launch's, 4 ms later: ignored
    eye_bci_ros2._once_per_ctrl_c(2, None, last)   # still within SAME_CTRL_C_S
    with pytest.raises(KeyboardInterrupt):          # a Ctrl-C of its own
        eye_bci_ros2._once_per_ctrl_c(2, None, last)


def test_launchs_sigint_inside_the_quiet_exit_cannot_break_it(monkeypatch):
    """
    The second SIGINT of one Ctrl-C lands while the hook decides: it still ends quietly.

    (With Python's own handler that SIGINT raised a KeyboardInterrupt inside the
    hook: "Error in sys.excepthook", both tracebacks, and the process ended by
    the signal; seen under ``ros2 launch`` on a loaded machine.)
    """
    import os
    import signal
    import time

    import eye_bci_ros2
    exits = []
    monkeypatch.setattr(eye_bci_ros2.os, '_exit', exits.append)
    told = eye_bci_ros2._interrupted

    def interrupted_again(error):
        os.kill(os.getpid(), signal.SIGINT)   # launch forwards the terminal's Ctrl-C
        return told(error)

    monkeypatch.setattr(eye_bci_ros2, '_interrupted', interrupted_again)
    last = [time.monotonic()]                 # the terminal's SIGINT interrupted the import
    previous = signal.signal(signal.SIGINT,
                             lambda s, f: eye_bci_ros2._once_per_ctrl_c(s, f, last))
    try:
        eye_bci_ros2._quiet_interrupt(KeyboardInterrupt, KeyboardInterrupt(), None)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert exits == [0]
