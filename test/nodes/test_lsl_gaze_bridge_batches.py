"""The bridge's batching around announced decision times, a real LSL outlet pushing per sample."""

import threading

from builtin_interfaces.msg import Time
from lsl_outlets import bridge_parameters, make_outlet, sample_for
import numpy as np
import pylsl
import pytest
from rclpy.parameter import Parameter
from ros_harness import GazeCollector

from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.ros.conversions import ns_to_stamp
from eye_bci_ros2.ros.topics import DECISION_DUE_TOPIC, LATCHED_QOS

pytestmark = [pytest.mark.ros, pytest.mark.lsl]

RATE_HZ = 1000.0
#: Long beside the short poll (2 ms): a pull at the due time and one half an idle period later
#: differ by 250 ms, which a loaded machine's late pusher or executor does not blur.
IDLE_S = 0.5
#: Messages of the idle batches looked at (the first two may be partial).
IDLE_BATCHES = 5
WAIT_S = 30.0


class Pusher(threading.Thread):
    """A tracker application: every sample pushed on its own, stamped with its due time."""

    def __init__(self, outlet, count):
        super().__init__(daemon=True)
        self.outlet, self.count = outlet, count
        self.pushed = 0

    def run(self):
        sample = sample_for('xy_pixels', [[960.0, 540.0]])[0].tolist()
        start = pylsl.local_clock()
        while self.pushed < self.count:
            due = min(self.count, int((pylsl.local_clock() - start) * RATE_HZ) + 1)
            for index in range(self.pushed, due):
                self.outlet.push_sample(sample, start + index / RATE_HZ)
            self.pushed = due
            threading.Event().wait(0.0005)


def batches(gaze):
    """Each batch's size and the stamp of its newest sample, ns: (B,), (B,)."""
    stamps, _ = gaze.samples()
    sizes = np.array([m.width for m in gaze.messages])
    return sizes, stamps[np.cumsum(sizes) - 1] * 1e9


def test_between_due_decisions_samples_come_in_bigger_batches_and_none_is_lost(graph):
    outlet, info = make_outlet('xy_pixels', rate=RATE_HZ)
    bridge = graph.add(LslGazeBridge, parameter_overrides=[
        Parameter(name, value=value) for name, value in bridge_parameters(
            'xy_pixels', info, idle_poll_period_s=IDLE_S, stats_period_s=0.0).items()])
    gaze = GazeCollector(graph.node('gaze_listener'))
    announcer = graph.node('gaze_listener').create_publisher(Time, DECISION_DUE_TOPIC,
                                                             LATCHED_QOS)
    assert graph.spin_until(outlet.have_consumers, WAIT_S), 'bridge never connected'
    # A decision due far ahead: the bridge pulls every IDLE_S.
    announcer.publish(ns_to_stamp(bridge.get_clock().now().nanoseconds + 60_000_000_000))
    # Gaze for the idle batches, the due time 5.5 idle periods after them, and a second more.
    pusher = Pusher(outlet, int(((IDLE_BATCHES + 6.5) * IDLE_S + 1.0) * RATE_HZ))
    pusher.start()
    assert graph.spin_until(lambda: len(gaze.messages) >= IDLE_BATCHES, WAIT_S)
    sizes, lasts = batches(gaze)
    # Batches of what IDLE_S gathers: far more than the 2 ms poll's one or two (a busy
    # machine only makes them bigger).
    assert np.median(sizes[2:]) >= 0.5 * IDLE_S * RATE_HZ
    # A decision due half-way between two idle pulls (their timer does not drift).
    end_ns = int(lasts[-1] + 5.5 * IDLE_S * 1e9)
    announcer.publish(ns_to_stamp(end_ns))
    assert graph.spin_until(lambda: not pusher.is_alive() and gaze.count >= pusher.count,
                            WAIT_S), f'{gaze.count} of {pusher.count} samples arrived'
    stamps, _ = gaze.samples()
    # Every sample, once, in order.
    assert len(stamps) == pusher.count
    assert np.all(np.diff(stamps) > 0)
    assert stamps[-1] * 1e9 > end_ns + 0.5 * IDLE_S * 1e9, 'the gaze ended before the due time'
    # From just before the due time the short period takes over: the batch that brings the
    # first sample stamped after it was pulled within a few ms of it (its newest sample),
    # not half an idle period later (sample stamps, not timing: a busy machine would only
    # delay the pulls).
    sizes, lasts = batches(gaze)
    due = int(np.argmax(lasts >= end_ns))
    assert lasts[due] - end_ns < 0.25 * IDLE_S * 1e9
