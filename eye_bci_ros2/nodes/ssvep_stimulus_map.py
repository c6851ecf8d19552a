"""
Node ``ssvep_stimulus_map``: give every offered option a stimulus, on ``ssvep/stimuli``.

A stand-in for the task's own assignment (the menu knows its options): it
subscribes ``choices/regions`` and, whenever the set of offered labels
changes, publishes (latched) sensor_msgs/JointState on ``ssvep/stimuli``
with :func:`eye_bci_ros2.ssvep.stimuli.assign_stimuli` in the regions'
order (``frequencies`` in turn, phases stepping by ``phase_step_rad``) and
the epoch ``lead_s`` after now (the stimulus window starts frame 0 then; the
decoder's round starts then).
"""

import math
from typing import Optional

from rclpy.node import Node
from sensor_msgs.msg import JointState
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.ros.conversions import marker_array_to_regions
from eye_bci_ros2.ros.log_throttle import WARN_PERIOD_S
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.ssvep_messages import stimulus_map_to_msg
from eye_bci_ros2.ros.topics import LATCHED_QOS, REGIONS_TOPIC, SSVEP_STIMULI_TOPIC
from eye_bci_ros2.ssvep.stimuli import (assign_stimuli, DEFAULT_FREQUENCIES, DEFAULT_PHASE_STEP,
                                        MAX_FREQUENCY_HZ)


def _frequencies(value) -> Optional[str]:
    if not value or not all(math.isfinite(f) and 0 < f < MAX_FREQUENCY_HZ for f in value):
        return f'needs stimulus frequencies in (0, {MAX_FREQUENCY_HZ:g}) Hz, got {list(value)}'
    if len(set(value)) != len(value):
        return f'has a frequency twice: {list(value)}'
    return None


PARAMETERS = (
    ParamSpec('frequencies', list(DEFAULT_FREQUENCIES), 'stimulus frequencies to assign in '
              'order, Hz (at least as many as options)', check=_frequencies,
              array_type='double_array'),
    ParamSpec('phase_step_rad', DEFAULT_PHASE_STEP, 'phase step between options, rad',
              value_range=(0.0, 2 * math.pi)),
    ParamSpec('lead_s', 0.1, 'epoch = this long after the options change, s',
              value_range=(0.0, 10.0)),
)


class SsvepStimulusMap(Node):
    """Publish a stimulus map for each new set of offered options."""

    def __init__(self, **kwargs):
        """Declare parameters and topics."""
        super().__init__('ssvep_stimulus_map', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._params_changed)
        self._publisher = self.create_publisher(JointState, SSVEP_STIMULI_TOPIC, LATCHED_QOS)
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)
        self._labels = None

    def _params_changed(self, changed) -> None:
        self._params.update(changed)

    def _on_regions(self, msg: MarkerArray) -> None:
        try:
            labels = tuple(marker_array_to_regions(msg)[0])
            if not labels or labels == self._labels:
                return
            self._labels = labels
            epoch = self.get_clock().now().nanoseconds * 1e-9 + self._params['lead_s']
            stimuli = assign_stimuli(labels, self._params['frequencies'],
                                     self._params['phase_step_rad'], epoch)
            self._publisher.publish(stimulus_map_to_msg(stimuli))
        except ValueError as error:
            self.get_logger().warning(f'no stimulus map for the options: {error}',
                                      throttle_duration_sec=WARN_PERIOD_S)


def main(args=None):
    """Run the ssvep_stimulus_map node."""
    spin_node(SsvepStimulusMap, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
