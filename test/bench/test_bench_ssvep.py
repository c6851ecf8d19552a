"""bench.ssvep's rounds: what they count is what happened."""

import numpy as np

from bench.ssvep import _round, _scan, ROOMS
from eye_bci_ros2.sim.eeg import SUBJECTS


def test_an_intent_round_is_chosen_by_hybrid_and_ssvep():
    target, ssvep, hybrid = _round(SUBJECTS[7], 3, ROOMS, intent=True)
    assert hybrid is not None and hybrid[0] == target
    assert ssvep is not None and ssvep[0] == target
    assert 1.0 <= hybrid[1] <= 5.0  # not before the gaze window has ended


def test_a_midas_round_looks_over_the_options_without_a_hybrid_choice():
    glances = _scan(np.random.default_rng(1), ROOMS, 5.0)
    assert len({label for _, label in glances}) == len(ROOMS)
    gaps = np.diff([t for t, _ in glances])
    assert np.all((gaps >= 0.25) & (gaps <= 0.5))
    _, _, hybrid = _round(SUBJECTS[7], 4, ROOMS, intent=False)
    assert hybrid is None
