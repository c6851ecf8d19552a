"""
Benchmark: whether the tolerant decision rule pays (issue 10: marker size, wrong choices).

Rules compared, each on the node's own decision code
(:class:`eye_bci_ros2.arbitration.RoundEvidence`, fed the valid samples in
stamp order, as ``bench/decision.py`` and the accuracy test do):

* ``mean`` (the original), ``vote``, ``early`` (the node's early decision,
  :class:`bench.decision.EarlyConfig` defaults, mean at the window end):
  inside-only classification;
* ``tol_mean``, ``tol_vote``, ``tol_early``: the same code given a
  :class:`TolerantRegions` (a ``RegionSet`` whose ``classify`` and
  ``classify_one`` apply :func:`eye_bci_ros2.tolerance.extend_to_nearby`),
  so every sample and the window-end mean are classified by the tolerant rule
  with the gaze-error model :data:`MODEL` converted to px at each sample
  (the person's screen geometry, as a configured arbiter has it) and
  :data:`RATIO`.  Nothing else in the decision changes.

Measurements:

1. ``smallest``: the accuracy test's binary search
   (:func:`eye_bci_ros2.accuracy_test.search_thresholds`: room scenario,
   ``original_tobii_4c`` person, 0.8 deg offset, 1 s window, seed 0, every one
   of K = 20 trials right) per rule.  Goal: <= 12 px for the default rule.
2. ``midway``: the gaze rests midway between two neighbouring options of a
   ``bench/decision.py`` layout (3, 4, 9 targets, sizes S 60..200 px, gap S/2)
   for the whole window (the person looks at neither: any choice is wrong),
   for the bench's consumer person and the 0.8 deg person.  Goal: <= 0.5 %
   wrong for every rule offered as a default.
3. ``other_target``: ``bench/decision.py``'s stress scenario (the gaze rests on
   another option when the menu appears, then moves to the goal): wrong %.
4. ``hit_rate``: of the samples after fixation onset in
   ``bench/decision.py``'s main scenario, the fraction of inside samples and of
   near samples (outside, counted by the tolerance) that count for the option
   looked at: the hit rate the evidence model should use for each kind.

Run: ``python -m bench.tolerance`` (about a minute; ``--quick``: seconds).
"""

import argparse
import json
import math
import sys
import time
from typing import Dict, Optional, Sequence

import numpy as np

from bench import decision
from eye_bci_ros2 import accuracy_test
from eye_bci_ros2.arbitration import RegionSet, RoundEvidence
from eye_bci_ros2.gaze_model import (CONSUMER_TRACKER, GazeParams, GazeSimulator,
                                     ORIGINAL_TOBII_4C, ScreenGeometry)
from eye_bci_ros2.scene import default_scene_path, load_scene
from eye_bci_ros2.tolerance import DEFAULT_RATIO, extend_to_nearby, GazeErrorModel

#: The gaze-error model of the tolerant rule (defaults: 0.8 deg, 0.3 deg, k = 2).
MODEL = GazeErrorModel()
#: Nearest / second-nearest distance ratio.
RATIO = DEFAULT_RATIO
#: Rules measured: name -> (window rule or 'early', tolerant, ratio, share).  ``share``: a
#: choice needs at least this fraction of the samples it weighed on its label (see
#: :func:`_decide`; 0 = today's decision code).  ``/s``: the strict variant proposed for
#: the midway goal (ratio 0.2, share 0.5).
RULES = {
    'mean': ('mean', False, RATIO, 0.0),
    'vote': ('vote', False, RATIO, 0.0),
    'early': ('early', False, RATIO, 0.0),
    'tol_mean': ('mean', True, RATIO, 0.0),
    'tol_vote': ('vote', True, RATIO, 0.0),
    'tol_early': ('early', True, RATIO, 0.0),
    'mean/s': ('mean', False, RATIO, 0.5),
    'early/s': ('early', False, RATIO, 0.5),
    'tol_mean/s': ('mean', True, 0.2, 0.5),
    'tol_vote/s': ('vote', True, 0.2, 0.5),
    'tol_early/s': ('early', True, 0.2, 0.5),
}
#: The issue's goals.
GOAL_SMALLEST_PX = 12.0
GOAL_MIDWAY_WRONG = 0.005
#: Trials per cell (full, quick) for the midway and other_target scenarios.
TRIALS = 200
QUICK_TRIALS = 20
#: Trials of the binary search (the accuracy test's default K).
SEARCH_TRIALS = 20
MIDWAY_SEED = 3_000_000


class TolerantRegions(RegionSet):
    """
    A ``RegionSet`` that classifies by the tolerant rule (the hook the arbiter needs).

    :param model: gaze-error model, degrees.
    :param ratio: nearest / second-nearest distance ratio, (0, 1].
    :param screen: the person's screen, for degrees -> px at each sample.
    """

    def __init__(self, labels, polygons, stamp: float = 0.0, model: GazeErrorModel = MODEL,
                 ratio: float = RATIO, screen: Optional[ScreenGeometry] = None):
        """Prepare the regions and the rule."""
        super().__init__(labels, polygons, stamp)
        self.model = model
        self.ratio = ratio
        self.screen = screen if screen is not None else ScreenGeometry()

    @classmethod
    def of(cls, regions: RegionSet, **rule) -> 'TolerantRegions':
        """Return ``regions`` with the tolerant rule."""
        return cls(regions.labels, regions.polygons, regions.stamp, **rule)

    def classify(self, points) -> np.ndarray:
        """Region index of each point (N, 2) px by the tolerant rule, -1 = none."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        inside = super().classify(points)
        return extend_to_nearby(inside, points, self.polygons,
                                self.model.tolerance_px(points, self.screen), self.ratio)

    def classify_one(self, x: float, y: float) -> int:
        """Region index of one point, tolerant rule."""
        return int(self.classify(np.array([[x, y]]))[0])


def _decide(rule: str, points, stamps, regions: RegionSet, config: decision.EarlyConfig,
            screen: ScreenGeometry) -> Optional[str]:
    """
    Label chosen by a rule of :data:`RULES` for one trial (window 0..config.window_s).

    Share test (``share`` > 0), a change of the decision code simulated here:
    a window-end choice needs ``counts[label] >= share * samples_used`` (all
    valid samples of the window, in and out of regions); an early choice needs
    that share over the samples since the chosen label's current run began
    (:func:`_run_share`), else the round goes on to the window end.
    """
    base, tolerant, ratio, share = RULES[rule]
    if tolerant:
        regions = TolerantRegions.of(regions, screen=screen, ratio=ratio)
    keep = stamps < config.window_s
    points, stamps = points[keep], stamps[keep]

    def evidence():
        return RoundEvidence(0.0, hit_rate=config.hit_rate, min_samples=config.min_samples,
                             dwell_s=config.dwell_s, min_reaction_s=config.min_reaction_s)

    if base == 'early':
        early = evidence()
        made = early.add(points, stamps, regions, config.confidence)
        if made is not None and _run_share(made, points, stamps, regions) >= share:
            return made.label
        base = config.method
    window = evidence()
    window.add(points, stamps, regions)
    made = window.decide(base)
    if made.label is None or made.counts.get(made.label, 0) < share * max(made.samples_used, 1):
        return None
    return made.label


def _run_share(made, points, stamps, regions: RegionSet) -> float:
    """
    Share of the samples since the chosen label's current run began that count for it.

    The run (``RoundEvidence``'s: in-region samples on one label, outside
    samples not interrupting it) starts after the last sample on another
    label before the decision; the share is over every sample (in and out of
    regions) from its first sample to the deciding one.
    """
    upto = stamps <= made.time_to_decision + 1e-12
    region = regions.classify(points[upto])
    labels = np.array(list(regions.labels) + [''], dtype=object)[region]
    on = labels == made.label
    other = (region >= 0) & ~on
    last_other = np.flatnonzero(other)
    begin = last_other[-1] + 1 if last_other.size else 0
    first_on = np.flatnonzero(on[begin:])
    if not first_on.size:
        return 0.0
    window = on[begin + first_on[0]:]
    return float(window.mean())


def smallest(rules: Sequence[str] = tuple(RULES), trials: int = SEARCH_TRIALS,
             params: GazeParams = ORIGINAL_TOBII_4C, seed: int = 0) -> Dict[str, Dict]:
    """
    Smallest marker chosen right in every trial, per rule (px), by the accuracy test's search.

    The trials are :func:`eye_bci_ros2.accuracy_test.run_trials`'s (same
    persons, targets, start point and window; checked: ``mean`` gives the
    accuracy test's figure), decided by :func:`_decide`.
    """
    scenario = accuracy_test.RoomScenario(load_scene(default_scene_path()))
    settings = accuracy_test.TrialSettings(params=params)
    config = decision.EarlyConfig(window_s=settings.window_s)
    data = []
    for trial in range(trials):
        target = trial % len(scenario.labels)
        simulator = GazeSimulator(params, seed=accuracy_test.trial_seed(seed, trial))
        trace = simulator.simulate(settings.window_s, [(0.0, scenario.targets[target])],
                                   initial_xy=scenario.start_xy)
        data.append((scenario.labels[target], trace.t[trace.valid], trace.xy[trace.valid]))
    out = {}
    for rule in rules:
        def predicate(size, rule=rule):
            regions = scenario.regions(size)
            return all(_decide(rule, points, stamps, regions, config, params.person.screen)
                       == label for label, stamps, points in data)
        try:
            found, note = float(accuracy_test.binary_search_threshold(predicate, 1, 300)), ''
        except ValueError as error:
            found, note = math.nan, str(error)
            if 'lower bound' in note:
                found = 1.0
                note = 'right at 1 px already (the lower bound)'
        out[rule] = {'threshold_px': found, 'note': note}
    return out


def _midway_trials(count: int, size: float, seeds, params: GazeParams):
    """Trials resting midway between two horizontally neighbouring targets: (stamps, points)."""
    centres = decision.layout(count, size, params)
    columns, _ = decision.LAYOUTS[count]
    left = [i for i in range(count) if i % columns < columns - 1]
    trials = []
    for seed in seeds:
        rng = np.random.default_rng([int(seed), count, int(size), 7])
        i = int(rng.choice(left))
        midway = (centres[i] + centres[i + 1]) / 2.0
        trace = GazeSimulator(params, seed=int(seed)).simulate(
            decision.WINDOW_S, [(0.0, midway)], initial_xy=midway)
        trials.append((trace.t[trace.valid], trace.xy[trace.valid]))
    return trials


def midway(rules: Sequence[str] = tuple(RULES), trials: int = TRIALS,
           params: GazeParams = CONSUMER_TRACKER, counts=(3, 4, 9),
           sizes=decision.SIZES) -> Dict[str, Dict]:
    """Wrong choices (any choice) with the gaze midway between two options, per rule and cell."""
    config = decision.EarlyConfig()
    screen = params.person.screen
    table: Dict[str, Dict] = {rule: {} for rule in rules}
    seeds = range(MIDWAY_SEED, MIDWAY_SEED + trials)
    for count in counts:
        for size in sizes:
            regions = decision.region_set(count, size)
            data = _midway_trials(count, size, seeds, params)
            for rule in rules:
                wrong = [_decide(rule, points, stamps, regions, config, screen) is not None
                         for stamps, points in data]
                table[rule][f'{count}x{size}'] = float(np.mean(wrong))
    for rule in rules:
        table[rule]['all'] = float(np.mean(list(table[rule].values())))
    return table


def other_target(rules: Sequence[str] = tuple(RULES), trials: int = TRIALS,
                 params: GazeParams = CONSUMER_TRACKER, counts=(3, 4, 9),
                 sizes=decision.SIZES) -> Dict[str, Dict]:
    """Accuracy and wrong fraction in bench/decision.py's stress scenario, per rule."""
    config = decision.EarlyConfig()
    screen = params.person.screen
    out: Dict[str, Dict] = {rule: {'wrong': 0, 'correct': 0, 'trials': 0} for rule in rules}
    seeds = range(decision.TEST_SEED, decision.TEST_SEED + trials)
    for count in counts:
        for size in sizes:
            regions = decision.region_set(count, size)
            data = decision.simulate_trials(count, size, seeds, 'other_target', params)
            for rule in rules:
                labels = [_decide(rule, t.points, t.stamps, regions, config, screen)
                          for t in data]
                row = out[rule]
                row['trials'] += len(data)
                row['correct'] += sum(label == str(t.goal) for label, t in zip(labels, data))
                row['wrong'] += sum(label is not None and label != str(t.goal)
                                    for label, t in zip(labels, data))
    return {rule: {'accuracy': row['correct'] / row['trials'],
                   'wrong': row['wrong'] / row['trials'], 'trials': row['trials']}
            for rule, row in out.items()}


def hit_rate(trials: int = TRIALS, params: GazeParams = CONSUMER_TRACKER, counts=(3, 4, 9),
             sizes=decision.SIZES) -> Dict[str, float]:
    """Fraction of inside and of near samples (after fixation onset) on the option looked at."""
    screen = params.person.screen
    tallies = np.zeros((2, 2))   # [inside, near] x [hits, total]
    seeds = range(decision.TEST_SEED, decision.TEST_SEED + trials)
    for count in counts:
        for size in sizes:
            regions = decision.region_set(count, size)
            tolerant = TolerantRegions.of(regions, screen=screen)
            for t in decision.simulate_trials(count, size, seeds, 'new_menu', params):
                after = t.stamps >= t.onset
                points = t.points[after]
                inside = regions.classify(points)
                near = tolerant.classify(points)
                near[inside >= 0] = -1
                for row, region in enumerate((inside, near)):
                    counted = region >= 0
                    tallies[row, 0] += np.count_nonzero(region[counted] == t.goal)
                    tallies[row, 1] += np.count_nonzero(counted)
    return {'inside': tallies[0, 0] / tallies[0, 1], 'near': tallies[1, 0] / tallies[1, 1],
            'inside_samples': int(tallies[0, 1]), 'near_samples': int(tallies[1, 1])}


def run(quick: bool = False) -> Dict:
    """Run every measurement (module doc); return the section."""
    started = time.perf_counter()
    trials = QUICK_TRIALS if quick else TRIALS
    section = {
        'smallest_px': smallest(trials=5 if quick else SEARCH_TRIALS),
        'midway_wrong': {p.name: midway(trials=trials, params=p)
                         for p in (CONSUMER_TRACKER, ORIGINAL_TOBII_4C)},
        'other_target': other_target(trials=trials),
        'hit_rate': hit_rate(trials=max(trials // 4, 5)),
        'setup': {'model': {'accuracy_deg': MODEL.accuracy_deg,
                            'precision_deg': MODEL.precision_deg, 'k_sigma': MODEL.k_sigma,
                            'tolerance_deg': MODEL.tolerance_deg},
                  'ratio': RATIO, 'trials': trials,
                  'seconds': round(time.perf_counter() - started, 1)},
    }
    return section


def format_lines(section: Dict) -> list:
    """Human table of a section."""
    setup = section['setup']
    model = setup['model']
    lines = [f"tolerant rule: {model['tolerance_deg']:.2f} deg tolerance (accuracy "
             f"{model['accuracy_deg']} deg, precision {model['precision_deg']} deg, k "
             f"{model['k_sigma']}), ratio {setup['ratio']}; {setup['trials']} trials per cell",
             '', f"{'rule':>12} {'smallest px':>11} " + ' '.join(
                 f'{"midway " + name[:16] + " %":>25}' for name in section['midway_wrong'])
             + f" {'other_target wrong%':>20}"]
    for rule in RULES:
        px = section['smallest_px'][rule]['threshold_px']
        mids = ' '.join(f"{100 * table[rule]['all']:>25.2f}"
                        for table in section['midway_wrong'].values())
        lines.append(f'{rule:>12} {px:>11g} {mids} '
                     f"{100 * section['other_target'][rule]['wrong']:>20.2f}")
    lines.append('')
    for name, table in section['midway_wrong'].items():
        cells = [cell for cell in table[next(iter(RULES))] if cell != 'all']
        lines.append(f'midway wrong % per cell ({name}):')
        lines.append(f"{'rule':>12} " + ' '.join(f'{cell:>7}' for cell in cells))
        for rule in RULES:
            lines.append(f'{rule:>12} ' + ' '.join(f'{100 * table[rule][cell]:>7.1f}'
                                                   for cell in cells))
    hits = section['hit_rate']
    lines.append('')
    lines.append(f"hit rate after fixation onset: inside {hits['inside']:.3f} "
                 f"({hits['inside_samples']} samples), near {hits['near']:.3f} "
                 f"({hits['near_samples']} samples)")
    best = section['smallest_px']['tol_mean']['threshold_px']
    lines.append(f'goals: smallest (tol_mean) {best:g} px (<= {GOAL_SMALLEST_PX:g}); midway '
                 f'wrong <= {100 * GOAL_MIDWAY_WRONG} % for every rule offered as a default')
    lines.append(f"({setup['seconds']} s)")
    return lines


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the benchmark and print its table (and JSON with --json)."""
    parser = argparse.ArgumentParser(prog='python -m bench.tolerance',
                                     description=__doc__.split('\n\n')[0].strip())
    parser.add_argument('--quick', action='store_true', help='few trials')
    parser.add_argument('--json', metavar='PATH', help='also write the section as JSON')
    args = parser.parse_args(argv)
    section = run(quick=args.quick)
    print('\n'.join(format_lines(section)))
    if args.json:
        with open(args.json, 'w', encoding='utf-8') as output:
            json.dump(section, output, indent=2, default=lambda v: None if (
                isinstance(v, float) and math.isnan(v)) else v)
            output.write('\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
