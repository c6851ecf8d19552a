"""The room -> table menu and its protocol, driven through its topics and parameters."""

import math
import os
import signal
import subprocess
import sys

from geometry_msgs.msg import PointStamped, PoseStamped
import numpy as np
from paths import REPO
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from scripted_navigator import GoalSender, ScriptedNavigator
from std_msgs.msg import Bool, Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.navigation.approach import scene_goals
from eye_bci_ros2.navigation.robot_settings import RobotSettings
from eye_bci_ros2.nodes.choice_menu import ChoiceMenu
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.ros.conversions import arrays_to_pose, pose_to_arrays, regions_to_marker_array
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.ros.topics import (EVENT_QOS, LATCHED_QOS, NAVIGATE_TO_POSE_ACTION,
                                     VIEW_QOS)
from eye_bci_ros2.sim.robot import SimRobot
from eye_bci_ros2.task.scene import load_scene

pytestmark = pytest.mark.ros

SCENE = load_scene(default_scene_path())
ROOMS = ['kitchen', 'living_room', 'bedroom', 'office']
KITCHEN_TABLES = ['kitchen/table_1', 'kitchen/table_2', 'kitchen/table_3', 'back']
#: Fast protocol timings for the tests (a person would use the defaults).
FAST = {'settle_s': 0.3, 'look_away_s': 0.6, 'pause_after_s': 0.5}

SMALL_SCENE = """
frame_id: map
overview: {eye: [0, -5, 10], focus: [0, 0, 0], up: [0, 0, 1]}
rooms:
  - name: hall
    marker: {position: [-2, 0, 0.1], scale: [1, 1, 0.05]}
    view: {eye: [-2, -3, 4], focus: [-2, 0, 0], up: [0, 0, 1]}
    tables:
      - name: desk
        marker: {position: [-2, 0, 0.8], scale: [0.5, 0.5, 0.05]}
  - name: lab
    marker: {position: [2, 0, 0.1], scale: [1, 1, 0.05]}
    view: {eye: [2, -3, 4], focus: [2, 0, 0], up: [0, 0, 1]}
    tables:
      - name: bench
        marker: {position: [2, 0, 0.8], scale: [0.5, 0.5, 0.05]}
"""


class Probe:
    """The menu's topics as a user (and the other nodes) see them."""

    def __init__(self, graph):
        node = graph.node('probe')
        self.node = node
        self.choices = Collector(node, MarkerArray, 'choices', LATCHED_QOS)
        self.goals = Collector(node, PoseStamped, 'camera/goal', LATCHED_QOS)
        self.results = Collector(node, String, 'choice_menu/result', EVENT_QOS)
        self.requests = Collector(node, Empty, 'choice/request', EVENT_QOS)
        self.states = Collector(node, String, 'choice_menu/state', LATCHED_QOS)
        self.progress = Collector(node, String, 'choice_menu/progress', LATCHED_QOS)
        self.publisher = node.create_publisher(String, 'choice', EVENT_QOS)
        self.no_choice = node.create_publisher(String, 'choice/none', EVENT_QOS)
        self.pose = node.create_publisher(PoseStamped, 'camera/pose', LATCHED_QOS)
        self.gaze = node.create_publisher(PointStamped, 'gaze/point', VIEW_QOS)
        self.on_screen = node.create_publisher(Bool, 'gaze/on_screen', LATCHED_QOS)
        self.regions = node.create_publisher(MarkerArray, 'choices/regions', LATCHED_QOS)
        self.graph = graph
        self.answered = 0

    def labels(self):
        """Labels of the current options (the last `choices` message)."""
        if self.choices.last is None:
            return None
        return [m.text for m in self.choices.last.markers if m.action == Marker.ADD]

    def wait_labels(self, labels):
        assert self.graph.spin_until(lambda: self.labels() == labels, 10.0), self.labels()

    def state(self):
        return self.states.last.data if self.states.last is not None else None

    def wait_state(self, state, timeout=10.0):
        assert self.graph.spin_until(lambda: self.state() == state, timeout), self.state()

    def choose(self, label):
        self.publisher.publish(String(data=label))

    def camera_at(self, view):
        """Publish camera/pose at a view (what the camera_tracker does when RViz got there)."""
        message = PoseStamped()
        message.header.frame_id = 'map'
        message.pose = arrays_to_pose(*look_at_pose(*view.as_tuple()))
        self.pose.publish(message)

    def look(self, x, y):
        message = PointStamped()
        message.header.frame_id = 'screen'
        message.point.x, message.point.y = float(x), float(y)
        self.gaze.publish(message)

    def progress_is(self, text, timeout=10.0):
        """Wait until choice_menu/progress says ``text`` (or starts with it, ``...``)."""
        def said():
            last = self.progress.last
            if last is None:
                return False
            if text.endswith('...'):
                return last.data.startswith(text[:-3])
            return last.data == text
        assert self.graph.spin_until(said, timeout), self.progress.last

    def answer_when_asked(self, menu, label):
        """Answer the open question of the options shown now (asked maybe long ago)."""
        assert self.graph.spin_until(lambda: menu._protocol.asked_at is not None, 10.0), \
            self.state()
        self.answered = len(self.requests.messages)
        self.graph.spin_for(0.15)
        self.choose(label)

    def ask_and_answer(self, label):
        """Wait for a question not answered yet, then answer it."""
        assert self.graph.spin_until(lambda: len(self.requests.messages) > self.answered,
                                     10.0), self.state()
        self.answered = len(self.requests.messages)
        self.graph.spin_for(0.15)   # an answer comes at least min_answer_s after the question
        self.choose(label)


def goal_is(message, view):
    position, quaternion = pose_to_arrays(message.pose)
    expected_position, expected_quaternion = look_at_pose(*view.as_tuple())
    return bool(np.allclose(position, expected_position, atol=1e-9) and np.allclose(
        quaternion, expected_quaternion, atol=1e-9))


def start(graph, **overrides):
    probe = Probe(graph)
    settings = dict(FAST)
    settings.update(overrides)
    menu = graph.add(ChoiceMenu, parameter_overrides=[
        Parameter(name, value=value) for name, value in settings.items()])
    probe.wait_labels(ROOMS)
    assert graph.spin_until(lambda: probe.publisher.get_subscription_count() > 0 and all(
        menu.count_subscribers(topic) > 0 for topic in ('choice_menu/result', 'choice/request'))
        and probe.pose.get_subscription_count() > 0
        and probe.on_screen.get_subscription_count() > 0, 10.0)
    return menu, probe


def test_rooms_then_tables_then_outcome(graph):
    """Without a robot (robot_goals false) a table is the outcome at once."""
    menu, probe = start(graph, settle_s=30.0, robot_goals=False)
    array = probe.choices.last
    assert array.markers[0].action == Marker.DELETEALL  # old options vanish in RViz
    cubes = array.markers[1:]
    assert all(m.type == Marker.CUBE and m.header.frame_id == 'map' for m in cubes)
    kitchen = SCENE.room('kitchen')
    np.testing.assert_allclose([cubes[0].scale.x, cubes[0].scale.y, cubes[0].scale.z],
                               kitchen.marker.scale)
    np.testing.assert_allclose(pose_to_arrays(cubes[0].pose)[0], kitchen.marker.position)
    assert len({(m.ns, m.id) for m in cubes}) == len(cubes)
    assert graph.spin_until(lambda: probe.goals.last is not None, 10.0)
    assert goal_is(probe.goals.last, SCENE.overview)
    assert probe.goals.last.header.frame_id == 'map'

    # Not asked before the camera arrives; a decision meanwhile does not count.
    graph.spin_for(0.3)
    assert not probe.requests.messages and probe.state() == 'waiting_for_camera'
    probe.choose('kitchen')
    graph.spin_for(0.3)
    assert probe.labels() == ROOMS
    probe.camera_at(SCENE.overview)
    probe.ask_and_answer('kitchen')
    # The camera moves: the rooms are withdrawn and the tables not shown until it is there
    # (issue 33: options offered while it moved were part of the set, and flickered twice).
    probe.wait_labels([])
    assert graph.spin_until(lambda: goal_is(probe.goals.last, kitchen.view), 10.0)
    graph.spin_for(0.3)
    assert probe.labels() == []
    probe.camera_at(kitchen.view)
    probe.wait_labels(KITCHEN_TABLES)
    table = kitchen.table('kitchen/table_2').marker
    np.testing.assert_allclose(pose_to_arrays(probe.choices.last.markers[2].pose)[1],
                               table.orientation)
    asked = len(probe.requests.messages)
    probe.ask_and_answer('kitchen/table_2')
    assert len(probe.requests.messages) == asked + 1
    assert graph.spin_until(lambda: probe.results.messages, 10.0)
    assert [m.data for m in probe.results.messages] == ['kitchen/table_2']
    # repeat (default): start over, once the camera is back at the overview.
    assert graph.spin_until(lambda: goal_is(probe.goals.last, SCENE.overview), 10.0)
    probe.camera_at(SCENE.overview)
    probe.wait_labels(ROOMS)


def test_a_camera_without_pose_is_asked_once_settled(graph):
    menu, probe = start(graph, settle_s=0.5)
    assert graph.spin_until(lambda: probe.requests.messages, 5.0)
    graph.spin_for(0.5)
    assert len(probe.requests.messages) == 1 and probe.state() == 'asking'


def test_back_returns_to_the_rooms(graph):
    menu, probe = start(graph)
    probe.ask_and_answer('office')
    probe.wait_labels(['office/table_1', 'office/table_2', 'office/table_3', 'back'])
    back = probe.choices.last.markers[4]
    assert (back.ns, back.id, back.text) == ('tables', 3, 'back')
    probe.ask_and_answer('back')
    probe.wait_labels(ROOMS)
    assert not probe.results.messages
    assert graph.set_parameters('/choice_menu', {'back_option': False})[0].successful
    probe.ask_and_answer('office')
    probe.wait_labels(['office/table_1', 'office/table_2', 'office/table_3'])


def test_the_gaze_must_leave_the_chosen_option(graph):
    menu, probe = start(graph, look_away_s=30.0)
    square = np.array([[[100.0, 100.0], [200.0, 100.0], [200.0, 200.0], [100.0, 200.0]]])
    sources = [Marker(ns='rooms', id=0, text='kitchen')]
    probe.regions.publish(regions_to_marker_array(square, sources, probe.node.get_clock()
                                                  .now().to_msg()))
    graph.spin_for(0.2)
    probe.ask_and_answer('kitchen')
    probe.wait_labels(KITCHEN_TABLES)
    asked = len(probe.requests.messages)
    probe.wait_state('waiting_for_look_away')
    probe.look(150, 150)        # still on the kitchen's place
    graph.spin_for(0.8)
    assert len(probe.requests.messages) == asked
    probe.look(400, 150)        # one sample out: a spike, not yet a look elsewhere
    graph.spin_for(0.3)
    assert len(probe.requests.messages) == asked
    for _ in range(4):          # the gaze stays out: it has left
        probe.look(400, 150)
        graph.spin_for(0.05)
    assert graph.spin_until(lambda: len(probe.requests.messages) == asked + 1, 5.0)


def test_a_still_gaze_where_the_table_was_chosen_is_never_asked_again(graph):
    """The live fault: a gaze left where a table was cycled table -> confirm -> back."""
    menu, probe = start(graph, look_away_s=0.3)
    probe.ask_and_answer('kitchen')
    probe.wait_labels(KITCHEN_TABLES)
    square = np.array([[[100.0, 100.0], [200.0, 100.0], [200.0, 200.0], [100.0, 200.0]]])
    sources = [Marker(ns='tables', id=1, text='kitchen/table_2')]
    probe.regions.publish(regions_to_marker_array(square, sources, probe.node.get_clock()
                                                  .now().to_msg()))
    probe.ask_and_answer('kitchen/table_2')
    probe.wait_labels(CONFIRM)
    asked = len(probe.requests.messages)
    # A still gaze on the table's place (tracker noise, one spike out) for over six times
    # look_away_s: the gaze never left, so the confirmation is never asked.
    rng = np.random.default_rng(1)
    for k in range(60):
        x, y = 150.0 + rng.normal(0.0, 4.0, 2)
        probe.look(400.0 if k == 20 else x, y)
        graph.spin_for(1.0 / 30.0)
    assert probe.state() == 'waiting_for_look_away'
    assert len(probe.requests.messages) == asked
    # The gaze goes elsewhere and stays: now it has left, and the question is asked.
    for _ in range(5):
        probe.look(600.0, 150.0)
        graph.spin_for(0.05)
    assert graph.spin_until(lambda: len(probe.requests.messages) == asked + 1, 5.0)


def test_off_screen_pauses_and_resumes(graph):
    menu, probe = start(graph)
    probe.wait_state('asking')
    asked = len(probe.requests.messages)
    probe.on_screen.publish(Bool(data=False))
    probe.wait_state('paused')
    probe.choose('kitchen')         # a decision during the pause does not count
    graph.spin_for(0.3)
    assert probe.labels() == ROOMS
    probe.on_screen.publish(Bool(data=True))
    probe.wait_state('asking')
    assert len(probe.requests.messages) == asked + 1   # asked again
    probe.ask_and_answer('kitchen')
    probe.wait_labels(KITCHEN_TABLES)


def test_invalid_choices_are_ignored(graph):
    menu, probe = start(graph, robot_goals=False)
    offers = len(probe.choices.messages)
    for label in ('garage', 'kitchen/table_1', '', 'Kitchen'):
        probe.ask_and_answer(label)
    # Each one asks the arbiter for a new decision; nothing else changes.
    assert graph.spin_until(lambda: len(probe.requests.messages) == 5, 10.0)
    assert len(probe.choices.messages) == offers and probe.labels() == ROOMS
    assert menu.options == tuple(ROOMS)

    # A valid answer's offer must come; the menu publishes its offers in order, so one
    # made late for an invalid answer would come before it.
    probe.ask_and_answer('office')
    office = ['office/table_1', 'office/table_2', 'office/table_3', 'back']
    probe.wait_labels(office)
    assert len(probe.choices.messages) == offers + 1
    probe.ask_and_answer('kitchen/table_1')  # a table of another room
    probe.ask_and_answer('office')  # a room, while tables are offered
    assert probe.labels() == office and not probe.results.messages
    # Likewise the result of a valid answer: a late one for those two would come first.
    probe.ask_and_answer('office/table_3')
    assert graph.spin_until(lambda: probe.results.messages, 10.0)
    assert [m.data for m in probe.results.messages] == ['office/table_3']


def test_finishes_when_not_repeating(graph):
    menu, probe = start(graph, repeat=False, robot_goals=False)
    probe.ask_and_answer('bedroom')
    probe.wait_labels(['bedroom/table_1', 'bedroom/table_2', 'bedroom/table_3', 'back'])
    probe.ask_and_answer('bedroom/table_1')
    assert graph.spin_until(lambda: probe.results.messages, 10.0)
    probe.wait_labels([])
    assert [m.action for m in probe.choices.last.markers] == [Marker.DELETEALL]
    probe.wait_state('finished')
    offers = len(probe.choices.messages)
    probe.choose('bedroom')
    graph.spin_for(0.5)
    assert len(probe.choices.messages) == offers and menu.options == ()
    assert [m.data for m in probe.results.messages] == ['bedroom/table_1']


def test_previous_behaviour_without_ask_on_arrival(graph):
    menu, probe = start(graph, ask_on_arrival=False, back_option=False)
    probe.choose('kitchen')
    probe.wait_labels(['kitchen/table_1', 'kitchen/table_2', 'kitchen/table_3'])
    graph.spin_for(0.3)
    assert not probe.requests.messages  # new labels: the arbiter starts a round itself


def test_bad_protocol_parameter_is_rejected(graph):
    menu, probe = start(graph)
    result = graph.set_parameters('/choice_menu', {'settle_s': -1.0})[0]
    assert not result.successful
    assert graph.set_parameters('/choice_menu', {'settle_s': 2.0})[0].successful


def test_bad_scene_file_refuses_to_start(graph, tmp_path):
    path = tmp_path / 'bad.yaml'
    path.write_text(SMALL_SCENE.replace('scale: [1, 1, 0.05]', 'scale: [1, -1, 0.05]', 1))
    with pytest.raises(ValueError,
                       match=r'scene_file: .*bad\.yaml:\d+: rooms\[0\]\.marker\.scale'):
        graph.add(ChoiceMenu, parameter_overrides=[Parameter('scene_file', value=str(path))])
    with pytest.raises(ValueError, match="frame 'map' but world_frame is 'odom'"):
        graph.add(ChoiceMenu, parameter_overrides=[Parameter('world_frame', value='odom')])


def test_scene_file_parameter_reloads_or_rejects(graph, tmp_path):
    menu, probe = start(graph, robot_goals=False)
    bad = tmp_path / 'bad.yaml'
    bad.write_text(SMALL_SCENE.replace('up: [0, 0, 1]', 'up: [0, 0.5, -1]', 1))
    result = graph.set_parameters('/choice_menu', {'scene_file': str(bad)})[0]
    assert not result.successful
    assert str(bad) in result.reason and 'parallel to the view' in result.reason
    result = graph.set_parameters('/choice_menu', {'scene_file': str(tmp_path / 'nope.yaml')})[0]
    assert not result.successful and 'cannot read scene file' in result.reason
    result = graph.set_parameters('/choice_menu', {'world_frame': 'odom'})[0]
    assert not result.successful and 'frame_id' in result.reason
    probe.ask_and_answer('kitchen')  # the old scene still works
    probe.wait_labels(KITCHEN_TABLES)

    good = tmp_path / 'small.yaml'
    good.write_text(SMALL_SCENE)
    assert graph.set_parameters('/choice_menu', {'scene_file': str(good)})[0].successful
    probe.wait_labels(['hall', 'lab'])  # reloaded: starts over at the rooms
    small = load_scene(good)
    assert graph.spin_until(lambda: goal_is(probe.goals.last, small.overview), 10.0)
    requests = len(probe.requests.messages)
    # Reloading the same labels: asked again once the camera is there.
    assert graph.set_parameters('/choice_menu', {'scene_file': str(good)})[0].successful
    assert graph.spin_until(lambda: len(probe.requests.messages) > requests, 10.0)
    probe.ask_and_answer('lab')
    probe.wait_labels(['lab/bench', 'back'])
    probe.ask_and_answer('lab/bench')
    assert graph.spin_until(lambda: probe.results.messages, 10.0)
    assert probe.results.last.data == 'lab/bench'


# -- the robot: confirm, NavigateToPose, stop (a cancel), feedback, the result ---------------

GOALS = scene_goals(SCENE, 0.3)
CONFIRM = ['go', 'back']
TABLE = 'kitchen/table_2'


def goal_pose(message):
    """x, y, yaw of a PoseStamped goal."""
    position, quaternion = pose_to_arrays(message.pose)
    return np.array([position[0], position[1],
                     2 * math.atan2(quaternion[2], quaternion[3])])


def same_heading(a, b):
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi) < 1e-6


def confirming(graph, table=TABLE, **overrides):
    """Start a menu and answer up to its 'go' or 'back' question after a table."""
    menu, probe = start(graph, **overrides)
    probe.ask_and_answer(table.split('/')[0])
    probe.wait_labels(KITCHEN_TABLES)
    probe.ask_and_answer(table)
    probe.wait_labels(CONFIRM)
    return menu, probe


def go_and_send(probe):
    """Answer 'go', then the second look: 'send' (the menu's default send_rounds)."""
    probe.ask_and_answer('go')
    probe.wait_labels(['send', 'back'])
    probe.ask_and_answer('send')


def driving(graph, **overrides):
    """Return a menu whose 'go' the scripted navigator accepted and executes, probe, navigator."""
    navigator = graph.add(ScriptedNavigator)
    menu, probe = confirming(graph, **overrides)
    assert graph.spin_until(lambda: menu._navigator.server_is_ready(), 10.0)
    go_and_send(probe)
    assert graph.spin_until(lambda: navigator.executing, 10.0)
    probe.wait_labels(['stop'])
    return menu, probe, navigator


def test_go_then_send_sends_a_navigation_goal_and_its_success_offers_the_rooms(graph):
    navigator = graph.add(ScriptedNavigator)
    menu, probe = confirming(graph)
    graph.spin_for(0.3)
    assert not navigator.goals and not probe.results.messages
    probe.ask_and_answer('go')
    probe.wait_labels(['send', 'back'])           # 'go' alone sends nothing: the second look
    graph.spin_for(0.3)
    assert not navigator.goals and not probe.results.messages
    probe.ask_and_answer('send')
    assert graph.spin_until(lambda: navigator.executing, 10.0)
    goal = navigator.goals[-1]
    assert goal.header.frame_id == 'map'
    x, y, yaw = goal_pose(goal)
    np.testing.assert_allclose([x, y], GOALS[TABLE][:2], atol=1e-9)
    assert same_heading(yaw, GOALS[TABLE][2])
    assert [m.data for m in probe.results.messages] == [TABLE]
    probe.wait_labels(['stop'])
    probe.wait_state('driving')
    navigator.feedback(3.04)
    probe.progress_is(f"driving to '{TABLE}': 3.0 m left")
    navigator.feedback(0.1)         # nearly there: still driving until the result says
    probe.progress_is(f"driving to '{TABLE}': 0.1 m left")
    graph.spin_for(0.3)
    assert probe.labels() == ['stop']
    navigator.finish('succeed')
    probe.progress_is(f"arrived at '{TABLE}'")
    probe.wait_labels(ROOMS)    # the next task
    assert len(navigator.goals) == 1 and navigator.cancels == 0


def test_no_navigation_server_is_said_at_once(graph):
    # No timeout involved: the feedback timeout is ten minutes.
    menu, probe = confirming(graph, feedback_timeout_s=600.0)
    # A server of an earlier test on this domain may linger in discovery for a moment.
    assert graph.spin_until(lambda: not menu._navigator.server_is_ready(), 30.0)
    go_and_send(probe)
    probe.progress_is(f"the robot refused the goal to '{TABLE}': no navigation server on "
                      f'/{NAVIGATE_TO_POSE_ACTION}: choose again')
    probe.wait_labels(KITCHEN_TABLES)


def test_a_rejected_goal_is_said_at_once(graph):
    navigator = graph.add(ScriptedNavigator, accept=False)
    menu, probe = confirming(graph, feedback_timeout_s=600.0)
    assert graph.spin_until(lambda: menu._navigator.server_is_ready(), 10.0)
    go_and_send(probe)
    probe.progress_is(f"the robot refused the goal to '{TABLE}': /{NAVIGATE_TO_POSE_ACTION} "
                      'rejected it: choose again')
    probe.wait_labels(KITCHEN_TABLES)
    assert len(navigator.goals) == 1


def test_an_aborted_goal_is_said_in_nav2s_words(graph):
    menu, probe, navigator = driving(graph)
    navigator.feedback(4.0)
    navigator.finish('abort', 208, 'no path through the kitchen door')
    probe.progress_is(f"the robot did not reach '{TABLE}': there is no path to the goal (no "
                      'path through the kitchen door): choose again')
    probe.wait_labels(KITCHEN_TABLES)


def test_a_feedback_gap_is_said_and_stop_stays_offered(graph):
    menu, probe, navigator = driving(graph, feedback_timeout_s=1.0)
    navigator.feedback(5.0)
    probe.progress_is(f"driving to '{TABLE}': 5.0 m left")
    probe.progress_is('no feedback from the robot for 1 s...')
    assert probe.labels() == ['stop'] and menu.state == 'driving' and navigator.executing
    navigator.feedback(4.0)             # it speaks again: the drive goes on
    probe.progress_is(f"driving to '{TABLE}': 4.0 m left")
    navigator.finish('succeed')
    probe.progress_is(f"arrived at '{TABLE}'")
    assert navigator.cancels == 0 and len(navigator.goals) == 1


def test_the_menu_reads_no_odometry(graph):
    menu, probe = start(graph)
    topics = {subscription.topic_name for subscription in menu.subscriptions}
    assert not topics & {'/odom', '/goal_pose'}
    assert not {publisher.topic_name for publisher in menu.publishers} & {'/goal_pose'}


@pytest.mark.parametrize('when', ['accepted', 'with feedback', 'silent'])
def test_stop_is_a_cancel_in_every_drive_state(graph, when):
    menu, probe, navigator = driving(graph, feedback_timeout_s=1.0)
    if when != 'accepted':
        navigator.feedback(6.0)
        probe.progress_is(f"driving to '{TABLE}': 6.0 m left")
    if when == 'silent':
        probe.progress_is('no feedback from the robot...')
    probe.ask_and_answer('stop')
    assert graph.spin_until(lambda: navigator.cancels == 1, 10.0)
    probe.progress_is(f"stopped on the way to '{TABLE}'")
    probe.wait_labels(ROOMS)
    assert len(navigator.goals) == 1      # no goal: a stop is a cancel


def test_a_refused_stop_is_said_and_stop_cancels_again(graph):
    menu, probe, navigator = driving(graph)
    navigator.accept_cancel = False
    probe.ask_and_answer('stop')
    probe.progress_is(f"the robot refused the stop on the way to '{TABLE}' (the server "
                      "rejected it): choose 'stop' again")
    assert probe.labels() == ['stop'] and navigator.executing
    navigator.accept_cancel = True
    probe.ask_and_answer('stop')
    probe.progress_is(f"stopped on the way to '{TABLE}'")
    assert navigator.cancels == 2 and len(navigator.goals) == 1


def test_a_menu_restarted_mid_drive_offers_stop_first(graph):
    navigator = graph.add(ScriptedNavigator)
    # The goal of a menu that died without a word (SIGKILL): a client gone, its goal driving.
    dead_menu = graph.add(GoalSender)
    assert graph.spin_until(dead_menu.client.server_is_ready, 10.0)
    dead_menu.send()
    assert graph.spin_until(lambda: navigator.executing, 10.0)
    probe = Probe(graph)
    menu = graph.add(ChoiceMenu, parameter_overrides=[
        Parameter(name, value=value) for name, value in FAST.items()])
    probe.wait_labels(['stop'])
    probe.progress_is('the robot drives to a goal this menu did not send...')
    probe.answer_when_asked(menu, 'stop')
    assert graph.spin_until(lambda: navigator.cancels == 1 and not navigator.executing, 10.0)
    probe.progress_is('the robot stopped')
    probe.wait_labels(ROOMS)        # then the menu starts over
    assert len(navigator.goals) == 1 and menu.state != 'driving'


def test_a_goal_that_preempts_the_menus_is_met_with_stop(graph, capfd):
    menu, probe, navigator = driving(graph)
    rviz_user = graph.add(GoalSender)
    assert graph.spin_until(rviz_user.client.server_is_ready, 10.0)
    rviz_user.send()                    # nav2 aborts the menu's goal, drives to this one
    probe.progress_is("the robot drives to a goal this menu did not send: 'stop' is offered "
                      'first')
    # Said in the log too (the latched progress topic may carry only the newer line).
    assert f"the robot did not reach '{TABLE}': it ended without a reason (another goal may " \
        'have taken its place): choose again' in capfd.readouterr().err
    probe.wait_labels(['stop'])
    probe.answer_when_asked(menu, 'stop')
    probe.progress_is('the robot stopped')
    probe.wait_labels(ROOMS)
    assert len(navigator.goals) == 2 and navigator.cancels == 1


def test_looking_away_neither_sends_nor_stops(graph):
    navigator = graph.add(ScriptedNavigator)
    menu, probe = confirming(graph)
    probe.on_screen.publish(Bool(data=False))         # the person looks away: no 'go'
    probe.wait_state('paused')
    graph.spin_for(1.0)
    assert not navigator.goals and probe.labels() == CONFIRM
    probe.on_screen.publish(Bool(data=True))
    go_and_send(probe)
    assert graph.spin_until(lambda: navigator.executing, 10.0)
    probe.on_screen.publish(Bool(data=False))         # ... and it drives on
    probe.wait_state('paused')
    for step in range(5):
        navigator.feedback(5.0 - step)
        graph.spin_for(0.2)
    assert len(navigator.goals) == 1 and navigator.cancels == 0
    assert menu.options == ('stop',) and navigator.executing
    assert probe.progress.last.data.startswith('driving')


def test_back_in_the_confirmation_sends_no_goal(graph):
    navigator = graph.add(ScriptedNavigator)
    menu, probe = confirming(graph)
    probe.ask_and_answer('back')
    probe.wait_labels(KITCHEN_TABLES)
    probe.ask_and_answer('back')       # and back to the rooms: no destination either
    probe.wait_labels(ROOMS)
    graph.spin_for(0.5)
    assert not navigator.goals and not probe.results.messages


def test_an_unanswered_confirmation_returns_to_the_tables_and_sends_nothing(graph):
    navigator = graph.add(ScriptedNavigator)
    menu, probe = start(graph, confirm_rounds=2, min_answer_s=0.0)
    probe.ask_and_answer('kitchen')
    probe.wait_labels(KITCHEN_TABLES)
    probe.ask_and_answer('kitchen/table_2')
    asked = probe.answered          # the tables' question, answered
    for _ in range(2):      # the confirmation asked, then the arbiter's round without a choice
        assert graph.spin_until(lambda: len(probe.requests.messages) > asked, 10.0)
        asked = len(probe.requests.messages)
        assert probe.labels() == CONFIRM
        probe.no_choice.publish(String(data='no fixation'))
    probe.wait_labels(KITCHEN_TABLES)
    assert not navigator.goals and not probe.results.messages


def test_ctrl_c_mid_drive_cancels_the_goal(graph):
    """The menu's process gets SIGINT (Ctrl-C, launch's shutdown): the server sees the cancel."""
    navigator = graph.add(ScriptedNavigator)
    probe = Probe(graph)
    arguments = [f'{name}:={value}' for name, value in FAST.items()]
    env = dict(os.environ, ROS_DOMAIN_ID=str(graph.domain))
    process = subprocess.Popen(
        [sys.executable, '-m', 'eye_bci_ros2.nodes.choice_menu', '--ros-args',
         *[part for argument in arguments for part in ('-p', argument)]],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, cwd=REPO)
    try:
        probe.wait_labels(ROOMS)
        assert graph.spin_until(lambda: probe.publisher.get_subscription_count() > 0, 30.0)
        probe.wait_state('asking', 30.0)        # asked maybe before the probe listened
        probe.answered = len(probe.requests.messages)
        graph.spin_for(0.15)
        probe.choose('kitchen')
        probe.wait_labels(KITCHEN_TABLES)
        probe.ask_and_answer(TABLE)
        probe.wait_labels(CONFIRM)
        go_and_send(probe)
        assert graph.spin_until(lambda: navigator.executing, 20.0)
        navigator.feedback(7.0)
        probe.progress_is(f"driving to '{TABLE}': 7.0 m left")
        process.send_signal(signal.SIGINT)
        assert graph.spin_until(lambda: navigator.cancels == 1, 20.0)
        assert graph.spin_until(lambda: process.poll() is not None, 20.0)
        output = process.stdout.read()
        assert process.returncode == 0, output
        assert 'the robot goal is cancelled: the menu ends' in output
        assert 'Traceback' not in output and len(navigator.goals) == 1
    finally:
        if process.poll() is None:
            process.kill()
        process.wait()


# -- the real menu and the real sim_robot, at real speed --------------------------------------

def test_the_menu_drives_sim_robot_across_the_scene_at_real_speed(graph):
    """'go' to a table two rooms away: the robot at 0.5 m/s, the menu says it all."""
    robot = graph.add(SimRobot)
    menu, probe = start(graph)
    table = 'office/table_3'        # from (5, 5) through two doors: about 14 m
    probe.ask_and_answer('office')
    probe.wait_labels(['office/table_1', 'office/table_2', table, 'back'])
    probe.ask_and_answer(table)
    probe.wait_labels(CONFIRM)
    assert graph.spin_until(lambda: menu._navigator.server_is_ready(), 10.0)
    go_and_send(probe)
    probe.wait_labels(['stop'])
    probe.progress_is(f"driving to '{table}'...")
    sent = len(probe.progress.messages)
    # 0.5 m/s at most: 30 s or more; the menu follows the whole way.
    probe.progress_is(f"arrived at '{table}'", timeout=120.0)
    lines = [m.data for m in probe.progress.messages[sent - 1:]]
    left = [float(line.split(': ')[1].split(' m')[0]) for line in lines
            if line.startswith('driving to')]
    assert left[0] > 10.0 and left[-1] < 1.0 and left == sorted(left, reverse=True), lines
    assert not [line for line in lines if line.startswith(('no feedback', 'the robot did'))]
    probe.wait_labels(ROOMS)
    # The simulated robot stands at the menu's goal.
    goal = menu.robot_goals[table]
    pose = robot.drive.pose
    assert math.hypot(*(pose[:2] - goal[:2])) <= RobotSettings().goal_tolerance_m


def test_stop_stands_sim_robot_mid_drive(graph):
    """'stop' while cruising: a cancel; the robot brakes and stands, nothing drives it back."""
    robot = graph.add(SimRobot)
    menu, probe = start(graph)
    probe.ask_and_answer('living_room')
    probe.wait_labels(['living_room/table_1', 'living_room/table_2', 'living_room/table_3',
                       'back'])
    probe.ask_and_answer('living_room/table_3')
    probe.wait_labels(CONFIRM)
    assert graph.spin_until(lambda: menu._navigator.server_is_ready(), 10.0)
    go_and_send(probe)
    probe.wait_labels(['stop'])
    start_pose = np.array(robot.drive.pose)
    assert graph.spin_until(lambda: math.hypot(*(robot.drive.pose[:2] - start_pose[:2]))
                            > 2.0, 60.0)
    probe.ask_and_answer('stop')
    probe.progress_is("stopped on the way to 'living_room/table_3'", timeout=10.0)
    stood = np.array(robot.drive.pose)
    graph.spin_for(1.0)
    assert np.allclose(robot.drive.pose, stood, atol=1e-6)      # standing still
    assert math.hypot(*(stood[:2] - start_pose[:2])) > 2.0     # not driven back
    probe.wait_labels(ROOMS)
