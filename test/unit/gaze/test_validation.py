"""Validation, correction fit and the bridge's parameter file, with simulated gaze (no ROS)."""

import math

import numpy as np
import pytest

from eye_bci_ros2.gaze.validation import (apply_correction, correction_values, correction_yaml,
                                          CorrectionRefused, error_model, fit_correction, IDENTITY,
                                          implausibility, load_correction, measure,
                                          samples_per_target, save_correction, target_layout,
                                          validate_and_correct)
from eye_bci_ros2.sim.person import GazeSimulator, IDEAL_EYE, ORIGINAL_TOBII_4C

#: The 0.8 deg person of the original set-up, without drift and with an ideal eye (a constant
#: offset, the same direction for every seed, so a second validation sees the same person
#: with new noise; no error that varies over the screen, no landing errors, no spikes).
PERSON = ORIGINAL_TOBII_4C.with_changes(drift_deg=0.0, offset_direction_deg=30.0, **IDEAL_EYE)
SCREEN = PERSON.person.screen
DWELL_S = 1.5


def run_validation(targets, seed=4, correction=None, params=PERSON):
    """Show each target for DWELL_S; return the samples per target (corrected if given)."""
    onsets = DWELL_S * np.arange(len(targets))
    schedule = [(float(t), tuple(xy)) for t, xy in zip(onsets, targets)]
    trace = GazeSimulator(params, seed=seed).simulate(DWELL_S * len(targets), schedule)
    xy = trace.xy if correction is None else apply_correction(trace.xy, correction)
    return samples_per_target(trace.t, xy, onsets, onsets + DWELL_S, settle_s=0.5)


def test_layouts_have_the_centre_first_and_stay_on_screen():
    five, nine = target_layout(5), target_layout(9)
    assert five.shape == (5, 2) and nine.shape == (9, 2)
    np.testing.assert_allclose(five[0], [960, 540])
    np.testing.assert_allclose(five[1:], [[192, 108], [1728, 108], [192, 972], [1728, 972]])
    assert len({tuple(p) for p in nine}) == 9
    with pytest.raises(ValueError, match='5 or 9'):
        target_layout(7)


def test_samples_after_the_settle_time_only_and_nan_dropped():
    stamps = np.arange(0, 2, 0.1)
    points = np.stack([stamps, stamps], axis=1)
    points[12] = np.nan
    split = samples_per_target(stamps, points, [0.0, 1.0], [1.0, 2.0], settle_s=0.5)
    np.testing.assert_allclose(split[0][:, 0], [0.5, 0.6, 0.7, 0.8, 0.9])
    np.testing.assert_allclose(split[1][:, 0], [1.5, 1.6, 1.7, 1.8, 1.9])


def test_measure_reports_the_simulated_offset_and_jitter_in_degrees():
    targets = target_layout(9)
    report = measure(targets, run_validation(targets), SCREEN)
    assert report.accuracy_deg == pytest.approx(0.8, abs=0.1)
    # Successive samples differ by sqrt(2) x 0.3 deg per axis: RMS over both axes 0.6 deg.
    assert report.precision_deg == pytest.approx(0.6, abs=0.08)
    assert report.accuracy_px == pytest.approx(0.8 * SCREEN.px_per_degree(), rel=0.2)
    assert not report.missing
    assert len(report.lines()) == 10


@pytest.mark.parametrize('kind', ['auto', 'affine', 'quadratic'])
def test_a_nine_target_correction_leaves_at_most_a_fifth_of_a_degree(kind):
    targets = target_layout(9)
    fit = fit_correction(targets, run_validation(targets), kind=kind, screen=SCREEN)
    # The person's error is one offset: the held-out errors choose the simplest fit.
    assert fit.kind == ('offset' if kind == 'auto' else kind)
    assert fit.residual_before_deg == pytest.approx(0.8, abs=0.1)
    # Validate again later, with the correction applied as the bridge applies it.
    again = measure(targets, run_validation(targets, seed=5, correction=fit.values),
                    SCREEN)
    assert again.accuracy_deg <= 0.2


def test_offset_correction_from_five_targets():
    targets = target_layout(5)
    fit = fit_correction(targets, run_validation(targets), screen=SCREEN)
    assert fit.kind == 'offset'
    np.testing.assert_allclose(fit.matrix[:, :2], np.eye(2))
    again = measure(targets, run_validation(targets, seed=5, correction=fit.matrix),
                    SCREEN)
    assert again.accuracy_deg <= 0.2


def test_refused_when_a_target_got_no_gaze():
    targets = target_layout(5)
    samples = run_validation(targets)
    samples[3] = samples[3][:0]
    with pytest.raises(CorrectionRefused, match='target.*4'):
        fit_correction(targets, samples, screen=SCREEN)
    report, fit, reason = validate_and_correct(targets, samples, SCREEN)
    assert fit is None and 'fewer than' in reason and report.missing == [3]


def test_refused_when_affine_needs_more_targets():
    targets = target_layout(5)
    with pytest.raises(CorrectionRefused, match='at least 6'):
        fit_correction(targets, run_validation(targets), kind='affine', screen=SCREEN)


def test_refused_when_the_fit_is_implausible():
    targets = target_layout(9)
    # Gaze that shrinks the screen by half around the centre: not a calibration drift.
    squeezed = [np.repeat([[960 + (x - 960) * 0.5, 540 + (y - 540) * 0.5]], 20, axis=0)
                for x, y in targets]
    with pytest.raises(CorrectionRefused, match='scales'):
        fit_correction(targets, squeezed, screen=SCREEN)


def test_refused_when_it_would_not_help():
    targets = target_layout(5)
    exact = [np.repeat([t], 20, axis=0) for t in targets]
    with pytest.raises(CorrectionRefused, match='not reduce'):
        fit_correction(targets, exact, screen=SCREEN)


def test_apply_correction_identity_nan_and_bad_values():
    xy = np.array([[10.0, 20.0], [np.nan, 5.0]])
    # A sample with a NaN coordinate is lost: it comes out all NaN.
    np.testing.assert_array_equal(apply_correction(xy, IDENTITY), [[10, 20], [np.nan, np.nan]])
    np.testing.assert_allclose(apply_correction(xy[:1], [1, 0, 5, 0, 1, -3]), [[15, 17]])
    with pytest.raises(ValueError, match='6 finite numbers'):
        apply_correction(xy, [1, 0, 0])
    with pytest.raises(ValueError, match='or 12'):
        apply_correction(xy, [1, 0, 0, 0, 1, 0, 0, 0, math.inf, 0, 0, 0])
    assert implausibility(IDENTITY) == ''
    assert 'mirrors' in implausibility([-1, 0, 1920, 0, 1, 0])
    assert 'moves the gaze' in implausibility([1, 0, 800, 0, 1, 0])


@pytest.mark.parametrize('values', [
    [1.01, 0.0, -12.5, 0.002, 0.99, 7.25],
    # A second-order correction: the affine 6, then the x^2, x*y, y^2 terms of x and of y.
    [1.01, 0.0, -12.5, 0.002, 0.99, 7.25, 2.5e-06, -1.25e-06, 0.0, 0.0, 3.0e-07, -4.5e-06]])
def test_parameter_file_round_trip(tmp_path, values):
    text = correction_yaml(values)
    assert text.startswith('/lsl_gaze_bridge:\n  ros__parameters:\n    gaze_correction:')
    path = save_correction(str(tmp_path / 'gaze_correction.yaml'), values)
    assert correction_values(load_correction(path)) == values
    (tmp_path / 'bad.yaml').write_text('just text\n')
    with pytest.raises(ValueError, match='parameter file'):
        load_correction(str(tmp_path / 'bad.yaml'))


def test_error_model_for_the_tolerant_rule_from_a_validation():
    targets = target_layout(9)
    model = error_model(measure(targets, run_validation(targets), SCREEN))
    assert model.accuracy_deg == pytest.approx(0.8, abs=0.1)
    assert model.precision_deg == pytest.approx(0.3, abs=0.05)
    empty = measure(targets, [np.zeros((0, 2))] * 9, SCREEN)
    with pytest.raises(ValueError, match='no target had gaze'):
        error_model(empty)
