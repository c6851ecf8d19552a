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
looks around, with no intent, through the whole menu as the nodes run it,
with the menu's defaults, on the same real gaze (:mod:`bench.midas`'s free
looking: options at random places clear of the dots), from the rooms
(:func:`menu_replay`): the rooms (:data:`ROOMS`), the chosen room's tables
(:data:`TABLES` + 'back'), the confirmation ('back' on the table's place,
'go' :data:`MENU_GAP_DEG` beside it towards the screen's centre, the menu's
layout, :func:`eye_bci_ros2.task.menu.confirm_markers`; elsewhere when that
place is not clear of the dots), asked ``confirm_rounds`` rounds, then
'send' (:data:`SEND_GAP_DEG` above or below 'go', :func:`send_layout`) with
'back' on the place of 'go', asked ``send_rounds`` rounds; 'send' is a goal,
and the rooms again.  The confirm and send steps' options carry the menu's
labels (:data:`STEP_LABELS`), so the arbiter's second looks apply
(``second_look_dwell_s``; ``--second-look-dwell`` for the trade-off).  Rounds
are asked again as the nodes do (:func:`asked_again`); the camera's arrival
and the look-away gate are left out (an upper bound in that respect);
minutes are minutes of menu.  Each step's share is reported, and the steps
'go' / 'back' and 'send' are also measured at any moment of free looking
(:func:`step_trials`: thousands of trials that share no gaze), so that the
rate is a product of measured factors with a 95 % bound (each factor's
bound at 1 - 0.05 / k).  Its price: the intended 'go' (:func:`intended_go`:
'go' on a dot as it appears, then 'send' on the next dot), the share that
reaches 'send', the median and slowest time.  ``--json PATH`` writes
``{"midas": {"goals", "minutes", "goals_per_min", "upper95_per_min"},
"intended_go": {"rounds", "go", "rate", "median_s", "slowest_s"}}``.

Usage::

    python -m bench.confirmation [--data DIR] [--seed 0]
    python -m bench.confirmation --midas [--json PATH] [--layouts 20]
                                 [--confirm-rounds N] [--send-rounds N]
                                 [--second-look-dwell S]
"""

import argparse
from dataclasses import replace
import json
import math
import sys
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np
from scipy import stats

from bench import midas
from bench.real_gaze import (_decide, _fits, _ppd, intent, load_folder, PITCH, RULES,
                             settings_for_recording, squares)
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings
from eye_bci_ros2.experiments.trials import decide_trial
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING, px_per_degree_at
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.gaze import GazeRecording
from eye_bci_ros2.task.menu import (BACK_LABEL, GO_LABEL, GO_RIGHT, ProtocolSettings,
                                    SEND_DOWN, SEND_LABEL)

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


#: An intended 'go' must be sent within this from 'go' appearing, s (issue 38).
INTENDED_S = 1.5
#: The rooms step: 4 rooms (the default scene's), :data:`SIZE` px.
ROOMS = 4
#: 'send' to 'go' on the default screen, degrees: SEND_DOWN half-heights of the 720 px
#: panel, at the screen's centre.
SEND_GAP_DEG = float(SEND_DOWN * 360 / px_per_degree_at(
    np.array([[DEFAULT_VIEWING.width_px / 2, DEFAULT_VIEWING.height_px / 2]]),
    DEFAULT_VIEWING)[0])
#: One-sided confidence of the bound on goals per minute, split over its factors.
CONFIDENCE = 0.95
#: Replays per recording of ``--midas`` (each with its own layouts): 260 minutes of menu
#: and 15,600 'send' trials over the 13 minutes of real gaze (docs/selection.md).
MIDAS_REPLAYS = 20


def send_layout(recording: GazeRecording, go: np.ndarray, rng: np.random.Generator,
                clearance_deg: float = midas.CLEARANCE_DEG) -> Optional[np.ndarray]:
    """
    Return the 'send' step's centres (2, 2), ('send', 'back'), for 'go' at ``go``, or None.

    'send' :data:`SEND_GAP_DEG` above or below 'go' towards the screen's centre,
    else the other side, else anywhere at least that far from 'go'; clear of the
    dots; 'back' on 'go''s place (:func:`eye_bci_ros2.task.menu.send_markers`).
    """
    go = np.asarray(go, dtype=float)
    gap = SEND_GAP_DEG * _ppd(recording, go)
    inwards = 1.0 if go[1] < recording.screen.height_px / 2 else -1.0
    screen = np.array([recording.screen.width_px, recording.screen.height_px], dtype=float)
    places = [go + [0.0, inwards * gap], go - [0.0, inwards * gap]] + list(
        rng.uniform(SIZE / 2, screen - SIZE / 2, (midas.TRIES, 2)))
    for place in places:
        centres = np.array([place, go])
        if (np.hypot(*(place - go)) >= gap - 1e-9 and _fits(centres, SIZE, recording)
                and midas._edge_distance(place, SIZE, recording.targets.places).min()
                >= clearance_deg * _ppd(recording, place)):
            return centres
    return None


#: The steps of the menu as replayed, in order, and what passing each means.
STEPS = ('rooms', 'tables', 'confirm', 'send')
#: The labels of the steps whose options the arbiter's rule knows by name (its
#: second_look_labels): the first passes the step, the second is 'back'.
STEP_LABELS = {'confirm': (GO_LABEL, BACK_LABEL), 'send': (SEND_LABEL, BACK_LABEL)}


def step_options(step: str, centres: np.ndarray, shown: float) -> RegionSet:
    """Return a step's options as the arbiter sees them: the menu's labels, else indices."""
    if step not in STEP_LABELS:
        return midas._options(centres, SIZE, shown)
    return RegionSet(list(STEP_LABELS[step]), squares(centres, SIZE), shown)


def chosen_index(step: str, label: str) -> int:
    """Return the index of the option a step's label names (:func:`step_options`)."""
    return STEP_LABELS[step].index(label) if step in STEP_LABELS else int(label)


def asked_again(stamps: np.ndarray, start: float, window_s: float) -> float:
    """
    Return when the menu asks again after a round from ``start`` s ended without a choice.

    As the nodes do it: the arbiter ends a round at the first sample stamped at or after
    its window's end (``choice/none``), the menu asks again then, and the new round takes
    the samples that arrive after the question (not that one: it closed the last round).

    :param stamps: the valid samples' stamps (M,) s, ascending.
    """
    index = int(np.searchsorted(stamps, start + window_s))
    return float(stamps[index]) if index < len(stamps) else start + window_s


def _empty_tally() -> Dict:
    return {'minutes': 0.0, 'rounds': 0, 'layouts': 0, 'goals': 0, 'go after': [],
            'answers': [],
            **{f'{step} offered': 0 for step in STEPS},
            **{f'{step} passed': 0 for step in STEPS},
            'tables back': 0, 'confirm back': 0, 'confirm unanswered': 0,
            'send back': 0, 'send unanswered': 0}


def menu_replay(recording: GazeRecording, rule: ArbiterSettings, settings: ProtocolSettings,
                layouts: int = midas.LAYOUTS, seed: int = 0,
                places: Optional[Dict[str, Callable]] = None) -> Dict:
    """
    Replay one recording as free looking through the whole menu, once per layout (module doc).

    Rooms (asked until answered) -> the room's tables and 'back' (asked until
    answered; 'back' returns to the rooms) -> the confirmation 'go' / 'back'
    (``confirm_rounds`` rounds; 'back' or none: the tables) -> 'send'
    (``send_rounds`` rounds; none: the tables; 0: 'go' is the goal) -> a goal,
    and the rooms again.  Each step's options appear, and are asked about, at
    the choice that opens it; a round without a choice is asked again at its
    end (``shown_since``: when they appeared).

    :param places: where each step's options are (the default draws them clear of the
        dots, :func:`bench.midas.layout`, :func:`midas_confirm_layout`, :func:`send_layout`):
        'rooms' () -> (ROOMS, 2), 'tables' (room index) -> (TABLES + 1, 2) with 'back'
        last, 'confirm' (the table's centre) -> (2, 2) 'go', 'back', 'send' ('go''s centre)
        -> (2, 2) 'send', 'back'; None from any ends the layout's replay.
    :returns: the tally: minutes of menu, rounds, per step how often it was
        offered and passed (rooms: a room chosen; tables: a table; confirm:
        'go'; send: 'send'), 'back' and unanswered counts, goals, per goal
        the seconds from the table's choice, and 'answers': each step's
        outcome in order, (step, the option's index or None: unanswered, s).
    """
    rng = np.random.default_rng([seed, 35, len(recording.stamps)])
    stamps, points = midas._valid(recording)
    first, end = float(recording.stamps[0]), float(recording.stamps[-1])
    draw = {'rooms': lambda: midas.layout(recording, ROOMS, SIZE, midas.CLEARANCE_DEG, rng),
            'tables': lambda room: midas.layout(recording, TABLES + 1, SIZE,
                                                midas.CLEARANCE_DEG, rng),
            'confirm': lambda table: midas_confirm_layout(recording, table, rng),
            'send': lambda go: send_layout(recording, go, rng), **(places or {})}
    total = _empty_tally()
    limits = {'rooms': np.inf, 'tables': np.inf, 'confirm': settings.confirm_rounds,
              'send': settings.send_rounds}
    for _ in range(layouts):
        rooms = draw['rooms']()
        tables: Dict[int, Optional[np.ndarray]] = {}
        if rooms is None:
            continue
        total['layouts'] += 1
        start = shown = first
        step, centres, room, unanswered, table_at = 'rooms', rooms, 0, 0, first
        total['rooms offered'] += 1
        # New options start a round with the samples from their stamp on (the arbiter
        # takes the recent ones), a question asked again after it (asked_again).
        side = 'left'
        while start + rule.window_s <= end and centres is not None:
            low = np.searchsorted(stamps, start, side)
            high = np.searchsorted(stamps, start + rule.window_s)
            outcome = decide_trial(points[low:high], stamps[low:high],
                                   step_options(step, centres, shown), rule, start=start,
                                   shown_since=shown)
            total['rounds'] += 1
            if outcome.label is None:
                start, side = asked_again(stamps, start, rule.window_s), 'right'
                unanswered += 1
                if unanswered >= limits[step]:
                    total[f'{step} unanswered'] += 1
                    total['answers'].append((step, None, start))
                    step, centres, shown, unanswered = 'tables', tables[room], start, 0
                    total['tables offered'] += 1
                    side = 'left'
                continue
            chosen = chosen_index(step, outcome.label)
            start = shown = outcome.time_s
            side = 'left'
            unanswered = 0
            total['answers'].append((step, chosen, start))
            if step == 'rooms':
                total['rooms passed'] += 1
                room = chosen
                if room not in tables:
                    tables[room] = draw['tables'](room)
                step, centres = 'tables', tables[room]
            elif step == 'tables' and chosen == TABLES:
                total['tables back'] += 1
                step, centres = 'rooms', rooms
            elif step == 'tables':
                total['tables passed'] += 1
                table_at = start
                step, centres = 'confirm', draw['confirm'](tables[room][chosen])
            elif step in ('confirm', 'send') and chosen == 1:
                total[f'{step} back'] += 1
                step, centres = 'tables', tables[room]
            elif step == 'confirm' and settings.send_rounds:
                total['confirm passed'] += 1
                step, centres = 'send', draw['send'](centres[0])
            else:
                total[f'{step} passed'] += 1
                total['goals'] += 1
                total['go after'].append(start - table_at)
                step, centres = 'rooms', rooms
            total[f'{step} offered'] += 1
        total['minutes'] += (min(start, end) - first) / 60.0
    return total


def step_trials(recording: GazeRecording, rule: ArbiterSettings, step: str, rounds: int,
                layouts: int = midas.LAYOUTS, seed: int = 0) -> Dict[str, int]:
    """
    Measure a step's pass share at many moments of free looking (module doc): trials and passes.

    The step's options appear at moments ``rounds`` windows apart (trials that
    share no gaze), at places drawn anew for each, clear of the dots, and are
    asked ``rounds`` rounds: 'confirm' ('go' / 'back', 'back' at the drawn place,
    'go' as the menu puts it) passes on 'go'; 'send' ('back' at the drawn place, where
    'go' was, 'send' as the menu puts it) on 'send'.
    """
    rng = np.random.default_rng([seed, 37, len(recording.stamps), len(step)])
    stamps, points = midas._valid(recording)
    first, end = float(recording.stamps[0]), float(recording.stamps[-1])
    span = rounds * rule.window_s
    tally = {'trials': 0, 'passed': 0}
    for _ in range(layouts):
        for onset in np.arange(first, end - span, span):
            place = midas.layout(recording, 1, SIZE, midas.CLEARANCE_DEG, rng)
            if place is None:
                continue
            # 'send' with 'back' on the 'go' at the drawn place; 'go' / 'back' with 'back' there.
            centres = (send_layout if step == 'send' else midas_confirm_layout)(
                recording, place[0], rng)
            if centres is None:
                continue
            options, start, chosen = step_options(step, centres, onset), onset, None
            side = 'left'
            while start < onset + span - 1e-9 and chosen is None:
                low = np.searchsorted(stamps, start, side)
                high = np.searchsorted(stamps, start + rule.window_s)
                chosen = decide_trial(points[low:high], stamps[low:high], options, rule,
                                      start=start, shown_since=onset).label
                start, side = asked_again(stamps, start, rule.window_s), 'right'
            tally['trials'] += 1
            tally['passed'] += int(chosen == STEP_LABELS[step][0])
    return tally


def intended_go(recordings: Sequence[GazeRecording], settings: ProtocolSettings,
                seed: int = 0, base: Optional[ArbiterSettings] = None) -> Dict:
    """
    Count the intended 'go' on real gaze, through 'go' and 'send' (module doc).

    Every jump of a dot with a next one is a round: 'go' (100 px) on the dot,
    'back' at the menu's gap beside it, asked ``confirm_rounds`` rounds (and
    until the next jump); then, if 'go' was chosen, 'send' (100 px) on the
    next dot from its onset (a target that appears elsewhere, as 'send' does)
    and 'back' on this dot (where 'go' was), asked ``send_rounds`` rounds (and
    until the jump after); rounds whose next dot lies within :data:`PITCH`
    sizes of this one are left out (the menu never puts 'send' there).  The
    time is the sum of the two reactions, each from its target's onset.

    :returns: ``{'rounds', 'go' (both passed), 'back', 'none', 'go after': s per 'go',
        'people': {recording: (rounds, go, go within INTENDED_S)}}``.
    """
    counts: Dict = {'rounds': 0, 'go': 0, 'back': 0, 'none': 0, 'go after': [], 'people': {}}
    base = base or RULES['default']
    rng = np.random.default_rng([seed, 31])
    gap = next(iter(LAYOUTS.values()))
    for recording in recordings:
        rule = settings_for_recording(base, recording)
        stamps, points = midas._valid(recording)
        onsets = list(recording.targets.onsets) + [float(recording.stamps[-1])]
        places = recording.targets.places

        def ask(options: RegionSet, onset: float, end: float) -> Tuple[Optional[str], float]:
            start, side = onset, 'left'
            while start < end - 1e-9:
                low = np.searchsorted(stamps, start, side)
                high = np.searchsorted(stamps, min(start + rule.window_s, end))
                made = decide_trial(points[low:high], stamps[low:high], options, rule,
                                    start=start, shown_since=onset)
                if made.label is not None:
                    return made.label, made.time_s - onset
                start, side = asked_again(stamps, start, rule.window_s), 'right'
            return None, math.nan

        before = (counts['rounds'], counts['go'], len(counts['go after']))
        for onset, centres in confirm_rounds(recording, gap, rng):
            index = onsets.index(onset)
            if index + 2 >= len(onsets) or np.hypot(*(places[index + 1] - places[index])) \
                    < PITCH * SIZE:
                continue        # no next dot for 'send', or one too near for 'back' beside it
            counts['rounds'] += 1
            label, go_s = ask(step_options('confirm', centres[::-1], onset), onset,
                              min(onsets[index + 1], onset + settings.confirm_rounds
                                  * rule.window_s))
            if label != GO_LABEL:
                counts['back' if label == BACK_LABEL else 'none'] += 1
                continue
            if not settings.send_rounds:
                counts['go'] += 1
                counts['go after'].append(go_s)
                continue
            later = onsets[index + 1]
            # 'send' on the next dot, 'back' on this one (where 'go' was: send_markers).
            label, send_s = ask(step_options('send', np.array([places[index + 1],
                                                               places[index]]), later),
                                later, min(onsets[index + 2], later + settings.send_rounds
                                           * rule.window_s))
            if label == SEND_LABEL:
                counts['go'] += 1
                counts['go after'].append(go_s + send_s)
            else:
                counts['back' if label == BACK_LABEL else 'none'] += 1
        if counts['rounds'] > before[0]:
            counts['people'][recording.name] = (
                counts['rounds'] - before[0], counts['go'] - before[1],
                sum(1 for t in counts['go after'][before[2]:] if t <= INTENDED_S))
    return counts


def poisson_upper(count: int, exposure: float, confidence: float) -> float:
    """One-sided upper confidence bound of a Poisson rate: ``count`` events in ``exposure``."""
    return float(stats.chi2.ppf(confidence, 2 * count + 2) / 2.0 / max(exposure, 1e-12))


def binomial_upper(passed: int, trials: int, confidence: float) -> float:
    """One-sided upper Clopper-Pearson bound of a share: ``passed`` of ``trials``."""
    if trials <= 0 or passed >= trials:
        return 1.0
    return float(stats.beta.ppf(confidence, passed + 1, trials - passed))


def run_midas(data=None, layouts: int = MIDAS_REPLAYS, seed: int = 0,
              settings: Optional[ProtocolSettings] = None,
              base: Optional[ArbiterSettings] = None) -> Dict:
    """
    Goals per minute of looking around without intent, and the intended 'go' (module doc).

    :param settings: the menu's protocol (default: its defaults).
    :returns: ``{'settings', 'chain': the whole menu's tally (:func:`menu_replay`),
        'trials': {step: {'trials', 'passed'}}, 'factors': [(name, value, upper)],
        'midas': {goals, minutes, goals_per_min, upper95_per_min, product_per_min},
        'intended_go': {rounds, go, rate, median_s, slowest_s, back, none}}``, or
        ``{'skipped': reason}`` without data.
    """
    settings = settings or ProtocolSettings()
    base = base or RULES['default']
    recordings = midas.load_recordings(data)
    if recordings is None:
        return {'skipped': midas.NO_DATA}
    chain = _empty_tally()
    trials = {step: {'trials': 0, 'passed': 0} for step in ('confirm', 'send')}
    for recording in recordings:
        rule = settings_for_recording(base, recording)
        for key, value in menu_replay(recording, rule, settings, layouts, seed).items():
            chain[key] += value
        for step, rounds in (('confirm', settings.confirm_rounds),
                             ('send', settings.send_rounds)):
            if rounds:
                for key, value in step_trials(recording, rule, step, rounds, layouts,
                                              seed).items():
                    trials[step][key] += value
    minutes = max(chain['minutes'], 1e-9)
    # goals / min = confirmations opened / min x P('go' | confirmation) x P('send' | 'go'):
    # each factor bounded at 1 - (1 - CONFIDENCE) / k, so the product's bound holds at 95 %.
    factors = [('confirmations opened per minute', chain['confirm offered'] / minutes,
                chain['confirm offered'], minutes, 'rate'),
               ("'go' per confirmation (the menu's flow)", chain['confirm passed']
                / max(chain['confirm offered'], 1), chain['confirm passed'],
                chain['confirm offered'], 'share')]
    if settings.send_rounds:
        send = trials['send']
        factors.append(("'send' per 'go' (trials at any moment)",
                        send['passed'] / max(send['trials'], 1), send['passed'],
                        send['trials'], 'share'))
    level = 1.0 - (1.0 - CONFIDENCE) / len(factors)
    bounded = []
    product = upper = 1.0
    for name, value, count, exposure, kind in factors:
        high = (poisson_upper(count, exposure, level) if kind == 'rate'
                else binomial_upper(count, exposure, level))
        bounded.append({'factor': name, 'value': value, 'count': count,
                        'of': exposure, 'upper': high})
        product *= value
        upper *= high
    # The goals counted in the replay bound the rate on their own too; the smaller holds.
    direct = poisson_upper(chain['goals'], minutes, CONFIDENCE)
    intended = intended_go(recordings, settings, seed, base)
    after = intended['go after']
    return {
        'settings': {'confirm_rounds': settings.confirm_rounds,
                     'send_rounds': settings.send_rounds, 'dwell_s': base.dwell_s,
                     'second_look_dwell_s': base.second_look_dwell_s},
        'recordings': [r.name for r in recordings], 'chain': chain, 'trials': trials,
        'factors': bounded,
        'midas': {'goals': chain['goals'], 'minutes': chain['minutes'],
                  'goals_per_min': chain['goals'] / minutes,
                  'upper95_per_min': min(upper, direct), 'product_per_min': product,
                  'direct_upper95_per_min': direct, 'product_upper95_per_min': upper},
        'intended_go': {'rounds': intended['rounds'], 'go': intended['go'],
                        'rate': intended['go'] / max(intended['rounds'], 1),
                        'median_s': float(np.median(after)) if after else math.nan,
                        'slowest_s': float(max(after)) if after else math.nan,
                        'back': intended['back'], 'none': intended['none'],
                        'within_1_5_s': sum(1 for t in after if t <= INTENDED_S),
                        'people': intended['people']},
    }


def format_midas(result: Dict) -> List[str]:
    """Return the Midas goals' report, as printed."""
    if 'skipped' in result:
        return [f"skipped: {result['skipped']}"]
    chain, m, go = result['chain'], result['midas'], result['intended_go']
    conf = result['settings']
    lines = [f'looking around without intent, through the whole menu (rooms {ROOMS}, tables '
             f'{TABLES} + back, go/back, send; {SIZE} px, clear of the dots), default rule, '
             f"confirm_rounds {conf['confirm_rounds']}, send_rounds {conf['send_rounds']}, "
             f"dwell_s {conf['dwell_s']:g}, second_look_dwell_s {conf['second_look_dwell_s']:g}:",
             f"{chain['layouts']} replays, {chain['minutes']:.1f} minutes of menu, "
             f"{chain['rounds']} rounds", '',
             '| step | offered | passed | share | then back | unanswered |',
             '|---|---|---|---|---|---|']
    for step in STEPS:
        offered, passed = chain[f'{step} offered'], chain[f'{step} passed']
        back = chain.get(f'{step} back', '')
        lines.append(f'| {step} | {offered} | {passed} | {passed / max(offered, 1):.3f} | '
                     f"{back} | {chain.get(f'{step} unanswered', '')} |")
    lines += ['', 'the same steps at any moment of free looking (trials sharing no gaze):',
              '| step | trials | passed | share |', '|---|---|---|---|']
    for step, row in result['trials'].items():
        if row['trials']:
            lines.append(f"| {step} | {row['trials']} | {row['passed']} | "
                         f"{row['passed'] / row['trials']:.4f} |")
    lines += ['', 'goals per minute as a product of measured factors (each bounded at '
                  f'{100 * (1 - (1 - CONFIDENCE) / len(result["factors"])):.1f} %, '
                  'the product at 95 %):', '| factor | measured | count | of | upper bound |',
              '|---|---|---|---|---|']
    for row in result['factors']:
        lines.append(f"| {row['factor']} | {row['value']:.4g} | {row['count']} | "
                     f"{row['of']:.4g} | {row['upper']:.4g} |")
    lines += ['', f"robot goals: {m['goals']} in {m['minutes']:.1f} minutes = "
                  f"{m['goals_per_min']:.4f} per minute; product of the factors "
                  f"{m['product_per_min']:.2g} per minute; upper 95 % bound "
                  f"{m['upper95_per_min']:.2g} per minute (product "
                  f"{m['product_upper95_per_min']:.2g}, goals counted "
                  f"{m['direct_upper95_per_min']:.2g}); one goal in "
                  f"{1 / max(m['upper95_per_min'], 1e-12) / 60:.1f} hours at the bound",
              "intended 'go' (real gaze: 'go' on a dot"
              f"{', send on the next' if conf['send_rounds'] else ''}): {go['go']} of "
              f"{go['rounds']} ({100 * go['rate']:.1f} %), {go['back']} back, {go['none']} none;"
              f" median {go['median_s']:.2f} s, slowest {go['slowest_s']:.2f} s from 'go' "
              f"appearing (both reactions), {go['within_1_5_s']} within 1.5 s",
              'per person (sent, within 1.5 s, of the rounds): ' + ', '.join(
                  f'{name} {done}, {quick} of {rounds}'
                  for name, (rounds, done, quick) in go['people'].items())]
    return lines


def midas_json(result: Dict) -> Dict:
    """Return the ``--json`` summary (module doc)."""
    keys = {'midas': ('goals', 'minutes', 'goals_per_min', 'upper95_per_min'),
            'intended_go': ('rounds', 'go', 'rate', 'median_s', 'slowest_s')}
    return {section: {key: result[section][key] for key in names}
            for section, names in keys.items()}


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
    parser.add_argument('--layouts', type=int, default=MIDAS_REPLAYS,
                        help='with --midas: replays per recording, each with its own layouts')
    parser.add_argument('--confirm-rounds', type=int,
                        help="with --midas: the menu's confirm_rounds (default: its default)")
    parser.add_argument('--send-rounds', type=int,
                        help="with --midas: the menu's send_rounds (0: no 'send'; default: "
                             'its default)')
    parser.add_argument('--second-look-dwell', type=float,
                        help="with --midas: the arbiter's second_look_dwell_s (default: its "
                             'default)')
    parser.add_argument('--json', help='with --midas: write the summary here')
    args = parser.parse_args(argv)
    try:
        if args.midas:
            changed = {name: value for name, value in (
                ('confirm_rounds', args.confirm_rounds), ('send_rounds', args.send_rounds))
                if value is not None}
            base = RULES['default'] if args.second_look_dwell is None else \
                RULES['default'].replace(second_look_dwell_s=args.second_look_dwell)
            result = run_midas(args.data, args.layouts, args.seed,
                               replace(ProtocolSettings(), **changed), base)
            lines = format_midas(result)
            if args.json and 'skipped' not in result:
                with open(args.json, 'w', encoding='utf-8') as out:
                    json.dump(midas_json(result), out, indent=1)
        else:
            lines = format_lines(run(data=args.data, seed=args.seed))
    except (OSError, ValueError) as error:
        print(f'confirmation: {error}', file=sys.stderr)
        return 1
    print('\n'.join(lines))
    return 0


if __name__ == '__main__':
    sys.exit(main())
