"""
Smoke tests of the decision-time benchmark (bench/decision.py).

Quick mode only; nothing here depends on how fast anything ran, only on what
the benchmark computes: its layouts, trials, metrics, tuning and section.
"""

import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench import decision, run_all  # noqa: E402

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
                                              'hit_rate', 'method', 'window_s'}
    assert section['setup']['tuned_on_test_set'] is False
    assert set(section['stress_other_target']) == {'original', 'node_default', 'best',
                                                   'proposal'}
    search = section['best']['search']
    assert search['configurations'] == len(search['results']) == 4  # the quick grid


def test_goal_row_is_the_worst_best_cell_at_100_px(section):
    goal = section['goal_100px']
    best = [section['best'][c]['100'] for c in ('3', '4', '9')]
    original = [section['original'][c]['100'] for c in ('3', '4', '9')]

    assert goal['accuracy'] == min(m['accuracy'] for m in best)
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
    expected = decision.wolpaw_bits(metrics['accuracy'], 4) * 60 / seconds
    assert metrics['itr_bits_per_min'] == pytest.approx(expected)


def test_wolpaw_bits_known_values_and_edges():
    assert decision.wolpaw_bits(1.0, 4) == pytest.approx(2.0)
    assert decision.wolpaw_bits(1.0, 9) == pytest.approx(math.log2(9))
    expected = 2 + 0.9 * math.log2(0.9) + 0.1 * math.log2(0.1 / 3)
    assert decision.wolpaw_bits(0.9, 4) == pytest.approx(expected)
    assert decision.wolpaw_bits(0.25, 4) == 0.0
    assert decision.wolpaw_bits(0.1, 4) == 0.0  # below chance: no information, not negative
    assert decision.itr_bits_per_min(1.0, 4, 0.5) == pytest.approx(240.0)
    with pytest.raises(ValueError, match='accuracy'):
        decision.wolpaw_bits(1.2, 3)
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
    for config in (decision.EarlyConfig(0.95, 2, 0.0, 0.9), decision.EarlyConfig()):
        for trial in trials:
            whole = decision.decide_early(trial, regions, config)
            assert decision.decide_early(trial, regions, config, chunk=2) == whole
            assert decision.decide_early(trial, regions, config, chunk=1) == whole


def test_benchmark_decisions_are_the_node_trackers_decisions():
    arbitration = pytest.importorskip('eye_bci_ros2.arbitration')
    if not hasattr(arbitration, 'ChoiceTracker'):
        pytest.skip('no ChoiceTracker (the node logic without ROS) in arbitration')
    regions = decision.region_set(4, 60)
    trials = decision.simulate_trials(4, 60, range(decision.TEST_SEED, decision.TEST_SEED + 20))
    config = decision.EarlyConfig(0.95, 2, 0.0, 0.9)
    for early in (True, False):
        for trial in trials:
            settings = arbitration.ArbiterSettings(
                method='mean', window_s=decision.WINDOW_S, early_decision=early,
                confidence=config.confidence, min_samples=config.min_samples,
                dwell_s=config.dwell_s, hit_rate=config.hit_rate)
            tracker = arbitration.ChoiceTracker(settings)
            tracker.add_regions(regions, now=0.0)
            made = None
            for stamp, (x, y) in zip(trial.stamps, trial.points):
                made = tracker.add_sample(stamp, x, y, now=stamp + 0.01)
                if made is not None:
                    break
            if made is None:  # the first sample after the window closes it
                made = tracker.add_sample(decision.WINDOW_S, 0.0, 0.0, now=decision.WINDOW_S)
            if early:
                label, when = decision.decide_early(trial, regions, config)
                if when < decision.WINDOW_S:
                    assert made.time_to_decision == pytest.approx(when)
            else:
                label, _ = decision.decide_window(trial, regions, 'mean')
            assert made.label == label


def test_gaze_resting_on_a_target_fools_the_fast_rule_but_not_the_proposal():
    config = decision.EarlyConfig(0.95, 3, 0.0, 0.9)
    regions = decision.region_set(3, 100)
    trials = decision.simulate_trials(3, 100, range(decision.TEST_SEED, decision.TEST_SEED + 10),
                                      'other_target')
    for trial in trials:
        resting = str(int(np.argmin(np.hypot(*(decision.layout(3, 100) - trial.start).T))))
        label, when = decision.decide_early(trial, regions, config)
        assert label == resting and when < trial.onset
        label, when = decision.decide_fresh(trial, regions, config)
        assert label == str(trial.goal) and when > trial.onset - 0.05


def test_tuning_never_sees_a_test_seed(monkeypatch):
    simulated = set()
    tuned_on = []
    simulate, tune = decision.simulate_trials, decision.tune

    def recording_simulate(count, size, seeds, scenario='new_menu', params=decision.PARAMS):
        simulated.update(seeds)
        return simulate(count, size, seeds, scenario, params)

    def recording_tune(data, grid):
        tuned_on.append({id(trial) for _, trials in data.values() for trial in trials})
        tuned_on.append(set(simulated))  # everything simulated so far is tuning data
        return tune(data, grid)

    monkeypatch.setattr(decision, 'simulate_trials', recording_simulate)
    monkeypatch.setattr(decision, 'tune', recording_tune)
    decision.run(quick=True, trials=3, tuning_trials=4, counts=(3,), sizes=(100,),
                 stress=False)

    assert len(tuned_on[0]) == 4
    assert tuned_on[1] == set(range(decision.TUNING_SEED, decision.TUNING_SEED + 4))
    assert simulated - tuned_on[1] == set(range(decision.TEST_SEED, decision.TEST_SEED + 3))


def test_run_all_loads_it_and_prints_its_tables(section, capsys):
    assert run_all.load('decision') is decision
    lines = run_all.format_table('decision', section, decision.TABLE_COLUMNS)
    assert any(line.lstrip().startswith('goal_100px') for line in lines)
    assert decision.main(['--quick']) == 0
    out = capsys.readouterr().out
    assert 'goal at 100 px' in out and 'stress' in out and 'RoundEvidence' in out
