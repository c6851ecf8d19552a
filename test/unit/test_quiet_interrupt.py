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
