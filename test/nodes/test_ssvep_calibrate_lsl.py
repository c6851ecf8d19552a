"""ssvep_calibrate over a real LSL stream (its own simulated outlet) -> a model for TRCA."""

import pytest

from eye_bci_ros2.ssvep.decoders import TrcaModel
from eye_bci_ros2.tools.ssvep_calibrate import main

pytestmark = [pytest.mark.lsl, pytest.mark.slow]


def test_calibrate_records_lsl_and_fits(tmp_path, capsys):
    path = tmp_path / 'model.npz'
    assert main(['--source', 'lsl', '--drive-sim', '--options', 'a,b', '--trials', '3',
                 '--rest-trials', '2', '--trial-s', '1.0', '--rest-s', '0.5', '--subject',
                 's6', '--output', str(path)]) == 0
    out = capsys.readouterr().out
    assert out.count('attend ') == 6 and out.count('rest: look at the fixation point') == 2
    model = TrcaModel.load(str(path))
    assert model.labels == ('a', 'b') and model.template_s == pytest.approx(1.0)
    assert model.rest is not None
    assert model.channels == ('O1', 'Oz', 'O2', 'POz', 'PO3', 'PO4', 'PO7', 'PO8')
