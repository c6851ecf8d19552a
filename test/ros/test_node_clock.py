"""NodeClock reads what node.get_clock().now() reads: system time, or /clock with use_sim_time."""

import time

import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from eye_bci_ros2.ros.conversions import ns_to_stamp
from eye_bci_ros2.ros.node_clock import NodeClock

pytestmark = pytest.mark.ros


def test_system_time_then_simulated_time_then_system_time_again(graph):
    node = graph.node('clocked')
    clock = NodeClock(node)
    before = time.time_ns()
    read = clock.ns()
    assert clock.system_time and before <= read <= node.get_clock().now().nanoseconds

    # use_sim_time on: the node's clock follows /clock, and so does NodeClock.
    on = Parameter('use_sim_time', Parameter.Type.BOOL, True)
    assert node.set_parameters([on])[0].successful
    assert not clock.system_time
    publisher = graph.node('sim_clock').create_publisher(Clock, '/clock', 10)
    simulated = 42 * 10**9 + 5

    def published():
        publisher.publish(Clock(clock=ns_to_stamp(simulated)))
        return node.get_clock().now().nanoseconds == simulated

    assert graph.spin_until(published)
    assert clock.ns() == simulated and clock.seconds() == pytest.approx(42.0)

    # And off again: the system clock.
    off = Parameter('use_sim_time', Parameter.Type.BOOL, False)
    assert node.set_parameters([off])[0].successful
    assert clock.system_time
    assert abs(clock.ns() - time.time_ns()) < 10**9


def test_a_node_started_with_simulated_time_reads_clock_from_the_start(graph):
    node = graph.add(Node, 'sim_started',
                     parameter_overrides=[Parameter('use_sim_time', value=True)])
    clock = NodeClock(node)
    assert not clock.system_time
    assert clock.ns() == node.get_clock().now().nanoseconds == 0   # no /clock yet
