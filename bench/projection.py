"""
Benchmark: re-projecting M cube markers to screen regions after a camera move.

The timed operation is what ``marker_projector`` does when a new camera pose
arrives: build the analytic RViz intrinsic and the External (``look_at``), then
:func:`eye_bci_ros2.projection.geometry.box_silhouettes` for all markers.  It is compared
with :func:`bench.reference_original.silhouettes_original`, the original
per-marker, per-corner way, measured in the same run on the same markers; for
large M the reference runs on the first markers only and its time is scaled
linearly (``reference_extrapolated``).  Both must give the same polygons within
:data:`TOLERANCE_PX` on the markers the reference ran on.

The scene is like RViz's default orbit view: focal point at the origin, eye
10 m away at 45 deg pitch, markers of random pose and size within 5 m of the
origin, all in front of the camera.
"""

import itertools
import math
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from bench import reference_original
from bench.timing import measure
from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import rviz_intrinsic

#: Metrics shown in the printed table (the JSON has them all).
TABLE_COLUMNS = ('ms', 'ms_min', 'reference_ms', 'speedup', 'reference_extrapolated',
                 'max_difference_px', 'agrees')
#: Marker counts of a full run.
SIZES = (10, 100, 1000, 10000)
#: Marker counts of a ``--quick`` run.
QUICK_SIZES = (10, 100)
#: Render panel width and height (px) of the simulated RViz view.
IMAGE_SIZE = (1600, 900)
#: Point the orbit camera looks at and the world's up vector (world frame).
FOCUS = (0.0, 0.0, 0.0)
UP = (0.0, 0.0, 1.0)
#: Markers the reference projects at most (larger M: extrapolated linearly).
REFERENCE_MARKERS = 1000
QUICK_REFERENCE_MARKERS = 20
#: Largest allowed vertex difference between fast path and reference, px.
TOLERANCE_PX = 1e-6

Markers = Tuple[np.ndarray, np.ndarray, np.ndarray]


def make_markers(count: int, seed: int = 0) -> Markers:
    """
    Random cube markers around the origin.

    :param count: number of markers M.
    :param seed: random seed (same seed, same scene).
    :returns: ``(positions, quaternions_xyzw, scales)`` with shapes (M, 3),
        (M, 4) (order x, y, z, w, unit) and (M, 3); world frame, m.  Positions
        lie within 5 m of the origin horizontally and 0-1.5 m up; side lengths
        are 0.02-0.6 m, so thin plates like the original's choices occur too.
    """
    rng = np.random.default_rng(seed)
    positions = np.column_stack([rng.uniform(-5.0, 5.0, count), rng.uniform(-5.0, 5.0, count),
                                 rng.uniform(0.0, 1.5, count)])
    quaternions = rng.normal(size=(count, 4))
    quaternions /= np.linalg.norm(quaternions, axis=1, keepdims=True)
    scales = rng.uniform(0.02, 0.6, size=(count, 3))
    return positions, quaternions, scales


def orbit_eyes(count: int = 16, distance: float = 10.0, pitch: float = math.pi / 4,
               yaw: float = math.pi / 4) -> np.ndarray:
    """
    Eye positions of an RViz orbit camera moving around :data:`FOCUS`.

    :returns: shape (count, 3), world frame, m; yaw sweeps +-0.3 rad around ``yaw``.
    """
    yaws = yaw + np.linspace(-0.3, 0.3, count)
    return np.asarray(FOCUS) + distance * np.column_stack([
        math.cos(pitch) * np.cos(yaws), math.cos(pitch) * np.sin(yaws),
        np.full(count, math.sin(pitch))])


def reproject(markers: Markers, eye) -> Tuple[np.ndarray, np.ndarray]:
    """
    Screen regions of ``markers`` seen from ``eye`` (the fast path under test).

    :returns: ``(polygons (M, 6, 2) image px, visible (M,))`` as
        :func:`eye_bci_ros2.projection.geometry.box_silhouettes` gives them.
    """
    intrinsic = rviz_intrinsic(*IMAGE_SIZE)
    external = geometry.look_at(eye, FOCUS, UP)
    return geometry.box_silhouettes(*markers, intrinsic, external)


def reproject_reference(markers: Markers, eye) -> List[Optional[List[Tuple[float, float]]]]:
    """Screen regions of ``markers`` seen from ``eye``, the original way."""
    positions, quaternions, scales = (m.tolist() for m in markers)
    return reference_original.silhouettes_original(
        positions, quaternions, scales, rviz_intrinsic(*IMAGE_SIZE), list(eye), FOCUS, UP)


def polygon_mismatch(polygons: np.ndarray, visible: np.ndarray,
                     reference: Sequence[Optional[Sequence[Tuple[float, float]]]]) -> float:
    """
    Largest vertex distance (px) between fast-path polygons and reference hulls.

    Polygons are compared as vertex sets (the start vertex and winding may
    differ); padding repeats are dropped first.  A difference in visibility or
    in vertex count counts as infinitely far.

    :param polygons: shape (M, K, 2) from :func:`reproject`.
    :param visible: shape (M,) bool.
    :param reference: M hulls (or None) from :func:`reproject_reference`.
    """
    worst = 0.0
    for row, shown, hull in zip(polygons, visible, reference):
        if bool(shown) != (hull is not None):
            return math.inf
        if hull is None:
            continue
        keep = np.ones(len(row), dtype=bool)
        keep[1:] = np.any(row[1:] != row[:-1], axis=1)
        keep[-1] &= np.any(row[-1] != row[0])
        fast = row[keep]
        slow = np.asarray(hull)
        if len(fast) != len(slow):
            return math.inf
        distances = np.linalg.norm(fast[:, None, :] - slow[None, :, :], axis=2)
        worst = max(worst, distances.min(axis=1).max(), distances.min(axis=0).max())
    return float(worst)


def _measure_size(count: int, reference_markers: int, quick: bool, seed: int) -> Dict:
    """Time the fast path and the reference for ``count`` markers."""
    markers = make_markers(count, seed)
    eyes = orbit_eyes()
    moves = itertools.cycle(eyes)
    fast = measure(lambda: reproject(markers, next(moves)), repeat=5 if quick else 15,
                   min_batch_s=0.005 if quick else 0.02)

    subset_count = min(count, reference_markers)
    subset = tuple(m[:subset_count] for m in markers)
    reference_moves = itertools.cycle(eyes)
    reference = measure(lambda: reproject_reference(subset, next(reference_moves)),
                        repeat=1 if quick else 3, number=1, warmup=1)
    reference_s = reference.median_s * count / subset_count

    polygons, visible = reproject(subset, eyes[0])
    mismatch = polygon_mismatch(polygons, visible, reproject_reference(subset, eyes[0]))
    result = {
        'ms': fast.median_ms,
        'ms_min': fast.min_ms,
        'reference_ms': reference_s * 1e3,
        'speedup': reference_s / fast.median_s,
        'reference_markers': subset_count,
        'reference_extrapolated': subset_count < count,
        'max_difference_px': mismatch,
        'agrees': mismatch <= TOLERANCE_PX,
        'visible_markers': int(np.count_nonzero(reproject(markers, eyes[0])[1])),
    }
    if hasattr(geometry, 'BoxSet'):
        # A prepared set keeps the world corners between camera moves.
        boxes = geometry.BoxSet(*markers)
        intrinsic = rviz_intrinsic(*IMAGE_SIZE)
        prepared = measure(
            lambda: boxes.silhouettes(intrinsic, geometry.look_at(next(moves), FOCUS, UP)),
            repeat=5 if quick else 15, min_batch_s=0.005 if quick else 0.02)
        result['prepared_ms'] = prepared.median_ms
    return result


def run(quick: bool = False, sizes: Optional[Sequence[int]] = None,
        reference_markers: Optional[int] = None, seed: int = 0) -> Dict[str, Dict]:
    """
    Run the projection benchmark.

    :param quick: small sizes and few repeats (seconds, for smoke tests).
    :param sizes: marker counts M; default :data:`SIZES` (:data:`QUICK_SIZES` if quick).
    :param reference_markers: most markers the reference projects per run.
    :param seed: random seed of the scene.
    :returns: ``{str(M): {'ms', 'ms_min', 'reference_ms', 'speedup',
        'reference_markers', 'reference_extrapolated', 'max_difference_px',
        'agrees', 'visible_markers'[, 'prepared_ms']}}``; times are medians,
        ms per re-projection of all M markers.
    """
    if sizes is None:
        sizes = QUICK_SIZES if quick else SIZES
    if reference_markers is None:
        reference_markers = QUICK_REFERENCE_MARKERS if quick else REFERENCE_MARKERS
    if reference_markers < 1:
        raise ValueError(f'reference_markers must be >= 1, got {reference_markers}')
    return {str(count): _measure_size(int(count), reference_markers, quick, seed)
            for count in sizes}
