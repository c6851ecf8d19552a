"""
Benchmark: gaze at tracker rates as a lab runs it, measured from outside (``make bench``).

What a lab runs: a tracker application pushing every sample on its own
(``push_sample``, each with its own stamp, as App-TobiiPro and the EyeLink
and Pupil relays do; ``--push chunk``: 10 ms chunks, as an SDK that batches),
the nodes started as ``ros2 run`` starts them (one process per node, ``python
-m eye_bci_ros2.nodes.<node> --ros-args -p ...``) or as ``eye_bci`` does (one
process), with ``profile:=xy_pixels source_width:=1366 source_height:=768``,
three options on ``choices``, and a ``choice/request`` every
:data:`REQUEST_PERIOD_S` with ``window_s:=0.2``: a round is always open, as
with the menu asking again after each answer; ``choices/feedback`` on (the
arbiter's default 30 Hz).

Per scenario, on a private ROS domain:

* a *pusher* process (spawn): a real pylsl outlet laid out as ``xy_pixels``,
  pushing from the moment the bridge connected, the simulated gaze resting
  on one known option (3 px noise);
* the nodes (subprocesses, default parameters apart from the stream
  selection, the profile, ``window_s`` and ``stats_period_s:=1``, whose log
  lines give the bridge's counts);
* this process: a driver node publishing the options and the requests and
  taking ``choice`` / ``choice/none`` with their arrival time;
* ``busy``: a busy loop pinned to the other core (``os.sched_setaffinity``,
  niced: it only has to keep that core from the nodes), the nodes, the
  pusher and this process pinned to one core: what is left of a 2-core lab
  PC with RViz drawing on the other.

Measured over the rounds (after a warm-up):

* CPU of every node process, the pusher and this process (user + system
  time over the wall time, psutil; 100 % = one core) and of the rest of the
  machine (other users: the noise of a shared machine), with the load average,
  and the time the hypervisor took the virtual CPUs away while they had work
  (``steal`` in /proc/stat): a node stalled for a few ms that way makes a
  latency's tail, whatever its code does;
* the nodes' CPU over the pusher's: the pusher's work is fixed (``rate``
  pushes a second), so its CPU tells how fast the machine ran in that run,
  which on this 2-core virtual machine varies by about a fifth from run to run
  (the same code's nodes alike); compare runs by this ratio;
* wake-ups of every process's main thread per second (its voluntary context
  switches: for a node process, its executor's);
* latency = ``choice`` arrival - request - ``window_s`` (the decision at the
  window end; ``early_decision:=false`` so that every round runs its window),
  p50 / p99 / max; scenarios with the node's own early decision report
  request -> ``choice`` instead;
* how late the pusher pushed each sample after its stamp (p50 / p99 / max):
  part of every latency, as a tracker's own delivery delay is, and the first
  suspect of a latency's tail on a shared virtual machine;
* samples lost: pushed vs received by the bridge (its ``gaze: N received``
  log lines), and per round the samples the arbiter decided on (its
  ``choice ...: N samples`` log line) vs the samples stamped in the window
  (``window_s`` x rate, +-1);
* rounds: right, wrong (a choice of another option), without a choice, unanswered
  (no answer before the next request, 50 ms after the window end: the round is
  replaced).

Scenario names: ``layout-rate-push-load[-early][-fixed]``, e.g.
``processes-2000-chunk-busy``; ``-early``: the arbiter's own early decision
(the node default); ``-fixed``: the reference in the same run, the bridge
pulling every ``poll_period_s`` whatever is due (``idle_poll_period_s`` set to
it: the batching before ``choice/due``).

A last part, ``burst`` (:func:`burst`): 100 000 samples stamped inside an
open round's window arrive at once (a sender that stalled); every one must be
decided on, the parameter service must answer during the drain.

And ``wake_up`` (:func:`wake_up_cost`): what one executor wake-up costs in CPU
whatever its callback does, as the nodes spin (an empty timer at 250 Hz in a
process of its own against the same process without it).  On this 2-core
virtual machine it is about 0.1 ms: why the nodes count their timers' ticks as
well as their work.

Usage::

    python -m bench.lab_rate [--long] [--seconds S] [--only NAME ...] [--repeat N]
                             [--no-burst] [--set NAME:=VALUE ...]

``LAB_RATE_LOG=FILE`` writes the node processes' log lines of the last scenario there.
"""

import argparse
import contextlib
from dataclasses import dataclass, replace
import json
import math
import multiprocessing
import os
import re
import subprocess
import sys
import tempfile
import time
from typing import Dict, Iterator, List, Optional, Sequence, Tuple
import uuid

from domain_coordinator import domain_id
import numpy as np
import psutil
import pylsl
import rclpy
from rclpy.context import Context
from rclpy.parameter_client import AsyncParameterClient
from std_msgs.msg import Empty, String

from bench.latency import default_poll_period, Driver, encode_xy_pixels, make_outlet
from bench.timing import machine_info
from eye_bci_ros2.ros.runner import (freeze_startup_objects, make_executor, spin_for,
                                     spin_until, STOP_POLL_S)
from eye_bci_ros2.ros.startup import quiet_liblsl
from eye_bci_ros2.ros.topics import EVENT_QOS, NO_CHOICE_TOPIC

#: Round window, s, and the request period: a round is always open.
WINDOW_S = 0.2
REQUEST_PERIOD_S = 0.25
#: Measured seconds of rounds per scenario (default run, ``--long``).
SECONDS, LONG_SECONDS = 8.0, 30.0
#: Gaze noise around the looked-at option, screen px (fixational jitter + tracker noise).
GAZE_NOISE_PX = 3.0
#: Chunked pushes: one chunk per this, s (an SDK that batches).
CHUNK_PERIOD_S = 0.01
#: Samples of the burst part (83 s of a 1200 Hz tracker at once).
BURST_SAMPLES = 100_000
#: Waits, s.
SETUP_TIMEOUT_S = 40.0
DRAIN_TIMEOUT_S = 10.0
WARMUP_ROUNDS = 8
#: The four pipeline nodes (``ros2 run`` starts one process each).
NODES = ('lsl_gaze_bridge', 'camera_tracker', 'marker_projector', 'choice_arbiter')
#: Goals (2-core machine, 1200 Hz per-sample pushes, a round always open).
GOAL_CPU_PERCENT = {'eye_bci': 10.0, 'processes': 20.0}
GOAL_2000_FACTOR = 1.5
GOAL_P99_MS = {'idle': 5.0, 'busy': 20.0}

_RECEIVED_LINE = re.compile(r'\[lsl_gaze_bridge\]: gaze: (\d+) received, (\d+) published')
_DECISION_LINE = re.compile(r"\[choice_arbiter\]: choice '([^']*)' by \w+: (\d+) samples")


@dataclass(frozen=True)
class Scenario:
    """One set-up: how the nodes run, the tracker rate and pushes, and the machine's load."""

    layout: str = 'eye_bci'         # 'eye_bci' (one process) or 'processes' (ros2 run each)
    rate: float = 1200.0            # Hz
    push: str = 'sample'            # 'sample' (push_sample each) or 'chunk' (10 ms chunks)
    load: str = 'idle'              # 'idle' or 'busy' (the other core busy)
    early: bool = False             # the arbiter's own early decision (node default) on
    fixed: bool = False             # the reference: the bridge pulls every poll_period_s
    extra: Tuple[str, ...] = ()     # more NAME:=VALUE parameters, for every node
    window_s: float = WINDOW_S      # the arbiter's window_s

    @property
    def name(self) -> str:
        """Name the scenario, e.g. ``eye_bci-1200-sample-idle``."""
        return '-'.join([self.layout, f'{self.rate:g}', self.push, self.load]
                        + (['early'] if self.early else []) + (['fixed'] if self.fixed else []))


#: The default run (~2 minutes): the goals' set-ups, then 2000 Hz and chunks.
DEFAULT_SCENARIOS = (
    Scenario('eye_bci'), Scenario('processes'),
    Scenario('eye_bci', load='busy'), Scenario('processes', load='busy'),
    Scenario('eye_bci', 2000.0), Scenario('processes', 2000.0),
    Scenario('eye_bci', push='chunk'), Scenario('eye_bci', early=True),
)
#: ``--long``: every combination, and the node defaults (early decision) per layout.
LONG_SCENARIOS = tuple(
    Scenario(layout, rate, push, load)
    for load in ('idle', 'busy') for layout in ('eye_bci', 'processes')
    for rate in (1200.0, 2000.0) for push in ('sample', 'chunk')) + (
    Scenario('eye_bci', early=True), Scenario('processes', early=True))


# -- the tracker ---------------------------------------------------------------------------

def push_loop(conn, name: str, source_id: str, rate: float, push: str,
              core: Optional[int]) -> None:
    """
    Push gaze at ``rate`` Hz until told to stop (the pusher process).

    In on ``conn``: ``('aim', x, y)`` screen px (1920x1080); ``('burst', n,
    t0, t1)``: push n samples at the aim stamped evenly in [t0, t1) (LSL
    clock) in one chunk (a tracker that stalled); ``None`` = stop pushing,
    then anything: close the outlet (a closed outlet takes the samples still
    in the inlet with it).  Out: ``('ready',)`` once the outlet exists,
    ``('pushing', first_stamp)`` once a consumer connected and pushing began,
    ``('burst', pushed_at)``, ``('done', pushed, lateness)`` (the burst not
    counted; :func:`push_lateness`).
    Every sample is stamped with its due time ``start + i / rate`` (LSL
    clock), also when the pusher runs late, as a tracker's samples carry
    their acquisition time.
    """
    if core is not None:
        os.sched_setaffinity(0, {core})
    outlet = make_outlet(name, source_id, rate)
    # A tracker app (C, C++) has no collector pausing it; this one's would delay pushes.
    freeze_startup_objects()
    conn.send(('ready',))
    aim = np.array(encode_xy_pixels((40.0, 40.0)))
    scale = np.array(encode_xy_pixels((1.0, 1.0)))
    rng = np.random.default_rng(11)
    while not outlet.have_consumers():
        if conn.poll(0.01):
            command = conn.recv()
            if command is None:
                conn.send(('done', 0, _percentiles([])))
                return
            aim = np.array(encode_xy_pixels(command[1:]))
    start, pushed = pylsl.local_clock(), 0
    runs: List[Tuple[float, int, int]] = []    # (pushed at, first index, end index)
    conn.send(('pushing', start))
    while True:
        while conn.poll():
            command = conn.recv()
            if command is None:
                conn.send(('done', pushed, push_lateness(runs, start, rate)))
                conn.poll(DRAIN_TIMEOUT_S)
                return
            if command[0] == 'burst':
                count, first, last = command[1:]
                points = aim + scale * rng.normal(0.0, GAZE_NOISE_PX, (count, 2))
                pushed_at = pylsl.local_clock()
                outlet.push_chunk(points.tolist(),
                                  (first + (last - first) * np.arange(count) / count).tolist())
                conn.send(('burst', pushed_at))
                continue
            aim = np.array(encode_xy_pixels(command[1:]))
        now = pylsl.local_clock()
        due = int((now - start) * rate) + 1
        if due > pushed:
            runs.append((now, pushed, due))
        if push == 'sample':
            for index in range(pushed, due):   # one push per sample, as tracker apps do
                point = aim + scale * rng.normal(0.0, GAZE_NOISE_PX, 2)
                outlet.push_sample(point.tolist(), start + index / rate)
            pushed = max(pushed, due)
            time.sleep(max(0.0, start + pushed / rate - pylsl.local_clock()))
        else:
            count = due - pushed
            if count > 0:
                points = aim + scale * rng.normal(0.0, GAZE_NOISE_PX, (count, 2))
                outlet.push_chunk(points.tolist(), (start + (pushed + np.arange(count)) / rate)
                                  .tolist())
                pushed = due
            time.sleep(CHUNK_PERIOD_S)


def push_lateness(runs: Sequence[Tuple[float, int, int]], start: float,
                  rate: float) -> Dict[str, float]:
    """
    How long after its stamp the pusher pushed each sample, ms (p50, p99, max).

    A latency includes it: a decision waits for the first sample stamped after the
    window end, which comes no earlier than the tracker sends it.

    :param runs: per pass of the push loop: (LSL time, first sample index, end index).
    """
    if not runs:
        return _percentiles([])
    at, first, end = (np.asarray(column) for column in zip(*runs))
    counts = end - first
    # Each sample's index: its run's first index plus its place in the run.
    index = (np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
             + np.repeat(first, counts))
    return _percentiles((np.repeat(at, counts) - (start + index / rate)) * 1e3)


def busy_loop(core: int) -> None:
    """Keep ``core`` busy until terminated (a lab PC's RViz on the other core)."""
    os.sched_setaffinity(0, {core})
    os.nice(19)
    while True:
        pass


# -- the nodes -----------------------------------------------------------------------------

def node_commands(scenario: Scenario, name: str, source_id: str) -> Dict[str, List[str]]:
    """Return the command lines that start the nodes, as ``ros2 run`` / ``eye_bci`` do."""
    parameters = ['profile:=xy_pixels', 'source_width:=1366', 'source_height:=768',
                  f'stream_name:={name}', f'source_id:={source_id}', 'stats_period_s:=1.0',
                  f'window_s:={scenario.window_s!r}']
    if not scenario.early:
        parameters.append('early_decision:=false')
    if scenario.fixed:
        parameters.append(f'idle_poll_period_s:={default_poll_period()!r}')
    parameters += list(scenario.extra)
    ros_args = ['--ros-args'] + [part for value in parameters for part in ('-p', value)]
    if scenario.layout == 'eye_bci':
        return {'eye_bci': [sys.executable, '-m', 'eye_bci_ros2.nodes.eye_bci'] + ros_args}
    # One process per node; each takes only its own parameters (an unknown one is warned).
    own = {'lsl_gaze_bridge': ('profile', 'source_', 'stream_', 'stats_', 'idle_'),
           'choice_arbiter': ('window_s', 'early_decision')}
    commands = {}
    for node in NODES:
        kept = [value for value in parameters if value.startswith(own.get(node, ('-',)))
                or value in scenario.extra]
        commands[node] = ([sys.executable, '-m', f'eye_bci_ros2.nodes.{node}', '--ros-args']
                          + [part for value in kept for part in ('-p', value)])
    return commands


def _cpu_s(process: psutil.Process) -> float:
    times = process.cpu_times()
    return times.user + times.system


def _wakeups(process: psutil.Process) -> int:
    """
    Return the voluntary context switches of the process's main thread so far.

    Each is a wake-up after a wait: for a node process, its executor's (the spin loop
    runs in the main thread); each costs CPU whatever the callback does
    (:func:`wake_up_cost`).
    """
    return process.num_ctx_switches().voluntary


def _machine_cpu_s() -> Tuple[float, float]:
    """Return the machine's busy CPU time and its stolen time (the hypervisor's), s."""
    times = psutil.cpu_times()
    steal = getattr(times, 'steal', 0.0)
    guest = getattr(times, 'guest', 0.0) + getattr(times, 'guest_nice', 0.0)  # in user, nice
    return sum(times) - times.idle - getattr(times, 'iowait', 0.0) - steal - guest, steal


def _stop(processes: Sequence[subprocess.Popen]) -> None:
    for process in processes:
        if process.poll() is None:
            process.terminate()
    for process in processes:
        try:
            process.wait(10.0)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


class NoChoiceDriver(Driver):
    """The latency bench's driver, also taking ``choice/none`` with its arrival time."""

    def __init__(self, **kwargs):
        """Subscribe ``choice/none`` too."""
        super().__init__(**kwargs)
        self.no_choice: List[Tuple[float, str]] = []
        self.create_subscription(String, NO_CHOICE_TOPIC, lambda m: self.no_choice.append(
            (pylsl.local_clock(), m.data)), EVENT_QOS)


# -- one scenario --------------------------------------------------------------------------

def _read_logs(logs: Dict[str, object]) -> str:
    """Return what the node processes wrote so far (their log lines)."""
    text = ''
    for stream in logs.values():
        stream.flush()
        stream.seek(0)
        text += stream.read()
    return text


@contextlib.contextmanager
def driver_graph() -> Iterator[Tuple[int, object, 'NoChoiceDriver']]:
    """Yield a free ROS domain, an executor and the bench's driver node on it; tear down after."""
    with domain_id() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        executor = make_executor(context=context)
        driver = NoChoiceDriver(context=context)
        executor.add_node(driver)
        # The bench's own collector pauses would count as the nodes' latency.
        freeze_startup_objects()
        try:
            yield domain, executor, driver
        finally:
            executor.shutdown()
            driver.destroy_node()
            context.try_shutdown()


def _bridge_received(logs) -> int:
    """Sum the bridge's ``gaze: N received`` lines (``logs``: the text or the log files)."""
    text = logs if isinstance(logs, str) else _read_logs(logs)
    return sum(int(m.group(1)) for m in _RECEIVED_LINE.finditer(text))


def _percentiles(values: Sequence[float]) -> Dict[str, float]:
    values = np.asarray(values, dtype=float)
    if not len(values):
        return {'p50_ms': math.nan, 'p99_ms': math.nan, 'max_ms': math.nan}
    return {'p50_ms': round(float(np.percentile(values, 50)), 2),
            'p99_ms': round(float(np.percentile(values, 99)), 2),
            'max_ms': round(float(values.max()), 2)}


def _match_rounds(requests: List[float], answers: List[Tuple[float, str, Optional[str]]]):
    """Pair each request with the first answer before the next request: (request, answer)."""
    paired = []
    for index, asked in enumerate(requests):
        until = requests[index + 1] if index + 1 < len(requests) else math.inf
        answer = next((a for a in answers if asked < a[0] < until), None)
        paired.append((asked, answer))
    return paired


def measure(scenario: Scenario, seconds: float = SECONDS, log=sys.stderr) -> Dict[str, object]:
    """Run one scenario (module doc); return its row."""
    name, source_id = f'lab-rate-{uuid.uuid4().hex}', f'lab-rate-{uuid.uuid4().hex}'
    cores = sorted(os.sched_getaffinity(0))
    busy = scenario.load == 'busy'
    if busy and len(cores) < 2:
        return {'skipped': 'needs 2 cores'}
    node_core = cores[0] if busy else None
    own_affinity = set(cores)
    spawn = multiprocessing.get_context('spawn')
    here, there = spawn.Pipe()
    pusher = spawn.Process(target=push_loop, daemon=True, args=(
        there, name, source_id, scenario.rate, scenario.push, node_core))
    burner = spawn.Process(target=busy_loop, args=(cores[1],), daemon=True) if busy else None
    processes: Dict[str, subprocess.Popen] = {}
    logs: Dict[str, object] = {}
    with driver_graph() as (domain, executor, driver):
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
        if busy:
            os.sched_setaffinity(0, {node_core})
        try:
            if burner is not None:
                burner.start()
            pusher.start()
            if not here.poll(SETUP_TIMEOUT_S):
                raise RuntimeError('the LSL pusher did not start')
            here.recv()
            for node, command in node_commands(scenario, name, source_id).items():
                logs[node] = tempfile.TemporaryFile(mode='w+')
                processes[node] = subprocess.Popen(
                    command, env=env, stdout=logs[node], stderr=subprocess.STDOUT,
                    preexec_fn=(lambda: os.sched_setaffinity(0, {node_core}))
                    if busy else None)
            driver.publish_menu()
            if not spin_until(executor, lambda: driver.regions is not None
                              and len(driver.regions.markers) == 3, SETUP_TIMEOUT_S):
                raise RuntimeError('marker_projector published no regions')
            targets = driver.targets()
            label = list(targets)[1]
            here.send(('aim', *targets[label]))
            if not here.poll(SETUP_TIMEOUT_S):
                raise RuntimeError('the bridge did not connect to the LSL stream')
            here.recv()   # ('pushing', start)
            requests: List[float] = []

            def ask(rounds: int) -> None:
                next_at = time.monotonic()
                for _ in range(rounds):
                    spin_for(executor, max(0.0, next_at - time.monotonic()), step_s=0.005)
                    requests.append(pylsl.local_clock())
                    driver.request_pub.publish(Empty())
                    next_at += REQUEST_PERIOD_S

            ask(WARMUP_ROUNDS)   # DDS discovery, the LSL clock offset, first decisions
            spin_for(executor, REQUEST_PERIOD_S)
            requests.clear()
            measured = dict(processes, pusher=pusher)
            handles = {key: psutil.Process(p.pid) for key, p in measured.items()}
            handles['driver'] = psutil.Process()
            start_cpu = {key: _cpu_s(h) for key, h in handles.items()}
            start_wakeups = {key: _wakeups(h) for key, h in handles.items()}
            (machine_start, steal_start), wall = _machine_cpu_s(), time.monotonic()
            first_answer = len(driver.received), len(driver.no_choice)
            ask(int(round(seconds / REQUEST_PERIOD_S)))
            spin_for(executor, REQUEST_PERIOD_S)
            wall = time.monotonic() - wall
            cpu = {key: 100.0 * (_cpu_s(h) - start_cpu[key]) / wall
                   for key, h in handles.items()}
            wakeups = {key: (_wakeups(h) - start_wakeups[key]) / wall
                       for key, h in handles.items()}
            machine, steal = _machine_cpu_s()
            machine = 100.0 * (machine - machine_start) / wall
            steal = 100.0 * (steal - steal_start) / wall
            load_average = os.getloadavg()
            here.send(None)
            pushed, lateness = (here.recv()[1:] if here.poll(10.0)
                                else (math.nan, _percentiles([])))
            # The bridge's counter lines (stats_period_s 1 s) until they hold every sample.
            spin_until(executor, lambda: _bridge_received(logs) >= pushed, DRAIN_TIMEOUT_S,
                       step_s=0.1)
        finally:
            if pusher.is_alive():
                here.send(None)
                here.send(None)
                pusher.join(5.0)
            if pusher.is_alive():
                pusher.terminate()
            if burner is not None and burner.is_alive():
                burner.terminate()
                burner.join(5.0)
            _stop(list(processes.values()))
            os.sched_setaffinity(0, own_affinity)
    text = _read_logs(logs)
    if os.environ.get('LAB_RATE_LOG'):
        with open(os.environ['LAB_RATE_LOG'], 'w') as out:
            out.write(text)
    for stream in logs.values():
        stream.close()
    answers = ([(t, 'choice', chosen) for t, chosen in driver.received[first_answer[0]:]]
               + [(t, 'none', None) for t, _ in driver.no_choice[first_answer[1]:]])
    return _row(scenario, requests, sorted(answers), label, cpu, machine, steal, load_average,
                pushed, text, log, wakeups, lateness)


def _row(scenario: Scenario, requests, answers, label: str, cpu: Dict[str, float],
         machine: float, steal: float, load_average, pushed: int, text: str, log,
         wakeups: Dict[str, float], lateness: Dict[str, float]) -> Dict[str, object]:
    """
    Summarise one scenario's measurements.

    :param machine: the whole machine's busy CPU, %.
    :param steal: the CPU the hypervisor took away meanwhile, %.
    """
    node_keys = [key for key in cpu if key not in ('pusher', 'driver')]
    nodes_cpu = sum(cpu[key] for key in node_keys)
    ours = nodes_cpu + cpu['pusher'] + cpu['driver'] + (100.0 if scenario.load == 'busy' else 0)
    paired = _match_rounds(requests, answers)
    latencies, wrong, none, unanswered = [], 0, 0, 0
    for asked, answer in paired:
        if answer is None:
            unanswered += 1
            continue
        arrived, kind, chosen = answer
        if kind == 'none':
            none += 1
            continue
        if chosen != label:
            wrong += 1
        offset = 0.0 if scenario.early else WINDOW_S
        latencies.append((arrived - asked - offset) * 1e3)
    received = _bridge_received(text)
    used = [int(m.group(2)) for m in _DECISION_LINE.finditer(text)]
    expected = int(round(WINDOW_S * scenario.rate))
    short = [expected - 1 - n for n in used if n < expected - 1] if not scenario.early else []
    row = {
        'extra_parameters': list(scenario.extra),
        'cpu_percent': {key: round(value, 1) for key, value in cpu.items()},
        'nodes_cpu_percent': round(nodes_cpu, 1),
        'nodes_cpu_per_pusher_cpu': (round(nodes_cpu / cpu['pusher'], 3)
                                     if cpu['pusher'] > 0 else None),
        'main_thread_wakeups_per_s': {key: round(value) for key, value in wakeups.items()},
        'others_cpu_percent': round(max(0.0, machine - ours), 1),
        'stolen_cpu_percent': round(steal, 1),
        'load_average_1min': round(load_average[0], 2),
        ('request_to_choice' if scenario.early else 'window_end_to_choice'):
            _percentiles(latencies),
        'rounds': len(paired), 'rounds_right': len(latencies) - wrong, 'rounds_wrong': wrong,
        'rounds_no_choice': none, 'rounds_unanswered': unanswered,
        'samples_pushed': pushed, 'samples_bridge_received': received,
        'pusher_lateness': lateness,
        'samples_lost_lsl': pushed - received if received else None,
        'arbiter_window_samples_expected': expected, 'arbiter_rounds_counted': len(used),
        'arbiter_rounds_short': len(short), 'arbiter_samples_short': int(sum(short)),
    }
    print(f'lab_rate {scenario.name}: nodes {row["nodes_cpu_percent"]} % '
          f'({row["nodes_cpu_per_pusher_cpu"]} x the pusher\'s; '
          f'{", ".join(f"{k} {v:.1f}" for k, v in row["cpu_percent"].items())}; '
          f'wake-ups/s {", ".join(f"{k} {wakeups[k]:.0f}" for k in node_keys)}), '
          f'latency {row.get("window_end_to_choice") or row.get("request_to_choice")} '
          f'(the pusher late p99 {lateness["p99_ms"]} ms), '
          f'rounds {row["rounds_right"]}/{row["rounds"]} right, {wrong} wrong, '
          f'{none} none, {unanswered} unanswered; pushed {pushed}, bridge {received}; '
          f'others {row["others_cpu_percent"]} %, stolen {row["stolen_cpu_percent"]} %, '
          f'load {row["load_average_1min"]}',
          file=log, flush=True)
    return row


def _goals(section: Dict[str, Dict]) -> Dict[str, object]:
    """Judge the goals on the rows measured (module doc of the issue's goals)."""
    goals = {}
    for layout, limit in GOAL_CPU_PERCENT.items():
        row = section.get(Scenario(layout).name)
        if row and 'nodes_cpu_percent' in row:
            goals[f'{layout}_1200_cpu'] = row['nodes_cpu_percent'] <= limit
        fast = section.get(Scenario(layout, 2000.0).name)
        if row and fast and 'nodes_cpu_percent' in fast:
            goals[f'{layout}_2000_cpu'] = (fast['nodes_cpu_percent']
                                           <= GOAL_2000_FACTOR * limit)
    row = section.get('burst')
    if row:
        goals['burst'] = (abs(row['samples_decided_on'] - row['samples_pushed']) <= 1
                          and row['choice'] == row['expected']
                          and row['next_choice'] == row['next_expected'])
    for key, row in section.items():
        if 'window_end_to_choice' not in row:
            continue
        load = 'busy' if '-busy' in key else 'idle'
        goals[f'{key}_p99'] = row['window_end_to_choice']['p99_ms'] <= GOAL_P99_MS[load]
        goals[f'{key}_right'] = (row['rounds_wrong'] == 0 and row['arbiter_samples_short'] == 0
                                 and not row['samples_lost_lsl'])
    return goals


def burst(samples: int = BURST_SAMPLES, log=sys.stderr) -> Dict[str, object]:
    """
    Push ``samples`` gaze samples at once into the running nodes (``eye_bci``, one process).

    A round is asked (window 2 s), then ``samples`` stamped inside its window
    arrive in one LSL chunk (a sender that stalled, or a 100 kHz test
    stream), on an option where the gaze then stays.  Measured: samples
    stamped in the window (the burst and the tracker's own 1200 Hz, +-1) vs
    samples the decision used (the arbiter's log line), time from the push to
    ``choice``, the
    bridge's parameter service answering during the drain (``ros2 param get``
    round trips), and the next ordinary round's choice.
    """
    scenario = Scenario('eye_bci', window_s=2.0)
    name, source_id = f'lab-burst-{uuid.uuid4().hex}', f'lab-burst-{uuid.uuid4().hex}'
    spawn = multiprocessing.get_context('spawn')
    here, there = spawn.Pipe()
    pusher = spawn.Process(target=push_loop, daemon=True, args=(
        there, name, source_id, 1200.0, 'chunk', None))
    process, output = None, tempfile.TemporaryFile(mode='w+')
    with driver_graph() as (domain, executor, driver):
        try:
            pusher.start()
            if not here.poll(SETUP_TIMEOUT_S):
                raise RuntimeError('the LSL pusher did not start')
            here.recv()
            command = node_commands(scenario, name, source_id)['eye_bci']
            process = subprocess.Popen(command, stdout=output, stderr=subprocess.STDOUT,
                                       env=dict(os.environ, ROS_DOMAIN_ID=str(domain)))
            client = AsyncParameterClient(driver, 'lsl_gaze_bridge')
            driver.publish_menu()
            if not spin_until(executor, lambda: driver.regions is not None
                              and len(driver.regions.markers) == 3, SETUP_TIMEOUT_S):
                raise RuntimeError('marker_projector published no regions')
            targets = driver.targets()
            labels = list(targets)
            if not here.poll(SETUP_TIMEOUT_S):
                raise RuntimeError('the bridge did not connect to the LSL stream')
            here.recv()
            spin_for(executor, 2.0)    # the clock offset, DDS discovery
            received = len(driver.received)
            driver.request_pub.publish(Empty())
            spin_for(executor, 1.2)
            # Stamped inside the round's window, all in one chunk, on the first option, where
            # the gaze then stays (the fixation rule decides where the gaze last settled).
            first = pylsl.local_clock() - 1.1
            here.send(('aim', *targets[labels[0]]))
            here.send(('burst', samples, first, first + 0.9))
            answers, started = [], time.monotonic()
            while time.monotonic() - started < 60.0 and len(driver.received) <= received:
                asked = time.monotonic()
                future = client.get_parameters(['max_chunk'])
                executor.spin_until_future_complete(future, timeout_sec=5.0)
                answers.append((time.monotonic() - asked) * 1e3 if future.done() else math.inf)
                spin_for(executor, 0.05)
            drained_s = time.monotonic() - started
            chosen = driver.received[received][1] if len(driver.received) > received else None
            # The next ordinary round, on the third option.
            here.send(('aim', *targets[labels[2]]))
            spin_for(executor, 0.5)
            received = len(driver.received)
            driver.request_pub.publish(Empty())
            spin_until(executor, lambda: len(driver.received) > received, 5.0)
            following = driver.received[received][1] if len(driver.received) > received else None
        finally:
            if pusher.is_alive():
                for _ in range(3):
                    here.send(None)
                pusher.join(5.0)
            if pusher.is_alive():
                pusher.terminate()
            if process is not None:
                _stop([process])
    text = _read_logs({'eye_bci': output})
    if os.environ.get('LAB_RATE_LOG'):
        with open(os.environ['LAB_RATE_LOG'], 'w') as out:
            out.write(text)
    used = [int(m.group(2)) for m in _DECISION_LINE.finditer(text)]
    output.close()
    # The burst and the tracker's own samples stamped in the window.
    row = {'samples_pushed': samples + int(2.0 * 1200.0),
           'samples_decided_on': max(used, default=0),
           'choice': chosen, 'expected': labels[0], 'push_to_choice_s': round(drained_s, 2),
           'parameter_answers': len(answers),
           'parameter_answer_max_ms': round(max(answers), 1) if answers else math.nan,
           'next_choice': following, 'next_expected': labels[2]}
    print(f'lab_rate burst: {row}', file=log, flush=True)
    return row


#: Rate of the empty timer of :func:`wake_up_cost`, Hz, and how long each half runs, s.
WAKE_UP_HZ, WAKE_UP_S = 250.0, 5.0


def _spin_timer(rate_hz: float, seconds: float, conn) -> None:
    """Spin an executor as the nodes do, with an empty timer at ``rate_hz`` (0: none)."""
    context = Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node('wake_up_cost', context=context)
        ticks = [0]

        def tick():
            ticks[0] += 1
        if rate_hz > 0:
            node.create_timer(1.0 / rate_hz, tick)
        executor = make_executor(context)
        executor.add_node(node)
        freeze_startup_objects()
        start, cpu = time.monotonic(), time.process_time()
        spin_for(executor, seconds, step_s=STOP_POLL_S)   # the nodes' own spin step
        conn.send((time.process_time() - cpu, time.monotonic() - start, ticks[0]))
        executor.shutdown()
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def wake_up_cost(log=sys.stderr) -> Dict[str, object]:
    """CPU per executor wake-up: an empty timer against none, each in a fresh process."""
    spawn = multiprocessing.get_context('spawn')
    results = {}
    for rate in (0.0, WAKE_UP_HZ):
        here, there = spawn.Pipe()
        process = spawn.Process(target=_spin_timer, args=(rate, WAKE_UP_S, there), daemon=True)
        process.start()
        results[rate] = here.recv() if here.poll(WAKE_UP_S + 30.0) else None
        process.join(10.0)
    if None in results.values():
        return {'error': 'a timing process did not report'}
    (idle_cpu, idle_wall, _), (cpu, wall, ticks) = results[0.0], results[WAKE_UP_HZ]
    row = {'timer_hz': WAKE_UP_HZ, 'ticks_per_s': round(ticks / wall, 1),
           'cpu_percent_without': round(100.0 * idle_cpu / idle_wall, 2),
           'cpu_percent_with': round(100.0 * cpu / wall, 2),
           'cpu_us_per_wake_up': round(1e6 * (cpu / wall - idle_cpu / idle_wall)
                                       / max(ticks / wall, 1e-9), 1)}
    print(f'lab_rate wake_up: {row}', file=log, flush=True)
    return row


def run(quick: bool = False, scenarios: Sequence[Scenario] = DEFAULT_SCENARIOS,
        seconds: float = SECONDS, repeat: int = 1, with_burst: bool = True,
        log=sys.stderr) -> Dict[str, object]:
    """Measure ``scenarios`` and the burst (``quick``: the first two, 3 s each, no burst)."""
    if quick:
        scenarios, seconds, with_burst = scenarios[:2], 3.0, False
    section: Dict[str, object] = {}
    for attempt in range(repeat):
        for scenario in scenarios:
            key = scenario.name + (f'#{attempt + 1}' if repeat > 1 else '')
            section[key] = measure(scenario, seconds, log)
    if with_burst:
        section['burst'] = burst(log=log)
        section['wake_up'] = wake_up_cost(log=log)
    section['goals'] = _goals(section)
    section['machine'] = machine_info()
    return section


def _scenario(text: str) -> Scenario:
    """Parse ``layout-rate-push-load[-early]`` (a scenario's name)."""
    parts = text.split('-')
    flags = set(parts[4:])
    if len(parts) < 4 or not flags <= {'early', 'fixed'}:
        raise argparse.ArgumentTypeError(f"'{text}' is not layout-rate-push-load[-early]"
                                         '[-fixed], e.g. eye_bci-1200-sample-idle')
    scenario = Scenario(parts[0], float(parts[1]), parts[2], parts[3], 'early' in flags,
                        'fixed' in flags)
    if scenario.layout not in GOAL_CPU_PERCENT or scenario.push not in ('sample', 'chunk') \
            or scenario.load not in GOAL_P99_MS:
        raise argparse.ArgumentTypeError(f"'{text}': layout eye_bci|processes, push "
                                         'sample|chunk, load idle|busy')
    return scenario


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Print ``{"lab_rate": {...}}``; 1 if a goal is missed."""
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    parser = argparse.ArgumentParser(prog='python -m bench.lab_rate',
                                     description=__doc__.strip().splitlines()[0])
    parser.add_argument('--long', action='store_true',
                        help=f'every combination, {LONG_SECONDS:g} s each')
    parser.add_argument('--seconds', type=float, default=0.0,
                        help=f'measured seconds per scenario (default {SECONDS:g})')
    parser.add_argument('--only', type=_scenario, nargs='+', metavar='NAME',
                        help='scenarios by name, e.g. eye_bci-1200-sample-busy')
    parser.add_argument('--repeat', type=int, default=1, help='run the scenarios N times')
    parser.add_argument('--no-burst', action='store_true',
                        help='skip the burst part (always skipped with --only)')
    parser.add_argument('--set', nargs='+', default=[], metavar='NAME:=VALUE',
                        help='more parameters for the nodes, e.g. idle_poll_period_s:=0.04')
    args = parser.parse_args(argv)
    scenarios = args.only or (LONG_SCENARIOS if args.long else DEFAULT_SCENARIOS)
    scenarios = [replace(scenario, extra=tuple(args.set)) for scenario in scenarios]
    seconds = args.seconds or (LONG_SECONDS if args.long else SECONDS)
    section = run(False, scenarios, seconds, args.repeat, not args.no_burst and not args.only)
    print(json.dumps({'lab_rate': section}, indent=2))
    return 0 if all(section['goals'].values()) else 1


if __name__ == '__main__':
    sys.exit(main())
