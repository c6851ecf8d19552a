"""session_markers: each event on its LSL marker stream, read by a real pylsl inlet, stamped."""

import json
import time

from geometry_msgs.msg import PoseStamped
from marker_rig import (ChoosingRig, MarkerInlet, OPTIONS, square, TRACKER_LAG_S,
                        unique_namespace)
import numpy as np
import pylsl
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.gaze.validation import ValidationOutcome
from eye_bci_ros2.nodes.session_markers import SessionMarkers
from eye_bci_ros2.recordings.session_markers import FORMAT_VERSION, stream_identity
from eye_bci_ros2.ros.conversions import ns_to_stamp, regions_to_marker_array
from eye_bci_ros2.ros.topics import (CHOICE_DETAIL_TOPIC, EVENT_QOS, GOAL_POSE_TOPIC, GOAL_QOS,
                                     LATCHED_QOS, MENU_ANSWER_TOPIC, MENU_PROGRESS_TOPIC,
                                     MENU_RESULT_TOPIC, MENU_STATE_TOPIC, REGIONS_TOPIC,
                                     REQUEST_TOPIC, SSVEP_STIMULI_TOPIC, VALIDATION_RESULT_TOPIC)
from eye_bci_ros2.streams.lsl_connection import clock_pair

pytestmark = [pytest.mark.ros, pytest.mark.lsl]

WAIT_S = 30.0
#: A ROS stamp mapped by the node and by the test (two clock pairs) agree this well, s.
PAIR_TOLERANCE_S = 0.002
#: The rig's tracker rate, Hz, and how near a choice's stamp lies to a pushed sample's, s
#: (measured: tens of us; a stamp taken at arrival falls anywhere in the 4 ms period).
RIG_RATE_HZ = 250.0
GRID_TOLERANCE_S = 0.00025


def ros_to_lsl_here(stamp_ns: int) -> float:
    """Map a ROS stamp to the LSL clock with the test's own clock pair (the narrowest read)."""
    now_ns, lsl_now = clock_pair(time.time_ns, pylsl.local_clock)
    return lsl_now + (stamp_ns - now_ns) * 1e-9


class Topics:
    """A driver node publishing every topic session_markers reads, in its namespace."""

    def __init__(self, graph, namespace):
        node = graph.add(Node, 'marker_topics', namespace=namespace)
        self.node = node
        make = node.create_publisher
        self.regions = make(MarkerArray, REGIONS_TOPIC, LATCHED_QOS)
        self.request = make(Empty, REQUEST_TOPIC, EVENT_QOS)
        self.detail = make(String, CHOICE_DETAIL_TOPIC, EVENT_QOS)
        self.answer = make(String, MENU_ANSWER_TOPIC, EVENT_QOS)
        self.result = make(String, MENU_RESULT_TOPIC, EVENT_QOS)
        self.progress = make(String, MENU_PROGRESS_TOPIC, LATCHED_QOS)
        self.state = make(String, MENU_STATE_TOPIC, LATCHED_QOS)
        self.goal = make(PoseStamped, GOAL_POSE_TOPIC, GOAL_QOS)
        self.validation = make(String, VALIDATION_RESULT_TOPIC, EVENT_QOS)
        self.stimuli = make(JointState, SSVEP_STIMULI_TOPIC, LATCHED_QOS)
        publishers = [self.regions, self.request, self.detail, self.answer, self.result,
                      self.progress, self.state, self.goal, self.validation, self.stimuli]
        assert graph.spin_until(lambda: all(p.get_subscription_count() for p in publishers),
                                WAIT_S), 'session_markers did not subscribe'


@pytest.fixture
def rig(graph):
    namespace = unique_namespace()
    node = graph.add(SessionMarkers, namespace=namespace)
    inlet = MarkerInlet(node.source_id)
    topics = Topics(graph, namespace)
    assert graph.spin_until(node.outlet.have_consumers, WAIT_S)
    yield node, inlet, topics, namespace
    inlet.close()


def received(graph, inlet, publish, event, count=1):
    """Publish, wait for the marker; return (marker, stamp, LSL time before, after)."""
    before = pylsl.local_clock()
    already = len(inlet.of(event))
    publish()
    markers = inlet.wait(graph, event, already + count)
    after = pylsl.local_clock()
    body, stamp = markers[-1]
    assert body['v'] == FORMAT_VERSION
    return body, stamp, before, after


def test_the_stream_says_which_pipeline(rig):
    node, inlet, _, namespace = rig
    name, source_id = stream_identity(namespace, 'host')
    assert inlet.info.name() == name == f'eye_bci_markers {namespace}'
    assert inlet.info.source_id() == node.source_id
    assert node.source_id.endswith('/' + namespace.strip('/'))
    assert source_id.startswith('eye_bci_markers@')


def test_a_question_carries_the_options_and_their_regions(graph, rig):
    node, inlet, topics, _ = rig
    polygons = np.stack([square(*OPTIONS[label], 100.0) for label in OPTIONS])
    sources = [Marker(ns='tables', id=index, text=label) for index, label in enumerate(OPTIONS)]
    shown_ns = time.time_ns() - 200_000_000       # the screen showed them 0.2 s ago
    body, stamp, _, _ = received(graph, inlet, lambda: topics.regions.publish(
        regions_to_marker_array(polygons, sources, ns_to_stamp(shown_ns))), 'options')
    assert abs(stamp - ros_to_lsl_here(shown_ns)) < PAIR_TOLERANCE_S
    assert [option['label'] for option in body['options']] == list(OPTIONS)
    # The same options seen from a moved view: no news.
    topics.regions.publish(regions_to_marker_array(polygons + 5.0, sources,
                                                   ns_to_stamp(time.time_ns())))
    assert graph.spin_until(lambda: node.regions[1][0, 0, 0] == polygons[0, 0, 0] + 5.0)
    body, stamp, before, after = received(graph, inlet,
                                          lambda: topics.request.publish(Empty()), 'question')
    assert before <= stamp <= after
    assert body['step'] == ['tables']
    assert [option['label'] for option in body['options']] == list(OPTIONS)
    np.testing.assert_allclose(body['options'][0]['region'], polygons[0] + 5.0)
    assert len(inlet.of('options')) == 1


def test_a_choice_and_a_no_choice_are_stamped_at_their_last_gaze_sample(graph, rig):
    _, inlet, topics, _ = rig
    gaze_ns = time.time_ns() - 700_000_000       # a sample 0.7 s ago: not the arrival time
    detail = {'label': 'left', 'reason': None, 'input_mode': 'gaze', 'rule': 'fixation',
              'evidence': {'samples': 90, 'posterior': 0.97, 'counts': {'left': 80}},
              'stamp_ns': gaze_ns, 'gaze_stamp': True}
    body, stamp, _, _ = received(
        graph, inlet, lambda: topics.detail.publish(String(data=json.dumps(detail))), 'choice')
    assert abs(stamp - ros_to_lsl_here(gaze_ns)) < PAIR_TOLERANCE_S
    assert body['label'] == 'left' and body['rule'] == 'fixation'
    assert body['evidence'] == detail['evidence'] and body['gaze_stamp'] is True
    none = dict(detail, label=None, reason='no fixation on an option', stamp_ns=gaze_ns + 10**8)
    body, stamp, _, _ = received(
        graph, inlet, lambda: topics.detail.publish(String(data=json.dumps(none))), 'no_choice')
    assert abs(stamp - ros_to_lsl_here(gaze_ns + 10**8)) < PAIR_TOLERANCE_S
    assert body['reason'] == 'no fixation on an option' and body['label'] is None


def test_the_menu_events_confirmation_go_stop_arrival_and_failure(graph, rig):
    _, inlet, topics, _ = rig
    for label, event in (('kitchen', 'answer'), ('kitchen/table_2', 'answer'), ('go', 'go'),
                         ('stop', 'stop')):
        body, stamp, before, after = received(
            graph, inlet, lambda: topics.answer.publish(String(data=label)), event)
        assert body['label'] == label and before <= stamp <= after
    assert inlet.of('go')[0][0]['goal'] == 'kitchen/table_2'    # what 'go' confirmed
    body, *_ = received(graph, inlet, lambda: topics.result.publish(
        String(data='kitchen/table_2')), 'outcome')
    assert body['label'] == 'kitchen/table_2'
    for text, event in (("driving to 'kitchen/table_2': 3.1 m left", 'driving'),
                        ("arrived at 'kitchen/table_2'", 'arrived'),
                        ("stopped on the way to 'kitchen/table_2'", 'stopped'),
                        ("the robot did not move toward 'kitchen/table_2' within 10 s (3.5 m "
                         'left, no nearer): choose again', 'failed'),
                        ("sending the robot to 'kitchen/table_2'", 'robot')):
        body, stamp, before, after = received(
            graph, inlet, lambda: topics.progress.publish(String(data=text)), event)
        assert body['text'] == text and before <= stamp <= after
    body, *_ = received(graph, inlet, lambda: topics.state.publish(String(data='driving')),
                        'state')
    assert body['state'] == 'driving'
    goal = PoseStamped()
    goal.header.frame_id = 'map'
    goal.pose.position.x, goal.pose.position.y = 2.5, -1.0
    goal.pose.orientation.z, goal.pose.orientation.w = np.sin(0.25), np.cos(0.25)
    body, *_ = received(graph, inlet, lambda: topics.goal.publish(goal), 'goal')
    assert (body['frame'], body['x'], body['y']) == ('map', 2.5, -1.0)
    assert body['yaw_rad'] == pytest.approx(0.5, abs=1e-3)


def test_a_validation_result_and_a_stimulus_onset_at_its_frame_0(graph, rig):
    _, inlet, topics, _ = rig
    outcome = ValidationOutcome(accepted=False, reason='a target got 3 of 20 samples')
    body, *_ = received(graph, inlet,
                        lambda: topics.validation.publish(String(data=outcome.to_json())),
                        'validation')
    assert body['accepted'] is False and body['reason'] == 'a target got 3 of 20 samples'
    epoch_ns = time.time_ns() + 100_000_000      # the stimulus window starts 0.1 s ahead
    stimuli = JointState(name=['left', 'right'], position=[13.0, 15.0], velocity=[0.0, 1.5])
    stimuli.header.stamp = ns_to_stamp(epoch_ns)
    body, stamp, _, _ = received(graph, inlet, lambda: topics.stimuli.publish(stimuli),
                                 'stimulus_onset')
    assert abs(stamp - ros_to_lsl_here(epoch_ns)) < PAIR_TOLERANCE_S
    assert body['frame'] == 0 and body['labels'] == ['left', 'right']
    assert body['frequencies_hz'] == [13.0, 15.0] and body['phases_rad'] == [0.0, 1.5]


def test_a_bad_message_loses_nothing_after_it(graph, rig):
    node, inlet, topics, _ = rig
    topics.detail.publish(String(data='{not json'))
    topics.validation.publish(String(data='[1, 2]'))
    body, *_ = received(graph, inlet, lambda: topics.answer.publish(String(data='back')),
                        'answer')
    assert body['label'] == 'back'
    assert [m['event'] for m, _ in inlet.pull()] == ['answer']
    assert node.context.ok()


def test_enabled_false_publishes_no_stream_and_true_opens_it(graph):
    namespace = unique_namespace()
    node = graph.add(SessionMarkers, namespace=namespace,
                     parameter_overrides=[Parameter('enabled', value=False)])
    assert node.outlet is None
    assert pylsl.resolve_byprop('source_id', node.source_id, 1, 2.0) == []
    results = graph.set_parameters(f'{namespace}/session_markers', {'enabled': True})
    assert results[0].successful
    inlet = MarkerInlet(node.source_id)
    inlet.close()


def test_real_choices_are_stamped_on_the_gaze_sample_they_were_made_on(graph):
    # The real bridge and arbiter choose on a real tracker outlet's gaze; the marker of each
    # choice must carry the LSL stamp of the last sample the decision used: one the tracker
    # pushed (on its grid of 1/rate), at least the tracker's latency before the marker came.
    rig = ChoosingRig(graph, rate_hz=RIG_RATE_HZ)
    inlet = MarkerInlet(rig.markers_node.source_id)
    try:
        rig.offer()
        rig.start()
        asked = ['left', 'right', 'left', 'right']
        for index, label in enumerate(asked):
            rig.ask(label)
            inlet.wait(graph, 'choice', index + 1)
        questions = inlet.of('question')
        assert len(questions) >= len(asked)
        assert [o['label'] for o in questions[0][0]['options']] == list(OPTIONS)
    finally:
        rig.close()
    choices = inlet.of('choice')
    assert [body['label'] for body, _ in choices] == asked
    arrived = [at for (body, _), at in zip(inlet.markers, inlet.arrived)
               if body['event'] == 'choice']
    for (body, stamp), at in zip(choices, arrived):
        assert body['rule'] == 'fixation' and body['gaze_stamp'] is True
        assert body['evidence']['posterior'] >= 0.9
        assert abs(stamp - rig.pusher.stamp_near(stamp)) < GRID_TOLERANCE_S
        assert at - stamp >= TRACKER_LAG_S
    # Each choice after its question.
    assert all(q[1] < c[1] for q, c in zip(questions, choices))


def test_each_question_while_stimuli_flicker_marks_its_trial_at_a_stimulus_frame(graph, rig):
    node, inlet, topics, _ = rig
    refresh = node.get_parameter('refresh_hz').value
    epoch_ns = time.time_ns() - 1_000_000_000     # the stimuli started a second ago
    stimuli = JointState(name=['left', 'right'], position=[13.0, 15.0], velocity=[0.0, 1.5])
    stimuli.header.stamp = ns_to_stamp(epoch_ns)
    received(graph, inlet, lambda: topics.stimuli.publish(stimuli), 'stimulus_onset')
    body, stamp, _, _ = received(graph, inlet, lambda: topics.request.publish(Empty()),
                                 'trial_onset')
    question = inlet.of('question')[-1][1]
    frame = body['frame']
    assert frame >= refresh and body['refresh_hz'] == refresh
    # On the stimulus frame grid, the first frame at or after the question.
    assert abs(stamp - ros_to_lsl_here(epoch_ns + round(frame * 1e9 / refresh))) \
        < PAIR_TOLERANCE_S
    assert question - 1e-6 <= stamp < question + 1.0 / refresh
