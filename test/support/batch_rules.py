"""
Batch oracles of the count rules: one batch of samples, static regions, no state.

The tests compare the node's incremental evidence
(:class:`eye_bci_ros2.decision.evidence.RoundEvidence`) with these straightforward
versions of the original ``mean`` rule and of ``vote``; nothing in the
package uses them.  Which region holds a point is decided here too, by a plain
point-in-polygon test (:func:`region_of`), not by the package's classifier.
"""

import math
from typing import Tuple

import numpy as np

from eye_bci_ros2.decision.evidence import counts_summary, Decision, DEFAULT_HIT_RATE
from eye_bci_ros2.decision.regions import points_array, RegionSet

#: Edge tolerance of the inside test, px^2 (cross product of an edge and the point's offset).
INSIDE_TOLERANCE = 1e-9


def _centroid(polygon: np.ndarray) -> Tuple[float, float]:
    """Area centroid of one polygon (K, 2) by the shoelace sums; vertex mean if flat."""
    area = sx = sy = 0.0
    count = len(polygon)
    for k in range(count):
        (x0, y0), (x1, y1) = polygon[k], polygon[(k + 1) % count]
        cross = x0 * y1 - x1 * y0
        area += cross / 2
        sx += (x0 + x1) * cross
        sy += (y0 + y1) * cross
    if not abs(area) > 1e-12:
        return float(np.mean(polygon[:, 0])), float(np.mean(polygon[:, 1]))
    return sx / (6 * area), sy / (6 * area)


def _inside(polygon: np.ndarray, x: float, y: float) -> bool:
    """Whether (x, y) lies in a convex polygon (K, 2) of either winding, edges included."""
    if not (np.all(np.isfinite(polygon)) and math.isfinite(x) and math.isfinite(y)):
        return False
    crosses = []
    count = len(polygon)
    for k in range(count):
        (x0, y0), (x1, y1) = polygon[k], polygon[(k + 1) % count]
        crosses.append((x1 - x0) * (y - y0) - (y1 - y0) * (x - x0))
    return (all(c >= -INSIDE_TOLERANCE for c in crosses)
            or all(c <= INSIDE_TOLERANCE for c in crosses))


def region_of(region_set: RegionSet, x: float, y: float) -> int:
    """
    Index of the region holding (x, y) px, -1 in none: written apart from the package.

    A point in several regions goes to the one whose area centroid is nearest
    (the first of equals), as the node documents.
    """
    best, best_distance = -1, math.inf
    for index, polygon in enumerate(region_set.polygons):
        if _inside(polygon, x, y):
            cx, cy = _centroid(polygon)
            distance = (x - cx) ** 2 + (y - cy) ** 2
            if best < 0 or distance < best_distance:
                best, best_distance = index, distance
    return best


def regions_of(region_set: RegionSet, points: np.ndarray) -> np.ndarray:
    """:func:`region_of` of each point (N, 2) -> (N,) int."""
    return np.array([region_of(region_set, float(x), float(y)) for x, y in points],
                    dtype=np.intp)


def _label_counts(region_set: RegionSet, region: np.ndarray) -> Tuple[list, np.ndarray]:
    """Distinct labels of a set and the count of region indices per label."""
    distinct = sorted(region_set.label_set)
    index = {label: i for i, label in enumerate(distinct)}
    to_label = np.array([index[label] for label in region_set.labels] + [-1], dtype=np.intp)
    ids = to_label[region]
    counts = np.bincount(ids[ids >= 0], minlength=len(distinct))
    return distinct, counts


def decide_mean(points, region_set: RegionSet,
                hit_rate: float = DEFAULT_HIT_RATE) -> Decision:
    """
    Apply the original rule to one batch of samples and static regions.

    Drop the samples outside every region, average the rest, and choose the
    region that contains the mean.

    :param points: shape (N, 2), screen px.
    :param region_set: the regions shown.
    :param hit_rate: only for the reported posterior.
    :returns: the decision; ``label`` is None when no sample is in a region or
        the mean is in none.
    """
    points = points_array(points)
    region = regions_of(region_set, points)
    inside = region >= 0
    used, in_region = len(points), int(inside.sum())
    if not in_region:
        return Decision(None, 'mean', used, 0, 0.0, math.nan, reason='no sample in any region')
    distinct, counts = _label_counts(region_set, region)
    _, margin, posterior = counts_summary(counts, hit_rate)
    mean = points[inside].mean(axis=0)
    chosen = region_of(region_set, float(mean[0]), float(mean[1]))
    counts_map = dict(zip(distinct, counts.tolist()))
    mean_point = (float(mean[0]), float(mean[1]))
    if chosen < 0:
        leader = int(np.argmax(counts))
        return Decision(None, 'mean', used, in_region, margin, float(posterior[leader]),
                        counts=counts_map, mean_point=mean_point,
                        reason=f'mean ({mean[0]:.1f}, {mean[1]:.1f}) px is in no region')
    label = region_set.labels[chosen]
    return Decision(label, 'mean', used, in_region, margin,
                    float(posterior[distinct.index(label)]), counts=counts_map,
                    mean_point=mean_point)


def decide_vote(points, region_set: RegionSet,
                hit_rate: float = DEFAULT_HIT_RATE) -> Decision:
    """
    Choose the majority of the in-region samples, on one batch and static regions.

    :param points: shape (N, 2), screen px.
    :param region_set: the regions shown.
    :param hit_rate: only for the reported posterior.
    :returns: the decision; ``label`` is None without in-region samples or on
        a tie between the two leading labels.
    """
    points = points_array(points)
    region = regions_of(region_set, points)
    used, in_region = len(points), int((region >= 0).sum())
    if not in_region:
        return Decision(None, 'vote', used, 0, 0.0, math.nan, reason='no sample in any region')
    distinct, counts = _label_counts(region_set, region)
    leader, margin, posterior = counts_summary(counts, hit_rate)
    mean = points[region >= 0].mean(axis=0)
    details = {'counts': dict(zip(distinct, counts.tolist())),
               'mean_point': (float(mean[0]), float(mean[1]))}
    if margin == 0.0:
        return Decision(None, 'vote', used, in_region, 0.0, float(posterior[leader]),
                        reason='tie between the leading regions', **details)
    return Decision(distinct[leader], 'vote', used, in_region, margin, float(posterior[leader]),
                    **details)
