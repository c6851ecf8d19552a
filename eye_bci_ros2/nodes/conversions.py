"""
Message <-> numpy conversions at the node edges.

Regions on ``choices/regions`` (visualization_msgs/MarkerArray): each message is
the complete current set, one closed LINE_STRIP per visible marker, frame
``screen``, points (x = screen u px, y = screen v px, z = 0) with the first point
repeated at the end, and the source marker's ns, id and text.  A region's
label is its ``text`` when set, else ``ns/id``.
"""

from typing import List, Sequence, Tuple

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose
import numpy as np
from visualization_msgs.msg import Marker, MarkerArray

#: frame_id of everything in screen pixels.
SCREEN_FRAME = 'screen'


def marker_label(ns: str, marker_id: int, text: str) -> str:
    """Name a choice: the marker's text if set, else ``ns/id``."""
    return text if text else f'{ns}/{marker_id}'


def pose_to_arrays(pose: Pose) -> Tuple[np.ndarray, np.ndarray]:
    """Position (3,) and quaternion (4,) x, y, z, w of a geometry_msgs/Pose."""
    p, q = pose.position, pose.orientation
    return np.array([p.x, p.y, p.z]), np.array([q.x, q.y, q.z, q.w])


def arrays_to_pose(position, quaternion_xyzw) -> Pose:
    """geometry_msgs/Pose from a position (3,) and quaternion x, y, z, w (4,)."""
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in position)
    (pose.orientation.x, pose.orientation.y, pose.orientation.z,
     pose.orientation.w) = (float(v) for v in quaternion_xyzw)
    return pose


def cube_marker(ns: str, marker_id: int, text: str, frame_id: str, position,
                quaternion_xyzw, scale, color_rgba=(1.0, 1.0, 1.0, 1.0),
                stamp: Time = None) -> Marker:
    """
    Build one choice: an ADD CUBE marker.

    :param position: centre, shape (3,), m, in ``frame_id``.
    :param quaternion_xyzw: orientation, order x, y, z, w.
    :param scale: full side lengths (3,), m.
    :param color_rgba: r, g, b, a in [0, 1].
    :param stamp: header stamp (default zero: "latest" in RViz).
    """
    marker = Marker(ns=ns, id=int(marker_id), type=Marker.CUBE, action=Marker.ADD, text=text)
    marker.header.frame_id = frame_id
    if stamp is not None:
        marker.header.stamp = stamp
    marker.pose = arrays_to_pose(position, quaternion_xyzw)
    marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in scale)
    (marker.color.r, marker.color.g, marker.color.b,
     marker.color.a) = (float(v) for v in color_rgba)
    return marker


def regions_to_marker_array(
        polygons: np.ndarray, sources: Sequence[Marker], stamp: Time,
        line_width_px: float = 2.0) -> MarkerArray:
    """
    Build the ``choices/regions`` message.

    :param polygons: shape (R, K, 2), screen px, one row per source marker
        (repeated trailing vertices are dropped).
    :param sources: the R markers the regions come from (ns, id, text, colour).
    :param stamp: when these regions became what the screen shows.
    :param line_width_px: drawn line width.
    """
    array = MarkerArray()
    for polygon, source in zip(polygons, sources):
        region = Marker()
        region.header.frame_id = SCREEN_FRAME
        region.header.stamp = stamp
        region.ns = source.ns
        region.id = source.id
        region.text = source.text
        region.type = Marker.LINE_STRIP
        region.action = Marker.ADD
        region.pose.orientation.w = 1.0
        region.scale.x = float(line_width_px)
        region.color = source.color
        if region.color.a == 0.0:
            region.color.a = 1.0
        region.points = [Point(x=float(u), y=float(v), z=0.0) for u, v in _distinct(polygon)]
        region.points.append(region.points[0])
        array.markers.append(region)
    return array


def marker_array_to_regions(array: MarkerArray) -> Tuple[List[str], np.ndarray]:
    """
    Read a ``choices/regions`` message.

    :returns: ``(labels, polygons)``: R labels and polygons of shape (R, K, 2)
        in screen px, padded by repeating each polygon's last vertex to the
        longest one.  Markers that are not closed LINE_STRIPs with at least
        3 distinct finite points are skipped.
    """
    labels, outlines = [], []
    for marker in array.markers:
        if marker.type != Marker.LINE_STRIP or marker.action != Marker.ADD:
            continue
        points = np.array([[p.x, p.y] for p in marker.points], dtype=float).reshape(-1, 2)
        if len(points) > 1 and np.array_equal(points[0], points[-1]):
            points = points[:-1]
        if len(points) < 3 or not np.all(np.isfinite(points)):
            continue
        labels.append(marker_label(marker.ns, marker.id, marker.text))
        outlines.append(points)
    width = max((len(o) for o in outlines), default=3)
    polygons = np.full((len(outlines), width, 2), np.nan)
    for row, outline in enumerate(outlines):
        polygons[row, :len(outline)] = outline
        polygons[row, len(outline):] = outline[-1]
    return labels, polygons


def _distinct(polygon: np.ndarray) -> np.ndarray:
    """Drop consecutive repeated vertices (the padding of short outlines)."""
    polygon = np.asarray(polygon, dtype=float)
    keep = np.ones(len(polygon), dtype=bool)
    keep[1:] = np.any(polygon[1:] != polygon[:-1], axis=1)
    return polygon[keep]
