"""
The executables as a user starts them: --help, start-up errors, stopping, stream reports.

Each runs as its own process (``python -m``, what the console scripts call) on a private
domain, the way ``ros2 run`` and ``ros2 launch`` start them.
"""

import contextlib
import math
import os
import re
import signal
import subprocess
import sys
import time

from domain_coordinator import domain_id
from geometry_msgs.msg import PointStamped
from lsl_outlets import make_outlet, unique_id
from paths import loaded
import pytest
from ros_harness import Collector
from watched_process import Process

from eye_bci_ros2.ros.runner import CLEANUP_LIMIT_S, HARD_LIMIT_S
from eye_bci_ros2.ros.startup import LSL_QUIET_CONFIG
from eye_bci_ros2.ros.topics import LATCHED_QOS, VALIDATION_TARGET_TOPIC

pytestmark = [pytest.mark.ros, pytest.mark.slow]

NODES = ('lsl_gaze_bridge', 'camera_tracker', 'marker_projector', 'choice_arbiter',
         'choice_menu', 'eye_bci', 'gaze_validation')


def start(module, *args, domain):
    """Start ``python -m eye_bci_ros2.nodes.<module> args`` with piped output."""
    return subprocess.Popen(
        [sys.executable, '-m', f'eye_bci_ros2.nodes.{module}', *args],
        env=dict(os.environ, ROS_DOMAIN_ID=str(domain)), stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)


@contextlib.contextmanager
def killed_if_left(process: subprocess.Popen):
    """Give ``process`` to the block; kill it if the block leaves it running (a failed test)."""
    try:
        yield process
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()


def run(module, *args, timeout=60):
    """Run an executable to its end; return (status, stdout, stderr)."""
    with domain_id() as domain:
        process = start(module, *args, domain=domain)
        out, err = process.communicate(timeout=timeout)
    return process.returncode, out, err


@pytest.mark.parametrize('module', NODES)
def test_help_says_what_it_subscribes_publishes_and_its_parameters(module):
    status, out, err = run(module, '--help')
    assert status == 0, err
    assert 'usage: ros2 run eye_bci_ros2' in out
    assert 'parameters' in out and 'publish' in out


@pytest.mark.parametrize('module, args, reason', [
    ('eye_bci', ['--with-menus'], "unknown option '--with-menus': did you mean --with-menu?"),
    ('marker_projector', ['-p', 'screen_offset_x:=64'], "'-p' is a ROS argument and must "
     'follow --ros-args'),
])
def test_a_mistyped_command_line_is_refused_in_one_line(module, args, reason):
    status, out, err = run(module, *args)
    assert status == 1 and err.strip().splitlines()[-1] == f'cannot start: {reason}' + (
        '' if module == 'eye_bci' else ', e.g. --ros-args -p NAME:=VALUE (without it ROS '
        'ignores it)'), err
    assert 'Traceback' not in err


@pytest.mark.parametrize('args, reason', [
    (['-p', 'method:=median'], 'median'),
    (['-p', 'window_s:=abc'], 'window_s'),
    (['--params-file', '/no/such/file.yaml'], 'params file'),
])
def test_a_start_up_error_is_one_line_and_status_1(args, reason):
    status, out, err = run('choice_arbiter', '--ros-args', *args)
    assert status == 1
    # liblsl and the nodes may log before; the reason is one line, the last.
    last = err.strip().splitlines()[-1]
    assert last.startswith('cannot start:') and reason in last, err[-2000:]
    assert 'Traceback' not in err


@pytest.mark.parametrize('args, reason', [
    (['-p', 'targets:=7'], '7 targets: use 5 or 9'),
    (['-p', 'settle_s:=2.0', '-p', 'target_s:=1.0'], 'settle_s'),
])
def test_gaze_validation_refuses_a_bad_start_with_one_line(args, reason):
    status, _, err = run('gaze_validation', '--ros-args', *args)
    assert status == 1 and 'Traceback' not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith('cannot start:') and reason in last, err[-2000:]


def test_gaze_validation_without_gaze_refuses_before_a_target_with_one_line(graph, tmp_path):
    """No bridge running: refused after gaze_wait_s, the reason in one line, no target shown."""
    targets = Collector(graph.node('person'), PointStamped, VALIDATION_TARGET_TOPIC,
                        LATCHED_QOS)
    output = tmp_path / 'correction.yaml'
    with killed_if_left(start('gaze_validation', '--ros-args', '-p', 'gaze_wait_s:=2.0', '-p',
                              f'output:={output}', domain=graph.domain)) as process:
        # Its first target message (latched) says "none yet": the listener hears it.
        assert graph.spin_until(lambda: targets.messages, 30.0), 'never heard validation/target'
        assert graph.spin_until(lambda: process.poll() is not None, 60.0), 'still running'
        out, err = process.communicate()
    graph.spin_for(0.5)     # anything it published before it ended
    assert process.returncode == 1 and 'Traceback' not in err, err[-2000:]
    refused = [line for line in err.splitlines() if 'validation refused' in line]
    assert len(refused) == 1 and refused[0].endswith(
        'validation refused: no gaze on gaze/samples in 2 s: is lsl_gaze_bridge running and '
        'the tracker streaming?'), err[-2000:]
    assert all(math.isnan(message.point.x) for message in targets.messages)
    assert not output.exists()


def test_eye_bci_refuses_a_bad_override_with_one_line():
    status, _, err = run('eye_bci', '--ros-args', '-p', 'image_width:=abc')
    assert status == 1 and 'Traceback' not in err
    assert err.strip().splitlines()[-1].startswith('cannot start: invalid parameter override')


#: The line each node logs last before it spins (its handlers are in place by then).
UP_LINE = {'marker_projector': r'\[marker_projector\]: projecting markers in',
           'eye_bci': r'\[choice_arbiter\]: choice_arbiter: method'}


@pytest.mark.parametrize('signals', [('INT',), ('TERM',), ('INT', 'INT'), ('TERM', 'INT')],
                         ids=lambda s: '+'.join(s))
@pytest.mark.parametrize('module', ['marker_projector', 'eye_bci'])
def test_stops_cleanly_on_sigint_and_sigterm_even_twice(module, signals, tmp_path):
    with domain_id() as domain:
        node = Process([sys.executable, '-m', f'eye_bci_ros2.nodes.{module}'], os.environ,
                       domain, tmp_path / 'node.log')
        with killed_if_left(node.process):
            assert node.wait_for(UP_LINE[module]), node.output()[-2000:]
            for index, name in enumerate(signals):
                node.process.send_signal(getattr(signal, f'SIG{name}'))
                time.sleep(0.002 * index)   # launch's copy follows the terminal's (not a wait)
            status = node.finish(timeout=30)
    text = node.output()
    assert status == 0, text[-2000:]
    assert 'Traceback' not in text and 'Exception' not in text, text[-2000:]


def test_the_bridge_names_the_streams_it_sees_when_none_matches(tmp_path):
    outlet, info = make_outlet('custom', stream_type=unique_id('other-type'))
    with domain_id() as domain:
        bridge = Process([sys.executable, '-m', 'eye_bci_ros2.nodes.lsl_gaze_bridge',
                          '--ros-args', '-p', 'profile:=tobii_pro',
                          '-p', 'resolve_period_s:=0.2'], os.environ, domain,
                         tmp_path / 'bridge.log')
        with killed_if_left(bridge.process):
            named = bridge.wait_for(f"type '{re.escape(info.type())}'.*select with")
            bridge.process.send_signal(signal.SIGINT)
            status = bridge.finish(timeout=30)
    text = bridge.output()
    assert named and status == 0, text[-3000:]
    assert 'looking for an LSL gaze stream' in text
    del outlet


def test_ssvep_stimulus_needs_the_opt_in_and_a_display_and_says_so_in_one_line():
    status, out, err = run('ssvep_stimulus', '--help')
    assert status == 0 and 'photosensitive epilepsy' in out and 'accept_flicker' in out, out
    # No flicker without the explicit opt-in: the warning, and how to opt in.
    status, out, err = run('ssvep_stimulus')
    last = err.strip().splitlines()[-1]
    assert status == 1 and 'photosensitive epilepsy' in last and \
        last.endswith('--ros-args -p accept_flicker:=true'), err
    # Opted in, but no display: one line, no traceback.
    env_display = os.environ.pop('DISPLAY', None)
    try:
        status, out, err = run('ssvep_stimulus', '--ros-args', '-p', 'accept_flicker:=true')
    finally:
        if env_display is not None:
            os.environ['DISPLAY'] = env_display
    assert status == 1 and err.strip().splitlines()[-1].startswith(
        'cannot start: no display to draw the stimuli on'), err
    assert 'Traceback' not in err


#: A node whose clean-up is stuck in C code that keeps the interpreter (a regular
#: expression that backtracks for hours): no Python thread can run, signals are ignored.
STUCK_IN_DESTROY = """
import re
from rclpy.node import Node
from eye_bci_ros2.ros.runner import spin_node


class Stuck(Node):
    def __init__(self):
        super().__init__('stuck_in_destroy')
        self.create_timer(0.05, lambda: print('spinning', flush=True))

    def destroy_node(self):
        print('stopping', flush=True)
        re.match(r'(a+)+$', 'a' * 64 + 'b')
        super().destroy_node()


spin_node(Stuck)
"""


def test_a_clean_up_stuck_where_no_python_runs_still_ends(tmp_path):
    script = tmp_path / 'stuck.py'
    script.write_text(STUCK_IN_DESTROY)
    limit = CLEANUP_LIMIT_S + HARD_LIMIT_S
    with domain_id() as domain:
        with killed_if_left(subprocess.Popen(
                [sys.executable, str(script)], env=dict(os.environ, ROS_DOMAIN_ID=str(domain)),
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)) as process:
            assert process.stdout.readline().strip() == 'spinning'
            process.send_signal(signal.SIGINT)
            out, err = process.communicate(timeout=limit + 20.0)
    assert 'stopping' in out
    # faulthandler's thread ends it: status 1 and where it hung, not a SIGKILL's -9.
    assert process.returncode == 1, err[-2000:]
    assert 'Timeout' in err and 'destroy_node' in err, err[-2000:]


#: An executable's start-up (argv[0] is an executable's name) with a stand-in for numpy's
#: import: a Ctrl-C inside it becomes an ImportError without the KeyboardInterrupt in its
#: chain, as numpy's C-extensions report it ("...the C-extensions failed..."). The SIGINTs
#: come from inside the imports, so they land there on any machine, loaded or not.
CTRL_C_IN_IMPORTS = """
import signal
import sys
import time

from eye_bci_ros2.ros.startup import prepare_process

prepare_process()    # first, as every console script: the SIGINT handler, the quiet hook

case = sys.argv.pop(1)


def ctrl_c():
    signal.raise_signal(signal.SIGINT)   # runs the handler before it returns


def import_like_numpy():
    interrupted = False
    try:
        ctrl_c()
    except KeyboardInterrupt:
        interrupted = True
    if interrupted:
        raise ImportError('Importing the numpy C-extensions failed.')


if case == 'converted':
    import_like_numpy()    # the terminal's Ctrl-C lands in the import
else:   # 'swallowed': an import swallows the first; the second comes seconds later (load)
    try:
        ctrl_c()
    except KeyboardInterrupt:
        pass
    time.sleep(1.5)
    import_like_numpy()
from rclpy.node import Node
from eye_bci_ros2.ros.runner import spin_node


class Started(Node):
    def __init__(self, **kwargs):
        super().__init__('started', **kwargs)
        print('started', flush=True)


spin_node(Started)
"""


@pytest.mark.parametrize('case', ['converted', 'swallowed'])
def test_a_ctrl_c_that_an_import_turns_into_an_error_still_ends_quietly(tmp_path, case):
    """
    Ctrl-C during start-up, caught by an import that raises its own error (numpy's).

    Seen under load: the second SIGINT of one Ctrl-C landed inside numpy's import,
    and ``camera_tracker`` printed numpy's ImportError and exited 1.
    """
    script = tmp_path / 'camera_tracker'
    script.write_text(CTRL_C_IN_IMPORTS)
    with domain_id() as domain:
        with killed_if_left(subprocess.Popen(
                [sys.executable, str(script), case],
                env=dict(os.environ, ROS_DOMAIN_ID=str(domain)),
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)) as process:
            out, err = process.communicate(timeout=60)
    assert process.returncode == 0 and err == '', err[-2000:]
    assert 'started' not in out     # nothing starts after a Ctrl-C


@pytest.mark.parametrize('gap_ms', [0.2, 1.0, 3.0, 10.0])
def test_a_ctrl_c_while_importing_ends_quietly_even_when_it_comes_twice(gap_ms):
    """
    Ctrl-C under ``ros2 launch`` during start-up: the terminal's SIGINT, then launch's.

    The console script (argv[0] is the executable's name, as ``ros2 run`` and
    launch start it) is interrupted while it imports its modules (numpy is
    loaded), then again ``gap_ms`` later: it ends with status 0 and prints nothing.
    """
    script = os.path.join(os.path.dirname(sys.executable), 'camera_tracker')
    if not os.path.exists(script):
        pytest.skip(f'no console script {script} (pip install -e . makes it)')
    with domain_id() as domain:
        with killed_if_left(subprocess.Popen(
                [script], env=dict(os.environ, ROS_DOMAIN_ID=str(domain)),
                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)) as process:
            end = time.monotonic() + 30.0
            while not loaded(process.pid, 'numpy') and time.monotonic() < end:
                time.sleep(0.0005)
            process.send_signal(signal.SIGINT)
            time.sleep(gap_ms / 1000.0)
            process.send_signal(signal.SIGINT)
            out, err = process.communicate(timeout=30)
    assert process.returncode == 0, err[-2000:]
    assert 'Traceback' not in err and 'KeyboardInterrupt' not in err, err[-2000:]


def test_an_executable_gets_the_quiet_liblsl_and_the_quiet_ctrl_c(tmp_path):
    """
    The console script prepares its process (``eye_bci_ros2.ros.startup``), the import does not.

    ``lsl_gaze_bridge`` as ``ros2 run`` starts it, for a user without a liblsl
    configuration of their own: liblsl's INFO lines stay off the terminal (its
    configuration is written to the temporary folder), and Ctrl-C ends it with status 0.
    """
    script = os.path.join(os.path.dirname(sys.executable), 'lsl_gaze_bridge')
    if not os.path.exists(script):
        pytest.skip(f'no console script {script} (pip install -e . makes it)')
    temporary, home = tmp_path / 'tmp', tmp_path / 'home'
    temporary.mkdir()
    home.mkdir()
    env = {key: value for key, value in os.environ.items() if key != 'LSLAPICFG'}
    env.update(TMPDIR=str(temporary), HOME=str(home))
    with domain_id() as domain:
        bridge = Process([script, '--ros-args', '-p', f'source_id:={unique_id("nobody")}',
                          '-p', 'resolve_period_s:=0.2'], env, domain, tmp_path / 'bridge.log')
        with killed_if_left(bridge.process):
            looking = bridge.wait_for('looking for an LSL gaze stream')
            bridge.process.send_signal(signal.SIGINT)
            status = bridge.finish(timeout=30)
    text = bridge.output()
    assert looking and status == 0, text[-3000:]
    assert 'INFO|' not in text and 'Loaded default config' not in text, text[-3000:]
    assert 'Traceback' not in text and 'KeyboardInterrupt' not in text, text[-3000:]
    written = list(temporary.glob('eye_bci_ros2_lsl_api_*.cfg'))
    assert len(written) == 1 and written[0].read_text() == LSL_QUIET_CONFIG, written
