"""Pure parts of the validation procedure: unproject, composed corrections, outcome, menu step."""

import json
import math

import numpy as np
import pytest

from eye_bci_ros2.gaze.profiles import build_config, convert, resolve_mapping
from eye_bci_ros2.gaze.validation import (apply_correction, compose_corrections, correction_values,
                                          IDENTITY, is_identity, ValidationOutcome)
from eye_bci_ros2.projection.camera_model import OrthographicCamera, RvizCamera
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.task.menu import (Log, MenuProtocol, Offer, ProtocolSettings, Request, Validate,
                                    VALIDATING, WAITING_FOR_CAMERA)
from eye_bci_ros2.task.scene import load_scene

PIXELS = np.array([[0.0, 0.0], [640.0, 360.0], [1279.0, 719.0], [100.5, 650.25]])
DEPTHS = np.array([0.5, 2.0, 7.5, 30.0])
CAMERAS = {
    'perspective': RvizCamera.from_look_at([3.0, -2.0, 4.0], [0.0, 0.5, 0.0], [0.0, 0.0, 1.0]),
    'calibrated': RvizCamera(
        [[900.0, 2.0, 630.0, 0.0], [0.0, 880.0, 370.0, 0.0], [0.0, 0.0, 1.0, 0.0]],
        external=RvizCamera.from_look_at([1.0, 1.0, 3.0], [0.0, 0.0, 0.0],
                                         [0.0, 0.0, 1.0]).external),
    'orthographic': OrthographicCamera.top_down(1.5, -2.0, 0.4, 35.0),
}


@pytest.mark.parametrize('name', sorted(CAMERAS))
def test_unproject_is_the_inverse_of_project(name):
    camera = CAMERAS[name]
    points = camera.unproject(PIXELS, DEPTHS)
    uv, depth = camera.project(points)
    np.testing.assert_allclose(uv, PIXELS, atol=1e-7)
    np.testing.assert_allclose(depth, DEPTHS, rtol=1e-10)
    # And the other way round: world points in front of the camera come back.
    again = camera.unproject(uv, depth)
    np.testing.assert_allclose(again, points, atol=1e-9)


def test_unproject_at_the_principal_point_lies_on_the_optical_axis():
    camera = CAMERAS['perspective']
    point, = camera.unproject([[640.0, 360.0]], 2.0)
    axis = camera.external[2, :3]
    np.testing.assert_allclose(point, camera.eye + 2.0 * axis, atol=1e-12)


@pytest.mark.parametrize('depth', [0.0, -1.0, math.nan])
def test_unproject_refuses_depths_not_in_front(depth):
    with pytest.raises(ValueError, match='depths > 0'):
        CAMERAS['perspective'].unproject([[1.0, 2.0]], depth)


def test_composed_correction_applies_inner_then_outer():
    inner = [1.01, 0.002, -15.0, -0.001, 0.99, 8.0]
    outer = [0.995, 0.0, 4.0, 0.003, 1.004, -2.5]
    points = np.array([[0.0, 0.0], [960.0, 540.0], [1900.0, 30.0]])
    np.testing.assert_allclose(
        apply_correction(points, compose_corrections(outer, inner)),
        apply_correction(apply_correction(points, inner), outer), atol=1e-9)
    np.testing.assert_allclose(correction_values(compose_corrections(outer, IDENTITY)), outer)
    assert is_identity(IDENTITY) and is_identity(np.reshape(IDENTITY, (2, 3)))
    assert not is_identity(inner)


def test_the_bridge_conversion_applies_the_correction_after_scaling_and_before_the_margin():
    config = build_config({'profile': 'xy_pixels', 'offscreen_margin_px': 105.0})
    mapping = resolve_mapping(config, ['x', 'y'], 2)
    shift = np.array([[1.0, 0.0, 10.0], [0.0, 1.0, -5.0]])
    samples = np.array([[683.0, 384.0], [np.nan, 10.0], [-80.0, 384.0]])  # 3rd: -112 px
    plain = convert(samples, mapping)
    corrected = convert(samples, mapping, shift)
    np.testing.assert_allclose(plain.xy, [[960.0, 540.0]])
    np.testing.assert_allclose(corrected.xy, [[970.0, 535.0], [-80.0 * 1920 / 1366 + 10.0, 535.0]])
    assert corrected.dropped['nonfinite'] == 1 and plain.dropped['offscreen'] == 1


def test_an_outcome_is_one_json_line_that_reads_back():
    refused = ValidationOutcome(False, 'no correction: target(s) 3 got fewer than 10 gaze '
                                'samples', targets=5, accuracy_deg=0.8, precision_deg=0.6)
    text = refused.to_json()
    assert '\n' not in text and json.loads(text)['residual_deg'] is None
    back = ValidationOutcome.from_json(text)
    assert not back.accepted and back.reason == refused.reason and math.isnan(back.residual_deg)
    assert back.summary() == refused.summary() and 'refused' in back.summary()
    accepted = ValidationOutcome(True, kind='affine', targets=9, accuracy_deg=0.8,
                                 precision_deg=0.6, residual_deg=0.1, residual_px=4.0,
                                 correction=[1.0, 0.0, 3.0, 0.0, 1.0, -2.0], output='c.yaml')
    back = ValidationOutcome.from_json(accepted.to_json())
    assert back == accepted
    assert 'residual accuracy 0.10 deg' in back.summary() and 'c.yaml' in back.summary()


@pytest.mark.parametrize('text', ['', 'accepted', '[1, 2]', '{"accepted": "yes"}',
                                  '{"accepted": true, "targets": 9, "bogus": {"a": 1}, '
                                  '"kind": 3, "extra": [1]} x'])
def test_anything_else_is_not_an_outcome(text):
    with pytest.raises(ValueError, match='not a validation result'):
        ValidationOutcome.from_json(text)


# -- the menu's validation step --------------------------------------------------------------

SCENE = load_scene(default_scene_path())


def kinds(actions, kind):
    return [a for a in actions if isinstance(a, kind)]


def test_validate_first_offers_the_rooms_only_after_an_accepted_validation():
    menu = MenuProtocol(SCENE, ProtocolSettings(validate_first=True))
    actions = menu.start(0.0)
    assert kinds(actions, Validate) and not kinds(actions, Offer)
    assert menu.state == VALIDATING and menu.options == ()
    assert not kinds(menu.tick(5.0), Request)
    assert 'validating' in kinds(menu.on_choice('kitchen', 5.0), Log)[0].text
    actions = menu.on_validation(True, 'validation accepted: ...', 6.0)
    assert kinds(actions, Offer) and not kinds(actions, Validate)
    assert menu.state == WAITING_FOR_CAMERA
    # A scene reload starts over at the rooms without validating again.
    assert not kinds(menu.start(7.0), Validate)


def test_a_refused_validation_is_run_again_then_the_menu_goes_on():
    menu = MenuProtocol(SCENE, ProtocolSettings(validate_first=True, validation_retries=2))
    menu.start(0.0)
    for run in (2, 3):
        actions = menu.on_validation(False, 'validation refused: no gaze', float(run))
        assert kinds(actions, Validate) and not kinds(actions, Offer)
        assert f'run {run} of 3' in kinds(actions, Log)[0].text
    actions = menu.on_validation(False, 'validation refused: no gaze', 4.0)
    assert kinds(actions, Offer) and not kinds(actions, Validate)
    assert 'going on with the gaze correction as it was' in kinds(actions, Log)[0].text
    assert kinds(menu.on_validation(True, 'late', 5.0), Log)[0].text.startswith(
        'validation result not asked for')


def test_without_validate_first_nothing_changes():
    menu = MenuProtocol(SCENE)
    assert kinds(menu.start(0.0), Offer) and not kinds(menu.start(0.0), Validate)
    assert kinds(menu.on_validation(True, 'x', 1.0), Log)
    with pytest.raises(ValueError, match='validation_retries'):
        ProtocolSettings(validation_retries=-1)
