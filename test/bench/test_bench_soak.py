"""The soak's verdict and summary (bench/soak.py), on results made by hand: no ROS, no LSL."""

import copy

from bench import soak


def _results():
    stats = {'count': 3, 'median': 0.2, 'p95': 0.4, 'max': 0.5}
    memory = {'rss_start_mb': 100.0, 'rss_end_mb': 100.5, 'rss_max_mb': 100.6,
              'rss_growth_mb_per_min': 0.05, 'flat': True}
    return {
        'config': {'duration_s': 600.0, 'rate_hz': 1200.0, 'push': 'push_sample',
                   'arbiter': {'method': 'fixation', 'window_s': 1.0}},
        'samples': {'pushed_total': 720_000, 'pushed_nan': 9000, 'expected_on_ros': 700_000,
                    'gaze_received': 700_000, 'lost': 0, 'pusher_error': None},
        'rounds': {'asked': 900, 'right_choice': 600, 'no_choice_looking_at_nothing': 290,
                   'no_choice': 10, 'wrong_choice': 0, 'more_than_one_outcome': 0,
                   'unanswered': 0, 'duration_s': stats, 'open_fraction': 0.9},
        'memory': {'nodes': dict(memory), 'pusher': dict(memory)},
        'cpu_percent': {'nodes': {'count': 3, 'median': 30.0, 'p95': 35.0, 'max': 40.0},
                        'pusher': {'count': 3, 'median': 20.0, 'p95': 25.0, 'max': 30.0}},
    }


def test_the_verdict_fails_on_a_lost_sample_a_wrong_round_or_growing_memory():
    good = _results()
    assert soak.passed(good)
    assert soak.summary_lines(good)[-1].endswith('no sample lost, no wrong round, memory flat')

    for path, value in ((('samples', 'lost'), 1), (('samples', 'lost'), None),
                        (('rounds', 'wrong_choice'), 1), (('rounds', 'unanswered'), 1),
                        (('rounds', 'more_than_one_outcome'), 1)):
        bad = copy.deepcopy(good)
        bad[path[0]][path[1]] = value
        assert not soak.passed(bad), path
        assert 'FAILED' in soak.summary_lines(bad)[-1]
    leaking = copy.deepcopy(good)
    leaking['memory']['nodes']['flat'] = False
    assert not soak.passed(leaking)
    short = copy.deepcopy(good)   # a check of a minute cannot tell a leak from settling
    short['memory']['nodes']['flat'] = None
    assert soak.passed(short)
    assert soak.summary_lines(short)[-1].endswith('(too short a run to judge memory)')


def test_the_summary_says_what_was_counted():
    lines = '\n'.join(soak.summary_lines(_results()))

    assert '700000 valid from the first the bridge received, 700000 received on ROS: 0 lost' \
        in lines
    assert "10 'no choice' looking at an option" in lines and '0 wrong' in lines
    assert 'a round open 90 % of the time' in lines
    assert 'nodes process: RSS 100.0 -> 100.5 MB' in lines
    assert 'pusher process' in lines
