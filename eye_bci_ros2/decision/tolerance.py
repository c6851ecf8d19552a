"""
Tolerant classification of gaze samples: near an option counts for it, between two counts for none.

Pure numpy.  Frame: ``screen`` (px, x right, y down).  Regions are convex
polygons, shape (R, K, 2), any winding, closed implicitly (the last vertex
joins the first); a polygon may be padded with NaN vertices or by repeating
its last vertex, and an all-NaN polygon contains nothing and is infinitely far
(the conventions of :class:`eye_bci_ros2.projection.geometry.PolygonSet` and the
arbiter's ``RegionSet``).

Rule (:func:`classify_tolerant`), per sample:

1. inside a region: the sample counts for it (inside several: the one whose
   area centroid is nearest, as the arbiter does);
2. outside every region: with ``d1`` the distance to the nearest region and
   ``d2`` to the second nearest (point to polygon, px; infinite with one
   region), it counts for the nearest when ``d1 <= tolerance`` **and**
   ``d1 <= ratio * d2``; otherwise for none.  A sample midway between two
   options has ``d1 ~ d2`` and counts for neither.

Size-aware variant (``size_aware=True``): the error model says where the
measured gaze falls around the point looked at, and a person looks at the
middle of a small option; so the tolerance is counted from the option's
centre: a sample outside counts when ``d1 <= tolerance - half_size`` of the
nearest option (``sqrt(area) / 2``).  A large option (half size above the
tolerance) gets no tolerance (the original inside rule), a tiny one the whole
tolerance around it; gaze between large options stays neutral.

The tolerance comes from a model of the tracker's error in degrees
(:class:`GazeErrorModel`: ``k`` standard deviations of the radial error of a
tracker with accuracy ``accuracy_deg`` and precision ``precision_deg``)
converted to px at the sample's own place on the screen
(:func:`eye_bci_ros2.projection.visual_angle.px_per_degree_at`), so it covers more px
towards the screen edges, as the error does.

Evidence model.  An inside sample keeps the arbiter's hit rate ``h`` (0.9).
A near sample (outside, counted by the tolerance) should use the same
``h`` (:data:`NEAR_HIT_RATE`): ``bench/tolerance.py`` measures, after
fixation onset on an option (``bench/decision.py``'s main scenario), that
0.99 of the near samples count for the option looked at (1.00 of the inside
ones), above the 0.9 the model assumes; a separate, lower weight per near
sample is not needed.  What near samples do need is the share test the
benchmark proposes (a choice needs a share of *all* the samples it weighed),
since a gaze resting between two options yields near samples too.
"""

from dataclasses import dataclass
import math
from typing import Optional, Tuple, Union

import numpy as np

from eye_bci_ros2.decision.regions import polygon_centroids, RegionSet
from eye_bci_ros2.projection.geometry import polygon_signed_area, PolygonSet
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING, px_per_degree_at, ScreenGeometry

#: How a decision rule classifies samples: 'tolerant' (this module) or 'inside' (the original:
#: only samples inside an option count for it).
CLASSIFICATIONS = ('tolerant', 'inside')

#: Default ratio of nearest to second-nearest distance below which a near sample counts.
DEFAULT_RATIO = 0.5

#: Hit rate for a near (outside, within tolerance) sample in the evidence model (module doc).
NEAR_HIT_RATE = 0.9

#: Points are processed in blocks of this many (bounds the (block, R, K) temporaries).
BLOCK = 4096


@dataclass(frozen=True)
class GazeErrorModel:
    """
    The tracker's gaze error, in degrees of visual angle.

    :param accuracy_deg: expected constant offset after calibration (magnitude), degrees
        (a consumer tracker: 0.5-1.0).
    :param precision_deg: sample-to-sample noise, standard deviation per axis, degrees
        (0.3 for a consumer tracker).
    :param k_sigma: tolerance in standard deviations of the radial error (2-3).

    The radial error's standard deviation is ``sqrt(accuracy^2 + 2 precision^2)``
    (the offset taken as a per-person draw of that RMS magnitude, the noise
    isotropic), so the tolerance is ``k_sigma`` times that.  Defaults: 0.8 deg,
    0.3 deg, k = 2: 1.80 deg, 74 px at the centre of the default screen.
    """

    accuracy_deg: float = 0.8
    precision_deg: float = 0.3
    k_sigma: float = 2.0

    def __post_init__(self):
        """Reject an error model no tracker has."""
        for name in ('accuracy_deg', 'precision_deg', 'k_sigma'):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f'{name} must be a finite number >= 0, got {value!r}')
        if self.tolerance_deg >= 30.0:
            raise ValueError(f'a gaze tolerance of {self.tolerance_deg:.1f} deg (k_sigma x '
                             'radial error) is not a tracker error: keep it below 30 deg')

    @property
    def radial_sd_deg(self) -> float:
        """Return the standard deviation of the radial gaze error, degrees."""
        return math.sqrt(self.accuracy_deg ** 2 + 2.0 * self.precision_deg ** 2)

    @property
    def tolerance_deg(self) -> float:
        """Return the tolerance, degrees: ``k_sigma * radial_sd_deg``."""
        return self.k_sigma * self.radial_sd_deg

    def tolerance_px(self, points, screen: ScreenGeometry = DEFAULT_VIEWING) -> np.ndarray:
        """
        Return the tolerance in px at each screen point.

        :param points: screen px, shape (N, 2).
        :returns: px, shape (N,); NaN for NaN points.
        """
        return self.tolerance_deg * px_per_degree_at(np.asarray(points, dtype=float)
                                                     .reshape(-1, 2), screen)


def _points(points) -> np.ndarray:
    """Return points as float (N, 2)."""
    array = np.asarray(points, dtype=float)
    if array.shape == (2,):
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f'gaze points must have shape (N, 2), got {array.shape}')
    return array


def fill_padding(polygons) -> Tuple[np.ndarray, np.ndarray]:
    """
    Replace NaN padding vertices by the previous finite vertex (a zero-length edge).

    :param polygons: shape (R, K, 2), px.
    :returns: ``(filled (R, K, 2), valid (R,))``; an invalid (all-NaN) polygon
        stays NaN.
    """
    polygons = np.asarray(polygons, dtype=float)
    if polygons.ndim != 3 or polygons.shape[2] != 2 or polygons.shape[1] < 1:
        raise ValueError(f'region polygons must have shape (R, K, 2), got {polygons.shape}')
    finite = np.all(np.isfinite(polygons), axis=2)
    valid = finite.sum(axis=1) >= 3
    count = polygons.shape[1]
    index = np.where(finite, np.arange(count)[None, :], -1)
    np.maximum.accumulate(index, axis=1, out=index)
    first = np.argmax(finite, axis=1)
    index = np.where(index < 0, first[:, None], index)
    filled = np.take_along_axis(polygons, index[:, :, None], axis=1)
    filled[~valid] = np.nan
    return filled, valid


def _edge_distances(points: np.ndarray, filled: np.ndarray) -> np.ndarray:
    """Distance from each point to each polygon's boundary (N, R), px; NaN for invalid."""
    start = filled
    edge = np.roll(filled, -1, axis=1) - start                      # (R, K, 2)
    length2 = np.sum(edge * edge, axis=2)                           # (R, K)
    safe = np.where(length2 > 0, length2, 1.0)
    out = np.empty((len(points), len(filled)))
    for lo in range(0, len(points), BLOCK):
        p = points[lo:lo + BLOCK, None, None, :]                    # (n, 1, 1, 2)
        rel = p - start[None]                                       # (n, R, K, 2)
        t = np.clip(np.sum(rel * edge[None], axis=3) / safe[None], 0.0, 1.0)
        t = np.where(length2[None] > 0, t, 0.0)
        gap = rel - t[..., None] * edge[None]
        out[lo:lo + BLOCK] = np.sqrt(np.min(np.sum(gap * gap, axis=3), axis=2))
    return out


def polygon_distances(points, polygons) -> np.ndarray:
    """
    Distance from points to convex polygons: 0 inside, else to the nearest edge.

    :param points: shape (N, 2), screen px.
    :param polygons: shape (R, K, 2), screen px (module doc).
    :returns: shape (N, R), px; ``inf`` for an all-NaN polygon and NaN for a
        NaN point.
    """
    filled, valid = fill_padding(polygons)
    return _distances(_points(points), np.where(valid[:, None, None], filled, 0.0), valid,
                      PolygonSet(filled))


def _distances(points: np.ndarray, zeroed: np.ndarray, valid: np.ndarray,
               polygon_set: PolygonSet) -> np.ndarray:
    """:func:`polygon_distances` from prepared polygons (padding filled, invalid ones zeroed)."""
    with np.errstate(invalid='ignore'):
        distance = _edge_distances(points, zeroed)
        inside = polygon_set.contains(points)
    distance[inside] = 0.0
    distance[:, ~valid] = np.inf
    distance[~np.all(np.isfinite(points), axis=1)] = np.nan
    return distance


def _check_rule(tolerance_px, ratio: float, count: int) -> np.ndarray:
    """Validate the rule's parameters; return the tolerance as (N,) or scalar array."""
    if not (isinstance(ratio, (int, float)) and 0.0 < ratio <= 1.0):
        raise ValueError(f'ratio must be in (0, 1], got {ratio!r}: the nearest option must '
                         'be at most ratio times as far as the second')
    tolerance = np.asarray(tolerance_px, dtype=float)
    if tolerance.ndim > 1 or (tolerance.ndim == 1 and len(tolerance) != count):
        raise ValueError(f'tolerance_px must be a number or shape ({count},), got shape '
                         f'{tolerance.shape}')
    # NaN per sample (the tolerance at a NaN point) is allowed: that sample counts for none.
    if np.any(tolerance < 0) or (tolerance.ndim == 0 and np.isnan(tolerance)):
        raise ValueError(f'tolerance_px must be >= 0 px (finite or inf), got {tolerance_px!r}')
    return tolerance


def nearby(distance: np.ndarray, tolerance_px: Union[float, np.ndarray],
           ratio: float, shrink_px: Optional[np.ndarray] = None) -> np.ndarray:
    """
    Apply the rule's outside part to a distance matrix (module doc, step 2).

    :param distance: shape (N, R), px (NaN rows: no region).
    :param tolerance_px: px, scalar or shape (N,).
    :param ratio: in (0, 1].
    :param shrink_px: per region (R,), px subtracted from the tolerance when
        that region is the nearest (the size-aware rule), or None.
    :returns: shape (N,) int, the nearest region when the sample counts for
        it, else -1 (inside samples, distance 0, always count).
    """
    count, regions = distance.shape
    tolerance = _check_rule(tolerance_px, ratio, count)
    if regions == 0:
        return np.full(count, -1, dtype=np.intp)
    clean = np.where(np.isnan(distance), np.inf, distance)
    nearest = np.argmin(clean, axis=1)
    if regions > 1:
        two = np.partition(clean, 1, axis=1)
        first, second = two[:, 0], two[:, 1]
    else:
        first, second = clean[:, 0], np.full(count, np.inf)
    if shrink_px is not None:
        tolerance = tolerance - np.asarray(shrink_px, dtype=float)[nearest]
    with np.errstate(invalid='ignore'):
        counts = np.isfinite(first) & (first <= tolerance) & (first <= ratio * second)
    return np.where(counts, nearest, -1).astype(np.intp)


def half_sizes(polygons) -> np.ndarray:
    """
    Half the size of each region, px: ``sqrt(area) / 2`` (the half side of a square of equal area).

    :param polygons: shape (R, K, 2), px (module doc); an empty polygon gives 0.
    :returns: shape (R,).
    """
    filled, valid = fill_padding(polygons)
    area = np.abs(polygon_signed_area(np.where(valid[:, None, None], filled, 0.0)))
    return np.sqrt(area) / 2.0


def classify_tolerant(points, polygons, tolerance_px: Union[float, np.ndarray],
                      ratio: float = DEFAULT_RATIO, *, size_aware: bool = False) -> np.ndarray:
    """
    Region of each gaze sample under the tolerant rule (module doc).

    :param points: shape (N, 2), screen px; NaN points count for none.
    :param polygons: shape (R, K, 2), screen px, convex, NaN-padded (module doc).
    :param tolerance_px: how far outside a region a sample may still count for
        it, px, scalar or shape (N,) (e.g. :meth:`GazeErrorModel.tolerance_px`);
        0 gives the inside-only rule.
    :param ratio: the nearest region must be at most ``ratio`` times as far as
        the second nearest, in (0, 1].
    :param size_aware: the tolerance counts from the region's centre, not its
        edge (module doc): reduced by the nearest region's :func:`half_sizes`.
    :returns: shape (N,) int, region index, -1 = none.
    """
    points = _points(points)
    distance = polygon_distances(points, polygons)
    region = nearby(distance, tolerance_px, ratio, half_sizes(polygons) if size_aware else None)
    inside = distance == 0.0
    several = np.flatnonzero(inside.sum(axis=1) > 1)
    if several.size:
        filled, _ = fill_padding(polygons)
        centre = polygon_centroids(filled)
        delta = points[several, None, :] - centre[None]
        squared = np.where(inside[several], np.sum(delta * delta, axis=2), np.inf)
        region[several] = np.argmin(squared, axis=1)
    return region


def extend_to_nearby(region, points, polygons, tolerance_px: Union[float, np.ndarray],
                     ratio: float = DEFAULT_RATIO, *, size_aware: bool = False) -> np.ndarray:
    """
    Add the near samples to an inside-only classification (the arbiter's hook).

    :param region: shape (N,) int, an inside-only classification (e.g.
        ``RegionSet.classify``: index or -1); kept where >= 0.
    :param points: shape (N, 2), screen px.
    :param polygons: shape (R, K, 2), the polygons ``region`` indexes.
    :param tolerance_px: px, scalar or shape (N,).
    :param ratio: in (0, 1].
    :param size_aware: see :func:`classify_tolerant`.
    :returns: shape (N,) int: ``region`` where it is >= 0, else the tolerant
        rule's region for the sample or -1.
    """
    region = np.asarray(region, dtype=np.intp)
    points = _points(points)
    if region.shape != (len(points),):
        raise ValueError(f'{len(region)} region indices for {len(points)} points')
    tolerance = _check_rule(tolerance_px, ratio, len(points))
    out = region.copy()
    outside = np.flatnonzero(region < 0)
    if outside.size:
        sub = tolerance[outside] if tolerance.ndim == 1 else tolerance
        shrink = half_sizes(polygons) if size_aware else None
        out[outside] = nearby(polygon_distances(points[outside], polygons), sub, ratio, shrink)
    return out


class TolerantRegions(RegionSet):
    """
    A ``RegionSet`` that classifies by the tolerant rule (the arbiter's classifier).

    :param model: gaze-error model, degrees.
    :param ratio: nearest / second-nearest distance ratio, (0, 1].
    :param screen: the person's screen, for degrees -> px at each sample.
    :param size_aware: the tolerance counts from the option's centre.
    """

    def __init__(self, labels, polygons, stamp: float = 0.0,
                 model: GazeErrorModel = GazeErrorModel(), ratio: float = DEFAULT_RATIO,
                 screen: Optional[ScreenGeometry] = None, size_aware: bool = False):
        """Prepare the regions and the rule."""
        super().__init__(labels, polygons, stamp)
        self.model = model
        self.ratio = ratio
        self.size_aware = size_aware
        self.screen = screen if screen is not None else DEFAULT_VIEWING
        # Prepared once per set (the arbiter classifies every gaze batch with it).
        filled, self._valid = fill_padding(self.polygons)
        self._zeroed = np.where(self._valid[:, None, None], filled, 0.0)
        self._filled_set = PolygonSet(filled)
        self._half_sizes = half_sizes(self.polygons) if size_aware else None

    @classmethod
    def of(cls, regions: RegionSet, **rule) -> 'TolerantRegions':
        """Return ``regions`` with the tolerant rule."""
        return cls(regions.labels, regions.polygons, regions.stamp, **rule)

    def classify(self, points) -> np.ndarray:
        """Region index of each point (N, 2) px by the tolerant rule, -1 = none."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        return self._nearby(points, super().classify(points))

    def _nearby(self, points: np.ndarray, region: np.ndarray) -> np.ndarray:
        """Give the points (N, 2) px outside every region (-1 in ``region``) the tolerant rule."""
        # extend_to_nearby with the prepared polygons: the same result.
        outside = np.flatnonzero(region < 0)
        if outside.size and len(self.labels):
            away = points[outside]
            tolerance = _check_rule(self.model.tolerance_px(away, self.screen), self.ratio,
                                    len(away))
            distance = _distances(away, self._zeroed, self._valid, self._filled_set)
            region[outside] = nearby(distance, tolerance, self.ratio, self._half_sizes)
        return region

    def classify_one(self, x: float, y: float) -> int:
        """Region index of one point, tolerant rule (:meth:`classify` of one row)."""
        index = super().classify_one(x, y)
        if index >= 0 or not len(self.labels):
            return index      # inside an option: the tolerance is not asked
        return int(self._nearby(np.array([[x, y]]), np.array([-1]))[0])
