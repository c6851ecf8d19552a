"""
The screen as the person sees it: pixels per degree of visual angle at any screen point.

Pure numpy.  The geometry (screen size in mm, resolution in px, viewing
distance in mm, the eye on the perpendicular through the screen centre) is
:class:`ScreenGeometry` (the simulated person of :mod:`eye_bci_ros2.sim.person`
looks through it too); this module also holds the defaults of the decision
rule (a 24 inch 16:9 screen, 531 x 299 mm, 1920 x 1080 px, seen from 650 mm)
and the local scale that converts a gaze error model given in degrees into
pixels at the place where a sample falls.

Local scale.  For a screen point at (X, Y) mm from the screen centre and a
viewing distance D, the ray from the eye has length ``r = sqrt(X^2 + Y^2 +
D^2)``.  A small step on the screen perpendicular to the line from the
screen centre (tangential) turns the ray by ``step / r``; a radial step by
``step * D / r^2``.  One degree therefore covers ``r`` (tangential) and
``r^2 / D`` (radial) mm per radian: equal at the centre, up to ~10 % apart in
the corners of the default screen.  :func:`px_per_degree_at` returns their
geometric mean (a circle of 1 deg on the eye's sphere maps to an ellipse of
the same area as a circle of that radius on the screen), times the pixel
density (geometric mean of x and y).
"""

from dataclasses import dataclass
import math
from numbers import Real
from typing import Tuple

import numpy as np

from eye_bci_ros2.base.settings import Setting
from eye_bci_ros2.base.validators import ensure, Interval

#: One inch, mm.
MM_PER_INCH = 25.4


@dataclass(frozen=True)
class ScreenGeometry:
    """
    The display the person looks at and how far away they sit.

    :param width_px: horizontal resolution, px.
    :param height_px: vertical resolution, px.
    :param width_mm: visible width, mm.
    :param height_mm: visible height, mm.
    :param distance_mm: eye to screen centre, perpendicular to the screen, mm.

    The default is a 23.8 inch 16:9 monitor (527 x 296 mm) at 1920x1080 seen
    from 600 mm: 38.15 px per degree at the centre.
    """

    width_px: int = 1920
    height_px: int = 1080
    width_mm: float = 527.0
    height_mm: float = 296.0
    distance_mm: float = 600.0

    def __post_init__(self):
        """Reject sizes that cannot be a screen."""
        for name in ('width_px', 'height_px', 'width_mm', 'height_mm', 'distance_mm'):
            value = getattr(self, name)
            ensure(isinstance(value, Real) and math.isfinite(value) and value > 0,
                   f'screen {name} must be a positive number, got {value!r}')

    @property
    def size_px(self) -> np.ndarray:
        """(width, height), px, shape (2,)."""
        return np.array([self.width_px, self.height_px], dtype=float)

    @property
    def centre_px(self) -> np.ndarray:
        """Screen centre (x, y), px, shape (2,)."""
        return self.size_px / 2.0

    @property
    def px_per_mm(self) -> np.ndarray:
        """Pixel density (x, y), px/mm, shape (2,)."""
        return self.size_px / np.array([self.width_mm, self.height_mm])

    def px_per_degree(self, axis: int = 0) -> float:
        """
        Pixels spanned by one degree centred on the screen centre.

        ``2 * distance * tan(0.5 deg) * px_per_mm``: exact for a 1 deg object at
        the centre; towards the edges a degree covers more pixels.

        :param axis: 0 = horizontal, 1 = vertical.
        """
        return float(self.visual_angle_px(1.0, axis))

    def visual_angle_px(self, deg, axis: int = 0):
        """
        Size in px of an object centred on the screen centre subtending ``deg``.

        :param deg: visual angle(s), degrees, scalar or array, 0 <= deg < 180.
        :param axis: 0 = horizontal, 1 = vertical.
        :returns: px, same shape as ``deg``.
        """
        deg = np.asarray(deg, dtype=float)
        ensure(bool(np.all((deg >= 0) & (deg < 180))),
               f'visual angle must be in [0, 180) degrees, got {deg}')
        return 2.0 * self.distance_mm * np.tan(np.radians(deg) / 2.0) * self.px_per_mm[axis]

    def px_to_visual_angle(self, px, axis: int = 0):
        """
        Visual angle, degrees, of an object of ``px`` pixels centred on the screen centre.

        Inverse of :meth:`visual_angle_px`.
        """
        px = np.asarray(px, dtype=float)
        return np.degrees(2.0 * np.arctan(px / self.px_per_mm[axis] / 2.0 / self.distance_mm))

    def rays(self, xy) -> np.ndarray:
        """
        Rays from the eye through screen points (eye frame, mm, not normalised).

        :param xy: screen px, shape (N, 2).
        :returns: shape (N, 3): (x_mm, y_mm, distance_mm).
        """
        xy = np.asarray(xy, dtype=float)
        mm = (xy - self.centre_px) / self.px_per_mm
        return np.concatenate([mm, np.full(mm.shape[:-1] + (1,), self.distance_mm)], axis=-1)

    def _tangent_basis(self, xy) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return unit rays d and unit tangents e_x (horizontal) and e_y = d x e_x (down)."""
        d = self.rays(xy)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        # Horizontal tangent: perpendicular to d within the eye's x-z plane.
        e_x = np.stack([d[..., 2], np.zeros_like(d[..., 0]), -d[..., 0]], axis=-1)
        e_x /= np.linalg.norm(e_x, axis=-1, keepdims=True)
        return d, e_x, np.cross(d, e_x)

    def rotate_gaze(self, xy, delta_deg) -> np.ndarray:
        """
        Turn the gaze rays through screen points by small angles and re-intersect the screen.

        The ray d becomes ``d + tan(dx) e_x + tan(dy) e_y`` with e_x the
        horizontal tangent (right) and e_y the tangent pointing down the screen,
        so a pure horizontal or vertical error of ``dx`` degrees is exactly
        ``dx`` degrees of visual angle.

        :param xy: screen px, shape (N, 2).
        :param delta_deg: (right, down) angles, degrees, shape (N, 2) or (2,).
        :returns: screen px, shape (N, 2).
        """
        d, e_x, e_y = self._tangent_basis(xy)
        t = np.tan(np.radians(np.asarray(delta_deg, dtype=float)))
        ray = d + t[..., :1] * e_x + t[..., 1:] * e_y
        mm = ray[..., :2] * (self.distance_mm / ray[..., 2:])
        return mm * self.px_per_mm + self.centre_px

    def angular_error_deg(self, xy, reference) -> np.ndarray:
        """
        Per-axis angles from reference points to points: inverse of :meth:`rotate_gaze`.

        :param xy: measured screen px, shape (N, 2).
        :param reference: true screen px, shape (N, 2) or (2,).
        :returns: (right, down) degrees, shape (N, 2).
        """
        xy = np.asarray(xy, dtype=float)
        reference = np.broadcast_to(np.asarray(reference, dtype=float), xy.shape)
        d, e_x, e_y = self._tangent_basis(reference)
        q = self.rays(xy)
        q = q / np.sum(q * d, axis=-1, keepdims=True)
        return np.degrees(np.arctan(np.stack(
            [np.sum(q * e_x, axis=-1), np.sum(q * e_y, axis=-1)], axis=-1)))

    def angle_between_deg(self, a, b) -> np.ndarray:
        """
        Visual angle between the rays through screen points a and b, degrees.

        :param a: screen px, shape (N, 2) or (2,).
        :param b: screen px, same shape (or broadcastable).
        :returns: shape (N,) or scalar.
        """
        ra = self.rays(a)
        rb = self.rays(b)
        cross = np.linalg.norm(np.cross(ra, rb), axis=-1)
        return np.degrees(np.arctan2(cross, np.sum(ra * rb, axis=-1)))


#: The person's screen in the original report: 1920x1080; 23.8 inch panel assumed.
DEFAULT_SCREEN = ScreenGeometry()


def px_per_degree(screen: ScreenGeometry = DEFAULT_SCREEN) -> float:
    """Horizontal pixels per degree at the centre of ``screen`` (38.15 for the default)."""
    return screen.px_per_degree()


def visual_angle_px(deg, screen: ScreenGeometry = DEFAULT_SCREEN):
    """Horizontal size in px of an object at the centre of ``screen`` subtending ``deg``."""
    return screen.visual_angle_px(deg)


def screen_from_diagonal(diagonal_inch: float = 24.0, aspect: float = 16.0 / 9.0,
                         width_px: int = 1920, height_px: int = 1080,
                         distance_mm: float = 650.0) -> ScreenGeometry:
    """
    Return the screen geometry of a monitor given by its diagonal and aspect ratio.

    :param diagonal_inch: visible diagonal, inch (> 0).
    :param aspect: width / height of the visible area (> 0).
    :param width_px: horizontal resolution, px.
    :param height_px: vertical resolution, px.
    :param distance_mm: eye to the screen centre, mm.
    :raises ValueError: a size that cannot be a screen.
    """
    if not (math.isfinite(diagonal_inch) and diagonal_inch > 0
            and math.isfinite(aspect) and aspect > 0):
        raise ValueError(f'screen diagonal ({diagonal_inch!r} inch) and aspect ratio '
                         f'({aspect!r}) must be positive numbers')
    diagonal_mm = diagonal_inch * MM_PER_INCH
    height_mm = diagonal_mm / math.hypot(aspect, 1.0)
    return ScreenGeometry(width_px=width_px, height_px=height_px,
                          width_mm=round(aspect * height_mm, 1), height_mm=round(height_mm, 1),
                          distance_mm=distance_mm)


#: The decision rule's default: a 24 inch 16:9 monitor (531 x 299 mm, 1920 x 1080 px) at 650
#: mm, 41.0 px per degree at the centre.
DEFAULT_VIEWING = screen_from_diagonal()

#: Largest screen side, px (16K).
MAX_SIDE_PX = 16384

# The person's screen as settings, declared once (eye_bci_ros2.base.settings): the
# choice_arbiter (degrees <-> px for its rule) and gaze_validation (accuracy in degrees)
# both take them, with the same names, defaults, ranges and descriptions.
SCREEN_WIDTH = Setting(
    DEFAULT_VIEWING.width_px,
    "The person's screen, the one the gaze is in (frame screen): width, px",
    interval=Interval(1, MAX_SIDE_PX), unit='px', name='screen_width')
SCREEN_HEIGHT = Setting(
    DEFAULT_VIEWING.height_px, "The person's screen: height, px",
    interval=Interval(1, MAX_SIDE_PX), unit='px', name='screen_height')
SCREEN_WIDTH_MM = Setting(
    DEFAULT_VIEWING.width_mm, "The person's screen: visible width, mm (degrees <-> px)",
    interval=Interval(10.0, 10000.0), unit='mm', name='screen_width_mm')
SCREEN_HEIGHT_MM = Setting(
    DEFAULT_VIEWING.height_mm, "The person's screen: visible height, mm",
    interval=Interval(10.0, 10000.0), unit='mm', name='screen_height_mm')
VIEWING_DISTANCE = Setting(
    DEFAULT_VIEWING.distance_mm, "Distance from the person's eyes to the screen centre, mm",
    interval=Interval(50.0, 10000.0), unit='mm', name='viewing_distance_mm')
#: The person's screen, in the order :class:`ScreenGeometry` takes it.
SCREEN_SETTINGS = (SCREEN_WIDTH, SCREEN_HEIGHT, SCREEN_WIDTH_MM, SCREEN_HEIGHT_MM,
                   VIEWING_DISTANCE)


def px_per_degree_at(points, screen: ScreenGeometry = DEFAULT_VIEWING) -> np.ndarray:
    """
    Pixels spanned by one degree of visual angle around screen points (module doc).

    :param points: screen px (x right, y down, origin top-left), shape (N, 2)
        or (2,); NaN points give NaN.
    :param screen: the person's screen and viewing distance.
    :returns: px per degree, shape (N,) (a scalar array for one (2,) point).
    """
    points = np.asarray(points, dtype=float)
    if points.shape[-1:] != (2,):
        raise ValueError(f'screen points must have shape (N, 2), got {points.shape}')
    mm = (points - screen.centre_px) / screen.px_per_mm
    distance = float(screen.distance_mm)
    ray = np.sqrt(np.sum(mm * mm, axis=-1) + distance * distance)
    # Geometric mean of tangential (r) and radial (r^2 / D) mm per radian.
    mm_per_radian = ray ** 1.5 / math.sqrt(distance)
    density = math.sqrt(float(np.prod(screen.px_per_mm)))
    return mm_per_radian * density * (math.pi / 180.0)


def degrees_to_px(degrees, points, screen: ScreenGeometry = DEFAULT_VIEWING) -> np.ndarray:
    """
    Convert an angle (degrees) into px at screen points (:func:`px_per_degree_at`).

    :param degrees: visual angle, degrees, scalar or shape (N,), >= 0.
    :param points: screen px, shape (N, 2).
    :returns: px, shape (N,).
    """
    degrees = np.asarray(degrees, dtype=float)
    if np.any(degrees < 0):
        raise ValueError(f'a visual angle must be >= 0 degrees, got {degrees}')
    return degrees * px_per_degree_at(points, screen)
