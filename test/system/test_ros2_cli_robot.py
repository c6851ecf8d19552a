"""
sim_robot with the real ``ros2`` command line, as a nav2 user tries a robot.

``ros2 action send_goal /navigate_to_pose nav2_msgs/action/NavigateToPose ... --feedback``
shows a falling ``distance_remaining`` and SUCCEEDED; Ctrl-C on it mid-drive cancels the goal,
which ends CANCELED with the robot standing within 1.5 s; ``ros2 topic echo /tf --once``
shows map -> odom -> base_link.  The robot drives at real speed.  The command line is
installed as in test_ros2_cli.py (skipped, with the reason, where the installer cannot
download); ``sim_robot`` is the venv's executable (``ros2 run`` of every executable is
test_ros2_cli.py's).
"""

import os
from pathlib import Path
import re
import subprocess
import sys
import time

from action_msgs.msg import GoalStatus, GoalStatusArray
from domain_coordinator import domain_id
from nav_msgs.msg import Odometry
import pytest
import rclpy
from rclpy.context import Context
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from watched_process import Process, TRACEBACK, WAIT_S

from eye_bci_ros2.navigation.frames import BASE_FRAME, MAP_FRAME, ODOM_FRAME
from eye_bci_ros2.ros.runner import make_executor, spin_until
from eye_bci_ros2.ros.topics import NAVIGATE_TO_POSE_ACTION, ODOM_QOS, ODOM_TOPIC

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ACTION = ['action', 'send_goal', '/' + NAVIGATE_TO_POSE_ACTION,
          'nav2_msgs/action/NavigateToPose']
#: A goal in the bedroom 4 m east of the start (about 10 s at 0.5 m/s), and one in the living
#: room (a long drive, cancelled).
NEAR = '{pose: {header: {frame_id: map}, pose: {position: {x: 9.0, y: 5.0}, ' \
       'orientation: {w: 1.0}}}}'
FAR = '{pose: {header: {frame_id: map}, pose: {position: {x: 15.0, y: 8.5}, ' \
      'orientation: {w: 1.0}}}}'
#: The robot stands this soon after the cancel, s (the issue's bound).
STAND_WITHIN_S = 1.5


@pytest.fixture
def env():
    """Return the environment of the commands: this one, discovery on this machine."""
    return dict(os.environ, PYTHONUNBUFFERED='1', RCUTILS_COLORIZED_OUTPUT='0',
                ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')


def run(command, env, domain, timeout=WAIT_S):
    """Run a short command; return (status, output)."""
    result = subprocess.run(command, env=dict(env, ROS_DOMAIN_ID=str(domain)),
                            capture_output=True, text=True, timeout=timeout)
    return result.returncode, result.stdout + result.stderr


def distances(output: str):
    return [float(value) for value in re.findall(r'distance_remaining: ([0-9.eE+-]+)', output)]


def start_robot(ros2, env, domain, tmp_path, *rules):
    robot = Process([str(Path(sys.executable).parent / 'sim_robot'), '--ros-args', *rules],
                    env, domain, tmp_path / 'sim_robot.log')
    assert robot.wait_for('simulated robot'), robot.output()
    return robot


def stop(robot):
    robot.interrupt()
    assert robot.finish() == 0, robot.output()[-3000:]
    assert not TRACEBACK.search(robot.output()), robot.output()[-3000:]


def test_send_goal_with_feedback_succeeds_and_tf_carries_the_chain(ros2, env, tmp_path):
    with domain_id() as domain:
        robot = start_robot(ros2, env, domain, tmp_path)
        try:
            status, out = run([str(ros2), 'topic', 'echo', '--no-daemon', '--once', '/tf',
                               'tf2_msgs/msg/TFMessage'], env, domain)
            assert status == 0, out
            # One message holds both transforms: map -> odom, odom -> base_link.
            frames = re.findall(r"frame_id: '?(\w+)'?\s+child_frame_id: '?(\w+)'?", out)
            assert (MAP_FRAME, ODOM_FRAME) in frames and (ODOM_FRAME, BASE_FRAME) in frames, out
            goal = Process([str(ros2), *ACTION, NEAR, '--feedback'], env, domain,
                           tmp_path / 'send_goal.log')
            assert goal.finish(timeout=120.0) == 0, goal.output()
            out = goal.output()
            assert 'Goal accepted' in out and 'Goal finished with status: SUCCEEDED' in out, out
            seen = distances(out)
            assert len(seen) >= 10 and seen[0] > 3.5 and min(seen) < 0.5, seen
            assert all(b <= a + 0.02 for a, b in zip(seen, seen[1:])), seen
            assert robot.wait_for('arrived at'), robot.output()
        finally:
            stop(robot)


def test_ctrl_c_on_send_goal_cancels_and_the_robot_stands_within_1_5_s(ros2, env, tmp_path):
    with domain_id() as domain:
        robot = start_robot(ros2, env, domain, tmp_path)
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        executor = make_executor(context=context)
        try:
            node = rclpy.create_node('watcher', context=context)
            executor.add_node(node)
            odometry, statuses = [], []
            node.create_subscription(Odometry, ODOM_TOPIC, odometry.append, ODOM_QOS)
            node.create_subscription(
                GoalStatusArray, NAVIGATE_TO_POSE_ACTION + '/_action/status',
                lambda m: statuses.append([s.status for s in m.status_list]),
                QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL))
            goal = Process([str(ros2), *ACTION, FAR, '--feedback'], env, domain,
                           tmp_path / 'send_goal.log')
            # Mid-drive: at top speed.
            assert spin_until(executor, lambda: odometry
                              and odometry[-1].twist.twist.linear.x > 0.45, 120.0), \
                goal.output()
            sent = time.time()
            goal.interrupt()
            goal.finish()
            # The command asks the server to cancel; its own context is shut by the same
            # Ctrl-C, so it may not wait for the answer: the action's status says CANCELED.
            assert 'Canceling goal' in goal.output(), goal.output()
            assert spin_until(executor, lambda: statuses
                              and GoalStatus.STATUS_CANCELED in statuses[-1], 30.0), statuses
            # Standing (the node's clock is the system clock here): the first still odometry
            # after the Ctrl-C, and still ever after.
            count = len(odometry)
            assert spin_until(executor, lambda: len(odometry) >= count + 20, 30.0)
            after = [m for m in odometry if m.header.stamp.sec + m.header.stamp.nanosec * 1e-9
                     >= sent]
            still = [m.twist.twist.linear.x == 0.0 and m.twist.twist.angular.z == 0.0
                     for m in after]
            first = still.index(True)
            assert all(still[first:])
            stood = after[first].header.stamp
            assert stood.sec + stood.nanosec * 1e-9 - sent <= STAND_WITHIN_S
            assert robot.wait_for('cancelled goal: the robot stands'), robot.output()
        finally:
            executor.shutdown()
            rclpy.shutdown(context=context)
            stop(robot)
