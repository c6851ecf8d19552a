"""
Animated RViz camera views: easing, view interpolation, camera poses.

Pure numpy (no rclpy).  A *view* is ``(eye, focus, up)``: arrays of shape
(3,) in the world frame (m), as RViz's view controllers hold it.  A move
from one view to another follows rviz_animated_view_controller (and its
successor rviz_cinematographer, default "WAVE" speed profile): with the
relative time ``r = clamp(t / T, 0, 1)`` the progress in space is
``s = (1 - cos(pi r)) / 2`` and eye, focus and up are each interpolated
linearly, ``(1 - s) start + s goal``.  That makes the speed zero at both ends
and exact at the goal.  Where RViz's linear up would be degenerate (zero, or
along the view direction, e.g. turning the camera upside down), the up of the
slerped camera orientation is used instead, so the view is always valid.

Camera poses (position + quaternion x, y, z, w, world frame):

* optical (REP-103, what ``camera/goal`` and ``camera/pose`` carry): z
  forward, x right, y down;
* Ogre (what RViz's camera and ``rviz/current_camera_pose`` carry): looks
  along -Z, +Y up, +X right: ``R_ogre = R_optical @ diag(1, -1, -1)``.
"""

import math
from typing import Tuple

import numpy as np

from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import look_at_pose, ogre_pose_from_optical

#: (eye, focus, up), each shape (3,), world frame, m.
ViewTuple = Tuple[np.ndarray, np.ndarray, np.ndarray]

#: An up vector whose part across the view is below this fraction of its
#: length (sine of ~0.06 deg) is treated as parallel to the view.
_PARALLEL_TOLERANCE = 1e-3

#: Goals look at the plane z = 0 when the view ray meets it within this range, m.
MAX_GROUND_DISTANCE = 1e4


def ease_progress(elapsed_s: float, duration_s: float) -> float:
    """
    Return the progress in space of an RViz animated move, ``(1 - cos(pi t / T)) / 2``.

    :param elapsed_s: time since the move started, s (clamped to [0, T]).
    :param duration_s: transition time T, s; T <= 0 means an immediate jump.
    :returns: progress in [0, 1]; exactly 0 at t <= 0 and 1 at t >= T.
    """
    if duration_s <= 0.0 or elapsed_s >= duration_s:
        return 1.0
    if elapsed_s <= 0.0:
        return 0.0
    return 0.5 * (1.0 - math.cos(math.pi * elapsed_s / duration_s))


def as_view(eye, focus, up) -> ViewTuple:
    """
    Check a view and return it as float arrays.

    :raises ValueError: wrong shape, NaN, eye == focus or up along the view.
    """
    geometry.look_at(eye, focus, up)
    return (np.array(eye, dtype=float), np.array(focus, dtype=float),
            np.array(up, dtype=float))


def interpolate_view(start: ViewTuple, goal: ViewTuple, progress: float) -> ViewTuple:
    """
    Return the view a fraction ``progress`` of the way from ``start`` to ``goal``.

    Eye, focus and up are interpolated linearly, as RViz does; if that gives
    a degenerate camera (eye on focus, or up along the view) the slerped
    orientation supplies the view direction or the up vector instead.

    :param start: (eye, focus, up) at progress 0, valid (see :func:`as_view`).
    :param goal: (eye, focus, up) at progress 1, valid.
    :param progress: in [0, 1] (clamped); 0 and 1 return copies of the
        endpoints exactly.
    :returns: (eye, focus, up), a valid view.
    """
    s = min(max(float(progress), 0.0), 1.0)
    if s == 0.0:
        return tuple(np.array(v, dtype=float) for v in start)
    if s == 1.0:
        return tuple(np.array(v, dtype=float) for v in goal)
    eye, focus, up = ((1.0 - s) * np.asarray(a, dtype=float) + s * np.asarray(b, dtype=float)
                      for a, b in zip(start, goal))
    forward = focus - eye
    distance = np.linalg.norm(forward)
    if distance < 1e-9 or not _across(up, forward):
        rotation = _slerp_rotation(start, goal, s)
        if distance < 1e-9:
            distances = [np.linalg.norm(np.subtract(v[1], v[0])) for v in (start, goal)]
            forward = rotation[:, 2] * ((1.0 - s) * distances[0] + s * distances[1])
            focus = eye + forward
        if not _across(up, forward):
            up = -rotation[:, 1]
            if not _across(up, forward):
                # The slerped up may lie along a linearly interpolated view:
                # any direction across the view keeps the camera valid.
                up = np.eye(3)[np.argmin(np.abs(forward))]
    return eye, focus, up


def optical_rotation(eye, focus, up) -> np.ndarray:
    """
    Return the orientation of a view's optical camera in the world frame.

    :returns: shape (3, 3); columns are the camera's x (right), y (down) and
        z (forward) axes in world coordinates.
    """
    return geometry.look_at(eye, focus, up)[:3, :3].T


def ogre_pose(eye, focus, up) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return the Ogre camera pose of a view (``rviz/current_camera_pose``).

    :returns: ``(position (3,), quaternion (4,) x, y, z, w)``, world frame;
        the camera looks along its -Z axis with +Y up.
    """
    return ogre_pose_from_optical(*look_at_pose(eye, focus, up))


def view_from_optical_pose(position, quaternion_xyzw,
                           fallback_distance: float = 1.0, ground_z: float = 0.0) -> ViewTuple:
    """
    Return the RViz view (eye, focus, up) that shows what an optical camera pose shows.

    A pose does not say how far away the focus is; it only matters for the
    path of an animated move, not for the final picture.  The focus is where
    the view ray meets the floor ``z = ground_z`` (where menu views look), or
    ``fallback_distance`` ahead when the ray misses it.

    :param position: camera centre, shape (3,), world frame, m.
    :param quaternion_xyzw: optical camera orientation, order x, y, z, w.
    :param fallback_distance: focus distance when the ray misses the floor, m, > 0.
    :param ground_z: height of the floor, m.
    :returns: (eye, focus, up) with up = the camera's -y axis.
    :raises ValueError: NaN, wrong shape or a zero quaternion.
    """
    eye = np.array(position, dtype=float)
    if eye.shape != (3,) or not np.all(np.isfinite(eye)):
        raise ValueError(f'camera position must be 3 finite numbers, got {position!r}')
    rotation = geometry.quaternion_to_matrix(quaternion_xyzw)
    forward, up = rotation[:, 2], -rotation[:, 1]
    distance = float(fallback_distance)
    if forward[2] < -1e-9:
        along = (ground_z - eye[2]) / forward[2]
        if 1e-3 < along < MAX_GROUND_DISTANCE:
            distance = along
    return eye, eye + distance * forward, up


class ViewAnimation:
    """
    One eased move between two views, timed in seconds on any monotonic clock.

    :param start: (eye, focus, up) when the move starts.
    :param goal: (eye, focus, up) to reach.
    :param start_time_s: clock time of the start, s.
    :param duration_s: transition time T, s (<= 0: jump).
    """

    def __init__(self, start: ViewTuple, goal: ViewTuple, start_time_s: float,
                 duration_s: float):
        """Set up the move (both views are checked)."""
        self.start = as_view(*start)
        self.goal = as_view(*goal)
        self.start_time_s = float(start_time_s)
        self.duration_s = max(float(duration_s), 0.0)

    def progress_at(self, time_s: float) -> float:
        """Return the eased progress in [0, 1] at clock time ``time_s``."""
        return ease_progress(time_s - self.start_time_s, self.duration_s)

    def view_at(self, time_s: float) -> ViewTuple:
        """Return the view at ``time_s``; exactly the goal once the move is over."""
        return interpolate_view(self.start, self.goal, self.progress_at(time_s))

    def finished_at(self, time_s: float) -> bool:
        """Tell whether the move has reached its goal at ``time_s``."""
        return self.progress_at(time_s) >= 1.0


def _across(up: np.ndarray, forward: np.ndarray) -> bool:
    """Tell whether ``up`` has a usable part across the view direction."""
    up_norm = np.linalg.norm(up)
    forward_norm = np.linalg.norm(forward)
    if up_norm < 1e-9 or forward_norm < 1e-9:
        return False
    sine = np.linalg.norm(np.cross(up, forward)) / (up_norm * forward_norm)
    return sine > _PARALLEL_TOLERANCE


def _slerp_rotation(start: ViewTuple, goal: ViewTuple, s: float) -> np.ndarray:
    """Slerp the optical camera orientation a fraction ``s`` along the shortest arc."""
    q0 = geometry.matrix_to_quaternion(optical_rotation(*start))
    q1 = geometry.matrix_to_quaternion(optical_rotation(*goal))
    dot = float(np.dot(q0, q1))
    if dot < 0.0:
        q1, dot = -q1, -dot
    if dot > 0.9995:
        q = (1.0 - s) * q0 + s * q1
    else:
        angle = math.acos(min(dot, 1.0))
        q = (math.sin((1.0 - s) * angle) * q0 + math.sin(s * angle) * q1) / math.sin(angle)
    return geometry.quaternion_to_matrix(q)
