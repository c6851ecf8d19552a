"""
A simulated person's EEG over real LSL, the ssvep_decoder node and a task driver, for tests.

:class:`Rig` starts an :class:`eye_bci_ros2.sim.eeg_outlet.EegStreamer` (a real LSL
outlet, unique source_id), the decoder node reading it, and a driver node that
offers options (``choices/regions``) with their stimuli (``ssvep/stimuli``) and
makes the simulated person attend one of them, and collects ``ssvep/choice``
and ``ssvep/scores``.
"""

from fault_rig import LogTap
from lsl_outlets import unique_id
import numpy as np
import pylsl
from rclpy.parameter import Parameter
from ros_harness import Collector
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.nodes.ssvep_decoder import SsvepDecoder
from eye_bci_ros2.ros.conversions import cube_marker, regions_to_marker_array
from eye_bci_ros2.ros.ssvep_messages import seconds_to_time, stimulus_map_to_msg
from eye_bci_ros2.ros.topics import EVENT_QOS, LATCHED_QOS
from eye_bci_ros2.sim.eeg import EegSimulator, SUBJECTS
from eye_bci_ros2.sim.eeg_outlet import EegStreamer
from eye_bci_ros2.ssvep.stimuli import assign_stimuli, StimulusMap

#: Generous waits, s (2 shared cores: never a timing assertion).
WAIT_S = 15.0
LABELS = ('kitchen', 'bedroom', 'bathroom')


class Rig:
    """The decoder node, a driver node that plays the task, and a simulated EEG outlet."""

    def __init__(self, graph, capfd, simulator=None, streamer_args=None, **parameters):
        """Create the outlet (not started), the decoder with ``parameters`` and the driver."""
        self.graph = graph
        self.log = LogTap(capfd)
        self.source_id = unique_id('eeg')
        simulator = simulator or EegSimulator(SUBJECTS[6], seed=2)
        self.streamer = EegStreamer(simulator, source_id=self.source_id,
                                    **(streamer_args or {}))
        values = {'source_id': self.source_id, 'layout': simulator.layout.name}
        values.update(parameters)
        self.node = graph.add(SsvepDecoder, parameter_overrides=[
            Parameter(k, value=v) for k, v in values.items()])
        self.driver = graph.node('ssvep_task')
        self.regions_pub = self.driver.create_publisher(MarkerArray, 'choices/regions',
                                                        LATCHED_QOS)
        self.stimuli_pub = self.driver.create_publisher(JointState, 'ssvep/stimuli',
                                                        LATCHED_QOS)
        self.choices = Collector(self.driver, String, 'ssvep/choice', EVENT_QOS)
        self.scores = Collector(self.driver, JointState, 'ssvep/scores', 10)

    def ros_now(self) -> float:
        """Return the ROS clock, s."""
        return self.driver.get_clock().now().nanoseconds * 1e-9

    def start(self):
        """Start the outlet; return once the decoder has connected to it."""
        self.streamer.start()
        assert self.graph.spin_until(lambda: bool(self.node.stream), WAIT_S), 'no stream'
        return self

    def offer(self, labels=LABELS, stimuli_labels=None, attend=None):
        """
        Offer options with stimuli from now on; the person attends ``attend``.

        Option i is the square [100 + 300 i, 300 + 300 i] x [100, 300] screen px.

        :returns: the ROS time of the offer (regions stamp and stimulus epoch), s.
        """
        now = self.ros_now()
        sources = [cube_marker('rooms', i, label, 'map', (i, 0, 0), (0, 0, 0, 1), (1, 1, 0.1))
                   for i, label in enumerate(labels)]
        polygons = np.array([[[100 + 300 * i, 100], [300 + 300 * i, 100],
                              [300 + 300 * i, 300], [100 + 300 * i, 300]]
                             for i in range(len(labels))], dtype=float)
        stimuli = assign_stimuli(stimuli_labels or labels, epoch_s=now)
        self.regions_pub.publish(regions_to_marker_array(polygons, sources,
                                                         seconds_to_time(now)))
        self.stimuli_pub.publish(stimulus_map_to_msg(stimuli))
        lsl_epoch = pylsl.local_clock() - (self.ros_now() - now)
        self.streamer.show(StimulusMap(stimuli.labels, stimuli.frequencies, stimuli.phases,
                                       lsl_epoch))
        self.streamer.attend(attend, lsl_epoch)
        return now

    #: The option :meth:`choices_before_sentinel` offers; no test offers it otherwise.
    SENTINEL = 'sentinel'

    def choices_before_sentinel(self):
        """
        Return the choices received before one more choice that must come.

        Offers new options (a new round), one of them :data:`SENTINEL`, which the
        person attends, and waits for its choice.  The decoder publishes its
        choices in order on one topic, so a late choice of an earlier round arrives
        ahead of this one, where a fixed wait may end before it comes; no earlier
        round offered :data:`SENTINEL`, so that late choice cannot be mistaken for it.
        """
        self.offer((self.SENTINEL, 'elsewhere'), attend=self.SENTINEL)
        labels = lambda: [m.data for m in self.choices.messages]  # noqa: E731
        assert self.graph.spin_until(lambda: self.SENTINEL in labels(), WAIT_S), labels()
        return labels()[:labels().index(self.SENTINEL)]

    def stop(self):
        """Close the decoder's inlet, then stop the outlet (the stream disappears)."""
        # liblsl can crash when an outlet is destroyed under a connected inlet: the
        # lost-stream test does that on purpose, teardown does not.
        self.node.close_stream()
        self.streamer.stop()
