"""
EEG stream layouts of the common amplifiers' LSL applications, and channel choice.

Each :class:`EegLayout` says what an application advertises on LSL (stream
type, name, rate, channel count, labels) and where its EEG channels are.
:func:`resolve_channels` picks the channels a decoder reads (by label, e.g.
the occipital O1, Oz, O2, POz, PO3, PO4, or by 0-based index) from what a
stream actually carries, or says why it cannot.

Layouts (what the applications send; units microvolts):

- ``openbci_gui``: the OpenBCI GUI's Networking widget, LSL "TimeSeriesRaw"
  (or Filt): name ``obci_eeg1``, type ``EEG``, 8 channels (Cyton; 16 with
  Daisy, 4 Ganglion), 250 Hz, float32, *no channel labels*.  The electrodes
  are assumed to sit at the Ultracortex Mark IV default positions Fp1, Fp2,
  C3, C4, P7, P8, O1, O2 (channels 1-8); set ``channels`` by index otherwise.
  The Cyton's ADC rails at +-187500 uV.
- ``unicorn``: g.tec Unicorn Hybrid Black (Unicorn LSL app): name
  ``Unicorn``, 17 channels at 250 Hz: 8 EEG (``EEG 1`` .. ``EEG 8`` at the
  default positions Fz, C3, Cz, C4, Pz, PO7, Oz, PO8), accelerometer X/Y/Z,
  gyroscope X/Y/Z, battery, counter, validation.  App versions differ in the
  advertised type; the default selection accepts any type with that name.
- ``liveamp``: Brain Products LiveAmp (BrainVision LSL connector): name
  ``LiveAmpSN-<serial>``, type ``EEG``, channels labelled by the cap
  (actiCAP 32: Fp1 ... O1, Oz, O2 ...), 250/500/1000 Hz (500 here), optional
  ``ACC_X/Y/Z`` channels after the EEG.
- ``generic``: any EEG stream; channels by the stream's labels or by index.
"""

from dataclasses import dataclass
import re
from typing import List, Optional, Sequence, Tuple

#: Channels an SSVEP decoder reads by default, the ones found are used.
DEFAULT_OCCIPITAL = ('O1', 'Oz', 'O2', 'POz', 'PO3', 'PO4', 'PO7', 'PO8')

#: A channel label that names an electrode in the common styles: ``Oz``, ``EEG Oz``,
#: ``EEG Oz-REF`` / ``Oz-A1`` / ``Oz:Ref`` (EDF and many amplifier applications write the
#: signal type before and the reference after the position); group 1 is the position.
_POSITION_LABEL = re.compile(r'(?:eeg[\s_:]*)?([a-z]{1,3}(?:z|\d{1,2}))(?:\s*[-:/]\s*\w+)?',
                             re.IGNORECASE)

#: Selection wildcard for stream type or name.
ANY = '*'

#: actiCAP 32-channel montage, the LiveAmp connector's default channel labels.
ACTICAP_32 = ('Fp1', 'Fz', 'F3', 'F7', 'FT9', 'FC5', 'FC1', 'C3', 'T7', 'TP9', 'CP5', 'CP1',
              'Pz', 'P3', 'P7', 'O1', 'Oz', 'O2', 'P4', 'P8', 'TP10', 'CP6', 'CP2', 'Cz',
              'C4', 'T8', 'FT10', 'FC6', 'FC2', 'F4', 'F8', 'Fp2')


@dataclass(frozen=True)
class EegLayout:
    """
    What an EEG application advertises on LSL.

    :param name: layout name (parameter value).
    :param stream_type: LSL type it sends (``ANY`` = do not check).
    :param stream_name: LSL name, or its prefix when ``name_is_prefix``.
    :param nominal_srate: rate it advertises, Hz (the simulator's default).
    :param channel_labels: labels it writes, or assumes by position when
        ``labelled`` is False; all channels, EEG and others.
    :param eeg_positions: electrode position (10-20 label) of each channel
        that carries EEG, in channel order; None = the label itself.
    :param labelled: whether the stream's description carries the labels.
    :param rail_uv: amplitude at which the amplifier saturates, uV; 0 =
        unknown (the decoder then spots clipping as a run of identical
        samples far from zero: set ``rail_uv`` when the amplifier's range is known,
        e.g. 500 for a g.Mobilab+'s +-500 uV).
    """

    name: str
    stream_type: str
    stream_name: str
    nominal_srate: float
    channel_labels: Tuple[str, ...]
    eeg_positions: Optional[Tuple[str, ...]] = None
    labelled: bool = True
    name_is_prefix: bool = False
    rail_uv: float = 187500.0

    def positions(self, labels: Sequence[str]) -> List[str]:
        """
        Electrode position of each channel of a stream in this layout.

        :param labels: the stream's labels ('' where none), one per channel.
        :returns: a position label per channel ('' when not EEG or unknown).
        """
        positions = list(labels)
        if self.eeg_positions is not None:
            positions = list(self.eeg_positions[:len(labels)])
            positions += [''] * (len(labels) - len(positions))
        elif not any(labels):
            positions = list(self.channel_labels[:len(labels)])
            positions += [''] * (len(labels) - len(positions))
        return positions


_UNICORN_LABELS = tuple(f'EEG {i}' for i in range(1, 9)) + (
    'Accelerometer X', 'Accelerometer Y', 'Accelerometer Z', 'Gyroscope X', 'Gyroscope Y',
    'Gyroscope Z', 'Battery Level', 'Counter', 'Validation Indicator')

LAYOUTS = {
    'openbci_gui': EegLayout(
        'openbci_gui', 'EEG', 'obci_eeg1', 250.0,
        ('Fp1', 'Fp2', 'C3', 'C4', 'P7', 'P8', 'O1', 'O2'), labelled=False),
    'unicorn': EegLayout(
        'unicorn', ANY, 'Unicorn', 250.0, _UNICORN_LABELS,
        eeg_positions=('Fz', 'C3', 'Cz', 'C4', 'Pz', 'PO7', 'Oz', 'PO8'), rail_uv=750000.0),
    'liveamp': EegLayout(
        'liveamp', 'EEG', 'LiveAmpSN-', 500.0, ACTICAP_32, name_is_prefix=True,
        rail_uv=341000.0),
    'generic': EegLayout('generic', 'EEG', ANY, 250.0, (), rail_uv=0.0),
}

#: Layout names, for parameter choices.
LAYOUT_NAMES = tuple(LAYOUTS)


def electrode_position(label: str) -> str:
    """
    Return the electrode position a channel label names, or '' when it names none.

    ``'EEG Oz-REF'`` -> ``'Oz'``, ``'O1-A1'`` -> ``'O1'``, ``'Oz'`` -> ``'Oz'``,
    ``'EEG 1'`` / ``'Accelerometer X'`` -> ``''``.
    """
    match = _POSITION_LABEL.fullmatch(str(label).strip())
    return match.group(1) if match else ''


def stream_name_matches(layout: EegLayout, name: str, wanted: str = '') -> bool:
    """Tell whether an LSL stream name fits ``wanted`` ('' = the layout's name)."""
    if wanted == ANY:
        return True
    if not wanted:
        if layout.name_is_prefix:
            return name.startswith(layout.stream_name)
        return layout.stream_name in (ANY, name)
    return name == wanted


def parse_channels(text: str) -> List[str]:
    """
    Split a ``channels`` parameter: labels or 0-based indices, comma separated.

    :returns: the tokens, stripped; [] for '' (the default occipital set).
    :raises ValueError: for an empty entry.
    """
    if not str(text).strip():
        return []
    tokens = [token.strip() for token in str(text).split(',')]
    if any(not token for token in tokens):
        raise ValueError(f"'{text}' has an empty entry; separate labels or indices by "
                         f'single commas')
    return tokens


def resolve_channels(layout: EegLayout, labels: Sequence[str], channel_count: int,
                     wanted: Sequence[str] = ()) -> Tuple[List[int], List[str]]:
    """
    Choose the channels to decode from a stream.

    :param layout: the application's layout.
    :param labels: the stream's channel labels ('' or missing where none).
    :param channel_count: channels the stream carries.
    :param wanted: labels (case-insensitive, matched against the electrode
        positions, the raw labels and the position a label such as
        ``EEG Oz-REF`` names, :func:`electrode_position`) or 0-based indices; empty = every
        channel of :data:`DEFAULT_OCCIPITAL` the stream has.
    :returns: ``(indices, names)``: 0-based channel indices and their names.
    :raises ValueError: with what is missing and what the stream has.
    """
    labels = list(labels)[:channel_count]
    labels += [''] * (channel_count - len(labels))
    positions = layout.positions(labels)
    lookup = {}
    for index, (raw, position) in enumerate(zip(labels, positions)):
        for key in (raw, position, electrode_position(raw)):
            if key:
                lookup.setdefault(key.lower(), index)
    known = ', '.join(f'{i}:{p or r or "?"}' for i, (r, p) in enumerate(zip(labels, positions)))
    if not wanted:
        indices = [lookup[name.lower()] for name in DEFAULT_OCCIPITAL if name.lower() in lookup]
        if not indices:
            raise ValueError(
                f"no occipital channel ({', '.join(DEFAULT_OCCIPITAL)}) among the stream's "
                f'channels ({known or "no labels"}); set channels by label or 0-based index')
    else:
        indices, missing = [], []
        for token in wanted:
            if token.lstrip('-').isdigit():
                index = int(token)
                if not 0 <= index < channel_count:
                    missing.append(f'index {index} (the stream has {channel_count} channels)')
                    continue
            elif token.lower() in lookup:
                index = lookup[token.lower()]
            else:
                missing.append(f"'{token}'")
                continue
            indices.append(index)
        if missing:
            raise ValueError(f"channels {', '.join(missing)} not in the stream "
                             f'(its channels: {known or "no labels"})')
    if len(set(indices)) != len(indices):
        raise ValueError(f'channels {list(wanted)} name the same channel twice')
    names = [electrode_position(positions[i]) or positions[i] or labels[i] or str(i)
             for i in indices]
    return indices, names
