"""The menu's protocol as a pure state machine (no ROS): ask on arrival, look away, pause, back."""

import numpy as np
import pytest

from eye_bci_ros2.projection.camera_model import look_at_pose, rviz_intrinsic
from eye_bci_ros2.projection.geometry import project_points
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.task.menu import (Answer, ASKING, BACK_LABEL, back_marker, FINISHED, LOOK_AWAY,
                                    MenuProtocol, Offer, PAUSED, ProtocolSettings, READY, Request,
                                    Result, WAITING_FOR_CAMERA)
from eye_bci_ros2.task.scene import load_scene

SCENE = load_scene(default_scene_path())
ROOMS = ('kitchen', 'living_room', 'bedroom', 'office')
KITCHEN = SCENE.room('kitchen')
TABLES = ('kitchen/table_1', 'kitchen/table_2', 'kitchen/table_3', BACK_LABEL)
SQUARE = np.array([[100.0, 100.0], [200.0, 100.0], [200.0, 200.0], [100.0, 200.0]])


def kinds(actions, kind):
    return [a for a in actions if isinstance(a, kind)]


def at(view):
    """camera/pose of a view: position, quaternion (optical)."""
    return look_at_pose(*view.as_tuple())


def arrive(menu, view, now):
    return menu.on_camera_pose(*at(view), now)


def asked_menu(**settings):
    """Return a menu that offered the rooms, saw the camera arrive and asked."""
    menu = MenuProtocol(SCENE, ProtocolSettings(**settings))
    menu.start(0.0)
    assert menu.state == WAITING_FOR_CAMERA
    assert kinds(arrive(menu, SCENE.overview, 0.5), Request)
    assert menu.state == ASKING
    return menu


def test_asks_only_when_the_camera_has_arrived():
    menu = MenuProtocol(SCENE)
    actions = menu.start(0.0)
    offer = kinds(actions, Offer)[0]
    assert tuple(m.text for m in offer.markers) == ROOMS and offer.view is SCENE.overview
    assert not kinds(actions, Request)
    # The camera moves towards the goal: still not asked.
    position, quaternion = at(SCENE.overview)
    for step, now in enumerate((0.1, 0.2, 0.3)):
        assert not kinds(menu.on_camera_pose(position + [0, 0, 1.0 - step * 0.3], quaternion,
                                             now), Request)
    assert menu.state == WAITING_FOR_CAMERA
    assert kinds(menu.on_camera_pose(position + [0, 0, 0.01], quaternion, 0.4), Request)
    assert menu.state == ASKING
    # Asked once only.
    assert not kinds(menu.on_camera_pose(position, quaternion, 0.5), Request)
    assert not kinds(menu.tick(3.0), Request)


def test_a_camera_that_stops_short_counts_as_arrived_once_settled():
    menu = MenuProtocol(SCENE, ProtocolSettings(settle_s=1.0))
    menu.start(0.0)
    position, quaternion = at(SCENE.overview)
    menu.on_camera_pose(position + [2.0, 0, 0], quaternion, 0.2)
    menu.on_camera_pose(position + [1.0, 0, 0], quaternion, 0.4)    # still moving
    assert not kinds(menu.tick(1.3), Request)
    assert kinds(menu.tick(1.41), Request)
    # Without any camera/pose at all (static view): asked after settle_s.
    still = MenuProtocol(SCENE, ProtocolSettings(settle_s=1.0))
    still.start(0.0)
    assert not kinds(still.tick(0.9), Request) and kinds(still.tick(1.0), Request)


def test_choices_count_only_as_answers():
    menu = MenuProtocol(SCENE)
    menu.start(0.0)
    # The arbiter decides while the camera moves: ignored.
    assert not kinds(menu.on_choice('kitchen', 0.3), Offer)
    assert menu.options == ROOMS
    arrive(menu, SCENE.overview, 0.5)
    # In flight when the request went out: not its answer.
    assert not kinds(menu.on_choice('kitchen', 0.55), Offer)
    assert menu.state == ASKING
    # An unknown label asks again.
    actions = menu.on_choice('garage', 1.0)
    assert kinds(actions, Request) and menu.asked_at == 1.0
    actions = menu.on_choice('kitchen', 1.5)
    offer = kinds(actions, Offer)[0]
    assert tuple(m.text for m in offer.markers) == TABLES and offer.view is KITCHEN.view


def test_back_option_returns_to_the_rooms_without_an_outcome():
    menu = asked_menu(look_away_s=0.5)
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 2.0)
    assert menu.state == ASKING
    actions = menu.on_choice(BACK_LABEL, 3.0)
    assert not kinds(actions, Result)
    assert tuple(m.text for m in kinds(actions, Offer)[0].markers) == ROOMS
    without = asked_menu(back_option=False)
    without.on_choice('kitchen', 1.0)
    assert BACK_LABEL not in without.options


def test_back_marker_is_in_view_at_the_lower_left_and_faces_the_camera():
    marker = back_marker(KITCHEN.view)
    intrinsic = rviz_intrinsic(1280, 720)
    uv, depth = project_points(marker.position[None], intrinsic, KITCHEN.view.external())
    assert depth[0] > 0
    assert 0 < uv[0, 0] < 640 * 0.4 and 720 * 0.75 < uv[0, 1] < 720
    np.testing.assert_allclose(marker.orientation, at(KITCHEN.view)[1])
    tables = np.array([t.marker.position for t in KITCHEN.tables])
    table_uv, _ = project_points(tables, intrinsic, KITCHEN.view.external())
    assert np.min(np.hypot(*(table_uv - uv[0]).T)) > 150


def test_after_a_choice_the_gaze_must_leave_the_chosen_option():
    menu = asked_menu(look_away_s=5.0, look_away_margin_px=10.0)
    menu.on_regions(['kitchen', 'office'], np.stack([SQUARE, SQUARE + 300]))
    menu.on_choice('kitchen', 1.0)
    assert kinds(arrive(menu, KITCHEN.view, 1.5), Request) == []
    assert menu.state == LOOK_AWAY
    assert not kinds(menu.on_gaze_point(150.0, 150.0, 1.6), Request)   # still on it
    assert not kinds(menu.on_gaze_point(205.0, 150.0, 1.7), Request)   # within the margin
    assert kinds(menu.on_gaze_point(260.0, 150.0, 1.8), Request)
    assert menu.state == ASKING


def test_or_a_pause_passes():
    menu = asked_menu(look_away_s=1.5)
    menu.on_regions(['kitchen'], SQUARE[None])
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 1.2)
    menu.on_gaze_point(150.0, 150.0, 2.0)
    assert menu.state == LOOK_AWAY
    assert kinds(menu.tick(2.5), Request)


def test_gaze_off_screen_pauses_and_resumes_with_a_new_question():
    menu = asked_menu(pause_after_s=2.0)
    assert not menu.on_screen(False, 1.0)
    assert menu.tick(2.9) == [] and menu.state == ASKING
    menu.tick(3.0)
    assert menu.state == PAUSED
    # A choice while paused is not an answer.
    assert not kinds(menu.on_choice('kitchen', 3.5), Offer)
    assert not kinds(menu.tick(10.0), Request)
    actions = menu.on_screen(True, 11.0)
    assert kinds(actions, Request) and menu.state == ASKING
    assert kinds(menu.on_choice('kitchen', 11.5), Offer)
    # A short look away does not pause.
    menu2 = asked_menu(pause_after_s=2.0)
    menu2.on_screen(False, 1.0)
    menu2.on_screen(True, 2.5)
    assert menu2.tick(4.0) == [] and menu2.state == ASKING


def test_outcome_then_rooms_again_or_finish():
    menu = asked_menu(look_away_s=0.2)
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 1.5)
    actions = menu.on_choice('kitchen/table_2', 2.0)
    assert [r.label for r in kinds(actions, Result)] == ['kitchen/table_2']
    assert menu.options == ROOMS
    done = asked_menu(repeat=False, look_away_s=0.2)
    done.on_choice('kitchen', 1.0)
    arrive(done, KITCHEN.view, 1.5)
    actions = done.on_choice('kitchen/table_1', 2.0)
    assert kinds(actions, Offer)[0].markers == () and done.state == FINISHED
    assert not kinds(done.on_choice('kitchen', 3.0), Offer)


def test_previous_behaviour_without_ask_on_arrival():
    menu = MenuProtocol(SCENE, ProtocolSettings(ask_on_arrival=False, back_option=False))
    assert not kinds(menu.start(0.0), Request)
    assert kinds(menu.on_choice('kitchen', 0.1), Offer)
    assert menu.state in (READY, WAITING_FOR_CAMERA)
    assert kinds(menu.on_choice('garage', 0.2), Request)


def test_bad_settings_and_poses_say_why():
    with pytest.raises(ValueError, match='settle_s'):
        ProtocolSettings(settle_s=-1.0)
    menu = MenuProtocol(SCENE)
    menu.start(0.0)
    assert 'ignored' in menu.on_camera_pose([np.nan, 0, 0], [0, 0, 0, 1], 0.1)[0].text


def test_a_round_without_a_choice_asks_the_question_again():
    menu = asked_menu()                      # asked at 0.5 s
    assert menu.on_no_choice('no sample in any region', 0.55) == []  # the replaced round
    again = menu.on_no_choice('no sample in any region', 1.6)
    assert len(kinds(again, Request)) == 1 and menu.state == ASKING
    assert menu.asked_at == 1.6
    # Only the answer to the new question counts; once answered nothing is asked again.
    assert kinds(menu.on_choice('kitchen', 1.65), Offer) == []
    assert kinds(menu.on_choice('kitchen', 1.8), Answer) == [Answer('kitchen')]
    assert menu.on_no_choice('late round', 1.9) == []


def test_every_choice_the_menu_acts_on_is_an_answer():
    menu = asked_menu(back_option=True)
    assert kinds(menu.on_choice('kitchen', 1.0), Answer) == [Answer('kitchen')]
    arrive(menu, KITCHEN.view, 2.0)
    menu.tick(4.0)                           # look-away pause over: asked again
    actions = menu.on_choice('kitchen/table_2', 4.5)
    assert kinds(actions, Answer) == [Answer('kitchen/table_2')]
    assert [r.label for r in kinds(actions, Result)] == ['kitchen/table_2']
    ignored = menu.on_choice('office', 4.6)  # not asked: ignored, no answer
    assert kinds(ignored, Answer) == []
