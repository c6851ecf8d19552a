"""bench/confirmation.py: wrong goals after the confirmation step, on real recorded gaze."""

from lab_recording import write_lab_csv
import numpy as np
import pytest

from bench import confirmation
from eye_bci_ros2.recordings import find_data

REAL = find_data('real_gaze')


@pytest.mark.skipif(REAL is None, reason='no real gaze recordings (../shared/data/real_gaze)')
def test_the_confirmation_step_on_real_gaze(capsys):
    assert confirmation.main([]) == 0
    printed = capsys.readouterr().out
    assert 'menu layout' in printed and 'wrong goals per first choice' in printed
    result = confirmation.run()
    for row in result['layouts'].values():
        # Every jump of the dot gave a round, and most were answered 'back' (looked at).
        assert row['rounds'] > 200 and row['back'] > 0.9 * row['rounds']
        assert row['go'] + row['back'] + row['none'] == row['rounds']
        # The confirmation can only lower the wrong-goal rate of the first choice.
        assert row['wrong_goal_bound'] < result['first']['wrong %'] / 100.0


def test_rounds_put_back_on_the_dot_and_go_beside_it():
    class Targets:
        jumps = True
        places = np.array([[500.0, 400.0], [960.0, 540.0], [60.0, 540.0]])
        onsets = np.array([0.0, 1.0, 2.0])

        def __len__(self):
            return len(self.places)

    class Screen:
        width_px, height_px = 1920, 1080

    class Recording:
        targets, screen = Targets(), Screen()

    rounds = list(confirmation.confirm_rounds(Recording(), lambda r, p: 300.0,
                                              np.random.default_rng(0)))
    assert [start for start, _ in rounds] == [1.0, 2.0]
    for (start, centres), dot in zip(rounds, Targets.places[1:]):
        np.testing.assert_allclose(centres[1], dot)                 # 'back' on the dot
        assert abs(abs(centres[0, 0] - dot[0]) - 300.0) < 1e-9     # 'go' 300 px beside it
    assert rounds[1][1][0, 0] == 360.0      # the side that keeps 'go' on the screen


# A person who looks around with no intent: 0.8 s at T, 1.7 s at another place, and again.
# Table 0 at T; 'back' on T in the confirmation step, 'go' at G; nothing else is looked at.
T, G, ELSEWHERE = (400.0, 540.0), (1400.0, 540.0), (1400.0, 150.0)
TABLES = np.array([T, (960.0, 150.0), (960.0, 930.0), (1800.0, 100.0)])   # 3 tables, 'back'
SECONDS = 50.2


def looking_around(folder, second_place):
    """Write and load a recording whose gaze rests 0.8 s at T, 1.7 s at second_place, ..."""
    stamps = np.arange(0.0, SECONDS, 1 / 60)
    at_t = stamps % 2.5 < 0.8
    noise = np.random.default_rng(0).normal(0, 1, (len(stamps), 2))
    points = np.where(at_t[:, None], T, second_place) + noise
    write_lab_csv(folder, stamps, points, np.array([[1800.0, 980.0]]), SECONDS)
    recording, = confirmation.load_folder(folder)
    return recording


def midas_goals(recording, timeout_s=None):
    """Replay it with the tables at TABLES and the confirmation's 'go' at G, 'back' on T."""
    rule = confirmation.settings_for_recording(confirmation.RULES['default'], recording)
    assert rule.dwell_s < 0.8 and rule.window_s == 1.0
    return confirmation.midas_goals(recording, rule, layouts=1, tables=lambda: TABLES,
                                    confirm=lambda table: np.array([G, table]),
                                    timeout_s=timeout_s)


def test_a_glance_at_a_table_then_at_go_is_a_robot_goal(tmp_path):
    # Each 2.5 s from 2.5 s on (the gaze on T at 0 s was there before the tables: not a
    # reaction to them) a fixation on T chooses table 0, the next one on G sends the robot
    # (before the first round of the confirmation ends), and a new room's tables appear.
    # 19 cycles (at 2.5 ... 47.5 s) in 50.2 s: 19 goals, none undone.
    recording = looking_around(tmp_path, G)
    total = midas_goals(recording)
    assert (total['tables'], total['goals'], total['back']) == (19, 19, 0), total
    assert 48.4 / 60 < total['minutes'] <= SECONDS / 60
    # Each 'go' 0.8 s after its table: 2 rounds of the confirmation (2 s) keep every one.
    assert midas_goals(recording, timeout_s=2.0)['goals'] == 19


def test_gaze_that_comes_back_to_the_table_undoes_it(tmp_path):
    # The gaze leaves T for a place where nothing is shown, and comes back 2.5 s later: a
    # fixation on 'back' (on T).  The same tables return under the gaze resting on T (not a
    # reaction to them); it leaves and comes back: a table every 5 s (2.5 ... 47.5 s), each
    # one undone 2.5 s later but the last (the recording ends during its confirmation).
    recording = looking_around(tmp_path, ELSEWHERE)
    total = midas_goals(recording)
    assert (total['tables'], total['goals'], total['back']) == (10, 0, 9), total
    # 2 rounds (2 s): back to the tables 2 s after each table (the gaze elsewhere),
    # and the next landing on T 0.35 s later chooses the table again: one every 2.5 s.
    total = midas_goals(recording, timeout_s=2.0)
    assert (total['tables'], total['timeouts'], total['goals'], total['back']) == \
        (19, 19, 0, 0), total


def test_the_menu_layout_puts_back_on_the_table_and_go_beside_it(tmp_path):
    recording = looking_around(tmp_path, G)
    go, back = confirmation.midas_confirm_layout(recording, np.array(T),
                                                 np.random.default_rng(0))
    np.testing.assert_allclose(back, T)
    assert go[1] == T[1] and go[0] > T[0]              # towards the screen's centre
    assert go[0] - T[0] == pytest.approx(
        confirmation.MENU_GAP_DEG * confirmation._ppd(recording, np.array(T)))
    # A dot where the menu puts 'go': 'go' goes elsewhere, clear of it, as far from 'back'.
    recording.targets.places[:] = go
    moved, _ = confirmation.midas_confirm_layout(recording, np.array(T),
                                                 np.random.default_rng(0))
    assert np.abs(moved - go).max() > confirmation.SIZE
    assert np.hypot(*(moved - T)) >= go[0] - T[0] - 1e-9


def test_midas_on_an_empty_folder_says_why_and_fails(tmp_path, capsys):
    assert confirmation.main(['--midas', '--data', str(tmp_path)]) == 1
    assert 'confirmation:' in capsys.readouterr().err


@pytest.mark.skipif(REAL is None, reason='no real gaze recordings (../shared/data/real_gaze)')
def test_robot_goals_of_looking_around_on_real_gaze(capsys):
    assert confirmation.main(['--midas', '--layouts', '1', '--confirm-rounds', '0', '5']) == 0
    printed = capsys.readouterr().out
    assert '| until answered | 9 |' in printed and '| confirm_rounds 5 | 9 |' in printed
    result = confirmation.run_midas(layouts=1, rounds=(None, 5))
    for row in result['midas'].values():
        # Every recording replayed to its end: the two 5-minute sessions and seven short ones.
        assert row['layouts'] == 9 and row['minutes'] > 12.0
        # A goal needs a table first, and each table is answered once at most.
        assert row['goals'] + row['back'] + row['timeouts'] <= row['tables']
        assert row['goals_per_minute'] == row['goals'] / row['minutes']
    assert result['midas'][None]['timeouts'] == 0
    for intended in result['intended'].values():
        # The person looking at 'go' as it appears confirms almost every time.
        assert intended['go'] > 0.95 * intended['rounds'] > 250
