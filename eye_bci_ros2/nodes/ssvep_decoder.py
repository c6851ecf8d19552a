"""
Node ``ssvep_decoder``: choose among the offered options from SSVEP in EEG over LSL.

Subscribes ``choices/regions`` (visualization_msgs/MarkerArray, latched: the
offered options' labels, the marker's text else ``ns/id``), ``ssvep/stimuli``
(sensor_msgs/JointState, latched: each option's flicker, see
:mod:`eye_bci_ros2.ros.ssvep_messages`) and ``choice/request``
(std_msgs/Empty); reads an EEG stream from LSL (:mod:`eye_bci_ros2.ssvep.layouts`);
publishes ``ssvep/scores`` (sensor_msgs/JointState, every ``decide_period_s``
while a round is open, and after its choice with ``keep_scoring``: per-option
posterior and score) and ``ssvep/choice``
(std_msgs/String, the chosen label, at most once per round).

Rounds: a round starts when the set of offered labels changes, when a new
stimulus map arrives, or on ``choice/request``; it starts at the latest of
the regions' stamp, the stimulus epoch and the request (node clock), and
ends with its choice (:mod:`eye_bci_ros2.ssvep.online`).

The stream is found, kept or switched and its samples stamped on the ROS
clock by :class:`eye_bci_ros2.streams.lsl_connection.StreamConnection`, the same
connection (and the same time rule) as the gaze bridge's, with the EEG
profile of :mod:`eye_bci_ros2.ssvep.eeg_stream`; a timer lets it look for
the stream, a second one pulls with a zero timeout, so nothing blocks the
executor.

Bad input never chooses and never stops the node; each kind is logged as one
line at most every 5 s: a lost stream (the node looks for it again), a quiet
stream, channels that cannot be found (missing labels), railed / flat / NaN
channels, a wrong rate, an irregular-rate stream, a stimulus map that does
not match the options or is invalid.
"""

import math
from typing import Any, Dict, Optional

import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.ros.conversions import marker_array_to_regions
from eye_bci_ros2.ros.log_throttle import KeyedWarnings
from eye_bci_ros2.ros.lsl_adapter import LogReporter, PylslBackend
from eye_bci_ros2.ros.node_clock import NodeClock
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.ssvep_messages import msg_to_stimulus_map, scores_to_msg, time_to_seconds
from eye_bci_ros2.ros.topics import (EVENT_QOS, LATCHED_QOS, REGIONS_TOPIC, REQUEST_TOPIC,
                                     SCORES_QOS, SSVEP_CHOICE_TOPIC, SSVEP_SCORES_TOPIC,
                                     SSVEP_STIMULI_TOPIC)
from eye_bci_ros2.ssvep.decision import DEFAULT_GAIN, DEFAULT_HOLD_S, DEFAULT_REST_Z, RULES
from eye_bci_ros2.ssvep.decoders import DECODERS, TrcaModel
from eye_bci_ros2.ssvep.eeg_stream import EegStreamProfile
from eye_bci_ros2.ssvep.layouts import ANY, LAYOUT_NAMES, LAYOUTS, parse_channels, resolve_channels
from eye_bci_ros2.ssvep.online import DEFAULT_ONSET_S, OnlineDecoder, OnlineSettings
from eye_bci_ros2.ssvep.stimuli import StimulusMap
from eye_bci_ros2.streams.lsl_connection import (ConnectionSettings, StreamConnection,
                                                 StreamDescription)


def _channels_text(value) -> Optional[str]:
    try:
        parse_channels(value)
    except ValueError as error:
        return str(error)
    return None


def _band(value) -> Optional[str]:
    if len(value) != 2 or not all(math.isfinite(v) for v in value) or \
            not 0 < value[0] < value[1]:
        return f'needs [low, high] Hz with 0 < low < high, got {list(value)}'
    return None


PARAMETERS = (
    ParamSpec('layout', 'generic', 'EEG application whose LSL layout to expect',
              choices=LAYOUT_NAMES),
    ParamSpec('stream_type', '', f"LSL stream type; '' = the layout's, '{ANY}' = any"),
    ParamSpec('stream_name', '', f"LSL stream name; '' = the layout's, '{ANY}' = any"),
    ParamSpec('source_id', '', "LSL source_id; '' = any"),
    ParamSpec('channels', '',
              'channels to decode: labels (electrode positions, e.g. O1,Oz,O2) or 0-based '
              "indices, comma separated; '' = the occipital channels found "
              '(O1, Oz, O2, POz, PO3, PO4, PO7, PO8)', check=_channels_text),
    ParamSpec('decoder', 'fbcca',
              'fbcca (no training) or trca / ensemble_trca (needs model_file)',
              choices=DECODERS),
    ParamSpec('model_file', '', 'TRCA model (.npz from ssvep_calibrate)'),
    ParamSpec('window_s', 2.0, 'longest EEG window, s; beyond it the window slides',
              value_range=(0.2, 20.0)),
    ParamSpec('min_window_s', 1.0, 'shortest window that may choose, s',
              value_range=(0.1, 20.0)),
    ParamSpec('threshold', 0.95, 'evidence needed for a choice (posterior or margin)',
              value_range=(0.01, 1.0)),
    ParamSpec('rule', 'posterior', "evidence: posterior (each option's evidence against the "
              "rest model, with a 'nothing attended' hypothesis) or margin", choices=RULES),
    ParamSpec('gain', DEFAULT_GAIN, "the posterior's gain: expected evidence z (null standard "
              'deviations) of an attended option', value_range=(0.1, 100.0)),
    ParamSpec('rest_z', DEFAULT_REST_Z, "evidence z at which 'nothing attended' is as likely "
              'as one option (higher: fewer choices when nobody attends, slower ones)',
              value_range=(0.0, 20.0)),
    ParamSpec('hold_s', DEFAULT_HOLD_S, 'an option is chosen once its evidence has reached '
              "'threshold' in every decision step over this long, s (an SSVEP lasts, chance "
              'crossings do not; 0 = at the first step)', value_range=(0.0, 10.0)),
    ParamSpec('onset_s', DEFAULT_ONSET_S, "a round's EEG window starts this long after the "
              'round (gaze shift and SSVEP build-up), s', value_range=(0.0, 10.0)),
    ParamSpec('notch_hz', 50.0, 'line frequency to notch (and its harmonics), Hz; 0 = none',
              value_range=(0.0, 1000.0)),
    ParamSpec('band', [6.0, 90.0], 'pass band before the filter bank, [low, high] Hz '
              '(high clipped to 0.45 x rate)', check=_band, array_type='double_array'),
    ParamSpec('bands', 5, 'FBCCA sub-bands (Chen 2015: 8 m .. 88 Hz)', value_range=(1, 10)),
    ParamSpec('harmonics', 5, 'FBCCA reference harmonics', value_range=(1, 10)),
    ParamSpec('rail_uv', 0.0, "amplitude counted as railed, uV; 0 = the layout's (generic: "
              'unknown, then clipping shows as a run of identical samples far from zero)',
              value_range=(0.0, 1e9)),
    ParamSpec('settle_s', 0.0, 'how long filter output stays out after a start, a gap or a '
              "bad sample, s; 0 = the filters' measured settle time", value_range=(0.0, 10.0)),
    ParamSpec('flat_uv', 0.1, 'filtered std below which a channel is flat, uV',
              value_range=(0.0, 1000.0)),
    ParamSpec('keep_scoring', False,
              "after the round's choice keep publishing ssvep/scores (no further choice); "
              "set it for the arbiter's hybrid input mode"),
    ParamSpec('decide_period_s', 0.1, 'period of scoring the window, s',
              value_range=(0.01, 5.0)),
    ParamSpec('poll_period_s', 0.02, 'period of pulling EEG from LSL, s',
              value_range=(0.001, 1.0)),
    ParamSpec('resolve_period_s', 0.5, 'period of looking for the stream, s',
              value_range=(0.05, 10.0)),
    ParamSpec('stale_timeout_s', 1.0, 'warn when the stream sends nothing for this long, s',
              value_range=(0.05, 3600.0)),
)

_STREAM_KEYS = ('layout', 'stream_type', 'stream_name', 'source_id')


def _settings(values: Dict[str, Any]) -> OnlineSettings:
    """Online settings from the parameters (raises ValueError with a reason)."""
    return OnlineSettings(
        decoder=values['decoder'], window_s=values['window_s'],
        min_window_s=values['min_window_s'], threshold=values['threshold'],
        rule=values['rule'], gain=values['gain'], rest_z=values['rest_z'],
        hold_s=values['hold_s'],
        onset_s=values['onset_s'], settle_s=values['settle_s'], bands=values['bands'],
        harmonics=values['harmonics'], band=tuple(values['band']),
        notch_hz=values['notch_hz'],
        rail_uv=values['rail_uv'] or LAYOUTS[values['layout']].rail_uv,
        flat_uv=values['flat_uv'], keep_scoring=values['keep_scoring'])


def _load_model(values: Dict[str, Any]) -> Optional[TrcaModel]:
    if values['decoder'] == 'fbcca':
        return None
    if not values['model_file']:
        raise ValueError(f"decoder '{values['decoder']}' needs model_file (record one with "
                         f'ssvep_calibrate)')
    return TrcaModel.load(values['model_file'])


def _check_all(values: Dict[str, Any]) -> Optional[str]:
    try:
        _settings(values)
        _load_model(values)
    except ValueError as error:
        return str(error)
    return None


def _connection_settings(values: Dict[str, Any]) -> ConnectionSettings:
    """Return the LSL connection's settings from the parameters."""
    return ConnectionSettings(stale_timeout_s=values['stale_timeout_s'])


class SsvepDecoder(Node):
    """Publish SSVEP scores and choices from an EEG LSL stream."""

    def __init__(self, **kwargs):
        """Declare parameters and topics, start looking for the EEG stream."""
        super().__init__('ssvep_decoder', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._on_parameters, _check_all)
        self._model = _load_model(self._params)
        self._warnings = KeyedWarnings(self.get_logger())
        self._choice_pub = self.create_publisher(String, SSVEP_CHOICE_TOPIC, EVENT_QOS)
        self._scores_pub = self.create_publisher(JointState, SSVEP_SCORES_TOPIC, SCORES_QOS)
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)
        self.create_subscription(JointState, SSVEP_STIMULI_TOPIC, self._on_stimuli, LATCHED_QOS)
        self.create_subscription(Empty, REQUEST_TOPIC, self._on_request, EVENT_QOS)
        self._options: tuple = ()
        self._stimuli: Optional[StimulusMap] = None
        self._round_start = 0.0
        self._decoder: Optional[OnlineDecoder] = None
        self._channel_indices = None
        self._bind_error = ''
        self._time = NodeClock(self)
        self._connection = StreamConnection(
            EegStreamProfile(self._params), PylslBackend(),
            _connection_settings(self._params), LogReporter(self.get_logger()),
            ros_now_ns=self._time.ns,
            on_connected=self._on_connected, on_quiet=self._on_quiet)
        self._my_timers = {}
        self._make_timers(('poll_period_s', 'resolve_period_s', 'decide_period_s'))
        #: Choices published since start (for tests and tools).
        self.choices_published = 0
        self.get_logger().info(
            f"ssvep_decoder: {self._params['decoder']}, window {self._params['min_window_s']}"
            f"-{self._params['window_s']} s, threshold {self._params['threshold']}; looking "
            f"for an EEG stream ({self._params['layout']} layout)")

    # -- public state ------------------------------------------------------------------------

    @property
    def stream(self) -> str:
        """Describe the EEG stream in use ('' while looking)."""
        stream = self._connection.stream
        return stream.describe() if stream else ''

    @property
    def connection(self) -> StreamConnection:
        """Give the LSL connection in use (stream, clock offset, measured rate, gaps)."""
        return self._connection

    @property
    def channels(self):
        """Return the decoded channel names, or None until a stream fits the parameters."""
        return self._decoder.channels if self._decoder is not None else None

    def close_stream(self) -> None:
        """Close the inlet and stop looking for streams (before its outlet goes away)."""
        self._connection.close()
        self._decoder = None
        for key in ('poll_period_s', 'resolve_period_s'):
            timer = self._my_timers.pop(key, None)
            if timer is not None:
                self.destroy_timer(timer)

    def destroy_node(self):
        """Close the inlet, then destroy the node (a second call does nothing more)."""
        if self._my_timers.get('decide_period_s') is None:
            return None
        self.close_stream()
        self._my_timers.pop('decide_period_s', None)
        return super().destroy_node()

    # -- parameters --------------------------------------------------------------------------

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        self._params.update(changed)
        if {'decoder', 'model_file'} & set(changed):
            self._model = _load_model(self._params)
        profile = EegStreamProfile(self._params)
        if set(_STREAM_KEYS) & set(changed):
            self._decoder = None
            self._connection.reselect(profile, _connection_settings(self._params))
        else:
            self._connection.refit(profile, _connection_settings(self._params))
            if self._connection.stream is not None:
                self._bind()
        self._make_timers(changed)

    def _make_timers(self, changed) -> None:
        callbacks = {'poll_period_s': self._poll, 'resolve_period_s': self._maintain,
                     'decide_period_s': self._decide}
        for key, callback in callbacks.items():
            if key in changed:
                if key in self._my_timers:
                    self.destroy_timer(self._my_timers[key])
                self._my_timers[key] = self.create_timer(self._params[key], callback)

    def _now(self) -> float:
        return self._time.seconds()

    def _warn(self, key: str, text: str) -> None:
        """Log a warning of kind ``key`` at most once per WARN_PERIOD_S."""
        self._warnings.warn(key, text)

    # -- the stream --------------------------------------------------------------------------

    def _maintain(self) -> None:
        """Let the connection find, keep or switch the stream (resolve timer)."""
        try:
            self._connection.maintain()
        except Exception as error:  # noqa: B902 - a node never dies on a stream
            self._warn('maintain', f'LSL maintenance failed: {error}')

    def _on_connected(self, stream: StreamDescription) -> None:
        """Choose the channels of a stream just opened."""
        self._bind()

    def _on_quiet(self) -> None:
        """Say that no choice comes while the stream is quiet or lost."""
        self._warn('quiet', 'no SSVEP choice until EEG samples come again')
        if self._connection.stream is None:
            self._decoder = None

    def _bind(self) -> None:
        """Choose the channels and build the online decoder, or say why not."""
        self._decoder = None
        self._channel_indices = None
        stream = self._connection.stream
        try:
            layout = LAYOUTS[self._params['layout']]
            indices, names = resolve_channels(layout, stream.labels or (), stream.channel_count,
                                              parse_channels(self._params['channels']))
            if stream.nominal_srate <= 0:
                raise ValueError('the stream has an irregular rate (nominal 0 Hz); SSVEP '
                                 'needs a regular sampling rate')
            # The FBCCA null is measured in the background: no decision step waits for it.
            self._decoder = OnlineDecoder(stream.nominal_srate, names, _settings(self._params),
                                          self._model, background_null=True)
        except ValueError as error:
            self._bind_error = str(error)
            self.get_logger().warning(f'cannot decode {stream.describe()}: {error}; no SSVEP '
                                      'choice until the parameters fit the stream')
            return
        self._channel_indices = np.array(indices)
        self.get_logger().info(f"decoding channels {', '.join(names)} at "
                               f'{stream.nominal_srate:g} Hz')
        self._restart_round(self._round_start)

    def _poll(self) -> None:
        """Pull what the inlet holds and feed the decoder."""
        try:
            for chunk in self._connection.acquire():
                self._feed(chunk.samples[chunk.good], chunk.stamps_ns[chunk.good] * 1e-9)
        except Exception as error:  # noqa: B902 - a node never dies on a sample
            self._warn('read', f'failed to decode {self.stream}: {error}')

    def _feed(self, samples: np.ndarray, stamps: np.ndarray) -> None:
        """Give the decoder a chunk: samples (N, C), ROS times (N,) s."""
        if self._decoder is None:
            self._warn('bind', f'EEG samples dropped: {self._bind_error}')
            return
        if len(stamps):
            self._decoder.add(stamps, np.asarray(samples, dtype=float)[:, self._channel_indices])

    # -- options, stimuli, rounds ------------------------------------------------------------

    def _restart_round(self, start: float) -> None:
        self._round_start = start
        if self._decoder is not None and self._options:
            self._decoder.start_round(start, self._options, self._stimuli)

    def _on_regions(self, msg: MarkerArray) -> None:
        try:
            labels = tuple(marker_array_to_regions(msg)[0])
            if labels == self._options:
                return
            self._options = labels
            stamp = time_to_seconds(msg.markers[0].header.stamp) if msg.markers else 0.0
            self._restart_round(max(stamp or self._now(), self._epoch()))
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._warn('regions', f'regions message ignored: {error}')

    def _epoch(self) -> float:
        return self._stimuli.epoch_s if self._stimuli is not None else 0.0

    def _on_stimuli(self, msg: JointState) -> None:
        try:
            stimuli = msg_to_stimulus_map(msg)
        except ValueError as error:
            self._stimuli = None
            self._warn('stimuli', f'stimulus map on {SSVEP_STIMULI_TOPIC} ignored: {error}; no '
                       'SSVEP choice until a valid one arrives')
            self._restart_round(self._now())
            return
        if stimuli.epoch_s == 0.0:
            stimuli = StimulusMap(stimuli.labels, stimuli.frequencies, stimuli.phases,
                                  self._now())
        self._stimuli = stimuli
        self._restart_round(max(stimuli.epoch_s, self._round_start))

    def _on_request(self, msg: Empty) -> None:
        self._restart_round(self._now())

    # -- deciding ----------------------------------------------------------------------------

    def _decide(self) -> None:
        try:
            if self._decoder is None or not self._options:
                return
            done = not self._decoder.round_open
            result = self._decoder.step()
            for note in self._decoder.notes:
                self.get_logger().warning(note)
            self._decoder.notes.clear()
            if result is None:
                return
            if result.problem:
                if not done:
                    self._warn(result.problem[:30], f'no SSVEP choice: {result.problem}')
                return
            if result.excluded:
                self._warn('excluded', f"EEG channels left out: {', '.join(result.excluded)}")
            if len(result.scores):
                self._scores_pub.publish(scores_to_msg(result.labels, result.posterior,
                                                       result.scores, result.window_s,
                                                       result.end_s))
            if result.choice is not None:
                self._choice_pub.publish(String(data=result.choice))
                self.choices_published += 1
                self.get_logger().info(
                    f"SSVEP choice '{result.choice}' after a {result.window_s:.2f} s window "
                    f'(posterior {result.posterior.max():.3f}, evidence z '
                    f'{result.evidence.max():.1f})')
        except Exception as error:  # noqa: B902 - a node never dies on a timer
            self._warn('decide', f'SSVEP decoding failed: {error}')


def main(args=None):
    """Run the ssvep_decoder node."""
    spin_node(SsvepDecoder, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
