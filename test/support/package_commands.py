"""The package's executables as a user starts them, for :mod:`watched_process`."""

import contextlib
import os
from pathlib import Path
import re
import sys
from typing import Iterator, List

from domain_coordinator import domain_id
from watched_process import Process


def command(module: str, *args: str) -> List[str]:
    """Return the command line of ``eye_bci_ros2.<module>`` (what its console script runs)."""
    return [sys.executable, '-m', f'eye_bci_ros2.{module}', *args]


def lines(process: Process, pattern: str) -> List[str]:
    """Return the lines of the process's output that match ``pattern`` (regex)."""
    return [line for line in process.output().splitlines() if re.search(pattern, line)]


def ended(module: str, *args: str, log: Path) -> Process:
    """Run an executable on a private domain until it ends by itself; return its process."""
    with domain_id() as domain:
        process = Process(command(module, *args), dict(os.environ), domain, log)
        process.finish()
    return process


def stop_all(*processes) -> None:
    """Press Ctrl-C in each process still running and wait for its end (a failed test's)."""
    for process in processes:
        if process is not None and process.process.poll() is None:
            process.interrupt()
            process.finish()


def stop(process: Process) -> int:
    """Press Ctrl-C and wait for the end; return the exit status."""
    process.interrupt()
    return process.finish()


@contextlib.contextmanager
def running(module: str, *args: str, log: Path, domain: int) -> Iterator[Process]:
    """Give the block an executable started on ``domain``; stop it if the block left it."""
    process = Process(command(module, *args), dict(os.environ), domain, log)
    try:
        yield process
    finally:
        stop_all(process)
