"""
What a user reads on the terminal: each thing said once, in the package's words.

The executables run as processes, as ``ros2 run`` starts them; the tracker
is ``sim_gaze`` (a real LSL outlet in its own process), stopped and started
again as a person unplugging and restarting a tracker would.
"""

import os

from domain_coordinator import domain_id
from lsl_outlets import unique_id
from package_commands import command, ended, lines, stop_all
import pytest
from watched_process import Process

pytestmark = [pytest.mark.ros, pytest.mark.lsl, pytest.mark.slow]

#: The bridge's periodic statistics line.
STATS = r'gaze: \d+ received'


def test_a_tracker_that_stops_and_restarts_is_reported_once_each_without_liblsl(tmp_path):
    tracker, name = unique_id('tracker'), unique_id('eyes')
    sender = command('sim.gaze_outlet', '--source-id', tracker, '--name', name)
    with domain_id() as domain:
        bridge = Process(command('nodes.lsl_gaze_bridge', '--ros-args', '-p',
                                 f'source_id:={tracker}', '-p', 'stats_period_s:=0.5', '-p',
                                 'stale_timeout_s:=30.0'), os.environ, domain,
                         tmp_path / 'bridge.log')
        first = Process(sender, os.environ, domain, tmp_path / 'sender1.log')
        second = None
        try:
            assert bridge.wait_for('connected to gaze LSL stream'), bridge.output()[-3000:]
            assert bridge.wait_for(STATS), bridge.output()[-3000:]
            first.interrupt()                    # the tracker stops
            assert first.finish() == 0
            assert bridge.wait_for('lost gaze stream'), bridge.output()[-3000:]
            second = Process(sender, os.environ, domain, tmp_path / 'sender2.log')
            assert bridge.wait_for('is back'), bridge.output()[-3000:]
            # A statistics line of the stream back.
            assert bridge.wait_for(STATS, count=len(lines(bridge, STATS)) + 1), \
                bridge.output()[-3000:]
            bridge.interrupt()                   # before this tracker stops too
            assert bridge.finish() == 0
        finally:
            stop_all(bridge, first, second)
    text = bridge.output()
    # liblsl's receiver thread said nothing; the bridge said it once, in one line.
    assert 'ERR|' not in text and 'Stream transmission broke off' not in text, text[-3000:]
    assert text.count('lost gaze stream') == 1, text[-3000:]
    # The same tracker again is not "switching to" a stream of the same name.
    back, = lines(bridge, 'is back')
    assert back.endswith('is back (its sender restarted); reconnecting') and \
        f"'{name}'" in back, back
    assert 'switching to' not in text, text[-3000:]
    # Statistics name the stream their samples came from, also after it was lost.
    stats = lines(bridge, STATS)
    assert stats and all(f"from '{name}'" in line for line in stats), stats
    assert 'Traceback' not in text


def test_a_missing_scene_is_said_once(tmp_path):
    missing = tmp_path / 'no_such_scene.yaml'
    menu = ended('nodes.choice_menu', '--ros-args', '-p', f'scene_file:={missing}',
                 log=tmp_path / 'menu.log')
    text = menu.output()
    assert menu.process.returncode == 1 and 'Traceback' not in text, text
    assert text.count(f'cannot read scene file {missing}') == 1, text
    assert text.strip().splitlines()[-1].startswith('cannot start: '), text


@pytest.mark.parametrize('x, y, shared', [('gaze_x', 'gaze_x', 'gaze_x'),
                                          ('left_x,right_x', 'left_y,left_x', 'left_x')])
def test_x_and_y_naming_one_channel_are_refused_with_the_reason(tmp_path, x, y, shared):
    bridge = ended('nodes.lsl_gaze_bridge', '--ros-args', '-p', 'profile:=custom', '-p',
                   f'x_channel:={x}', '-p', f'y_channel:={y}', log=tmp_path / 'bridge.log')
    text = bridge.output()
    assert bridge.process.returncode == 1 and 'Traceback' not in text, text
    assert text.strip().splitlines()[-1] == (
        'cannot start: invalid parameter overrides: x_channel and y_channel both name channel '
        f"'{shared}': x and y must be two different channels of the stream"), text
