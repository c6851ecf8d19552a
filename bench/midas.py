"""
The Midas touch on real gaze: choices per minute for a person who only looks around.

The real recordings (:mod:`eye_bci_ros2.recordings.gaze`) are people looking
at dots that jump or glide over the screen: gaze that goes where the person
wants, but never to choose.  Here that gaze is replayed as *free looking*
over a menu whose options are elsewhere, and every choice is a Midas touch
(a look taken for a choice).

* **Layouts**: ``N`` square options of ``S`` px (``--options``, ``--sizes``)
  at random places on the screen whose edges lie at least ``--clearance``
  degrees from every place a dot of the recording stood still (the person
  never looked *at* an option on purpose: only the tracker's error, a
  saccade's landing or a glance brings the gaze there), options apart by
  half a size at least.  ``--layouts`` layouts per recording and size.
* **Rounds back to back, as the menu asks** (:mod:`eye_bci_ros2.task.menu`):
  the options appear at the recording's start and the question is asked at
  once; a round lasts the rule's window; a round without a choice is asked
  again at its end about the same options (shown since they appeared:
  ``shown_since``); after a choice the next options (another layout) appear
  and are asked about at once.  Each round is decided by the node's own code
  (:func:`eye_bci_ros2.experiments.trials.decide_trial`) on the recording's
  screen and viewing distance.
* **Figure**: choices per minute of replayed gaze, per option count and size,
  over every recording (two people of the Tobii X2-60 set and seven 9-point
  validations), for the node's default rule and the same at the window end.
* **The same rounds with intent** (the price of a change): every jump of a
  dot is a question whose options (as ``bench.real_gaze``'s intent rounds:
  3 x 3 of ``S`` px, one centred where the dot appears) appear at the dot's
  onset; asked back to back until a choice or the next jump.  Right, wrong,
  none, and the median time of a right choice after the onset.

Variants (for the comparison in docs/selection.md): ``--dwell S`` sets the
rule's ``dwell_s``; ``--new-question`` treats a question asked again as new
(``shown_since`` = the round start: a fixation under way when it is asked
is a resting gaze), where the node takes the options' time on the screen.

Usage::

    python -m bench.midas [--data DIR] [--sizes 100 200] [--options 4 9]
                          [--layouts 5] [--clearance 1.0] [--seed 0]
                          [--dwell S] [--new-question]

Right and wrong choices on the same recordings: ``python -m bench.real_gaze``.
Figures: docs/selection.md ("Looking around").
"""

import argparse
import sys
from typing import Dict, List, Optional, Sequence

import numpy as np

from bench.real_gaze import (_ppd, intent_rounds, load_folder, RULES,
                             settings_for_recording, squares)
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings
from eye_bci_ros2.experiments.trials import decide_trial
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.gaze_recording import GazeRecording

#: Option sizes, px, and counts (4: the menu's rooms; 9: a 3 x 3 menu's worth).
SIZES = (100, 200)
COUNTS = (4, 9)
#: Layouts per recording, size and count.
LAYOUTS = 5
#: Every option's edge at least this far from every place a dot stood, degrees: above the
#: median error of remote trackers (about 1 deg), so a fixation on a dot is not one on an
#: option, and small enough that options fit between the dots of a dense grid.
CLEARANCE_DEG = 1.0
#: Random places tried per option before a layout is given up.
TRIES = 400
#: The rules measured (the node's default, and the same deciding at the window end only).
MIDAS_RULES = ('default', 'default, window end')


def _edge_distance(centre: np.ndarray, size: float, places: np.ndarray) -> np.ndarray:
    """Distance from each place (K, 2) to a square option's edge (0 inside), px."""
    gap = np.maximum(np.abs(places - centre) - size / 2, 0.0)
    return np.hypot(gap[:, 0], gap[:, 1])


def layout(recording: GazeRecording, count: int, size: float, clearance_deg: float,
           rng: np.random.Generator) -> Optional[np.ndarray]:
    """
    Draw option centres (count, 2) px clear of every target place (module doc), or None.

    :param clearance_deg: least distance of an option's edge from a target place, deg.
    """
    screen = recording.screen
    places = recording.targets.places
    centres: List[np.ndarray] = []
    for _ in range(count):
        for _ in range(TRIES):
            centre = rng.uniform([size / 2, size / 2],
                                 [screen.width_px - size / 2, screen.height_px - size / 2])
            clear = clearance_deg * _ppd(recording, centre)
            if _edge_distance(centre, size, places).min() < clear:
                continue
            if centres and np.abs(np.array(centres) - centre).max(axis=1).min() < 1.5 * size:
                continue
            centres.append(centre)
            break
        else:
            return None
    return np.array(centres)


def _options(centres: np.ndarray, size: float, shown: float) -> RegionSet:
    """Return the options as the arbiter sees them, shown from ``shown`` s."""
    return RegionSet([str(i) for i in range(len(centres))], squares(centres, size), shown)


def _valid(recording: GazeRecording):
    """Return the valid samples: stamps (M,) s, points (M, 2) px."""
    valid = np.isfinite(recording.points).all(axis=1)
    return recording.stamps[valid], recording.points[valid]


def replay(recording: GazeRecording, rule: ArbiterSettings, count: int, size: float,
           layouts: int, clearance_deg: float, seed: int = 0,
           new_question: bool = False) -> Dict[str, float]:
    """
    Ask back to back over one recording, once per layout (module doc).

    :returns: ``{'minutes': replayed gaze, 'choices': made, 'rounds': asked,
        'layouts': drawn, 'beyond': [per choice: how far the deciding fixation lay
        outside the chosen option's edge, deg (0: inside)]}``.
    """
    rng = np.random.default_rng([seed, count, int(size), len(recording.stamps)])
    end = float(recording.stamps[-1])
    total = {'minutes': 0.0, 'choices': 0, 'rounds': 0, 'layouts': 0, 'beyond': []}
    stamps, points = _valid(recording)
    for _ in range(layouts):
        start = shown = float(recording.stamps[0])
        centres = layout(recording, count, size, clearance_deg, rng)
        if centres is None:
            continue
        total['layouts'] += 1
        while start + rule.window_s <= end:
            low, high = np.searchsorted(stamps, [start, start + rule.window_s])
            outcome = decide_trial(points[low:high], stamps[low:high],
                                   _options(centres, size, shown), rule, start=start,
                                   shown_since=start if new_question else shown)
            total['rounds'] += 1
            if outcome.label is None:
                start = start + rule.window_s
                continue
            total['choices'] += 1
            place = np.asarray(outcome.decision.mean_point, dtype=float)
            total['beyond'].append(float(_edge_distance(
                centres[int(outcome.label)], size, place.reshape(1, 2))[0])
                / _ppd(recording, place))
            # The next step's options appear, and are asked about, at the choice.
            start = shown = outcome.time_s
            centres = layout(recording, count, size, clearance_deg, rng)
            if centres is None:
                break
        total['minutes'] += (min(start, end) - float(recording.stamps[0])) / 60.0
    return total


def intent(recording: GazeRecording, rule: ArbiterSettings, size: float, seed: int = 0,
           new_question: bool = False) -> List[str]:
    """
    Ask back to back about each dot's options until a choice or the next jump (module doc).

    :returns: per jump: 'right', 'wrong' or 'none', and the time of a right choice after
        the onset, s (``'right 0.483'``).
    """
    stamps, points = _valid(recording)
    onsets = list(recording.targets.onsets) + [float(recording.stamps[-1])]
    outcomes = []
    for onset, centres, goal in intent_rounds(recording, 9, size, seed):
        end = onsets[onsets.index(onset) + 1]
        options, start, outcome = _options(centres, size, onset), onset, 'none'
        while start < end:
            low, high = np.searchsorted(stamps, [start, min(start + rule.window_s, end)])
            made = decide_trial(points[low:high], stamps[low:high], options, rule,
                                start=start, shown_since=start if new_question else onset)
            if made.label is not None:
                outcome = ('right' if int(made.label) == goal else 'wrong') + \
                    f' {made.time_s - onset:.3f}'
                break
            start += rule.window_s
        outcomes.append(outcome)
    return outcomes


def _intent_tally(outcomes: List[str]) -> Dict[str, float]:
    """Right / wrong / none % and the median time of a right choice, ms."""
    count = max(len(outcomes), 1)
    times = [float(o.split()[1]) for o in outcomes if o.startswith('right')]
    return {'rounds': len(outcomes),
            **{f'{kind} %': 100.0 * sum(o.startswith(kind) for o in outcomes) / count
               for kind in ('right', 'wrong', 'none')},
            'median ms': 1000.0 * float(np.median(times)) if times else float('nan')}


#: Why a run without a folder of recordings measures nothing.
NO_DATA = 'no real gaze recordings (../shared/data/real_gaze or --data DIR)'


def load_recordings(data=None) -> Optional[List[GazeRecording]]:
    """
    Return the gaze recordings in ``data`` (default: the development copy), None without one.

    :raises ValueError: a folder without a recording of a known format.
    """
    folder = data if data is not None else find_data('real_gaze')
    if folder is None:
        return None
    recordings = load_folder(folder)
    if not recordings:
        raise ValueError(f'no gaze recording of a known format in {folder}')
    return recordings


def run(data=None, sizes: Sequence[int] = SIZES, counts: Sequence[int] = COUNTS,
        layouts: int = LAYOUTS, clearance_deg: float = CLEARANCE_DEG, seed: int = 0,
        dwell_s: Optional[float] = None, new_question: bool = False) -> Dict:
    """
    Measure choices per minute, and the same rounds with intent (module doc).

    :returns: ``{'recordings': [...], 'midas': {rule: {f'{N} x {S} px': {...}}},
        'intent': {rule: {f'9 x {S} px': {...}}}}``, or ``{'skipped': reason}`` without
        data.
    """
    recordings = load_recordings(data)
    if recordings is None:
        return {'skipped': NO_DATA}
    result: Dict = {'recordings': [r.name for r in recordings], 'midas': {}, 'intent': {}}
    for name in MIDAS_RULES:
        base = RULES[name] if dwell_s is None else RULES[name].replace(dwell_s=dwell_s)
        cells = result['midas'][name] = {}
        for count in counts:
            for size in sizes:
                total = {'minutes': 0.0, 'choices': 0, 'rounds': 0, 'layouts': 0,
                         'beyond': []}
                for recording in recordings:
                    rule = settings_for_recording(base, recording)
                    for key, value in replay(recording, rule, count, size, layouts,
                                             clearance_deg, seed, new_question).items():
                        total[key] += value
                total['per minute'] = total['choices'] / max(total['minutes'], 1e-9)
                beyond = np.array(total.pop('beyond'))
                outside = beyond[beyond > 0]
                total['outside %'] = 100.0 * len(outside) / max(len(beyond), 1)
                total['median deg beyond'] = float(np.median(outside)) if len(outside) \
                    else float('nan')
                cells[f'{count} x {size} px'] = total
        result['intent'][name] = {
            f'9 x {size} px': _intent_tally(
                [outcome for recording in recordings if recording.targets.jumps
                 for outcome in intent(recording, settings_for_recording(base, recording),
                                       size, seed, new_question)])
            for size in sizes}
    return result


def format_lines(section: Dict) -> List[str]:
    """Return the table, as printed."""
    if 'skipped' in section:
        return [f"skipped: {section['skipped']}"]
    lines = [f"recordings: {', '.join(section['recordings'])}", '',
             '| rule | options | layouts | minutes | rounds | choices | choices per minute | '
             'outside the option % | median deg beyond its edge |',
             '|---|---|---|---|---|---|---|---|---|']
    for rule, cells in section['midas'].items():
        for name, t in cells.items():
            lines.append(f"| {rule} | {name} | {t['layouts']} | {t['minutes']:.1f} | "
                         f"{t['rounds']} | {t['choices']} | {t['per minute']:.2f} | "
                         f"{t['outside %']:.0f} | {t['median deg beyond']:.2f} |")
    lines += ['', '| rule, with intent (asked back to back) | options | jumps | right % | '
                  'wrong % | none % | median ms after onset |', '|---|---|---|---|---|---|---|']
    for rule, cells in section['intent'].items():
        for name, t in cells.items():
            lines.append(f"| {rule} | {name} | {t['rounds']} | {t['right %']:.1f} | "
                         f"{t['wrong %']:.1f} | {t['none %']:.1f} | {t['median ms']:.0f} |")
    return lines


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Command line (module doc)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0].strip())
    parser.add_argument('--data', help='folder of recordings (default: the development copy)')
    parser.add_argument('--sizes', type=int, nargs='+', default=list(SIZES))
    parser.add_argument('--options', type=int, nargs='+', default=list(COUNTS))
    parser.add_argument('--layouts', type=int, default=LAYOUTS)
    parser.add_argument('--clearance', type=float, default=CLEARANCE_DEG,
                        help='least distance of an option from a dot, degrees')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--dwell', type=float, help="the rule's dwell_s, s (a variant)")
    parser.add_argument('--new-question', action='store_true',
                        help='a question asked again is new: a gaze resting then must move '
                             '(a variant)')
    args = parser.parse_args(argv)
    try:
        section = run(data=args.data, sizes=args.sizes, counts=args.options,
                      layouts=args.layouts, clearance_deg=args.clearance, seed=args.seed,
                      dwell_s=args.dwell, new_question=args.new_question)
    except (OSError, ValueError) as error:
        print(f'midas: {error}', file=sys.stderr)
        return 1
    print('\n'.join(format_lines(section)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
