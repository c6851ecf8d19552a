"""FBCCA and (ensemble) TRCA on simulated subjects; agreement with meegkit's TRCA."""

import numpy as np
import pytest

from eye_bci_ros2.sim.eeg import calibration_session, EegSimulator, SUBJECTS
from eye_bci_ros2.ssvep.decoders import (fbcca_null, FbccaDecoder, null_windows, sideband_hz,
                                         sideband_statistic, trca_filter, TrcaModel,
                                         with_sidebands)
from eye_bci_ros2.ssvep.filters import filter_recording
from eye_bci_ros2.ssvep.stimuli import assign_stimuli
from eye_bci_ros2.ssvep.training import fit_trca

LABELS = ('kitchen', 'bedroom', 'living room', 'bathroom')
STIMULI = assign_stimuli(LABELS)


def _session(subject, seed, per_option, trial_s=2.0):
    simulator = EegSimulator(subject, seed=seed)
    times, samples, trials = calibration_session(simulator, STIMULI, per_option, trial_s,
                                                 seed=seed)
    return simulator, times, samples, trials


def _accuracy(decoder, subject, window_s, seed=50, per_option=5):
    simulator, times, samples, trials = _session(subject, seed, per_option)
    filtered = filter_recording(samples, simulator.rate)
    length = int(window_s * simulator.rate)
    correct = 0
    for onset, label in trials:
        start = np.searchsorted(times, onset)
        scores = decoder.scores(filtered[:, start:start + length], 0.0)
        correct += LABELS[int(np.argmax(scores))] == label
    return correct / len(trials)


@pytest.mark.parametrize('subject', SUBJECTS[3:], ids=lambda s: s.name)
def test_fbcca_chooses_right_at_2_s_on_the_stronger_subjects(subject):
    decoder = FbccaDecoder(STIMULI.frequencies, 250.0)
    assert _accuracy(decoder, subject, 2.0) >= 0.95


def test_fbcca_on_the_weakest_subject_is_still_better_than_chance():
    decoder = FbccaDecoder(STIMULI.frequencies, 250.0)
    assert _accuracy(decoder, SUBJECTS[0], 2.0, per_option=10) >= 0.45


@pytest.fixture(scope='module')
def trca_model():
    simulator, times, samples, trials = _session(SUBJECTS[1], 7, 5)
    return fit_trca(samples, times, trials, STIMULI, simulator.rate, simulator.labels)


def test_ensemble_trca_beats_fbcca_at_1_s_on_a_weak_subject(trca_model):
    fbcca = _accuracy(FbccaDecoder(STIMULI.frequencies, 250.0), SUBJECTS[1], 1.0,
                      per_option=10)
    trca = _accuracy(trca_model, SUBJECTS[1], 1.0, per_option=10)
    assert trca >= 0.9
    assert trca > fbcca


def test_trca_save_and_load_give_the_same_scores(trca_model, tmp_path):
    path = tmp_path / 'model.npz'
    trca_model.save(str(path))
    loaded = TrcaModel.load(str(path))
    assert loaded.labels == LABELS and loaded.channels == trca_model.channels
    window = np.random.default_rng(0).standard_normal((5, 300, 8))
    np.testing.assert_allclose(loaded.scores(window, 0.3), trca_model.scores(window, 0.3))
    single = TrcaModel.load(str(path), ensemble=False)
    assert not single.ensemble


def test_bad_model_files_say_why(tmp_path):
    with pytest.raises(ValueError, match='cannot read TRCA model'):
        TrcaModel.load(str(tmp_path / 'missing.npz'))
    broken = tmp_path / 'broken.npz'
    np.savez(broken, version=1, labels=np.array(['a']))
    with pytest.raises(ValueError, match='cannot read TRCA model'):
        TrcaModel.load(str(broken))


def test_trca_needs_two_trials_per_stimulus():
    simulator, times, samples, trials = _session(SUBJECTS[4], 3, 1)
    with pytest.raises(ValueError, match='at least 2'):
        fit_trca(samples, times, trials, STIMULI, simulator.rate, simulator.labels)


def test_trca_agrees_with_meegkit():
    """Compare with meegkit's TRCA (a port of Nakanishi's MATLAB code) on the same trials."""
    meegkit_trca = pytest.importorskip('meegkit.trca')
    from meegkit.utils.trca import bandpass
    simulator, times, samples, trials = _session(SUBJECTS[2], 11, 6)
    test_sim, test_times, test_samples, test_trials = _session(SUBJECTS[2], 12, 5)
    rate, length = simulator.rate, int(1.0 * simulator.rate)
    band = [(8.0, 88.0), (6.0, 100.0)]

    def cut(times_, samples_, trials_):
        starts = np.searchsorted(times_, [onset for onset, _ in trials_])
        x = np.stack([samples_[s:s + length] for s in starts], axis=-1)  # (n, C, T)
        return bandpass(x, rate, *band), np.array([LABELS.index(lb) for _, lb in trials_])

    train, y_train = cut(times, samples, trials)
    test, y_test = cut(test_times, test_samples, test_trials)

    # The spatial filter of one stimulus: the same direction.
    ours = trca_filter(np.moveaxis(train[..., y_train == 0], -1, 0))
    theirs = np.real(meegkit_trca.trca(train[..., y_train == 0].copy()))
    cosine = abs(ours @ theirs) / np.linalg.norm(theirs)
    assert cosine > 0.999

    # Whole decoders, one band, ensemble: the same predictions.
    reference = meegkit_trca.TRCA(rate, [band], ensemble=True).fit(train, y_train)
    predicted_theirs = reference.predict(test)
    epochs = np.moveaxis(train, -1, 0)[:, None]  # (T, 1, n, C)
    model = TrcaModel.fit(epochs, y_train, LABELS, STIMULI.frequencies, STIMULI.phases, rate,
                          simulator.labels, ensemble=True)
    # meegkit band-passes its test trials once more (zero-phase): do the same.
    refiltered = bandpass(test, rate, *band)
    predicted_ours = np.array([np.argmax(model.scores(refiltered[..., i][None]))
                               for i in range(test.shape[-1])])
    assert np.mean(predicted_ours == predicted_theirs) >= 0.95
    # One band, 1 s, a weak subject: both well above chance (0.25), not perfect.
    assert np.mean(predicted_ours == y_test) >= 0.6


def test_trca_refuses_a_calibration_whose_trials_do_not_repeat():
    """Free-running flicker (LEDs): each trial's phase is random, the templates average out."""
    simulator = EegSimulator(SUBJECTS[6], seed=21)
    rng = np.random.default_rng(21)
    simulator.start(0.0, None)
    times, chunks, trials, now = [], [], [], 1.0
    for label in np.repeat(LABELS, 5):
        # The flicker's epoch is not the trial onset: its phase there is random.
        epoch = now - rng.uniform(0.0, 1.0)
        simulator.set_stimuli(STIMULI.__class__(STIMULI.labels, STIMULI.frequencies,
                                                STIMULI.phases, epoch))
        simulator.set_attended(str(label), now)
        trials.append((now, str(label)))
        simulator.set_attended(None, now + 2.0)
        now += 3.0 + rng.uniform(0.0, 0.5)  # trials not locked to the mains either
        t, x = simulator.next_chunk(now)
        times.append(t)
        chunks.append(x)
    times, samples = np.concatenate(times), np.concatenate(chunks)
    with pytest.raises(ValueError, match='do not repeat.*phase-locked|do not repeat.*fbcca'):
        fit_trca(samples, times, trials, STIMULI, simulator.rate, simulator.labels)
    # The same recording with phase-locked stimuli (the calibration session) is accepted.
    _, times, samples, trials = _session(SUBJECTS[6], 21, 5)
    model = fit_trca(samples, times, trials, STIMULI, simulator.rate, simulator.labels)
    assert model.rest is not None and model.rest.source == 'calibration'


def test_trca_evidence_of_rest_stays_in_its_null(trca_model):
    """A rest trial's scores are near the model's null; an attended trial's far above it."""
    simulator = EegSimulator(SUBJECTS[1], seed=77)
    times, samples, trials = calibration_session(simulator, STIMULI, 2, seed=77,
                                                 rest_trials=6)
    filtered = filter_recording(samples, simulator.rate)
    rest_z, attended_z = [], []
    for onset, label in trials:
        start = np.searchsorted(times, onset)
        z = trca_model.rest.z(trca_model.scores(filtered[:, start:start + 500]), 2.0)
        if label is None:
            rest_z.append(z.max())
        else:
            attended_z.append(z[LABELS.index(label)])
    assert max(rest_z) < 3.0 < np.median(attended_z)


def test_the_sideband_statistic_follows_a_sloping_spectrum():
    """
    Nobody attends and the log spectrum slopes across the options' neighbourhoods.

    As real EEG's does (1/f, an alpha rhythm's flank): every option's statistic stays 0,
    where the sidebands' arithmetic mean put it 0.11 below (lower sidebands stronger);
    a response at an option still stands out by its size.
    """
    offered = (13.0, 17.0, 21.0)
    frequencies = with_sidebands(offered, sideband_hz(1.0))
    sloping = 0.4 * np.exp(-0.3 * frequencies)  # scores falling by a quarter per Hz
    assert np.allclose(sideband_statistic(sloping), 0.0, atol=1e-12)
    attended = sloping.copy()
    attended[1] *= 4.0  # the 17 Hz option scores 4 x its neighbourhood
    assert np.allclose(sideband_statistic(attended), [0.0, np.log(4.0), 0.0], atol=1e-12)


def test_the_fbcca_null_is_centred_at_each_offered_frequency():
    """
    The filters shift the statistic at some frequencies; the null follows them.

    8 Hz: its lower sidebands fall on the filter bank's 8 Hz edge (white noise: +0.14,
    0.7 standard deviations); 10 Hz: its 5th harmonic on the 50 Hz notch (-0.17).
    """
    rate, channels, offered = 250.0, 4, (8.0, 10.0, 13.0)
    windows = null_windows(1.0, 2.0)
    null = fbcca_null(rate, channels, 5, 5, (6.0, 90.0), 50.0, windows, sideband_hz(1.0),
                      offered)
    # Fresh white noise (another seed than the null's), through the same filters.
    noise = np.random.default_rng(7).standard_normal((int(130 * rate), channels))
    filtered = filter_recording(noise, rate)
    decoder = FbccaDecoder(with_sidebands(offered, sideband_hz(1.0)), rate)
    n = int(2.0 * rate)
    z = np.array([null.z(sideband_statistic(decoder.scores(filtered[:, s:s + n])), 2.0)
                  for s in range(int(3 * rate), filtered.shape[1] - n, n)])
    pooled = (z * np.asarray(null.std)[-1] + np.asarray(null.option_means)[-1]
              - np.asarray(null.mean)[-1]) / np.asarray(null.std)[-1]
    # Against the pooled mean the 8 Hz option sits well above 0 and 10 Hz below; against
    # its own mean every option is centred (60 windows: standard error ~0.13).
    assert pooled[:, 0].mean() > 0.35 and pooled[:, 1].mean() < -0.35
    assert np.all(np.abs(z.mean(axis=0)) < 0.4)
