"""
Planning off the robot's control loop: a thread, and by default a process of its own.

The simulated robot publishes odometry and TF at 20 Hz from its executor's
thread; a plan takes milliseconds to tenths of a second (the map's size and
resolution, :mod:`eye_bci_ros2.navigation.planner`).  :class:`PlanWorker`
takes one request at a time (a newer request replaces one not yet started:
only the latest goal matters) and leaves the outcome, a
:class:`~eye_bci_ros2.navigation.planner.Plan` or the
:class:`~eye_bci_ros2.navigation.planner.NoPath` that says why not, for the
loop to take at its next tick (:meth:`PlanWorker.take`); the loop never waits.

Where the plan is computed: scipy's Dijkstra holds the GIL while it runs, so
a plan in a thread of the robot's process would hold the loop for that long
(on a 0.02 m map, about a tenth of a second: two odometry ticks lost per
plan).  With ``separate_process`` (the default) the worker thread hands each
request to a child Python process (``python -m
eye_bci_ros2.navigation.plan_worker``, this module: numpy and scipy, no ROS)
over a pipe and waits for the answer without the GIL; the map goes to the
child once per planner.  The child lives in its own session (a terminal's
Ctrl-C does not reach it) and ends when its pipe closes: when
:meth:`PlanWorker.close` is called or the robot's process ends in any way.
``separate_process=False`` plans in the thread (tests of the queue's
semantics).

Pure Python (threading, subprocess, multiprocessing.connection).
"""

from dataclasses import dataclass
from multiprocessing.connection import Connection
import os
import signal
import subprocess
import sys
import threading
from typing import Hashable, List, Optional, Union

import numpy as np

from eye_bci_ros2.navigation import nav2_codes
from eye_bci_ros2.navigation.occupancy import Grid
from eye_bci_ros2.navigation.planner import NoPath, Plan, Planner


@dataclass(frozen=True, eq=False)
class PlanOutcome:
    """
    What came of one request.

    :ivar key: the caller's tag of the request (e.g. its goal).
    :ivar result: the plan, or why there is none.
    """

    key: Hashable
    result: Union[Plan, NoPath]


class PlanWorker:
    """A thread that plans the latest request, in a child process by default (module doc)."""

    def __init__(self, name: str = 'planner', separate_process: bool = True):
        """Start the thread (and the child process)."""
        self._lock = threading.Condition()
        self._request = None
        self._outcomes: List[PlanOutcome] = []
        self._closed = False
        self._busy = False
        self._withdrawn: Optional[Hashable] = None
        self._child: Optional[_Child] = _Child() if separate_process else None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def request(self, key: Hashable, planner: Planner, start: np.ndarray,
                goal: np.ndarray) -> None:
        """Ask for a plan from ``start`` to ``goal`` (x, y, m); it replaces one not started."""
        with self._lock:
            self._request = (key, planner, np.array(start[:2], dtype=float),
                             np.array(goal[:2], dtype=float))
            self._lock.notify()

    def warm(self, planner: Planner) -> None:
        """Build ``planner``'s graph ahead (the first plan on a new map is slower)."""
        with self._lock:
            if self._request is None:
                self._request = (None, planner, None, None)
                self._lock.notify()

    def withdraw(self, key: Hashable) -> None:
        """Forget the request tagged ``key``, started or not, and its outcome."""
        with self._lock:
            if self._request is not None and self._request[0] == key:
                self._request = None
            self._outcomes = [outcome for outcome in self._outcomes if outcome.key != key]
            self._withdrawn = key

    def take(self) -> List[PlanOutcome]:
        """Return the outcomes finished since the last call (never blocks for long)."""
        with self._lock:
            outcomes, self._outcomes = self._outcomes, []
        return outcomes

    @property
    def idle(self) -> bool:
        """Tell whether nothing is asked or being planned."""
        with self._lock:
            return self._request is None and not self._busy

    def close(self, timeout: float = 2.0) -> None:
        """End the thread and the child (after the plan being computed, if any)."""
        with self._lock:
            self._closed = True
            self._lock.notify()
        if self._child is not None:
            self._child.close(timeout)
        self._thread.join(timeout)

    def _run(self) -> None:
        while True:
            with self._lock:
                while self._request is None and not self._closed:
                    self._lock.wait()
                if self._closed:
                    return
                key, planner, start, goal = self._request
                self._request = None
                self._busy = True
                self._withdrawn = None
            try:
                result = self._plan(planner, start, goal)
            except NoPath as error:
                result = error
            except Exception as error:  # noqa: B902 - a bug must not end the thread unheard
                result = NoPath(f'planning failed: {error!r}', nav2_codes.PLANNER_UNKNOWN)
            with self._lock:
                self._busy = False
                if result is not None and self._withdrawn != key:
                    self._outcomes.append(PlanOutcome(key=key, result=result))

    def _plan(self, planner: Planner, start, goal) -> Optional[Plan]:
        if self._child is None:
            if start is None:
                planner.warm()
                return None
            return planner.plan(start, goal)
        return self._child.plan(planner, start, goal)


class _Child:
    """The planning process and the pipes to it (used by the worker's thread only)."""

    def __init__(self):
        from_parent, to_child = os.pipe()
        from_child, to_parent = os.pipe()
        self._process = subprocess.Popen(
            [sys.executable, '-m', __name__, str(from_parent), str(to_parent)],
            pass_fds=(from_parent, to_parent), start_new_session=True,
            env=dict(os.environ, OPENBLAS_NUM_THREADS='1'))
        os.close(from_parent)
        os.close(to_parent)
        self._send = Connection(to_child, readable=False)
        self._receive = Connection(from_child, writable=False)
        self._planner: Optional[Planner] = None

    def plan(self, planner: Planner, start, goal) -> Optional[Plan]:
        """Plan in the child (sending it the map first when the planner is new)."""
        if self._process.poll() is not None:
            raise NoPath(f'the planning process ended (status {self._process.returncode})',
                         nav2_codes.PLANNER_UNKNOWN)
        if planner is not self._planner:
            grid = planner.grid
            self._send.send(('map', grid.blocked, grid.resolution, grid.origin,
                             planner.radius_m))
            self._planner = planner
        if start is None:
            return None
        self._send.send(('plan', start, goal))
        kind, *payload = self._receive.recv()
        if kind == 'plan':
            return Plan(points=payload[0])
        raise NoPath(*payload)

    def close(self, timeout: float) -> None:
        """Close the pipes: the child ends; wait for it."""
        for connection in (self._send, self._receive):
            connection.close()
        try:
            self._process.wait(timeout)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()


def serve(receive: Connection, send: Connection) -> None:
    """Run the child's loop: a map, then plans, until the pipe closes."""
    planner: Optional[Planner] = None
    while True:
        try:
            message = receive.recv()
        except (EOFError, OSError):
            return
        if message[0] == 'map':
            _, blocked, resolution, origin, radius = message
            planner = Planner(Grid(blocked=blocked, resolution=resolution, origin=origin),
                              radius)
            planner.warm()
            continue
        _, start, goal = message
        try:
            send.send(('plan', planner.plan(start, goal).points))
        except NoPath as error:
            send.send(('nopath', str(error), error.code))
        except Exception as error:  # noqa: B902 - told to the robot, the child goes on
            send.send(('nopath', f'planning failed: {error!r}', nav2_codes.PLANNER_UNKNOWN))


if __name__ == '__main__':
    # A terminal's Ctrl-C does not reach this process (its own session); the parent closing
    # the pipe ends it.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    serve(Connection(int(sys.argv[1]), writable=False),
          Connection(int(sys.argv[2]), readable=False))
