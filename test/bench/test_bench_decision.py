"""
Smoke tests of the decision-time benchmark (bench/decision.py).

Quick mode only; nothing here depends on how fast anything ran, only on what
the benchmark computes: its layouts, trials, metrics, tuning and section.
"""

import math

import numpy as np
import pytest

from bench import decision, run_all
from eye_bci_ros2.decision.rounds import ArbiterSettings, RoundScheduler
from eye_bci_ros2.experiments.metrics import wolpaw_bits

METRIC_KEYS = {'accuracy', 'wrong', 'no_choice', 'median_samples', 'median_ms', 'mean_ms',
               'itr_bits_per_min', 'trials', 'not_landed'}


@pytest.fixture(scope='module')
def section():
    return decision.run(quick=True)


def _cells(table):
    return [(count, size, metrics) for count, row in table.items()
            if count not in ('config', 'search') for size, metrics in row.items()]


def test_quick_section_has_every_rule_count_and_size(section):
    for rule in ('original', 'vote', 'node_default', 'best'):
        cells = _cells(section[rule])
        assert {(c, s) for c, s, _ in cells} == {
            (str(c), str(s)) for c in (3, 4, 9) for s in decision.SIZES}, rule
        for count, size, metrics in cells:
            assert METRIC_KEYS <= set(metrics), (rule, count, size)
            assert metrics['trials'] == decision.QUICK_TRIALS
            total = metrics['accuracy'] + metrics['wrong'] + metrics['no_choice']
            assert total == pytest.approx(1.0)
    assert set(section['best']['config']) == {'confidence', 'min_samples', 'dwell_s',
                                              'hit_rate', 'method', 'window_s',
                                              'min_reaction_s'}
    assert section['setup']['tuned_on_test_set'] is False
    for rule in ('original', 'vote', 'node_default', 'best'):
        stress = section['stress_other_target'][rule]
        assert {(c, s) for c, s, _ in _cells(stress)} == {
            (str(c), str(s)) for c in (3, 4, 9) for s in decision.SIZES}, rule
    for scenario in decision.SCENARIOS:
        assert set(section['fast_1200hz'][scenario]) == {'original', 'node_default', 'best'}
    search = section['best']['search']
    assert search['configurations'] == len(search['results']) == 4  # the quick grid
    assert search['tuning_sets'] == ['new_menu', 'other_target', 'new_menu_1200hz',
                                     'other_target_1200hz']


def test_goal_row_is_the_worst_best_cell_at_100_px(section):
    goal = section['goal_100px']
    best = [section['best'][c]['100'] for c in ('3', '4', '9')]
    original = [section['original'][c]['100'] for c in ('3', '4', '9')]
    stress = [section['stress_other_target']['best'][c]['100'] for c in ('3', '4', '9')]

    assert goal['accuracy'] == min(m['accuracy'] for m in best)
    assert goal['stress_accuracy'] == min(m['accuracy'] for m in stress)
    assert goal['median_ms'] == max(m['median_ms'] for m in best)
    ratios = [b['itr_bits_per_min'] / o['itr_bits_per_min'] for b, o in zip(best, original)]
    assert goal['itr_ratio'] == pytest.approx(min(ratios))
    assert goal['met'] == (goal['accuracy'] >= 0.99 and goal['median_ms'] <= 150
                           and goal['itr_ratio'] >= 2)


def test_original_rule_decides_at_the_window_end_and_early_rule_before(section):
    for count, size, metrics in _cells(section['original']):
        # Fixation onset is after the saccade latency (>= 120 ms), so at most ~900 ms remain.
        assert 400 < metrics['median_ms'] < 900, (count, size)
    for count, size, metrics in _cells(section['best']):
        assert metrics['median_ms'] < section['original'][count][size]['median_ms']


def test_itr_is_wolpaw_with_the_mean_time_plus_gaze_shift(section):
    metrics = section['original']['4']['100']
    seconds = metrics['mean_ms'] / 1e3 + decision.GAZE_SHIFT_S
    expected = wolpaw_bits(4, metrics['accuracy']) * 60 / seconds
    assert metrics['itr_bits_per_min'] == pytest.approx(expected)


def test_wolpaw_bits_known_values_and_edges():
    assert wolpaw_bits(4, 1.0) == pytest.approx(2.0)
    assert wolpaw_bits(9, 1.0) == pytest.approx(math.log2(9))
    expected = 2 + 0.9 * math.log2(0.9) + 0.1 * math.log2(0.1 / 3)
    assert wolpaw_bits(4, 0.9) == pytest.approx(expected)
    assert wolpaw_bits(4, 0.25) == 0.0
    assert wolpaw_bits(4, 0.1) == 0.0  # below chance: no information, not negative
    assert decision.itr_bits_per_min(1.0, 4, 0.5) == pytest.approx(240.0)
    with pytest.raises(ValueError, match='accuracy'):
        wolpaw_bits(3, 1.2)
    with pytest.raises(ValueError, match='time per selection'):
        decision.itr_bits_per_min(1.0, 3, 0.0)


def test_layouts_are_a_row_and_grids_centred_at_a_pitch_of_one_and_a_half_sizes():
    row = decision.layout(3, 100)
    assert np.allclose(row[:, 1], 540) and np.allclose(np.diff(row[:, 0]), 150)
    grid = decision.layout(9, 60)
    assert np.allclose(grid.mean(axis=0), (960, 540))
    assert sorted(set(np.round(grid[:, 0]))) == [870, 960, 1050]
    assert sorted(set(np.round(grid[:, 1]))) == [450, 540, 630]
    regions = decision.region_set(4, 200)
    assert regions.classify(decision.layout(4, 200)).tolist() == [0, 1, 2, 3]
    # The gap between neighbours (S / 2) is in no region.
    assert regions.classify([[960, 540]]).tolist() == [-1]
    with pytest.raises(ValueError, match='no layout for 5 targets'):
        decision.layout(5, 100)


def test_trials_start_where_the_scenario_says_and_land_after_a_latency():
    seeds = range(decision.TEST_SEED, decision.TEST_SEED + 15)
    centres = decision.layout(9, 100)
    for trial in decision.simulate_trials(9, 100, seeds, 'new_menu'):
        assert np.all(np.any(np.abs(trial.start - centres) >= 100, axis=1))
        assert 0.1 < trial.onset < decision.WINDOW_S
        assert np.all(np.diff(trial.stamps) > 0) and np.all(np.isfinite(trial.points))
    for trial in decision.simulate_trials(9, 100, seeds, 'other_target'):
        resting = np.flatnonzero(np.all(np.isclose(centres, trial.start), axis=1))
        assert resting.size == 1 and resting[0] != trial.goal
    with pytest.raises(ValueError, match='unknown scenario'):
        decision.simulate_trials(3, 100, seeds, 'somewhere')


def test_early_decision_fed_in_node_sized_chunks_equals_one_batch():
    regions = decision.region_set(9, 60)
    trials = decision.simulate_trials(9, 60, range(decision.TEST_SEED, decision.TEST_SEED + 20))
    tuned = decision.COUNT_EARLY.replace(confidence=0.95, min_samples=2, dwell_s=0.0,
                                         hit_rate=0.9)
    for config in (tuned, decision.NODE_DEFAULT):
        for trial in trials:
            whole = decision.decide(trial, regions, config)
            assert decision.decide(trial, regions, config, chunk=2) == whole
            assert decision.decide(trial, regions, config, chunk=1) == whole


@pytest.mark.parametrize('scenario', decision.SCENARIOS)
def test_benchmark_decisions_are_the_node_rounds_decisions(scenario):
    regions = decision.region_set(4, 60)
    trials = decision.simulate_trials(4, 60, range(decision.TEST_SEED, decision.TEST_SEED + 20),
                                      scenario)
    config = decision.NODE_DEFAULT  # the node defaults, early decision on
    assert config == ArbiterSettings(early_decision=True, window_s=decision.WINDOW_S)
    for early in (True, False):
        for trial in trials:
            settings = config.replace(early_decision=early)
            rounds = RoundScheduler(settings)
            rounds.add_regions(regions, now=0.0)
            made = None
            for stamp, (x, y) in zip(trial.stamps, trial.points):
                made = rounds.add_sample(stamp, x, y, now=stamp + 0.01)
                if made is not None:
                    break
            if made is None:  # the first sample after the window closes it
                made = rounds.add_sample(decision.WINDOW_S, 0.0, 0.0, now=decision.WINDOW_S)
            label, when = decision.decide(trial, regions, settings)
            if early:
                assert (made.method == 'early') == (when < decision.WINDOW_S)
                if when < decision.WINDOW_S:
                    assert made.time_to_decision == pytest.approx(when)
            else:
                assert when == decision.WINDOW_S
            assert made.label == label


def test_gaze_resting_on_a_target_fools_the_fast_rule_without_min_reaction():
    # The count rule's early decision on 3 samples: the rule the tuning varies.
    fresh = decision.COUNT_EARLY.replace(confidence=0.95, min_samples=3, dwell_s=0.0,
                                         hit_rate=0.9, min_reaction_s=0.1)
    stale = fresh.replace(min_reaction_s=0.0)
    regions = decision.region_set(3, 100)
    trials = decision.simulate_trials(3, 100, range(decision.TEST_SEED, decision.TEST_SEED + 10),
                                      'other_target')
    for trial in trials:
        resting = str(int(np.argmin(np.hypot(*(decision.layout(3, 100) - trial.start).T))))
        label, when = decision.decide(trial, regions, stale)
        assert label == resting and when < trial.onset
        label, when = decision.decide(trial, regions, fresh)
        assert label == str(trial.goal) and when > trial.onset - 0.05


def test_tuning_never_sees_a_test_seed(monkeypatch):
    simulated = set()
    tuned_on = []
    simulate, tune = decision.simulate_trials, decision.tune

    def recording_simulate(count, size, seeds, scenario='new_menu', params=decision.PARAMS):
        simulated.update(seeds)
        return simulate(count, size, seeds, scenario, params)

    def recording_tune(sets, grid):
        tuned_on.append({id(trial) for data in sets.values() for _, trials in data.values()
                         for trial in trials})
        tuned_on.append(set(simulated))  # everything simulated so far is tuning data
        return tune(sets, grid)

    monkeypatch.setattr(decision, 'simulate_trials', recording_simulate)
    monkeypatch.setattr(decision, 'tune', recording_tune)
    decision.run(quick=True, trials=3, tuning_trials=4, counts=(3,), sizes=(100,),
                 fast_trials=2)

    assert len(tuned_on[0]) == 2 * 4 + 2 * 2  # 90 Hz and 1200 Hz, both scenarios
    assert tuned_on[1] == set(range(decision.TUNING_SEED, decision.TUNING_SEED + 4))
    assert simulated - tuned_on[1] == set(range(decision.TEST_SEED, decision.TEST_SEED + 3))


def test_tuning_rejects_a_rule_fooled_by_a_resting_gaze():
    sets = {scenario: decision._simulate([(3, 100)], decision.TUNING_SEED, 10, scenario)
            for scenario in decision.SCENARIOS}
    grid = {'confidence': (0.95,), 'min_samples': (2,), 'dwell_s': (0.02,),
            'min_reaction_s': (0.0, 0.1), 'hit_rate': (0.9,)}
    config, search = decision.tune(sets, grid)
    assert config.min_reaction_s == 0.1 and search['selected_feasible']
    # Alone the main scenario cannot tell them apart (no one reacts in 0.1 s).
    results = decision.tune({'new_menu': sets['new_menu']}, grid)[1]['results']
    assert results[0]['mean_itr_bits_per_min'] == results[1]['mean_itr_bits_per_min']


def test_run_all_prints_its_own_table(section, capsys):
    assert run_all.load('decision') is decision
    lines = run_all.section_lines('decision', section, formatter=decision.format_lines)
    assert lines[0] == 'decision:' and lines[1:] == decision.format_lines(section)
    text = '\n'.join(lines)
    assert 'goal at 100 px, main scenario' in text and 'stress accuracy' in text
    # the main table and one per stress scenario
    assert text.count(' best  9  200 ') == 1 + len(decision.STRESS_SCENARIOS)
    for scenario in decision.STRESS_SCENARIOS:
        assert f'stress ({scenario})' in text
    assert '1200 Hz tracker, other_target' in text
    assert decision.main(['--quick']) == 0
    out = capsys.readouterr().out
    assert 'goal at 100 px' in out and 'stress' in out and 'RoundEvidence' in out


def test_run_all_falls_back_to_the_generic_table_when_a_formatter_fails():
    def broken(section):
        raise KeyError('rows')

    lines = run_all.section_lines('x', {'1': {'ms': 2.0}}, formatter=broken)
    assert 'format_lines failed' in lines[0]
    assert lines[1].split() == ['x', 'ms'] and lines[3].split() == ['1', '2.000']


def test_stress_scenarios_start_where_they_say(section):
    seeds = range(decision.TEST_SEED, decision.TEST_SEED + 10)
    centres = decision.layout(4, 100)
    outside = decision.PARAMS.person.screen.visual_angle_px(decision.NEAR_EDGE_DEG)
    for trial in decision.simulate_trials(4, 100, seeds, 'near_edge'):
        # Just outside a target that is not the goal: nearest another target, off its edge.
        offset = np.abs(centres - trial.start)
        nearest = int(np.argmin(np.hypot(*offset.T)))
        assert nearest != trial.goal
        assert np.isclose(offset[nearest].max(), 50 + outside)
    moving = decision.simulate_trials(4, 100, seeds, 'camera_moving')
    history = moving[0].regions
    assert history[0].stamp == 0.0 and history[-1].stamp >= decision.MOVE_S - 1e-9
    np.testing.assert_allclose(history[-1].centroids, centres)
    assert not np.allclose(history[0].centroids, centres)


def test_the_node_default_never_chooses_wrong_in_the_stress_scenarios(section):
    # On the quick section's 20 persons per cell.  The full bench (200 per cell) finds one
    # wrong choice in 200 at near_edge 9 x 100 px (0.5 %) and none while the camera moves.
    for scenario in ('near_edge', 'camera_moving'):
        cells = [m for row in section[f'stress_{scenario}']['node_default'].values()
                 for m in row.values()]
        assert max(m['wrong'] for m in cells) == 0.0, scenario
