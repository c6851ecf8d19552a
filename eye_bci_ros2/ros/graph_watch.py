"""
Notice a second pipeline on the same ROS graph, and say so.

Two ``eye_bci`` (or two launches) on one domain and namespace share every
topic: each arbiter gets every gaze sample twice (once per bridge) and each
decision is published on ``choice`` twice (once per arbiter), with nothing
wrong in either process.  :class:`GraphWatch` looks at the graph every
:data:`CHECK_PERIOD_S` and logs one warning when such a second party appears
(naming it, and the fix), and one line when it is gone.  Discovery is not
instant, so it tells after a few seconds, never at once.
"""

from typing import Dict, Iterable, List

from rclpy.node import Node

#: How often the graph is looked at, s (a few listing calls; no messages).
CHECK_PERIOD_S = 2.0
#: How a user separates two pipelines.
FIX = ('give each pipeline its own namespace (--ros-args -r __ns:=/person2, or a launch '
       'namespace) or ROS_DOMAIN_ID')


class GraphWatch:
    """
    Watch the graph for another publisher of a node's outputs and another reader like it.

    :param node: the watching node.
    :param outputs: topics the node publishes, one publisher each; another
        publisher on one of them is another pipeline's node.
    :param inputs: topics the node reads; a second node of the same name
        reading one of them, or several publishers on it, is another
        pipeline.
    """

    def __init__(self, node: Node, outputs: Iterable[str], inputs: Iterable[str]):
        """Start looking every CHECK_PERIOD_S (a timer of ``node``)."""
        self._node = node
        self._outputs = list(outputs)
        self._inputs = list(inputs)
        #: What is wrong now: {topic: one line}; empty when the graph is as expected.
        self.problems: Dict[str, str] = {}
        self._timer = node.create_timer(CHECK_PERIOD_S, self.check)

    def _resolved(self, topic: str) -> str:
        return self._node.resolve_topic_name(topic)

    def _names(self, infos) -> List[str]:
        return sorted({_full_name(info.node_namespace, info.node_name) for info in infos})

    def check(self) -> Dict[str, str]:
        """Look at the graph once; log what changed; return :attr:`problems`."""
        me = (self._node.get_namespace(), self._node.get_name())
        found: Dict[str, str] = {}
        for topic in self._outputs:
            topic = self._resolved(topic)
            infos = self._node.get_publishers_info_by_topic(topic)
            if len(infos) > 1:
                others = [info for info in infos
                          if (info.node_namespace, info.node_name) != me] or infos[1:]
                found[topic] = (f'{len(infos)} publishers of {topic} (also '
                                f'{", ".join(self._names(others))}): every decision may reach '
                                f'the task twice; a second pipeline on this graph? {FIX}')
        for topic in self._inputs:
            topic = self._resolved(topic)
            twins = [info for info in self._node.get_subscriptions_info_by_topic(topic)
                     if (info.node_namespace, info.node_name) == me]
            publishers = self._node.get_publishers_info_by_topic(topic)
            if len(twins) > 1:
                found[topic] = (f'another {_full_name(*me)} reads {topic}: a second pipeline '
                                f'on this graph? {FIX}')
            elif len(publishers) > 1:
                found[topic] = (f'{len(publishers)} publishers of {topic} '
                                f'({", ".join(self._names(publishers))}): each sample may '
                                f'arrive more than once; a second pipeline on this graph? {FIX}')
        self._report(found)
        return self.problems

    def _report(self, found: Dict[str, str]) -> None:
        logger = self._node.get_logger()
        for topic, text in found.items():
            if self.problems.get(topic) != text:
                logger.warning(text)
        for topic in set(self.problems) - set(found):
            logger.info(f'{topic}: the other pipeline is gone')
        self.problems = found


def _full_name(namespace: str, name: str) -> str:
    return namespace.rstrip('/') + '/' + name
