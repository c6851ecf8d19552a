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

The bridge publishes and the arbiter takes these messages serialized
(:class:`GazeCdr`: the CDR bytes built and read with numpy, a few
microseconds a batch, where rclpy's Python message costs about 30 us each
way): the bytes on the wire are exactly those of :func:`gaze_batch`'s
message, and every other subscriber sees an ordinary PointCloud2.
"""

import functools
import struct
from typing import List, Optional, Sequence, Tuple

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PointStamped, Pose
import numpy as np
from rclpy.serialization import deserialize_message
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
    first, points = _gaze_points(stamps_ns, xy)
    return PointCloud2(
        header=Header(stamp=ns_to_stamp(first), frame_id=frame_id), height=1,
        width=len(points), fields=GAZE_FIELDS, is_bigendian=False,
        point_step=GAZE_DTYPE.itemsize, row_step=GAZE_DTYPE.itemsize * len(points),
        data=points.tobytes(), is_dense=True)


def _gaze_points(stamps_ns: np.ndarray, xy: np.ndarray) -> Tuple[int, np.ndarray]:
    """Return a batch's first stamp, ns, and its points (N,) of :data:`GAZE_DTYPE`."""
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64).reshape(-1)
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if not len(stamps_ns) or len(stamps_ns) != len(xy):
        raise ValueError(f'a gaze batch needs N >= 1 stamps and points, got {len(stamps_ns)} '
                         f'and {len(xy)}')
    first = int(stamps_ns[0])
    points = np.empty(len(xy), dtype=GAZE_DTYPE)
    points['x'], points['y'] = xy[:, 0], xy[:, 1]
    points['t'] = (stamps_ns - first) * 1e-9
    return first, points


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


class GazeCdr:
    """
    ``gaze/samples`` messages as CDR bytes, built and read with numpy (module doc).

    The constant bytes (the fields, :data:`GAZE_FIELDS`) are laid out once per
    frame, padding zeroed (rclpy leaves it undefined); a batch fills in its
    stamp, width, row_step and data.  Reading checks every constant byte but
    the padding, and the sizes; anything else (another publisher's layout, a
    frame other than ``screen``, a malformed message) goes through rclpy and
    :func:`gaze_batch_arrays`, so it is refused with the same reason.
    """

    #: XCDR1 little-endian encapsulation header.
    ENCAPSULATION = b'\x00\x01\x00\x00'

    def __init__(self, frame_id: str = SCREEN_FRAME):
        """Lay out the constant bytes of ``frame_id``'s messages."""
        frame = frame_id.encode() + b'\x00'
        # Offsets count from the end of the encapsulation header (CDR alignment).
        head = bytearray(8) + struct.pack('<I', len(frame)) + frame
        head += bytes(_align4(len(head)) - len(head))
        self._width_at = len(head) + 4
        head += struct.pack('<II', 1, 0)
        # (start, end) of the bytes that must match, relative to the block after width.
        block, self._checked = bytearray(struct.pack('<I', len(GAZE_FIELDS))), [(0, 4)]
        for field in GAZE_FIELDS:
            name = field.name.encode() + b'\x00'
            checked = len(block)
            block += struct.pack('<I', len(name)) + name
            self._checked.append((checked, len(block)))
            block += bytes(_align4(len(block)) - len(block))
            checked = len(block)
            block += struct.pack('<IB', field.offset, field.datatype)
            self._checked.append((checked, len(block)))
            block += bytes(_align4(len(block)) - len(block))
            checked = len(block)
            block += struct.pack('<I', field.count)
            self._checked.append((checked, len(block)))
        checked = len(block)
        block += b'\x00'                     # is_bigendian false
        self._checked.append((checked, len(block)))
        block += bytes(_align4(len(block)) - len(block))
        checked = len(block)
        block += struct.pack('<I', GAZE_DTYPE.itemsize)
        self._checked.append((checked, len(block)))
        self._constant = bytes(block)
        self._head = self.ENCAPSULATION + bytes(head) + self._constant + bytes(8)
        self._width_at += 4
        self._data_at = len(self._head)

    def build(self, stamps_ns: np.ndarray, xy: np.ndarray) -> bytes:
        """Return the serialized :func:`gaze_batch` of ``stamps_ns`` (N,) ns, ``xy`` (N, 2) px."""
        first, points = _gaze_points(stamps_ns, xy)
        count = len(points)
        head = bytearray(self._head)
        seconds, nanoseconds = divmod(first, _NS_PER_S)
        struct.pack_into('<iI', head, 4, seconds, nanoseconds)
        struct.pack_into('<I', head, self._width_at, count)
        size = count * GAZE_DTYPE.itemsize
        struct.pack_into('<II', head, self._data_at - 8, size, size)
        return bytes(head) + points.tobytes() + b'\x01'

    def read(self, data: bytes) -> Tuple[np.ndarray, np.ndarray, bool]:
        """
        Read a serialized ``gaze/samples`` message.

        :returns: ``(stamps, xy, stamped)``: as :func:`gaze_batch_arrays`, and
            whether the header carries a stamp (a zero stamp: unstamped).
        :raises ValueError: as :func:`gaze_batch_arrays` (the reason says why).
        """
        fast = self._read_fast(data)
        if fast is not None:
            return fast
        try:
            message = deserialize_message(data, PointCloud2)
        except Exception as error:  # noqa: B902 - rclpy raises several kinds
            raise ValueError(f'gaze batch ignored: not a PointCloud2 ({error})') from None
        stamps, xy = gaze_batch_arrays(message)
        stamp = message.header.stamp
        return stamps, xy, bool(stamp.sec or stamp.nanosec)

    def _read_fast(self, data: bytes) -> Optional[Tuple[np.ndarray, np.ndarray, bool]]:
        """Read a message of exactly this layout; None for anything else."""
        if len(data) < 16 or data[:4] != self.ENCAPSULATION:
            return None
        length = _u32(data, 12)
        if data[16:16 + length] not in (b'\x00', SCREEN_FRAME.encode() + b'\x00'):
            return None
        width_at = 4 + _align4(12 + length) + 4
        block = width_at + 4
        data_at = block + len(self._constant) + 8
        if len(data) < data_at + 1:
            return None
        if data[block:block + len(self._constant)] != self._constant and any(
                data[block + first:block + last] != self._constant[first:last]
                for first, last in self._checked):
            return None   # another layout (padding, rclpy leaves it undefined, may differ)
        count = _u32(data, width_at - 4) * _u32(data, width_at)
        size = count * GAZE_DTYPE.itemsize
        if _u32(data, data_at - 8) != size or _u32(data, data_at - 4) != size \
                or len(data) != data_at + size + 1:
            return None
        seconds, nanoseconds = struct.unpack_from('<iI', data, 4)
        values = np.frombuffer(data, dtype='<f8', count=3 * count, offset=data_at)
        stamps = (seconds * _NS_PER_S + nanoseconds) * 1e-9 + values[2::3]
        xy = values.reshape(count, 3)[:, :2].copy()
        return stamps, xy, bool(seconds or nanoseconds)


def _align4(offset: int) -> int:
    return (offset + 3) & ~3


def _u32(data: bytes, offset: int) -> int:
    return struct.unpack_from('<I', data, offset)[0]


@functools.lru_cache(maxsize=8)
def gaze_cdr(frame_id: str = SCREEN_FRAME) -> GazeCdr:
    """Return the :class:`GazeCdr` of ``frame_id`` (made once)."""
    return GazeCdr(frame_id)


def gaze_point(stamp_ns: int, x: float, y: float,
               frame_id: str = SCREEN_FRAME) -> PointStamped:
    """Build one ``gaze/point`` message: a sample at ``stamp_ns`` ns, (x, y) screen px."""
    return PointStamped(header=Header(stamp=ns_to_stamp(stamp_ns), frame_id=frame_id),
                        point=Point(x=float(x), y=float(y), z=0.0))


@functools.lru_cache(maxsize=8)
def _point_frame(frame_id: str) -> bytes:
    """Return the CDR bytes of a PointStamped's frame_id, padded for the point after it."""
    frame = frame_id.encode() + b'\x00'
    # After the stamp (8 bytes): the frame_id string, then x, y, z aligned to 8.
    head = struct.pack('<I', len(frame)) + frame
    return head + bytes(-(8 + len(head)) % 8)


def gaze_point_cdr(stamp_ns: int, x: float, y: float, frame_id: str = SCREEN_FRAME) -> bytes:
    """
    Return the serialized :func:`gaze_point`: what the bridge publishes on ``gaze/point``.

    Built with :mod:`struct` (a few microseconds) where rclpy's Python message costs
    tens at the bridge's poll; the bytes are those of ``gaze_point``'s message but
    the padding, which is zeroed.
    """
    seconds, nanoseconds = divmod(int(stamp_ns), _NS_PER_S)
    return (GazeCdr.ENCAPSULATION + struct.pack('<iI', seconds, nanoseconds)
            + _point_frame(frame_id) + struct.pack('<ddd', float(x), float(y), 0.0))


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


#: ns of the marker that says which camera view a ``choices/regions`` message was projected
#: with (:mod:`eye_bci_ros2.decision.camera_view`); its pose is the camera's, optical.
CAMERA_VIEW_NS = 'camera_view'


def regions_to_marker_array(
        polygons: np.ndarray, sources: Sequence[Marker], stamp: Time,
        line_width_px: float = 2.0, camera: Optional[Tuple[str, Pose]] = None) -> MarkerArray:
    """
    Build the ``choices/regions`` message.

    :param polygons: shape (R, K, 2), screen px, one row per source marker
        (repeated trailing vertices are dropped).
    :param sources: the R markers the regions come from (ns, id, text, colour).
    :param stamp: when these regions became what the screen shows.
    :param line_width_px: drawn line width.
    :param camera: the camera pose projected with (frame, optical pose): appended
        as an invisible ARROW of ns :data:`CAMERA_VIEW_NS` after the regions.
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
    if camera is not None:
        view = Marker()
        view.header.frame_id, view.pose = camera
        view.header.stamp = stamp
        view.ns = CAMERA_VIEW_NS
        view.type = Marker.ARROW
        view.action = Marker.ADD
        view.scale.x, view.scale.y, view.scale.z = 0.3, 0.05, 0.05   # alpha 0: not drawn
        array.markers.append(view)
    return array


def regions_camera_view(array: MarkerArray) -> Optional[np.ndarray]:
    """
    Return the camera view a ``choices/regions`` message was projected with, or None.

    :returns: shape (7,): position x, y, z and orientation x, y, z, w of the camera
        (:data:`CAMERA_VIEW_NS`); None when the message does not say.
    """
    for marker in reversed(array.markers):
        if marker.ns == CAMERA_VIEW_NS and marker.type == Marker.ARROW:
            return pose_view(marker.pose)
    return None


def pose_view(pose: Pose) -> np.ndarray:
    """Return a pose as a camera view: shape (7,), position then quaternion x, y, z, w."""
    p, q = pose.position, pose.orientation
    return np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w], dtype=float)


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
