"""An executable started as a user starts it from a terminal, its output kept in a file."""

import os
from pathlib import Path
import re
import signal
import subprocess
import sys
import time
from typing import List, Optional

#: Longest wait for a line, s (a loaded machine: imports and discovery take seconds).
WAIT_S = 60.0


class UserProcess:
    """
    ``python -m eye_bci_ros2.<module> args`` in its own process group, stdout and stderr in a file.

    :param module: the module under ``eye_bci_ros2`` (what the console script runs).
    :param log: the file the output goes to.
    :param domain: ROS_DOMAIN_ID (None: the environment's).
    """

    def __init__(self, module: str, *args: str, log: Path, domain: Optional[int] = None):
        env = dict(os.environ)
        if domain is not None:
            env['ROS_DOMAIN_ID'] = str(domain)
        self.log = log
        self._file = open(log, 'w')
        command: List[str] = [sys.executable, '-m', f'eye_bci_ros2.{module}', *args]
        self.process = subprocess.Popen(command, env=env, stdout=self._file,
                                        stderr=subprocess.STDOUT, text=True,
                                        start_new_session=True)

    def output(self) -> str:
        """Return everything the process printed so far."""
        return self.log.read_text()

    def wait_for(self, pattern: str, timeout: float = WAIT_S, count: int = 1) -> Optional[str]:
        """Wait until ``pattern`` (regex) is on ``count`` lines; return the last, None if not."""
        end = time.monotonic() + timeout
        while True:
            lines = [line for line in self.output().splitlines() if re.search(pattern, line)]
            if len(lines) >= count:
                return lines[count - 1]
            if self.process.poll() is not None or time.monotonic() > end:
                return None
            time.sleep(0.1)

    def stop(self, timeout: float = WAIT_S) -> int:
        """Press Ctrl-C (SIGINT to the group) and wait for the end; return the exit status."""
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGINT)
        try:
            return self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait()
            raise AssertionError(f'did not end within {timeout:g} s:\n{self.output()[-3000:]}')
        finally:
            self._file.close()

    def __enter__(self) -> 'UserProcess':
        """Give the process to the block."""
        return self

    def __exit__(self, *_) -> None:
        """Stop it if the block left it running (a failed test)."""
        if self.process.poll() is None:
            self.stop()
        self._file.close()
