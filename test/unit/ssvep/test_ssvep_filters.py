"""Streaming filters: chunking, pass band, notch, the Chen 2015 filter bank."""

import numpy as np
import pytest

from eye_bci_ros2.ssvep.filters import (filter_bank_sos, filter_bank_weights, preprocess_sos,
                                        StreamingFilterBank)
from eye_bci_ros2.ssvep.references import sine_cosine_references

RATE = 250.0


def _gain(rate, frequency, bands=5, notch_hz=50.0):
    """Steady-state amplitude gain of each band for a sinusoid (after 2 s of settling)."""
    t = np.arange(int(6 * rate)) / rate
    x = np.sin(2 * np.pi * frequency * t)[:, None]
    out = StreamingFilterBank(rate, 1, bands, notch_hz=notch_hz).process(x)
    steady = out[:, int(2 * rate):, 0]
    return np.sqrt(2) * steady.std(axis=1)


def test_chunked_filtering_equals_filtering_at_once():
    x = np.random.default_rng(1).standard_normal((1000, 3))
    whole = StreamingFilterBank(RATE, 3).process(x)
    bank = StreamingFilterBank(RATE, 3)
    parts = [bank.process(x[a:b]) for a, b in ((0, 1), (1, 77), (77, 500), (500, 1000))]
    np.testing.assert_allclose(np.concatenate(parts, axis=1), whole, atol=1e-12)


def test_ssvep_frequencies_pass_and_line_noise_is_notched():
    assert _gain(RATE, 12.0)[0] == pytest.approx(1.0, abs=0.06)
    assert _gain(RATE, 50.0)[0] < 0.03  # notched: more than 30 dB down
    assert _gain(1000.0, 60.0, notch_hz=60.0)[0] < 0.03
    assert _gain(RATE, 2.0)[0] < 0.05  # below the pass band


def test_sub_band_m_starts_at_8m_hz():
    gains = _gain(RATE, 12.0)
    assert gains[0] > 0.9  # 8-88 Hz passes 12 Hz
    assert gains[2] < 0.05  # 24-88 Hz does not
    gains = _gain(RATE, 30.0)
    assert np.all(gains[:3] > 0.9)


def test_chen_weights():
    np.testing.assert_allclose(filter_bank_weights(3),
                               [1.25, 2 ** -1.25 + 0.25, 3 ** -1.25 + 0.25])


def test_bad_designs_say_why():
    with pytest.raises(ValueError, match='does not fit'):
        preprocess_sos(100.0, band=(60.0, 90.0))
    with pytest.raises(ValueError, match='at most'):
        filter_bank_sos(100.0, bands=10)
    with pytest.raises(ValueError, match='shape'):
        StreamingFilterBank(RATE, 2).process(np.zeros((5, 3)))


def test_references_are_the_stimulus_harmonics():
    refs = sine_cosine_references([10.0], 250.0, 250, harmonics=2, phases=[0.5])
    t = np.arange(250) / 250.0
    np.testing.assert_allclose(refs[0, :, 0], np.sin(2 * np.pi * 10 * t + 0.5))
    np.testing.assert_allclose(refs[0, :, 3], np.cos(2 * (2 * np.pi * 10 * t + 0.5)))
    # Whole cycles: the columns are orthogonal.
    gram = refs[0].T @ refs[0] / 125.0
    np.testing.assert_allclose(gram, np.eye(4), atol=1e-9)


def test_the_settle_time_is_where_the_start_up_transient_has_died_out():
    """A step at the start (an electrode offset) rings no longer than the measured time."""
    rate = 250.0
    bank = StreamingFilterBank(rate, 1)
    out = bank.process(np.full((int(6 * rate), 1), 100.0))  # a 100 uV offset from rest
    settled = int(bank.settle_s * rate)
    assert 0.5 < bank.settle_s < 3.0
    # Before it the transient is large, after it tiny against EEG's few uV.
    assert np.abs(out[:, :int(0.3 * rate)]).max() > 1.0
    assert np.abs(out[:, settled:]).max() < 0.5
