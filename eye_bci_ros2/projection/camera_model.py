"""
The RViz camera as a pinhole model: pure numpy, no rclpy.

Shaped like image_geometry's ``PinholeCameraModel``, for the camera that RViz
renders the scene with.  Conventions (docs/DESIGN.md):

* world: the RViz fixed frame, m.
* optical camera frame (REP-103): z forward, x right, y down, m.
* Ogre camera frame (what RViz's view controllers move): looks along -Z, +Y
  up, +X right, so ``R_optical = R_ogre @ diag(1, -1, -1)``.
* x-forward camera frame (the Jazzy port of the animated view controller,
  ``rviz_plugin_view_animated``): x = view direction, y left, z = camera up.
* image: top-left of the render panel, u right, v down, px.
* screen: image + (X0, Y0) = ``screen_offset``, px.
* Quaternions are ordered x, y, z, w.
"""

import math
from typing import Sequence, Tuple

import numpy as np

from eye_bci_ros2.projection import geometry

#: Render panel used when nothing else is known: 1280x720 px, the render panel
#: of an RViz window on a 1920x1080 screen (side panels and toolbars take the rest).
DEFAULT_IMAGE_SIZE = (1280, 720)

#: Where that panel's top-left corner sits on the 1920x1080 screen
#: (:data:`eye_bci_ros2.projection.visual_angle.DEFAULT_VIEWING`), px: (X0, Y0), the
#: marker_projector's default screen offset.
DEFAULT_PANEL_OFFSET = (320, 180)

#: RViz2 (Ogre 1.12) renders with this vertical field of view, degrees.
RVIZ_FOV_Y_DEG = 45.0

__all__ = ['clip_polygons', 'look_at_pose', 'ogre_pose_from_optical', 'optical_pose_from',
           'optical_pose_from_ogre', 'OrthographicCamera', 'parse_intrinsic', 'pose_from_optical',
           'POSE_CONVENTIONS', 'rviz_intrinsic', 'RvizCamera']

#: Camera pose conventions a pose topic can use (see :func:`optical_pose_from`).
POSE_CONVENTIONS = ('ogre', 'x_forward', 'optical')

#: Columns: the optical axes (x right, y down, z forward) in x-forward camera
#: axes (x forward, y left, z up): ``R_optical = R_x_forward @ _X_FORWARD_TO_OPTICAL``.
_X_FORWARD_TO_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])

#: Tolerance on the last row [0, 0, 1, 0] of a user-supplied intrinsic.
_LAST_ROW_TOLERANCE = 1e-2


def rviz_intrinsic(width, height, fov_y_deg: float = 45.0) -> np.ndarray:
    """
    Analytic intrinsic of an RViz2 render panel (Ogre: square pixels, centred principal point).

    :param width: render panel width W, px (> 0).
    :param height: render panel height H, px (> 0).
    :param fov_y_deg: vertical field of view, degrees, in (0, 180); RViz uses 45.
    :returns: shape (3, 4), ``fx = fy = (H / 2) / tan(FOVy / 2)``, ``cx = W / 2``,
        ``cy = H / 2``.
    :raises ValueError: non-positive size or a field of view outside (0, 180).
    """
    width, height, fov_y_deg = float(width), float(height), float(fov_y_deg)
    if not (math.isfinite(width) and math.isfinite(height) and width > 0 and height > 0):
        raise ValueError(f'render panel size must be positive, got {width} x {height} px')
    if not (math.isfinite(fov_y_deg) and 0.0 < fov_y_deg < 180.0):
        raise ValueError(f'fov_y_deg must be in (0, 180) degrees, got {fov_y_deg}')
    focal = (height / 2.0) / math.tan(math.radians(fov_y_deg) / 2.0)
    return np.array([[focal, 0.0, width / 2.0, 0.0],
                     [0.0, focal, height / 2.0, 0.0],
                     [0.0, 0.0, 1.0, 0.0]])


def parse_intrinsic(values) -> np.ndarray:
    """
    Check and reshape a user-supplied intrinsic matrix.

    :param values: 12 numbers, row-major 3x4, or an array of shape (3, 4):
        ``[[fx, s, cx, tx], [0, fy, cy, ty], [0, 0, 1, 0]]``.
    :returns: shape (3, 4).
    :raises ValueError: not exactly 12 finite numbers, a focal term <= 0, or a
        last row that is not [0, 0, 1, 0] (within 1e-2).
    """
    array = np.asarray(values, dtype=float)
    if array.size != 12:
        raise ValueError(f'intrinsic matrix needs exactly 12 numbers (row-major 3x4), '
                         f'got {array.size}')
    if not np.all(np.isfinite(array)):
        raise ValueError('intrinsic matrix contains NaN or infinite values')
    matrix = array.reshape(3, 4)
    if matrix[0, 0] <= 0 or matrix[1, 1] <= 0:
        raise ValueError(f'intrinsic focal terms must be positive, got fx={matrix[0, 0]}, '
                         f'fy={matrix[1, 1]}')
    if np.max(np.abs(matrix[2] - [0.0, 0.0, 1.0, 0.0])) > _LAST_ROW_TOLERANCE:
        raise ValueError(f'intrinsic last row must be [0, 0, 1, 0], got {matrix[2].tolist()}')
    return matrix


def optical_pose_from_ogre(position, quaternion_xyzw) -> Tuple[np.ndarray, np.ndarray]:
    """
    Convert an RViz (Ogre) camera pose to the optical camera pose.

    The Ogre camera looks along its -Z with +Y up; the optical frame looks
    along +z with y down, x unchanged: ``R_optical = R_ogre @ diag(1, -1, -1)``,
    a half turn about the camera's own x axis.

    :param position: camera centre in the world frame, shape (3,), m.
    :param quaternion_xyzw: Ogre camera orientation in the world frame, order
        x, y, z, w; normalised here, must not be zero.
    :returns: ``(position (3,), quaternion_xyzw (4,))`` of the optical frame,
        quaternion unit with w >= 0.
    :raises ValueError: NaN/infinite values or a zero quaternion.
    """
    position = _finite('camera position', position, 3)
    x, y, z, w = _unit_quaternion(quaternion_xyzw)
    # q_ogre * (1, 0, 0, 0): the half turn about x, in closed form.
    return position, _canonical(np.array([w, z, -y, -x]))


def ogre_pose_from_optical(position, quaternion_xyzw) -> Tuple[np.ndarray, np.ndarray]:
    """
    Convert an optical camera pose to the RViz (Ogre) camera pose.

    The inverse of :func:`optical_pose_from_ogre` (the same half turn).

    :param position: camera centre in the world frame, shape (3,), m.
    :param quaternion_xyzw: optical frame orientation, order x, y, z, w.
    :returns: ``(position (3,), quaternion_xyzw (4,))`` of the Ogre camera.
    """
    return optical_pose_from_ogre(position, quaternion_xyzw)


def optical_pose_from(convention: str, position,
                      quaternion_xyzw) -> Tuple[np.ndarray, np.ndarray]:
    """
    Convert a camera pose in a named convention to the optical camera pose.

    * ``ogre``: the Ogre camera (forward -Z, up +Y), as the ROS 1
      ``rviz_animated_view_controller`` publishes on ``rviz/current_camera_pose``;
      see :func:`optical_pose_from_ogre`.
    * ``x_forward``: pose x = view direction, z = camera up (y left), as the Jazzy
      port publishes on ``rviz_plugin_view_animated_<N>/pose``: the Ogre
      orientation times ``RPY(0, pi/2, pi/2)`` (weraleiso/ias_rviz_plugins,
      rviz_plugin_view_animated/source/rviz_plugin_view_animated.cpp,
      ``PublishViewPose``).  Then ``R_optical = R_x_forward @ M`` with M's
      columns (0, -1, 0), (0, 0, -1), (1, 0, 0).
    * ``optical``: already z forward, y down (REP-103 camera frame).

    :param convention: one of :data:`POSE_CONVENTIONS`.
    :param position: camera centre in the world frame, shape (3,), m.
    :param quaternion_xyzw: orientation in the world frame, order x, y, z, w;
        normalised here, must not be zero.
    :returns: ``(position (3,), quaternion_xyzw (4,))`` of the optical frame,
        quaternion unit with w >= 0.
    :raises ValueError: unknown convention, NaN/infinite values or a zero quaternion.
    """
    if convention == 'ogre':
        return optical_pose_from_ogre(position, quaternion_xyzw)
    position = _finite('camera position', position, 3)
    quaternion = _unit_quaternion(quaternion_xyzw)
    if convention == 'optical':
        return position, _canonical(quaternion)
    if convention == 'x_forward':
        rotation = geometry.quaternion_to_matrix(quaternion) @ _X_FORWARD_TO_OPTICAL
        return position, _canonical(geometry.matrix_to_quaternion(rotation))
    raise ValueError(f"unknown pose convention '{convention}' "
                     f"(one of: {', '.join(POSE_CONVENTIONS)})")


def pose_from_optical(convention: str, position,
                      quaternion_xyzw) -> Tuple[np.ndarray, np.ndarray]:
    """
    Convert an optical camera pose to a named convention (inverse of :func:`optical_pose_from`).

    :param convention: one of :data:`POSE_CONVENTIONS`.
    :param position: camera centre in the world frame, shape (3,), m.
    :param quaternion_xyzw: optical frame orientation, order x, y, z, w.
    :returns: ``(position (3,), quaternion_xyzw (4,))`` in ``convention``.
    """
    if convention == 'x_forward':
        position = _finite('camera position', position, 3)
        rotation = geometry.quaternion_to_matrix(
            _unit_quaternion(quaternion_xyzw)) @ _X_FORWARD_TO_OPTICAL.T
        return position, _canonical(geometry.matrix_to_quaternion(rotation))
    # The Ogre half turn is its own inverse; the optical case is the identity.
    return optical_pose_from(convention, position, quaternion_xyzw)


def look_at_pose(eye, focus, up) -> Tuple[np.ndarray, np.ndarray]:
    """
    Optical camera pose of an RViz view given by eye, focus and up.

    :param eye: camera position, world frame, shape (3,), m.
    :param focus: point looked at, world frame, shape (3,), m.
    :param up: world direction that appears up in the image, shape (3,).
    :returns: ``(position (3,), quaternion_xyzw (4,))``, optical convention.
    :raises ValueError: eye == focus, up parallel to the view, zero up or NaN.
    """
    external = geometry.look_at(eye, focus, up)
    return np.asarray(eye, dtype=float).reshape(3), geometry.matrix_to_quaternion(
        external[:3, :3].T)


def clip_polygons(polygons, width: float, height: float) -> Tuple[np.ndarray, np.ndarray]:
    """
    Clip convex polygons to the image rectangle [0, W] x [0, H].

    Sutherland-Hodgman against the four edges, vectorised over polygons.

    :param polygons: shape (M, K, 2), px, convex, padding by repeated
        vertices allowed; NaN rows are empty.
    :param width: W, px.
    :param height: H, px.
    :returns: ``(clipped, nonempty)``: clipped shape (M, K', 2), K' <= K + 4,
        winding kept, short outlines padded by repeating their last vertex, NaN
        rows where nothing (or only a line or point) is left; nonempty (M,) bool.
    """
    polygons = np.asarray(polygons, dtype=float)
    if polygons.ndim != 3 or polygons.shape[2] != 2:
        raise ValueError(f'polygons must have shape (M, K, 2), got {polygons.shape}')
    # Half-planes n . p + c >= 0: u >= 0, u <= W, v >= 0, v <= H.
    planes = ((1.0, 0.0, 0.0), (-1.0, 0.0, float(width)),
              (0.0, 1.0, 0.0), (0.0, -1.0, float(height)))
    with np.errstate(invalid='ignore'):
        inside = np.all((polygons[..., 0] >= 0) & (polygons[..., 0] <= width)
                        & (polygons[..., 1] >= 0) & (polygons[..., 1] <= height), axis=1)
    # Usually most outlines lie wholly on the panel: only the others are cut.
    cut = np.flatnonzero(~inside)
    pieces = polygons[cut]
    for a, b, c in planes:
        pieces = _clip_half_plane(pieces, a, b, c)
    width_out = max(polygons.shape[1], pieces.shape[1])
    clipped = _pad_vertices(polygons, width_out)
    clipped[cut] = _pad_vertices(pieces, width_out)
    area = geometry.polygon_signed_area(np.nan_to_num(clipped))
    nonempty = np.all(np.isfinite(clipped), axis=(1, 2)) & (np.abs(area) > 1e-12)
    clipped[~nonempty] = np.nan
    return clipped, nonempty


def _clip_half_plane(polygons: np.ndarray, a: float, b: float, c: float) -> np.ndarray:
    """Clip (M, K, 2) convex polygons to ``a u + b v + c >= 0``; see clip_polygons."""
    count, vertices = polygons.shape[:2]
    nxt = np.roll(polygons, -1, axis=1)
    with np.errstate(invalid='ignore', divide='ignore'):
        d = polygons[..., 0] * a + polygons[..., 1] * b + c
        d_next = np.roll(d, -1, axis=1)
        inside = d >= 0
        inside_next = d_next >= 0
        crossing = (inside != inside_next) & np.isfinite(d) & np.isfinite(d_next)
        t = d / (d - d_next)
        cut = polygons + t[..., None] * (nxt - polygons)
    # Each edge emits its start vertex if inside, then its crossing point.
    candidates = np.stack([polygons, cut], axis=2).reshape(count, 2 * vertices, 2)
    keep = np.stack([inside, crossing], axis=2).reshape(count, 2 * vertices)
    order = np.argsort(~keep, axis=1, kind='stable')
    kept = keep.sum(axis=1)
    width = max(int(kept.max(initial=0)), 1)
    compact = np.take_along_axis(candidates, order[:, :width, None], axis=1)
    # Pad short outlines with their last kept vertex; nothing kept -> NaN.
    column = np.arange(width)[None, :]
    last = np.maximum(kept - 1, 0)[:, None]
    compact = np.take_along_axis(compact, np.minimum(column, last)[..., None], axis=1)
    compact[kept == 0] = np.nan
    return compact


def _finite(name: str, value, size: int) -> np.ndarray:
    """Return ``value`` as a flat float array of ``size`` finite numbers, else ValueError."""
    array = np.array(value, dtype=float).reshape(-1)
    if array.size != size:
        raise ValueError(f'{name} needs {size} numbers, got {array.size}')
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{name} contains NaN or infinite values')
    return array


def _unit_quaternion(quaternion_xyzw) -> np.ndarray:
    """Return the normalised quaternion (4,), raising ValueError on zero or NaN."""
    q = _finite('quaternion', quaternion_xyzw, 4)
    norm = np.linalg.norm(q)
    if norm < 1e-9:
        raise ValueError('quaternion has zero length')
    return q / norm


def _canonical(quaternion_xyzw: np.ndarray) -> np.ndarray:
    """Pick the sign with w >= 0 so equal rotations compare equal."""
    return quaternion_xyzw if quaternion_xyzw[3] >= 0 else -quaternion_xyzw


class _PanelCamera:
    """
    What every RViz camera model shares: the render panel, where it sits, the pose.

    Subclasses give ``intrinsic``, ``project``, ``back_project`` and
    ``_silhouettes`` for their projection; ``unproject`` (a pixel at a depth)
    is built on them.

    :ivar image_size: (W, H) of the render panel, px.
    :ivar screen_offset: (X0, Y0), shape (2,), px: the render panel's top-left
        on the screen.
    :ivar external: shape (4, 4), world -> optical camera.
    """

    def _set_panel(self, image_size, screen_offset, external) -> None:
        """Check and store the panel size (W, H) px, offset (X0, Y0) px and external (4, 4)."""
        width, height = (float(v) for v in np.asarray(image_size, dtype=float).reshape(2))
        if not (np.isfinite(width) and np.isfinite(height)) or width <= 0 or height <= 0:
            raise ValueError(f'image size must be positive, got {width:g} x {height:g} px')
        self.image_size = (width, height)
        self.screen_offset = _finite('screen offset', screen_offset, 2)
        self.external = np.eye(4) if external is None else _check_external(external)

    @property
    def eye(self) -> np.ndarray:
        """Camera centre in the world frame, shape (3,), m."""
        return -self.external[:3, :3].T @ self.external[:3, 3]

    @property
    def projection(self) -> np.ndarray:
        """Return the 3x4 world -> image matrix ``intrinsic @ external`` (the report's C)."""
        return self.intrinsic @ self.external

    def to_screen(self, uv) -> np.ndarray:
        """Image px (..., 2) -> screen px (..., 2): add (X0, Y0)."""
        return np.asarray(uv, dtype=float) + self.screen_offset

    def to_image(self, screen_xy) -> np.ndarray:
        """Screen px (..., 2) -> image px (..., 2): subtract (X0, Y0)."""
        return np.asarray(screen_xy, dtype=float) - self.screen_offset

    def in_image(self, uv) -> np.ndarray:
        """Which image points (N, 2) lie on the render panel, shape (N,) bool."""
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        width, height = self.image_size
        with np.errstate(invalid='ignore'):
            return ((uv[:, 0] >= 0) & (uv[:, 0] <= width)
                    & (uv[:, 1] >= 0) & (uv[:, 1] <= height))

    def unproject(self, uv, depth) -> np.ndarray:
        """
        World points that project to image pixels at a depth: the inverse of ``project``.

        ``project(unproject(uv, d)) == (uv, d)`` for both projections (the
        point on the pixel's ray whose depth along the optical axis is ``d``).

        :param uv: shape (N, 2) (or (2,)), image px (``to_image`` of screen px).
        :param depth: m in front of the camera, > 0, scalar or shape (N,).
        :returns: shape (N, 3), world frame, m.
        :raises ValueError: a non-finite pixel or a depth that is not > 0.
        """
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        depth = np.broadcast_to(np.asarray(depth, dtype=float), (len(uv),))
        if not np.all(np.isfinite(depth) & (depth > 0)):
            raise ValueError(f'unproject needs depths > 0 m, got {depth.tolist()}')
        origins, directions = self.back_project(uv)
        # Depth is linear along a ray: solve depth(origin + t direction) = depth for t.
        _, start = self.project(origins)
        _, step = self.project(origins + directions)
        return origins + directions * ((depth - start) / (step - start))[:, None]

    def box_regions(self, positions, quaternions_xyzw, scales,
                    clip: bool = True) -> Tuple[np.ndarray, np.ndarray]:
        """
        Screen regions of M box markers.

        Each region is the convex hull of the box's projected corners (its
        exact silhouette), cut to the render panel when ``clip``, then moved
        by (X0, Y0) into screen px.  A box with any corner behind the camera,
        a box that contains the camera, and (when clipping) a box wholly off
        the panel has no region: it is never drawn inverted or off-panel.

        :param positions: shape (M, 3), world frame, m.
        :param quaternions_xyzw: shape (M, 4), order x, y, z, w, not zero.
        :param scales: shape (M, 3), full side lengths, m, > 0.
        :param clip: cut regions to the render panel [0, W] x [0, H].
        :returns: ``(polygons, visible)``: polygons shape (M, K, 2) screen px,
            counter-clockwise as the person sees it, padded by repeating the
            last vertex (K = 6, or at least 10 when clipping); visible shape (M,) bool;
            rows of invisible boxes are NaN.
        """
        polygons, visible = self._silhouettes(positions, quaternions_xyzw, scales)
        if clip:
            polygons, on_panel = clip_polygons(polygons, *self.image_size)
            visible = visible & on_panel
            polygons = _pad_vertices(polygons, 10)
        return self.to_screen(polygons), visible

    def __repr__(self) -> str:
        """Summarise the camera for logs."""
        return (f'{type(self).__name__}(image_size={self.image_size}, '
                f'screen_offset={self.screen_offset.tolist()}, eye={self.eye.round(3).tolist()})')


class RvizCamera(_PanelCamera):
    """
    A pinhole model of the camera RViz renders with, and where its panel sits.

    The perspective view controllers (Orbit, XYOrbit, ThirdPersonFollower,
    FPS).  Immutable: the ``with_*`` methods return a new camera.

    :ivar intrinsic: shape (3, 4), px.
    :ivar image_size: (W, H) of the render panel, px.
    :ivar screen_offset: (X0, Y0), shape (2,), px: the render panel's top-left
        on the screen.
    :ivar external: shape (4, 4), world -> optical camera.
    """

    #: Which projection this model uses.
    kind = 'perspective'

    def __init__(self, intrinsic, image_size: Sequence[int] = DEFAULT_IMAGE_SIZE,
                 screen_offset: Sequence[float] = (0.0, 0.0), external=None):
        """
        Build a camera.

        :param intrinsic: shape (3, 4) or 12 numbers row-major, see
            :func:`parse_intrinsic`.
        :param image_size: render panel (W, H), px, both > 0.
        :param screen_offset: (X0, Y0), px.
        :param external: shape (4, 4), world -> camera; identity when None
            (camera at the world origin looking along world +z).
        :raises ValueError: on any invalid part.
        """
        self.intrinsic = parse_intrinsic(intrinsic)
        self._set_panel(image_size, screen_offset, external)

    @classmethod
    def from_look_at(cls, eye, focus, up, image_size: Sequence[int] = DEFAULT_IMAGE_SIZE,
                     fov_y_deg: float = RVIZ_FOV_Y_DEG, intrinsic=None,
                     screen_offset: Sequence[float] = (0.0, 0.0)) -> 'RvizCamera':
        """
        Build a camera from an RViz view (eye, focus, up; world frame, m).

        :param intrinsic: calibrated (3, 4); when None the analytic RViz
            intrinsic of ``image_size`` and ``fov_y_deg`` is used.
        """
        if intrinsic is None:
            intrinsic = rviz_intrinsic(image_size[0], image_size[1], fov_y_deg)
        return cls(intrinsic, image_size, screen_offset, geometry.look_at(eye, focus, up))

    @classmethod
    def from_pose(cls, position, quaternion_xyzw,
                  image_size: Sequence[int] = DEFAULT_IMAGE_SIZE,
                  fov_y_deg: float = RVIZ_FOV_Y_DEG, intrinsic=None,
                  screen_offset: Sequence[float] = (0.0, 0.0)) -> 'RvizCamera':
        """
        Build a camera from its optical pose in the world frame.

        :param position: shape (3,), m.
        :param quaternion_xyzw: optical frame orientation, order x, y, z, w.
        """
        if intrinsic is None:
            intrinsic = rviz_intrinsic(image_size[0], image_size[1], fov_y_deg)
        return cls(intrinsic, image_size, screen_offset,
                   geometry.external_from_pose(position, quaternion_xyzw))

    def replace(self, intrinsic=None, image_size=None, screen_offset=None,
                external=None) -> 'RvizCamera':
        """Return a copy with the given parts changed (None keeps a part)."""
        return RvizCamera(
            self.intrinsic if intrinsic is None else intrinsic,
            self.image_size if image_size is None else image_size,
            self.screen_offset if screen_offset is None else screen_offset,
            self.external if external is None else external)

    def with_pose(self, position, quaternion_xyzw) -> 'RvizCamera':
        """Return a copy moved to an optical pose (world frame, x, y, z, w)."""
        return self.replace(external=geometry.external_from_pose(position, quaternion_xyzw))

    def with_look_at(self, eye, focus, up) -> 'RvizCamera':
        """Return a copy looking from ``eye`` at ``focus`` with ``up`` (world frame)."""
        return self.replace(external=geometry.look_at(eye, focus, up))

    def project(self, points) -> Tuple[np.ndarray, np.ndarray]:
        """
        Project world points into the image.

        :param points: shape (N, 3), world frame, m.
        :returns: ``(uv, depth)``: uv shape (N, 2) image px (NaN behind the
            camera), depth shape (N,) m along the optical axis.
        """
        return geometry.project_points(points, self.intrinsic, self.external)

    def back_project(self, uv) -> Tuple[np.ndarray, np.ndarray]:
        """
        World rays through image pixels.

        :param uv: shape (N, 2), image px.
        :returns: ``(origins, directions)``, both shape (N, 3), world frame:
            every ray starts at the eye; unit directions.
        """
        origin, directions = geometry.back_project(uv, self.intrinsic, self.external)
        return np.repeat(origin[None, :], len(directions), axis=0), directions

    def _silhouettes(self, positions, quaternions_xyzw, scales):
        return geometry.box_silhouettes(
            positions, quaternions_xyzw, scales, self.intrinsic, self.external)


class OrthographicCamera(_PanelCamera):
    """
    RViz2's orthographic camera (the TopDownOrtho view controller) and its panel.

    TopDownOrtho (``FixedOrientationOrthoViewController``) puts the camera at
    (X, Y, 500 m) above the target frame, looking straight down, turned by
    ``Angle`` about the world Z axis, with ``Scale`` px per m (ros2/rviz,
    jazzy, rviz_default_plugins/src/rviz_default_plugins/view_controllers/ortho/
    fixed_orientation_ortho_view_controller.cpp).  The model itself takes any
    optical pose: every world point at depth > 0 in front of the camera plane
    projects to ``u = s x_c + W/2``, ``v = s y_c + H/2`` (see
    :func:`eye_bci_ros2.projection.geometry.orthographic_intrinsic`).  Immutable.

    :ivar scale: px per m.
    :ivar intrinsic: affine shape (3, 4) ``[[s, 0, 0, W/2], [0, s, 0, H/2], [0, 0, 0, 1]]``,
        so :attr:`projection` is a 3x4 affine camera that the calibration
        report (:func:`eye_bci_ros2.projection.calibration.residuals`) reads like any other.
    """

    #: Which projection this model uses.
    kind = 'orthographic'

    #: Height of the TopDownOrtho camera above the target frame, m
    #: (``ORTHO_VIEW_CONTROLLER_CAMERA_Z`` in fixed_orientation_ortho_view_controller.cpp).
    CAMERA_Z = 500.0

    def __init__(self, scale_px_per_m: float, image_size: Sequence[int] = DEFAULT_IMAGE_SIZE,
                 screen_offset: Sequence[float] = (0.0, 0.0), external=None):
        """
        Build an orthographic camera.

        :param scale_px_per_m: px per m on the panel, > 0.
        :param image_size: render panel (W, H), px, both > 0.
        :param screen_offset: (X0, Y0), px.
        :param external: shape (4, 4), world -> optical camera; when None the
            TopDownOrtho camera at (0, 0, 500) with Angle 0.
        :raises ValueError: on any invalid part.
        """
        if external is None:
            external = top_down_external(0.0, 0.0, 0.0)
        self._set_panel(image_size, screen_offset, external)
        self.scale = float(scale_px_per_m)
        self.intrinsic = geometry.orthographic_intrinsic(*self.image_size, self.scale)

    @classmethod
    def top_down(cls, x: float, y: float, angle: float, scale_px_per_m: float,
                 image_size: Sequence[int] = DEFAULT_IMAGE_SIZE,
                 screen_offset: Sequence[float] = (0.0, 0.0)) -> 'OrthographicCamera':
        """Build the camera of a TopDownOrtho view (X, Y m; Angle rad; Scale px/m)."""
        return cls(scale_px_per_m, image_size, screen_offset, top_down_external(x, y, angle))

    def replace(self, scale_px_per_m=None, image_size=None, screen_offset=None,
                external=None) -> 'OrthographicCamera':
        """Return a copy with the given parts changed (None keeps a part)."""
        return OrthographicCamera(
            self.scale if scale_px_per_m is None else scale_px_per_m,
            self.image_size if image_size is None else image_size,
            self.screen_offset if screen_offset is None else screen_offset,
            self.external if external is None else external)

    def with_pose(self, position, quaternion_xyzw) -> 'OrthographicCamera':
        """Return a copy moved to an optical pose (world frame, x, y, z, w)."""
        return self.replace(external=geometry.external_from_pose(position, quaternion_xyzw))

    def project(self, points) -> Tuple[np.ndarray, np.ndarray]:
        """
        Project world points into the image (parallel projection).

        :param points: shape (N, 3), world frame, m.
        :returns: ``(uv, depth)``: uv shape (N, 2) image px (NaN behind the
            camera plane), depth shape (N,) m along the optical axis.
        """
        return geometry.project_points_orthographic(points, self.intrinsic, self.external)

    def back_project(self, uv) -> Tuple[np.ndarray, np.ndarray]:
        """
        World rays through image pixels: parallel, one per pixel.

        :param uv: shape (N, 2), image px.
        :returns: ``(origins, directions)``, both shape (N, 3), world frame:
            origins on the camera plane, every direction the optical axis.
        """
        return geometry.back_project_orthographic(uv, self.intrinsic, self.external)

    def _silhouettes(self, positions, quaternions_xyzw, scales):
        return geometry.box_silhouettes_orthographic(
            positions, quaternions_xyzw, scales, self.intrinsic, self.external)


def top_down_external(x: float, y: float, angle: float) -> np.ndarray:
    """
    World -> optical camera of a TopDownOrtho view.

    The controller sets the camera node's position to (X, Y, 500) and its
    orientation to ``Quaternion(Angle, UNIT_Z)`` (Ogre camera: looks along -Z,
    up +Y), fixed_orientation_ortho_view_controller.cpp ``orientCamera`` and
    ``updateCamera``.  So optical x (right) = (cos a, sin a, 0), y (down) =
    (sin a, -cos a, 0), z (forward) = (0, 0, -1).

    :param x: X, m, world frame.
    :param y: Y, m, world frame.
    :param angle: Angle about world Z, rad.
    :returns: shape (4, 4).
    """
    values = np.array([x, y, angle], dtype=float)
    if not np.all(np.isfinite(values)):
        raise ValueError(f'TopDownOrtho view needs finite X, Y and Angle, got {values.tolist()}')
    c, s = np.cos(values[2]), np.sin(values[2])
    rotation = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])  # rows: optical axes
    external = np.eye(4)
    external[:3, :3] = rotation
    external[:3, 3] = -rotation @ np.array([values[0], values[1], OrthographicCamera.CAMERA_Z])
    return external


def _pad_vertices(polygons: np.ndarray, count: int) -> np.ndarray:
    """Pad (M, K, 2) outlines to (M, max(K, count), 2) by repeating the last vertex."""
    missing = count - polygons.shape[1]
    if missing <= 0:
        return polygons
    return np.concatenate([polygons, np.repeat(polygons[:, -1:], missing, axis=1)], axis=1)


def _check_external(external) -> np.ndarray:
    """Validate a 4x4 rigid world -> camera transform and return it as floats."""
    external = _finite('external', external, 16).reshape(4, 4)
    rotation = external[:3, :3]
    if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6) or \
            np.linalg.det(rotation) <= 0 or not np.allclose(external[3], [0, 0, 0, 1]):
        raise ValueError('external must be a rigid 4x4 transform (rotation and translation)')
    return external.copy()
