"""
The menu's protocol as a pure state machine: when to ask, what a choice does, pause, back.

No rclpy: :class:`MenuProtocol` takes the inputs of the ``choice_menu`` node
(times in s on one clock) and returns the actions the node performs
(:class:`Offer`, :class:`Request`, :class:`Result`, :class:`Log`); its
:attr:`MenuProtocol.state` says what it waits for.

Steps: the rooms of the scene (overview view), then the tables of the chosen
room (the room's view) plus a **back** option (:data:`BACK_LABEL`, a marker
at the lower left of the room's view, :func:`back_marker`) that returns to the
rooms, then the outcome (``room/table``) and the rooms again (``repeat``) or
nothing (finished).

When a question is asked (``choice/request``), all of these at once:

1. **options offered**, not finished;
2. **camera arrived** at the goal of this step: the last ``camera/pose``
   (optical convention) is within ``arrive_tolerance_m`` and
   ``arrive_tolerance_deg`` of the ``camera/goal`` just published, or the
   camera has **settled**: no pose moved by more than those tolerances for
   ``settle_s`` since the goal was published (a view controller that stops
   short of the goal, or no view controller: the static view never moves);
   a camera that starts moving more than ``settle_s`` after the goal is
   taken as settled too early;
3. **looked away** (after a choice), judged from the samples: the gaze
   (``gaze/point``, screen px) has left the chosen option's screen region as
   it was at the choice (from ``choices/regions``) by more than
   ``look_away_margin_px``, and stayed out for :data:`LEFT_S` over
   :data:`LEFT_SAMPLES` samples or more in a row (one sample or a short burst
   out is a tracker's spike, not a look elsewhere); or the gaze went off
   screen.  A gaze that never left has not left, however long it stays: only
   when nothing can be judged (no region of the chosen option, or no gaze
   sample since the choice) does ``look_away_s`` pass the gate by time;
4. **not paused**: the gaze has not been off screen (``gaze/on_screen``
   false) for ``pause_after_s`` or more; it resumes when ``gaze/on_screen``
   is true again, and the question is asked again.

Each question is asked once (one ``Request``), and again when the arbiter
reports that its round ended without a choice (``choice/none``,
:meth:`MenuProtocol.on_no_choice`).  A choice counts only when it
answers the question: it arrives while the menu is asking, at least
``min_answer_s`` after the request (a decision made before the request, in
flight when it went out, is not an answer), and names an offered option.
``min_answer_s`` must stay below the arbiter's fastest answer: its round
starts when the request arrives and a fresh fixation on a second look ('go',
'send') decides ``second_look_dwell_s`` (0.05 s) later.  A choice ignored as
too early asks again: the menu cannot tell it from the answer, whose round
has then closed (without a new question nothing would ever come).  Any other
choice is logged and ignored (an unknown label while asking asks again).  So
the menu never advances on its own, whatever the arbiter decides between
questions.

``ask_on_arrival`` false gives the previous behaviour: every valid choice
counts at once, nothing is asked except after an unusable choice or an
unchanged offer.

**Options appear once the view has settled.**  When a step moves the camera
(a room chosen, back to the rooms), the old options are withdrawn at once
(an empty :class:`Offer` with the camera goal) and the new ones are shown
(a second :class:`Offer`, no goal) only when the camera has arrived or
settled (rule 2): while the camera moves, some options are outside the render
panel, and options shown then were offered in part (3 of the 4 rooms), the
SSVEP stimulus map reassigned twice.  With no camera pose yet, or when the
camera is already there, they are shown at once.

**The robot** (``robot_goals``, :data:`GO_LABEL`, :data:`STOP_LABEL`): a chosen
table is a destination; it is *not* acted on yet: the menu offers a
confirmation step, ``go`` and ``back`` (:func:`confirm_markers`, in the same
view).  Only ``go`` sends the table's approach pose as a navigation goal
(:class:`SendGoal`, ``goals``: label -> x, y, yaw in the scene's frame; the
node sends it as nav2's NavigateToPose action) and is the outcome
(:class:`Result`); ``back`` offers the tables again.  Rooms and ``back`` are
not destinations: no goal.  A confirmation asked ``confirm_rounds`` times
without an answer (rounds reported on ``choice/none``; the same chances in
every input mode) goes back to the tables, no goal: a person who only looks
around answers it by chance too, but late (``python -m bench.confirmation
--midas``: a 'go' by the Midas touch comes a median 18 s after the table,
every intended 'go' measured in the first two 1 s rounds), so asking for
ever only lets a stray 'go' come.  **A second look** (``send_rounds``, 1):
'go' chosen does not send yet; 'send' (:data:`SEND_LABEL`,
:func:`send_marker`) appears where the gaze was not and is asked at once;
'back' takes the place of 'go' (:func:`send_markers`: where the gaze that
chose 'go' rests, it can only undo; two options, so SSVEP and the hybrid can
answer too); only a fresh fixation on 'send' within ``send_rounds`` rounds
sends the goal; 'back' or no answer: back to the tables.  A person who means
'go' looks at 'send' next (one short saccade and fixation); a wandering
gaze that chose 'go' by chance seldom lands on a target that just appeared
elsewhere within a second (docs/selection.md, "Looking around without
intent": each step's share on real gaze).

**The drive** follows the navigation action, never a guess from odometry.  From
the goal sent until it ends the menu offers ``stop`` (:func:`stop_marker`) and
asks at once and again after each round without a choice.  A refused goal
(:meth:`MenuProtocol.on_goal_response`: no action server, or rejected) is said
at once and the tables offered again.  :class:`Progress` says the distance left
from the action's feedback (:meth:`MenuProtocol.on_feedback`); the result
(:meth:`MenuProtocol.on_goal_result`) ends the drive: arrived (the next task:
the rooms, or finish), failed (nav2's reason in words; the tables again) or
cancelled.  ``stop`` is a cancel and nothing else (:class:`CancelGoal`; no
stop, hold or timeout is ever a goal): the stop stays offered until the robot
reports the goal ended, a refused cancel is said and a second ``stop`` cancels
again.  No feedback on an accepted goal for ``feedback_timeout_s`` is said in
one line and 'stop' stays offered: silence never ends a drive, and progress is
never called a failure.  A goal with no answer at all for as long (a server
gone but not yet seen gone) is given up and the tables offered again; should
it be accepted later, it is cancelled.  Looking away
chooses nothing: the robot goes on, and it never starts without ``go``.  A
new scene (``start``) while driving cancels the goal first.  A goal this menu
did not send (:meth:`MenuProtocol.on_other_goals`: a menu restarted while its
robot drives) is met with ``stop`` before anything else; the menu starts over
when that goal has ended.

``validate_first``: the experiment starts with a gaze validation
(:class:`Validate`; the node sends ``validation/start`` to
``gaze_validation``) and offers the rooms only once it has ended
(:meth:`MenuProtocol.on_validation`): at once after an accepted one; a
refused one is logged with its reason and run again up to
``validation_retries`` times, after which the menu goes on with the
bridge's correction as it was (a warning says so).
"""

from dataclasses import dataclass, field, replace
import math
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from eye_bci_ros2.decision.tolerance import polygon_distances
from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.task.scene import CubeMarker, Room, Scene, View

#: Label of the option that goes back from the tables to the rooms (and, in the
#: confirmation step, from the chosen table to the tables).
BACK_LABEL = 'back'
#: Labels of the confirmation (send the robot) and of the stop while it drives.
GO_LABEL = 'go'
STOP_LABEL = 'stop'
#: Label of the second look that confirms 'go' (``send_rounds``): it appears once 'go' is
#: chosen, where the gaze was not (:func:`send_marker`).
SEND_LABEL = 'send'
#: Marker namespaces of the steps of the menu.
ROOMS_NS = 'rooms'
TABLES_NS = 'tables'
CONFIRM_NS = 'confirm'
DRIVE_NS = 'drive'
#: The progress line is renewed when the distance left changes by this much, m.
PROGRESS_STEP_M = 0.1
#: How a navigation goal ended (:meth:`MenuProtocol.on_goal_result`; the node maps the
#: action's GoalStatus to these).
SUCCEEDED = 'succeeded'
ABORTED = 'aborted'
CANCELED = 'canceled'
#: The gaze has left the chosen option when this many gaze points in a row, spanning
#: :data:`LEFT_S` or more, lie beyond the margin: a look elsewhere (a fixation lasts
#: 0.1 s or more), not a spike or a burst of noise (one or two samples).
LEFT_SAMPLES = 2
LEFT_S = 0.1
#: What the protocol waits for (:attr:`MenuProtocol.state`).
WAITING_FOR_CAMERA = 'waiting_for_camera'
LOOK_AWAY = 'waiting_for_look_away'
PAUSED = 'paused'
VALIDATING = 'validating'
READY = 'ready'
ASKING = 'asking'
DRIVING = 'driving'
FINISHED = 'finished'
IDLE = 'idle'


@dataclass(frozen=True)
class ProtocolSettings:
    """
    The protocol's parameters (the ``choice_menu`` node's).

    :param ask_on_arrival: the protocol of the module doc; False = every valid
        choice counts at once (the previous menu).
    :param back_option: offer :data:`BACK_LABEL` with the tables.
    :param repeat: after an outcome start over at the rooms (else finish).
    :param arrive_tolerance_m: camera position within this of the goal, m.
    :param arrive_tolerance_deg: camera orientation within this of the goal, degrees.
    :param settle_s: a camera that has not moved for this long has arrived, s.
    :param look_away_s: after a choice, ask again after this when the gaze cannot be
        judged (no region of the chosen option, no gaze point since the choice), s.
    :param look_away_margin_px: the gaze must be this far outside the chosen
        option's region, px.
    :param pause_after_s: gaze off screen this long pauses the menu, s.
    :param min_answer_s: a choice sooner than this after the request is not its answer, s.
    :param validate_first: start with a gaze validation (module doc).
    :param validation_retries: a refused validation is run again this many times.
    :param robot_goals: a chosen table is confirmed ('go'/'back') and sent to the robot
        (module doc); False: the table is the outcome at once and nothing moves.
    :param feedback_timeout_s: no word from the robot (feedback, an answer to the goal)
        for this long is said, s; 'stop' stays offered and the drive goes on.
    :param confirm_rounds: a confirmation asked this many times without an answer
        returns to the tables, no goal.
    :param send_rounds: 'go' is confirmed by a second look, at 'send' (module doc), asked
        this many rounds; unanswered: back to the tables, no goal (0: 'go' sends at once).
    """

    ask_on_arrival: bool = True
    back_option: bool = True
    repeat: bool = True
    arrive_tolerance_m: float = 0.05
    arrive_tolerance_deg: float = 2.0
    settle_s: float = 1.0
    look_away_s: float = 1.5
    look_away_margin_px: float = 10.0
    pause_after_s: float = 2.0
    min_answer_s: float = 0.04
    validate_first: bool = False
    validation_retries: int = 1
    robot_goals: bool = True
    # nav2's bt_navigator sends feedback on every tick of its tree (100 Hz), sim_robot at
    # 10 Hz or more: a few seconds of silence mean a robot or a link in trouble.
    feedback_timeout_s: float = 3.0
    confirm_rounds: int = 2
    send_rounds: int = 1

    def __post_init__(self):
        """Reject values the protocol cannot run with."""
        if isinstance(self.validation_retries, bool) or not isinstance(
                self.validation_retries, int) or self.validation_retries < 0:
            raise ValueError(f'validation_retries must be an integer >= 0, got '
                             f'{self.validation_retries!r}')
        if isinstance(self.confirm_rounds, bool) or not isinstance(
                self.confirm_rounds, int) or self.confirm_rounds < 1:
            raise ValueError(f'confirm_rounds must be an integer >= 1, got '
                             f'{self.confirm_rounds!r}')
        if isinstance(self.send_rounds, bool) or not isinstance(
                self.send_rounds, int) or self.send_rounds < 0:
            raise ValueError(f'send_rounds must be an integer >= 0, got {self.send_rounds!r}')
        for name in ('arrive_tolerance_m', 'arrive_tolerance_deg', 'settle_s', 'look_away_s',
                     'look_away_margin_px', 'pause_after_s', 'min_answer_s',
                     'feedback_timeout_s'):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f'{name} must be a finite number >= 0, got {value!r}')


@dataclass(frozen=True)
class Offer:
    """Show these options (``choices``) and move the camera to ``view`` (``camera/goal``)."""

    markers: Tuple[CubeMarker, ...]
    ns: str
    view: Optional[View]


@dataclass(frozen=True)
class Request:
    """Ask the arbiter for a decision (``choice/request``)."""


@dataclass(frozen=True)
class Validate:
    """Run a gaze validation (``validation/start``); :meth:`MenuProtocol.on_validation` ends it."""


@dataclass(frozen=True)
class Result:
    """An outcome (``choice_menu/result``)."""

    label: str


@dataclass(frozen=True)
class Answer:
    """A choice the menu acted on: it answered the question (``choice_menu/answer``)."""

    label: str


@dataclass(frozen=True, eq=False)
class SendGoal:
    """
    Send the robot a navigation goal: a confirmed destination, never a stop.

    The node answers with :meth:`MenuProtocol.on_goal_response`.

    :ivar label: the destination's label.
    :ivar pose: x, y (m) and yaw (rad) in the scene's frame, shape (3,).
    """

    label: str
    pose: np.ndarray


@dataclass(frozen=True)
class CancelGoal:
    """
    Cancel the robot's goal: the only way the menu stops the robot.

    :ivar every: cancel every goal of the navigation server (a goal this menu did
        not send, :meth:`MenuProtocol.on_other_goals`); False: the menu's own goal.
    """

    every: bool = False


@dataclass(frozen=True)
class Progress:
    """What the robot is doing, for the person (``choice_menu/progress``)."""

    text: str


@dataclass(frozen=True)
class Log:
    """A line for the node's log: level 'info' or 'warning'."""

    level: str
    text: str


Action = Union[Offer, Request, Result, Answer, Log, Validate, SendGoal, CancelGoal, Progress]


def _quaternion_angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    """Rotation angle between two unit quaternions (x, y, z, w), degrees."""
    dot = abs(float(np.dot(a / np.linalg.norm(a), b / np.linalg.norm(b))))
    return math.degrees(2.0 * math.acos(min(dot, 1.0)))


def poses_close(position_a, quaternion_a, position_b, quaternion_b, tolerance_m: float,
                tolerance_deg: float) -> bool:
    """Tell whether two poses (position m, quaternion x, y, z, w) agree within tolerances."""
    distance = float(np.linalg.norm(np.subtract(position_a, position_b)))
    return distance <= tolerance_m and _quaternion_angle_deg(
        np.asarray(quaternion_a, dtype=float), np.asarray(quaternion_b, dtype=float)) \
        <= tolerance_deg


#: Colours of the step options (r, g, b, a).
BACK_COLOUR = (0.55, 0.6, 0.7, 1.0)
GO_COLOUR = (0.2, 0.75, 0.3, 1.0)
STOP_COLOUR = (0.85, 0.15, 0.15, 1.0)
#: Side of the go / back / stop squares, in half-heights of the view (0.3: 108 px of a
#: 720 px panel, about 2.8 deg at the default screen: options of 100 px and more are
#: chosen right in 88 % and wrong in 0.7 % of real-gaze rounds, docs/selection.md).
STEP_SIDE = 0.3
#: Horizontal place of 'go', in half-widths from the view's centre, on the side away
#: from the chosen table (see :func:`confirm_markers`).
GO_RIGHT = 0.6


def _view_axes(view: View, fov_y_deg: float, aspect: float):
    """Return the view's camera rows (right, down, forward), half-width and half-height, m."""
    rotation = geometry.look_at(view.eye, view.focus, view.up)[:3, :3]
    distance = float(np.linalg.norm(np.subtract(view.focus, view.eye)))
    half_height = distance * math.tan(math.radians(fov_y_deg) / 2.0)
    return rotation, half_height * aspect, half_height


def view_square(view: View, label: str, right: float, down: float, side: float, colour,
                fov_y_deg: float = 45.0, aspect: float = 16.0 / 9.0) -> CubeMarker:
    """
    Return a thin square option facing the camera at a place of the view's image.

    Sizes are in half-heights of the image (at the focus distance: the square
    appears as large as a square of that side at the focus would).

    :param right: from the image centre to the right, in half-widths (-1 .. 1).
    :param down: from the image centre downwards, in half-heights (-1 .. 1).
    :param side: side in half-heights.
    :param fov_y_deg: vertical field of view of the render panel, degrees.
    :param aspect: render panel width / height.
    """
    rotation, half_width, half_height = _view_axes(view, fov_y_deg, aspect)
    # Halfway between the eye and the focus: above the floor (and a map drawn on it) and
    # the tables, so nothing in the scene hides it; the image place and size are the same.
    near = 0.5
    eye = np.asarray(view.eye, dtype=float)
    position = eye + near * (np.asarray(view.focus, dtype=float) - eye
                             + right * half_width * rotation[0]
                             + down * half_height * rotation[1])
    edge = near * side * half_height
    _, quaternion = look_at_pose(view.eye, view.focus, view.up)
    return CubeMarker(text=label, position=position, orientation=quaternion,
                      scale=np.array([edge, edge, 0.02 * edge]),
                      color=np.asarray(colour, dtype=float))


def image_place(view: View, point, fov_y_deg: float = 45.0,
                aspect: float = 16.0 / 9.0) -> Tuple[float, float]:
    """Return where a world point (3,) appears in the view: (right, down) in half-sizes."""
    rotation, half_width, half_height = _view_axes(view, fov_y_deg, aspect)
    camera = rotation @ (np.asarray(point, dtype=float) - np.asarray(view.eye, dtype=float))
    depth = float(np.linalg.norm(np.subtract(view.focus, view.eye)))
    if not camera[2] > 0:
        return 0.0, 0.0
    scale = depth / camera[2]
    return (float(camera[0] * scale / half_width), float(camera[1] * scale / half_height))


def back_marker(view: View, fov_y_deg: float = 45.0, aspect: float = 16.0 / 9.0,
                colour=BACK_COLOUR) -> CubeMarker:
    """
    Return the back option's marker: a thin square facing the camera at the view's lower left.

    It sits 80 % of the half-width left and 75 % of the half-height down from
    the image centre (in the corner, away from the tables around the focus),
    its side 12 % of the half-height (:func:`view_square`).

    :param view: the room's view.
    :param fov_y_deg: vertical field of view of the render panel, degrees.
    :param aspect: render panel width / height.
    """
    return view_square(view, BACK_LABEL, -0.8, 0.75, 0.12, colour, fov_y_deg, aspect)


def confirm_markers(view: View, chosen: CubeMarker, fov_y_deg: float = 45.0,
                    aspect: float = 16.0 / 9.0) -> Tuple[CubeMarker, CubeMarker]:
    """
    Return the confirmation step's options, (go, back), in the room's view.

    The Midas touch: when the table is chosen the person is looking at it, and
    a gaze that stays there (or comes back to it) must not send the robot.
    So 'back', the harmless answer, takes the chosen table's place, and 'go'
    appears :data:`GO_RIGHT` half-widths from the centre on the other side of
    the view, at the table's height (a third of the panel's width or more from
    where the person looked: a deliberate saccade, never a dwell carried
    over).  Whatever the gaze does without meaning to, it can only undo.
    """
    right, down = image_place(view, chosen.position, fov_y_deg, aspect)
    down = float(np.clip(down, -0.6, 0.6))
    go_right = -GO_RIGHT if right >= 0 else GO_RIGHT
    back_right = float(np.clip(right, -0.8, 0.8))   # same side as the table: >= GO_RIGHT apart
    return (view_square(view, GO_LABEL, go_right, down, STEP_SIDE, GO_COLOUR, fov_y_deg, aspect),
            view_square(view, BACK_LABEL, back_right, down, STEP_SIDE, BACK_COLOUR, fov_y_deg,
                        aspect))


#: How far 'send' lies from 'go', vertically, in half-heights (0.7: 252 px of a 720 px
#: panel, about 6.1 deg on the default screen: a saccade of its own, well beyond the
#: fixation rule's 2 deg resting radius and its 3 sigma halo around an option).
SEND_DOWN = 0.7
#: ... and no nearer the view's top or bottom edge than this, half-heights from the centre.
SEND_EDGE = 0.85


def send_marker(view: View, go: CubeMarker, avoid: Sequence[CubeMarker] = (),
                fov_y_deg: float = 45.0, aspect: float = 16.0 / 9.0) -> CubeMarker:
    """
    Return the 'send' option: it appears once 'go' is chosen, :data:`SEND_DOWN` above or below.

    The Midas touch's last gate: a wandering gaze that chose 'go' by chance
    must now, within ``send_rounds`` rounds, make a fresh fixation on a
    target that was not there before and lies where the gaze was not.  Of the
    places above and below 'go' (within :data:`SEND_EDGE`), the one farthest
    from everything else worth looking at (``avoid``: the tables, 'back', where
    'stop' will be) on the screen.  A person who means 'go' looks at it at once.
    """
    right, down = image_place(view, go.position, fov_y_deg, aspect)
    others = np.array([image_place(view, marker.position, fov_y_deg, aspect)
                       for marker in avoid]).reshape(-1, 2) * [aspect, 1.0]
    best, clearance = None, -math.inf
    for send_down in (down - SEND_DOWN, down + SEND_DOWN):
        send_down = float(np.clip(send_down, -SEND_EDGE, SEND_EDGE))
        # Distances in half-heights (the image's x scaled by the aspect).
        nearest = float(np.min(np.hypot(*(others - [right * aspect, send_down]).T))) \
            if len(others) else 0.0
        if nearest > clearance:
            best, clearance = send_down, nearest
    return view_square(view, SEND_LABEL, right, best, STEP_SIDE, GO_COLOUR, fov_y_deg,
                       aspect)


def send_markers(view: View, go: CubeMarker, avoid: Sequence[CubeMarker] = (),
                 fov_y_deg: float = 45.0, aspect: float = 16.0 / 9.0
                 ) -> Tuple[CubeMarker, CubeMarker]:
    """
    Return the second look's options, ('send', 'back'): 'back' takes the place of 'go'.

    'send' appears where the gaze was not (:func:`send_marker`); 'back' where it
    is most likely to linger, on the 'go' just chosen, so that whatever a gaze
    that stays or comes back there does, it only undoes (as the confirmation's
    'back' on the table).  Two options, not one: every input mode can answer
    (SSVEP compares the options' responses, and the hybrid arbiter needs its
    EEG to tell one option from another; 'send' alone was never answered by
    them), and looking back is an explicit "no".
    """
    send = send_marker(view, go, avoid, fov_y_deg, aspect)
    return send, replace(go, text=BACK_LABEL, color=np.asarray(BACK_COLOUR, dtype=float))


def stop_marker(go: CubeMarker, back: CubeMarker) -> CubeMarker:
    """
    Return the stop option shown while the robot drives: where 'back' was.

    Not where 'go' was: the gaze that chose 'go' rests there, and the stop is
    asked at once (no look-away gate), so it must take a new saccade.
    """
    return replace(back, text=STOP_LABEL, color=np.asarray(STOP_COLOUR, dtype=float))


@dataclass
class _Goal:
    """The camera goal of the current step and what is known of the camera since."""

    view: View
    position: np.ndarray
    quaternion: np.ndarray
    published_at: float
    last_move: float
    arrived: bool = False


@dataclass
class _LookAway:
    """The gate after a choice."""

    chosen_at: float
    region: Optional[np.ndarray] = None     # (K, 2) screen px, the chosen option at the choice
    done: bool = False
    samples: int = 0                        # gaze points judged since the choice
    outside: int = 0                        # ... of them beyond the margin, in a row
    outside_since: float = math.nan         # the first of that run, s

    def take(self, distance: float, margin: float, now: float) -> bool:
        """Take a gaze point ``distance`` px from the region; True once the gaze has left."""
        self.samples += 1
        if not distance > margin:
            self.outside, self.outside_since = 0, math.nan
            return False
        if not self.outside:
            self.outside_since = now
        self.outside += 1
        return self.outside >= LEFT_SAMPLES and now - self.outside_since >= LEFT_S - 1e-9


@dataclass
class _Drive:
    """A navigation goal the robot drives to: the menu's own (confirmed) or another's."""

    label: str                              # the destination; '' for another's goal
    sent_at: float
    other: bool = False                     # a goal this menu did not send
    accepted: bool = False                  # the robot accepted it
    stopping: bool = False                  # 'stop' chosen: cancelled, the end not yet heard
    heard_at: float = math.nan              # the robot's last word (accepted, feedback)
    silent: bool = False                    # the silence was said
    shown_m: float = math.nan               # the distance in the last progress line

    def __post_init__(self):
        """Count the robot's silence from the moment the goal was sent."""
        self.heard_at = self.sent_at

    @property
    def name(self) -> str:
        """Say which goal this is, for the person."""
        return 'a goal this menu did not send' if self.other else f"'{self.label}'"


@dataclass
class MenuProtocol:
    """
    The room -> table menu's protocol (module doc); the node feeds it and performs its actions.

    :param scene: rooms, tables, views.
    :param settings: the protocol's parameters.
    :param goals: each destination's robot goal, label -> x, y (m), yaw (rad) in the
        scene's frame, shape (3,); a table without one is an outcome only (nothing moves).
    """

    scene: Scene
    settings: ProtocolSettings = field(default_factory=ProtocolSettings)
    goals: Dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self):
        """Start with nothing offered (call :meth:`start`)."""
        self.room: Optional[Room] = None
        self.finished = False
        self.offered: Tuple[str, ...] = ()
        self._markers: Tuple[Tuple[CubeMarker, ...], str] = ((), ROOMS_NS)
        self._shown = False
        self._goal: Optional[_Goal] = None
        self._pose: Optional[Tuple[np.ndarray, np.ndarray]] = None
        self._look_away: Optional[_LookAway] = None
        self._off_screen_since: Optional[float] = None
        self._paused = False
        self._asked_at: Optional[float] = None
        self._regions: Tuple[Sequence[str], np.ndarray] = ((), np.zeros((0, 3, 2)))
        self._validating = False
        self._validated = False
        self._validation_runs = 0
        self.pending: Optional[str] = None          # a chosen table waiting for 'go'
        self._unanswered = 0                         # its confirmation's rounds without one
        self._sending = False                        # 'go' chosen: 'send' offered
        self.drive: Optional[_Drive] = None

    # -- state ------------------------------------------------------------------------------

    @property
    def state(self) -> str:
        """Return what the menu waits for (one of the module's state names)."""
        state = self._step_state()
        if self.drive is not None and state in (READY, ASKING, WAITING_FOR_CAMERA, LOOK_AWAY):
            return DRIVING
        return state

    def _step_state(self) -> str:
        """Return what the current step waits for (the question's conditions)."""
        if self.finished:
            return FINISHED
        if self._validating:
            return VALIDATING
        if not self.offered:
            return IDLE
        if self._paused:
            return PAUSED
        if self._asked_at is not None:
            return ASKING
        if self._look_away is not None and not self._look_away.done:
            return LOOK_AWAY
        if self._goal is not None and not self._goal.arrived:
            return WAITING_FOR_CAMERA
        return READY

    @property
    def options(self) -> Tuple[str, ...]:
        """Return the labels offered now (empty once finished)."""
        return () if self.finished else self.offered

    @property
    def asked_at(self) -> Optional[float]:
        """Return when the open question was asked, s (None: not asking)."""
        return self._asked_at

    # -- inputs -----------------------------------------------------------------------------

    def start(self, now: float) -> List[Action]:
        """Offer the rooms (also: start over after a scene reload); first validate if asked."""
        actions = self.cancel_drive('the menu starts over', now)
        self._look_away = None
        self.pending = None
        if self.settings.validate_first and not self._validated:
            self._validating, self._validation_runs = True, 1
            return actions + [Log('info', 'starting with a gaze validation'), Validate()]
        return actions + self._offer_rooms(now)

    def on_validation(self, accepted: bool, summary: str, now: float) -> List[Action]:
        """Take the outcome of the validation asked for (module doc); others are ignored."""
        if not self._validating:
            return [Log('info', f'validation result not asked for, ignored: {summary}')]
        if not accepted and self._validation_runs <= self.settings.validation_retries:
            self._validation_runs += 1
            return [Log('warning', f'{summary}; validating again (run {self._validation_runs} '
                                   f'of {self.settings.validation_retries + 1})'), Validate()]
        self._validating, self._validated = False, True
        if accepted:
            return [Log('info', summary)] + self._offer_rooms(now)
        return [Log('warning', f'{summary}; going on with the gaze correction as it was')] + \
            self._offer_rooms(now)

    def reoffer(self, now: float) -> List[Action]:
        """Offer the current step again (e.g. in a new world frame); the question is asked anew."""
        if self.finished or self._validating:
            return []
        if self.drive is not None:
            return self._offer_stop(now)
        if self.room is None:
            return self._offer_rooms(now)
        if self.pending is not None:
            return self._offer_send(now) if self._sending else self._offer_confirm(now)
        return self._offer_tables(self.room, now)

    def on_camera_pose(self, position, quaternion, now: float) -> List[Action]:
        """Take a ``camera/pose`` (optical convention; position m, quaternion x, y, z, w)."""
        position = np.asarray(position, dtype=float).reshape(3)
        quaternion = np.asarray(quaternion, dtype=float).reshape(4)
        if not (np.all(np.isfinite(position)) and np.all(np.isfinite(quaternion))
                and np.linalg.norm(quaternion) > 0):
            return [Log('warning', 'camera pose with NaN or a zero quaternion ignored')]
        previous, self._pose = self._pose, (position, quaternion)
        goal = self._goal
        if goal is None or goal.arrived:
            return []
        tol = self.settings
        if poses_close(position, quaternion, goal.position, goal.quaternion,
                       tol.arrive_tolerance_m, tol.arrive_tolerance_deg):
            goal.arrived = True
            return [Log('info', 'camera arrived at the goal')] + self.tick(now)
        if previous is None or not poses_close(position, quaternion, *previous,
                                               tol.arrive_tolerance_m,
                                               tol.arrive_tolerance_deg):
            goal.last_move = now
        return self.tick(now)

    def on_goal_response(self, accepted: bool, reason: str, now: float) -> List[Action]:
        """
        Take the robot's answer to the goal just sent (:class:`SendGoal`).

        :param accepted: the navigation server accepted it.
        :param reason: why not, in words (no server, rejected), when not accepted.
        """
        drive = self.drive
        if drive is None or drive.other or drive.accepted:
            if accepted:        # given up before the answer came: it must not drive
                return [Log('warning', 'a goal the menu gave up was accepted late: '
                                       'cancelling it'), CancelGoal()]
            return [Log('info', f'a refusal of a goal no longer followed: {reason}')]
        if not accepted:
            self.drive = None
            text = f'the robot refused the goal to {drive.name}: {reason}: choose again'
            return [Log('warning', text), Progress(text), *self._offer_tables(self.room, now)]
        drive.accepted, drive.heard_at, drive.silent = True, now, False
        actions: List[Action] = [Log('info', f'the robot accepted the goal to {drive.name}')]
        if drive.stopping:          # 'stop' was chosen before the answer came
            actions.append(CancelGoal())
        return actions

    def on_feedback(self, distance_m: float, now: float) -> List[Action]:
        """Take the navigation's feedback on the menu's goal: the distance left, m."""
        drive = self.drive
        if drive is None or drive.other:
            return []
        actions = self._heard(drive, now)
        if not (math.isfinite(distance_m) and distance_m >= 0):
            return actions + [Log('warning', f'feedback with a distance left of {distance_m} '
                                             'ignored')]
        if not drive.stopping and not abs(distance_m - drive.shown_m) < PROGRESS_STEP_M:
            drive.shown_m = distance_m
            actions.append(Progress(f'driving to {drive.name}: {distance_m:.1f} m left'))
        return actions

    def on_goal_result(self, outcome: str, reason: str, now: float) -> List[Action]:
        """
        Take how the menu's goal ended: :data:`SUCCEEDED`, :data:`ABORTED` or :data:`CANCELED`.

        :param reason: the robot's reason in words (nav2's error code and message) for
            any end but success.
        """
        drive = self.drive
        if drive is None or drive.other:
            return [Log('info', f'the end of a goal no longer followed: {outcome}')]
        self.drive = None
        if outcome == SUCCEEDED:
            return [Log('info', f'arrived at {drive.name}'), Progress(f'arrived at {drive.name}'),
                    *self._next_task(now)]
        if outcome == CANCELED and drive.stopping:
            return [Log('info', f'the robot stopped on the way to {drive.name}'),
                    Progress(f'stopped on the way to {drive.name}'), *self._next_task(now)]
        if outcome == CANCELED:
            text = f'the goal to {drive.name} was cancelled, not by this menu: choose again'
        else:
            text = f'the robot did not reach {drive.name}: {reason}: choose again'
        return [Log('warning', text), Progress(text), *self._offer_tables(self.room, now)]

    def on_cancel_response(self, accepted: bool, reason: str, now: float) -> List[Action]:
        """Take the robot's answer to a cancel: a refused stop is said and 'stop' offered on."""
        drive = self.drive
        if drive is None or not drive.stopping:
            return []
        actions = self._heard(drive, now)
        if accepted:
            return actions + [Log('info', f'the robot is stopping on the way to {drive.name}')]
        drive.stopping = False
        text = (f'the robot refused the stop on the way to {drive.name} ({reason}): choose '
                "'stop' again")
        return actions + [Log('warning', text), Progress(text)]

    def on_other_goals(self, active: bool, now: float) -> List[Action]:
        """
        Take whether the robot has a goal this menu did not send (the action's status).

        Such a goal (a menu restarted while its robot drives, another client) is met
        with 'stop' before anything else; when it has ended the menu starts over.
        """
        drive = self.drive
        if active and drive is None:
            self.pending = None
            self._validating = False        # validated again when the menu starts over
            self.drive = _Drive('', now, other=True, accepted=True)
            text = "the robot drives to a goal this menu did not send: 'stop' is offered first"
            return [Log('warning', text), Progress(text), *self._offer_stop(now)]
        if active or drive is None or not drive.other:
            return []
        self.drive = None
        text = ('the robot stopped' if drive.stopping else
                'the goal this menu did not send has ended')
        return [Log('info', text), Progress(text), *self.start(now)]

    def on_regions(self, labels: Sequence[str], polygons) -> None:
        """Take the current ``choices/regions`` (labels, polygons (R, K, 2) screen px)."""
        self._regions = (tuple(labels), np.asarray(polygons, dtype=float).reshape(
            len(labels), -1, 2) if len(labels) else np.zeros((0, 3, 2)))

    def on_gaze_point(self, x: float, y: float, now: float) -> List[Action]:
        """Take a gaze point (``gaze/point``, screen px)."""
        gate = self._look_away
        if gate is None or gate.done or not (math.isfinite(x) and math.isfinite(y)):
            return []
        if gate.region is None:
            return self.tick(now)
        distance = float(polygon_distances([[x, y]], gate.region[None])[0, 0])
        if gate.take(distance, self.settings.look_away_margin_px, now):
            gate.done = True
            return [Log('info', 'gaze left the chosen option')] + self.tick(now)
        return self.tick(now)

    def on_screen(self, on_screen: bool, now: float) -> List[Action]:
        """Take ``gaze/on_screen``: whether the gaze is on the screen now."""
        actions: List[Action] = []
        if on_screen:
            self._off_screen_since = None
            if self._paused:
                self._paused = False
                actions.append(Log('info', 'gaze back on the screen: the menu goes on'))
                actions += self.tick(now)
            return actions
        if self._off_screen_since is None:
            self._off_screen_since = now
        gate = self._look_away
        if gate is not None and not gate.done:
            gate.done = True      # off screen: the gaze has left the chosen option
        return self.tick(now)

    def on_choice(self, label: str, now: float) -> List[Action]:
        """Take a ``choice``; act on it only when it answers the open question (module doc)."""
        if self.finished:
            return [Log('info', f"menu finished: ignoring choice '{label}'")]
        if self._validating:
            return [Log('info', f"ignoring choice '{label}': validating")]
        if self.settings.ask_on_arrival:
            if self._asked_at is None or self._paused:
                why = 'paused' if self._paused else f'not asked ({self.state})'
                return [Log('info', f"ignoring choice '{label}': {why}")]
            if now - self._asked_at < self.settings.min_answer_s:
                # Asked again: if this was the answer after all, the round the question
                # opened has closed with it, and nothing else would ever come.
                since, self._asked_at = now - self._asked_at, now
                return [Log('info', f"ignoring choice '{label}': made before the question "
                                    f'({since:.3f} s after it): asking again'), Request()]
        if label not in self.offered:
            self._asked_at = None
            again = self.tick(now) if self.settings.ask_on_arrival else [Request()]
            return [Log('warning', f"ignoring choice '{label}': not one of "
                                   f"{', '.join(self.offered)}"), *again]
        self._asked_at = None
        if self.settings.ask_on_arrival:
            self._look_away = _LookAway(now, self._region_of(label))
        if self.drive is not None:
            return [Answer(label), *self._stop(now)]
        if self.room is None:
            room = self.scene.room(label)
            return [Answer(label), Log('info', f"room chosen: '{label}'"),
                    *self._offer_tables(room, now)]
        if self.pending is not None:
            return [Answer(label), *self._confirm_answer(label, now)]
        if label == BACK_LABEL:
            return [Answer(label), Log('info', 'back to the rooms'), *self._offer_rooms(now)]
        if self.settings.robot_goals and label in self.goals:
            self.pending = label
            return [Answer(label), Log('info', f"'{label}' chosen: 'go' sends the robot, "
                                               "'back' returns to the tables"),
                    *self._offer_confirm(now)]
        actions: List[Action] = [Answer(label), Result(label), Log('info', f"outcome: '{label}'")]
        if self.settings.robot_goals:
            actions.append(Log('warning', f"no robot goal for '{label}': nothing sent"))
        return actions + self._next_task(now)

    def on_no_choice(self, reason: str, now: float) -> List[Action]:
        """Take an arbiter round that ended without a choice: ask the open question again."""
        if self.finished or self._asked_at is None or self._paused:
            return []
        if now - self._asked_at < self.settings.min_answer_s:
            return []  # the round the request replaced, or one in flight with it
        if self.pending is not None:
            self._unanswered += 1
            limit = self.settings.send_rounds if self._sending else self.settings.confirm_rounds
            if self._unanswered >= limit:
                what = SEND_LABEL if self._sending else self.pending
                self._sending = False
                return [Log('info', f"no answer to '{what}' in {self._unanswered} rounds"),
                        *self._confirmed(False, now)]
        self._asked_at = now
        return [Log('info', f'no choice ({reason}): asking again'), Request()]

    def tick(self, now: float) -> List[Action]:
        """Apply the timed rules (settle, look-away time, pause, drive); call it periodically."""
        actions: List[Action] = []
        drive = self.drive
        if drive is not None and not drive.other and not drive.accepted and \
                now - drive.heard_at >= self.settings.feedback_timeout_s:
            # A server that is gone but not yet seen gone: the goal is given up (a late
            # acceptance is cancelled, on_goal_response), the tables offered again.
            self.drive = None
            text = (f'no answer to the goal to {drive.name} in '
                    f'{now - drive.heard_at:.0f} s: choose again')
            return [Log('warning', text), Progress(text), *self._offer_tables(self.room, now)]
        if drive is not None and not drive.other and not drive.silent and \
                now - drive.heard_at >= self.settings.feedback_timeout_s:
            drive.silent = True
            text = (f'no feedback from the robot for {now - drive.heard_at:.0f} s on the way '
                    f"to {drive.name}: 'stop' is still offered")
            actions += [Log('warning', text), Progress(text)]
        goal = self._goal
        if goal is not None and not goal.arrived and now - goal.last_move >= \
                self.settings.settle_s:
            goal.arrived = True
            # Without any camera/pose (a static view, no camera_tracker) nothing settled.
            actions.append(Log('info', f'camera settled ({self.settings.settle_s:g} s '
                                       'without moving): taken as arrived')
                           if self._pose is not None else
                           Log('info', f'no camera/pose in {self.settings.settle_s:g} s: '
                                       'asking without waiting for the camera'))
        if goal is not None and goal.arrived and not self._shown:
            actions += self._show()
        gate = self._look_away
        if gate is not None and not gate.done and (gate.region is None or not gate.samples) \
                and now - gate.chosen_at >= self.settings.look_away_s:
            gate.done = True    # nothing to judge the gaze by (module doc, rule 3)
        if (self._off_screen_since is not None and not self._paused and self.offered
                and not self.finished
                and now - self._off_screen_since >= self.settings.pause_after_s):
            self._paused = True
            self._asked_at = None
            actions.append(Log('info', f'gaze off screen for {self.settings.pause_after_s:g} '
                                       's: paused'))
        return actions + self._maybe_ask(now)

    def cancel_drive(self, why: str, now: float, own_only: bool = False) -> List[Action]:
        """
        Cancel a drive the menu no longer follows (a new scene, robot_goals off); [] if none.

        :param own_only: only the menu's own goal (the menu ends: another's goal is not
            its to stop).
        """
        drive = self.drive
        if drive is None or (own_only and drive.other):
            return []
        self.drive = None
        actions: List[Action] = [Log('warning', f'{why}: stopping the robot on its way to '
                                                f'{drive.name}')]
        if drive.accepted or drive.other:
            actions.append(CancelGoal(every=drive.other))
        return actions + [Progress(f'stopping on the way to {drive.name} ({why})')]

    # -- the robot --------------------------------------------------------------------------

    def _confirmed(self, go: bool, now: float) -> List[Action]:
        """Act on the confirmation step's answer: 'go' sends the goal, 'back' offers the tables."""
        label, self.pending = self.pending, None
        if not go:
            return [Log('info', f"'{label}' not confirmed: back to the tables"),
                    *self._offer_tables(self.room, now)]
        goal = np.asarray(self.goals[label], dtype=float).reshape(3)
        self.drive = _Drive(label, now)
        # The stop is asked at once: no look-away gate (stop_marker is not where 'go' was).
        self._look_away = None
        return [Result(label), SendGoal(label, goal.copy()),
                Log('info', f"'{label}' confirmed: robot goal x {goal[0]:.2f} m, y "
                            f'{goal[1]:.2f} m, yaw {math.degrees(goal[2]):.0f} deg'),
                Progress(f"sending the robot to '{label}'"), *self._offer_stop(now)]

    def _stop(self, now: float) -> List[Action]:
        """
        'stop' chosen while driving: cancel the goal; 'stop' stays offered until it has ended.

        A goal not yet accepted is cancelled when it is (:meth:`on_goal_response`).
        """
        drive = self.drive
        drive.stopping = True
        actions: List[Action] = [Log('info', f'stop chosen on the way to {drive.name}'),
                                 Progress(f'stopping on the way to {drive.name}')]
        if drive.accepted:
            actions.append(CancelGoal(every=drive.other))
        return actions

    def _heard(self, drive: _Drive, now: float) -> List[Action]:
        """Take a word from the robot: the silence (if it was said) has ended."""
        drive.heard_at = now
        if not drive.silent:
            return []
        drive.silent = False
        return [Log('info', f'the robot answers again on the way to {drive.name}')]

    def _next_task(self, now: float) -> List[Action]:
        """After an outcome: the rooms again (repeat) or finish."""
        if self.settings.repeat:
            return self._offer_rooms(now)
        return self._finish()

    # -- steps ------------------------------------------------------------------------------

    def _region_of(self, label: str) -> Optional[np.ndarray]:
        labels, polygons = self._regions
        if label in labels:
            return polygons[list(labels).index(label)]
        return None

    def _offer(self, markers: Sequence[CubeMarker], ns: str, view: View,
               now: float) -> List[Action]:
        self.finished = False
        labels = tuple(marker.text for marker in markers)
        same = bool(labels) and set(labels) == set(self.offered)
        self.offered = labels
        self._markers = (tuple(markers), ns)
        self._asked_at = None
        previous = self._goal
        position, quaternion = look_at_pose(*view.as_tuple())
        self._goal = _Goal(view, position, quaternion, now, now)
        if (previous is not None and previous.arrived and previous.view is view) or (
                self._pose is not None and poses_close(
                    *self._pose, position, quaternion, self.settings.arrive_tolerance_m,
                    self.settings.arrive_tolerance_deg)):
            self._goal.arrived = True
        if not self.settings.ask_on_arrival or self._goal.arrived or self._pose is None:
            # Shown at once: the previous menu, the camera already there, or no camera
            # pose known (nothing known to be moving; the projector waits for a pose).
            self._shown = True
            actions: List[Action] = [Offer(tuple(markers), ns, view)]
        else:
            self._shown = False
            actions = [Offer((), ns, view)]     # withdraw the old options; the camera moves
        if not self.settings.ask_on_arrival:
            # Same labels again: the arbiter would not see a change.
            return actions + ([Request()] if same else [])
        return actions + self.tick(now)

    def _show(self) -> List[Action]:
        """Show the step's options: the camera has arrived (or settled)."""
        self._shown = True
        markers, ns = self._markers
        return [Offer(markers, ns, None)]

    def _offer_rooms(self, now: float) -> List[Action]:
        self.room = None
        self.pending = None
        self._sending = False
        return self._offer([room.marker for room in self.scene.rooms], ROOMS_NS,
                           self.scene.overview, now)

    def _offer_tables(self, room: Room, now: float) -> List[Action]:
        self.room = room
        markers = [table.marker for table in room.tables]
        if self.settings.back_option:
            markers.append(back_marker(room.view))
        return self._offer(markers, TABLES_NS, room.view, now)

    def _confirm_answer(self, label: str, now: float) -> List[Action]:
        """Act on the confirmation's answer: 'go' offers 'send' (send_rounds), 'send' sends."""
        if label == GO_LABEL and self.settings.send_rounds and not self._sending:
            return [Log('info', f"'go' for '{self.pending}': look at 'send' to send the robot"),
                    *self._offer_send(now)]
        self._sending = False
        return self._confirmed(label in (GO_LABEL, SEND_LABEL), now)

    def _offer_send(self, now: float) -> List[Action]:
        """Offer 'send' and 'back' (:func:`send_markers`) and ask at once (no look-away gate)."""
        self._unanswered = 0
        self._sending = True
        self._look_away = None
        go, back = confirm_markers(self.room.view, self.room.table(self.pending).marker)
        markers = send_markers(self.room.view, go, [back] + [t.marker for t in self.room.tables])
        return self._offer(markers, CONFIRM_NS, self.room.view, now)

    def _offer_confirm(self, now: float) -> List[Action]:
        self._unanswered = 0
        self._sending = False
        go, back = confirm_markers(self.room.view, self.room.table(self.pending).marker)
        return self._offer([go, back], CONFIRM_NS, self.room.view, now)

    def _offer_stop(self, now: float) -> List[Action]:
        if self.drive.other or self.room is None:
            # Nothing chosen here (a restarted menu): the stop in the middle of the
            # overview, where the gaze rests; looking there can only stop the robot.
            stop = view_square(self.scene.overview, STOP_LABEL, 0.0, 0.0, STEP_SIDE,
                               STOP_COLOUR)
            return self._offer([stop], DRIVE_NS, self.scene.overview, now)
        go, back = confirm_markers(self.room.view, self.room.table(self.drive.label).marker)
        return self._offer([stop_marker(go, back)], DRIVE_NS, self.room.view, now)

    def _finish(self) -> List[Action]:
        self.finished = True
        self.room = None
        self.pending = None
        self.offered = ()
        self._goal = None
        self._asked_at = None
        return [Offer((), ROOMS_NS, None), Log('info', 'menu finished (repeat is false)')]

    def _maybe_ask(self, now: float) -> List[Action]:
        """Ask when every condition holds and the question is not asked yet."""
        if not self.settings.ask_on_arrival or self._step_state() != READY:
            return []
        self._asked_at = now
        return [Request()]
