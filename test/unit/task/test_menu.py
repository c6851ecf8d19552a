"""The menu's protocol as a pure state machine (no ROS): ask on arrival, look away, pause, back."""

import numpy as np
import pytest

from eye_bci_ros2.projection.camera_model import look_at_pose, rviz_intrinsic
from eye_bci_ros2.projection.geometry import project_points
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.task.menu import (ABORTED, Answer, ASKING, BACK_LABEL, back_marker,
                                    CANCELED, CancelGoal, confirm_markers, DRIVING, FINISHED,
                                    GO_LABEL, Log, LOOK_AWAY, MenuProtocol, Offer, PAUSED,
                                    Progress, ProtocolSettings, READY, Request, Result,
                                    SEND_DOWN, SEND_LABEL, send_marker, SendGoal, STOP_LABEL,
                                    SUCCEEDED, VALIDATING, WAITING_FOR_CAMERA)
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
    actions = menu.tick(1.41)
    assert kinds(actions, Request)
    assert [log.text for log in kinds(actions, Log)] == [
        'camera settled (1 s without moving): taken as arrived']
    # Without any camera/pose at all (static view): asked after settle_s.
    still = MenuProtocol(SCENE, ProtocolSettings(settle_s=1.0))
    still.start(0.0)
    assert not kinds(still.tick(0.9), Request)
    actions = still.tick(1.0)
    assert kinds(actions, Request)
    # ... and says so: no "camera settled", as there is no camera.
    said = [log.text for log in kinds(actions, Log)]
    assert said == ['no camera/pose in 1 s: asking without waiting for the camera'], said


def test_choices_count_only_as_answers():
    menu = MenuProtocol(SCENE)
    menu.start(0.0)
    # The arbiter decides while the camera moves: ignored.
    assert not kinds(menu.on_choice('kitchen', 0.3), Offer)
    assert menu.options == ROOMS
    arrive(menu, SCENE.overview, 0.5)
    # In flight when the request went out: not its answer.
    assert not kinds(menu.on_choice('kitchen', 0.52), Offer)
    assert menu.state == ASKING
    # An unknown label asks again.
    actions = menu.on_choice('garage', 1.0)
    assert kinds(actions, Request) and menu.asked_at == 1.0
    actions = menu.on_choice('kitchen', 1.5)
    offer = kinds(actions, Offer)[0]
    assert offer.markers == () and offer.view is KITCHEN.view   # the camera moves first
    shown = kinds(arrive(menu, KITCHEN.view, 2.0), Offer)[0]
    assert tuple(m.text for m in shown.markers) == TABLES and shown.view is None


def test_back_option_returns_to_the_rooms_without_an_outcome():
    menu = asked_menu(look_away_s=0.5)
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 2.0)
    assert menu.state == ASKING
    actions = menu.on_choice(BACK_LABEL, 3.0)
    assert not kinds(actions, Result)
    assert menu.options == ROOMS and kinds(actions, Offer)[0].view is SCENE.overview
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
    # Out, judged from the samples: a run of LEFT_SAMPLES spanning LEFT_S or more.
    assert not kinds(menu.on_gaze_point(260.0, 150.0, 1.8), Request)
    assert not kinds(menu.on_gaze_point(262.0, 152.0, 1.85), Request)
    actions = menu.on_gaze_point(261.0, 149.0, 1.9)
    assert kinds(actions, Request) and 'gaze left the chosen option' in [
        a.text for a in kinds(actions, Log)]
    assert menu.state == ASKING


def test_a_gaze_that_never_left_has_not_left_however_long_it_stays():
    menu = asked_menu(look_away_s=1.5)
    menu.on_regions(['kitchen'], SQUARE[None])
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 1.2)
    # A still gaze on the chosen place, with a tracker's spikes beyond the margin (one
    # sample, or two within 0.05 s): never "left", never asked, long after look_away_s.
    rng = np.random.default_rng(0)
    spikes = {30: 400.0, 90: 380.0, 91: 390.0}
    for k in range(300):                        # 10 s at 30 Hz
        now = 2.0 + k / 30.0
        x, y = 150.0 + rng.normal(0, 5, 2)
        actions = menu.on_gaze_point(spikes.get(k, x), y, now) + menu.tick(now)
        assert not kinds(actions, Request), now
        assert 'gaze left the chosen option' not in [a.text for a in kinds(actions, Log)]
    assert menu.state == LOOK_AWAY
    # Without a gaze point since the choice there is nothing to judge: look_away_s passes.
    menu = asked_menu(look_away_s=1.5)
    menu.on_regions(['kitchen'], SQUARE[None])
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 1.2)
    assert not kinds(menu.tick(2.4), Request)
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
    """Without a robot (robot_goals false) the table is the outcome at once."""
    menu = asked_menu(look_away_s=0.2, robot_goals=False)
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 1.5)
    actions = menu.on_choice('kitchen/table_2', 2.0)
    assert [r.label for r in kinds(actions, Result)] == ['kitchen/table_2']
    assert menu.options == ROOMS
    done = asked_menu(repeat=False, look_away_s=0.2, robot_goals=False)
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
    assert menu.on_no_choice('no sample in any region', 0.52) == []  # the replaced round
    again = menu.on_no_choice('no sample in any region', 1.6)
    assert len(kinds(again, Request)) == 1 and menu.state == ASKING
    assert menu.asked_at == 1.6
    # Only the answer to the new question counts; once answered nothing is asked again.
    assert kinds(menu.on_choice('kitchen', 1.62), Offer) == []
    assert kinds(menu.on_choice('kitchen', 1.8), Answer) == [Answer('kitchen')]
    assert menu.on_no_choice('late round', 1.9) == []


def test_the_arbiters_fastest_answer_counts_as_the_answer():
    # A fresh look at 'go' or 'send' decides second_look_dwell_s after the round start
    # that the request opened: taken as made before the question, the round that answered
    # it is gone and the menu waits for ever (make demo on a loaded machine).
    from eye_bci_ros2.decision.rounds import ArbiterSettings
    arbiter = ArbiterSettings()
    fastest = min(arbiter.dwell_s, arbiter.second_look_dwell_s)
    menu = asked_menu()                      # asked at 0.5 s
    assert kinds(menu.on_choice('kitchen', 0.5 + fastest), Answer) == [Answer('kitchen')]


def test_a_choice_ignored_as_made_before_the_question_asks_again():
    # The menu cannot tell by its arrival whether an early choice is the replaced round's
    # or the one its question opened (closed by that choice): asked again, the arbiter has
    # a round for the question either way, and only its answer counts.
    menu = asked_menu(min_answer_s=0.1)      # asked at 0.5 s
    actions = menu.on_choice('kitchen', 0.55)
    assert kinds(actions, Answer) == [] and len(kinds(actions, Request)) == 1
    assert menu.state == ASKING and menu.asked_at == 0.55
    assert kinds(menu.on_choice('kitchen', 0.6), Answer) == []
    assert kinds(menu.on_choice('kitchen', 0.9), Answer) == [Answer('kitchen')]


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


# -- options shown once the view has settled (issue 33, point 7) ------------------------------

def test_options_appear_once_when_the_camera_has_settled():
    """Back to the rooms: none is offered while the camera moves, all four once it is there."""
    menu = asked_menu(look_away_s=0.2)
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 1.5)
    actions = menu.on_choice(BACK_LABEL, 2.0)
    offers = kinds(actions, Offer)
    assert [o.markers for o in offers] == [()] and offers[0].view is SCENE.overview
    position, quaternion = at(SCENE.overview)
    shown = []
    for step, now in enumerate(np.arange(2.1, 2.6, 0.1)):     # on its way
        shown += kinds(menu.on_camera_pose(position + [0, -3.0 + 0.6 * step, 0], quaternion,
                                           now), Offer)
        shown += kinds(menu.tick(now + 0.05), Offer)
    assert shown == [] and menu.state == WAITING_FOR_CAMERA
    shown = kinds(menu.on_camera_pose(position, quaternion, 2.7), Offer)
    assert [tuple(m.text for m in o.markers) for o in shown] == [ROOMS]
    assert shown[0].view is None                 # the camera goal was sent with the withdrawal
    assert not kinds(menu.tick(5.0), Offer)      # offered once
    # A camera that stops short: shown when it has settled (settle_s), once.
    menu.on_choice('office', 3.0)
    menu.on_camera_pose(position + [1.0, 0, 0], quaternion, 3.1)
    assert not kinds(menu.tick(3.9), Offer)
    assert len(kinds(menu.tick(4.2), Offer)) == 1 and not kinds(menu.tick(4.5), Offer)


# -- the robot: confirm, goal, stop, progress, arrival --------------------------------------

#: A goal per table (x, y, yaw): a metre south of the table, facing north.
GOALS = {table.marker.text: np.array([table.marker.position[0],
                                      table.marker.position[1] - 1.0, np.pi / 2])
         for room in SCENE.rooms for table in room.tables}
TABLE = 'kitchen/table_2'


def confirming(**settings):
    """
    Return a menu asking 'go' or 'back' after kitchen/table_2 was chosen, and the time.

    'go' sends at once here (send_rounds 0); the second look, 'send', has its own tests.
    """
    menu = MenuProtocol(SCENE, ProtocolSettings(
        **{'look_away_s': 0.2, 'send_rounds': 0, **settings}), GOALS)
    menu.start(0.0)
    arrive(menu, SCENE.overview, 0.5)
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 1.5)
    actions = menu.on_choice(TABLE, 2.0)
    assert not kinds(actions, SendGoal) and not kinds(actions, Result)
    assert menu.options == (GO_LABEL, BACK_LABEL) and menu.pending == TABLE
    assert kinds(menu.tick(2.3), Request) and menu.state == ASKING
    return menu, 2.5


def driving(accept=True, **settings):
    """Return a menu whose 'go' was just chosen (and accepted), its actions and the time."""
    menu, now = confirming(**settings)
    actions = menu.on_choice(GO_LABEL, now)
    if accept:
        actions += menu.on_goal_response(True, '', now + 0.1)
    return menu, actions, now


def test_a_table_is_sent_only_after_go():
    menu, actions, now = driving(accept=False)
    goal = kinds(actions, SendGoal)
    assert [g.label for g in goal] == [TABLE]
    np.testing.assert_allclose(goal[0].pose, GOALS[TABLE])
    assert [r.label for r in kinds(actions, Result)] == [TABLE]
    assert menu.options == (STOP_LABEL,) and menu.state == DRIVING
    # The stop is asked at once: no look-away gate, no camera move.
    assert kinds(actions, Request)
    assert kinds(actions, Progress)[0].text == f"sending the robot to '{TABLE}'"
    # The distance left comes from the robot's feedback.
    menu.on_goal_response(True, '', now + 0.1)
    assert kinds(menu.on_feedback(3.04, now + 0.2), Progress)[0].text == \
        f"driving to '{TABLE}': 3.0 m left"


def test_an_unanswered_confirmation_returns_to_the_tables_without_a_goal():
    menu, now = confirming(confirm_rounds=3)
    for t in (3.3, 4.3):                        # asked at 2.3 s: two rounds without a choice
        assert kinds(menu.on_no_choice('no fixation', t), Request) and menu.pending == TABLE
    actions = menu.on_no_choice('no fixation', 5.3)
    assert f"no answer to '{TABLE}' in 3 rounds" in [a.text for a in kinds(actions, Log)]
    assert not kinds(actions, SendGoal) and not kinds(actions, Result)
    assert menu.options == TABLES and menu.pending is None
    # A late 'go' is no answer any more; the next confirmation has its own 3 rounds.
    assert not kinds(menu.on_choice(GO_LABEL, 5.5), SendGoal)
    menu.tick(7.0)
    menu.on_choice(TABLE, 7.5)
    assert kinds(menu.tick(7.8), Request) and menu.pending == TABLE
    for t in (8.8, 9.8):
        menu.on_no_choice('no fixation', t)
    assert [g.label for g in kinds(menu.on_choice(GO_LABEL, 10.0), SendGoal)] == [TABLE]
    # Rounds while paused are not the person's: not counted.
    menu, now = confirming(confirm_rounds=1, pause_after_s=1.0)
    menu.on_screen(False, 2.5)
    assert [a.text for a in menu.tick(3.5)] == ['gaze off screen for 1 s: paused']
    assert menu.on_no_choice('no fixation', 4.0) == [] and menu.pending == TABLE
    with pytest.raises(ValueError, match='confirm_rounds must be an integer >= 1'):
        ProtocolSettings(confirm_rounds=0)


def test_go_offers_send_where_the_gaze_was_not_and_only_send_sends_the_robot():
    menu, now = confirming(send_rounds=1)
    actions = menu.on_choice(GO_LABEL, now)
    assert not kinds(actions, SendGoal) and not kinds(actions, Result)
    assert menu.options == (SEND_LABEL, BACK_LABEL) and menu.pending == TABLE
    # Asked at once (no look-away gate: 'send' is not where the gaze is), in the same view.
    assert kinds(actions, Request) and menu.state == ASKING
    assert kinds(actions, Offer)[0].view is not None and \
        kinds(actions, Offer)[0].view is KITCHEN.view
    # 'send' lies SEND_DOWN half-heights from 'go', far from 'back' and every table.
    intrinsic = rviz_intrinsic(1280, 720)
    go, back = confirm_markers(KITCHEN.view, KITCHEN.table(TABLE).marker)
    send, back_on_go = kinds(actions, Offer)[0].markers
    assert send.text == SEND_LABEL
    # 'back' where the gaze that chose 'go' rests: staying there can only undo.
    assert back_on_go.text == BACK_LABEL and np.allclose(back_on_go.position, go.position)
    uv, depth = project_points(np.array([go.position, back.position, send.position]
                                        + [t.marker.position for t in KITCHEN.tables]),
                               intrinsic, KITCHEN.view.external())
    assert np.all(depth > 0) and np.all((uv >= 0) & (uv <= [1280, 720]))
    assert np.hypot(*(uv[2] - uv[0])) >= 0.75 * SEND_DOWN * 360       # its own saccade
    assert np.hypot(*(uv[[1, 3, 4, 5]] - uv[2]).T).min() > 0.5 * 640
    actions = menu.on_choice(SEND_LABEL, now + 0.5)
    assert [g.label for g in kinds(actions, SendGoal)] == [TABLE]
    assert [r.label for r in kinds(actions, Result)] == [TABLE]
    assert menu.options == (STOP_LABEL,) and menu.state == DRIVING


def test_back_in_the_send_step_sends_nothing_and_offers_the_tables():
    menu, now = confirming(send_rounds=1)
    menu.on_choice(GO_LABEL, now)
    actions = menu.on_choice(BACK_LABEL, now + 0.5)
    assert not kinds(actions, SendGoal) and not kinds(actions, Result)
    logged = [a.text for a in kinds(actions, Log)]
    assert f"'{TABLE}' not confirmed: back to the tables" in logged
    assert menu.options == TABLES and menu.pending is None
    # Offered again ('reoffer', e.g. a new world frame): 'send' and 'back' again.
    menu.tick(now + 1.0)
    menu.on_choice(TABLE, now + 1.5)
    menu.tick(now + 3.5)
    menu.on_choice(GO_LABEL, now + 4.0)
    assert [m.text for m in kinds(menu.reoffer(now + 4.1), Offer)[0].markers] == [
        SEND_LABEL, BACK_LABEL]


def test_send_unanswered_returns_to_the_tables_without_a_goal():
    menu, now = confirming(send_rounds=1)
    menu.on_choice(GO_LABEL, now)
    actions = menu.on_no_choice('no fixation', now + 1.0)
    assert f"no answer to '{SEND_LABEL}' in 1 rounds" in [a.text for a in kinds(actions, Log)]
    assert not kinds(actions, SendGoal) and menu.options == TABLES and menu.pending is None
    # A late 'send' is no answer; the next table's confirmation starts with 'go' again.
    assert not kinds(menu.on_choice(SEND_LABEL, now + 1.2), SendGoal)
    menu.tick(now + 2.0)
    menu.on_choice(TABLE, now + 2.5)
    assert menu.options == (GO_LABEL, BACK_LABEL)
    with pytest.raises(ValueError, match='send_rounds must be an integer >= 0'):
        ProtocolSettings(send_rounds=-1)
    # The menu's defaults: a second look, asked one round; the confirmation two.
    assert (ProtocolSettings().send_rounds, ProtocolSettings().confirm_rounds) == (1, 2)


def test_back_in_the_confirmation_sends_nothing_and_offers_the_tables():
    menu, now = confirming()
    actions = menu.on_choice(BACK_LABEL, now)
    assert not kinds(actions, SendGoal) and not kinds(actions, Result)
    assert menu.options == TABLES and menu.pending is None
    # Rooms and back are no destinations; a table is confirmed again.
    menu.tick(now + 0.5)
    assert not kinds(menu.on_choice(BACK_LABEL, now + 1.0), SendGoal)
    assert menu.options == ROOMS


def test_looking_away_neither_sends_nor_stops():
    menu, now = confirming(pause_after_s=1.0)
    menu.on_screen(False, now)
    for t in np.arange(now, now + 30.0, 0.5):       # the person looks away for 30 s
        assert not kinds(menu.tick(t), SendGoal)
    assert menu.state == PAUSED and menu.pending == TABLE
    menu.on_screen(True, now + 30.0)
    menu, actions, now = driving(pause_after_s=1.0)
    menu.on_screen(False, now + 0.1)
    later = []
    for step, t in enumerate(np.arange(now + 0.5, now + 20.0, 0.5)):
        later += menu.on_feedback(5.0 - 0.1 * step, t) + menu.tick(t)
    assert not kinds(later, (SendGoal, CancelGoal)) and menu.drive is not None
    assert menu.state == PAUSED


def test_stop_is_a_cancel_and_stays_offered_until_the_goal_has_ended():
    menu, actions, now = driving()
    menu.on_feedback(2.0, now + 1.0)
    actions = menu.on_choice(STOP_LABEL, now + 1.2)
    assert kinds(actions, CancelGoal) == [CancelGoal(every=False)]
    assert not kinds(actions, SendGoal)
    assert kinds(actions, Progress)[0].text == f"stopping on the way to '{TABLE}'"
    assert menu.options == (STOP_LABEL,) and menu.state != ASKING
    # The robot brakes: its feedback says no more progress; the end says stopped.
    assert not kinds(menu.on_feedback(1.8, now + 1.4), Progress)
    assert menu.on_cancel_response(True, '', now + 1.3)[0].level == 'info'
    actions = menu.on_goal_result(CANCELED, '', now + 2.0)
    assert kinds(actions, Progress)[0].text == f"stopped on the way to '{TABLE}'"
    assert menu.drive is None and menu.options == ROOMS     # the next task
    assert not kinds(actions, (SendGoal, CancelGoal))


def test_stop_in_every_drive_state_never_sends_a_goal():
    # Before the goal is accepted: the cancel goes out when it is.
    menu, actions, now = driving(accept=False)
    actions = menu.on_choice(STOP_LABEL, now + 0.2)
    assert not kinds(actions, (CancelGoal, SendGoal))
    assert kinds(menu.on_goal_response(True, '', now + 0.3), CancelGoal) == [CancelGoal()]
    # ... or it was refused anyway: nothing to cancel.
    menu, actions, now = driving(accept=False)
    menu.on_choice(STOP_LABEL, now + 0.2)
    actions = menu.on_goal_response(False, 'rejected', now + 0.3)
    assert not kinds(actions, (CancelGoal, SendGoal)) and menu.drive is None
    # While silent: a cancel.
    menu, actions, now = driving()
    menu.tick(now + 10.0)
    menu.tick(now + 10.5)
    assert kinds(menu.on_choice(STOP_LABEL, now + 11.0), CancelGoal) == [CancelGoal()]
    # A refused cancel is said; 'stop' is offered and cancels again.
    actions = menu.on_cancel_response(False, 'refused', now + 11.1)
    assert 'refused the stop' in kinds(actions, Progress)[0].text
    assert menu.options == (STOP_LABEL,) and menu.drive is not None
    menu.tick(now + 13.0)
    assert kinds(menu.on_choice(STOP_LABEL, now + 13.5), CancelGoal)
    # The robot arrived before the cancel reached it: arrived.
    actions = menu.on_goal_result(SUCCEEDED, '', now + 13.6)
    assert kinds(actions, Progress)[0].text == f"arrived at '{TABLE}'"


def test_arrival_and_failure_come_from_the_result_and_progress_from_feedback():
    menu, actions, now = driving()
    lines = []
    for step, distance in enumerate((2.5, 2.45, 2.3, 1.0, 0.3, 0.0)):
        lines += kinds(menu.on_feedback(distance, now + step), Progress)
    # A line when the distance left changed by 0.1 m or more.
    assert [p.text for p in lines] == [f"driving to '{TABLE}': {d} m left"
                                       for d in ('2.5', '2.3', '1.0', '0.3', '0.0')]
    assert menu.state == DRIVING            # no guess: only the result ends the drive
    actions = menu.on_goal_result(SUCCEEDED, '', now + 7)
    assert kinds(actions, Progress)[-1].text == f"arrived at '{TABLE}'"
    assert menu.drive is None and menu.options == ROOMS
    assert not kinds(actions, (SendGoal, CancelGoal))
    done, _, now = driving(repeat=False)
    done.on_goal_result(SUCCEEDED, '', now + 1)
    assert done.state == FINISHED
    # Aborted: the reason in words, the tables again; nothing sent.
    menu, actions, now = driving()
    actions = menu.on_goal_result(ABORTED, 'there is no path to the goal', now + 1)
    text = kinds(actions, Progress)[0].text
    assert text == (f"the robot did not reach '{TABLE}': there is no path to the goal: "
                    'choose again')
    assert [a.text for a in kinds(actions, Log) if a.level == 'warning'] == [text]
    assert menu.options == TABLES and menu.drive is None
    assert not kinds(actions, (SendGoal, CancelGoal))
    # Cancelled by someone else: said, the tables again.
    menu, actions, now = driving()
    actions = menu.on_goal_result(CANCELED, '', now + 1)
    assert 'not by this menu' in kinds(actions, Progress)[0].text
    assert menu.options == TABLES


def test_a_refused_goal_is_said_at_once():
    menu, actions, now = driving(accept=False)
    actions = menu.on_goal_response(False, 'no navigation server on navigate_to_pose', now)
    text = kinds(actions, Progress)[0].text
    assert text == (f"the robot refused the goal to '{TABLE}': no navigation server on "
                    'navigate_to_pose: choose again')
    assert [a.text for a in kinds(actions, Log) if a.level == 'warning'] == [text]
    assert menu.options == TABLES and menu.drive is None
    assert not kinds(actions, (SendGoal, CancelGoal))
    # A late refusal of a goal no longer followed changes nothing.
    assert not kinds(menu.on_goal_response(False, 'gone', now + 1), (Offer, CancelGoal))


def test_silence_is_said_and_never_ends_the_drive():
    menu, actions, now = driving(feedback_timeout_s=3.0)
    for t in np.arange(now + 0.5, now + 60.0, 0.1):     # a minute of feedback, 0.5 m/s
        assert not kinds(menu.on_feedback(max(0.0, 30.0 - 0.5 * (t - now)), t)
                         + menu.tick(t), Log)
    assert menu.drive is not None and menu.state == DRIVING
    # No feedback for 3 s: one line, 'stop' stays offered.
    t = now + 60.0
    assert not kinds(menu.tick(t + 2.9), Log)
    actions = menu.tick(t + 3.0)
    text = kinds(actions, Progress)[0].text
    assert text.startswith('no feedback from the robot for 3 s') and "'stop'" in text
    assert [a.level for a in kinds(actions, Log)] == ['warning']
    assert not kinds(menu.tick(t + 10.0), Log)              # said once
    assert menu.options == (STOP_LABEL,) and menu.drive is not None
    assert not kinds(menu.tick(t + 100.0), (SendGoal, CancelGoal, Offer))
    assert kinds(menu.on_feedback(1.0, t + 101.0), Log)[0].text.startswith(
        'the robot answers again')
    # No answer to the goal (a server gone but not yet seen gone): given up, the tables
    # again; a late acceptance is cancelled.
    menu, actions, now = driving(accept=False, feedback_timeout_s=3.0)
    assert not kinds(menu.tick(now + 2.9), Log)
    actions = menu.tick(now + 3.0)
    assert kinds(actions, Progress)[0].text == (f"no answer to the goal to '{TABLE}' in 3 s: "
                                                'choose again')
    assert menu.drive is None and menu.options == TABLES
    assert kinds(menu.on_goal_response(True, '', now + 4.0), CancelGoal) == [CancelGoal()]
    with pytest.raises(ValueError, match='feedback_timeout_s'):
        ProtocolSettings(feedback_timeout_s=float('nan'))


def test_a_new_scene_while_driving_cancels_the_goal():
    menu, actions, now = driving()
    actions = menu.start(now + 1.0)
    assert kinds(actions, CancelGoal) == [CancelGoal()] and not kinds(actions, SendGoal)
    assert menu.drive is None and menu.options == ROOMS
    # ... a goal not yet accepted: nothing to cancel now (a late acceptance is not followed).
    menu, actions, now = driving(accept=False)
    assert not kinds(menu.start(now + 1.0), CancelGoal)
    assert not kinds(menu.cancel_drive('again', now + 1.0), CancelGoal)


def test_a_goal_the_menu_did_not_send_is_met_with_stop_first():
    menu = asked_menu(validate_first=False)
    actions = menu.on_other_goals(True, 1.0)
    assert menu.options == (STOP_LABEL,) and menu.state == DRIVING
    assert 'did not send' in kinds(actions, Progress)[0].text
    assert menu.on_other_goals(True, 1.1) == []             # said once
    arrive(menu, SCENE.overview, 1.2)
    assert menu.state == DRIVING and menu.asked_at is not None
    actions = menu.on_choice(STOP_LABEL, 1.5)
    assert kinds(actions, CancelGoal) == [CancelGoal(every=True)]
    # It ended (status): the menu starts over at the rooms.
    actions = menu.on_other_goals(False, 2.0)
    assert kinds(actions, Progress)[0].text == 'the robot stopped'
    assert menu.options == ROOMS and menu.drive is None
    # A room chosen while another's goal drives is no room: only 'stop' counts.
    menu = asked_menu()
    menu.on_other_goals(True, 1.0)
    assert 'not one of' in menu.on_choice('kitchen', 3.0)[0].text
    # The menu ending does not cancel a goal that is not its own; a new scene does.
    assert menu.cancel_drive('the menu ends', 3.0, own_only=True) == []
    assert kinds(menu.cancel_drive('new scene', 3.0), CancelGoal) == [CancelGoal(every=True)]
    # Even during the first validation: 'stop' first, the validation after it.
    menu = MenuProtocol(SCENE, ProtocolSettings(validate_first=True))
    menu.start(0.0)
    assert menu.state == VALIDATING
    menu.on_other_goals(True, 0.5)
    assert menu.options == (STOP_LABEL,)
    menu.on_other_goals(False, 2.0)
    assert menu.state == VALIDATING


def test_without_robot_goals_a_table_is_the_outcome_and_nothing_moves():
    menu = MenuProtocol(SCENE, ProtocolSettings(look_away_s=0.2, robot_goals=False), GOALS)
    menu.start(0.0)
    arrive(menu, SCENE.overview, 0.5)
    menu.on_choice('kitchen', 1.0)
    arrive(menu, KITCHEN.view, 1.5)
    actions = menu.on_choice(TABLE, 2.0)
    assert [r.label for r in kinds(actions, Result)] == [TABLE] and not kinds(actions, SendGoal)


def test_confirmation_layout_go_is_far_from_the_chosen_table():
    """'back' takes the chosen table's place, 'go' the other side of the view (Midas touch)."""
    intrinsic = rviz_intrinsic(1280, 720)
    for table in KITCHEN.tables:
        go, back = confirm_markers(KITCHEN.view, table.marker)
        uv, depth = project_points(np.array([table.marker.position, go.position,
                                             back.position]), intrinsic,
                                   KITCHEN.view.external())
        assert np.all(depth > 0) and np.all((uv >= 0) & (uv <= [1280, 720]))
        assert np.hypot(*(uv[1] - uv[0])) >= 0.6 * 640        # go: 384 px or more away
        assert np.hypot(*(uv[2] - uv[0])) < 60                 # back: where the table was
        assert go.position[2] > table.marker.position[2]        # above the tables and floor
        assert (go.text, back.text) == (GO_LABEL, BACK_LABEL)


def test_send_is_its_own_saccade_from_go_and_far_from_the_tables_in_every_room():
    intrinsic = rviz_intrinsic(1280, 720)
    for room in SCENE.rooms:
        tables = [t.marker for t in room.tables]
        for table in tables:
            go, back = confirm_markers(room.view, table)
            send = send_marker(room.view, go, [back] + tables)
            uv, depth = project_points(np.array([go.position, send.position]
                                                + [m.position for m in [back] + tables]),
                                       intrinsic, room.view.external())
            assert np.all(depth > 0) and np.all((uv[1] >= 54) & (uv[1] <= [1226, 666]))
            assert np.hypot(*(uv[1] - uv[0])) >= 0.75 * SEND_DOWN * 360, room.marker.text
            # About 6 deg or more from 'back' and every table: outside their 3 sigma halo.
            assert np.hypot(*(uv[2:] - uv[1]).T).min() >= 240, (room.marker.text, table.text)


def test_the_arbiters_urgent_option_is_the_menus_stop():
    # The fixation rule lets a resting gaze choose 'stop' (no look away and back): the
    # arbiter's default must name the menu's stop (decision may not import task).
    from eye_bci_ros2.decision.rounds import ArbiterSettings
    assert ArbiterSettings().urgent_label == STOP_LABEL
