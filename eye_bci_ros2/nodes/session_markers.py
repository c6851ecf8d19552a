"""
Node ``session_markers``: the session's events on an LSL marker stream, for LabRecorder.

Labs record their LSL streams (the tracker's gaze, the amplifier's EEG) with
LabRecorder into one XDF file; this node adds the session's events as a stream of
type ``Markers`` (irregular rate, one string channel; each marker one JSON object,
:mod:`eye_bci_ros2.recordings.session_markers` has the format and docs/hardware.md
the fields).  The stream's name and source_id say which pipeline
(``eye_bci_markers /left`` for the namespace ``/left``,
:func:`~eye_bci_ros2.recordings.session_markers.stream_identity`).  ``enabled``
(default true) turns it off.

It listens to the pipeline's topics and never publishes:

* ``choices/regions`` -> ``options`` when the set of options changes (labels,
  screen px outlines, the menu's step from the markers' namespace), at the
  regions' stamp; ``choice/request`` -> ``question`` with the options on the
  screen then (the projector may show a new set just after the question: its
  ``options`` marker follows);
* ``choice/detail`` (the arbiter's JSON of each ``choice`` and ``choice/none``)
  -> ``choice`` (label, rule, evidence) and ``no_choice`` (reason), stamped at the
  last gaze sample the decision used;
* ``choice_menu/answer`` -> ``answer`` (a room, a table, back), ``go`` (the
  confirmation, with ``goal``: the table answered before it), ``stop``;
  ``choice_menu/result`` -> ``outcome``; ``choice_menu/goal`` (the menu's NavigateToPose
  goals) and ``goal_pose`` (RViz's "2D Goal Pose") -> ``goal`` (frame, x, y, yaw);
* ``choice_menu/progress`` -> ``driving``, ``arrived``, ``stopped``, ``failed``
  (a line that asks to choose again), else ``robot``, the text kept
  (:func:`~eye_bci_ros2.recordings.session_markers.progress_event`);
  ``choice_menu/state`` -> ``state``;
* ``validation/result`` -> ``validation`` (its JSON's fields);
* ``ssvep/stimuli`` -> ``stimulus_onset`` at the stimulus epoch (frame 0 of every
  option's flicker), with labels, frequencies and phases; then each question
  -> ``trial_onset`` at the first frame at or after it (``refresh_hz``), with
  its frame number: the trial's EEG epoch, phase-locked to the stimuli (TRCA).

Stamps (module doc of :mod:`~eye_bci_ros2.recordings.session_markers`): an event whose
topic carries the moment it is about (a decision's last gaze sample, a stimulus
epoch: ROS stamps) is mapped to this machine's LSL clock by a clock pair read at
the push; any other is stamped with the LSL clock when its message arrives.
"""

import json
import socket
from typing import Any, Dict, Optional

from geometry_msgs.msg import PoseStamped
import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.navigation.occupancy import yaw_of
from eye_bci_ros2.nodes.ssvep_stimulus import PARAMETERS as STIMULUS_PARAMETERS
from eye_bci_ros2.recordings.session_markers import (
    ANSWER, answer_event, CHOICE, GO, GOAL, marker_text, NO_CHOICE, OPTIONS, OUTCOME,
    progress_event, QUESTION, question_fields, ros_to_lsl, STATE, STIMULUS_ONSET,
    stream_identity, trial_frame, TRIAL_ONSET, VALIDATION)
from eye_bci_ros2.ros.conversions import marker_array_to_regions, stamp_to_ns
from eye_bci_ros2.ros.log_throttle import KeyedWarnings
from eye_bci_ros2.ros.marker_outlet import MarkerOutlet
from eye_bci_ros2.ros.node_clock import NodeClock
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.ssvep_messages import msg_to_stimulus_map
from eye_bci_ros2.ros.topics import (CHOICE_DETAIL_TOPIC, EVENT_QOS, GOAL_POSE_TOPIC, GOAL_QOS,
                                     LATCHED_QOS, MENU_ANSWER_TOPIC, MENU_GOAL_TOPIC,
                                     MENU_PROGRESS_TOPIC,
                                     MENU_RESULT_TOPIC, MENU_STATE_TOPIC, REGIONS_TOPIC,
                                     REQUEST_TOPIC, SSVEP_STIMULI_TOPIC, VALIDATION_RESULT_TOPIC)
from eye_bci_ros2.streams.lsl_connection import clock_pair

PARAMETERS = (
    ParamSpec('enabled', True,
              "publish the session's events on an LSL stream of type Markers (one JSON "
              'object per event, for LabRecorder); false = no stream'),
    ParamSpec('refresh_hz', next(p.default for p in STIMULUS_PARAMETERS
                                 if p.name == 'refresh_hz'),
              "the SSVEP stimulus display's refresh rate, Hz (as ssvep_stimulus's): a "
              "trial's onset is the first frame at or after its question",
              value_range=(1.0, 1000.0)),
    ParamSpec('stream_name', '',
              "the marker stream's name; '' = eye_bci_markers and the node's namespace",
              read_only=True),
)


class SessionMarkers(Node):
    """Push the pipeline's events, read from its topics, to an LSL marker stream."""

    def __init__(self, **kwargs):
        """Declare parameters, open the outlet (when enabled), subscribe the topics."""
        super().__init__('session_markers', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._on_parameters)
        self._time = NodeClock(self)
        self._warnings = KeyedWarnings(self.get_logger())
        name, self.source_id = stream_identity(self.get_namespace(), socket.gethostname())
        self.stream_name = self._params['stream_name'] or name
        self._outlet: Optional[MarkerOutlet] = None
        self._open()
        #: The options on the screen now: (labels, polygons (R, K, 2) px, namespaces).
        self._regions = ([], np.zeros((0, 3, 2)), [])
        #: The menu's last answer that was not go or stop (the table 'go' confirms).
        self._answered: Optional[str] = None
        #: Frame 0 of the stimuli flickering now, ns on the ROS clock (None: no stimuli).
        self._epoch_ns: Optional[int] = None
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)
        self.create_subscription(Empty, REQUEST_TOPIC, self._on_request, EVENT_QOS)
        self.create_subscription(String, CHOICE_DETAIL_TOPIC, self._on_detail, EVENT_QOS)
        self.create_subscription(String, MENU_ANSWER_TOPIC, self._on_answer, EVENT_QOS)
        self.create_subscription(String, MENU_RESULT_TOPIC, self._on_result, EVENT_QOS)
        self.create_subscription(String, MENU_PROGRESS_TOPIC, self._on_progress, LATCHED_QOS)
        self.create_subscription(String, MENU_STATE_TOPIC, self._on_state, LATCHED_QOS)
        self.create_subscription(PoseStamped, GOAL_POSE_TOPIC, self._on_goal, GOAL_QOS)
        self.create_subscription(PoseStamped, MENU_GOAL_TOPIC, self._on_goal, EVENT_QOS)
        self.create_subscription(String, VALIDATION_RESULT_TOPIC, self._on_validation,
                                 EVENT_QOS)
        self.create_subscription(JointState, SSVEP_STIMULI_TOPIC, self._on_stimuli,
                                 LATCHED_QOS)

    # -- the outlet ----------------------------------------------------------------------------

    @property
    def outlet(self) -> Optional[MarkerOutlet]:
        """Give the LSL outlet in use (None when ``enabled`` is false)."""
        return self._outlet

    @property
    def regions(self) -> tuple:
        """Give the options on the screen now: (labels, polygons (R, K, 2) px, namespaces)."""
        return self._regions

    def _open(self) -> None:
        if self._params['enabled'] and self._outlet is None:
            self._outlet = MarkerOutlet(self.stream_name, self.source_id,
                                        self.get_namespace())
            self.get_logger().info(f"session events on LSL: stream '{self.stream_name}' of "
                                   f"type Markers, source_id '{self.source_id}'")
        elif not self._params['enabled'] and self._outlet is not None:
            self._outlet.close()
            self._outlet = None
            self.get_logger().info('session events: LSL marker stream closed (enabled false)')

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        self._params.update(changed)
        self._open()

    def destroy_node(self):
        """Close the outlet, then destroy the node."""
        if self._outlet is not None:
            self._outlet.close()
            self._outlet = None
        return super().destroy_node()

    def _push(self, event: str, stamp_ns: Optional[int] = None, **fields: Any) -> None:
        """Push one marker, at ``stamp_ns`` (ROS clock) or now."""
        outlet = self._outlet
        if outlet is None:
            return
        if stamp_ns:
            ros_now_ns, lsl_now = clock_pair(self._time.ns, outlet.local_clock)
            stamp = ros_to_lsl(stamp_ns, ros_now_ns, lsl_now)
        else:
            stamp = outlet.local_clock()
        outlet.push(marker_text(event, **fields), stamp)

    def _guard(self, what: str, handler, *args) -> None:
        """Run a callback's work; a bad message is one throttled line, never the node's end."""
        try:
            handler(*args)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._warnings.warn(what, f'{what}: message not recorded as a marker: {error}')

    # -- the topics ----------------------------------------------------------------------------

    def _on_regions(self, msg: MarkerArray) -> None:
        def take():
            labels, polygons = marker_array_to_regions(msg)
            steps = [m.ns for m in msg.markers
                     if m.type == Marker.LINE_STRIP and m.action == Marker.ADD]
            new = set(labels) != set(self._regions[0])
            self._regions = (labels, polygons, steps)
            if new:   # a moved view (same labels) is not news; new options are
                stamp = stamp_to_ns(msg.markers[0].header.stamp) if msg.markers else 0
                self._push(OPTIONS, stamp, **question_fields(labels, polygons, steps))
        self._guard(REGIONS_TOPIC, take)

    def _on_request(self, msg: Empty) -> None:
        def take():
            now_ns = self._time.ns()
            self._push(QUESTION, now_ns, **question_fields(*self._regions))
            if self._epoch_ns is not None:
                frame, stamp_ns = trial_frame(now_ns, self._epoch_ns, self._params['refresh_hz'])
                self._push(TRIAL_ONSET, stamp_ns, frame=frame,
                           refresh_hz=self._params['refresh_hz'])
        self._guard(REQUEST_TOPIC, take)

    def _on_detail(self, msg: String) -> None:
        def take():
            detail = _json_object(msg.data)
            stamp_ns = int(detail.pop('stamp_ns'))
            event = CHOICE if detail.get('label') is not None else NO_CHOICE
            self._push(event, stamp_ns, **detail)
        self._guard(CHOICE_DETAIL_TOPIC, take)

    def _on_answer(self, msg: String) -> None:
        def take():
            event = answer_event(msg.data)
            if event == GO:     # the confirmation: of the table answered just before it
                self._push(GO, label=msg.data, goal=self._answered)
            else:
                self._push(event, label=msg.data)
            if event == ANSWER:
                self._answered = msg.data
        self._guard(MENU_ANSWER_TOPIC, take)

    def _on_result(self, msg: String) -> None:
        self._guard(MENU_RESULT_TOPIC, lambda: self._push(OUTCOME, label=msg.data))

    def _on_progress(self, msg: String) -> None:
        self._guard(MENU_PROGRESS_TOPIC,
                    lambda: self._push(progress_event(msg.data), text=msg.data))

    def _on_state(self, msg: String) -> None:
        self._guard(MENU_STATE_TOPIC, lambda: self._push(STATE, state=msg.data))

    def _on_goal(self, msg: PoseStamped) -> None:
        def take():
            p, q = msg.pose.position, msg.pose.orientation
            self._push(GOAL, frame=msg.header.frame_id, x=p.x, y=p.y,
                       yaw_rad=yaw_of(np.array([q.x, q.y, q.z, q.w])))
        self._guard(GOAL_POSE_TOPIC, take)

    def _on_validation(self, msg: String) -> None:
        self._guard(VALIDATION_RESULT_TOPIC,
                    lambda: self._push(VALIDATION, **_json_object(msg.data)))

    def _on_stimuli(self, msg: JointState) -> None:
        def take():
            stimuli = msg_to_stimulus_map(msg)
            # Zero: frame 0 at arrival (topics: ssvep/stimuli).
            self._epoch_ns = stamp_to_ns(msg.header.stamp) or self._time.ns()
            self._push(STIMULUS_ONSET, self._epoch_ns, frame=0,
                       labels=list(stimuli.labels), frequencies_hz=list(stimuli.frequencies),
                       phases_rad=list(stimuli.phases))
        self._guard(SSVEP_STIMULI_TOPIC, take)


def _json_object(text: str) -> Dict[str, Any]:
    """Read a topic's JSON object (ValueError with the reason when it is not one)."""
    body = json.loads(text)
    if not isinstance(body, dict):
        raise ValueError(f'not a JSON object: {text[:80]!r}')
    return body


def main(args=None):
    """Run the session_markers node until Ctrl-C."""
    spin_node(SessionMarkers, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
