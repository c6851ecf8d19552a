"""session_report: questions, unasked choices, cues and drives of a session; one-line errors."""

import numpy as np
from paths import REPO
import pytest

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.experiments import session_report
from eye_bci_ros2.experiments.session_bag import Session
from eye_bci_ros2.ros.session_topics import RECORDED_TOPICS, ros2_bag_record_command

SQUARE = np.array([[0, 0], [100, 0], [100, 100], [0, 100]], dtype=float)


def two_options(stamp):
    return RegionSet(['left', 'right'], [SQUARE, SQUARE + [500, 0]], stamp)


def test_questions_pair_with_what_ended_them_and_unasked_choices_are_kept_apart():
    session = Session(path='bag', start=0.0, end=20.0)
    session.regions = [two_options(0.5)]
    session.cues = [(0.4, 'left'), (4.9, 'right'), (9.0, '')]
    session.requests = [1.0, 3.0, 5.0, 10.0]
    session.no_choices = [(2.0, 'no valid gaze sample')]
    # The second question is answered, the third answered wrong, the fourth not cued;
    # one choice comes with no question open (before any request).
    session.choices = [(0.8, 'right'), (3.6, 'left'), (5.5, 'left'), (10.4, 'right')]
    report = session_report.build_report(session)
    ended = [(q.asked, q.chosen, q.reason, q.intended, q.correct) for q in report.questions]
    assert ended == [(1.0, None, 'no valid gaze sample', 'left', None),
                     (3.0, 'left', '', 'left', True),
                     (5.0, 'left', '', 'right', False),
                     (10.0, 'right', '', '', None)]
    assert report.unasked_choices == [(0.8, 'right')]
    # Accuracy over the cued answers only; the time per selection starts where the previous
    # question ended when the options were already on the screen.
    assert report.cued == 2 and report.accuracy == 0.5
    assert report.questions[1].selection_time_s == pytest.approx(3.6 - 2.0)
    assert report.questions[1].decision_time_s == pytest.approx(0.6)
    assert report.itr_bits_per_min == 0.0      # 50 % of 2 options is chance


def test_a_drive_runs_from_its_goal_to_the_menus_word_with_the_odometry_between():
    session = Session(path='bag', start=0.0, end=30.0)
    session.goals = [(10.0, np.array([3.0, 0.0, 0.0]))]
    session.progress = [(10.1, 'driving: 3.0 m left'), (13.0, "arrived at 'kitchen/table_1'")]
    times = np.linspace(9.0, 14.0, 51)
    x = np.clip(times - 10.0, 0.0, 3.0)
    session.odometry = np.column_stack([times, x, np.zeros_like(x), np.zeros_like(x)])
    (drive,) = session_report.find_drives(session)
    assert drive.arrived and drive.end == 13.0 and drive.goal == [3.0, 0.0, 0.0]
    assert drive.path_m == pytest.approx(3.0, abs=0.11)


def test_a_folder_that_is_no_bag_is_one_line(tmp_path, capsys):
    assert session_report.main([str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f'session_report: {tmp_path} is not a '
                                               'readable rosbag2')


def test_the_docs_give_the_ros2_bag_record_command_of_the_one_list():
    command = ros2_bag_record_command()
    assert command in (REPO / 'docs' / 'recording.md').read_text()
    assert command.split()[-len(RECORDED_TOPICS):] == [
        t.name if t.name.startswith('/') else '/' + t.name for t in RECORDED_TOPICS]
    assert ' /left/gaze/samples ' in ros2_bag_record_command('left')
    assert ros2_bag_record_command('left').endswith(' /tf /tf_static')
