"""INFO lines the nodes log through log_throttle.log_info reach /rosout as rclpy's own do."""

import inspect

import pytest
from rcl_interfaces.msg import Log
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from eye_bci_ros2.ros.log_throttle import log_at, log_info, QuietRepeats

pytestmark = pytest.mark.ros


def rosout_lines(graph, node_name):
    """Return the /rosout messages of ``node_name`` as they arrive (a list that grows)."""
    lines = []
    graph.node('listener').create_subscription(
        Log, '/rosout', lambda message: lines.append(message) if message.name == node_name
        else None, QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                              durability=DurabilityPolicy.TRANSIENT_LOCAL))
    return lines


def test_a_line_logged_without_the_caller_search_reaches_rosout_like_loggers_own(graph):
    node = graph.node('talker')
    lines = rosout_lines(graph, 'talker')
    node.get_logger().info('the logger itself: 1 line')
    own_line = inspect.currentframe().f_lineno - 1
    log_info(node.get_logger(), 'through log_info: 1 line')
    fast_line = inspect.currentframe().f_lineno - 1
    QuietRepeats(node.get_logger()).info('through QuietRepeats: 1 line')
    assert graph.spin_until(lambda: len(lines) >= 3)
    own, fast, quiet = lines[:3]
    assert (fast.msg, quiet.msg) == ('through log_info: 1 line', 'through QuietRepeats: 1 line')
    # The same severity, logger and caller fields as the logger's own line, each from its
    # own call site.
    assert fast.level == own.level == Log.INFO
    assert (fast.file, fast.function) == (own.file, own.function) == (
        __file__, 'test_a_line_logged_without_the_caller_search_reaches_rosout_like_loggers_own')
    assert (own.line, fast.line) == (own_line, fast_line)
    assert quiet.function == 'info' and quiet.file.endswith('log_throttle.py')


def test_a_line_below_the_loggers_level_is_not_logged(graph):
    node = graph.node('quiet_talker')
    lines = rosout_lines(graph, 'quiet_talker')
    node.get_logger().set_level(30)   # WARN
    log_info(node.get_logger(), 'not shown')
    node.get_logger().warning('shown')
    assert graph.spin_until(lambda: lines)
    graph.spin_for(0.2)
    assert [m.msg for m in lines] == ['shown']


def test_one_call_site_logs_warnings_and_news_in_any_order(graph):
    # rclpy's own logger refuses a call site whose severity changes (issue 39: the bridge's
    # "no valid gaze" warning, then its "valid gaze again" line from the same site).
    node = graph.node('turncoat')
    lines = rosout_lines(graph, 'turncoat')
    for warning in (True, False, True, False):
        log_at(node.get_logger(), warning, f'warning {warning}')
        site = inspect.currentframe().f_lineno - 1
    assert graph.spin_until(lambda: len(lines) >= 4)
    assert [(m.level, m.msg) for m in lines] == [
        (Log.WARN, 'warning True'), (Log.INFO, 'warning False')] * 2
    assert {(m.file, m.line) for m in lines} == {(__file__, site)}
