"""
Planning in a thread of its own, so that a robot's control loop never waits for a plan.

The simulated robot publishes odometry and TF at 20 Hz from its executor's
thread; a plan across the scene takes tens of milliseconds
(:mod:`eye_bci_ros2.navigation.planner`).  :class:`PlanWorker` takes one
request at a time (a newer request replaces one not yet started: only the
latest goal matters) and leaves the outcome, a
:class:`~eye_bci_ros2.navigation.planner.Plan` or the
:class:`~eye_bci_ros2.navigation.planner.NoPath` that says why not, for the
loop to take at its next tick (:meth:`PlanWorker.take`).  The loop never
blocks on it.  scipy's Dijkstra holds the GIL while it runs (a few
milliseconds on the shipped scene), so the loop's tick can be that late, never
skipped; the rest of a plan (the shortcut, in numpy) lets it run.

Pure Python (threading); the thread is a daemon and :meth:`PlanWorker.close`
ends it.
"""

from dataclasses import dataclass
import threading
from typing import Hashable, List, Optional, Union

import numpy as np

from eye_bci_ros2.navigation import nav2_codes
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
    """A thread that plans the latest request (module doc)."""

    def __init__(self, name: str = 'planner'):
        """Start the thread."""
        self._lock = threading.Condition()
        self._request = None
        self._outcomes: List[PlanOutcome] = []
        self._closed = False
        self._busy = False
        self._withdrawn: Optional[Hashable] = None
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
        """Build ``planner``'s graph in the thread (the first plan on a new map is slower)."""
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
        """End the thread (after the plan it is computing, if any)."""
        with self._lock:
            self._closed = True
            self._lock.notify()
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
            result: Optional[Union[Plan, NoPath]] = None
            try:
                if start is None:
                    planner.warm()
                else:
                    result = planner.plan(start, goal)
            except NoPath as error:
                result = error
            except Exception as error:  # noqa: B902 - a bug must not end the thread unheard
                result = NoPath(f'planning failed: {error!r}', nav2_codes.PLANNER_UNKNOWN)
            with self._lock:
                self._busy = False
                if result is not None and self._withdrawn != key:
                    self._outcomes.append(PlanOutcome(key=key, result=result))
