"""The room -> table menu, driven through its topics and parameters."""

from geometry_msgs.msg import PoseStamped
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from std_msgs.msg import Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.nodes.choice_menu import ChoiceMenu
from eye_bci_ros2.nodes.conversions import pose_to_arrays
from eye_bci_ros2.nodes.topics import EVENT_QOS, LATCHED_QOS
from eye_bci_ros2.scene import default_scene_path, load_scene
from eye_bci_ros2.view_animation import optical_pose

pytestmark = pytest.mark.ros

SCENE = load_scene(default_scene_path())
ROOMS = ['kitchen', 'living_room', 'bedroom', 'office']

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
    """The menu's topics as a user sees them."""

    def __init__(self, graph):
        node = graph.node('probe')
        self.choices = Collector(node, MarkerArray, 'choices', LATCHED_QOS)
        self.goals = Collector(node, PoseStamped, 'camera/goal', LATCHED_QOS)
        self.results = Collector(node, String, 'choice_menu/result', EVENT_QOS)
        self.requests = Collector(node, Empty, 'choice/request', EVENT_QOS)
        self.publisher = node.create_publisher(String, 'choice', EVENT_QOS)
        self.graph = graph

    def labels(self):
        """Labels of the current options (the last `choices` message)."""
        if self.choices.last is None:
            return None
        return [m.text for m in self.choices.last.markers if m.action == Marker.ADD]

    def wait_labels(self, labels):
        assert self.graph.spin_until(lambda: self.labels() == labels, 10.0), self.labels()

    def choose(self, label):
        self.publisher.publish(String(data=label))


def goal_is(message, view):
    position, quaternion = pose_to_arrays(message.pose)
    expected_position, expected_quaternion = optical_pose(*view.as_tuple())
    return bool(np.allclose(position, expected_position, atol=1e-9) and np.allclose(
        quaternion, expected_quaternion, atol=1e-9))


def start(graph, **overrides):
    probe = Probe(graph)
    menu = graph.add(ChoiceMenu, parameter_overrides=[
        Parameter(name, value=value) for name, value in overrides.items()])
    probe.wait_labels(ROOMS)
    assert graph.spin_until(lambda: probe.publisher.get_subscription_count() > 0 and all(
        menu.count_subscribers(topic) > 0 for topic in ('choice_menu/result', 'choice/request')),
        10.0)
    return menu, probe


def test_rooms_then_tables_then_outcome(graph):
    menu, probe = start(graph)
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

    probe.choose('kitchen')
    probe.wait_labels(['kitchen/table_1', 'kitchen/table_2', 'kitchen/table_3'])
    assert graph.spin_until(lambda: goal_is(probe.goals.last, kitchen.view), 10.0)
    table = kitchen.table('kitchen/table_2').marker
    np.testing.assert_allclose(pose_to_arrays(probe.choices.last.markers[2].pose)[1],
                               table.orientation)
    graph.spin_for(0.3)
    assert not probe.requests.messages  # new labels: the arbiter starts a round itself

    probe.choose('kitchen/table_2')
    assert graph.spin_until(lambda: probe.results.messages, 10.0)
    assert [m.data for m in probe.results.messages] == ['kitchen/table_2']
    probe.wait_labels(ROOMS)  # repeat (default): start over
    assert graph.spin_until(lambda: goal_is(probe.goals.last, SCENE.overview), 10.0)


def test_invalid_choices_are_ignored(graph):
    menu, probe = start(graph)
    offers = len(probe.choices.messages)
    for label in ('garage', 'kitchen/table_1', '', 'Kitchen'):
        probe.choose(label)
    # Each one asks the arbiter for a new decision; nothing else changes.
    assert graph.spin_until(lambda: len(probe.requests.messages) == 4, 10.0)
    assert len(probe.choices.messages) == offers and probe.labels() == ROOMS
    assert menu.options == tuple(ROOMS)

    probe.choose('office')
    probe.wait_labels(['office/table_1', 'office/table_2', 'office/table_3'])
    probe.choose('kitchen/table_1')  # a table of another room
    probe.choose('office')  # a room, while tables are offered
    graph.spin_for(0.5)
    assert probe.labels() == ['office/table_1', 'office/table_2', 'office/table_3']
    assert not probe.results.messages
    probe.choose('office/table_3')
    assert graph.spin_until(lambda: probe.results.messages, 10.0)
    assert probe.results.last.data == 'office/table_3'


def test_finishes_when_not_repeating(graph):
    menu, probe = start(graph, repeat=False)
    probe.choose('bedroom')
    probe.wait_labels(['bedroom/table_1', 'bedroom/table_2', 'bedroom/table_3'])
    probe.choose('bedroom/table_1')
    assert graph.spin_until(lambda: probe.results.messages, 10.0)
    probe.wait_labels([])
    assert [m.action for m in probe.choices.last.markers] == [Marker.DELETEALL]
    offers = len(probe.choices.messages)
    probe.choose('bedroom')
    graph.spin_for(0.5)
    assert len(probe.choices.messages) == offers and menu.options == ()
    assert [m.data for m in probe.results.messages] == ['bedroom/table_1']


def test_bad_scene_file_refuses_to_start(graph, tmp_path):
    path = tmp_path / 'bad.yaml'
    path.write_text(SMALL_SCENE.replace('scale: [1, 1, 0.05]', 'scale: [1, -1, 0.05]', 1))
    with pytest.raises(ValueError,
                       match=r'scene_file: .*bad\.yaml:\d+: rooms\[0\]\.marker\.scale'):
        graph.add(ChoiceMenu, parameter_overrides=[Parameter('scene_file', value=str(path))])
    with pytest.raises(ValueError, match="frame 'map' but world_frame is 'odom'"):
        graph.add(ChoiceMenu, parameter_overrides=[Parameter('world_frame', value='odom')])


def test_scene_file_parameter_reloads_or_rejects(graph, tmp_path):
    menu, probe = start(graph)
    bad = tmp_path / 'bad.yaml'
    bad.write_text(SMALL_SCENE.replace('up: [0, 0, 1]', 'up: [0, 0.5, -1]', 1))
    result = graph.set_parameters('/choice_menu', {'scene_file': str(bad)})[0]
    assert not result.successful
    assert str(bad) in result.reason and 'parallel to the view' in result.reason
    result = graph.set_parameters('/choice_menu', {'scene_file': str(tmp_path / 'nope.yaml')})[0]
    assert not result.successful and 'cannot read scene file' in result.reason
    result = graph.set_parameters('/choice_menu', {'world_frame': 'odom'})[0]
    assert not result.successful and 'frame_id' in result.reason
    probe.choose('kitchen')  # the old scene still works
    probe.wait_labels(['kitchen/table_1', 'kitchen/table_2', 'kitchen/table_3'])

    good = tmp_path / 'small.yaml'
    good.write_text(SMALL_SCENE)
    assert graph.set_parameters('/choice_menu', {'scene_file': str(good)})[0].successful
    probe.wait_labels(['hall', 'lab'])  # reloaded: starts over at the rooms
    small = load_scene(good)
    assert graph.spin_until(lambda: goal_is(probe.goals.last, small.overview), 10.0)
    requests = len(probe.requests.messages)
    graph.spin_for(0.3)
    assert len(probe.requests.messages) == requests  # new labels: no request
    # Reloading the same labels: the arbiter would not notice, so ask it.
    assert graph.set_parameters('/choice_menu', {'scene_file': str(good)})[0].successful
    assert graph.spin_until(lambda: len(probe.requests.messages) == requests + 1, 10.0)
    probe.choose('lab')
    probe.wait_labels(['lab/bench'])
    probe.choose('lab/bench')
    assert graph.spin_until(lambda: probe.results.messages, 10.0)
    assert probe.results.last.data == 'lab/bench'
