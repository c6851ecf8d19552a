"""
LabRecorder's XDF of a session: each choice lies on the gaze sample it was made on.

The real LabRecorder records the tracker's gaze and the session's markers while the
real nodes choose; pyxdf loads the file as a lab does.
"""

from lsl_outlets import unique_id
from marker_rig import ChoosingRig, MarkerInlet, OPTIONS
import numpy as np
import pylsl
import pytest

from eye_bci_ros2.gaze.profiles import PROFILES
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING
from eye_bci_ros2.recordings.lab_recorder import LabRecording, select_session_streams
from eye_bci_ros2.recordings.session_markers import parse_marker
from eye_bci_ros2.sim.eeg import EegSimulator, SUBJECTS
from eye_bci_ros2.sim.eeg_outlet import EegStreamer

pyxdf = pytest.importorskip('pyxdf')
pytest.importorskip('labrecorder')
pytestmark = [pytest.mark.ros, pytest.mark.lsl]


def stream_of(streams, kind):
    found = [s for s in streams if s['info']['type'][0] == kind]
    assert len(found) == 1, [s['info']['type'][0] for s in streams]
    return found[0]


def test_each_choice_in_the_xdf_lies_within_a_sample_of_its_gaze(graph, tmp_path):
    rig = ChoosingRig(graph, rate_hz=600.0)
    # The amplifier: simulated EEG on a real LSL outlet.
    amplifier = EegStreamer(EegSimulator(SUBJECTS[0], seed=1), source_id=unique_id('amp'))
    amplifier.start()
    eeg_info, = pylsl.resolve_byprop('source_id', amplifier.info.source_id(), 1, 10.0)
    # The session's streams as the module picks them (the rig's namespace, this tracker).
    inlet = MarkerInlet(rig.markers_node.source_id)     # resolves the marker stream
    streams = select_session_streams([rig.gaze_info, eeg_info, inlet.info],
                                     rig.namespace, gaze_source_id=rig.gaze_info.source_id(),
                                     eeg_source_id=amplifier.info.source_id())
    assert [s.type() for s in streams] == ['Gaze', 'EEG', 'Markers']
    asked = ['right', 'left', 'right', 'left']
    path = tmp_path / 'session.xdf'
    recording = LabRecording(path, streams)
    try:
        rig.offer()
        rig.start()
        for index, label in enumerate(asked):
            rig.ask(label)
            inlet.wait(graph, 'choice', index + 1)
        graph.spin_for(0.5)
    finally:
        rig.close()
        recording.stop()
        amplifier.stop()
        inlet.close()

    # As a lab loads it: pyxdf's defaults (clock offsets applied, stamps de-jittered).
    loaded, _ = pyxdf.load_xdf(str(path))
    gaze, markers = stream_of(loaded, 'Gaze'), stream_of(loaded, 'Markers')
    eeg = stream_of(loaded, 'EEG')['time_stamps']
    assert markers['info']['name'][0] == f'eye_bci_markers {rig.namespace}'
    events = [parse_marker(text[0]) for text in markers['time_series']]
    choices = [(body, stamp) for body, stamp in zip(events, markers['time_stamps'])
               if body['event'] == 'choice']
    assert [body['label'] for body, _ in choices] == asked
    assert sum(body['event'] == 'question' for body in events) >= len(asked)
    period = 1.0 / rig.rate_hz
    # The tracker's px (xy_pixels: a 1366 x 768 sender screen) on the person's screen.
    layout = PROFILES['xy_pixels']
    scale = np.array([DEFAULT_VIEWING.width_px / layout.source_width,
                      DEFAULT_VIEWING.height_px / layout.source_height])
    times, xy = gaze['time_stamps'], np.asarray(gaze['time_series'], dtype=float) * scale
    errors = []
    for body, stamp in choices:
        nearest = int(np.argmin(np.abs(times - stamp)))
        errors.append(abs(times[nearest] - stamp))
        # The gaze sample it lies on is on the chosen option (the gaze that made it).
        cx, cy = OPTIONS[body['label']]
        assert abs(xy[nearest, 0] - cx) < 100 and abs(xy[nearest, 1] - cy) < 100
    print(f'choice marker to its gaze sample in the XDF: max {max(errors) * 1e3:.3f} ms, '
          f'one sample = {period * 1e3:.3f} ms')
    assert max(errors) < period
    # The EEG of the same session spans every choice (one clock for all three streams).
    assert all(eeg[0] < stamp < eeg[-1] for _, stamp in choices)
