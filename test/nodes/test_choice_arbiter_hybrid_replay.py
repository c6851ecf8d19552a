"""
The choice_arbiter in hybrid mode decides a real paired round exactly as bench.real_hybrid.

A real EEG trial (decoded by the ssvep_decoder's online decoder) and a real gaze
round, paired as ``python -m bench.real_hybrid`` pairs them, are replayed
through the node on its topics: ``choices/regions`` at the cue, each gaze
sample as its own ``gaze/samples`` batch at its stamp, the decoder's
``ssvep/scores`` and ``ssvep/choice`` at their times.  Simulated time
(``use_sim_time``, ``/clock``) puts the node clock where the bench's clock is
for every message: each message is published once the node reads its time and
the next waits until the node has taken it.
"""

import dataclasses
import itertools

from arbiter_rig import ArbiterRig
import numpy as np
import pytest
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from bench import real_hybrid
from bench.real_gaze import load_folder
from bench.ssvep_real import _online
from eye_bci_ros2.decision.fusion import FusionSettings
from eye_bci_ros2.decision.rounds import ArbiterSettings, COUNT_RULE
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.eeg import eeg_data_dir, find_eeg_recordings, load_eeg
from eye_bci_ros2.ros.conversions import (cube_marker, gaze_batch, ns_to_stamp,
                                          regions_to_marker_array)
from eye_bci_ros2.ros.ssvep_messages import scores_to_msg
from eye_bci_ros2.ros.topics import (EVENT_QOS, SCORES_QOS, SSVEP_CHOICE_TOPIC,
                                     SSVEP_SCORES_TOPIC)
from eye_bci_ros2.ssvep.online import OnlineSettings

pytestmark = [pytest.mark.ros]

#: Generous wait for each message to be taken, s (2 shared cores).
WAIT_S = 15.0


def _ns(seconds: float) -> int:
    return int(round(seconds * 1e9))


@pytest.fixture(scope='module')
def pairings():
    """Pair 8 trials of a real session (rest and stimuli) with gaze rounds, as the bench does."""
    gaze_folder, eeg_folder = find_data('real_gaze'), eeg_data_dir()
    paths = find_eeg_recordings(eeg_folder) if eeg_folder else []
    if gaze_folder is None or not paths:
        pytest.skip('no real gaze or EEG recordings (../shared/data/real_gaze, real_eeg)')
    recording = load_eeg(paths[0])
    first = next(i for i, (_, hz) in enumerate(recording.trials) if hz is not None) - 2
    end = int(recording.trials[first + 8][0] * recording.rate)
    recording = dataclasses.replace(recording, eeg_uv=recording.eeg_uv[:end],
                                    trials=recording.trials[first:first + 8])
    trials = _online(recording, OnlineSettings(keep_scoring=True), None)
    labels = tuple(f'{hz:g} Hz' for hz in load_eeg(paths[0]).frequencies)
    looks = itertools.cycle(real_hybrid.gaze_looks(load_folder(gaze_folder)))
    return real_hybrid.pair(recording.subject, trials, labels, looks,
                            np.random.default_rng(0))


class ReplayRig(ArbiterRig):
    """The arbiter in hybrid mode on simulated time, and the decoder's topics."""

    def setup(self):
        """Add the clock and the decoder's publishers."""
        self.clock = self.driver.create_publisher(Clock, '/clock', 10)
        self.scores = self.driver.create_publisher(JointState, SSVEP_SCORES_TOPIC, SCORES_QOS)
        self.ssvep_choice = self.driver.create_publisher(String, SSVEP_CHOICE_TOPIC, EVENT_QOS)
        self.publishers += [self.scores, self.ssvep_choice]
        # Counts what the node's fusion took (a spy that calls through to the real method).
        fusion = self.arbiter._fusion.fusion
        self.taken = 0
        for name in ('ssvep_scores', 'ssvep_choice'):
            method = getattr(fusion, name)
            setattr(fusion, name, self._counting(method))

    def _counting(self, method):
        def counted(*args):
            self.taken += 1
            return method(*args)
        return counted

    def at(self, t: float) -> None:
        """Set the simulated clock to ``t`` s and wait until the node reads it."""
        stamp = ns_to_stamp(_ns(t))

        def reads_it():
            self.clock.publish(Clock(clock=stamp))
            return self.arbiter.get_clock().now().nanoseconds == _ns(t)

        assert self.graph.spin_until(reads_it, WAIT_S), f'the node clock did not reach {t} s'

    def replay(self, pairing: real_hybrid.Pairing) -> list:
        """Publish the round's messages in time order; return the time of each choice, s."""
        self.at(pairing.cue)
        sources = [cube_marker('options', i, label, 'map', (i, 0, 0), (0, 0, 0, 1), (1, 1, 1))
                   for i, label in enumerate(pairing.labels)]
        self.regions.publish(regions_to_marker_array(pairing.regions.polygons, sources,
                                                     ns_to_stamp(_ns(pairing.cue))))
        assert self.graph.spin_until(lambda: self.arbiter.rounds_started == 1, WAIT_S)
        events = [(float(t), 0, 'gaze', i) for i, t in enumerate(pairing.stamps)]
        events += [(t, 1, 'scores', (labels, posterior))
                   for t, labels, posterior in pairing.steps]
        if pairing.ssvep_choice is not None:
            events.append((pairing.ssvep_choice[1], 2, 'choice', pairing.ssvep_choice[0]))
        chosen_at = []
        for t, _, kind, value in sorted(events, key=lambda e: (e[0], e[1])):
            self.at(t)
            before = (self.arbiter.samples_received, self.taken)
            if kind == 'gaze':
                self.gaze.publish(gaze_batch(np.array([_ns(t)]), pairing.points[value:value + 1]))
                done = (lambda: self.arbiter.samples_received > before[0])
            elif kind == 'scores':
                # The raw scores (velocity) are not recorded by the bench; the arbiter reads
                # the posterior only.
                self.scores.publish(scores_to_msg(value[0], np.array(value[1]),
                                                  np.zeros(len(value[1])), 0.0, t))
                done = (lambda: self.taken > before[1])
            else:
                self.ssvep_choice.publish(String(data=value))
                done = (lambda: self.taken > before[1])
            assert self.graph.spin_until(done, WAIT_S), f'the node did not take the {kind}'
            if self.arbiter._fusion.fusion.chosen and not chosen_at:
                chosen_at.append(t - pairing.cue)
        return chosen_at


def _rig(graph, pairing):
    settings = real_hybrid.arbiter_settings(pairing)
    defaults = ArbiterSettings()
    parameters = {name: getattr(defaults, name) for name in (*COUNT_RULE, 'max_future_s')}
    parameters.update({name: getattr(settings, name) for name in (
        'screen_width', 'screen_height', 'screen_width_mm', 'screen_height_mm',
        'viewing_distance_mm')})
    return ReplayRig(graph, input_mode='hybrid', use_sim_time=True, **parameters)


@pytest.mark.parametrize('intent', [True, False], ids=['intent', 'no intent'])
def test_the_node_decides_a_real_paired_round_as_the_bench(graph, pairings, intent):
    bench_rounds = real_hybrid.decide_all(pairings, {'hybrid': FusionSettings('hybrid')})
    # An intent round the hybrid chose (by the posterior, before any choice of the decoder),
    # or a no-intent round whose gaze nominated a candidate the EEG did not confirm.
    decided = next(d for d in bench_rounds['hybrid'] if d.pairing.intent == intent and (
        (d.choice is not None and d.after_s + d.pairing.cue
         < (d.pairing.ssvep_choice or ('', np.inf))[1]) if intent
        else real_hybrid.gaze_decision(d.pairing)[0].label is not None))
    rig = _rig(graph, decided.pairing)
    chosen_at = rig.replay(decided.pairing)
    if intent:
        assert rig.graph.spin_until(lambda: rig.labels, WAIT_S)
        assert rig.labels == [decided.choice] == [decided.pairing.attended]
        assert chosen_at == [pytest.approx(decided.after_s, abs=1e-6)]
    else:
        # Every message taken, the gaze decided, and nothing chosen: as the bench.
        assert rig.arbiter.last_decision.label == real_hybrid.gaze_decision(
            decided.pairing)[0].label
        assert decided.choice is None and not chosen_at and rig.labels == []
