"""The gaze statistics on recordings whose truth is known: an ideal simulated eye, edited."""

from dataclasses import replace

import numpy as np
import pytest

from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING
from eye_bci_ros2.recordings.gaze import TargetSchedule
from eye_bci_ros2.recordings.gaze_statistics import (blink_count, find_spikes, gaze_angles_deg,
                                                     gaze_statistics)
from eye_bci_ros2.sim.person import CONSUMER_TRACKER, IDEAL_EYE, record_schedule

#: A dot that jumps every 1.5 s between places 10-25 deg apart.
PLACES = np.array([[300.0, 250.0], [1600.0, 800.0], [960.0, 200.0], [250.0, 850.0],
                   [1650.0, 300.0]] * 4)
ONSETS = 1.5 * np.arange(len(PLACES))
SCHEDULE = TargetSchedule(ONSETS, ONSETS, np.append(ONSETS[1:], 1.5 * len(PLACES)), PLACES)
#: An eye without noise, losses or landing errors, with a constant 200 ms latency, at 500 Hz.
IDEAL = CONSUMER_TRACKER.with_changes(
    **IDEAL_EYE, offset_deg=0.0, jitter_deg=0.0, drift_deg=0.0, blink_rate_per_min=0.0,
    loss_prob=0.0, latency_ms=200.0, latency_min_ms=200.0, latency_sd_ms=0.0, rate_hz=500.0)


def test_an_ideal_eye_has_its_latency_lands_at_once_and_rests_on_the_target():
    stats = gaze_statistics([record_schedule(SCHEDULE, DEFAULT_VIEWING, IDEAL)])
    assert stats.steps == len(PLACES) - 1
    # The onset is found within the velocity filter's 20 ms span.
    assert stats.latency_median_ms == pytest.approx(200.0, abs=15.0)
    assert stats.latency_p90_ms - stats.latency_p10_ms < 10.0
    assert stats.anticipation_share == 0.0
    assert stats.corrective_share == 0.0 and stats.slow_landing_share == 0.0
    assert stats.error_median_deg < 0.01 and stats.mean_offset_deg < 0.01
    assert stats.drift_median_deg < 0.01
    assert stats.gain_median == pytest.approx(1.0, abs=0.01)
    assert stats.gain_p10 > 0.98 and stats.landing_ratio_p90 < 0.01
    assert np.isnan(stats.rest_median_ms)  # no second saccade
    assert stats.spikes_per_1000 == 0.0 and stats.blinks_per_min == 0.0


def test_an_undershooting_eye_needs_a_correction_and_lands_late():
    undershoot = IDEAL.with_changes(saccade_gain=0.75, correction_interval_ms=150.0)
    stats = gaze_statistics([record_schedule(SCHEDULE, DEFAULT_VIEWING, undershoot)])
    # 25 % short of 10-25 deg steps is more than 2 deg off; corrected about 150 ms later.
    assert stats.corrective_share > 0.9
    assert stats.slow_landing_share > 0.9 and stats.settle_median_ms > 150.0
    assert stats.error_median_deg < 0.01
    # A quarter short of the way, and resting there until the correction.
    assert stats.gain_median == pytest.approx(0.75, abs=0.02)
    assert stats.landing_ratio_median == pytest.approx(0.25, abs=0.02)
    # Gamma around 150 ms (SD a quarter), less the few ms the velocity filter adds to each
    # saccade's ends.
    assert 130.0 < stats.rest_median_ms < 160.0


def test_spikes_and_blinks_put_into_a_recording_are_counted():
    recording = record_schedule(SCHEDULE, DEFAULT_VIEWING, IDEAL.with_changes(jitter_deg=0.1),
                                seed=2)
    points = recording.points.copy()
    rate = 500
    # Three single samples 3 deg off, in fixations.
    spikes = [int((onset + 1.0) * rate) for onset in ONSETS[[2, 7, 11]]]
    for index in spikes:
        points[index] = DEFAULT_VIEWING.rotate_gaze(points[index][None], [3.0, 0.0])[0]
    # Two blinks of 150 ms, and a 10 ms loss that is not a blink.
    for start, length in ((5.2, 0.15), (17.1, 0.15), (20.0, 0.01)):
        points[int(start * rate):int((start + length) * rate)] = np.nan
    edited = replace(recording, points=points)
    found = np.flatnonzero(find_spikes(gaze_angles_deg(edited.screen, edited.points)))
    np.testing.assert_array_equal(found, spikes)
    assert blink_count(edited) == 2
    stats = gaze_statistics([edited])
    duration = recording.stamps[-1] - recording.stamps[0]
    assert stats.blinks_per_min == pytest.approx(2 * 60.0 / duration)
    assert stats.spikes_per_1000 == pytest.approx(3e3 / np.isfinite(points[:, 0]).sum())
