"""Shared pytest fixtures: a private ROS 2 graph per test."""

import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))

from ros_harness import ros_graph  # noqa: E402

pytest_plugins = ['fault_counter']


@pytest.fixture
def graph():
    """Provide a fresh ROS 2 context on its own domain id, torn down after the test."""
    with ros_graph() as g:
        yield g
