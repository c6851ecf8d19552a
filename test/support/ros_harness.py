"""
In-process ROS 2 test harness: private Context, own domain id, one executor.

The executor is the one the executables use (:func:`eye_bci_ros2.ros.runner.make_executor`:
the EventsExecutor unless ``EYE_BCI_EXECUTOR=single``).

Modelled on rclpy's own tests: every test gets a fresh ``Context`` on a
domain id reserved by ``domain_coordinator`` so tests never see each other's
traffic, and tears down executor -> nodes -> context.
"""

import contextlib
import time
from typing import Any, Callable, Dict, List, Optional, Tuple

from domain_coordinator import domain_id
import numpy as np
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from sensor_msgs.msg import PointCloud2

from eye_bci_ros2.ros.conversions import gaze_batch, gaze_batch_arrays, SCREEN_FRAME
from eye_bci_ros2.ros.runner import make_executor, spin_for, spin_until
from eye_bci_ros2.ros.topics import GAZE_QOS, GAZE_SAMPLES_TOPIC

#: Samples per gaze/samples message the test publishers send (20 ms at 1200 Hz; the
#: bridge sends what it pulls each poll, a few samples at its default 2 ms).
GAZE_CHUNK = 24

#: A parameter read with no answer after this long is sent again (get_parameters), s.
RETRY_S = 4.0


class RosGraph:
    """A private ROS 2 graph: a context, an executor and the nodes on it."""

    def __init__(self, context: Context, domain: int):
        self.context = context
        self.domain = domain
        self.executor = make_executor(context=context)
        self.nodes: List[Node] = []

    def add(self, node_class, *args, **kwargs) -> Any:
        """Create a node on this graph (``context=`` filled in) and spin it."""
        node = node_class(*args, context=self.context, **kwargs)
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def node(self, name: str) -> Node:
        """Create a plain helper node for test publishers and subscribers."""
        return self.add(Node, name)

    def spin_for(self, seconds: float) -> None:
        """Spin the executor for ``seconds`` of wall time."""
        spin_for(self.executor, seconds)

    def spin_until(self, predicate: Callable[[], bool], timeout: float = 5.0) -> bool:
        """Spin until ``predicate()`` is true; return whether it became true."""
        return spin_until(self.executor, predicate, timeout)

    def wait_future(self, future, timeout: float = 5.0):
        """Spin until ``future`` is done and return its result."""
        self.executor.spin_until_future_complete(future, timeout_sec=timeout)
        assert future.done(), 'timed out waiting for a ROS future'
        return future.result()

    def set_parameters(self, node_name: str, values: Dict[str, Any],
                       timeout: float = 5.0) -> list:
        """
        Set parameters over the parameter services, as ``ros2 param set`` does.

        :returns: the list of ``SetParametersResult``, one per parameter.
        """
        client = self._param_client(node_name, timeout)
        parameters = [value if isinstance(value, Parameter) else Parameter(name, value=value)
                      for name, value in values.items()]
        response = self.wait_future(client.set_parameters(parameters), timeout)
        return list(response.results)

    def get_parameters(self, node_name: str, names: List[str], timeout: float = 5.0) -> list:
        """
        Read parameters over the parameter services (``ros2 param get``).

        A node just started in another process may answer its first request to a
        reply reader it has not matched yet (DDS discovery): the reply is lost, so a
        read that gets no answer within a few seconds is sent again (reading twice is
        harmless), until ``timeout``.
        """
        client = self._param_client(node_name, timeout)
        end = time.monotonic() + timeout
        while True:
            future = client.get_parameters(names)
            self.executor.spin_until_future_complete(
                future, timeout_sec=max(min(RETRY_S, end - time.monotonic()), 0.0))
            if future.done() or time.monotonic() >= end:
                break
        assert future.done(), 'timed out waiting for a ROS future'
        return [parameter_value_to_python(value) for value in future.result().values]

    def _param_client(self, node_name: str, timeout: float) -> AsyncParameterClient:
        helper = getattr(self, '_param_helper', None)
        if helper is None:
            helper = self._param_helper = self.node('test_param_client')
            self._param_clients = {}
        # One client per node: each holds six service clients, and a new one per call
        # makes every wait set (and so every later call) slower.
        client = self._param_clients.get(node_name)
        if client is None:
            client = self._param_clients[node_name] = AsyncParameterClient(helper, node_name)
        assert self.spin_until(lambda: client.services_are_ready(), timeout), \
            f'parameter services of {node_name} not ready'
        return client

    def shutdown(self) -> None:
        """Tear down executor -> nodes -> context."""
        self.executor.shutdown()
        for node in self.nodes:
            node.destroy_node()
            # Then the action servers and clients the node left: rclpy's destroy_node leaves
            # them, and with them the node's participant, whose latched goal status a later
            # graph on the same domain would still see.
            for waitable in list(node.waitables):
                destroy = getattr(waitable, 'destroy', None)
                if destroy is not None:
                    destroy()
        self.context.try_shutdown()


@contextlib.contextmanager
def ros_graph():
    """Yield a :class:`RosGraph` on a fresh context and a reserved domain id."""
    with domain_id() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        graph = RosGraph(context, domain)
        try:
            yield graph
        finally:
            graph.shutdown()


def gaze_messages(points, stamps, frame: str = SCREEN_FRAME,
                  chunk: int = GAZE_CHUNK) -> List[PointCloud2]:
    """
    Split gaze samples into ``gaze/samples`` batches, as the bridge publishes them.

    :param points: shape (N, 2), screen px (anything, NaN included).
    :param stamps: shape (N,), acquisition times, s (>= 0; 0 = unstamped).
    :param chunk: samples per message.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    stamps_ns = np.rint(np.asarray(stamps, dtype=float).reshape(-1) * 1e9).astype(np.int64)
    return [gaze_batch(stamps_ns[i:i + chunk], points[i:i + chunk], frame)
            for i in range(0, len(points), chunk)]


def gaze_samples(messages) -> Tuple[np.ndarray, np.ndarray]:
    """Stamps (N,) s and points (N, 2) px of ``gaze/samples`` messages, in order."""
    pairs = [gaze_batch_arrays(message) for message in messages]
    if not pairs:
        return np.zeros(0), np.zeros((0, 2))
    return np.concatenate([p[0] for p in pairs]), np.concatenate([p[1] for p in pairs])


class Collector:
    """Subscribe to a topic and keep every message received."""

    def __init__(self, node: Node, msg_type, topic: str, qos):
        self.messages: List[Any] = []
        self.subscription = node.create_subscription(msg_type, topic, self.messages.append, qos)

    @property
    def last(self) -> Optional[Any]:
        """Return the newest message, or None."""
        return self.messages[-1] if self.messages else None


class GazeCollector:
    """Subscribe to ``gaze/samples`` and keep every sample received, in order."""

    def __init__(self, node: Node):
        self.messages: List[PointCloud2] = []
        self.count = 0
        self.subscription = node.create_subscription(
            PointCloud2, GAZE_SAMPLES_TOPIC, self._on_batch, GAZE_QOS)

    def _on_batch(self, message: PointCloud2) -> None:
        self.messages.append(message)
        self.count += message.width * message.height

    def samples(self, first: int = 0) -> Tuple[np.ndarray, np.ndarray]:
        """Stamps (N,) s and points (N, 2) px of the samples from number ``first`` on."""
        stamps, points = gaze_samples(self.messages)
        return stamps[first:], points[first:]
