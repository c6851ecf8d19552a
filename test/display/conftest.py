"""One private Xvfb server for all display tests (pyglet keeps its X connection open)."""

import os
import shutil
import subprocess
import time

import pytest


@pytest.fixture(scope='session')
def xvfb():
    """Run a private Xvfb server (an X server without a monitor) for the whole session."""
    if shutil.which('Xvfb') is None:
        pytest.skip('needs Xvfb (apt package xvfb)')
    number = 100 + os.getpid() % 800
    server = subprocess.Popen(['Xvfb', f':{number}', '-screen', '0', '800x600x24',
                               '-nolisten', 'tcp'], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    time.sleep(1.0)
    previous = os.environ.get('DISPLAY')
    os.environ['DISPLAY'] = f':{number}'
    yield f':{number}'
    import pyglet
    for window in list(pyglet.app.windows):
        window.close()
    if previous is None:
        os.environ.pop('DISPLAY', None)
    else:
        os.environ['DISPLAY'] = previous
    # The server stays up until this process exits: pyglet's open X connection would
    # end the process (Xlib I/O error) if it went away first.
    import atexit
    atexit.register(server.terminate)
