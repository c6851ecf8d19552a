"""
The original room -> table experiment, end to end in one process (``make demo``).

What runs (all real, nothing mocked but RViz and the person):

* the pipeline nodes (lsl_gaze_bridge, camera_tracker, marker_projector,
  choice_arbiter, choice_menu: :func:`eye_bci_ros2.nodes.eye_bci.make_pipeline_nodes`)
  and ``sim_rviz_view`` (the simulated RViz camera, animated moves) on one
  rclpy executor, on a real ROS 2 graph in a private domain id (from
  ``domain_coordinator``, so two demos or tests never cross-talk);
* a simulated person with an eye tracker (:class:`eye_bci_ros2.sim.gaze_outlet.GazeStreamer`,
  the ``original_tobii_4c`` preset by default, seeded) streaming over real
  LSL with a source_id unique to this run; the bridge accepts only that one;
* the experiment: a script of (room, table) pairs (seeded, covering
  different rooms).  For each pair the menu offers the rooms, the person looks
  at the scripted room, the arbiter decides, the menu zooms into the chosen
  room and offers its tables, the person looks at the scripted table, the
  arbiter decides again; the menu asks to confirm the table ('go' / 'back':
  the person looks at 'go' when the table chosen is the scripted one, else
  at 'back'; after 'go', at 'send', the second look that appears then),
  sends the robot (``sim_robot``, the simulated nav2 robot on the scene's map,
  driving ``robot_time_scale`` times faster than real time so the demo stays
  quick) and offers 'stop' while it drives: the person looks
  away (at a corner of the screen, off the panel: that neither stops nor
  sends it), and the menu offers the rooms again when it has arrived.

The person looks at the script's target, never at the system's decisions:
the target's screen point is computed from what the simulated screen shows
(the current ``rviz/current_camera_pose`` of the simulated RViz, the analytic
RViz projection, the true panel offset, and the marker the menu currently
shows on ``choices``), not from ``choices/regions``.  While the camera moves
the target moves with the marker.  If the system picks the wrong room, the
scripted table is not on the screen: the person then looks at the table with
the same number in the room shown; if it picks ``back``, the rooms come again
and the person looks at the scripted room again.

The protocol is the shipped nodes' (:mod:`eye_bci_ros2.task.menu`): the
``choice_menu`` asks (``choice/request``) only once the camera has arrived
at the view of the new options (from ``camera/pose``) and the gaze has left
the option just chosen (or ``look_away_s`` passed), and acts only on a choice
that answers the question (``choice_menu/answer``).  The driver here asks
nothing: it is the scripted person and the experimenter's notebook.  A
selection is an answer the menu acted on; the arbiter's rounds without a
choice in between are counted (``no_choice_rounds``), their time is in the
selection's.  ``--ask on-change`` sets the menu's ``ask_on_arrival`` false
(every valid choice counts at once, as before the protocol) and shows what
the protocol prevents: rounds that start while the camera still moves.

Each selection is printed; at the end a summary: accuracy, mean decision
time (question to answer), mean time per selection (new options on the
screen, camera move and look-away included, to the answer) and the
information transfer rate by Wolpaw's formula with the latter.  ``demo_output/`` receives a
picture of the screen per selection, ``summary.json`` and ``selections.csv``.
"""

import argparse
from contextlib import contextmanager
import csv
from dataclasses import asdict, dataclass, field, replace
import json
import math
import os
import sys
import time
from typing import Dict, Iterator, List, Optional, Sequence, Tuple
import uuid

from domain_coordinator import domain_id
from geometry_msgs.msg import Pose
from nav2_msgs.action import NavigateToPose
from nav_msgs.msg import OccupancyGrid, Path
import numpy as np
import pylsl
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState, PointCloud2
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.decision.evidence import Decision
from eye_bci_ros2.decision.fusion import GAZE, HYBRID, INPUT_MODES
from eye_bci_ros2.decision.regions import classify_against_history, RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, METHODS
from eye_bci_ros2.experiments import render as demo_render
from eye_bci_ros2.experiments import session_report
from eye_bci_ros2.experiments.metrics import itr_bits_per_minute
from eye_bci_ros2.navigation.occupancy import yaw_of
from eye_bci_ros2.nodes.eye_bci import make_pipeline_nodes, NODE_NAMES
from eye_bci_ros2.nodes.ssvep_decoder import SsvepDecoder
from eye_bci_ros2.nodes.ssvep_stimulus_map import SsvepStimulusMap
from eye_bci_ros2.projection.camera_model import (DEFAULT_IMAGE_SIZE, DEFAULT_PANEL_OFFSET,
                                                  optical_pose_from_ogre, RVIZ_FOV_Y_DEG,
                                                  RvizCamera)
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING
from eye_bci_ros2.recordings.lab_recorder import describe, LabRecording
from eye_bci_ros2.recordings.session_markers import STREAM_PREFIX as MARKER_STREAM_PREFIX
from eye_bci_ros2.ros.conversions import (gaze_batch_arrays, marker_array_to_regions,
                                          pose_to_arrays)
from eye_bci_ros2.ros.feedback_markers import option_label, OptionMarkers
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.ros.runner import make_executor, spin_for, spin_until as _spin_until
from eye_bci_ros2.ros.ssvep_messages import msg_to_stimulus_map
from eye_bci_ros2.ros.startup import quiet_liblsl
from eye_bci_ros2.ros.topics import (ACTION_FEEDBACK_QOS, CHOICES_TOPIC, CUE_TOPIC, EVENT_QOS,
                                     FEEDBACK_QOS, FEEDBACK_TOPIC, GAZE_QOS,
                                     GAZE_SAMPLES_TOPIC, LATCHED_QOS, MAP_QOS, MAP_TOPIC,
                                     MENU_ANSWER_TOPIC, MENU_PROGRESS_TOPIC, MENU_RESULT_TOPIC,
                                     NAVIGATE_TO_POSE_FEEDBACK_TOPIC, PLAN_QOS, PLAN_TOPIC,
                                     REGIONS_TOPIC, REQUEST_TOPIC, RVIZ_CAMERA_POSE_TOPIC,
                                     SSVEP_STIMULI_TOPIC)
from eye_bci_ros2.sim.eeg import EegSimulator, SUBJECTS
from eye_bci_ros2.sim.eeg_outlet import EegStreamer
from eye_bci_ros2.sim.gaze_outlet import GazeStreamer
from eye_bci_ros2.sim.person import GazeParams, ORIGINAL_TOBII_4C, PRESETS
from eye_bci_ros2.sim.robot import SimRobot
from eye_bci_ros2.sim.rviz_view import SimRvizView
from eye_bci_ros2.task.menu import BACK_LABEL, GO_LABEL, SEND_LABEL, STOP_LABEL
from eye_bci_ros2.task.scene import load_scene, Scene
from eye_bci_ros2.tools.session_record import open_session_bag, SessionRecorder

#: The person's screen, px (the Linux machine of the original report).
SCREEN_SIZE = (DEFAULT_VIEWING.width_px, DEFAULT_VIEWING.height_px)
#: The RViz render panel, px, and where its top-left sits on the screen (X0, Y0).
PANEL_SIZE = DEFAULT_IMAGE_SIZE
PANEL_OFFSET = DEFAULT_PANEL_OFFSET
#: Vertical field of view RViz renders with, degrees.
FOV_Y_DEG = RVIZ_FOV_Y_DEG
#: The longest a drive may take, wall-clock s (a cross-scene drive at real speed: ~40 s).
DRIVE_LIMIT_S = 180.0
#: Where the person looks before and after the experiment: a corner of the
#: screen, off the render panel, so no question can be answered by accident.
REST_XY = (160.0, 90.0)
#: A low-noise person for short runs (--quick): every choice should be right.
QUICK_PERSON = ORIGINAL_TOBII_4C.with_changes(
    offset_deg=0.3, jitter_deg=0.15, drift_deg=0.0, blink_rate_per_min=0.0, loss_prob=0.0,
    name='quick_low_noise')
#: When questions are asked (see the module doc).
ASK_MODES = ('on-arrival', 'on-change')
#: Answers per step the time limit of the whole run allows for.
MAX_ATTEMPTS = 3
#: Steps of a round: the room, the table, its confirmation ('go', 'send'), the drive.
STEPS_PER_ROUND = 5
#: What may choose (the arbiter's input_mode): fusion's modes.
INPUTS = INPUT_MODES
#: Gaze samples that must reach the pipeline before the experiment starts.
WARMUP_SAMPLES = 20
#: The session's bag in the output folder (``session_report`` reads it for the pictures),
#: and its LSL streams (gaze, EEG, markers) as LabRecorder wrote them.
BAG_NAME = 'session_bag'
XDF_NAME = 'session.xdf'
#: How long LabRecorder is given to take the last markers before it stops, s.
LAB_DRAIN_S = 0.5


class DemoError(RuntimeError):
    """Something the demo cannot continue after; the message says what and why."""


#: The choice_arbiter's defaults: the demo runs the node's default rule unless told.
_NODE_DEFAULTS = ArbiterSettings()


@dataclass
class DemoOptions:
    """
    Settings of one demo run (the command-line options).

    :ivar rounds: (room, table) pairs to choose.
    :ivar seed: seeds the script and the simulated person.
    :ivar method: decision rule at the window end, 'mean' (original) or 'vote'.
    :ivar early: let the arbiter decide early when confident.
    :ivar window_s: gaze collection window of a round, s.
    :ivar output_dir: where pictures and summaries go ('' = none written).
    :ivar preset: simulated person and tracker (gaze_model preset name, or
        'quick_low_noise').
    :ivar ask: 'on-arrival' (the menu's protocol: ask once the camera has
        arrived) or 'on-change' (the menu's ``ask_on_arrival`` false).
    :ivar transition_s: duration of the simulated RViz camera moves, s.
    :ivar timeout_s: longest wait for one decision, s (twice that for SSVEP input).
    :ivar stream_timeout_s: longest wait for the first gaze over LSL, s.
    :ivar pictures: write a PNG per selection.
    :ivar verbose: show the nodes' INFO log lines (else warnings and errors only).
    :ivar input_mode: what chooses: 'gaze', 'ssvep' (the SSVEP decoder on simulated EEG) or
        'hybrid' (a gaze candidate confirmed by SSVEP), the arbiter's ``input_mode``.
    :ivar subject: simulated EEG subject (eye_bci_ros2.sim.eeg.SUBJECTS name).
    :ivar robot_time_scale: the simulated robot drives this many times faster than real
        time (sim_robot ``time_scale``); ``drive_s`` is the robot's own time.
    """

    rounds: int = 4
    seed: int = 0
    method: str = _NODE_DEFAULTS.method
    early: bool = _NODE_DEFAULTS.early_decision
    window_s: float = 1.0
    output_dir: str = 'demo_output'
    preset: str = ORIGINAL_TOBII_4C.name
    ask: str = 'on-arrival'
    transition_s: float = 0.5
    timeout_s: float = 15.0
    stream_timeout_s: float = 15.0
    pictures: bool = True
    verbose: bool = False
    input_mode: str = GAZE
    subject: str = 's4'
    robot_time_scale: float = 10.0


@dataclass
class Selection:
    """
    One answer the menu acted on: the question, the person's intent, the system's choice.

    Times are s; screen points px.  ``time_to_decision_s`` is the arbiter's
    (sample time from its round start to the last sample used);
    ``decision_time_s`` runs from the question (``choice/request``) to the
    answer; ``selection_time_s`` from the moment the options appeared (camera
    move included) to the answer.  ``no_choice_rounds``: the arbiter's rounds
    that ended without a choice while the question was open.
    """

    round_index: int
    step: str
    attempt: int
    offered: List[str]
    intended: str
    chosen: Optional[str]
    method: str
    samples_used: int
    in_region_samples: int
    time_to_decision_s: float
    decision_time_s: float
    selection_time_s: float
    target_xy: Optional[Tuple[float, float]]
    mean_point: Optional[Tuple[float, float]]
    counts: Dict[str, int]
    reason: str
    camera_eye: Tuple[float, float, float]
    no_choice_rounds: int = 0
    #: Gaze samples the picture shows, and of those counted for an option (must equal
    #: ``samples_used`` and ``in_region_samples``: the picture says what the terminal says).
    picture_samples: int = 0
    picture_counted: int = 0
    picture: str = ''
    #: A confirmed table's drive: goal [x, y, yaw], arrived, drive_s (the robot's time),
    #: path_m (driven, from odometry), picture; None for other selections.
    robot: Optional[dict] = None
    # Drawing data, not written to the summary.
    screen: Optional[demo_render.ScreenPicture] = field(default=None, repr=False)
    drive: Optional[demo_render.DrivePicture] = field(default=None, repr=False)

    @property
    def correct(self) -> bool:
        """Tell whether the system chose what the person meant."""
        return self.chosen is not None and self.chosen == self.intended

    def as_row(self) -> dict:
        """Return the record as plain data (JSON/CSV)."""
        row = {key: value for key, value in asdict(self).items()
               if key not in ('screen', 'drive')}
        row['correct'] = self.correct
        return row


@dataclass
class DemoResult:
    """What a demo run produced."""

    options: DemoOptions
    person: str
    source_id: str
    script: List[Tuple[str, str]]
    selections: List[Selection]
    outcomes: List[str]
    accuracy: float
    mean_decision_s: float
    mean_time_s: float
    itr_bits_per_min: float
    files: List[str]
    #: The report of the recorded session (session_report), None when nothing was written.
    report: Optional[session_report.Report] = None


@contextmanager
def demo_domain() -> Iterator[int]:
    """
    Yield the ROS domain of the demo's graph: ``$ROS_DOMAIN_ID`` when set, else a free one.

    A user who set ROS_DOMAIN_ID (to watch the demo with ``ros2 topic echo``,
    or to keep off a shared network's graph) gets that domain; otherwise one
    that no other test or demo on this machine uses (domain_coordinator).
    """
    named = os.environ.get('ROS_DOMAIN_ID', '').strip()
    if named:
        yield int(named)
        return
    with domain_id() as domain:
        yield domain


def make_script(scene: Scene, rounds: int, seed: int) -> List[Tuple[str, str]]:
    """
    Draw the (room label, table name) pairs the person will choose.

    Rooms are visited in a seeded random order, all before any repeats; the
    table numbers are balanced the same way, so a few rounds cover different
    rooms and different tables.

    :raises ValueError: rounds < 1.
    """
    if rounds < 1:
        raise ValueError(f'need at least one round, got {rounds}')
    rng = np.random.default_rng(seed)
    script = []
    rooms: List[int] = []
    tables: List[int] = []
    for _ in range(rounds):
        if not rooms:
            rooms = [int(i) for i in rng.permutation(len(scene.rooms))]
        room = scene.rooms[rooms.pop(0)]
        if not tables:
            tables = [int(i) for i in rng.permutation(max(len(r.tables) for r in scene.rooms))]
        table = room.tables[tables.pop(0) % len(room.tables)]
        script.append((room.name, table.name))
    return script


def person_params(name: str) -> GazeParams:
    """Return the gaze preset called ``name`` (see :data:`PRESETS`, plus quick_low_noise)."""
    presets = dict(PRESETS)
    presets[QUICK_PERSON.name] = QUICK_PERSON
    if name not in presets:
        raise ValueError(f"unknown person preset '{name}': use one of {', '.join(presets)}")
    return presets[name]


def _length(points: np.ndarray) -> float:
    """Return the length of a polyline (N, 2), m."""
    steps = np.diff(np.asarray(points, dtype=float).reshape(-1, 2), axis=0)
    return float(np.sum(np.hypot(steps[:, 0], steps[:, 1])))


def _seconds(stamp) -> float:
    """builtin_interfaces/Time -> float s."""
    return stamp.sec + stamp.nanosec * 1e-9


def floor_polygons(scene: Scene, camera: RvizCamera) -> List[Tuple[str, np.ndarray]]:
    """Screen outlines (K, 2) px of the rooms' floor areas seen by ``camera``."""
    floors = []
    for room in scene.rooms:
        if room.area is None:
            continue
        x_min, y_min, x_max, y_max = room.area
        corners = np.array([[x_min, y_min, 0.0], [x_max, y_min, 0.0],
                            [x_max, y_max, 0.0], [x_min, y_max, 0.0]])
        uv, depth = camera.project(corners)
        if np.all(depth > 0):
            floors.append((room.name, camera.to_screen(uv)))
    return floors


class ExperimentDriver(Node):
    """
    The simulated person and the experimenter's notebook, as a node.

    Watches what the (simulated) screen shows and makes the person look at
    the scripted marker; records the offered choices, the questions the menu
    asks, the gaze the pipeline received, the arbiter's decisions and the
    menu's answers (module doc).  It asks nothing.
    """

    def __init__(self, scene: Scene, script: List[Tuple[str, str]], streamer: GazeStreamer,
                 arbiter, options: DemoOptions, eeg=None, menu=None, **kwargs):
        """
        Subscribe to what the screen shows and what the system decides.

        :param arbiter: the ChoiceArbiter node of this process (its
            ``last_decision`` is read after every callback).
        :param eeg: the simulated EEG (an EegStreamer) for the ssvep and hybrid inputs:
            it shows the stimuli of ``ssvep/stimuli`` and attends the intended option.
        :param menu: the ChoiceMenu node of this process (its state, for messages).
        :param kwargs: passed to :class:`rclpy.node.Node`.
        """
        super().__init__('demo_experiment', **kwargs)
        self.scene = scene
        self.script = script
        self.streamer = streamer
        self.arbiter = arbiter
        self.menu = menu
        self.options = options
        self._base_camera = RvizCamera.from_look_at(
            *scene.overview.as_tuple(), image_size=PANEL_SIZE, fov_y_deg=FOV_Y_DEG,
            screen_offset=PANEL_OFFSET)
        self.camera: Optional[RvizCamera] = None
        # The options on choices, and by label: (position (3,), quaternion xyzw (4,),
        # scale (3,), colour rgba (4,)).
        self._choices = OptionMarkers()
        self.markers: Dict[str, tuple] = {}
        self.offered: Tuple[str, ...] = ()
        self.region_history: List[RegionSet] = []
        self.gaze_stamps: List[float] = []
        self.gaze_points: List[Tuple[float, float]] = []
        self.outcomes: List[str] = []
        self.selections: List[Selection] = []
        self.running = False
        self.finished = False
        self.intended: Optional[str] = None
        self.round_index = 0
        self.step = 'rooms'
        # ROS-clock times, s: options shown, the menu's last question (None: not asked).
        self.shown_at = math.nan
        self.asked_at: Optional[float] = None
        self._seen_decision: Optional[Decision] = None
        self._no_choice = 0
        self._target_path: List[Tuple[float, float, float]] = []
        self.create_subscription(Empty, REQUEST_TOPIC, self._on_request, EVENT_QOS)
        # The feedback halos (choices/feedback) as RViz would show them.
        self.halos = OptionMarkers()
        self.create_subscription(MarkerArray, FEEDBACK_TOPIC, self._on_feedback, FEEDBACK_QOS)
        self.create_subscription(String, MENU_ANSWER_TOPIC, self._on_answer, EVENT_QOS)
        self.create_subscription(MarkerArray, CHOICES_TOPIC, self._on_choices, LATCHED_QOS)
        self.create_subscription(Pose, RVIZ_CAMERA_POSE_TOPIC, self._on_camera, LATCHED_QOS)
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)
        self.create_subscription(PointCloud2, GAZE_SAMPLES_TOPIC, self._on_gaze, GAZE_QOS)
        self.create_subscription(String, MENU_RESULT_TOPIC, self._on_result, EVENT_QOS)
        # The cue (the option the script asks for), recorded for the session's report.
        self._cue = self.create_publisher(String, CUE_TOPIC, LATCHED_QOS)
        self.eeg = eeg
        # Answers the menu acted on, not yet recorded (label, ROS time s).
        self._answers: List[Tuple[str, float]] = []
        # The robot: where the navigation's feedback put it (ROS time s, x, y, yaw in the
        # map frame), the newest plan (M, 2) and map, the menu's progress lines; the table
        # waiting for 'go' and the drive under way (its table selection and when 'go' was
        # answered).
        self.robot_path: List[Tuple[float, float, float, float]] = []
        self.plan = np.zeros((0, 2))
        self.map: Optional[OccupancyGrid] = None
        self.progress: List[str] = []
        self._pending: Optional[str] = None
        # ... and the number of progress lines before it.
        self._drive: Optional[Tuple[Selection, float, int]] = None
        self._withdrawn_at = math.nan
        # The action's feedback topic: any node may listen (as `ros2 action send_goal
        # --feedback` shows it); current_pose is the robot in the map frame.
        self.create_subscription(NavigateToPose.Impl.FeedbackMessage,
                                 NAVIGATE_TO_POSE_FEEDBACK_TOPIC, self._on_robot_feedback,
                                 ACTION_FEEDBACK_QOS)
        self.create_subscription(Path, PLAN_TOPIC, self._on_plan, PLAN_QOS)
        self.create_subscription(OccupancyGrid, MAP_TOPIC, self._on_map, MAP_QOS)
        self.create_subscription(String, MENU_PROGRESS_TOPIC, self._on_progress, LATCHED_QOS)
        if eeg is not None:
            self.create_subscription(JointState, SSVEP_STIMULI_TOPIC, self._on_stimuli,
                                     LATCHED_QOS)

    def now_s(self) -> float:
        """Return the ROS clock (the clock of the gaze and region stamps), s."""
        return self.get_clock().now().nanoseconds * 1e-9

    @property
    def question_start(self) -> float:
        """Return when the open question was asked (ROS clock, s; the options' time if later)."""
        asked = self.asked_at if self.asked_at is not None else self.shown_at
        return max(asked, self.shown_at) if math.isfinite(self.shown_at) else asked

    # -- what the screen shows ------------------------------------------------------------

    def _on_choices(self, message: MarkerArray) -> None:
        # The options as RViz shows them (OptionMarkers: RViz2's semantics, a DELETEALL
        # clears its namespace only), seen by label.
        for problem in self._choices.apply(message):
            self.get_logger().warning(f'choices: {problem}')
        self.markers = {}
        for marker in self._choices.options:
            position, quaternion = pose_to_arrays(marker.pose)
            scale = np.array([marker.scale.x, marker.scale.y, marker.scale.z])
            colour = (marker.color.r, marker.color.g, marker.color.b, marker.color.a)
            self.markers[option_label(marker)] = (position, quaternion, scale, colour)
        labels = tuple(self.markers)
        if not labels and self.offered:
            # Withdrawn while the camera moves: the step began here (the move is part of it).
            self._withdrawn_at = self.now_s()
        if set(labels) != set(self.offered):
            self.offered = labels
            if self.running and labels:
                self._new_question()
        self._look()

    def _on_camera(self, message: Pose) -> None:
        position, quaternion = pose_to_arrays(message)
        try:
            position, quaternion = optical_pose_from_ogre(position, quaternion)
            self.camera = self._base_camera.with_pose(position, quaternion)
        except ValueError as error:
            self.get_logger().warning(f'camera pose ignored: {error}')
            return
        self._look()

    def _on_regions(self, message: MarkerArray) -> None:
        labels, polygons = marker_array_to_regions(message)
        stamp = _seconds(message.markers[0].header.stamp) if message.markers else self.now_s()
        self.region_history.append(RegionSet(labels, polygons, stamp))

    def _on_feedback(self, message: MarkerArray) -> None:
        self.halos.apply(message)

    def _on_request(self, message: Empty) -> None:
        """Note when the menu asks its question (the arbiter starts a round)."""
        self.asked_at = self.now_s()

    def _on_answer(self, message: String) -> None:
        """Keep a choice the menu acted on, for :meth:`poll` (after the arbiter's callback)."""
        self._answers.append((message.data, self.now_s()))

    def _on_gaze(self, message: PointCloud2) -> None:
        stamps, points = gaze_batch_arrays(message)
        self.gaze_stamps.extend(stamps.tolist())
        self.gaze_points.extend(map(tuple, points.tolist()))

    def _on_stimuli(self, message: JointState) -> None:
        """Flicker what the task assigned, on the simulated EEG's clock (LSL)."""
        stimuli = msg_to_stimulus_map(message)
        to_lsl = pylsl.local_clock() - self.now_s()
        self.eeg.show(replace(stimuli, epoch_s=stimuli.epoch_s + to_lsl))

    def _on_result(self, message: String) -> None:
        self.outcomes.append(message.data)

    def _on_robot_feedback(self, message) -> None:
        position, quaternion = pose_to_arrays(message.feedback.current_pose.pose)
        self.robot_path.append((self.now_s(), float(position[0]), float(position[1]),
                                yaw_of(quaternion)))

    def _on_plan(self, message: Path) -> None:
        if message.poses:       # the drive's plan (an empty one clears RViz's after a stop)
            self.plan = np.array([[p.pose.position.x, p.pose.position.y]
                                  for p in message.poses]).reshape(-1, 2)

    def _on_map(self, message: OccupancyGrid) -> None:
        self.map = message

    def _on_progress(self, message: String) -> None:
        """Take the menu's word on the robot: when the drive ended (arrived, stopped, failed)."""
        self.progress.append(message.data)
        if self._drive is None or self.menu is None or self.menu.driving:
            return      # on its way ("driving to", "no feedback from the robot", ...)
        selection, sent_at, lines_before = self._drive
        self._drive = None
        # What the menu said on the way: a silence ("no feedback from the robot ...").
        said = [line for line in self.progress[lines_before:]
                if line.startswith(('no feedback', 'no answer'))]
        now = self.now_s()
        goal = self.menu.robot_goals.get(selection.chosen)
        goals = [] if goal is None else [np.asarray(goal, dtype=float)]
        driven = np.array([o[1:] for o in self.robot_path if sent_at <= o[0] <= now]
                          ).reshape(-1, 3)
        if len(self.plan) and len(driven):
            # From where the robot started (the plan's start) to where feedback last put it.
            driven = np.vstack([[*self.plan[0], driven[0, 2]], driven])
        arrived = message.data.startswith('arrived')
        selection.robot = {
            'goal': [round(float(v), 4) for v in goals[0]] if goals else None,
            'arrived': arrived, 'drive_s': (now - sent_at) * self.options.robot_time_scale,
            'path_m': _length(driven[:, :2]), 'plan_m': _length(self.plan),
            'silences': said, 'picture': '', 'progress': message.data}
        selection.drive = self._drive_picture(selection, driven, goals)
        if arrived:
            self.round_index += 1
            if self.round_index >= len(self.script):
                self.finish()

    def _drive_picture(self, selection: Selection, driven: np.ndarray,
                       goals: List[np.ndarray]) -> demo_render.DrivePicture:
        robot = selection.robot
        occupancy, origin, resolution = None, (0.0, 0.0), 0.05
        if self.map is not None:
            info = self.map.info
            occupancy = np.array(self.map.data, dtype=np.int16).reshape(
                info.height, info.width)
            origin = (info.origin.position.x, info.origin.position.y)
            resolution = info.resolution
        tables = [(t.marker.text, (float(t.marker.position[0]), float(t.marker.position[1])))
                  for room in self.scene.rooms for t in room.tables]
        verdict = 'ARRIVED' if robot['arrived'] else 'NOT ARRIVED'
        return demo_render.DrivePicture(
            title=f"Round {selection.round_index}: the robot to '{selection.chosen}' -> "
                  f'{verdict}',
            details=[f"confirmed with 'go'; {robot['path_m']:.1f} m driven in "
                     f"{robot['drive_s']:.1f} s (robot time; the simulation ran "
                     f'{self.options.robot_time_scale:g}x real time); menu: '
                     f"{robot['progress']}"],
            occupancy=occupancy, origin=origin, resolution=resolution, tables=tables,
            path=driven[:, :2], plan=self.plan.copy(), goal=goals[0] if goals else None,
            robot=driven[-1] if len(driven) else None)

    # -- the person -----------------------------------------------------------------------

    def target_xy(self) -> Optional[np.ndarray]:
        """Return where the intended marker's centre is on the screen now, px, or None."""
        if self.intended is None or self.camera is None or self.intended not in self.markers:
            return None
        position = self.markers[self.intended][0]
        uv, depth = self.camera.project(position[None, :])
        if not depth[0] > 0 or not self.camera.in_image(uv)[0]:
            return None
        return self.camera.to_screen(uv[0])

    def _look(self) -> None:
        """Point the person's eyes at the intended marker (it may be moving)."""
        if not self.running:
            return
        xy = self.target_xy()
        if xy is None:
            return  # not on the screen (yet): keep looking where they were
        self.streamer.set_target(xy, pylsl.local_clock())
        if self.eeg is not None:
            self.eeg.attend(self.intended, pylsl.local_clock())
        self._target_path.append((self.now_s(), float(xy[0]), float(xy[1])))

    def _new_question(self) -> None:
        """Work out what the person wants from the options now shown."""
        room, table = self.script[self.round_index]
        labels = set(self.offered)
        if labels == set(self.scene.room_labels):
            self.step, self.intended = 'rooms', room
        elif labels == {GO_LABEL, BACK_LABEL}:
            # Seen which table was chosen: 'go' if it is the one meant, else 'back'.
            self.step = 'confirm'
            self.intended = GO_LABEL if self._pending == f'{room}/{table}' else BACK_LABEL
        elif labels == {SEND_LABEL, BACK_LABEL}:
            # After 'go': the second look, at 'send' where it appeared (if 'go' was meant;
            # else 'back', on the 'go' just chosen).
            self.step = 'send'
            self.intended = SEND_LABEL if self._pending == f'{room}/{table}' else BACK_LABEL
        elif labels == {STOP_LABEL}:
            # The robot drives: the person looks away from 'stop' (off the panel).
            self.step, self.intended = 'drive', None
            self.streamer.set_target(REST_XY, pylsl.local_clock())
            if self.eeg is not None:
                self.eeg.attend(None)
        else:
            shown_room = next(label for label in self.offered if '/' in label).split('/')[0]
            self.step, self.intended = 'tables', f'{shown_room}/{table}'
        now = self.now_s()
        self.shown_at = self._withdrawn_at if math.isfinite(self._withdrawn_at) else now
        self._withdrawn_at = math.nan
        self._no_choice = 0
        self._target_path = []
        self._cue.publish(String(data=self.intended or ''))

    # -- the experiment -------------------------------------------------------------------

    def ready(self) -> bool:
        """Tell whether gaze flows, the screen is known and the start-up round has closed."""
        return (len(self.gaze_stamps) >= WARMUP_SAMPLES and self.camera is not None
                and set(self.offered) == set(self.scene.room_labels)
                and self.arbiter.last_decision is not None)

    def begin(self) -> None:
        """Start the script: the person looks at the first room (the menu asks)."""
        self._seen_decision = self.arbiter.last_decision
        self.running = True
        self.round_index = 0
        self._answers = []
        self._new_question()
        self._look()

    def poll(self) -> Optional[Selection]:
        """
        Count the arbiter's rounds; record the menu's answer, move the script on.

        :returns: the new selection, or None.
        :raises DemoError: no answer within the timeout.
        """
        if not self.running:
            return None
        decision = self.arbiter.last_decision
        if decision is not self._seen_decision:
            self._seen_decision = decision
            if decision is not None and decision.label is None and self.asked_at is not None:
                self._no_choice += 1
        if not self._answers and self.step == 'drive':
            if self._drive is not None and self.now_s() - self._drive[1] > DRIVE_LIMIT_S:
                raise DemoError(f'the robot has not ended its drive to '
                                f"'{self._drive[0].chosen}' within {DRIVE_LIMIT_S:g} s "
                                f'(menu: {self.progress[-1:]})')
            return None     # the navigation's result ends the drive
        if not self._answers:
            elapsed = self.now_s() - self.shown_at
            # SSVEP waits for the response to build up (the decoder's onset_s) and a
            # window of EEG each time it is asked: twice the time.
            timeout = self.options.timeout_s * (1 if self.options.input_mode == GAZE else 2)
            if elapsed > timeout:
                raise DemoError(
                    f'no answer within {timeout:g} s of the options '
                    f'appearing (round {self.round_index + 1}, {self.step}; menu state '
                    f"'{self.menu_state()}'; {self._no_choice} rounds without a choice); gaze "
                    f'samples received so far: {len(self.gaze_stamps)}')
            return None
        label, answered_at = self._answers.pop(0)
        # The arbiter's decision the menu acted on (its choice), else one naming the answer.
        gaze = decision if decision is not None and decision.label == label else None
        if gaze is None:
            gaze = Decision(label, self.options.input_mode, 0, 0, 0.0, math.nan)
        elif self.options.input_mode != GAZE:
            gaze = replace(gaze, method=self.options.input_mode)
        selection = self._record(gaze, answered_at)
        self.selections.append(selection)
        if self.step == 'tables' and label != BACK_LABEL:
            self._pending = label
        elif (self.step == 'confirm' and label == GO_LABEL and not self._send_rounds()) or (
                self.step == 'send' and label == SEND_LABEL):
            table = next(s for s in reversed(self.selections) if s.step == 'tables')
            self._drive = (table, answered_at, len(self.progress))
        # The round ends when the robot has arrived (_on_progress).
        return selection

    def _send_rounds(self) -> int:
        """Return the menu's send_rounds (0: 'go' sends the robot at once)."""
        return int(self.menu.get_parameter('send_rounds').value) if self.menu is not None \
            else 0

    def menu_state(self) -> str:
        """Return what the menu waits for (its node's state), '' when unknown."""
        return getattr(self.menu, 'state', '') if self.menu is not None else ''

    def finish(self) -> None:
        """Stop the experiment: the person looks away from the panel."""
        self.running = False
        self.finished = True
        self.intended = None
        self._cue.publish(String(data=''))
        self.streamer.set_target(REST_XY, pylsl.local_clock())
        if self.eeg is not None:
            self.eeg.attend(None)

    def _record(self, decision: Decision, now: float) -> Selection:
        """Turn the answer's decision into a Selection with its picture data."""
        start = self.question_start
        attempt = 1 + sum(1 for earlier in self.selections
                          if (earlier.round_index, earlier.step) == (self.round_index + 1,
                                                                     self.step))
        target = self.target_xy()
        if target is None and self._target_path:
            target = np.array(self._target_path[-1][1:])
        selection = Selection(
            round_index=self.round_index + 1, step=self.step, attempt=attempt,
            offered=list(self.offered), intended=self.intended, chosen=decision.label,
            method=decision.method, samples_used=decision.samples_used,
            in_region_samples=decision.in_region_samples,
            time_to_decision_s=float(decision.time_to_decision),
            decision_time_s=now - start, selection_time_s=now - self.shown_at,
            target_xy=None if target is None else (float(target[0]), float(target[1])),
            mean_point=decision.mean_point, counts=dict(decision.counts),
            reason=decision.reason, camera_eye=tuple(float(v) for v in self.camera.eye),
            no_choice_rounds=self._no_choice)
        selection.screen = self._picture(selection, decision, start)
        selection.picture_samples = len(selection.screen.gaze)
        selection.picture_counted = int(np.count_nonzero(selection.screen.gaze_in_region))
        return selection

    def _picture(self, selection: Selection, decision: Decision,
                 start: float) -> demo_render.ScreenPicture:
        """Collect what the screen showed during the selection and where the gaze fell."""
        # The samples the decision weighed: from its round's start to its last sample.
        if math.isfinite(decision.round_start):
            start = decision.round_start
        end = start + (decision.time_to_decision if math.isfinite(decision.time_to_decision)
                       else self.options.window_s)
        stamps = np.array(self.gaze_stamps)
        points = np.array(self.gaze_points, dtype=float).reshape(-1, 2)
        use = (stamps >= start) & (stamps <= end + 1e-9) & (stamps < start + self.options.window_s)
        stamps, points = stamps[use], points[use]
        settings = self.arbiter.settings
        inside = classify_against_history(stamps, points, self.region_history,
                                          settings.regions)
        if decision.weighed_stamps:
            # The fixation rule weighs one fixation: its samples are what counted.
            inside = np.isin(stamps, decision.weighed_stamps)
        # The outlines shown at the last sample used (the menu may have moved on since).
        shown = [r for r in self.region_history if r.stamp <= end] or self.region_history[:1]
        latest = shown[-1] if shown else RegionSet([], [])
        regions = dict(zip(latest.labels, latest.polygons))
        colours = {label: marker[3] for label, marker in self.markers.items()}
        # The target since the options appeared: it moves while the camera does.
        path = np.array([p[1:] for p in self._target_path if p[0] >= self.shown_at - 0.05])
        if selection.target_xy is not None:
            path = np.vstack([path.reshape(-1, 2), [selection.target_xy]])
        verdict = 'CORRECT' if selection.correct else (
            'NO CHOICE' if selection.chosen is None else 'WRONG')
        chosen = 'nothing' if selection.chosen is None else f"'{selection.chosen}'"
        title = (f'Round {selection.round_index}, {selection.step}'
                 f"{f' (attempt {selection.attempt})' if selection.attempt > 1 else ''}: "
                 f"intended '{selection.intended}', chosen {chosen} -> {verdict}")
        details = [
            f'{decision.method}: {decision.samples_used} gaze samples used, '
            f'{decision.in_region_samples} counted for an option; answered '
            f'{selection.decision_time_s:.2f} s after the question, '
            f'{selection.selection_time_s:.2f} s after the options appeared'
            + (f' ({decision.reason})' if decision.reason else ''),
            'samples per option: ' + (', '.join(demo_render.summarise_counts(decision.counts))
                                      or 'none')
            + (f'; {selection.no_choice_rounds} round(s) without a choice before'
               if selection.no_choice_rounds else ''),
        ]
        return demo_render.ScreenPicture(
            title=title, details=details, screen_size=SCREEN_SIZE,
            panel=(PANEL_OFFSET[0], PANEL_OFFSET[1], PANEL_SIZE[0], PANEL_SIZE[1]),
            floors=floor_polygons(self.scene, self.camera), regions=regions, colours=colours,
            gaze=points, gaze_in_region=inside, mean_point=decision.mean_point,
            chosen=decision.label, intended=selection.intended, target_path=path,
            rule=settings.describe(),
            halos=self._halos())

    def _halos(self) -> List[Tuple[np.ndarray, Tuple[float, float, float, float]]]:
        """Return the feedback halos shown now, as screen outlines with their colours."""
        markers = self.halos.options
        if self.camera is None or not markers:
            return []
        positions, quaternions = zip(*(pose_to_arrays(m.pose) for m in markers))
        polygons, visible = self.camera.box_regions(
            positions, quaternions, [(m.scale.x, m.scale.y, m.scale.z) for m in markers])
        return [(polygon, (m.color.r, m.color.g, m.color.b, m.color.a))
                for polygon, shown, m in zip(polygons, visible, markers) if shown]


def run_demo(options: DemoOptions, log=print) -> DemoResult:
    """
    Run the experiment and write its pictures and summary.

    :param options: the settings.
    :param log: where progress lines go (``print`` by default).
    :returns: the result.
    :raises DemoError: no gaze stream, no decision in time, too many retries.
    :raises ValueError: invalid options.
    """
    if options.method not in METHODS:
        raise ValueError(f"unknown method '{options.method}': use one of {', '.join(METHODS)}")
    if options.ask not in ASK_MODES:
        raise ValueError(f"unknown ask mode '{options.ask}': use one of {', '.join(ASK_MODES)}")
    if not 0 < options.window_s <= 60:
        raise ValueError(f'window must be in (0, 60] s, got {options.window_s}')
    if not 0 <= options.transition_s <= 60:
        raise ValueError(f'camera move time must be in [0, 60] s, got {options.transition_s}')
    if not (options.timeout_s > 0 and options.stream_timeout_s > 0):
        raise ValueError('timeouts must be > 0 s')
    if not 0.1 <= options.robot_time_scale <= 100:
        raise ValueError(f'robot time scale must be in [0.1, 100], got '
                         f'{options.robot_time_scale}')
    person = person_params(options.preset)
    scene_path = default_scene_path()
    scene = load_scene(scene_path)
    script = make_script(scene, options.rounds, options.seed)
    source_id = f'eye_bci_demo-{uuid.uuid4()}'

    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    asking = {'on-arrival': "the menu's protocol: asked (choice/request) once the camera has "
                            'arrived and the gaze has left the last choice',
              'on-change': 'every valid choice counts at once (menu ask_on_arrival false)'}
    log(f'questions: {asking[options.ask]}; camera moves take {options.transition_s:g} s; '
        "each table is confirmed ('go') before the simulated robot drives there, "
        f'{options.robot_time_scale:g}x faster than real time')
    log('script: ' + ', '.join(f'{room}/{table}' for room, table in script))
    # Lost samples are left out, as the original C# sender (Tobii's gaze point
    # stream) delivers only valid gaze.
    streamer = GazeStreamer(params=person, seed=options.seed, source_id=source_id,
                            initial_xy=REST_XY, send_lost=False)
    log(streamer.describe())

    # Logger levels are process-wide: quiet the nodes for the run, then put them back.
    quiet = () if options.verbose else NODE_NAMES + ('choice_menu', 'sim_rviz_view',
                                                     'sim_robot', 'demo_experiment')
    levels = {name: rclpy.logging.get_logger_level(name) for name in quiet}
    for name in quiet:
        rclpy.logging.set_logger_level(name, rclpy.logging.LoggingSeverity.WARN)
    with demo_domain() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        executor = make_executor(context=context)
        nodes: List[Node] = []
        eeg = None
        eeg_id = ''
        lab = None
        # The session's marker stream, named for this run (LabRecorder records it by name).
        markers_name = f'{MARKER_STREAM_PREFIX} demo-{uuid.uuid4()}'
        try:
            nodes = make_pipeline_nodes(context, overrides={
                'session_markers': {'stream_name': markers_name},
                'lsl_gaze_bridge': {'source_id': source_id, 'stats_period_s': 0.0},
                'marker_projector': {
                    'image_width': PANEL_SIZE[0], 'image_height': PANEL_SIZE[1],
                    'fov_y_deg': FOV_Y_DEG, 'screen_offset_x': PANEL_OFFSET[0],
                    'screen_offset_y': PANEL_OFFSET[1]},
                'choice_arbiter': {'method': options.method, 'window_s': options.window_s,
                                   'early_decision': options.early,
                                   'input_mode': options.input_mode},
                'choice_menu': {'scene_file': scene_path, 'repeat': True,
                                'ask_on_arrival': options.ask == 'on-arrival'},
            }, with_menu=True)
            named = dict(zip(NODE_NAMES + ('choice_menu',), nodes))
            log(f"decision rule: {named['choice_arbiter'].settings.describe()}")
            view = SimRvizView(context=context, parameter_overrides=[
                Parameter('transition_time_s', value=float(options.transition_s))])
            nodes.append(view)
            nodes.append(SimRobot(context=context, parameter_overrides=[
                Parameter('scene_file', value=scene_path),
                Parameter('time_scale', value=float(options.robot_time_scale))]))
            if options.input_mode != GAZE:
                eeg_id = f'eye_bci_demo_eeg-{uuid.uuid4()}'
                subject = next(s for s in SUBJECTS if s.name == options.subject)
                eeg = EegStreamer(EegSimulator(subject, seed=options.seed), source_id=eeg_id)
                eeg.start()
                nodes.append(SsvepStimulusMap(context=context))
                nodes.append(SsvepDecoder(context=context, parameter_overrides=[
                    Parameter('source_id', value=eeg_id),
                    Parameter('keep_scoring', value=options.input_mode == HYBRID)]))
            driver = ExperimentDriver(scene, script, streamer, named['choice_arbiter'], options,
                                      eeg=eeg, menu=named['choice_menu'], context=context)
            nodes.append(driver)
            # The session recorded as a study records it (session_record, in this process).
            recorder = None
            if options.output_dir:
                recorder = SessionRecorder(open_session_bag(options.output_dir, BAG_NAME),
                                           context=context)
                nodes.append(recorder)
            for node in nodes:
                executor.add_node(node)
            log(f'ROS 2 domain {domain}: {", ".join(n.get_name() for n in nodes)} on one '
                f'executor; LSL source_id {source_id}')
            if recorder is not None and not _spin_until(executor, recorder.recording_all, 10.0):
                raise DemoError(f'session_record did not find the session topics: recording '
                                f"{', '.join(recorder.recorded) or 'nothing'}")
            streamer.start()
            if options.output_dir:
                lab = _lab_recording(os.path.join(options.output_dir, XDF_NAME),
                                     [source_id, eeg_id], markers_name, options.stream_timeout_s)
                log(f'LabRecorder records {", ".join(describe(s) for s in lab.streams)} into '
                    f'{lab.path}')
            _experiment(executor, driver, streamer, named['lsl_gaze_bridge'], options, log)
            # Let the menu's last result arrive.
            _spin_until(executor, lambda: len(driver.outcomes) >= len(script), 2.0)
            if recorder is not None:   # and the recorder take what the driver has seen
                _spin_until(executor, lambda: recorder.has_seen(
                    {MENU_PROGRESS_TOPIC: len(driver.progress),
                     MENU_RESULT_TOPIC: len(driver.outcomes)}), 2.0)
        finally:
            if lab is not None:   # while the outlets still stream
                # LabRecorder's inlets tell nothing of what they took: half a second for the
                # last markers (the arrival) to reach them before the footers are written.
                spin_for(executor, LAB_DRAIN_S)
                lab.stop()
            executor.shutdown()
            for node in nodes:
                node.destroy_node()
            # After the bridge (and the decoder) closed their inlets, so liblsl does not
            # report a broken stream (or crash, seen once with an outlet under a live inlet).
            streamer.stop()
            if eeg is not None:
                eeg.stop()
            context.try_shutdown()
            for name, level in levels.items():
                rclpy.logging.set_logger_level(name, level)

    return _summarise(options, person, source_id, script, driver, log)


def _lab_recording(path: str, source_ids: Sequence[str], markers_name: str,
                   timeout_s: float) -> LabRecording:
    """Record the run's gaze (and EEG) outlets and its marker stream with LabRecorder."""
    wanted = {source for source in source_ids if source}
    end = time.monotonic() + timeout_s
    while True:
        found = [info for info in pylsl.resolve_streams(1.0)
                 if info.source_id() in wanted or info.name() == markers_name]
        if len(found) > len(wanted) or time.monotonic() > end:
            break
    if len(found) <= len(wanted):
        raise DemoError(f"LabRecorder: the run's LSL streams were not all found within "
                        f'{timeout_s:g} s (found: {", ".join(map(describe, found)) or "none"})')
    return LabRecording(path, found)


def _experiment(executor, driver: ExperimentDriver, streamer: GazeStreamer, bridge,
                options: DemoOptions, log) -> None:
    """Wait for gaze, then run the script to the end."""
    start = time.monotonic()
    if not _spin_until(executor, lambda: len(driver.gaze_stamps) >= WARMUP_SAMPLES,
                       options.stream_timeout_s):
        if streamer.error is not None:
            raise DemoError(f'the simulated eye tracker failed: {streamer.error}')
        where = bridge.stream or 'no stream connected'
        raise DemoError(
            f'no gaze reached the pipeline within {options.stream_timeout_s:g} s '
            f"(LSL source_id '{driver.streamer.info.source_id()}'; bridge: {where}; "
            f"samples published: {bridge.counters['published']}): is LSL working on this "
            'machine (loopback multicast)?')
    if not _spin_until(executor, driver.ready, options.timeout_s):
        raise DemoError('the pipeline did not settle: no camera pose, no rooms offered or '
                        'the start-up round did not close')
    log(f'gaze flowing after {time.monotonic() - start:.1f} s; starting the experiment')
    driver.begin()
    printed = 0
    drives_printed = set()

    def poll():
        nonlocal printed
        driver.poll()
        while printed < len(driver.selections):
            _print_selection(driver.selections[printed], log)
            printed += 1
        for selection in driver.selections:
            if selection.robot is not None and id(selection) not in drives_printed:
                drives_printed.add(id(selection))
                _print_drive(selection, log)
        if streamer.error is not None:
            raise DemoError(f'the simulated eye tracker failed: {streamer.error}')

    # The driver raises DemoError on a per-question timeout; this bounds the whole run.
    limit = options.timeout_s * (STEPS_PER_ROUND * len(driver.script) * MAX_ATTEMPTS + 1)
    if not _spin_until(executor, lambda: driver.finished, limit, poll):
        raise DemoError(f'the experiment did not finish within {limit:g} s')


def _print_selection(selection: Selection, log) -> None:
    """Print one selection as it happens."""
    verdict = 'correct' if selection.correct else (
        'NO CHOICE' if selection.chosen is None else 'WRONG')
    retry = f', attempt {selection.attempt}' if selection.attempt > 1 else ''
    target = ('off screen' if selection.target_xy is None
              else f'({selection.target_xy[0]:.0f}, {selection.target_xy[1]:.0f}) px')
    log(f'round {selection.round_index} {selection.step}{retry}: offered '
        f'{", ".join(selection.offered)}')
    log(f"  person looks at '{selection.intended}' at {target}; system chose "
        f"'{selection.chosen}' -> {verdict}")
    log(f'  {selection.method}: {selection.samples_used} samples used '
        f'({selection.in_region_samples} counted for an option); answered '
        f'{selection.decision_time_s:.2f} s after the question, '
        f'{selection.selection_time_s:.2f} s after the options appeared'
        + (f'; {selection.no_choice_rounds} round(s) without a choice before'
           if selection.no_choice_rounds else '')
        + (f'; {selection.reason}' if selection.reason else ''))


def _print_drive(selection: Selection, log) -> None:
    """Print a drive once it has ended."""
    robot = selection.robot
    goal = robot['goal']
    where = ('no goal seen' if goal is None else
             f'goal ({goal[0]:.2f}, {goal[1]:.2f}) m, {math.degrees(goal[2]):.0f} deg')
    log(f"  robot to '{selection.chosen}': {where}; "
        f"{'arrived' if robot['arrived'] else 'NOT arrived'} after {robot['drive_s']:.1f} s "
        f"(robot time), {robot['path_m']:.1f} m driven (plan {robot['plan_m']:.1f} m)"
        + ''.join(f'; menu: {line}' for line in robot['silences']))


def _summarise(options: DemoOptions, person: GazeParams, source_id: str,
               script: List[Tuple[str, str]], driver: ExperimentDriver, log) -> DemoResult:
    """Compute the summary, write the files and print it."""
    selections = driver.selections
    correct = sum(s.correct for s in selections)
    accuracy = correct / len(selections) if selections else 0.0
    mean_decision = float(np.mean([s.decision_time_s for s in selections])) if selections \
        else math.nan
    mean_time = float(np.mean([s.selection_time_s for s in selections])) if selections \
        else math.nan
    itr = itr_bits_per_minute([len(s.offered) for s in selections], accuracy, mean_time)
    result = DemoResult(options=options, person=person.name, source_id=source_id,
                        script=script, selections=selections, outcomes=list(driver.outcomes),
                        accuracy=accuracy, mean_decision_s=mean_decision,
                        mean_time_s=mean_time, itr_bits_per_min=itr, files=[])
    if options.output_dir:
        result.files = _write_outputs(result, person)
    log(f'summary: {len(selections)} selections, {correct} correct: accuracy '
        f'{100 * accuracy:.1f} %; mean decision time {mean_decision:.2f} s (question to '
        f'decision); mean time per selection {mean_time:.2f} s (options shown to decision); '
        f'ITR {itr:.1f} bits/min (Wolpaw, N = choices offered, P = accuracy, T = time per '
        'selection)')
    log('outcomes (menu results): ' + (', '.join(result.outcomes) or 'none')
        + '; intended: ' + ', '.join(f'{room}/{table}' for room, table in script))
    if result.files:
        log(f'wrote {len(result.files)} files to {options.output_dir}/: '
            + ', '.join(os.path.basename(f) for f in result.files))
    return result


def _write_outputs(result: DemoResult, person: GazeParams) -> List[str]:
    """Write the pictures, summary.json and selections.csv; return their paths."""
    directory = result.options.output_dir
    os.makedirs(directory, exist_ok=True)
    # The pictures are the recorded session's report (session_report: the same for a study).
    report = session_report.build_report(session_report.read_session(
        os.path.join(directory, BAG_NAME)))
    files = session_report.write_report(report, directory, pictures=result.options.pictures)
    result.report = report
    rows = [s.as_row() for s in result.selections]
    summary = {
        'options': asdict(result.options), 'person': asdict(person),
        'lsl_source_id': result.source_id,
        'script': [f'{room}/{table}' for room, table in result.script],
        'outcomes': result.outcomes, 'selections': rows,
        'accuracy': result.accuracy, 'mean_decision_time_s': result.mean_decision_s,
        'mean_time_per_selection_s': result.mean_time_s,
        'itr_bits_per_min': result.itr_bits_per_min,
        'robot_time_scale': result.options.robot_time_scale,
        'itr_formula': 'Wolpaw: B = log2 N + P log2 P + (1-P) log2((1-P)/(N-1)), averaged '
                       'over selections (N = choices offered), ITR = B * 60 / T',
    }
    path = os.path.join(directory, 'summary.json')
    with open(path, 'w', encoding='utf-8') as stream:
        json.dump(summary, stream, indent=2, default=demo_render.json_default)
    files.append(path)
    path = os.path.join(directory, 'selections.csv')
    columns = ['round_index', 'step', 'attempt', 'intended', 'chosen', 'correct', 'method',
               'samples_used', 'in_region_samples', 'time_to_decision_s', 'decision_time_s',
               'selection_time_s',
               'offered', 'reason', 'picture', 'robot_goal', 'robot_arrived', 'robot_drive_s',
               'robot_path_m']
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        writer = csv.DictWriter(stream, fieldnames=columns, extrasaction='ignore')
        writer.writeheader()
        for row in rows:
            robot = row['robot'] or {}
            writer.writerow({**row, 'offered': ' '.join(row['offered']),
                             'picture': os.path.basename(row['picture']),
                             'robot_goal': ' '.join(f'{v:.4f}' for v in robot.get('goal') or ()),
                             'robot_arrived': robot.get('arrived', ''),
                             'robot_drive_s': robot.get('drive_s', ''),
                             'robot_path_m': robot.get('path_m', '')})
    files.append(path)
    return files


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line options of ``demo``."""
    parser = argparse.ArgumentParser(
        prog='demo', description='Run the original room -> table experiment end to end: the '
        'real nodes on a private ROS 2 graph, a simulated person streaming gaze over real LSL, '
        'a simulated RViz camera.',
        epilog='The simulated RViz uses the analytic RViz projection (1280x720 panel at '
               '(320, 180) on a 1920x1080 screen). Output: a PNG of the screen per '
               'selection, summary.json and selections.csv.')
    d = DemoOptions()
    parser.add_argument('--rounds', type=int, default=None,
                        help=f'(room, table) pairs to choose (default {d.rounds}; 1 with --quick)')
    parser.add_argument('--seed', type=int, default=d.seed,
                        help=f'seeds the script and the simulated person (default {d.seed})')
    parser.add_argument('--method', choices=METHODS, default=d.method,
                        help=f'decision rule; fixation = the node default, mean = the original '
                             f'(default {d.method})')
    parser.add_argument('--input', choices=INPUTS, default=d.input_mode,
                        help='what chooses: gaze, ssvep (simulated EEG and the SSVEP decoder) '
                             'or hybrid (gaze candidates confirmed by SSVEP) '
                             f'(default {d.input_mode})')
    parser.add_argument('--subject', default=d.subject,
                        choices=[subject.name for subject in SUBJECTS],
                        help='simulated EEG subject for --input ssvep/hybrid '
                             f'(default {d.subject})')
    parser.add_argument('--early', action=argparse.BooleanOptionalAction, default=d.early,
                        help='let the arbiter decide before the window ends when confident '
                             f'(default: {"on" if d.early else "off"}, as the node)')
    parser.add_argument('--ask', choices=ASK_MODES, default=d.ask,
                        help='when each question is asked: once the camera move has ended '
                             '(as in the original experiment) or when the options change '
                             f'(default {d.ask})')
    parser.add_argument('--transition-s', type=float, default=d.transition_s,
                        help=f'duration of the simulated RViz camera moves, s '
                             f'(default {d.transition_s:g})')
    parser.add_argument('--robot-time-scale', type=float, default=d.robot_time_scale,
                        help='the simulated robot drives this many times faster than real '
                             f'time (default {d.robot_time_scale:g})')
    parser.add_argument('--window-s', type=float, default=d.window_s,
                        help=f'gaze collection window per question, s (default {d.window_s:g})')
    parser.add_argument('--preset', default=None,
                        choices=sorted(PRESETS) + [QUICK_PERSON.name],
                        help=f'simulated person and tracker (default {d.preset}; '
                             f'{QUICK_PERSON.name} with --quick)')
    parser.add_argument('--output-dir', default=d.output_dir,
                        help=f"where pictures and summaries go; '' = nowhere "
                             f'(default {d.output_dir})')
    parser.add_argument('--no-pictures', action='store_true', help='skip the PNGs')
    parser.add_argument('--verbose', action='store_true',
                        help="show the nodes' INFO log lines")
    parser.add_argument('--quick', action='store_true',
                        help='a short run for tests: 1 round, a low-noise person')
    parser.add_argument('--timeout-s', type=float, default=d.timeout_s,
                        help=f'longest wait for one decision, s (default {d.timeout_s:g})')
    parser.add_argument('--stream-timeout-s', type=float, default=d.stream_timeout_s,
                        help=f'longest wait for gaze over LSL, s (default {d.stream_timeout_s:g})')
    return parser


def options_from_args(args: argparse.Namespace) -> DemoOptions:
    """Turn parsed arguments into :class:`DemoOptions` (applying --quick)."""
    options = DemoOptions(seed=args.seed, method=args.method, early=args.early, ask=args.ask,
                          input_mode=args.input, subject=args.subject,
                          transition_s=args.transition_s,
                          robot_time_scale=args.robot_time_scale,
                          window_s=args.window_s, output_dir=args.output_dir,
                          timeout_s=args.timeout_s, stream_timeout_s=args.stream_timeout_s,
                          pictures=not args.no_pictures, verbose=args.verbose)
    if args.quick:
        options = replace(options, rounds=1, preset=QUICK_PERSON.name)
    if args.rounds is not None:
        options = replace(options, rounds=args.rounds)
    if args.preset is not None:
        options = replace(options, preset=args.preset)
    return options


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the demo; return 0 when it finished, 1 when something failed."""
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    parser = build_parser()
    args = parser.parse_args(argv)
    options = options_from_args(args)
    if options.rounds < 1:
        parser.error('--rounds must be at least 1')
    try:
        run_demo(options)
    except (RuntimeError, ValueError) as error:  # DemoError is a RuntimeError
        print(f'demo failed: {error}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print('demo interrupted', file=sys.stderr)
        return 130
    return 0


if __name__ == '__main__':
    sys.exit(main())
