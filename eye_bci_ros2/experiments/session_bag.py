"""
A recorded session, read from its rosbag2 (``session_record`` or ``ros2 bag record``).

The bag's raw messages are read with rosbags and decoded by rclpy with the
package's own message readers (:mod:`eye_bci_ros2.ros.conversions`: gaze
batches, region outlines), so a bag is read as the nodes read the topics.
Times are s on the ROS clock: gaze at its acquisition stamps, regions at their
header stamp, every other message at its reception (the bag's log time, as
``ros2 bag record`` stamps).  Topic names are those of
:data:`eye_bci_ros2.ros.session_topics.RECORDED_TOPICS` in the session's
namespace, found from the bag (the namespace of its ``gaze/samples`` or
``choice``).
"""

from dataclasses import dataclass, field
import math
from pathlib import Path
from typing import Dict, List, Optional, Tuple

import numpy as np
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Reader

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.navigation.occupancy import yaw_of
from eye_bci_ros2.ros.conversions import (gaze_batch_arrays, marker_array_to_regions,
                                          pose_to_arrays, stamp_to_ns)
from eye_bci_ros2.ros.feedback_markers import option_label
from eye_bci_ros2.ros.message_types import message_class
from eye_bci_ros2.ros.topics import (CHOICE_TOPIC, CHOICES_TOPIC, CUE_TOPIC, GAZE_SAMPLES_TOPIC,
                                     GOAL_POSE_TOPIC, MAP_TOPIC, MENU_ANSWER_TOPIC,
                                     MENU_GOAL_TOPIC, MENU_PROGRESS_TOPIC, MENU_RESULT_TOPIC,
                                     MENU_STATE_TOPIC,
                                     NAVIGATE_TO_POSE_ACTION, NO_CHOICE_TOPIC, ODOM_TOPIC,
                                     PLAN_TOPIC, REGIONS_TOPIC, REQUEST_TOPIC,
                                     VALIDATION_RESULT_TOPIC)

#: The action's feedback topic (nav2's NavigateToPose: the robot's pose on the way).
FEEDBACK_TOPIC = NAVIGATE_TO_POSE_ACTION + '/_action/feedback'
#: String topics kept as (time, text) lists, by the Session attribute that holds them.
_TEXT_TOPICS = {CHOICE_TOPIC: 'choices', NO_CHOICE_TOPIC: 'no_choices', CUE_TOPIC: 'cues',
                MENU_ANSWER_TOPIC: 'answers', MENU_RESULT_TOPIC: 'results',
                MENU_PROGRESS_TOPIC: 'progress', MENU_STATE_TOPIC: 'states',
                VALIDATION_RESULT_TOPIC: 'validations'}

Events = List[Tuple[float, str]]


@dataclass
class GridMap:
    """The map: cells (H, W) 0 free, 100 occupied, -1 unknown; origin (x, y) m; cell size m."""

    occupancy: np.ndarray
    origin: Tuple[float, float]
    resolution: float


@dataclass
class Session:
    """
    What a session's bag holds, as arrays and event lists (times s on the ROS clock).

    :ivar gaze_t: shape (N,), the gaze samples' acquisition times, ascending.
    :ivar gaze_xy: shape (N, 2), screen px.
    :ivar regions: every ``choices/regions`` set, stamped, in order.
    :ivar colours: option label -> (r, g, b, a) from ``choices``.
    :ivar requests: times of ``choice/request`` (a question asked).
    :ivar goals: (time, [x, y, yaw]) of ``goal_pose`` and ``choice_menu/goal``.
    :ivar odometry: shape (M, 4): time, x, y, yaw of ``odom``.
    :ivar robot_poses: shape (F, 4): time, x, y, yaw of the action's feedback.
    :ivar plans: (time, (K, 2) path) of ``plan``.
    :ivar counts: messages per topic (relative name).
    """

    path: str
    namespace: str = ''
    gaze_t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    gaze_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    regions: List[RegionSet] = field(default_factory=list)
    colours: Dict[str, Tuple[float, float, float, float]] = field(default_factory=dict)
    requests: List[float] = field(default_factory=list)
    choices: Events = field(default_factory=list)
    no_choices: Events = field(default_factory=list)
    cues: Events = field(default_factory=list)
    answers: Events = field(default_factory=list)
    results: Events = field(default_factory=list)
    progress: Events = field(default_factory=list)
    states: Events = field(default_factory=list)
    validations: Events = field(default_factory=list)
    goals: List[Tuple[float, np.ndarray]] = field(default_factory=list)
    odometry: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    robot_poses: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    plans: List[Tuple[float, np.ndarray]] = field(default_factory=list)
    map: Optional[GridMap] = None   # noqa: A003 - nav2's name for it
    counts: Dict[str, int] = field(default_factory=dict)
    start: float = math.nan
    end: float = math.nan


def _namespace(topics: List[str]) -> str:
    """Return the session's namespace ('' or '/ns') from the bag's topic names."""
    for name in (GAZE_SAMPLES_TOPIC, CHOICE_TOPIC, REGIONS_TOPIC):
        for topic in topics:
            if topic.endswith('/' + name):
                return topic[:-len(name) - 1]
    return ''


def _pose_row(stamp: float, pose) -> List[float]:
    position, quaternion = pose_to_arrays(pose)
    return [stamp, float(position[0]), float(position[1]), yaw_of(quaternion)]


def read_session(path) -> Session:
    """
    Read a session's bag folder.

    :raises ValueError: not a rosbag2 folder (or its metadata cannot be read); the
        reason in one line.
    """
    path = Path(path)
    try:
        reader = Reader(path)
        reader.open()
    except Exception as error:   # noqa: B902 - rosbags raises its own kinds; one line
        raise ValueError(f'{path} is not a readable rosbag2: '
                         f'{str(error).splitlines()[0] if str(error) else type(error).__name__}'
                         ) from None
    session = Session(path=str(path))
    try:
        topics = [c.topic for c in reader.connections]
        session.namespace = _namespace(topics)
        relative = {c.id: c.topic[len(session.namespace) + 1:]
                    if c.topic.startswith(session.namespace + '/') else c.topic
                    for c in reader.connections}
        classes = {}
        for connection in reader.connections:
            try:
                classes[connection.id] = message_class(connection.msgtype)
            except (ImportError, AttributeError, ValueError):
                classes[connection.id] = None   # a type not installed here: not read
        gaze_t, gaze_xy, odometry, poses = [], [], [], []
        for connection, stamp_ns, data in reader.messages():
            cls = classes[connection.id]
            if cls is None:
                continue
            topic = relative[connection.id]
            session.counts[topic] = session.counts.get(topic, 0) + 1
            stamp = stamp_ns * 1e-9
            session.start = stamp if math.isnan(session.start) else min(session.start, stamp)
            session.end = stamp if math.isnan(session.end) else max(session.end, stamp)
            message = deserialize_message(bytes(data), cls)
            if topic == GAZE_SAMPLES_TOPIC:
                try:
                    stamps, points = gaze_batch_arrays(message)
                except ValueError:
                    continue
                gaze_t.append(stamps)
                gaze_xy.append(points)
            elif topic in _TEXT_TOPICS:
                getattr(session, _TEXT_TOPICS[topic]).append((stamp, message.data))
            elif topic == REQUEST_TOPIC:
                session.requests.append(stamp)
            elif topic == REGIONS_TOPIC:
                labels, polygons = marker_array_to_regions(message)
                shown = (stamp_to_ns(message.markers[0].header.stamp) * 1e-9
                         if message.markers else stamp)
                session.regions.append(RegionSet(labels, polygons, shown))
            elif topic == CHOICES_TOPIC:
                for marker in message.markers:
                    session.colours[option_label(marker)] = (
                        marker.color.r, marker.color.g, marker.color.b, marker.color.a)
            elif topic in (GOAL_POSE_TOPIC, MENU_GOAL_TOPIC):
                session.goals.append((stamp, np.array(_pose_row(stamp, message.pose)[1:])))
            elif topic == ODOM_TOPIC:
                odometry.append(_pose_row(stamp, message.pose.pose))
            elif topic == FEEDBACK_TOPIC:
                poses.append(_pose_row(stamp, message.feedback.current_pose.pose))
            elif topic == PLAN_TOPIC:
                session.plans.append((stamp, np.array(
                    [[p.pose.position.x, p.pose.position.y] for p in message.poses]
                ).reshape(-1, 2)))
            elif topic == MAP_TOPIC:
                info = message.info
                session.map = GridMap(
                    np.array(message.data, dtype=np.int16).reshape(info.height, info.width),
                    (info.origin.position.x, info.origin.position.y), info.resolution)
    finally:
        reader.close()
    if gaze_t:
        stamps, points = np.concatenate(gaze_t), np.concatenate(gaze_xy)
        order = np.argsort(stamps, kind='stable')
        session.gaze_t, session.gaze_xy = stamps[order], points[order]
    session.odometry = np.array(odometry, dtype=float).reshape(-1, 4)
    session.robot_poses = np.array(poses, dtype=float).reshape(-1, 4)
    return session
