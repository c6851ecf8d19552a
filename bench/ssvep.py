"""
SSVEP benchmarks on the simulated subjects: accuracy / ITR, Midas touch, decoder CPU.

1. ``accuracy``: FBCCA and ensemble TRCA (fitted on a 5-trials-per-option
   calibration of the same subject) on cue-guided trials of the 4-room menu,
   window 0.5-2 s from ``onset_s`` (1 s) after the stimulus onset; mean
   over the 8 simulated people of :data:`PEOPLE`
   (:data:`eye_bci_ros2.sim.eeg.REALISTIC_SUBJECTS`, whose statistics match
   real recordings; their response builds up after the cue, so the early
   windows are weak); Wolpaw ITR with a selection time
   of window + :data:`GAZE_SHIFT_S` (Nakanishi 2018's 0.5 s cue / gaze shift).
2. ``rounds``: the room -> table task (4 then 3 options) through the online
   decoder (:class:`eye_bci_ros2.ssvep.online.OnlineDecoder`: FBCCA with the
   default settings, and ensemble TRCA fitted on 5 trials per option with
   ``min_window_s`` 0.5) and the hybrid fusion (:class:`eye_bci_ros2.decision.fusion.ChoiceFusion`,
   default settings), in *intent* rounds (the person looks at and attends one
   option) and *Midas-touch* rounds (the person looks over the options for
   :data:`ROUND_S` s, 0.25-0.5 s per glance, attending whatever the gaze is on,
   without intent).  The gaze decision is modelled, not simulated: in intent
   rounds the looked-at option (margin 1), in Midas rounds the option with the
   most dwell in the gaze window (1 s), margin = (its dwell - the runner-up's)
   / the window: gaze alone *always* chooses one (one choice per Midas round);
   hybrid must make 0.  SNR: narrow-band SNR at Oz over 10 s of attention.
3. ``cpu``: the online decoder (filter bank on every sample, FBCCA with
   sidebands on a growing/sliding 2 s window every 0.1 s, 4 options) processing one
   simulated minute in 20 ms chunks, at 250 and 1000 Hz with 8 and 32
   channels: CPU seconds (``time.process_time``) / 60 s = fraction of one
   core (the FBCCA null, measured once per set-up, timed apart:
   ``null_setup_cpu_s``), and the same divided by a reference workload timed in the same run
   (``reference_s``: 200 QR factorisations of a 2000 x 32 matrix).

Usage::

    python -m bench.ssvep            # short (about a minute on 2 shared cores)
    python -m bench.ssvep --full     # more trials and rounds
"""

import argparse
import sys
import time
from typing import Dict, List, Optional

import numpy as np

from bench.timing import report
from eye_bci_ros2.decision.fusion import ChoiceFusion, FusionSettings
from eye_bci_ros2.experiments.metrics import GAZE_SHIFT_S, wolpaw_bits
from eye_bci_ros2.sim.eeg import (calibration_session, EegSimulator, narrowband_snr_db,
                                  REALISTIC_SUBJECTS, SUBJECTS)
from eye_bci_ros2.ssvep.decoders import (fbcca_null, FbccaDecoder, null_windows, sideband_hz,
                                         TrcaModel)
from eye_bci_ros2.ssvep.filters import filter_recording
from eye_bci_ros2.ssvep.layouts import ACTICAP_32
from eye_bci_ros2.ssvep.online import DEFAULT_ONSET_S as ONSET_S, OnlineDecoder, OnlineSettings
from eye_bci_ros2.ssvep.stimuli import assign_stimuli, StimulusMap
from eye_bci_ros2.ssvep.training import fit_trca

ROOMS = ('kitchen', 'living_room', 'bedroom', 'office')
TABLES = ('table_1', 'table_2', 'table_3')
WINDOWS_S = (0.5, 1.0, 1.5, 2.0)
#: Longest round of the online rounds, s; the gaze window of the arbiter, s.
ROUND_S = 5.0
GAZE_WINDOW_S = 1.0
STEP_S = 0.1
CHUNK_S = 0.02

TABLE_COLUMNS = None
#: The simulated people of the accuracy and rounds sections: like the real recordings'
#: (weak, building up, drifting, with alpha; test/sim/test_sim_eeg_real.py), not the
#: clear responders the functional tests use.
PEOPLE = REALISTIC_SUBJECTS


def _accuracy(full: bool) -> Dict[str, Dict]:
    """Accuracy and ITR against window length, FBCCA and ensemble TRCA."""
    stimuli = assign_stimuli(ROOMS)
    per_option = 10 if full else 3
    correct = {(name, w): [] for name in ('fbcca', 'ensemble_trca') for w in WINDOWS_S}
    snrs = []
    refused = 0
    for index, subject in enumerate(PEOPLE):
        calibration = EegSimulator(subject, seed=1000 + index)
        model = _calibrate(calibration, stimuli, index)
        refused += model is None
        test = EegSimulator(subject, seed=2000 + index)
        t, x, trials = calibration_session(test, stimuli, per_option, ONSET_S + 2.0, 1.0,
                                           seed=100 + index)
        steady = EegSimulator(subject, seed=3000 + index)
        _, recording = steady.simulate(10.0, [(0.0, ROOMS[0])], stimuli)
        snrs.append(narrowband_snr_db(recording[:, steady.labels.index('Oz')], steady.rate,
                                      stimuli.frequencies[0]))
        filtered = filter_recording(x, test.rate)
        fbcca = FbccaDecoder(stimuli.frequencies, test.rate)
        for onset, label in trials:
            start = int(np.searchsorted(t, onset + ONSET_S))
            target = ROOMS.index(label)
            for w in WINDOWS_S:
                window = filtered[:, start:start + int(round(w * test.rate))]
                correct[('fbcca', w)].append(np.argmax(fbcca.scores(window)) == target)
                correct[('ensemble_trca', w)].append(
                    model is not None and np.argmax(model.scores(window, ONSET_S)) == target)
    section = {}
    for (name, w), hits in correct.items():
        accuracy = float(np.mean(hits))
        bits = wolpaw_bits(len(ROOMS), accuracy)
        section[f'{name} {w:g} s'] = {
            'accuracy': round(accuracy, 4), 'bits': round(bits, 3),
            'itr_bpm': round(bits * 60.0 / (w + GAZE_SHIFT_S), 1), 'trials': len(hits)}
    section['subjects'] = {'count': len(PEOPLE), 'trca_calibrations_refused': refused,
                           'snr_db_min': round(float(min(snrs)), 1),
                           'snr_db_max': round(float(max(snrs)), 1)}
    return section


def _calibrate(simulator, stimuli, seed) -> Optional[TrcaModel]:
    """Fit ensemble TRCA on 5 trials per option and 5 rest trials; None if refused."""
    t, x, trials = calibration_session(simulator, stimuli, 5, ONSET_S + 2.0, 1.0, seed=seed,
                                       rest_trials=5)
    try:
        return fit_trca(x, t, trials, stimuli, simulator.rate, simulator.labels,
                        onset_s=ONSET_S)
    except ValueError:  # trials that do not repeat: counted as a refused calibration
        return None


def _scan(rng, labels, duration_s) -> List:
    """Look over the options without intent: (t, label) glances of 0.25-0.5 s."""
    glances, t, last = [], 0.0, None
    while t < duration_s:
        label = rng.choice([lb for lb in labels if lb != last])
        glances.append((t, str(label)))
        last = label
        t += rng.uniform(0.25, 0.5)
    return glances


def _round(subject, seed, labels, intent: bool, model=None):
    """One online round; returns what SSVEP alone and hybrid chose and when."""
    rng = np.random.default_rng(seed)
    stimuli = assign_stimuli(labels, epoch_s=2.0)
    simulator = EegSimulator(subject, seed=seed)
    simulator.start(0.0, stimuli)
    if intent:
        target = str(rng.choice(labels))
        schedule = [(2.0, target)]
        candidate, margin = target, 1.0
    else:
        target = None
        schedule = [(2.0 + t, label) for t, label in _scan(rng, labels, ROUND_S)]
        dwell = dict.fromkeys(labels, 0.0)
        times = [t for t, _ in schedule] + [2.0 + ROUND_S]
        for (t, label), end in zip(schedule, times[1:]):
            dwell[label] += max(0.0, min(end, 2.0 + GAZE_WINDOW_S) - t)
        candidate = max(dwell, key=dwell.get)
        shares = sorted(dwell.values(), reverse=True)
        margin = (shares[0] - shares[1]) / sum(shares)
    for t, label in schedule:
        simulator.set_attended(label, t)
    settings = OnlineSettings(keep_scoring=True) if model is None else OnlineSettings(
        decoder='ensemble_trca', min_window_s=0.5, keep_scoring=True)
    decoder = OnlineDecoder(simulator.rate, simulator.labels, settings, model)
    fusion = ChoiceFusion(FusionSettings('hybrid'))
    fusion.new_round(labels)
    decoder.add(*simulator.next_chunk(2.0))  # the stream ran before the round
    decoder.start_round(2.0, labels, stimuli)
    now, ssvep, hybrid = 2.0, None, None
    next_step = 2.0 + STEP_S
    while now < 2.0 + ROUND_S and (hybrid is None or ssvep is None):
        now += CHUNK_S
        decoder.add(*simulator.next_chunk(now))
        if now >= 2.0 + GAZE_WINDOW_S and fusion.candidate is None and not fusion.chosen:
            got = fusion.gaze(candidate, now, margin)
            hybrid = (got, now - 2.0) if got and hybrid is None else hybrid
        if now + 1e-9 < next_step:
            continue
        next_step += STEP_S
        result = decoder.step()
        if result is None or not len(result.scores):
            continue
        got = fusion.ssvep_scores(result.labels, result.posterior, now)
        if result.choice is not None and ssvep is None:
            ssvep = (result.choice, now - 2.0)
            got = got or fusion.ssvep_choice(result.choice, now)
        if got and hybrid is None:
            hybrid = (got, now - 2.0)
    return target, ssvep, hybrid


def _rounds(full: bool, decoder: str = 'fbcca') -> Dict[str, Dict]:
    """Intent and Midas-touch rounds: SSVEP alone vs hybrid, with one decoder."""
    per_subject = 12 if full else 2
    outcome = {key: [] for key in ('ssvep intent', 'hybrid intent', 'ssvep midas',
                                   'hybrid midas')}
    for index, subject in enumerate(PEOPLE):
        models = {}
        if decoder != 'fbcca':
            for labels in (ROOMS, TABLES):
                models[labels] = _calibrate(EegSimulator(subject, seed=5000 + index),
                                            assign_stimuli(labels), index)
            if any(model is None for model in models.values()):
                continue  # refused: this person has no TRCA rounds
        for k in range(per_subject):
            labels = ROOMS if k % 2 == 0 else TABLES
            seed = 10_000 + 100 * index + k
            model = models.get(labels)
            target, ssvep, hybrid = _round(subject, seed, labels, True, model)
            outcome['ssvep intent'].append((target, ssvep, len(labels)))
            outcome['hybrid intent'].append((target, hybrid, len(labels)))
            target, ssvep, hybrid = _round(subject, seed + 50, labels, False, model)
            outcome['ssvep midas'].append((None, ssvep, len(labels)))
            outcome['hybrid midas'].append((None, hybrid, len(labels)))
    section = {}
    for key, rows in outcome.items():
        if not rows:  # every calibration refused
            section[key] = {'rounds': 0}
            continue
        chosen = [(target, got) for target, got, _ in rows if got is not None]
        row = {'rounds': len(rows), 'choices': len(chosen)}
        if key.endswith('intent'):
            right = sum(target == got[0] for target, got in chosen)
            accuracy = right / len(rows)
            selection_s = (np.mean([got[1] for _, got in chosen]) if chosen else ROUND_S) \
                + GAZE_SHIFT_S
            bits = np.mean([wolpaw_bits(n, accuracy) for _, _, n in rows])
            row.update({'correct': right, 'wrong': len(chosen) - right,
                        'accuracy': round(accuracy, 4),
                        'precision': round(right / len(chosen), 4) if chosen else None,
                        'mean_time_s': round(selection_s - GAZE_SHIFT_S, 2),
                        'itr_bpm': round(float(bits) * 60.0 / selection_s, 1)})
        section[key] = row
    section['gaze midas'] = {'rounds': len(outcome['hybrid midas']),
                             'choices': len(outcome['hybrid midas'])}
    return section


def _reference_s() -> float:
    """CPU time of a fixed workload, s (200 QR of 2000 x 32)."""
    matrix = np.random.default_rng(0).standard_normal((2000, 32))
    start = time.process_time()
    for _ in range(200):
        np.linalg.qr(matrix)
    return time.process_time() - start


#: Simulated seconds of EEG the CPU part decodes per set-up (the complete run).
CPU_DURATION_S = 60.0


def _cpu(full: bool, duration: float = CPU_DURATION_S) -> Dict[str, Dict]:
    """Fraction of one core the online decoder needs for ``duration`` s of a real-time stream."""
    section = {}
    stimuli = assign_stimuli(ROOMS, epoch_s=0.0)
    reference = _reference_s()
    for rate in (250.0, 1000.0):
        for channels in (8, 32):
            if channels == 8:
                simulator = EegSimulator(SUBJECTS[3], rate=rate, seed=1)
            else:
                simulator = EegSimulator(SUBJECTS[3], layout='liveamp', rate=rate, seed=1)
            times, samples = simulator.simulate(duration, [(0.0, 'bedroom')], stimuli)
            names = list(simulator.labels)
            decoder = OnlineDecoder(rate, names, OnlineSettings(threshold=1.0))
            chunk = int(round(CHUNK_S * rate))
            step = int(round(STEP_S / CHUNK_S))
            decoder.start_round(0.0, ROOMS, StimulusMap(stimuli.labels, stimuli.frequencies,
                                                        stimuli.phases, 0.0))
            # The FBCCA null is measured once per set-up (cached): timed on its own.
            setup = time.process_time()
            fbcca_null(rate, len(names), 5, 5, (6.0, 90.0), 50.0, null_windows(1.0, 2.0),
                       sideband_hz(1.0), tuple(float(f) for f in stimuli.frequencies))
            setup_s = time.process_time() - setup
            start = time.process_time()
            for k, first in enumerate(range(0, len(times), chunk)):
                decoder.add(times[first:first + chunk], samples[first:first + chunk])
                if k % step == 0:
                    decoder.step()
            cpu_s = time.process_time() - start
            section[f'{rate:g} Hz x {channels} ch'] = {
                'cpu_s': round(cpu_s, 3), 'core_fraction': round(cpu_s / duration, 4),
                'null_setup_cpu_s': round(setup_s, 2),
                'reference_s': round(reference, 3),
                # Per simulated minute, whatever the duration decoded.
                'vs_reference': round(cpu_s * 60.0 / duration / reference, 2)}
    assert len(ACTICAP_32) == 32
    return section


def run(quick: bool = False, full: bool = False,
        cpu_duration_s: float = CPU_DURATION_S) -> Dict[str, Dict]:
    """
    Run the SSVEP benchmarks; ``quick`` = the CPU part only (for smoke tests).

    :param cpu_duration_s: simulated seconds the CPU part decodes per set-up (``make
        bench``'s default run decodes fewer; the core fraction is per second decoded).
    """
    results = {}
    if not quick:
        results.update({f'accuracy: {k}': v for k, v in _accuracy(full).items()})
        for decoder in ('fbcca', 'ensemble_trca'):
            results.update({f'rounds {decoder}: {k}': v
                            for k, v in _rounds(full, decoder).items()})
    results.update({f'cpu: {k}': v for k, v in _cpu(full, cpu_duration_s).items()})
    return results


def format_lines(section: Dict[str, Dict]) -> List[str]:
    """One line per row."""
    return [f'{name:<34} ' + ', '.join(f'{k} {v}' for k, v in row.items())
            for name, row in section.items()]


def main(argv=None) -> int:
    """Run and print; ``--full`` for more trials, ``--json PATH`` to save."""
    parser = argparse.ArgumentParser(prog='bench.ssvep', description=__doc__.split('\n')[1])
    parser.add_argument('--full', action='store_true', help='more trials and rounds')
    parser.add_argument('--quick', action='store_true', help='CPU part only')
    parser.add_argument('--json', default='', help='write the results here')
    args = parser.parse_args(argv)
    started = time.perf_counter()
    results = run(quick=args.quick, full=args.full)
    report(format_lines(results), results, started, args.json)
    return 0


if __name__ == '__main__':
    sys.exit(main())
