"""
Record a session's ROS side as a rosbag2 (MCAP), where there is no ``ros2 bag``.

``session_record [-o FOLDER]`` subscribes to each topic of
:data:`eye_bci_ros2.ros.session_topics.RECORDED_TOPICS` once it appears on the
graph (checked every :data:`DISCOVERY_PERIOD_S`), with the type the graph
names, and writes every message as it arrived (serialized, never decoded;
stamped with its reception time as ``ros2 bag record`` does) into a bag that
``ros2 bag info`` and ``ros2 bag play`` read (:mod:`eye_bci_ros2.recordings.bag_writer`):
each topic with its publishers' offered QoS and type hash, so ``play``
latches again what was latched.  Relative names follow the namespace
(``--ros-args -r __ns:=/left``).

Ctrl-C (or SIGTERM) closes the bag whole.  A folder that cannot be made is
one line and status 1 before anything starts; a write that fails mid-run
(disk full) closes the bag with what was written before, says so in one
line, and ends with status 1.  A topic whose type is not installed here
(nav2's action feedback without nav2_msgs) is named once and left out.

Usage::

    session_record                      # into session_YYYYmmdd_HHMMSS/
    session_record -o study/p01_run1
    session_record --ros-args -r __ns:=/left
"""

import argparse
import os
import shutil
import sys
import time
from typing import Dict, List, Optional, Sequence

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.utilities import remove_ros_args
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)

from eye_bci_ros2.recordings.bag_writer import BagError, FLUSH_PERIOD_S, SessionBagWriter
from eye_bci_ros2.ros.message_types import message_class, message_definition_from_class
from eye_bci_ros2.ros.runner import spin_nodes
from eye_bci_ros2.ros.session_topics import RECORDED_TOPICS, RecordedTopic
from eye_bci_ros2.ros.topics import (CHOICE_TOPIC, GAZE_SAMPLES_TOPIC, REGIONS_TOPIC,
                                     REQUEST_TOPIC)

#: How often the graph is looked at for topics not yet recorded, s.
DISCOVERY_PERIOD_S = 0.5
#: The topics without which a session's report has nothing (waited for by the demo).
SESSION_CORE = (GAZE_SAMPLES_TOPIC, REQUEST_TOPIC, CHOICE_TOPIC, REGIONS_TOPIC)


def _time(duration) -> QosTime:
    nanoseconds = int(duration.nanoseconds)
    return QosTime(nanoseconds // 10**9, nanoseconds % 10**9)


def bag_qos(profile: QoSProfile) -> Qos:
    """Turn an rclpy QoS profile (a publisher's offered QoS) into the bag's form."""
    return Qos(history=QosHistory(int(profile.history)), depth=int(profile.depth),
               reliability=QosReliability(int(profile.reliability)),
               durability=QosDurability(int(profile.durability)),
               deadline=_time(profile.deadline), lifespan=_time(profile.lifespan),
               liveliness=QosLiveliness(int(profile.liveliness)),
               liveliness_lease_duration=_time(profile.liveliness_lease_duration),
               avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions))


def subscription_qos(wanted: QoSProfile, offered: Sequence[QoSProfile]) -> QoSProfile:
    """
    Return the QoS that receives from every publisher found (as ``ros2 bag record`` adapts).

    Reliable only when every publisher is; transient local only when every one is (so a
    latched topic's last message arrives); the topic's own depth.
    """
    reliable = all(p.reliability == ReliabilityPolicy.RELIABLE for p in offered)
    latched = bool(offered) and all(
        p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in offered)
    return QoSProfile(
        history=wanted.history, depth=max(wanted.depth, 1),
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                    else DurabilityPolicy.VOLATILE))


def _rihs01(endpoint) -> str:
    type_hash = getattr(endpoint, 'topic_type_hash', None)
    value = getattr(type_hash, 'value', None)
    if getattr(type_hash, 'version', 0) != 1 or not value:
        return ''
    return 'RIHS01_' + bytes(value).hex()


class SessionRecorder(Node):
    """
    Subscribes to the session's topics as they appear and writes them to a bag.

    :ivar writer: the bag (:class:`SessionBagWriter`).
    :ivar exit_status: 1 once writing failed (the runner then ends the process), else None.
    """

    def __init__(self, writer: SessionBagWriter,
                 topics: Sequence[RecordedTopic] = RECORDED_TOPICS, **kwargs) -> None:
        """
        Start looking for the topics.

        :param writer: the open bag (closed by :meth:`destroy_node`).
        :param topics: what to record.
        :param kwargs: passed to :class:`rclpy.node.Node`.
        """
        super().__init__('session_record', **kwargs)
        self.writer = writer
        self.exit_status: Optional[int] = None
        self._topics = {self.resolve_topic_name(t.name): t for t in topics}
        self._recording: Dict[str, object] = {}
        self._skipped: Dict[str, str] = {}
        self._clock = self.get_clock()
        self._last_flush = time.monotonic()
        self.create_timer(DISCOVERY_PERIOD_S, self._look)
        self._look()

    def _look(self) -> None:
        """Subscribe to the session topics that have appeared; flush the pending chunk."""
        if time.monotonic() - self._last_flush >= FLUSH_PERIOD_S:
            self._last_flush = time.monotonic()
            if not self.writer.flush():
                self._stop()
                return
        for name, types in self.get_topic_names_and_types():
            topic = self._topics.get(name)
            if topic is None or name in self._recording or name in self._skipped:
                continue
            self._subscribe(name, topic, types[0] if types else topic.type)

    def _subscribe(self, name: str, topic: RecordedTopic, type_name: str) -> None:
        try:
            cls = message_class(type_name)
        except (ImportError, AttributeError, ValueError) as error:
            self._skipped[name] = str(error)
            self.get_logger().warning(f'{name} ({type_name}) not recorded: its type is not '
                                      f'installed here ({error})')
            return
        definitions = None
        if not self.writer.knows(type_name):
            definitions = message_definition_from_class(cls)
            self.writer.add_types(definitions)
        publishers = self.get_publishers_info_by_topic(name)
        offered = [p.qos_profile for p in publishers]
        type_hash = next((h for h in map(_rihs01, publishers) if h), '')
        self.writer.add_topic(name, type_name, [bag_qos(q) for q in offered], type_hash,
                              definitions)
        self._recording[name] = self.create_subscription(
            cls, name, lambda data, name=name: self._on_message(name, data),
            subscription_qos(topic.qos, offered), raw=True)

    def _on_message(self, name: str, data: bytes) -> None:
        # The reception time on the ROS clock, as ``ros2 bag record`` stamps (rclpy 7.1.6's
        # EventsExecutor cannot hand a raw message's MessageInfo to a callback).
        if not self.writer.write(name, self._clock.now().nanoseconds, data):
            self._stop()

    def _stop(self) -> None:
        if self.exit_status is None and self.writer.problem:
            self.get_logger().error(self.writer.problem)
            self.exit_status = 1

    def recording_all(self, topics: Sequence[str] = SESSION_CORE) -> bool:
        """Tell whether ``topics`` (relative names) are all being recorded."""
        return all(self.resolve_topic_name(name) in self._recording for name in topics)

    def has_seen(self, counts: Dict[str, int]) -> bool:
        """Tell whether at least ``counts`` messages (by relative topic name) were recorded."""
        return all(self.writer.counts.get(self.resolve_topic_name(name), 0) >= count
                   for name, count in counts.items())

    @property
    def recorded(self) -> List[str]:
        """Return the topics being recorded."""
        return sorted(self._recording)

    def destroy_node(self) -> None:
        """Stop recording and close the bag whole."""
        for subscription in self._recording.values():
            self.destroy_subscription(subscription)
        self._recording.clear()
        had_problem = bool(self.writer.problem)
        problem = self.writer.close()
        counts = self.writer.counts
        if problem and not had_problem:
            self.get_logger().error(problem)
        elif not problem:
            print(f'session_record: {self.writer.path} closed: {sum(counts.values())} '
                  f'messages on {sum(1 for n in counts.values() if n)} topics',
                  file=sys.stderr, flush=True)
        super().destroy_node()


def open_session_bag(folder: str, name: str) -> SessionBagWriter:
    """
    Open a new bag ``folder/name``, replacing one of that name (the demo's own output).

    :raises BagError: it cannot be made (one line).
    """
    path = os.path.join(folder, name)
    if os.path.isdir(path):
        shutil.rmtree(path)
    os.makedirs(folder, exist_ok=True)
    return SessionBagWriter(path)


def default_folder() -> str:
    """Return ``session_YYYYmmdd_HHMMSS`` (local time), as ``ros2 bag record`` names bags."""
    return time.strftime('session_%Y%m%d_%H%M%S')


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line options of ``session_record``."""
    parser = argparse.ArgumentParser(
        prog='session_record', description=__doc__.strip().splitlines()[0],
        epilog='Topics: ' + ', '.join(t.name for t in RECORDED_TOPICS))
    parser.add_argument('-o', '--output', default=None,
                        help='the bag folder to create (default session_YYYYmmdd_HHMMSS)')
    return parser


def main(argv: Optional[List[str]] = None) -> None:
    """Record until Ctrl-C; exit 1 with one line when the bag cannot be made or written."""
    argv = list(sys.argv if argv is None else argv)
    args = build_parser().parse_args(remove_ros_args(argv)[1:])
    try:
        writer = SessionBagWriter(args.output or default_folder())
    except BagError as error:
        print(f'session_record: {error}', file=sys.stderr)
        sys.exit(1)
    ros_args = argv[argv.index('--ros-args'):] if '--ros-args' in argv else []
    print(f'session_record: recording into {writer.path} (Ctrl-C closes it)', file=sys.stderr,
          flush=True)
    try:
        spin_nodes(lambda: [SessionRecorder(writer)], args=argv[:1] + ros_args)
    finally:
        writer.close()   # closed already when the node was made; here when it was not


if __name__ == '__main__':
    main()
