"""
The original implementation's way of projecting markers and classifying gaze.

This module re-creates, for comparison only, how the original report's
``eye_tracking_engine.py`` worked (see its sections 3.1.2, 3.2 and 7.2): for
every marker and every corner the camera's ``T_camera^world`` is rebuilt from
eye, focus and up with Python lists and small numpy operations, inverted with
``np.linalg.inv`` into the External, multiplied into ``C = Intrinsic .
External`` and applied to the corner; gaze samples are then tested one at a
time, region by region, in Python.  The only changes are the ones a fair
comparison needs: all 8 corners of each box (the original took the 4 vertices
of a thin cube's face) and their convex hull (monotone chain, in Python), so
that it computes the same regions as :func:`eye_bci_ros2.projection.geometry.box_silhouettes`.

Nothing here is used by the nodes: it is deliberately slow.
"""

import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

Point2 = Tuple[float, float]

#: Same threshold as :data:`eye_bci_ros2.projection.geometry.MIN_DEPTH` (m).
MIN_DEPTH = 1e-6


def external_original(eye: Sequence[float], focus: Sequence[float],
                      up: Sequence[float]) -> np.ndarray:
    """
    Build the External (world -> camera) as the original did: T_camera^world, inverted.

    The columns of ``T_camera^world`` are the camera's x, y, z axes and its
    origin (the eye) in the world frame; z = F - P, y is minus the part of
    ``up`` orthogonal to z (so up appears as -v), x = y cross z.

    :returns: shape (4, 4).
    """
    z = [focus[i] - eye[i] for i in range(3)]
    z_norm = math.sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2])
    z = [c / z_norm for c in z]
    up_dot_z = up[0] * z[0] + up[1] * z[1] + up[2] * z[2]
    y = [-(up[i] - up_dot_z * z[i]) for i in range(3)]
    y_norm = math.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
    y = [c / y_norm for c in y]
    x = [y[1] * z[2] - y[2] * z[1], y[2] * z[0] - y[0] * z[2], y[0] * z[1] - y[1] * z[0]]
    camera_to_world = np.array([
        [x[0], y[0], z[0], eye[0]],
        [x[1], y[1], z[1], eye[1]],
        [x[2], y[2], z[2], eye[2]],
        [0.0, 0.0, 0.0, 1.0],
    ])
    return np.linalg.inv(camera_to_world)


def pixel_of_point_original(point: Sequence[float], intrinsic: np.ndarray,
                            eye: Sequence[float], focus: Sequence[float],
                            up: Sequence[float]) -> Tuple[float, float, float]:
    """
    Project one world point, rebuilding the External for it as the original did.

    :param point: (x, y, z), world frame, m.
    :param intrinsic: shape (3, 4).
    :returns: ``(u, v, depth)``: image px and depth along the optical axis, m.
    """
    external = external_original(eye, focus, up)
    projection = np.dot(intrinsic, external)
    s_u, s_v, s = np.dot(projection, [point[0], point[1], point[2], 1.0])
    return float(s_u / s), float(s_v / s), float(s)


def rotation_original(quaternion_xyzw: Sequence[float]) -> List[List[float]]:
    """Rotation matrix (lists) of a quaternion (x, y, z, w), normalised first."""
    x, y, z, w = quaternion_xyzw
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def box_corners_original(position: Sequence[float], quaternion_xyzw: Sequence[float],
                         scale: Sequence[float]) -> List[List[float]]:
    """
    Compute the 8 corners of a cube marker, one at a time with Python lists.

    Corner ``i`` has local offset ``(+-sx/2, +-sy/2, +-sz/2)`` with bit 0 of
    ``i`` for +x, bit 1 for +y, bit 2 for +z (same order as
    :data:`eye_bci_ros2.projection.geometry.CORNER_SIGNS`).
    """
    rotation = rotation_original(quaternion_xyzw)
    corners = []
    for i in range(8):
        local = [(scale[axis] / 2) * (1.0 if (i >> axis) & 1 else -1.0) for axis in range(3)]
        corners.append([position[row] + sum(rotation[row][k] * local[k] for k in range(3))
                        for row in range(3)])
    return corners


def convex_hull_original(points: Sequence[Point2]) -> List[Point2]:
    """
    Convex hull of 2-D points by Andrew's monotone chain, in Python.

    :returns: hull vertices, counter-clockwise in a (u right, v up) plane,
        collinear points dropped.
    """
    ordered = sorted(points)

    def cross(o: Point2, a: Point2, b: Point2) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: List[Point2] = []
    for p in ordered:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 1e-12:
            lower.pop()
        lower.append(p)
    upper: List[Point2] = []
    for p in reversed(ordered):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 1e-12:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def silhouettes_original(positions, quaternions_xyzw, scales, intrinsic, eye, focus,
                         up) -> List[Optional[List[Point2]]]:
    """
    Screen regions of markers, marker by marker and corner by corner.

    :param positions: M marker centres (x, y, z), world frame, m.
    :param quaternions_xyzw: M orientations, order x, y, z, w.
    :param scales: M full side lengths, m.
    :param intrinsic: shape (3, 4).
    :param eye: camera position, world frame, m.
    :param focus: point the camera looks at, world frame, m.
    :param up: world vector that appears up in the image.
    :returns: per marker the hull of its projected corners in image px, or
        None when a corner is not in front of the camera.
    """
    regions: List[Optional[List[Point2]]] = []
    for position, quaternion, scale in zip(positions, quaternions_xyzw, scales):
        pixels = []
        in_front = True
        for corner in box_corners_original(position, quaternion, scale):
            u, v, depth = pixel_of_point_original(corner, intrinsic, eye, focus, up)
            if depth <= MIN_DEPTH:
                in_front = False
                break
            pixels.append((u, v))
        regions.append(convex_hull_original(pixels) if in_front else None)
    return regions


def point_in_polygon_original(x: float, y: float, polygon: Sequence[Point2]) -> bool:
    """
    Whether (x, y) lies in a convex polygon of either winding (edges count as inside).

    Repeated vertices (zero-length edges) are skipped.
    """
    sign = 0
    count = len(polygon)
    for k in range(count):
        x0, y0 = polygon[k]
        x1, y1 = polygon[(k + 1) % count]
        cross = (x1 - x0) * (y - y0) - (y1 - y0) * (x - x0)
        if cross > 1e-9:
            if sign < 0:
                return False
            sign = 1
        elif cross < -1e-9:
            if sign > 0:
                return False
            sign = -1
    return True


def classify_original(points, polygons) -> List[int]:
    """
    Region of each gaze sample, one sample at a time, region by region.

    :param points: N samples (x, y), px.
    :param polygons: R convex polygons, each a sequence of (x, y) px, or None
        for a region that is not shown.
    :returns: per sample the index of the first region that contains it, -1
        for none (the original dropped those samples as noise).
    """
    labels = []
    for x, y in points:
        label = -1
        for index, polygon in enumerate(polygons):
            if polygon is not None and point_in_polygon_original(x, y, polygon):
                label = index
                break
        labels.append(label)
    return labels
