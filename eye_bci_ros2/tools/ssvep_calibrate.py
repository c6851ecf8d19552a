"""
``ssvep_calibrate``: record a cue-guided SSVEP calibration and fit a TRCA model.

The person attends each option ``--trials`` times in a seeded random order,
mixed with ``--rest-trials`` rest trials (the stimuli shown, the person looks
at a fixation point): each trial starts its stimuli at the onset (frame 0 at
the onset, the map's phases), lasts ``--onset-s`` (the gaze reaching the
option, the response building up: not learnt, as the decoder leaves it out
of its windows) plus ``--trial-s`` (the template) and is followed by
``--rest-s`` of rest.  The model keeps a rest model (its scores when nobody
attends an option) against which the decoder weighs the evidence, and the
tool refuses a calibration whose trials do not repeat: TRCA needs stimuli
whose phase is the same at each onset (a screen stimulus drawn frame by
frame from the onset, as ``ssvep_stimulus`` draws them), not free-running
flicker such as LEDs (use ``decoder:=fbcca`` for those).  The
model (.npz) is what ``ssvep_decoder`` loads with ``decoder:=ensemble_trca
model_file:=...``; it remembers the options, their stimuli, the rate, the
channels and the filter settings, and the decoder refuses a stream or a
stimulus map that does not match them.

Sources:

- ``--source sim``: the simulated amplifier directly (no LSL), seconds of work;
- ``--source lsl``: a real LSL EEG stream (``--stream-name`` / ``--source-id``,
  ``--layout``, ``--channels``), recorded in real time while the tool cues
  the trials (it prints ``attend <label>`` at each onset, for a person, and
  with ``--drive-sim`` it starts a simulated outlet itself and makes its
  simulated person attend the cued option).

The stimulus display is not driven by this tool: with a real person, show
the map printed at the start (``ssvep/stimuli``) and restart its epoch at
each cue.

Example::

    ssvep_calibrate --options kitchen,bedroom,bathroom --trials 6 --output model.npz
"""

import argparse
import os
import sys
import tempfile
import time
from typing import List, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.ros.startup import quiet_liblsl
from eye_bci_ros2.sim.eeg import calibration_session, EegSimulator, SUBJECTS
from eye_bci_ros2.ssvep.layouts import LAYOUT_NAMES, LAYOUTS, parse_channels, resolve_channels
from eye_bci_ros2.ssvep.online import DEFAULT_ONSET_S
from eye_bci_ros2.ssvep.stimuli import assign_stimuli, StimulusMap
from eye_bci_ros2.ssvep.training import fit_trca

#: Exit status for a user error (bad options, unusable recordings).
EXIT_BAD_INPUT = 2
#: Exit status when an output file cannot be written: before recording (nothing recorded),
#: or after it (the result is then in a fallback file, named in one line).
EXIT_WRITE_FAILED = 1


def build_parser() -> argparse.ArgumentParser:
    """Command line of ``ssvep_calibrate``."""
    parser = argparse.ArgumentParser(prog='ssvep_calibrate', description=__doc__.split('\n')[1])
    parser.add_argument('--options', required=True, help='option labels, comma separated '
                        '(stimuli assigned in order, as the task assigns them)')
    parser.add_argument('--trials', type=int, default=5, help='trials per option (>= 2)')
    parser.add_argument('--rest-trials', type=int, default=-1,
                        help='rest trials (the stimuli shown, the person looks at a fixation '
                        'point): what the model learns "nobody attends" from (default: '
                        "--trials; 0 = only the other options' trials)")
    parser.add_argument('--trial-s', type=float, default=2.0)
    parser.add_argument('--rest-s', type=float, default=1.0)
    parser.add_argument('--onset-s', type=float, default=DEFAULT_ONSET_S,
                        help="time from each onset the template leaves out, s (the decoder's "
                        'onset_s)')
    parser.add_argument('--output', required=True, help='model file (.npz)')
    parser.add_argument('--source', choices=('sim', 'lsl'), default='sim')
    parser.add_argument('--layout', choices=LAYOUT_NAMES, default='generic')
    parser.add_argument('--channels', default='', help="labels or indices ('' = occipital)")
    parser.add_argument('--subject', default='s4', choices=[s.name for s in SUBJECTS],
                        help='simulated subject (sim source, --drive-sim)')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--stream-name', default='', help="lsl: stream name ('' = layout's)")
    parser.add_argument('--source-id', default='', help='lsl: source_id')
    parser.add_argument('--drive-sim', action='store_true',
                        help='lsl: start a simulated outlet and make it attend the cues')
    parser.add_argument('--notch-hz', type=float, default=50.0)
    parser.add_argument('--save-recording', default='',
                        help='also save the raw calibration recording here (.npz)')
    parser.add_argument('--recordings', default='',
                        help='fit from these saved recordings (comma separated, from '
                        '--save-recording of earlier sessions) instead of recording now')
    parser.add_argument('--single', action='store_true',
                        help='save for plain TRCA scoring (default ensemble)')
    return parser


def record_simulated(args, stimuli: StimulusMap):
    """Record with the simulator directly: (times, samples, trials, rate, labels)."""
    subject = next(s for s in SUBJECTS if s.name == args.subject)
    simulator = EegSimulator(subject, args.layout, seed=args.seed)
    times, samples, trials = calibration_session(simulator, stimuli, args.trials,
                                                 args.onset_s + args.trial_s, args.rest_s,
                                                 args.seed,
                                                 rest_trials=args.rest_trials)
    return times, samples, trials, simulator.rate, list(simulator.labels)


def record_lsl(args, stimuli: StimulusMap):
    """Record a real LSL stream while cueing: (times, samples, trials, rate, labels)."""
    import pylsl  # only this source needs liblsl

    from eye_bci_ros2.sim.eeg_outlet import EegStreamer
    streamer = None
    source_id = args.source_id
    if args.drive_sim:
        subject = next(s for s in SUBJECTS if s.name == args.subject)
        source_id = source_id or f'ssvep_calibrate-{time.time_ns()}'
        streamer = EegStreamer(EegSimulator(subject, args.layout, seed=args.seed),
                               source_id=source_id).start()
    try:
        predicate = f"source_id='{source_id}'" if source_id else "type='EEG'"
        found = pylsl.resolve_bypred(predicate, 1, 10.0)
        layout = LAYOUTS[args.layout]
        found = [info for info in found if not args.stream_name
                 or info.name() == args.stream_name]
        if not found:
            raise ValueError(f'no EEG LSL stream found ({predicate})')
        inlet = pylsl.StreamInlet(found[0], max_buflen=60)
        info = inlet.info(timeout=5.0)
        labels = []
        channel = info.desc().child('channels').child('channel')
        while not channel.empty():
            labels.append(channel.child_value('label'))
            channel = channel.next_sibling('channel')
        labels += [''] * (info.channel_count() - len(labels))
        layout.positions(labels)
        offset = inlet.time_correction(timeout=5.0)
        order = np.repeat(np.arange(len(stimuli.labels) + 1),
                          [args.trials] * len(stimuli.labels) + [args.rest_trials])
        np.random.default_rng(args.seed).shuffle(order)
        times: List[np.ndarray] = []
        chunks: List[np.ndarray] = []
        trials: List[Tuple[float, Optional[str]]] = []

        def pull_until(deadline: float) -> None:
            while pylsl.local_clock() < deadline:
                samples, stamps = inlet.pull_chunk(timeout=0.05, max_samples=4096)
                if stamps:
                    times.append(np.asarray(stamps) + offset)
                    chunks.append(np.asarray(samples, dtype=float))

        pull_until(pylsl.local_clock() + args.rest_s)
        for target in order:
            label = stimuli.labels[target] if target < len(stimuli.labels) else None
            onset = pylsl.local_clock()
            print(f'attend {label}' if label else 'rest: look at the fixation point, at no '
                  'option', flush=True)
            if streamer is not None:
                streamer.show(StimulusMap(stimuli.labels, stimuli.frequencies,
                                          stimuli.phases, onset))
                streamer.attend(label, onset)
            trials.append((onset, label))
            pull_until(onset + args.onset_s + args.trial_s)
            if streamer is not None:
                streamer.attend(None)
            pull_until(pylsl.local_clock() + args.rest_s)
        return (np.concatenate(times), np.concatenate(chunks), trials, info.nominal_srate(),
                labels)
    finally:
        if streamer is not None:
            streamer.stop()


def npz_path(path: str) -> str:
    """Return the file ``np.savez`` writes for ``path`` (it adds ``.npz`` when missing)."""
    return path if path.endswith('.npz') else path + '.npz'


def unwritable(path: str) -> Optional[str]:
    """
    Return why ``path`` cannot be written (one line), or None when it can.

    Tried for real (opened for appending, a new file removed again), so a missing or
    read-only directory, a directory of that name or a full disk are all caught.
    """
    existed = os.path.exists(path)
    try:
        with open(path, 'ab'):
            pass
    except OSError as error:
        return f"cannot write '{path}': {error.strerror or error}"
    if not existed:
        os.remove(path)
    return None


def fallback_path(path: str) -> str:
    """Return where a file meant for ``path`` goes when ``path`` fails: the temp dir, stamped."""
    stamp = time.strftime('%Y%m%d-%H%M%S')
    return os.path.join(tempfile.gettempdir(),
                        f'ssvep_calibrate-{stamp}-{os.getpid()}-{os.path.basename(path)}')


def save_or_fallback(path: str, save, what: str) -> str:
    """
    Write with ``save(path)``; when that fails, write to :func:`fallback_path` instead.

    :param what: what is saved, for the one line said on stderr.
    :returns: the file written.
    :raises OSError: when the fallback cannot be written either.
    """
    try:
        save(path)
        return npz_path(path)
    except OSError as error:
        fallback = npz_path(fallback_path(npz_path(path)))
        save(fallback)
        print(f"ssvep_calibrate: cannot write '{npz_path(path)}' "
              f'({error.strerror or error}): {what} saved to {fallback} instead',
              file=sys.stderr, flush=True)
        return fallback


def save_recording(path: str, times, samples, trials, rate: float, labels) -> None:
    """Write a calibration recording (.npz, no pickles); rest trials have label ''."""
    np.savez(path, times=np.asarray(times, float), samples=np.asarray(samples, float),
             onsets=np.array([t for t, _ in trials], float),
             labels=np.array([label or '' for _, label in trials], dtype=str),
             rate=float(rate), channels=np.array(labels, dtype=str))


def load_recordings(paths: Sequence[str]):
    """Read saved recordings of one set-up: (times, samples, trials lists, rate, labels)."""
    times, samples, trials, rate, labels = [], [], [], None, None
    for path in paths:
        try:
            with np.load(path, allow_pickle=False) as data:
                times.append(data['times'])
                samples.append(data['samples'])
                trials.append([(float(t), str(label) or None)
                               for t, label in zip(data['onsets'], data['labels'])])
                these = (float(data['rate']), data['channels'].tolist())
        except (OSError, KeyError, ValueError, EOFError) as error:
            raise ValueError(f"cannot read calibration recording '{path}': {error}") from None
        if rate is not None and these != (rate, labels):
            raise ValueError(f"'{path}' was recorded at {these[0]:g} Hz from channels "
                             f"{', '.join(these[1])}, the first at {rate:g} Hz from "
                             f"{', '.join(labels)}: one model needs one set-up")
        rate, labels = these
    return times, samples, trials, rate, labels


def main(argv: Optional[Sequence[str]] = None) -> int:
    """
    Run the calibration; 0 on success, 2 on a user error, 1 when an output is unwritable.

    An output that cannot be written is refused before anything is recorded; one that
    fails afterwards is saved to a fallback file (named in one line), so a session is
    never lost.
    """
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    args = build_parser().parse_args(argv)
    for path in filter(None, (args.output, args.save_recording)):
        problem = unwritable(npz_path(path))
        if problem:
            print(f'ssvep_calibrate: {problem}; nothing recorded', file=sys.stderr)
            return EXIT_WRITE_FAILED
    written = {}
    try:
        options = [label.strip() for label in args.options.split(',') if label.strip()]
        if args.trials < 2:
            raise ValueError('--trials must be at least 2 (TRCA needs 2 trials per option)')
        if args.rest_trials < 0:
            args.rest_trials = args.trials
        stimuli = assign_stimuli(options)
        print('stimuli: ' + ', '.join(f'{lb} {f:g} Hz {p:.2f} rad' for lb, f, p in zip(
            stimuli.labels, stimuli.frequencies, stimuli.phases)), flush=True)
        if args.recordings:
            times, samples, trials, rate, labels = load_recordings(
                [p.strip() for p in args.recordings.split(',') if p.strip()])
        else:
            record = record_simulated if args.source == 'sim' else record_lsl
            times, samples, trials, rate, labels = record(args, stimuli)
            if args.save_recording:
                recorded = (times, samples, trials, rate, labels)
                written['recording'] = save_or_fallback(
                    args.save_recording, lambda path: save_recording(path, *recorded),
                    'the recording')
            times, samples, trials = [times], [samples], [trials]
        indices, names = resolve_channels(LAYOUTS[args.layout], labels, samples[0].shape[1],
                                          parse_channels(args.channels))
        model = fit_trca([x[:, indices] for x in samples], times, trials, stimuli, rate,
                         names, args.trial_s, notch_hz=args.notch_hz, onset_s=args.onset_s,
                         ensemble=not args.single)
        written['model'] = save_or_fallback(args.output, model.save, 'the model')
    except ValueError as error:
        print(f'ssvep_calibrate: {error}', file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as error:
        print(f'ssvep_calibrate: cannot write the fallback file either: {error}',
              file=sys.stderr)
        return EXIT_WRITE_FAILED
    count = sum(label is not None for listed in trials for _, label in listed)
    print(f'saved TRCA model of {len(options)} options, {count} trials from {len(trials)} '
          f"recording(s) ({args.trial_s:g} s, channels {', '.join(names)}, {rate:g} Hz) to "
          f"{written['model']}")
    asked = {'model': args.output, 'recording': args.save_recording}
    return 0 if all(path == npz_path(asked[key]) for key, path in written.items()) \
        else EXIT_WRITE_FAILED


if __name__ == '__main__':
    sys.exit(main())
