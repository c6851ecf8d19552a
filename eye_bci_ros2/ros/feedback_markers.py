"""
The ``choices/feedback`` MarkerArray from a :class:`~eye_bci_ros2.decision.feedback.Feedback`.

One CUBE per offered option marker, in the option marker's frame (the world
frame), with the **same ns and id** as the option (so show it on its own RViz
display): a halo at the option's pose, slightly larger in the option's plane
and thinner than it so the option shows through, coloured by the highlight
state (grey: none, yellow: gazed, green: chosen) and growing with the
progress of the decision (:func:`eye_bci_ros2.decision.feedback.halo_scale`).  An
option no longer offered gets a DELETE (same ns and id) once.

:class:`OptionMarkers` keeps the options of the ``choices`` topic with RViz2's
MarkerArray semantics (:class:`eye_bci_ros2.ros.marker_store.MarkerStore`, as
the marker_projector does).
"""

from typing import Iterable, List, Optional, Sequence, Set, Tuple

from builtin_interfaces.msg import Time
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.decision.feedback import Feedback, halo_scale, NONE, STATE_COLOURS
from eye_bci_ros2.ros.conversions import cube_marker, marker_label, pose_to_arrays
from eye_bci_ros2.ros.marker_store import Key, MarkerStore


def option_markers(choices: MarkerArray) -> Sequence[Marker]:
    """Return the option markers of a ``choices`` message (its ADD markers)."""
    return [m for m in choices.markers if m.action == Marker.ADD]


def feedback_to_marker_array(feedback: Feedback, options: Sequence[Marker], stamp: Time,
                             previous: Iterable[Key] = ()) -> Tuple[MarkerArray, Set[Key]]:
    """
    Build the ``choices/feedback`` message (module doc).

    :param feedback: per label state and progress; a label without an entry
        is shown as 'none' with no progress.
    :param options: the option markers offered now (from ``choices``); their
        label is ``text``, else ``ns/id``.
    :param stamp: header stamp.
    :param previous: (ns, id) of the halos sent before; those not offered any
        more get a DELETE.
    :returns: ``(message, keys)``: keys = (ns, id) of the halos now shown.
    """
    array = MarkerArray()
    keys: Set[Key] = set()
    for option in options:
        label = marker_label(option.ns, option.id, option.text)
        entry = feedback.get(label)
        state, progress = (entry.state, entry.progress) if entry is not None else (NONE, 0.0)
        position, quaternion = pose_to_arrays(option.pose)
        scale = (option.scale.x, option.scale.y, option.scale.z)
        halo = cube_marker(option.ns, option.id, '', option.header.frame_id, position,
                           quaternion, halo_scale(scale, progress), STATE_COLOURS[state], stamp)
        array.markers.append(halo)
        keys.add((option.ns, option.id))
    for ns, marker_id in sorted(set(previous) - keys):
        gone = Marker(ns=ns, id=int(marker_id), action=Marker.DELETE)
        gone.header.stamp = stamp
        if options:
            gone.header.frame_id = options[0].header.frame_id
        array.markers.append(gone)
    return array, keys


class FeedbackMarkers:
    """Remember the halos sent, so each message deletes those no longer offered."""

    def __init__(self):
        """Start with nothing shown."""
        self.shown: Set[Key] = set()

    def update(self, feedback: Feedback, options: Sequence[Marker],
               stamp: Time) -> Optional[MarkerArray]:
        """Return the next ``choices/feedback`` message (None when there is nothing to say)."""
        array, keys = feedback_to_marker_array(feedback, options, stamp, self.shown)
        self.shown = keys
        return array if array.markers else None


def option_label(marker: Marker) -> str:
    """Return an option marker's label (its text, else ns/id), as on ``choices/regions``."""
    return marker_label(marker.ns, marker.id, marker.text)


class OptionMarkers(MarkerStore):
    """The options offered on ``choices``, by (ns, id), in the order they were added."""

    @property
    def options(self) -> List[Marker]:
        """Return the option markers held."""
        return self.markers

    def get(self, label: str) -> Optional[Marker]:
        """Return the option marker with ``label``, or None."""
        return next((m for m in self.markers if option_label(m) == label), None)
