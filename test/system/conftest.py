"""Fixtures of the system tests: the real ``ros2`` command line."""

from colcon_workspace import ros2_command, Unavailable
import pytest


@pytest.fixture(scope='module')
def ros2():
    """Return the path of the real ``ros2`` wrapper (skip when it cannot be installed)."""
    try:
        return ros2_command()
    except Unavailable as reason:
        pytest.skip(f'the real ros2 command line is not at hand: {reason}')
