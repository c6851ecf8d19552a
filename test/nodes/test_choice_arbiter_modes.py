"""The arbiter's input modes with the real ssvep_decoder on simulated EEG over LSL."""

import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from sensor_msgs.msg import PointCloud2
from ssvep_rig import LABELS, Rig, WAIT_S
from std_msgs.msg import Empty, String

from eye_bci_ros2.decision.rounds import COUNT_RULE
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.ros.conversions import gaze_batch
from eye_bci_ros2.ros.topics import EVENT_QOS, GAZE_QOS, GAZE_SAMPLES_TOPIC
from eye_bci_ros2.sim.eeg import EegSimulator, SUBJECTS

pytestmark = [pytest.mark.ros, pytest.mark.lsl, pytest.mark.slow]

GAZE_RATE_HZ = 100.0
#: Beyond max_lag_s, for the node to act on the expiry, s.
LAG_MARGIN_S = 0.5


class Modes:
    """The arbiter in one input mode, the decoder rig, and gaze from the test."""

    def __init__(self, graph, capfd, mode, decoder=True, **arbiter):
        self.graph = graph
        values = {**COUNT_RULE, 'input_mode': mode, 'window_s': 1.0, 'max_future_s': 5.0,
                  **arbiter}
        self.arbiter = graph.add(ChoiceArbiter, parameter_overrides=[
            Parameter(k, value=v) for k, v in values.items()])
        self.rig = Rig(graph, capfd, simulator=EegSimulator(SUBJECTS[6], seed=7))
        if decoder:
            self.rig.start()
        else:  # no EEG stream at all: the decoder never publishes
            self.rig.node.destroy_node()
        node = self.rig.driver
        self.gaze_pub = node.create_publisher(PointCloud2, GAZE_SAMPLES_TOPIC, GAZE_QOS)
        self.request_pub = node.create_publisher(Empty, 'choice/request', EVENT_QOS)
        self.choices = Collector(node, String, 'choice', EVENT_QOS)
        assert graph.spin_until(lambda: self.gaze_pub.get_subscription_count() > 0
                                and node.count_publishers('choice') > 0, WAIT_S)

    @property
    def labels(self):
        """Return the choices published by the arbiter."""
        return [m.data for m in self.choices.messages]

    def look(self, label, start, seconds=1.3):
        """Publish gaze on option ``label``'s region, stamped from ``start`` (ROS s)."""
        index = LABELS.index(label)
        rng = np.random.default_rng(index)
        count = int(seconds * GAZE_RATE_HZ)
        points = rng.normal((200 + 300 * index, 200), 10.0, (count, 2))
        stamps = start + (np.arange(count) + 0.5) / GAZE_RATE_HZ
        self.gaze_pub.publish(gaze_batch(np.rint(stamps * 1e9).astype(np.int64), points))

    def play_round(self, look=None, attend=None, settle=True):
        """Offer the options (new stimuli), look at / attend options; return the offer time."""
        if settle:
            self.graph.spin_for(1.5)  # the decoder's filters settle on the stream
        start = self.rig.offer(attend=attend)
        self.graph.spin_for(0.2)
        if look is not None:
            self.look(look, start)
        return start

    def choices_before_sentinel(self, label):
        """
        Return the choices published before one more choice that must come: ``label``.

        A new round (a request) where the person looks at and attends ``label``,
        which both gaze and SSVEP choose in every mode.  The arbiter publishes its
        choices in order on one topic: a late choice of an earlier round arrives
        ahead of this one, where a fixed wait may end before it comes.  ``label``
        must differ from any choice the test fears.
        """
        self.graph.spin_for(1.5)  # as play_round: the decoder's filters settle
        rounds = self.arbiter.rounds_started
        self.request_pub.publish(Empty())
        assert self.graph.spin_until(lambda: self.arbiter.rounds_started > rounds, WAIT_S)
        start = self.arbiter.round_start
        self.rig.offer(attend=label)
        self.look(label, start)
        assert self.graph.spin_until(lambda: label in self.labels, 2 * WAIT_S), self.labels
        return self.labels[:self.labels.index(label)]

    def past_max_lag(self):
        """
        Spin past the longest a hybrid choice may come after its evidence (max_lag_s).

        For a test without an EEG stream, where no choice can act as a sentinel.
        """
        max_lag_s, = self.graph.get_parameters('/choice_arbiter', ['max_lag_s'])
        self.graph.spin_for(max_lag_s + LAG_MARGIN_S)

    def stop(self):
        """Stop the EEG outlet."""
        if self.rig.streamer.running:
            self.rig.stop()


@pytest.fixture
def modes(graph, capfd):
    made = []

    def make(*args, **kwargs):
        made.append(Modes(graph, capfd, *args, **kwargs))
        return made[-1]

    yield make
    for item in made:
        item.stop()


def test_ssvep_mode_publishes_the_ssvep_choice(graph, modes):
    rig = modes('ssvep')
    rig.play_round(look='kitchen', attend='bathroom')  # gaze is ignored in this mode
    assert graph.spin_until(lambda: rig.labels, WAIT_S)
    assert rig.choices_before_sentinel('bedroom') == ['bathroom']


def test_gaze_mode_is_unchanged(graph, modes):
    rig = modes('gaze', decoder=False)
    rig.play_round(look='bedroom', settle=False)
    assert graph.spin_until(lambda: rig.labels, WAIT_S)
    assert rig.labels == ['bedroom']


def test_hybrid_gaze_alone_never_chooses(graph, modes):
    rig = modes('hybrid', decoder=False, max_lag_s=1.0)
    rig.play_round(settle=False)
    for label in LABELS + LABELS:
        graph.spin_for(0.5)  # past the stamps of the previous round's gaze
        rig.request_pub.publish(Empty())
        graph.spin_for(0.2)
        rig.look(label, rig.rig.ros_now())
        # The gaze decided this round ...
        assert graph.spin_until(lambda: getattr(rig.arbiter.last_decision, 'label', None)
                                == label, WAIT_S)
    rig.past_max_lag()
    assert rig.labels == []  # ... but nothing was chosen


def test_hybrid_gaze_and_ssvep_agreeing_choose(graph, modes):
    rig = modes('hybrid')
    rig.play_round(look='bedroom', attend='bedroom')
    assert graph.spin_until(lambda: rig.labels, WAIT_S)
    assert rig.choices_before_sentinel('kitchen') == ['bedroom']


def test_hybrid_gaze_and_ssvep_disagreeing_do_not_choose(graph, modes):
    rig = modes('hybrid')
    rig.play_round(look='kitchen', attend='bathroom')
    assert graph.spin_until(lambda: rig.rig.choices.messages, WAIT_S)  # SSVEP did decide
    assert graph.spin_until(lambda: getattr(rig.arbiter.last_decision, 'label', None)
                            == 'kitchen', WAIT_S)   # and gaze
    assert rig.rig.choices.messages[0].data == 'bathroom'
    assert rig.choices_before_sentinel('bedroom') == []


def test_input_mode_is_checked(graph, modes):
    rig = modes('gaze', decoder=False)
    result, = graph.set_parameters('/choice_arbiter', {'input_mode': 'eeg'})
    assert not result.successful and 'eeg' in result.reason
    result, = graph.set_parameters('/choice_arbiter', {'input_mode': 'hybrid'})
    assert result.successful
    rig.play_round(look='bedroom', settle=False)
    assert graph.spin_until(lambda: getattr(rig.arbiter.last_decision, 'label', None)
                            == 'bedroom', WAIT_S)   # gaze decided; no SSVEP to confirm it
    rig.past_max_lag()
    assert rig.labels == []
