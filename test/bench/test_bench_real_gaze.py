"""bench/real_gaze.py: the node's rule on real recorded gaze, and the command a lab runs."""

from types import SimpleNamespace

from lab_recording import write_lab_csv
import numpy as np
import pytest

from bench import real_gaze
from eye_bci_ros2.recordings import find_data

REAL = find_data('real_gaze')
needs_data = pytest.mark.skipif(
    REAL is None, reason='no real gaze recordings (../shared/data/real_gaze)')


@pytest.fixture(scope='module')
def recordings():
    return real_gaze.load_folder(REAL)


@needs_data
def test_the_default_rule_on_real_gaze_meets_the_selection_goals(recordings):
    rule = real_gaze.RULES['default']
    hundred = real_gaze.intent(recordings, rule, 9, 100)
    assert hundred['rounds'] > 100
    assert hundred['wrong %'] <= 1.0 and hundred['right %'] >= 85.0, hundred
    assert hundred['median ms'] <= 600.0, hundred
    two_hundred = real_gaze.intent(recordings, rule, 9, 200)
    assert two_hundred['wrong %'] <= 0.5 and two_hundred['right %'] >= 97.0, two_hundred


@needs_data
def test_the_default_rule_does_not_choose_for_a_resting_gaze(recordings):
    midas = real_gaze.midas(recordings, real_gaze.RULES['default'])
    assert midas['resting near']['rounds'] > 100 and midas['resting away']['rounds'] > 100
    assert midas['resting near']['chosen %'] <= 5.0, midas
    assert midas['resting away']['chosen %'] <= 0.5, midas


@needs_data
def test_the_previous_default_chose_wrong_where_the_new_one_abstains(recordings):
    # What the bench exists to show: counting samples fires on transient landings.
    previous = real_gaze.intent(recordings, real_gaze.RULES['previous default'], 9, 100)
    default = real_gaze.intent(recordings, real_gaze.RULES['default'], 9, 100)
    assert previous['wrong %'] > 3 * max(default['wrong %'], 1.0)


def test_a_labs_own_csv_recording_runs_through_the_command(tmp_path, capsys):
    # Twelve targets, 1.5 s apart; the eyes leave at each onset and give no sample for
    # 0.25 s (the jump), then rest on the new target with 8 px noise until the next onset.
    rate, period, flight = 60, 1.5, 0.25
    rng = np.random.default_rng(0)
    places = rng.uniform([300, 300], [1620, 780], size=(12, 2))
    stamps = np.arange(0, 12 * period, 1 / rate)
    target = np.minimum((stamps / period).astype(int), 11)
    points = places[target] + rng.normal(0, 8, (len(stamps), 2))
    points[stamps % period <= flight] = np.nan
    write_lab_csv(tmp_path, stamps, points, places, period)
    assert real_gaze.main(['--data', str(tmp_path), '--sizes', '200', '--options', '3']) == 0
    out = capsys.readouterr().out
    assert 'lab (csv, 60 Hz, 12 targets)' in out
    table = {cells[0]: cells[1:] for cells in (
        [cell.strip() for cell in line.strip('|').split('|')] for line in out.splitlines()
        if line.startswith('| ') and '3 x 200 px' in line)}
    # Every target after the first is one round (the first has no jump to it); the eyes
    # rest on each goal for 1.25 s, so every rule chooses it, and never another.
    for rule in real_gaze.RULES:
        assert table[rule][:5] == ['3 x 200 px', '11', '100.0', '0.0', '0.0'], (rule, out)
    # The default rule decides the dwell after the first sample on the goal; the "window
    # end" rule at the end of its window.
    first_on_goal = np.ceil(flight * rate + 1e-9) / rate
    default = real_gaze.RULES['default']
    assert float(table['default'][5]) == pytest.approx(
        1000 * (first_on_goal + default.dwell_s), abs=1.0)
    assert float(table['default, window end'][5]) == pytest.approx(
        1000 * real_gaze.RULES['default, window end'].window_s, abs=1.0)


def test_a_folder_that_does_not_exist_is_one_line_and_status_1(tmp_path, capsys):
    assert real_gaze.main(['--data', str(tmp_path / 'missing')]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith('real_gaze:') and 'no such folder' in err and '\n' not in err


def _person(name):
    return SimpleNamespace(name=name, targets=SimpleNamespace(jumps=True))


def _figures(right, wrong, near=0.0, rounds=100):
    row = {'rounds': rounds, 'right %': right, 'wrong %': wrong,
           'none %': 100.0 - right - wrong, 'median ms': 500.0}
    return {'9 x 100 px': row, '9 x 200 px': dict(row),
            'resting near': {'rounds': 50, 'chosen %': near},
            'resting away': {'rounds': 50, 'chosen %': 0.0}}


def test_a_new_person_is_measured_with_the_rule_chosen_on_the_others(monkeypatch):
    """
    Leave-one-person-out: the rule is chosen on the other people only, by the goal.

    Person 'a' does best with the default, which errs on 'b' and 'c' together; a rule
    that is cautious everywhere keeps the goal on them: 'a' held out is measured with it,
    not with the default that the figures of all three (or 'a''s own) would pick.
    """
    names = list(real_gaze.candidates())
    cautious = names[-1]
    figures = {('a', 'default'): _figures(95.0, 0.0), ('a', cautious): _figures(70.0, 0.0),
               ('b', 'default'): _figures(90.0, 3.0), ('b', cautious): _figures(60.0, 0.0),
               ('c', 'default'): _figures(90.0, 0.0, near=8.0),
               ('c', cautious): _figures(80.0, 0.5)}
    settings = real_gaze.candidates()

    def measure(recordings, rule, seed=0):
        name, = [n for n, s in settings.items() if s == rule][:1]
        return figures.get((recordings[0].name, name), _figures(0.0, 50.0))

    monkeypatch.setattr(real_gaze, 'measure', measure)
    found = real_gaze.new_people([_person('a'), _person('b'), _person('c')])
    held = found['people']['a']
    assert held['chosen'] == cautious
    assert held['held out']['9 x 100 px']['right %'] == 70.0     # 'a' with the cautious rule
    assert held['default']['9 x 100 px']['right %'] == 95.0
    # 'b' held out: on 'a' and 'c' the default keeps the goal (no wrong, 4 % resting near).
    assert found['people']['b']['chosen'] == 'default'
    assert found['people']['c']['chosen'] == cautious
    # Pooled over the held-out people, weighted by rounds: (70 + 90 + 80) / 3.
    assert found['pooled']['9 x 100 px']['right %'] == pytest.approx(80.0)
    assert found['range']['9 x 100 px'] == (90.0, 95.0)
    lines = real_gaze.new_people_lines(found)
    assert any(line.startswith('| **pooled, held out** | | 80.0 / ') for line in lines), lines


def test_one_person_gives_no_held_out_figure():
    assert real_gaze.new_people([_person('a')]) == {}
