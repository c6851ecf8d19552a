"""The shipped protocol between choice_menu and choice_arbiter, through their topics."""

from geometry_msgs.msg import PoseStamped
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from std_msgs.msg import Empty, String

from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.choice_menu import ChoiceMenu
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.ros.conversions import arrays_to_pose
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.ros.topics import EVENT_QOS, LATCHED_QOS, NO_CHOICE_TOPIC, REQUEST_TOPIC
from eye_bci_ros2.task.scene import load_scene

pytestmark = pytest.mark.ros


def test_a_round_without_gaze_reports_no_choice_and_the_menu_asks_again(graph):
    """No gaze at all: each round ends without a choice, the menu asks again each time."""
    probe = graph.node('probe')
    requests = Collector(probe, Empty, REQUEST_TOPIC, EVENT_QOS)
    none = Collector(probe, String, NO_CHOICE_TOPIC, EVENT_QOS)
    choices = Collector(probe, String, 'choice', EVENT_QOS)
    pose = probe.create_publisher(PoseStamped, 'camera/pose', LATCHED_QOS)
    graph.add(ChoiceArbiter, parameter_overrides=[Parameter('window_s', value=0.3),
                                                  Parameter('stall_timeout_s', value=0.1)])
    graph.add(ChoiceMenu, parameter_overrides=[Parameter('settle_s', value=0.3)])
    # The camera is at the overview, the goal of the rooms: the menu asks.
    message = PoseStamped()
    message.header.frame_id = 'map'
    message.pose = arrays_to_pose(*look_at_pose(
        *load_scene(default_scene_path()).overview.as_tuple()))
    pose.publish(message)
    assert graph.spin_until(lambda: len(none.messages) >= 2 and len(requests.messages) >= 3,
                            15.0), (len(requests.messages), [m.data for m in none.messages])
    assert 'no valid gaze sample' in none.messages[0].data
    assert not choices.messages   # nothing was chosen on its own
