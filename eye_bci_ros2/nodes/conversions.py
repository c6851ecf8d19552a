"""
Message <-> numpy conversions at the node edges.

Regions on ``choices/regions`` (visualization_msgs/MarkerArray): each message is
the complete current set, one closed LINE_STRIP per visible marker, frame
``screen``, points (x = screen u px, y = screen v px, z = 0) with the first point
repeated at the end, and the source marker's ns, id and text.  A region's
label is its ``text`` when set, else ``ns/id``.

Gaze batches on ``gaze/samples`` (sensor_msgs/PointCloud2): one message per
chunk the bridge pulls from LSL, ``height`` 1, ``width`` N samples in
acquisition order, frame ``screen``; ``header.stamp`` is the first sample's
acquisition time on the ROS clock and each point holds

===== ======== ====== =====================================================
field datatype offset meaning
===== ======== ====== =====================================================
x     FLOAT64  0      screen x, px
y     FLOAT64  8      screen y, px
t     FLOAT64  16     acquisition time - header.stamp, s (ns resolution)
===== ======== ====== =====================================================

little-endian, ``point_step`` 24, ``is_dense`` true (no invalid sample is
sent).  A per-point time ``t`` relative to the header stamp is how lidar
drivers stamp their points, so generic PointCloud2 tools read it; float64
keeps every sample's point exactly as the bridge computed it and its own
stamp exact over chunks of any length (24 bytes a sample: 48 kB/s at 2000 Hz).
"""

from typing import List, Sequence, Tuple

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PointStamped, Pose
import numpy as np
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header
from visualization_msgs.msg import Marker, MarkerArray

#: frame_id of everything in screen pixels.
SCREEN_FRAME = 'screen'

#: One gaze sample in a ``gaze/samples`` message (module doc).
GAZE_DTYPE = np.dtype([('x', '<f8'), ('y', '<f8'), ('t', '<f8')])
#: The PointCloud2 fields of :data:`GAZE_DTYPE`.
GAZE_FIELDS = [PointField(name=name, offset=8 * index, datatype=PointField.FLOAT64, count=1)
               for index, name in enumerate(GAZE_DTYPE.names)]
_GAZE_LAYOUT = tuple((f.name, f.offset, f.datatype, f.count) for f in GAZE_FIELDS)
_NS_PER_S = 1_000_000_000


def stamp_to_ns(stamp: Time) -> int:
    """builtin_interfaces/Time -> integer ns."""
    return stamp.sec * _NS_PER_S + stamp.nanosec


def ns_to_stamp(nanoseconds: int) -> Time:
    """Integer ns (>= 0) -> builtin_interfaces/Time."""
    seconds, nanoseconds = divmod(int(nanoseconds), _NS_PER_S)
    return Time(sec=seconds, nanosec=nanoseconds)


def gaze_batch(stamps_ns: np.ndarray, xy: np.ndarray,
               frame_id: str = SCREEN_FRAME) -> PointCloud2:
    """
    Build one ``gaze/samples`` message (module doc, "Gaze batches").

    :param stamps_ns: shape (N,) int, N >= 1, acquisition times, ns on the ROS clock.
    :param xy: shape (N, 2), screen px.
    """
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64).reshape(-1)
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if not len(stamps_ns) or len(stamps_ns) != len(xy):
        raise ValueError(f'a gaze batch needs N >= 1 stamps and points, got {len(stamps_ns)} '
                         f'and {len(xy)}')
    first = int(stamps_ns[0])
    points = np.empty(len(xy), dtype=GAZE_DTYPE)
    points['x'], points['y'] = xy[:, 0], xy[:, 1]
    points['t'] = (stamps_ns - first) * 1e-9
    return PointCloud2(
        header=Header(stamp=ns_to_stamp(first), frame_id=frame_id), height=1,
        width=len(points), fields=GAZE_FIELDS, is_bigendian=False,
        point_step=GAZE_DTYPE.itemsize, row_step=GAZE_DTYPE.itemsize * len(points),
        data=points.tobytes(), is_dense=True)


def gaze_batch_arrays(message: PointCloud2) -> Tuple[np.ndarray, np.ndarray]:
    """
    Read a ``gaze/samples`` message.

    :returns: ``(stamps, xy)``: acquisition times, shape (N,) s on the ROS
        clock (float64: sub-microsecond for centuries), and points (N, 2)
        screen px, in message order.
    :raises ValueError: the fields, sizes or frame are not those of the
        module doc (the reason says which).
    """
    layout = tuple((f.name, f.offset, f.datatype, f.count) for f in message.fields)
    if layout != _GAZE_LAYOUT or message.point_step != GAZE_DTYPE.itemsize \
            or message.is_bigendian:
        raise ValueError(f'gaze batch with fields {[f.name for f in message.fields]} and '
                         f'point_step {message.point_step} ignored: expected little-endian '
                         f'float64 x, y, t, point_step {GAZE_DTYPE.itemsize}')
    count = message.width * message.height
    if len(message.data) != count * GAZE_DTYPE.itemsize:
        raise ValueError(f'gaze batch of {count} points with {len(message.data)} bytes '
                         f'ignored: expected {count * GAZE_DTYPE.itemsize}')
    if message.header.frame_id not in ('', SCREEN_FRAME):
        raise ValueError(f"gaze in frame '{message.header.frame_id}' ignored: expected "
                         f"'{SCREEN_FRAME}' (px)")
    points = np.frombuffer(message.data, dtype=GAZE_DTYPE, count=count)
    stamps = stamp_to_ns(message.header.stamp) * 1e-9 + points['t']
    xy = np.stack([points['x'], points['y']], axis=1)
    return stamps, xy


def gaze_point(stamp_ns: int, x: float, y: float,
               frame_id: str = SCREEN_FRAME) -> PointStamped:
    """Build one ``gaze/point`` message: a sample at ``stamp_ns`` ns, (x, y) screen px."""
    return PointStamped(header=Header(stamp=ns_to_stamp(stamp_ns), frame_id=frame_id),
                        point=Point(x=float(x), y=float(y), z=0.0))


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
