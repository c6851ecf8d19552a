"""ssvep_calibrate on the simulated amplifier: a model the decoder can load and use."""

import numpy as np

from eye_bci_ros2.sim.eeg import calibration_session, EegSimulator, SUBJECTS
from eye_bci_ros2.ssvep.decoders import TrcaModel
from eye_bci_ros2.ssvep.filters import filter_recording
from eye_bci_ros2.ssvep.stimuli import assign_stimuli
from eye_bci_ros2.tools.ssvep_calibrate import main


def test_calibrate_fits_a_model_that_decodes_new_trials(tmp_path, capsys):
    path = tmp_path / 'model.npz'
    assert main(['--options', 'kitchen,bedroom,bath', '--trials', '4', '--subject', 's3',
                 '--output', str(path)]) == 0
    assert 'saved TRCA model of 3 options x 4 trials' in capsys.readouterr().out
    model = TrcaModel.load(str(path))
    assert model.labels == ('kitchen', 'bedroom', 'bath') and model.ensemble
    stimuli = assign_stimuli(model.labels)
    simulator = EegSimulator(SUBJECTS[2], seed=99)
    times, samples, trials = calibration_session(simulator, stimuli, 4, seed=99)
    columns = [simulator.labels.index(name) for name in model.channels]
    filtered = filter_recording(samples[:, columns], 250.0)
    correct = [model.labels[int(np.argmax(model.scores(
        filtered[:, np.searchsorted(times, onset):][:, :250])))] == label
        for onset, label in trials]
    assert np.mean(correct) >= 0.9


def test_calibrate_refuses_too_few_trials(tmp_path, capsys):
    assert main(['--options', 'a,b', '--trials', '1', '--output',
                 str(tmp_path / 'm.npz')]) == 2
    assert 'at least 2' in capsys.readouterr().err
