"""
Calibration of the RViz camera intrinsic from world/pixel pairs: pure numpy, no rclpy.

Frames and units (docs/DESIGN.md): world points in m (the RViz fixed frame), pixels
in *image* px (top-left of the render panel, u right, v down), the External is
the 4x4 world -> optical camera transform (z forward, x right, y down).

Three ways to get the 3x4 Intrinsic ``[[fx, s, cx, 0], [0, fy, cy, 0], [0, 0, 1, 0]]``:

* :func:`rviz_intrinsic`: the analytic RViz2 (Ogre) model, no data needed.
* :func:`fit_projection` + :func:`intrinsic_from_projection`: the original
  report's procedure, an 11-parameter DLT for ``C = Intrinsic . External``
  (normalised, after Hartley) then ``Intrinsic = C . External^-1``.  Needs at
  least 6 points that are not coplanar.
* :func:`fit_intrinsic`: with the External known, a linear least-squares fit
  of only the intrinsic parameters; its residuals are pixel distances, so it
  is the maximum-likelihood fit for Gaussian reading noise.  Works with 3
  points and on a flat map.

:func:`calibrate` runs one of them on a fit subset and reports residuals
(:class:`Residuals`) on fit and held-out points; :func:`compare_with_rviz`
turns a disagreement with the analytic model into a diagnosis.
"""

from dataclasses import dataclass, field
import math
from typing import Dict, List, Optional, Sequence

import numpy as np

from eye_bci_ros2.projection import geometry
# rviz_intrinsic is in the calibration API too.
from eye_bci_ros2.projection.camera_model import rviz_intrinsic
from eye_bci_ros2.projection.geometry import MIN_DEPTH

#: Points closer than this in front of the camera (m) count as behind it.

#: Relative singular value below which a configuration counts as degenerate.
RANK_TOLERANCE = 1e-9

#: Fewest points each method accepts.
MIN_POINTS = {'dlt': 6, 'rviz': 3, 'full': 3}

#: Intrinsic models of :func:`fit_intrinsic` and what they leave free.
MODELS = {'rviz': 'f, cx, cy (square pixels, no skew)', 'full': 'fx, fy, skew, cx, cy'}

#: Display scale factors that explain a focal length off by a constant ratio.
HIDPI_FACTORS = (1.25, 1.5, 1.75, 2.0, 2.5, 3.0)


def _as_array(name: str, value, columns: int) -> np.ndarray:
    """Return ``value`` as a finite float array of shape (N, columns)."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f'{name} must be numbers, shape (N, {columns}): {error}') from None
    if array.ndim != 2 or array.shape[1] != columns:
        raise ValueError(f'{name} must have shape (N, {columns}), got {array.shape}')
    bad = ~np.all(np.isfinite(array), axis=1)
    if np.any(bad):
        raise ValueError(f'{name} contains NaN or infinite values '
                         f'(rows {np.flatnonzero(bad).tolist()})')
    return array


def _matrix(name: str, value, shape) -> np.ndarray:
    """Return ``value`` as a finite float matrix of the given shape."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f'{name} must be a {shape[0]}x{shape[1]} matrix of numbers: '
                         f'{error}') from None
    if array.shape != tuple(shape):
        raise ValueError(f'{name} must have shape {tuple(shape)}, got {array.shape}')
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{name} contains NaN or infinite values')
    return array


def _external(value) -> np.ndarray:
    """Check an External: a rigid 4x4 world -> camera transform."""
    external = _matrix('external', value, (4, 4))
    if not np.allclose(external[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise ValueError(f'external must be a homogeneous transform with last row [0, 0, 0, 1], '
                         f'got {external[3].tolist()}')
    rotation = external[:3, :3]
    if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6) or \
            np.linalg.det(rotation) < 0:
        raise ValueError('external rotation is not a proper rotation matrix (orthonormal, '
                         'det +1): build it with geometry.look_at or external_from_pose')
    return external


def _correspondences(points, pixels, minimum: int, method: str):
    """Validate matched world points (N, 3) and pixels (N, 2)."""
    points = _as_array('points', points, 3)
    pixels = _as_array('pixels', pixels, 2)
    if len(points) != len(pixels):
        raise ValueError(f'points and pixels must pair up: {len(points)} points but '
                         f'{len(pixels)} pixels')
    if len(points) < minimum:
        raise ValueError(f'{method} needs at least {minimum} points, got {len(points)}')
    extent = max(float(np.ptp(points, axis=0).max()), 1.0)
    gaps = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)
    first, second = np.nonzero(np.triu(gaps <= 1e-9 * extent, k=1))
    if len(first):
        raise ValueError(f'points {first[0]} and {second[0]} are the same world point '
                         f'{points[first[0]].tolist()}: each pair must be a distinct point')
    return points, pixels


def _normalising_transform(coordinates: np.ndarray) -> np.ndarray:
    """Similarity moving the centroid to 0 and the mean distance to sqrt(dim) (Hartley)."""
    dim = coordinates.shape[1]
    centroid = coordinates.mean(axis=0)
    mean_distance = np.linalg.norm(coordinates - centroid, axis=1).mean()
    scale = math.sqrt(dim) / mean_distance if mean_distance > 0 else 1.0
    transform = np.eye(dim + 1)
    transform[:dim, :dim] *= scale
    transform[:dim, dim] = -scale * centroid
    return transform


def flatness(points) -> float:
    """
    How far world points are from lying in one plane.

    :param points: shape (N, 3), m.
    :returns: smallest over largest singular value of the centred points:
        0 for coplanar points, about 0.3-0.6 for a well spread 3-D cloud.
    """
    points = _as_array('points', points, 3)
    singular = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    return float(singular[-1] / singular[0]) if singular[0] > 0 else 0.0


def fit_projection(points, pixels) -> np.ndarray:
    """
    Fit the 3x4 projection C (``[s u, s v, s] = C [X; 1]``) by normalised DLT.

    The original report's procedure, made robust: world points and pixels are
    first translated and scaled (Hartley), C is the singular vector of the
    smallest singular value of the design matrix, then denormalised.

    :param points: world points, shape (N, 3), m, N >= 6, not coplanar.
    :param pixels: their image pixels, shape (N, 2), px.
    :returns: C, shape (3, 4), scaled so that ``C[2, 3] == 1`` (as in the
        report).  The overall scale of C is arbitrary, so its third row is
        not a depth; use :func:`pixel_errors` or :func:`intrinsic_from_projection`.
    :raises ValueError: fewer than 6 points, coplanar or collinear points,
        a degenerate configuration, NaN, mismatched shapes, duplicated points,
        or a world origin on the camera's focal plane (C[2, 3] = 0).
    """
    points, pixels = _correspondences(points, pixels, MIN_POINTS['dlt'], 'the DLT')
    count = len(points)
    world_t = _normalising_transform(points)
    image_t = _normalising_transform(pixels)
    world = np.column_stack([points, np.ones(count)]) @ world_t.T
    image = np.column_stack([pixels, np.ones(count)]) @ image_t.T

    centred = np.linalg.svd(world[:, :3], compute_uv=False)
    if centred[1] <= RANK_TOLERANCE * centred[0]:
        raise ValueError('the points are collinear: the DLT needs at least 6 points spread '
                         'in 3-D (use fit_intrinsic with the known camera pose instead)')
    if centred[2] <= RANK_TOLERANCE * centred[0]:
        raise ValueError('the points are coplanar (e.g. all on a flat map): the 11-parameter '
                         'DLT is undetermined; give points at different heights or use '
                         'fit_intrinsic with the known camera pose')

    design = np.zeros((2 * count, 12))
    design[0::2, 0:4] = world
    design[0::2, 8:12] = -image[:, 0:1] * world
    design[1::2, 4:8] = world
    design[1::2, 8:12] = -image[:, 1:2] * world
    _, singular, vt = np.linalg.svd(design)
    if singular[10] <= RANK_TOLERANCE * singular[0]:
        raise ValueError('degenerate point configuration: the DLT has no unique solution '
                         '(points and camera centre on a twisted cubic, or too few distinct '
                         'points); add points spread over the view at different heights')
    normalised = vt[-1].reshape(3, 4)
    projection = np.linalg.solve(image_t, normalised) @ world_t
    if abs(projection[2, 3]) <= 1e-12 * np.abs(projection).max():
        raise ValueError("C[2, 3] is zero (the world origin lies on the camera's focal "
                         'plane): cannot scale it to 1; move the world origin or the camera')
    return projection / projection[2, 3]


def intrinsic_from_projection(projection, external) -> np.ndarray:
    """
    Intrinsic from a projection C and the External it was taken with (``C . External^-1``).

    The report's step.  C has an arbitrary scale, so the result is scaled so
    that its third row's rotation part has unit length and points forward
    (then ``[2, 2] ~ 1`` and depths come out positive).

    :param projection: C, shape (3, 4).
    :param external: shape (4, 4), world -> camera, rigid.
    :returns: shape (3, 4); for a noiseless C it equals the true intrinsic.
    :raises ValueError: bad shapes, NaN, a non-rigid External, or a C whose
        viewing direction is perpendicular to the External's.
    """
    projection = _matrix('projection', projection, (3, 4))
    external = _external(external)
    intrinsic = projection @ np.linalg.inv(external)
    depth_row = np.linalg.norm(intrinsic[2, :3])
    if depth_row <= 1e-12 * max(np.abs(intrinsic).max(), 1e-300) or \
            abs(intrinsic[2, 2]) <= 0.5 * depth_row:
        angle = math.degrees(math.acos(min(1.0, abs(intrinsic[2, 2]) / max(depth_row, 1e-300))))
        raise ValueError(f'the projection C and the External disagree on the viewing direction '
                         f'by {angle:.0f} deg: C is wrong (too few, too noisy or nearly '
                         'coplanar points) or was fitted with another camera pose')
    return intrinsic / (math.copysign(depth_row, intrinsic[2, 2]))


def camera_points(points, external) -> np.ndarray:
    """Transform world points (N, 3) into the optical camera frame (N, 3), m."""
    points = _as_array('points', points, 3)
    external = _external(external)
    return points @ external[:3, :3].T + external[:3, 3]


def fit_intrinsic(points, pixels, external, model: str = 'rviz') -> np.ndarray:
    """
    Fit the intrinsic directly by linear least squares, the External being known.

    With camera-frame points ``(X, Y, Z)`` and ``x = X / Z``, ``y = Y / Z``
    the model is ``u = fx x + s y + cx``, ``v = fy y + cy``: linear in the
    parameters, and the residuals are pixel distances.

    :param points: world points, shape (N, 3), m; all in front of the camera;
        may be coplanar.
    :param pixels: their image pixels, shape (N, 2), px.
    :param external: shape (4, 4), world -> camera, rigid.
    :param model: 'rviz' fits f, cx, cy (square pixels, no skew: what RViz
        leaves free); 'full' fits fx, fy, skew, cx, cy.
    :returns: shape (3, 4), ``[[fx, s, cx, 0], [0, fy, cy, 0], [0, 0, 1, 0]]``.
    :raises ValueError: an unknown model, fewer than 3 points, points behind
        the camera, a configuration that does not fix the parameters, NaN,
        mismatched shapes or duplicated points.
    """
    if model not in MODELS:
        raise ValueError(f'model must be one of {sorted(MODELS)}, got {model!r}')
    points, pixels = _correspondences(points, pixels, MIN_POINTS[model],
                                      f'the {model!r} intrinsic fit')
    in_camera = camera_points(points, external)
    behind = in_camera[:, 2] <= MIN_DEPTH
    if np.any(behind):
        raise ValueError(f'points {np.flatnonzero(behind).tolist()} are behind the camera: '
                         'check the camera eye/focus/up and the point coordinates')
    x, y = (in_camera[:, :2] / in_camera[:, 2:3]).T
    ones, zeros = np.ones_like(x), np.zeros_like(x)
    if model == 'rviz':
        design = np.block([[np.column_stack([x, ones, zeros])],
                           [np.column_stack([y, zeros, ones])]])
        focal, cx, cy = _solve(design, np.concatenate(pixels.T),
                               'all points lie on one ray through the camera')
        fx, fy, skew = focal, focal, 0.0
    else:
        fx, skew, cx = _solve(np.column_stack([x, y, ones]), pixels[:, 0],
                              'the points appear on one straight line in the image; the '
                              'full model needs 3 points not on one image line')
        fy, cy = _solve(np.column_stack([y, ones]), pixels[:, 1],
                        'all points are at the same image height')
    return np.array([[fx, skew, cx, 0.0], [0.0, fy, cy, 0.0], [0.0, 0.0, 1.0, 0.0]])


def fit_orthographic(points, pixels, external) -> np.ndarray:
    """
    Fit an orthographic (TopDownOrtho) intrinsic, the External being known.

    The model of :func:`eye_bci_ros2.projection.geometry.orthographic_intrinsic`:
    ``u = s X + cx``, ``v = s Y + cy`` with camera-frame ``(X, Y)`` in m, linear
    in (s, cx, cy); the residuals are pixel distances.  ``s @ external`` is
    then a 3x4 affine camera that :func:`residuals` reports on.

    :param points: world points, shape (N >= 3, 3), m.
    :param pixels: their image pixels, shape (N, 2), px.
    :param external: shape (4, 4), world -> camera, rigid.
    :returns: shape (3, 4), ``[[s, 0, 0, cx], [0, s, 0, cy], [0, 0, 0, 1]]``.
    :raises ValueError: fewer than 3 points, all points on one line along the
        view, NaN, mismatched shapes or duplicated points.
    """
    points, pixels = _correspondences(points, pixels, MIN_POINTS['rviz'],
                                      'the orthographic fit')
    x, y = camera_points(points, external)[:, :2].T
    ones, zeros = np.ones_like(x), np.zeros_like(x)
    design = np.block([[np.column_stack([x, ones, zeros])], [np.column_stack([y, zeros, ones])]])
    scale, cx, cy = _solve(design, np.concatenate(pixels.T),
                           'all points lie on one line along the view direction')
    return np.array([[scale, 0.0, 0.0, cx], [0.0, scale, 0.0, cy], [0.0, 0.0, 0.0, 1.0]])


def _solve(design: np.ndarray, target: np.ndarray, degenerate: str) -> np.ndarray:
    """Least-squares solve with a rank check (columns are normalised coordinates or 1: O(1))."""
    singular = np.linalg.svd(design, compute_uv=False)
    if singular[-1] <= 1e-9 * singular[0]:
        raise ValueError(f'degenerate point configuration: {degenerate}')
    return np.linalg.lstsq(design, target, rcond=None)[0]


def project(projection, points) -> np.ndarray:
    """
    Pixels of world points under a 3x4 projection (``Intrinsic . External[:3]`` or a DLT C).

    :param projection: shape (3, 4), any scale or sign.
    :param points: shape (N, 3), m.
    :returns: shape (N, 2), image px; inf where the point is on the focal plane.
        A point behind the camera is projected like one in front (a DLT's sign
        is arbitrary; :func:`eye_bci_ros2.projection.geometry.apply_projection`).
    """
    projection = _matrix('projection', projection, (3, 4))
    points = _as_array('points', points, 3)
    uv, _ = geometry.apply_projection(projection, points)
    uv[~np.isfinite(uv)] = np.inf
    return uv


def pixel_errors(projection, points, pixels) -> np.ndarray:
    """
    Per-point reprojection error.

    :param projection: shape (3, 4).
    :param points: world points, shape (N, 3), m.
    :param pixels: measured image pixels, shape (N, 2), px.
    :returns: shape (N,), Euclidean distance in px between predicted and measured.
    """
    pixels = _as_array('pixels', pixels, 2)
    predicted = project(projection, points)
    if len(predicted) != len(pixels):
        raise ValueError(f'points and pixels must pair up: {len(predicted)} points but '
                         f'{len(pixels)} pixels')
    with np.errstate(invalid='ignore'):
        errors = np.linalg.norm(predicted - pixels, axis=1)
    errors[~np.isfinite(errors)] = np.inf
    return errors


@dataclass(frozen=True)
class Residuals:
    """Reprojection errors of a set of points, px."""

    #: Per-point errors, shape (N,), px.
    errors: np.ndarray

    @property
    def count(self) -> int:
        """Return the number of points."""
        return len(self.errors)

    @property
    def rms(self) -> float:
        """Return the root mean square error, px (NaN when empty)."""
        return float(np.sqrt(np.mean(self.errors ** 2))) if self.count else math.nan

    @property
    def maximum(self) -> float:
        """Return the largest error, px (NaN when empty)."""
        return float(self.errors.max()) if self.count else math.nan


def residuals(projection, points, pixels) -> Residuals:
    """Return the :class:`Residuals` of world points (N, 3) against pixels (N, 2)."""
    return Residuals(pixel_errors(projection, points, pixels))


def intrinsic_parameters(intrinsic) -> Dict[str, float]:
    """
    Readable parameters of a 3x4 intrinsic (scaled so that ``[2, 2] == 1``).

    :returns: dict with fx, fy, skew, cx, cy (px); a DLT intrinsic's small
        off-model terms (4th column, ``[1, 0]``, ``[2, 0:2]``) are ignored.
    """
    intrinsic = _matrix('intrinsic', intrinsic, (3, 4))
    if abs(intrinsic[2, 2]) < 1e-12:
        raise ValueError('intrinsic[2, 2] is zero: not a camera intrinsic')
    k = intrinsic / intrinsic[2, 2]
    return {'fx': float(k[0, 0]), 'fy': float(k[1, 1]), 'skew': float(k[0, 1]),
            'cx': float(k[0, 2]), 'cy': float(k[1, 2])}


@dataclass(frozen=True)
class CalibrationResult:
    """An intrinsic fitted on one camera view, with its residuals."""

    #: 'rviz', 'full' (direct fits) or 'dlt' (the original procedure).
    method: str
    #: Fitted intrinsic, shape (3, 4).
    intrinsic: np.ndarray
    #: External of the calibration view, shape (4, 4).
    external: np.ndarray
    #: Which points were used to fit, shape (N,) bool; the rest are held out.
    fit_mask: np.ndarray
    #: Errors of every point of the calibration view, shape (N,), px.
    errors: np.ndarray
    #: For the DLT, the fitted C (3, 4) before ``C . External^-1``; else None.
    projection: Optional[np.ndarray] = None
    #: Flatness of the fit points (see :func:`flatness`).
    flatness: float = field(default=math.nan)

    @property
    def fit(self) -> Residuals:
        """Return the residuals of the points used to fit."""
        return Residuals(self.errors[self.fit_mask])

    @property
    def held_out(self) -> Residuals:
        """Return the residuals of the held-out points (may be empty)."""
        return Residuals(self.errors[~self.fit_mask])

    @property
    def parameters(self) -> Dict[str, float]:
        """Return fx, fy, skew, cx, cy, px."""
        return intrinsic_parameters(self.intrinsic)

    def evaluate(self, points, pixels, external) -> Residuals:
        """Residuals of the fitted intrinsic on another view (points (N, 3), pixels (N, 2))."""
        return residuals(self.intrinsic @ _external(external), points, pixels)


def calibrate(points, pixels, external, method: str = 'rviz',
              fit_mask: Optional[Sequence[bool]] = None) -> CalibrationResult:
    """
    Fit an intrinsic on one view and measure it on fit and held-out points.

    :param points: world points, shape (N, 3), m.
    :param pixels: image pixels, shape (N, 2), px.
    :param external: External of the view, shape (4, 4).
    :param method: 'rviz' or 'full' (:func:`fit_intrinsic`), or 'dlt'
        (:func:`fit_projection` then :func:`intrinsic_from_projection`).
    :param fit_mask: shape (N,) bool, True for the points to fit with; the
        others are held out.  Default: all points.
    :raises ValueError: as the chosen fit, or a bad mask.
    """
    if method not in MIN_POINTS:
        raise ValueError(f'method must be one of {sorted(MIN_POINTS)}, got {method!r}')
    points = _as_array('points', points, 3)
    pixels = _as_array('pixels', pixels, 2)
    external = _external(external)
    if fit_mask is None:
        mask = np.ones(len(points), dtype=bool)
    else:
        mask = np.asarray(fit_mask)
        if mask.shape != (len(points),) or mask.dtype != bool:
            raise ValueError(f'fit_mask must be {len(points)} booleans, got shape {mask.shape} '
                             f'of {mask.dtype}')
    projection = None
    if method == 'dlt':
        projection = fit_projection(points[mask], pixels[mask])
        intrinsic = intrinsic_from_projection(projection, external)
    else:
        intrinsic = fit_intrinsic(points[mask], pixels[mask], external, method)
    return CalibrationResult(
        method=method, intrinsic=intrinsic, external=external, fit_mask=mask,
        errors=pixel_errors(intrinsic @ external, points, pixels), projection=projection,
        flatness=flatness(points[mask]))


@dataclass(frozen=True)
class RvizComparison:
    """A fitted intrinsic against the analytic RViz one, with diagnoses."""

    #: Analytic focal length, px.
    model_focal: float
    #: Fitted focal length (mean of fx and fy), px.
    focal: float
    #: Principal point of the fit minus the panel centre, (du, dv) px.
    principal_offset: np.ndarray
    #: Human-readable warnings; empty when the fit agrees with the model.
    warnings: List[str]

    @property
    def focal_ratio(self) -> float:
        """Return the fitted over the analytic focal length."""
        return self.focal / self.model_focal


def compare_with_rviz(intrinsic, width, height, fov_y_deg: float = 45.0,
                      focal_tolerance: float = 0.02,
                      principal_tolerance_px: float = 4.0) -> RvizComparison:
    """
    Compare a fitted intrinsic with the analytic RViz model and say what a mismatch means.

    A wrong panel height or HiDPI scaling changes the focal length (the field
    of view is vertical); a wrong width moves only cx; pixels read with a
    wrong screen offset (X0, Y0) move the principal point but not the focal
    length.

    :param intrinsic: fitted, shape (3, 4).
    :param width: render panel width the user gave, px.
    :param height: render panel height the user gave, px.
    :param fov_y_deg: vertical field of view, degrees.
    :param focal_tolerance: relative focal-length difference that warns.
    :param principal_tolerance_px: principal-point distance that warns, px.
    """
    model = intrinsic_parameters(rviz_intrinsic(width, height, fov_y_deg))
    fit = intrinsic_parameters(intrinsic)
    focal = (fit['fx'] + fit['fy']) / 2.0
    ratio = focal / model['fx']
    offset = np.array([fit['cx'] - model['cx'], fit['cy'] - model['cy']])
    tan_half = math.tan(math.radians(fov_y_deg) / 2.0)
    warnings = []
    focal_off = abs(ratio - 1.0) > focal_tolerance
    # A whole-panel rescale moves the principal point with the focal length.
    principal = np.array([fit['cx'], fit['cy']])
    scaled = focal_off and bool(np.all(
        np.abs(principal - ratio * np.array([model['cx'], model['cy']]))
        <= principal_tolerance_px))
    if focal_off:
        message = (f'focal length {focal:.1f} px is {100 * (ratio - 1):+.1f}% off the analytic '
                   f'{model["fx"]:.1f} px of a {width:g}x{height:g} px panel at FOV '
                   f'{fov_y_deg:g} deg: ')
        factor = next((f for f in HIDPI_FACTORS
                       if min(abs(ratio / f - 1), abs(ratio * f - 1)) < focal_tolerance / 2),
                      None)
        if factor is not None:
            message += (f'the ratio {ratio:.3f} matches a display scale factor of {factor:g} '
                        '(HiDPI): the pixels and the panel size are in different units '
                        '(physical vs logical px); give both in the same units')
        else:
            message += (f'the readings fit a render panel about {2 * focal * tan_half:.0f} px '
                        'high: check image_height (the render panel, not the RViz window or '
                        'the screen) and fov_y_deg')
        if scaled:
            message += (f'; the principal point agrees: the readings are of a '
                        f'{2 * fit["cx"]:.0f}x{2 * fit["cy"]:.0f} px panel')
            if factor is None:
                message += ', so image_width/image_height are wrong'
        warnings.append(message)
    pp_off = np.abs(offset) > principal_tolerance_px
    if np.any(pp_off) and not scaled:
        message = (f'principal point ({fit["cx"]:.1f}, {fit["cy"]:.1f}) px is off the panel '
                   f'centre ({model["cx"]:.1f}, {model["cy"]:.1f}) by ({offset[0]:+.1f}, '
                   f'{offset[1]:+.1f}) px: ')
        if not focal_off:
            message += ('the focal length agrees, so the panel height is right and the pixels '
                        'are probably shifted: if they were read in screen px, the screen '
                        f'offset is wrong by X0 {offset[0]:+.0f}, Y0 {offset[1]:+.0f} px '
                        "(pixels must count from the render panel's top-left corner)")
            if pp_off[0] and not pp_off[1]:
                message += (f'; or image_width is wrong: a {2 * fit["cx"]:.0f} px wide panel '
                            'would explain cx')
        else:
            message += (f'wrong image size (a {2 * fit["cx"]:.0f}x{2 * fit["cy"]:.0f} px panel '
                        'would explain it) or a wrong X0/Y0 screen offset')
        warnings.append(message)
    if abs(fit['fx'] / fit['fy'] - 1.0) > focal_tolerance:
        warnings.append(f'non-square pixels: fx/fy = {fit["fx"] / fit["fy"]:.3f}; RViz renders '
                        'square pixels, so the u and v readings are scaled differently (a '
                        'resized screenshot, or gaze/screen scaling applied to one axis)')
    if abs(fit['skew']) > focal_tolerance * focal:
        warnings.append(f'skew {fit["skew"]:.1f} px: RViz has none; the readings are sheared or '
                        'the camera up vector is wrong')
    return RvizComparison(model_focal=model['fx'], focal=focal, principal_offset=offset,
                          warnings=warnings)
