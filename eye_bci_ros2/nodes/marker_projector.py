"""
marker_projector: where each choice marker appears on the screen.

Subscribes ``choices`` (visualization_msgs/MarkerArray, latched, as RViz
reads it) and ``camera/pose`` (geometry_msgs/PoseStamped, optical convention,
latched) and publishes ``choices/regions`` (visualization_msgs/MarkerArray,
latched): the complete current set, one closed LINE_STRIP per visible marker,
points in screen px, same ns/id/text as the marker (see
:mod:`eye_bci_ros2.ros.conversions`), and last an invisible ARROW of ns
``camera_view`` whose pose is the camera pose projected with: an arbiter uses
regions only when made for the view on its ``camera/pose``, so a second
pipeline's projector showing another view changes nothing
(:mod:`eye_bci_ros2.decision.camera_view`).

Markers are kept by (ns, id) with RViz2's semantics
(:class:`eye_bci_ros2.ros.marker_store.MarkerStore`: ADD/MODIFY adds or
replaces, DELETE removes one, DELETEALL with an ns that namespace's, without
one all; a marker with a NaN or infinite value is ignored); a marker with a
``lifetime`` (> 0.1 ms) expires that long after it was received, on the node's
clock.  A CUBE's region is the silhouette of its corners; any other type is
treated as the box its scale spans around its pose.  Only markers in
``world_frame`` are projected (there is no tf2 here).  A marker partly behind
the camera, one containing the camera, and one wholly outside the render panel
get no region.  Regions are recomputed and republished whenever the markers,
the camera or a parameter change; nothing is published before the first camera
pose.

The projection is perspective (Orbit, XYOrbit, ThirdPersonFollower, FPS and the
animated controller) or orthographic (TopDownOrtho: ``ortho_scale`` px per m
around the panel centre); ``projection`` and the panel size can come from an
``rviz_config`` file (see :func:`camera_from_parameters`).
"""

from typing import Any, Dict, List, Optional

from geometry_msgs.msg import PoseStamped
import numpy as np
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.time import Time
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.projection.camera_model import (DEFAULT_PANEL_OFFSET, OrthographicCamera,
                                                  parse_intrinsic, rviz_intrinsic, RvizCamera)
from eye_bci_ros2.projection.geometry import external_from_pose, WORLD_FRAME
from eye_bci_ros2.ros.conversions import pose_to_arrays, regions_to_marker_array
from eye_bci_ros2.ros.log_throttle import KeyedWarnings
from eye_bci_ros2.ros.marker_store import Box, Key, MarkerStore
from eye_bci_ros2.ros.parameters import check_frame_id, declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.rviz_file import at_default, rviz_config_spec, rviz_view
from eye_bci_ros2.ros.topics import (CAMERA_POSE_TOPIC, CHOICES_QOS, CHOICES_TOPIC, LATCHED_QOS,
                                     REGIONS_TOPIC)

#: Largest render panel side accepted, px.
MAX_IMAGE_SIDE = 16384

#: Where the default 1280x720 render panel sits: centred on a 1920x1080 screen,
#: as in the default scene (config/scene.yaml).  Measure it for a real RViz
#: (``find_panel``); px, fractional on a scaled (HiDPI) screen.
DEFAULT_SCREEN_OFFSET = tuple(float(v) for v in DEFAULT_PANEL_OFFSET)


#: Problems listed in one warning about a MarkerArray.
MAX_LISTED = 5

#: Lifetimes up to this are "forever", as in RViz2 (``> 100000`` ns in
#: MarkerCommon::configureMarker).
MIN_LIFETIME_NS = 100000

#: How often markers with a lifetime are checked for expiry, s.
EXPIRY_CHECK_S = 0.05

#: Default ``ortho_scale``: TopDownOrtho's default Scale, px per m.
DEFAULT_ORTHO_SCALE = 10.0


class MarkerTable:
    """
    Markers by (ns, id) as numpy rows, updated in place.

    Rows ``[0, len(table))`` of :attr:`positions` (M, 3) m, :attr:`quaternions`
    (M, 4) x, y, z, w unit, :attr:`scales` (M, 3) m and :attr:`frames` (M,)
    are live; :attr:`sources` holds each row's marker message (ns, id, text,
    colour).  Adding is amortised O(1), deleting O(1) (the last row moves into
    the hole), so a camera move re-projects the table as it stands.
    """

    def __init__(self, capacity: int = 16):
        """Create an empty table with room for ``capacity`` markers."""
        self._count = 0
        self._rows: Dict[Key, int] = {}
        self.sources: List[Marker] = []
        capacity = max(int(capacity), 1)
        self.positions = np.zeros((capacity, 3))
        self.quaternions = np.zeros((capacity, 4))
        self.scales = np.zeros((capacity, 3))
        self.frames = np.zeros(capacity, dtype=object)

    def _grow(self) -> None:
        """Double the capacity, keeping the live rows."""
        for name in ('positions', 'quaternions', 'scales', 'frames'):
            array = getattr(self, name)
            grown = np.zeros((2 * len(array),) + array.shape[1:], dtype=array.dtype)
            grown[:self._count] = array[:self._count]
            setattr(self, name, grown)

    def __len__(self) -> int:
        """Return the number of markers held."""
        return self._count

    def __contains__(self, key: Key) -> bool:
        """Tell whether a marker (ns, id) is held."""
        return key in self._rows

    def upsert(self, key: Key, frame: str, position: np.ndarray, quaternion_xyzw: np.ndarray,
               scale: np.ndarray, source: Marker) -> None:
        """Add marker ``key`` or replace it (RViz ADD/MODIFY)."""
        row = self._rows.get(key)
        if row is None:
            if self._count == len(self.positions):
                self._grow()
            row = self._count
            self._count += 1
            self._rows[key] = row
            self.sources.append(source)
        else:
            self.sources[row] = source
        self.positions[row] = position
        self.quaternions[row] = quaternion_xyzw
        self.scales[row] = scale
        self.frames[row] = frame

    def delete(self, key: Key) -> bool:
        """Remove marker ``key`` (RViz DELETE); return whether it was there."""
        row = self._rows.pop(key, None)
        if row is None:
            return False
        last = self._count - 1
        if row != last:
            for array in (self.positions, self.quaternions, self.scales, self.frames):
                array[row] = array[last]
            self.sources[row] = self.sources[last]
            moved = self.sources[row]
            self._rows[(moved.ns, moved.id)] = row
        self.sources.pop()
        self._count = last
        return True

    def clear(self) -> None:
        """Remove every marker (RViz DELETEALL with an empty ns)."""
        self._rows.clear()
        self.sources.clear()
        self._count = 0

    def keys_in(self, ns: str) -> List[Key]:
        """Return the keys of every marker in namespace ``ns``."""
        return [key for key in self._rows if key[0] == ns]

    def keys(self) -> List[Key]:
        """Return the keys of every marker held."""
        return list(self._rows)


def _intrinsic_values(value: Any) -> Optional[str]:
    if not value:
        return None
    try:
        parse_intrinsic(value)
    except ValueError as error:
        return f'{error} (empty = analytic RViz intrinsic from the image size and fov_y_deg)'
    return None


PARAMETERS: List[ParamSpec] = [
    ParamSpec('world_frame', WORLD_FRAME,
              'RViz fixed frame: only markers (and camera poses) in this frame are projected.',
              check=check_frame_id),
    ParamSpec('image_width', 1280, 'Width W of the RViz render panel, px.',
              value_range=(1, MAX_IMAGE_SIDE)),
    ParamSpec('image_height', 720, 'Height H of the RViz render panel, px.',
              value_range=(1, MAX_IMAGE_SIDE)),
    ParamSpec('fov_y_deg', 45.0,
              'Vertical field of view of the RViz camera, degrees (RViz2: 45); used '
              'when intrinsic_matrix is empty.',
              value_range=(1.0, 179.0)),
    ParamSpec('intrinsic_matrix', [],
              'Calibrated 3x4 intrinsic, 12 numbers row-major [fx, s, cx, tx, 0, fy, cy, '
              'ty, 0, 0, 1, 0]; empty = analytic RViz intrinsic (image size, fov_y_deg).',
              check=_intrinsic_values, array_type='double_array'),
    ParamSpec('screen_offset_x', DEFAULT_SCREEN_OFFSET[0],
              "X0: screen x of the render panel's left edge, px (screen = image + X0); "
              'may be fractional (a scaled screen).',
              value_range=(-MAX_IMAGE_SIDE, MAX_IMAGE_SIDE)),
    ParamSpec('screen_offset_y', DEFAULT_SCREEN_OFFSET[1],
              "Y0: screen y of the render panel's top edge, px (screen = image + Y0); "
              'may be fractional (a scaled screen).',
              value_range=(-MAX_IMAGE_SIDE, MAX_IMAGE_SIDE)),
    ParamSpec('clip_to_image', True,
              'Cut regions to the render panel (a marker wholly off the panel gets no '
              'region); false = whole silhouettes even where RViz does not draw them.'),
    ParamSpec('projection', 'auto',
              'RViz camera projection: perspective (Orbit, XYOrbit, FPS, ...), orthographic '
              "(TopDownOrtho) or auto (rviz_config's view controller; perspective without one).",
              choices=('auto', 'perspective', 'orthographic')),
    ParamSpec('ortho_scale', DEFAULT_ORTHO_SCALE,
              "Orthographic projection: TopDownOrtho's Scale, px per m; at its default the "
              "rviz_config file's Scale is used.",
              value_range=(1e-6, 1e9)),
    rviz_config_spec('its render panel size (while image_width and image_height are at '
                     'their defaults), projection kind and TopDownOrtho Scale'),
]


def camera_from_parameters(values: Dict[str, Any], external=None):
    """
    Build the camera that the projector's parameters (and ``rviz_config``) describe.

    Precedence (see :mod:`eye_bci_ros2.ros.rviz_file`): image size from
    ``image_width``/``image_height`` unless both are at their defaults and the
    file's window state gives a panel size; projection from ``projection``
    unless it is ``auto`` (then the file's view controller, perspective without
    a file); the orthographic scale from ``ortho_scale`` unless it is at its
    default and the file has a TopDownOrtho Scale.

    :param values: ``{name: value}`` of :data:`PARAMETERS`.
    :param external: world -> camera (4, 4), or None for the identity.
    :returns: :class:`RvizCamera` or :class:`OrthographicCamera`.
    :raises ValueError: the parameters or the file describe no valid camera.
    """
    view = rviz_view(values)
    size = (values['image_width'], values['image_height'])
    if view is not None and view.panel_size and \
            at_default(values, PARAMETERS, 'image_width', 'image_height'):
        size = view.panel_size
    kind = values['projection']
    if kind == 'auto':
        kind = view.projection if view is not None else 'perspective'
    offset = (values['screen_offset_x'], values['screen_offset_y'])
    if kind == 'orthographic':
        if values['intrinsic_matrix']:
            raise ValueError('intrinsic_matrix is a perspective calibration: leave it empty with '
                             'the orthographic projection (ortho_scale sets the scale)')
        scale = values['ortho_scale']
        if view is not None and view.ortho_scale and at_default(values, PARAMETERS,
                                                                'ortho_scale'):
            scale = view.ortho_scale
        return OrthographicCamera(scale, size, offset, np.eye(4) if external is None else external)
    if values['intrinsic_matrix']:
        intrinsic = parse_intrinsic(values['intrinsic_matrix'])
    else:
        intrinsic = rviz_intrinsic(size[0], size[1], values['fov_y_deg'])
    return RvizCamera(intrinsic, size, offset, external)


def _camera_problem(values: Dict[str, Any]) -> Optional[str]:
    try:
        camera_from_parameters(values)
    except ValueError as error:
        return str(error)
    return None


class MarkerProjector(Node):
    """Project the ``choices`` markers into screen regions for the current camera."""

    def __init__(self, **kwargs):
        """Declare parameters, subscribe to markers and camera, publish regions."""
        super().__init__('marker_projector', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._on_parameters,
                                          check_all=_camera_problem)
        self._camera = camera_from_parameters(self._params)
        self._camera_frame: Optional[str] = None  # None until a camera pose arrives
        self._camera_pose = None                  # the last camera/pose's pose
        self._table = MarkerTable()
        # The markers as RViz shows them; the table follows them for the projection.
        self._store = MarkerStore(on_add=self._added, on_remove=self._delete)
        self._expiry: Dict[Key, Time] = {}  # markers with a lifetime: when they go
        self._expiry_timer = self.create_timer(EXPIRY_CHECK_S, self._expire)
        self._expiry_timer.cancel()
        self._warnings = KeyedWarnings(self.get_logger())
        self._last_stamp: Optional[Time] = None
        self._publisher = self.create_publisher(MarkerArray, REGIONS_TOPIC, LATCHED_QOS)
        self.create_subscription(MarkerArray, CHOICES_TOPIC, self._on_markers, CHOICES_QOS)
        self.create_subscription(PoseStamped, CAMERA_POSE_TOPIC, self._on_camera, LATCHED_QOS)
        self.get_logger().info(f'projecting markers in \'{self._params["world_frame"]}\' with '
                               f'{self._camera!r}; waiting for camera/pose')

    @property
    def camera(self):
        """Return the camera regions are computed with (pose from the last camera/pose)."""
        return self._camera

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        self._params.update(changed)
        self._camera = camera_from_parameters(self._params, self._camera.external)
        # A person who set the panel wants to see it taken (and what it now is).
        width, height = self._camera.image_size
        x, y = self._camera.screen_offset
        source = f" (from {self._params['rviz_config']})" if 'rviz_config' in changed and \
            self._params['rviz_config'] else ''
        self.get_logger().info(
            f"{', '.join(sorted(changed))} set: render panel {width:g}x{height:g} px at screen "
            f'offset ({x:g}, {y:g}) px{source}')
        if 'world_frame' in changed and self._camera_frame is not None and \
                self._camera_frame != self._params['world_frame']:
            self.get_logger().warning(
                f"world_frame is now '{self._params['world_frame']}' but the camera pose is "
                f"in '{self._camera_frame}': no regions until a camera pose in "
                f"'{self._params['world_frame']}' arrives")
            self._camera_frame = None
            self._publisher.publish(MarkerArray())
            return
        self._publish()

    def _on_camera(self, message: PoseStamped) -> None:
        frame = message.header.frame_id or self._params['world_frame']
        if frame != self._params['world_frame']:
            self._warn(f"ignoring camera/pose in frame '{frame}': expected "
                       f"'{self._params['world_frame']}' (no tf2 here)")
            return
        try:
            external = external_from_pose(*pose_to_arrays(message.pose))
        except ValueError as error:
            self._warn(f'ignoring camera/pose: {error}; keeping the last good camera')
            return
        self._camera = self._camera.replace(external=external)
        self._camera_frame = frame
        self._camera_pose = message.pose   # said in the regions (decision.camera_view)
        # The screen changed when RViz moved the camera (the pose's stamp), not now.
        stamp = Time.from_msg(message.header.stamp, clock_type=self.get_clock().clock_type)
        self._publish(stamp if stamp.nanoseconds > 0 else None)

    def _on_markers(self, message: MarkerArray) -> None:
        problems = self._store.apply(message, self.get_clock().now())
        if problems:
            shown = '; '.join(problems[:MAX_LISTED])
            more = len(problems) - MAX_LISTED
            self._warn(f'choices: {shown}' + (f'; and {more} more' if more > 0 else ''))
        self._publish()

    def _added(self, key: Key, marker: Marker, box: Box, received: Time) -> Optional[str]:
        """Put a marker the store added or replaced into the table; return a note, if any."""
        position, quaternion, scale, note = box
        label = f'{marker.ns}/{marker.id}'
        frame = marker.header.frame_id or self._params['world_frame']
        self._table.upsert(key, frame, position, quaternion, scale, marker)
        self._expiry.pop(key, None)
        lifetime = Duration.from_msg(marker.lifetime)
        if lifetime.nanoseconds > MIN_LIFETIME_NS:
            self._expiry[key] = received + lifetime
            if self._expiry_timer.is_canceled():
                self._expiry_timer.reset()
        if frame != self._params['world_frame']:
            return (f"marker {label} is in frame '{frame}', not "
                    f"'{self._params['world_frame']}': not projected (no tf2 here)")
        if note:
            return f'marker {label}: {note}'
        return None

    def _delete(self, key: Key) -> None:
        self._table.delete(key)
        self._expiry.pop(key, None)

    def _expire(self) -> None:
        """Remove markers whose lifetime is over (RViz's removeExpiredMarkers)."""
        now = self.get_clock().now()
        expired = [key for key, until in self._expiry.items() if now >= until]
        self._store.remove_all(expired)
        if not self._expiry:
            self._expiry_timer.cancel()
        if expired:
            self._publish()

    def _warn(self, text: str) -> None:
        """Log a warning, the same text at most once per WARN_PERIOD_S."""
        self._warnings.warn(text, text)

    def _publish(self, stamp: Optional[Time] = None) -> None:
        """Publish the regions of every marker, stamped ``stamp`` (default now)."""
        if self._camera_frame is None:
            self.get_logger().info('no camera/pose yet: regions wait for it', once=True)
            return
        count = len(self._table)
        polygons = np.zeros((0, 3, 2))
        rows = np.zeros(0, dtype=np.intp)
        if count:
            table = self._table
            try:
                polygons, visible = self._camera.box_regions(
                    table.positions[:count], table.quaternions[:count], table.scales[:count],
                    clip=self._params['clip_to_image'])
            except ValueError as error:  # the table holds checked values: a bug if it happens
                self._warn(f'cannot project the markers: {error}; regions not updated')
                return
            visible &= table.frames[:count] == self._params['world_frame']
            rows = np.flatnonzero(visible)
        # Stamps never go back, so consumers can order region sets by them.
        stamp = stamp or self.get_clock().now()
        if self._last_stamp is not None and stamp < self._last_stamp:
            stamp = self._last_stamp
        self._last_stamp = stamp
        message = regions_to_marker_array(
            polygons[rows], [self._table.sources[row] for row in rows], stamp.to_msg(),
            camera=(self._camera_frame, self._camera_pose))
        self._publisher.publish(message)


def main(args=None):
    """Run the marker_projector node."""
    spin_node(MarkerProjector, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
