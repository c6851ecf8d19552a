"""
``ssvep_calibrate --output PATH`` as a user runs it, where PATH cannot be written.

A calibration session is minutes of a person's attention: a path that cannot
be written is refused before anything is recorded, and one that fails after
the recording (a directory removed, a disk unmounted) leaves the model in a
fallback file named in one line, never a traceback and a lost session.
"""

import os
import re
import shutil
import subprocess
import sys

from lsl_outlets import unique_id
import pytest

from eye_bci_ros2.ssvep.decoders import TrcaModel

pytestmark = [pytest.mark.lsl, pytest.mark.slow]

#: A short session (2 options x 3 trials, 2 rest trials) over the tool's own simulated outlet.
QUICK = ['--options', 'a,b', '--trials', '3', '--rest-trials', '2', '--trial-s', '1.0',
         '--rest-s', '0.5']


def command(*args):
    """Return the command line of the ``ssvep_calibrate`` console script."""
    return [sys.executable, '-m', 'eye_bci_ros2.tools.ssvep_calibrate', *args]


@pytest.mark.parametrize('where, reason', [('no/such/model.npz', 'No such file or directory'),
                                           ('a_file/model.npz', 'Not a directory')])
def test_an_unwritable_output_is_refused_before_recording(tmp_path, where, reason):
    (tmp_path / 'a_file').write_text('')
    output = tmp_path / where
    result = subprocess.run(command(*QUICK, '--source', 'lsl', '--drive-sim', '--output',
                                    str(output)), capture_output=True, text=True, timeout=120)
    assert result.returncode == 1, result.stderr
    assert result.stderr.strip().splitlines() == [
        f"ssvep_calibrate: cannot write '{output}': {reason}; nothing recorded"]
    assert 'attend' not in result.stdout       # not one trial cued


def test_an_output_that_fails_after_the_recording_goes_to_a_named_fallback(tmp_path):
    out_dir = tmp_path / 'session'
    out_dir.mkdir()
    spare = tmp_path / 'tmp'
    spare.mkdir()
    output = out_dir / 'model.npz'
    process = subprocess.Popen(
        command(*QUICK, '--source', 'lsl', '--drive-sim', '--source-id',
                unique_id('calibrate-fallback'), '--output', str(output)),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env=dict(os.environ, TMPDIR=str(spare)))
    try:
        # Recording: the first cue.  Now the output directory goes away.
        for line in process.stdout:
            if line.startswith('attend '):
                break
        shutil.rmtree(out_dir)
        out, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 1, err
    assert 'Traceback' not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    found = re.fullmatch(rf"ssvep_calibrate: cannot write '{re.escape(str(output))}' "
                         r'\(No such file or directory\): the model saved to (\S+) instead',
                         lines[0])
    assert found, lines[0]
    fallback = found.group(1)
    assert os.path.dirname(fallback) == str(spare)
    assert TrcaModel.load(fallback).labels == ('a', 'b')
    assert out.strip().splitlines()[-1].endswith(f'to {fallback}')
