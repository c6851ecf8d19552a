"""
Hints the executables give a user, followed as a user would follow them.

A hint that sends the user the wrong way is worse than none: each is taken
literally here (the parameter it suggests is set, the document section it
names is opened, the figure it states is compared with what runs).
"""

import math
import os
import re
import subprocess
import sys

from domain_coordinator import domain_id
from lsl_outlets import make_outlet, unique_id
from package_commands import lines, running, stop
from paths import REPO
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.lsl, pytest.mark.slow]

#: A reference to a section of a document, as the hints write it: (docs/x.md, "Section").
DOC_REFERENCE = re.compile(r'\((README\.md|docs/[\w.-]+\.md), "([^"]+)"\)')


def section_exists(document: str, section: str) -> bool:
    """Tell whether ``document`` (a repository path) has the heading ``section[: ...]``."""
    with open(REPO / document, encoding='utf-8') as stream:
        return any(re.fullmatch(rf'#+ {re.escape(section)}(: .*)?', line.strip())
                   for line in stream)


def test_the_bridge_says_an_eeg_stream_is_no_gaze_and_following_it_connects(tmp_path):
    """The old hint (stream_type:='EEG') is refused with the reason; the new one works."""
    amplifier, info = make_outlet('custom', name=unique_id('LiveAmp'),
                                  source_id=unique_id('amp'), stream_type='EEG')
    with domain_id() as domain, \
            running('nodes.lsl_gaze_bridge', '--ros-args', '-p', 'profile:=custom', '-p',
                    'stream_type:=EEG', '-p', f'source_id:={info.source_id()}',
                    log=tmp_path / 'eeg.log', domain=domain) as bridge:
        assert bridge.wait_for('not taking'), bridge.output()[-3000:]
        assert stop(bridge) == 0
    line, = lines(bridge, 'not taking')
    assert (f"not taking '{info.name()}' (type 'EEG'" in line and 'it is an EEG stream, not '
            "gaze (a gaze bridge cannot use it): start the eye tracker's LSL sender (sim_gaze "
            'to try without one)' in line), line
    assert 'Traceback' not in bridge.output()
    del amplifier
    # What it says to do: a tracker's sender (here sim_gaze), and the bridge connects.
    tracker = unique_id('tracker')
    with domain_id() as domain, \
            running('sim.gaze_outlet', '--source-id', tracker, log=tmp_path / 'sim.log',
                    domain=domain), \
            running('nodes.lsl_gaze_bridge', '--ros-args', '-p', f'source_id:={tracker}',
                    log=tmp_path / 'gaze.log', domain=domain) as bridge:
        assert bridge.wait_for('connected to gaze LSL stream'), bridge.output()[-3000:]
    line, = lines(bridge, 'connected to gaze LSL stream')
    assert f"source_id '{tracker}'" in line, line


def test_sim_eeg_help_states_the_frequencies_it_then_sends(tmp_path):
    help_text = subprocess.run([sys.executable, '-m', 'eye_bci_ros2.sim.eeg_outlet', '--help'],
                               capture_output=True, text=True, timeout=60).stdout
    stated = re.search(r'in order \(([\d., ]+) \.\.\. Hz, phase steps ([\d.]+) pi\)',
                       ' '.join(help_text.split()))
    assert stated, help_text
    frequencies = [float(f) for f in stated.group(1).split(',')]
    with domain_id() as domain, \
            running('sim.eeg_outlet', '--source-id', unique_id('sim_eeg'),
                    log=tmp_path / 'eeg.log', domain=domain) as sender:
        assert sender.wait_for('(?m)^stimuli: '), sender.output()[-3000:]
    line, = lines(sender, '^stimuli: ')
    sent = [float(f) for f in re.findall(r' ([\d.]+) Hz', line)]
    assert sent[:len(frequencies)] == frequencies, (stated.group(0), line)
    phases = [float(p) for p in re.findall(r' ([\d.]+) rad', line)]
    assert phases[1] - phases[0] == pytest.approx(float(stated.group(2)) * math.pi, abs=0.01)


#: Starts view_animated_bridge as a machine without RViz2's view-controller messages would:
#: the set-up builds them into the venv (interfaces/), so the import is refused here.
WITHOUT_VIEW_MESSAGES = """
import runpy, sys

class Missing:
    def find_spec(self, name, path=None, target=None):
        if name.split('.')[0] == 'rviz_plugin_view_animated_msgs':
            raise ModuleNotFoundError(f'No module named {name!r}')

sys.meta_path.insert(0, Missing())
runpy.run_module('eye_bci_ros2.nodes.view_animated_bridge', run_name='__main__')
"""


def test_view_animated_bridge_names_a_section_that_says_how_to_build_its_messages():
    process = subprocess.run([sys.executable, '-c', WITHOUT_VIEW_MESSAGES],
                             capture_output=True, text=True, timeout=60)
    err = process.stderr
    last = err.strip().splitlines()[-1]
    assert process.returncode == 1 and last.startswith('cannot start:'), err
    reference = DOC_REFERENCE.search(last)
    assert reference, last
    document, section = reference.groups()
    assert section_exists(document, section), reference.group(0)
    with open(REPO / document, encoding='utf-8') as stream:
        text = stream.read()
    body = text[text.index(f' {section}\n'):]
    body = body[:body.find('\n#', 1) if '\n#' in body[1:] else len(body)]
    assert 'rviz_plugin_view_animated_msgs' in body and 'colcon' in body


def test_every_document_section_the_package_names_exists():
    """Every (docs/x.md, "Section") in the package's messages and docstrings is there."""
    named = []
    for folder, _, files in os.walk(REPO / 'eye_bci_ros2'):
        for name in files:
            if name.endswith('.py'):
                with open(os.path.join(folder, name), encoding='utf-8') as stream:
                    # Joined strings: one reference may span two source lines.
                    text = re.sub(r"['\"]\s*\n\s*['\"]", '', stream.read())
                named += [(name, *match) for match in DOC_REFERENCE.findall(
                    ' '.join(text.split()))]
    assert named, 'no reference found: the pattern is wrong'
    missing = [ref for ref in named if not section_exists(*ref[1:])]
    assert not missing, missing
