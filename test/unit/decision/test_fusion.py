"""Input modes: gaze, SSVEP, hybrid (gaze never chooses alone)."""

import numpy as np
import pytest

from eye_bci_ros2.decision.fusion import ChoiceFusion, confirmation, FusionOutcome, FusionSettings
from eye_bci_ros2.ssvep.decision import DEFAULT_GAIN, DEFAULT_REST_Z, posterior

OPTIONS = ('kitchen', 'bedroom', 'bathroom')


def _fusion(mode, **settings):
    fusion = ChoiceFusion(FusionSettings(mode, **settings))
    fusion.new_round(OPTIONS)
    return fusion


def test_gaze_mode_is_todays_behaviour():
    fusion = _fusion('gaze')
    assert fusion.gaze('kitchen', 1.0) == 'kitchen'
    assert fusion.ssvep_choice('bedroom', 1.1) is None
    assert fusion.gaze(None, 2.0) is None


def test_ssvep_mode_takes_the_decoder_choice_once_per_round():
    fusion = _fusion('ssvep')
    assert fusion.gaze('kitchen', 1.0) is None
    assert fusion.ssvep_choice('garden', 1.0) is None  # not offered
    assert fusion.ssvep_choice('bedroom', 1.2) == 'bedroom'
    assert fusion.ssvep_choice('bedroom', 1.3) is None
    fusion.new_round()
    assert fusion.ssvep_choice('kitchen', 2.0) == 'kitchen'


def test_hybrid_gaze_alone_never_chooses():
    fusion = _fusion('hybrid')
    for t in range(10):
        assert fusion.gaze(OPTIONS[t % 3], float(t)) is None
    assert fusion.candidate == 'kitchen'


@pytest.mark.parametrize('ssvep_first', [False, True])
def test_hybrid_gaze_confirmed_by_the_ssvep_choice(ssvep_first):
    fusion = _fusion('hybrid')
    if ssvep_first:
        assert fusion.ssvep_choice('bedroom', 1.0) is None
        assert fusion.gaze('bedroom', 1.5) == 'bedroom'
    else:
        assert fusion.gaze('bedroom', 1.0) is None
        assert fusion.ssvep_choice('bedroom', 1.5) == 'bedroom'
    assert fusion.chosen and fusion.gaze('bedroom', 2.0) is None


def test_hybrid_disagreement_or_stale_evidence_does_not_choose():
    fusion = _fusion('hybrid', max_lag_s=1.0, hold_s=0.0)
    assert fusion.gaze('bedroom', 1.0) is None
    assert fusion.ssvep_choice('kitchen', 1.2) is None
    assert fusion.ssvep_scores(OPTIONS, [0.1, 0.95, 0.0], 5.0) is None  # too late
    assert fusion.gaze('bedroom', 5.5) == 'bedroom'  # fresh gaze + that posterior


def test_hybrid_confirmed_by_the_ssvep_posterior():
    fusion = _fusion('hybrid', confirm_threshold=0.8, hold_s=0.5)
    assert fusion.ssvep_scores(OPTIONS, [0.3, 0.6, 0.1], 1.0) is None
    assert fusion.gaze('bedroom', 1.1) is None
    # Above the threshold from 1.2 s: confirmed once it has held for 0.5 s.
    assert [fusion.ssvep_scores(OPTIONS, [0.05, 0.85, 0.05], 1.2 + 0.1 * k)
            for k in range(6)] == [None] * 5 + ['bedroom']


def test_hybrid_a_brief_posterior_excursion_does_not_confirm():
    """One step's high posterior is noise (nobody attending); the hold is measured anew."""
    fusion = _fusion('hybrid', confirm_threshold=0.8, hold_s=0.5)
    assert fusion.gaze('bedroom', 1.0) is None
    steps = [0.9, 0.9, 0.9, 0.5, 0.9, 0.9, 0.9, 0.9, 0.5]
    assert all(fusion.ssvep_scores(OPTIONS, [0.0, p, 0.0], 1.0 + 0.1 * k) is None
               for k, p in enumerate(steps))
    assert not fusion.chosen


def test_hybrid_a_wandering_gaze_nominates_no_candidate():
    fusion = _fusion('hybrid', min_gaze_margin=0.5, hold_s=0.0)
    assert fusion.ssvep_scores(OPTIONS, [0.0, 0.99, 0.0], 1.0) is None
    assert fusion.gaze('bedroom', 1.1, margin=0.2) is None and fusion.candidate is None
    assert fusion.gaze('bedroom', 1.2, margin=0.9) == 'bedroom'


def test_bad_settings_say_why():
    with pytest.raises(ValueError, match='input_mode'):
        FusionSettings('eeg')
    with pytest.raises(ValueError, match='confirm_threshold'):
        FusionSettings('hybrid', confirm_threshold=0.0)


def test_a_gaze_decision_says_when_its_round_can_lead_to_no_choice():
    # The node publishes choice/none from this outcome; no mode is compared in the node.
    gaze = _fusion('gaze')
    assert gaze.gaze_outcome('kitchen', 1.0).choice == 'kitchen'
    assert gaze.gaze_outcome(None, 2.0, reason='no sample in any region').no_choice == \
        'no sample in any region'
    ssvep = _fusion('ssvep')
    assert ssvep.gaze_outcome(None, 1.0, reason='no sample') == FusionOutcome()
    hybrid = _fusion('hybrid', min_gaze_margin=0.5)
    unsteady = hybrid.gaze_outcome('kitchen', 1.0, margin=0.2)
    assert unsteady.choice is None and 'too unsteady' in unsteady.no_choice
    waiting = hybrid.gaze_outcome('kitchen', 2.0, margin=0.9)
    assert waiting == FusionOutcome() and hybrid.candidate == 'kitchen'
    assert hybrid.ssvep_choice('kitchen', 2.5) == 'kitchen'
    assert hybrid.gaze_outcome(None, 3.0, reason='no sample') == FusionOutcome(), \
        'a round already chosen is not reported as ending without a choice'


def test_the_candidate_is_confirmed_against_rest_not_against_the_other_options():
    """Gaze says which option: the EEG answers "this one, or nothing?" (one-stimulus detection)."""
    # The decoder's posterior of the candidate (index 1) is its one-stimulus detection against
    # rest whatever the unattended options' evidence, as long as they do not lead it.
    detection = np.exp(DEFAULT_GAIN * 2.5) / (np.exp(DEFAULT_GAIN * 2.5)
                                              + np.exp(DEFAULT_GAIN * DEFAULT_REST_Z))
    for others in ([0.0, 0.0], [1.5, 1.0], [-1.0, 2.4]):
        z = np.array([others[0], 2.5, others[1]])
        assert confirmation(posterior(z))[1] == pytest.approx(detection)
    # Another option leading: the person attends that one, the gaze is wrong.
    assert confirmation(posterior(np.array([4.0, 2.5, 0.0])))[1] == 0.0
    # No "nothing attended" share (another decoder): its posterior as it is; junk counts 0.
    assert confirmation([0.2, 0.8, 0.0]).tolist() == [0.0, 0.8, 0.0]
    assert confirmation([float('nan'), 0.5, 0.1]).tolist()[0] == 0.0


def test_hybrid_a_posterior_shared_with_unattended_options_still_confirms():
    fusion = _fusion('hybrid', confirm_threshold=0.9, hold_s=0.0)
    assert fusion.gaze('bedroom', 1.0) is None
    # 0.85 of the posterior, 0.1 on an option nobody looks at, 0.05 on nothing: 0.85 / 0.9.
    assert fusion.ssvep_scores(OPTIONS, [0.1, 0.85, 0.0], 1.1) == 'bedroom'
    fusion = _fusion('hybrid', confirm_threshold=0.9, hold_s=0.0)
    assert fusion.gaze('bedroom', 1.0) is None
    # 0.6 on it and 0.4 on nothing: not enough, whatever the threshold of the decoder.
    assert fusion.ssvep_scores(OPTIONS, [0.0, 0.6, 0.0], 1.1) is None
