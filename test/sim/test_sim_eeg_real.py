"""The simulated EEG against real recordings: the statistics the decoders care about."""

import numpy as np
import pytest

from eye_bci_ros2.recordings.eeg import (eeg_data_dir, find_eeg_recordings, load_eeg,
                                         session_statistics)
from eye_bci_ros2.sim.eeg import cued_recording, REALISTIC_SUBJECTS, SUBJECTS

#: How far the simulated medians may lie from the real ones (dB, or a share for buildup).
TOLERANCES = {'snr_db': 2.5, 'snr_iqr_db': 2.0, 'buildup': 0.3, 'alpha_db': 2.5}


def _medians(recordings):
    rows = [session_statistics(r.eeg_uv, r.rate, r.channels.index('Oz'), r.trials)
            for r in recordings]
    return {key: float(np.nanmedian([row[key] for row in rows])) for key in rows[0]}


@pytest.fixture(scope='module')
def real():
    folder = eeg_data_dir()
    paths = find_eeg_recordings(folder) if folder else []
    if not paths:
        pytest.skip('no real EEG recordings (../shared/data/real_eeg or $EYE_BCI_REAL_EEG)')
    return _medians([load_eeg(path) for path in paths])


def test_realistic_subjects_match_the_recordings(real):
    simulated = _medians([cued_recording(subject, seed=index)
                          for index, subject in enumerate(REALISTIC_SUBJECTS)])
    for key, tolerance in TOLERANCES.items():
        assert abs(simulated[key] - real[key]) <= tolerance, (key, simulated, real)
    # The response builds up after the cue, in the recordings and the simulation alike.
    assert real['buildup'] < 0.6 and simulated['buildup'] < 0.6


def test_the_clear_responders_are_clearer_than_people(real):
    """The functional tests' subjects are not what a decoder meets: say so by measuring."""
    clear = _medians([cued_recording(subject, seed=index)
                      for index, subject in enumerate(SUBJECTS[4:6])])
    assert clear['snr_db'] > real['snr_db'] + 5.0
