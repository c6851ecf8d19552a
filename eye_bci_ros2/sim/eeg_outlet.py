"""
Stream simulated EEG over Lab Streaming Layer, laid out like a real amplifier's app.

A real ``pylsl.StreamOutlet`` with the stream type, name, channel count,
labels (or none, as the OpenBCI GUI), rate and float32 format of the chosen
layout (:mod:`eye_bci_ros2.ssvep.layouts`), fed from a background thread by
an :class:`eye_bci_ros2.sim.eeg.EegSimulator`.  Sample timestamps are their
acquisition times on ``pylsl.local_clock()``; the stimulus epoch and the
attention schedule are on the same clock.

Pure pylsl + numpy, runs without ROS::

    sim_eeg --layout openbci_gui --subject s4 --options kitchen,bedroom,bath
    sim_eeg --attend 0:kitchen,4:bath,8: --duration 12 --options kitchen,bath
"""

import argparse
import logging
import math
import sys
import time
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np
import pylsl

from eye_bci_ros2.ros.startup import quiet_liblsl
from eye_bci_ros2.sim.eeg import EegSimulator, REALISTIC_SUBJECTS, SUBJECTS
from eye_bci_ros2.sim.lsl_outlet import OutletThread, stream_info
from eye_bci_ros2.ssvep.layouts import ANY, LAYOUT_NAMES
from eye_bci_ros2.ssvep.stimuli import (assign_stimuli, DEFAULT_FREQUENCIES, DEFAULT_PHASE_STEP,
                                        StimulusMap)

_LOG = logging.getLogger(__name__)

#: Hook that may change a chunk before it is pushed (fault injection in tests):
#: ``(times (n,), samples (n, C)) -> samples``.
ChunkHook = Callable[[np.ndarray, np.ndarray], np.ndarray]


class EegStreamer(OutletThread):
    """
    A real LSL EEG outlet fed by a simulator from a background thread.

    :param simulator: the amplifier and person.
    :param name: stream name (default: the layout's, with ``SIM`` for a serial).
    :param source_id: LSL source id (give each test its own).
    :param chunk_ms: push period, ms (OpenBCI GUI and most apps: 10-40 ms).
    :param nominal_rate: advertised rate, Hz (default the simulator's; a wrong
        one plays a misconfigured app).
    :param on_push: optional :data:`ChunkHook`.
    """

    def __init__(self, simulator: EegSimulator, *, name: Optional[str] = None,
                 source_id: str = 'sim_eeg', chunk_ms: float = 20.0,
                 nominal_rate: Optional[float] = None, on_push: Optional[ChunkHook] = None):
        if not 1.0 <= chunk_ms <= 1000.0:
            raise ValueError(f'chunk_ms must be in [1, 1000], got {chunk_ms}')
        self.simulator = simulator
        layout = simulator.layout
        if name is None:
            name = layout.stream_name + ('SIM-0001' if layout.name_is_prefix else '')
            if name == ANY:
                name = 'sim_eeg'
        stream_type = 'EEG' if layout.stream_type == ANY else layout.stream_type
        rate = simulator.rate if nominal_rate is None else float(nominal_rate)
        # The channel description the layout's application writes (none for some).
        labels = simulator.labels if layout.labelled else ()
        info = stream_info(name, stream_type, len(simulator.labels), rate, source_id,
                           application=f'eye_bci_ros2 sim_eeg ({layout.name})',
                           labels=labels, unit='microvolts', types=['EEG'] * len(labels))
        info.desc().child('acquisition').append_child_value('subject', simulator.subject.name)
        super().__init__(info, chunk_ms / 1e3, 'EEG')
        self.on_push = on_push
        self.samples_pushed = 0
        self._pending: List[Tuple[str, object, Optional[float]]] = []

    def describe(self) -> str:
        """One line saying what is streamed."""
        sim = self.simulator
        return (f"LSL stream '{self.info.name()}' type '{self.info.type()}' source_id "
                f"'{self.info.source_id()}': {len(sim.labels)} ch float32 uV at "
                f'{self.info.nominal_srate():g} Hz ({sim.layout.name} layout), subject '
                f'{sim.subject.name} (SSVEP {sim.subject.ssvep_uv:g} uV at Oz)')

    def _begin(self, t0: float) -> None:
        """Start the amplifier at ``t0`` with what was set before start()."""
        self.simulator.start(t0, None)
        for kind, value, t in self._pending:
            self._apply(kind, value, t0 if t is None else max(t, t0))
        self._pending = []

    def _acquire(self, now: float) -> Tuple[np.ndarray, np.ndarray]:
        """Every sample acquired up to ``now``: times (n,), samples (n, C)."""
        return self.simulator.next_chunk(now)

    def _push(self, data: Tuple[np.ndarray, np.ndarray]) -> None:
        """Push one chunk (after the fault hook) with its acquisition stamps."""
        times, samples = data
        if len(times):
            if self.on_push is not None:
                samples = self.on_push(times, samples)
            self._outlet.push_chunk(np.asarray(samples, dtype=np.float32), times.tolist())
            self.samples_pushed += len(times)

    def show(self, stimuli: Optional[StimulusMap]) -> None:
        """Show a stimulus map; its ``epoch_s`` on ``pylsl.local_clock()`` (thread-safe)."""
        self._set('stimuli', stimuli, None)

    def attend(self, label: Optional[str], t: Optional[float] = None) -> None:
        """Attend option ``label`` (None = nothing) from ``t`` (LSL clock, default now)."""
        self._set('attend', label, t)

    def _set(self, kind: str, value, t: Optional[float]) -> None:
        with self._lock:
            if self._thread is None:
                self._pending.append((kind, value, t))
                return
            self._apply(kind, value, pylsl.local_clock() if t is None else t)

    def _apply(self, kind: str, value, t: float) -> None:
        if kind == 'stimuli':
            self.simulator.set_stimuli(value)
        else:
            self.simulator.set_attended(value, t)


def parse_attend(text: str) -> List[Tuple[float, Optional[str]]]:
    """
    Parse ``--attend``: ``t:label`` entries, comma separated (empty label = none).

    :raises ValueError: for a malformed entry.
    """
    schedule = []
    for entry in filter(None, (part.strip() for part in text.split(','))):
        time_text, sep, label = entry.partition(':')
        try:
            t = float(time_text)
        except ValueError:
            t = float('nan')
        if not sep or not t >= 0:
            raise ValueError(f"--attend entry '{entry}' is not 'seconds:label'")
        schedule.append((t, label.strip() or None))
    return sorted(schedule, key=lambda item: item[0])


def build_parser() -> argparse.ArgumentParser:
    """Command line of ``sim_eeg``."""
    parser = argparse.ArgumentParser(
        prog='sim_eeg', description='Stream simulated SSVEP EEG over LSL in the layout of a '
        'real amplifier application (no ROS needed).')
    parser.add_argument('--layout', default='generic', choices=LAYOUT_NAMES)
    parser.add_argument('--subject', default='s4',
                        choices=[s.name for s in SUBJECTS + REALISTIC_SUBJECTS],
                        help='s1-s8: clear responders; r1-r8: like real recordings (weak, '
                        'building up after a cue, with alpha)')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--rate', type=float, default=0.0, help='Hz (0 = the layout rate)')
    parser.add_argument('--options', default='option 1,option 2,option 3,option 4',
                        help='option labels, comma separated; stimuli are assigned in '
                        f"order ({', '.join(f'{f:g}' for f in DEFAULT_FREQUENCIES[:3])} ... "
                        f'Hz, phase steps {DEFAULT_PHASE_STEP / math.pi:g} pi), epoch at '
                        'start')
    parser.add_argument('--attend', default='0:option 1',
                        help="schedule 't:label,...' in s from the start ('t:' = none)")
    parser.add_argument('--line-hz', type=float, default=50.0)
    parser.add_argument('--railed', default='', help='channel labels stuck at full scale')
    parser.add_argument('--duration', type=float, default=0.0, help='s (0 = until Ctrl-C)')
    parser.add_argument('--source-id', default='sim_eeg')
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run ``sim_eeg`` until the duration ends or Ctrl-C."""
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO, format='%(message)s')
    try:
        options = [label.strip() for label in args.options.split(',') if label.strip()]
        schedule = parse_attend(args.attend)
        subject = next(s for s in SUBJECTS + REALISTIC_SUBJECTS if s.name == args.subject)
        railed = [label.strip() for label in args.railed.split(',') if label.strip()]
        simulator = EegSimulator(subject, args.layout, args.rate or None, seed=args.seed,
                                 railed=railed, line_hz=args.line_hz)
        streamer = EegStreamer(simulator, source_id=args.source_id)
        stimuli = assign_stimuli(options)
    except (ValueError, StopIteration) as error:
        print(f'sim_eeg: {error}', file=sys.stderr)
        return 2
    streamer.start()
    t0 = pylsl.local_clock()
    streamer.show(StimulusMap(stimuli.labels, stimuli.frequencies, stimuli.phases, t0))
    for t, label in schedule:
        streamer.attend(label, t0 + t)
    _LOG.info(streamer.describe())
    _LOG.info('stimuli: ' + ', '.join(f'{lb} {f:g} Hz {p:.2f} rad' for lb, f, p in zip(
        stimuli.labels, stimuli.frequencies, stimuli.phases)))
    try:
        while args.duration <= 0 or pylsl.local_clock() - t0 < args.duration:
            time.sleep(0.1)
            if streamer.error is not None:
                return 1
    except KeyboardInterrupt:
        pass
    finally:
        streamer.stop()
    return 0


if __name__ == '__main__':
    sys.exit(main())
