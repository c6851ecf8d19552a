"""
Offered regions on the screen and which of them a gaze point falls in: pure numpy.

Everything is in the ``screen`` frame (px, x right, y down; docs/DESIGN.md,
"Frames and units").

Overlapping regions: a point inside several regions belongs to the one whose
area centroid is nearest to it (the first listed on an exact tie).
"""

import math
from typing import Callable, Dict, Hashable, Optional, Sequence

import numpy as np

from eye_bci_ros2.projection.geometry import PolygonSet


def points_array(points) -> np.ndarray:
    """Return ``points`` as a float array of shape (N, 2)."""
    array = np.asarray(points, dtype=float)
    if array.ndim == 1 and array.shape == (2,):
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f'gaze points must have shape (N, 2), got {array.shape}')
    return array


def polygon_centroids(polygons: np.ndarray) -> np.ndarray:
    """Area centroids of polygons (R, K, 2) -> (R, 2); vertex mean if degenerate."""
    x, y = polygons[..., 0], polygons[..., 1]
    x_next, y_next = np.roll(x, -1, axis=1), np.roll(y, -1, axis=1)
    cross = x * y_next - x_next * y
    area = cross.sum(axis=1) / 2
    with np.errstate(divide='ignore', invalid='ignore'):
        cx = ((x + x_next) * cross).sum(axis=1) / (6 * area)
        cy = ((y + y_next) * cross).sum(axis=1) / (6 * area)
    centroids = np.stack([cx, cy], axis=1)
    flat = ~(np.abs(area) > 1e-12)
    centroids[flat] = polygons[flat].mean(axis=1)
    return centroids


class RegionSet:
    """
    The regions offered at one moment: labels and convex screen polygons.

    :param labels: R labels (a region's text, else ns/id); repeated labels are
        allowed and pool their evidence.
    :param polygons: shape (R, K, 2), screen px, convex, any winding; rows may
        repeat their last vertex as padding; NaN rows contain nothing.
    :param stamp: when these regions became what the screen shows, s.
    """

    def __init__(self, labels: Sequence[str], polygons, stamp: float = 0.0):
        """Prepare the regions for fast point tests."""
        labels = tuple(str(label) for label in labels)
        polygons = np.asarray(polygons, dtype=float)
        if polygons.size == 0 and not labels:
            polygons = np.zeros((0, 3, 2))
        if polygons.ndim != 3 or polygons.shape[2] != 2 or polygons.shape[1] < 3:
            raise ValueError(f'region polygons must have shape (R, K >= 3, 2), '
                             f'got {polygons.shape}')
        if len(labels) != len(polygons):
            raise ValueError(f'{len(labels)} labels for {len(polygons)} region polygons')
        if not math.isfinite(stamp):
            raise ValueError(f'region stamp must be finite, got {stamp}')
        self.labels = labels
        self.polygons = polygons
        self.stamp = float(stamp)
        self.centroids = polygon_centroids(polygons)
        self._set = PolygonSet(polygons)
        # Classifiers made from this set, by the rule that made them (:meth:`under`).
        self._under: Dict[Hashable, 'RegionSet'] = {}

    def __len__(self) -> int:
        """Return the number of regions."""
        return len(self.labels)

    def under(self, rule: Hashable, make: Callable[['RegionSet'], 'RegionSet']) -> 'RegionSet':
        """
        Return this set under a classification rule, made by ``make(self)`` once per rule.

        Every round of a menu classifies with the same rule: it is built once, not per round.

        :param rule: what ``make`` depends on besides the regions (hashable).
        """
        made = self._under.get(rule)
        if made is None:
            made = self._under[rule] = make(self)
        return made

    def __repr__(self) -> str:
        """Describe the set briefly."""
        return f'RegionSet({list(self.labels)}, stamp={self.stamp:.3f})'

    @property
    def label_set(self) -> frozenset:
        """Return the distinct labels offered."""
        return frozenset(self.labels)

    def classify(self, points) -> np.ndarray:
        """
        Find the region of each point.

        :param points: shape (N, 2), screen px; NaN points are in no region.
        :returns: shape (N,) int, the region index, -1 when in none; a point in
            several regions goes to the one with the nearest centroid.
        """
        points = points_array(points)
        if not self.labels:
            return np.full(len(points), -1, dtype=np.intp)
        with np.errstate(invalid='ignore', over='ignore'):  # NaN, inf: in no region
            inside = self._set.contains(points)
        return self._resolve(points, inside)

    def classify_one(self, x: float, y: float) -> int:
        """Per-sample path of :meth:`classify`: region index of (x, y) px, or -1."""
        if not self.labels:
            return -1
        inside = self._set.contains_one(x, y)
        hits = inside.count(True)
        if hits < 2:
            return inside.index(True) if hits else -1
        point = np.array([[x, y]], dtype=float)
        return int(self._resolve(point, np.array([inside]))[0])

    def _resolve(self, points: np.ndarray, inside: np.ndarray) -> np.ndarray:
        """Pick one region per point from an (N, R) inside matrix."""
        hits = inside.sum(axis=1)
        result = np.where(hits > 0, inside.argmax(axis=1), -1)
        several = np.flatnonzero(hits > 1)
        if several.size:
            delta = points[several, None, :] - self.centroids[None, :, :]
            distance = np.einsum('nrk,nrk->nr', delta, delta)
            distance[~inside[several]] = np.inf
            result[several] = distance.argmin(axis=1)
        return result


def classify_against_history(stamps: np.ndarray, points: np.ndarray,
                             history: Sequence[RegionSet],
                             classifier: Optional[Callable[[RegionSet], RegionSet]] = None
                             ) -> np.ndarray:
    """
    Tell which samples count for a region shown at their own time.

    :param stamps: shape (N,), s, ascending.
    :param points: shape (N, 2), screen px.
    :param history: region sets in arrival order (stamps ascending).
    :param classifier: the rule's classification of a set
        (:meth:`ArbiterSettings.regions`); None: inside a region.
    :returns: shape (N,) bool.
    """
    inside = np.zeros(len(stamps), dtype=bool)
    if not len(stamps) or not history:
        return inside
    history_stamps = np.array([regions.stamp for regions in history])
    shown = np.searchsorted(history_stamps, stamps, side='right') - 1
    for index in np.unique(shown):
        rows = shown == index
        regions = history[max(int(index), 0)]
        if classifier is not None:
            regions = classifier(regions)
        inside[rows] = regions.classify(points[rows]) >= 0
    return inside
