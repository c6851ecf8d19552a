"""Amplifier layouts and the choice of occipital channels."""

import pytest

from eye_bci_ros2.ssvep.layouts import (electrode_position, LAYOUTS, parse_channels,
                                        resolve_channels, stream_name_matches)


def test_openbci_gui_without_labels_uses_the_ultracortex_positions():
    indices, names = resolve_channels(LAYOUTS['openbci_gui'], [''] * 8, 8)
    assert (indices, names) == ([6, 7], ['O1', 'O2'])


def test_unicorn_eeg_channels_by_position():
    layout = LAYOUTS['unicorn']
    indices, names = resolve_channels(layout, layout.channel_labels, 17)
    assert names == ['Oz', 'PO7', 'PO8']
    assert indices == [6, 5, 7]
    assert resolve_channels(layout, layout.channel_labels, 17, ['EEG 7'])[0] == [6]


def test_liveamp_by_label_case_insensitive_and_by_index():
    layout = LAYOUTS['liveamp']
    indices, names = resolve_channels(layout, layout.channel_labels, 32, ['oz', '15', 'O2'])
    assert names == ['Oz', 'O1', 'O2']
    assert indices == [16, 15, 17]


def test_missing_channels_are_named_with_what_the_stream_has():
    with pytest.raises(ValueError, match=r"'Oz'.*not in the stream.*0:Fp1"):
        resolve_channels(LAYOUTS['generic'], ['Fp1', 'Fp2'], 2, ['Oz'])
    with pytest.raises(ValueError, match='index 9'):
        resolve_channels(LAYOUTS['generic'], ['Fp1', 'Fp2'], 2, ['9'])
    with pytest.raises(ValueError, match='no occipital channel'):
        resolve_channels(LAYOUTS['generic'], ['', ''], 2)
    with pytest.raises(ValueError, match='twice'):
        resolve_channels(LAYOUTS['generic'], ['Oz', 'O1'], 2, ['Oz', '0'])


def test_channel_parameter_and_stream_names():
    assert parse_channels(' O1, Oz ,3') == ['O1', 'Oz', '3']
    assert parse_channels('') == []
    with pytest.raises(ValueError, match='empty entry'):
        parse_channels('O1,,Oz')
    assert stream_name_matches(LAYOUTS['liveamp'], 'LiveAmpSN-054211-0237')
    assert not stream_name_matches(LAYOUTS['openbci_gui'], 'obci_eeg2')
    assert stream_name_matches(LAYOUTS['openbci_gui'], 'mine', 'mine')
    assert stream_name_matches(LAYOUTS['generic'], 'anything')


def test_edf_style_labels_resolve_to_their_electrode():
    """``EEG Oz-REF`` (EDF, many amplifier apps), ``O1-A1``, ``EEG PO3`` name positions."""
    labels = ['EEG Fp1-REF', 'EEG O1-A1', 'EEG Oz-REF', 'O2:Ref', 'EEG POz', 'ECG',
              'Accelerometer X', 'EEG 1']
    indices, names = resolve_channels(LAYOUTS['generic'], labels, len(labels))
    assert names == ['O1', 'Oz', 'O2', 'POz'] and indices == [1, 2, 3, 4]
    indices, names = resolve_channels(LAYOUTS['generic'], labels, len(labels), ['oz', 'Fp1'])
    assert indices == [2, 0] and names == ['Oz', 'Fp1']
    assert electrode_position('EEG 1') == '' and electrode_position('Counter') == ''
