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
    assert 'saved TRCA model of 3 options, 12 trials from 1 recording' in \
        capsys.readouterr().out
    model = TrcaModel.load(str(path))
    assert model.labels == ('kitchen', 'bedroom', 'bath') and model.ensemble
    # It learnt what nobody attending looks like (the rest trials): its null.
    assert model.rest is not None and model.rest.source == 'calibration'
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


def test_calibrate_from_several_saved_recordings(tmp_path, capsys):
    """Two sessions recorded on different days fit one model; a different set-up is refused."""
    first, second = tmp_path / 'a.npz', tmp_path / 'b.npz'
    for seed, path in ((1, first), (2, second)):
        assert main(['--options', 'a,b', '--trials', '3', '--subject', 's5', '--seed',
                     str(seed), '--save-recording', str(path),
                     '--output', str(tmp_path / 'x.npz')]) == 0
    assert main(['--options', 'a,b', '--recordings', f'{first},{second}',
                 '--output', str(tmp_path / 'both.npz')]) == 0
    assert '12 trials from 2 recording(s)' in capsys.readouterr().out
    assert main(['--options', 'a,b', '--trials', '3', '--subject', 's5', '--layout',
                 'liveamp', '--save-recording', str(tmp_path / 'c.npz'),
                 '--output', str(tmp_path / 'y.npz')]) == 0
    capsys.readouterr()
    assert main(['--options', 'a,b', '--recordings', f"{first},{tmp_path / 'c.npz'}",
                 '--output', str(tmp_path / 'mixed.npz')]) == 2
    assert 'one model needs one set-up' in capsys.readouterr().err
