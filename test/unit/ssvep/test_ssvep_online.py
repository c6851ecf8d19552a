"""The online decoder on simulated streams: choices, and junk that must not choose."""

import threading

import numpy as np
import pytest

from eye_bci_ros2.sim.eeg import calibration_session, EegSimulator, EegSubject, SUBJECTS
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


def _advertised(advertised_hz, true_hz, subject=SUBJECTS[5], seed=3,
                settings=OnlineSettings(), model=None):
    """Stream at ``true_hz``, advertised at ``advertised_hz``, 'bedroom' attended."""
    simulator = EegSimulator(subject, seed=seed, rate=true_hz)
    simulator.start(0.0, STIMULI)
    simulator.set_attended('bedroom', 0.0)
    decoder = OnlineDecoder(advertised_hz, simulator.labels, settings, model)
    decoder.start_round(0.0, LABELS, STIMULI)
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
    simulator, decoder = _advertised(500.0, 250.0)
    results = _run(decoder, simulator, 4.0, start=0.0)
    assert _choices(results) == []
    assert 'advertises 500 Hz' in results[-1].problem


def test_a_stimulus_map_that_misses_an_option_gives_no_choice():
    simulator, decoder = _setup()
    decoder.start_round(1.0, LABELS + ('garden',), STIMULI)
    results = _run(decoder, simulator, 3.0)
    assert _choices(results) == [] and "'garden'" in results[-1].problem


def test_ensemble_trca_online_and_its_checks():
    calibration = EegSimulator(SUBJECTS[4], seed=8)
    times, samples, trials = calibration_session(calibration, STIMULI, 5, rest_trials=5)
    model = fit_trca(samples, times, trials, STIMULI, calibration.rate, calibration.labels)
    settings = OnlineSettings(decoder='ensemble_trca', min_window_s=0.5)
    simulator, decoder = _setup(SUBJECTS[4], 'bathroom', settings, model)
    assert _choices(_run(decoder, simulator, 3.0)) == ['bathroom']
    # Nobody attending: the model's rest model keeps it from choosing.
    simulator, decoder = _setup(SUBJECTS[4], None, settings, model)
    assert _choices(_run(decoder, simulator, 6.0)) == []
    moved = StimulusMap(LABELS, STIMULI.frequencies[:2] + (STIMULI.frequencies[2] + 1.0,),
                        STIMULI.phases, 1.0)
    simulator, decoder = _setup(SUBJECTS[4], 'bathroom', settings, model)
    decoder.start_round(1.0, LABELS, moved)
    problem = _run(decoder, simulator, 2.0)[-1].problem
    assert f'model learnt it at {STIMULI.frequencies[2]:g} Hz' in problem
    with pytest.raises(ValueError, match='needs a TRCA model'):
        OnlineDecoder(250.0, calibration.labels, settings)
    with pytest.raises(ValueError, match='fitted on channels'):
        OnlineDecoder(250.0, calibration.labels[:4], settings, model)


def test_a_stream_faster_than_advertised_is_decoded_at_its_true_rate():
    """256 Hz advertised as 250 Hz (2.4 %): measured from the sample times and used."""
    simulator, decoder = _advertised(250.0, 256.0, seed=4)
    results = _run(decoder, simulator, 6.0, start=0.0)
    # No choice at the wrong rate: until RATE_PRECISE_SPAN_S of sample times the decoder
    # runs at the advertised 250 Hz, where the attended 14 Hz shows at 14.3 Hz and its
    # harmonics further off (the fifth by 1.7 Hz, past the 1 Hz between options); then it
    # starts again at 256 Hz, whose first min_window_s is not full before 6 s.
    assert _choices(results) == []
    assert decoder.measured_rate == pytest.approx(256.0, abs=0.05)
    assert decoder.rate == pytest.approx(256.0, abs=0.01)
    assert any('advertises 250 Hz' in note and 'decoding at 256' in note
               for note in decoder.notes)
    decoder.start_round(6.0, LABELS, STIMULI)
    assert _choices(_run(decoder, simulator, 4.0, start=6.0)) == ['bedroom']


def test_a_trca_model_refuses_a_stream_at_another_true_rate():
    calibration = EegSimulator(SUBJECTS[4], seed=8)
    times, samples, trials = calibration_session(calibration, STIMULI, 4)
    model = fit_trca(samples, times, trials, STIMULI, calibration.rate, calibration.labels)
    simulator, decoder = _advertised(250.0, 256.0, SUBJECTS[4], seed=9,
                                     settings=OnlineSettings(decoder='ensemble_trca'),
                                     model=model)
    results = _run(decoder, simulator, 7.0, start=0.0)
    # A model fitted at 250 Hz reads a 256 Hz stream wrong: it chooses nothing, neither
    # before the rate is known precisely nor after, when it says why.
    assert _choices(results) == []
    assert 'not 250 Hz as the TRCA model was fitted' in results[-1].problem


def test_the_filters_settle_time_is_measured_and_kept_out():
    simulator, decoder = _setup()
    assert decoder.settle_s > 1.0  # the Chebyshev sub-bands ring longer than the old 1 s
    fresh = OnlineDecoder(250.0, simulator.labels)
    fresh.start_round(0.0, LABELS, STIMULI)
    simulator = EegSimulator(SUBJECTS[5], seed=3)
    simulator.start(0.0, STIMULI)
    results = _run(fresh, simulator, fresh.settle_s + 1.5, start=0.0)
    scored = [r for r in results if len(r.scores)]
    assert scored and all(r.end_s - r.window_s >= fresh.settle_s - 0.005 for r in scored)


def test_a_round_window_starts_after_the_onset():
    simulator, decoder = _setup(settings=OnlineSettings(onset_s=0.5))
    results = [r for r in _run(decoder, simulator, 2.0) if r.window_s]
    # The round starts at 1.0 s: its window holds nothing before 1.5 s.
    assert results and all(r.end_s - r.window_s >= 1.5 - 0.005 for r in results)


def test_strong_alpha_with_nobody_attending_never_chooses():
    """Alpha bursts (10 Hz, below the default options) are not an attended stimulus."""
    alpha = EegSubject('alpha', 5.0, alpha_uv=12.0, alpha_hz=10.0)
    for seed in range(2):
        simulator, decoder = _setup(alpha, None, seed=seed)
        assert _choices(_run(decoder, simulator, 8.0)) == []


def test_a_live_decoder_never_waits_for_the_fbcca_null(monkeypatch):
    """With ``background_null`` the null is measured off the decision path (node's mode)."""
    from eye_bci_ros2.ssvep import decoders
    # The measurement is held until released: stands for a slow one (1000 Hz x 32 channels)
    # without depending on how fast this machine is.
    release = threading.Event()
    measure = decoders._measure_null

    def held(*key):
        release.wait(30.0)
        return measure(*key)

    monkeypatch.setattr(decoders, '_measure_null', held)
    # Empty caches of this process's rest models for this test alone: a fresh process, as a
    # node starts, whichever test measured these settings before; restored afterwards, so
    # the held measurement is not left to the next test either.
    monkeypatch.setattr(decoders, '_NULLS', {})
    monkeypatch.setattr(decoders, '_MEASURING', {})
    settings = OnlineSettings(window_s=1.9, min_window_s=0.9)
    simulator = EegSimulator(SUBJECTS[5], seed=3)
    simulator.start(0.0, STIMULI)
    simulator.set_attended('bedroom', 1.0)
    decoder = OnlineDecoder(simulator.rate, simulator.labels, settings, background_null=True)
    decoder.add(*simulator.next_chunk(1.0))
    decoder.start_round(1.0, LABELS, STIMULI)
    waiting = _run(decoder, simulator, 2.5)
    assert _choices(waiting) == []
    assert 'measuring the FBCCA rest model' in (waiting[-1].problem or '')
    release.set()
    for thread in list(decoders._MEASURING.values()):
        thread.join(30.0)
    assert _choices(_run(decoder, simulator, 2.0, start=3.5)) == ['bedroom']
