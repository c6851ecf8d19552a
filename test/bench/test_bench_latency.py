"""bench/latency.py end to end with a few rounds: every round decided by its marked sample."""

import pytest

from bench import latency

pytestmark = [pytest.mark.ros, pytest.mark.lsl]


def test_every_round_is_decided_by_its_marked_sample():
    section = latency.measure(rounds=5)
    # Wrong choices or lost rounds would mean the marked sample did not decide.
    assert section['rounds'] == section['rounds_requested'] == 5
    assert section['rounds_wrong_choice'] == 0 and section['rounds_lost'] == 0
    assert 0 < section['min_ms'] <= section['p50_ms'] <= section['p99_ms'] \
        <= section['max_ms']
    assert section['bridge_cpu_percent'] > 0
    assert section['bridge_poll_period_s'] == latency.default_poll_period()
    assert set(section) >= {'p50_ms', 'p99_ms', 'bridge_cpu_percent', 'push_rate_hz'}
