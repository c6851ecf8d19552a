"""
The topics a study records: the one list for ``session_record`` and ``ros2 bag record``.

A session's ROS side is what the person was offered and chose, what the
screen showed, and what the robot did.  ``session_record`` subscribes to
each of these topics once it appears on the graph, with the type the graph
names; docs/recording.md prints the same list as a ``ros2 bag record``
command (:func:`ros2_bag_record_command`) for an apt install.  Both record
each topic's offered QoS, so ``ros2 bag play`` latches again what was
latched (``choices``, ``choices/regions``, ``camera/pose``, ``map``,
``plan``, ``/tf_static``, the menu's state, the action's status).

The list holds what a report needs and no bulk the session does not: the
per-sample cursor (``gaze/point``, ``gaze/samples`` holds every sample), the
robot's drawing (``robot/marker``) and ``choice/due`` (the arbiter's
schedule) are left out.
"""

from typing import NamedTuple, Tuple

from rclpy.qos import qos_profile_action_status_default, QoSProfile

from eye_bci_ros2.ros.topics import (CAMERA_GOAL_TOPIC, CAMERA_POSE_TOPIC,
                                     CHOICE_DETAIL_TOPIC, CHOICE_TOPIC,
                                     CHOICES_QOS, CHOICES_TOPIC, CUE_TOPIC, EVENT_QOS,
                                     FEEDBACK_QOS, FEEDBACK_TOPIC, GAZE_ON_SCREEN_TOPIC,
                                     GAZE_QOS, GAZE_SAMPLES_TOPIC, GOAL_POSE_TOPIC, GOAL_QOS,
                                     LATCHED_QOS, MAP_QOS, MAP_TOPIC, MENU_ANSWER_TOPIC,
                                     MENU_GOAL_TOPIC, MENU_PROGRESS_TOPIC, MENU_RESULT_TOPIC,
                                     MENU_STATE_TOPIC,
                                     NAVIGATE_TO_POSE_ACTION, NO_CHOICE_TOPIC, ODOM_QOS,
                                     ODOM_TOPIC, PLAN_QOS, PLAN_TOPIC, REGIONS_TOPIC,
                                     REQUEST_TOPIC, SCORES_QOS, SSVEP_CHOICE_TOPIC,
                                     SSVEP_SCORES_TOPIC, SSVEP_STIMULI_TOPIC, TF_STATIC_TOPIC,
                                     TF_TOPIC, VALIDATION_RESULT_TOPIC, VALIDATION_START_TOPIC,
                                     VALIDATION_TARGET_TOPIC)

#: rclpy's action server publishes feedback with this (a default QoSProfile, depth 10).
ACTION_FEEDBACK_QOS = QoSProfile(depth=10)
#: /tf as tf2_ros's broadcaster publishes it: reliable, volatile, depth 100.
TF_QOS = QoSProfile(depth=100)


class RecordedTopic(NamedTuple):
    """
    One topic of a session.

    :ivar name: the topic (relative names follow the recorder's namespace).
    :ivar type: its ROS 2 type (``pkg/msg/Type``); the graph's type is recorded when it
        differs (a robot of another kind).
    :ivar qos: what the recorder asks for: as deep as the publisher's queue, latched where
        the publisher latches (the reliability and durability follow the publishers found).
    """

    name: str
    type: str   # noqa: A003 - the ROS word (ros2 topic type)
    qos: QoSProfile


_STRING = 'std_msgs/msg/String'
_MARKERS = 'visualization_msgs/msg/MarkerArray'

#: Every topic of a session, in the order ``ros2 bag record`` is given them.
RECORDED_TOPICS: Tuple[RecordedTopic, ...] = (
    RecordedTopic(GAZE_SAMPLES_TOPIC, 'sensor_msgs/msg/PointCloud2', GAZE_QOS),
    RecordedTopic(GAZE_ON_SCREEN_TOPIC, 'std_msgs/msg/Bool', LATCHED_QOS),
    RecordedTopic(CAMERA_POSE_TOPIC, 'geometry_msgs/msg/PoseStamped', LATCHED_QOS),
    RecordedTopic(CAMERA_GOAL_TOPIC, 'geometry_msgs/msg/PoseStamped', LATCHED_QOS),
    RecordedTopic(CHOICES_TOPIC, _MARKERS, CHOICES_QOS),
    RecordedTopic(REGIONS_TOPIC, _MARKERS, LATCHED_QOS),
    RecordedTopic(FEEDBACK_TOPIC, _MARKERS, FEEDBACK_QOS),
    RecordedTopic(REQUEST_TOPIC, 'std_msgs/msg/Empty', EVENT_QOS),
    RecordedTopic(CHOICE_TOPIC, _STRING, EVENT_QOS),
    RecordedTopic(NO_CHOICE_TOPIC, _STRING, EVENT_QOS),
    RecordedTopic(CHOICE_DETAIL_TOPIC, _STRING, EVENT_QOS),
    RecordedTopic(CUE_TOPIC, _STRING, LATCHED_QOS),
    RecordedTopic(MENU_STATE_TOPIC, _STRING, LATCHED_QOS),
    RecordedTopic(MENU_ANSWER_TOPIC, _STRING, EVENT_QOS),
    RecordedTopic(MENU_RESULT_TOPIC, _STRING, EVENT_QOS),
    RecordedTopic(MENU_PROGRESS_TOPIC, _STRING, LATCHED_QOS),
    RecordedTopic(VALIDATION_START_TOPIC, 'std_msgs/msg/Empty', EVENT_QOS),
    RecordedTopic(VALIDATION_TARGET_TOPIC, 'geometry_msgs/msg/PointStamped', LATCHED_QOS),
    RecordedTopic(VALIDATION_RESULT_TOPIC, _STRING, EVENT_QOS),
    RecordedTopic(SSVEP_STIMULI_TOPIC, 'sensor_msgs/msg/JointState', LATCHED_QOS),
    RecordedTopic(SSVEP_SCORES_TOPIC, 'sensor_msgs/msg/JointState', SCORES_QOS),
    RecordedTopic(SSVEP_CHOICE_TOPIC, _STRING, EVENT_QOS),
    RecordedTopic(GOAL_POSE_TOPIC, 'geometry_msgs/msg/PoseStamped', GOAL_QOS),
    RecordedTopic(MENU_GOAL_TOPIC, 'geometry_msgs/msg/PoseStamped', EVENT_QOS),
    RecordedTopic(NAVIGATE_TO_POSE_ACTION + '/_action/status',
                  'action_msgs/msg/GoalStatusArray', qos_profile_action_status_default),
    RecordedTopic(NAVIGATE_TO_POSE_ACTION + '/_action/feedback',
                  'nav2_msgs/action/NavigateToPose_FeedbackMessage', ACTION_FEEDBACK_QOS),
    RecordedTopic(ODOM_TOPIC, 'nav_msgs/msg/Odometry', ODOM_QOS),
    RecordedTopic(MAP_TOPIC, 'nav_msgs/msg/OccupancyGrid', MAP_QOS),
    RecordedTopic(PLAN_TOPIC, 'nav_msgs/msg/Path', PLAN_QOS),
    RecordedTopic(TF_TOPIC, 'tf2_msgs/msg/TFMessage', TF_QOS),
    RecordedTopic(TF_STATIC_TOPIC, 'tf2_msgs/msg/TFMessage', LATCHED_QOS),
)


def ros2_bag_record_command(namespace: str = '', output: str = 'session') -> str:
    """
    Return the ``ros2 bag record`` command of :data:`RECORDED_TOPICS` (apt ROS 2 Jazzy).

    :param namespace: the pipeline's namespace ('' = none): relative names are put in it.
    :param output: the bag's folder.
    """
    prefix = '/' + namespace.strip('/') if namespace.strip('/') else ''
    names = [topic.name if topic.name.startswith('/') else f'{prefix}/{topic.name}'
             for topic in RECORDED_TOPICS]
    return f'ros2 bag record -s mcap -o {output} ' + ' '.join(names)
