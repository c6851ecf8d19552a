"""The choice_arbiter's default tolerant rule, through its topics and the parameter service."""

from arbiter_rig import ArbiterRig, to_time
import numpy as np
import pytest
from rclpy.parameter import Parameter
from ros_harness import gaze_messages
from visualization_msgs.msg import Marker

from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter
from eye_bci_ros2.ros.conversions import regions_to_marker_array

pytestmark = pytest.mark.ros

RATE_HZ = 100.0
#: Two small (16 px) options near the centre of the default 24-inch screen, where the
#: default tolerance (0.8 deg / 0.3 deg, k 2, size-aware) reaches 66 px beyond their edge.
SMALL, OTHER = (960.0, 540.0), (1260.0, 540.0)
#: Gaze resting 30 px beyond SMALL's right edge: within the tolerance, clearly nearer SMALL.
JUST_OUTSIDE = (998.0, 540.0)
#: Two small options 100 px apart, and the point midway (42 px from each edge).
LEFT_PAIR, RIGHT_PAIR, MIDWAY = (960.0, 540.0), (1060.0, 540.0), (1010.0, 540.0)
#: Off every option by far.
FAR = (200.0, 950.0)


class Rig(ArbiterRig):
    """The arbiter plus a driver publishing small regions, gaze and requests."""

    def __init__(self, graph, **parameters):
        super().__init__(graph, 'tolerant_driver', 11, **parameters)

    def offer(self, layout, side=16.0):
        """Publish ``layout`` (label -> centre px) as ``side`` px squares; return the stamp."""
        stamp = self.now()
        half = side / 2.0
        polygons = np.array([[[x - half, y - half], [x + half, y - half],
                              [x + half, y + half], [x - half, y + half]]
                             for x, y in layout.values()])
        sources = [Marker(ns='options', id=i, text=label) for i, label in enumerate(layout)]
        rounds = self.arbiter.rounds_started
        self.regions.publish(regions_to_marker_array(polygons, sources, to_time(stamp)))
        assert self.graph.spin_until(lambda: self.arbiter.rounds_started > rounds, 10.0)
        return stamp

    def rest(self, point, start, seconds=1.1, lead_s=0.2):
        """Publish gaze off the options for ``lead_s`` then resting at ``point`` (100 Hz)."""
        lead = int(lead_s * RATE_HZ)
        count = int(seconds * RATE_HZ)
        points = np.vstack([self.rng.normal(FAR, 5.0, (lead, 2)),
                            self.rng.normal(point, 3.0, (count - lead, 2))])
        stamps = start + (np.arange(count) + 0.5) / RATE_HZ
        for message in gaze_messages(points, stamps):
            self.gaze.publish(message)
        return count

    def decision(self, received_before):
        """Spin until every sample sent is taken and the round is decided; return it."""
        assert self.graph.spin_until(
            lambda: self.arbiter.samples_received >= received_before
            and self.arbiter.round_start is None, 10.0), 'no decision'
        return self.arbiter.last_decision


@pytest.mark.parametrize('early', [False, True])
def test_gaze_just_outside_a_small_option_chooses_it_and_inside_does_not(graph, early):
    rig = Rig(graph, early_decision=early)
    sent = rig.rest(JUST_OUTSIDE, rig.offer({'small': SMALL, 'other': OTHER}))
    decision = rig.decision(sent)
    assert decision.label == 'small', decision.summary()
    assert decision.method == ('early' if early else 'mean')
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    assert rig.labels == ['small']

    # The original rule, chosen at run time through the parameter service.
    results = graph.set_parameters('/choice_arbiter',
                                   {'classification': 'inside', 'min_share': 0})
    assert all(result.successful for result in results), [r.reason for r in results]
    assert graph.get_parameters('/choice_arbiter', ['classification', 'min_share']) == \
        ['inside', 0.0]
    sent += rig.rest(JUST_OUTSIDE, rig.request())
    decision = rig.decision(sent)
    assert decision.label is None and decision.reason == 'no sample in any region'
    assert rig.choices_before_sentinel() == ['small']


def test_gaze_midway_between_two_options_chooses_nothing(graph):
    rig = Rig(graph, early_decision=True)
    sent = rig.rest(MIDWAY, rig.offer({'left': LEFT_PAIR, 'right': RIGHT_PAIR}), lead_s=0.0)
    decision = rig.decision(sent)
    assert decision.label is None, decision.summary()
    assert rig.choices_before_sentinel() == []


def test_bad_rule_parameters_get_a_one_line_reason_and_the_node_keeps_running(graph):
    rig = Rig(graph)
    bad = {'classification': 'nearby', 'ratio': 0.0, 'min_share': 1.5,
           'viewing_distance_mm': -650.0, 'screen_width': 0}
    for name, value in bad.items():
        result = graph.set_parameters('/choice_arbiter', {name: value})[0]
        assert not result.successful, name
        assert result.reason and '\n' not in result.reason, (name, result.reason)
    # Each value alone is fine, together they are no tracker's error: the reason says so.
    assert graph.set_parameters('/choice_arbiter', {'accuracy_deg': 9.0})[0].successful
    result = graph.set_parameters('/choice_arbiter', {'k_sigma': 8.0})[0]
    assert not result.successful and 'below 30 deg' in result.reason, result.reason
    assert '\n' not in result.reason
    # What a person types: an integer for a double.
    results = graph.set_parameters('/choice_arbiter', {'accuracy_deg': 1, 'screen_width_mm': 600})
    assert all(result.successful for result in results), [r.reason for r in results]
    assert graph.get_parameters('/choice_arbiter', ['accuracy_deg', 'screen_width_mm',
                                                    'classification', 'ratio', 'k_sigma']) \
        == [1.0, 600.0, 'tolerant', 0.5, 2.0]
    # The node still chooses.
    sent = rig.rest(JUST_OUTSIDE, rig.offer({'small': SMALL, 'other': OTHER}))
    assert rig.decision(sent).label == 'small'
    assert graph.spin_until(lambda: rig.choices.messages, 10.0)
    assert rig.labels == ['small']


def test_bad_rule_override_fails_at_start_with_the_reason(graph):
    with pytest.raises(ValueError, match='below 30 deg'):
        graph.add(ChoiceArbiter, parameter_overrides=[
            Parameter('accuracy_deg', value=9.0), Parameter('k_sigma', value=8.0)])
