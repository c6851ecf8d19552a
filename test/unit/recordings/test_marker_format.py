"""The marker format, the stamp mapping and the stream choice of a session's LSL recording."""

import json
import math
from types import SimpleNamespace

from hypothesis import given, strategies as st
import numpy as np
import pytest

from eye_bci_ros2.decision.evidence import Decision
from eye_bci_ros2.recordings.lab_recorder import LabRecording, select_session_streams
from eye_bci_ros2.recordings.session_markers import (
    answer_event, decision_detail, EVENTS, marker_text, parse_marker, progress_event,
    question_fields, ros_to_lsl, stream_identity, trial_frame)
from eye_bci_ros2.streams.lsl_connection import acquisition_stamps_ns


def test_a_marker_is_one_json_line_a_lab_parses_with_nan_as_null():
    text = marker_text('choice', label='kitchen', evidence={'posterior': float('nan'),
                                                            'counts': {'kitchen': np.int64(12)}},
                       mean_point=(np.float32(960.123456), 540.0), stamp=float('inf'))
    assert '\n' not in text
    body = json.loads(text)
    assert body == parse_marker(text)
    assert body['event'] == 'choice' and body['v'] == 1 and body['label'] == 'kitchen'
    assert body['evidence'] == {'posterior': None, 'counts': {'kitchen': 12}}
    assert body['mean_point'] == [960.123, 540.0] and body['stamp'] is None


def test_an_unknown_event_or_a_non_marker_is_refused_with_the_reason():
    with pytest.raises(ValueError, match="unknown marker event 'chioce'"):
        marker_text('chioce', label='a')
    with pytest.raises(ValueError, match='not a marker'):
        parse_marker('[1, 2]')
    assert len(set(EVENTS)) == len(EVENTS)


@given(st.lists(st.floats(0.0, 1e6), min_size=1, max_size=20),
       st.floats(-5.0, 5.0), st.integers(10**18, 2 * 10**18), st.floats(0.0, 1e6))
def test_ros_to_lsl_inverts_the_bridge_stamps_to_the_tracker_stamp_on_this_clock(
        tracker, correction, ros_now_ns, lsl_now):
    # The bridge: t_ros = t_lsl + correction + (ros_now - lsl_now); the markers invert it with
    # the same pair: the tracker's stamp on this machine's LSL clock, to the ns rounding.
    tracker = np.asarray(tracker)
    stamps_ns, good = acquisition_stamps_ns(tracker, correction, ros_now_ns, lsl_now)
    assert good.all()
    back = np.array([ros_to_lsl(ns, ros_now_ns, lsl_now) for ns in stamps_ns])
    np.testing.assert_allclose(back, tracker + correction, rtol=0, atol=1e-8)


def test_the_stream_name_and_source_id_say_which_pipeline():
    assert stream_identity('/', 'lab-pc') == ('eye_bci_markers', 'eye_bci_markers@lab-pc/')
    assert stream_identity('/left', 'lab-pc') == ('eye_bci_markers /left',
                                                  'eye_bci_markers@lab-pc/left')
    assert stream_identity('/a/b/', 'x')[1] == 'eye_bci_markers@x/a/b'
    assert stream_identity('/left', 'x') != stream_identity('/right', 'x')


def test_menu_lines_become_their_events():
    assert [answer_event(label) for label in ('kitchen', 'back', 'go', 'stop')] == [
        'answer', 'answer', 'go', 'stop']
    assert progress_event("driving to 'kitchen/table_2': 3.1 m left") == 'driving'
    assert progress_event("arrived at 'kitchen/table_2'") == 'arrived'
    assert progress_event("stopped on the way to 'kitchen/table_2'") == 'stopped'
    assert progress_event("the robot did not move toward 'kitchen/table_2' within 10 s "
                          '(3.5 m left, no nearer): choose again') == 'failed'
    # The NavigateToPose menu's lines.
    assert progress_event("the robot refused the goal to 'k/t': unreachable: choose "
                          'again') == 'failed'
    assert progress_event("the robot did not reach 'k/t': 103 (no valid path): choose "
                          'again') == 'failed'
    assert progress_event('the robot stopped') == 'stopped'
    for line in ("sending the robot to 'k/t'", "stopping on the way to 'k/t'",
                 "no feedback from the robot for 3 s on the way to 'k/t': 'stop' is still "
                 'offered', "the robot refused the stop on the way to 'k/t' (busy): choose "
                 "'stop' again", ''):
        assert progress_event(line) == 'robot', line


def test_a_question_lists_each_option_with_its_region_without_padding():
    polygons = np.array([[[0, 0], [10, 0], [10, 10], [10, 10]],
                         [[20, 0], [30, 0], [30, 10], [20, 10]]], dtype=float)
    fields = question_fields(['a', 'b'], polygons, ['tables', 'tables'])
    assert fields['step'] == ['tables']
    assert [o['label'] for o in fields['options']] == ['a', 'b']
    assert fields['options'][0]['region'].tolist() == [[0, 0], [10, 0], [10, 10]]
    assert len(fields['options'][1]['region']) == 4
    body = json.loads(marker_text('question', **fields))
    assert body['options'][1]['region'] == [[20, 0], [30, 0], [30, 10], [20, 10]]


def test_a_decision_is_told_with_its_rule_evidence_and_last_gaze_stamp():
    decision = Decision(label='left', method='early', samples_used=90, in_region_samples=80,
                        margin=1.0, posterior=0.97, time_to_decision=0.45,
                        counts={'left': 80}, mean_point=(500.0, 400.0), fresh_samples=70,
                        round_start=1_700_000_000.25)
    body = json.loads(decision_detail(decision, 'left', None, 'gaze', 'fixation', 42))
    assert body['label'] == 'left' and body['reason'] is None
    assert (body['rule'], body['decided_by'], body['input_mode']) == ('fixation', 'early',
                                                                      'gaze')
    assert body['evidence']['counts'] == {'left': 80} and body['evidence']['fresh'] == 70
    assert body['gaze_stamp'] is True
    assert abs(body['stamp_ns'] - 1_700_000_000_700_000_000) < 1000    # float s -> ns


def test_a_no_choice_without_samples_and_an_ssvep_choice_are_stamped_when_decided():
    empty = Decision(label=None, method='mean', samples_used=0, in_region_samples=0,
                     margin=0.0, posterior=math.nan, reason='no gaze samples',
                     round_start=100.0)
    body = json.loads(decision_detail(empty, None, 'no gaze samples', 'gaze', 'mean', 7))
    assert body['stamp_ns'] == 7 and body['gaze_stamp'] is False
    assert body['evidence']['posterior'] is None and body['reason'] == 'no gaze samples'
    body = json.loads(decision_detail(None, 'right', None, 'ssvep', 'fixation', 9))
    assert (body['label'], body['stamp_ns'], body['evidence']) == ('right', 9, None)


def info(kind, name, source_id):
    """Describe a resolved stream as pylsl.StreamInfo does (type, name, source_id)."""
    return SimpleNamespace(type=lambda: kind, name=lambda: name, source_id=lambda: source_id)


def test_the_sessions_streams_are_its_gaze_eeg_and_its_own_markers():
    streams = [info('Gaze', 'tobii', 'tracker-1'), info('Gaze', 'tobii', 'tracker-2'),
               info('EEG', 'obci_eeg1', 'amp'), info('Markers', 'eye_bci_markers', 'm@pc/'),
               info('Markers', 'eye_bci_markers /left', 'eye_bci_markers@pc/left'),
               info('Markers', 'eye_bci_markers /left', 'eye_bci_markers@other/left'),
               info('Markers', 'psychopy', 'p'), info('Audio', 'mic', 'mic')]
    chosen = select_session_streams(streams, '/left', gaze_source_id='tracker-2', host='pc')
    assert [(s.type(), s.source_id()) for s in chosen] == [
        ('Gaze', 'tracker-2'), ('EEG', 'amp'), ('Markers', 'eye_bci_markers@pc/left')]
    assert len(select_session_streams(streams, '/left')) == 5     # any host: both pipelines
    assert [s.source_id() for s in select_session_streams(streams, '/', markers=False)] == [
        'tracker-1', 'tracker-2', 'amp']


def test_a_trial_starts_at_the_first_stimulus_frame_at_or_after_its_question():
    epoch = 10**18
    assert trial_frame(epoch - 5 * 10**8, epoch, 60.0) == (0, epoch)     # before the epoch
    assert trial_frame(epoch, epoch, 60.0) == (0, epoch)
    frame, stamp = trial_frame(epoch + 1_000_000_001, epoch, 60.0)
    assert frame == 61 and stamp == epoch + round(61e9 / 60)
    frame, stamp = trial_frame(epoch + 500_000_000, epoch, 144.0)     # exactly on frame 72
    assert (frame, stamp) == (72, epoch + 500_000_000)


def test_a_recording_refuses_nothing_to_record_an_unresolved_stream_and_a_bad_path(tmp_path):
    with pytest.raises(ValueError, match='nothing to record'):
        LabRecording(tmp_path / 'a.xdf', [])
    made_by_hand = SimpleNamespace(type=lambda: 'EEG', name=lambda: 'amp', uid=lambda: '',
                                   source_id=lambda: 'amp-1')
    with pytest.raises(ValueError, match="cannot record 'amp' .*not a resolved stream"):
        LabRecording(tmp_path / 'a.xdf', [made_by_hand])
    resolved = SimpleNamespace(uid=lambda: 'u-1')
    with pytest.raises(OSError, match='is not a folder'):
        LabRecording(tmp_path / 'missing' / 'a.xdf', [resolved])
