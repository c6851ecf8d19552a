"""The ssvep_stimulus node under Xvfb: regions and stimuli from topics -> the drawn patches."""

import numpy as np
import pytest
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.ros.conversions import regions_to_marker_array
from eye_bci_ros2.ros.ssvep_messages import seconds_to_time, stimulus_map_to_msg
from eye_bci_ros2.ros.topics import LATCHED_QOS
from eye_bci_ros2.ssvep.stimuli import assign_stimuli, luminance

pytestmark = pytest.mark.ros


def test_the_node_flickers_the_offered_regions(graph, xvfb):
    from eye_bci_ros2.nodes.ssvep_stimulus import SsvepStimulus
    node = graph.add(SsvepStimulus, visible=False, parameter_overrides=[
        Parameter('accept_flicker', value=True),
        Parameter('width', value=800), Parameter('height', value=600),
        Parameter('vsync', value=False)])
    driver = graph.node('task')
    regions = driver.create_publisher(MarkerArray, 'choices/regions', LATCHED_QOS)
    stimuli_pub = driver.create_publisher(JointState, 'ssvep/stimuli', LATCHED_QOS)
    centres = [(200.0, 200.0), (600.0, 400.0)]
    polygons = np.array([[[x - 50, y - 50], [x + 50, y - 50], [x + 50, y + 50],
                          [x - 50, y + 50]] for x, y in centres])
    now = node.get_clock().now().nanoseconds * 1e-9
    regions.publish(regions_to_marker_array(
        polygons, [Marker(ns='rooms', id=i, text=t) for i, t in enumerate(('a', 'b'))],
        seconds_to_time(now)))
    stimuli = assign_stimuli(['a', 'b'], frequencies=(10.0, 12.0), epoch_s=now)
    stimuli_pub.publish(stimulus_map_to_msg(stimuli))
    graph.spin_until(lambda: len(node._pending) == 2, 10.0)
    levels = []
    for k in range(1, 31):
        node.render(now + (k - 1) / 60.0)  # draws the frame due at the next retrace: k
        pixels = node.window.read_pixels()
        levels.append([int(pixels[int(y), int(x), 0]) for x, y in centres])
        assert node.window.frame == k
    expected = np.rint(255 * luminance(np.arange(1, 31), stimuli.frequencies, stimuli.phases,
                                       60.0))
    np.testing.assert_allclose(levels, expected, atol=1)
