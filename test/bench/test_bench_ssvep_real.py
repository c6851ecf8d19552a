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
    """
    Load 8 trials of one real recording, rest and stimulus ones: about 90 s of EEG.

    The sessions begin with their rest trials; the stimuli offered are those of
    the trials kept, so the slice must hold every stimulus and some rest.
    """
    folder = eeg_data_dir()
    paths = find_eeg_recordings(folder) if folder else []
    if not paths:
        pytest.skip('no real EEG recordings (../shared/data/real_eeg or $EYE_BCI_REAL_EEG)')
    recording = load_eeg(paths[len(paths) // 2])
    first = next(i for i, (_, hz) in enumerate(recording.trials) if hz is not None) - 2
    trials = recording.trials[first:first + 8]
    assert {hz for _, hz in trials} == {None, *recording.frequencies}
    end = int(recording.trials[first + 8][0] * recording.rate)
    return dataclasses.replace(recording, eeg_uv=recording.eeg_uv[:end], trials=trials)


def test_the_streamed_rounds_replay_exactly_and_rest_trials_get_no_choice(session):
    trials = ssvep_real._online(session, OnlineSettings(keep_scoring=True), None)
    assert len(trials) == 8 and any(t['target'] is None for t in trials)
    assert all(t['steps'] for t in trials)  # every round decoded
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


def test_settings_from_the_command_line_and_one_line_for_a_mistake():
    assert ssvep_real.parse_settings(['window_s=4', 'harmonics=3', 'keep_scoring=true']) == \
        {'window_s': 4.0, 'harmonics': 3, 'keep_scoring': True}
    with pytest.raises(ValueError, match='not a setting given as KEY=VALUE'):
        ssvep_real.parse_settings(['window=4'])
    with pytest.raises(ValueError, match='harmonics needs a int'):
        ssvep_real.parse_settings(['harmonics=three'])
    with pytest.raises(ValueError, match='min_window_s'):  # a combination that cannot work
        ssvep_real.parse_settings(['window_s=0.5'])


def test_white_noise_rounds_are_all_null_and_set_rest_z_for_the_target(session):
    settings = OnlineSettings(keep_scoring=True)
    rounds = ssvep_real._null_rounds([session], settings)
    assert len(rounds) == 8 and all(t['target'] is None for t in rounds)
    assert all(t['steps'] for t in rounds)  # decoded, not refused
    row = ssvep_real._null_rest_z(rounds, settings, settings.hold_s)
    chosen = [t for t in ssvep_real._replay(rounds, ssvep_real._rule(
        settings, rest_z=row['rest_z'])) if t['choice'] is not None]
    assert len(chosen) <= ssvep_real.NULL_TARGET * len(rounds) or \
        row['rest_z'] == ssvep_real.NULL_REST_Z_GRID[-1]
    # Fewer choices on nothing as rest_z grows.
    shares = [row[f'choices_at_{z:g}'] for z in ssvep_real.REST_Z_GRID]
    assert shares == sorted(shares, reverse=True)


def test_leave_subject_out_chooses_rest_z_and_hold_on_the_other_subjects(session):
    trials = ssvep_real._online(session, OnlineSettings(keep_scoring=True), None)
    per_subject = {'a': trials[:4], 'b': trials[4:]}
    grid = [{'rest_z': 20.0, 'hold_s': 0.0}, {'rest_z': 1.5, 'hold_s': 0.5}]
    rows = ssvep_real._leave_subjects_out(per_subject, grid)
    for subject in ('a', 'b'):
        constants = {'rest_z': rows[subject]['rest_z'], 'hold_s': rows[subject]['hold_s']}
        assert constants in grid
        # The held-out subject is decided with the constants the other one chose.
        expected = ssvep_real._online_row(ssvep_real._replay(
            per_subject[subject], DecisionRule(**constants)))
        assert {k: rows[subject][k] for k in expected} == expected
    assert rows['all']['stimulus_trials'] == rows['a']['stimulus_trials'] + \
        rows['b']['stimulus_trials']
