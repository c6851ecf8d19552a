"""
The thin Jazzy ``main`` every executable shares, and the choice of executor.

Executors.  ``events`` (the default) is rclpy's C++
``rclpy.experimental.EventsExecutor``: it takes each message, timer and
service request as an event, without rebuilding a wait set per callback, and
delivers about 7x the messages per second of the ``single`` (Python
``SingleThreadedExecutor``) on a 2-core machine.  It is marked experimental in
rclpy 7.1.6; the project's tests run every node on it (timers, parameter
services, ``spin_until_future_complete``, shutdown) and on ``single`` where a
test says so.  Set ``EYE_BCI_EXECUTOR=single`` to use the Python executor in
every executable, the demo, the benches and the tests.
"""

import os
import sys
from typing import Callable, List, Optional

import rclpy
from rclpy.context import Context
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node

#: Executor names, default first.
EXECUTORS = ('events', 'single')
#: Environment variable that selects the executor by name.
EXECUTOR_ENV = 'EYE_BCI_EXECUTOR'


def executor_kind() -> str:
    """Return the executor name in force: ``$EYE_BCI_EXECUTOR``, else the default."""
    kind = os.environ.get(EXECUTOR_ENV, '').strip().lower() or EXECUTORS[0]
    if kind not in EXECUTORS:
        raise ValueError(f"{EXECUTOR_ENV}='{kind}' is not one of {', '.join(EXECUTORS)}")
    return kind


def make_executor(context: Optional[Context] = None, kind: Optional[str] = None) -> Executor:
    """
    Create the executor in force (module doc).

    :param context: rclpy context (None: the default one).
    :param kind: ``events`` or ``single``; None = :func:`executor_kind`.
    """
    kind = kind or executor_kind()
    if kind == 'events':
        # It enables faulthandler on sys.stderr, which raises when stderr is no file
        # (captured by pytest, replaced by a GUI): give it the process's own stderr then.
        saved = sys.stderr
        try:
            sys.stderr.fileno()
        except (AttributeError, OSError, ValueError):
            sys.stderr = sys.__stderr__
        try:
            return EventsExecutor(context=context)
        finally:
            sys.stderr = saved
    if kind == 'single':
        return SingleThreadedExecutor(context=context)
    raise ValueError(f"executor '{kind}' is not one of {', '.join(EXECUTORS)}")


def spin_nodes(make_nodes: Callable[[], List[Node]], args: Optional[List[str]] = None) -> None:
    """
    Init rclpy, spin nodes on one executor until Ctrl-C or shutdown, then clean up.

    A node that refuses to start (a bad parameter override or file) exits with
    status 1 and its reason, not a traceback.

    :param make_nodes: builds the nodes (after ``rclpy.init``).
    :param args: command-line arguments (``--ros-args ...``), default sys.argv.
    """
    rclpy.init(args=args)
    nodes: List[Node] = []
    executor = None
    status = 0
    try:
        executor = make_executor()
        nodes = make_nodes()
        for node in nodes:
            executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ValueError, InvalidParameterValueException, InvalidParameterTypeException) as error:
        print(f'cannot start: {error}', file=sys.stderr)
        status = 1
    finally:
        if executor is not None:
            executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    if status:
        sys.exit(status)


def spin_node(make_node: Callable[[], Node], args: Optional[List[str]] = None) -> None:
    """Run one node as :func:`spin_nodes` does."""
    spin_nodes(lambda: [make_node()], args)
