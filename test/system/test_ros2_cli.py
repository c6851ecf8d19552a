"""
What a ROS 2 user types, with the real ``ros2`` command line, on a colcon-built workspace.

``ros2 run`` of every executable (``--help``), ``ros2 param set/get/dump``
and the dump given back with ``--params-file``, a mistyped parameter name,
``ros2 topic echo /choice`` while a simulated tracker looks at an option,
and ``ros2 launch`` of both launch files stopped by Ctrl-C (once, twice,
during start-up): exit status, no traceback, no process left behind; Ctrl-C
mid-drive with a robot of one's own (``robot:=none``) stops that robot.

The command line (ros2cli, launch, launch_ros; not on PyPI) is installed
from ``../shared/tools/ros2cli/install.sh`` into ``build/ros2cli``; without
that script, or where it cannot download (no network), these tests skip and
say why.  Ctrl-C is a SIGINT to the launch's whole process group, as a
terminal sends it.  The slowest are marked ``slow``;
the whole module takes about 2 minutes on 2 cores.
"""

import importlib
from pathlib import Path
import re
import subprocess
import time
from typing import List, Optional

from colcon_workspace import build_workspace, PACKAGE, sourced_environment
from domain_coordinator import domain_id
from lsl_outlets import bridge_parameters, make_outlet, sample_for
from paths import loaded
import pytest
from watched_process import Process, TRACEBACK, WAIT_S
import yaml

pytestmark = [pytest.mark.ros, pytest.mark.slow]

#: Without the daemon, a ros2 command discovers the graph itself: give it time (a user's
#: daemon has been listening all along).
DISCOVERY = ('--spin-time', '2', '--timeout', '10')


@pytest.fixture(scope='module')
def env(tmp_path_factory, ros2):
    """Return the environment of a sourced colcon workspace holding the package."""
    workspace = build_workspace(tmp_path_factory.mktemp('ws'))
    environment = sourced_environment(workspace)
    environment.update(PYTHONUNBUFFERED='1', RCUTILS_COLORIZED_OUTPUT='0',
                       ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    # ros2 param/topic start a daemon by default: keep none running after the tests.
    environment.pop('ROS_DOMAIN_ID', None)
    return environment


def run(command: List[str], env: dict, domain: int, timeout: float = WAIT_S):
    """Run a short command; return (status, output)."""
    result = subprocess.run(command, env=dict(env, ROS_DOMAIN_ID=str(domain)),
                            capture_output=True, text=True, timeout=timeout)
    return result.returncode, result.stdout + result.stderr


#: How long one ``ros2 param`` call may take before it is asked again, s.
PARAM_CALL_S = 30.0


def run_param(command: List[str], env: dict, domain: int):
    """
    Run a ``ros2 param`` command; ask once more if it hangs; return (status, output).

    ros2param waits for the service's answer without a timeout (its ``--timeout`` bounds
    discovery only: ros2/ros2cli#1159), and a response can be lost while the DDS
    discovery of its reply is unfinished, which a loaded machine makes likelier.  A
    node that does not answer fails both calls.
    """
    try:
        return run(command, env, domain, timeout=PARAM_CALL_S)
    except subprocess.TimeoutExpired:
        return run(command, env, domain, timeout=PARAM_CALL_S)


def alive(pids: List[int]) -> List[int]:
    """Return the pids of ``pids`` that still run (not zombies)."""
    running = []
    for pid in pids:
        try:
            state = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()[0]
        except (FileNotFoundError, IndexError):
            continue
        if state != 'Z':
            running.append(pid)
    return running


def started_pids(output: str) -> List[int]:
    """Return the pids ``ros2 launch`` reports as started."""
    return [int(pid) for pid in re.findall(r'process started with pid \[(\d+)\]', output)]


def stopped_cleanly(output: str) -> int:
    """
    Count the nodes ``ros2 launch`` saw stop cleanly, or whose exit status it lost.

    A node that has already left on the terminal's SIGINT (sent to the whole
    group) when launch forwards its own is reaped by ``Popen.send_signal``,
    which polls first (bpo-38630); asyncio's child watcher then finds no child
    ("Unknown child process pid N, will report returncode 255") and launch says
    the node died with 255.  That is launch's bookkeeping under CPython, not the
    node's exit: such a node counts when both lines name its pid (that it left
    no traceback and is gone, :func:`assert_clean_stop` checks).
    """
    lost = set(re.findall(r'Unknown child process pid (\d+), will report returncode 255',
                          output))
    died = set(re.findall(r'process has died \[pid (\d+), exit code 255,', output))
    return output.count('process has finished cleanly') + len(lost & died)


def executables() -> List[str]:
    """Return the console scripts of setup.py (what ``ros2 run`` offers)."""
    from test_colcon_build import console_scripts
    return sorted(entry.split('=', 1)[0].strip() for entry in console_scripts())


def test_ros2_run_every_executable_help(ros2, env, tmp_path):
    with domain_id() as domain:
        processes = {name: Process([str(ros2), 'run', PACKAGE, name, '--help'], env, domain,
                                   tmp_path / f'{name}.log') for name in executables()}
        for name, process in processes.items():
            status = process.finish()
            output = process.output()
            assert status == 0, f'{name} --help: status {status}\n{output[-2000:]}'
            assert 'usage' in output.lower() and not TRACEBACK.search(output), \
                f'{name} --help:\n{output[-2000:]}'
            assert len(output.splitlines()) < 120, f'{name} --help is not short'


def test_param_set_get_dump_and_the_dump_as_params_file(ros2, env, tmp_path):
    with domain_id() as domain:
        node = Process([str(ros2), 'run', PACKAGE, 'marker_projector', '--ros-args', '-p',
                        'screen_ofset_x:=64'], env, domain, tmp_path / 'projector.log')
        try:
            assert node.wait_for('waiting for camera/pose'), node.output()
            # The typo is named, with the name that was meant (once the node is built: after
            # the line above, so waited for).
            assert node.wait_for(r"unknown parameter 'screen_ofset_x'.*'screen_offset_x'"), \
                node.output()
            daemonless = ['--no-daemon', *DISCOVERY]
            status, out = run_param([str(ros2), 'param', 'set', *daemonless, '/marker_projector',
                                    'screen_offset_x', '64.5'], env, domain)
            assert status == 0 and 'Set parameter successful' in out, out
            status, out = run_param([str(ros2), 'param', 'get', *daemonless, '/marker_projector',
                                    'screen_offset_x'], env, domain)
            assert status == 0 and '64.5' in out, out
            status, out = run_param([str(ros2), 'param', 'set', *daemonless, '/marker_projector',
                                    'image_widht', '1920'], env, domain)
            assert 'Setting parameter failed' in out, out
            # The answer itself says which name was meant (not only the node's log).
            assert "did you mean 'image_width'?" in out, out
            assert node.wait_for(r"unknown parameter 'image_widht'.*'image_width'"), \
                node.output()
            status, out = run_param([str(ros2), 'param', 'set', *daemonless, '/marker_projector',
                                    'profile', 'tobii_pro'], env, domain)
            assert 'it is a parameter of lsl_gaze_bridge, not of this node' in out, out
            status, dumped = run_param([str(ros2), 'param', 'dump', *daemonless,
                                       '/marker_projector'], env, domain)
            assert status == 0, dumped
        finally:
            node.interrupt()
            assert node.finish() == 0, node.output()
        values = yaml.safe_load(dumped)['/marker_projector']['ros__parameters']
        assert values['screen_offset_x'] == 64.5
        assert values['intrinsic_matrix'] == []    # declared and set: the dump is complete
        saved = tmp_path / 'projector.yaml'
        saved.write_text(dumped)
        again = Process([str(ros2), 'run', PACKAGE, 'marker_projector', '--ros-args',
                         '--params-file', str(saved)], env, domain, tmp_path / 'again.log')
        try:
            assert again.wait_for('waiting for camera/pose'), again.output()
            assert 'screen_offset=[64.5, 180.0]' in again.output(), again.output()
            status, out = run_param([str(ros2), 'param', 'dump', '--no-daemon', *DISCOVERY,
                                    '/marker_projector'], env, domain)
            assert yaml.safe_load(out) == yaml.safe_load(dumped)
        finally:
            again.interrupt()
            assert again.finish() == 0, again.output()
        assert not TRACEBACK.search(node.output() + again.output())


#: The nodes whose dumps are checked, and their modules (their PARAMETERS tables).
MODULES = {name: f'eye_bci_ros2.nodes.{name}' for name in (
    'lsl_gaze_bridge', 'camera_tracker', 'marker_projector', 'choice_arbiter', 'choice_menu',
    'gaze_validation')}


def test_every_node_of_eye_bci_and_gaze_validation_dumps_what_it_declares(ros2, env, tmp_path):
    nodes = list(MODULES)
    with domain_id() as domain:
        pipeline = Process([str(ros2), 'run', PACKAGE, 'eye_bci', '--with-menu'], env, domain,
                           tmp_path / 'eye_bci.log')
        validation = Process([str(ros2), 'run', PACKAGE, 'gaze_validation', '--ros-args', '-p',
                              'on_request:=true'], env, domain, tmp_path / 'validation.log')
        dumps = {}
        try:
            assert validation.wait_for('waiting for validation/start'), validation.output()
            assert pipeline.wait_for('waiting for camera/pose'), pipeline.output()
            for name in nodes:
                status, out = run_param([str(ros2), 'param', 'dump', '--no-daemon',
                                         *DISCOVERY, f'/{name}'], env, domain)
                assert status == 0, out
                dumps[name] = yaml.safe_load(out)[f'/{name}']['ros__parameters']
                declared = {spec.name for spec in getattr(importlib.import_module(
                    MODULES[name]), 'PARAMETERS', ())}
                assert set(dumps[name]) - {'use_sim_time', 'start_type_description_service'}
                assert declared <= set(dumps[name]), f'{name}: {declared - set(dumps[name])}'
        finally:
            for process in (pipeline, validation):
                process.interrupt()
            for process in (pipeline, validation):
                assert process.finish() == 0, process.output()[-3000:]


def test_topic_echo_choice_while_the_tracker_looks_at_an_option(ros2, env, tmp_path):
    import rclpy
    from rclpy.context import Context
    from test_whole_graph import aim, menu, ROOMS
    from std_msgs.msg import Empty
    from visualization_msgs.msg import MarkerArray

    from eye_bci_ros2.ros.topics import CHOICES_TOPIC, EVENT_QOS, LATCHED_QOS, REQUEST_TOPIC

    outlet, info = make_outlet('xy_pixels', rate=100.0)
    rules = [f'{name}:={value}' for name, value in bridge_parameters('xy_pixels', info).items()]
    with domain_id() as domain:
        pipeline = Process([str(ros2), 'run', PACKAGE, 'eye_bci', '--ros-args',
                            *[arg for rule in rules for arg in ('-p', rule)],
                            # The original rule: the test is about the command line, not the
                            # rule, and gaze that rests on an option before a round never makes
                            # the fixation rule choose (not a reaction).
                            '-p', 'window_s:=0.5', '-p', 'method:=mean'], env, domain,
                           tmp_path / 'eye_bci.log')
        echo = Process([str(ros2), 'topic', 'echo', '--no-daemon', '--once', '/choice',
                        'std_msgs/msg/String'], env, domain, tmp_path / 'echo.log')
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        try:
            node = rclpy.create_node('task', context=context)
            node.create_publisher(MarkerArray, CHOICES_TOPIC, LATCHED_QOS).publish(menu())
            request = node.create_publisher(Empty, REQUEST_TOPIC, EVENT_QOS)
            assert pipeline.wait_for('connected to gaze LSL stream'), pipeline.output()
            end = time.monotonic() + WAIT_S
            pushed = 0
            while echo.process.poll() is None and time.monotonic() < end:
                outlet.push_sample(sample_for('xy_pixels', aim(ROOMS['bathroom'])).tolist())
                pushed += 1
                if pushed % 100 == 0:       # a round that opens while the gaze is there
                    request.publish(Empty())
                time.sleep(0.01)
            assert echo.finish() == 0, echo.output()
            assert 'data: bathroom' in echo.output(), echo.output() + pipeline.output()[-3000:]
        finally:
            pipeline.interrupt()
            status = pipeline.finish()
            node.destroy_node()
            context.try_shutdown()
        assert status == 0 and not TRACEBACK.search(pipeline.output()), pipeline.output()


def launch(ros2, env, domain, tmp_path, *arguments, name='launch') -> Process:
    """Start ``ros2 launch eye_bci_ros2 ARGUMENTS``."""
    return Process([str(ros2), 'launch', PACKAGE, *arguments], env, domain,
                   tmp_path / f'{name}.log')


#: The processes each launch file starts: the pipeline (bridge, camera tracker, projector,
#: arbiter, session markers); the experiment adds the menu and sim_robot (robot:=sim).
PIPELINE_NODES = 5
EXPERIMENT_NODES = PIPELINE_NODES + 2


def assert_clean_stop(process: Process, status: int, expected_nodes: Optional[int]) -> None:
    """Status 0, no traceback, every started node gone."""
    output = process.output()
    assert status == 0, f'status {status}\n{output[-3000:]}'
    assert not TRACEBACK.search(output), output[-3000:]
    pids = started_pids(output)
    if expected_nodes is not None:
        assert len(pids) == expected_nodes, output[-3000:]
    assert not alive(pids), f'left running: {alive(pids)}\n{output[-3000:]}'


@pytest.mark.parametrize('file, nodes', [('pipeline.launch.py', PIPELINE_NODES),
                                         ('experiment.launch.py', EXPERIMENT_NODES)])
def test_launch_then_ctrl_c_once_stops_every_node(ros2, env, tmp_path, file, nodes):
    arguments = [file] + (['rviz:=false'] if file.startswith('experiment') else [])
    with domain_id() as domain:
        process = launch(ros2, env, domain, tmp_path, *arguments)
        assert process.wait_for('waiting for camera/pose'), process.output()
        process.interrupt()
        assert_clean_stop(process, process.finish(), nodes)


@pytest.mark.parametrize('gap_s', [0.3, 0.35, 0.4, 0])
def test_launch_ctrl_c_twice_a_third_of_a_second_apart_exits_0(ros2, env, tmp_path, gap_s):
    # Issue 39: the second Ctrl-C landed after launch had stopped every node and put back
    # Python's own SIGINT handler: KeyboardInterrupt, status 130 (the README says 0).
    with domain_id() as domain:
        process = launch(ros2, env, domain, tmp_path, 'experiment.launch.py', 'rviz:=false')
        assert process.wait_for('waiting for camera/pose'), process.output()
        if gap_s:
            process.interrupt(times=2, gap_s=gap_s)
        else:   # the second the moment launch saw every node end (the narrow case)
            process.interrupt()
            assert process.wait_for(r'process has (finished cleanly|died)', count=6, timeout=30)
            process.interrupt()
        status = process.finish()
        assert_clean_stop(process, status, EXPERIMENT_NODES)
        # An intended stop is no node's failure: no "was required" line for each node.
        assert 'was required' not in process.output(), process.output()[-300:]


def importing_rclpy(pids: List[int]) -> bool:
    """Tell whether every process has our package's imports under way (rclpy loaded)."""
    return all(loaded(pid, 'rclpy') for pid in pids)


def test_launch_ctrl_c_twice_and_during_start_up(ros2, env, tmp_path):
    with domain_id() as domain:
        twice = launch(ros2, env, domain, tmp_path, 'experiment.launch.py', 'rviz:=false',
                       name='twice')
        assert twice.wait_for('waiting for camera/pose'), twice.output()
        # Ctrl-C, and again once launch has taken the first (as a person presses it again
        # when the stop seems slow; a busy machine may take longer than a fixed gap).
        twice.interrupt()
        twice.wait_for('user interrupted with ctrl-c', timeout=5.0)
        twice.interrupt()
        status = twice.finish()
        # Every node stops cleanly, and launch too: a second SIGINT after the nodes have gone
        # is ignored (ros/launch_stop.py), not a KeyboardInterrupt.
        assert stopped_cleanly(twice.output()) == EXPERIMENT_NODES, twice.output()
        assert_clean_stop(twice, status, EXPERIMENT_NODES)
        # While the nodes still import (rclpy is loaded, no node exists yet).  Earlier, in
        # Python's own start-up, only Python itself could keep quiet.
        early = launch(ros2, env, domain, tmp_path, 'pipeline.launch.py', name='early')
        assert early.wait_for('process started', count=4), early.output()
        end = time.monotonic() + WAIT_S
        while not importing_rclpy(started_pids(early.output())) and time.monotonic() < end:
            time.sleep(0.01)
        early.interrupt()
        assert_clean_stop(early, early.finish(), PIPELINE_NODES)


def test_launch_refuses_a_missing_params_file_and_rviz2_before_starting_anything(
        ros2, env, tmp_path):
    with domain_id() as domain:
        missing = launch(ros2, env, domain, tmp_path, 'pipeline.launch.py',
                         'params_file:=/no/such/params.yaml', name='missing')
        assert missing.finish() == 1
        assert "params_file '/no/such/params.yaml' does not exist" in missing.output()
        assert not started_pids(missing.output())
        rviz = launch(ros2, env, domain, tmp_path, 'experiment.launch.py', name='rviz')
        status = rviz.finish()
        if 'rviz2' in env.get('AMENT_PREFIX_PATH', ''):
            pytest.skip('rviz2 is installed here')
        assert status == 1 and 'rviz2 is not installed' in rviz.output(), rviz.output()
        assert not started_pids(rviz.output())


def test_a_failed_node_is_seen_as_the_readme_says_though_launch_exits_0(ros2, env, tmp_path):
    """docs/running.md, "What to expect": ``echo $?`` gives 0; "process has died" tells."""
    readme = (Path(__file__).resolve().parents[2] / 'docs' / 'running.md').read_text()
    for said in ('; echo $?` prints `0`', 'process has died [pid N, exit code 1',
                 "2>&1 | tee launch.log` then\n  `grep 'process has died' launch.log`"):
        assert said in readme, said
    log = tmp_path / 'launch.log'
    # As a user's script does it, in a shell: the launch's own status, then the grep.
    script = (f"'{ros2}' launch {PACKAGE} pipeline.launch.py profile:=tobi 2>&1 "
              f"| tee '{log}'; echo \"launch status ${{PIPESTATUS[0]}}\"; "
              f"grep 'process has died' '{log}'")
    with domain_id() as domain:
        shell = Process(['bash', '-c', script], env, domain, tmp_path / 'shell.log')
        assert shell.finish() == 0, shell.output()
    output = shell.output()
    assert 'launch status 0' in output, output[-3000:]
    died = [line for line in output.splitlines() if line.startswith('[ERROR]')]
    assert len(died) == 2 and died[0] == died[1], output[-3000:]   # the launch's, the grep's
    assert re.match(r'\[ERROR\] \[lsl_gaze_bridge-1\]: process has died \[pid \d+, '
                    r'exit code 1, ', died[0]), died
    assert "cannot start: invalid parameter override: profile: 'tobi'" in output
    assert 'process[lsl_gaze_bridge-1] was required: shutting down launched system' in output
    assert not alive(started_pids(output)), output[-3000:]


def test_launch_refuses_a_boolean_argument_that_is_not_one(ros2, env, tmp_path):
    with domain_id() as domain:
        maybe = launch(ros2, env, domain, tmp_path, 'experiment.launch.py', 'rviz:=maybe',
                       name='maybe')
        status = maybe.finish()
        output = maybe.output()
        assert status == 1, output
        assert "rviz:='maybe' is not a boolean (accepted: true, 1, false, 0; any case)" \
            in output
        assert output.count('is not a boolean') == 1 and not TRACEBACK.search(output), output
        assert not started_pids(output)
        # The accepted values are read as launch reads them: 'False' starts no RViz2.
        accepted = launch(ros2, env, domain, tmp_path, 'experiment.launch.py', 'rviz:=False',
                          'robot:=none',
                          name='accepted')
        assert accepted.wait_for('waiting for camera/pose'), accepted.output()
        accepted.interrupt()
        assert_clean_stop(accepted, accepted.finish(), PIPELINE_NODES + 1)


def test_launch_ends_every_node_when_one_dies_at_start_up(ros2, env, tmp_path):
    with domain_id() as domain:
        process = launch(ros2, env, domain, tmp_path, 'experiment.launch.py', 'rviz:=false',
                         'profile:=tobi')
        status = process.finish()
        output = process.output()
        assert "profile: 'tobi' is not one of" in output
        assert 'lsl_gaze_bridge ended' in output or 'was required' in output, output[-3000:]
        assert not alive(started_pids(output)), output[-3000:]
        assert status == 0 and not TRACEBACK.search(output), output[-3000:]


def test_ctrl_c_on_the_launch_mid_drive_stops_a_robot_of_its_own(ros2, env, tmp_path):
    """
    ``robot:=none`` with a robot of one's own (sim_robot apart, as a nav2 robot would be).

    The person confirms a table; the robot drives; Ctrl-C on the launch: the menu cancels
    its goal before it ends, the goal ends CANCELED and the robot stands.
    """
    import rclpy
    from rclpy.context import Context
    from action_msgs.msg import GoalStatus, GoalStatusArray
    from nav_msgs.msg import Odometry
    from package_commands import stop_all
    from ros_harness import Collector
    from std_msgs.msg import String
    from eye_bci_ros2.ros.runner import make_executor, spin_for, spin_until
    from eye_bci_ros2.ros import topics
    with domain_id() as domain:
        robot = Process([str(ros2), 'run', PACKAGE, 'sim_robot'], env, domain,
                        tmp_path / 'robot.log')
        # No tracker: the bridge must not take another run's gaze stream on this machine.
        params = tmp_path / 'no_tracker.yaml'
        params.write_text(yaml.safe_dump({'/lsl_gaze_bridge': {'ros__parameters': {
            'source_id': f'no-tracker-{domain}-{time.monotonic_ns()}'}}}))
        experiment = launch(ros2, env, domain, tmp_path, 'experiment.launch.py', 'rviz:=false',
                            'robot:=none', f'params_file:={params}', name='experiment')
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        executor = make_executor(context=context)
        try:
            person = rclpy.create_node('person', context=context)
            executor.add_node(person)
            state = Collector(person, String, topics.MENU_STATE_TOPIC, topics.LATCHED_QOS)
            progress = Collector(person, String, topics.MENU_PROGRESS_TOPIC,
                                 topics.LATCHED_QOS)
            status = Collector(person, GoalStatusArray, topics.NAVIGATE_TO_POSE_STATUS_TOPIC,
                               topics.ACTION_STATUS_QOS)
            odom = Collector(person, Odometry, topics.ODOM_TOPIC, topics.ODOM_QOS)
            answers = Collector(person, String, topics.MENU_ANSWER_TOPIC, topics.EVENT_QOS)
            choose = person.create_publisher(String, topics.CHOICE_TOPIC, topics.EVENT_QOS)

            def answer(label):
                """Choose ``label`` when asked, until the menu acts on it (choice_menu/answer)."""
                taken = len([m for m in answers.messages if m.data == label])
                for _ in range(30):
                    assert spin_until(executor, lambda: state.last is not None
                                      and state.last.data in ('asking', 'driving'), WAIT_S), \
                        experiment.output()[-3000:]
                    spin_for(executor, 0.2)
                    choose.publish(String(data=label))
                    if spin_until(executor, lambda: len(
                            [m for m in answers.messages if m.data == label]) > taken, 2.0):
                        return
                raise AssertionError(f"'{label}' was never taken:\n{experiment.output()[-3000:]}")

            def lines():
                return [message.data for message in progress.messages]

            for label in ('living_room', 'living_room/table_3', 'go', 'send'):
                answer(label)
            assert spin_until(executor, lambda: odom.last is not None
                              and odom.last.twist.twist.linear.x > 0.3, WAIT_S), lines()
            experiment.interrupt()
            assert_clean_stop(experiment, experiment.finish(), None)

            def cancelled():
                last = status.last
                return last is not None and [s.status for s in last.status_list][-1:] == [
                    GoalStatus.STATUS_CANCELED]
            assert spin_until(executor, cancelled, 10.0), status.last
            # Standing: the odometry's twist is zero and its pose stays.
            assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == 0.0, 5.0)
            standing = odom.last.pose.pose.position
            spin_for(executor, 1.0)
            assert abs(odom.last.pose.pose.position.x - standing.x) < 1e-6
            assert abs(odom.last.pose.pose.position.y - standing.y) < 1e-6
            assert 'the robot goal is cancelled: the menu ends' in experiment.output()
        finally:
            stop_all(experiment, robot)
            executor.shutdown()
            context.try_shutdown()
