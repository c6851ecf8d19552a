"""A second pipeline on the same graph is noticed and named by the arbiter."""

from fault_rig import LogTap
import pytest

from eye_bci_ros2.nodes.choice_arbiter import ChoiceArbiter

pytestmark = pytest.mark.ros

WAIT_S = 10.0


def test_a_lone_arbiter_sees_no_other_pipeline(graph):
    arbiter = graph.add(ChoiceArbiter)
    # Its own publisher and subscription are discovered first: then nothing else is there.
    assert graph.spin_until(
        lambda: len(arbiter.get_publishers_info_by_topic('/choice')) == 1
        and len(arbiter.get_subscriptions_info_by_topic('/gaze/samples')) == 1, WAIT_S)
    assert arbiter.graph_watch.check() == {}


def test_a_second_arbiter_is_named_with_the_fix_and_its_leaving_is_told(graph, capfd):
    log = LogTap(capfd)
    first = graph.add(ChoiceArbiter)
    second = graph.add(ChoiceArbiter)
    assert graph.spin_until(lambda: '/choice' in first.graph_watch.check(), WAIT_S)
    problems = first.graph_watch.problems
    assert 'another /choice_arbiter reads /gaze/samples' in problems['/gaze/samples']
    assert '2 publishers of /choice' in problems['/choice']
    assert '__ns:=' in problems['/choice']     # says how to separate them
    assert log.wait_for(graph, r'WARN.*2 publishers of /choice')
    graph.nodes.remove(second)
    graph.executor.remove_node(second)
    second.destroy_node()
    assert graph.spin_until(lambda: first.graph_watch.check() == {}, WAIT_S)
    assert log.wait_for(graph, r'/choice: the other pipeline is gone')
