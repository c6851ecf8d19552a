"""choice_arbiter's ``choice/detail``: each outcome with its rule, evidence and last gaze stamp."""

import json

from arbiter_rig import ArbiterRig, to_time
import numpy as np
import pytest
from ros_harness import Collector, gaze_messages
from std_msgs.msg import String
from visualization_msgs.msg import Marker

from eye_bci_ros2.ros.conversions import regions_to_marker_array
from eye_bci_ros2.ros.topics import (CHOICE_DETAIL_TOPIC, EVENT_QOS, NO_CHOICE_TOPIC,
                                     SSVEP_CHOICE_TOPIC)

pytestmark = pytest.mark.ros

RATE_HZ = 100.0
LEFT, RIGHT, OFF = (300.0, 500.0), (1500.0, 500.0), (900.0, 900.0)
WAIT_S = 10.0


class Rig(ArbiterRig):
    """The arbiter, a driver, and the arbiter's ``choice/detail`` and ``choice/none``."""

    def setup(self):
        self.details = Collector(self.driver, String, CHOICE_DETAIL_TOPIC, EVENT_QOS)
        self.nones = Collector(self.driver, String, NO_CHOICE_TOPIC, EVENT_QOS)
        self.ssvep = self.driver.create_publisher(String, SSVEP_CHOICE_TOPIC, EVENT_QOS)
        self.awaited.append(CHOICE_DETAIL_TOPIC)

    def offer(self):
        """Offer two 200 px squares; return the round's start, s."""
        sources = [Marker(ns='choices', id=index, text=label)
                   for index, label in enumerate(('left', 'right'))]
        polygons = np.array([[[x - 100, y - 100], [x + 100, y - 100], [x + 100, y + 100],
                              [x - 100, y + 100]] for x, y in (LEFT, RIGHT)])
        rounds = self.arbiter.rounds_started
        self.regions.publish(regions_to_marker_array(polygons, sources, to_time(self.now())))
        assert self.graph.spin_until(lambda: self.arbiter.rounds_started > rounds, WAIT_S)
        return self.arbiter.round_start

    def look(self, centre, start, seconds):
        """Publish gaze around ``centre`` from ``start``; return the stamps sent, ns."""
        count = int(seconds * RATE_HZ)
        stamps = start + (np.arange(count) + 0.5) / RATE_HZ
        for message in gaze_messages(self.rng.normal(centre, 10.0, (count, 2)), stamps):
            self.gaze.publish(message)
        return np.rint(stamps * 1e9).astype(np.int64)

    def detail(self, count=1):
        """Wait for ``count`` details; return the last, parsed."""
        assert self.graph.spin_until(lambda: len(self.details.messages) >= count, WAIT_S)
        return json.loads(self.details.messages[count - 1].data)


def test_a_choice_is_told_with_its_rule_evidence_and_the_stamp_of_its_last_sample(graph):
    rig = Rig(graph)
    sent = rig.look(LEFT, rig.offer(), 1.3)
    detail = rig.detail()
    assert detail['label'] == 'left' and detail['reason'] is None
    assert detail['rule'] == 'mean' and detail['input_mode'] == 'gaze'
    assert detail['evidence']['counts']['left'] == detail['evidence']['in_region'] > 0
    # The stamp of one sample sent (the last the decision used), to rounding of float s.
    assert detail['gaze_stamp'] is True
    assert np.min(np.abs(sent - detail['stamp_ns'])) < 1000
    assert graph.spin_until(lambda: rig.labels == ['left'], WAIT_S)


def test_a_round_without_a_choice_is_told_with_its_reason(graph):
    rig = Rig(graph)
    sent = rig.look(OFF, rig.offer(), 1.3)
    detail = rig.detail()
    assert detail['label'] is None and detail['reason']
    assert graph.spin_until(lambda: rig.nones.messages, WAIT_S)
    assert detail['reason'] == rig.nones.messages[0].data
    assert detail['stamp_ns'] <= sent[-1] + 1000


def test_hybrid_a_choice_ssvep_confirms_is_stamped_at_its_gaze_candidate(graph):
    rig = Rig(graph, input_mode='hybrid')
    sent = rig.look(RIGHT, rig.offer(), 1.3)
    assert graph.spin_until(lambda: rig.arbiter.last_decision is not None, WAIT_S)
    assert rig.labels == []                    # gaze alone never chooses in hybrid
    rig.ssvep.publish(String(data='right'))
    assert graph.spin_until(lambda: rig.labels == ['right'], WAIT_S)
    detail = rig.detail()
    assert detail['label'] == 'right' and detail['input_mode'] == 'hybrid'
    assert detail['gaze_stamp'] is True
    assert np.min(np.abs(sent - detail['stamp_ns'])) < 1000
