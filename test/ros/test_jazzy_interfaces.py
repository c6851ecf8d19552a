"""
nav2_msgs, tf2_msgs and the view controller's messages, as this set-up has them, are Jazzy's.

On the PyPI set-up they are built from ``interfaces/`` with colcon into the venv (they are
not on PyPI); on a ROS machine they are the apt packages.  A real bt_navigator, RViz2 or tf2
must talk to them: DDS matches the type name, and the RIHS01 type hash travels in the
discovery data, where tools compare it.  The hashes below are Jazzy's (nav2 1.3.x;
``ros_interfaces.md`` in the shared reference, computed with
rosidl_generator_type_description; TFMessage's is what a real Jazzy robot's
``ros2 topic info -v /tf`` shows).
"""

import json
from pathlib import Path

from action_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped, TransformStamped
import nav2_msgs
from nav2_msgs.action import NavigateToPose
import pytest
from rclpy.action import ActionClient, ActionServer
from ros_harness import Collector
import tf2_msgs
from tf2_msgs.msg import TFMessage

pytestmark = pytest.mark.ros

JAZZY_HASHES = {
    'nav2_msgs/action/NavigateToPose':
        'a56dba8a3234a1215e610180dc703ae25bbf406dded8b54887891c9732857eab',
    'nav2_msgs/action/NavigateToPose_Goal':
        '22a9dffbd6733011220460bd52edbc7843c8fc86282d40bc7ad3ca176a9dec10',
    'nav2_msgs/action/NavigateToPose_Result':
        'ddbff7fc6d1e51d774d5defdb8398a57cb23fa8709355002d676408bb4860b85',
    'nav2_msgs/action/NavigateToPose_Feedback':
        '9ebc544c7d41bd8c6060b191bf9f5e4ddca6c2f61ee9e04fcb62ed5d67218a33',
    'nav2_msgs/action/NavigateToPose_FeedbackMessage':
        '9d1f6fa2eb975ce733b419ac2e97b134d8ff92b6478b6559feed9a50bdfd82b3',
    'nav2_msgs/action/NavigateToPose_SendGoal':
        'a4fcb3bee1bf32e21a0e541a943b221aa0826996e2c98f079b47022b256f48b5',
    'nav2_msgs/action/NavigateToPose_GetResult':
        'c407920357d566771e8882b4ef4d1f1a84ee922d609920ccd57faa6d6e391dc5',
    'tf2_msgs/msg/TFMessage':
        'e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087',
}

ACTION = 'navigate_to_pose'


def built_hashes(package, interface: str) -> dict:
    """
    Return {type name: hash} of the type description the build installed for ``interface``.

    ``rosidl_generate_interfaces`` installs ``share/<package>/<interface>.json`` beside the
    Python package's ``lib/pythonX.Y/site-packages``, in the venv as under /opt/ros/jazzy.
    """
    prefix = Path(package.__file__).resolve().parents[4]
    path = prefix / 'share' / package.__name__ / f'{interface}.json'
    assert path.is_file(), f'no type description at {path}'
    return {entry['type_name']: entry['hash_string']
            for entry in json.loads(path.read_text())['type_hashes']}


def test_the_built_type_hashes_are_jazzys():
    built = {**built_hashes(nav2_msgs, 'action/NavigateToPose'),
             **built_hashes(tf2_msgs, 'msg/TFMessage')}
    assert {name: built.get(name) for name in JAZZY_HASHES} == {
        name: f'RIHS01_{value}' for name, value in JAZZY_HASHES.items()}


def endpoint_hashes(node, topic: str) -> set:
    """
    Return the type hashes the graph shows for the publishers of ``topic``.

    A participant that has just left the domain (a test before) may still be listed for a
    while, with the same types: all of them are compared.
    """
    return {str(info.topic_type_hash) for info in node.get_publishers_info_by_topic(topic)}


def test_the_graph_carries_jazzys_hashes(graph):
    # What discovery carries (``ros2 topic info -v``), from the compiled type support.
    node = graph.node('robot')
    node.create_publisher(TFMessage, '/tf', 10)
    ActionServer(node, NavigateToPose, ACTION, lambda goal: NavigateToPose.Result())
    assert endpoint_hashes(node, '/tf') == {'RIHS01_' + JAZZY_HASHES['tf2_msgs/msg/TFMessage']}
    assert endpoint_hashes(node, f'/{ACTION}/_action/feedback') == {'RIHS01_' + JAZZY_HASHES[
        'nav2_msgs/action/NavigateToPose_FeedbackMessage']}


def test_navigate_to_pose_goal_feedback_and_result(graph):
    def execute(goal_handle):
        goal = goal_handle.request
        feedback = NavigateToPose.Feedback(current_pose=goal.pose, number_of_recoveries=1,
                                           distance_remaining=2.5)
        feedback.navigation_time.sec = 3
        goal_handle.publish_feedback(feedback)
        goal_handle.abort()
        return NavigateToPose.Result(error_code=NavigateToPose.Result.TF_ERROR,
                                     error_msg=f'no transform to {goal.pose.header.frame_id}')

    ActionServer(graph.node('bt_navigator'), NavigateToPose, ACTION, execute)
    client = ActionClient(graph.node('menu'), NavigateToPose, ACTION)
    assert graph.spin_until(client.server_is_ready, 10.0)
    pose = PoseStamped()
    pose.header.frame_id = 'map'
    pose.pose.position.x, pose.pose.orientation.w = 4.5, 1.0
    feedback = []
    handle = graph.wait_future(client.send_goal_async(
        NavigateToPose.Goal(pose=pose, behavior_tree=''),
        feedback_callback=lambda message: feedback.append(message.feedback)), 10.0)
    assert handle.accepted
    result = graph.wait_future(handle.get_result_async(), 10.0)
    assert result.status == GoalStatus.STATUS_ABORTED
    assert result.result.error_code == 9002 and result.result.error_msg == 'no transform to map'
    assert graph.spin_until(lambda: feedback, 5.0)
    (received,) = feedback
    assert received.distance_remaining == pytest.approx(2.5)
    assert received.number_of_recoveries == 1 and received.navigation_time.sec == 3
    assert received.current_pose.header.frame_id == 'map'
    assert received.current_pose.pose.position.x == pytest.approx(4.5)


def test_tf_message_round_trip(graph):
    publisher = graph.node('robot').create_publisher(TFMessage, '/tf', 10)
    tf = Collector(graph.node('listener'), TFMessage, '/tf', 10)
    transform = TransformStamped()
    transform.header.frame_id, transform.child_frame_id = 'odom', 'base_link'
    transform.transform.translation.x, transform.transform.rotation.w = 1.25, 1.0
    second = TransformStamped(child_frame_id='odom')
    second.header.frame_id = 'map'

    def delivered():
        publisher.publish(TFMessage(transforms=[transform, second]))
        return tf.messages

    assert graph.spin_until(delivered, 10.0)
    received = tf.last.transforms
    assert [(t.header.frame_id, t.child_frame_id) for t in received] == [
        ('odom', 'base_link'), ('map', 'odom')]
    assert received[0].transform.translation.x == pytest.approx(1.25)
