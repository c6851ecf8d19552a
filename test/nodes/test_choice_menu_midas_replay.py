"""
The choice_menu and the choice_arbiter answer real free-looking gaze as bench.confirmation --midas.

``python -m bench.confirmation --midas`` replays real gaze of people who do not mean to
choose through the menu's protocol (rooms, tables and 'back', 'go' / 'back' asked
``confirm_rounds`` rounds, 'send' asked ``send_rounds``) decided by the arbiter's code.
Here the same gaze goes through the real nodes on their topics: the menu (the node's
defaults, but the two gates the bench leaves out, the camera's arrival and the look
away, set to pass at once: ``settle_s`` and ``look_away_s`` 0) and the arbiter (its
default rule, on the recording's screen).  The test stands in for the projector: each
``choices`` the menu offers becomes ``choices/regions`` at the bench's places for those
labels, stamped now.  Each gaze sample is its own ``gaze/samples`` batch at its stamp,
on simulated time (``use_sim_time``, ``/clock``): the next message waits until the
nodes have taken the last one, and after a round ends until the menu has asked again.
The menu's answers (``choice_menu/answer``) must be the bench's, at the same times.
"""

import dataclasses

import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from bench import confirmation, midas
from bench.real_gaze import squares
from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.nodes.choice_menu import ChoiceMenu
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.ros.conversions import gaze_batch, ns_to_stamp, regions_to_marker_array
from eye_bci_ros2.ros.topics import (CHOICES_TOPIC, EVENT_QOS, GAZE_QOS, GAZE_SAMPLES_TOPIC,
                                     LATCHED_QOS, MENU_ANSWER_TOPIC, REGIONS_TOPIC)
from eye_bci_ros2.task.menu import ASKING, BACK_LABEL, GO_LABEL, ProtocolSettings, SEND_LABEL

pytestmark = [pytest.mark.ros]

#: Generous wait for each message to be taken, s (2 shared cores).
WAIT_S = 15.0
#: The replayed stretch of the recording, s: long enough for every step of the menu.
SECONDS = 60.0
#: Seeds the bench's places (one replay).
SEED = 5


def _ns(seconds: float) -> int:
    return int(round(seconds * 1e9))


class Places:
    """The bench's places of each step, drawn once (as the bench draws them), then kept."""

    def __init__(self, recording):
        self.rng = np.random.default_rng(SEED)
        self.recording = recording
        self.rooms = None
        self.tables = {}
        self.confirm = {}
        self.send = {}

    def draw_rooms(self):
        if self.rooms is None:
            self.rooms = midas.layout(self.recording, confirmation.ROOMS, confirmation.SIZE,
                                      midas.CLEARANCE_DEG, self.rng)
        return self.rooms

    def draw_tables(self, room):
        if room not in self.tables:
            self.tables[room] = midas.layout(self.recording, confirmation.TABLES + 1,
                                             confirmation.SIZE, midas.CLEARANCE_DEG, self.rng)
        return self.tables[room]

    def draw_confirm(self, table):
        key = tuple(table)
        if key not in self.confirm:
            self.confirm[key] = confirmation.midas_confirm_layout(self.recording, table,
                                                                  self.rng)
        return self.confirm[key]

    def draw_send(self, go):
        key = tuple(go)
        if key not in self.send:
            self.send[key] = confirmation.send_layout(self.recording, go, self.rng)
        return self.send[key]

    def as_bench(self):
        return {'rooms': self.draw_rooms, 'tables': self.draw_tables,
                'confirm': self.draw_confirm, 'send': self.draw_send}


@pytest.fixture(scope='module')
def replayed():
    """Return the first SECONDS of a real X2-60 session, the bench's places and answers."""
    folder = find_data('real_gaze')
    if folder is None:
        pytest.skip('no real gaze recordings (../shared/data/real_gaze)')
    recording = next(r for r in confirmation.load_folder(folder) if 'X260_ss1' in r.name)
    keep = recording.stamps < SECONDS
    recording = dataclasses.replace(recording, stamps=recording.stamps[keep],
                                    points=recording.points[keep])
    rule = confirmation.settings_for_recording(confirmation.RULES['default'], recording)
    places = Places(recording)
    total = confirmation.menu_replay(recording, rule, ProtocolSettings(), layouts=1,
                                     places=places.as_bench())
    return recording, rule, places, total


def _bench_labels(menu, places, answers):
    """Return the bench's answers as the menu's labels: [(label, s)], up to a goal."""
    rooms = list(menu.scene.room_labels)
    labels, room = [], None
    for step, chosen, at in answers:
        if chosen is None:
            continue                    # unanswered: the menu answers nothing
        if step == 'rooms':
            room = menu.scene.room(rooms[chosen])
            labels.append((rooms[chosen], at))
        elif step == 'tables':
            names = [table.marker.text for table in room.tables] + [BACK_LABEL]
            labels.append((names[chosen], at))
        elif step == 'confirm':
            labels.append(((GO_LABEL, BACK_LABEL)[chosen], at))
        elif chosen == 1:
            labels.append((BACK_LABEL, at))     # 'back' in the send step: the tables
        else:
            labels.append((SEND_LABEL, at))
            break                       # a goal: the robot drives (the bench goes on)
    return labels


def _bench_offers(answers):
    """Return the steps the bench offered, in order: [(step, s)], up to a goal."""
    offers = [('rooms', 0.0)]
    for step, chosen, at in answers:
        if step == 'send' and chosen == 0:
            break
        following = {'rooms': 'tables', 'confirm': 'tables' if chosen != 0 else 'send',
                     'tables': 'rooms' if chosen == confirmation.TABLES else 'confirm',
                     'send': 'tables'}
        offers.append((following[step], at))
    return offers


def _step(labels):
    """Name the step whose labels these are."""
    if labels[0] == SEND_LABEL:
        return 'send'
    if labels[0] == GO_LABEL:
        return 'confirm'
    return 'tables' if BACK_LABEL in labels else 'rooms'


class Projector:
    """Stands in for marker_projector: the menu's offer at the bench's places, stamped now."""

    def __init__(self, driver, menu, places):
        self.menu, self.places, self.driver = menu, places, driver
        self.offers = []            # (step, s) of each offer, in order
        self.regions = driver.create_publisher(MarkerArray, REGIONS_TOPIC, LATCHED_QOS)
        driver.create_subscription(MarkerArray, CHOICES_TOPIC, self._on_choices, LATCHED_QOS)

    def _centres(self, labels):
        scene, protocol = self.menu.scene, self.menu._protocol
        if labels == list(scene.room_labels):
            return self.places.draw_rooms()
        room = protocol.room
        index = list(scene.room_labels).index(room.marker.text)
        tables = self.places.draw_tables(index)
        if set(labels) == {GO_LABEL, BACK_LABEL} or labels == [SEND_LABEL, BACK_LABEL]:
            chosen = [t.marker.text for t in room.tables].index(protocol.pending)
            confirm = self.places.draw_confirm(tables[chosen])
            return confirm if labels[0] == GO_LABEL else self.places.draw_send(confirm[0])
        return tables

    def _on_choices(self, message):
        markers = [m for m in message.markers if m.action == Marker.ADD]
        labels = [m.text for m in markers]
        if not labels or labels[0] == 'stop':
            return
        centres = self._centres(labels)
        sources = [Marker(ns=m.ns, id=m.id, text=m.text) for m in markers]
        stamp = self.driver.get_clock().now().nanoseconds
        self.offers.append((_step(labels), stamp * 1e-9))
        self.regions.publish(regions_to_marker_array(
            squares(centres, confirmation.SIZE), sources, ns_to_stamp(stamp)))


def test_the_nodes_answer_real_free_looking_as_the_bench(graph, replayed):
    recording, rule, places, total = replayed
    sim = Parameter('use_sim_time', value=True)
    arbiter = graph.add(ChoiceArbiter, parameter_overrides=[sim] + [
        Parameter(name, value=getattr(rule, name)) for name in (
            'screen_width', 'screen_height', 'screen_width_mm', 'screen_height_mm',
            'viewing_distance_mm')])
    driver = graph.node('replay_driver')
    driver.set_parameters([sim])
    clock = driver.create_publisher(Clock, '/clock', 10)
    gaze = driver.create_publisher(PointCloud2, GAZE_SAMPLES_TOPIC, GAZE_QOS)
    answers = Collector(driver, String, MENU_ANSWER_TOPIC, EVENT_QOS)
    assert graph.spin_until(lambda: gaze.get_subscription_count() > 0, WAIT_S)
    menu = graph.add(ChoiceMenu, parameter_overrides=[
        sim, Parameter('settle_s', value=0.0), Parameter('look_away_s', value=0.0)])
    projector = Projector(driver, menu, places)
    assert menu.get_parameter('confirm_rounds').value == ProtocolSettings().confirm_rounds
    assert menu.get_parameter('send_rounds').value == ProtocolSettings().send_rounds
    nodes = (arbiter, menu, driver)

    def at(t):
        stamp = ns_to_stamp(_ns(t))

        def read():
            clock.publish(Clock(clock=stamp))
            return all(node.get_clock().now().nanoseconds == _ns(t) for node in nodes)
        assert graph.spin_until(read, WAIT_S), f'the nodes did not reach {t} s'

    def asking(t):
        """Tell whether the menu asks about what it offers, in the arbiter's open round."""
        return (menu.state == ASKING and arbiter.round_start is not None
                and abs(arbiter.round_start - t) < 1e-6
                and arbiter._rounds.offered == frozenset(menu.options))

    at(0.0)
    assert graph.spin_until(lambda: asking(0.0) and projector.regions.get_subscription_count(),
                            WAIT_S), f'the rooms were not asked: {menu.state}'
    stamps, points = midas._valid(recording)
    seen, live = arbiter.last_decision, []
    for t, point in zip(stamps.tolist(), points):
        at(t)
        received = arbiter.samples_received
        gaze.publish(gaze_batch(np.array([_ns(t)]), point.reshape(1, 2)))
        assert graph.spin_until(lambda: arbiter.samples_received > received, WAIT_S)
        if arbiter.last_decision is not seen:
            seen = arbiter.last_decision
            # A round ended: a choice the menu answers, or none; then the next question.
            assert graph.spin_until(lambda: asking(t) or menu.state != ASKING and
                                    menu._protocol.drive is not None, WAIT_S), menu.state
            count = len(answers.messages)
            assert graph.spin_until(lambda: len(answers.messages) >= count, WAIT_S)
            live += [(m.data, t) for m in answers.messages[len(live):]]
            if menu._protocol.drive is not None:
                break                   # a goal: the robot drives
    expected = _bench_labels(menu, places, total['answers'])
    # The stretch goes through the steps a wandering gaze reaches: rooms, tables, 'back'
    # in both steps, and confirmations left unanswered (back to the tables in the bench and
    # in the node alike, or the tables chosen next would be no answer).
    assert total['confirm unanswered'] >= 3 and total['confirm back'] >= 1
    assert total['tables back'] >= 1 and len(expected) >= 8
    assert [label for label, _ in live] == [label for label, _ in expected]
    np.testing.assert_allclose([t for _, t in live], [t for _, t in expected], atol=1e-6)
    # And the same steps offered at the same times: a confirmation left unanswered returns
    # to the tables after confirm_rounds rounds in the node as in the bench.
    offers = _bench_offers(total['answers'])
    assert [step for step, _ in projector.offers] == [step for step, _ in offers]
    np.testing.assert_allclose([t for _, t in projector.offers], [t for _, t in offers],
                               atol=1e-6)
