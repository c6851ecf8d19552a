"""
Validation as a user runs it: sim_gaze --follow, lsl_gaze_bridge and gaze_validation as processes.

The issue's goal is measured here end to end: the 0.8 deg offset of the original_tobii_4c
person (its drift off: ``--drift-deg 0``; an ideal eye: ``--ideal-eye``, no error that varies
over the screen, which an offset correction cannot remove) is corrected to at most 0.2 deg
residual accuracy, and
the saved file is what ``lsl_gaze_bridge --ros-args --params-file`` reads.  With the preset's
drift the residual is about the drift (bench/validation.py).
"""

import os
import re
import signal
import subprocess
import sys

from domain_coordinator import domain_id
from lsl_outlets import unique_id
import numpy as np
import pytest

from eye_bci_ros2.gaze.validation import load_correction, save_correction

pytestmark = [pytest.mark.ros, pytest.mark.lsl, pytest.mark.slow]

GOAL_DEG = 0.2
SHIFT = [1.01, 0.0, -20.0, 0.0, 1.01, 12.0]


def start(module, *args, domain):
    """Start ``python -m eye_bci_ros2.<module> args`` on ``domain`` with piped output."""
    return subprocess.Popen([sys.executable, '-m', f'eye_bci_ros2.{module}', *args],
                            env=dict(os.environ, ROS_DOMAIN_ID=str(domain)),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def stop(process, timeout=15):
    """SIGINT a process and return its (status, stdout, stderr)."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
    try:
        out, err = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        out, err = process.communicate()
    return process.returncode, out, err


def test_the_bridge_reads_the_saved_file_with_params_file(graph, tmp_path):
    path = save_correction(str(tmp_path / 'correction.yaml'), SHIFT)
    bridge = start('nodes.lsl_gaze_bridge', '--ros-args', '--params-file', path,
                   domain=graph.domain)
    try:
        value, = graph.get_parameters('/lsl_gaze_bridge', ['gaze_correction'], timeout=20.0)
    finally:
        status, _, err = stop(bridge)
    assert value == SHIFT
    assert status == 0, err[-2000:]


def test_sim_person_bridge_and_validation_reach_the_residual_goal(tmp_path):
    source = unique_id('sim-validation-process')
    output = tmp_path / 'correction.yaml'
    with domain_id() as domain:
        person = start('sim.gaze_outlet', '--preset', 'original_tobii_4c', '--seed', '1',
                       '--drift-deg', '0', '--ideal-eye',
                       '--follow', 'validation/target', '--source-id', source,
                       '--status-s', '0', domain=domain)
        bridge = start('nodes.lsl_gaze_bridge', '--ros-args', '-p', f'source_id:={source}',
                       domain=domain)
        try:
            # The person's screen: 527 x 296 mm at 600 mm (sim_gaze's default).
            validation = start(
                'nodes.gaze_validation', '--ros-args', '-p', 'screen_width_mm:=527.0',
                '-p', 'screen_height_mm:=296.0', '-p', 'viewing_distance_mm:=600.0',
                '-p', 'camera_wait_s:=0.0', '-p', 'bridge_timeout_s:=20.0',
                # Started with the bridge: its first gaze may take a while on a loaded machine.
                '-p', 'gaze_wait_s:=30.0',
                '-p', f'output:={output}', domain=domain)
            out, err = validation.communicate(timeout=120)
        finally:
            stop(person)
            stop(bridge)
    assert validation.returncode == 0, err[-3000:]
    summary = [line for line in err.splitlines() if 'validation accepted' in line]
    assert len(summary) == 1, err[-3000:]
    before, residual = (float(v) for v in re.search(
        r'accuracy ([0-9.]+) deg, precision.*residual accuracy ([0-9.]+) deg',
        summary[0]).groups())
    print(f'original_tobii_4c through the processes: accuracy {before:.2f} deg -> residual '
          f'{residual:.2f} deg')
    assert before > 0.5 and residual <= GOAL_DEG
    assert np.all(np.isfinite(load_correction(str(output))))
