"""
The terminal monitor on a private graph that publishes gaze batches, options and choices.

The gaze batches are sensor_msgs/PointCloud2 built here (fields x, y float32
screen px, t float64 s after header.stamp), as the bridge publishes them on
``gaze/samples``; options are ``choices/regions`` as marker_projector
publishes them; decisions are ``choice`` strings.
"""

import io
import os
import signal
import subprocess
import sys
import threading
import time

from builtin_interfaces.msg import Time
import numpy as np
import pytest
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.ros.conversions import gaze_batch, regions_to_marker_array
from eye_bci_ros2.ros.topics import EVENT_QOS, GAZE_QOS, LATCHED_QOS, MENU_PROGRESS_TOPIC
from eye_bci_ros2.tools import monitor as monitor_tool
from eye_bci_ros2.tools.monitor import Monitor, Screen, status_line, status_lines

pytestmark = pytest.mark.ros

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RATE_HZ = 1200.0
#: Longest wait for discovery and for the monitor to show what was sent, s.
WAIT_S = 30.0
#: Two options: 'kitchen' (text) at x 100..300 and 'rooms/1' (no text) at x 400..600.
SQUARES = {('rooms', 0, 'kitchen'): (100.0, 300.0), ('rooms', 1, ''): (400.0, 600.0)}


def gaze_cloud(xy, stamp_s, dt_s) -> PointCloud2:
    """Build one gaze batch: samples at stamp_s + dt_s[i], screen px xy[i]."""
    stamps_ns = np.rint((stamp_s + np.asarray(dt_s, dtype=float)) * 1e9).astype(np.int64)
    return gaze_batch(stamps_ns, xy)


def regions_message() -> MarkerArray:
    """Build choices/regions with the two SQUARES, 100..300 px high."""
    polygons, sources = [], []
    for (ns, marker_id, text), (x0, x1) in SQUARES.items():
        polygons.append([[x0, 100.0], [x1, 100.0], [x1, 300.0], [x0, 300.0]])
        sources.append(Marker(ns=ns, id=marker_id, text=text))
    return regions_to_marker_array(np.array(polygons), sources, Time())


class Sender:
    """A test node playing the bridge, the projector and the arbiter."""

    def __init__(self, graph):
        node = graph.node('monitor_test_sender')
        self.gaze = node.create_publisher(PointCloud2, 'gaze/samples', GAZE_QOS)
        self.regions = node.create_publisher(MarkerArray, 'choices/regions', LATCHED_QOS)
        self.choice = node.create_publisher(String, 'choice', EVENT_QOS)
        self.t = 1000.0

    def batches(self, count, per_batch=12, xy=(200.0, 200.0), gap_after=None, gap_s=0.3):
        """Publish ``count`` batches of samples at RATE_HZ; one gap after batch ``gap_after``."""
        for index in range(count):
            dt = np.arange(per_batch) / RATE_HZ
            self.gaze.publish(gaze_cloud(np.tile(xy, (per_batch, 1)), self.t, dt))
            self.t += per_batch / RATE_HZ
            if index == gap_after:
                self.t += gap_s - 1 / RATE_HZ


def test_status_shows_rate_gaps_gaze_region_options_and_choices(graph):
    monitor = graph.add(Monitor)
    sender = Sender(graph)
    sender.regions.publish(regions_message())
    assert graph.spin_until(lambda: monitor.labels, 10.0), 'no regions reached the monitor'
    # Wait until the gaze subscription is matched, then 50 batches of 12 at 1200 Hz,
    # one 0.3 s gap (a blink), the newest sample in 'kitchen'.
    assert graph.spin_until(lambda: sender.gaze.get_subscription_count() > 0, 10.0)
    sender.batches(50, gap_after=20)
    sender.choice.publish(String(data='kitchen'))
    sender.choice.publish(String(data='rooms/1'))
    assert graph.spin_until(lambda: monitor.gaze.samples == 600 and
                            len(monitor.decisions) == 2, 10.0), monitor.status()
    status = monitor.status()
    assert status['samples'] == 600 and status['messages'] == 50
    assert status['gaps'] == 1 and status['longest_gap_s'] == pytest.approx(0.3, abs=1e-3)
    # 600 samples over 599 / 1200 s of stamps plus the 0.3 s gap.
    assert status['sample_rate'] == pytest.approx(599 / (599 / RATE_HZ + 0.3 - 1 / RATE_HZ),
                                                  rel=1e-3)
    assert status['gaze_xy'] == [200.0, 200.0] and status['gaze_region'] == 'kitchen'
    assert status['options'] == ['kitchen', 'rooms/1']
    assert status['decisions'] == ['kitchen', 'rooms/1']
    lines = status_lines(status, monitor.decisions)
    assert lines[0].startswith('gaze ') and '600 samples, 1 gaps (longest 0.30 s), ok' in lines[0]
    assert lines[1] == "looking  (200.0, 200.0) px, in 'kitchen'"
    assert lines[2] == 'options  2: kitchen, rooms/1'
    assert lines[3].startswith("choice   'rooms/1' ") and "; 'kitchen' " in lines[3]
    line = status_line(status, 3.0)
    assert 'samples=600 gaps=1 ' in line and 'gaze=200.0,200.0 region=kitchen' in line
    assert 'options=kitchen|rooms/1 last_choice=rooms/1' in line
    # Gaze between the options, then outside the screen's options altogether.
    sender.batches(1, xy=(350.0, 200.0))
    assert graph.spin_until(lambda: monitor.gaze.samples == 612, 10.0)
    assert monitor.status()['gaze_region'] == ''
    assert 'in no option' in status_lines(monitor.status())[1]


def test_the_robot_is_shown_as_the_menu_reports_it(graph):
    """``choice_menu/progress`` (latched, the menu's words): driving, arrived, stopped."""
    monitor = graph.add(Monitor)
    menu = graph.node('monitor_test_menu')
    progress = menu.create_publisher(String, MENU_PROGRESS_TOPIC, LATCHED_QOS)
    assert monitor.status()['robot'] is None
    for text in ("driving to 'table_2': 1.4 m left", "arrived at 'table_2'",
                 "stopped on the way to 'table_1'"):
        progress.publish(String(data=text))
        assert graph.spin_until(lambda: monitor.status()['robot'] == text, 10.0), \
            monitor.status()['robot']
        assert f'robot    {text}' in status_lines(monitor.status())
    line = status_line(monitor.status(), 1.0)
    assert " robot=stopped_on_the_way_to_'table_1' " in line, line


def test_a_monitor_started_later_sees_the_robot_at_once(graph):
    """Latched: a monitor started while the robot drives shows it without waiting for news."""
    menu = graph.node('monitor_test_menu')
    progress = menu.create_publisher(String, MENU_PROGRESS_TOPIC, LATCHED_QOS)
    progress.publish(String(data="driving to 'table_1': 3.0 m left"))
    monitor = graph.add(Monitor)
    assert graph.spin_until(
        lambda: monitor.status()['robot'] == "driving to 'table_1': 3.0 m left", 10.0)


def test_unreadable_batch_is_counted_and_shown_not_fatal(graph):
    monitor = graph.add(Monitor)
    sender = Sender(graph)
    assert graph.spin_until(lambda: sender.gaze.get_subscription_count() > 0, 10.0)
    broken = gaze_cloud([[1.0, 2.0]], 5.0, [0.0])
    broken.fields = [field for field in broken.fields if field.name != 'x']
    sender.gaze.publish(broken)
    sender.batches(2)
    assert graph.spin_until(lambda: monitor.gaze.samples == 24, 10.0)
    status = monitor.status()
    assert status['bad_messages'] == 1 and "fields ['y', 't']" in status['problem']
    assert status_lines(status)[-1].startswith('problem  unreadable gaze/samples message')


def test_nothing_yet_and_stale_gaze_are_said_plainly(graph):
    monitor = graph.add(Monitor)
    lines = status_lines(monitor.status())
    assert lines == ['gaze     nothing on gaze/samples yet', 'looking  -',
                     'options  none offered', 'choice   -', 'robot    -',
                     "nodes    none of the pipeline's seen (is eye_bci running, with this "
                     'ROS_DOMAIN_ID and namespace?)']
    sender = Sender(graph)
    assert graph.spin_until(lambda: sender.gaze.get_subscription_count() > 0, 10.0)
    sender.batches(1)
    assert graph.spin_until(lambda: monitor.gaze.samples == 12, 10.0)
    later = monitor.status(now=time.monotonic() + 5.0)
    assert later['sample_rate'] == 0.0
    assert 'NOTHING for 5.' in status_lines(later)[0]


def test_terminal_output_redraws_in_place_and_pipe_output_appends_lines(graph):
    monitor = graph.add(Monitor)
    terminal, pipe = io.StringIO(), io.StringIO()
    screen, plain = Screen(terminal, terminal=True), Screen(pipe, terminal=False)
    for _ in range(2):
        screen.show(monitor)
        plain.show(monitor)
    first, second = terminal.getvalue().split('\n' + '\x1b[7F\x1b[J')
    assert first.startswith('eye_bci monitor ') and '\x1b' not in first
    assert second.count('\n') == 7
    lines = pipe.getvalue().splitlines()
    assert len(lines) == 2 and all(line.startswith('t=') for line in lines)
    assert '\x1b' not in pipe.getvalue()
    plain.choice(0.0, 'kitchen')
    assert pipe.getvalue().splitlines()[-1].endswith(' choice kitchen')


def test_run_prints_plain_lines_and_each_choice_until_stopped(graph):
    sender = Sender(graph)
    sender.regions.publish(regions_message())
    stop = threading.Event()
    out = io.StringIO()

    def publish():
        end = time.monotonic() + WAIT_S
        while not (sender.gaze.get_subscription_count() and sender.choice.get_subscription_count()
                   ) and time.monotonic() < end:
            time.sleep(0.01)
        for _ in range(40):
            sender.batches(1)
            time.sleep(0.02)   # a tracker's pace, not a wait
        sender.choice.publish(String(data='kitchen'))
        # Stop once the monitor has shown all of it (its status comes every --period).
        while not ('samples=480 ' in out.getvalue() and ' choice kitchen' in out.getvalue()) \
                and time.monotonic() < end:
            time.sleep(0.05)
        stop.set()

    thread = threading.Thread(target=publish)
    thread.start()
    args = monitor_tool.build_parser().parse_args(['--duration', str(2 * WAIT_S),
                                                   '--period', '0.5'])
    try:
        assert monitor_tool.run(args, context=graph.context, stream=out, terminal=False,
                                stop=stop) == 0
    finally:
        stop.set()
        thread.join()
    lines = out.getvalue().splitlines()
    periodic = [line for line in lines if line.startswith('t=')]
    assert len(periodic) >= 2 and all('\x1b' not in line for line in lines)
    assert any(line.endswith(' choice kitchen') for line in lines)
    assert 'samples=480 ' in lines[-1] and 'options=kitchen|rooms/1' in lines[-1]


def test_run_ends_by_itself_after_its_duration(graph):
    out = io.StringIO()
    args = monitor_tool.build_parser().parse_args(['--duration', '0.6', '--period', '0.2'])
    start = time.monotonic()
    assert monitor_tool.run(args, context=graph.context, stream=out, terminal=False) == 0
    assert time.monotonic() - start >= 0.6
    lines = out.getvalue().splitlines()
    assert lines and all(line.startswith('t=') for line in lines)
    assert 'gaze_rate=' in lines[-1]


def test_command_line_once_on_the_graph(graph):
    sender = Sender(graph)
    sender.regions.publish(regions_message())
    env = dict(os.environ, ROS_DOMAIN_ID=str(graph.domain), PYTHONPATH=REPO)
    process = subprocess.Popen(
        [sys.executable, '-m', 'eye_bci_ros2.tools.monitor', '--once', '--period', '4'],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=REPO)
    graph.spin_for(0.1)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    lines = out.splitlines()
    assert len(lines) == 1, out
    assert lines[0].startswith('t=') and 'options=kitchen|rooms/1' in lines[0]


def test_command_line_help_and_bad_option():
    result = subprocess.run([sys.executable, '-m', 'eye_bci_ros2.tools.monitor', '--help'],
                            capture_output=True, text=True, cwd=REPO, timeout=60)
    assert result.returncode == 0 and 'gaze/samples' in result.stdout
    result = subprocess.run([sys.executable, '-m', 'eye_bci_ros2.tools.monitor',
                             '--duration', '-1'], capture_output=True, text=True, cwd=REPO,
                            timeout=60)
    assert result.returncode == 2 and 'positive number' in result.stderr


@pytest.mark.parametrize('signals', [('SIGINT',), ('SIGINT', 'SIGINT'), ('SIGTERM',),
                                     ('SIGTERM', 'SIGINT')])
def test_ctrl_c_and_sigterm_end_it_cleanly_even_twice(graph, signals):
    env = dict(os.environ, ROS_DOMAIN_ID=str(graph.domain), PYTHONPATH=REPO)
    process = subprocess.Popen(
        [sys.executable, '-m', 'eye_bci_ros2.tools.monitor', '--period', '0.2'],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=REPO)
    assert process.stdout.readline().startswith('t=')   # running: its first status line
    for name in signals:
        process.send_signal(getattr(signal, name))
        time.sleep(0.002)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert 'Traceback' not in err
