"""Shared pytest fixtures: a private ROS 2 graph per test; one private X server per session."""

import atexit
import os

import pytest

from ros_harness import ros_graph
from xvfb_server import start_xvfb

pytest_plugins = ['fault_counter']


@pytest.fixture
def graph():
    """Provide a fresh ROS 2 context on its own domain id, torn down after the test."""
    with ros_graph() as g:
        yield g


@pytest.fixture(scope='session')
def xvfb():
    """
    Run a private Xvfb server for the whole session and set DISPLAY to it.

    One per session because pyglet keeps its X connection open.  Skips, naming
    the package, where Xvfb is not installed.
    """
    try:
        server, display = start_xvfb()
    except FileNotFoundError as missing:
        pytest.skip(f'needs {missing}')
    previous = os.environ.get('DISPLAY')
    os.environ['DISPLAY'] = display
    yield display
    import pyglet
    for window in list(pyglet.app.windows):
        window.close()
    if previous is None:
        os.environ.pop('DISPLAY', None)
    else:
        os.environ['DISPLAY'] = previous
    # The server stays up until this process exits: pyglet's open X connection would
    # end the process (Xlib I/O error) if it went away first.
    atexit.register(server.terminate)
