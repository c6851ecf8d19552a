"""
Which correction a validation fits: offset, affine or second-order, chosen by held-out targets.

Simulated gaze (no ROS): the person of :mod:`test_validation` without an
offset, seen through a tracker whose error bends over the screen, and the
real 9-point recordings when ``../shared/data/real_gaze`` is there.
"""

import numpy as np
import pytest

from bench import correction_fit
from eye_bci_ros2.gaze.validation import (apply_correction, choose_kind, compose_corrections,
                                          correction_values, CorrectionRefused, fit_correction,
                                          implausibility, measure, samples_per_target,
                                          target_layout)
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.sim.person import GazeSimulator, IDEAL_EYE, ORIGINAL_TOBII_4C

#: A person who looks where asked (0.3 deg jitter; no offset, drift, landing errors or spikes).
PERSON = ORIGINAL_TOBII_4C.with_changes(drift_deg=0.0, offset_deg=0.0, **IDEAL_EYE)
SCREEN = PERSON.person.screen
DWELL_S = 1.5


def bend(xy, size_px, centre, half_span):
    """
    Return gaze bent by a tracker error that grows with the square of the distance from centre.

    ``size_px`` in x (half that in y) at the outer targets (``half_span`` px from ``centre``),
    0 at the centre: an error no single offset or affine map removes.
    """
    u = (np.asarray(xy) - centre) / half_span
    return xy + size_px * np.stack([u[..., 0] ** 2, 0.5 * u[..., 1] ** 2], axis=-1)


def run_validation(targets, seed, distort, correction=None):
    """Show each target for DWELL_S to the tracker ``distort``; return the samples per target."""
    onsets = DWELL_S * np.arange(len(targets))
    schedule = [(float(t), tuple(xy)) for t, xy in zip(onsets, targets)]
    trace = GazeSimulator(PERSON, seed=seed).simulate(DWELL_S * len(targets), schedule)
    xy = distort(trace.xy)
    if correction is not None:
        xy = apply_correction(xy, correction)
    return samples_per_target(trace.t, xy, onsets, onsets + DWELL_S, settle_s=0.5)


def layout_bend(size_px):
    """Return the node's 9-target layout (outer targets at 10 % of the screen) and a bend."""
    targets = target_layout(9, SCREEN.width_px, SCREEN.height_px)
    half_span = np.abs(targets - SCREEN.centre_px).max(axis=0)
    return targets, lambda xy: bend(xy, size_px, SCREEN.centre_px, half_span)


def test_an_error_that_varies_over_the_screen_gets_a_second_order_fit():
    targets, distort = layout_bend(30.0)
    fit = fit_correction(targets, run_validation(targets, 4, distort), screen=SCREEN)
    assert fit.kind == 'quadratic' and fit.note == ''
    assert len(fit.values) == 12
    # The data chose it: at targets left out of the fit it beats the simpler kinds.
    assert fit.candidates['quadratic'] < min(fit.candidates['offset'],
                                             fit.candidates['affine'])
    # Validate again later (new noise) with the correction applied as the bridge applies it.
    again = measure(targets, run_validation(targets, 5, distort, fit.values), SCREEN)
    affine = fit_correction(targets, run_validation(targets, 4, distort), 'affine', SCREEN)
    with_affine = measure(targets, run_validation(targets, 5, distort, affine.values), SCREEN)
    assert again.accuracy_deg <= 0.2 < with_affine.accuracy_deg


def test_a_second_order_fit_that_extrapolates_badly_falls_back_with_a_reason():
    # Targets over the middle half of the screen only (as the ETDQualitizer layout): a bend
    # that a second-order map follows there turns it into a fold near the screen corners.
    centre, half_span = SCREEN.centre_px, SCREEN.size_px / 4
    targets = centre + half_span * np.array([[x, y] for y in (-1, 0, 1) for x in (-1, 0, 1)])
    samples = run_validation(targets, 4, lambda xy: bend(xy, 30.0, centre, half_span))
    fit = fit_correction(targets, samples, screen=SCREEN)
    assert fit.kind in ('offset', 'affine')
    assert fit.note.startswith('quadratic fit refused: the correction')
    assert fit.candidates['quadratic'] < fit.candidates[fit.kind]
    with pytest.raises(CorrectionRefused, match='scales the gaze'):
        fit_correction(targets, samples, 'quadratic', SCREEN)


def test_five_targets_cannot_have_a_second_order_fit():
    targets, distort = layout_bend(30.0)
    five = target_layout(5, SCREEN.width_px, SCREEN.height_px)
    with pytest.raises(CorrectionRefused, match='at least 9'):
        fit_correction(five, run_validation(five, 4, distort), 'quadratic', SCREEN)


def test_the_simplest_kind_within_one_standard_error_of_the_best_is_chosen():
    spread = np.array([-0.1, 0.1] * 4 + [0.0])       # standard error 0.035 deg
    assert choose_kind({'offset': 0.5 + spread, 'affine': 0.3 + spread,
                        'quadratic': 0.28 + spread}) == 'affine'
    assert choose_kind({'offset': 0.5 + spread, 'affine': 0.45 + spread,
                        'quadratic': 0.3 + spread}) == 'quadratic'
    assert choose_kind({'offset': 0.31 + spread, 'affine': 0.3 + spread}) == 'offset'


def test_second_order_corrections_compose_with_the_bridges_current_one():
    affine = [1.01, 0.002, -15.0, -0.001, 0.99, 8.0]
    second = [1.0, 0.0, 3.0, 0.0, 1.0, -2.0, 2e-6, -1e-6, 0.0, 1e-6, 0.0, -3e-6]
    grid = np.stack(np.meshgrid(np.linspace(0, 1920, 7), np.linspace(0, 1080, 5)),
                    axis=-1).reshape(-1, 2)
    for outer, inner, tolerance_px in ((second, affine, 1e-6), (affine, second, 1e-6),
                                       (second, second, 0.05)):
        total = compose_corrections(outer, inner, SCREEN)
        np.testing.assert_allclose(apply_correction(grid, total),
                                   apply_correction(apply_correction(grid, inner), outer),
                                   atol=tolerance_px)
    # Affine after affine stays the 6-number parameter.
    assert len(correction_values(compose_corrections(affine, affine))) == 6


def test_a_second_order_correction_that_folds_or_bends_far_is_implausible():
    assert implausibility([1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0], SCREEN) == ''
    # x' = x - 6e-4 x^2 turns back at x = 833 px: a fold inside the screen.
    assert 'mirrors or flattens' in implausibility([1, 0, 0, 0, 1, 0, -6e-4, 0, 0, 0, 0, 0],
                                                   SCREEN)
    # A gentle bend whose pull reaches 0.3 x the distance at the right edge.
    assert 'scales' in implausibility([1, 0, 0, 0, 1, 0, 8e-5, 0, 0, 0, 0, 0], SCREEN)


REAL_GAZE = find_data('real_gaze')


@pytest.mark.skipif(REAL_GAZE is None, reason='no real_gaze recordings (../shared/data beside '
                    'the repository, or EYE_BCI_DATA)')
def test_on_real_validation_recordings_the_fit_chosen_helps_where_it_was_not_fitted():
    section = correction_fit.run(data=str(REAL_GAZE))
    print('\n' + '\n'.join(correction_fit.format_lines(section)))   # the figures, with -s
    assert len(section) >= 3, 'expected the 9-point validation recordings'
    for name, row in section.items():
        if row['auto'] == 'refused':
            assert row['reason'].startswith('no correction:'), name
            continue
        # Better than no correction, and never worse than an offset, at held-out targets.
        assert row['auto_deg'] < row['before_deg'], name
        assert row['auto_deg'] <= row['offset_deg'], name
