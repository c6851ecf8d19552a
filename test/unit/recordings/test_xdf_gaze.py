"""Gaze from LabRecorder's XDF files: a small file written here, read by recordings.xdf."""

from pathlib import Path
import struct
from typing import List, Sequence
from xml.sax.saxutils import escape

import numpy as np
import pytest

from eye_bci_ros2.projection.visual_angle import ScreenGeometry
from eye_bci_ros2.recordings.gaze import load_gaze, RecordingError
from eye_bci_ros2.recordings.xdf import load_xdf_gaze
from eye_bci_ros2.sim.tracker_layout import encode

#: Where the person looked, screen px (1920x1080), one row per sample; NaN = lost.
POINTS = np.array([[960.0, 540.0], [100.0, 50.0], [np.nan, np.nan], [1800.0, 1000.0],
                   [500.0, 700.0]])
#: Each sample's LSL stamp, s: a 60 Hz tracker with some jitter, far from 0.
STAMPS = 5000.0 + np.array([0.0, 0.0168, 0.0332, 0.0501, 0.0667])


def chunk(tag: int, content: bytes) -> bytes:
    """Make one XDF chunk: [NumLengthBytes=4][Length][Tag][Content]."""
    return b'\x04' + struct.pack('<I', len(content) + 2) + struct.pack('<H', tag) + content


def stream_header(stream_id: int, name: str, stream_type: str, labels: Sequence[str],
                  channel_format: str, rate: float) -> bytes:
    """Make a StreamHeader chunk as LabRecorder writes it (the fields pyxdf reads)."""
    channels = ''.join(f'<channel><label>{escape(label)}</label></channel>' for label in labels)
    xml = (f'<?xml version="1.0"?><info><name>{escape(name)}</name><type>{escape(stream_type)}'
           f'</type><channel_count>{len(labels)}</channel_count><nominal_srate>{rate}'
           f'</nominal_srate><channel_format>{channel_format}</channel_format><source_id>'
           f'{escape(name)}-1</source_id><desc><channels>{channels}</channels></desc></info>')
    return chunk(2, struct.pack('<I', stream_id) + xml.encode())


def numeric_samples(stream_id: int, stamps: np.ndarray, values: np.ndarray,
                    dtype: str) -> bytes:
    """Make a Samples chunk of numeric channels, each sample with its stamp."""
    body = b'\x04' + struct.pack('<I', len(stamps))
    for stamp, row in zip(stamps, values):
        body += b'\x08' + struct.pack('<d', stamp) + np.asarray(row, dtype=dtype).tobytes()
    return chunk(3, struct.pack('<I', stream_id) + body)


def string_samples(stream_id: int, stamps: Sequence[float], values: Sequence[str]) -> bytes:
    """Make a Samples chunk of a one-channel string stream (markers)."""
    body = b'\x04' + struct.pack('<I', len(stamps))
    for stamp, text in zip(stamps, values):
        raw = text.encode()
        body += b'\x08' + struct.pack('<d', stamp) + b'\x04' + struct.pack('<I', len(raw)) + raw
    return chunk(3, struct.pack('<I', stream_id) + body)


def write_xdf(path: Path, gaze_streams: List[str]) -> None:
    """Write an XDF file with EEG, markers and one Tobii Pro gaze stream per name given."""
    parts = [b'XDF:', chunk(1, b'<?xml version="1.0"?><info><version>1.0</version></info>')]
    eeg = np.random.default_rng(0).standard_normal((20, 4))
    parts.append(stream_header(1, 'amp', 'EEG', ['O1', 'O2', 'Oz', 'Pz'], 'float32', 250.0))
    parts.append(stream_header(2, 'events', 'Markers', ['event'], 'string', 0.0))
    labels = ('left_x', 'left_y', 'left_pupil', 'right_x', 'right_y', 'right_pupil')
    for index, name in enumerate(gaze_streams):
        parts.append(stream_header(3 + index, name, 'Eyetracker', labels, 'float32', 60.0))
    parts.append(numeric_samples(1, 5000.0 + np.arange(20) / 250.0, eeg, '<f4'))
    parts.append(string_samples(2, [5000.01], ['target 1']))
    samples = encode('tobii_pro', POINTS, (1920, 1080), eye_offset_px=(4.0, 0.0))
    for index, _ in enumerate(gaze_streams):
        # Two chunks, as LabRecorder writes a stream in pieces.
        parts.append(numeric_samples(3 + index, STAMPS[:2], samples[:2], '<f4'))
        parts.append(numeric_samples(3 + index, STAMPS[2:], samples[2:], '<f4'))
    path.write_bytes(b''.join(parts))


def test_the_gaze_stream_of_an_xdf_file_becomes_a_recording(tmp_path):
    path = tmp_path / 'session.xdf'
    write_xdf(path, ['Tobii'])
    recording = load_gaze(path)
    lost = ~np.isfinite(POINTS).all(axis=1)
    # The Tobii Pro layout (normalised, two eyes averaged) back in screen px; lost stays lost.
    np.testing.assert_allclose(recording.points[~lost], POINTS[~lost], atol=1e-3)
    assert np.isnan(recording.points[lost]).all()
    # The recorded stamps from 0, not de-jittered: a replay sends them as they were.
    np.testing.assert_allclose(recording.stamps, STAMPS - STAMPS[0], atol=1e-9)
    assert recording.name == 'session' and 'Tobii' in recording.tracker
    assert len(recording.targets) == 0


def test_the_screen_given_scales_a_normalised_stream(tmp_path):
    path = tmp_path / 'session.xdf'
    write_xdf(path, ['Tobii'])
    small = ScreenGeometry(width_px=960, height_px=540)
    recording = load_xdf_gaze(path, screen=small)
    np.testing.assert_allclose(recording.points[0], [480.0, 270.0], atol=1e-3)


def test_several_gaze_streams_must_be_named_and_a_name_picks_one(tmp_path):
    path = tmp_path / 'two.xdf'
    write_xdf(path, ['Tobii', 'Tobii_spare'])
    with pytest.raises(RecordingError, match="2 streams of gaze: 'Tobii'.*'Tobii_spare'"):
        load_xdf_gaze(path)
    assert len(load_xdf_gaze(path, stream_name='Tobii_spare').stamps) == len(STAMPS)
    with pytest.raises(RecordingError, match="no stream named 'EyeLink' among: 'amp' \\(EEG\\)"):
        load_xdf_gaze(path, stream_name='EyeLink')


def test_a_file_without_gaze_or_not_xdf_is_one_clear_error(tmp_path):
    path = tmp_path / 'eeg_only.xdf'
    write_xdf(path, [])
    with pytest.raises(RecordingError, match='no stream of gaze among'):
        load_gaze(path)
    broken = tmp_path / 'broken.xdf'
    broken.write_bytes(b'not an xdf file at all')
    with pytest.raises(RecordingError, match='not a readable XDF file') as error:
        load_gaze(broken)
    assert '\n' not in str(error.value)
