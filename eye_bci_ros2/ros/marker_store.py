"""
RViz markers by (ns, id), changed by MarkerArray messages as RViz2 changes its display.

The one implementation of RViz2's MarkerArray semantics (``MarkerCommon``,
ros2/rviz jazzy, rviz_default_plugins/src/rviz_default_plugins/displays/marker/
marker_common.cpp) in this package: the markers of an array are applied in
order; ADD/MODIFY adds or replaces; DELETE removes one; DELETEALL with an
empty ``ns`` removes every marker received before it, with a non-empty ``ns``
only that namespace's (markers after it in the same array survive); a marker
with a NaN or infinite pose, scale, colour or point is ignored whatever its
action, and an ADD whose box is unusable (:func:`marker_box`) is skipped.
Each skipped marker gives one reason.

Users: ``marker_projector`` (which keeps a projection table beside it, through
the ``on_add`` / ``on_remove`` hooks), ``choice_arbiter``'s options
(:class:`eye_bci_ros2.ros.feedback_markers.OptionMarkers`) and the demo's
driver.
"""

from typing import Any, Callable, Dict, Iterable, List, Optional, Tuple

import numpy as np
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.ros.conversions import pose_to_arrays

#: A marker's identity in RViz.
Key = Tuple[str, int]
#: What :func:`marker_box` returns: position (3,), unit quaternion (4,), scale (3,), note.
Box = Tuple[np.ndarray, np.ndarray, np.ndarray, Optional[str]]


def marker_box(marker: Marker) -> Box:
    """
    Box of a marker message: position (3,), unit quaternion x, y, z, w (4,), scale (3,).

    :returns: the arrays and a note for the log (or None): an all-zero
        quaternion is read as the identity, as RViz draws it.
    :raises ValueError: NaN/infinite pose or scale, or a scale <= 0.
    """
    position, quaternion = pose_to_arrays(marker.pose)
    scale = np.array([marker.scale.x, marker.scale.y, marker.scale.z])
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(quaternion))):
        raise ValueError('pose contains NaN or infinite values')
    if not np.all(np.isfinite(scale)) or np.any(scale <= 0):
        raise ValueError(f'scale must be positive on every axis, got {scale.tolist()}')
    note = None
    norm = np.linalg.norm(quaternion)
    if norm == 0.0:
        quaternion, norm = np.array([0.0, 0.0, 0.0, 1.0]), 1.0
        note = 'orientation is all zero: using the identity, as RViz does'
    elif norm < 1e-9:
        raise ValueError('orientation quaternion has (almost) zero length')
    return position, quaternion / norm, scale, note


def non_finite_fields(marker: Marker) -> List[str]:
    """
    Name the parts of a marker holding NaN or infinite values.

    What RViz2 checks before any action (``validateFloats`` in
    marker_common.cpp): pose, scale, colour and points.
    """
    position, quaternion = pose_to_arrays(marker.pose)
    parts = {
        'pose': np.concatenate([position, quaternion]),
        'scale': [marker.scale.x, marker.scale.y, marker.scale.z],
        'color': [marker.color.r, marker.color.g, marker.color.b, marker.color.a],
        'points': [value for p in marker.points for value in (p.x, p.y, p.z)],
    }
    return [name for name, values in parts.items()
            if len(values) and not np.all(np.isfinite(np.asarray(values, dtype=float)))]


#: ``on_add(key, marker, box, received)``: called after a marker was added or replaced;
#: returns a note for the log, or None.
OnAdd = Callable[[Key, Marker, Box, Any], Optional[str]]


class MarkerStore:
    """The markers RViz would show, by (ns, id), in the order they were first added."""

    def __init__(self, on_add: Optional[OnAdd] = None,
                 on_remove: Optional[Callable[[Key], None]] = None):
        """
        Start empty.

        :param on_add: called for each marker added or replaced (module doc).
        :param on_remove: called with the key of each marker removed.
        """
        self._markers: Dict[Key, Marker] = {}
        self._on_add = on_add
        self._on_remove = on_remove

    @property
    def markers(self) -> List[Marker]:
        """Return the markers held."""
        return list(self._markers.values())

    def __len__(self) -> int:
        """Return the number of markers held."""
        return len(self._markers)

    def __contains__(self, key: Key) -> bool:
        """Tell whether a marker (ns, id) is held."""
        return key in self._markers

    def keys(self, ns: Optional[str] = None) -> List[Key]:
        """Return the keys held (of namespace ``ns`` only, when given)."""
        return [key for key in self._markers if ns is None or key[0] == ns]

    def apply(self, message: MarkerArray, received: Any = None) -> List[str]:
        """
        Apply a MarkerArray (module doc).

        :param received: passed to ``on_add`` (e.g. when it arrived, for lifetimes).
        :returns: one reason per marker skipped or noted (empty when all were applied).
        """
        return [problem for problem in (self.apply_marker(marker, received)
                                        for marker in message.markers) if problem]

    def apply_marker(self, marker: Marker, received: Any = None) -> Optional[str]:
        """Apply one marker command; return a problem or note to report, if any."""
        key = (marker.ns, marker.id)
        label = f'{marker.ns}/{marker.id}'
        if marker.action == Marker.ADD:
            try:
                box = marker_box(marker)
            except ValueError as error:
                return f'skipped marker {label}: {error}'
        broken = non_finite_fields(marker)
        if broken:  # RViz ignores such a message whatever its action
            return f"skipped marker {label}: NaN or infinite {', '.join(broken)}"
        if marker.action == Marker.DELETEALL:
            self.remove_all(self.keys(marker.ns) if marker.ns else self.keys())
        elif marker.action == Marker.DELETE:
            self.remove(key)
        elif marker.action == Marker.ADD:
            self._markers[key] = marker
            if self._on_add is not None:
                return self._on_add(key, marker, box, received)
        else:
            return f'skipped marker {label}: unknown action {marker.action}'
        return None

    def remove(self, key: Key) -> None:
        """Remove a marker (RViz DELETE; also when its lifetime ends)."""
        if self._markers.pop(key, None) is not None and self._on_remove is not None:
            self._on_remove(key)

    def remove_all(self, keys: Iterable[Key]) -> None:
        """Remove these markers."""
        for key in list(keys):
            self.remove(key)
