"""
SSVEP decoders on real EEG: offline accuracy / ITR, and the online decoder as the node runs it.

Reads recordings of :mod:`eye_bci_ros2.recordings.eeg` (e.g. Kalunga et al.
2016 "SSVEP Exo": 256 Hz, 8 occipital channels, LEDs at 13/17/21 Hz, and
rest trials: a fixation point, nothing attended) from ``--data DIR``
(default: ``$EYE_BCI_REAL_EEG`` or ``../shared/data/real_eeg`` beside the
clone).

1. ``offline``: each decoder forced to choose among the session's stimuli on
   windows of 0.5-3 s starting :data:`OFFLINE_START_S` after the cue (the
   response has built up), accuracy and Wolpaw ITR (selection time = window
   + :data:`~eye_bci_ros2.experiments.metrics.GAZE_SHIFT_S`).
2. ``online``: each session streamed through
   :class:`~eye_bci_ros2.ssvep.online.OnlineDecoder` with a decision step
   every 0.1 s (the node's; its samples fed at once, which filters exactly as
   the node's 0.02 s chunks), one round per trial from its cue for
   :data:`ROUND_S` s, the decoder's default settings: right / wrong / no
   choice of the stimulus trials, choices in rest trials, median decision
   time after the cue; and leave-subject-out: each subject decided with the
   ``rest_z`` (:data:`REST_Z_GRID`) that does best on the *other* subjects
   within the goals' limits (FBCCA, replayed from the recorded evidence),
   and the same with ``rest_z`` and ``hold_s`` (:data:`HOLD_S_GRID`) chosen together;
   and the recorded evidence replayed under other decision constants
   (:data:`REPLAY_GRID`: ``rest_z``, ``threshold``, ``hold_s``).
3. ``statistic``: the FBCCA evidence statistic's spread on real EEG
   nobody attends (rest trials, unattended options) beside its white-noise
   null, and the attended option's median z, at 1, 2 and 4 s windows.
4. ``white-noise rounds``: the same rounds streamed with white noise for EEG
   (nobody attends: every choice is false): the share with a choice by
   ``rest_z``, the smallest ``rest_z`` that keeps it within
   :data:`NULL_TARGET` (a threshold derived from the null, not from the
   recordings), and the real rounds decided with it.
5. ``hybrid``: the same rounds through the hybrid fusion
   (:class:`~eye_bci_ros2.decision.fusion.ChoiceFusion`, default settings) with the
   gaze resting on an option from :data:`GAZE_AT_S` after the cue: in rest
   trials on each option in turn (looking without attending: must not
   choose), in stimulus trials on the attended one (must be confirmed).

Decoders: ``fbcca`` (no training) and ``trca`` / ``ensemble_trca`` calibrated
as the README says (``ssvep_calibrate``: the subject's *other* sessions, their
stimulus and rest trials, 2 s from each cue + ``onset_s``).  A calibration
the model refuses (trials that do not repeat: stimuli not phase-locked to the
trials) is reported as refused; ``--force-trca`` fits it anyway, to show what
the rest model does with such a model.  Nothing here is tuned on the
recordings: the decision's constants come from the white-noise null
(:func:`eye_bci_ros2.ssvep.decoders.fbcca_null`) and the module defaults.
Results per subject and overall.

Usage::

    python -m bench.ssvep_real [--data DIR] [--subjects s01,s02] [--json PATH]
                               [--set window_s=4 ...]
"""

import argparse
import dataclasses
import sys
import time
from typing import Dict, List, Optional, Sequence

import numpy as np

from bench.timing import report
from eye_bci_ros2.decision.fusion import ChoiceFusion, FusionSettings
from eye_bci_ros2.experiments.metrics import GAZE_SHIFT_S, wolpaw_bits
from eye_bci_ros2.recordings.eeg import (by_subject, eeg_data_dir, EEG_DATA_ENV, EegRecording,
                                         find_eeg_recordings, load_eeg)
from eye_bci_ros2.ssvep.decision import DecisionRule, HeldDecision
from eye_bci_ros2.ssvep.decoders import (fbcca_null, FbccaDecoder, sideband_hz, sideband_statistic,
                                         TrcaModel, with_sidebands)
from eye_bci_ros2.ssvep.filters import filter_recording
from eye_bci_ros2.ssvep.online import OnlineDecoder, OnlineSettings
from eye_bci_ros2.ssvep.stimuli import StimulusMap
from eye_bci_ros2.ssvep.training import fit_trca

#: Length of a round from the cue, s (the recordings' trials last 5 s).
ROUND_S = 5.0
#: Online decision step, s (the node's decide period).
STEP_S = 0.1
#: Offline windows, s, and where they start after the cue, s.
WINDOWS_S = (0.5, 1.0, 1.5, 2.0, 3.0)
OFFLINE_START_S = 1.5
#: The goals' limits: wrong choices per stimulus trial, choices per rest trial.
GOAL_WRONG = 0.01
GOAL_REST = 0.02
#: ``rest_z`` values the leave-subject-out evaluation chooses from.
REST_Z_GRID = (1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0)
#: ``hold_s`` values the joint leave-subject-out evaluation chooses from (with ``rest_z``).
HOLD_S_GRID = (0.0, 0.3, 0.5, 0.7, 1.0)
#: (``rest_z``, ``threshold``, ``hold_s``) the recorded evidence is replayed under (all
#: subjects): the trade between right choices, wrong ones and choices on nothing; the
#: former default (2.5, 0.95, no hold) among them.
REPLAY_GRID = ((2.5, 0.95, 0.0), (2.0, 0.95, 0.0), (1.0, 0.95, 0.5), (2.0, 0.95, 0.5),
               (1.0, 0.95, 0.7), (1.5, 0.95, 0.3))
#: Share of rounds nobody attends that may end with a choice, the target the ``rest_z``
#: derived from the white-noise null (:func:`_null_rounds`) is set for: half the goals' 2 %
#: of rest trials, because real EEG's statistic spreads 3-5 % wider than white noise's.
NULL_TARGET = 0.01
#: ``rest_z`` values the white-noise rounds are replayed under.
NULL_REST_Z_GRID = tuple(np.round(np.arange(0.5, 4.01, 0.25), 2).tolist())
#: Window lengths the FBCCA statistic is compared with its white-noise null at, s.
STATISTIC_WINDOWS_S = (1.0, 2.0, 4.0)
#: When the gaze reaches the option in the hybrid rounds, after the cue, s.
GAZE_AT_S = 1.0
#: Calibration trial length, s.
TRIAL_S = 2.0
DECODERS = ('fbcca', 'trca', 'ensemble_trca')

TABLE_COLUMNS = None


def _labels(frequencies: Sequence[float]) -> tuple:
    return tuple(f'{f:g} Hz' for f in frequencies)


def _stimuli(recording: EegRecording, epoch_s: float = 0.0) -> StimulusMap:
    frequencies = recording.frequencies
    return StimulusMap(_labels(frequencies), frequencies, (0.0,) * len(frequencies), epoch_s)


def _calibrate(others: List[EegRecording], decoder: str, settings: OnlineSettings,
               force: bool) -> TrcaModel:
    """Fit a TRCA model on other sessions of the subject, as ssvep_calibrate fits one."""
    stimuli = _stimuli(others[0])
    trials = [[(cue, None if hz is None else f'{hz:g} Hz')
               for cue, hz in recording.trials] for recording in others]
    return fit_trca([r.eeg_uv for r in others], [r.times for r in others], trials, stimuli,
                    others[0].rate, others[0].channels, trial_s=TRIAL_S,
                    ensemble=decoder == 'ensemble_trca', min_window_s=settings.min_window_s,
                    require_repeat=not force, onset_s=settings.onset_s)


def _offline(recording: EegRecording, model: Optional[TrcaModel]) -> Dict[float, List[bool]]:
    """Score the forced choice of each stimulus trial by window length."""
    frequencies = np.array(recording.frequencies)
    filtered = filter_recording(recording.eeg_uv, recording.rate)
    fbcca = FbccaDecoder(frequencies, recording.rate)
    hits = {w: [] for w in WINDOWS_S}
    for cue, hz in recording.trials:
        if hz is None:
            continue
        start = int(round((cue + OFFLINE_START_S) * recording.rate))
        for w in WINDOWS_S:
            window = filtered[:, start:start + int(round(w * recording.rate))]
            scores = (fbcca.scores(window) if model is None
                      else model.scores(window, OFFLINE_START_S))  # the cue is the epoch
            hits[w].append(bool(frequencies[np.argmax(scores)] == hz))
    return hits


def _statistic(recordings: Sequence[EegRecording], settings: OnlineSettings) -> Dict[str, Dict]:
    """
    Compare the FBCCA evidence statistic on real EEG with its white-noise null, by window.

    Windows from ``onset_s`` after each cue: the statistic of every option in
    rest trials and of the unattended options in stimulus trials (the real
    null: its standard deviation), and the attended option's z against that
    real null (median).  White noise: :func:`~eye_bci_ros2.ssvep.decoders.fbcca_null`.
    """
    rows = {}
    delta = sideband_hz(settings.min_window_s)
    for length in STATISTIC_WINDOWS_S:
        null, attended = [], []
        for recording in recordings:
            frequencies = np.array(recording.frequencies)
            fbcca = FbccaDecoder(with_sidebands(frequencies, delta), recording.rate)
            filtered = filter_recording(recording.eeg_uv, recording.rate)
            n = int(round(length * recording.rate))
            for cue, hz in recording.trials:
                start = int(round((cue + settings.onset_s) * recording.rate))
                values = sideband_statistic(fbcca.scores(filtered[:, start:start + n]))
                own = frequencies == hz
                null += values[~own].tolist()
                attended += values[own].tolist()
        null, attended = np.array(null), np.array(attended)
        first = recordings[0]
        white = fbcca_null(first.rate, len(first.channels), settings.bands, settings.harmonics,
                           settings.band, settings.notch_hz, (length,), delta)
        rows[f'{length:g} s'] = {
            'real_null_sd': round(float(null.std()), 3),
            'white_noise_sd': round(float(white.std[0]), 3),
            'attended_median_z': round(float(np.median((attended - null.mean()) / null.std())),
                                       2)}
    return rows


def _online(recording: EegRecording, settings: OnlineSettings,
            model: Optional[TrcaModel]) -> List[Dict]:
    """Stream a session through the online decoder; one round per trial."""
    decoder = OnlineDecoder(recording.rate, recording.channels, settings, model)
    times, samples = recording.times, recording.eeg_uv
    # Fed a step's samples at a time: the filters give the same output in any chunking
    # (test_ssvep_filters) and the steps fall at the same times as with 0.02 s chunks.
    chunk = int(round(STEP_S * recording.rate))
    per_step = 1
    cues = iter(recording.trials)
    upcoming = next(cues, None)
    outcome: List[Dict] = []
    trial = None
    for k, first in enumerate(range(0, len(times), chunk)):
        decoder.add(times[first:first + chunk], samples[first:first + chunk])
        now = times[min(first + chunk, len(times)) - 1]
        if upcoming is not None and now >= upcoming[0]:
            cue, hz = upcoming
            decoder.start_round(cue, _stimuli(recording).labels, _stimuli(recording, cue))
            trial = {'target': None if hz is None else f'{hz:g} Hz', 'choice': None,
                     'after_s': None, 'cue': cue, 'labels': _stimuli(recording).labels,
                     'steps': []}
            outcome.append(trial)
            upcoming = next(cues, None)
        if trial is None or now > trial['cue'] + ROUND_S or k % per_step:
            continue
        result = decoder.step()
        if result is None:
            continue
        if len(result.posterior):
            trial['steps'].append((float(now), result.labels, result.posterior.tolist(),
                                   result.evidence.tolist(), result.window_s, result.end_s))
        if result.choice is not None and trial['choice'] is None:
            trial['choice'], trial['after_s'] = result.choice, float(now - trial['cue'])
    return outcome


def _null_rounds(recordings: Sequence[EegRecording], settings: OnlineSettings) -> List[Dict]:
    """
    Stream white noise through the online decoder in these sessions' rounds.

    Each session's EEG is replaced by seeded white noise (10 uV, its length,
    rate and channels) and its rounds are decoded as usual: nobody attends any
    option, so every choice is a false one.  The statistic's null
    (:func:`~eye_bci_ros2.ssvep.decoders.fbcca_null`) is measured on the same
    kind of noise; this measures what the decision rule (its ``rest_z``,
    threshold and hold over the round's overlapping windows) makes of it.
    """
    rounds = []
    for index, recording in enumerate(recordings):
        noise = np.random.default_rng(7000 + index).standard_normal(recording.eeg_uv.shape)
        null = dataclasses.replace(recording, eeg_uv=10.0 * noise)
        rounds += [dict(t, target=None) for t in _online(null, settings, None)]
    return rounds


def _rule(settings: OnlineSettings, **changes) -> DecisionRule:
    """Return the decision rule of these settings, with ``changes`` (e.g. ``rest_z``)."""
    return dataclasses.replace(settings.decision_rule(), **changes)


def _null_rest_z(rounds: List[Dict], settings: OnlineSettings, hold_s: float) -> Dict:
    """
    Find the smallest ``rest_z`` with at most NULL_TARGET of the white-noise rounds choosing.

    :returns: a row: that ``rest_z`` and the share of rounds with a choice at each grid value.
    """
    shares = {}
    for rest_z in NULL_REST_Z_GRID:
        row = _online_row(_replay(rounds, _rule(settings, rest_z=rest_z, hold_s=hold_s)))
        shares[rest_z] = row['rest_choices'] / max(row['rest_trials'], 1)
    chosen = next((z for z in NULL_REST_Z_GRID if shares[z] <= NULL_TARGET),
                  NULL_REST_Z_GRID[-1])
    return {'rounds': len(rounds), 'hold_s': hold_s, 'rest_z': chosen,
            'choices_at_default': round(shares.get(settings.rest_z, float('nan')), 4),
            **{f'choices_at_{z:g}': round(share, 4) for z, share in shares.items()
               if z in REST_Z_GRID}}


def _hybrid(trials: List[Dict]) -> Dict:
    """
    Run the hybrid fusion on these rounds: the gaze rests on an option from ``GAZE_AT_S``.

    Rest trials: the gaze rests on each option in turn (the person looks at it
    without attending it: the EEG says nothing is attended); a choice is a
    false one.  Stimulus trials: the gaze rests on the attended option.
    """
    rest = confirmed = 0
    rest_rounds = stimulus_rounds = 0
    for trial in trials:
        labels = trial['labels']
        candidates = labels if trial['target'] is None else (trial['target'],)
        for candidate in candidates:
            fusion = ChoiceFusion(FusionSettings('hybrid'))
            fusion.new_round(labels)
            got = None
            gazed = False
            for t, step_labels, posterior, _, _, _ in trial['steps']:
                if not gazed and t >= trial['cue'] + GAZE_AT_S:
                    got = fusion.gaze(candidate, t, 1.0) or got
                    gazed = True
                got = fusion.ssvep_scores(step_labels, posterior, t) or got
            if trial['target'] is None:
                rest_rounds += 1
                rest += got is not None
            else:
                stimulus_rounds += 1
                confirmed += got == candidate
    return {'rest_rounds': rest_rounds, 'rest_choices': rest,
            'rest_no_choice_share': round(1 - rest / rest_rounds, 4) if rest_rounds else None,
            'intent_rounds': stimulus_rounds, 'intent_confirmed': confirmed,
            'intent_share': round(confirmed / stimulus_rounds, 3) if stimulus_rounds else None}


def _replay(trials: List[Dict], rule: DecisionRule) -> List[Dict]:
    """
    Decide the rounds again under another rule, from their recorded evidence.

    The decision is a function of the steps' evidence z, windows and times
    (:class:`~eye_bci_ros2.ssvep.decision.HeldDecision`), and a round takes its
    first choice, so this equals streaming them again.
    """
    replayed = []
    for trial in trials:
        choice = after = None
        held = HeldDecision(rule)
        for t, labels, _, z, window_s, end_s in trial['steps']:
            index = held.update(np.array(z), window_s, end_s)
            if index is not None:
                choice, after = labels[index], t - trial['cue']
                break
        replayed.append(dict(trial, choice=choice, after_s=after))
    return replayed


def _acceptable(row: Dict) -> bool:
    """Tell whether a row keeps the goals' limits: <= 1 % wrong, <= 2 % rest choices."""
    return (row['wrong'] <= GOAL_WRONG * row['stimulus_trials']
            and row['rest_choices'] <= GOAL_REST * row['rest_trials'])


def _leave_subjects_out(per_subject: Dict[str, List[Dict]],
                        grid: Sequence[Dict[str, float]] = tuple(
                            {'rest_z': z} for z in REST_Z_GRID)) -> Dict[str, Dict]:
    """
    Decision constants chosen on the other subjects, evaluated on each one.

    For every subject, the ``grid`` entry (keyword arguments of
    :class:`~eye_bci_ros2.ssvep.decision.DecisionRule`; default: each
    :data:`REST_Z_GRID` value) that gives the most right choices on the *other*
    subjects within the goals' limits (the last entry if none does) decides
    that subject's rounds.
    """
    rows, pooled = {}, []
    for subject, trials in per_subject.items():
        others = [t for s, listed in per_subject.items() if s != subject for t in listed]
        best, best_right = grid[-1], -1
        for constants in grid:
            row = _online_row(_replay(others, DecisionRule(**constants)))
            if _acceptable(row) and row['right'] > best_right:
                best, best_right = constants, row['right']
        held_out = _replay(trials, DecisionRule(**best))
        rows[subject] = dict(_online_row(held_out), **best)
        pooled += held_out
    rows['all'] = _online_row(pooled)
    return rows


def _online_row(trials: List[Dict]) -> Dict:
    stimulus = [t for t in trials if t['target'] is not None]
    rest = [t for t in trials if t['target'] is None]
    right = sum(t['choice'] == t['target'] for t in stimulus)
    wrong = sum(t['choice'] is not None and t['choice'] != t['target'] for t in stimulus)
    times = [t['after_s'] for t in stimulus if t['choice'] is not None]
    return {'stimulus_trials': len(stimulus), 'right': right, 'wrong': wrong,
            'no_choice': len(stimulus) - right - wrong,
            'right_share': round(right / len(stimulus), 3) if stimulus else None,
            'wrong_share': round(wrong / len(stimulus), 3) if stimulus else None,
            'rest_trials': len(rest),
            'rest_choices': sum(t['choice'] is not None for t in rest),
            'median_decision_s': round(float(np.median(times)), 2) if times else None}


def _offline_row(hits: Dict[float, List[bool]], classes: int) -> Dict:
    row = {}
    for w, values in hits.items():
        accuracy = float(np.mean(values)) if values else 0.0
        row[f'acc_{w:g}s'] = round(accuracy, 3)
        row[f'itr_{w:g}s'] = round(wolpaw_bits(classes, accuracy) * 60.0 / (w + GAZE_SHIFT_S),
                                   1)
    row['trials'] = len(next(iter(hits.values()), []))
    return row


#: Types of the online settings ``--set`` can override.
SETTABLE = (float, int, str, bool)


def parse_settings(pairs: Sequence[str]) -> Dict[str, object]:
    """
    Read ``KEY=VALUE`` overrides of :class:`~eye_bci_ros2.ssvep.online.OnlineSettings`.

    :raises ValueError: for an unknown key, a value of the wrong type, or a
        setting that is not a number, a word or a flag, with which.
    """
    kinds = {f.name: f.type for f in dataclasses.fields(OnlineSettings)}
    overrides: Dict[str, object] = {}
    for pair in pairs:
        key, _, value = pair.partition('=')
        kind = kinds.get(key)
        if kind not in SETTABLE:
            names = ', '.join(k for k, t in kinds.items() if t in SETTABLE)
            raise ValueError(f'--set {pair}: not a setting given as KEY=VALUE (one of {names})')
        try:
            overrides[key] = (value.lower() in ('1', 'true', 'yes') if kind is bool
                              else kind(value))
        except ValueError:
            raise ValueError(f'--set {pair}: {key} needs a {kind.__name__}') from None
    OnlineSettings(**overrides)  # refuse a combination that cannot work, with why
    return overrides


def unavailable() -> Optional[str]:
    """Say why the benchmark cannot run here (no recordings), or None (``bench.run_all``)."""
    folder = eeg_data_dir()
    if folder is None or not find_eeg_recordings(folder):
        return (f'no real EEG recordings (set ${EEG_DATA_ENV} or put them in '
                '../shared/data/real_eeg)')
    return None


def run(quick: bool = False, data: Optional[str] = None, subjects: Sequence[str] = (),
        decoders: Sequence[str] = DECODERS, force_trca: bool = False,
        log=sys.stderr, overrides: Optional[Dict[str, object]] = None,
        null_rounds: bool = True) -> Dict[str, Dict]:
    """
    Run on every subject of ``data``; ``quick`` = the first two subjects, FBCCA only.

    ``overrides``: online decoder settings other than the defaults (:func:`parse_settings`).
    ``null_rounds``: also stream white noise through the rounds (``white-noise rounds``;
    about as long again as the FBCCA rounds themselves).

    :raises FileNotFoundError: when there are no recordings.
    """
    folder = data or eeg_data_dir()
    paths = find_eeg_recordings(folder) if folder else []
    if not paths:
        raise FileNotFoundError(f'no real EEG recordings in {folder or "(not found)"}; '
                                'give --data DIR')
    groups = by_subject(load_eeg(path) for path in paths)
    if subjects:
        groups = {s: groups[s] for s in subjects if s in groups}
    if quick:
        groups = dict(list(groups.items())[:2])
        decoders = ('fbcca',)
    settings = OnlineSettings(**(overrides or {}))
    results: Dict[str, Dict] = {}
    for decoder in decoders:
        online_all, offline_all, refused = [], {w: [] for w in WINDOWS_S}, []
        per_subject: Dict[str, List[Dict]] = {}
        for subject, recordings in groups.items():
            online, offline = [], {w: [] for w in WINDOWS_S}
            for index, recording in enumerate(recordings):
                model = None
                if decoder != 'fbcca':
                    others = recordings[:index] + recordings[index + 1:]
                    if not others:
                        refused.append(f'{subject}: one session, nothing to calibrate on')
                        continue
                    try:
                        model = _calibrate(others, decoder, settings, force_trca)
                    except ValueError as error:
                        refused.append(f'{subject}: {str(error)[:90]}')
                        continue
                hits = _offline(recording, model)
                for w in WINDOWS_S:
                    offline[w] += hits[w]
                online += _online(recording, dataclasses.replace(
                    settings, decoder=decoder, keep_scoring=True), model)
            print(f'{decoder} {subject}: {_online_row(online)}', file=log, flush=True)
            if online:
                classes = len(recordings[0].frequencies)
                results[f'{decoder} online {subject}'] = _online_row(online)
                results[f'{decoder} offline {subject}'] = _offline_row(offline, classes)
                online_all += online
                per_subject[subject] = online
                for w in WINDOWS_S:
                    offline_all[w] += offline[w]
        if decoder == 'fbcca':
            for length, row in _statistic([r for listed in groups.values() for r in listed],
                                          settings).items():
                results[f'fbcca statistic {length}'] = row
        if online_all and decoder == 'fbcca' and null_rounds:
            # The decision rule's false alarms on the statistic's own null, and the rest_z
            # they set for NULL_TARGET, tried on the real rounds.
            null = _null_rest_z(_null_rounds([r for listed in groups.values() for r in listed],
                                             dataclasses.replace(settings, keep_scoring=True)),
                                settings, settings.hold_s)
            results['fbcca white-noise rounds'] = null
            results['fbcca online white-noise rest_z'] = dict(_online_row(_replay(
                online_all, _rule(settings, rest_z=null['rest_z']))), rest_z=null['rest_z'])
        if online_all:
            results[f'{decoder} online all'] = _online_row(online_all)
            results[f'{decoder} hybrid all'] = _hybrid(online_all)
            for rest_z, threshold, hold_s in REPLAY_GRID:  # other decision constants
                results[f'{decoder} online replay rest_z {rest_z:g} threshold {threshold:g} '
                        f'hold_s {hold_s:g}'] = _online_row(_replay(online_all, DecisionRule(
                            rest_z=rest_z, threshold=threshold, hold_s=hold_s)))
            if decoder == 'fbcca' and len(per_subject) > 1:
                for subject, row in _leave_subjects_out(per_subject).items():
                    results[f'{decoder} online leave-subject-out {subject}'] = row
                joint = [{'rest_z': z, 'hold_s': h} for z in REST_Z_GRID for h in HOLD_S_GRID]
                for subject, row in _leave_subjects_out(per_subject, joint).items():
                    results[f'{decoder} online leave-subject-out rest_z+hold_s {subject}'] = row
            results[f'{decoder} offline all'] = _offline_row(offline_all, 3)
        if refused:
            results[f'{decoder} calibration refused'] = {
                'sessions': len(refused), 'first': refused[0]}
    return results


def format_lines(section: Dict[str, Dict]) -> List[str]:
    """One line per row."""
    return [f'{name:<32} ' + ', '.join(f'{k} {v}' for k, v in row.items())
            for name, row in section.items()]


def main(argv=None) -> int:
    """Run and print; ``--json PATH`` to save."""
    parser = argparse.ArgumentParser(prog='bench.ssvep_real',
                                     description=__doc__.split('\n')[1])
    parser.add_argument('--data', default='', help='folder of recordings (*.npz)')
    parser.add_argument('--subjects', default='', help='comma-separated, e.g. s01,s02')
    parser.add_argument('--decoders', default=','.join(DECODERS))
    parser.add_argument('--force-trca', action='store_true',
                        help='fit TRCA even when the calibration trials do not repeat')
    parser.add_argument('--quick', action='store_true', help='two subjects, FBCCA only')
    parser.add_argument('--json', default='', help='write the results here')
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='an online decoder setting other than its default, e.g. '
                             'window_s=4 (repeatable)')
    args = parser.parse_args(argv)
    started = time.perf_counter()
    try:
        results = run(args.quick, args.data or None,
                      [s for s in args.subjects.split(',') if s],
                      [d for d in args.decoders.split(',') if d], args.force_trca,
                      overrides=parse_settings(args.set))
    except (FileNotFoundError, ValueError) as error:
        print(f'bench.ssvep_real: {error}', file=sys.stderr)
        return 2
    report(format_lines(results), results, started, args.json)
    return 0


if __name__ == '__main__':
    sys.exit(main())
