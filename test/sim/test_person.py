"""The simulated person and tracker (pure numpy): geometry, statistics, timing, seeds."""

import math

import numpy as np
import pytest

from eye_bci_ros2.projection.visual_angle import (DEFAULT_SCREEN, px_per_degree, ScreenGeometry,
                                                  visual_angle_px)
from eye_bci_ros2.sim.person import (CONSUMER_TRACKER, GazeParams, GazeSimulator, IDEAL_EYE,
                                     ORIGINAL_TOBII_4C, PersonParams, TrackerParams)

SCREEN = DEFAULT_SCREEN
#: Two places far apart on the 1920x1080 screen, px.
LEFT, RIGHT = (300.0, 300.0), (1600.0, 800.0)


def ideal(params: GazeParams = CONSUMER_TRACKER, **changes) -> GazeParams:
    """Return params with an ideal eye (IDEAL_EYE) unless asked, to test one mechanism."""
    return params.with_changes(**{**IDEAL_EYE, **changes})


def quiet(params: GazeParams = CONSUMER_TRACKER, **changes) -> GazeParams:
    """Return params of an ideal eye without blinks, losses or noise unless asked."""
    base = {'blink_rate_per_min': 0.0, 'loss_prob': 0.0, 'jitter_deg': 0.0, 'offset_deg': 0.0,
            **IDEAL_EYE}
    base.update(changes)
    return params.with_changes(**base)


# Screen geometry -------------------------------------------------------------

def test_px_per_degree_matches_a_hand_computation():
    # 1920 px / 527 mm = 3.6433 px/mm; 1 deg at 600 mm spans
    # 2 * 600 * tan(0.5 deg) = 10.4724 mm -> 38.153 px.
    assert px_per_degree() == pytest.approx(38.153, abs=2e-3)
    assert SCREEN.px_per_degree(axis=1) == pytest.approx(1080 / 296 * 10.4724, abs=2e-3)
    assert visual_angle_px(2.0) == pytest.approx(2 * 600 * math.tan(math.radians(1)) * 1920 / 527)
    assert SCREEN.px_to_visual_angle(visual_angle_px(3.0)) == pytest.approx(3.0)
    # An object of px_per_degree pixels centred on the screen subtends 1 deg.
    half = px_per_degree() / 2
    assert SCREEN.angle_between_deg((960 - half, 540), (960 + half, 540)) == pytest.approx(1.0)
    closer = ScreenGeometry(distance_mm=300.0)
    assert closer.px_per_degree() == pytest.approx(38.153 / 2, abs=1e-3)


def test_rotating_the_gaze_ray_is_exact_in_degrees_and_invertible():
    rng = np.random.default_rng(0)
    xy = rng.uniform((0, 0), (1920, 1080), size=(500, 2))
    delta = rng.normal(0.0, 2.0, size=(500, 2))
    moved = SCREEN.rotate_gaze(xy, delta)
    np.testing.assert_allclose(SCREEN.angular_error_deg(moved, xy), delta, atol=1e-9)
    # Each of a pure horizontal or vertical error is that many degrees of visual angle.
    for delta in ((1.5, 0.0), (0.0, -1.5)):
        np.testing.assert_allclose(SCREEN.angle_between_deg(SCREEN.rotate_gaze(xy, delta), xy),
                                   1.5, atol=1e-9)
    # Right and down are +x and +y on the screen; a degree covers more px at the edge.
    centre = SCREEN.rotate_gaze([[960, 540]], [1.0, 1.0])[0]
    assert centre[0] > 960 + 38 and centre[1] > 540 + 38
    edge = SCREEN.rotate_gaze([[1900, 540]], [1.0, 0.0])[0]
    assert edge[0] - 1900 > centre[0] - 960 + 5


# Statistics of the measurement -----------------------------------------------

@pytest.mark.parametrize('offset_deg, direction_deg, jitter_deg', [
    (0.5, 30.0, 0.3), (1.2, 250.0, 0.1)])
def test_fixation_error_has_the_requested_offset_and_jitter(offset_deg, direction_deg,
                                                            jitter_deg):
    params = ideal(offset_deg=offset_deg, offset_direction_deg=direction_deg,
                   jitter_deg=jitter_deg)
    target = (1400.0, 300.0)
    trace = GazeSimulator(params, seed=4).simulate(120.0, [(0.0, target)], initial_xy=target)
    valid = trace.valid
    error = SCREEN.angular_error_deg(trace.xy[valid], target)
    expected = offset_deg * np.array([math.cos(math.radians(direction_deg)),
                                      math.sin(math.radians(direction_deg))])
    np.testing.assert_allclose(error.mean(axis=0), expected, atol=0.01)
    np.testing.assert_allclose(error.std(axis=0), jitter_deg, rtol=0.05)
    # The eye itself stays on the target: the error is the tracker's.
    np.testing.assert_allclose(trace.eye_xy, np.broadcast_to(target, trace.eye_xy.shape))


def test_the_offset_direction_is_a_property_of_the_seeded_person():
    directions = []
    for seed in range(6):
        sim = GazeSimulator(CONSUMER_TRACKER, seed=seed)
        assert np.linalg.norm(sim.offset_vector_deg) == pytest.approx(0.5)
        directions.append(math.atan2(*sim.offset_vector_deg[::-1]))
        again = GazeSimulator(CONSUMER_TRACKER, seed=seed).offset_vector_deg
        np.testing.assert_array_equal(again, sim.offset_vector_deg)
    assert np.ptp(directions) > 1.0


def test_drift_adds_a_slow_error_of_the_requested_rms():
    params = quiet(ORIGINAL_TOBII_4C, drift_deg=0.2, drift_period_s=4.0)
    sim = GazeSimulator(params, seed=2)
    trace = sim.simulate(600.0, [(0.0, (960, 540))], initial_xy=(960, 540))
    error = SCREEN.angular_error_deg(trace.xy, (960, 540))
    np.testing.assert_allclose(np.sqrt((error ** 2).mean(axis=0)), 0.2, rtol=0.15)
    # Slow: neighbouring samples differ by far less than the drift itself.
    assert np.abs(np.diff(error, axis=0)).max() < 0.01


def test_blinks_and_losses_remove_the_requested_fraction_of_samples():
    params = ideal(blink_rate_per_min=15.0, loss_prob=0.02)
    trace = GazeSimulator(params, seed=7).simulate(1800.0, [(0.0, (960, 540))])
    lost = ~trace.valid
    np.testing.assert_array_equal(np.isnan(trace.xy).any(axis=1), lost)
    assert trace.dropped.mean() == pytest.approx(0.02, abs=0.003)
    assert trace.blink.mean() == pytest.approx(params.person.blink_fraction, rel=0.2)
    assert lost.mean() == pytest.approx(params.person.lost_fraction, rel=0.15)
    # Blinks are runs of 100-300 ms, about 15 a minute.
    edges = np.flatnonzero(np.diff(trace.blink.astype(int)))
    starts, ends = edges[::2] + 1, edges[1::2] + 1
    n = min(len(starts), len(ends))
    durations = trace.t[ends[:n]] - trace.t[starts[:n]]
    assert durations.min() >= 0.1 - 1.5 / 90 and durations.max() <= 0.3 + 1.5 / 90
    assert len(starts) / 30.0 == pytest.approx(15.0, rel=0.2)


def test_no_blinks_and_no_losses_when_both_are_off():
    trace = GazeSimulator(quiet(), seed=1).simulate(60.0, [(0.0, (960, 540))])
    assert trace.valid.all() and np.isfinite(trace.xy).all()


# Eye movements ---------------------------------------------------------------

def jump_trials(params: GazeParams, trials: int = 150, seed: int = 5):
    """Alternate the target between LEFT and RIGHT every second; return the trace."""
    schedule = [(k + 0.5, RIGHT if k % 2 == 0 else LEFT) for k in range(trials)]
    sim = GazeSimulator(params, seed=seed)
    return sim.simulate(trials + 0.5, schedule, initial_xy=LEFT), schedule


def test_saccade_latency_and_duration_follow_the_parameters():
    # A 1 kHz tracker resolves the timing to a millisecond.
    params = quiet(rate_hz=1000.0)
    person = params.person
    trace, schedule = jump_trials(params, trials=400)
    onsets, durations = [], []
    for t_jump, new in schedule:
        old = LEFT if new == RIGHT else RIGHT
        window = slice(*np.searchsorted(trace.t, [t_jump, t_jump + 1.0]))
        t, eye = trace.t[window], trace.eye_xy[window]
        moved = np.argmax(np.hypot(*(eye - old).T) > 1e-6)
        arrived = np.argmax(np.hypot(*(eye - new).T) < 1e-6)
        onsets.append(t[moved] - t_jump)
        durations.append(t[arrived] - t[moved])
    onsets, durations = np.array(onsets), np.array(durations)
    assert onsets.min() >= person.latency_min_ms / 1e3
    assert onsets.mean() == pytest.approx(person.latency_ms / 1e3, abs=0.008)
    assert onsets.std() == pytest.approx(person.latency_sd_ms / 1e3, rel=0.2)
    amplitude = SCREEN.angle_between_deg(LEFT, RIGHT)
    expected = min(person.saccade_base_ms + person.saccade_ms_per_deg * amplitude,
                   person.saccade_max_ms) / 1e3
    np.testing.assert_allclose(durations, expected, atol=0.002)


def test_measured_gaze_reaches_a_new_target_only_after_the_latency():
    params = ideal(blink_rate_per_min=0.0)
    trace, schedule = jump_trials(params, trials=60)
    near_deg = 3.0
    delays = []
    for t_jump, new in schedule:
        window = (trace.t >= t_jump) & (trace.t < t_jump + 1.0) & trace.valid
        near = window & (SCREEN.angle_between_deg(trace.xy, new) < near_deg)
        delays.append(trace.t[np.argmax(near)] - t_jump)
        # Settled on the new target: about the offset away, within the jitter.
        settled = window & (trace.t > t_jump + 0.6)
        assert np.median(SCREEN.angle_between_deg(trace.xy[settled], new)) < 1.0
    delays = np.array(delays)
    assert delays.min() >= params.person.latency_min_ms / 1e3
    assert 0.2 < np.median(delays) < 0.35


def test_a_slowly_moving_target_is_followed_by_catch_up_saccades():
    params = quiet()
    speed_px = 4 * px_per_degree()  # 4 deg/s

    def target(t):
        return np.stack([400 + speed_px * t, np.full_like(t, 540.0)], axis=1)

    trace = GazeSimulator(params, seed=3).trace(np.arange(0, 5, 1 / 90), target,
                                                initial_xy=(400, 540))
    lag_deg = SCREEN.angle_between_deg(trace.eye_xy, target(trace.t))
    later = trace.t > 1.0
    # About one latency behind (0.2 s * 4 deg/s) plus the re-targeting step.
    assert np.median(lag_deg[later]) < 1.6
    steps = np.count_nonzero(np.diff(trace.eye_xy[:, 0]) > 0.5)
    assert steps > 10


def test_a_callable_schedule_of_jumps_equals_the_list_schedule():
    params = ideal()
    t = GazeSimulator(params, seed=1).sample_times(6.0)
    switch = t[np.argmax(t >= 2.0)]

    def target(times):
        out = np.where((times < 2.0)[:, None], LEFT, RIGHT)
        out[(times >= 4.0)] = np.nan
        return out

    by_list = GazeSimulator(params, seed=1).trace(
        t, [(t[0], LEFT), (switch, RIGHT), (t[np.argmax(t >= 4.0)], None)])
    by_callable = GazeSimulator(params, seed=1).trace(t, target)
    np.testing.assert_array_equal(by_callable.xy, by_list.xy)
    # No target from 4 s on: the eye stays where it was.
    assert np.all(by_list.eye_xy[t > 4.0] == RIGHT)


def test_a_target_that_moves_again_first_ends_on_the_newest_place():
    params = quiet()
    schedule = [(0.0, LEFT), (1.0, RIGHT), (1.05, (960.0, 100.0))]
    trace = GazeSimulator(params, seed=0).simulate(2.0, schedule, initial_xy=LEFT)
    np.testing.assert_allclose(trace.eye_xy[-1], (960.0, 100.0))
    assert np.all(trace.eye_xy[trace.t < 1.0 + params.person.latency_min_ms / 1e3] == LEFT)


def test_primary_saccades_undershoot_and_far_landings_are_corrected():
    params = quiet(rate_hz=1000.0, saccade_gain=0.9, landing_sd=0.05, correction_min_deg=0.75)
    trace, schedule = jump_trials(params, trials=120)
    person = params.person
    amplitude = SCREEN.angle_between_deg(LEFT, RIGHT)
    covered, corrected = [], 0
    for t_jump, new in schedule:
        old = LEFT if new == RIGHT else RIGHT
        window = (trace.t >= t_jump) & (trace.t < t_jump + 1.0)
        eye = trace.eye_xy[window]
        moving = np.flatnonzero(np.hypot(*np.diff(eye, axis=0).T) > 1e-6)
        # The first landing: where the eye rests for the first time after moving.
        rest = moving[np.flatnonzero(np.diff(moving) > 30)]
        first = eye[rest[0] + 20] if len(rest) else eye[-1]
        covered.append(SCREEN.angle_between_deg(old, first) / amplitude)
        far = SCREEN.angle_between_deg(first, new) > person.correction_min_deg
        corrected += far
        # Wherever it first landed, the eye ends near the target.
        assert SCREEN.angle_between_deg(eye[-1], new) < person.correction_min_deg + 0.5
        if far:
            assert SCREEN.angle_between_deg(eye[-1], new) < SCREEN.angle_between_deg(first, new)
    assert np.median(covered) == pytest.approx(0.9, abs=0.02)
    # A 10 % undershoot of a ~35 deg saccade is far off: nearly every step is corrected.
    assert corrected / len(schedule) > 0.8


def test_anticipatory_saccades_start_before_the_target_can_be_seen():
    params = quiet(rate_hz=1000.0, anticipation_prob=0.25)
    trace, schedule = jump_trials(params, trials=200)
    early = 0
    for t_jump, new in schedule:
        old = LEFT if new == RIGHT else RIGHT
        window = (trace.t >= t_jump) & (trace.t < t_jump + 1.0)
        t, eye = trace.t[window], trace.eye_xy[window]
        moved = np.argmax(np.hypot(*(eye - old).T) > 1e-6)
        early += t[moved] - t_jump < 0.08
    assert early / len(schedule) == pytest.approx(0.25, abs=0.08)


def test_the_error_varies_over_the_screen_by_the_field_and_is_the_persons_own():
    places = [(x, y) for x in (200.0, 960.0, 1720.0) for y in (150.0, 540.0, 930.0)]
    errors = []
    for seed in (1, 2):
        sim = GazeSimulator(quiet(field_deg=0.6), seed=seed)
        errors.append(np.array([SCREEN.angular_error_deg(
            sim.simulate(0.1, [(0.0, xy)], initial_xy=xy).xy[-1:], xy)[0] for xy in places]))
    for error in errors:
        # Not one offset: the error differs between places by about the field's size.
        assert 0.3 < np.sqrt(np.mean(np.sum((error - error.mean(axis=0)) ** 2, axis=1))) < 1.5
    assert np.abs(errors[0] - errors[1]).max() > 0.2


def test_the_wander_is_slow_and_of_the_requested_rms():
    params = quiet(wander_deg=0.3, wander_tau_s=0.5)
    trace = GazeSimulator(params, seed=3).simulate(300.0, [(0.0, (960, 540))],
                                                   initial_xy=(960, 540))
    error = SCREEN.angular_error_deg(trace.xy, (960, 540))
    np.testing.assert_allclose(np.sqrt(np.mean(error ** 2, axis=0)), 0.3, rtol=0.15)
    lag = int(0.05 * params.tracker.rate_hz)
    near = np.corrcoef(error[:-lag, 0], error[lag:, 0])[0, 1]
    far = np.corrcoef(error[:-10 * lag * 5, 0], error[10 * lag * 5:, 0])[0, 1]
    assert near > 0.85 and abs(far) < 0.2


def test_spikes_are_single_samples_far_from_the_eye():
    params = quiet(spike_prob=0.01, jitter_deg=0.1)
    trace = GazeSimulator(params, seed=4).simulate(200.0, [(0.0, (960, 540))],
                                                   initial_xy=(960, 540))
    error = SCREEN.angle_between_deg(trace.xy, trace.eye_xy)
    assert trace.spike.mean() == pytest.approx(0.01, rel=0.2)
    assert np.all(error[trace.spike] >= 2.0 - 0.5) and np.all(error[~trace.spike] < 1.0)


def test_a_saccade_rings_after_it_lands():
    params = quiet(rate_hz=1000.0, pso_fraction=0.05)
    trace, schedule = jump_trials(params, trials=4)
    t_jump, new = schedule[0]
    window = (trace.t >= t_jump) & (trace.t < t_jump + 1.0)
    beyond = SCREEN.angle_between_deg(trace.eye_xy[window], LEFT) \
        - SCREEN.angle_between_deg(LEFT, new)
    amplitude = SCREEN.angle_between_deg(LEFT, new)
    # The eye passes the target by about 5 % of the amplitude, then comes back onto it.
    assert beyond.max() == pytest.approx(0.05 * amplitude, rel=0.25)
    np.testing.assert_allclose(trace.eye_xy[window][-1], new, atol=1e-6)


def test_a_moving_target_is_pursued_smoothly_with_a_few_catch_up_saccades():
    params = quiet(pursuit_gain=0.9, pursuit_latency_ms=100.0)
    speed_deg = 10.0
    speed_px = speed_deg * px_per_degree()

    def target(t):
        return np.stack([300 + speed_px * t, np.full_like(t, 540.0)], axis=1)

    rate = params.tracker.rate_hz
    trace = GazeSimulator(params, seed=3).trace(np.arange(0, 6, 1 / rate), target,
                                                initial_xy=(300, 540))
    later = trace.t[1:] > 1.0
    eye_speed = SCREEN.angle_between_deg(trace.eye_xy[:-1], trace.eye_xy[1:]) * rate
    smooth = eye_speed[later] < 30.0
    # Mostly smooth, at about the pursuit gain times the target's angular speed ...
    goal = target(trace.t)
    goal_speed = SCREEN.angle_between_deg(goal[:-1], goal[1:]) * rate
    assert smooth.mean() > 0.9
    gain = eye_speed[later][smooth] / goal_speed[later][smooth]
    assert np.median(gain) == pytest.approx(0.9, abs=0.03)
    # ... with catch-up saccades that keep the eye within a few degrees of the target.
    catch_up = np.count_nonzero(np.diff((eye_speed[later] >= 30.0).astype(int)) == 1)
    assert 1 <= catch_up <= 10
    lag = SCREEN.angle_between_deg(trace.eye_xy, target(trace.t))[trace.t > 1.0]
    assert np.median(lag) < 2.0


# Seeds, timing, streaming ----------------------------------------------------

def test_a_seed_reproduces_the_samples_and_another_seed_does_not():
    schedule = [(0.0, LEFT), (1.0, RIGHT)]
    a = GazeSimulator(ORIGINAL_TOBII_4C, seed=11).simulate(5.0, schedule)
    b = GazeSimulator(ORIGINAL_TOBII_4C, seed=11).simulate(5.0, schedule)
    c = GazeSimulator(ORIGINAL_TOBII_4C, seed=12).simulate(5.0, schedule)
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_array_equal(a.xy, b.xy)
    assert not np.array_equal(a.xy, c.xy, equal_nan=True)
    sim = GazeSimulator(ORIGINAL_TOBII_4C, seed=11)
    np.testing.assert_array_equal(sim.samples(a.t, schedule), sim.samples(a.t, schedule))


@pytest.mark.parametrize('params', [ORIGINAL_TOBII_4C, CONSUMER_TRACKER])
def test_sample_times_follow_the_tracker_rate(params):
    t = GazeSimulator(params, seed=0).sample_times(10.0, start_s=100.0)
    rate = params.tracker.rate_hz
    assert len(t) == round(10.0 * rate)
    assert np.all(np.diff(t) > 0)
    assert (len(t) - 1) / (t[-1] - t[0]) == pytest.approx(rate, rel=1e-3)
    assert t[0] == pytest.approx(100.0, abs=0.5 / rate)
    assert ORIGINAL_TOBII_4C.tracker.rate_hz == 87.0 and CONSUMER_TRACKER.tracker.rate_hz == 90.0


def test_streaming_in_chunks_gives_the_same_samples_as_one_batch():
    params = ORIGINAL_TOBII_4C
    schedule = [(0.3, LEFT), (1.7, RIGHT), (2.2, (900.0, 500.0)), (3.1, None), (3.5, LEFT)]
    batch = GazeSimulator(params, seed=9).simulate(6.0, schedule, start_s=0.0)

    streamed = GazeSimulator(params, seed=9)
    streamed.start(0.0)
    rng = np.random.default_rng(0)
    now, pending, chunks = 0.0, list(schedule), []
    while now < 6.5:
        now += rng.uniform(0.001, 0.15)
        while pending and pending[0][0] <= now:
            streamed.set_target(pending[0][1], pending[0][0])
            pending.pop(0)
        chunk = streamed.next_chunk(now)
        assert np.all(chunk.t <= now)
        chunks.append(chunk)
    t = np.concatenate([c.t for c in chunks])
    xy = np.concatenate([c.xy for c in chunks])
    n = len(batch)
    assert len(t) >= n
    np.testing.assert_array_equal(t[:n], batch.t)
    np.testing.assert_array_equal(xy[:n], batch.xy)


# Bad input -------------------------------------------------------------------

@pytest.mark.parametrize('make, message', [
    (lambda: PersonParams(jitter_deg=-0.1), 'jitter_deg'),
    (lambda: PersonParams(latency_ms=100.0), 'latency_ms'),
    (lambda: PersonParams(loss_prob=1.0), 'loss_prob'),
    (lambda: PersonParams(blink_min_ms=300.0, blink_max_ms=100.0), 'blink_min_ms'),
    (lambda: ScreenGeometry(distance_mm=0.0), 'distance_mm'),
    (lambda: TrackerParams(rate_hz=0.0), 'rate_hz'),
    (lambda: CONSUMER_TRACKER.with_changes(colour='red'), 'colour'),
    (lambda: GazeSimulator(CONSUMER_TRACKER, seed=-1), 'seed'),
    (lambda: GazeSimulator(CONSUMER_TRACKER).samples([0.0, 0.2, 0.1], [(0, LEFT)]), 'order'),
    (lambda: GazeSimulator(CONSUMER_TRACKER).samples([0.0], [(1, LEFT), (0, RIGHT)]), 'order'),
    (lambda: GazeSimulator(CONSUMER_TRACKER).samples([0.0], [(0, (1, 2, 3))]), 'target'),
    (lambda: GazeSimulator(CONSUMER_TRACKER).samples([0.0], lambda t: t), 'target'),
])
def test_bad_input_is_rejected_with_a_clear_message(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_with_changes_reaches_person_tracker_and_screen():
    params = CONSUMER_TRACKER.with_changes(offset_deg=1.0, rate_hz=60.0, distance_mm=700.0)
    assert params.person.offset_deg == 1.0
    assert params.tracker.rate_hz == 60.0
    assert params.person.screen.distance_mm == 700.0
    assert CONSUMER_TRACKER.person.offset_deg == 0.5
