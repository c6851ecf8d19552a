"""
Topic names and quality-of-service profiles: the one home of the topic contract.

Every name is relative, so a namespace (``--ros-args -r __ns:=/left``) moves a
whole pipeline.  docs/DESIGN.md ("Topics") says what each carries.
"""

from rclpy.qos import (DurabilityPolicy, HistoryPolicy, qos_profile_action_status_default,
                       QoSProfile, ReliabilityPolicy)

#: Every gaze sample, batched: sensor_msgs/PointCloud2, one message per LSL chunk
#: (see :mod:`eye_bci_ros2.ros.conversions`, "Gaze batches").
GAZE_SAMPLES_TOPIC = 'gaze/samples'
#: A per-sample view for people and simple tools (``ros2 topic echo``, a gaze cursor):
#: geometry_msgs/PointStamped, the newest sample, at most ``point_rate_hz``.
GAZE_POINT_TOPIC = 'gaze/point'

#: The options to choose among (visualization_msgs/MarkerArray, RViz semantics; task or menu ->
#: projector, RViz; CHOICES_QOS) and their regions on the screen (the projector's
#: MarkerArray of closed LINE_STRIPs, screen px; LATCHED_QOS).
CHOICES_TOPIC = 'choices'
REGIONS_TOPIC = 'choices/regions'

#: The RViz camera: the pose an RViz view controller publishes (geometry_msgs/Pose, Ogre
#: convention; camera_tracker's default ``pose_topic``; RVIZ_POSE_QOS), the tracked camera
#: (geometry_msgs/PoseStamped, optical convention, LATCHED_QOS) and the view a task wants
#: (geometry_msgs/PoseStamped, LATCHED_QOS).
RVIZ_CAMERA_POSE_TOPIC = 'rviz/current_camera_pose'
CAMERA_POSE_TOPIC = 'camera/pose'
CAMERA_GOAL_TOPIC = 'camera/goal'

#: The original experiment's menu (std_msgs/String): outcomes (EVENT_QOS), what it waits
#: for (LATCHED_QOS), every choice it acted on (EVENT_QOS) and what the robot it sent is
#: doing (distance left, arrived, stopped; LATCHED_QOS).
MENU_RESULT_TOPIC = 'choice_menu/result'
MENU_STATE_TOPIC = 'choice_menu/state'
MENU_ANSWER_TOPIC = 'choice_menu/answer'
MENU_PROGRESS_TOPIC = 'choice_menu/progress'
#: Each robot goal the menu sent as a NavigateToPose goal (geometry_msgs/PoseStamped, map
#: frame, EVENT_QOS): a record for recorders and people (an action goal is on no topic);
#: nothing moves on it.
MENU_GOAL_TOPIC = 'choice_menu/goal'

#: The arbiter's choice (std_msgs/String, the label) and a round that ended without one
#: (std_msgs/String, the reason; input mode gaze), both EVENT_QOS; ``choice/request``
#: (std_msgs/Empty) asks for a round.
CHOICE_TOPIC = 'choice'
NO_CHOICE_TOPIC = 'choice/none'
REQUEST_TOPIC = 'choice/request'
#: What the participant was asked to choose (std_msgs/String, the option's label; LATCHED_QOS):
#: published by a cued experiment (the demo's script) when it cues; '' = no cue.  Recorded
#: so that a session's report knows each answer's intended option (accuracy, ITR).
CUE_TOPIC = 'experiment/cue'
#: Each ``choice`` and ``choice/none`` told in full (std_msgs/String, one JSON object:
#: label or reason, rule, evidence and the ROS stamp of the last gaze sample used,
#: eye_bci_ros2.recordings.session_markers.decision_fields; EVENT_QOS), published just
#: before it: what the session's marker stream records.
CHOICE_DETAIL_TOPIC = 'choice/detail'
#: When the open round's decision can next come (builtin_interfaces/Time, a sample stamp on
#: the ROS clock, LATCHED_QOS; choice_arbiter -> lsl_gaze_bridge): the earliest early
#: decision, then the window end.  The gaze stamped up to it is wanted promptly then, so
#: the bridge pulls at its short period around it and in bigger batches otherwise.
DECISION_DUE_TOPIC = 'choice/due'

#: What the person is shown of the selection while it happens (choice_arbiter ->
#: RViz): visualization_msgs/MarkerArray in the options' frame, one halo per option
#: with the option's ns and id (eye_bci_ros2.ros.feedback_markers), at most
#: ``feedback_rate_hz``; FEEDBACK_QOS.
FEEDBACK_TOPIC = 'choices/feedback'

#: Whether the newest gaze is on the screen (std_msgs/Bool, LATCHED_QOS): published by the
#: bridge when it changes (and once per stream); false while the stream is stale or lost.
GAZE_ON_SCREEN_TOPIC = 'gaze/on_screen'

#: Validation (eye_bci_ros2.nodes.gaze_validation): the target shown now (screen px,
#: geometry_msgs/PointStamped, frame ``screen``, NaN = none; LATCHED_QOS: the simulated
#: person follows it), its RViz markers (visualization_msgs/MarkerArray, world frame,
#: LATCHED_QOS), a request to run (std_msgs/Empty, EVENT_QOS) and the outcome (std_msgs/String,
#: one JSON line of eye_bci_ros2.gaze.validation.ValidationOutcome, EVENT_QOS).
VALIDATION_TARGET_TOPIC = 'validation/target'
VALIDATION_TARGETS_TOPIC = 'validation/targets'
VALIDATION_START_TOPIC = 'validation/start'
VALIDATION_RESULT_TOPIC = 'validation/result'

#: SSVEP (eye_bci_ros2.ros.ssvep_messages): each option's stimulus (latched,
#: sensor_msgs/JointState), the decoder's per-option posterior and score per step
#: (JointState, SCORES_QOS) and its choice (std_msgs/String, EVENT_QOS).
SSVEP_STIMULI_TOPIC = 'ssvep/stimuli'
SSVEP_SCORES_TOPIC = 'ssvep/scores'
SSVEP_CHOICE_TOPIC = 'ssvep/choice'

#: The robot (eye_bci_ros2.navigation, sim_robot; nav2's names): the goal
#: (geometry_msgs/PoseStamped in the map frame, what nav2's bt_navigator and RViz's
#: "2D Goal Pose" use: each one becomes a NavigateToPose goal; GOAL_QOS), the robot's
#: odometry (nav_msgs/Odometry in frame ``odom``, child ``base_link``, REP-105; ODOM_QOS),
#: the map (nav_msgs/OccupancyGrid; MAP_QOS, as map_server), the planned path (nav_msgs/Path,
#: a heading on every pose; PLAN_QOS) and the robot drawn for RViz
#: (visualization_msgs/MarkerArray in ``base_link``: its body and heading, and its footprint;
#: ROBOT_MARKER_QOS).
GOAL_POSE_TOPIC = 'goal_pose'
#: nav2's NavigateToPose action (nav2_msgs/action/NavigateToPose, as bt_navigator serves it;
#: rclpy's default action QoS): the menu is its client, sim_robot its server.  Its goal
#: status is on ``navigate_to_pose/_action/status``.
NAVIGATE_TO_POSE_ACTION = 'navigate_to_pose'
#: Its hidden parts any node may use: the goals' status (action_msgs/GoalStatusArray,
#: ACTION_STATUS_QOS; the menu sees a goal it did not send), the feedback
#: (NavigateToPose.Impl.FeedbackMessage; the demo records the drive) and the cancel
#: service (action_msgs/srv/CancelGoal; a zero goal id cancels every goal).
NAVIGATE_TO_POSE_STATUS_TOPIC = NAVIGATE_TO_POSE_ACTION + '/_action/status'
NAVIGATE_TO_POSE_FEEDBACK_TOPIC = NAVIGATE_TO_POSE_ACTION + '/_action/feedback'
NAVIGATE_TO_POSE_CANCEL_SERVICE = NAVIGATE_TO_POSE_ACTION + '/_action/cancel_goal'
#: TF (tf2_msgs/TFMessage; REP-105 frames map -> odom -> base_link): ``tf`` volatile,
#: ``tf_static`` latched as tf2_ros's static broadcaster.
TF_TOPIC = '/tf'
TF_STATIC_TOPIC = '/tf_static'
#: ``/tf``: as tf2_ros's TransformBroadcaster publishes (reliable, volatile, depth 100).
TF_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=100,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
ODOM_TOPIC = 'odom'
MAP_TOPIC = 'map'
PLAN_TOPIC = 'plan'
ROBOT_MARKER_TOPIC = 'robot/marker'

#: Gaze batches: reliable and deep; a message holds a whole chunk (up to max_chunk
#: samples), so 1000 messages are seconds of gaze even at 2000 Hz.
GAZE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=1000,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: SSVEP scores: one message per decoding step (10 Hz); reliable, a few seconds deep.
SCORES_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=50,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: The per-sample view: only the newest matters, so best effort and shallow.
VIEW_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=5,
    reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)

#: Tools that watch a topic (the monitor): best effort, so it matches reliable and
#: best-effort publishers alike, as deep as the gaze queue.
LISTENER_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=GAZE_QOS.depth,
    reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)

#: State that a late joiner needs at once (camera pose, regions, menu): latched.
LATCHED_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=1,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)

#: Events (choices, requests): reliable, never dropped in a burst.
EVENT_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=10,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: ``choices``: latched like LATCHED_QOS, but deep, because MarkerArrays are
#: incremental (RViz semantics): with depth 1, an array that arrives before the
#: previous one is taken replaces it, and a lost DELETE leaves a withdrawn
#: choice selectable.
CHOICES_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=100,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)

#: What RViz view-controller ports publish with: reliable, volatile, depth 10.
RVIZ_POSE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=10,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: ``choices/feedback``: reliable and volatile (what RViz's MarkerArray display asks for,
#: config/eye_bci.rviz), a few messages deep: every message is complete (each offered
#: option's halo, and a DELETE for each halo withdrawn since the previous one).
FEEDBACK_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=10,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: ``odom``: a stream at >= 20 Hz, reliable (a menu that waits for arrival must not miss
#: the last message) and a second deep; as a robot driver's odometry, volatile.
ODOM_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=20,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: ``goal_pose``: what RViz's "2D Goal Pose" tool publishes with (as its view controllers) and
#: nav2's bt_navigator takes.
GOAL_QOS = RVIZ_POSE_QOS

#: ``map``: as nav2's map_server publishes it: reliable, transient local, depth 1 (a
#: subscriber must ask for transient local, as RViz's Map display does when told to).
MAP_QOS = LATCHED_QOS

#: ``plan``: one message per new goal; latched, so RViz started later shows the path.
PLAN_QOS = LATCHED_QOS

#: ``robot/marker``: reliable and volatile, like the feedback halos (what RViz's
#: MarkerArray display asks for), a few messages deep.
ROBOT_MARKER_QOS = FEEDBACK_QOS

#: An action's status topic, as rclpy's and rclcpp's action servers publish it (reliable,
#: transient local, depth 1: a client that starts later sees the goals at once).
ACTION_STATUS_QOS = qos_profile_action_status_default
#: An action's feedback topic, as rclpy's action servers publish it.
ACTION_FEEDBACK_QOS = EVENT_QOS
