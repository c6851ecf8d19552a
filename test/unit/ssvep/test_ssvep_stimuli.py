"""The stimulus map message fields and the sampled-sinusoid luminance."""

import math

import numpy as np
import pytest

from eye_bci_ros2.ssvep.stimuli import (assign_stimuli, decode_stimulus_map, encode_stimulus_map,
                                        luminance)


def test_round_trip_and_assignment():
    stimuli = assign_stimuli(['kitchen', 'bath'], epoch_s=12.5)
    names, frequencies, phases, epoch = encode_stimulus_map(stimuli)
    # The defaults sit above the alpha band (8-12 Hz), 1 Hz apart.
    assert names == ['kitchen', 'bath'] and frequencies == [13.0, 14.0]
    assert phases == pytest.approx([0.0, 0.35 * math.pi]) and epoch == 12.5
    assert decode_stimulus_map(names, frequencies, phases, epoch) == stimuli
    assert stimuli.stimulus('bath') == (14.0, phases[1])


@pytest.mark.parametrize('fields, reason', [
    (([], [], []), 'no option'),
    ((['a', 'b'], [8.0], [0.0, 0.0]), '2 names but 1 frequencies'),
    ((['a', 'a'], [8.0, 9.0], [0, 0]), "'a' twice"),
    ((['a', ''], [8.0, 9.0], [0, 0]), 'empty name'),
    ((['a', 'b'], [8.0, -1.0], [0, 0]), r'b: -1 Hz'),
    ((['a', 'b'], [8.0, float('nan')], [0, 0]), 'must be in'),
    ((['a', 'b'], [8.0, 8.0], [0.0, 2 * math.pi]), 'same stimulus'),
    ((['a'], [8.0], [float('inf')]), 'phases must be finite'),
])
def test_bad_maps_are_rejected_with_a_reason(fields, reason):
    with pytest.raises(ValueError, match=reason):
        decode_stimulus_map(*fields)


def test_phases_may_be_left_out_and_options_are_checked():
    stimuli = decode_stimulus_map(['a', 'b'], [8.0, 9.0], [])
    assert stimuli.phases == (0.0, 0.0)
    assert stimuli.mismatch(['a']) is None
    assert "'c'" in stimuli.mismatch(['a', 'c'])
    with pytest.raises(ValueError, match='only 8'):
        assign_stimuli([str(i) for i in range(9)])


def test_luminance_is_the_sampled_sinusoid():
    frames = np.arange(120)
    values = luminance(frames, [10.0, 12.0], [0.0, math.pi / 2], 60.0)
    assert values.shape == (120, 2)
    np.testing.assert_allclose(values[:, 1], 0.5 * (1 + np.sin(
        2 * np.pi * 12.0 * frames / 60.0 + math.pi / 2)))
    assert values.min() >= 0.0 and values.max() <= 1.0
    assert values[0, 0] == 0.5 and values[0, 1] == 1.0
    with pytest.raises(ValueError, match='half the refresh'):
        luminance(frames, [30.0], [0.0], 60.0)
