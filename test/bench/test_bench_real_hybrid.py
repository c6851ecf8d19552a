"""bench.real_hybrid on folders named with its flags: what it counts is what the code chose."""

import json
import math
from types import SimpleNamespace

import pytest

from bench import real_hybrid, run_all
from eye_bci_ros2.decision.fusion import INPUT_MODES
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.eeg import by_subject, eeg_data_dir, find_eeg_recordings, load_eeg

#: Each kind of round, per EEG session of the Kalunga recordings: 24 stimulus trials, and
#: 8 rest trials once per option (3).
INTENT, NO_INTENT = 24, 8 * 3


@pytest.fixture(scope='module')
def folders(tmp_path_factory):
    """Make a gaze folder of one person's recording and an EEG folder of two subjects' sessions."""
    gaze, eeg = find_data('real_gaze'), eeg_data_dir()
    paths = find_eeg_recordings(eeg) if eeg else []
    if gaze is None or not paths or not list(gaze.glob('human_*_ss1.txt.gz')):
        pytest.skip('no real gaze and EEG recordings (../shared/data/real_gaze, real_eeg)')
    root = tmp_path_factory.mktemp('recordings')
    (root / 'gaze').mkdir()
    (root / 'eeg').mkdir()
    for path in gaze.glob('human_*_ss1.txt.gz'):   # samples and target messages
        (root / 'gaze' / path.name).symlink_to(path)
    # The first session of the first and last subjects (symlinks: nothing copied).
    groups = by_subject(load_eeg(path) for path in paths)
    for subject in (min(groups), max(groups)):
        name = groups[subject][0].name + '.npz'
        (root / 'eeg' / name).symlink_to(eeg / name)
    return root / 'gaze', root / 'eeg', (min(groups), max(groups))


@pytest.fixture(scope='module')
def pairings(folders):
    gaze, eeg, _ = folders
    return real_hybrid.load_pairings(str(gaze), str(eeg), log=open('/dev/null', 'w'))


def test_the_flags_read_another_folder_and_the_json_has_each_mode(folders, tmp_path, capsys):
    gaze, eeg, subjects = folders
    out = tmp_path / 'hybrid.json'
    assert real_hybrid.main(['--gaze-data', str(gaze), '--eeg-data', str(eeg),
                             '--json', str(out)]) == 0
    assert '| hybrid |' in capsys.readouterr().out
    result = json.loads(out.read_text())
    assert result['rounds']['gaze_recordings'] == ['lookAtPoint_X260_ss1']
    assert sorted(result['subjects']) == sorted(subjects)
    for mode in INPUT_MODES:
        row = result[mode]
        assert row['intent_rounds'] == 2 * INTENT and row['no_intent_rounds'] == 2 * NO_INTENT
        assert row['right'] + row['wrong'] + row['none'] == pytest.approx(1.0)
        assert 0.0 <= row['midas'] <= 1.0 and row['median_s'] > 0.0


def test_each_mode_chooses_what_its_code_chose(pairings):
    decided = real_hybrid.decide_all(
        pairings, {mode: real_hybrid.FusionSettings(mode) for mode in INPUT_MODES})
    gaze = [real_hybrid.gaze_decision(p)[0] for p in pairings]
    for index, pairing in enumerate(pairings):
        label = getattr(gaze[index], 'label', None)
        assert decided['gaze'][index].choice == label
        assert decided['ssvep'][index].choice == (pairing.ssvep_choice or (None,))[0]
        # The hybrid chooses only what the gaze nominated, never before the EEG could say.
        hybrid = decided['hybrid'][index]
        assert hybrid.choice in (None, label)
        assert hybrid.choice is None or hybrid.after_s >= 2.0   # onset 1 s + a 1 s window
    rows = {mode: real_hybrid.tally(rounds) for mode, rounds in decided.items()}
    counts = rows['hybrid']['counts']
    assert counts['right'] + counts['wrong'] + counts['none'] == rows['hybrid']['intent_rounds']
    # Real figures: gaze alone chooses when a person merely looks; the hybrid almost never.
    assert rows['gaze']['midas'] > 0.8
    assert rows['hybrid']['midas'] <= 0.05 and rows['hybrid']['wrong'] <= 0.05
    assert rows['hybrid']['right'] > 0.3


def test_a_missing_folder_is_one_line(tmp_path, capsys):
    assert real_hybrid.main(['--eeg-data', str(tmp_path / 'nowhere')]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith('bench.real_hybrid: ') and '\n' not in err


def test_run_all_skips_it_without_recordings(tmp_path):
    outcome = run_all.run_benchmarks(['real_hybrid'], data={'real_gaze': str(tmp_path)},
                                     log=open('/dev/null', 'w'))
    assert 'no real' in outcome['skipped']['real_hybrid']


def _rounds(subject, right, wrong, midas, intent=20, rest=20):
    """Decided rounds of one subject: ``right``/``wrong`` of ``intent``, ``midas`` of ``rest``."""
    labels = ('13 Hz', '17 Hz', '21 Hz')
    rounds = []
    for index in range(intent):
        pairing = SimpleNamespace(subject=subject, intent=True, attended='13 Hz', labels=labels)
        choice = '13 Hz' if index < right else ('17 Hz' if index < right + wrong else None)
        rounds.append(real_hybrid.Decided(pairing, choice, 3.0 if choice else math.nan))
    for index in range(rest):
        pairing = SimpleNamespace(subject=subject, intent=False, attended=None, labels=labels)
        rounds.append(real_hybrid.Decided(pairing, '13 Hz' if index < midas else None,
                                          3.0 if index < midas else math.nan))
    return rounds


def test_a_new_subject_is_decided_with_the_setting_chosen_on_the_others():
    """
    Leave-subject-out: each subject's rounds under the setting the other subjects chose.

    'eager' chooses most, but confirmed one no-intent round of s3's: on s1 and s3
    together (1 of 80, over the goal's 1 %) it is refused, so s1 held out is decided
    with 'careful', though its own figures, or all three subjects' (1 of 120), pick
    'eager'.  s3 held out is decided with 'eager', which s1 and s2 allow.
    """
    decided = {'eager': (_rounds('s1', 19, 0, 0, rest=40) + _rounds('s2', 18, 0, 0, rest=40)
                         + _rounds('s3', 18, 0, 1, rest=40)),
               'careful': (_rounds('s1', 12, 0, 0, rest=40) + _rounds('s2', 14, 0, 0, rest=40)
                           + _rounds('s3', 10, 0, 0, rest=40))}
    found = real_hybrid.held_out_subjects(decided)
    assert {s: row['setting'] for s, row in found['subjects'].items()} == {
        's1': 'careful', 's2': 'careful', 's3': 'eager'}
    assert found['subjects']['s1']['right'] == 0.6        # 12 of 20 under 'careful'
    pooled = found['pooled']
    assert pooled['counts']['right'] == 12 + 14 + 18 and pooled['intent_rounds'] == 60
    assert pooled['counts']['midas'] == 1 and pooled['no_intent_rounds'] == 120
