"""
Benchmark: gaze samples classified into screen regions per second.

These paths are measured against R = 3, 10 and 100 regions:

* batch: :meth:`eye_bci_ros2.projection.geometry.PolygonSet.contains` on a large array
  of samples in chunks of :data:`CHUNK` (bounded memory: the (chunk, R * K)
  edge-value matrix stays in cache), reduced to one region index per sample;
* per message: one sample at a time through the per-sample classification
  of the arbiter's core (:meth:`eye_bci_ros2.decision.rounds.RegionSet.classify_one`,
  or :class:`~eye_bci_ros2.projection.geometry.PolygonSet` on a (1, 2) array while that
  module does not exist); and, as ``per_message_rounds_samples_per_s``, one
  sample per :meth:`eye_bci_ros2.decision.rounds.RoundScheduler.add_sample` call,
  the choice_arbiter node's work per gaze message without ROS (classification
  plus the round's bookkeeping);
* reference: the original way, a Python loop over samples and regions
  (:func:`bench.reference_original.classify_original`).

All of them must give every sample the same region.  Regions are hexagons and
quadrilaterals (what box silhouettes look like) of 60-200 px on a 1920x1080
screen, one per cell of a grid so that they do not overlap; half the samples
are fixations scattered around region centres, half anywhere on the screen.
"""

from typing import Callable, Dict, Optional, Sequence, Tuple

import numpy as np

from bench import reference_original
from bench.timing import measure

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, COUNT_RULE, ORIGINAL_RULE, RoundScheduler
from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING

#: Metrics shown in the printed table (the JSON has them all).
TABLE_COLUMNS = ('samples_per_s', 'per_message_samples_per_s',
                 'per_message_rounds_samples_per_s', 'reference_samples_per_s', 'speedup',
                 'in_region_fraction', 'agrees')
#: Screen size, px.
SCREEN_SIZE = (DEFAULT_VIEWING.width_px, DEFAULT_VIEWING.height_px)
#: Region counts R of a run.
REGION_COUNTS = (3, 10, 100)
#: Samples per chunk of the batch path.
CHUNK = 4096
#: Samples of the batch path (full run, quick run).
BATCH_SAMPLES = 1_000_000
QUICK_BATCH_SAMPLES = 20_000
#: Samples sent one at a time through the per-message path.
MESSAGE_SAMPLES = 3000
QUICK_MESSAGE_SAMPLES = 200
#: Samples the Python reference classifies.
REFERENCE_SAMPLES = 3000
QUICK_REFERENCE_SAMPLES = 200


def make_regions(count: int, seed: int = 0) -> np.ndarray:
    """
    Non-overlapping convex screen regions like projected cube markers.

    :param count: number of regions R.
    :param seed: random seed.
    :returns: shape (R, 6, 2), screen px; even rows are hexagons, odd rows
        quadrilaterals padded by repeating their last vertex (as
        :func:`eye_bci_ros2.projection.geometry.box_silhouettes` pads them).  Each fits a
        cell of a grid over the screen and spans 60-200 px (less when the
        cells are smaller than 200 px).
    """
    rng = np.random.default_rng(seed)
    width, height = SCREEN_SIZE
    columns = int(np.ceil(np.sqrt(count * width / height)))
    rows = int(np.ceil(count / columns))
    cell_w, cell_h = width / columns, height / rows
    cells = rng.permutation(columns * rows)[:count]
    centres = np.column_stack([(cells % columns + 0.5) * cell_w,
                               (cells // columns + 0.5) * cell_h])
    largest = min(200.0, 0.95 * min(cell_w, cell_h))
    sizes = rng.uniform(min(60.0, largest), largest, count)
    polygons = np.empty((count, 6, 2))
    for kind, vertices in ((0, 6), (1, 4)):
        chosen = np.arange(count) % 2 == kind
        angles = np.linspace(0, 2 * np.pi, vertices, endpoint=False)[None, :] \
            + rng.uniform(0, 2 * np.pi, (chosen.sum(), 1))
        # Squash along a random axis: a marker seen obliquely; convexity survives.
        squash = rng.uniform(0.6, 1.0, (chosen.sum(), 1))
        outline = np.stack([np.cos(angles), squash * np.sin(angles)], axis=-1)
        tilt = rng.uniform(0, np.pi, chosen.sum())
        rotation = np.stack([np.stack([np.cos(tilt), -np.sin(tilt)], -1),
                             np.stack([np.sin(tilt), np.cos(tilt)], -1)], -2)
        outline = np.einsum('rij,rkj->rki', rotation, outline) * (sizes[chosen, None, None] / 2)
        outline = np.concatenate([outline, np.repeat(outline[:, -1:], 6 - vertices, axis=1)], 1)
        polygons[chosen] = centres[chosen, None, :] + outline
    return polygons


def make_gaze(count: int, polygons: np.ndarray, seed: int = 1) -> np.ndarray:
    """
    Gaze samples: half fixations near region centres (sigma 30 px), half uniform.

    :returns: shape (count, 2), screen px, clipped to the screen.
    """
    rng = np.random.default_rng(seed)
    centres = polygons.mean(axis=1)
    fixations = count // 2
    near = centres[rng.integers(0, len(centres), fixations)] \
        + rng.normal(0.0, 30.0, (fixations, 2))
    anywhere = rng.uniform((0, 0), SCREEN_SIZE, (count - fixations, 2))
    points = np.concatenate([near, anywhere])[rng.permutation(count)]
    return np.clip(points, 0, np.asarray(SCREEN_SIZE) - 1)


def classify_batch(polygon_set: geometry.PolygonSet, points: np.ndarray,
                   chunk: int = CHUNK) -> np.ndarray:
    """
    Region index of every sample, chunk by chunk.

    :param polygon_set: the prepared regions.
    :param points: shape (N, 2), screen px.
    :param chunk: samples per :meth:`~eye_bci_ros2.projection.geometry.PolygonSet.contains` call.
    :returns: shape (N,) int, the first region containing the sample, -1 for none.
    """
    labels = np.empty(len(points), dtype=np.intp)
    for start in range(0, len(points), chunk):
        inside = polygon_set.contains(points[start:start + chunk])
        labels[start:start + chunk] = np.where(inside.any(axis=1), inside.argmax(axis=1), -1)
    return labels


def per_message_classifier(polygons: np.ndarray) -> Tuple[str, Callable[[float, float], int]]:
    """
    Return the per-message classification the arbiter node uses, as ``f(x, y) -> index``.

    :returns: ``(api_name, f)``; ``f`` gives the region index or -1.
    """
    region_set = RegionSet([str(i) for i in range(len(polygons))], polygons)
    return 'regions.RegionSet.classify_one', region_set.classify_one


def per_message_rounds(polygons: np.ndarray) -> Optional[Callable[[list], object]]:
    """
    Return ``f(points)`` feeding samples one by one to the arbiter's core, or None without it.

    ``f`` opens a round on ``polygons`` in a fresh
    :class:`eye_bci_ros2.decision.rounds.RoundScheduler` (window long enough for
    every sample, no early decision, the original rule), passes each sample to
    :meth:`~eye_bci_ros2.decision.rounds.RoundScheduler.add_sample` as the
    choice_arbiter node does per gaze message (stamps 1 ms apart), then closes
    the round and returns its decision.
    """
    region_set = RegionSet([str(i) for i in range(len(polygons))], polygons, 0.0)

    def feed(points: list) -> object:
        window_s = len(points) * 1e-3 + 1.0
        rounds = RoundScheduler(ArbiterSettings(**{**COUNT_RULE, **ORIGINAL_RULE},
                                                window_s=window_s))
        rounds.add_regions(region_set, now=0.0)  # new labels: a round starts at stamp 0
        for index, (x, y) in enumerate(points):
            stamp = index * 1e-3
            rounds.add_sample(stamp, x, y, stamp)
        return rounds.tick(now=2 * window_s + rounds.settings.stall_timeout_s)
    return feed


def _measure_regions(count: int, samples: int, messages: int, reference_samples: int,
                     chunk: int, quick: bool, seed: int) -> Dict:
    """Throughput of the three paths against ``count`` regions."""
    polygons = make_regions(count, seed)
    points = make_gaze(samples, polygons, seed + 1)
    polygon_set = geometry.PolygonSet(polygons)
    repeat = 3 if quick else 5
    batch = measure(lambda: classify_batch(polygon_set, points, chunk), repeat=repeat,
                    number=1, warmup=1)

    api, classify_one = per_message_classifier(polygons)
    message_points = points[:messages].tolist()

    def per_message() -> list:
        return [classify_one(x, y) for x, y in message_points]
    message = measure(per_message, repeat=repeat, number=1, warmup=1)
    feed = per_message_rounds(polygons)
    rounds_timing = None
    if feed is not None:
        rounds_timing = measure(lambda: feed(message_points), repeat=repeat, number=1,
                                warmup=1)

    reference_points = points[:reference_samples].tolist()
    reference_polygons = polygons.tolist()
    reference = measure(
        lambda: reference_original.classify_original(reference_points, reference_polygons),
        repeat=1 if quick else 3, number=1, warmup=0)

    # Every path must give every sample the same region.
    labels = classify_batch(polygon_set, points, chunk)
    check = min(messages, reference_samples)
    reference_labels = reference_original.classify_original(reference_points[:check],
                                                            reference_polygons)
    agrees = bool(np.array_equal(labels[:check], reference_labels)
                  and np.array_equal(labels[:check], per_message()[:check]))
    if feed is not None:
        # The round must have counted exactly the in-region samples the batch found.
        round_counts = feed(message_points).counts
        found = labels[:messages]
        expected = {str(region): int(np.count_nonzero(found == region))
                    for region in np.unique(found[found >= 0])}
        agrees = agrees and {k: v for k, v in round_counts.items() if v} == expected
    result = {
        'samples_per_s': samples / batch.median_s,
        'samples_per_s_best': samples / batch.min_s,
        'per_message_samples_per_s': messages / message.median_s,
        'reference_samples_per_s': reference_samples / reference.median_s,
        'speedup': (samples / batch.median_s) / (reference_samples / reference.median_s),
        'batch_samples': samples,
        'chunk': chunk,
        'per_message_api': api,
        'in_region_fraction': float(np.mean(labels >= 0)),
        'agrees': agrees,
    }
    if rounds_timing is not None:
        result['per_message_rounds_samples_per_s'] = messages / rounds_timing.median_s
    return result


def run(quick: bool = False, region_counts: Optional[Sequence[int]] = None,
        samples: Optional[int] = None, chunk: int = CHUNK, seed: int = 0) -> Dict[str, Dict]:
    """
    Run the arbitration benchmark.

    :param quick: few samples and repeats (seconds, for smoke tests).
    :param region_counts: region counts R; default :data:`REGION_COUNTS`.
    :param samples: samples of the batch path; default :data:`BATCH_SAMPLES`
        (:data:`QUICK_BATCH_SAMPLES` if quick).
    :param chunk: samples per chunk of the batch path.
    :param seed: random seed of regions and gaze.
    :returns: ``{str(R): {'samples_per_s', 'samples_per_s_best',
        'per_message_samples_per_s', 'reference_samples_per_s', 'speedup',
        'batch_samples', 'chunk', 'per_message_api', 'in_region_fraction',
        'agrees'[, 'per_message_rounds_samples_per_s']}}``; rates are samples
        per second from median times; ``speedup`` is batch over reference.
    """
    if region_counts is None:
        region_counts = REGION_COUNTS
    if samples is None:
        samples = QUICK_BATCH_SAMPLES if quick else BATCH_SAMPLES
    if samples < 1 or chunk < 1:
        raise ValueError(f'samples and chunk must be >= 1, got {samples} and {chunk}')
    messages = min(samples, QUICK_MESSAGE_SAMPLES if quick else MESSAGE_SAMPLES)
    reference_samples = min(samples, QUICK_REFERENCE_SAMPLES if quick else REFERENCE_SAMPLES)
    return {str(count): _measure_regions(int(count), samples, messages, reference_samples,
                                         chunk, quick, seed)
            for count in region_counts}
