"""Loaders of recorded gaze (recordings.gaze): files the tests write, and the real ones."""

import gzip

import numpy as np
import pytest

from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.gaze import combine_eyes, find_recordings, load_gaze, RecordingError

REAL = find_data('real_gaze')


def write(path, text, compress=False):
    """Write ``text`` to ``path`` (gzip-compressed when asked); return the path."""
    if compress:
        with gzip.open(path, 'wt') as handle:
            handle.write(text)
    else:
        path.write_text(text)
    return path


def test_both_eyes_average_where_both_are_valid_and_one_eye_stands_in_for_the_other():
    left = np.array([[100.0, 200.0], [np.nan, np.nan], [110.0, 210.0], [np.nan, 5.0]])
    right = np.array([[104.0, 204.0], [50.0, 60.0], [np.nan, np.nan], [np.nan, np.nan]])
    combined = combine_eyes(left, right)
    assert combined[:3].tolist() == [[102.0, 202.0], [50.0, 60.0], [110.0, 210.0]]
    assert np.isnan(combined[3]).all()


def test_a_x260_recording_with_its_messages(tmp_path):
    header = 'Time\tL POR X [px]\tL POR Y [px]\tR POR X [px]\tR POR Y [px]\tL Diam [px]\n'
    rows = ''.join(f'{1000000 + 16667 * i}\t{500 + i}\t300\t{502 + i}\t302\t3.1\n'
                   for i in range(120))
    write(tmp_path / 'human_samples_lookAtPoint_X_ss9.txt.gz', header + rows, compress=True)
    write(tmp_path / 'human_msgs_lookAtPoint_X_ss9.txt.gz',
          '1000000\t0\t960.00\t540.00\n2000000\t1\t100.00\t200.00\n', compress=True)
    [path] = find_recordings(tmp_path)
    recording = load_gaze(path)
    assert recording.name == 'lookAtPoint_X_ss9'
    assert recording.stamps[0] == 0.0 and recording.rate_hz == pytest.approx(60.0, rel=1e-3)
    assert recording.points[0].tolist() == [501.0, 301.0]
    assert recording.targets.onsets.tolist() == [0.0, 1.0]
    assert recording.targets.places.tolist() == [[960.0, 540.0], [100.0, 200.0]]
    assert recording.targets.jumps and recording.screen.distance_mm == 565.0


def test_an_etdq_recording_turns_its_target_runs_into_a_schedule(tmp_path):
    lines = ['timestamp\tleft_x\tleft_y\ttarget_id\ttar_x\ttar_y']
    for i in range(300):
        still = 100 <= i < 200 or i >= 250
        target, place = (1, (-480, -270)) if i < 200 else (2, (480, 270))
        cells = (target, *place) if still else (-1, -1, -1)
        lines.append(f'{1000 + 10 * i}\t{place[0]}\t{place[1]}\t' + '\t'.join(map(str, cells)))
    recording = load_gaze(write(tmp_path / 'etdq_Tracker_100Hz.tsv', '\n'.join(lines) + '\n'))
    targets = recording.targets
    assert targets.places.tolist() == [[480.0, 270.0], [1440.0, 810.0]]   # top-left origin
    assert targets.still.tolist() == pytest.approx([1.0, 2.5])
    assert targets.onsets.tolist() == pytest.approx([0.0, 1.99])          # the glide starts
    assert not targets.jumps


def test_a_labs_csv_with_its_screen_in_comments(tmp_path):
    write(tmp_path / 'p01.gaze.csv', '# screen_px: 2560x1440\n# screen_mm: 597x336\n'
          '# distance_mm: 700\ntime_s,x_px,y_px\n0.0,10,20\n0.01,,\n0.02,12,22\n')
    write(tmp_path / 'p01.targets.csv', 'onset_s,x_px,y_px\n0.0,11,21\n')
    recording = load_gaze(tmp_path / 'p01.gaze.csv')
    assert (recording.screen.width_px, recording.screen.distance_mm) == (2560, 700.0)
    assert recording.lost_share == pytest.approx(1 / 3)
    assert recording.targets.ends.tolist() == [0.02]


@pytest.mark.parametrize('name, text, reason', [
    ('a.gaze.csv', 'time_s,x,y\n0,1,2\n', "no column 'x_px'"),
    ('b.gaze.csv', 'time_s,x_px,y_px\n', 'no samples'),
    ('c.txt', 'x', 'not a known gaze recording'),
    ('etdq_d.tsv', 'timestamp\tleft_x\tleft_y\ttarget_id\ttar_x\ttar_y\n0\t1\t1\t-1\t-1\t-1\n',
     'no target is shown still'),
])
def test_a_file_that_is_not_a_recording_is_refused_in_one_line(tmp_path, name, text, reason):
    path = write(tmp_path / name, text)
    if name.endswith('.gaze.csv'):
        write(tmp_path / (name[:-len('.gaze.csv')] + '.targets.csv'), 'onset_s,x_px,y_px\n0,1,1\n')
    with pytest.raises(RecordingError, match=reason) as raised:
        load_gaze(path)
    assert '\n' not in str(raised.value)


@pytest.mark.skipif(REAL is None, reason='no real gaze recordings (../shared/data/real_gaze)')
def test_the_real_recordings_load_with_their_schedules():
    recordings = [load_gaze(path) for path in find_recordings(REAL)]
    assert recordings, 'no recording of a known format in the folder'
    for recording in recordings:
        assert np.all(np.diff(recording.stamps) >= 0)
        assert len(recording.targets) >= 9
        on_screen = np.isfinite(recording.points).all(axis=1)
        assert np.mean(on_screen) > 0.9, recording.name
        # Settled gaze lies near the targets: median error under 3 degrees.
        errors = []
        for k in range(len(recording.targets)):
            _, points = recording.between(recording.targets.still[k] + 0.6,
                                          recording.targets.ends[k])
            if len(points):
                errors.append(np.hypot(*(np.nanmedian(points, axis=0)
                                         - recording.targets.places[k])))
        assert np.nanmedian(errors) < 3 * recording.screen.px_per_degree(), recording.name
