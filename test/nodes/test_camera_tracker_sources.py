"""camera_tracker with real RViz2 sources: pose topic, convention, type from the graph, .rviz."""

from pathlib import Path

from fault_rig import LogTap
from geometry_msgs.msg import Pose, PoseStamped
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from std_msgs.msg import String

from eye_bci_ros2.nodes.camera_tracker import CameraTracker, DEFAULT_EYE, DEFAULT_FOCUS
from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import look_at_pose, pose_from_optical
from eye_bci_ros2.ros.conversions import arrays_to_pose, pose_to_arrays
from eye_bci_ros2.ros.topics import LATCHED_QOS, RVIZ_POSE_QOS

pytestmark = pytest.mark.ros

PORT_TOPIC = 'rviz_plugin_view_animated_1/pose'
CONFIG = Path(__file__).resolve().parents[2] / 'config' / 'eye_bci.rviz'
#: An RViz file whose view is a first-person camera at (1, 2, 3) m, pitched 0.2 rad down.
FPS_VIEW = ('Visualization Manager:\n  Global Options:\n    Fixed Frame: map\n'
            '  Views:\n    Current:\n      Class: rviz_default_plugins/FPS\n'
            '      Position: {X: 1, Y: 2, Z: 3}\n      Pitch: 0.2\n      Yaw: 0\n')

#: A view RViz might show, and its optical pose.
EYE, FOCUS, UP = [0.0, -8.0, 12.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]
OPTICAL = look_at_pose(EYE, FOCUS, UP)


def start(graph, **overrides):
    tracker = graph.add(CameraTracker, parameter_overrides=[
        Parameter(name, value=value) for name, value in overrides.items()])
    poses = Collector(graph.node('tracker_test'), PoseStamped, 'camera/pose', LATCHED_QOS)
    assert graph.spin_until(lambda: poses.messages, 10.0)   # the static view
    return tracker, poses


def stamped(position, quaternion_xyzw, frame='map'):
    message = PoseStamped(pose=arrays_to_pose(position, quaternion_xyzw))
    message.header.frame_id = frame
    return message


def same_pose(message, position, quaternion_xyzw):
    got_position, got_quaternion = pose_to_arrays(message.pose)
    np.testing.assert_allclose(got_position, position, atol=1e-9)
    np.testing.assert_allclose(geometry.quaternion_to_matrix(got_quaternion),
                               geometry.quaternion_to_matrix(quaternion_xyzw), atol=1e-9)


def publish_until_answered(graph, publisher, message, poses):
    before = len(poses.messages)
    assert graph.spin_until(lambda: publisher.get_subscription_count() > 0, 10.0)
    publisher.publish(message)
    assert graph.spin_until(lambda: len(poses.messages) > before, 10.0)
    return poses.last


def test_port_pose_stamped_x_forward_is_found_on_the_graph_and_converted(graph):
    tracker, poses = start(graph, pose_topic=PORT_TOPIC, pose_convention='x_forward')
    assert tracker.pose_type is None                      # no publisher yet: nothing to read
    port = graph.node('rviz2').create_publisher(PoseStamped, PORT_TOPIC, 1)
    assert graph.spin_until(lambda: tracker.pose_type is PoseStamped, 10.0)
    # What the port publishes for this view: x along the view, z up.
    message = stamped(*pose_from_optical('x_forward', *OPTICAL))
    same_pose(publish_until_answered(graph, port, message, poses), *OPTICAL)
    assert poses.last.header.frame_id == 'map'


def test_pose_stamped_in_another_frame_is_refused_with_a_reason(graph, capfd):
    log = LogTap(capfd)
    tracker, poses = start(graph, pose_topic=PORT_TOPIC, pose_convention='optical')
    port = graph.node('rviz2').create_publisher(PoseStamped, PORT_TOPIC, 1)
    assert graph.spin_until(lambda: tracker.pose_type is PoseStamped, 10.0)
    assert graph.spin_until(lambda: port.get_subscription_count() > 0, 10.0)
    port.publish(stamped(*OPTICAL, frame='odom'))
    assert log.wait_for(graph, r"pose in frame 'odom', expected world_frame 'map'.*no tf2")
    assert len(poses.messages) == 1                        # still the static view
    same_pose(publish_until_answered(graph, port, stamped(*OPTICAL, frame='/map'), poses),
              *OPTICAL)


def test_plain_pose_with_the_optical_convention(graph):
    tracker, poses = start(graph, pose_topic='camera_source', pose_convention='optical')
    source = graph.node('source').create_publisher(Pose, 'camera_source', RVIZ_POSE_QOS)
    assert graph.spin_until(lambda: tracker.pose_type is Pose, 10.0)
    same_pose(publish_until_answered(graph, source, arrays_to_pose(*OPTICAL), poses), *OPTICAL)


def test_a_topic_of_another_type_is_named_and_not_read(graph, capfd):
    log = LogTap(capfd)
    tracker, _ = start(graph, pose_topic='camera_source')
    graph.node('source').create_publisher(String, 'camera_source', 1)
    assert log.wait_for(graph, r'camera_source has type std_msgs/msg/String; camera_tracker '
                               r'reads geometry_msgs/msg/Pose or geometry_msgs/msg/PoseStamped')
    assert tracker.pose_type is None


def test_pose_topic_can_be_switched_at_run_time(graph):
    tracker, poses = start(graph)
    old = graph.node('ros1').create_publisher(Pose, 'rviz/current_camera_pose', RVIZ_POSE_QOS)
    assert graph.spin_until(lambda: tracker.pose_type is Pose, 10.0)
    results = graph.set_parameters('/camera_tracker', {'pose_topic': PORT_TOPIC,
                                                       'pose_convention': 'x_forward'})
    assert all(result.successful for result in results)
    port = graph.node('rviz2').create_publisher(PoseStamped, PORT_TOPIC, 1)
    assert graph.spin_until(lambda: tracker.pose_type is PoseStamped, 10.0)
    assert graph.spin_until(lambda: old.get_subscription_count() == 0, 10.0)
    message = stamped(*pose_from_optical('x_forward', *OPTICAL))
    same_pose(publish_until_answered(graph, port, message, poses), *OPTICAL)
    bad = graph.set_parameters('/camera_tracker', {'pose_topic': 'two words'})[0]
    assert not bad.successful and 'not a valid topic name' in bad.reason


def test_rviz_config_gives_the_static_view(graph, tmp_path):
    config = tmp_path / 'top.rviz'
    config.write_text('Visualization Manager:\n  Global Options:\n    Fixed Frame: map\n'
                      '  Views:\n    Current:\n      Class: rviz_default_plugins/TopDownOrtho\n'
                      '      Angle: 0\n      Scale: 20\n      X: 4\n      Y: 5\n')
    _, poses = start(graph, rviz_config=str(config))
    position, quaternion = pose_to_arrays(poses.last.pose)
    np.testing.assert_allclose(position, [4, 5, 500])
    rotation = geometry.quaternion_to_matrix(quaternion)
    np.testing.assert_allclose(rotation[:, 2], [0, 0, -1], atol=1e-12)   # looking down
    np.testing.assert_allclose(rotation[:, 1], [0, -1, 0], atol=1e-12)   # map +y up on screen


def test_default_rviz_file_gives_the_default_view(graph):
    _, poses = start(graph, rviz_config=str(CONFIG))
    same_pose(poses.last, *look_at_pose(DEFAULT_EYE, DEFAULT_FOCUS, [0, 0, 1]))


def test_explicit_view_parameters_win_over_rviz_config(graph, tmp_path):
    _, poses = start(graph, rviz_config=str(CONFIG), eye=EYE, focus=FOCUS)
    same_pose(poses.last, *OPTICAL)


@pytest.mark.parametrize('contents, overrides, reason', [
    (None, {}, 'cannot read rviz_config'),
    ('Visualization Manager:\n  Views:\n    Current:\n      Class: rviz/Orbit\n', {},
     "unknown view controller class 'rviz/Orbit'"),
    ('Visualization Manager:\n  Views:\n    Current:\n      Class: rviz_default_plugins/FPS\n'
     '      Target Frame: base_footprint\n', {}, "Target Frame 'base_footprint'"),
    ('Visualization Manager:\n  Global Options:\n    Fixed Frame: odom\n  Views:\n'
     '    Current:\n      Class: rviz_default_plugins/Orbit\n', {},
     "Fixed Frame 'odom' but world_frame is 'map'"),
])
def test_unusable_rviz_config_stops_the_node_with_a_reason(graph, tmp_path, contents,
                                                           overrides, reason):
    config = tmp_path / 'view.rviz'
    if contents is not None:
        config.write_text(contents)
    with pytest.raises(ValueError, match=reason):
        graph.add(CameraTracker, parameter_overrides=[
            Parameter('rviz_config', value=str(config))])


def test_rviz_config_is_read_only(graph, tmp_path):
    config = tmp_path / 'fps.rviz'
    config.write_text(FPS_VIEW)
    _, poses = start(graph, rviz_config=str(config))
    result = graph.set_parameters('/camera_tracker', {'rviz_config': str(CONFIG)})[0]
    # Refused with the reason, and the file read at start-up still holds.
    assert not result.successful and 'read-only' in result.reason, result.reason
    assert graph.get_parameters('/camera_tracker', ['rviz_config']) == [str(config)]
    np.testing.assert_allclose(pose_to_arrays(poses.last.pose)[0], [1, 2, 3])


def test_view_parameters_at_their_defaults_do_not_hide_rviz_config(graph, tmp_path):
    # As with --params-file config/eye_bci.yaml, which spells out every default.
    config = tmp_path / 'fps.rviz'
    config.write_text(FPS_VIEW)
    _, poses = start(graph, rviz_config=str(config), eye=DEFAULT_EYE, focus=DEFAULT_FOCUS,
                     up=[0.0, 0.0, 1.0])
    position, quaternion = pose_to_arrays(poses.last.pose)
    np.testing.assert_allclose(position, [1, 2, 3])
    forward = geometry.quaternion_to_matrix(quaternion)[:, 2]
    np.testing.assert_allclose(forward, [np.cos(0.2), 0, -np.sin(0.2)], atol=1e-12)
