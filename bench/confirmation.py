"""
How often a wrong first choice still becomes a robot goal, with the menu's confirmation step.

On real recorded gaze (:mod:`bench.real_gaze`'s recordings and rules, the
node's default rule): a goal is sent only after 'go' in the confirmation
step, and a person who sees a wrong table chosen looks at 'back'.  So a
wrong goal needs two things: a wrong first choice (the 9 x 100 px intent
rounds of :func:`bench.real_gaze.intent`) and a confirmation round that picks
'go' while the person looks at 'back'.  The confirmation rounds are real
gaze rounds too: every jump of a recording's dot is one, 'back' (100 px)
centred where the dot appears, 'go' (100 px) beside it:

* **menu layout**: 'go' :data:`MENU_GAP_DEG` away horizontally (the menu
  puts 'go' 0.6 half-widths of the panel from the chosen table and 'back'
  there, :func:`eye_bci_ros2.task.menu.confirm_markers`: 384 px of the default
  1280 px panel, 9.4 deg on the default 24-inch screen at 65 cm);
* **adjacent** (a bound for any layout): 'go' at the benchmark's pitch of
  1.5 sizes, a 50 px gap.

A confirmation round without a choice is asked again (the menu asks until
answered), so the share of confirmation answers that are 'go' is
``go / (go + back)``; the wrong-goal rate per first choice is the wrong-first
rate times that.  With no 'go' in N rounds the upper 95 % bound is 3 / N
(the rule of three).  The rounds are independent of the first choice's
(a wrong first choice comes with the same tracker error at that place: the
figure assumes the confirmation does not share it, which the menu's layout
helps, 'go' being elsewhere on the screen).

**Midas goals** (``--midas``): robot goals per minute of a person who only
looks around, with no intent, through the menu's flow on the same real gaze
(:mod:`bench.midas`'s free looking, rounds back to back as the menu asks):
a tables step (3 tables + 'back', :data:`SIZE` px, placed as
:func:`bench.midas.layout` places options, clear of the dots); a table
chosen opens the confirmation step at once, 'back' on the table's place and
'go' :data:`MENU_GAP_DEG` beside it towards the screen's centre (the menu's
layout, :func:`eye_bci_ros2.task.menu.confirm_markers`; the other side if it
does not fit, else anywhere at least that far: 'go' must be clear of the dots
too, and the dense grids leave no room at the menu's places); 'back' there returns to the same
tables; 'go' is a goal, and a new room's tables follow (as does the tables
step's 'back': the rooms step between is left out, it only adds time without
goals, so the figure is an upper bound in that respect).  The drive's time
is not counted: minutes are minutes of menu.  Measured as the menu asks
until answered, and with its ``confirm_rounds`` (asked that many rounds
without an answer: back to the tables, no goal).  Its price: the intended
'go' rounds (every jump of a dot, 'go' 100 px on the dot, 'back' at the
menu's gap beside it, asked back to back until a choice, the next jump or
the last round): how many are still answered 'go'.

Usage::

    python -m bench.confirmation [--data DIR] [--seed 0]
    python -m bench.confirmation --midas [--layouts 5] [--confirm-rounds N [N ...]]
"""

import argparse
import sys
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np

from bench import midas
from bench.real_gaze import (_decide, _fits, _ppd, intent, load_folder, PITCH, RULES,
                             settings_for_recording)
from eye_bci_ros2.decision.rounds import ArbiterSettings
from eye_bci_ros2.experiments.trials import decide_trial
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING, px_per_degree_at
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.gaze import GazeRecording
from eye_bci_ros2.task.menu import GO_RIGHT, ProtocolSettings

#: Option size, px (the tables step's measured figure is at 100 px).
SIZE = 100
#: The menu's 'go' to 'back' distance on the default screen, degrees: GO_RIGHT half-widths
#: of the 1280 px panel, at the screen's centre.
MENU_GAP_DEG = float(GO_RIGHT * 640 / px_per_degree_at(
    np.array([[DEFAULT_VIEWING.width_px / 2, DEFAULT_VIEWING.height_px / 2]]),
    DEFAULT_VIEWING)[0])


def confirm_rounds(recording: GazeRecording, gap_px, rng: np.random.Generator):
    """Yield (start s, centres (2, 2): go, back) for each jump; 'back' on the dot."""
    targets = recording.targets
    if not targets.jumps:
        return
    for k in range(1, len(targets)):
        back = np.asarray(targets.places[k], dtype=float)
        gap = gap_px(recording, back)
        for side in rng.permutation([1.0, -1.0]):
            centres = np.array([back + [side * gap, 0.0], back])
            if _fits(centres, SIZE, recording):
                yield float(targets.onsets[k]), centres
                break


def confirmation(recordings: Sequence[GazeRecording], gap_px, seed: int = 0) -> Dict:
    """Count the confirmation rounds' outcomes under the default rule: go, back, none."""
    counts = {'rounds': 0, 'go': 0, 'back': 0, 'none': 0}
    rng = np.random.default_rng([seed, 31])
    for recording in recordings:
        rule = settings_for_recording(RULES['default'], recording)
        for start, centres in confirm_rounds(recording, gap_px, rng):
            chosen, _ = _decide(recording, centres, SIZE, start, rule)
            counts['rounds'] += 1
            counts[{None: 'none', 0: 'go', 1: 'back'}[chosen]] += 1
    return counts


LAYOUTS = {
    f'menu layout (go {MENU_GAP_DEG:.1f} deg away)':
        lambda recording, place: MENU_GAP_DEG * _ppd(recording, place),
    f'adjacent (go {PITCH * SIZE:.0f} px away)': lambda recording, place: PITCH * SIZE,
}


def run(data=None, seed: int = 0) -> Dict:
    """Return the first-choice tally and each layout's confirmation counts and rates."""
    folder = data if data is not None else find_data('real_gaze')
    if folder is None:
        return {'skipped': 'no real gaze recordings (../shared/data/real_gaze or --data DIR)'}
    recordings = load_folder(folder)
    first = intent(recordings, RULES['default'], 9, SIZE, seed)
    result = {'first': first, 'layouts': {}}
    wrong_first = first['wrong %'] / 100.0
    for name, gap in LAYOUTS.items():
        counts = confirmation(recordings, gap, seed)
        answered = counts['go'] + counts['back']
        go_share = counts['go'] / answered if answered else float('nan')
        bound = (counts['go'] if counts['go'] else 3.0) / max(answered, 1)
        result['layouts'][name] = dict(
            counts, go_share=go_share, go_share_bound=bound,
            wrong_goal=wrong_first * go_share, wrong_goal_bound=wrong_first * bound)
    return result


#: The tables step: 3 tables and 'back' (the last option).
TABLES = 3


def midas_confirm_layout(recording: GazeRecording, back: np.ndarray, rng: np.random.Generator,
                         clearance_deg: float = midas.CLEARANCE_DEG) -> Optional[np.ndarray]:
    """
    Return the confirmation step's centres (2, 2), (go, back), for a table at ``back``.

    'back' on the table's place, 'go' :data:`MENU_GAP_DEG` beside it towards the
    screen's centre, else on the other side, else anywhere at least that far from
    'back' on the screen; always clear of the dots; None if no place is (module doc).
    """
    back = np.asarray(back, dtype=float)
    gap = MENU_GAP_DEG * _ppd(recording, back)
    inwards = 1.0 if back[0] < recording.screen.width_px / 2 else -1.0
    screen = np.array([recording.screen.width_px, recording.screen.height_px], dtype=float)
    places = [back + [inwards * gap, 0.0], back - [inwards * gap, 0.0]] + list(
        rng.uniform(SIZE / 2, screen - SIZE / 2, (midas.TRIES, 2)))
    for go in places:
        centres = np.array([go, back])
        if (np.hypot(*(go - back)) >= gap - 1e-9 and _fits(centres, SIZE, recording)
                and midas._edge_distance(go, SIZE, recording.targets.places).min()
                >= clearance_deg * _ppd(recording, go)):
            return centres
    return None


def midas_goals(recording: GazeRecording, rule: ArbiterSettings, layouts: int = midas.LAYOUTS,
                seed: int = 0,
                tables: Optional[Callable[[], Optional[np.ndarray]]] = None,
                confirm: Optional[Callable[[np.ndarray], Optional[np.ndarray]]] = None,
                timeout_s: Optional[float] = None) -> Dict[str, float]:
    """
    Replay one recording as free looking through the menu's flow, once per layout (module doc).

    :param tables: draws a tables step's centres (TABLES + 1, 2), 'back' last (default:
        :func:`bench.midas.layout`, clear of the dots); :param confirm: the confirmation
        step's centres (go, back) for a chosen table's centre (default:
        :func:`midas_confirm_layout`).  Either returning None ends the layout's replay.
    :param timeout_s: a confirmation unanswered this long after it appeared returns to the
        tables, s (None: asked until answered; the menu's ``confirm_rounds`` N: N windows).
    :returns: ``{'minutes': of menu, 'rounds': asked, 'tables': chosen, 'back': the
        confirmation's 'back' chosen, 'goals': its 'go' chosen, 'layouts': replayed,
        'go after': per goal, s from the table's choice to the 'go', 'timeouts'}``.
    """
    rng = np.random.default_rng([seed, 33, len(recording.stamps)])
    if tables is None:
        def tables():
            return midas.layout(recording, TABLES + 1, SIZE, midas.CLEARANCE_DEG, rng)
    if confirm is None:
        def confirm(place):
            return midas_confirm_layout(recording, place, rng)
    stamps, points = midas._valid(recording)
    first, end = float(recording.stamps[0]), float(recording.stamps[-1])
    total = {'minutes': 0.0, 'rounds': 0, 'tables': 0, 'back': 0, 'goals': 0, 'layouts': 0,
             'go after': [], 'timeouts': 0}
    for _ in range(layouts):
        start = shown = first
        room = centres = tables()
        confirming = False
        if centres is None:
            continue
        total['layouts'] += 1
        while start + rule.window_s <= end:
            deadline = shown + timeout_s if confirming and timeout_s is not None else np.inf
            low, high = np.searchsorted(stamps, [start, min(start + rule.window_s, deadline)])
            outcome = decide_trial(points[low:high], stamps[low:high],
                                   midas._options(centres, SIZE, shown), rule, start=start,
                                   shown_since=shown)
            total['rounds'] += 1
            if outcome.label is None and start + rule.window_s >= deadline:
                total['timeouts'] += 1
                centres, confirming, start = room, False, deadline
                shown = start
                continue
            if outcome.label is None:
                start += rule.window_s
                continue
            # The next step's options appear, and are asked about, at the choice.
            asked, start = shown, outcome.time_s
            shown = start
            chosen = int(outcome.label)
            if not confirming and chosen < TABLES:
                total['tables'] += 1
                centres, confirming = confirm(room[chosen]), True
            elif confirming and chosen == 1:
                total['back'] += 1
                centres, confirming = room, False
            else:
                if confirming:
                    total['goals'] += 1
                    total['go after'].append(start - asked)
                room = centres = tables()
                confirming = False
            if centres is None:
                break
        total['minutes'] += (min(start, end) - first) / 60.0
    return total


def intended_go(recordings: Sequence[GazeRecording], rounds: Optional[int] = None,
                seed: int = 0) -> Dict:
    """Count the intended 'go' rounds' answers (module doc): go, back, none; 'go after' s."""
    counts: Dict = {'rounds': 0, 'go': 0, 'back': 0, 'none': 0, 'go after': []}
    rng = np.random.default_rng([seed, 31])
    gap = next(iter(LAYOUTS.values()))
    for recording in recordings:
        rule = settings_for_recording(RULES['default'], recording)
        stamps, points = midas._valid(recording)
        onsets = list(recording.targets.onsets) + [float(recording.stamps[-1])]
        for onset, centres in confirm_rounds(recording, gap, rng):
            options = midas._options(centres[::-1], SIZE, onset)     # 'go' on the dot
            end = onsets[onsets.index(onset) + 1]
            end = end if rounds is None else min(end, onset + rounds * rule.window_s)
            start, answer = onset, 'none'
            while start < end:
                low, high = np.searchsorted(stamps, [start, min(start + rule.window_s, end)])
                made = decide_trial(points[low:high], stamps[low:high], options, rule,
                                    start=start, shown_since=onset)
                if made.label is not None:
                    answer = 'go' if made.label == '0' else 'back'
                    counts['go after'] += [made.time_s - onset] if answer == 'go' else []
                    break
                start += rule.window_s
            counts['rounds'] += 1
            counts[answer] += 1
    return counts


def run_midas(data=None, layouts: int = midas.LAYOUTS, seed: int = 0,
              rounds: Sequence[Optional[int]] = (None, ProtocolSettings().confirm_rounds)
              ) -> Dict:
    """
    Return the Midas goals and the intended 'go' answers per ``confirm_rounds`` (module doc).

    :returns: ``{'midas': {rounds: {...}}, 'intended': {rounds: {...}}}`` (rounds None:
        asked until answered), or ``{'skipped': reason}`` without data.
    """
    recordings = midas.load_recordings(data)
    if recordings is None:
        return {'skipped': midas.NO_DATA}
    return {'midas': {count: _midas_total(recordings, layouts, seed, count) for count in rounds},
            'intended': {count: intended_go(recordings, count, seed) for count in rounds}}


def _midas_total(recordings: Sequence[GazeRecording], layouts: int, seed: int,
                 rounds: Optional[int]) -> Dict:
    """Sum :func:`midas_goals` over the recordings; the rates per minute of menu."""
    total = {'minutes': 0.0, 'rounds': 0, 'tables': 0, 'back': 0, 'goals': 0, 'layouts': 0,
             'go after': [], 'timeouts': 0}
    for recording in recordings:
        rule = settings_for_recording(RULES['default'], recording)
        timeout_s = None if rounds is None else rounds * rule.window_s
        for key, value in midas_goals(recording, rule, layouts, seed,
                                      timeout_s=timeout_s).items():
            total[key] += value
    minutes = max(total['minutes'], 1e-9)
    after = total['go after']
    return dict(total, goals_per_minute=total['goals'] / minutes,
                tables_per_minute=total['tables'] / minutes,
                median_go_s=float(np.median(after)) if after else float('nan'))


def _rounds_name(rounds: Optional[int]) -> str:
    return 'until answered' if rounds is None else f'confirm_rounds {rounds}'


def format_midas(result: Dict) -> List[str]:
    """Return the Midas goals' report, as printed."""
    if 'skipped' in result:
        return [f"skipped: {result['skipped']}"]
    lines = ['looking around without intent, through the menu (tables: 3 + back, '
             f'{SIZE} px; confirm: go/back, menu layout), default rule:',
             '| confirmation asked | layouts | minutes | tables chosen | then back | unanswered | '
             'then go (goals) | goals per minute | median s from table to go |',
             '|---|---|---|---|---|---|---|---|---|']
    for rounds, row in result['midas'].items():
        lines.append(f"| {_rounds_name(rounds)} | {row['layouts']} | {row['minutes']:.1f} | "
                     f"{row['tables']} | {row['back']} | {row['timeouts']} | {row['goals']} | "
                     f"{row['goals_per_minute']:.2f} | {row['median_go_s']:.1f} |")
    lines += ['', "intended 'go' (go on the dot, real gaze rounds, asked until a choice or the "
                  'next jump):', '| confirmation asked | rounds | go | back | none | go % | '
                  "slowest 'go', s |", '|---|---|---|---|---|---|---|']
    for rounds, row in result['intended'].items():
        slowest = max(row['go after']) if row['go after'] else float('nan')
        lines.append(f"| {_rounds_name(rounds)} | {row['rounds']} | {row['go']} | "
                     f"{row['back']} | {row['none']} | "
                     f"{100 * row['go'] / max(row['rounds'], 1):.1f} | {slowest:.2f} |")
    return lines


def format_lines(result: Dict) -> List[str]:
    """Return the report, as printed."""
    if 'skipped' in result:
        return [f"skipped: {result['skipped']}"]
    first = result['first']
    lines = [f"first choice, 9 x {SIZE} px, default rule: {first['rounds']} rounds, "
             f"{first['right %']:.1f} % right, {first['wrong %']:.1f} % wrong", '',
             "| confirmation ('back' looked at) | rounds | go | back | none | 'go' per answer "
             '| wrong goals per first choice |', '|---|---|---|---|---|---|---|']
    for name, row in result['layouts'].items():
        share = (f"{100 * row['go_share']:.2f} %" if row['go'] else
                 f"0 (< {100 * row['go_share_bound']:.2f} %, 95 %)")
        goal = (f"{100 * row['wrong_goal']:.4f} %" if row['go'] else
                f"0 (< {100 * row['wrong_goal_bound']:.4f} %, 95 %)")
        lines.append(f"| {name} | {row['rounds']} | {row['go']} | {row['back']} | "
                     f"{row['none']} | {share} | {goal} |")
    lines.append(f"without the confirmation step: {first['wrong %']:.1f} % of first choices "
                 'are wrong goals')
    return lines


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Command line (module doc)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0].strip())
    parser.add_argument('--data', help='folder of recordings (default: the development copy)')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--midas', action='store_true',
                        help='robot goals per minute of looking around without intent')
    parser.add_argument('--layouts', type=int, default=midas.LAYOUTS,
                        help='with --midas: replays per recording')
    parser.add_argument('--confirm-rounds', type=int, nargs='+',
                        help='with --midas: confirm_rounds values (0: asked until answered; '
                             "default: 0 and the menu's)")
    args = parser.parse_args(argv)
    try:
        if args.midas:
            rounds = (None, ProtocolSettings().confirm_rounds) if not args.confirm_rounds \
                else [n if n > 0 else None for n in args.confirm_rounds]
            lines = format_midas(run_midas(args.data, args.layouts, args.seed, rounds))
        else:
            lines = format_lines(run(data=args.data, seed=args.seed))
    except (OSError, ValueError) as error:
        print(f'confirmation: {error}', file=sys.stderr)
        return 1
    print('\n'.join(lines))
    return 0


if __name__ == '__main__':
    sys.exit(main())
