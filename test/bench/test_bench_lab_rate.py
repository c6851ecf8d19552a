"""bench/lab_rate.py's plumbing on a tiny run: the nodes as a lab starts them, samples counted."""

import io

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
    # 1.5 s of rounds every REQUEST_PERIOD_S; the gaze rests on the asked option all along,
    # so every round is answered, with that option.
    assert row['rounds'] == 6
    assert (row['rounds_right'], row['rounds_wrong'], row['rounds_no_choice'],
            row['rounds_unanswered']) == (6, 0, 0, 0), row
    assert row['samples_pushed'] > 0 and row['samples_lost_lsl'] == 0
    # Each window holds WINDOW_S x 1200 Hz samples, less at most one at its edge.
    assert row['arbiter_window_samples_expected'] == 240
    assert row['arbiter_rounds_counted'] >= 6 and row['arbiter_samples_short'] == 0
    assert row['cpu_percent']['eye_bci'] > 0 and row['nodes_cpu_per_pusher_cpu'] > 0
    assert row['main_thread_wakeups_per_s']['eye_bci'] > 0
    assert row['stolen_cpu_percent'] >= 0 and row['others_cpu_percent'] >= 0


def test_a_row_summarises_rounds_samples_and_cpu_as_counted_by_hand():
    # Four rounds asked 0.25 s apart: the option asked, another one, no choice, no answer.
    requests = [10.0, 10.25, 10.5, 10.75]
    answers = [(10.21, 'choice', 'b'), (10.47, 'choice', 'a'), (10.72, 'none', None)]
    log = ('[lsl_gaze_bridge]: gaze: 1000 received, 990 published\n'
           '[lsl_gaze_bridge]: gaze: 200 received, 200 published\n'
           "[choice_arbiter]: choice 'b' by mean: 240 samples\n"
           "[choice_arbiter]: choice 'a' by mean: 236 samples\n")
    row = lab_rate._row(lab_rate.Scenario('eye_bci'), requests, answers, 'b',
                        {'eye_bci': 30.0, 'pusher': 12.0, 'driver': 3.0}, machine=80.0,
                        steal=1.5, load_average=(1.25, 1.0, 1.0), pushed=1210, text=log,
                        log=io.StringIO(), wakeups={'eye_bci': 250.4, 'pusher': 1200.0,
                                                    'driver': 10.0},
                        lateness={'p50_ms': 0.1, 'p99_ms': 0.5, 'max_ms': 1.0})
    assert (row['rounds'], row['rounds_right'], row['rounds_wrong'], row['rounds_no_choice'],
            row['rounds_unanswered']) == (4, 1, 1, 1, 1)
    # Answers 10 and 20 ms after each window's end (WINDOW_S 0.2 s after the request).
    assert row['window_end_to_choice'] == {'p50_ms': 15.0, 'p99_ms': 19.9, 'max_ms': 20.0}
    # The nodes (eye_bci alone) used 30 % of a core, 2.5 times the pusher's 12 %; of the
    # machine's 80 %, 30 + 12 + 3 are this bench's.
    assert row['nodes_cpu_percent'] == 30.0 and row['nodes_cpu_per_pusher_cpu'] == 2.5
    assert row['others_cpu_percent'] == 35.0 and row['stolen_cpu_percent'] == 1.5
    assert row['main_thread_wakeups_per_s'] == {'eye_bci': 250, 'pusher': 1200, 'driver': 10}
    # 1200 of 1210 samples reached the bridge; one window held 236 of the 239 it must.
    assert row['samples_bridge_received'] == 1200 and row['samples_lost_lsl'] == 10
    assert row['arbiter_window_samples_expected'] == 240
    assert (row['arbiter_rounds_counted'], row['arbiter_rounds_short'],
            row['arbiter_samples_short']) == (2, 1, 3)


def test_the_wake_up_cost_is_measured_with_and_without_the_timer(monkeypatch):
    monkeypatch.setattr(lab_rate, 'WAKE_UP_S', 1.0)
    row = lab_rate.wake_up_cost()
    assert 'error' not in row, row
    # The timer ran in its process at its rate: never faster, and a loaded machine may
    # delay some ticks but not half of them.
    assert 0.5 * lab_rate.WAKE_UP_HZ <= row['ticks_per_s'] <= 1.02 * lab_rate.WAKE_UP_HZ, row
    # The wake-ups cost CPU: the process with the timer used more than the one without.
    assert row['cpu_percent_with'] > row['cpu_percent_without'] >= 0, row
    assert row['cpu_us_per_wake_up'] > 0, row
