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
from eye_bci_ros2.experiments.render import png_size
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.task.menu import BACK_LABEL, GO_LABEL, SEND_LABEL
from eye_bci_ros2.task.scene import load_scene

SCENE = load_scene(default_scene_path())


def test_wolpaw_bits_and_itr():
    assert demo.wolpaw_bits(4, 1.0) == pytest.approx(2.0)
    assert demo.wolpaw_bits(4, 0.9) == pytest.approx(
        2 + 0.9 * np.log2(0.9) + 0.1 * np.log2(0.1 / 3))
    assert demo.wolpaw_bits(4, 0.25) == 0.0  # chance carries nothing
    # Four 4-way and four 3-way choices, all right, 1.5 s each.
    itr = demo.itr_bits_per_minute([4, 3] * 4, 1.0, 1.5)
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
    assert robot['drive_s'] > 0 and robot['path_m'] > 0
    assert rooms['robot'] is None and confirm['robot'] is None and send['robot'] is None


@pytest.mark.ros
@pytest.mark.lsl
def test_quick_demo_writes_a_screen_picture_per_selection(quick_run):
    _, _, out, summary = quick_run
    pictures = [s['picture'] for s in summary['selections']]
    assert [os.path.basename(p) for p in pictures] == ['round1_rooms.png', 'round1_tables.png',
                                                       'round1_confirm.png', 'round1_send.png']
    for picture in pictures:
        assert png_size(picture) == demo.SCREEN_SIZE
        assert os.path.getsize(picture) > 20000
    with open(out / 'selections.csv', newline='') as stream:
        rows = list(csv.DictReader(stream))
    assert [row['correct'] for row in rows] == ['True', 'True', 'True', 'True']
    assert rows[0]['picture'] == 'round1_rooms.png'
    # The drive, from above: the map, the path driven, the goal and the robot.
    drive = summary['selections'][1]['robot']['picture']
    assert os.path.basename(drive) == 'round1_drive.png' and os.path.getsize(drive) > 20000
    assert rows[1]['robot_arrived'] == 'True' and len(rows[1]['robot_goal'].split()) == 3
    assert float(rows[1]['robot_path_m']) > 0 and rows[0]['robot_arrived'] == ''


@pytest.mark.ros
@pytest.mark.lsl
def test_demo_fails_cleanly_when_no_gaze_arrives(tmp_path, capsys):
    code = demo.main(['--quick', '--stream-timeout-s', '0.01', '--output-dir', str(tmp_path)])
    assert code == 1
    assert 'no gaze reached the pipeline within 0.01 s' in capsys.readouterr().err
    assert not os.listdir(tmp_path)


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
    assert printed.count('arrived after') == 4
