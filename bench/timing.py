"""
Shared timing helpers for the benchmarks.

Every measurement calls the function a few times untimed first (warm-up:
caches, lazy imports, numpy dispatch), then times ``repeat`` batches of
``number`` calls with :func:`time.perf_counter` while the garbage collector is
disabled, and reports the minimum and the median per call.  The minimum is the
best estimate of what the code costs; the median shows how much the machine
(2 shared cores) disturbed the run.
"""

from dataclasses import dataclass
import gc
import json
import os
import platform
import statistics
import sys
import time
from typing import Callable, Dict, List

import numpy as np


@dataclass(frozen=True)
class Timing:
    """Seconds per call of a timed function."""

    #: Fastest batch, s per call.
    min_s: float
    #: Median batch, s per call.
    median_s: float
    #: Number of timed batches.
    repeat: int
    #: Calls per batch.
    number: int

    @property
    def min_ms(self) -> float:
        """Fastest batch, ms per call."""
        return self.min_s * 1e3

    @property
    def median_ms(self) -> float:
        """Median batch, ms per call."""
        return self.median_s * 1e3


class _GcDisabled:
    """Context manager: garbage collector off inside, previous state restored after."""

    def __enter__(self):
        self._was_enabled = gc.isenabled()
        gc.collect()
        gc.disable()
        return self

    def __exit__(self, *exc_info):
        if self._was_enabled:
            gc.enable()
        return False


def time_batches(func: Callable[[], object], number: int, repeat: int) -> List[float]:
    """
    Time ``repeat`` batches of ``number`` calls of ``func`` with the GC disabled.

    :returns: seconds per call of each batch, length ``repeat``.
    """
    if number < 1 or repeat < 1:
        raise ValueError(f'number and repeat must be >= 1, got {number} and {repeat}')
    per_call = []
    with _GcDisabled():
        for _ in range(repeat):
            start = time.perf_counter()
            for _ in range(number):
                func()
            per_call.append((time.perf_counter() - start) / number)
    return per_call


def autorange(func: Callable[[], object], min_batch_s: float = 0.02,
              max_number: int = 100000) -> int:
    """
    Choose the calls per batch so that one batch lasts at least ``min_batch_s`` seconds.

    Short functions are batched so that the timer's resolution and the loop's
    own cost do not dominate; slow ones get ``number = 1``.
    """
    number = 1
    while number < max_number:
        elapsed = time_batches(func, number, 1)[0] * number
        if elapsed >= min_batch_s:
            break
        # Aim a little past the target so the loop rarely needs a third round.
        number = min(max_number, max(number * 2, int(number * 1.2 * min_batch_s
                                                     / max(elapsed, 1e-9))))
    return number


def measure(func: Callable[[], object], repeat: int = 7, number: int = 0, warmup: int = 2,
            min_batch_s: float = 0.02) -> Timing:
    """
    Time ``func`` (no arguments): warm-up, then ``repeat`` batches.

    :param func: the code under test; its result is discarded.
    :param repeat: number of timed batches (the min and median are over these).
    :param number: calls per batch; 0 chooses it with :func:`autorange`.
    :param warmup: untimed calls first.
    :param min_batch_s: batch duration :func:`autorange` aims for, s.
    :returns: per-call :class:`Timing`.
    """
    for _ in range(warmup):
        func()
    if number <= 0:
        number = autorange(func, min_batch_s)
    per_call = time_batches(func, number, repeat)
    return Timing(min(per_call), statistics.median(per_call), repeat, number)


def _cpu_model() -> str:
    """CPU model name from /proc/cpuinfo, else what :mod:`platform` knows."""
    try:
        with open('/proc/cpuinfo', encoding='utf-8') as cpuinfo:
            for line in cpuinfo:
                if line.startswith('model name'):
                    return line.split(':', 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_info() -> Dict[str, object]:
    """Describe the machine and software the numbers were measured on."""
    try:
        available = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        available = os.cpu_count()
    try:
        load = list(os.getloadavg())
    except OSError:
        load = None
    return {
        'cpu_count': os.cpu_count(),
        'cpus_available': available,
        'load_average_1_5_15_min': load,
        'processor': _cpu_model(),
        'platform': platform.platform(),
        'python': sys.version.split()[0],
        'python_implementation': platform.python_implementation(),
        'numpy': np.__version__,
        # numpy's BLAS threads compete for the shared cores; say how they were set.
        'thread_environment': {name: os.environ.get(name) for name in (
            'OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS')},
    }


def report(lines: List[str], results: Dict[str, object], started: float,
           json_path: str = '') -> None:
    """
    Print a bench's table lines and its run time; write its results as JSON when asked.

    :param lines: the formatted table.
    :param results: what the bench measured (JSON-serialisable).
    :param started: ``time.perf_counter()`` at the bench's start.
    :param json_path: file to write the results to ('' = none).
    """
    print('\n'.join(lines))
    print(f'({time.perf_counter() - started:.0f} s)')
    if json_path:
        with open(json_path, 'w') as stream:
            json.dump(results, stream, indent=1)
