"""
Node ``ssvep_decoder``: choose among the offered options from SSVEP in EEG over LSL.

Subscribes ``choices/regions`` (visualization_msgs/MarkerArray, latched: the
offered options' labels, the marker's text else ``ns/id``), ``ssvep/stimuli``
(sensor_msgs/JointState, latched: each option's flicker, see
:mod:`eye_bci_ros2.nodes.ssvep_messages`) and ``choice/request``
(std_msgs/Empty); reads an EEG stream from LSL (:mod:`eye_bci_ros2.ssvep.layouts`);
publishes ``ssvep/scores`` (sensor_msgs/JointState, every ``decide_period_s``
while a round is open, and after its choice with ``keep_scoring``: per-option
posterior and score) and ``ssvep/choice``
(std_msgs/String, the chosen label, at most once per round).

Rounds: a round starts when the set of offered labels changes, when a new
stimulus map arrives, or on ``choice/request``; it starts at the latest of
the regions' stamp, the stimulus epoch and the request (node clock), and
ends with its choice (:mod:`eye_bci_ros2.ssvep.online`).

The stream is found by a ``pylsl.ContinuousResolver`` polled by a timer and
read by a second timer with zero-timeout pulls, so nothing blocks the
executor.  Sample times: the sender's LSL timestamps, corrected by liblsl's
clock offset to this machine (refreshed in the background), then mapped to
the ROS clock by ``ros_now - local_clock()`` at each pull.

Bad input never chooses and never stops the node; each kind is logged as one
line at most every 5 s: a lost stream (the node looks for it again), a quiet
stream, channels that cannot be found (missing labels), railed / flat / NaN
channels, a wrong rate, an irregular-rate stream, a stimulus map that does
not match the options or is invalid.
"""

import math
import time
from typing import Any, Dict, Optional

import numpy as np
import pylsl
from pylsl.util import LostError, TimeoutError as LslTimeoutError
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Empty, String
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.gaze_stream import channel_labels
from eye_bci_ros2.nodes.conversions import marker_array_to_regions
from eye_bci_ros2.nodes.log_throttle import KeyedWarnings
from eye_bci_ros2.nodes.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.nodes.runner import spin_node
from eye_bci_ros2.nodes.ssvep_messages import (msg_to_stimulus_map, scores_to_msg,
                                               time_to_seconds)
from eye_bci_ros2.nodes.topics import (EVENT_QOS, LATCHED_QOS, SCORES_QOS, SSVEP_CHOICE_TOPIC,
                                       SSVEP_SCORES_TOPIC, SSVEP_STIMULI_TOPIC)
from eye_bci_ros2.ssvep.decision import DEFAULT_GAIN, DEFAULT_REST_Z, RULES
from eye_bci_ros2.ssvep.decoders import DECODERS, TrcaModel
from eye_bci_ros2.ssvep.layouts import (ANY, LAYOUT_NAMES, LAYOUTS, parse_channels,
                                        resolve_channels, stream_name_matches)
from eye_bci_ros2.ssvep.online import DEFAULT_ONSET_S, OnlineDecoder, OnlineSettings
from eye_bci_ros2.ssvep.stimuli import StimulusMap

#: A resolver forgets a stream this long after it stopped answering, s.
RESOLVER_FORGET_S = 2.0
#: Longest wait for a stream's full description when connecting, s.
INFO_TIMEOUT_S = 0.2
#: Without a clock offset after this long, the offset is taken as 0 (same host), s.
CLOCK_SYNC_TIMEOUT_S = 5.0
#: Inlet buffer, s.
INLET_BUFFER_S = 30
#: Refresh the LSL clock offset this often, s.
TIME_CORRECTION_PERIOD_S = 5.0


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


def _describe(info: pylsl.StreamInfo) -> str:
    rate = info.nominal_srate()
    return (f"'{info.name()}' (type '{info.type()}', source_id '{info.source_id()}', "
            f"{info.channel_count()} ch, {f'{rate:g} Hz' if rate > 0 else 'irregular rate'})")


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
        self.create_subscription(MarkerArray, 'choices/regions', self._on_regions, LATCHED_QOS)
        self.create_subscription(JointState, SSVEP_STIMULI_TOPIC, self._on_stimuli, LATCHED_QOS)
        self.create_subscription(Empty, 'choice/request', self._on_request, EVENT_QOS)
        self._options: tuple = ()
        self._stimuli: Optional[StimulusMap] = None
        self._round_start = 0.0
        self._inlet: Optional[pylsl.StreamInlet] = None
        self._stream = ''
        self._uid = ''
        self._ignored: Dict[str, float] = {}
        self._decoder: Optional[OnlineDecoder] = None
        self._channel_indices = None
        self._bind_error = ''
        self._labels = []
        self._rate = 0.0
        self._time_correction: Optional[float] = None
        self._corrected_at = 0.0
        self._connected_at = 0.0
        self._last_sample_at = 0.0
        self._buffer = None
        self._resolver = None
        self._start_resolver()
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
        return self._stream

    @property
    def channels(self):
        """Return the decoded channel names, or None until a stream fits the parameters."""
        return self._decoder.channels if self._decoder is not None else None

    def close_stream(self) -> None:
        """Close the inlet and stop looking for streams (before its outlet goes away)."""
        self._disconnect()
        self._resolver = None
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
        if set(_STREAM_KEYS) & set(changed):
            self._disconnect()
            self._ignored.clear()
            self._start_resolver()
        elif self._inlet is not None:
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
        return self.get_clock().now().nanoseconds * 1e-9

    def _warn(self, key: str, text: str) -> None:
        """Log a warning of kind ``key`` at most once per WARN_PERIOD_S."""
        self._warnings.warn(key, text)

    # -- the stream --------------------------------------------------------------------------

    def _start_resolver(self) -> None:
        layout = LAYOUTS[self._params['layout']]
        stream_type = self._params['stream_type'] or layout.stream_type
        terms = []
        if stream_type != ANY and "'" not in stream_type:
            terms.append(f"type='{stream_type}'")
        if self._params['source_id'] and "'" not in self._params['source_id']:
            terms.append(f"source_id='{self._params['source_id']}'")
        try:
            self._resolver = pylsl.ContinuousResolver(
                pred=' and '.join(terms), forget_after=RESOLVER_FORGET_S) if terms \
                else pylsl.ContinuousResolver(forget_after=RESOLVER_FORGET_S)
        except Exception as error:  # noqa: B902 - liblsl errors must not kill the node
            self._resolver = None
            self.get_logger().error(f'cannot start the LSL resolver: {error}')

    def _matches(self, info: pylsl.StreamInfo) -> bool:
        layout = LAYOUTS[self._params['layout']]
        stream_type = self._params['stream_type'] or layout.stream_type
        source_id = self._params['source_id']
        return ((stream_type == ANY or info.type() == stream_type)
                and stream_name_matches(layout, info.name(), self._params['stream_name'])
                and (not source_id or info.source_id() == source_id)
                and info.channel_format() != pylsl.cf_string)

    def _maintain(self) -> None:
        """Connect when idle; refresh the clock offset; report a quiet stream."""
        try:
            now = time.monotonic()
            if self._inlet is None:
                self._connect(now)
                return
            if now - self._corrected_at >= TIME_CORRECTION_PERIOD_S:
                self._refresh_correction(now)
            quiet = now - max(self._last_sample_at, self._connected_at)
            if quiet >= self._params['stale_timeout_s']:
                self._warn('stale', f'no EEG samples from {self._stream} for {quiet:.1f} s: '
                           'no SSVEP choice until they resume')
        except Exception as error:  # noqa: B902 - a node never dies on a stream
            self._warn('maintain', f'LSL maintenance failed: {error}')

    def _connect(self, now: float) -> None:
        if self._resolver is None:
            self._start_resolver()
            return
        candidates = [info for info in self._resolver.results()
                      if self._matches(info) and self._ignored.get(info.uid(), 0.0) <= now]
        if not candidates:
            self._warn('looking', f"looking for an EEG LSL stream ({self._params['layout']} "
                       'layout); none found yet')
            return
        info = max(candidates, key=lambda item: item.created_at())
        inlet = pylsl.StreamInlet(info, max_buflen=INLET_BUFFER_S, recover=False)
        try:
            full = inlet.info(timeout=INFO_TIMEOUT_S)
        except LslTimeoutError:
            return
        except LostError:
            self._ignored[info.uid()] = now + 2.5 * RESOLVER_FORGET_S
            return
        for call in (inlet.open_stream, inlet.time_correction):
            try:
                call(timeout=0.0)
            except LslTimeoutError:
                pass
        self._inlet, self._uid, self._stream = inlet, full.uid(), _describe(full)
        self._labels = channel_labels(full)
        self._rate = full.nominal_srate()
        self._connected_at = self._last_sample_at = now
        self._time_correction = None
        self._buffer = np.empty((1024, inlet.channel_count), dtype=inlet.np_dtype)
        self.get_logger().info(f'connected to EEG stream {self._stream}; channels: '
                               f"{', '.join(lb or '?' for lb in self._labels) or 'no labels'}")
        self._bind()

    def _bind(self) -> None:
        """Choose the channels and build the online decoder, or say why not."""
        self._decoder = None
        self._channel_indices = None
        try:
            layout = LAYOUTS[self._params['layout']]
            indices, names = resolve_channels(layout, self._labels, self._buffer.shape[1],
                                              parse_channels(self._params['channels']))
            if self._rate <= 0:
                raise ValueError('the stream has an irregular rate (nominal 0 Hz); SSVEP '
                                 'needs a regular sampling rate')
            self._decoder = OnlineDecoder(self._rate, names, _settings(self._params),
                                          self._model)
        except ValueError as error:
            self._bind_error = str(error)
            self.get_logger().warning(f'cannot decode {self._stream}: {error}; no SSVEP '
                                      'choice until the parameters fit the stream')
            return
        self._channel_indices = np.array(indices)
        self.get_logger().info(f"decoding channels {', '.join(names)} at {self._rate:g} Hz")
        self._restart_round(self._round_start)

    def _disconnect(self) -> None:
        inlet, self._inlet = self._inlet, None
        self._stream, self._decoder = '', None
        if inlet is not None:
            try:
                inlet.close_stream()
            except Exception:  # noqa: B902 - closing a dead inlet may fail; nothing to do
                pass

    def _refresh_correction(self, now: float) -> bool:
        try:
            self._time_correction = self._inlet.time_correction(timeout=0.0)
            self._corrected_at = now
        except LslTimeoutError:
            pass
        return self._time_correction is not None

    def _poll(self) -> None:
        """Pull what the inlet holds and feed the decoder."""
        if self._inlet is None:
            return
        now = time.monotonic()
        try:
            if self._time_correction is None and not self._refresh_correction(now):
                if now - self._connected_at < CLOCK_SYNC_TIMEOUT_S:
                    return  # keep the samples in the inlet until they can be timed
                self._time_correction = 0.0
                self._warn('clock', f'no LSL clock offset from {self._stream}: taking it as '
                           '0 (same machine)')
            for _ in range(8):
                samples, stamps = self._inlet.pull_chunk(
                    timeout=0.0, max_samples=len(self._buffer), dest_obj=self._buffer,
                    as_numpy=True)
                if not len(stamps):
                    break
                self._last_sample_at = now
                self._feed(np.asarray(samples, dtype=float), np.asarray(stamps, dtype=float))
                if len(stamps) < len(self._buffer):
                    break
        except LostError:
            self.get_logger().warning(f'lost EEG stream {self._stream}; no SSVEP choice '
                                      'until it is back; looking for it')
            self._ignored[self._uid] = now + 2.5 * RESOLVER_FORGET_S
            self._disconnect()
        except Exception as error:  # noqa: B902 - a node never dies on a sample
            self._warn('read', f'failed to read {self._stream}: {error}')

    def _feed(self, samples: np.ndarray, stamps: np.ndarray) -> None:
        if self._decoder is None:
            self._warn('bind', f'EEG samples dropped: {self._bind_error}')
            return
        offset = self._now() - pylsl.local_clock() + self._time_correction
        self._decoder.add(stamps + offset, samples[:, self._channel_indices])

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
