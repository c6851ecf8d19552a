"""
Reference for bench.gaze_rate: the gaze path before batching, one message per sample.

What the bridge and the arbiter did before ``gaze/samples``: the bridge pulled
LSL chunks on a 2 ms timer and published one geometry_msgs/PointStamped per
sample; the arbiter took one message per sample and fed it to the same
:class:`eye_bci_ros2.decision.rounds.RoundScheduler`, both on rclpy's Python
``SingleThreadedExecutor``.  Run as a process by the benchmark::

    python -m bench.reference_per_sample bridge STREAM_NAME
    python -m bench.reference_per_sample arbiter
"""

import signal
import sys
import threading

from geometry_msgs.msg import PointStamped
import numpy as np
import pylsl
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, RoundScheduler
from eye_bci_ros2.nodes.conversions import gaze_point, marker_array_to_regions
from eye_bci_ros2.nodes.topics import GAZE_QOS, LATCHED_QOS, REGIONS_TOPIC

#: The reference's own gaze topic (the pipeline's nodes do not listen to it).
TOPIC = 'reference/gaze'
POLL_PERIOD_S = 0.002


class ReferenceBridge(Node):
    """Pull LSL chunks every 2 ms; publish one PointStamped per sample."""

    def __init__(self, stream_name: str):
        """Open the inlet of the stream called ``stream_name``."""
        super().__init__('reference_bridge')
        info = pylsl.resolve_byprop('name', stream_name, timeout=10.0)[0]
        self.inlet = pylsl.StreamInlet(info, max_buflen=60)
        self.inlet.open_stream(timeout=5.0)
        self.publisher = self.create_publisher(PointStamped, TOPIC, GAZE_QOS)
        self.create_timer(POLL_PERIOD_S, self.poll)

    def poll(self) -> None:
        """Publish what the inlet holds, a message per sample."""
        samples, stamps = self.inlet.pull_chunk(timeout=0.0, max_samples=1024)
        now_ns = self.get_clock().now().nanoseconds
        for x, y in np.asarray(samples, dtype=float).reshape(-1, 2)[:, :2].tolist():
            self.publisher.publish(gaze_point(now_ns, x, y))


class ReferenceArbiter(Node):
    """Feed each PointStamped to a RoundScheduler, one call per message."""

    def __init__(self):
        """Subscribe to the reference gaze and the regions."""
        super().__init__('reference_arbiter')
        self.rounds = RoundScheduler(ArbiterSettings())
        self.create_subscription(PointStamped, TOPIC, self.on_gaze, GAZE_QOS)
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self.on_regions, LATCHED_QOS)

    def now(self) -> float:
        """Return the ROS clock, s."""
        return self.get_clock().now().nanoseconds * 1e-9

    def on_gaze(self, message: PointStamped) -> None:
        """Take one sample."""
        stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
        self.rounds.add_sample(stamp, message.point.x, message.point.y, self.now())

    def on_regions(self, message: MarkerArray) -> None:
        """Take the offered regions."""
        labels, polygons = marker_array_to_regions(message)
        self.rounds.add_regions(RegionSet(labels, polygons, self.now()), self.now())


def main(argv=None) -> int:
    """Run one reference node until SIGTERM."""
    argv = sys.argv[1:] if argv is None else argv
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    rclpy.init()
    node = ReferenceBridge(argv[1]) if argv[0] == 'bridge' else ReferenceArbiter()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    while not stop.is_set():
        executor.spin_once(timeout_sec=0.1)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
