"""A command started as a user starts it, its output watched for the lines that mark events."""

import os
from pathlib import Path
import re
import signal
import subprocess
import time
from typing import List

#: Longest wait for a process to start, answer or stop, s.
WAIT_S = 60.0
#: The lines that must never reach a user.
TRACEBACK = re.compile(r'Traceback \(most recent call last\)|KeyboardInterrupt')


class Process:
    """A command started as a user starts it, in its own process group, output collected."""

    def __init__(self, command: List[str], env: dict, domain: int, log: Path):
        self.log = log
        self._file = open(log, 'w')
        self.process = subprocess.Popen(
            command, env=dict(env, ROS_DOMAIN_ID=str(domain)), stdout=self._file,
            stderr=subprocess.STDOUT, text=True, start_new_session=True,
            # A shell's background job ignores SIGINT; a terminal's foreground job does not.
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))

    def output(self) -> str:
        """Return everything the process printed so far."""
        return self.log.read_text()

    def wait_for(self, pattern: str, timeout: float = WAIT_S, count: int = 1) -> bool:
        """Wait until ``pattern`` (regex) appeared ``count`` times; False if it ended first."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if len(re.findall(pattern, self.output())) >= count:
                return True
            if self.process.poll() is not None:
                return len(re.findall(pattern, self.output())) >= count
            time.sleep(0.1)
        return False

    def interrupt(self, times: int = 1, gap_s: float = 0.3) -> None:
        """Press Ctrl-C ``times``: SIGINT to the whole process group."""
        for _ in range(times):
            try:
                os.killpg(self.process.pid, signal.SIGINT)
            except ProcessLookupError:
                return
            time.sleep(gap_s)

    def finish(self, timeout: float = WAIT_S) -> int:
        """Wait for the end; return the exit status (kill the group if it hangs)."""
        try:
            return self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait()
            raise AssertionError(f'did not end within {timeout:g} s:\n{self.output()[-3000:]}')
        finally:
            self._file.close()
