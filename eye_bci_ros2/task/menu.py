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
3. **looked away** (after a choice): the gaze (``gaze/point``, screen px) has
   left the chosen option's screen region as it was at the choice (from
   ``choices/regions``) by more than ``look_away_margin_px``, or the gaze went
   off screen, or ``look_away_s`` has passed since the choice (the pause
   that lets a person who keeps looking go on);
4. **not paused**: the gaze has not been off screen (``gaze/on_screen``
   false) for ``pause_after_s`` or more; it resumes when ``gaze/on_screen``
   is true again, and the question is asked again.

Each question is asked once (one ``Request``), and again when the arbiter
reports that its round ended without a choice (``choice/none``,
:meth:`MenuProtocol.on_no_choice`).  A choice counts only when it
answers the question: it arrives while the menu is asking, at least
``min_answer_s`` after the request (a decision made before the request, in
flight when it went out, is not an answer: the arbiter's early rule needs
fresh gaze at least 0.1 s after a round start anyway), and names an offered
option.  Any other choice is logged and ignored (an unknown label while
asking asks again).  So the menu never advances on its own, whatever the
arbiter decides between questions.

``ask_on_arrival`` false gives the previous behaviour: every valid choice
counts at once, nothing is asked except after an unusable choice or an
unchanged offer.

``validate_first``: the experiment starts with a gaze validation
(:class:`Validate`; the node sends ``validation/start`` to
``gaze_validation``) and offers the rooms only once it has ended
(:meth:`MenuProtocol.on_validation`): at once after an accepted one; a
refused one is logged with its reason and run again up to
``validation_retries`` times, after which the menu goes on with the
bridge's correction as it was (a warning says so).
"""

from dataclasses import dataclass, field
import math
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np

from eye_bci_ros2.decision.tolerance import polygon_distances
from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.task.scene import CubeMarker, Room, Scene, View

#: Label of the option that goes back from the tables to the rooms.
BACK_LABEL = 'back'
#: Marker namespaces of the two levels of the menu.
ROOMS_NS = 'rooms'
TABLES_NS = 'tables'
#: What the protocol waits for (:attr:`MenuProtocol.state`).
WAITING_FOR_CAMERA = 'waiting_for_camera'
LOOK_AWAY = 'waiting_for_look_away'
PAUSED = 'paused'
VALIDATING = 'validating'
READY = 'ready'
ASKING = 'asking'
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
    :param look_away_s: after a choice, ask again at the latest after this, s.
    :param look_away_margin_px: the gaze must be this far outside the chosen
        option's region, px.
    :param pause_after_s: gaze off screen this long pauses the menu, s.
    :param min_answer_s: a choice sooner than this after the request is not its answer, s.
    :param validate_first: start with a gaze validation (module doc).
    :param validation_retries: a refused validation is run again this many times.
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
    min_answer_s: float = 0.1
    validate_first: bool = False
    validation_retries: int = 1

    def __post_init__(self):
        """Reject values the protocol cannot run with."""
        if isinstance(self.validation_retries, bool) or not isinstance(
                self.validation_retries, int) or self.validation_retries < 0:
            raise ValueError(f'validation_retries must be an integer >= 0, got '
                             f'{self.validation_retries!r}')
        for name in ('arrive_tolerance_m', 'arrive_tolerance_deg', 'settle_s', 'look_away_s',
                     'look_away_margin_px', 'pause_after_s', 'min_answer_s'):
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


@dataclass(frozen=True)
class Log:
    """A line for the node's log: level 'info' or 'warning'."""

    level: str
    text: str


Action = Union[Offer, Request, Result, Answer, Log, Validate]


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


def back_marker(view: View, fov_y_deg: float = 45.0, aspect: float = 16.0 / 9.0,
                colour=(0.55, 0.6, 0.7, 1.0)) -> CubeMarker:
    """
    Return the back option's marker: a thin square facing the camera at the view's lower left.

    It sits at the focus distance, 80 % of the half-width left and 75 % of the
    half-height down from the image centre (in the corner, away from the
    tables around the focus), its side 12 % of the half-height.

    :param view: the room's view.
    :param fov_y_deg: vertical field of view of the render panel, degrees.
    :param aspect: render panel width / height.
    """
    external = geometry.look_at(view.eye, view.focus, view.up)
    rotation = external[:3, :3]          # rows: camera x (right), y (down), z (forward)
    distance = float(np.linalg.norm(np.subtract(view.focus, view.eye)))
    half_height = distance * math.tan(math.radians(fov_y_deg) / 2.0)
    half_width = half_height * aspect
    position = (np.asarray(view.focus, dtype=float) - 0.8 * half_width * rotation[0]
                + 0.75 * half_height * rotation[1])
    side = 0.12 * half_height
    _, quaternion = look_at_pose(view.eye, view.focus, view.up)
    return CubeMarker(text=BACK_LABEL, position=position, orientation=quaternion,
                      scale=np.array([side, side, 0.02 * side]),
                      color=np.asarray(colour, dtype=float))


@dataclass
class _Goal:
    """The camera goal of the current step and what is known of the camera since."""

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


@dataclass
class MenuProtocol:
    """
    The room -> table menu's protocol (module doc); the node feeds it and performs its actions.

    :param scene: rooms, tables, views.
    :param settings: the protocol's parameters.
    """

    scene: Scene
    settings: ProtocolSettings = field(default_factory=ProtocolSettings)

    def __post_init__(self):
        """Start with nothing offered (call :meth:`start`)."""
        self.room: Optional[Room] = None
        self.finished = False
        self.offered: Tuple[str, ...] = ()
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

    # -- state ------------------------------------------------------------------------------

    @property
    def state(self) -> str:
        """Return what the menu waits for (one of the module's state names)."""
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
        self._look_away = None
        if self.settings.validate_first and not self._validated:
            self._validating, self._validation_runs = True, 1
            return [Log('info', 'starting with a gaze validation'), Validate()]
        return self._offer_rooms(now)

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
        if self.room is None:
            return self._offer_rooms(now)
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
        if distance > self.settings.look_away_margin_px:
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
                return [Log('info', f"ignoring choice '{label}': made before the question "
                                    f'({now - self._asked_at:.3f} s after it)')]
        if label not in self.offered:
            self._asked_at = None
            again = self.tick(now) if self.settings.ask_on_arrival else [Request()]
            return [Log('warning', f"ignoring choice '{label}': not one of "
                                   f"{', '.join(self.offered)}"), *again]
        self._asked_at = None
        if self.settings.ask_on_arrival:
            self._look_away = _LookAway(now, self._region_of(label))
        if self.room is None:
            room = self.scene.room(label)
            return [Answer(label), Log('info', f"room chosen: '{label}'"),
                    *self._offer_tables(room, now)]
        if label == BACK_LABEL:
            return [Answer(label), Log('info', 'back to the rooms'), *self._offer_rooms(now)]
        actions: List[Action] = [Answer(label), Result(label),
                                 Log('info', f"outcome: '{label}'")]
        if self.settings.repeat:
            return actions + self._offer_rooms(now)
        return actions + self._finish()

    def on_no_choice(self, reason: str, now: float) -> List[Action]:
        """Take an arbiter round that ended without a choice: ask the open question again."""
        if self.finished or self._asked_at is None or self._paused:
            return []
        if now - self._asked_at < self.settings.min_answer_s:
            return []  # the round the request replaced, or one in flight with it
        self._asked_at = now
        return [Log('info', f'no choice ({reason}): asking again'), Request()]

    def tick(self, now: float) -> List[Action]:
        """Apply the timed rules (settle, look-away time, pause); call it periodically."""
        actions: List[Action] = []
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
        gate = self._look_away
        if gate is not None and not gate.done and now - gate.chosen_at >= \
                self.settings.look_away_s:
            gate.done = True
        if (self._off_screen_since is not None and not self._paused and self.offered
                and not self.finished
                and now - self._off_screen_since >= self.settings.pause_after_s):
            self._paused = True
            self._asked_at = None
            actions.append(Log('info', f'gaze off screen for {self.settings.pause_after_s:g} '
                                       's: paused'))
        return actions + self._maybe_ask(now)

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
        self._asked_at = None
        position, quaternion = look_at_pose(*view.as_tuple())
        self._goal = _Goal(position, quaternion, now, now)
        if self._pose is not None and poses_close(
                *self._pose, position, quaternion, self.settings.arrive_tolerance_m,
                self.settings.arrive_tolerance_deg):
            self._goal.arrived = True
        actions: List[Action] = [Offer(tuple(markers), ns, view)]
        if not self.settings.ask_on_arrival:
            # Same labels again: the arbiter would not see a change.
            return actions + ([Request()] if same else [])
        return actions + self.tick(now)

    def _offer_rooms(self, now: float) -> List[Action]:
        self.room = None
        return self._offer([room.marker for room in self.scene.rooms], ROOMS_NS,
                           self.scene.overview, now)

    def _offer_tables(self, room: Room, now: float) -> List[Action]:
        self.room = room
        markers = [table.marker for table in room.tables]
        if self.settings.back_option:
            markers.append(back_marker(room.view))
        return self._offer(markers, TABLES_NS, room.view, now)

    def _finish(self) -> List[Action]:
        self.finished = True
        self.room = None
        self.offered = ()
        self._goal = None
        self._asked_at = None
        return [Offer((), ROOMS_NS, None), Log('info', 'menu finished (repeat is false)')]

    def _maybe_ask(self, now: float) -> List[Action]:
        """Ask when every condition holds and the question is not asked yet."""
        if not self.settings.ask_on_arrival or self.state != READY:
            return []
        self._asked_at = now
        return [Request()]
