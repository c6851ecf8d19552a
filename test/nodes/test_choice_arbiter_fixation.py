"""The choice_arbiter with its default rule (the fixation rule), through its topics."""

from dataclasses import fields

from arbiter_rig import ArbiterRig
import numpy as np
import pytest
from ros_harness import Collector
from std_msgs.msg import String
from test_choice_arbiter import LEFT, OFF, Rig, RIGHT

from eye_bci_ros2.decision.rounds import ArbiterSettings, COUNT_RULE
from eye_bci_ros2.ros.topics import EVENT_QOS, NO_CHOICE_TOPIC

pytestmark = pytest.mark.ros

#: The node's own defaults for every setting the rig would set to the count rule.
DEFAULT_RULE = {name: getattr(ArbiterSettings(), name) for name in COUNT_RULE}


def glance(rig, start, first, then, rate=100.0):
    """Gaze resting on ``first`` for 0.3 s, then a saccade to ``then`` for 0.6 s; published."""
    points = np.vstack([rig.looks(first, int(0.3 * rate), 8.0),
                        rig.looks(then, int(0.6 * rate), 8.0)])
    rig.send(points, start)


def test_the_node_default_is_the_fixation_rule():
    assert {field.name for field in fields(ArbiterSettings)} >= set(COUNT_RULE)
    assert DEFAULT_RULE['method'] == 'fixation' and DEFAULT_RULE['early_decision']


def test_a_look_after_the_question_chooses_early(graph):
    rig = Rig(graph, **DEFAULT_RULE)
    start = rig.offer({'kitchen': LEFT, 'bedroom': RIGHT})
    glance(rig, start, OFF, RIGHT)
    assert graph.spin_until(lambda: rig.labels, 10.0)
    assert rig.labels == ['bedroom']
    decision = rig.arbiter.last_decision
    assert decision.method == 'early'
    # The fixation began at 0.3 s and had to last dwell_s: not before 0.45 s.
    assert 0.44 <= decision.time_to_decision < 0.7


def test_a_gaze_resting_on_an_option_from_the_question_on_is_no_choice_with_the_reason(graph):
    class NoneRig(Rig):
        def setup(self):
            self.none = Collector(self.driver, String, NO_CHOICE_TOPIC, EVENT_QOS)
            self.awaited.append(NO_CHOICE_TOPIC)

    rig = NoneRig(graph, **DEFAULT_RULE, window_s=0.5, stall_timeout_s=0.1)
    start = rig.offer({'kitchen': LEFT, 'bedroom': RIGHT})
    rig.send(rig.looks(LEFT, 60, 8.0), start)
    assert graph.spin_until(lambda: rig.none.messages, 10.0)
    assert 'rested on' in rig.none.messages[0].data and "'kitchen'" in rig.none.messages[0].data
    assert rig.labels == []


def test_garbage_between_the_looks_is_never_evidence(graph):
    rig = Rig(graph, **DEFAULT_RULE)
    start = rig.offer({'kitchen': LEFT, 'bedroom': RIGHT})
    points = np.vstack([rig.looks(OFF, 30, 8.0), rig.looks(LEFT, 60, 8.0)])
    points[35:37] = np.nan                      # a blink
    points[40] = RIGHT                          # a spike on the other option
    points[45] = (1e9, -1e9)                    # tracker garbage
    rig.send(points, start)
    assert graph.spin_until(lambda: rig.labels, 10.0)
    assert rig.labels == ['kitchen']


def test_the_rule_is_a_parameter_and_the_count_rule_is_one_set_away(graph):
    rig = ArbiterRig(graph, **DEFAULT_RULE)
    assert rig.arbiter.get_parameter('method').value == 'fixation'
    result, = graph.set_parameters(rig.arbiter.get_name(), {'method': 'vote'})
    assert result.successful, result.reason
    assert rig.arbiter.get_parameter('method').value == 'vote'


def test_a_gaze_resting_on_stop_is_chosen_as_fast_as_a_fresh_look(graph):
    # The robot set off while the person looked where 'stop' appears (it takes the place
    # of 'back', the chosen table's): no "look away and back" for a stop (urgent_label).
    rig = Rig(graph, **DEFAULT_RULE)
    assert rig.arbiter.get_parameter('urgent_label').value == 'stop'
    start = rig.offer({'stop': LEFT})
    rig.send(rig.looks(LEFT, 100, 8.0), start)
    resting = rig.wait_decision()
    assert graph.spin_until(lambda: rig.labels, 10.0)
    assert rig.labels == ['stop'] and resting.method == 'early'
    # A fresh look: 'stop' elsewhere (offered after every stamp of the gaze above; the same
    # label, so asked), the gaze lands on it 0.3 s after the question.
    later = start + 1.2
    assert graph.spin_until(lambda: rig.now() > later, 10.0)
    rig.offer({'stop': RIGHT}, stamp=later, new_round=False)
    start = rig.request()
    glance(rig, start, OFF, RIGHT)
    assert graph.spin_until(lambda: len(rig.labels) == 2, 10.0)
    fresh = rig.arbiter.last_decision
    assert rig.labels == ['stop', 'stop'] and fresh is not resting
    # Sample time from the round start (the rule's timing, not the wall clock): dwell_s
    # after the round start for the resting gaze, dwell_s after the landing for the fresh
    # one; a sample period (10 ms) apart at most.
    dwell = ArbiterSettings().dwell_s
    assert resting.time_to_decision <= dwell + 0.011
    assert resting.time_to_decision <= fresh.time_to_decision - 0.3 + 0.011


def test_a_gaze_resting_on_go_is_still_no_choice(graph):
    # Only the urgent option: 'go' under a resting gaze waits for a look away and back.
    class NoneRig(Rig):
        def setup(self):
            self.none = Collector(self.driver, String, NO_CHOICE_TOPIC, EVENT_QOS)
            self.awaited.append(NO_CHOICE_TOPIC)

    rig = NoneRig(graph, **DEFAULT_RULE, window_s=0.5, stall_timeout_s=0.1)
    start = rig.offer({'go': LEFT, 'back': RIGHT})
    rig.send(rig.looks(LEFT, 60, 8.0), start)
    assert graph.spin_until(lambda: rig.none.messages, 10.0)
    assert "rested on 'go'" in rig.none.messages[0].data and rig.labels == []


def test_a_fresh_look_at_send_chooses_after_the_second_look_dwell(graph):
    # 'send' appeared where the gaze was not ('back' where it rests): the node's defaults
    # decide a fresh fixation on it after second_look_dwell_s, not dwell_s.
    rig = Rig(graph, **DEFAULT_RULE)
    assert rig.arbiter.get_parameter('second_look_labels').value.split() == ['go', 'send']
    second = rig.arbiter.get_parameter('second_look_dwell_s').value
    assert second < ArbiterSettings().dwell_s
    start = rig.offer({'send': RIGHT, 'back': LEFT})
    glance(rig, start, LEFT, RIGHT)
    assert graph.spin_until(lambda: rig.labels, 10.0)
    assert rig.labels == ['send']
    decision = rig.arbiter.last_decision
    # The fixation began at 0.3 s: decided second_look_dwell_s later (a sample, 10 ms, and
    # the landing's settling at most), well before dwell_s would allow.
    assert 0.3 + second - 0.011 <= decision.time_to_decision < 0.3 + ArbiterSettings().dwell_s
