"""bench/confirmation.py: wrong goals after the confirmation step, on real recorded gaze."""

import json

from lab_recording import write_lab_csv
import numpy as np
import pytest

from bench import confirmation
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.task.menu import ProtocolSettings

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


# A person who looks around with no intent, from place to place (screen px); nothing else
# is looked at.  Rooms: room 0 at R; its tables: table 0 at T, 'back' far away; the
# confirmation: 'go' at G, 'back' on T; 'send' at S, 'back' on G.
R, T, G, S = (300.0, 200.0), (400.0, 540.0), (1400.0, 540.0), (1400.0, 900.0)
ELSEWHERE = (960.0, 100.0)
FAR = [(1800.0, 100.0), (1800.0, 300.0), (1800.0, 500.0)]
PLACES = {'rooms': lambda: np.array([R] + FAR),
          'tables': lambda room: np.array([T, (960.0, 300.0), (960.0, 760.0), FAR[0]]),
          'confirm': lambda table: np.array([G, table]),
          'send': lambda go: np.array([S, go])}
STEP_S = 0.6
SECONDS = 48.3


def looking_around(folder, path):
    """Write and load a recording whose gaze rests STEP_S at each place of ``path``, again."""
    stamps = np.arange(0.0, SECONDS, 1 / 60)
    where = np.array(path)[(stamps // STEP_S).astype(int) % len(path)]
    points = where + np.random.default_rng(0).normal(0, 1, (len(stamps), 2))
    write_lab_csv(folder, stamps, points, np.array([[1800.0, 980.0]]), SECONDS)
    recording, = confirmation.load_folder(folder)
    return recording


def replay(recording, **settings):
    """Replay it through the whole menu with the options at PLACES."""
    rule = confirmation.settings_for_recording(confirmation.RULES['default'], recording)
    assert rule.dwell_s < STEP_S and rule.window_s == 1.0
    return confirmation.menu_replay(recording, rule, ProtocolSettings(**settings), layouts=1,
                                    places=PLACES)


def test_a_look_at_a_room_a_table_go_and_send_is_a_robot_goal(tmp_path):
    # Each cycle R, T, G, S (2.4 s) from 2.4 s on (the gaze on R at 0 s was there before the
    # rooms: not a reaction to them) chooses the room, the table, 'go', then 'send' (it
    # appeared at 'go', the look lands on it within its one round): 19 cycles, 19 goals.
    total = replay(looking_around(tmp_path, [R, T, G, S]))
    assert total['goals'] == total['send passed'] == 19, total
    assert total['rooms passed'] == total['tables passed'] == total['confirm passed'] == 19
    assert total['send offered'] == 19 and total['send unanswered'] == 0
    assert 46.0 / 60 < total['minutes'] <= SECONDS / 60
    # Each goal 1.1 s after its table (table dwell_s 0.15 s into T, 'send', a second look,
    # second_look_dwell_s 0.05 s into S).
    rule = confirmation.RULES['default']
    assert np.allclose(total['go after'], 2 * STEP_S - rule.dwell_s + rule.second_look_dwell_s,
                       atol=0.03)


def test_go_without_the_look_at_send_is_no_goal(tmp_path):
    # The same wandering gaze, but after 'go' it goes elsewhere: without 'send'
    # (send_rounds 0) every 'go' is a goal; with it (the default) none is, each 'send'
    # unanswered after its round and the tables offered again.
    recording = looking_around(tmp_path, [R, T, G, ELSEWHERE])
    assert replay(recording, send_rounds=0)['goals'] == 19
    total = replay(recording)
    assert total['goals'] == 0 and total['confirm passed'] >= 19
    assert total['send unanswered'] == total['send offered'] == total['confirm passed']
    # ... and a gaze that goes to 'back' in the send step (here put where it goes next)
    # answers 'back': the tables, no goal.
    places = dict(PLACES, send=lambda go: np.array([S, ELSEWHERE]))
    rule = confirmation.settings_for_recording(confirmation.RULES['default'], recording)
    total = confirmation.menu_replay(recording, rule, ProtocolSettings(), layouts=1,
                                     places=places)
    assert total['goals'] == 0 and total['send back'] == total['confirm passed'] >= 19


def test_an_unanswered_confirmation_returns_to_the_tables(tmp_path):
    # Table chosen, then the gaze stays away from 'go' and 'back' for 1.2 s: after
    # confirm_rounds (2) rounds the tables again, no goal; asked for ever (a large
    # confirm_rounds) the confirmation waits until the gaze comes back to T: 'back'.
    recording = looking_around(tmp_path, [R, T, ELSEWHERE, ELSEWHERE])
    total = replay(recording)
    assert total['goals'] == 0 and total['confirm unanswered'] >= 10, total
    assert total['confirm back'] == 0
    patient = replay(recording, confirm_rounds=1000)
    assert patient['confirm unanswered'] == 0 and patient['confirm back'] >= 9, patient


def test_send_lies_where_the_gaze_was_not(tmp_path):
    recording = looking_around(tmp_path, [R])
    go = np.array([1400.0, 300.0])                    # above the screen's centre
    send, back = confirmation.send_layout(recording, go, np.random.default_rng(0))
    assert send[0] == go[0] and send[1] > go[1]       # below 'go', towards the centre
    np.testing.assert_array_equal(back, go)           # 'back' where 'go' was
    assert send[1] - go[1] == pytest.approx(
        confirmation.SEND_GAP_DEG * confirmation._ppd(recording, go))
    assert confirmation.SEND_GAP_DEG > 2 * 2.0        # beyond the resting radius, twice


def test_the_bounds_are_the_rule_of_three_without_events():
    assert confirmation.poisson_upper(0, 100.0, 0.95) == pytest.approx(3.0 / 100, rel=0.01)
    assert confirmation.binomial_upper(0, 1000, 0.95) == pytest.approx(3.0 / 1000, rel=0.01)
    assert confirmation.binomial_upper(5, 1000, 0.95) > 5 / 1000
    assert confirmation.binomial_upper(3, 3, 0.95) == 1.0


def test_the_menu_layout_puts_back_on_the_table_and_go_beside_it(tmp_path):
    recording = looking_around(tmp_path, [R])
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
def test_robot_goals_of_looking_around_on_real_gaze(capsys, tmp_path):
    out = tmp_path / 'out.json'
    assert confirmation.main(['--midas', '--layouts', '1', '--json', str(out)]) == 0
    printed = capsys.readouterr().out
    assert 'upper 95 % bound' in printed and "intended 'go'" in printed
    summary = json.loads(out.read_text())
    midas, go = summary['midas'], summary['intended_go']
    # Every recording replayed to its end, from the rooms: the two 5-minute sessions and
    # seven short ones.
    assert midas['minutes'] > 12.0
    assert midas['goals_per_min'] == midas['goals'] / midas['minutes']
    assert midas['upper95_per_min'] >= midas['goals_per_min'] and midas['upper95_per_min'] > 0
    # The person looking at 'go' as it appears, then at the next target, confirms almost
    # every time, in about a second.
    assert go['go'] >= 0.97 * go['rounds'] and go['rounds'] > 250
    assert go['median_s'] <= 1.5 and go['slowest_s'] >= go['median_s']
    result = confirmation.run_midas(layouts=1)
    chain = result['chain']
    assert chain['layouts'] == 9
    # A goal needs each step passed in turn; a step is passed at most as often as offered.
    for step in confirmation.STEPS:
        assert chain[f'{step} passed'] <= chain[f'{step} offered']
    assert chain['goals'] == chain['send passed'] <= chain['confirm passed'] \
        <= chain['tables passed']
    # The bound is the product of its factors' bounds (or the goals counted, if smaller).
    product = np.prod([row['upper'] for row in result['factors']])
    assert result['midas']['upper95_per_min'] == pytest.approx(
        min(product, result['midas']['direct_upper95_per_min']))
