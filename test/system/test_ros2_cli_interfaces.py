"""
The real ``ros2`` command line on nav2's and tf2's interfaces, as a user would check them.

``ros2 action send_goal ... nav2_msgs/action/NavigateToPose --feedback`` against an rclpy
action server, and ``ros2 topic info -v /tf``, which shows the type hash a real Jazzy robot
shows.  On the PyPI set-up the interfaces are the ones ``make`` builds into the venv
(``interfaces/``).  ros2cli is installed as in test_ros2_cli.py (skips where it cannot be);
it has no ``ros2 interface`` (ros2interface is not among the shared sources).
"""

import os
import subprocess

from nav2_msgs.action import NavigateToPose
import pytest
from rclpy.action import ActionServer
from tf2_msgs.msg import TFMessage

pytestmark = [pytest.mark.ros, pytest.mark.slow]

#: TFMessage's RIHS01 in Jazzy (test/ros/test_jazzy_interfaces.py has them all).
TF_MESSAGE_HASH = 'RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087'
#: A ros2 command without the daemon discovers the graph itself: give it time.
DISCOVERY = ('--no-daemon', '--spin-time', '3')
#: How long a ros2 command may take on a loaded 2-core machine, s.
COMMAND_S = 120.0


def on_graph(graph, command):
    """Run ``command`` on ``graph``'s domain while its nodes spin; return (status, output)."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(graph.domain), PYTHONUNBUFFERED='1',
               RCUTILS_COLORIZED_OUTPUT='0')
    with subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True) as process:
        try:
            assert graph.spin_until(lambda: process.poll() is not None, COMMAND_S), \
                f'{" ".join(command[1:3])} did not end'
        finally:
            if process.poll() is None:
                process.kill()
        output = process.stdout.read()
    return process.returncode, output


def test_send_goal_with_feedback(graph, ros2):
    def execute(goal_handle):
        goal_handle.publish_feedback(NavigateToPose.Feedback(
            current_pose=goal_handle.request.pose, distance_remaining=0.75))
        goal_handle.succeed()
        return NavigateToPose.Result()

    ActionServer(graph.node('bt_navigator'), NavigateToPose, 'navigate_to_pose', execute)
    status, output = on_graph(graph, [
        ros2, 'action', 'send_goal', '--feedback', '/navigate_to_pose',
        'nav2_msgs/action/NavigateToPose',
        '{pose: {header: {frame_id: map}, pose: {position: {x: 1.5}}}}'])
    assert status == 0, output
    assert 'Goal accepted' in output, output
    assert 'distance_remaining: 0.75' in output, output
    assert 'error_code: 0' in output, output
    assert 'Goal finished with status: SUCCEEDED' in output, output


def test_topic_info_shows_jazzys_tf_type_hash(graph, ros2):
    graph.node('robot').create_publisher(TFMessage, '/tf', 10)
    status, output = on_graph(graph, [ros2, 'topic', 'info', *DISCOVERY, '-v', '/tf'])
    assert status == 0, output
    assert 'Type: tf2_msgs/msg/TFMessage' in output, output
    assert f'Topic type hash: {TF_MESSAGE_HASH}' in output, output
