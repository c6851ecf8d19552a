"""The demo: the room -> table experiment end to end over real ROS 2 and LSL."""

import contextlib
import csv
import io
import json
import os

import numpy as np
import pytest

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings
from eye_bci_ros2.experiments import demo
from eye_bci_ros2.experiments.metrics import itr_bits_per_minute, wolpaw_bits
from eye_bci_ros2.experiments.render import png_size
from eye_bci_ros2.navigation.robot_settings import RobotSettings
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.task.menu import BACK_LABEL, GO_LABEL, SEND_LABEL
from eye_bci_ros2.task.scene import load_scene

SCENE = load_scene(default_scene_path())


def test_wolpaw_bits_and_itr():
    assert wolpaw_bits(4, 1.0) == pytest.approx(2.0)
    assert wolpaw_bits(4, 0.9) == pytest.approx(
        2 + 0.9 * np.log2(0.9) + 0.1 * np.log2(0.1 / 3))
    assert wolpaw_bits(4, 0.25) == 0.0  # chance carries nothing
    # Four 4-way and four 3-way choices, all right, 1.5 s each.
    itr = itr_bits_per_minute([4, 3] * 4, 1.0, 1.5)
    assert itr == pytest.approx((2 + np.log2(3)) / 2 * 40)


def test_script_covers_different_rooms_and_is_seeded():
    script = demo.make_script(SCENE, 4, seed=7)
    assert sorted(room for room, _ in script) == sorted(r.name for r in SCENE.rooms)
    assert len({table for _, table in script}) > 1
    assert script == demo.make_script(SCENE, 4, seed=7)
    for room, table in script:
        assert SCENE.room(room).table(f'{room}/{table}') is not None
    with pytest.raises(ValueError, match='at least one round'):
        demo.make_script(SCENE, 0, seed=1)


def test_samples_are_classified_against_the_regions_shown_at_their_time():
    square = [[0, 0], [10, 0], [10, 10], [0, 10]]
    history = [RegionSet(['a'], [square], 0.0),
               RegionSet(['a'], [np.add(square, 100)], 1.0)]
    stamps = np.array([0.5, 0.6, 1.5, 1.6])
    points = np.array([[5, 5], [105, 105], [5, 5], [105, 105]], dtype=float)
    inside = demo.classify_against_history(stamps, points, history)
    assert inside.tolist() == [True, False, False, True]


@pytest.mark.ros
def test_the_driver_sees_the_options_as_rviz_does_deleteall_clears_its_namespace(graph):
    from visualization_msgs.msg import Marker, MarkerArray

    from eye_bci_ros2.ros.topics import CHOICES_QOS, CHOICES_TOPIC

    driver = graph.add(demo.ExperimentDriver, SCENE, [], None, None, demo.DemoOptions())
    publisher = graph.node('task').create_publisher(MarkerArray, CHOICES_TOPIC, CHOICES_QOS)

    def cube(ns, marker_id, text):
        marker = Marker(ns=ns, id=marker_id, type=Marker.CUBE, action=Marker.ADD, text=text)
        marker.header.frame_id = 'map'
        marker.pose.orientation.w = 1.0
        marker.scale.x = marker.scale.y = marker.scale.z = 1.0
        return marker

    publisher.publish(MarkerArray(markers=[cube('rooms', 0, 'kitchen'), cube('rooms', 1, 'hall'),
                                           cube('back', 0, 'back')]))
    assert graph.spin_until(lambda: len(driver.markers) == 3)
    # A DELETEALL in one namespace clears that namespace only (RViz2's MarkerArray semantics).
    publisher.publish(MarkerArray(markers=[Marker(ns='rooms', action=Marker.DELETEALL),
                                           cube('rooms', 2, 'office')]))
    assert graph.spin_until(lambda: set(driver.markers) == {'back', 'office'}), driver.markers


@pytest.fixture(scope='module')
def quick_run(tmp_path_factory):
    """Run ``demo --quick`` once; the tests below check what it printed and wrote."""
    out = tmp_path_factory.mktemp('demo') / 'out'
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        code = demo.main(['--quick', '--seed', '3', '--output-dir', str(out)])
    summary = json.loads((out / 'summary.json').read_text())
    return code, stdout.getvalue(), out, summary


@pytest.mark.ros
@pytest.mark.lsl
def test_quick_demo_finishes_with_every_choice_right(quick_run):
    code, printed, _, summary = quick_run
    assert code == 0
    # The node's default rule, named as the pictures' legend names it.
    assert 'decision rule: fixation rule: a still fixation of 0.15 s' in printed
    assert 'summary: 4 selections, 4 correct: accuracy 100.0 %' in printed
    assert 'ITR' in printed
    for row in summary['selections']:
        # The picture shows exactly the samples the decision weighed, classified by its rule.
        assert (row['picture_samples'], row['picture_counted']) == (
            row['samples_used'], row['in_region_samples']), row
    selections = summary['selections']
    assert [s['correct'] for s in selections] == [True, True, True, True]
    assert summary['accuracy'] == 1.0
    assert summary['itr_bits_per_min'] > 0
    for selection in selections:
        # The node's default: a still fixation of dwell_s (0.15 s: 13 samples at 87 Hz,
        # fewer when the simulated tracker lost some to a blink or a dropout; which samples
        # it holds depends on when the round starts, which a loaded machine shifts) with at
        # least min_samples decides early, before the 1 s window ends.
        assert selection['method'] == 'early'
        assert selection['in_region_samples'] >= ArbiterSettings().min_samples
        assert selection['time_to_decision_s'] < 1.0
        assert selection['samples_used'] >= selection['in_region_samples']


@pytest.mark.ros
@pytest.mark.lsl
def test_menu_goes_from_rooms_to_the_room_view_to_its_tables(quick_run):
    _, _, _, summary = quick_run
    (room, table), = [entry.split('/') for entry in summary['script']]
    rooms, tables, confirm, send = summary['selections']
    assert rooms['step'] == 'rooms' and rooms['intended'] == room
    assert sorted(rooms['offered']) == sorted(SCENE.room_labels)
    assert np.allclose(rooms['camera_eye'], SCENE.overview.eye, atol=1e-3)
    assert tables['step'] == 'tables' and tables['intended'] == f'{room}/{table}'
    # The room's tables and the menu's way back.
    assert sorted(tables['offered']) == sorted(
        [t.marker.text for t in SCENE.room(room).tables] + [BACK_LABEL])
    # The camera had zoomed into the chosen room when the table was chosen.
    assert np.allclose(tables['camera_eye'], SCENE.room(room).view.eye, atol=1e-3)
    assert summary['outcomes'] == [f'{room}/{table}']
    # The table was confirmed ('go', in the same view) before the robot drove there.
    assert confirm['step'] == 'confirm' and confirm['intended'] == confirm['chosen'] == GO_LABEL
    assert sorted(confirm['offered']) == sorted([GO_LABEL, BACK_LABEL])
    assert np.allclose(confirm['camera_eye'], SCENE.room(room).view.eye, atol=1e-3)
    # ... and 'go' by the second look, at 'send', which appeared then (send_rounds).
    assert send['step'] == 'send' and send['intended'] == send['chosen'] == SEND_LABEL
    assert send['offered'] == [SEND_LABEL, BACK_LABEL]
    robot = tables['robot']
    assert robot['arrived'] and len(robot['goal']) == 3
    assert_drove_the_plan(robot)
    assert rooms['robot'] is None and confirm['robot'] is None and send['robot'] is None


@pytest.mark.ros
@pytest.mark.lsl
def test_quick_demo_pictures_are_the_recorded_sessions_report(quick_run):
    _, _, out, summary = quick_run
    report = json.loads((out / 'report.json').read_text())
    # session_report found the demo's questions in the bag: each answer the menu acted on,
    # the person's intent from the cue, all right; the start-up round without a choice.
    answered = [q for q in report['questions'] if q['chosen'] is not None]
    assert [q['chosen'] for q in answered] == [s['chosen'] for s in summary['selections']]
    assert [q['intended'] for q in answered] == [s['intended'] for s in summary['selections']]
    assert [q['correct'] for q in answered] == [True] * len(summary['selections'])
    assert report['accuracy'] == 1.0 and report['itr_bits_per_min'] > 0
    assert report['unasked_choices'] == []
    for question in answered:
        assert os.path.basename(question['picture']) == f"question_{question['index']:03d}.png"
        assert png_size(question['picture']) == demo.SCREEN_SIZE
        assert os.path.getsize(question['picture']) > 20000
        assert question['gaze_samples'] > 0 and question['in_region_samples'] > 0
    # The drive, from above: the map, the plan, the path driven (odometry), arrived.
    (drive,) = report['drives']
    robot = summary['selections'][1]['robot']
    assert drive['arrived'] and drive['goal'] == robot['goal']
    assert drive['path_m'] == pytest.approx(robot['path_m'], abs=0.3)
    # The path drawn is the robot's in the map frame (the feedback's), not odometry's own
    # drifting frame: it ends where the goal is and starts where the plan does.
    from eye_bci_ros2.experiments.session_bag import read_session
    from eye_bci_ros2.experiments.session_report import build_report
    (drawn,) = build_report(read_session(out / demo.BAG_NAME)).drives
    assert np.hypot(*(drawn.path[-1, :2] - robot['goal'][:2])) < 0.25, drawn.path[-1]
    assert np.hypot(*(drawn.path[0, :2] - drawn.plan[0])) < 0.25, (drawn.path[0], drawn.plan[0])
    assert os.path.basename(drive['picture']) == 'drive_01.png'
    assert os.path.getsize(drive['picture']) > 20000
    assert os.path.getsize(out / 'timeline.png') > 20000
    with open(out / 'questions.csv', newline='') as stream:
        rows = list(csv.DictReader(stream))
    assert [row['correct'] for row in rows if row['chosen']] == ['True'] * len(answered)
    assert (out / demo.BAG_NAME / 'metadata.yaml').is_file()


@pytest.mark.ros
@pytest.mark.lsl
def test_the_demos_bag_holds_every_question_choice_and_drive(quick_run):
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import QosDurability
    from rosbags.typesys import get_typestore, Stores

    _, _, out, summary = quick_run
    found = {}
    with AnyReader([out / demo.BAG_NAME],
                   default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        for connection, stamp, data in reader.messages():
            found.setdefault(connection.topic, []).append(
                (stamp, reader.deserialize(data, connection.msgtype)))
        connections = {c.topic: c for c in reader.connections}
    chosen = [s['chosen'] for s in summary['selections']]
    assert [m.data for _, m in found['/choice']] == chosen
    assert [m.data for _, m in found['/choice_menu/answer']] == chosen
    # A question per choice and per round without one; the last ('stop' while the robot
    # drove) may still be open when the demo ends.
    ended = len(chosen) + len(found['/choice/none'])
    assert ended <= len(found['/choice/request']) <= ended + 1
    # Each choice after its question, each answer after its choice.
    requests = [t for t, _ in found['/choice/request']]
    for (t_choice, _), (t_answer, _) in zip(found['/choice'], found['/choice_menu/answer']):
        assert any(t <= t_choice for t in requests) and t_choice <= t_answer
    # The drive: the goal, the map, the plan, the odometry, the menu's arrival.
    (_, goal), = found['/choice_menu/goal']
    assert [goal.pose.position.x, goal.pose.position.y] == pytest.approx(
        summary['selections'][1]['robot']['goal'][:2], abs=1e-3)
    assert len(found['/odom']) > 5 and found['/plan'] and found['/map']
    assert found['/choice_menu/progress'][-1][1].data.startswith('arrived')
    # Latched topics are stored latched (ros2 bag play re-latches them).
    for topic in ('/choices', '/choices/regions', '/map', '/camera/pose'):
        qos = connections[topic].ext.offered_qos_profiles
        assert qos and {q.durability for q in qos} == {QosDurability.TRANSIENT_LOCAL}, topic


@pytest.mark.ros
@pytest.mark.lsl
def test_demo_fails_cleanly_when_no_gaze_arrives(tmp_path, capsys):
    code = demo.main(['--quick', '--stream-timeout-s', '0.01', '--output-dir', str(tmp_path)])
    assert code == 1
    assert 'no gaze reached the pipeline within 0.01 s' in capsys.readouterr().err
    # No pictures or summary of a run that did not happen; its recordings are kept, whole.
    assert sorted(os.listdir(tmp_path)) == sorted([demo.BAG_NAME, demo.XDF_NAME])
    assert (tmp_path / demo.BAG_NAME / 'metadata.yaml').is_file()


@pytest.mark.ros
@pytest.mark.lsl
@pytest.mark.parametrize('mode', ['ssvep', 'hybrid'])
def test_quick_demo_with_ssvep_input_chooses_right(tmp_path, mode):
    """The room -> table experiment with the SSVEP decoder on simulated EEG choosing."""
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        code = demo.main(['--quick', '--input', mode, '--output-dir', str(tmp_path),
                          '--no-pictures'])
    printed = stdout.getvalue()
    assert code == 0, printed[-2000:]
    summary = json.loads((tmp_path / 'summary.json').read_text())
    # The menu's defaults in every input mode: the room, the table, 'go' and 'send' (offered
    # with 'back', so the SSVEP decoder and the hybrid arbiter can answer it), then the drive.
    assert [(s['step'], s['chosen'], s['correct']) for s in summary['selections']][2:] == [
        ('confirm', GO_LABEL, True), ('send', SEND_LABEL, True)]
    assert all(s['correct'] for s in summary['selections'])
    assert {s['method'] for s in summary['selections']} == {mode}
    assert summary['selections'][1]['robot']['arrived']
    assert summary['itr_bits_per_min'] > 0


@pytest.mark.ros
@pytest.mark.lsl
def test_make_demo_confirms_every_table_and_the_robot_arrives(tmp_path):
    """What ``make demo`` shows a user: four tables, each confirmed, sent and arrived at."""
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        code = demo.main(['--output-dir', str(tmp_path), '--no-pictures'])
    printed = stdout.getvalue()
    assert code == 0, printed[-2000:]
    summary = json.loads((tmp_path / 'summary.json').read_text())
    tables = [s for s in summary['selections'] if s['step'] == 'tables'
              and s['chosen'] != BACK_LABEL]
    assert [s['chosen'] for s in tables] == summary['script'] == summary['outcomes']
    for table in tables:
        index = summary['selections'].index(table)
        later = summary['selections'][index + 1:index + 3]
        assert [(s['step'], s['chosen']) for s in later] == [('confirm', GO_LABEL),
                                                             ('send', SEND_LABEL)]
        assert table['robot']['arrived'], table['robot']
        assert_drove_the_plan(table['robot'])
    assert printed.count('arrived after') == 4


def assert_drove_the_plan(robot):
    """Assert the robot drove its plan, no faster than its top speed, never silent."""
    # The robot's time (sim_robot's time_scale x the wall clock); 0.5 m/s at most.
    assert robot['drive_s'] >= robot['path_m'] / RobotSettings().max_speed, robot
    assert robot['plan_m'] > 0 and abs(robot['path_m'] - robot['plan_m']) <= \
        0.1 * robot['plan_m'], robot
    assert robot['silences'] == [], robot


@pytest.mark.ros
@pytest.mark.lsl
def test_the_demo_at_real_speed_arrives_at_every_table(tmp_path):
    """``demo --robot-time-scale 1 --rounds 2``: every drive at 0.5 m/s arrives, none held."""
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):
        code = demo.main(['--robot-time-scale', '1', '--rounds', '2', '--seed', '1',
                          '--output-dir', str(tmp_path), '--no-pictures'])
    printed = stdout.getvalue()
    assert code == 0, printed[-2000:]
    summary = json.loads((tmp_path / 'summary.json').read_text())
    drives = [s['robot'] for s in summary['selections'] if s['robot'] is not None]
    assert len(drives) == 2 and summary['outcomes'] == summary['script']
    # The second drive goes from one room's table to another room's: across the scene.
    assert len({entry.split('/')[0] for entry in summary['script']}) == 2
    for robot in drives:
        assert robot['arrived'], robot
        assert_drove_the_plan(robot)
    # At real speed a drive across the scene takes longer than the old 10 s progress timeout.
    assert max(robot['drive_s'] for robot in drives) > 10.0, drives


@pytest.mark.ros
@pytest.mark.lsl
def test_the_demos_xdf_and_bag_hold_the_same_session_with_consistent_stamps(quick_run):
    pyxdf = pytest.importorskip('pyxdf')
    from eye_bci_ros2.experiments.session_bag import read_session
    from eye_bci_ros2.recordings.session_markers import parse_marker

    _, _, out, summary = quick_run
    loaded, _ = pyxdf.load_xdf(str(out / demo.XDF_NAME))     # as a lab loads it
    kinds = sorted(stream['info']['type'][0] for stream in loaded)
    assert kinds == ['Gaze', 'Markers']
    markers = next(s for s in loaded if s['info']['type'][0] == 'Markers')
    gaze = next(s for s in loaded if s['info']['type'][0] == 'Gaze')
    events = [(float(t), parse_marker(text[0]))
              for t, text in zip(markers['time_stamps'], markers['time_series'])]

    def of(kind):
        return [(t, body) for t, body in events if body['event'] == kind]

    session = read_session(out / demo.BAG_NAME)
    # Every question, choice, round without one and drive is in both.
    assert [body['label'] for _, body in of('choice')] == [text for _, text in session.choices]
    assert len(of('question')) == len(session.requests)
    assert len(of('no_choice')) == len(session.no_choices)
    assert [[body['x'], body['y']] for _, body in of('goal')] == [
        pytest.approx(goal[:2], abs=1e-3) for _, goal in session.goals]
    assert len(of('arrived')) == 1 and session.progress[-1][1].startswith('arrived')
    assert [s['chosen'] for s in summary['selections']] == \
        [body['label'] for _, body in sorted(of('answer') + of('go'), key=lambda e: e[0])]
    # Stamps: a question is marked when it is asked, on the LSL clock; the bag holds its
    # reception on the ROS clock, in the same process: one offset between the clocks.
    offsets = np.array([t_bag - t_xdf for (t_xdf, _), t_bag in zip(of('question'),
                                                                   sorted(session.requests))])
    assert np.ptp(offsets) < 0.05, offsets
    offset = float(np.median(offsets))
    period = np.median(np.diff(gaze['time_stamps']))
    for (t_xdf, body), (t_bag, _) in zip(of('choice'), session.choices):
        # The choice lies on its last gaze sample in the XDF (within one sample), and the
        # bag received it after that sample, within the decision's latency.
        assert np.min(np.abs(gaze['time_stamps'] - t_xdf)) <= period
        assert np.min(np.abs(session.gaze_t - (t_xdf + offset))) <= period + 0.01
        assert 0.0 <= t_bag - (t_xdf + offset) < 0.5


@pytest.mark.ros
@pytest.mark.lsl
def test_session_report_reads_the_xdf_alone_and_compares_it_with_the_bag(quick_run, tmp_path):
    from eye_bci_ros2.experiments import session_report

    _, _, out, summary = quick_run
    chosen = [s['chosen'] for s in summary['selections']]
    assert session_report.main([str(out / demo.XDF_NAME), '-o', str(tmp_path / 'xdf')]) == 0
    alone = json.loads((tmp_path / 'xdf' / 'report.json').read_text())
    assert [q['chosen'] for q in alone['questions'] if q['chosen']] == chosen
    assert all(q['gaze_samples'] > 0 for q in alone['questions'])
    assert alone['cued'] == 0 and alone['drives'][0]['goal'][:2] == pytest.approx(
        summary['selections'][1]['robot']['goal'][:2], abs=1e-3)
    assert session_report.main([str(out / demo.BAG_NAME), str(out / demo.XDF_NAME),
                                '-o', str(tmp_path / 'both')]) == 0
    both = json.loads((tmp_path / 'both' / 'report.json').read_text())['xdf']
    assert both['same_choices'] is True
    for kind in ('questions', 'choices', 'no_choice_rounds', 'goals'):
        assert both[kind][0] == both[kind][1] > 0 or kind == 'no_choice_rounds', kind
    # Each choice reached the bag after its last gaze sample, within the decision latency.
    assert len(both['choice_lag_s']) == len(chosen)
    assert all(0.0 <= lag < 0.5 for lag in both['choice_lag_s']), both['choice_lag_s']
