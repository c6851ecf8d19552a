"""The ssvep_stimulus_map node: a stimulus per offered option, on each new set of options."""

import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from sensor_msgs.msg import JointState
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.nodes.ssvep_stimulus_map import SsvepStimulusMap
from eye_bci_ros2.ros.conversions import regions_to_marker_array
from eye_bci_ros2.ros.ssvep_messages import msg_to_stimulus_map, seconds_to_time
from eye_bci_ros2.ros.topics import LATCHED_QOS

pytestmark = pytest.mark.ros


def _regions(labels, stamp):
    polygons = np.array([[[0, 0], [10, 0], [10, 10]]] * len(labels), dtype=float) + \
        np.arange(len(labels))[:, None, None] * 20
    return regions_to_marker_array(polygons, [Marker(ns='m', id=i, text=t)
                                              for i, t in enumerate(labels)],
                                   seconds_to_time(stamp))


def test_each_new_set_of_options_gets_a_map(graph):
    node = graph.add(SsvepStimulusMap, parameter_overrides=[
        Parameter('frequencies', value=[8.0, 10.0, 12.0])])
    driver = graph.node('task')
    regions = driver.create_publisher(MarkerArray, 'choices/regions', LATCHED_QOS)
    maps = Collector(driver, JointState, 'ssvep/stimuli', LATCHED_QOS)
    now = node.get_clock().now().nanoseconds * 1e-9
    regions.publish(_regions(['a', 'b'], now))
    assert graph.spin_until(lambda: maps.messages, 10.0)
    first = msg_to_stimulus_map(maps.last)
    assert first.labels == ('a', 'b') and first.frequencies == (8.0, 10.0)
    assert now < first.epoch_s < now + 1.0
    regions.publish(_regions(['a', 'b'], now + 0.1))  # moved, same options: no new map
    regions.publish(_regions(['x', 'y', 'z'], now + 0.2))
    assert graph.spin_until(lambda: len(maps.messages) == 2, 10.0)
    graph.spin_for(0.3)
    assert len(maps.messages) == 2
    assert msg_to_stimulus_map(maps.last).frequencies == (8.0, 10.0, 12.0)
    result, = graph.set_parameters('/ssvep_stimulus_map', {'frequencies': [8.0, 8.0]})
    assert not result.successful and 'twice' in result.reason
