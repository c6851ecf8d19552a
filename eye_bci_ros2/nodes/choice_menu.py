"""
The hierarchical room -> table menu of the original experiment, with a protocol a person can trust.

Offers the rooms of a scene (``scene_file``, see :mod:`eye_bci_ros2.task.scene`)
as cube markers with the overview camera view; when a room is chosen, moves
the camera to that room's view and offers its tables and a ``back`` option
(``back_option``); when a table is chosen, reports the outcome
('kitchen/table_2') and starts over at the rooms (``repeat``) or finishes
(offers nothing).  With a robot (``robot_goals``, the default) a chosen
table is confirmed first: the menu offers ``go`` and ``back`` (in the
same view; 'go' away from where the person was looking), then, after
``go``, ``send`` and ``back`` (``send_rounds``: a second look, elsewhere;
'back' where 'go' was); only 'send' sends the table's approach pose as a
goal of nav2's NavigateToPose action and reports the outcome; while the
robot drives it offers ``stop`` (a cancel of the goal) and says the distance
left, from the action's feedback, on ``choice_menu/progress``; when the
action reports the goal succeeded it offers the rooms again.
When to ask and which choices count is the pure
:class:`eye_bci_ros2.task.menu.MenuProtocol` (its module doc has the rules): the
question (``choice/request``) is asked once the camera has arrived at the
step's goal (or settled), the gaze has left the option just chosen (or
without gaze to judge, ``look_away_s`` passed; a still gaze has not left)
and the gaze is not off screen for ``pause_after_s``
(a pause); only a choice that answers the question counts.

Topics:

* publishes ``choices`` visualization_msgs/MarkerArray (latched): a
  DELETEALL, then one CUBE per option, ``text`` = its label, frame
  ``world_frame``; finishing publishes only the DELETEALL;
* publishes ``camera/goal`` geometry_msgs/PoseStamped (latched): optical
  camera pose (z forward, x right, y down) of the view to show;
* publishes ``choice_menu/result`` std_msgs/String: each outcome;
* publishes ``choice_menu/answer`` std_msgs/String: each choice the menu acted
  on (a room, a table or ``back``; the arbiter's other choices are ignored);
* publishes ``choice/request`` std_msgs/Empty: the question, once per step
  when the protocol's conditions hold (and again after an unusable choice,
  or after a pause);
* publishes ``choice_menu/state`` std_msgs/String (latched): what the menu
  waits for: ``waiting_for_camera``, ``waiting_for_look_away``, ``paused``,
  ``asking``, ``driving`` (the robot is on its way; ``stop`` offered), ``finished``;
* is a client of the action ``navigate_to_pose``
  (nav2_msgs/action/NavigateToPose, as nav2's bt_navigator and sim_robot
  serve it): 'go' sends a confirmed table's approach pose
  (:func:`eye_bci_ros2.navigation.approach.scene_goals` for a robot of
  ``robot_radius_m``; frame ``world_frame``, the scene's map frame); no
  server, or a rejected goal, is said at once; the feedback's
  ``distance_remaining`` is the distance left; the result ends the drive
  (aborted: nav2's error code in words, :mod:`eye_bci_ros2.navigation.nav2_codes`).
  'stop' cancels the goal, and nothing else: no stop is ever a goal.  The menu
  cancels its goal when it ends (Ctrl-C, SIGTERM, ``destroy_node``) and waits up
  to :data:`CANCEL_WAIT_S` for the server to take the cancel;
* subscribes ``navigate_to_pose/_action/status`` action_msgs/GoalStatusArray:
  a goal this menu did not send (a menu restarted while its robot drives) is
  met with 'stop' (a cancel of every goal) before anything else;
* publishes ``choice_menu/goal`` geometry_msgs/PoseStamped: each goal sent, a
  record for recorders (an action goal is on no topic; nothing moves on it);
* publishes ``choice_menu/progress`` std_msgs/String (latched): what the
  robot is doing ("driving to 'kitchen/table_2': 3.1 m left", "arrived at
  ...", "stopped ...", "the robot did not reach ...: there is no path to
  the goal", "no feedback from the robot for 3 s ...");
* subscribes ``choice`` std_msgs/String: the label chosen; a choice that is
  not an answer (not asked, paused, made before the question) or not one of
  the current options is logged and ignored;
* subscribes ``choice/none`` std_msgs/String: the arbiter's round ended
  without a choice; an open question is asked again;
* subscribes ``camera/pose`` geometry_msgs/PoseStamped (optical, the
  camera_tracker's): whether the camera has arrived;
* subscribes ``choices/regions`` visualization_msgs/MarkerArray: the screen
  region of the option chosen, for the look-away rule;
* subscribes ``gaze/point`` geometry_msgs/PointStamped (screen px, the
  bridge's rate-limited view; best effort): whether the gaze left it;
* subscribes ``gaze/on_screen`` std_msgs/Bool (latched): whether the gaze is
  on the screen (the bridge publishes it; without it the menu never pauses);
* with ``validate_first``: publishes ``validation/start`` std_msgs/Empty once
  ``gaze_validation`` (``on_request:=true``) listens, subscribes
  ``validation/result`` std_msgs/String (its JSON line) and offers the rooms
  only after the validation (a refused one is run again up to
  ``validation_retries`` times, then the menu goes on; see
  :mod:`eye_bci_ros2.task.menu`).

``ask_on_arrival`` false restores the previous menu: every valid choice
counts at once and it asks only after an unusable choice or an unchanged offer.

No feedback for ``feedback_timeout_s`` is said in one line and 'stop' stays
offered: silence never ends a drive (a goal never answered is given up then,
and cancelled if accepted later).  The menu reads no odometry: where the
robot is and whether it has arrived is the navigation server's word (nav2
checks arrival with its own goal checker, in its own frames).  It never
publishes ``goal_pose``: a goal on a topic cannot be cancelled, so a stop
would have to be another goal (docs/DESIGN.md, "The protocol in the shipped nodes").
``robot_goals`` false: a chosen table is the outcome at once and nothing is sent.

Setting ``scene_file`` (even to its current value) reloads the scene and
starts over at the rooms; a bad file is rejected with the reason and the
current scene kept.
"""

from collections import deque
from dataclasses import fields, replace
import math
from typing import Any, Dict, List, Optional, Sequence
import uuid

from action_msgs.msg import GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal as CancelGoalService
from geometry_msgs.msg import PointStamped, PoseStamped
from nav2_msgs.action import NavigateToPose
import numpy as np
from rclpy.action import ActionClient
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Bool, Empty, String
from unique_identifier_msgs.msg import UUID
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.gaze.validation import ValidationOutcome
from eye_bci_ros2.navigation import nav2_codes
from eye_bci_ros2.navigation.approach import scene_goals
from eye_bci_ros2.navigation.robot_settings import RobotSettings
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.projection.geometry import WORLD_FRAME
from eye_bci_ros2.ros.conversions import (arrays_to_pose, cube_marker, marker_array_to_regions,
                                          pose_to_arrays)
from eye_bci_ros2.ros.log_throttle import QuietRepeats, WARN_PERIOD_S
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.ros.parameters import check_frame_id, declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.topics import (ACTION_STATUS_QOS, CAMERA_GOAL_TOPIC, CAMERA_POSE_TOPIC,
                                     CHOICE_TOPIC, CHOICES_TOPIC, EVENT_QOS,
                                     GAZE_ON_SCREEN_TOPIC, GAZE_POINT_TOPIC, LATCHED_QOS,
                                     MENU_ANSWER_TOPIC, MENU_GOAL_TOPIC, MENU_PROGRESS_TOPIC,
                                     MENU_RESULT_TOPIC,
                                     MENU_STATE_TOPIC, NAVIGATE_TO_POSE_ACTION,
                                     NAVIGATE_TO_POSE_CANCEL_SERVICE,
                                     NAVIGATE_TO_POSE_STATUS_TOPIC, NO_CHOICE_TOPIC,
                                     REGIONS_TOPIC, REQUEST_TOPIC, VALIDATION_RESULT_TOPIC,
                                     VALIDATION_START_TOPIC, VIEW_QOS)
from eye_bci_ros2.task.menu import (ABORTED, Action, Answer, CANCELED, CancelGoal, Log,
                                    MenuProtocol, Offer, Progress, ProtocolSettings, Request,
                                    Result, ROOMS_NS, SendGoal, SUCCEEDED, TABLES_NS, Validate)
from eye_bci_ros2.task.scene import CubeMarker, load_scene, Scene, View

__all__ = ['ChoiceMenu', 'main', 'resolve_scene_path', 'ROOMS_NS', 'TABLES_NS']

#: How often the timed rules (settle, look-away time, pause) are applied, s.
TICK_S = 0.05
#: The longest the menu, when it ends, waits for the server to take its cancel, s (well
#: inside the runner's clean-up limit).
CANCEL_WAIT_S = 2.0
#: How a goal ended, by its GoalStatus (anything else is an abort).
_OUTCOMES = {GoalStatus.STATUS_SUCCEEDED: SUCCEEDED, GoalStatus.STATUS_CANCELED: CANCELED,
             GoalStatus.STATUS_ABORTED: ABORTED}
#: The goals whose status the menu keeps (the finished ones are forgotten beyond this).
MAX_GOALS_KEPT = 200
#: A goal whose status is one of these may move the robot.
_ACTIVE = (GoalStatus.STATUS_ACCEPTED, GoalStatus.STATUS_EXECUTING,
           GoalStatus.STATUS_CANCELING)
#: A cancel's return codes in words (action_msgs/srv/CancelGoal).
_CANCEL_WORDS = {
    CancelGoalService.Response.ERROR_REJECTED: 'the server rejected it',
    CancelGoalService.Response.ERROR_UNKNOWN_GOAL_ID: 'the server does not know the goal',
    CancelGoalService.Response.ERROR_GOAL_TERMINATED: 'the goal had already ended'}

#: Protocol parameters: name -> (description, range); defaults from ProtocolSettings.
_PROTOCOL_PARAMETERS = {
    'ask_on_arrival': ('Ask (choice/request) only when the camera has arrived, the gaze has '
                       'left the last choice and is on screen; only answers count (false: '
                       'every valid choice counts at once, the previous menu)', None),
    'back_option': ("Offer a 'back' option with the tables (returns to the rooms)", None),
    'repeat': ('After a table is chosen, start over at the rooms (true) or finish (false: '
               'offer nothing more)', None),
    'arrive_tolerance_m': ('camera/pose within this distance of camera/goal has arrived, m',
                           (0.0, 100.0)),
    'arrive_tolerance_deg': ('camera/pose within this rotation of camera/goal has arrived, '
                             'degrees', (0.0, 180.0)),
    'settle_s': ('A camera that has not moved for this long has arrived (settled), s',
                 (0.0, 60.0)),
    'look_away_s': ('After a choice, ask again after this when the gaze cannot be judged (no '
                    'region of the chosen option or no gaze/point since); a gaze seen staying '
                    'on it is never taken as gone, s', (0.0, 60.0)),
    'look_away_margin_px': ('The gaze must be this far outside the chosen option to have '
                            'left it, px', (0.0, 1000.0)),
    'pause_after_s': ('Gaze off screen (gaze/on_screen false) this long pauses the menu, s',
                      (0.0, 3600.0)),
    'min_answer_s': ('A choice sooner than this after the request is not its answer, s',
                     (0.0, 10.0)),
    'validate_first': ('Start with a gaze validation (validation/start, answered by '
                       'gaze_validation on_request:=true) and offer the rooms only after it',
                       None),
    'validation_retries': ('A refused validation is run again this many times, then the menu '
                           'goes on with the correction as it was', None),
    'robot_goals': ("A chosen table is confirmed ('go' / 'back') and its approach pose sent as "
                    "a NavigateToPose goal; 'stop' (a cancel) while the robot drives (false: "
                    'the table is the outcome at once, nothing moves)', None),
    'feedback_timeout_s': ('No feedback from the navigation (or no answer to a goal) for this '
                           "long is said; 'stop' stays offered and the drive goes on, s",
                           (0.5, 600.0)),
    'confirm_rounds': ("A confirmation ('go' / 'back') asked this many times without an "
                       'answer (choice/none) returns to the tables, no goal (a stray look '
                       'answers it late)', None),
    'send_rounds': ("After 'go', 'send' appears where the gaze was not, 'back' where 'go' "
                    'was; a fresh look at send within this many rounds sends the robot, else '
                    "back to the tables (0: 'go' sends at once)", None),
}

#: The robot's radius the approach poses are made for: sim_robot's default.
_ROBOT = RobotSettings()


def resolve_scene_path(value: str) -> str:
    """Return the scene file path a ``scene_file`` value names ('' = the default)."""
    return value if value.strip() else default_scene_path()


class ChoiceMenu(Node):
    """Room -> table menu driven by ``choice``; publishes options, camera goals, questions."""

    def __init__(self, **kwargs):
        """Create the node; ``kwargs`` go to :class:`rclpy.node.Node`."""
        super().__init__('choice_menu', **kwargs)
        # "no choice: asking again" while the person does not choose: not a line each time.
        self._quiet = QuietRepeats(self.get_logger())
        # A scene_file is loaded once while it is validated and used on apply.
        self._candidate: Optional[tuple] = None
        self._goals_candidate: Optional[Dict[str, np.ndarray]] = None
        # The approach poses of the last (scene, radius): made once, not on every parameter.
        self._goals_made: tuple = (None, None, {})
        defaults = ProtocolSettings()
        parameters = [
            ParamSpec('scene_file', '',
                      'Scene YAML with rooms, tables and views (empty = the installed '
                      'config/scene.yaml); setting it reloads and starts over',
                      check=self._check_scene_file),
            ParamSpec('repeat', defaults.repeat, _PROTOCOL_PARAMETERS['repeat'][0]),
            ParamSpec('world_frame', WORLD_FRAME,
                      'Frame of the markers, camera goals and robot goals; must match the '
                      "scene's frame_id", check=check_frame_id),
            ParamSpec('robot_radius_m', _ROBOT.radius_m,
                      "Radius of the robot's footprint, m: each table's goal is where a robot "
                      'this large stands in front of it (as sim_robot radius_m)',
                      value_range=(0.05, 2.0)),
        ]
        for name, (description, value_range) in _PROTOCOL_PARAMETERS.items():
            if name == 'repeat':
                continue
            default = getattr(defaults, name)
            parameters.append(ParamSpec(name, float(default) if value_range else default,
                                        description, value_range=value_range))
        try:
            values = declare_parameters(self, parameters, self._on_parameters,
                                        check_all=self._check_all)
        except ValueError:
            self.destroy_node()     # the runner says why, in one line
            raise
        scene, goals = self._candidate[1], self._goals_candidate
        self._candidate = self._goals_candidate = None
        self._world_frame = values['world_frame']
        self._protocol = MenuProtocol(scene, self._settings(values), goals or {})
        self._state = ''

        self._choices_pub = self.create_publisher(MarkerArray, CHOICES_TOPIC, LATCHED_QOS)
        self._goal_pub = self.create_publisher(PoseStamped, CAMERA_GOAL_TOPIC, LATCHED_QOS)
        self._result_pub = self.create_publisher(String, MENU_RESULT_TOPIC, EVENT_QOS)
        self._answer_pub = self.create_publisher(String, MENU_ANSWER_TOPIC, EVENT_QOS)
        self._request_pub = self.create_publisher(Empty, REQUEST_TOPIC, EVENT_QOS)
        self._state_pub = self.create_publisher(String, MENU_STATE_TOPIC, LATCHED_QOS)
        self._progress_pub = self.create_publisher(String, MENU_PROGRESS_TOPIC, LATCHED_QOS)
        self._sent_goal_pub = self.create_publisher(PoseStamped, MENU_GOAL_TOPIC, EVENT_QOS)
        # The robot: nav2's NavigateToPose.  The goal the protocol follows (its id and, once
        # accepted, its handle); every goal id this node sent (the status topic's other
        # goals are not the menu's); a cancel-all client for those.
        self._navigator = ActionClient(self, NavigateToPose, NAVIGATE_TO_POSE_ACTION)
        self._cancel_all = self.create_client(CancelGoalService,
                                              NAVIGATE_TO_POSE_CANCEL_SERVICE)
        self._goal_id: Optional[bytes] = None
        self._goal_handle = None
        self._sent_ids = deque(maxlen=100)
        self._others_active = False
        self._goal_states: Dict[bytes, int] = {}    # goal id -> its last status
        self._cancelling = None             # the last cancel's future
        self.create_subscription(GoalStatusArray, NAVIGATE_TO_POSE_STATUS_TOPIC,
                                 self._on_goal_status, ACTION_STATUS_QOS)
        self.create_subscription(String, CHOICE_TOPIC, self._on_choice, EVENT_QOS)
        self.create_subscription(String, NO_CHOICE_TOPIC, self._on_no_choice, EVENT_QOS)
        self.create_subscription(PoseStamped, CAMERA_POSE_TOPIC, self._on_pose, LATCHED_QOS)
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)
        self.create_subscription(PointStamped, GAZE_POINT_TOPIC, self._on_gaze_point,
                                 VIEW_QOS)
        self.create_subscription(Bool, GAZE_ON_SCREEN_TOPIC, self._on_screen, LATCHED_QOS)
        self._validation_pub = self.create_publisher(Empty, VALIDATION_START_TOPIC, EVENT_QOS)
        self.create_subscription(String, VALIDATION_RESULT_TOPIC, self._on_validation,
                                 EVENT_QOS)
        self._validation_due = False     # a Validate waiting for gaze_validation to listen
        self.create_timer(TICK_S, self._on_tick)
        self.get_logger().info(
            f'scene {scene.source}: rooms {", ".join(scene.room_labels)}')
        self._perform(self._protocol.start(self._now()))

    @property
    def scene(self) -> Scene:
        """Return the scene in use."""
        return self._protocol.scene

    @property
    def options(self) -> Sequence[str]:
        """Return the labels offered now (empty once finished)."""
        return self._protocol.options

    @property
    def driving(self) -> bool:
        """Tell whether the menu follows a drive (from 'go' until the goal has ended)."""
        return self._protocol.drive is not None

    @property
    def robot_goals(self) -> Dict[str, np.ndarray]:
        """Return each table's robot goal: label -> x, y (m), yaw (rad) in the map frame."""
        return dict(self._protocol.goals)

    @property
    def state(self) -> str:
        """Return what the menu waits for (:attr:`eye_bci_ros2.task.menu.MenuProtocol.state`)."""
        return self._protocol.state

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    @staticmethod
    def _settings(values: Dict[str, Any]) -> ProtocolSettings:
        names = {f.name for f in fields(ProtocolSettings)}
        return ProtocolSettings(**{k: v for k, v in values.items() if k in names})

    # -- inputs -----------------------------------------------------------------------------

    def _guard(self, what: str, handler) -> None:
        try:
            self._perform(handler())
        except Exception as error:  # a message must never kill the node
            self.get_logger().error(f'failed to handle {what}: {error}',
                                    throttle_duration_sec=WARN_PERIOD_S)

    def _on_choice(self, message: String) -> None:
        self._guard(f"choice '{message.data}'",
                    lambda: self._protocol.on_choice(message.data, self._now()))

    def _on_no_choice(self, message: String) -> None:
        self._guard('choice/none',
                    lambda: self._protocol.on_no_choice(message.data, self._now()))

    def _on_pose(self, message: PoseStamped) -> None:
        if message.header.frame_id and message.header.frame_id != self._world_frame:
            self.get_logger().warning(
                f"camera/pose in frame '{message.header.frame_id}', not '{self._world_frame}'"
                ': ignored', throttle_duration_sec=WARN_PERIOD_S)
            return
        self._guard('camera/pose', lambda: self._protocol.on_camera_pose(
            *pose_to_arrays(message.pose), self._now()))

    def _on_regions(self, message: MarkerArray) -> None:
        def take():
            self._protocol.on_regions(*marker_array_to_regions(message))
            return []
        self._guard('choices/regions', take)

    def _on_gaze_point(self, message: PointStamped) -> None:
        self._guard('gaze/point', lambda: self._protocol.on_gaze_point(
            message.point.x, message.point.y, self._now()))

    def _on_screen(self, message: Bool) -> None:
        self._guard('gaze/on_screen',
                    lambda: self._protocol.on_screen(bool(message.data), self._now()))

    def _on_validation(self, message: String) -> None:
        try:
            outcome = ValidationOutcome.from_json(message.data)
        except ValueError as error:
            self.get_logger().warning(f'{VALIDATION_RESULT_TOPIC}: {error}',
                                      throttle_duration_sec=WARN_PERIOD_S)
            return
        self._guard(VALIDATION_RESULT_TOPIC, lambda: self._protocol.on_validation(
            outcome.accepted, outcome.summary(), self._now()))

    def _on_tick(self) -> None:
        if self._others_active and not self._navigator.server_is_ready():
            # The server is gone (and every goal with it): no goal of its drives any more.
            self._goal_states = {}
            self._update_other_goals()
        if self._validation_due:
            if self._validation_pub.get_subscription_count() > 0:
                self._validation_due = False
                self._validation_pub.publish(Empty())
            else:
                self.get_logger().warning(
                    f'waiting for gaze_validation (on_request:=true) on {VALIDATION_START_TOPIC}',
                    throttle_duration_sec=WARN_PERIOD_S)
        self._guard('the menu timer', lambda: self._protocol.tick(self._now()))

    # -- outputs ----------------------------------------------------------------------------

    def _perform(self, actions: List[Action]) -> None:
        # The protocol's answers to what an action started (a goal refused at once) come
        # after the rest of the actions that started it.
        queue = deque(actions)
        while queue:
            action = queue.popleft()
            if isinstance(action, Offer):
                if action.view is not None:
                    self._publish_goal(action.view)
                self._publish_choices(action.markers, action.ns)
            elif isinstance(action, Request):
                self._request_pub.publish(Empty())
            elif isinstance(action, Validate):
                self._validation_due = True
            elif isinstance(action, Result):
                self._result_pub.publish(String(data=action.label))
            elif isinstance(action, SendGoal):
                queue.extend(self._send_goal(action.pose))
            elif isinstance(action, CancelGoal):
                self._cancel_goal(action.every)
            elif isinstance(action, Progress):
                self._progress_pub.publish(String(data=action.text))
            elif isinstance(action, Answer):
                self._quiet.reset()     # a choice: what follows is news again
                self._answer_pub.publish(String(data=action.label))
            elif isinstance(action, Log):
                if action.level == 'warning':
                    self.get_logger().warning(action.text, throttle_duration_sec=1.0)
                else:
                    self._quiet.info(action.text)
        state = self._protocol.state
        if state != self._state:
            self._state = state
            self._state_pub.publish(String(data=state))

    def _publish_goal(self, view: View) -> None:
        goal = PoseStamped()
        goal.header.frame_id = self._world_frame
        goal.header.stamp = self.get_clock().now().to_msg()
        goal.pose = arrays_to_pose(*look_at_pose(*view.as_tuple()))
        self._goal_pub.publish(goal)

    # -- the robot: NavigateToPose ----------------------------------------------------------

    def _send_goal(self, pose: np.ndarray) -> List[Action]:
        """Send a NavigateToPose goal: x, y (m), yaw (rad) in the map frame, on the floor."""
        now = self._now()
        if not self._navigator.server_is_ready():
            self._goal_id = None
            return self._protocol.on_goal_response(
                False, f'no navigation server on {self._navigator_name()}', now)
        goal = NavigateToPose.Goal()
        goal.pose.header.frame_id = self._world_frame
        goal.pose.header.stamp = self.get_clock().now().to_msg()
        half = float(pose[2]) / 2.0
        goal.pose.pose = arrays_to_pose([pose[0], pose[1], 0.0],
                                        [0.0, 0.0, math.sin(half), math.cos(half)])
        # The id is made here, before the goal leaves: the status topic may name it first.
        goal_id = uuid.uuid4().bytes
        self._goal_id, self._goal_handle = goal_id, None
        self._sent_ids.append(goal_id)
        future = self._navigator.send_goal_async(
            goal, feedback_callback=self._on_feedback, goal_uuid=UUID(uuid=list(goal_id)))
        self._sent_goal_pub.publish(goal.pose)      # the record; nothing moves on it
        future.add_done_callback(lambda done: self._on_goal_response(goal_id, done))
        return []

    def _navigator_name(self) -> str:
        return self.resolve_topic_name(NAVIGATE_TO_POSE_ACTION)

    def _on_goal_response(self, goal_id: bytes, future) -> None:
        try:
            handle = future.result()
        except Exception as error:  # noqa: B902 - the server vanished while answering
            handle, reason = None, f'no answer from {self._navigator_name()} ({error})'
        else:
            reason = f'{self._navigator_name()} rejected it'
        if goal_id != self._goal_id:
            # A goal the menu no longer follows (a new scene, a stop before the answer):
            # it must not drive the robot.
            if handle is not None and handle.accepted:
                self.get_logger().warning('a goal accepted after the menu gave it up: '
                                          'cancelling it')
                handle.cancel_goal_async()
            return
        accepted = handle is not None and handle.accepted
        if accepted:
            self._goal_handle = handle
            handle.get_result_async().add_done_callback(
                lambda done: self._on_result(goal_id, done))
        else:
            self._goal_id = None
        self._guard('the goal response', lambda: self._protocol.on_goal_response(
            accepted, reason, self._now()))

    def _on_feedback(self, message) -> None:
        if bytes(message.goal_id.uuid) != self._goal_id:
            return
        self._guard('navigation feedback', lambda: self._protocol.on_feedback(
            float(message.feedback.distance_remaining), self._now()))

    def _on_result(self, goal_id: bytes, future) -> None:
        if goal_id != self._goal_id:
            return
        self._goal_id, self._goal_handle = None, None
        try:
            response = future.result()
        except Exception as error:  # noqa: B902 - the server vanished
            outcome, reason = ABORTED, f'no result from {self._navigator_name()} ({error})'
        else:
            outcome = _OUTCOMES.get(response.status, ABORTED)
            code, message = response.result.error_code, response.result.error_msg
            # nav2 aborts a goal that another goal preempts with an empty result.
            reason = nav2_codes.describe(code, message) if code or message else \
                'it ended without a reason (another goal may have taken its place)'

        self._guard('the navigation result', lambda: self._protocol.on_goal_result(
            outcome, reason, self._now()))
        # Another goal may still drive the robot (it preempted this one).
        self._guard('the goal status', lambda: self._protocol.on_other_goals(
            self._others_active, self._now()))

    def _cancel_goal(self, every: bool) -> None:
        """Cancel the followed goal (or every goal of the server)."""
        if every:
            if not self._cancel_all.service_is_ready():
                self.get_logger().warning(f'cannot stop the robot: no navigation server on '
                                          f'{self._navigator_name()}')
                return
            # A zero goal id and stamp: every goal (action_msgs/srv/CancelGoal).
            future = self._cancel_all.call_async(CancelGoalService.Request())
        elif self._goal_handle is not None:
            future = self._goal_handle.cancel_goal_async()
        else:
            return
        self._cancelling = future
        future.add_done_callback(self._on_cancel_response)

    def _on_cancel_response(self, future) -> None:
        try:
            response = future.result()
        except Exception as error:  # noqa: B902 - the server vanished
            accepted, reason = False, f'no answer ({error})'
        else:
            # rclpy's server answers a cancel its callback refused with no error and no goal.
            accepted = response.return_code == CancelGoalService.Response.ERROR_NONE and \
                len(response.goals_canceling) > 0
            reason = _CANCEL_WORDS.get(response.return_code or
                                       CancelGoalService.Response.ERROR_REJECTED,
                                       f'code {response.return_code}')
        self._guard('the cancel response', lambda: self._protocol.on_cancel_response(
            accepted, reason, self._now()))

    def _on_goal_status(self, message: GoalStatusArray) -> None:
        """
        Take the action's status: whether a goal this menu did not send is active.

        Each goal's last known status is kept: a message of another publisher on the
        topic (a server gone but not yet seen gone) does not end a goal it does not list.
        """
        for status in message.status_list:
            self._goal_states[bytes(status.goal_info.goal_id.uuid)] = status.status
        if len(self._goal_states) > MAX_GOALS_KEPT:
            self._goal_states = {goal: state for goal, state in self._goal_states.items()
                                 if state in _ACTIVE}
        self._update_other_goals()

    def _update_other_goals(self) -> None:
        own = set(self._sent_ids)
        self._others_active = any(state in _ACTIVE and goal not in own
                                  for goal, state in self._goal_states.items())
        self._guard('the goal status', lambda: self._protocol.on_other_goals(
            self._others_active, self._now()))

    def destroy_node(self) -> None:
        """Cancel the menu's goal (the robot stops when the menu ends), then destroy."""
        try:
            self._cancel_on_exit()
        except Exception as error:  # noqa: B902 - the node must still be destroyed
            self.get_logger().error(f'could not cancel the robot goal: {error}')
        if hasattr(self, '_navigator'):
            self._navigator.destroy()   # rclpy's destroy_node leaves an action client
        super().destroy_node()

    def _cancel_on_exit(self) -> None:
        """Cancel the followed goal and wait for the server to take it (CANCEL_WAIT_S)."""
        if not hasattr(self, '_protocol') or not self.context.ok():
            return
        self._cancelling = None
        drive = self._protocol.drive
        # A goal sent but not answered yet has no handle: cancelled by its id.
        in_flight = self._goal_id if self._goal_handle is None else None
        self._perform(self._protocol.cancel_drive('the menu ends', self._now(), own_only=True))
        future, self._goal_id, self._goal_handle = self._cancelling, None, None
        if future is None and in_flight is not None and drive is not None and \
                not drive.other and self._cancel_all.service_is_ready():
            request = CancelGoalService.Request()
            request.goal_info.goal_id.uuid = list(in_flight)
            future = self._cancel_all.call_async(request)
        if future is None:
            return
        # The executor that ran the node has stopped: a private one takes the answer, so
        # the request has left the process when destroy_node returns.
        executor = SingleThreadedExecutor(context=self.context)
        try:
            executor.add_node(self)
            executor.spin_until_future_complete(future, timeout_sec=CANCEL_WAIT_S)
        finally:
            executor.remove_node(self)
            executor.shutdown()
        response = future.result() if future.done() else None
        if response is not None and response.return_code == \
                CancelGoalService.Response.ERROR_NONE and response.goals_canceling:
            self.get_logger().info('the robot goal is cancelled: the menu ends')
        else:
            self.get_logger().warning(f'the navigation server did not confirm the cancel '
                                      f'within {CANCEL_WAIT_S:g} s')

    def _publish_choices(self, markers: Sequence[CubeMarker], ns: str) -> None:
        stamp = self.get_clock().now().to_msg()
        clear = Marker(action=Marker.DELETEALL)
        clear.header.frame_id = self._world_frame
        clear.header.stamp = stamp
        array = MarkerArray(markers=[clear])
        for index, source in enumerate(markers):
            array.markers.append(cube_marker(
                ns, index, source.text, self._world_frame, source.position,
                source.orientation, source.scale, source.color, stamp))
        self._choices_pub.publish(array)

    # -- parameters -------------------------------------------------------------------------

    def _check_scene_file(self, value: str) -> Optional[str]:
        try:
            self._candidate = (value, load_scene(resolve_scene_path(value)))
        except ValueError as error:
            return str(error)
        return None

    def _check_all(self, values: Dict[str, Any]) -> Optional[str]:
        if self._candidate is not None and self._candidate[0] == values['scene_file']:
            scene = self._candidate[1]
        else:
            scene = self._protocol.scene if hasattr(self, '_protocol') else None
        if scene is not None and scene.frame_id != values['world_frame']:
            return (f"scene {scene.source} is in frame '{scene.frame_id}' but world_frame "
                    f"is '{values['world_frame']}': set frame_id in the scene file to match")
        self._goals_candidate = None
        if scene is not None and values['robot_goals']:
            try:
                self._goals_candidate = self._scene_goals(scene, values['robot_radius_m'])
            except ValueError as error:
                return f'{error} (robot_radius_m, or robot_goals false: no robot)'
        try:
            self._settings(values)
        except ValueError as error:
            return str(error)
        return None

    def _scene_goals(self, scene: Scene, radius_m: float) -> Dict[str, np.ndarray]:
        made_scene, made_radius, goals = self._goals_made
        if made_scene is not scene or made_radius != radius_m:
            goals = scene_goals(scene, radius_m)
            self._goals_made = (scene, radius_m, goals)
        return goals

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        protocol = self._protocol
        settings = {k: v for k, v in changed.items()
                    if k in {f.name for f in fields(ProtocolSettings)}}
        if settings:
            protocol.settings = replace(protocol.settings, **settings)
        if 'world_frame' in changed:
            self._world_frame = changed['world_frame']
        now = self._now()
        if self._goals_candidate is not None:
            protocol.goals = self._goals_candidate
            self._goals_candidate = None
        if not protocol.settings.robot_goals:
            self._perform(protocol.cancel_drive('robot_goals set false', now))
        if 'scene_file' in changed and self._candidate is not None:
            protocol.scene = self._candidate[1]
            self.get_logger().info(
                f'loaded scene {protocol.scene.source}: rooms '
                f'{", ".join(protocol.scene.room_labels)}')
            self._perform(protocol.start(now))
        elif 'world_frame' in changed or 'back_option' in changed:
            # Re-offer the same step (stamped in the new frame / with or without 'back').
            self._perform(protocol.reoffer(now))
        else:
            self._perform(protocol.tick(now))
        self._candidate = None


def main(args=None):
    """Run the choice menu."""
    spin_node(ChoiceMenu, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
