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
every executable, the demo, the benches and the tests.  Its ``spin()`` is not
used: in rclpy 7.1.6 it polls the clock at most of a core and does not return
on a signal, while ``spin_once(timeout)`` waits without CPU (bench/README).

Stopping.  rclpy's own signal handlers are not installed: they raise
KeyboardInterrupt wherever the main thread is (a second Ctrl-C from
``ros2 launch`` then lands inside ``destroy_node``) and shut the context down
from another thread while the executor builds its wait set.  Here SIGINT and
SIGTERM only set a flag that the spin loop checks every
:data:`STOP_POLL_S`; once it stops, both are ignored, and a clean-up that
hangs (rclpy's ``destroy_node`` has been seen spinning) ends after
:data:`CLEANUP_LIMIT_S` with one line and status 1.  A clean-up stuck in C
code that holds the interpreter (where no Python thread runs, and the ignored
signals would leave it to SIGKILL) ends :data:`HARD_LIMIT_S` later through
``faulthandler``'s own thread: status 1 and the stacks where it hung.  A
normal stop exits 0.  A Ctrl-C before these handlers (during the imports) ends
the process quietly with status 0 (:mod:`eye_bci_ros2.ros.startup`), also when
an import swallowed it: nothing is started then.
A node that does one job and ends (``gaze_validation``) sets its attribute
``exit_status`` (an int, None while it runs): the loop stops and the process
exits with it.  A window that must draw in the main thread
(``ssvep_stimulus``) passes a ``foreground`` loop: the executor then spins in
a second thread.

Pauses.  Once the nodes exist, everything made at start-up (modules, rclpy,
numpy, message types, parameters) is moved out of the garbage collector's
reach (:func:`gc.freeze`): a full collection otherwise walks all of it, and
paused the whole process 17-18 ms every ten seconds or so at tracker rates,
a decision late by that whenever it fell at a window end (``python -m
bench.lab_rate``).  Nothing made at start-up is freed by it: those objects
live as long as the process.

Mistakes on the command line are one line each: an unknown option (``eye_bci
--with-menus``) or a ROS argument before ``--ros-args`` (``-p x:=1``) refuse
to start; a parameter name that no node declares (``-p screen_ofset_x:=64``,
a params-file key ``image_widht``) is warned with the closest known name.
"""

import difflib
import faulthandler
import gc
import importlib
import os
import re
import signal
import sys
import threading
import time
from typing import Callable, List, Optional, Sequence, Tuple

import rclpy
from rclpy.context import Context
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from eye_bci_ros2.ros.parameters import quote_param_rules, warn_unknown_overrides
from eye_bci_ros2.ros.startup import ctrl_c_pending, quiet_liblsl

#: rcl's error type (a bad params file, a malformed --ros-args rule).  rclpy raises it
#: from ``rclpy.init`` but exports it only from its private C extension
#: (``rclpy.impl.implementation_singleton``); this is the one place that imports it.
RCLError = _rclpy.RCLError
#: The event that moves an accepted action goal to EXECUTING, from the same extension.
#: rclpy's ``ServerGoalHandle.execute()`` also schedules a coroutine that must wait for the
#: goal's end, and the EventsExecutor resumes a waiting coroutine without pause (measured:
#: 180 000 resumes in 2 s, a third of a core): an action server that ends its goals from a
#: timer (sim_robot) moves them to EXECUTING with this event instead.
GOAL_EXECUTE_EVENT = _rclpy.GoalEvent.EXECUTE

#: Executor names, default first.
EXECUTORS = ('events', 'single')
#: Environment variable that selects the executor by name.
EXECUTOR_ENV = 'EYE_BCI_EXECUTOR'
#: Signals that stop an executable.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: Longest a stop request waits for the spin loop to notice it, s.
STOP_POLL_S = 0.1
#: Longest the clean-up after a stop may take before the process gives up, s.
CLEANUP_LIMIT_S = 5.0
#: ... and past this many more seconds, when no Python thread can run (module doc).
HARD_LIMIT_S = 2.0
#: ROS arguments that only work after ``--ros-args`` (rcl ignores them before it).
ROS_ONLY_ARGS = ('-p', '--param', '--params-file', '-r', '--remap', '--log-level', '-e',
                 '--enclave')


class StartError(RuntimeError):
    """A node cannot start for a reason the user can fix (no display, no consent, ...)."""


def executor_kind() -> str:
    """Return the executor name in force: ``$EYE_BCI_EXECUTOR``, else the default."""
    kind = os.environ.get(EXECUTOR_ENV, '').strip().lower() or EXECUTORS[0]
    if kind not in EXECUTORS:
        raise ValueError(f"{EXECUTOR_ENV}='{kind}' is not one of {', '.join(EXECUTORS)}")
    return kind


def freeze_startup_objects() -> None:
    """Move everything made so far out of the garbage collector's reach (module doc, "Pauses")."""
    gc.collect()
    gc.freeze()


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


def spin_until(executor: Executor, predicate: Callable[[], bool], timeout: float,
               poll: Optional[Callable[[], None]] = None, step_s: float = 0.01) -> bool:
    """
    Spin ``executor`` until ``predicate()`` holds or ``timeout`` s pass; return whether it held.

    :param poll: called after every spin step (e.g. to feed a simulated sender).
    :param step_s: longest wait of one step, s.
    """
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        executor.spin_once(timeout_sec=step_s)
        if poll is not None:
            poll()
    return predicate()


def spin_for(executor: Executor, seconds: float, step_s: float = 0.01) -> None:
    """Spin ``executor`` for ``seconds`` of wall time."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=min(step_s, max(0.0, end - time.monotonic())))


def non_ros_args(argv: List[str]) -> List[str]:
    """
    Return ``argv`` without its ROS arguments: each ``--ros-args`` up to ``--`` or the end.

    rcl's rule, applied here rather than by rclpy's ``remove_ros_args``: rcl
    parses every argument outside ``--ros-args`` too and warns of each
    ``name:=name`` there as a remap rule in a deprecated form, once per call (a
    mistyped ``-p profile:=tobii_pro`` before ``--ros-args`` got three such lines
    before the one that says what to do, :func:`command_line_problem`).
    """
    kept, ros = [], False
    for arg in argv:
        if ros:
            ros = arg != '--'
        elif arg == '--ros-args':
            ros = True
        else:
            kept.append(arg)
    return kept


def _stop_on_signals(stop: threading.Event) -> None:
    """Make SIGINT and SIGTERM only ask the spin loop to stop (module doc, "Stopping")."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, lambda *_: stop.set())


def _ignore_signals() -> None:
    """Ignore further SIGINT / SIGTERM: the clean-up must not be cut short."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)


def _first_line(error: BaseException) -> str:
    """Return the first line of an error's text (rcl's errors carry their C call stack)."""
    text = str(error).strip().splitlines()
    return text[0] if text else type(error).__name__


def plain_text(text: str) -> str:
    """Strip reST markup (````code````, ``:class:`x```) from a docstring for a terminal."""
    text = re.sub(r':[a-z]+:`~?([^`]+)`', lambda m: m.group(1).split('.')[-1], text)
    return text.replace('``', '')


def summary(module_doc: str) -> str:
    """Return the first paragraph of a module's docstring, plain (:func:`plain_text`)."""
    paragraph = (module_doc or '').strip().split('\n\n')[0]
    return plain_text(' '.join(line.strip() for line in paragraph.splitlines()))


def help_text(modules: Sequence[str], usage: str, options: Sequence[str] = ()) -> str:
    """
    Say what an executable does, in plain text: its nodes' summaries and parameters.

    One node: its docstring (plain) and one line per parameter.  Several nodes
    (``eye_bci``): one line per node and where to find each one's parameters.

    :param modules: names of the node modules (their docstring and ``PARAMETERS``).
    :param usage: the first line, e.g. ``ros2 run eye_bci_ros2 choice_arbiter``.
    :param options: the executable's own options, ``(option, what it does)``
        pairs (``--help`` is always there).
    """
    parts = [f'usage: {usage} [--ros-args -p NAME:=VALUE ... --params-file FILE]', '']
    loaded = [importlib.import_module(name) for name in modules]
    if len(loaded) > 1:
        parts.append(summary(loaded[0].__doc__ or ''))
        parts += ['', 'nodes (ros2 run eye_bci_ros2 NODE --help: its parameters):']
        for module in loaded[1:]:
            name = module.__name__.rsplit('.', 1)[-1]
            # Their docstrings start "Node NAME: ..." or "NAME: ...": said once here.
            text = re.sub(rf'^(Node )?`*{name}`*: ', '', summary(module.__doc__))
            parts.append(f'  {name}: {text}')
    else:
        parts.append(plain_text((loaded[0].__doc__ or '').strip()))
        specs = list(getattr(loaded[0], 'PARAMETERS', ()))
        if not specs:
            parts += ['', 'parameters: ros2 param describe on the running node, or '
                      'docs/parameters.md']
        else:
            parts += ['', 'parameters (ros2 param describe NODE NAME for ranges; '
                      'docs/parameters.md):']
            for spec in specs:
                line = plain_text(spec.description.splitlines()[0])
                parts.append(f'  {spec.name} = {spec.default!r}: {_shorten(line)}')
    parts += ['', 'options:', '  -h, --help: this text']
    parts += [f'  {option}: {text}' for option, text in options]
    parts += ['', f'Ctrl-C or SIGTERM stop it cleanly.  {EXECUTOR_ENV}=single selects the '
              'Python executor.']
    return '\n'.join(parts)


def _shorten(text: str, limit: int = 100) -> str:
    return text if len(text) <= limit else text[:limit - 3].rstrip() + '...'


def command_line_problem(argv: Sequence[str], options: Sequence[str] = ()) -> Optional[str]:
    """
    Return why a command line cannot be right (one line), or None.

    :param argv: the whole command line (program first).
    :param options: the executable's own options besides ``-h``/``--help``.
    """
    for arg in non_ros_args(list(argv))[1:]:
        if arg in ('-h', '--help') or arg in options:
            continue
        if arg in ROS_ONLY_ARGS or ':=' in arg:
            return (f"'{arg}' is a ROS argument and must follow --ros-args, e.g. "
                    '--ros-args -p NAME:=VALUE (without it ROS ignores it)')
        close = difflib.get_close_matches(arg, list(options) + ['--help', '--ros-args'], n=1)
        hint = f': did you mean {close[0]}?' if close else ' (--help lists the options)'
        return f"unknown option '{arg}'{hint}"
    return None


def spin_nodes(make_nodes: Callable[[], List[Node]], args: Optional[List[str]] = None,
               help_modules: Sequence[str] = (), usage: str = '',
               options: Sequence[Tuple[str, str]] = (),
               foreground: Optional[Callable[[List[Node], threading.Event], None]] = None,
               ) -> None:
    """
    Run nodes on one executor until Ctrl-C, SIGTERM or shutdown, then clean up; exit.

    ``-h`` / ``--help`` (before ``--ros-args``) prints :func:`help_text` and
    exits 0.  A node that refuses to start (a bad parameter override, a
    missing or malformed params file, a malformed ``--ros-args`` rule, an
    unknown option, a :class:`StartError`) exits with status 1 and a one-line
    reason, not a traceback.

    :param make_nodes: builds the nodes (after ``rclpy.init``).
    :param args: command-line arguments (``--ros-args ...``), default sys.argv.
    :param help_modules: names of the node modules that ``--help`` describes.
    :param usage: the command, for ``--help`` (default: ``ros2 run eye_bci_ros2``
        and the program's name).
    :param options: the executable's own options, ``(option, what it does)``;
        the caller reads them from the command line, any other is refused.
    :param foreground: a loop to run in the main thread (a window) while the
        executor spins in a second one; called with the nodes and the stop
        event, it returns when the event is set or it is done.
    """
    argv = list(sys.argv if args is None else args)
    program = os.path.splitext(os.path.basename(argv[0]))[0] if argv else 'NODE'
    if program == '__main__':   # python -m of a node's subpackage: the subpackage's name
        program = os.path.basename(os.path.dirname(os.path.abspath(argv[0])))
    if {'-h', '--help'} & set(non_ros_args(argv)[1:]):
        try:
            print(help_text(help_modules, usage or f'ros2 run eye_bci_ros2 {program}', options))
            sys.stdout.flush()
        except BrokenPipeError:     # `--help | head`: the reader has what it wanted
            os._exit(0)
        sys.exit(0)
    problem = command_line_problem(argv, [option for option, _ in options])
    if problem:
        print(f'cannot start: {problem}', file=sys.stderr)
        sys.exit(1)
    argv = [arg for arg in argv if arg not in [option for option, _ in options]]
    if ctrl_c_pending():    # a Ctrl-C during the imports that one of them swallowed
        sys.exit(0)
    quiet_liblsl()      # also for ``python -m``, which skips the console script's start-up
    stop = threading.Event()
    _stop_on_signals(stop)
    try:
        rclpy.init(args=quote_param_rules(argv), signal_handler_options=SignalHandlerOptions.NO)
    except RCLError as error:
        print(f'cannot start: {_first_line(error)}', file=sys.stderr)
        sys.exit(1)
    nodes: List[Node] = []
    executor = None
    status = 0
    try:
        executor = make_executor()
        nodes = make_nodes()
        warn_unknown_overrides(nodes)
        for node in nodes:
            executor.add_node(node)
        freeze_startup_objects()
        if foreground is None:
            status = _spin(executor, nodes, stop)
        else:
            status = _spin_behind(executor, nodes, stop, foreground)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ValueError, InvalidParameterValueException, InvalidParameterTypeException,
            RCLError, StartError) as error:
        print(f'cannot start: {_first_line(error)}', file=sys.stderr)
        status = 1
    finally:
        _ignore_signals()
        watchdog = threading.Timer(CLEANUP_LIMIT_S, _give_up)
        watchdog.daemon = True
        watchdog.start()
        faulthandler.dump_traceback_later(CLEANUP_LIMIT_S + HARD_LIMIT_S, exit=True)
        if executor is not None:
            executor.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
        faulthandler.cancel_dump_traceback_later()
        watchdog.cancel()
    sys.exit(status)


def _spin(executor: Executor, nodes: List[Node], stop: threading.Event) -> int:
    """Spin until ``stop``, shutdown or a node's ``exit_status``; return the exit status."""
    # rclpy.ok() takes a lock: asked every STOP_POLL_S, not once per event.
    checked = time.monotonic()
    while not stop.is_set():
        executor.spin_once(timeout_sec=STOP_POLL_S)
        if time.monotonic() - checked >= STOP_POLL_S:
            checked = time.monotonic()
            if not rclpy.ok():
                break
            finished = [node.exit_status for node in nodes
                        if getattr(node, 'exit_status', None) is not None]
            if finished:
                return max(finished)
    return 0


def _spin_behind(executor: Executor, nodes: List[Node], stop: threading.Event,
                 foreground: Callable[[List[Node], threading.Event], None]) -> int:
    """Spin in a second thread while ``foreground`` runs in this one; return the status."""
    result: List[int] = []
    errors: List[BaseException] = []

    def spin():
        try:
            result.append(_spin(executor, nodes, stop))
        except ExternalShutdownException:
            pass
        except BaseException as error:  # noqa: B902 - handed to the main thread
            errors.append(error)
        finally:
            stop.set()

    thread = threading.Thread(target=spin, name='executor', daemon=True)
    thread.start()
    try:
        foreground(nodes, stop)
    finally:
        stop.set()
        thread.join(CLEANUP_LIMIT_S)
    if errors:
        raise errors[0]
    return result[0] if result else 0


def _give_up() -> None:
    """End a clean-up that hangs (a node stuck in rclpy's destroy): one line, status 1."""
    print(f'clean-up did not finish within {CLEANUP_LIMIT_S:g} s: exiting', file=sys.stderr,
          flush=True)
    os._exit(1)


def spin_node(make_node: Callable[[], Node], args: Optional[List[str]] = None,
              help_modules: Sequence[str] = (), usage: str = '', **kwargs) -> None:
    """Run one node as :func:`spin_nodes` does (same keyword arguments)."""
    spin_nodes(lambda: [make_node()], args, help_modules, usage, **kwargs)
