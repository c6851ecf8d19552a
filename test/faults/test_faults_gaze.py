"""
Gaze faults: impossible values, broken stamps, floods, lost and duplicated streams.

Two entry points: the ``gaze`` topic of the real choice_arbiter (anything a
misbehaving publisher could send), and real LSL outlets read by the real
lsl_gaze_bridge (anything an eye-tracker application or a cable could do).
Both run in the full pipeline (:class:`fault_rig.Pipeline`: camera_tracker,
marker_projector, choice_arbiter) so every case ends with the question that
matters: was exactly the choice the good gaze supports published, or none?
"""

import gc
import math
import re
import time

from fault_rig import LogTap, Pipeline, WAIT_S
from lsl_outlets import make_outlet, sample_for, unique_id
import numpy as np
import pylsl
import pytest

from eye_bci_ros2.sim.lsl_outlet import open_outlet, stream_info

pytestmark = pytest.mark.ros

NAN, INF = math.nan, math.inf


def decide(rig, points, stamps=None):
    """Run one requested round with these gaze samples; return (Decision, new choices)."""
    rig.request()
    published = len(rig.choices.messages)
    rig.gaze(points, stamps=stamps)
    decision = rig.finish_round()
    return decision, [m.data for m in rig.choices.messages[published:]]


def with_bad_rows(good, bad, rng):
    """Mix ``bad`` samples (M, 2) into ``good`` ones (N, 2) at random places."""
    mixed = np.concatenate([good, bad])
    return mixed[rng.permutation(len(mixed))]


# -- the gaze topic --------------------------------------------------------------------------

BAD_VALUES = {
    'NaN gaze samples': [[NAN, NAN], [NAN, 300.0], [640.0, NAN]],
    'infinite gaze samples': [[INF, 300.0], [-INF, -INF], [640.0, INF]],
    'huge gaze values': [[1e308, 1e308], [-1e308, 5.0], [1e300, -1e300], [3e38, 3e38]],
    'negative and off-screen gaze': [[-5000.0, -5000.0], [99999.0, 400.0], [-1.0, 1e6]],
}


@pytest.mark.parametrize('name', sorted(BAD_VALUES))
def test_bad_gaze_values_are_never_evidence(graph, capfd, fault, name):
    rig = Pipeline(graph)
    log = LogTap(capfd)
    rig.offer_rooms()
    bad = np.repeat(BAD_VALUES[name], 80, axis=0)
    with fault('gaze', f'{name} (arbiter topic)'):
        # Bad samples among good ones on the kitchen: the kitchen, from the good ones only.
        good = rig.look_at_region('kitchen', count=120)
        mark = log.mark()
        decision, new = decide(rig, with_bad_rows(good, bad, rig.rng))
        assert (decision.label, new) == ('kitchen', ['kitchen']), decision.summary()
        assert decision.in_region_samples == 120
        # The log accounts for them: all samples seen, only the good ones in a region.
        assert log.wait_for(graph, f"choice 'kitchen' by mean: {120 + len(bad)} samples, "
                                   '120 in regions', mark)
        # Bad samples alone choose nothing.
        decision, new = decide(rig, bad)
        assert (decision.label, new) == (None, []), decision.summary()
        assert rig.answers('/choice_arbiter')
        rig.choose('bathroom')


def test_gaze_in_a_foreign_frame_is_ignored_with_a_warning(graph, capfd, fault):
    rig = Pipeline(graph)
    log = LogTap(capfd)
    rig.offer_rooms()
    with fault('gaze', 'gaze in the wrong frame (arbiter topic)'):
        mark = log.mark()
        rig.request()
        rig.gaze(rig.look_at_region('kitchen'), frame='camera_optical')
        assert log.wait_for(graph, "choice_arbiter.*gaze in frame 'camera_optical' ignored",
                            mark)
        decision = rig.finish_round()
        assert decision.label is None and decision.samples_used == 0
        assert rig.published_choices() == []
        rig.choose('kitchen')


def test_out_of_order_stamps_give_the_same_decision(graph, capfd, fault):
    rig = Pipeline(graph, arbiter_parameters={'window_s': 1.0})
    rig.offer_rooms()
    with fault('gaze', 'samples out of order in time (arbiter topic)'):
        # 0.4 s on the bathroom and 0.1 s off every region, published in shuffled order.
        points = np.concatenate([rig.look_at_region('bathroom', count=480),
                                 rig.rng.uniform([0, 0], [50, 50], (120, 2))])
        rig.request()
        start = rig.now()
        stamps = start + (np.arange(len(points)) + 0.5) / 1200.0
        order = rig.rng.permutation(len(points))
        published = len(rig.choices.messages)
        rig.gaze(points[order], stamps=stamps[order])
        decision = rig.finish_round()
        assert decision.label == 'bathroom', decision.summary()
        assert decision.samples_used == len(points) and decision.in_region_samples == 480
        assert [m.data for m in rig.choices.messages[published:]] == ['bathroom']


def test_stale_samples_from_before_the_round_are_not_evidence(graph, capfd, fault):
    rig = Pipeline(graph)
    rig.offer_rooms()
    with fault('gaze', 'samples stamped before the round (late delivery)'):
        kitchen = rig.look_at_region('kitchen', count=600)
        bathroom = rig.look_at_region('bathroom', count=240)
        rig.request()
        start = rig.now()
        # The kitchen samples arrive now but were taken 2 s ago, before the question.
        rig.gaze(kitchen, start=start - 2.0)
        rig.gaze(bathroom, start=start)
        decision = rig.finish_round()
        assert decision.label == 'bathroom', decision.summary()
        assert decision.samples_used == 240
        assert rig.published_choices() == ['bathroom']


def test_zero_stamps_count_as_arrival_time(graph, capfd, fault):
    rig = Pipeline(graph)
    rig.offer_rooms()
    with fault('gaze', 'unstamped samples (stamp 0)'):
        decision, new = decide(rig, rig.look_at_region('bedroom'),
                               stamps=np.zeros(240))
        assert (decision.label, new) == ('bedroom', ['bedroom']), decision.summary()


def test_one_corrupt_far_future_stamp_does_not_end_the_round(graph, capfd, fault):
    """A single sample stamped an hour ahead must not close the round before the gaze comes."""
    rig = Pipeline(graph, arbiter_parameters={'window_s': 1.0})
    rig.offer_rooms()
    with fault('gaze', 'one sample stamped an hour in the future'):
        rig.request()
        before = rig.arbiter.last_decision
        published = len(rig.choices.messages)
        rig.gaze([[640.0, 360.0]], stamps=[rig.now() + 3600.0])
        graph.spin_for(0.2)
        rig.gaze(rig.look_at_region('kitchen', count=480))
        decision = rig.finish_round(before=before)
        assert decision.label == 'kitchen', decision.summary()
        assert [m.data for m in rig.choices.messages[published:]] == ['kitchen']


def test_a_burst_of_ten_thousand_samples(graph, capfd, fault):
    rig = Pipeline(graph, arbiter_parameters={'window_s': 9.0, 'stall_timeout_s': 0.5})
    log = LogTap(capfd)
    rig.offer_rooms()
    with fault('gaze', 'burst of 10 000 samples at once (arbiter topic)') as case:
        points = rig.look_at_region('bedroom', count=10000)
        mark = log.mark()
        rig.request()
        # 10 000 samples at 1200 Hz (8.3 s of gaze) published in one go.
        rig.gaze(points)
        decision = rig.finish_round(timeout=60.0)
        assert decision.label == 'bedroom', decision.summary()
        assert rig.published_choices() == ['bedroom']
        assert log.wait_for(graph, r"choice 'bedroom' by mean: \d+ samples", mark)
        assert rig.answers('/choice_arbiter')
        # 10 000 samples are 417 batches of 24, within the gaze QoS's depth of 1000 messages
        # (reliable): every sample must be counted; a loss would be a smaller count.
        case.note = f'{decision.samples_used} of 10000 samples reached the arbiter'
        assert decision.samples_used == 10000, case.note


def test_gaze_that_stops_mid_round_closes_the_round_on_time(graph, capfd, fault):
    rig = Pipeline(graph, arbiter_parameters={'window_s': 1.0, 'stall_timeout_s': 0.3})
    rig.offer_rooms()
    with fault('gaze', 'gaze stops mid-round, then comes back (arbiter topic)'):
        rig.request()
        # 0.2 s on the kitchen, then silence: the round closes stall_timeout_s after its window.
        rig.gaze(rig.look_at_region('kitchen'))
        decision = rig.finish_round()
        assert decision.label == 'kitchen' and decision.samples_used == 240
        assert rig.published_choices() == ['kitchen']
        rig.choose('bathroom')


# -- real LSL through the bridge -------------------------------------------------------------


def lsl_pipeline(graph, outlet_info, **bridge):
    """Pipeline with the bridge reading ``outlet_info``'s stream, stale after 0.5 s."""
    parameters = {'profile': 'custom', 'stream_type': outlet_info.type(),
                  'stream_name': outlet_info.name(), 'source_id': outlet_info.source_id(),
                  'stale_timeout_s': 0.5, 'resolve_period_s': 0.1}
    parameters.update(bridge)
    return Pipeline(graph, bridge_parameters=parameters,
                    arbiter_parameters={'window_s': 1.0, 'stall_timeout_s': 0.3})


def connect(graph, outlet):
    """Wait until the bridge's inlet is attached to ``outlet``."""
    assert graph.spin_until(outlet.have_consumers, WAIT_S), 'bridge never connected'


def lsl_stamps(count, rate=1200.0):
    """LSL sample times (count,) from now on at ``rate`` Hz, s."""
    return pylsl.local_clock() + np.arange(count) / rate


def push(outlet, points, rate=1200.0):
    """Push screen points as one chunk, sampled from now on at ``rate`` Hz."""
    points = np.asarray(points, dtype=float)
    outlet.push_chunk(sample_for('custom', points).tolist(),
                      lsl_stamps(len(points), rate).tolist())


def lsl_round(rig, outlet, points):
    """Request a round, push ``points`` over LSL, wait for the outcome."""
    rig.request()
    published = len(rig.choices.messages)
    push(outlet, points)
    decision = rig.finish_round()
    return decision, [m.data for m in rig.choices.messages[published:]]


def first_lsl_sample(graph, rig, outlet):
    """Push one sample and wait for it on ``gaze`` (clock sync done, stream live)."""
    count = rig.gazes.count
    outlet.push_sample([1.0, 1.0])
    assert graph.spin_until(lambda: rig.gazes.count > count, WAIT_S)


@pytest.mark.lsl
def test_lsl_nan_inf_and_huge_samples_are_dropped_and_counted(graph, capfd, fault):
    outlet, info = make_outlet('custom', stream_type=unique_id('gaze'))
    rig = lsl_pipeline(graph, info)
    log = LogTap(capfd)
    rig.offer_rooms()
    connect(graph, outlet)
    first_lsl_sample(graph, rig, outlet)
    bad = [[NAN, 300.0], [INF, INF], [-INF, 5.0], [1e30, 1e30], [-1e30, 200.0], [NAN, NAN]]
    with fault('gaze', 'NaN, inf and huge values in LSL samples'):
        mark = log.mark()
        good = rig.look_at_region('kitchen', count=300)
        before = dict(rig.bridge.counters)
        samples = np.concatenate([good, np.repeat(bad, 20, axis=0)])
        order = rig.rng.permutation(len(samples))
        rig.request()
        published = len(rig.choices.messages)
        outlet.push_chunk(samples[order].tolist(), lsl_stamps(len(samples)).tolist())
        decision = rig.finish_round()
        assert decision.label == 'kitchen', decision.summary()
        assert [m.data for m in rig.choices.messages[published:]] == ['kitchen']
        counters = rig.bridge.counters
        assert counters['nonfinite'] - before['nonfinite'] == 80
        assert counters['offscreen'] - before['offscreen'] == 40
        assert counters['published'] - before['published'] == 300
        # Counted for the statistics line; no warning: valid gaze came with them (a warning
        # is for a stream with nothing valid, test_lsl_gaze_bridge).
        assert not re.search(r'WARN.*lsl_gaze_bridge.*(valid gaze|invalid)', log.since(mark))
        assert rig.answers('/lsl_gaze_bridge')


@pytest.mark.lsl
@pytest.mark.parametrize('channels', [1, 3])
def test_lsl_stream_with_the_wrong_channel_count(graph, capfd, fault, channels):
    """A 1-channel (short samples) or 3-channel stream where x, y are expected by label."""
    stream_type = unique_id('gaze')
    outlet = open_outlet(stream_info(unique_id('odd'), stream_type, channels, 0,
                                     unique_id('odd-source')))
    log = LogTap(capfd)
    mark = log.mark()   # the bridge may connect (and complain) while the rooms are offered
    rig = lsl_pipeline(graph, outlet.get_info(), x_channel='x', y_channel='y')
    rig.offer_rooms()
    with fault('gaze', f'LSL stream with {channels} unlabelled channel(s) (wrong layout)'):
        # Refused before a sample is read, with the reason; its samples never become gaze.
        assert log.wait_for(graph, 'lsl_gaze_bridge.*not taking .*does not fit profile '
                                   "'custom': x_channel: the stream has no channel labelled 'x'",
                            mark)
        rig.request()
        outlet.push_chunk([[100.0 * (k + 1)] * channels for k in range(50)])
        outlet.push_chunk([])   # an empty chunk is no sample at all
        decision = rig.finish_round()
        assert decision.label is None and decision.samples_used == 0
        assert rig.gazes.messages == [] and rig.published_choices() == []
        assert rig.bridge.stream is None and not outlet.have_consumers()
        assert rig.bridge.counters['received'] == 0
        assert rig.answers('/lsl_gaze_bridge')


@pytest.mark.lsl
def test_lsl_samples_out_of_order_in_time(graph, capfd, fault):
    outlet, info = make_outlet('custom', stream_type=unique_id('gaze'))
    rig = lsl_pipeline(graph, info)
    rig.offer_rooms()
    connect(graph, outlet)
    first_lsl_sample(graph, rig, outlet)
    with fault('gaze', 'LSL samples out of order in time'):
        points = rig.look_at_region('bathroom', count=360)
        rig.request()
        published = len(rig.choices.messages)
        stamps = lsl_stamps(len(points))
        order = rig.rng.permutation(len(points))
        outlet.push_chunk(sample_for('custom', points[order]).tolist(),
                          stamps[order].tolist())
        decision = rig.finish_round()
        assert decision.label == 'bathroom', decision.summary()
        assert [m.data for m in rig.choices.messages[published:]] == ['bathroom']
        # Each sample kept its own acquisition time, whatever the order.
        seconds, _ = rig.gazes.samples(rig.gazes.count - len(points))
        gaps = np.diff(np.sort(seconds))
        assert np.all(np.abs(gaps - 1 / 1200.0) < 1e-4)


@pytest.mark.lsl
@pytest.mark.parametrize('rate', [1200.0, 0.0], ids=['1200 Hz stream', 'irregular-rate stream'])
def test_lsl_burst_of_ten_thousand_samples_reaches_ros_whole(graph, capfd, fault, rate):
    """
    10 000 samples in one chunk (8 s of a 1200 Hz tracker after a stall) all arrive.

    The inlet of an irregular-rate stream must hold it (liblsl drops what does not
    fit, uncounted), and the bridge publishes it in batches of at most max_chunk.
    """
    outlet, info = make_outlet('custom', stream_type=unique_id('gaze'), rate=rate,
                               max_buffered=360)
    rig = lsl_pipeline(graph, info)
    rig.offer_rooms()
    connect(graph, outlet)
    first_lsl_sample(graph, rig, outlet)
    kind = f'{rate:g} Hz' if rate else 'irregular-rate'
    with fault('gaze', f'burst of 10 000 LSL samples at once ({kind} stream)') as case:
        before = dict(rig.bridge.counters)
        before_received, before_messages = rig.gazes.count, len(rig.gazes.messages)
        points = rig.look_at_region('kitchen', count=10000)
        push(outlet, points)
        graph.spin_until(lambda: rig.gazes.count - before_received >= 10000, 30.0)
        assert rig.answers('/lsl_gaze_bridge')
        counters = rig.bridge.counters
        seconds, received = rig.gazes.samples(before_received)
        case.note = (f"bridge pulled {counters['received'] - before['received']}, published "
                     f"{counters['published'] - before['published']}, {len(received)} arrived")
        assert len(received) == 10000, case.note
        # Whole and in order, each stamped with its acquisition time (1/1200 s apart).
        np.testing.assert_allclose(received, points, atol=1e-3)
        assert np.all(np.abs(np.diff(seconds) - 1 / 1200.0) < 1e-4)
        # In batches of at most max_chunk samples: ten or more messages, not 10 000.
        messages = rig.gazes.messages[before_messages:]
        max_chunk = rig.bridge.get_parameter('max_chunk').value
        assert len(messages) >= 10000 / max_chunk
        assert max(m.width for m in messages) <= max_chunk


@pytest.mark.lsl
def test_lsl_stream_that_stops_mid_round_and_comes_back(graph, capfd, fault):
    outlet, info = make_outlet('custom', stream_type=unique_id('gaze'))
    rig = lsl_pipeline(graph, info, stale_timeout_s=0.3)
    log = LogTap(capfd)
    rig.offer_rooms()
    connect(graph, outlet)
    first_lsl_sample(graph, rig, outlet)
    with fault('gaze', 'LSL stream stops mid-round and resumes'):
        graph.set_parameters('/choice_arbiter', {'window_s': 2.0})
        mark = log.mark()
        rig.request()
        published = len(rig.choices.messages)
        push(outlet, rig.look_at_region('kitchen', count=240))
        assert log.wait_for(graph, 'lsl_gaze_bridge.*no gaze samples from', mark)
        assert rig.bridge.stale
        push(outlet, rig.look_at_region('kitchen', count=240))
        assert log.wait_for(graph, 'lsl_gaze_bridge.*resumed', mark)
        decision = rig.finish_round()
        assert decision.label == 'kitchen', decision.summary()
        assert decision.in_region_samples == 480
        assert [m.data for m in rig.choices.messages[published:]] == ['kitchen']


@pytest.mark.lsl
def test_lsl_stream_lost_mid_round_and_restarted(graph, capfd, fault):
    name, source_id = unique_id('restart'), unique_id('restart-source')
    stream_type = unique_id('gaze')
    outlet, info = make_outlet('custom', name=name, source_id=source_id,
                               stream_type=stream_type)
    rig = lsl_pipeline(graph, info)
    log = LogTap(capfd)
    rig.offer_rooms()
    connect(graph, outlet)
    first_lsl_sample(graph, rig, outlet)
    with fault('gaze', 'LSL outlet lost mid-round (cable pulled) and restarted'):
        mark = log.mark()
        rig.request()
        published = len(rig.choices.messages)
        count = rig.gazes.count
        push(outlet, rig.look_at_region('bedroom', count=360))
        # 0.3 s on the bedroom (twice the dwell) reached gaze before the tracker dies.
        assert graph.spin_until(lambda: rig.gazes.count >= count + 360, WAIT_S)
        del outlet   # the tracker application dies
        gc.collect()
        assert log.wait_for(graph, 'lsl_gaze_bridge.*(lost gaze stream|no longer advertised)',
                            mark)
        decision = rig.finish_round()
        # What came before the loss is the evidence: the bedroom, chosen once.
        assert decision.label == 'bedroom', decision.summary()
        assert [m.data for m in rig.choices.messages[published:]] == ['bedroom']
        outlet, _ = make_outlet('custom', name=name, source_id=source_id,
                                stream_type=stream_type)
        connect(graph, outlet)
        first_lsl_sample(graph, rig, outlet)
        decision, new = lsl_round(rig, outlet, rig.look_at_region('bathroom', count=360))
        assert (decision.label, new) == ('bathroom', ['bathroom']), decision.summary()


def spin_streaming(graph, outlet, seconds, point=(20.0, 20.0)):
    """Spin while ``outlet`` streams a gaze point off every region at about 100 Hz."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        outlet.push_chunk(sample_for('custom', [point]).tolist())
        graph.spin_for(0.01)


@pytest.mark.lsl
def test_second_stream_of_the_same_type_is_not_mixed_in(graph, capfd, fault):
    stream_type = unique_id('gaze')
    first, first_info = make_outlet('custom', stream_type=stream_type)
    # Select by type only: any name, any source.
    rig = lsl_pipeline(graph, first_info, stream_name='*', source_id='*')
    log = LogTap(capfd)
    rig.offer_rooms()
    connect(graph, first)
    first_lsl_sample(graph, rig, first)
    with fault('gaze', 'second LSL stream of the same type appears'):
        mark = log.mark()
        second, second_info = make_outlet('custom', stream_type=stream_type)
        spin_streaming(graph, first, 1.5)   # the tracker streams on; the resolver sees both
        assert rig.bridge.stream_uid == first_info.uid()
        assert not second.have_consumers()
        rig.request()
        before = rig.arbiter.last_decision
        published = len(rig.choices.messages)
        push(second, rig.look_at_region('kitchen', count=600))   # the intruder
        push(first, rig.look_at_region('bathroom', count=360))   # the person
        deadline = time.monotonic() + WAIT_S
        while rig.arbiter.last_decision is before and time.monotonic() < deadline:
            spin_streaming(graph, first, 0.1)
        decision = rig.finish_round(before=before)
        assert decision.label == 'bathroom', decision.summary()
        assert decision.in_region_samples == 360
        assert [m.data for m in rig.choices.messages[published:]] == ['bathroom']
        assert rig.bridge.stream_uid == first_info.uid()
        assert 'switching to' not in log.since(mark)


@pytest.mark.lsl
def test_second_stream_of_the_same_type_is_reported(graph, capfd, fault):
    stream_type = unique_id('gaze')
    first, first_info = make_outlet('custom', stream_type=stream_type)
    rig = lsl_pipeline(graph, first_info, stream_name='*', source_id='*')
    log = LogTap(capfd)
    connect(graph, first)
    first_lsl_sample(graph, rig, first)
    with fault('gaze', 'second LSL stream of the same type appears: reported'):
        mark = log.mark()
        second, second_info = make_outlet('custom', stream_type=stream_type)
        spin_streaming(graph, first, 2.0)
        assert rig.bridge.stream_uid == first_info.uid()
        assert not second.have_consumers()
        reports = re.findall(f'lsl_gaze_bridge.*{second_info.name()}.*', log.since(mark))
        assert reports, 'the second stream is not mentioned in the log'
        # It names the other stream, the one in use, and how to pick the other one.
        assert second_info.uid() in reports[0] and first_info.name() in reports[0]
        assert f"set the parameter source_id to '{second_info.source_id()}'" in reports[0]
        # Once, not at every check.
        spin_streaming(graph, first, 1.0)
        assert len(re.findall(f'lsl_gaze_bridge.*{second_info.name()}', log.since(mark))) == 1


@pytest.mark.lsl
def test_quiet_tracker_is_not_replaced_by_another_device(graph, capfd, fault):
    """Tobii Stream Engine sends nothing while it sees no eyes: nobody else takes over."""
    stream_type = unique_id('gaze')
    tracker, tracker_info = make_outlet('custom', stream_type=stream_type)
    rig = lsl_pipeline(graph, tracker_info, stream_name='*', source_id='*')
    log = LogTap(capfd)
    rig.offer_rooms()
    connect(graph, tracker)
    first_lsl_sample(graph, rig, tracker)
    other, other_info = make_outlet('custom', stream_type=stream_type)
    with fault('gaze', 'tracker quiet (no eyes) while a second device streams'):
        mark = log.mark()
        # The person looks away for 2 s (stale after 0.5 s); the other device streams on.
        count = rig.gazes.count
        spin_streaming(graph, other, 2.0, point=rig.centre('kitchen'))
        assert log.wait_for(graph, 'lsl_gaze_bridge.*no gaze samples from', mark)
        assert rig.bridge.stale and rig.bridge.stream_uid == tracker_info.uid()
        assert rig.gazes.count == count and not other.have_consumers()
        assert 'switching to' not in log.since(mark)
        # The person looks back, at the bathroom: that is the choice.
        decision, new = lsl_round(rig, tracker, rig.look_at_region('bathroom', count=360))
        assert (decision.label, new) == ('bathroom', ['bathroom']), decision.summary()
        assert log.wait_for(graph, 'lsl_gaze_bridge.*resumed', mark)
    with fault('gaze', 'tracker gone while a second device streams: switch, with a warning'):
        mark = log.mark()
        del tracker   # the tracker application quits
        gc.collect()
        assert log.wait_for(graph, f'lsl_gaze_bridge.*{tracker_info.name()}.* is gone: '
                                   f'switching to .*{other_info.name()}', mark)
        connect(graph, other)
        assert rig.bridge.stream_uid == other_info.uid()
        first_lsl_sample(graph, rig, other)
        decision, new = lsl_round(rig, other, rig.look_at_region('kitchen', count=360))
        assert (decision.label, new) == ('kitchen', ['kitchen']), decision.summary()
