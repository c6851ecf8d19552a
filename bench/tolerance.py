"""
Benchmark: whether the tolerant decision rule pays (marker size, wrong choices).

Rules compared, each on the node's own decision code
(:class:`eye_bci_ros2.decision.rounds.RoundEvidence`, fed the valid samples in
stamp order, as ``bench/decision.py`` and the accuracy test do), named in
:data:`RULES`:

* ``mean`` (the original), ``vote``, ``early`` (the node's early decision,
  :data:`bench.decision.COUNT_EARLY`, mean at the window end):
  inside-only classification, today's code;
* ``tol_*``: the same code given a :class:`TolerantRegions` (a ``RegionSet``
  whose ``classify`` and ``classify_one`` apply
  :func:`eye_bci_ros2.decision.tolerance.extend_to_nearby`), so every sample and the
  window-end mean are classified by the tolerant rule, with the gaze-error
  model a validation of the person would give (:func:`model_for`: accuracy
  = the simulated offset, precision = the jitter, k = 2) converted to px at
  each sample on the person's screen;
* ``size_*``: the size-aware tolerance (counted from the option's centre:
  none for options larger than the error);
* ``*/s``: with the **share test** (the node's ``min_share`` 0.5, in
  :class:`eye_bci_ros2.decision.evidence.RoundEvidence`): a window-end choice needs at
  least half of *all* the window's valid samples (in and out of regions) on
  its label; an early choice needs :data:`eye_bci_ros2.decision.evidence.EARLY_SHARE` of
  the samples of the last ``EARLY_SHARE_S`` on its label at the deciding sample.
  ``size_mean/s`` is the choice_arbiter's default rule.

Every rule runs as :class:`eye_bci_ros2.decision.rounds.ArbiterSettings`
(:func:`settings_for`) on the node's decision code.

Measurements:

1. ``smallest``: the accuracy test's binary search (room scenario,
   ``original_tobii_4c`` person, 0.8 deg offset, 1 s window, seed 0, every
   one of K = 20 trials right, 1..300 px; the trials of
   :func:`eye_bci_ros2.experiments.accuracy_test.run_trials`, ``mean`` reproduces the
   accuracy test's 34 px) per rule; ``corrected``: the same after each
   person's 9-target validation and correction
   (:mod:`eye_bci_ros2.gaze.validation`).  Goals: <= 12 px, <= 8 px corrected.
2. ``midway``: the gaze rests midway between two neighbouring options of a
   ``bench/decision.py`` layout (3, 4, 9 targets, sizes S 60..200 px, gap
   S/2) for the whole window (the person looks at neither: any choice is
   wrong), for the bench's consumer person (0.5 deg) and the 0.8 deg person.
   Goal: <= 0.5 % wrong for every rule offered as a default.
3. ``other_target``: ``bench/decision.py``'s stress scenario (the gaze rests on
   another option when the menu appears, then moves to the goal): wrong %.
4. ``main``: accuracy and median decision time from fixation onset in
   ``bench/decision.py``'s main scenario (the window end for window rules).
5. ``hit_rate``: of the samples after fixation onset in the main scenario,
   the fraction of inside samples and of near samples (outside, counted by
   the tolerance) that count for the option looked at.

Run: ``python -m bench.tolerance`` (about a minute; ``--quick``: seconds;
``--trials 200`` for the figures in the report, ~2 minutes).
"""

import argparse
import functools
import json
import math
import sys
import time
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from bench import decision
from eye_bci_ros2.decision.evidence import RoundEvidence
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings
from eye_bci_ros2.decision.tolerance import DEFAULT_RATIO, GazeErrorModel, TolerantRegions
from eye_bci_ros2.experiments import accuracy_test
from eye_bci_ros2.gaze.validation import (apply_correction, CorrectionRefused, fit_correction,
                                          IDENTITY, samples_per_target, target_layout)
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.sim.person import CONSUMER_TRACKER, GazeParams, GazeSimulator, ORIGINAL_TOBII_4C
from eye_bci_ros2.task.scene import load_scene

#: The gaze-error model of the tolerant rule (defaults: 0.8 deg, 0.3 deg, k = 2).
MODEL = GazeErrorModel()
#: Nearest / second-nearest distance ratio.
RATIO = DEFAULT_RATIO
#: Rules measured: name -> (window rule or 'early', tolerant, ratio, share).  ``share``: a
#: choice needs at least this fraction of the samples it weighed on its label (see
#: :func:`_decide`; 0 = no share test, the original).  ``/s``: the strict variant proposed for
#: the midway goal (ratio 0.2, share 0.5); ``size_``: the size-aware tolerance
#: (:func:`eye_bci_ros2.decision.tolerance.classify_tolerant` ``size_aware``), ratio 0.5.
RULES = {
    'mean': ('mean', False, RATIO, 0.0, False),
    'vote': ('vote', False, RATIO, 0.0, False),
    'early': ('early', False, RATIO, 0.0, False),
    'tol_mean': ('mean', True, RATIO, 0.0, False),
    'tol_vote': ('vote', True, RATIO, 0.0, False),
    'tol_early': ('early', True, RATIO, 0.0, False),
    'mean/s': ('mean', False, RATIO, 0.5, False),
    'early/s': ('early', False, RATIO, 0.5, False),
    'tol_mean/s': ('mean', True, 0.2, 0.5, False),
    'tol_early/s': ('early', True, 0.2, 0.5, False),
    'size_mean': ('mean', True, RATIO, 0.0, True),
    'size_early': ('early', True, RATIO, 0.0, True),
    'size_mean/s': ('mean', True, RATIO, 0.5, True),
    'size_vote/s': ('vote', True, RATIO, 0.5, True),
    'size_early/s': ('early', True, RATIO, 0.5, True),
}
#: Accuracy of a validated and corrected tracker for the error model, deg (the issue's
#: residual goal; gaze_validation measures 0.06-0.15 deg).
VALIDATED_ACCURACY_DEG = 0.2
#: The node's default rule (ArbiterSettings defaults) and the original.
DEFAULT_RULES = ('size_mean/s', 'mean')
#: The issue's goals.
GOAL_SMALLEST_PX = 12.0
GOAL_MIDWAY_WRONG = 0.005
#: Trials per cell (full, quick) for the midway and other_target scenarios.
TRIALS = 100
QUICK_TRIALS = 20
#: Trials of the binary search (the accuracy test's default K).
SEARCH_TRIALS = 20
MIDWAY_SEED = 3_000_000


def model_for(params: GazeParams) -> GazeErrorModel:
    """
    Return the gaze-error model a validation of this person would give.

    Accuracy = the person's offset, precision = the jitter per axis; k as :data:`MODEL`.
    """
    person = params.person
    return GazeErrorModel(accuracy_deg=person.offset_deg, precision_deg=person.jitter_deg,
                          k_sigma=MODEL.k_sigma)


def settings_for(rule: str, config: ArbiterSettings, params: GazeParams) -> ArbiterSettings:
    """
    Return the choice_arbiter settings of a rule of :data:`RULES` for one simulated person.

    ``config``'s early decision and window (``bench/decision.py``'s
    ``COUNT_EARLY``); the rule's method, classification, ratio, size awareness
    and share test; the gaze-error model :func:`model_for` the person, on the
    person's screen.
    """
    base, tolerant, ratio, share, size_aware = RULES[rule]
    model, screen = model_for(params), params.person.screen
    return config.replace(
        method=config.method if base == 'early' else base, early_decision=base == 'early',
        classification='tolerant' if tolerant else 'inside', accuracy_deg=model.accuracy_deg,
        precision_deg=model.precision_deg, k_sigma=model.k_sigma, ratio=ratio,
        size_aware=size_aware, min_share=share, screen_width_mm=screen.width_mm,
        screen_height_mm=screen.height_mm, viewing_distance_mm=screen.distance_mm,
        screen_width=screen.width_px, screen_height=screen.height_px)


def _decide(rule: str, points, stamps, regions: RegionSet, config: ArbiterSettings,
            params: GazeParams) -> Optional[str]:
    """
    Label chosen by a rule of :data:`RULES` for one trial (window 0..config.window_s).

    The node's decision code with the rule's settings (:func:`settings_for`):
    the regions classified by the rule (``ArbiterSettings.regions``), the share
    test in :class:`eye_bci_ros2.decision.evidence.RoundEvidence` (``min_share``: a
    window-end choice needs that share of the window's valid samples, an
    early one ``evidence.EARLY_SHARE`` of the last ``EARLY_SHARE_S``); an
    early rule goes on to the window end when the early test never passes.
    """
    settings = settings_for(rule, config, params)
    keep = stamps < config.window_s
    evidence = settings.evidence(0.0)
    made = evidence.add(points[keep], stamps[keep], regions,
                        settings.confidence if settings.early_decision else None)
    return (made or evidence.decide(settings.method)).label


def _early(points, stamps, regions: RegionSet, config: ArbiterSettings,
           share_test: bool):
    """
    Run the node's early decision (``RoundEvidence.add(..., confidence)``), or None.

    :param regions: the classifier (a ``RegionSet`` or ``TolerantRegions``).
    :param share_test: with the early share test (any ``min_share`` > 0 turns it on).
    """
    evidence = RoundEvidence(0.0, hit_rate=config.hit_rate, min_samples=config.min_samples,
                             dwell_s=config.dwell_s, min_reaction_s=config.min_reaction_s,
                             min_share=0.5 if share_test else 0.0)
    return evidence.add(points, stamps, regions, config.confidence)


def smallest(rules: Sequence[str] = tuple(RULES), trials: int = SEARCH_TRIALS,
             params: GazeParams = ORIGINAL_TOBII_4C, seed: int = 0,
             corrected: bool = False) -> Dict[str, Dict]:
    """
    Smallest marker chosen right in every trial, per rule (px), by the accuracy test's search.

    The trials are :func:`eye_bci_ros2.experiments.accuracy_test.run_trials`'s (same
    persons, targets, start point and window; checked: ``mean`` gives the
    accuracy test's figure), decided by :func:`_decide`.

    :param corrected: each person first does a 9-target validation (same
        person: same simulator seed, 1.5 s per target), the correction
        :func:`eye_bci_ros2.gaze.validation.fit_correction` fits is applied to the
        trial's samples (as the bridge will), and the error model is that
        validation's measured accuracy and precision.
    """
    scenario = accuracy_test.RoomScenario(load_scene(default_scene_path()))
    settings = accuracy_test.TrialSettings(params=params)
    config = decision.COUNT_EARLY.replace(window_s=settings.window_s)
    data = []
    for trial in range(trials):
        target = trial % len(scenario.labels)
        simulator = GazeSimulator(params, seed=accuracy_test.trial_seed(seed, trial))
        trace = simulator.simulate(settings.window_s, [(0.0, scenario.targets[target])],
                                   initial_xy=scenario.start_xy)
        points = trace.xy[trace.valid]
        if corrected:
            points = apply_correction(points, _validated(params, trial_seed=accuracy_test
                                                         .trial_seed(seed, trial)))
        data.append((scenario.labels[target], trace.t[trace.valid], points))
    if corrected:
        # The residual error after correction is what the tolerance must cover.
        params = params.with_changes(offset_deg=CORRECTED_ACCURACY_DEG)
    out = {}
    for rule in rules:
        def predicate(size, rule=rule):
            regions = scenario.regions(size)
            return all(_decide(rule, points, stamps, regions, config, params)
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


#: Error model accuracy after validation and correction, degrees (the residual the
#: validation test measures is ~0.07 deg; 0.2 deg is the issue's bound).
CORRECTED_ACCURACY_DEG = 0.2


@functools.lru_cache(maxsize=4096)
def _validated(params: GazeParams, trial_seed: int) -> Tuple[float, ...]:
    """Validate one simulated person (9 targets, 1.5 s each) and return the fitted correction."""
    targets = target_layout(9, params.person.screen.width_px, params.person.screen.height_px)
    # 20 s before the trial (the drift moves on meanwhile).
    onsets = -20.0 - 1.5 * len(targets) + 1.5 * np.arange(len(targets))
    trace = GazeSimulator(params, seed=trial_seed).simulate(
        1.5 * len(targets), [(float(t), tuple(xy)) for t, xy in zip(onsets, targets)],
        start_s=float(onsets[0]))
    samples = samples_per_target(trace.t, trace.xy, onsets, onsets + 1.5)
    try:
        return tuple(fit_correction(targets, samples, screen=params.person.screen).values)
    except CorrectionRefused:   # a fit that would not help: the bridge keeps none
        return IDENTITY


def _midway_trials(count: int, size: float, seeds, params: GazeParams,
                   corrected: bool = False):
    """
    Trials resting midway between two horizontally neighbouring targets: (stamps, points).

    :param corrected: each person validated first and the fitted correction applied to
        the trial's gaze (what the bridge does after ``gaze_validation``).
    """
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
        points = trace.xy[trace.valid]
        if corrected:
            points = apply_correction(points, _validated(params, int(seed)))
        trials.append((trace.t[trace.valid], points))
    return trials


def midway(rules: Sequence[str] = tuple(RULES), trials: int = TRIALS,
           params: GazeParams = CONSUMER_TRACKER, counts=(3, 4, 9),
           sizes=decision.SIZES, corrected: bool = False) -> Dict[str, Dict]:
    """
    Wrong choices (any choice) with the gaze midway between two options, per rule and cell.

    :param corrected: validate each person and correct the gaze first; the rules then use
        the error model of a validated tracker (accuracy :data:`VALIDATED_ACCURACY_DEG`, as
        a user sets ``accuracy_deg`` after ``gaze_validation``).
    """
    config = decision.COUNT_EARLY
    rule_params = params.with_changes(offset_deg=VALIDATED_ACCURACY_DEG) if corrected \
        else params
    table: Dict[str, Dict] = {rule: {} for rule in rules}
    seeds = range(MIDWAY_SEED, MIDWAY_SEED + trials)
    for count in counts:
        for size in sizes:
            regions = decision.region_set(count, size)
            data = _midway_trials(count, size, seeds, params, corrected)
            for rule in rules:
                wrong = [_decide(rule, points, stamps, regions, config, rule_params) is not None
                         for stamps, points in data]
                table[rule][f'{count}x{size}'] = float(np.mean(wrong))
    for rule in rules:
        table[rule]['all'] = float(np.mean(list(table[rule].values())))
    return table


def other_target(rules: Sequence[str] = tuple(RULES), trials: int = TRIALS,
                 params: GazeParams = CONSUMER_TRACKER, counts=(3, 4, 9),
                 sizes=decision.SIZES) -> Dict[str, Dict]:
    """Accuracy and wrong fraction in bench/decision.py's stress scenario, per rule."""
    config = decision.COUNT_EARLY
    out: Dict[str, Dict] = {rule: {'wrong': 0, 'correct': 0, 'trials': 0} for rule in rules}
    seeds = range(decision.TEST_SEED, decision.TEST_SEED + trials)
    for count in counts:
        for size in sizes:
            regions = decision.region_set(count, size)
            data = decision.simulate_trials(count, size, seeds, 'other_target', params)
            for rule in rules:
                labels = [_decide(rule, t.points, t.stamps, regions, config, params)
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
            tolerant = TolerantRegions.of(regions, screen=screen,
                                          model=model_for(params))
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


def speed(rules: Sequence[str] = tuple(RULES), trials: int = TRIALS,
          params: GazeParams = CONSUMER_TRACKER, counts=(3, 4, 9),
          sizes=decision.SIZES) -> Dict[str, Dict[str, float]]:
    """
    Accuracy and median decision time from fixation onset (ms), bench/decision.py main scenario.

    The decision time is the deciding sample's stamp for an early decision,
    the window end otherwise (as ``bench/decision.py`` counts it).
    """
    config = decision.COUNT_EARLY
    seeds = range(decision.TEST_SEED, decision.TEST_SEED + trials)
    out: Dict[str, Dict[str, list]] = {rule: {'correct': [], 'ms': []} for rule in rules}
    for count in counts:
        for size in sizes:
            regions = decision.region_set(count, size)
            data = decision.simulate_trials(count, size, seeds, 'new_menu', params)
            for rule in rules:
                base, _, _, share, _ = RULES[rule]
                shown = settings_for(rule, config, params).regions(regions)
                for trial in data:
                    label = _decide(rule, trial.points, trial.stamps, regions, config, params)
                    out[rule]['correct'].append(label == str(trial.goal))
                    when = config.window_s
                    if base == 'early':
                        made = _early(trial.points, trial.stamps, shown, config, share > 0)
                        when = made.time_to_decision if made is not None else when
                    if math.isfinite(trial.onset):
                        out[rule]['ms'].append(1e3 * (when - trial.onset))
    return {rule: {'accuracy': float(np.mean(v['correct'])),
                   'median_ms': float(np.median(v['ms']))} for rule, v in out.items()}


def run(quick: bool = False, trials: Optional[int] = None) -> Dict:
    """Run every measurement (module doc); return the section."""
    started = time.perf_counter()
    trials = trials or (QUICK_TRIALS if quick else TRIALS)
    section = {
        'smallest_px': smallest(trials=5 if quick else SEARCH_TRIALS),
        'midway_wrong': {p.name: midway(trials=trials, params=p)
                         for p in (CONSUMER_TRACKER, ORIGINAL_TOBII_4C)},
        'other_target': other_target(trials=trials),
        'hit_rate': hit_rate(trials=max(trials // 4, 5)),
        'main': speed(trials=max(trials // 4, 5)),
        'smallest_px_corrected': smallest(trials=5 if quick else SEARCH_TRIALS,
                                          corrected=True),
        # The node's default and the original, after each person's validation + correction.
        'midway_wrong_corrected': midway(rules=DEFAULT_RULES, trials=trials,
                                         params=ORIGINAL_TOBII_4C, corrected=True),
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
             + f" {'other_target wrong%':>20} {'main acc%':>9} {'main ms':>7}"
             + f" {'corrected px':>12}"]
    for rule in RULES:
        px = section['smallest_px'][rule]['threshold_px']
        mids = ' '.join(f"{100 * table[rule]['all']:>25.2f}"
                        for table in section['midway_wrong'].values())
        main = section['main'][rule]
        lines.append(f'{rule:>12} {px:>11g} {mids} '
                     f"{100 * section['other_target'][rule]['wrong']:>20.2f} "
                     f"{100 * main['accuracy']:>9.1f} {main['median_ms']:>7.0f} "
                     f"{section['smallest_px_corrected'][rule]['threshold_px']:>12g}")
    lines.append('')
    for name, table in section['midway_wrong'].items():
        cells = [cell for cell in table[next(iter(RULES))] if cell != 'all']
        lines.append(f'midway wrong % per cell ({name}):')
        lines.append(f"{'rule':>12} " + ' '.join(f'{cell:>7}' for cell in cells))
        for rule in RULES:
            lines.append(f'{rule:>12} ' + ' '.join(f'{100 * table[rule][cell]:>7.1f}'
                                                   for cell in cells))
    corrected = section.get('midway_wrong_corrected')
    if corrected:
        cells = [cell for cell in corrected[next(iter(corrected))] if cell != 'all']
        lines.append(f'midway wrong % per cell ({ORIGINAL_TOBII_4C.name}, after validation + '
                     'correction):')
        lines.append(f"{'rule':>12} " + ' '.join(f'{cell:>7}' for cell in cells))
        for rule, table in corrected.items():
            lines.append(f'{rule:>12} ' + ' '.join(f'{100 * table[cell]:>7.1f}'
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
    parser.add_argument('--trials', type=int, default=None,
                        help=f'trials per cell (default {TRIALS}, --quick {QUICK_TRIALS})')
    parser.add_argument('--json', metavar='PATH', help='also write the section as JSON')
    args = parser.parse_args(argv)
    section = run(quick=args.quick, trials=args.trials)
    print('\n'.join(format_lines(section)))
    if args.json:
        with open(args.json, 'w', encoding='utf-8') as output:
            json.dump(section, output, indent=2, default=lambda v: None if (
                isinstance(v, float) and math.isnan(v)) else v)
            output.write('\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
