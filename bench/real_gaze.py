"""
Selection on real recorded gaze: the node's own decision code on people's recordings.

Every target step of a recording (:mod:`eye_bci_ros2.recordings.gaze`: the
Tobii X2-60 "lookAtPoint" files, the ETDQualitizer 9-point files, or a lab's
CSV) becomes selection rounds, decided by
:func:`eye_bci_ros2.experiments.trials.decide_trial` with the node's settings
for the recording's screen (size, mm, viewing distance):

* **intent** rounds (schedules whose dot jumps): ``N`` square options of
  ``S`` px at a pitch of 1.5 S (3 in a row, or 3 x 3), one of them centred
  where the dot appears (a cell chosen at random among those that keep every
  option on the screen); the round starts at the dot's onset and lasts the
  rule's window (1 s).  Right, wrong, no choice, and the decision time after
  the onset.
* **Midas** rounds, where the person does *not* mean to choose (any choice is
  wrong): *resting near* (from :data:`SETTLED_S` after a dot's onset to the
  next step, the gaze resting on the dot, the nearest option's edge 0.25-2 deg
  from the dot),
  *resting away* (that edge 2-8 deg away), *sweep* (the round starts 0.3 s
  before the next step; an option midway on the saccade's path, both dots at
  least 2 deg from every option), *pursuit* (schedules whose dot glides: an
  option midway on the glide, from the glide's start to the dot's rest).

The rules compared: the node's default (the fixation rule with its early
decision, :mod:`eye_bci_ros2.decision.fixation`), the same at the window end only, the
previous default (tolerant sample counts with the share test and an early
decision on a 20 ms run) and the original report's rule.  ``--curve`` adds the
trade of the default rule: right against wrong as ``confidence`` changes.
``--simulated`` runs the same rounds on the simulated person recorded on each
recording's own schedule (:func:`eye_bci_ros2.sim.person.record_schedule`).

**What a new person can expect** (:func:`new_people`, always printed): the
figures above are measured on the people the default was chosen on (the
rule, and its ``confidence`` from the trade curve).  Each person of the jump
recordings is held out in turn: the rule (among :data:`RULES` and the default
at each :data:`CURVE` confidence) is chosen on the *other* people by the
selection goal (:data:`GOAL`: the most right choices at 9 x 100 px among the
rules within its limits on wrong choices and resting gaze), then measured on
the held-out person; the pooled rows are what a person the settings were not
chosen on can expect, and each person's own row, at the default, is the
spread between people.

Usage::

    python -m bench.real_gaze [--data DIR] [--sizes 16 32 64 100 200] [--options 3 9]
                              [--curve] [--simulated] [--seed 0]

``--data`` defaults to the development copy (:func:`eye_bci_ros2.recordings.find_data`);
any folder of files in those formats works.  Figures: docs/selection.md.
"""

import argparse
import math
import sys
from typing import Dict, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, COUNT_RULE
from eye_bci_ros2.experiments.trials import decide_trial, ORIGINAL
from eye_bci_ros2.projection.visual_angle import px_per_degree_at
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.gaze import find_recordings, GazeRecording, load_gaze

#: Option sizes, px, and option counts of the intent rounds.
SIZES = (16, 32, 64, 100, 200)
COUNTS = (3, 9)
#: Pitch of the options, in option sizes (a gap of S / 2, as bench/decision.py).
PITCH = 1.5
#: Grid of each option count: columns, rows.
GRIDS = {3: (3, 1), 9: (3, 3)}
#: Size of the options of the Midas rounds, px.
MIDAS_SIZE = 100
#: Midas "near": the nearest option edge this far from the resting gaze, degrees.
NEAR_DEG = (0.25, 2.0)
#: Midas "away": this far, degrees.
AWAY_DEG = (2.0, 8.0)
#: Resting rounds start this long after the dot's onset (the gaze has landed), s.
SETTLED_S = 0.6
#: Sweep rounds start this long before the next step, s.
SWEEP_LEAD_S = 0.3
#: The confidences of the trade curve.
CURVE = (0.8, 0.9, 0.95, 0.99, 0.999)

#: The selection goal (docs/selection.md) the held-out choice keeps: at most this wrong %
#: at 9 x 100 px, and at most this % of resting-near and resting-away rounds chosen.
GOAL = {'wrong %': 1.0, 'resting near': 5.0, 'resting away': 0.5}
#: The layouts of the held-out figures: (options, px).
HELD_OUT_LAYOUTS = ((9, 100), (9, 200))

#: The previous default rule (tolerant counts, share test, early decision on a 20 ms run).
COUNT_EARLY = ArbiterSettings(**dict(COUNT_RULE, early_decision=True))

#: Rule name -> settings (the screen is set per recording).
RULES: Dict[str, ArbiterSettings] = {
    'default': ArbiterSettings(),
    'default, window end': ArbiterSettings(early_decision=False),
    'previous default': COUNT_EARLY,
    'original': ORIGINAL,
}


def squares(centres: np.ndarray, size: float) -> np.ndarray:
    """Square outlines of side ``size`` around centres (R, 2): (R, 4, 2), px."""
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float) * size / 2
    return centres[:, None, :] + corners[None, :, :]


def _fits(centres: np.ndarray, size: float, recording: GazeRecording) -> bool:
    """Whether every option lies on the screen."""
    half = size / 2
    screen = recording.screen
    return bool(np.all(centres - half >= 0) and np.all(centres[:, 0] + half <= screen.width_px)
                and np.all(centres[:, 1] + half <= screen.height_px))


def grid_at(place: np.ndarray, count: int, size: float, cell: int) -> np.ndarray:
    """Centres (count, 2) of a grid of ``count`` options whose cell ``cell`` is at ``place``."""
    columns, rows = GRIDS[count]
    pitch = PITCH * size
    column, row = cell % columns, cell // columns
    x = (np.arange(columns) - column) * pitch
    y = (np.arange(rows) - row) * pitch
    return np.stack(np.meshgrid(x, y), axis=-1).reshape(-1, 2) + place


def layout_with(place: np.ndarray, count: int, size: float, recording: GazeRecording,
                rng: np.random.Generator) -> Optional[Tuple[np.ndarray, int]]:
    """Return a layout with one option centred on ``place`` at a random cell that fits, or None."""
    for cell in rng.permutation(count):
        centres = grid_at(place, count, size, int(cell))
        if _fits(centres, size, recording):
            return centres, int(cell)
    return None


def settings_for_recording(settings: ArbiterSettings, recording: GazeRecording
                           ) -> ArbiterSettings:
    """Return the rule on the recording's screen (px, mm, viewing distance)."""
    screen = recording.screen
    return settings.replace(screen_width=int(screen.width_px),
                            screen_height=int(screen.height_px),
                            screen_width_mm=float(screen.width_mm),
                            screen_height_mm=float(screen.height_mm),
                            viewing_distance_mm=float(screen.distance_mm))


def _decide(recording: GazeRecording, centres: np.ndarray, size: float, start: float,
            settings: ArbiterSettings) -> Tuple[Optional[int], float]:
    """Decide one round: the chosen option's index (None: no choice) and the time, s."""
    stamps, points = recording.between(start, start + settings.window_s)
    valid = np.isfinite(points).all(axis=1)
    regions = RegionSet([str(i) for i in range(len(centres))], squares(centres, size), start)
    outcome = decide_trial(points[valid], stamps[valid], regions, settings, start=start)
    chosen = None if outcome.label is None else int(outcome.label)
    return chosen, outcome.time_s - start


def intent_rounds(recording: GazeRecording, count: int, size: float,
                  seed: int = 0) -> Iterator[Tuple[float, np.ndarray, int]]:
    """Intent rounds of a jump schedule: (start s, option centres (N, 2), the goal's index)."""
    if not recording.targets.jumps:
        return
    rng = np.random.default_rng([seed, count, int(size)])
    targets = recording.targets
    for k in range(1, len(targets)):
        made = layout_with(targets.places[k], count, size, recording, rng)
        if made is not None:
            yield float(targets.onsets[k]), made[0], made[1]


def _ppd(recording: GazeRecording, place: np.ndarray) -> float:
    """Pixels per degree at a screen place of the recording."""
    return float(px_per_degree_at(np.asarray(place, dtype=float).reshape(1, 2),
                                  recording.screen)[0])


def _clear_of(points: Sequence[np.ndarray], centres: np.ndarray, size: float,
              recording: GazeRecording, degrees: float) -> bool:
    """Whether every point lies at least ``degrees`` from every option's edge."""
    for point in points:
        gap = np.maximum(np.abs(centres - point) - size / 2, 0.0)
        if np.min(np.hypot(*gap.T)) < degrees * _ppd(recording, point):
            return False
    return True


def midas_rounds(recording: GazeRecording, seed: int = 0
                 ) -> Iterator[Tuple[str, float, float, np.ndarray]]:
    """Midas rounds (module doc): (kind, start s, window s, option centres (9, 2))."""
    rng = np.random.default_rng([seed, 7])
    targets, size = recording.targets, MIDAS_SIZE
    sides = np.array([[1, 0], [-1, 0], [0, 1], [0, -1]], dtype=float)
    for k in range(1, len(targets) - 1):
        rest = targets.places[k]
        rest_start = float(targets.still[k]) + SETTLED_S
        rest_window = min(float(targets.onsets[k + 1]) - rest_start, 1.0)
        if recording.targets.jumps and rest_window >= 0.5:
            for kind, (low, high) in (('resting near', NEAR_DEG), ('resting away', AWAY_DEG)):
                for _ in range(8):
                    gap = rng.uniform(low, high) * _ppd(recording, rest)
                    side = sides[rng.integers(4)]
                    centres = grid_at(rest + side * (size / 2 + gap), 9, size,
                                      int(rng.integers(9)))
                    if _fits(centres, size, recording) and _clear_of(
                            [rest], centres, size, recording, low):
                        yield kind, float(targets.onsets[k + 1]) - rest_window, rest_window, \
                            centres
                        break
        start, goal = targets.places[k - 1], targets.places[k]
        kind = 'sweep' if targets.jumps else 'pursuit'
        for _ in range(8):
            centres = grid_at((start + goal) / 2, 9, size, int(rng.integers(9)))
            if _fits(centres, size, recording) and _clear_of(
                    [start, goal], centres, size, recording, 2.0):
                if targets.jumps:
                    yield kind, float(targets.onsets[k]) - SWEEP_LEAD_S, 1.0, centres
                else:
                    yield kind, float(targets.onsets[k]), float(
                        targets.still[k] - targets.onsets[k]), centres
                break


def _tally(outcomes: List[Tuple[str, float]]) -> Dict[str, float]:
    """Count right / wrong / none % and the median decision time of right choices, ms."""
    count = max(len(outcomes), 1)
    times = [t for kind, t in outcomes if kind == 'right']
    return {'rounds': len(outcomes),
            'right %': 100.0 * sum(k == 'right' for k, _ in outcomes) / count,
            'wrong %': 100.0 * sum(k == 'wrong' for k, _ in outcomes) / count,
            'none %': 100.0 * sum(k == 'none' for k, _ in outcomes) / count,
            'median ms': 1000.0 * float(np.median(times)) if times else math.nan}


def intent(recordings: Sequence[GazeRecording], settings: ArbiterSettings, count: int,
           size: float, seed: int = 0) -> Dict[str, float]:
    """Intent rounds of every recording under one rule (module doc)."""
    outcomes = []
    for recording in recordings:
        rule = settings_for_recording(settings, recording)
        for start, centres, goal in intent_rounds(recording, count, size, seed):
            chosen, elapsed = _decide(recording, centres, size, start, rule)
            kind = 'none' if chosen is None else ('right' if chosen == goal else 'wrong')
            outcomes.append((kind, elapsed))
    return _tally(outcomes)


def midas(recordings: Sequence[GazeRecording], settings: ArbiterSettings,
          seed: int = 0) -> Dict[str, Dict[str, float]]:
    """Midas rounds of every recording under one rule: kind -> rounds, chosen %."""
    chosen: Dict[str, List[bool]] = {}
    for recording in recordings:
        rule = settings_for_recording(settings, recording)
        for kind, start, window, centres in midas_rounds(recording, seed):
            made, _ = _decide(recording, centres, MIDAS_SIZE, start,
                              rule.replace(window_s=max(window, 0.05)))
            chosen.setdefault(kind, []).append(made is not None)
    return {kind: {'rounds': len(flags), 'chosen %': 100.0 * float(np.mean(flags))}
            for kind, flags in chosen.items()}


def candidates() -> Dict[str, ArbiterSettings]:
    """Return the rules a held-out choice picks from: :data:`RULES`, the default per confidence."""
    found = dict(RULES)
    for confidence in CURVE:
        if confidence != RULES['default'].confidence:
            found[f'default, confidence {confidence:g}'] = RULES['default'].replace(
                confidence=confidence)
    return found


def measure(recordings: Sequence[GazeRecording], settings: ArbiterSettings,
            seed: int = 0) -> Dict[str, Dict[str, float]]:
    """Intent tallies of :data:`HELD_OUT_LAYOUTS` and the resting Midas rounds, one rule."""
    found: Dict[str, Dict[str, float]] = {
        f'{count} x {size} px': intent(recordings, settings, count, size, seed)
        for count, size in HELD_OUT_LAYOUTS}
    found.update(midas(recordings, settings, seed))
    return found


def within_goal(measured: Dict[str, Dict[str, float]]) -> bool:
    """Whether a rule's figures keep :data:`GOAL` (9 x 100 px wrong, resting gaze chosen)."""
    return (measured['9 x 100 px']['wrong %'] <= GOAL['wrong %']
            and all(measured.get(kind, {'chosen %': 0.0})['chosen %'] <= GOAL[kind]
                    for kind in ('resting near', 'resting away')))


def choose_rule(measured: Dict[str, Dict[str, Dict[str, float]]]) -> str:
    """
    Return the rule the goal picks from ``{rule: measure(...)}``.

    The most right at 9 x 100 px among the rules within :data:`GOAL`; when none
    is, the fewest wrong.  Ties: the order of ``measured``.
    """
    allowed = [name for name, rows in measured.items() if within_goal(rows)]
    if allowed:
        return max(allowed, key=lambda name: measured[name]['9 x 100 px']['right %'])
    return min(measured, key=lambda name: measured[name]['9 x 100 px']['wrong %'])


def pool(rows: Sequence[Dict[str, float]]) -> Dict[str, float]:
    """Pool intent tallies of several people (shares weighted by their rounds)."""
    rounds = sum(row['rounds'] for row in rows)
    pooled: Dict[str, float] = {'rounds': rounds}
    for key in ('right %', 'wrong %', 'none %'):
        pooled[key] = sum(row[key] * row['rounds'] for row in rows) / max(rounds, 1)
    return pooled


def people(recordings: Sequence[GazeRecording]) -> List[GazeRecording]:
    """Return the recordings with intent rounds (jump schedules), one per person."""
    return [recording for recording in recordings if recording.targets.jumps]


def new_people(recordings: Sequence[GazeRecording], seed: int = 0) -> Dict:
    """
    Measure what a person the rule was not chosen on can expect: leave-one-person-out.

    :returns: ``{'people': {name: {'default': measure, 'chosen': rule, 'held out':
        measure}}, 'pooled': {layout: tally, kind: chosen %}, 'range': {layout:
        (lowest, highest) right % of the people at the default}}``; ``{}`` with fewer
        than two people.
    """
    persons = people(recordings)
    if len(persons) < 2:
        return {}
    rules = candidates()
    # Every rule on every person once: a held-out choice only reads the others' rows.
    measured = {person.name: {name: measure([person], settings, seed)
                              for name, settings in rules.items()} for person in persons}
    found: Dict = {'people': {}}
    for person in persons:
        others = [other for other in persons if other is not person]
        on_others = {name: _pooled_measure([measured[o.name][name] for o in others])
                     for name in rules}
        chosen = choose_rule(on_others)
        found['people'][person.name] = {'default': measured[person.name]['default'],
                                        'chosen': chosen,
                                        'held out': measured[person.name][chosen]}
    held = [entry['held out'] for entry in found['people'].values()]
    found['pooled'] = _pooled_measure(held)
    found['range'] = {layout: (min(e['default'][layout]['right %'] for e in
                                   found['people'].values()),
                               max(e['default'][layout]['right %'] for e in
                                   found['people'].values()))
                      for layout in held[0] if 'right %' in held[0][layout]}
    return found


def _pooled_measure(rows: Sequence[Dict[str, Dict[str, float]]]) -> Dict[str, Dict[str, float]]:
    """Pool :func:`measure` results of several people: intent tallies and Midas shares."""
    pooled: Dict[str, Dict[str, float]] = {}
    for key in rows[0]:
        if 'right %' in rows[0][key]:
            pooled[key] = pool([row[key] for row in rows])
        else:
            counted = [row[key] for row in rows if key in row]
            total = sum(entry['rounds'] for entry in counted)
            pooled[key] = {'rounds': total, 'chosen %': sum(
                entry['chosen %'] * entry['rounds'] for entry in counted) / max(total, 1)}
    return pooled


def load_folder(folder) -> List[GazeRecording]:
    """Every recording of a known format in ``folder``."""
    return [load_gaze(path) for path in find_recordings(folder)]


def simulated_twins(recordings: Sequence[GazeRecording], seed: int = 0
                    ) -> List[GazeRecording]:
    """Record the simulated person on each recording's schedule and screen."""
    from eye_bci_ros2.sim.person import record_schedule
    return [record_schedule(recording.targets, recording.screen, rate_hz=recording.rate_hz,
                            seed=seed + index, name=f'simulated {recording.name}')
            for index, recording in enumerate(recordings)]


def run(quick: bool = False, data=None, sizes: Sequence[int] = SIZES,
        counts: Sequence[int] = COUNTS, curve: bool = False, simulated: bool = False,
        seed: int = 0) -> Dict:
    """
    Run the benchmark (``make bench`` section ``real_gaze``).

    :returns: ``{'intent': {rule: {f'{N} x {S} px': tally}}, 'midas': {rule: ...},
        'curve': {...}, 'simulated': {...}}``; ``{'skipped': reason}`` without data.
    """
    folder = data if data is not None else find_data('real_gaze')
    if folder is None:
        return {'skipped': 'no real gaze recordings (../shared/data/real_gaze or --data DIR)'}
    recordings = load_folder(folder)
    if quick:
        sizes, counts = (100, 200), (9,)
    result: Dict = {'recordings': [f'{r.name} ({r.tracker}, {r.rate_hz:.0f} Hz, '
                                   f'{len(r.targets)} targets)' for r in recordings],
                    'intent': {}, 'midas': {}}
    for name, settings in RULES.items():
        result['intent'][name] = {
            f'{count} x {size} px': intent(recordings, settings, count, size, seed)
            for count in counts for size in sizes}
        result['midas'][name] = midas(recordings, settings, seed)
    if curve:
        base = RULES['default']
        result['curve'] = {f'confidence {c:g}': {
            f'{count} x {size} px': intent(recordings, base.replace(confidence=c), count, size,
                                           seed)
            for count in counts for size in sizes} for c in CURVE}
    result['new people'] = new_people(recordings, seed)
    if simulated:
        twins = simulated_twins([r for r in recordings if r.targets.jumps], seed)
        result['simulated'] = {
            f'{count} x {size} px': intent(twins, RULES['default'], count, size, seed)
            for count in counts for size in sizes}
        result['simulated midas'] = midas(twins, RULES['default'], seed)
    return result


def format_lines(section: Dict) -> List[str]:
    """Return the tables of a section, as printed."""
    if 'skipped' in section:
        return [f"skipped: {section['skipped']}"]
    lines = ['recordings: ' + '; '.join(section['recordings']), '',
             '| rule | layout | rounds | right % | wrong % | none % | median ms after onset |',
             '|---|---|---|---|---|---|---|']
    for rule, cells in section['intent'].items():
        for layout, t in cells.items():
            lines.append(f"| {rule} | {layout} | {t['rounds']} | {t['right %']:.1f} | "
                         f"{t['wrong %']:.1f} | {t['none %']:.1f} | {t['median ms']:.0f} |")
    kinds = sorted({kind for rows in section['midas'].values() for kind in rows})
    lines += ['', '| rule | ' + ' | '.join(f'{k}: chosen % (rounds)' for k in kinds) + ' |',
              '|---|' + '---|' * len(kinds)]
    for rule, rows in section['midas'].items():
        lines.append(f'| {rule} | ' + ' | '.join(
            f"{rows[k]['chosen %']:.1f} ({rows[k]['rounds']})" if k in rows else '-'
            for k in kinds) + ' |')
    if 'curve' in section:
        lines += ['', '| default rule, confidence | layout | right % | wrong % | none % |',
                  '|---|---|---|---|---|']
        for name, cells in section['curve'].items():
            for layout, t in cells.items():
                lines.append(f"| {name} | {layout} | {t['right %']:.1f} | {t['wrong %']:.1f} "
                             f"| {t['none %']:.1f} |")
    if section.get('new people'):
        lines += new_people_lines(section['new people'])
    if 'simulated' in section:
        lines += ['', '| simulated person, default rule | rounds | right % | wrong % | none % '
                  '| median ms |', '|---|---|---|---|---|---|']
        for layout, t in section['simulated'].items():
            lines.append(f"| {layout} | {t['rounds']} | {t['right %']:.1f} | "
                         f"{t['wrong %']:.1f} | {t['none %']:.1f} | {t['median ms']:.0f} |")
        lines.append('simulated Midas: ' + ', '.join(
            f"{k} {v['chosen %']:.1f} % of {v['rounds']}"
            for k, v in section['simulated midas'].items()))
    return lines


def _measure_cells(rows: Dict[str, Dict[str, float]]) -> str:
    cells = [f"{rows[layout]['right %']:.1f} / {rows[layout]['wrong %']:.1f}"
             for layout in (f'{count} x {size} px' for count, size in HELD_OUT_LAYOUTS)]
    cells += [f"{rows[kind]['chosen %']:.1f}" if kind in rows else '-'
              for kind in ('resting near', 'resting away')]
    return ' | '.join(cells)


def new_people_lines(found: Dict) -> List[str]:
    """Return the held-out table (:func:`new_people`): per person, and pooled."""
    layouts = [f'{count} x {size} px' for count, size in HELD_OUT_LAYOUTS]
    lines = ['', 'what a new person can expect: each person held out, the rule chosen on the '
             'others (leave-one-person-out)',
             '| person | rule | ' + ' | '.join(f'{layout}: right / wrong %' for layout in layouts)
             + ' | resting near: chosen % | resting away: chosen % |',
             '|---|---|' + '---|' * (len(layouts) + 2)]
    for name, entry in found['people'].items():
        lines.append(f'| {name} | default (chosen on this person too) | '
                     f"{_measure_cells(entry['default'])} |")
        lines.append(f"| {name}, held out | {entry['chosen']} (chosen on the others) | "
                     f"{_measure_cells(entry['held out'])} |")
    lines.append(f"| **pooled, held out** | | {_measure_cells(found['pooled'])} |")
    lines.append('right % at the default, lowest-highest person: ' + ', '.join(
        f'{layout} {low:.1f}-{high:.1f}' for layout, (low, high) in found['range'].items()))
    return lines


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Command line (module doc)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0].strip())
    parser.add_argument('--data', help='folder of recordings (default: the development copy)')
    parser.add_argument('--sizes', type=int, nargs='+', default=list(SIZES))
    parser.add_argument('--options', type=int, nargs='+', default=list(COUNTS),
                        choices=sorted(GRIDS))
    parser.add_argument('--curve', action='store_true', help='the confidence trade curve')
    parser.add_argument('--simulated', action='store_true',
                        help='the same rounds on the simulated person')
    parser.add_argument('--seed', type=int, default=0)
    args = parser.parse_args(argv)
    try:
        section = run(data=args.data, sizes=args.sizes, counts=args.options, curve=args.curve,
                      simulated=args.simulated, seed=args.seed)
    except (OSError, ValueError) as error:
        print(f'real_gaze: {error}', file=sys.stderr)
        return 1
    print('\n'.join(format_lines(section)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
