"""
SSVEP messages <-> pure objects at the node edges (contract in :mod:`eye_bci_ros2.ssvep.stimuli`).

``ssvep/stimuli`` (latched) and ``ssvep/scores`` are sensor_msgs/JointState,
one "joint" per option:

- stimuli: name = option label, position = frequency Hz, velocity = phase
  rad, header.stamp = stimulus epoch (ROS time of frame 0), frame ``screen``;
- scores: name = offered option labels, position = posterior probability
  (with FBCCA's "nothing attended" share left out, so they may sum to less
  than 1), velocity = the decoder's raw score, effort = [window length s],
  header.stamp = time of the window's last EEG sample, frame ``eeg``.
"""

from typing import Sequence

from builtin_interfaces.msg import Time
import numpy as np
from sensor_msgs.msg import JointState

from eye_bci_ros2.ros.conversions import SCREEN_FRAME
from eye_bci_ros2.ssvep.stimuli import decode_stimulus_map, encode_stimulus_map, StimulusMap

#: frame_id of the scores (they describe EEG, not a place).
EEG_FRAME = 'eeg'


def seconds_to_time(seconds: float) -> Time:
    """ROS time from float seconds (>= 0)."""
    nanoseconds = int(round(seconds * 1e9))
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def time_to_seconds(stamp: Time) -> float:
    """builtin_interfaces/Time -> float s."""
    return stamp.sec + stamp.nanosec * 1e-9


def stimulus_map_to_msg(stimuli: StimulusMap) -> JointState:
    """Build the ``ssvep/stimuli`` message (raises ValueError for an invalid map)."""
    names, frequencies, phases, epoch = encode_stimulus_map(stimuli)
    msg = JointState(name=names, position=frequencies, velocity=phases)
    msg.header.frame_id = SCREEN_FRAME
    msg.header.stamp = seconds_to_time(epoch)
    return msg


def msg_to_stimulus_map(msg: JointState) -> StimulusMap:
    """Read an ``ssvep/stimuli`` message; ValueError with a reason when it is unusable."""
    return decode_stimulus_map(list(msg.name), list(msg.position), list(msg.velocity),
                               time_to_seconds(msg.header.stamp))


def scores_to_msg(labels: Sequence[str], posterior: np.ndarray, scores: np.ndarray,
                  window_s: float, end_s: float) -> JointState:
    """Build the ``ssvep/scores`` message of one decoding step."""
    msg = JointState(name=list(labels), position=[float(p) for p in posterior],
                     velocity=[float(s) for s in scores], effort=[float(window_s)])
    msg.header.frame_id = EEG_FRAME
    msg.header.stamp = seconds_to_time(max(end_s, 0.0))
    return msg
