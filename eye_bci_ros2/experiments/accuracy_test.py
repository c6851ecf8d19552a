"""
Run the original report's accuracy test: the smallest marker a person can still choose.

Room scenario of the report (section 5.3): the overview view of the default
scene with its four room markers, each scaled (in its own plane) so that its
silhouette on the screen measures ``s`` px, where the size of a region is the
side of the square of equal area, ``sqrt(area)``.  A trial: the person looks at
one room (the rooms in turn) from the screen centre, the round collects gaze
for ``window_s`` from the question, the decision rule picks a room; the trial
is correct when it picks the room looked at (no choice counts as wrong).

Two results:

1. the report's binary search for the smallest size (to 1 px, between 4 and
   300 px) at which every one of K trials with fixed seeds is correct
   (``--search-threshold`` < 1 accepts a fraction), per decision rule;
2. the accuracy against size curve, N trials per size, per rule
   (:data:`eye_bci_ros2.experiments.trials.RULES`: ``original`` = the
   report's rule, inside-only mean; ``early`` = the choice_arbiter's
   default, the fixation rule with its early decision; ``mean`` and ``vote``
   = the tolerant sample counts at the window end), written as CSV and PNG
   with a printed table.  By default ``original`` and ``early``: the
   report's rule beside the node's.

By default nothing runs in real time: the simulated person
(:mod:`eye_bci_ros2.sim.person`) produces each trial's samples on simulated
time, and the regions and decisions come from the same pure code the nodes
run (:meth:`RvizCamera.box_regions`, :class:`eye_bci_ros2.decision.rounds.RoundEvidence`),
so the test is fast and deterministic.  Lost samples (blinks, dropouts) are
removed before the decision, as the bridge drops them.

``--live`` runs the binary search with a real person and a real eye tracker:
the pipeline nodes run on the current ROS domain, the bridge reads the real
LSL stream, the test markers are published on ``choices`` (show them in RViz
with the overview view: eye (10, -2, 17), focus (10, 6, 0); the test also
publishes that view on ``camera/goal``), the terminal says which room to look
at, and each decision is recorded.
"""

import argparse
import csv
from dataclasses import asdict, dataclass, field
import json
import math
import os
import sys
import time
from typing import Callable, Dict, List, Optional, Sequence, TextIO, Tuple

import numpy as np

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings
from eye_bci_ros2.experiments import render as demo_render
from eye_bci_ros2.experiments.trials import decide_trial, RULES, settings_for
from eye_bci_ros2.projection.camera_model import (DEFAULT_IMAGE_SIZE, DEFAULT_PANEL_OFFSET,
                                                  RVIZ_FOV_Y_DEG, RvizCamera)
from eye_bci_ros2.projection.geometry import polygon_signed_area
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.ros.startup import quiet_liblsl
from eye_bci_ros2.sim.person import GazeParams, GazeSimulator, ORIGINAL_TOBII_4C, PRESETS
from eye_bci_ros2.task.scene import load_scene, Scene

#: RViz render panel (W, H) px, its offset (X0, Y0) on the 1920x1080 screen, vertical FOV.
PANEL_SIZE = DEFAULT_IMAGE_SIZE
PANEL_OFFSET = DEFAULT_PANEL_OFFSET
FOV_Y_DEG = RVIZ_FOV_Y_DEG
#: Decision rules the curve can show ('early' = early decision, mean at the window end).
CURVE_METHODS = RULES
#: Marker sizes of the curve, px.
DEFAULT_SIZES = (4, 5, 6, 7, 8, 10, 12, 14, 16, 20, 24, 28, 32, 40, 48, 64, 80, 100, 128,
                 160, 200, 250, 300)
#: The original report's finding, px.
REPORT_THRESHOLD_PX = 16.0


def binary_search_threshold(predicate: Callable[[float], bool], low: float, high: float,
                            tolerance: float = 1) -> float:
    """
    Find the smallest value at which a monotone predicate holds, by bisection.

    ``predicate`` must be False at ``low`` and True at ``high`` (False below
    a flip point, True from it on).  With integer bounds and an integer
    tolerance >= 1 only integers are tried (marker sizes in whole pixels).

    :param predicate: value -> bool, False below the threshold, True at and above.
    :param low: a value where the predicate is False.
    :param high: a value where the predicate is True, > low.
    :param tolerance: stop when the bracket is at most this wide (> 0).
    :returns: the smallest value tried at which the predicate holds; the
        threshold lies in (returned - tolerance, returned].
    :raises ValueError: a bad bracket or tolerance, or a predicate that is
        True at ``low`` or False at ``high`` (the flip is not inside).
    """
    if not tolerance > 0:
        raise ValueError(f'tolerance must be > 0, got {tolerance}')
    if not low < high:
        raise ValueError(f'need low < high, got low={low}, high={high}')
    at_low, at_high = bool(predicate(low)), bool(predicate(high))
    if at_low and not at_high:
        raise ValueError(f'the predicate is not monotone on [{low}, {high}]: it holds at '
                         f'{low} but not at {high}')
    if at_low:
        raise ValueError(f'the predicate already holds at the lower bound {low}: the '
                         'threshold is at or below it')
    if not at_high:
        raise ValueError(f'the predicate does not hold even at the upper bound {high}')
    integral = all(float(v).is_integer() for v in (low, high, tolerance))
    while high - low > tolerance:
        middle = (low + high) // 2 if integral else (low + high) / 2.0
        if predicate(middle):
            high = middle
        else:
            low = middle
    return high


class ProgressBar:
    """
    A plain text progress bar on a stream (stderr by default); tqdm-free.

    On a terminal it redraws in place at most every ``min_interval_s``;
    elsewhere (a log file, a pipe) it writes one line when closed.
    """

    def __init__(self, total: int, label: str = '', stream: Optional[TextIO] = None,
                 width: int = 30, min_interval_s: float = 0.1):
        """Start a bar for ``total`` steps."""
        self.total = max(int(total), 1)
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.min_interval_s = min_interval_s
        self.done = 0
        self.interactive = bool(getattr(self.stream, 'isatty', lambda: False)())
        self._drawn = -math.inf
        self._start = time.monotonic()

    def update(self, steps: int = 1, note: str = '') -> None:
        """Advance by ``steps`` and redraw if due."""
        self.done = min(self.done + steps, self.total)
        if self.interactive:
            self._draw(note)

    def _draw(self, note: str = '') -> None:
        now = time.monotonic()
        if now - self._drawn >= self.min_interval_s or self.done >= self.total:
            self._drawn = now
            filled = int(round(self.width * self.done / self.total))
            bar = '#' * filled + '.' * (self.width - filled)
            self.stream.write(f'\r{self.label} [{bar}] {self.done}/{self.total} '
                              f'{now - self._start:5.1f} s {note:<24.24}')
            self.stream.flush()

    def close(self) -> None:
        """Mark the work done (a search may need fewer steps), draw, end the line."""
        self.done = self.total
        self._drawn = -math.inf
        self._draw()
        self.stream.write('\n')
        self.stream.flush()


class RoomScenario:
    """
    The overview with the room markers of a scene, scalable to an on-screen size.

    :ivar camera: the overview camera (analytic RViz projection).
    :ivar labels: R room labels.
    :ivar positions: marker centres, shape (R, 3), world frame, m.
    :ivar quaternions: orientations x, y, z, w, shape (R, 4).
    :ivar scales: side lengths as in the scene, shape (R, 3), m.
    :ivar colours: r, g, b, a, shape (R, 4).
    :ivar targets: where each marker's centre is on the screen, shape (R, 2), px.
    :ivar start_xy: where the person looks when a trial starts (screen centre), px.
    """

    def __init__(self, scene: Scene, image_size: Sequence[int] = PANEL_SIZE,
                 screen_offset: Sequence[float] = PANEL_OFFSET, fov_y_deg: float = FOV_Y_DEG,
                 screen_size: Sequence[int] = (1920, 1080)):
        """Set up the overview camera and the room markers."""
        self.scene = scene
        self.camera = RvizCamera.from_look_at(*scene.overview.as_tuple(), image_size=image_size,
                                              fov_y_deg=fov_y_deg, screen_offset=screen_offset)
        markers = [room.marker for room in scene.rooms]
        self.labels = tuple(m.text for m in markers)
        self.positions = np.array([m.position for m in markers])
        self.quaternions = np.array([m.orientation for m in markers])
        self.scales = np.array([m.scale for m in markers])
        self.colours = np.array([m.color for m in markers])
        uv, depth = self.camera.project(self.positions)
        if np.any(depth <= 0) or not np.all(self.camera.in_image(uv)):
            raise ValueError('every room marker must be in view of the overview camera')
        self.targets = self.camera.to_screen(uv)
        self.start_xy = np.asarray(screen_size, dtype=float) / 2.0

    def sizes_px(self, scales) -> np.ndarray:
        """
        On-screen size of each marker with the given scales: sqrt of its area, px.

        :param scales: shape (R, 3), m.
        :returns: shape (R,); NaN for a marker with no region.
        """
        polygons, visible = self.camera.box_regions(self.positions, self.quaternions, scales)
        area = np.abs(polygon_signed_area(np.nan_to_num(polygons)))
        return np.where(visible, np.sqrt(area), np.nan)

    def scales_for(self, size_px: float) -> np.ndarray:
        """
        Scale the markers in their own plane so each measures ``size_px`` on the screen.

        The thin side keeps its length.  Perspective makes the size slightly
        non-linear in the scale, so a few fixed-point steps are taken.

        :returns: shape (R, 3), m.
        :raises ValueError: size_px not positive or a marker leaves the panel.
        """
        if not size_px > 0:
            raise ValueError(f'marker size must be > 0 px, got {size_px}')
        scales = self.scales.copy()
        for _ in range(6):
            sizes = self.sizes_px(scales)
            if not np.all(np.isfinite(sizes)):
                raise ValueError(f'at {size_px:g} px a room marker leaves the render panel')
            factor = size_px / sizes
            scales[:, :2] *= factor[:, None]
            if np.max(np.abs(factor - 1.0)) < 1e-6:
                break
        return scales

    def markers(self, size_px: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (positions (R, 3), quaternions (R, 4), scales (R, 3)) at ``size_px``."""
        return self.positions, self.quaternions, self.scales_for(size_px)

    def regions(self, size_px: float) -> RegionSet:
        """Return the screen regions of the markers at ``size_px`` (stamp 0)."""
        polygons, visible = self.camera.box_regions(*self.markers(size_px))
        if not np.all(visible):
            raise ValueError(f'at {size_px:g} px a room marker has no region')
        return RegionSet(self.labels, polygons, 0.0)


@dataclass(frozen=True)
class TrialSettings:
    """
    How each trial is simulated and decided.

    :ivar params: the simulated person and tracker.
    :ivar window_s: gaze collection window from the question, s.
    :ivar arbiter: the choice_arbiter's early-decision settings (its defaults).
    """

    params: GazeParams = ORIGINAL_TOBII_4C
    window_s: float = 1.0
    arbiter: ArbiterSettings = field(default_factory=ArbiterSettings)


@dataclass
class SizeResult:
    """Outcome of N trials at one size, per method."""

    size_px: float
    methods: Tuple[str, ...]
    correct: np.ndarray = field(repr=False)      # (N, M) bool
    no_choice: np.ndarray = field(repr=False)    # (N, M) bool
    decision_s: np.ndarray = field(repr=False)   # (N, M) s

    def accuracy(self, method: str) -> float:
        """Return the fraction of correct trials of ``method``."""
        return float(np.mean(self.correct[:, self.methods.index(method)]))


def trial_seed(seed: int, trial: int) -> int:
    """Return the simulator seed of one trial (independent streams per (seed, trial))."""
    return int(np.random.SeedSequence([int(seed), int(trial)]).generate_state(1)[0])


def run_trials(scenario: RoomScenario, size_px: float, trials: int, seed: int,
               settings: TrialSettings, methods: Sequence[str] = ('mean',),
               progress: Optional[ProgressBar] = None) -> SizeResult:
    """
    Simulate ``trials`` trials at one marker size and decide each with every method.

    Trial k looks at room k mod R with its own person (seed
    :func:`trial_seed`), so every size sees the same people and targets.

    :returns: per trial and method: correct, no choice, decision time.
    """
    unknown = [m for m in methods if m not in CURVE_METHODS]
    if unknown:
        raise ValueError(f"unknown method {unknown[0]!r}: use {', '.join(CURVE_METHODS)}")
    base = settings.arbiter.replace(window_s=settings.window_s)
    rules = [settings_for(method, base) for method in methods]
    regions = scenario.regions(size_px)
    count = len(methods)
    correct = np.zeros((trials, count), dtype=bool)
    no_choice = np.zeros((trials, count), dtype=bool)
    decision_s = np.full((trials, count), np.nan)
    for trial in range(trials):
        target = trial % len(scenario.labels)
        simulator = GazeSimulator(settings.params, seed=trial_seed(seed, trial))
        trace = simulator.simulate(settings.window_s, [(0.0, scenario.targets[target])],
                                   initial_xy=scenario.start_xy)
        valid = trace.valid
        points, stamps = trace.xy[valid], trace.t[valid]
        for column, rule in enumerate(rules):
            decision = decide_trial(points, stamps, regions, rule).decision
            correct[trial, column] = decision.label == scenario.labels[target]
            no_choice[trial, column] = decision.label is None
            decision_s[trial, column] = decision.time_to_decision
        if progress is not None:
            progress.update()
    return SizeResult(float(size_px), tuple(methods), correct, no_choice, decision_s)


def accuracy_curve(scenario: RoomScenario, sizes: Sequence[float], trials: int, seed: int,
                   settings: TrialSettings, methods: Sequence[str],
                   progress: Optional[ProgressBar] = None) -> List[SizeResult]:
    """Run :func:`run_trials` at every size."""
    return [run_trials(scenario, size, trials, seed, settings, methods, progress)
            for size in sizes]


CURVE_COLUMNS = ('size_px', 'method', 'trials', 'correct', 'no_choice', 'accuracy',
                 'ci95_low', 'ci95_high', 'mean_decision_s')


def curve_rows(results: Sequence[SizeResult]) -> List[dict]:
    """Turn curve results into CSV rows (:data:`CURVE_COLUMNS`)."""
    rows = []
    for result in results:
        for column, method in enumerate(result.methods):
            n = len(result.correct)
            k = int(result.correct[:, column].sum())
            low, high = demo_render.wilson_interval(k, n)
            rows.append({
                'size_px': _number(result.size_px), 'method': method, 'trials': n, 'correct': k,
                'no_choice': int(result.no_choice[:, column].sum()),
                'accuracy': round(k / n, 6), 'ci95_low': round(float(low), 6),
                'ci95_high': round(float(high), 6),
                'mean_decision_s': round(float(np.nanmean(result.decision_s[:, column])), 6)})
    return rows


def _number(value: float):
    """Return an integral float as int (for tidy CSV and JSON)."""
    return int(value) if float(value).is_integer() else float(value)


def write_csv(path: str, rows: Sequence[dict], columns: Sequence[str]) -> str:
    """Write rows with the given columns; returns ``path``."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        writer = csv.DictWriter(stream, fieldnames=list(columns))
        writer.writeheader()
        writer.writerows(rows)
    return path


def format_table(results: Sequence[SizeResult]) -> str:
    """Format the curve as a text table: size, then accuracy and no-choice % per method."""
    if not results:
        return ''
    methods = results[0].methods
    head = f"{'size px':>8} " + ' '.join(f'{m + " %":>9} {"no choice":>9}' for m in methods)
    lines = [head, '-' * len(head)]
    for result in results:
        none = 100 * result.no_choice.mean(axis=0)
        lines.append(f'{result.size_px:>8g} ' + ' '.join(
            f'{100 * result.accuracy(m):>9.1f} {none[i]:>9.1f}' for i, m in enumerate(methods)))
    return '\n'.join(lines)


def search_thresholds(scenario: RoomScenario, methods: Sequence[str], trials: int, seed: int,
                      settings: TrialSettings, low: int, high: int, fraction: float,
                      stream: Optional[TextIO] = None) -> Dict[str, dict]:
    """
    Run the binary search for each method.

    :returns: method -> {'threshold_px': value or NaN, 'note': text,
        'evaluations': [(size, accuracy), ...]}.
    """
    found = {}
    for method in methods:
        evaluations: List[Tuple[float, float]] = []
        steps = int(math.ceil(math.log2(max(high - low, 2)))) + 2
        bar = ProgressBar(steps, f'binary search ({method})', stream)

        def predicate(size, method=method, evaluations=evaluations, bar=bar):
            result = run_trials(scenario, size, trials, seed, settings, (method,))
            accuracy = result.accuracy(method)
            evaluations.append((float(size), accuracy))
            bar.update(note=f'{size:g} px: {100 * accuracy:.0f} %')
            return accuracy >= fraction - 1e-12

        note = ''
        if predicate(low):
            threshold, note = float(low), f'every trial right already at the lower bound {low} px'
        else:
            try:
                threshold = float(binary_search_threshold(predicate, low, high))
            except ValueError as error:
                threshold, note = math.nan, str(error)
        bar.close()
        found[method] = {'threshold_px': threshold, 'note': note,
                         'evaluations': evaluations}
    return found


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line options of ``accuracy_test``."""
    parser = argparse.ArgumentParser(
        prog='accuracy_test', description=__doc__.strip().split('\n\n')[0],
        epilog='Default mode: simulated person, pure pipeline code on simulated time (no ROS, '
               'no LSL; fast and deterministic). --live: real nodes, a real tracker on LSL '
               'and a real person looking at RViz.',
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument('--methods', default='original,early',
                        help=f"decision rules, comma separated, of {', '.join(CURVE_METHODS)}")
    parser.add_argument('--preset', default=ORIGINAL_TOBII_4C.name, choices=sorted(PRESETS),
                        help='simulated person and tracker')
    parser.add_argument('--seed', type=int, default=0, help='base seed of the trials')
    parser.add_argument('--window-s', type=float, default=1.0,
                        help='gaze collection window of a trial, s')
    parser.add_argument('--search-trials', type=int, default=20,
                        help='K: trials per size in the binary search')
    parser.add_argument('--search-threshold', type=float, default=1.0,
                        help='fraction of the K trials that must be correct (1 = all)')
    parser.add_argument('--low', type=int, default=1, help='binary search lower bound, px')
    parser.add_argument('--high', type=int, default=300, help='binary search upper bound, px')
    parser.add_argument('--trials', type=int, default=200, help='N: trials per size, curve')
    parser.add_argument('--sizes', default=','.join(str(s) for s in DEFAULT_SIZES),
                        help='marker sizes of the curve, px, comma separated')
    parser.add_argument('--no-search', action='store_true', help='skip the binary search')
    parser.add_argument('--no-curve', action='store_true', help='skip the curve')
    parser.add_argument('--output-dir', default='demo_output',
                        help='where accuracy_curve.csv/.png and accuracy_summary.json go')
    live = parser.add_argument_group('live mode (a real person and eye tracker)')
    live.add_argument('--live', action='store_true',
                      help='run the binary search with the real nodes, RViz and a real tracker')
    live.add_argument('--profile', default='xy_pixels', help='lsl_gaze_bridge profile')
    live.add_argument('--stream-name', default='', help='LSL stream name (bridge parameter)')
    live.add_argument('--stream-type', default='', help='LSL stream type (bridge parameter)')
    live.add_argument('--source-id', default='', help='LSL source_id (bridge parameter)')
    live.add_argument('--stream-timeout-s', type=float, default=30.0,
                      help='give up when no gaze arrives within this time, s')
    live.add_argument('--screen-offset', type=int, nargs=2, default=list(PANEL_OFFSET),
                      metavar=('X0', 'Y0'), help='render panel top-left on the screen, px')
    live.add_argument('--image-size', type=int, nargs=2, default=list(PANEL_SIZE),
                      metavar=('W', 'H'), help='RViz render panel size, px')
    live.add_argument('--lead-s', type=float, default=2.0,
                      help='time to find the room before the round starts, s')
    return parser


def _parse_methods(text: str) -> Tuple[str, ...]:
    methods = tuple(m.strip() for m in text.split(',') if m.strip())
    bad = [m for m in methods if m not in CURVE_METHODS]
    if not methods or bad:
        raise ValueError(f"--methods must list some of {', '.join(CURVE_METHODS)}, got {text!r}")
    return methods


def _parse_sizes(text: str) -> Tuple[float, ...]:
    try:
        sizes = tuple(float(s) for s in text.split(',') if s.strip())
    except ValueError:
        raise ValueError(f'--sizes must be numbers separated by commas, got {text!r}') from None
    if not sizes or any(not s > 0 for s in sizes):
        raise ValueError(f'--sizes must be positive, got {text!r}')
    return tuple(int(s) if s.is_integer() else s for s in sizes)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the accuracy test; return the exit code (0 done, 1 failed, 2 bad usage)."""
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        methods = _parse_methods(args.methods)
        sizes = _parse_sizes(args.sizes)
        if not 0 < args.search_threshold <= 1:
            raise ValueError('--search-threshold must be in (0, 1]')
        if args.search_trials < 1 or args.trials < 1:
            raise ValueError('--search-trials and --trials must be at least 1')
        if not 1 <= args.low < args.high:
            raise ValueError('need 1 <= --low < --high')
        settings = TrialSettings(params=PRESETS[args.preset], window_s=args.window_s)
        scene = load_scene(default_scene_path())
    except ValueError as error:
        parser.error(str(error))
    if args.live:
        return run_live(args, scene, methods)
    return _run_simulated(args, scene, methods, sizes, settings)


def _run_simulated(args, scene: Scene, methods, sizes, settings: TrialSettings) -> int:
    """Run the simulated search and curve, write and print the results."""
    scenario = RoomScenario(scene)
    person = settings.params.person
    setup = (f'simulated person {settings.params.name} (offset {person.offset_deg:g} deg, '
             f'jitter {person.jitter_deg:g} deg, {settings.params.tracker.rate_hz:g} Hz), '
             f'window {settings.window_s:g} s, seed {args.seed}; pure pipeline code on '
             'simulated time (no ROS, no LSL)')
    print(f'accuracy test, room scenario (overview, {len(scenario.labels)} rooms): {setup}')
    summary = {'mode': 'simulated', 'preset': settings.params.name,
               'settings': {k: v for k, v in asdict(settings).items() if k != 'params'},
               'person': asdict(settings.params), 'seed': args.seed}
    thresholds = {}
    if not args.no_search:
        found = search_thresholds(scenario, methods, args.search_trials, args.seed, settings,
                                  args.low, args.high, args.search_threshold)
        for method, item in found.items():
            thresholds[method] = item['threshold_px']
            rule = ('all' if args.search_threshold >= 1 else
                    f'>= {100 * args.search_threshold:g} % of the')
            if math.isfinite(item['threshold_px']):
                print(f"smallest marker size ({method}): {item['threshold_px']:g} px "
                      f'({rule} {args.search_trials} trials correct; original report: about '
                      f'{REPORT_THRESHOLD_PX:g} px)')
            else:
                print(f"smallest marker size ({method}): not found: {item['note']}")
        summary['binary_search'] = {
            'trials': args.search_trials, 'fraction': args.search_threshold,
            'low_px': args.low, 'high_px': args.high, 'results': found}
    files = []
    if not args.no_curve:
        bar = ProgressBar(len(sizes) * args.trials, 'accuracy curve')
        results = accuracy_curve(scenario, sizes, args.trials, args.seed, settings, methods,
                                 bar)
        bar.close()
        print(format_table(results))
        rows = curve_rows(results)
        csv_path = os.path.join(args.output_dir, 'accuracy_curve.csv')
        files.append(write_csv(csv_path, rows, CURVE_COLUMNS))
        curves = {m: (np.array([r.correct[:, i].sum() for r in results]),
                      np.array([len(r.correct) for r in results]))
                  for i, m in enumerate(methods)}
        note = setup
        if len(methods) > 1 and all(np.array_equal(c[0], curves[methods[0]][0])
                                    for c in curves.values()):
            # With one looked-at marker every miss is 'no choice', whatever the rule.
            note += ('\nthe rules agree at every size: each miss is a round with no gaze on '
                     'any marker')
            print('the rules agree at every size: each miss is a round with no gaze sample on '
                  'any marker (no choice)')
        png_path = os.path.join(args.output_dir, 'accuracy_curve.png')
        files.append(demo_render.plot_accuracy_curve(
            png_path, sizes, curves, thresholds,
            title=f'Room scenario: accuracy against marker size ({args.trials} trials per size)',
            note=note))
        summary['curve'] = rows
    os.makedirs(args.output_dir, exist_ok=True)
    path = os.path.join(args.output_dir, 'accuracy_summary.json')
    with open(path, 'w', encoding='utf-8') as stream:
        json.dump(summary, stream, indent=2, default=demo_render.json_default)
    files.append(path)
    print('wrote ' + ', '.join(files))
    return 0


def _quadrant(xy, scenario: RoomScenario) -> str:
    """Say where on the render panel a screen point lies ('upper left', ...)."""
    x0, y0 = scenario.camera.screen_offset
    width, height = scenario.camera.image_size
    vertical = 'upper' if xy[1] < y0 + height / 2 else 'lower'
    horizontal = 'left' if xy[0] < x0 + width / 2 else 'right'
    return f'{vertical} {horizontal}'


def run_live(args, scene: Scene, methods: Sequence[str]) -> int:
    """
    Run the binary search with a real person, a real tracker and the real nodes.

    The pipeline nodes (without the menu) run on the current ROS domain; the
    test markers go out on ``choices`` and the overview on ``camera/goal``;
    the terminal tells the person which room to look at; the arbiter decides.
    Uses the first of ``methods`` (:func:`eye_bci_ros2.experiments.trials.settings_for`).

    :returns: 0 when the search finished, 1 when no gaze arrived or it failed.
    """
    # Imported here: the default (simulated) mode needs no ROS.
    from geometry_msgs.msg import PoseStamped
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node
    from std_msgs.msg import Empty
    from visualization_msgs.msg import Marker, MarkerArray

    from eye_bci_ros2.nodes.eye_bci import make_pipeline_nodes
    from eye_bci_ros2.projection.camera_model import look_at_pose
    from eye_bci_ros2.ros.conversions import arrays_to_pose, cube_marker
    from eye_bci_ros2.ros.runner import make_executor, spin_until as spin
    from eye_bci_ros2.ros.topics import (CAMERA_GOAL_TOPIC, CHOICES_TOPIC, EVENT_QOS,
                                         LATCHED_QOS, REQUEST_TOPIC)

    scenario = RoomScenario(scene, image_size=args.image_size, screen_offset=args.screen_offset)
    method = methods[0]
    rule = settings_for(method, ArbiterSettings(window_s=args.window_s))
    overview = scene.overview
    context = Context()
    rclpy.init(context=context)
    executor = make_executor(context=context)
    nodes = []

    def spin_until(predicate, timeout):
        return spin(executor, predicate, timeout)

    try:
        nodes = make_pipeline_nodes(context, overrides={
            'lsl_gaze_bridge': {'profile': args.profile, 'stream_name': args.stream_name,
                                'stream_type': args.stream_type, 'source_id': args.source_id},
            'camera_tracker': {'eye': [float(v) for v in overview.eye],
                               'focus': [float(v) for v in overview.focus],
                               'up': [float(v) for v in overview.up]},
            'marker_projector': {'image_width': args.image_size[0],
                                 'image_height': args.image_size[1],
                                 'screen_offset_x': args.screen_offset[0],
                                 'screen_offset_y': args.screen_offset[1]},
            'choice_arbiter': {name: getattr(rule, name) for name in (
                'method', 'early_decision', 'window_s', 'classification', 'min_share')},
        })
        bridge, arbiter = nodes[0], nodes[3]
        helper = Node('accuracy_test', context=context)
        nodes.append(helper)
        choices = helper.create_publisher(MarkerArray, CHOICES_TOPIC, LATCHED_QOS)
        goal = helper.create_publisher(PoseStamped, CAMERA_GOAL_TOPIC, LATCHED_QOS)
        request = helper.create_publisher(Empty, REQUEST_TOPIC, EVENT_QOS)
        for node in nodes:
            executor.add_node(node)
        selection = bridge.config.describe_selection()
        print(f'live accuracy test: waiting up to {args.stream_timeout_s:g} s for gaze from an '
              f'LSL stream ({selection}, profile {args.profile}) ...', flush=True)
        if not spin_until(lambda: bridge.counters['published'] > 0, args.stream_timeout_s):
            found = bridge.stream or 'no matching stream found'
            print(f'accuracy_test --live: no gaze arrived within {args.stream_timeout_s:g} s '
                  f'({found}; looking for {selection}). Is the eye tracker streaming on LSL, '
                  'and do --profile/--stream-name/--source-id match it?', file=sys.stderr)
            return 1
        print(f'gaze from {bridge.stream}', flush=True)
        message = PoseStamped()
        message.header.frame_id = scene.frame_id
        message.pose = arrays_to_pose(*look_at_pose(*overview.as_tuple()))
        goal.publish(message)
        print(f'show RViz with the overview view (eye {overview.eye.tolist()}, focus '
              f'{overview.focus.tolist()}); its render panel {args.image_size[0]}x'
              f'{args.image_size[1]} px at ({args.screen_offset[0]}, {args.screen_offset[1]}) '
              'on the screen', flush=True)
        rng = np.random.default_rng(args.seed)
        log: List[dict] = []

        def show(size):
            positions, quaternions, scales = scenario.markers(size)
            array = MarkerArray(markers=[Marker(action=Marker.DELETEALL)])
            array.markers[0].header.frame_id = scene.frame_id
            for index, label in enumerate(scenario.labels):
                array.markers.append(cube_marker(
                    'rooms', index, label, scene.frame_id, positions[index],
                    quaternions[index], scales[index], scenario.colours[index],
                    helper.get_clock().now().to_msg()))
            choices.publish(array)

        def predicate(size):
            show(size)
            correct = 0
            for trial in range(args.search_trials):
                target = int(rng.integers(len(scenario.labels)))
                label = scenario.labels[target]
                where = _quadrant(scenario.targets[target], scenario)
                print(f'{size:g} px, trial {trial + 1}/{args.search_trials}: look at '
                      f"'{label}' ({where} of the panel)", flush=True)
                spin_until(lambda: False, args.lead_s)
                before = arbiter.last_decision
                request.publish(Empty())
                if not spin_until(lambda: arbiter.last_decision is not before,
                                  args.window_s + 10.0):
                    raise RuntimeError('the choice_arbiter made no decision; is gaze '
                                       'still arriving?')
                decision = arbiter.last_decision
                correct += decision.label == label
                print(f"   system chose '{decision.label}'"
                      f" -> {'correct' if decision.label == label else 'WRONG'}", flush=True)
                log.append({'size_px': size, 'trial': trial + 1, 'intended': label,
                            'chosen': decision.label or '',
                            'in_region_samples': decision.in_region_samples})
            return correct / args.search_trials >= args.search_threshold - 1e-12

        try:
            threshold = binary_search_threshold(predicate, args.low, args.high)
            print(f'smallest marker size ({method}, live): {threshold:g} px')
        except ValueError as error:
            print(f'binary search: {error}')
        path = write_csv(os.path.join(args.output_dir, 'accuracy_live_trials.csv'), log,
                         ('size_px', 'trial', 'intended', 'chosen', 'in_region_samples'))
        print(f'wrote {path}')
        return 0
    except (RuntimeError, ValueError) as error:
        print(f'accuracy_test --live failed: {error}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print('accuracy_test --live interrupted', file=sys.stderr)
        return 130
    finally:
        executor.shutdown()
        for node in nodes:
            node.destroy_node()
        context.try_shutdown()


if __name__ == '__main__':
    sys.exit(main())
