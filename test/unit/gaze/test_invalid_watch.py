"""When invalid gaze samples warrant a warning (eye_bci_ros2.gaze.invalid_watch)."""

import re

import numpy as np

from eye_bci_ros2.gaze.invalid_watch import InvalidGazeWatch

#: A tracker's sample period, ns (120 Hz).
PERIOD_NS = 8_333_333


def chunks(valid: np.ndarray, size: int = 12, reason: str = 'nonfinite'):
    """Yield (stamps, keep, dropped) chunks of a stream of valid/invalid flags."""
    stamps = np.arange(len(valid), dtype=np.int64) * PERIOD_NS
    for start in range(0, len(valid), size):
        keep = valid[start:start + size]
        yield stamps[start:start + size], keep, {reason: int(np.count_nonzero(~keep))}


def reports(watch, valid, **kwargs):
    return [report for chunk in chunks(valid, **kwargs)
            if (report := watch.update(*chunk)) is not None]


def test_blinks_and_glances_away_shorter_than_the_limit_are_never_reported():
    rng = np.random.default_rng(3)
    valid = np.ones(120 * 120, bool)              # two minutes at 120 Hz
    for start in rng.integers(0, len(valid) - 600, 80):
        valid[start:start + rng.integers(12, 48)] = False    # blinks, 0.1-0.4 s
    for start in (3000, 9000):
        valid[start:start + 600] = False                     # looks away for 5 s
    assert reports(InvalidGazeWatch(10.0), valid, reason='offscreen') == []


def test_a_layout_that_yields_only_invalid_samples_is_reported_once_with_what_to_check():
    watch = InvalidGazeWatch(2.0)
    found = reports(watch, np.zeros(120 * 30, bool))
    assert len(found) == 1 and found[0].warning
    assert 'no valid gaze sample since the stream started' in found[0].text
    assert 'nonfinite' in found[0].text and 'x_channel' in found[0].text


def test_a_long_stretch_after_valid_gaze_is_reported_once_then_its_end():
    valid = np.ones(120 * 40, bool)
    valid[1200:1200 + 120 * 15] = False          # 15 s without the eyes
    found = reports(InvalidGazeWatch(10.0), valid)
    assert [report.warning for report in found] == [True, False]
    # Judged per chunk (12 samples, 0.1 s here): at the first chunk past the limit.
    assert re.match(r'no valid gaze for 10\.[01] s \(\d+ nonfinite\)', found[0].text)
    assert found[1].text == 'valid gaze again after 15.0 s'


def test_a_new_stream_or_layout_starts_over():
    watch = InvalidGazeWatch(1.0)
    assert len(reports(watch, np.zeros(240, bool))) == 1
    watch.reset()
    found = reports(watch, np.zeros(240, bool))
    assert len(found) == 1 and 'since the stream started' in found[0].text
