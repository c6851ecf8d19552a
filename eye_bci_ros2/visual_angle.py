"""
The screen as the person sees it: pixels per degree of visual angle at any screen point.

Pure numpy.  The geometry (screen size in mm, resolution in px, viewing
distance in mm, the eye on the perpendicular through the screen centre) is
:class:`eye_bci_ros2.gaze_model.ScreenGeometry`, reused here; this module adds
the defaults of the decision rule (a 24 inch 16:9 screen, 531 x 299 mm,
1920 x 1080 px, seen from 650 mm) and the local scale that converts a gaze
error model given in degrees into pixels at the place where a sample falls.

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

import math

import numpy as np

from eye_bci_ros2.gaze_model import ScreenGeometry

#: One inch, mm.
MM_PER_INCH = 25.4


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
