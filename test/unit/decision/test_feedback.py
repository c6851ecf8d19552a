"""Feedback content (highlight, progress, rate) as plain data (no ROS)."""

import numpy as np
import pytest

from eye_bci_ros2.decision.evidence import early_progress, window_progress
from eye_bci_ros2.decision.feedback import (build_feedback, CHOSEN, FeedbackThrottle, GAZED,
                                            halo_scale, NONE, OptionFeedback)


def test_build_feedback_highlights_gazed_and_chosen():
    fb = build_feedback(['a', 'b', 'c', 'a'], gazed='b', progress={'b': 0.4, 'c': 2.0})
    assert fb.labels == ('a', 'b', 'c')
    assert fb.get('a') == OptionFeedback('a', NONE, 0.0)
    assert fb.get('b') == OptionFeedback('b', GAZED, 0.4)
    assert fb.get('c').progress == 1.0
    chosen = build_feedback(['a', 'b'], gazed='b', chosen='b')
    assert chosen.get('b') == OptionFeedback('b', CHOSEN, 1.0)
    assert fb.get('zzz') is None


def test_option_feedback_rejects_bad_values():
    with pytest.raises(ValueError, match='state'):
        OptionFeedback('a', 'blinking')
    with pytest.raises(ValueError, match='progress'):
        OptionFeedback('a', GAZED, 1.5)


def test_early_progress_reaches_one_exactly_when_the_rule_would_decide():
    # h = 0.9, R = 3: lambda = log(18); two fresh samples ahead give P = 0.988 > 0.95.
    counts = {'a': 2, 'b': 0, 'c': 0}
    done = early_progress(counts, 0.9, 0.95, 'a', 2, 2, 0.02, 0.02)
    assert done['a'] == pytest.approx(1.0) and done['b'] == 0.0
    # One sample ahead: P = 18 / 20 = 0.9 < 0.95, and the run is half way.
    half = early_progress({'a': 1, 'b': 0, 'c': 0}, 0.9, 0.95, 'a', 1, 2, 0.015, 0.02)
    assert half['a'] == pytest.approx(0.5)
    # The run and dwell are complete but the posterior is not: its part shows.
    posterior = early_progress({'a': 1, 'b': 0, 'c': 0}, 0.9, 0.95, 'a', 2, 2, 0.02, 0.02)
    assert posterior['a'] == pytest.approx((0.9 - 1 / 3) / (0.95 - 1 / 3))
    # The posterior is there but the run is not the leader's: no progress for it.
    assert early_progress(counts, 0.9, 0.95, 'b', 5, 2, 1.0, 0.02)['a'] == 0.0


def test_window_progress_fills_with_time_and_share():
    p = window_progress({'a': 30, 'b': 10}, samples=45, elapsed_s=0.5, window_s=1.0)
    assert p == {'a': pytest.approx(0.5 * 30 / 45), 'b': pytest.approx(0.5 * 10 / 45)}
    assert window_progress({'a': 90}, 90, 2.0, 1.0) == {'a': 1.0}
    with pytest.raises(ValueError):
        window_progress({}, 0, 0.0, 0.0)


def test_halo_is_thinner_and_grows_in_the_options_plane():
    scale = np.array([1.0, 0.8, 0.05])
    np.testing.assert_allclose(halo_scale(scale, 0.0), [1.12, 0.896, 0.025])
    np.testing.assert_allclose(halo_scale(scale, 1.0), [1.52, 1.216, 0.025])


def test_throttle_sends_changes_at_once_progress_at_30_hz_and_a_keepalive():
    throttle = FeedbackThrottle(max_rate_hz=30.0, min_step=0.02, keepalive_hz=1.0)
    idle = build_feedback(['a', 'b'])
    assert throttle.due(idle, 0.0)
    assert not throttle.due(idle, 0.1)
    gazed = build_feedback(['a', 'b'], gazed='a', progress={'a': 0.01})
    assert throttle.due(gazed, 0.101)                          # highlight changed: at once
    more = build_feedback(['a', 'b'], gazed='a', progress={'a': 0.2})
    assert not throttle.due(more, 0.11)                        # within 1/30 s
    assert throttle.due(more, 0.14)
    tiny = build_feedback(['a', 'b'], gazed='a', progress={'a': 0.205})
    assert not throttle.due(tiny, 0.5)                         # below min_step
    assert throttle.due(tiny, 1.2)                             # keepalive
    # A stream of 1 kHz updates sends at most ~30 per second.
    sent = sum(throttle.due(build_feedback(['a', 'b'], gazed='a',
                                           progress={'a': (i % 100) / 100}), 2 + i / 1000)
               for i in range(1000))
    assert 20 <= sent <= 31
