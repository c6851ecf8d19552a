"""The room -> table menu and its protocol, driven through its topics and parameters."""

import math

from geometry_msgs.msg import PointStamped, PoseStamped
from nav_msgs.msg import Odometry
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from std_msgs.msg import Bool, Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.navigation.approach import scene_goals
from eye_bci_ros2.nodes.choice_menu import ChoiceMenu
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.ros.conversions import arrays_to_pose, pose_to_arrays, regions_to_marker_array
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.ros.topics import EVENT_QOS, GOAL_QOS, LATCHED_QOS, ODOM_QOS, VIEW_QOS
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
        self.robot_goals = Collector(node, PoseStamped, 'goal_pose', GOAL_QOS)
        self.progress = Collector(node, String, 'choice_menu/progress', LATCHED_QOS)
        self.odom = node.create_publisher(Odometry, 'odom', ODOM_QOS)
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

    def robot_at(self, x, y, yaw, frame='map'):
        """Publish the robot's odometry (what sim_robot or a nav2 robot does)."""
        message = Odometry()
        message.header.frame_id = frame
        message.header.stamp = self.node.get_clock().now().to_msg()
        message.pose.pose = arrays_to_pose([x, y, 0.0], [0.0, 0.0, math.sin(yaw / 2),
                                                         math.cos(yaw / 2)])
        self.odom.publish(message)

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


# -- the robot: confirm, goal_pose, stop, progress, arrival ---------------------------------

GOALS = scene_goals(SCENE, 0.3)
CONFIRM = ['go', 'back']


def goal_pose(message):
    """x, y, yaw of a goal_pose message."""
    position, quaternion = pose_to_arrays(message.pose)
    return np.array([position[0], position[1],
                     2 * math.atan2(quaternion[2], quaternion[3])])


def same_heading(a, b):
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi) < 1e-6


def confirming(graph, table='kitchen/table_2', **overrides):
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


def test_go_then_send_sends_the_approach_pose_and_arrival_offers_the_rooms(graph):
    menu, probe = confirming(graph)
    graph.spin_for(0.3)
    assert not probe.robot_goals.messages and not probe.results.messages
    probe.robot_at(2.0, 7.0, 0.0)
    probe.ask_and_answer('go')
    probe.wait_labels(['send', 'back'])           # 'go' alone sends nothing: the second look
    graph.spin_for(0.3)
    assert not probe.robot_goals.messages and not probe.results.messages
    probe.ask_and_answer('send')
    assert graph.spin_until(lambda: probe.robot_goals.messages, 10.0)
    goal = probe.robot_goals.last
    assert goal.header.frame_id == 'map'
    x, y, yaw = goal_pose(goal)
    expected = GOALS['kitchen/table_2']
    np.testing.assert_allclose([x, y], expected[:2], atol=1e-9)
    assert same_heading(yaw, expected[2])
    assert [m.data for m in probe.results.messages] == ['kitchen/table_2']
    probe.wait_labels(['stop'])
    probe.wait_state('driving')
    left = math.hypot(x - 2.0, y - 7.0)
    assert graph.spin_until(lambda: probe.progress.last is not None and probe.progress.last.data
                            == f"driving to 'kitchen/table_2': {left:.1f} m left", 10.0), \
        probe.progress.last
    probe.robot_at(x - 1.0, y, yaw)
    assert graph.spin_until(lambda: probe.progress.last.data.endswith(': 1.0 m left'), 10.0)
    probe.robot_at(x - 0.1, y + 0.05, yaw + 0.1)
    assert graph.spin_until(lambda: probe.progress.last.data
                            == "arrived at 'kitchen/table_2'", 10.0)
    probe.wait_labels(ROOMS)    # the next task
    assert len(probe.robot_goals.messages) == 1


def test_back_in_the_confirmation_sends_no_goal(graph):
    menu, probe = confirming(graph)
    probe.ask_and_answer('back')
    probe.wait_labels(KITCHEN_TABLES)
    probe.ask_and_answer('back')       # and back to the rooms: no destination either
    probe.wait_labels(ROOMS)
    graph.spin_for(0.5)
    assert not probe.robot_goals.messages and not probe.results.messages


def test_stop_while_driving_sends_a_goal_at_the_robots_pose(graph):
    menu, probe = confirming(graph)
    go_and_send(probe)
    probe.wait_labels(['stop'])
    probe.robot_at(3.0, 8.0, 0.5)
    assert graph.spin_until(lambda: probe.progress.last.data.endswith('m left'), 10.0)
    probe.ask_and_answer('stop')
    assert graph.spin_until(lambda: len(probe.robot_goals.messages) == 2, 10.0)
    x, y, yaw = goal_pose(probe.robot_goals.last)
    np.testing.assert_allclose([x, y], [3.0, 8.0], atol=1e-9)
    assert same_heading(yaw, 0.5)
    assert graph.spin_until(lambda: probe.progress.last.data.startswith('stopped'), 10.0)


def test_looking_away_neither_sends_nor_stops(graph):
    menu, probe = confirming(graph)
    probe.on_screen.publish(Bool(data=False))         # the person looks away: no 'go'
    probe.wait_state('paused')
    graph.spin_for(1.0)
    assert not probe.robot_goals.messages and probe.labels() == CONFIRM
    probe.on_screen.publish(Bool(data=True))
    go_and_send(probe)
    probe.wait_labels(['stop'])
    probe.on_screen.publish(Bool(data=False))         # ... and it drives on
    probe.wait_state('paused')
    for step in range(5):
        probe.robot_at(2.0 + 0.2 * step, 7.0, 0.0)
        graph.spin_for(0.2)
    assert len(probe.robot_goals.messages) == 1 and menu.options == ('stop',)
    assert probe.progress.last.data.startswith('driving')


def test_an_unanswered_confirmation_returns_to_the_tables_and_sends_nothing(graph):
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
    assert not probe.robot_goals.messages and not probe.results.messages


def test_a_robot_that_does_not_move_is_reported(graph):
    menu, probe = confirming(graph, drive_timeout_s=1.0)
    go_and_send(probe)
    probe.robot_at(2.0, 7.0, 0.0, frame='odom')       # not the map frame: ignored
    assert graph.spin_until(lambda: probe.progress.last is not None and 'did not move'
                            in probe.progress.last.data, 10.0)
    assert 'no odometry' in probe.progress.last.data
    probe.wait_labels(KITCHEN_TABLES)                 # the task again
    assert len(probe.robot_goals.messages) == 1       # nothing more sent: no pose known
