"""bench.ssvep_real on a real recording: what it counts is what the decoder did."""

import dataclasses

import numpy as np
import pytest

from bench import run_all, ssvep_real
from eye_bci_ros2.recordings.eeg import eeg_data_dir, find_eeg_recordings, load_eeg
from eye_bci_ros2.ssvep.decision import DecisionRule
from eye_bci_ros2.ssvep.online import OnlineSettings


@pytest.fixture(scope='module')
def session():
    """Load the first 8 trials of one real recording: about 55 s of EEG."""
    folder = eeg_data_dir()
    paths = find_eeg_recordings(folder) if folder else []
    if not paths:
        pytest.skip('no real EEG recordings (../shared/data/real_eeg or $EYE_BCI_REAL_EEG)')
    recording = load_eeg(paths[len(paths) // 2])
    end = int((recording.trials[8][0]) * recording.rate)
    return dataclasses.replace(recording, eeg_uv=recording.eeg_uv[:end],
                               trials=recording.trials[:8])


def test_the_streamed_rounds_replay_exactly_and_rest_trials_get_no_choice(session):
    trials = ssvep_real._online(session, OnlineSettings(keep_scoring=True), None)
    assert len(trials) == 8 and any(t['target'] is None for t in trials)
    # A real person looking at a fixation point: no choice.
    assert all(t['choice'] is None for t in trials if t['target'] is None)
    # Replaying the recorded evidence with the same rule gives the same choices and times,
    # which is what the leave-subject-out evaluation relies on.
    replayed = ssvep_real._replay(trials, DecisionRule())
    assert [(t['choice'], t['after_s']) for t in replayed] == \
        [(t['choice'], t['after_s']) for t in trials]
    stricter = ssvep_real._replay(trials, DecisionRule(rest_z=20.0))
    assert all(t['choice'] is None for t in stricter)
    row = ssvep_real._online_row(trials)
    assert row['right'] + row['wrong'] + row['no_choice'] == row['stimulus_trials']


def test_the_loader_reads_the_recordings_and_says_why_it_cannot(tmp_path, session):
    assert session.rate == 256.0 and session.channels[0] == 'Oz'
    assert {hz for _, hz in session.trials} <= {None, 13.0, 17.0, 21.0}
    bad = tmp_path / 'kalunga_s99_x.npz'
    np.savez(bad, eeg_uv=np.zeros((10, 2)), sfreq=256.0, channels=np.array(['Oz']),
             events=np.zeros((0, 2), int))
    with pytest.raises(ValueError, match='does not match 1 channels'):
        load_eeg(bad)


def test_run_all_skips_the_real_bench_without_recordings(monkeypatch, tmp_path):
    monkeypatch.setenv('EYE_BCI_REAL_EEG', str(tmp_path / 'nowhere'))
    outcome = run_all.run_benchmarks(['ssvep_real'])
    assert 'no real EEG recordings' in outcome['skipped']['ssvep_real']
