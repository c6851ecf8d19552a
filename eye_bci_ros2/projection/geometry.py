"""
Projection geometry of the RViz camera: pure numpy, no rclpy.

Conventions (see docs/DESIGN.md):

* world: the RViz fixed frame, metres.
* camera (optical, REP-103): origin at the eye, z forward, x right, y down, metres.
* image: top-left of the render panel, u right, v down, pixels.
* screen: image + (X0, Y0), pixels.
* Quaternions are ordered x, y, z, w (as in ROS messages).

An *External* is the 4x4 homogeneous transform world -> camera; an *Intrinsic*
is the 3x4 matrix [[fx, s, cx, 0], [0, fy, cy, 0], [0, 0, 1, 0]].  Every
function is vectorised over points and markers and raises ``ValueError`` with
a readable message on bad input.
"""

from typing import List, Tuple

import numpy as np

#: The world frame's default name: RViz2's default fixed frame (every node's ``world_frame``,
#: the scene file's ``frame_id``).
WORLD_FRAME = 'map'

#: Corner ``i`` of a box has local offset ``signs[i] * scale / 2``; bit 0 of ``i``
#: is +x, bit 1 +y, bit 2 +z.
CORNER_SIGNS = np.array(
    [[1.0 if (i >> axis) & 1 else -1.0 for axis in range(3)] for i in range(8)])

#: Points closer than this in front of the camera (m) count as behind it.
MIN_DEPTH = 1e-6


def _finite_array(name: str, value, shape_tail: Tuple[int, ...]) -> np.ndarray:
    """Return ``value`` as a float array whose trailing shape is ``shape_tail``."""
    array = np.asarray(value, dtype=float)
    if array.shape[array.ndim - len(shape_tail):] != shape_tail or \
            array.ndim < len(shape_tail):
        raise ValueError(f'{name} must have shape (..., {", ".join(map(str, shape_tail))}), '
                         f'got {array.shape}')
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{name} contains NaN or infinite values')
    return array


def _matrix(name: str, value, shape: Tuple[int, int]) -> np.ndarray:
    """Return ``value`` as a finite float matrix of exactly ``shape``."""
    array = np.asarray(value, dtype=float)
    if array.shape != shape:
        raise ValueError(f'{name} must be a {shape[0]}x{shape[1]} matrix, got shape {array.shape}')
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{name} contains NaN or infinite values')
    return array


def look_at(eye, focus, up) -> np.ndarray:
    """
    Build the External (world -> optical camera) of an RViz view.

    :param eye: camera position P in the world frame, shape (3,), m.
    :param focus: point F the camera looks at, world frame, shape (3,), m.
    :param up: world vector that appears pointing up (-v) in the image, shape (3,).
    :returns: 4x4 homogeneous transform; rows of its rotation are the camera's
        x (right), y (down), z (forward) axes expressed in the world frame.
    :raises ValueError: eye == focus, up parallel to the view, zero up or NaN.
    """
    eye = _finite_array('eye', eye, (3,))
    focus = _finite_array('focus', focus, (3,))
    up = _finite_array('up', up, (3,))
    forward = focus - eye
    distance = np.linalg.norm(forward)
    if distance < 1e-9:
        raise ValueError(f'degenerate camera: eye {eye.tolist()} equals focus')
    z_axis = forward / distance
    up_norm = np.linalg.norm(up)
    if up_norm < 1e-12:
        raise ValueError('degenerate camera: up vector is zero')
    up_perp = up / up_norm - np.dot(up / up_norm, z_axis) * z_axis
    perp_norm = np.linalg.norm(up_perp)
    if perp_norm < 1e-6:
        raise ValueError(f'degenerate camera: up {up.tolist()} is parallel to the view '
                         f'direction {z_axis.tolist()}')
    y_axis = -up_perp / perp_norm
    x_axis = np.cross(y_axis, z_axis)
    external = np.eye(4)
    external[0, :3] = x_axis
    external[1, :3] = y_axis
    external[2, :3] = z_axis
    external[:3, 3] = -external[:3, :3] @ eye
    return external


def external_from_pose(position, quaternion_xyzw) -> np.ndarray:
    """
    Build the External from an optical camera pose in the world frame.

    :param position: camera centre in the world frame, shape (3,), m.
    :param quaternion_xyzw: orientation of the optical camera frame in the
        world frame, order x, y, z, w (need not be unit, must not be zero).
    :returns: 4x4 world -> camera transform.
    """
    position = _finite_array('position', position, (3,))
    rotation = quaternion_to_matrix(quaternion_xyzw)
    external = np.eye(4)
    external[:3, :3] = rotation.T
    external[:3, 3] = -rotation.T @ position
    return external


def quaternion_to_matrix(quaternion_xyzw) -> np.ndarray:
    """
    Rotation matrices of quaternions, normalised first.

    :param quaternion_xyzw: shape (4,) or (M, 4), order x, y, z, w.
    :returns: shape (3, 3) or (M, 3, 3).
    :raises ValueError: a zero or non-finite quaternion.
    """
    q = _finite_array('quaternion', quaternion_xyzw, (4,))
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(norm < 1e-9):
        raise ValueError('quaternion has zero length')
    x, y, z, w = np.moveaxis(q / norm, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def matrix_to_quaternion(rotation) -> np.ndarray:
    """
    Quaternion (x, y, z, w) of a rotation matrix, with w >= 0.

    :param rotation: shape (3, 3), proper orthonormal.
    :returns: shape (4,).
    """
    m = np.asarray(rotation, dtype=float)
    trace = np.trace(m)
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4, (m[1, 0] - m[0, 1]) / s]
    q = np.array(q)
    return q if q[3] >= 0 else -q


def project_points(points, intrinsic, external) -> Tuple[np.ndarray, np.ndarray]:
    """
    Project world points to image pixels.

    :param points: shape (N, 3), world frame, m.
    :param intrinsic: shape (3, 4).
    :param external: shape (4, 4), world -> camera.
    :returns: ``(uv, depth)``: uv shape (N, 2) in image px, depth shape (N,) in m
        along the optical axis.  Points with depth <= 0 are behind the camera:
        their uv is NaN.
    """
    points = _finite_array('points', points, (3,)).reshape(-1, 3)
    projection = _matrix('intrinsic', intrinsic, (3, 4)) @ _matrix('external', external, (4, 4))
    uv, depth = apply_projection(projection, points)
    uv[depth <= MIN_DEPTH] = np.nan
    return uv, depth


def apply_projection(projection: np.ndarray, points: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """
    Divide by depth: image px of points under a 3x4 projection (the one perspective formula).

    :param projection: shape (3, 4), e.g. ``intrinsic @ external[:3]``.
    :param points: shape (N, 3), world frame, m (validated by the caller).
    :returns: ``(uv, w)``: uv shape (N, 2) px (inf or NaN where w = 0), w
        shape (N,) the homogeneous third coordinate: the depth along the
        optical axis for an RViz intrinsic.  What a point behind the camera
        gets is the caller's rule: :func:`project_points` knows the depth
        and sets NaN; a DLT matrix has an arbitrary scale and sign, so
        :func:`eye_bci_ros2.projection.calibration.project` cannot tell behind from in
        front.
    """
    homogeneous = points @ projection[:, :3].T + projection[:, 3]
    w = homogeneous[:, 2]
    with np.errstate(divide='ignore', invalid='ignore'):
        uv = homogeneous[:, :2] / w[:, None]
    return uv, w


def orthographic_intrinsic(width, height, scale_px_per_m) -> np.ndarray:
    """
    Affine 3x4 intrinsic of RViz2's orthographic camera (TopDownOrtho).

    The view controller sets the projection
    ``buildScaledOrthoMatrix(-W / scale / 2, W / scale / 2, -H / scale / 2, H / scale / 2,
    near, far)`` on a panel of W x H px (ros2/rviz, jazzy,
    rviz_default_plugins/src/rviz_default_plugins/view_controllers/ortho/
    fixed_orientation_ortho_view_controller.cpp, ``updateCamera``; the matrix in
    rviz_rendering/src/rviz_rendering/orthographic.cpp), so one metre across the
    view is ``scale`` px and the optical axis hits the panel centre:
    ``u = scale * x_c + W / 2``, ``v = scale * y_c + H / 2`` (optical x_c right,
    y_c down, m).

    :param width: W, px, > 0.
    :param height: H, px, > 0.
    :param scale_px_per_m: the view's ``Scale``, px per m, > 0.
    :returns: ``[[s, 0, 0, W/2], [0, s, 0, H/2], [0, 0, 0, 1]]``, shape (3, 4): the
        standard affine camera form, so ``intrinsic @ external`` is a 3x4
        projection whose homogeneous third coordinate is always 1.
    """
    values = np.array([width, height, scale_px_per_m], dtype=float)
    if not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise ValueError(f'orthographic camera needs a positive panel size and scale, got '
                         f'{width} x {height} px at {scale_px_per_m} px/m')
    scale = values[2]
    return np.array([[scale, 0.0, 0.0, values[0] / 2], [0.0, scale, 0.0, values[1] / 2],
                     [0.0, 0.0, 0.0, 1.0]])


def _affine(intrinsic) -> np.ndarray:
    """Check an affine (orthographic) 3x4 intrinsic: no z term, last row [0, 0, 0, 1]."""
    intrinsic = _matrix('orthographic intrinsic', intrinsic, (3, 4))
    if np.any(np.abs(intrinsic[:2, 2]) > 1e-12) or \
            not np.allclose(intrinsic[2], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError('orthographic intrinsic must be [[a, b, 0, cx], [c, d, 0, cy], '
                         f'[0, 0, 0, 1]], got {intrinsic.tolist()}')
    if abs(np.linalg.det(intrinsic[:2, :2])) < 1e-12:
        raise ValueError('orthographic intrinsic is singular (zero scale)')
    return intrinsic


def project_points_orthographic(points, intrinsic, external) -> Tuple[np.ndarray, np.ndarray]:
    """
    Project world points to image pixels with an orthographic camera.

    :param points: shape (N, 3), world frame, m.
    :param intrinsic: affine (3, 4), see :func:`orthographic_intrinsic`.
    :param external: shape (4, 4), world -> optical camera.
    :returns: ``(uv, depth)``: uv shape (N, 2) in image px, depth shape (N,) in m
        along the optical axis from the camera plane.  Points with depth <= 0
        are behind the camera plane: their uv is NaN.
    """
    points = _finite_array('points', points, (3,)).reshape(-1, 3)
    external = _matrix('external', external, (4, 4))
    camera = points @ external[:3, :3].T + external[:3, 3]
    intrinsic = _affine(intrinsic)
    uv = camera[:, :2] @ intrinsic[:2, :2].T + intrinsic[:2, 3]
    depth = camera[:, 2]
    uv[depth <= MIN_DEPTH] = np.nan
    return uv, depth


def back_project_orthographic(pixels, intrinsic, external) -> Tuple[np.ndarray, np.ndarray]:
    """
    World rays through image pixels of an orthographic camera.

    :param pixels: shape (N, 2), image px.
    :param intrinsic: affine (3, 4), see :func:`orthographic_intrinsic`.
    :param external: shape (4, 4), world -> optical camera.
    :returns: ``(origins, directions)``, both shape (N, 3), world frame: each
        ray starts on the camera plane and runs along the optical axis (the
        same unit direction for every pixel); every point
        ``origin + t * direction`` with t > 0 projects to the pixel.
    """
    pixels = _finite_array('pixels', pixels, (2,)).reshape(-1, 2)
    intrinsic = _affine(intrinsic)
    external = _matrix('external', external, (4, 4))
    planar = np.linalg.solve(intrinsic[:2, :2], (pixels - intrinsic[:2, 3]).T).T
    camera = np.column_stack([planar, np.zeros(len(pixels))])
    rotation, translation = external[:3, :3], external[:3, 3]
    origins = (camera - translation) @ rotation
    directions = np.repeat(rotation[2][None, :], len(pixels), axis=0)
    return origins, directions


def cube_corners(position, quaternion_xyzw, scale) -> np.ndarray:
    """
    Corners of a cube marker.

    :param position: marker centre, shape (3,), world frame, m.
    :param quaternion_xyzw: orientation, order x, y, z, w.
    :param scale: full side lengths (sx, sy, sz), m; must be positive.
    :returns: shape (8, 3); corner ``i`` is ``p + R (signs[i] * scale / 2)``,
        see :data:`CORNER_SIGNS`.
    """
    position = _finite_array('position', position, (3,))
    quaternion_xyzw = _finite_array('quaternion', quaternion_xyzw, (4,))
    scale = _finite_array('scale', scale, (3,))
    if position.ndim != 1 or quaternion_xyzw.ndim != 1 or scale.ndim != 1:
        raise ValueError('cube_corners takes one marker: position (3,), quaternion (4,), '
                         'scale (3,); use cube_corners_batch for several')
    return cube_corners_batch(position[None], quaternion_xyzw[None], scale[None])[0]


def cube_corners_batch(positions, quaternions_xyzw, scales) -> np.ndarray:
    """
    Corners of M cube markers at once.

    :param positions: shape (M, 3), world frame, m.
    :param quaternions_xyzw: shape (M, 4), order x, y, z, w.
    :param scales: shape (M, 3), full side lengths, m, all > 0.
    :returns: shape (M, 8, 3).
    """
    positions = _finite_array('positions', positions, (3,)).reshape(-1, 3)
    quaternions = _finite_array('quaternions', quaternions_xyzw, (4,)).reshape(-1, 4)
    scales = _finite_array('scales', scales, (3,)).reshape(-1, 3)
    if not len(positions) == len(quaternions) == len(scales):
        raise ValueError(f'got {len(positions)} positions, {len(quaternions)} quaternions and '
                         f'{len(scales)} scales: one of each per marker')
    if np.any(scales <= 0):
        raise ValueError('cube scale must be positive on every axis')
    rotations = quaternion_to_matrix(quaternions)
    local = CORNER_SIGNS[None, :, :] * (scales[:, None, :] / 2)
    return positions[:, None, :] + np.einsum('mij,mkj->mki', rotations, local)


def _convex_hull_indices(points: np.ndarray) -> list:
    """Return the convex hull of 2-D points as indices, counter-clockwise (monotone chain)."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))

    def cross(o, a, b):
        return ((points[a][0] - points[o][0]) * (points[b][1] - points[o][1])
                - (points[a][1] - points[o][1]) * (points[b][0] - points[o][0]))

    lower, upper = [], []
    for i in order:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], i) <= 1e-12:
            lower.pop()
        lower.append(i)
    for i in reversed(order):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], i) <= 1e-12:
            upper.pop()
        upper.append(i)
    return lower[:-1] + upper[:-1]


def _silhouette_table() -> Tuple[np.ndarray, np.ndarray]:
    """
    Silhouette corner cycles of a box for each region the eye can be in.

    The eye's position relative to the box's three slabs (below, inside,
    above on each local axis) fixes which faces face it, hence which edges
    form the outline (Schmalstieg and Tobler, "Fast projected area
    computation for 3D bounding boxes", 1999).  The table is derived once
    here from a representative eye in each of the 26 outside regions.
    Rows hold 6 corner indices; 4-vertex outlines repeat their last index.
    Row order gives a negative signed area in (u, v) for every eye in the
    region (a proper camera cannot mirror the outline); the second table
    holds the same cycles reversed, for mirrored (e.g. fy < 0) intrinsics.
    """
    table = np.zeros((27, 6), dtype=np.intp)
    mirrored = np.zeros((27, 6), dtype=np.intp)
    corners = CORNER_SIGNS / 2
    for code in range(27):
        cls = np.array([code % 3, (code // 3) % 3, code // 9]) - 1
        if not cls.any():
            continue  # eye inside the box: no silhouette
        eye = cls * 3.0
        up = np.array([0.0, 0.0, 1.0]) if abs(cls[2]) == 0 or cls[:2].any() \
            else np.array([0.0, 1.0, 0.0])
        uv, _ = project_points(corners, np.array([[1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]),
                               look_at(eye, np.zeros(3), up))
        hull = _convex_hull_indices(uv.tolist())[::-1]
        table[code] = hull + [hull[-1]] * (6 - len(hull))
        mirrored[code] = hull[::-1] + [hull[0]] * (6 - len(hull))
    return table, mirrored


_SILHOUETTE, _SILHOUETTE_MIRRORED = _silhouette_table()


def box_silhouettes(positions, quaternions_xyzw, scales, intrinsic,
                    external) -> Tuple[np.ndarray, np.ndarray]:
    """
    Image outlines of M boxes: the convex hull of each one's projected corners.

    For a box wholly in front of the camera this is its exact silhouette under
    perspective.  Boxes with any corner at depth <= 0, and boxes that contain
    the eye, have no outline: they are reported invisible, never drawn
    inverted.

    :param positions: shape (M, 3), world frame, m.
    :param quaternions_xyzw: shape (M, 4), order x, y, z, w.
    :param scales: shape (M, 3), m, > 0.
    :param intrinsic: shape (3, 4).
    :param external: shape (4, 4), world -> camera.
    :returns: ``(polygons, visible)``: polygons shape (M, 6, 2) in image px,
        counter-clockwise on the screen as a person sees it (u right, v down,
        so the signed area in (u, v) is negative); 4-vertex outlines repeat their last
        vertex.  visible shape (M,) bool; rows of invisible boxes are NaN.
    """
    external = _matrix('external', external, (4, 4))
    positions, quaternions, scales = _boxes(positions, quaternions_xyzw, scales)
    corners = cube_corners_batch(positions, quaternions, scales)
    uv, depth = project_points(corners.reshape(-1, 3), intrinsic, external)
    # Eye in each box's local frame decides which outline the box shows.
    rotations = quaternion_to_matrix(quaternions)
    eye_world = -external[:3, :3].T @ external[:3, 3]
    eye_local = np.einsum('mji,mj->mi', rotations, eye_world - positions)
    half = scales / 2
    cls = (eye_local > half).astype(np.intp) - (eye_local < -half).astype(np.intp) + 1
    return _outlines(uv, depth, cls)


def box_silhouettes_orthographic(positions, quaternions_xyzw, scales, intrinsic,
                                 external) -> Tuple[np.ndarray, np.ndarray]:
    """
    Image outlines of M boxes under an orthographic camera (RViz2's TopDownOrtho).

    Under a parallel projection the silhouette of a box is the convex hull of
    its projected corners, which faces bound it depends only on the view
    direction (the eye "at infinity" behind the camera).  A box with any
    corner at depth <= 0 (behind the camera plane) has no outline.

    :param intrinsic: affine (3, 4) ``[[a, b, 0, cx], [c, d, 0, cy], [0, 0, 0, 1]]``,
        see :func:`project_points_orthographic`.
    :returns: as :func:`box_silhouettes`.
    """
    external = _matrix('external', external, (4, 4))
    positions, quaternions, scales = _boxes(positions, quaternions_xyzw, scales)
    corners = cube_corners_batch(positions, quaternions, scales)
    uv, depth = project_points_orthographic(corners.reshape(-1, 3), intrinsic, external)
    rotations = quaternion_to_matrix(quaternions)
    # Direction towards the eye at infinity, in each box's local frame.
    toward_eye = np.einsum('mji,j->mi', rotations, -external[2, :3])
    cls = np.sign(np.where(np.abs(toward_eye) < 1e-12, 0.0, toward_eye)).astype(np.intp) + 1
    return _outlines(uv, depth, cls)


def _boxes(positions, quaternions_xyzw, scales) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Check and shape M boxes: positions (M, 3), quaternions (M, 4), scales (M, 3)."""
    positions = _finite_array('positions', positions, (3,)).reshape(-1, 3)
    scales = _finite_array('scales', scales, (3,)).reshape(-1, 3)
    quaternions = _finite_array('quaternions', quaternions_xyzw, (4,)).reshape(-1, 4)
    return positions, quaternions, scales


def _outlines(uv: np.ndarray, depth: np.ndarray,
              cls: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """
    Pick each box's outline from its projected corners.

    :param uv: shape (M * 8, 2), image px of the corners.
    :param depth: shape (M * 8,), m.
    :param cls: shape (M, 3), per local axis 0 (eye below the slab), 1 (in
        it) or 2 (above it); all 1 means the eye is inside the box.
    """
    count = len(cls)
    uv = uv.reshape(count, 8, 2)
    in_front = np.all(depth.reshape(count, 8) > MIN_DEPTH, axis=1)
    code = cls[:, 0] + 3 * cls[:, 1] + 9 * cls[:, 2]
    visible = in_front & (code != 13)
    polygons = np.take_along_axis(uv, _SILHOUETTE[code][:, :, None], axis=1)
    mirror = polygon_signed_area(polygons) > 0
    if np.any(mirror):
        polygons[mirror] = np.take_along_axis(
            uv[mirror], _SILHOUETTE_MIRRORED[code[mirror]][:, :, None], axis=1)
    polygons[~visible] = np.nan
    return polygons, visible


def polygon_signed_area(polygons) -> np.ndarray:
    """
    Shoelace signed area of polygons, shape (..., K, 2) -> (...,).

    Positive when the vertices turn counter-clockwise in a right-handed (x
    right, y up) plane, so negative for an on-screen counter-clockwise loop in
    image coordinates (v down).
    """
    p = np.asarray(polygons, dtype=float)
    x, y = p[..., 0], p[..., 1]
    return 0.5 * np.sum(x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y, axis=-1)


def orient_polygons(polygons) -> np.ndarray:
    """Return convex polygons (M, K, 2) reordered to a negative signed area in (u, v)."""
    polygons = np.array(polygons, dtype=float)
    flip = polygon_signed_area(polygons) > 0
    polygons[flip] = polygons[flip, ::-1]
    return polygons


def points_in_convex_polygons(points, polygons, tolerance: float = 1e-9) -> np.ndarray:
    """
    Which points lie in which convex polygons (edges count as inside).

    :param points: shape (N, 2), px.
    :param polygons: shape (R, K, 2), convex, either winding (repeated
        vertices allowed as padding); NaN rows contain nothing.
    :param tolerance: slack in px^2 on the edge test.
    :returns: shape (N, R) bool.
    """
    return PolygonSet(polygons).contains(points, tolerance)


class PolygonSet:
    """
    Convex polygons prepared for fast point tests (edge half-planes as a matrix).

    Each edge k of polygon r is the half-plane ``a x + b y + c >= 0``; testing
    N points is one (N, 3) x (3, K*R) product, then a minimum over K.  The
    columns are edge-major (all polygons' edge 0, then edge 1, ...) so the
    minimum is K - 1 element-wise passes over contiguous (N, R) slices, which
    is ~10x faster than numpy's reduction over a short trailing axis; large N
    is processed in blocks whose (block, K*R) products stay in cache.
    """

    #: Bytes of the (block, K*R) edge-value matrix of one block of points.
    BLOCK_BYTES = 1 << 20
    #: Up to this many points one vectorised pass is cheapest (per-message path).
    SMALL_BATCH = 32

    def __init__(self, polygons):
        """Prepare ``polygons`` (R, K, 2), convex, any winding, NaN = empty."""
        polygons = np.asarray(polygons, dtype=float)
        if polygons.ndim != 3 or polygons.shape[2] != 2:
            raise ValueError(f'polygons must have shape (R, K, 2), got {polygons.shape}')
        self.polygons = polygons
        self.count, self.vertex_count = polygons.shape[:2]
        valid = np.all(np.isfinite(polygons), axis=(1, 2))
        oriented = np.where(valid[:, None, None], polygons, 0.0)
        # Orient every polygon one way so a single sign test works.
        oriented = orient_polygons(oriented)
        start = oriented
        end = np.roll(oriented, -1, axis=1)
        edge = end - start
        # Inside of a negative-area (image-CCW) loop is where cross(edge, p - start) <= 0.
        a = edge[..., 1]
        b = -edge[..., 0]
        c = -(a * start[..., 0] + b * start[..., 1])
        # Edge-major columns: column k * R + r is edge k of polygon r.
        self._coefficients = np.ascontiguousarray(
            np.stack([a, b, c]).transpose(0, 2, 1).reshape(3, -1))
        self._valid = valid
        self._block = max(256, self.BLOCK_BYTES // (8 * max(1, self.count * self.vertex_count)))
        # The same half-planes as Python floats, per valid polygon (contains_one).
        columns = self._coefficients.T.reshape(self.vertex_count, self.count, 3).tolist()
        self._edges = [[columns[edge][index] for edge in range(self.vertex_count)]
                       if valid[index] else None for index in range(self.count)]

    def contains(self, points, tolerance: float = 1e-9) -> np.ndarray:
        """
        Inside test.

        :param points: shape (N, 2), px; NaN points are inside nothing.
        :returns: shape (N, R) bool.
        """
        points = np.asarray(points, dtype=float)
        if points.ndim not in (1, 2) or points.shape[-1] != 2:
            raise ValueError(f'points must have shape (N, 2), got {points.shape}')
        points = points.reshape(-1, 2)
        count, regions, edges = len(points), self.count, self.vertex_count
        if count <= self.SMALL_BATCH:
            homogeneous = np.empty((count, 3))
            homogeneous[:, :2] = points
            homogeneous[:, 2] = 1.0
            worst = (homogeneous @ self._coefficients).reshape(count, edges, regions).min(axis=1)
            return (worst >= -tolerance) & self._valid[None, :]
        inside = np.empty((count, regions), dtype=bool)
        homogeneous = np.ones((min(count, self._block), 3))
        for start in range(0, count, self._block):
            size = min(self._block, count - start)
            homogeneous[:size, :2] = points[start:start + size]
            values = (homogeneous[:size] @ self._coefficients).reshape(size, edges, regions)
            worst = values[:, 0].copy()
            for edge in range(1, edges):
                np.minimum(worst, values[:, edge], out=worst)
            np.greater_equal(worst, -tolerance, out=inside[start:start + size])
        inside &= self._valid[None, :]
        return inside

    def contains_one(self, x: float, y: float, tolerance: float = 1e-9) -> List[bool]:
        """
        Inside test of one point (x, y) px: :meth:`contains` of one row, in Python floats.

        The per-sample path (a highlight, a fixation's place): for one point a numpy
        operation costs more than its arithmetic.  NaN is inside nothing.

        :returns: one bool per polygon (R,).
        """
        return [edges is not None and all(a * x + b * y + c >= -tolerance for a, b, c in edges)
                for edges in self._edges]


def back_project(pixels, intrinsic, external) -> Tuple[np.ndarray, np.ndarray]:
    """
    World rays through image pixels.

    :param pixels: shape (N, 2), image px.
    :param intrinsic: shape (3, 4); ``intrinsic @ external`` must have an
        invertible left 3x3 block.
    :param external: shape (4, 4), world -> camera.
    :returns: ``(origin, directions)``: the eye, shape (3,), and unit ray
        directions, shape (N, 3), in the world frame.  Every point
        ``origin + t * direction`` with t > 0 projects to the pixel.
    """
    pixels = _finite_array('pixels', pixels, (2,)).reshape(-1, 2)
    # General form, so calibrated intrinsics with a non-zero 4th column work too.
    projection = _matrix('intrinsic', intrinsic, (3, 4)) @ _matrix('external', external, (4, 4))
    left = projection[:, :3]
    if abs(np.linalg.det(left)) < 1e-12 * max(1.0, np.abs(left).max() ** 3):
        raise ValueError('projection is singular: cannot back-project')
    origin = -np.linalg.solve(left, projection[:, 3])
    homogeneous = np.column_stack([pixels, np.ones(len(pixels))])
    directions = np.linalg.solve(left, homogeneous.T).T
    # A ray points forward when its depth (third row) grows along it.
    directions *= np.sign(directions @ left[2])[:, None]
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return origin, directions
