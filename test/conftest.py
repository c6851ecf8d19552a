"""Shared pytest fixtures: a private ROS 2 graph per test."""

import pytest

from ros_harness import ros_graph

pytest_plugins = ['fault_counter']


@pytest.fixture
def graph():
    """Provide a fresh ROS 2 context on its own domain id, torn down after the test."""
    with ros_graph() as g:
        yield g
