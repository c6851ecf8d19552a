"""The online decoder on simulated streams: choices, and junk that must not choose."""

import numpy as np
import pytest

from eye_bci_ros2.sim.eeg import calibration_session, EegSimulator, SUBJECTS
from eye_bci_ros2.ssvep.online import OnlineDecoder, OnlineSettings
from eye_bci_ros2.ssvep.stimuli import assign_stimuli, StimulusMap
from eye_bci_ros2.ssvep.training import fit_trca

LABELS = ('kitchen', 'bedroom', 'bathroom')
STIMULI = assign_stimuli(LABELS, epoch_s=1.0)


def _run(decoder, simulator, seconds, chunk_s=0.02, hook=None, start=1.0):
    """Stream ``seconds`` of EEG into the decoder; return the results of every step."""
    results = []
    now = start
    while now < start + seconds:
        now += chunk_s
        times, samples = simulator.next_chunk(now)
        if hook is not None:
            times, samples = hook(times, samples)
        decoder.add(times, samples)
        result = decoder.step()
        if result is not None:
            results.append(result)
    return results


def _setup(subject=SUBJECTS[5], attended='bedroom', settings=OnlineSettings(), model=None,
           seed=3, **simulator_args):
    simulator = EegSimulator(subject, seed=seed, **simulator_args)
    simulator.start(0.0, STIMULI)
    simulator.set_attended(attended, 1.0)
    decoder = OnlineDecoder(simulator.rate, simulator.labels, settings, model)
    decoder.add(*simulator.next_chunk(1.0))  # the second before the round: nothing attended
    decoder.start_round(1.0, LABELS, STIMULI)
    return simulator, decoder


def _choices(results):
    return [r.choice for r in results if r.choice is not None]


def test_fbcca_chooses_the_attended_option_once():
    simulator, decoder = _setup()
    results = _run(decoder, simulator, 3.0)
    assert _choices(results) == ['bedroom']
    chosen = next(r for r in results if r.choice)
    assert 1.0 <= chosen.window_s <= 2.0
    assert chosen.posterior[LABELS.index('bedroom')] >= 0.95
    assert not decoder.round_open


def test_no_choice_before_the_minimum_window():
    simulator, decoder = _setup(settings=OnlineSettings(min_window_s=1.5, window_s=2.0))
    results = _run(decoder, simulator, 1.4)
    assert _choices(results) == [] and all(r.window_s < 1.5 for r in results)


def test_nothing_attended_never_chooses():
    simulator, decoder = _setup(attended=None)
    assert _choices(_run(decoder, simulator, 6.0)) == []


def test_nan_samples_and_railed_channels_are_left_out_but_fbcca_still_decides():
    def nan_burst(times, samples):
        samples = samples.copy()
        samples[(times > 1.3) & (times < 1.35), 6] = np.nan
        return times, samples

    simulator, decoder = _setup(railed=('O1',))
    results = _run(decoder, simulator, 4.0, hook=nan_burst)
    assert _choices(results) == ['bedroom']
    chosen = next(r for r in results if r.choice)
    assert 'O1 (railed)' in chosen.excluded
    assert decoder.counters['nonfinite'] > 0
    assert all(np.all(np.isfinite(r.scores)) for r in results)


def test_every_channel_railed_or_flat_gives_no_choice_and_a_reason():
    simulator, decoder = _setup(railed=('PO7', 'PO3', 'POz', 'PO4'),
                                flat=('PO8', 'O1', 'Oz', 'O2'))
    results = _run(decoder, simulator, 3.0)
    assert _choices(results) == []
    assert 'no usable EEG channel' in results[-1].problem
    assert 'Oz (flat)' in results[-1].problem and 'PO7 (railed)' in results[-1].problem


def test_a_wrong_rate_stops_decoding():
    simulator = EegSimulator(SUBJECTS[5], seed=3, rate=250.0)
    simulator.start(0.0, STIMULI)
    simulator.set_attended('bedroom', 0.0)
    decoder = OnlineDecoder(500.0, simulator.labels, OnlineSettings())
    decoder.start_round(0.0, LABELS, STIMULI)
    results = _run(decoder, simulator, 4.0, start=0.0)
    assert _choices(results) == []
    assert 'advertises 500 Hz' in results[-1].problem


def test_a_stimulus_map_that_misses_an_option_gives_no_choice():
    simulator, decoder = _setup()
    decoder.start_round(1.0, LABELS + ('garden',), STIMULI)
    results = _run(decoder, simulator, 3.0)
    assert _choices(results) == [] and "'garden'" in results[-1].problem


def test_ensemble_trca_online_and_its_checks():
    calibration = EegSimulator(SUBJECTS[1], seed=8)
    times, samples, trials = calibration_session(calibration, STIMULI, 5)
    model = fit_trca(samples, times, trials, STIMULI, calibration.rate, calibration.labels)
    settings = OnlineSettings(decoder='ensemble_trca', min_window_s=0.5)
    simulator, decoder = _setup(SUBJECTS[1], 'bathroom', settings, model)
    assert _choices(_run(decoder, simulator, 3.0)) == ['bathroom']
    moved = StimulusMap(LABELS, (8.0, 9.0, 11.0), STIMULI.phases, 1.0)
    simulator, decoder = _setup(SUBJECTS[1], 'bathroom', settings, model)
    decoder.start_round(1.0, LABELS, moved)
    assert 'model learnt it at 10 Hz' in _run(decoder, simulator, 2.0)[-1].problem
    with pytest.raises(ValueError, match='needs a TRCA model'):
        OnlineDecoder(250.0, calibration.labels, settings)
    with pytest.raises(ValueError, match='fitted on channels'):
        OnlineDecoder(250.0, calibration.labels[:4], settings, model)
