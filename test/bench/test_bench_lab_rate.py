"""bench/lab_rate.py's plumbing on a tiny run: the nodes as a lab starts them, samples counted."""

import pytest

from bench import lab_rate

pytestmark = [pytest.mark.ros, pytest.mark.lsl]


def test_scenario_names_round_trip_and_commands_start_the_nodes_as_ros2_run_does():
    scenario = lab_rate._scenario('processes-2000-chunk-busy-fixed')
    assert scenario == lab_rate.Scenario('processes', 2000.0, 'chunk', 'busy', fixed=True)
    assert lab_rate._scenario(scenario.name) == scenario
    commands = lab_rate.node_commands(scenario, 'name', 'source')
    assert set(commands) == set(lab_rate.NODES)
    bridge, arbiter = commands['lsl_gaze_bridge'], commands['choice_arbiter']
    assert bridge[1:3] == ['-m', 'eye_bci_ros2.nodes.lsl_gaze_bridge']
    assert 'profile:=xy_pixels' in bridge and 'source_id:=source' in bridge
    assert any(part.startswith('idle_poll_period_s:=') for part in bridge)
    assert 'window_s:=0.2' in arbiter and 'profile:=xy_pixels' not in arbiter
    single = lab_rate.node_commands(lab_rate.Scenario(), 'name', 'source')
    assert list(single) == ['eye_bci'] and 'window_s:=0.2' in single['eye_bci']
    with pytest.raises(Exception):
        lab_rate._scenario('eye_bci-1200-sample')


def test_a_short_run_counts_every_sample_and_answers_right():
    row = lab_rate.measure(lab_rate.Scenario('eye_bci'), seconds=1.5)
    assert row['rounds'] == 6
    assert row['rounds_wrong'] == 0
    assert row['rounds_right'] >= 1
    assert row['samples_pushed'] > 0 and row['samples_lost_lsl'] == 0
    assert row['arbiter_rounds_counted'] >= 1 and row['arbiter_samples_short'] == 0
    assert row['cpu_percent']['eye_bci'] > 0
    assert row['nodes_cpu_per_pusher_cpu'] == pytest.approx(
        row['nodes_cpu_percent'] / row['cpu_percent']['pusher'], abs=0.01)
    assert row['main_thread_wakeups_per_s']['eye_bci'] > 0
    assert row['stolen_cpu_percent'] >= 0 and row['others_cpu_percent'] >= 0


def test_the_wake_up_cost_is_measured_with_and_without_the_timer(monkeypatch):
    monkeypatch.setattr(lab_rate, 'WAKE_UP_S', 1.0)
    row = lab_rate.wake_up_cost()
    assert 'error' not in row, row
    # The timer ran in its process (about WAKE_UP_HZ ticks a second; the machine's load
    # may delay some), and both processes were measured.
    assert row['ticks_per_s'] > 0
    assert row['cpu_percent_with'] > 0 and row['cpu_percent_without'] >= 0
