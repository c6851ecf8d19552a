"""A private Xvfb server (an X server without a monitor) for tests that open a window."""

import os
import select
import shutil
import subprocess
import tempfile
import time
from typing import Tuple

#: How long Xvfb may take to accept connections on a loaded machine, s.
START_DEADLINE_S = 60.0


def start_xvfb(size: str = '800x600x24') -> Tuple[subprocess.Popen, str]:
    """
    Start Xvfb on a free display and return (process, display name) once it accepts clients.

    Xvfb chooses the display number itself and writes it to ``-displayfd`` when
    it is ready for connections: no guessed number, no sleep.

    :raises FileNotFoundError: no Xvfb here (the apt package ``xvfb``).
    :raises RuntimeError: it did not say it was ready within :data:`START_DEADLINE_S`.
    """
    if shutil.which('Xvfb') is None:
        raise FileNotFoundError('Xvfb (apt package xvfb)')
    read_end, write_end = os.pipe()
    log = tempfile.TemporaryFile()  # a file, not a pipe: nobody reads it while it runs
    server = subprocess.Popen(['Xvfb', '-displayfd', str(write_end), '-screen', '0', size,
                               '-nolisten', 'tcp'], pass_fds=(write_end,),
                              stdout=subprocess.DEVNULL, stderr=log)
    os.close(write_end)
    try:
        number = _read_line(read_end, time.monotonic() + START_DEADLINE_S)
    finally:
        # Only after the newline: Xvfb writes the number and the newline apart, and
        # dies if the pipe is gone between them.
        os.close(read_end)
    if not number:
        server.kill()
        server.wait(timeout=10)
        log.seek(0)
        error = log.read().decode(errors='replace').strip()
        raise RuntimeError(f'Xvfb did not report its display within {START_DEADLINE_S:g} s: '
                           f'{error.splitlines()[-1] if error else "no message"}')
    log.close()
    return server, f':{number}'


def _read_line(fd: int, deadline: float) -> str:
    """Read up to a newline (or end of file, or the monotonic ``deadline``); '' if none."""
    text = b''
    while not text.endswith(b'\n'):
        ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
        chunk = os.read(fd, 64) if ready else b''
        if not chunk:
            return ''
        text += chunk
    return text.decode().strip()
