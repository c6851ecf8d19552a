"""
The stimulus map: which flicker (frequency, phase) each offered option has.

The task (menu / scene) assigns every option a stimulus and publishes the
map; the stimulus window draws it and the decoder scores it.

Message (topic ``ssvep/stimuli``, latched, sensor_msgs/JointState, read
"one joint per option"):

- ``name[i]``: the option's label, exactly as on ``choices/regions`` (the
  marker's text, else ``ns/id``);
- ``position[i]``: its flicker frequency, Hz (0 < f < 100);
- ``velocity[i]``: its phase, rad, at the epoch;
- ``effort``: empty;
- ``header.stamp``: the epoch, ROS time at which every option's flicker has
  phase ``velocity[i]`` (frame 0 of the stimulus; zero = "when received");
- ``header.frame_id``: ``screen``.

Every option's luminance at display frame k (counted from the epoch) is
the sampled sinusoid ``L(k) = 0.5 (1 + sin(2 pi f k / refresh + phase))``
(Manyakov et al. 2013 / Chen et al. 2015 sampled sinusoidal stimulation).

:func:`encode_stimulus_map` / :func:`decode_stimulus_map` are the one place
where the message fields are built and checked; the node side only copies
them into / out of the JointState.
"""

from dataclasses import dataclass
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

#: Frequencies the task assigns by default, Hz: 1 Hz apart, above the alpha band
#: (8-12 Hz: an alpha rhythm at an option's frequency looks like its SSVEP to any
#: decoder, and options in it decode near chance for people like those of real
#: recordings, docs/ssvep.md) and clear of the filter bank's 8 Hz lower edge by more
#: than two sidebands; no option a harmonic of another (26 Hz > 20 Hz); all below
#: 30 Hz, half of a 60 Hz display's refresh.
DEFAULT_FREQUENCIES = (13.0, 14.0, 15.0, 16.0, 17.0, 18.0, 19.0, 20.0)
#: Phase step between neighbouring options, rad (JFPM, Chen et al. 2015: 0.35 pi).
DEFAULT_PHASE_STEP = 0.35 * math.pi
#: Highest stimulus frequency accepted, Hz.
MAX_FREQUENCY_HZ = 100.0


@dataclass(frozen=True)
class StimulusMap:
    """
    Stimuli of the offered options.

    :param labels: option labels, unique, (K,).
    :param frequencies: Hz, (K,).
    :param phases: rad, (K,), at the epoch.
    :param epoch_s: ROS time of the epoch, s (0 = unknown: take arrival).
    """

    labels: Tuple[str, ...]
    frequencies: Tuple[float, ...]
    phases: Tuple[float, ...]
    epoch_s: float = 0.0

    def stimulus(self, label: str) -> Tuple[float, float]:
        """Return (frequency Hz, phase rad) of ``label``."""
        index = self.labels.index(label)
        return self.frequencies[index], self.phases[index]

    def mismatch(self, option_labels: Sequence[str]) -> Optional[str]:
        """
        Say how the map does not fit the offered options, or None when it does.

        Every offered option needs a stimulus; stimuli of options not offered
        are ignored by the decoder (the map may cover a whole menu).
        """
        missing = [label for label in option_labels if label not in self.labels]
        if missing:
            return (f"no stimulus for offered option(s) {', '.join(map(repr, missing))} "
                    f"(the stimulus map has {', '.join(map(repr, self.labels)) or 'none'})")
        return None


def assign_stimuli(labels: Sequence[str], frequencies: Sequence[float] = DEFAULT_FREQUENCIES,
                   phase_step: float = DEFAULT_PHASE_STEP, epoch_s: float = 0.0) -> StimulusMap:
    """
    Give each option a frequency and phase (joint frequency-phase modulation).

    :param labels: option labels in display order.
    :param frequencies: frequencies to use in order, Hz; at least one per option.
    :param phase_step: phase increment per option, rad.
    :param epoch_s: ROS time of the stimulus epoch, s.
    """
    if len(labels) > len(frequencies):
        raise ValueError(f'{len(labels)} options but only {len(frequencies)} stimulus '
                         f'frequencies')
    phases = [(index * phase_step) % (2 * math.pi) for index in range(len(labels))]
    return decode_stimulus_map(list(labels), list(frequencies[:len(labels)]), phases, epoch_s)


def encode_stimulus_map(stimuli: StimulusMap) -> Tuple[List[str], List[float], List[float],
                                                       float]:
    """
    Message fields of a map: (name, position = Hz, velocity = rad, stamp s).

    :raises ValueError: when the map itself is invalid.
    """
    checked = decode_stimulus_map(list(stimuli.labels), list(stimuli.frequencies),
                                  list(stimuli.phases), stimuli.epoch_s)
    return (list(checked.labels), list(checked.frequencies), list(checked.phases),
            checked.epoch_s)


def decode_stimulus_map(names: Sequence[str], frequencies: Sequence[float],
                        phases: Sequence[float], epoch_s: float = 0.0) -> StimulusMap:
    """
    Read and check the message fields of a stimulus map.

    :param names: JointState.name, option labels.
    :param frequencies: JointState.position, Hz.
    :param phases: JointState.velocity, rad (empty = all 0).
    :param epoch_s: header.stamp, s.
    :raises ValueError: with a reason a user can act on.
    """
    names = [str(name) for name in names]
    frequencies = [float(f) for f in frequencies]
    phases = [float(p) for p in phases] if len(phases) else [0.0] * len(names)
    if not names:
        raise ValueError('the stimulus map lists no option (name is empty)')
    if len(frequencies) != len(names) or len(phases) != len(names):
        raise ValueError(f'the stimulus map has {len(names)} names but {len(frequencies)} '
                         f'frequencies (position) and {len(phases)} phases (velocity)')
    if any(not name for name in names):
        raise ValueError('the stimulus map has an option with an empty name')
    duplicates = sorted({name for name in names if names.count(name) > 1})
    if duplicates:
        raise ValueError(f"the stimulus map names {', '.join(map(repr, duplicates))} twice")
    bad = [f'{n}: {f:g} Hz' for n, f in zip(names, frequencies)
           if not (math.isfinite(f) and 0.0 < f < MAX_FREQUENCY_HZ)]
    if bad:
        raise ValueError(f'stimulus frequencies must be in (0, {MAX_FREQUENCY_HZ:g}) Hz: '
                         f"{', '.join(bad)}")
    if not all(math.isfinite(p) for p in phases):
        raise ValueError('stimulus phases must be finite numbers of rad')
    seen = {}
    for name, frequency, phase in zip(names, frequencies, phases):
        key = (round(frequency, 6), round(phase % (2 * math.pi), 6))
        if key in seen:
            raise ValueError(f"options '{seen[key]}' and '{name}' have the same stimulus "
                             f'({frequency:g} Hz, {phase:g} rad): the decoder cannot tell '
                             f'them apart')
        seen[key] = name
    if not (math.isfinite(epoch_s) and epoch_s >= 0.0):
        raise ValueError(f'the stimulus epoch must be a time >= 0 s, got {epoch_s}')
    return StimulusMap(tuple(names), tuple(frequencies), tuple(phases), float(epoch_s))


def luminance(frames: np.ndarray, frequencies: np.ndarray, phases: np.ndarray,
              refresh_hz: float) -> np.ndarray:
    """
    Sampled-sinusoid luminance of each stimulus at display frames.

    :param frames: frame indices k from the epoch, shape (N,).
    :param frequencies: Hz, shape (K,); must be below refresh_hz / 2.
    :param phases: rad, shape (K,).
    :param refresh_hz: display refresh rate, Hz.
    :returns: L in [0, 1], shape (N, K).
    """
    frames = np.asarray(frames, dtype=float).reshape(-1)
    frequencies = np.asarray(frequencies, dtype=float).reshape(-1)
    phases = np.asarray(phases, dtype=float).reshape(-1)
    if not refresh_hz > 0:
        raise ValueError(f'refresh rate must be > 0 Hz, got {refresh_hz}')
    if np.any(frequencies >= 0.5 * refresh_hz):
        raise ValueError(f'stimulus frequencies {frequencies.tolist()} Hz must be below half '
                         f'the refresh rate ({0.5 * refresh_hz:g} Hz)')
    return 0.5 * (1.0 + np.sin(2 * np.pi * frequencies[None, :] * frames[:, None] / refresh_hz
                               + phases[None, :]))
