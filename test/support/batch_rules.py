"""
Batch oracles of the count rules: one batch of samples, static regions, no state.

The tests compare the node's incremental evidence
(:class:`eye_bci_ros2.decision.evidence.RoundEvidence`) with these straightforward
versions of the original ``mean`` rule and of ``vote``; nothing in the
package uses them.
"""

import math
from typing import Tuple

import numpy as np

from eye_bci_ros2.decision.evidence import counts_summary, Decision, DEFAULT_HIT_RATE
from eye_bci_ros2.decision.regions import points_array, RegionSet


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
    region = region_set.classify(points)
    inside = region >= 0
    used, in_region = len(points), int(inside.sum())
    if not in_region:
        return Decision(None, 'mean', used, 0, 0.0, math.nan, reason='no sample in any region')
    distinct, counts = _label_counts(region_set, region)
    _, margin, posterior = counts_summary(counts, hit_rate)
    mean = points[inside].mean(axis=0)
    chosen = region_set.classify_one(mean[0], mean[1])
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
    region = region_set.classify(points)
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
