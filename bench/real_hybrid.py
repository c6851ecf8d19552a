"""
Gaze and SSVEP together on real recordings: the hybrid beside gaze alone and SSVEP alone.

Each real EEG trial (:mod:`eye_bci_ros2.recordings.eeg`, e.g. Kalunga et al.
2016: LEDs at 13 / 17 / 21 Hz and rest trials, 5 s from an audio cue) is
paired with a real gaze round (:mod:`eye_bci_ros2.recordings.gaze`, the jump
schedules: a dot appears at a target and the person looks at it), aligned at
the cue: the gaze round's target onset is the EEG trial's cue.  The options
are as many as the EEG's stimuli, squares of :data:`OPTION_PX` px in a row at
a pitch of 1.5 sizes (:data:`bench.real_gaze.PITCH`), one of them centred on
the gaze round's target (a cell that keeps the row on the screen, drawn at
random); the gaze recording's screen is the person's screen.

* **Intent rounds**: each stimulus trial; the gazed option is the one whose
  stimulus the trial attends.
* **No-intent rounds** (Midas): each rest trial once per option, the gaze
  resting on that option (the person looks at it with no intent: in the rest
  trials the person looked at a fixation point, so the EEG carries no
  stimulus; see the caveat in docs/ssvep.md).

Each round goes through the code the nodes run, with their default settings:
the gaze through :class:`~eye_bci_ros2.decision.rounds.RoundScheduler` (the
choice_arbiter's rounds; one batch per sample, arriving at its stamp), the EEG
through :class:`~eye_bci_ros2.ssvep.online.OnlineDecoder` (the
ssvep_decoder's, ``keep_scoring`` as the hybrid mode needs; 0.1 s steps, as
``bench.ssvep_real`` streams it), and both through
:class:`~eye_bci_ros2.decision.fusion.ChoiceFusion` in the input mode
compared (``gaze``, ``ssvep``, ``hybrid``), fed in time order as the
choice_arbiter feeds it (:func:`fuse`).  ``test/nodes/test_choice_arbiter_hybrid_replay``
replays a round through the node and checks it decides the same.

Reported per EEG subject and overall, for each mode: right / wrong / no choice
among the intent rounds (shares), choices among the no-intent rounds (Midas
share), the median time from the cue to a choice in the intent rounds, and the
Wolpaw ITR (N = the options, P = the right share of the intent rounds, per
the mean round time: the time to the choice, :data:`ROUND_S` for none, plus
:data:`~eye_bci_ros2.experiments.metrics.GAZE_SHIFT_S`).  Nothing is fitted:
every setting is the nodes' default.  The **bound**: the hybrid under every
(``confirm_threshold``, ``hold_s``) of :data:`BOUND_GRID`, and the most right
choices any of them makes within the goal's limits (chosen with hindsight on
these rounds: a bound, not a result).

**What a new subject can expect** (:func:`held_out_subjects`): the hybrid's
``confirm_threshold`` and ``hold_s`` were set with these subjects in view, so
each EEG subject is held out in turn, the setting chosen on the *other*
subjects (the most right choices among the :data:`BOUND_GRID` settings within
the goal's limits) and the held-out subject decided with it; the pooled rows
are the leave-subject-out figures.  The spread: each subject's rows, and each
gaze person's (the gaze recordings the rounds came from).

Usage::

    python -m bench.real_hybrid [--gaze-data DIR] [--eeg-data DIR] [--subjects s01,s02]
                                [--quick] [--json PATH]

Defaults: the development copies (:func:`eye_bci_ros2.recordings.find_data`,
``$EYE_BCI_REAL_EEG``).  Figures: docs/ssvep.md, "Gaze and SSVEP together".
"""

import argparse
from dataclasses import dataclass
import itertools
import math
from pathlib import Path
import sys
import time
from typing import Dict, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from bench.real_gaze import load_folder, PITCH, settings_for_recording, squares
from bench.ssvep_real import _online, ROUND_S
from bench.timing import report
from eye_bci_ros2.decision.evidence import Decision
from eye_bci_ros2.decision.fusion import ChoiceFusion, FusionSettings, INPUT_MODES
from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.decision.rounds import ArbiterSettings, RoundScheduler
from eye_bci_ros2.experiments.metrics import GAZE_SHIFT_S, wolpaw_bits
from eye_bci_ros2.projection.visual_angle import ScreenGeometry
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.eeg import (by_subject, eeg_data_dir, EegRecording,
                                         find_eeg_recordings, load_eeg)
from eye_bci_ros2.recordings.gaze import find_recordings
from eye_bci_ros2.recordings.gaze_recording import GazeRecording
from eye_bci_ros2.ssvep.online import OnlineSettings

#: Side of the square options, px.
OPTION_PX = 100
#: Gaze samples fed after the arbiter's window, s: the first one closes the round.
GAZE_TAIL_S = 0.2
#: The goal: hybrid choices in no-intent rounds, wrong and right choices in intent rounds.
GOAL_MIDAS = 0.01
GOAL_WRONG = 0.005
GOAL_RIGHT = 0.80
#: (``confirm_threshold``, ``hold_s``) of the hybrid the bound is sought over.
BOUND_GRID = tuple(itertools.product((0.5, 0.7, 0.8, 0.9, 0.95, 0.99, 0.999),
                                     (0.0, 0.3, 0.5, 0.7, 1.0, 1.5)))
#: The first subjects of the quick run.
QUICK_SUBJECTS = 2


@dataclass(frozen=True)
class GazeLook:
    """A real gaze round: a person's gaze from a target's onset, on that target's place."""

    recording: GazeRecording
    onset: float
    place: np.ndarray


@dataclass(frozen=True)
class Pairing:
    """
    One EEG trial with one gaze round, on the EEG clock (s).

    :param subject: the EEG subject.
    :param cue: the trial's cue, s; the gaze round's target onset is moved here.
    :param labels: the options (the stimuli), (K,).
    :param attended: the label the trial attends, None in a rest trial.
    :param gazed: the label the gaze goes to (the attended one in an intent round).
    :param centres: the options' centres, (K, 2) screen px, in the order of ``labels``.
    :param recording: the gaze recording (its screen is the person's).
    :param stamps: the gaze samples' stamps, (N,) s, from the cue.
    :param points: the gaze samples, (N, 2) screen px, NaN where lost.
    :param steps: the decoder's scoring steps: (time s, labels, posterior (K,)).
    :param ssvep_choice: the decoder's choice and its time, s, or None.
    :param look: where the gaze comes from (recording name and target onset).
    """

    subject: str
    cue: float
    labels: Tuple[str, ...]
    attended: Optional[str]
    gazed: str
    centres: np.ndarray
    recording: GazeRecording
    stamps: np.ndarray
    points: np.ndarray
    steps: Tuple[Tuple[float, Tuple[str, ...], Tuple[float, ...]], ...]
    ssvep_choice: Optional[Tuple[str, float]]
    look: str

    @property
    def intent(self) -> bool:
        """Whether the person means to choose (a stimulus trial)."""
        return self.attended is not None

    @property
    def regions(self) -> RegionSet:
        """Return the options as the choice_arbiter receives them (``choices/regions``)."""
        return RegionSet(list(self.labels), squares(self.centres, OPTION_PX), self.cue)


def gaze_looks(recordings: Sequence[GazeRecording]) -> List[GazeLook]:
    """
    Every target step of the jump schedules whose window of gaze was recorded.

    The first target of a recording is left out (no step leads to it), as in
    :func:`bench.real_gaze.intent_rounds`; glide schedules too (no onset the
    gaze jumps at).
    """
    window = ArbiterSettings().window_s + GAZE_TAIL_S
    looks = []
    for recording in recordings:
        targets = recording.targets
        if not targets.jumps:
            continue
        for k in range(1, len(targets)):
            onset = float(targets.onsets[k])
            if onset + window <= float(recording.stamps[-1]):
                looks.append(GazeLook(recording, onset, np.asarray(targets.places[k], float)))
    return looks


def row_layout(place: np.ndarray, count: int, screen: ScreenGeometry,
               rng: np.random.Generator) -> Optional[Tuple[np.ndarray, int]]:
    """
    Place ``count`` options in a row, one of them centred on ``place``.

    :returns: the centres (count, 2) px and the cell on ``place``, drawn at
        random among the cells that keep the row on the screen; None if none does.
    """
    half, pitch = OPTION_PX / 2, PITCH * OPTION_PX
    for cell in rng.permutation(count):
        centres = place + np.stack([(np.arange(count) - cell) * pitch, np.zeros(count)], axis=1)
        if (np.all(centres - half >= 0) and np.all(centres[:, 0] + half <= screen.width_px)
                and np.all(centres[:, 1] + half <= screen.height_px)):
            return centres, int(cell)
    return None


def _labels(recording: EegRecording) -> Tuple[str, ...]:
    return tuple(f'{hz:g} Hz' for hz in recording.frequencies)


def pair(subject: str, trials: Sequence[Dict], labels: Tuple[str, ...],
         looks: Iterator[GazeLook], rng: np.random.Generator) -> List[Pairing]:
    """
    Pair a session's decoded trials with gaze rounds (module doc).

    :param trials: the rounds of :func:`bench.ssvep_real._online` (keep_scoring).
    :param looks: gaze rounds to take in turn (a cycle: they are reused when the
        EEG has more rounds than the gaze recordings).
    """
    pairings = []
    for trial in trials:
        gazed_labels = labels if trial['target'] is None else (trial['target'],)
        for gazed in gazed_labels:
            while True:
                look = next(looks)
                made = row_layout(look.place, len(labels), look.recording.screen, rng)
                if made is not None:
                    break
            centres, cell = made
            # The gazed label at the cell on the target, the others in order around it.
            order = [label for label in labels if label != gazed]
            order.insert(cell, gazed)
            by_label = {label: centres[i] for i, label in enumerate(order)}
            end = look.onset + ArbiterSettings().window_s + GAZE_TAIL_S
            stamps, points = look.recording.between(look.onset, end)
            choice = None if trial['choice'] is None else (trial['choice'],
                                                           trial['cue'] + trial['after_s'])
            pairings.append(Pairing(
                subject, float(trial['cue']), labels, trial['target'], gazed,
                np.array([by_label[label] for label in labels]), look.recording,
                stamps - look.onset + trial['cue'], np.array(points),
                tuple((t, tuple(step_labels), tuple(posterior))
                      for t, step_labels, posterior, *_ in trial['steps']),
                choice, f'{look.recording.name} @ {look.onset:.2f} s'))
    return pairings


def arbiter_settings(pairing: Pairing) -> ArbiterSettings:
    """Return the choice_arbiter's default settings on the gaze recording's screen."""
    return settings_for_recording(ArbiterSettings(), pairing.recording)


def gaze_decision(pairing: Pairing, settings: Optional[ArbiterSettings] = None
                  ) -> Tuple[Optional[Decision], float]:
    """
    Decide the round's gaze as the choice_arbiter does.

    The regions arrive at the cue (stamped there), then every gaze sample as
    its own batch at its stamp (``now`` = the stamp: a bridge with no latency),
    the round's ticks at each arrival.

    :returns: the decision and when it was made (``now``), s; (None, nan) if
        the round made none (the recording ended).
    """
    settings = settings or arbiter_settings(pairing)
    made: List[Decision] = []
    rounds = RoundScheduler(settings, made.append)
    rounds.add_regions(pairing.regions, pairing.cue)
    for index, stamp in enumerate(pairing.stamps):
        rounds.add_samples(pairing.stamps[index:index + 1], pairing.points[index:index + 1],
                           float(stamp))
        rounds.tick(float(stamp))
        if made:
            return made[0], float(stamp)
    return None, math.nan


def fuse(pairing: Pairing, decision: Optional[Decision], decided_at: float,
         settings: FusionSettings) -> Tuple[Optional[str], float]:
    """
    Turn the gaze decision and the decoder's output into the round's choice, as the arbiter.

    The fusion (:class:`~eye_bci_ros2.decision.fusion.ChoiceFusion`) takes the
    options at the cue, the gaze decision at ``decided_at`` and each scoring
    step (``ssvep/scores``) and the decoder's choice (``ssvep/choice``) at its
    time, in time order (the gaze first at equal times).

    :returns: the choice and its time, s from the cue; (None, nan) for none.
    """
    fusion = ChoiceFusion(settings)
    fusion.new_round(pairing.labels)
    events = [(t, 1, 'scores', (labels, posterior)) for t, labels, posterior in pairing.steps]
    if pairing.ssvep_choice is not None:
        events.append((pairing.ssvep_choice[1], 2, 'choice', pairing.ssvep_choice[0]))
    if decision is not None:
        events.append((decided_at, 0, 'gaze', decision))
    for t, _, kind, value in sorted(events, key=lambda e: (e[0], e[1])):
        if kind == 'gaze':
            got = fusion.gaze_outcome(value.label, t, value.margin, value.reason).choice
        elif kind == 'scores':
            got = fusion.ssvep_scores(value[0], value[1], t)
        else:
            got = fusion.ssvep_choice(value, t)
        if got is not None:
            return got, t - pairing.cue
    return None, math.nan


@dataclass(frozen=True)
class Decided:
    """What one mode chose in one round: the label (None: none) and when, s from the cue."""

    pairing: Pairing
    choice: Optional[str]
    after_s: float


def decide_all(pairings: Sequence[Pairing],
               fusions: Dict[str, FusionSettings]) -> Dict[str, List[Decided]]:
    """Decide every round in each input mode (name -> fusion settings); the gaze once per round."""
    decided: Dict[str, List[Decided]] = {name: [] for name in fusions}
    for pairing in pairings:
        decision, at = gaze_decision(pairing)
        for name, settings in fusions.items():
            decided[name].append(Decided(pairing, *fuse(pairing, decision, at, settings)))
    return decided


def tally(rounds: Sequence[Decided]) -> Dict[str, float]:
    """
    Shares of right / wrong / no choice of the intent rounds, Midas share, times, ITR.

    Shares are of the intent rounds (``right``, ``wrong``, ``none``) and of the
    no-intent rounds (``midas``); ``median_s``: the median time from the cue
    to a choice in the intent rounds; ``itr_bits_min``: module doc.
    """
    intent = [r for r in rounds if r.pairing.intent]
    rest = [r for r in rounds if not r.pairing.intent]
    right = sum(r.choice == r.pairing.attended for r in intent)
    wrong = sum(r.choice is not None and r.choice != r.pairing.attended for r in intent)
    times = [r.after_s for r in intent if r.choice is not None]
    share = (lambda count, of: round(count / len(of), 4) if of else None)
    row = {'intent_rounds': len(intent), 'right': share(right, intent),
           'wrong': share(wrong, intent), 'none': share(len(intent) - right - wrong, intent),
           'no_intent_rounds': len(rest),
           'midas': share(sum(r.choice is not None for r in rest), rest),
           'median_s': round(float(np.median(times)), 2) if times else None,
           'right_within_5s': share(sum(r.choice == r.pairing.attended and r.after_s <= 5.0
                                        for r in intent), intent)}
    if intent:
        options = len(intent[0].pairing.labels)
        spent = np.mean([r.after_s if r.choice is not None else ROUND_S for r in intent])
        row['itr_bits_min'] = round(wolpaw_bits(options, right / len(intent)) * 60.0
                                    / (spent + GAZE_SHIFT_S), 1)
    row['counts'] = {'right': right, 'wrong': wrong, 'none': len(intent) - right - wrong,
                     'midas': sum(r.choice is not None for r in rest)}
    return row


def within_goal(row: Dict) -> bool:
    """Whether a row keeps the goal's limits on Midas and wrong choices."""
    return row['midas'] <= GOAL_MIDAS and row['wrong'] <= GOAL_WRONG


def grid_decisions(pairings: Sequence[Pairing]) -> Dict[str, List[Decided]]:
    """Decide the hybrid under every :data:`BOUND_GRID` setting: setting name -> rounds."""
    return decide_all(pairings, {
        f'confirm_threshold {c:g} hold_s {h:g}':
        FusionSettings('hybrid', confirm_threshold=c, hold_s=h) for c, h in BOUND_GRID})


def best_setting(rows: Dict[str, Dict]) -> Optional[str]:
    """Return the setting with the most right among those within the limits (None: none)."""
    allowed = [name for name, row in rows.items() if within_goal(row)]
    return max(allowed, key=lambda name: (rows[name]['right'], -rows[name]['midas']),
               default=None)


def bound(pairings: Sequence[Pairing],
          decided: Optional[Dict[str, List[Decided]]] = None) -> Dict[str, Dict]:
    """
    Decide the hybrid under every :data:`BOUND_GRID` setting; find the best within limits.

    :param decided: :func:`grid_decisions` of ``pairings``, if made already.
    :returns: ``{'best': row with its settings, 'grid': {name: row}}``; the best is the
        most right choices among the settings within the limits (hindsight).
    """
    decided = decided if decided is not None else grid_decisions(pairings)
    rows = {name: tally(rounds) for name, rounds in decided.items()}
    best = best_setting(rows)
    return {'best': dict(rows[best], setting=best) if best else {'setting': None},
            'grid': rows}


def held_out_subjects(decided: Dict[str, List[Decided]]) -> Dict:
    """
    Leave-subject-out: each subject decided with the setting chosen on the others (module doc).

    :param decided: :func:`grid_decisions`.
    :returns: ``{'pooled': row (tally of every held-out round), 'subjects': {subject:
        dict(row, setting=chosen)}}``; a subject for whom no setting keeps the limits on
        the others is decided with the default (``FusionSettings('hybrid')``).
    """
    default = FusionSettings('hybrid')
    fallback = f'confirm_threshold {default.confirm_threshold:g} hold_s {default.hold_s:g}'
    subjects = sorted({r.pairing.subject for rounds in decided.values() for r in rounds})
    held: List[Decided] = []
    found: Dict = {'subjects': {}}
    for subject in subjects:
        on_others = {name: tally([r for r in rounds if r.pairing.subject != subject])
                     for name, rounds in decided.items()}
        chosen = best_setting(on_others) or fallback
        mine = [r for r in decided[chosen] if r.pairing.subject == subject]
        held += mine
        found['subjects'][subject] = dict(tally(mine), setting=chosen)
    found['pooled'] = tally(held)
    return found


def _folder(given: Optional[str], kind: str, finder) -> str:
    folder = given or finder()
    if not folder:
        raise FileNotFoundError(f'no real {kind} recordings found; give --{kind}-data DIR')
    return str(folder)


def load_pairings(gaze_data: Optional[str] = None, eeg_data: Optional[str] = None,
                  subjects: Sequence[str] = (), quick: bool = False, seed: int = 0,
                  log=sys.stderr) -> List[Pairing]:
    """
    Decode every EEG session and pair its trials with gaze rounds (module doc).

    :raises FileNotFoundError: a folder without recordings of its kind.
    """
    gaze_folder = _folder(gaze_data, 'gaze', lambda: find_data('real_gaze'))
    eeg_folder = _folder(eeg_data, 'eeg', eeg_data_dir)
    looks = gaze_looks(load_folder(gaze_folder))
    if not looks:
        raise FileNotFoundError(f'no gaze recording with jumping targets in {gaze_folder}')
    paths = find_eeg_recordings(eeg_folder)
    if not paths:
        raise FileNotFoundError(f'no EEG recordings (*.npz) in {eeg_folder}')
    groups = by_subject(load_eeg(path) for path in paths)
    if subjects:
        groups = {s: groups[s] for s in subjects if s in groups}
    if quick:
        groups = dict(list(groups.items())[:QUICK_SUBJECTS])
    rng = np.random.default_rng(seed)
    cycle = itertools.cycle(looks)
    settings = OnlineSettings(keep_scoring=True)
    pairings: List[Pairing] = []
    for subject, recordings in groups.items():
        for recording in recordings:
            print(f'decoding {recording.name} ...', file=log, flush=True)
            pairings += pair(subject, _online(recording, settings, None), _labels(recording),
                             cycle, rng)
    return pairings


def evaluate(pairings: Sequence[Pairing], with_bound: bool = True) -> Dict:
    """
    Decide in the three modes; tally per subject and overall, with the hybrid's bound.

    :returns: ``{'gaze': row, 'ssvep': row, 'hybrid': row, 'subjects': {subject:
        {mode: row}}, 'bound': ..., 'rounds': ...}`` (rows of :func:`tally`).
    """
    decided = decide_all(pairings, {mode: FusionSettings(mode) for mode in INPUT_MODES})
    result: Dict = {mode: tally(rounds) for mode, rounds in decided.items()}
    result['subjects'] = {
        subject: {mode: tally([r for r in rounds if r.pairing.subject == subject])
                  for mode, rounds in decided.items()}
        for subject in sorted({p.subject for p in pairings})}
    result['goal'] = {'midas': GOAL_MIDAS, 'wrong': GOAL_WRONG, 'right_within_5s': GOAL_RIGHT,
                      'met': bool(within_goal(result['hybrid'])
                                  and result['hybrid']['right_within_5s'] >= GOAL_RIGHT)}
    result['gaze people'] = {
        person: {mode: tally([r for r in rounds if r.pairing.recording.name == person])
                 for mode, rounds in decided.items()}
        for person in sorted({p.recording.name for p in pairings})}
    if with_bound:
        grid = grid_decisions(pairings)
        result['bound'] = bound(pairings, grid)['best']
        result['held out'] = held_out_subjects(grid)
    looks = {p.look for p in pairings}
    result['rounds'] = {'pairings': len(pairings), 'gaze_rounds_used': len(looks),
                        'gaze_recordings': sorted({p.recording.name for p in pairings})}
    return result


def unavailable(gaze_data: Optional[str] = None, eeg_data: Optional[str] = None
                ) -> Optional[str]:
    """
    Say why the benchmark cannot run here (no recordings), or None (``bench.run_all``).

    :param gaze_data: the gaze folder named (None: the development copy's).
    :param eeg_data: the EEG folder named (None: the development copy's).
    """
    gaze_folder = gaze_data or find_data('real_gaze')
    if gaze_folder is None or not Path(gaze_folder).is_dir() or not find_recordings(gaze_folder):
        return 'no real gaze recordings (../shared/data/real_gaze or --gaze-data DIR)'
    eeg_folder = eeg_data or eeg_data_dir()
    if eeg_folder is None or not find_eeg_recordings(eeg_folder):
        return 'no real EEG recordings (../shared/data/real_eeg or --eeg-data DIR)'
    return None


def run(quick: bool = False, gaze_data: Optional[str] = None, eeg_data: Optional[str] = None,
        subjects: Sequence[str] = (), seed: int = 0, with_bound: bool = True) -> Dict:
    """
    Run the benchmark (``make bench`` section ``real_hybrid``); ``quick``: two subjects.

    :raises FileNotFoundError: no recordings of a kind.
    """
    pairings = load_pairings(gaze_data, eeg_data, subjects, quick, seed)
    return evaluate(pairings, with_bound)


def _row_line(name: str, row: Dict) -> str:
    cell = (lambda key: '-' if row.get(key) is None else f'{100 * row[key]:.1f}')
    return (f"| {name} | {row['intent_rounds']} | {cell('right')} | {cell('wrong')} | "
            f"{cell('none')} | {row['no_intent_rounds']} | {cell('midas')} | "
            f"{row['median_s'] if row['median_s'] is not None else '-'} | "
            f"{row.get('itr_bits_min', '-')} |")


def format_lines(section: Dict) -> List[str]:
    """Return the tables of a section, as printed."""
    header = ['| mode | intent rounds | right % | wrong % | no choice % | no-intent rounds | '
              'Midas % | median s to choice | ITR bits/min |', '|---|---|---|---|---|---|---|'
              '---|---|']
    lines = header + [_row_line(mode, section[mode]) for mode in INPUT_MODES]
    if section.get('bound'):
        best = section['bound']
        if best.get('setting'):
            lines.append(_row_line(f"hybrid bound ({best['setting']}, hindsight)", best))
        else:
            lines.append('hybrid bound: no setting of the grid keeps the limits')
    if section.get('held out'):
        held = section['held out']
        lines += ['', 'what a new subject can expect: the hybrid, confirm_threshold x hold_s '
                  'chosen on the other subjects (leave-subject-out):', *header,
                  _row_line('**hybrid, held out, pooled**', held['pooled'])]
        lines += [_row_line(f"{subject} held out ({row['setting']})", row)
                  for subject, row in held['subjects'].items()]
    lines += ['', 'per subject:', *header]
    for subject, rows in section['subjects'].items():
        lines += [_row_line(f'{subject} {mode}', rows[mode]) for mode in INPUT_MODES]
    lines += ['', 'per gaze person:', *header]
    for person, rows in section.get('gaze people', {}).items():
        lines += [_row_line(f'{person} {mode}', rows[mode]) for mode in INPUT_MODES]
    rights = [rows['hybrid']['right_within_5s'] for rows in section['subjects'].values()]
    if rights:
        lines.append(f'hybrid right within 5 s, lowest-highest subject: '
                     f'{100 * min(rights):.1f}-{100 * max(rights):.1f} %')
    lines += ['', f"goal met: {section['goal']['met']}; rounds: {section['rounds']}"]
    return lines


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Command line (module doc)."""
    parser = argparse.ArgumentParser(prog='bench.real_hybrid',
                                     description=__doc__.split('\n')[1])
    parser.add_argument('--gaze-data', default='', help='folder of gaze recordings')
    parser.add_argument('--eeg-data', default='', help='folder of EEG recordings (*.npz)')
    parser.add_argument('--subjects', default='', help='EEG subjects, comma-separated')
    parser.add_argument('--quick', action='store_true', help='the first two subjects, no bound')
    parser.add_argument('--seed', type=int, default=0, help='layouts and pairing')
    parser.add_argument('--json', default='', help='write the results here')
    args = parser.parse_args(argv)
    started = time.perf_counter()
    try:
        results = run(args.quick, args.gaze_data or None, args.eeg_data or None,
                      [s for s in args.subjects.split(',') if s], args.seed,
                      with_bound=not args.quick)
    except (OSError, ValueError) as error:
        print(f'bench.real_hybrid: {error}', file=sys.stderr)
        return 2
    report(format_lines(results), results, started, args.json)
    return 0


if __name__ == '__main__':
    sys.exit(main())
