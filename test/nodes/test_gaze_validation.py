"""gaze_validation through the real nodes: simulated person -> LSL -> bridge -> validation."""

import json
import os
import shutil
import tempfile

from geometry_msgs.msg import PointStamped
import numpy as np
import pytest
from validation_rig import camera_pose, make_rig, VIEW

from eye_bci_ros2.gaze.validation import correction_values, load_correction, ValidationOutcome
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.projection.camera_model import RvizCamera
from eye_bci_ros2.ros.conversions import pose_to_arrays
from eye_bci_ros2.ros.topics import LATCHED_QOS, VALIDATION_TARGET_TOPIC
from eye_bci_ros2.sim.person import IDEAL_EYE, ORIGINAL_TOBII_4C

pytestmark = [pytest.mark.ros, pytest.mark.lsl, pytest.mark.slow]

#: The issue's goal: the 0.8 deg person's residual after validation + correction.
GOAL_DEG = 0.2
#: Its offset (and jitter) without the preset's drift, which changes between the passes and
#: which no one-time correction removes (bench/validation.py reports both), and with an ideal
#: eye: no error varying over the screen (an offset correction cannot remove it), no landing
#: errors, no spikes.
OFFSET_PERSON = ORIGINAL_TOBII_4C.with_changes(drift_deg=0.0, **IDEAL_EYE)
SHIFT = [1.0, 0.0, 6.0, 0.0, 1.0, -4.0]


@pytest.fixture
def rigs():
    """Make validation set-ups, each with a running outlet; the outlets stop after the test."""
    made = []

    def make(graph, **kwargs):
        rig = make_rig(graph, **kwargs)
        made.append(rig)
        return rig

    yield make
    for rig in made:
        rig.streamer.stop()


def finished(graph, node, timeout=60.0):
    """Spin until the validation ended; return its outcome."""
    assert graph.spin_until(lambda: node.exit_status is not None, timeout), 'never finished'
    return node.outcome


def test_accepted_correction_brings_the_08_deg_offset_within_02_deg(graph, rigs, tmp_path):
    rig = rigs(graph, person=OFFSET_PERSON)
    arbiter = graph.add(ChoiceArbiter)
    assert arbiter.settings.accuracy_deg == 0.8        # the default error model
    output = str(tmp_path / 'correction.yaml')
    node = rig.start_validation(graph, output=output)
    outcome = finished(graph, node)
    print(outcome.summary())
    assert outcome.accepted, outcome.reason
    assert node.exit_status == 0
    # One offset everywhere: at targets left out of the fit, the simplest fit does best.
    assert outcome.kind == 'offset' and outcome.targets == 9
    assert outcome.held_out_deg < 0.3 and outcome.note == ''
    assert 0.5 < outcome.accuracy_deg < 1.1           # the person's 0.8 deg, measured
    assert outcome.residual_deg <= GOAL_DEG
    # Applied to the bridge, saved for --params-file, published as one JSON line.
    np.testing.assert_allclose(correction_values(rig.bridge.correction), outcome.correction)
    np.testing.assert_allclose(correction_values(load_correction(output)), outcome.correction)
    assert graph.spin_until(lambda: rig.results.messages, 5.0)
    published = ValidationOutcome.from_json(rig.results.last.data)
    assert published.accepted and published.residual_deg == pytest.approx(outcome.residual_deg)
    assert 'residual accuracy' in json.loads(rig.results.last.data)['summary']
    # The arbiter's tolerant rule now models the corrected tracker (set through its service).
    assert graph.spin_until(lambda: arbiter.settings.accuracy_deg < 0.8, 5.0)
    assert arbiter.settings.accuracy_deg == pytest.approx(outcome.residual_deg, abs=1e-6)
    assert 0.0 < arbiter.settings.precision_deg < 1.0


def test_targets_are_shown_in_front_of_the_camera_at_their_screen_points(graph, rigs):
    rig = rigs(graph)
    shown = []
    probe = graph.node('target_probe')
    probe.create_subscription(PointStamped, VALIDATION_TARGET_TOPIC, shown.append, LATCHED_QOS)
    node = rig.start_validation(graph, targets=5, target_s=0.5, settle_s=0.2, output='',
                                validate_again=False)
    finished(graph, node)
    camera = RvizCamera.from_pose(*pose_to_arrays(camera_pose().pose),
                                  screen_offset=(320.0, 180.0))
    points = [(m.point.x, m.point.y) for m in shown if np.isfinite(m.point.x)]
    arrays = [a for a in rig.markers.messages if len(a.markers) > 1]
    assert len(points) == 5 and len(arrays) >= 5
    assert np.isnan(shown[-1].point.x)                 # nothing to look at afterwards
    assert len(rig.markers.last.markers) == 1          # only the DELETEALL: gone from RViz
    for point, array in zip(points, arrays):
        disc, dot = array.markers[1:]
        assert (disc.type, disc.header.frame_id, disc.ns) == (disc.SPHERE, 'map', 'validation')
        for marker in (disc, dot):
            uv, depth = camera.project([pose_to_arrays(marker.pose)[0]])
            np.testing.assert_allclose(camera.to_screen(uv)[0], point, atol=1e-6)
            assert depth[0] > 0
        assert dot.scale.x < disc.scale.x
    # The centre target is the panel centre: the focus of the view, 2 m from the eye.
    np.testing.assert_allclose(points[0], (960.0, 540.0))
    centre = pose_to_arrays(arrays[0].markers[1].pose)[0]
    eye, focus = np.array(VIEW[0]), np.array(VIEW[1])
    np.testing.assert_allclose(centre, eye + 2.0 * (focus - eye) / np.linalg.norm(focus - eye),
                               atol=1e-9)


def test_a_target_without_gaze_refuses_and_leaves_the_bridge_unchanged(graph, rigs, tmp_path):
    rig = rigs(graph, follow=False, bridge_params={'gaze_correction': SHIFT})
    # The person looks at every target but the third, where they look away from the screen.
    seen = []

    def look(message):
        seen.append(message)
        xy = (message.point.x, message.point.y)
        if not np.isfinite(xy[0]):
            return
        count = sum(np.isfinite(m.point.x) for m in seen)
        rig.streamer.set_target((-2000.0, 540.0) if count == 3 else xy)

    graph.node('person').create_subscription(PointStamped, VALIDATION_TARGET_TOPIC, look,
                                             LATCHED_QOS)
    output = str(tmp_path / 'correction.yaml')
    node = rig.start_validation(graph, targets=5, target_s=1.0, output=output)
    outcome = finished(graph, node)
    assert not outcome.accepted and node.exit_status == 1
    assert 'target(s) 3 got fewer than' in outcome.reason and '\n' not in outcome.reason
    np.testing.assert_allclose(correction_values(rig.bridge.correction), SHIFT)
    assert graph.get_parameters('/lsl_gaze_bridge', ['gaze_correction']) == [SHIFT]
    assert not os.path.exists(output)
    assert graph.spin_until(lambda: rig.results.messages, 5.0)
    published = ValidationOutcome.from_json(rig.results.last.data)
    assert not published.accepted and published.reason == outcome.reason
    assert published.correction == SHIFT


def test_on_request_answers_each_start_and_keeps_running(graph, rigs):
    from std_msgs.msg import Empty

    from eye_bci_ros2.ros.topics import EVENT_QOS, VALIDATION_START_TOPIC
    rig = rigs(graph)
    node = rig.start_validation(graph, on_request=True, targets=5, target_s=0.8, settle_s=0.4,
                                output='', validate_again=False)
    graph.spin_for(0.5)
    assert not node.running and not rig.results.messages
    start = graph.node('starter').create_publisher(Empty, VALIDATION_START_TOPIC, EVENT_QOS)
    assert graph.spin_until(lambda: start.get_subscription_count() > 0, 5.0)
    start.publish(Empty())
    assert graph.spin_until(lambda: rig.results.messages, 30.0)
    assert ValidationOutcome.from_json(rig.results.last.data).accepted
    assert graph.spin_until(lambda: not node.running, 5.0)
    assert node.exit_status is None
    start.publish(Empty())                              # and again
    assert graph.spin_until(lambda: len(rig.results.messages) == 2, 30.0)


def targets_shown(graph):
    """Return the screen points gaze_validation shows, as they come (a list that grows)."""
    shown = []
    graph.node('target_watch').create_subscription(
        PointStamped, VALIDATION_TARGET_TOPIC,
        lambda m: shown.append(m) if np.isfinite(m.point.x) else None, LATCHED_QOS)
    return shown


def test_an_output_that_cannot_be_written_is_refused_before_the_first_target(
        graph, rigs, tmp_path):
    # Issue 39: the person looked at all 9 targets, then the result was lost.
    rig = rigs(graph, bridge_params={'gaze_correction': SHIFT})
    shown = targets_shown(graph)
    output = tmp_path / 'nonexistent_dir' / 'gc.yaml'
    node = rig.start_validation(graph, targets=5, output=str(output))
    outcome = finished(graph, node, timeout=20.0)
    assert not outcome.accepted and node.exit_status == 1
    assert outcome.reason.startswith(f"cannot write '{output}': No such file or directory")
    assert '\n' not in outcome.reason
    graph.spin_for(0.3)
    assert shown == []                                   # not one target shown
    np.testing.assert_allclose(correction_values(rig.bridge.correction), SHIFT)


def test_an_output_that_fails_at_the_end_keeps_the_correction_in_a_named_file(
        graph, rigs, tmp_path, monkeypatch):
    spare = tmp_path / 'tmp'
    spare.mkdir()
    monkeypatch.setattr(tempfile, 'tempdir', str(spare))  # where fallback files go
    session = tmp_path / 'session'
    session.mkdir()
    output = session / 'gc.yaml'
    rig = rigs(graph, person=OFFSET_PERSON)
    shown = targets_shown(graph)
    node = rig.start_validation(graph, targets=5, output=str(output), validate_again=False)
    # The directory goes away while the person looks at the targets (a stick pulled out).
    assert graph.spin_until(lambda: shown, 20.0)
    shutil.rmtree(session)
    outcome = finished(graph, node)
    assert outcome.accepted and node.exit_status == 0, outcome.reason
    assert os.path.dirname(outcome.output) == str(spare)
    assert os.path.basename(outcome.output).startswith('gaze_validation-')
    np.testing.assert_allclose(correction_values(load_correction(outcome.output)),
                               outcome.correction)
    np.testing.assert_allclose(correction_values(rig.bridge.correction), outcome.correction)
    assert f'saved to {outcome.output}' in outcome.summary()
