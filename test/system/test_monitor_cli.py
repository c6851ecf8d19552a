"""
``monitor --once`` beside a running ``eye_bci``: which nodes are up, what each waits for.

The pipeline runs as ``ros2 run`` starts it (``eye_bci`` in its own process), the
tracker is ``sim_gaze`` (a real LSL outlet), and the monitor is started once the
pipeline is up, so its own discovery is what it must wait for.
"""

import os
import subprocess
import sys

from domain_coordinator import domain_id
from lsl_outlets import unique_id
from package_commands import running, stop
import pytest

from eye_bci_ros2.tools.monitor import node_lines

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def monitor_once(domain: int) -> str:
    """Run ``monitor --once`` (output to a pipe: one plain line); return its line."""
    result = subprocess.run([sys.executable, '-m', 'eye_bci_ros2.tools.monitor', '--once'],
                            capture_output=True, text=True, timeout=120,
                            env=dict(os.environ, ROS_DOMAIN_ID=str(domain)))
    assert result.returncode == 0 and 'Traceback' not in result.stderr, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == 1, result.stdout
    return lines[0]


def field(line: str, key: str) -> str:
    """Return the value of ``key=`` in a plain status line."""
    return next(item.split('=', 1)[1] for item in line.split() if item.startswith(key + '='))


def test_once_names_the_running_nodes_and_what_each_waits_for(tmp_path):
    with domain_id() as domain:
        # Nothing running: it says so (after waiting for discovery), not just dashes.
        assert field(monitor_once(domain), 'nodes') == '-'
        tracker = unique_id('tracker')
        with running('nodes.eye_bci', '--ros-args', '-p', f'source_id:={tracker}',
                     log=tmp_path / 'eye_bci.log', domain=domain) as pipeline:
            assert pipeline.wait_for('waiting for camera/pose'), pipeline.output()[-3000:]
            # No tracker yet, no RViz, no menu: each node waits for its own input.
            assert field(monitor_once(domain), 'nodes') == (
                'lsl_gaze_bridge(gaze_stream),camera_tracker(rviz_camera),'
                'marker_projector(options),choice_arbiter(regions+gaze),session_markers')
            # The tracker starts: the bridge and the arbiter have their gaze.
            with running('sim.gaze_outlet', '--source-id', tracker, log=tmp_path / 'sim.log',
                         domain=domain):
                assert pipeline.wait_for('connected to gaze LSL stream'), \
                    pipeline.output()[-3000:]
                line = monitor_once(domain)
            assert field(line, 'nodes') == ('lsl_gaze_bridge,camera_tracker(rviz_camera),'
                                            'marker_projector(options),choice_arbiter(regions),'
                                            'session_markers')
            assert int(field(line, 'samples')) > 0
            assert stop(pipeline) == 0


def test_the_terminal_block_says_it_in_words():
    """The block a terminal shows: one line per node, "waiting for" in words."""
    assert node_lines({}) == ["nodes    none of the pipeline's seen (is eye_bci running, with "
                              'this ROS_DOMAIN_ID and namespace?)']
    lines = node_lines({'lsl_gaze_bridge': [('gaze_stream', 'a gaze stream')],
                        'choice_arbiter': []})
    assert lines == ['nodes    lsl_gaze_bridge  waiting for a gaze stream',
                     '         choice_arbiter   ok']
