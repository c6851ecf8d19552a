"""
The LSL connection's rules without liblsl: a fake clock and a fake network.

The fakes stand for liblsl only (resolver results, descriptions, an inlet's
pulls and clock offset); every rule exercised is the real
:class:`eye_bci_ros2.streams.lsl_connection.StreamConnection`.  The same rules run with
real liblsl in ``test/nodes/test_lsl_gaze_bridge.py`` and
``test/nodes/test_lsl_stream_choice.py``.
"""

from dataclasses import replace

import numpy as np
import pytest

from eye_bci_ros2.gaze.profiles import build_config, PROFILES
from eye_bci_ros2.gaze.stream import GazeStreamProfile, misfit
from eye_bci_ros2.ssvep.eeg_stream import EegStreamProfile
from eye_bci_ros2.streams.lsl_connection import (acquisition_stamps_ns, CLOCK_SYNC_TIMEOUT_S,
                                                 ConnectionSettings, find_gaps, LOST_IGNORE_S,
                                                 StreamConnection, StreamDescription, StreamLost)


class Clock:
    """A monotonic clock that moves only when told (s)."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class FakeInlet:
    """Chunks queued by the test; a clock offset once ``offset`` is set."""

    def __init__(self):
        self.queue = []
        self.offset = None
        self.lost = False
        self.closed = False

    def start(self):
        pass

    def time_correction(self):
        return self.offset

    def pull(self):
        if self.lost:
            raise StreamLost('gone')
        if not self.queue:
            return np.zeros((0, 2)), np.zeros(0)
        return self.queue.pop(0)

    def close(self):
        self.closed = True


class FakeLsl:
    """The network: streams advertised (with labels) and the inlets opened on them."""

    def __init__(self, lsl_clock=1000.0):
        self.streams = []
        self.inlets = {}
        self.lsl_clock = lsl_clock

    def local_clock(self):
        return self.lsl_clock

    def resolver(self, predicate):
        return self

    def results(self):
        return [replace(stream, labels=None) for stream in self.streams]

    def describe(self, stream):
        return next(s for s in self.streams if s.uid == stream.uid)

    def open_inlet(self, stream, max_chunk):
        self.inlets[stream.uid] = FakeInlet()
        return self.inlets[stream.uid]


class Log:
    """Every line the connection logs, with its level."""

    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(('info', text))

    def warning(self, text):
        self.lines.append(('warning', text))

    def throttled(self, key, text):
        self.lines.append(('warning', text))

    def text(self):
        return '\n'.join(text for _, text in self.lines)


def stream(uid, stream_type='Gaze', name='tracker', source_id='', channels=2, rate=0.0,
           created_at=1.0, labels=('', '')):
    """Describe a stream as the network advertises it."""
    return StreamDescription(uid=uid, name=name, stream_type=stream_type, source_id=source_id,
                             hostname='host', channel_count=channels, nominal_srate=rate,
                             created_at=created_at, labels=tuple(labels))


PUPIL = stream('pupil', name='pupil_capture', channels=22,
               labels=PROFILES['pupil_capture'].channel_labels)


def connection(profile=None, lsl=None, clock=None, ros_ns=None, **settings):
    """Make a connection on the fake network, by default with the default gaze profile."""
    lsl = lsl or FakeLsl()
    clock = clock or Clock()
    log = Log()
    connected = []
    conn = StreamConnection(
        profile or GazeStreamProfile(build_config({})), lsl, ConnectionSettings(**settings),
        log, ros_now_ns=ros_ns or (lambda: 5_000_000_000_000), clock=clock,
        on_connected=connected.append)
    return conn, lsl, clock, log, connected


def test_one_fitting_stream_is_taken_with_its_labels():
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [stream('a', source_id='tobii-1')]
    conn.maintain()
    assert conn.stream.uid == 'a' and connected == [conn.stream]
    assert "connected to gaze LSL stream 'tracker'" in log.text()


def test_a_pupil_stream_is_refused_under_xy_pixels_naming_the_profile_that_fits():
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [PUPIL]
    conn.maintain()
    conn.maintain()
    assert conn.stream is None and connected == []
    refusals = [text for level, text in log.lines if 'not taking' in text]
    assert len(refusals) == 1   # once, not at every look
    assert "does not fit profile 'xy_pixels'" in refusals[0]
    assert 'profile:=pupil_capture' in refusals[0] and 'confidence, norm_pos_x' in refusals[0]
    # Under the profile it fits, it is taken.
    conn.reselect(GazeStreamProfile(build_config({'profile': 'pupil_capture'})))
    conn.maintain()
    assert conn.stream.uid == 'pupil'


def test_of_a_refused_and_a_fitting_stream_the_fitting_one_is_taken():
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [PUPIL, stream('xy', source_id='crlab', created_at=0.5)]
    conn.maintain()
    assert conn.stream.uid == 'xy'


def test_explicit_channels_are_checked_against_the_labels_not_the_layout():
    profile = GazeStreamProfile(build_config({'profile': 'xy_pixels', 'x_channel': 'norm_pos_x',
                                              'y_channel': 'norm_pos_y'}))
    conn, lsl, clock, log, connected = connection(profile)
    lsl.streams = [PUPIL]
    conn.maintain()
    assert conn.stream.uid == 'pupil'


def test_strings_are_refused():
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [replace(stream('markers'), numeric=False)]
    conn.maintain()
    assert conn.stream is None and 'carries strings' in log.text()


def test_several_sources_take_none_and_say_how_to_pick_one():
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [stream('mine', source_id='tobii-A', created_at=1.0),
                   stream('theirs', source_id='tobii-B', created_at=2.0)]
    conn.maintain()
    conn.maintain()
    assert conn.stream is None and connected == []
    warnings = [text for level, text in log.lines if 'taking none' in text]
    assert len(warnings) == 1
    assert "source_id:='tobii-A'" in warnings[0] and "source_id:='tobii-B'" in warnings[0]
    # Streams without source_ids are told apart by name.
    conn2, lsl2, _, log2, _ = connection()
    lsl2.streams = [stream('x', name='left'), stream('y', name='right')]
    conn2.maintain()
    assert conn2.stream is None
    assert "stream_name:='left'" in log2.text() and "stream_name:='right'" in log2.text()


def test_several_streams_of_one_source_take_the_newest():
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [stream('old', source_id='tobii-A', created_at=1.0),
                   stream('new', source_id='tobii-A', created_at=2.0)]
    conn.maintain()
    assert conn.stream.uid == 'new'


def test_a_further_stream_is_reported_once_and_never_used():
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [stream('mine', source_id='tobii-A')]
    conn.maintain()
    lsl.streams.append(stream('theirs', source_id='tobii-B', created_at=2.0))
    conn.maintain()
    conn.maintain()
    assert conn.stream.uid == 'mine'
    reports = [text for level, text in log.lines if 'another LSL stream' in text]
    assert len(reports) == 1 and "set the parameter source_id to 'tobii-B'" in reports[0]


def test_a_lost_stream_is_ignored_for_a_while_then_its_source_is_preferred():
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [stream('a1', source_id='tobii-A')]
    conn.maintain()
    lsl.inlets['a1'].offset = 0.0
    lsl.inlets['a1'].lost = True
    assert conn.acquire() == [] and conn.stream is None
    assert 'lost gaze stream' in log.text()
    # The dead outlet is still listed: not reopened until the ignore-list entry expires.
    conn.maintain()
    assert conn.stream is None
    # The application restarts (same source) while another device appeared: its source wins.
    lsl.streams = [stream('a1', source_id='tobii-A'),
                   stream('b', source_id='tobii-B', created_at=3.0),
                   stream('a2', source_id='tobii-A', created_at=2.0)]
    conn.maintain()
    assert conn.stream.uid == 'a2'
    # To the user it is the same stream back, not a switch to one of the same name.
    assert "source_id 'tobii-A', 2 ch, irregular rate, host host) is back (its sender " \
        'restarted); reconnecting' in log.text()
    assert 'switching to' not in log.text()
    conn.disconnect()
    clock.now += LOST_IGNORE_S + 0.1   # the entry expired: a1 is a candidate again
    conn.maintain()
    assert conn.stream.uid == 'a2'      # still the newest of the source


def test_a_quiet_stream_is_kept_while_advertised_and_replaced_when_gone():
    conn, lsl, clock, log, connected = connection(stale_timeout_s=1.0)
    quiet = []
    conn._on_quiet = lambda: quiet.append(True)
    lsl.streams = [stream('a', source_id='tobii-A')]
    conn.maintain()
    lsl.inlets['a'].offset = 0.0
    conn.acquire()
    clock.now += 2.0
    conn.maintain()
    assert conn.stale and conn.stream.uid == 'a' and quiet == [True]
    lsl.streams = [stream('b', source_id='tobii-B', created_at=2.0)]
    conn.maintain()
    assert conn.stream.uid == 'b' and 'no longer advertised' in log.text()


def test_samples_wait_for_the_clock_offset_then_map_to_ros_time():
    # LSL clock 1000 s here, ROS clock 5000 s: a sample taken at sender time 900 s with an
    # offset of +99.5 s was taken at 999.5 s here, 0.5 s ago: ROS 4999.5 s.
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [stream('a', source_id='s')]
    conn.maintain()
    inlet = lsl.inlets['a']
    inlet.queue.append((np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([899.9, 900.0])))
    assert conn.acquire() == [] and inlet.queue   # held in the inlet
    inlet.offset = 99.5
    chunk, = conn.acquire()
    np.testing.assert_array_equal(chunk.stamps_ns, [4_999_400_000_000, 4_999_500_000_000])
    assert chunk.good.all() and conn.clock_offset == 99.5


def test_without_an_offset_chunks_are_placed_at_arrival_keeping_their_spacing():
    conn, lsl, clock, log, connected = connection()
    lsl.streams = [stream('a', source_id='s')]
    conn.maintain()
    inlet = lsl.inlets['a']
    clock.now += CLOCK_SYNC_TIMEOUT_S + 0.1
    inlet.queue.append((np.zeros((3, 2)), np.array([10.0, 10.25, 10.5])))
    chunk, = conn.acquire()
    np.testing.assert_array_equal(chunk.stamps_ns,
                                  [4_999_500_000_000, 4_999_750_000_000, 5_000_000_000_000])
    assert 'placing each chunk at its arrival time' in log.text()
    inlet.offset = 0.0   # the time service answers: the next check takes it
    conn.maintain()
    inlet.queue.append((np.zeros((1, 2)), np.array([999.0])))
    chunk, = conn.acquire()
    assert chunk.stamps_ns[0] == 4_999_000_000_000 and 'known again' in log.text()


def test_gaze_and_eeg_connections_stamp_one_lsl_time_alike():
    """The one mapping: the same sender time is the same ROS time for gaze and EEG."""
    stamps = {}
    for kind, profile, item in (
            ('gaze', GazeStreamProfile(build_config({})), stream('g', source_id='s')),
            ('EEG', EegStreamProfile({'layout': 'generic'}),
             stream('e', stream_type='EEG', source_id='s', channels=8, rate=250.0,
                    labels=[''] * 8))):
        lsl = FakeLsl()
        conn, lsl, clock, log, _ = connection(profile, lsl)
        lsl.streams = [item]
        conn.maintain()
        lsl.inlets[item.uid].offset = 0.25
        lsl.inlets[item.uid].queue.append(
            (np.zeros((1, item.channel_count)), np.array([998.0])))
        chunk, = conn.acquire()
        stamps[kind] = chunk.stamps_ns[0]
    assert stamps['gaze'] == stamps['EEG'] == 4_998_250_000_000


def test_corrupt_stamps_are_marked_not_good():
    stamps_ns, good = acquisition_stamps_ns(np.array([1.0, np.nan, 1e12, -1e12]), 0.0,
                                            10_000_000_000, 2.0)
    assert good.tolist() == [True, False, False, False]
    assert stamps_ns[0] == 9_000_000_000


def test_gaps_and_measured_rate():
    rate = 250.0
    times = np.arange(1000) / rate
    times[500:] += 0.3   # 0.3 s missing
    assert np.allclose(find_gaps(times, rate), [0.3 + 1 / rate])
    assert len(find_gaps(times + 1e-4 * np.sin(times), rate)) == 1   # jitter is not a gap
    assert len(find_gaps(times, 0.0)) == 0   # irregular streams have no gaps
    conn, lsl, clock, log, _ = connection(
        EegStreamProfile({'layout': 'generic'}))
    lsl.streams = [stream('e', stream_type='EEG', channels=1, rate=rate, labels=[''])]
    conn.maintain()
    inlet = lsl.inlets['e']
    inlet.offset = 0.0
    for start in range(0, 1000, 100):
        inlet.queue.append((np.zeros((100, 1)), times[start:start + 100]))
        conn.acquire()
    assert conn.gaps == 1 and conn.gap_s == pytest.approx(0.304)
    assert 'gap(s) in' in log.text()
    # The rate the sample times show between the gaps; a sender at 500 Hz would say so.
    assert conn.measured_rate_hz == pytest.approx(rate, rel=1e-6)


def test_eeg_profile_selects_by_layout_type_name_and_source():
    profile = EegStreamProfile({'layout': 'liveamp', 'stream_type': '', 'stream_name': '',
                                'source_id': 'amp-7'})
    assert profile.predicate() == "type='EEG' and source_id='amp-7'"
    assert profile.matches(stream('x', stream_type='EEG', name='LiveAmpSN-1234',
                                  source_id='amp-7'))
    assert not profile.matches(stream('x', stream_type='EEG', name='obci_eeg1',
                                      source_id='amp-7'))
    assert not profile.matches(stream('x', stream_type='EEG', name='LiveAmpSN-1234',
                                      source_id='amp-8'))


@pytest.mark.parametrize('sender', ['tobii_pro', 'pupil_capture', 'xy_pixels'])
def test_each_application_layout_fits_its_profile_and_is_named_under_another(sender):
    """Every tracker layout is taken by its own profile and refused, naming it, by the others."""
    spec = PROFILES[sender]
    labels = spec.channel_labels if spec.labelled else ('',) * len(spec.channel_labels)
    for profile_name in ('tobii_pro', 'pupil_capture', 'xy_pixels'):
        reason = misfit(build_config({'profile': profile_name}), labels, len(labels))
        if profile_name == sender:
            assert reason is None
        elif len(PROFILES[profile_name].channel_labels) != len(labels):
            assert f"does not fit profile '{profile_name}'" in reason
            assert f'profile:={sender}' in reason
