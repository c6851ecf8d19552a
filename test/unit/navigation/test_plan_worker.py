"""
The planning worker: the latest request is planned, outcomes are taken, a bad goal says why.

The queue's rules are tested in the thread (``separate_process=False``, where a test's own
planner can hold it busy); the real planning process with real plans and refusals.
"""

import threading
import time

import numpy as np
from paths import CONFIG
import pytest

from eye_bci_ros2.navigation.nav2_codes import GOAL_OCCUPIED, PLANNER_UNKNOWN
from eye_bci_ros2.navigation.occupancy import scene_grid
from eye_bci_ros2.navigation.plan_worker import PlanWorker
from eye_bci_ros2.navigation.planner import NoPath, Plan, Planner
from eye_bci_ros2.task.scene import load_scene

PLANNER = Planner(scene_grid(load_scene(CONFIG / 'scene.yaml')), 0.3)


def outcomes_of(worker, count, timeout=30.0):
    """Wait (polling, as the robot's tick does) until ``count`` outcomes came; return them."""
    found = []
    end = time.monotonic() + timeout
    while len(found) < count and time.monotonic() < end:
        found += worker.take()
        time.sleep(0.005)
    return found


@pytest.fixture
def worker():
    worker = PlanWorker(separate_process=False)
    yield worker
    worker.close()


@pytest.fixture(scope='module')
def process_worker():
    worker = PlanWorker()
    yield worker
    worker.close()


def test_a_plan_and_a_refusal_come_back_tagged_from_the_planning_process(process_worker):
    worker = process_worker
    worker.warm(PLANNER)
    worker.request('a', PLANNER, np.array([2.0, 5.0]), np.array([18.0, 10.5]))
    (first,) = outcomes_of(worker, 1)
    assert first.key == 'a' and isinstance(first.result, Plan)
    assert np.allclose(first.result.points[-1], [18.0, 10.5])
    worker.request('b', PLANNER, np.array([2.0, 5.0]), np.array([10.0, 3.0]))
    (second,) = outcomes_of(worker, 1)
    assert second.key == 'b' and isinstance(second.result, NoPath)
    assert second.result.code == GOAL_OCCUPIED and worker.idle


def test_a_newer_request_replaces_one_not_started_and_a_withdrawn_one_is_dropped(worker):
    gate = threading.Event()

    class Slow:
        """A planner that waits for the test before it plans (to hold the thread busy)."""

        def plan(self, start, goal):
            gate.wait(10.0)
            return PLANNER.plan(start, goal)

    worker.request('busy', Slow(), np.array([2.0, 5.0]), np.array([3.0, 5.0]))
    time.sleep(0.05)
    worker.request('old', PLANNER, np.array([2.0, 5.0]), np.array([4.0, 5.0]))
    worker.request('new', PLANNER, np.array([2.0, 5.0]), np.array([5.0, 6.0]))
    worker.withdraw('busy')
    assert not worker.idle
    gate.set()
    found = outcomes_of(worker, 1)
    found += outcomes_of(worker, 1, timeout=0.5)
    assert [outcome.key for outcome in found] == ['new']


def test_a_bug_in_planning_is_an_outcome_not_a_dead_thread(worker):
    class Broken:
        def plan(self, start, goal):
            raise ZeroDivisionError('oops')

    worker.request('x', Broken(), np.zeros(2), np.ones(2))
    (outcome,) = outcomes_of(worker, 1)
    assert isinstance(outcome.result, NoPath) and outcome.result.code == PLANNER_UNKNOWN
    assert 'ZeroDivisionError' in str(outcome.result)
    worker.request('y', PLANNER, np.array([2.0, 5.0]), np.array([4.0, 5.0]))
    assert isinstance(outcomes_of(worker, 1)[0].result, Plan)


def test_the_process_plans_a_new_map_it_is_sent_and_close_ends_thread_and_process():
    worker = PlanWorker()
    child = worker._child._process
    worker.request('a', PLANNER, np.array([2.0, 5.0]), np.array([18.0, 10.5]))
    assert isinstance(outcomes_of(worker, 1)[0].result, Plan)
    # A wider robot on the same map: the door it cannot pass says so.
    wide = Planner(PLANNER.grid, 0.6)
    worker.request('b', wide, np.array([2.0, 5.0]), np.array([18.0, 10.5]))
    (outcome,) = outcomes_of(worker, 1)
    assert isinstance(outcome.result, NoPath) and 'radius 0.6 m' in str(outcome.result)
    worker.close()
    assert not worker._thread.is_alive() and child.poll() is not None
