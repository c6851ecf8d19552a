"""
The original report's calibration protocol, simulated.

Per trial: two realistic RViz views of one map (1280x720 render panel, FOV
45 deg, orbit cameras 4-15 m from their focus, 30-75 deg above the map),
10 random map points visible in both, pixels read with 1 px Gaussian noise
(per axis).  6 points of the first view fit the intrinsic, which then predicts
all 10 points in the second view.  The figure is the worst of the 10 errors
in the second view against the *true* pixels (the reading noise of the second
view is excluded; the figure against the noisy readings, which is what a
person checking by eye sees, is reported too).

Methods: the default direct fit of the RViz model (f, cx, cy; External
known), the full 5-parameter direct fit, and the original 11-parameter DLT +
``C . External^-1``.  Cases: a flat map (heights within 1 cm) and heights up
to 3 m.  Run::

    .venv/bin/python -m bench.calibration_protocol
"""

import argparse
import json
import math
import sys
from typing import Dict, Optional, Tuple

import numpy as np

from eye_bci_ros2.projection.calibration import (fit_intrinsic, fit_projection,
                                                 intrinsic_from_projection)
from eye_bci_ros2.projection.calibration import pixel_errors
from eye_bci_ros2.projection.camera_model import rviz_intrinsic
from eye_bci_ros2.projection.geometry import look_at

#: Case name -> largest point height above the map, m.
CASES = {'flat map (heights within 1 cm)': 0.01, 'heights up to 3 m': 3.0}

#: Method name -> short description.
METHODS = {
    'rviz': 'direct fit, RViz model (f, cx, cy) [default]',
    'full': 'direct fit, full model (fx, fy, s, cx, cy)',
    'dlt': 'original 11-parameter DLT + C.External^-1',
}


def random_view(rng: np.random.Generator, centre: np.ndarray) -> np.ndarray:
    """External (4, 4) of an RViz orbit camera looking down at a point near ``centre``."""
    distance = rng.uniform(4.0, 15.0)
    elevation = math.radians(rng.uniform(30.0, 75.0))
    azimuth = rng.uniform(0.0, 2 * math.pi)
    focus = centre + np.array([*rng.uniform(-1.0, 1.0, 2), 0.0])
    eye = focus + distance * np.array([math.cos(elevation) * math.cos(azimuth),
                                       math.cos(elevation) * math.sin(azimuth),
                                       math.sin(elevation)])
    return look_at(eye, focus, [0.0, 0.0, 1.0])


def _visible(intrinsic: np.ndarray, external: np.ndarray, points: np.ndarray, width: int,
             height: int, margin: float) -> np.ndarray:
    """Which points (N, 3) are in front of the camera and inside the panel with a margin."""
    homogeneous = points @ (intrinsic @ external)[:, :3].T + (intrinsic @ external)[:, 3]
    depth = homogeneous[:, 2]
    with np.errstate(divide='ignore', invalid='ignore'):
        uv = homogeneous[:, :2] / depth[:, None]
    return ((depth > 0.5) & (uv[:, 0] >= margin) & (uv[:, 0] <= width - margin)
            & (uv[:, 1] >= margin) & (uv[:, 1] <= height - margin))


def draw_scene(rng: np.random.Generator, max_height: float, count: int = 10,
               width: int = 1280, height: int = 720, fov_y_deg: float = 45.0,
               margin: float = 20.0) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """
    Two views and ``count`` map points visible in both.

    :returns: ``(points (count, 3) m, external_fit (4, 4), external_test (4, 4))``.
    """
    intrinsic = rviz_intrinsic(width, height, fov_y_deg)
    while True:
        centre = np.array([*rng.uniform(-10.0, 10.0, 2), 0.0])
        first, second = random_view(rng, centre), random_view(rng, centre)
        radius = 6.0
        candidates = np.column_stack([centre[:2] + rng.uniform(-radius, radius, (2000, 2)),
                                      rng.uniform(0.0, max_height, 2000)])
        keep = _visible(intrinsic, first, candidates, width, height, margin) & \
            _visible(intrinsic, second, candidates, width, height, margin)
        if keep.sum() >= count:
            return candidates[keep][:count], first, second


def run_protocol(trials: int = 200, seed: int = 0, noise_px: float = 1.0, count: int = 10,
                 fit_count: int = 6, width: int = 1280, height: int = 720,
                 fov_y_deg: float = 45.0) -> Dict[str, Dict[str, Dict[str, float]]]:
    """
    Run the simulated protocol.

    :returns: ``{case: {method: stats}}``; stats holds ``median_px`` (median
        over trials of the worst second-view error against the true pixels;
        a failed fit counts as infinite), ``p90_px``, ``median_vs_reading_px``
        (against the noisy second-view readings), ``held_out_median_px``
        (worst error of the held-out points of the first view, against their
        readings) and ``failures`` (trials whose fit raised ValueError).
    """
    rng = np.random.default_rng(seed)
    intrinsic = rviz_intrinsic(width, height, fov_y_deg)
    results = {}
    for case, max_height in CASES.items():
        worst = {method: np.full((trials, 3), np.inf) for method in METHODS}
        failures = dict.fromkeys(METHODS, 0)
        for trial in range(trials):
            points, first, second = draw_scene(rng, max_height, count, width, height,
                                               fov_y_deg)
            true_first = _pixels(intrinsic @ first, points)
            true_second = _pixels(intrinsic @ second, points)
            read_first = true_first + rng.normal(0.0, noise_px, true_first.shape)
            read_second = true_second + rng.normal(0.0, noise_px, true_second.shape)
            fit, held = slice(0, fit_count), slice(fit_count, None)
            for method in METHODS:
                try:
                    if method == 'dlt':
                        fitted = intrinsic_from_projection(
                            fit_projection(points[fit], read_first[fit]), first)
                    else:
                        fitted = fit_intrinsic(points[fit], read_first[fit], first, method)
                except ValueError:
                    failures[method] += 1
                    continue
                worst[method][trial] = [
                    pixel_errors(fitted @ second, points, true_second).max(),
                    pixel_errors(fitted @ second, points, read_second).max(),
                    pixel_errors(fitted @ first, points[held], read_first[held]).max(),
                ]
        results[case] = {
            method: {
                'median_px': float(np.median(worst[method][:, 0])),
                'p90_px': float(np.percentile(worst[method][:, 0], 90)),
                'median_vs_reading_px': float(np.median(worst[method][:, 1])),
                'held_out_median_px': float(np.median(worst[method][:, 2])),
                'failures': failures[method],
            } for method in METHODS}
    return results


#: Metrics shown by ``make bench`` (bench/run_all.py).
TABLE_COLUMNS = ('median_px', 'p90_px', 'median_vs_reading_px', 'failures')


def run(quick: bool = False) -> Dict[str, Dict[str, float]]:
    """Run the protocol for ``make bench``: rows ``case/method`` (20 trials when quick)."""
    results = run_protocol(trials=20 if quick else 200)
    return {f'{case}/{method}': stats
            for case, methods in results.items() for method, stats in methods.items()}


def _pixels(projection: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Exact pixels (N, 2) of points (N, 3) under a 3x4 projection."""
    homogeneous = points @ projection[:, :3].T + projection[:, 3]
    return homogeneous[:, :2] / homogeneous[:, 2:3]


def format_table(results: Dict[str, Dict[str, Dict[str, float]]], trials: int,
                 command: str = 'python -m bench.calibration_protocol') -> str:
    """Render :func:`run_protocol` results as a text table, ending with the command."""
    lines = [f'Calibration protocol: 10 map points, 6 fit, 1 px reading noise, {trials} trials; '
             'worst error over the 10 points in a second view, px',
             f'{"case":<32} {"method":<46} {"median":>9} {"p90":>9} {"vs read":>9} '
             f'{"held-out":>9} {"failed":>7}']
    for case, by_method in results.items():
        for method, stats in by_method.items():
            lines.append(
                f'{case:<32} {METHODS[method]:<46} {_number(stats["median_px"])} '
                f'{_number(stats["p90_px"])} {_number(stats["median_vs_reading_px"])} '
                f'{_number(stats["held_out_median_px"])} {stats["failures"]:>7d}')
    lines.append('median/p90: against the true pixels; vs read: against the noisy readings of '
                 'the second view; held-out: worst of the 4 held-out points in the first view; '
                 'failed: fits that raised ValueError (counted as infinite error).')
    lines.append(f'command: {command}')
    return '\n'.join(lines)


def _number(value: float) -> str:
    """Format a pixel figure in 9 columns."""
    if not math.isfinite(value):
        return f'{"failed":>9}'
    return f'{value:9.2f}' if value < 1e5 else f'{value:9.1e}'


def main(argv: Optional[list] = None) -> int:
    """Run the protocol and print the table (``--json`` for machine-readable output)."""
    parser = argparse.ArgumentParser(prog='python -m bench.calibration_protocol',
                                     description=__doc__.strip().splitlines()[0])
    parser.add_argument('--trials', type=int, default=200, help='trials per case (200)')
    parser.add_argument('--seed', type=int, default=0, help='random seed (0)')
    parser.add_argument('--noise', type=float, default=1.0,
                        help='reading noise, px standard deviation per axis (1.0)')
    parser.add_argument('--json', action='store_true', help='print JSON instead of a table')
    args = parser.parse_args(argv)
    if args.trials < 1 or not args.noise >= 0:
        parser.error('--trials must be >= 1 and --noise >= 0')
    results = run_protocol(trials=args.trials, seed=args.seed, noise_px=args.noise)
    command = (f'.venv/bin/python -m bench.calibration_protocol --trials {args.trials} '
               f'--seed {args.seed} --noise {args.noise:g}')
    print(json.dumps(results, indent=2) if args.json
          else format_table(results, args.trials, command))
    return 0


if __name__ == '__main__':
    sys.exit(main())
