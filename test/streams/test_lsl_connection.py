"""
The LSL connection's rules on real liblsl: real outlets on loopback, the real pylsl adapter.

Every rule runs in the real
:class:`eye_bci_ros2.streams.lsl_connection.StreamConnection` over the real
:class:`eye_bci_ros2.ros.lsl_adapter.PylslBackend`, reading outlets opened by
the test (each with a unique stream type, so that tests running at the same
time on this machine never see each other's streams).  An outlet pushes any
stamp (``push_chunk(x, timestamps)``), stops and comes back.

Two faults cannot be produced on loopback and are the only things the
:class:`Network` below changes (each says so where it does it): an LSL time
service that does not answer (liblsl on loopback always returns a clock
offset within milliseconds), and a broken connection to an outlet that is
still alive and advertised (on one machine the connection only breaks when the
outlet goes).  The connection's monotonic clock is real time, moved ahead by
:meth:`Clock.skip` to pass its timeouts (5 s) without waiting them out.

The pure parts (the stamp mapping, gap finding, the profiles) are in
``test/unit/streams/test_lsl_connection_rules.py``; the nodes reading through
this connection in ``test/nodes/test_lsl_gaze_bridge.py`` and
``test/nodes/test_lsl_stream_choice.py``.
"""

import time

from lsl_outlets import make_outlet, unique_id
import numpy as np
import pylsl
import pytest

from eye_bci_ros2.gaze.profiles import build_config, PROFILES
from eye_bci_ros2.gaze.stream import GazeStreamProfile
from eye_bci_ros2.ros.lsl_adapter import PylslBackend
from eye_bci_ros2.sim.lsl_outlet import open_outlet, stream_info
from eye_bci_ros2.ssvep.eeg_stream import EegStreamProfile
from eye_bci_ros2.streams.lsl_connection import (CLOCK_SYNC_TIMEOUT_S, ConnectionSettings,
                                                 LOST_IGNORE_S, StreamConnection, StreamLost)

pytestmark = pytest.mark.lsl

#: Generous deadline for anything LSL does on loopback, s.
WAIT_S = 10.0
#: The ROS clock of these tests: the LSL clock plus this, s (a known, exact relation).
ROS_MINUS_LSL_S = 4000.0
#: clock_pair reads the two clocks within CLOCK_BRACKET_S (20 us); a loaded machine may
#: take longer between reads, so the stamps are checked to this, ns.
STAMP_TOLERANCE_NS = 1_000_000


def ros_now_ns() -> int:
    """Return the tests' ROS clock: the LSL clock shifted by ROS_MINUS_LSL_S, ns."""
    return int(round((pylsl.local_clock() + ROS_MINUS_LSL_S) * 1e9))


class Clock:
    """Real monotonic time, moved ahead by :meth:`skip` to pass the connection's timeouts."""

    def __init__(self):
        self.skipped = 0.0

    def __call__(self) -> float:
        return time.monotonic() + self.skipped

    def skip(self, seconds: float) -> None:
        """Let ``seconds`` pass for the connection at once."""
        self.skipped += seconds


class _Inlet:
    """A real pylsl inlet whose clock offset or connection the test can take away."""

    def __init__(self, inlet, network: 'Network'):
        self._inlet = inlet
        self._network = network
        self.broken = False

    def start(self):
        self._inlet.start()

    def time_correction(self):
        # Fault: the LSL time service does not answer (cannot be provoked on loopback).
        if self._network.offset_hidden:
            return None
        return self._inlet.time_correction()

    def pull(self):
        # Fault: the connection broke while the outlet lives on (cannot be provoked on
        # loopback, where a connection only breaks when its outlet is destroyed).
        if self.broken:
            raise StreamLost('connection broken by the test')
        return self._inlet.pull()

    def close(self):
        self._inlet.close()


class Network(PylslBackend):
    """
    The real pylsl adapter, giving the test its resolvers and inlets to look at.

    :attr:`offset_hidden` and :meth:`break_connection` are the two faults of
    the module doc; nothing else differs from the nodes' backend.
    """

    def __init__(self):
        self.resolvers = []
        self.inlets = {}
        self.offset_hidden = False

    def resolver(self, predicate):
        resolver = super().resolver(predicate)
        self.resolvers.append(resolver)
        return resolver

    def open_inlet(self, stream, max_chunk):
        self.inlets[stream.uid] = _Inlet(super().open_inlet(stream, max_chunk), self)
        return self.inlets[stream.uid]

    def break_connection(self, uid: str) -> None:
        """Break the connection to the stream ``uid`` (its outlet stays up)."""
        self.inlets[uid].broken = True

    def advertises(self, *uids: str) -> bool:
        """Tell whether the connection's resolver lists every stream of ``uids`` now."""
        listed = {stream.uid for stream in self.resolvers[0].results()}
        return set(uids) <= listed


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

    def having(self, part):
        """Return the lines containing ``part``."""
        return [text for _, text in self.lines if part in text]


class Rig:
    """A connection on the real network, with its clock, log and call-backs."""

    def __init__(self, profile, **settings):
        self.network = Network()
        self.clock = Clock()
        self.log = Log()
        self.connected = []
        self.quiet = []
        self.conn = StreamConnection(
            profile, self.network, ConnectionSettings(**settings), self.log,
            ros_now_ns=ros_now_ns, clock=self.clock, on_connected=self.connected.append,
            on_quiet=lambda: self.quiet.append(True))

    def until(self, condition, step=None, timeout=WAIT_S) -> bool:
        """Run ``step`` (default: maintain) until ``condition()``; False after ``timeout`` s."""
        step = step or self.conn.maintain
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            step()
            if condition():
                return True
            time.sleep(0.01)   # a poll period, as the nodes' timers have
        return False

    def wait_advertised(self, *infos) -> None:
        """Wait until the connection's own resolver lists all these streams (before choosing)."""
        uids = [info.uid() for info in infos]
        assert self.until(lambda: self.network.advertises(*uids), step=lambda: None), uids

    def connect(self, uid: str) -> None:
        """Maintain until the stream ``uid`` is open."""
        assert self.until(lambda: self.conn.stream is not None), self.log.text()
        assert self.conn.stream.uid == uid, self.log.text()

    def read(self, count: int):
        """Acquire until ``count`` samples arrived; return the chunks."""
        chunks = []

        def pull():
            chunks.extend(self.conn.acquire())
        assert self.until(lambda: sum(len(chunk.stamps_ns) for chunk in chunks) >= count,
                          step=pull), self.log.text()
        return chunks

    def close(self):
        self.conn.close()


@pytest.fixture
def stream_type():
    """Return a stream type no other test on this machine advertises."""
    return unique_id('Gaze')


def gaze_rig(stream_type, **config):
    """Make a gaze connection selecting ``stream_type`` (default profile xy_pixels)."""
    return Rig(GazeStreamProfile(build_config({'stream_type': stream_type, **config})))


def test_one_fitting_stream_is_taken_with_its_labels(stream_type):
    outlet, info = make_outlet('xy_pixels', stream_type=stream_type, source_id=unique_id('tobii'),
                               labelled=True)
    rig = gaze_rig(stream_type)
    rig.connect(info.uid())
    assert rig.connected == [rig.conn.stream]
    assert rig.conn.stream.labels == PROFILES['xy_pixels'].channel_labels
    assert f"connected to gaze LSL stream '{info.name()}'" in rig.log.text()
    assert outlet.wait_for_consumers(WAIT_S)
    rig.close()


def test_a_pupil_stream_is_refused_under_xy_pixels_naming_the_profile_that_fits(stream_type):
    pupil, info = make_outlet('pupil_capture', stream_type=stream_type)
    rig = gaze_rig(stream_type)
    assert rig.until(lambda: rig.log.having('not taking'))
    for _ in range(5):
        rig.conn.maintain()
    assert rig.conn.stream is None and rig.connected == []
    refusal, = rig.log.having('not taking')   # once, not at every look
    assert "does not fit profile 'xy_pixels'" in refusal
    assert 'profile:=pupil_capture' in refusal and 'confidence, norm_pos_x' in refusal
    assert not pupil.have_consumers()
    # Under the profile it fits, it is taken.
    rig.conn.reselect(GazeStreamProfile(build_config({
        'profile': 'pupil_capture', 'stream_type': stream_type, 'stream_name': info.name()})))
    rig.connect(info.uid())
    rig.close()


def test_of_a_refused_and_a_fitting_stream_the_fitting_one_is_taken(stream_type):
    pupil, pupil_info = make_outlet('pupil_capture', stream_type=stream_type)
    xy, xy_info = make_outlet('xy_pixels', stream_type=stream_type)
    rig = gaze_rig(stream_type)
    rig.wait_advertised(pupil_info, xy_info)
    rig.connect(xy_info.uid())
    assert rig.log.having('not taking')
    rig.close()


def test_explicit_channels_are_checked_against_the_labels_not_the_layout(stream_type):
    pupil, info = make_outlet('pupil_capture', stream_type=stream_type)
    rig = gaze_rig(stream_type, profile='xy_pixels', x_channel='norm_pos_x',
                   y_channel='norm_pos_y')
    rig.connect(info.uid())
    rig.close()


def test_strings_are_refused(stream_type):
    markers = open_outlet(pylsl.StreamInfo(unique_id('markers'), stream_type, 1, 0.0,
                                           pylsl.cf_string, unique_id('markers')))
    rig = gaze_rig(stream_type)
    assert rig.until(lambda: rig.log.having('carries strings')), rig.log.text()
    assert rig.conn.stream is None and not markers.have_consumers()
    rig.close()


def test_several_sources_take_none_and_say_how_to_pick_one(stream_type):
    mine, mine_info = make_outlet('xy_pixels', stream_type=stream_type,
                                  source_id=unique_id('tobii-A'))
    theirs, theirs_info = make_outlet('xy_pixels', stream_type=stream_type,
                                      source_id=unique_id('tobii-B'))
    rig = gaze_rig(stream_type)
    rig.wait_advertised(mine_info, theirs_info)
    for _ in range(5):
        rig.conn.maintain()
    assert rig.conn.stream is None and rig.connected == []
    warning, = rig.log.having('taking none')
    assert f"source_id:='{mine_info.source_id()}'" in warning
    assert f"source_id:='{theirs_info.source_id()}'" in warning
    assert not mine.have_consumers() and not theirs.have_consumers()


def test_streams_without_source_ids_are_told_apart_by_name(stream_type):
    left, left_info = make_outlet('xy_pixels', stream_type=stream_type, source_id='',
                                  name=unique_id('left'))
    right, right_info = make_outlet('xy_pixels', stream_type=stream_type, source_id='',
                                    name=unique_id('right'))
    rig = gaze_rig(stream_type)
    rig.wait_advertised(left_info, right_info)
    rig.conn.maintain()
    assert rig.conn.stream is None
    warning, = rig.log.having('taking none')
    assert f"stream_name:='{left_info.name()}'" in warning
    assert f"stream_name:='{right_info.name()}'" in warning


def test_several_streams_of_one_source_take_the_newest(stream_type):
    source = unique_id('tobii-A')
    old, old_info = make_outlet('xy_pixels', stream_type=stream_type, source_id=source)
    new, new_info = make_outlet('xy_pixels', stream_type=stream_type, source_id=source)
    assert new_info.created_at() > old_info.created_at()
    rig = gaze_rig(stream_type)
    rig.wait_advertised(old_info, new_info)
    rig.connect(new_info.uid())
    assert not old.have_consumers()
    rig.close()


def test_a_further_stream_is_reported_once_and_never_used(stream_type):
    mine, mine_info = make_outlet('xy_pixels', stream_type=stream_type)
    rig = gaze_rig(stream_type)
    rig.connect(mine_info.uid())
    theirs, theirs_info = make_outlet('xy_pixels', stream_type=stream_type)
    assert rig.until(lambda: rig.log.having('another LSL stream'))
    for _ in range(5):
        rig.conn.maintain()
    assert rig.conn.stream.uid == mine_info.uid() and not theirs.have_consumers()
    report, = rig.log.having('another LSL stream')
    assert f"set the parameter source_id to '{theirs_info.source_id()}'" in report
    rig.close()


def lose(rig, outlet_info):
    """Acquire until the connection has lost the stream it reads (its outlet was deleted)."""
    assert rig.until(lambda: rig.conn.stream is None, step=rig.conn.acquire), rig.log.text()
    assert rig.log.having('lost gaze stream') and rig.quiet == [True]
    assert rig.log.having(f"'{outlet_info.name()}'")


def test_a_restarted_sender_is_back_and_preferred_to_a_newer_device(stream_type):
    source, name = unique_id('tobii-A'), unique_id('tracker')
    first, first_info = make_outlet('xy_pixels', stream_type=stream_type, source_id=source,
                                    name=name)
    rig = gaze_rig(stream_type)
    rig.connect(first_info.uid())
    assert rig.until(lambda: rig.conn.clock_offset is not None, step=rig.conn.acquire)
    # The application restarts (same source and name) while another device appears after
    # it: once the first stream is lost, its source wins although the other one is newer.
    again, again_info = make_outlet('xy_pixels', stream_type=stream_type, source_id=source,
                                    name=name)
    other, other_info = make_outlet('xy_pixels', stream_type=stream_type)
    assert rig.until(lambda: len(rig.log.having('another LSL stream')) == 2)
    del first   # the outlet closes: its inlet's next pull raises liblsl's LostError
    lose(rig, first_info)
    rig.connect(again_info.uid())
    # To the user it is the same stream back, not a switch to one of the same name.
    assert rig.log.having(f"source_id '{source}', 2 ch, irregular rate, host "
                          f'{first_info.hostname()}) is back (its sender restarted); '
                          'reconnecting')
    assert not rig.log.having('switching to')
    assert not other.have_consumers()
    rig.close()


def test_a_lost_stream_is_replaced_by_another_with_a_warning(stream_type):
    first, first_info = make_outlet('xy_pixels', stream_type=stream_type)
    rig = gaze_rig(stream_type)
    rig.connect(first_info.uid())
    assert rig.until(lambda: rig.conn.clock_offset is not None, step=rig.conn.acquire)
    other, other_info = make_outlet('xy_pixels', stream_type=stream_type)
    assert rig.until(lambda: rig.log.having('another LSL stream'))
    del first
    lose(rig, first_info)
    rig.connect(other_info.uid())
    switch, = rig.log.having('is gone: switching to')
    assert f"'{first_info.name()}'" in switch and f"'{other_info.name()}'" in switch
    rig.close()


def test_a_broken_connection_is_ignored_for_a_while_then_its_stream_is_back(stream_type):
    outlet, info = make_outlet('xy_pixels', stream_type=stream_type)
    rig = gaze_rig(stream_type)
    rig.connect(info.uid())
    assert rig.until(lambda: rig.conn.clock_offset is not None, step=rig.conn.acquire)
    rig.network.break_connection(info.uid())
    assert rig.conn.acquire() == [] and rig.conn.stream is None
    assert rig.log.having('lost gaze stream')
    # Still advertised (the outlet lives): not reopened while the ignore-list entry lasts.
    for _ in range(5):
        rig.conn.maintain()
    assert rig.network.advertises(info.uid()) and rig.conn.stream is None
    rig.clock.skip(LOST_IGNORE_S + 0.1)   # the entry expired: the stream is a candidate again
    rig.connect(info.uid())
    assert rig.log.having('is back (its connection broke); reconnecting')
    rig.close()


def test_a_quiet_stream_is_kept_while_advertised_and_replaced_when_gone(stream_type):
    quiet, quiet_info = make_outlet('xy_pixels', stream_type=stream_type)
    rig = Rig(GazeStreamProfile(build_config({'stream_type': stream_type})),
              stale_timeout_s=1.0)
    rig.connect(quiet_info.uid())
    assert rig.until(lambda: rig.conn.clock_offset is not None, step=rig.conn.acquire)
    rig.clock.skip(2.0)
    rig.conn.maintain()
    assert rig.conn.stale and rig.conn.stream.uid == quiet_info.uid() and rig.quiet == [True]
    assert rig.log.having('it is still advertised, so it is kept')
    # Its sender goes; another one is there.  Only maintain runs here (no pull to see the
    # loss), so the resolver forgetting the stream is what replaces it.
    other, other_info = make_outlet('xy_pixels', stream_type=stream_type)
    del quiet
    assert rig.until(lambda: rig.conn.stream is not None
                     and rig.conn.stream.uid == other_info.uid()), rig.log.text()
    assert rig.log.having('no longer advertised')
    rig.close()


def test_samples_map_to_ros_time_by_the_clock_offset(stream_type):
    # A sample taken 0.5 s before now on the sender's LSL clock was taken 0.5 s before now
    # on the ROS clock: t_ros = t_lsl + offset + (ros_now - lsl_now).
    outlet, info = make_outlet('xy_pixels', stream_type=stream_type)
    rig = gaze_rig(stream_type)
    rig.connect(info.uid())
    assert outlet.wait_for_consumers(WAIT_S)
    taken = pylsl.local_clock() - 0.5
    outlet.push_chunk([[1.0, 2.0], [3.0, 4.0]], [taken - 0.1, taken])
    chunk, = rig.read(2)
    offset = rig.conn.clock_offset
    assert abs(offset) < 0.01   # one machine: one clock
    expected = (np.array([taken - 0.1, taken]) + offset + ROS_MINUS_LSL_S) * 1e9
    np.testing.assert_allclose(chunk.stamps_ns, expected, rtol=0, atol=STAMP_TOLERANCE_NS)
    np.testing.assert_array_equal(chunk.samples, [[1.0, 2.0], [3.0, 4.0]])
    assert chunk.good.all()
    rig.close()


def test_samples_wait_in_the_inlet_for_the_clock_offset(stream_type):
    outlet, info = make_outlet('xy_pixels', stream_type=stream_type)
    rig = gaze_rig(stream_type)
    rig.network.offset_hidden = True   # the time service does not answer (yet)
    rig.connect(info.uid())
    assert outlet.wait_for_consumers(WAIT_S)
    taken = pylsl.local_clock() - 0.5
    outlet.push_chunk([[1.0, 2.0], [3.0, 4.0]], [taken - 0.1, taken])
    # The pylsl inlet itself (inside the adapter's PylslInlet) tells what it holds.
    inlet = rig.network.inlets[info.uid()]._inlet._inlet
    assert rig.until(lambda: inlet.samples_available() == 2, step=lambda: None)
    assert rig.conn.acquire() == [] and inlet.samples_available() == 2   # held, not lost
    rig.network.offset_hidden = False
    chunk, = rig.read(2)
    expected = (np.array([taken - 0.1, taken]) + rig.conn.clock_offset + ROS_MINUS_LSL_S) * 1e9
    np.testing.assert_allclose(chunk.stamps_ns, expected, rtol=0, atol=STAMP_TOLERANCE_NS)
    rig.close()


def test_without_an_offset_chunks_are_placed_at_arrival_keeping_their_spacing(stream_type):
    outlet, info = make_outlet('xy_pixels', stream_type=stream_type)
    rig = gaze_rig(stream_type)
    rig.network.offset_hidden = True   # the time service never answers ...
    rig.connect(info.uid())
    assert outlet.wait_for_consumers(WAIT_S)
    rig.clock.skip(CLOCK_SYNC_TIMEOUT_S + 0.1)
    outlet.push_chunk(np.zeros((3, 2)), [10.0, 10.25, 10.5])   # stamps of another clock
    before = ros_now_ns()
    chunk, = rig.read(3)
    after = ros_now_ns()
    assert before <= chunk.stamps_ns[-1] <= after   # the newest sample: at its arrival
    np.testing.assert_array_equal(np.diff(chunk.stamps_ns), [250_000_000] * 2)
    assert rig.log.having('placing each chunk at its arrival time')
    assert rig.conn.clock_offset is None
    rig.network.offset_hidden = False   # ... until it does: a check takes it
    assert rig.until(lambda: rig.log.having('known again'))
    taken = pylsl.local_clock() - 1.0
    outlet.push_chunk([[0.0, 0.0]], [taken])
    chunk, = rig.read(1)
    expected = (taken + rig.conn.clock_offset + ROS_MINUS_LSL_S) * 1e9
    assert abs(chunk.stamps_ns[0] - expected) < STAMP_TOLERANCE_NS
    rig.close()


def eeg_outlet(stream_type, channels=8, rate=250.0):
    """Open an amplifier-like outlet without labels; return it and its advertised info."""
    outlet = open_outlet(stream_info(unique_id('eeg'), stream_type, channels, rate,
                                     unique_id('amp')))
    return outlet, outlet.get_info()


def test_gaze_and_eeg_connections_stamp_one_lsl_time_alike(stream_type):
    """The one mapping: the same sender time is the same ROS time for gaze and EEG."""
    eeg_type = unique_id('EEG')
    gaze_outlet, gaze_info = make_outlet('xy_pixels', stream_type=stream_type)
    eeg, eeg_info = eeg_outlet(eeg_type)
    rigs = {'gaze': (gaze_rig(stream_type), gaze_outlet, gaze_info, 2),
            'EEG': (Rig(EegStreamProfile({'layout': 'generic', 'stream_type': eeg_type})),
                    eeg, eeg_info, 8)}
    taken = pylsl.local_clock() - 2.0
    stamps, offsets = {}, {}
    for kind, (rig, outlet, info, channels) in rigs.items():
        rig.connect(info.uid())
        assert outlet.wait_for_consumers(WAIT_S)
        outlet.push_chunk(np.zeros((1, channels)), [taken])
        chunk, = rig.read(1)
        stamps[kind], offsets[kind] = chunk.stamps_ns[0], rig.conn.clock_offset
        rig.close()
    for kind in rigs:
        expected = (taken + offsets[kind] + ROS_MINUS_LSL_S) * 1e9
        assert abs(stamps[kind] - expected) < STAMP_TOLERANCE_NS, kind
    assert abs(stamps['gaze'] - stamps['EEG']) < STAMP_TOLERANCE_NS + 1e9 * abs(
        offsets['gaze'] - offsets['EEG'])


def test_corrupt_stamps_are_marked_not_good_and_the_rest_kept(stream_type):
    outlet, info = make_outlet('xy_pixels', stream_type=stream_type)
    rig = gaze_rig(stream_type)
    rig.connect(info.uid())
    assert outlet.wait_for_consumers(WAIT_S)
    taken = pylsl.local_clock() - 1.0
    outlet.push_chunk([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0], [4.0, 4.0]],
                      [taken, float('nan'), 1e12, -1e12])
    chunks = rig.read(4)
    good = np.concatenate([chunk.good for chunk in chunks])
    stamps_ns = np.concatenate([chunk.stamps_ns for chunk in chunks])
    assert good.tolist() == [True, False, False, False]
    assert stamps_ns[1:].tolist() == [0, 0, 0]
    expected = (taken + rig.conn.clock_offset + ROS_MINUS_LSL_S) * 1e9
    assert abs(stamps_ns[0] - expected) < STAMP_TOLERANCE_NS
    assert rig.conn.newest_stamp_ns == stamps_ns[0]
    rig.close()


def test_gaps_are_counted_and_the_rate_measured_between_them():
    rate = 250.0
    eeg_type = unique_id('EEG')
    outlet, info = eeg_outlet(eeg_type, channels=1, rate=rate)
    rig = Rig(EegStreamProfile({'layout': 'generic', 'stream_type': eeg_type}))
    rig.connect(info.uid())
    assert outlet.wait_for_consumers(WAIT_S)
    times = pylsl.local_clock() - 10.0 + np.arange(1000) / rate
    times[500:] += 0.3   # 0.3 s missing
    for start in range(0, 1000, 100):   # ten chunks: the gap falls between two of them
        outlet.push_chunk(np.zeros((100, 1)), times[start:start + 100].tolist())
    rig.read(1000)
    assert rig.conn.gaps == 1 and rig.conn.gap_s == pytest.approx(0.3 + 1 / rate)
    assert rig.log.having('1 gap(s) in')
    # The rate the sample times show between the gaps; a sender at 500 Hz would say so.
    assert rig.conn.measured_rate_hz == pytest.approx(rate, rel=1e-6)
    rig.close()


def test_an_eeg_stream_is_never_suggested_to_a_gaze_connection_of_any_type():
    # Issue 39: with stream_type:=* the bridge said "to use it instead, set source_id to
    # 'sim_eeg'" of an EEG stream.  Any type, and one name for both streams (so that only
    # these two match, whatever else runs on this machine).
    name = unique_id('lab')
    eeg = open_outlet(stream_info(name, 'EEG', 8, 250.0, source_id=unique_id('sim_eeg')))
    gaze, gaze_info = make_outlet('xy_pixels', name=name, source_id=unique_id('tobii'))
    rig = gaze_rig('*', stream_name=name)
    rig.wait_advertised(eeg.get_info(), gaze_info)
    rig.connect(gaze_info.uid())
    for _ in range(5):
        rig.conn.maintain()
    assert rig.log.having('not taking') and rig.conn.stream.uid == gaze_info.uid()
    assert rig.log.having('another LSL stream') == [], rig.log.text()
    rig.close()


def test_a_gaze_stream_is_refused_by_an_eeg_connection_whatever_it_selects():
    # Issue 39: the decoder took a Tobii stream and asked for channels by label.
    tobii, info = make_outlet('tobii_pro', source_id=unique_id('tobii'))
    rig = Rig(EegStreamProfile({'layout': 'generic', 'stream_type': '*',
                                'source_id': info.source_id()}))
    assert rig.until(lambda: rig.log.having('not taking')), rig.log.text()
    for _ in range(5):
        rig.conn.maintain()
    assert rig.conn.stream is None and not tobii.have_consumers()
    refusal, = rig.log.having('not taking')
    assert "it is an Eyetracker stream (an eye tracker's gaze), not EEG" in refusal
    rig.close()
