"""The ssvep_decoder node: real LSL EEG outlet of a simulated person -> ``ssvep/choice``."""

import subprocess
import sys

import numpy as np
import pytest
from sensor_msgs.msg import JointState
from ssvep_rig import LABELS, Rig, WAIT_S

from eye_bci_ros2.sim.eeg import EegSimulator, SUBJECTS

pytestmark = [pytest.mark.ros, pytest.mark.lsl, pytest.mark.slow]


@pytest.fixture
def rig_factory(graph, capfd):
    rigs = []

    def make(**kwargs):
        rig = Rig(graph, capfd, **kwargs)
        rigs.append(rig)
        return rig.start()

    yield make
    for rig in rigs:
        rig.stop()


def test_the_attended_option_is_chosen_once(graph, rig_factory):
    rig = rig_factory()
    rig.graph.spin_for(1.5)  # let the filters settle on the running stream
    rig.offer(attend='bathroom')
    assert graph.spin_until(lambda: rig.choices.messages, WAIT_S)
    assert [m.data for m in rig.choices.messages] == ['bathroom']
    scores = rig.scores.last  # the step that chose
    assert list(scores.name) == list(LABELS)
    assert scores.position[LABELS.index('bathroom')] >= 0.95
    assert 1.0 <= scores.effort[0] <= 2.0  # window length, s
    assert rig.choices_before_sentinel() == ['bathroom']  # one choice per round


def test_the_unicorn_layout_and_a_new_round(graph, rig_factory):
    rig = rig_factory(simulator=EegSimulator(SUBJECTS[7], layout='unicorn', seed=4))
    assert rig.node.channels == ('Oz', 'PO7', 'PO8')
    graph.spin_for(1.5)
    rig.offer(attend='kitchen')
    assert graph.spin_until(lambda: rig.choices.messages, WAIT_S)
    rig.offer(('garden', 'garage'), attend='garage')
    assert graph.spin_until(lambda: len(rig.choices.messages) == 2, WAIT_S)
    assert [m.data for m in rig.choices.messages] == ['kitchen', 'garage']


def test_nobody_attending_gives_no_choice(graph, rig_factory):
    rig = rig_factory()
    graph.spin_for(1.5)
    rig.offer(attend=None)
    graph.spin_for(5.0)   # rounds of decoding nobody's attention
    assert rig.scores.messages  # it did decode
    assert rig.choices_before_sentinel() == []


def test_a_stimulus_map_without_an_offered_option_gives_no_choice(graph, rig_factory):
    rig = rig_factory()
    graph.spin_for(1.5)
    rig.offer(stimuli_labels=('kitchen', 'bedroom'), attend='kitchen')
    assert rig.log.wait_for(graph, r'no SSVEP choice: stimulus map does not match the '
                            r"options: no stimulus for offered option\(s\) 'bathroom'")
    graph.spin_for(2.0)   # decoding steps while the map does not match
    assert rig.choices_before_sentinel() == []


def test_an_invalid_stimulus_map_is_refused_with_a_reason(graph, rig_factory):
    rig = rig_factory()
    rig.stimuli_pub.publish(JointState(name=['a', 'b'], position=[8.0]))
    assert rig.log.wait_for(graph, r'stimulus map on ssvep/stimuli ignored: the stimulus map '
                            r'has 2 names but 1 frequencies')


def test_railed_and_nan_channels_are_left_out(graph, rig_factory):
    def nan_on_oz(times, samples):
        samples = samples.copy()
        samples[::7, 6] = np.nan
        return samples

    rig = rig_factory(simulator=EegSimulator(SUBJECTS[7], seed=5, railed=('O1',)),
                      streamer_args={'on_push': nan_on_oz})
    graph.spin_for(1.5)
    rig.offer(attend='bedroom')
    assert graph.spin_until(lambda: rig.choices.messages, WAIT_S)
    assert [m.data for m in rig.choices.messages] == ['bedroom']
    log = rig.log.read()
    assert 'EEG channels left out' in log and 'O1 (railed)' in log and 'Oz (NaN' in log


def test_all_channels_junk_gives_no_choice_and_says_why(graph, rig_factory):
    labels = ('PO7', 'PO3', 'POz', 'PO4', 'PO8', 'O1', 'Oz', 'O2')
    rig = rig_factory(simulator=EegSimulator(SUBJECTS[7], seed=5, railed=labels[:4],
                                             flat=labels[4:]))
    graph.spin_for(1.5)
    rig.offer(attend='bedroom')
    assert rig.log.wait_for(graph, r'no SSVEP choice: no usable EEG channel: .*PO7 '
                            r'\(railed\).*Oz \(flat\)')
    assert rig.choices.messages == []


def test_a_wrong_rate_gives_no_choice_and_says_why(graph, rig_factory):
    rig = rig_factory(streamer_args={'nominal_rate': 500.0})
    rig.offer(attend='kitchen')
    assert rig.log.wait_for(graph, r'advertises 500 Hz but its sample times show 25\d\.\d Hz')
    assert rig.choices.messages == []


def test_missing_labels_say_which_channels_to_set(graph, rig_factory):
    rig = rig_factory(simulator=EegSimulator(SUBJECTS[7], layout='openbci_gui', seed=1),
                      channels='Oz')
    assert rig.log.wait_for(graph, r"cannot decode .*channels 'Oz' not in the stream")
    assert rig.node.channels is None
    result, = graph.set_parameters('/ssvep_decoder', {'channels': '6,7'})
    assert result.successful
    assert graph.spin_until(lambda: rig.node.channels == ('O1', 'O2'), WAIT_S)


def test_a_lost_stream_is_reported_and_found_again(graph, capfd):
    # The amplifier application runs as its own process, as on a real set-up (sim_eeg), and
    # dies (SIGKILL: no goodbye) under the connected decoder.
    rig = Rig(graph, capfd)
    amplifier = subprocess.Popen(
        [sys.executable, '-m', 'eye_bci_ros2.sim.eeg_outlet', '--layout', 'generic',
         '--source-id', rig.source_id], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        assert graph.spin_until(lambda: bool(rig.node.stream) and rig.node.channels, 20.0)
        graph.spin_for(0.5)
        mark = rig.log.mark()
        amplifier.kill()
        amplifier.wait(10.0)
        assert rig.log.wait_for(graph, r'lost EEG stream|no EEG samples from', mark)
        # It comes back: the decoder finds it again and chooses from it.
        rig.streamer.start()
        assert graph.spin_until(lambda: bool(rig.node.stream) and rig.node.channels, 20.0)
        graph.spin_for(1.5)
        rig.offer(attend='kitchen')
        assert graph.spin_until(lambda: rig.choices.messages, WAIT_S)
        assert [m.data for m in rig.choices.messages] == ['kitchen']
    finally:
        if amplifier.poll() is None:
            amplifier.kill()
            amplifier.wait(10.0)
        rig.stop()


def test_bad_parameters_are_refused_with_a_reason(graph, rig_factory):
    rig = rig_factory()
    result, = graph.set_parameters('/ssvep_decoder', {'decoder': 'trca'})
    assert not result.successful and 'needs model_file' in result.reason
    result, = graph.set_parameters('/ssvep_decoder', {'min_window_s': 5.0})
    assert not result.successful and 'min_window_s' in result.reason
    assert rig.node.stream


def test_ensemble_trca_from_a_calibration_file(graph, rig_factory, tmp_path):
    from eye_bci_ros2.tools.ssvep_calibrate import main as calibrate
    path = tmp_path / 'model.npz'
    assert calibrate(['--options', ','.join(LABELS), '--trials', '5', '--subject', 's2',
                      '--output', str(path)]) == 0
    rig = rig_factory(simulator=EegSimulator(SUBJECTS[1], seed=21), decoder='ensemble_trca',
                      model_file=str(path), min_window_s=0.5)
    graph.spin_for(1.5)
    rig.offer(attend='bedroom')
    assert graph.spin_until(lambda: rig.choices.messages, WAIT_S)
    assert [m.data for m in rig.choices.messages] == ['bedroom']
    # Options the model has no template for: no choice, and the reason.
    rig.offer(('garden', 'garage'), attend='garage')
    assert rig.log.wait_for(graph, r"TRCA model has no template for 'garden'")
    assert len(rig.choices.messages) == 1


def test_keep_scoring_goes_on_after_the_choice(graph, rig_factory):
    rig = rig_factory(keep_scoring=True)
    graph.spin_for(1.5)
    rig.offer(attend='kitchen')
    assert graph.spin_until(lambda: rig.choices.messages, WAIT_S)
    count = len(rig.scores.messages)
    graph.spin_for(1.0)
    assert len(rig.scores.messages) >= count + 3  # still scored ...
    assert [m.data for m in rig.choices.messages] == ['kitchen']  # ... but chosen once
