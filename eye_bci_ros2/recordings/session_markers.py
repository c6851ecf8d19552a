"""
A session's events as an LSL marker stream: the JSON of each event, its stamp, the stream's name.

Labs record their LSL streams with LabRecorder into one XDF file, and their
events travel as a stream of type ``Markers`` (irregular rate, one string
channel).  The ``session_markers`` node (:mod:`eye_bci_ros2.nodes.session_markers`)
publishes one; this module is its pure part, and what a reader of the XDF
needs: one marker is one JSON object on one line (:func:`marker_text`,
:func:`parse_marker`), always with ``"event"`` (one of :data:`EVENTS`) and
``"v"`` (:data:`FORMAT_VERSION`); the other fields are the event's (docs/hardware.md,
"LabRecorder", lists them).  NaN and infinities become ``null``: JSON has no
such numbers and a lab's parser must not choke on them.

Stamps.  Each marker is stamped on this machine's LSL clock at the moment it
is about, not when it was sent: a choice at the stamp of the last gaze sample
it weighed, a stimulus onset at its frame 0.  Those moments come as ROS
stamps; the gaze bridge made them from the tracker's LSL stamps by
``t_ros = t_lsl + time_correction + (ros_now - lsl_now)``
(:func:`eye_bci_ros2.streams.lsl_connection.acquisition_stamps_ns`), so the inverse
with this node's own clock pair (:func:`ros_to_lsl`) gives the tracker's stamp on
this machine's LSL clock, ``t_lsl + time_correction``: in the XDF, after the clock
offsets LabRecorder recorded (``pyxdf.load_xdf`` applies them by default), the
choice lies on its gaze sample.  The two clock pairs differ only by the drift of
the ROS clock against the LSL clock between them (microseconds).
"""

import json
import math
import re
from typing import Any, Dict, Optional, Sequence

import numpy as np

#: The LSL stream type of the markers (what LabRecorder and every XDF reader expect).
MARKER_TYPE = 'Markers'
#: The stream name's and source_id's first part; the namespace follows.
STREAM_PREFIX = 'eye_bci_markers'
#: The version of the marker format (field ``v``); raised when a field changes meaning.
FORMAT_VERSION = 1

#: Every event, in the order a session meets them (docs/hardware.md, "LabRecorder").
OPTIONS = 'options'            # choices/regions: a new set of options on the screen
QUESTION = 'question'          # choice/request: the options and their screen regions
CHOICE = 'choice'              # the arbiter's choice: label, rule, evidence
NO_CHOICE = 'no_choice'        # a round that ended without a choice, and why
ANSWER = 'answer'              # a choice the menu acted on (a room, a table, back)
GO = 'go'                      # the person confirmed the table: the robot may drive
STOP = 'stop'                  # the person stopped the robot
OUTCOME = 'outcome'            # the menu's outcome (the table), with the robot: after go
GOAL = 'goal'                  # the robot goal the menu published (map frame)
DRIVING = 'driving'            # choice_menu/progress: on the way (distance left)
ARRIVED = 'arrived'            # choice_menu/progress: the robot arrived
STOPPED = 'stopped'            # choice_menu/progress: the robot stopped (the person's stop)
FAILED = 'failed'              # choice_menu/progress: the drive failed (choose again)
ROBOT = 'robot'                # choice_menu/progress: any other line (sending, stopping, ...)
STATE = 'state'                # choice_menu/state: what the menu waits for
VALIDATION = 'validation'      # validation/result: the outcome of a gaze validation
STIMULUS_ONSET = 'stimulus_onset'  # ssvep/stimuli: frame 0 of a stimulus set
TRIAL_ONSET = 'trial_onset'    # a question while stimuli flicker: the first frame of its trial
EVENTS = (OPTIONS, QUESTION, CHOICE, NO_CHOICE, ANSWER, GO, STOP, OUTCOME, GOAL, DRIVING, ARRIVED,
          STOPPED, FAILED, ROBOT, STATE, VALIDATION, STIMULUS_ONSET, TRIAL_ONSET)

#: The menu's answers that are events of their own (task.menu.GO_LABEL, STOP_LABEL).
ANSWER_EVENTS = {'go': GO, 'stop': STOP}
#: choice_menu/progress lines (task.menu.Progress) by their first word, and the words every
#: failed drive's line ends with (the person is asked to choose again).
PROGRESS_EVENTS = {'driving': DRIVING, 'arrived': ARRIVED, 'stopped': STOPPED}
FAILED_WORDS = 'choose again'

#: Decimals kept of screen px and other measured floats (a marker is read by people too).
DECIMALS = 3


def _plain(value: Any) -> Any:
    """Return ``value`` as JSON can hold it: NaN/inf -> None, numpy -> Python, tuples -> lists."""
    if isinstance(value, dict):
        return {str(key): _plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(item) for item in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        value = float(value)
        return round(value, DECIMALS) if math.isfinite(value) else None
    return value


def marker_text(event: str, **fields: Any) -> str:
    """
    Return one marker: ``{"event": ..., "v": 1, **fields}`` as one JSON line.

    :param event: one of :data:`EVENTS`.
    :raises ValueError: an unknown event (a typo would make a marker no reader finds).
    """
    if event not in EVENTS:
        raise ValueError(f"unknown marker event '{event}' (events: {', '.join(EVENTS)})")
    body = {'event': event, 'v': FORMAT_VERSION}
    body.update(_plain(fields))
    return json.dumps(body, separators=(',', ':'), allow_nan=False)


def parse_marker(text: str) -> Dict[str, Any]:
    """
    Read one marker (what a lab does with each string of the XDF's marker stream).

    :raises ValueError: not a JSON object with an ``event``.
    """
    body = json.loads(text)
    if not isinstance(body, dict) or 'event' not in body:
        raise ValueError(f'not a marker (a JSON object with an "event"): {text[:80]!r}')
    return body


def ros_to_lsl(stamp_ns: int, ros_now_ns: int, lsl_now: float) -> float:
    """
    Map a ROS stamp to this machine's LSL clock (module doc): the bridge's mapping inverted.

    :param stamp_ns: the moment, ns on the ROS clock.
    :param ros_now_ns: the ROS clock, ns, read together with ``lsl_now``
        (:func:`eye_bci_ros2.streams.lsl_connection.clock_pair`).
    :param lsl_now: this machine's LSL clock, s.
    :returns: s on this machine's LSL clock.
    """
    return lsl_now + (int(stamp_ns) - int(ros_now_ns)) * 1e-9


def stream_identity(namespace: str, hostname: str) -> tuple:
    """
    Return the marker stream's ``(name, source_id)`` for the pipeline in ``namespace``.

    The name says which pipeline (``eye_bci_markers`` or ``eye_bci_markers /left``);
    the source_id adds the machine, so two pipelines never share one and LabRecorder
    finds a restarted node's stream again (same machine, same namespace).
    """
    namespace = '/' + namespace.strip('/') if namespace.strip('/') else ''
    name = f'{STREAM_PREFIX} {namespace}' if namespace else STREAM_PREFIX
    return name, f'{STREAM_PREFIX}@{hostname}{namespace or "/"}'


def trial_frame(question_ns: int, epoch_ns: int, refresh_hz: float) -> tuple:
    """
    Return the first stimulus frame of the trial a question starts: ``(frame, its stamp ns)``.

    Every option's flicker shows frame k at ``epoch + k / refresh``
    (:mod:`eye_bci_ros2.ssvep.stimuli`); the trial's EEG epoch starts at the first frame
    at or after the question (frame 0 for a question before the epoch), so epochs are
    phase-locked to the stimuli, as TRCA needs.

    :param question_ns: the question, ns on the ROS clock; :param epoch_ns: frame 0, ns.
    :param refresh_hz: the stimulus display's refresh rate, Hz.
    """
    frame = max(0, math.ceil((question_ns - epoch_ns) * 1e-9 * refresh_hz - 1e-9))
    return frame, epoch_ns + int(round(frame * 1e9 / refresh_hz))


def progress_event(text: str) -> str:
    """
    Return the event of a ``choice_menu/progress`` line.

    ``driving``, ``arrived``, ``stopped`` by its first word (``the robot stopped`` too);
    ``failed`` when it asks the person to choose again (a refused, aborted or unanswered
    goal); ``robot`` for any other line (sending, stopping, no feedback yet, ...).
    """
    word = re.match(r'\s*(\w*)', text).group(1).lower()
    if word in PROGRESS_EVENTS:
        return PROGRESS_EVENTS[word]
    if text.strip().lower() == 'the robot stopped':
        return STOPPED
    return FAILED if FAILED_WORDS in text else ROBOT


def answer_event(label: str) -> str:
    """Return the event of a ``choice_menu/answer``: 'go' and 'stop' are their own."""
    return ANSWER_EVENTS.get(label, ANSWER)


def question_fields(labels: Sequence[str], polygons: np.ndarray,
                    steps: Sequence[str] = ()) -> Dict[str, Any]:
    """
    Return a question's fields: each option's label and screen region.

    :param labels: R labels (as on ``choices/regions``).
    :param polygons: (R, K, 2) screen px, padded by repeating the last vertex
        (:func:`eye_bci_ros2.ros.conversions.marker_array_to_regions`); the padding is dropped.
    :param steps: the regions' marker namespaces (the menu's step: rooms, tables,
        confirm, drive); the distinct ones, in order.
    """
    options = []
    for label, polygon in zip(labels, np.asarray(polygons, dtype=float)):
        keep = np.ones(len(polygon), dtype=bool)
        keep[1:] = np.any(np.diff(polygon, axis=0) != 0.0, axis=1)
        options.append({'label': label, 'region': polygon[keep]})
    return {'options': options, 'step': list(dict.fromkeys(steps))}


def decision_detail(decision: Any, label: Optional[str], reason: Optional[str],
                    input_mode: str, rule: str, now_ns: int) -> str:
    """
    Return what the arbiter says of an outcome on ``choice/detail``: one JSON line.

    :param decision: the round's :class:`eye_bci_ros2.decision.evidence.Decision` that led
        to the outcome, or None (an SSVEP choice, no gaze decision behind it).
    :param label: the choice, or None.
    :param reason: why there is no choice, or None.
    :param input_mode: the arbiter's input mode (gaze, ssvep, hybrid).
    :param rule: the arbiter's gaze rule (its ``method``: fixation, mean, vote).
    :param now_ns: the ROS clock now, ns: the stamp of an outcome without gaze behind it.
    :returns: ``label``, ``reason``, ``input_mode``, ``rule``, ``decided_by`` (the
        decision's own method: ``early`` before the window end, else the rule; None
        without a decision), ``evidence`` (samples, in-region samples, fresh samples,
        margin, posterior, counts, mean point, time to decision; None without one) and
        ``stamp_ns``, what the outcome is about on the ROS clock: the stamp of the last gaze
        sample the decision used (``gaze_stamp`` true), else ``now_ns`` (false).
    """
    fields: Dict[str, Any] = {'label': label, 'reason': reason, 'input_mode': input_mode,
                              'rule': rule, 'decided_by': None, 'evidence': None,
                              'stamp_ns': int(now_ns), 'gaze_stamp': False}
    if decision is not None:
        fields.update(decided_by=decision.method, evidence={
            'samples': decision.samples_used, 'in_region': decision.in_region_samples,
            'fresh': decision.fresh_samples, 'margin': decision.margin,
            'posterior': decision.posterior, 'counts': dict(decision.counts),
            'mean_point': decision.mean_point,
            'time_to_decision_s': decision.time_to_decision})
        last = decision.round_start + decision.time_to_decision
        if math.isfinite(last):
            fields.update(stamp_ns=int(round(last * 1e9)), gaze_stamp=True)
    return json.dumps(_plain(fields), separators=(',', ':'), allow_nan=False)
