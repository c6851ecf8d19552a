"""The simulated EEG amplifier: SSVEP where attended, artefacts, faults, chunking."""

import numpy as np
import pytest

from eye_bci_ros2.sim.eeg import (calibration_session, EegSimulator, EegSubject, narrowband_snr_db,
                                  SUBJECTS)
from eye_bci_ros2.ssvep.stimuli import assign_stimuli

STIMULI = assign_stimuli(['a', 'b', 'c'], (8.0, 9.0, 10.0))  # the figures below are at these


def test_chunked_streaming_equals_one_batch():
    batch = EegSimulator(SUBJECTS[2], seed=4)
    _, whole = batch.simulate(3.0, [(0.0, 'a'), (1.3, 'c')], STIMULI)
    stream = EegSimulator(SUBJECTS[2], seed=4)
    stream.start(0.0, STIMULI)
    stream.set_attended('a', 0.0)
    stream.set_attended('c', 1.3)
    parts = [stream.next_chunk(until)[1] for until in (0.1, 0.101, 1.7, 2.9999)]
    np.testing.assert_allclose(np.concatenate(parts), whole, atol=1e-9)


def test_ssvep_at_the_attended_frequency_over_the_occiput():
    simulator = EegSimulator(SUBJECTS[4], seed=1)
    _, x = simulator.simulate(10.0, [(0.0, 'b')], STIMULI)
    oz = simulator.labels.index('Oz')
    assert narrowband_snr_db(x[:, oz], simulator.rate, 9.0) > 10.0
    assert narrowband_snr_db(x[:, oz], simulator.rate, 18.0) > 3.0  # 2nd harmonic
    assert narrowband_snr_db(x[:, oz], simulator.rate, 8.0) < 5.0  # not attended


def _lock_in_uv(x, rate, frequency):
    """Amplitude of the ``frequency`` component of x, uV (10 s: 0.1 Hz wide)."""
    t = np.arange(len(x)) / rate
    return 2 * abs(np.mean(x * np.exp(-2j * np.pi * frequency * t)))


def test_nothing_attended_gives_no_ssvep():
    subject = SUBJECTS[7]
    attended = EegSimulator(subject, seed=1)
    _, x = attended.simulate(10.0, [(0.0, 'a')], STIMULI)
    oz = attended.labels.index('Oz')
    response = _lock_in_uv(x[:, oz], 250.0, 8.0)
    assert response == pytest.approx(subject.ssvep_uv, rel=0.3)
    _, x = EegSimulator(subject, seed=1).simulate(10.0, [(0.0, None)], STIMULI)
    assert max(_lock_in_uv(x[:, oz], 250.0, f) for f in STIMULI.frequencies) < 0.3 * response


def test_subjects_span_weak_to_strong_responders():
    snrs = []
    for subject in (SUBJECTS[0], SUBJECTS[-1]):
        simulator = EegSimulator(subject, seed=2)
        _, x = simulator.simulate(10.0, [(0.0, 'a')], STIMULI)
        snrs.append(narrowband_snr_db(x[:, simulator.labels.index('Oz')], 250.0, 8.0))
    assert snrs[1] - snrs[0] > 8.0


def test_line_noise_blinks_and_faults():
    subject = EegSubject('x', 2.0, blink_rate_hz=1.0)
    simulator = EegSimulator(subject, layout='liveamp', rate=500.0, seed=3, railed=('O1',),
                             flat=('Cz',), line_hz=60.0)
    _, x = simulator.simulate(8.0, [(0.0, None)], STIMULI)
    labels = list(simulator.labels)
    assert np.all(x[:, labels.index('O1')] == simulator.layout.rail_uv)
    assert np.all(x[:, labels.index('Cz')] == 0.0)
    fp1, oz = labels.index('Fp1'), labels.index('Oz')
    assert narrowband_snr_db(x[:, fp1], 500.0, 60.0) > 10.0
    assert np.ptp(x[:, fp1]) > 2 * np.ptp(x[:, oz])  # blinks are frontal
    with pytest.raises(ValueError, match='no channel'):
        EegSimulator(subject, railed=('Q9',))


def test_unicorn_layout_carries_eeg_only_on_its_eeg_channels():
    simulator = EegSimulator(SUBJECTS[3], layout='unicorn', seed=1)
    _, x = simulator.simulate(2.0, [(0.0, 'a')], STIMULI)
    assert x.shape == (500, 17)
    assert np.all(x[:, 8:] == 0.0) and np.all(np.std(x[:, :8], axis=0) > 1.0)


def test_calibration_session_attends_each_option_equally():
    simulator = EegSimulator(SUBJECTS[3], seed=1)
    times, samples, trials = calibration_session(simulator, STIMULI, 2, trial_s=1.0,
                                                 rest_s=0.5)
    assert sorted(label for _, label in trials) == ['a', 'a', 'b', 'b', 'c', 'c']
    assert len(times) == len(samples) and times[-1] >= trials[-1][0] + 1.0
