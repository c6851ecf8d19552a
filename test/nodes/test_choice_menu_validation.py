"""choice_menu's validate_first: the experiment starts with gaze_validation, through the nodes."""

import pytest
from rclpy.parameter import Parameter
from ros_harness import Collector
from std_msgs.msg import Empty, String
from validation_rig import make_rig
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.gaze.validation import ValidationOutcome
from eye_bci_ros2.nodes.choice_menu import ChoiceMenu
from eye_bci_ros2.ros.topics import (EVENT_QOS, LATCHED_QOS, VALIDATION_RESULT_TOPIC,
                                     VALIDATION_START_TOPIC)

pytestmark = pytest.mark.ros


def offered(choices):
    """Return the labels of the last options offered on ``choices``."""
    if not choices.messages:
        return []
    return [m.text for m in choices.last.markers if m.action == Marker.ADD]


def states(collector):
    return [m.data for m in collector.messages]


def start_menu(graph, **params):
    menu = graph.add(ChoiceMenu, parameter_overrides=[
        Parameter(name, value=value) for name, value in dict(validate_first=True,
                                                             **params).items()])
    probe = graph.node('menu_probe')
    choices = Collector(probe, MarkerArray, 'choices', LATCHED_QOS)
    state = Collector(probe, String, 'choice_menu/state', LATCHED_QOS)
    return menu, probe, choices, state


@pytest.mark.lsl
@pytest.mark.slow
def test_the_menu_offers_the_rooms_after_the_validation_gaze_validation_ran(graph):
    rig = make_rig(graph)
    try:
        validation = rig.start_validation(graph, on_request=True, targets=5, target_s=0.8,
                                          settle_s=0.4, output='', validate_again=False)
        menu, probe, choices, state = start_menu(graph)
        assert graph.spin_until(lambda: validation.running, 10.0), 'validation never started'
        assert graph.spin_until(lambda: states(state) == ['validating'], 5.0), states(state)
        assert offered(choices) == []
        assert graph.spin_until(lambda: offered(choices), 30.0), 'rooms never offered'
        assert validation.outcome.accepted
        assert 'kitchen' in offered(choices)
        assert graph.spin_until(lambda: states(state)[-1] != 'validating', 5.0)
        assert states(state)[0] == 'validating'
        assert rig.bridge.correction is not None      # the correction is in force
    finally:
        rig.streamer.stop()


def test_a_refused_validation_is_run_again_then_the_menu_goes_on(graph):
    menu, probe, choices, state = start_menu(graph, validation_retries=1)
    starts = Collector(probe, Empty, VALIDATION_START_TOPIC, EVENT_QOS)
    result = probe.create_publisher(String, VALIDATION_RESULT_TOPIC, EVENT_QOS)
    refused = ValidationOutcome(False, 'no correction: target(s) 2 got fewer than 10 gaze '
                                'samples', targets=5).to_json()
    # The menu sends validation/start once something listens to it.
    assert graph.spin_until(lambda: len(starts.messages) == 1, 10.0)
    assert graph.spin_until(lambda: result.get_subscription_count() > 0, 5.0)
    result.publish(String(data=refused))
    assert graph.spin_until(lambda: len(starts.messages) == 2, 10.0), 'not run again'
    assert offered(choices) == [] and menu.state == 'validating'
    result.publish(String(data='not json'))            # a bad message: logged, nothing lost
    result.publish(String(data=refused))
    assert graph.spin_until(lambda: offered(choices), 10.0), 'the menu did not go on'
    assert len(starts.messages) == 2
    assert 'kitchen' in offered(choices)
