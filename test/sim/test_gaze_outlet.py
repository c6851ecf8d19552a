"""sim_gaze: the simulated tracker over a REAL LSL outlet, read back by a real inlet."""

import threading
import time
import uuid

import numpy as np
import pylsl
from pylsl.util import LostError
import pytest

from eye_bci_ros2.gaze.profiles import build_config, convert, resolve_mapping, stream_matches
from eye_bci_ros2.sim import gaze_outlet as sim_gaze
from eye_bci_ros2.sim.gaze_outlet import GazeStreamer, parse_script
from eye_bci_ros2.sim.person import (CONSUMER_TRACKER, GazeSimulator, IDEAL_EYE, ORIGINAL_TOBII_4C,
                                     PRO_TRACKER)

#: 1920x1080 person's screen -> 1366x768 sender's screen.
SCALE = np.array([1366 / 1920, 768 / 1080])
#: No noise, no losses, an ideal eye: every sample is exactly on the target.
EXACT = CONSUMER_TRACKER.with_changes(offset_deg=0.0, jitter_deg=0.0, loss_prob=0.0,
                                      blink_rate_per_min=0.0, **IDEAL_EYE)


def unique(prefix: str) -> str:
    """Return a name nobody else on this machine uses."""
    return f'{prefix}-{uuid.uuid4().hex}'


def open_inlet(source_id: str) -> pylsl.StreamInlet:
    """Resolve the stream by source_id and open an inlet on it."""
    found = pylsl.resolve_byprop('source_id', source_id, 1, 10.0)
    assert found, f'no LSL stream with source_id {source_id}'
    inlet = pylsl.StreamInlet(found[0], max_buflen=30, recover=False)
    inlet.open_stream(10.0)
    return inlet


def pull_for(inlet: pylsl.StreamInlet, seconds: float):
    """Pull everything for about ``seconds`` of wall time (starting at the first sample)."""
    chunks, stamps = [], []
    deadline = None
    give_up = time.monotonic() + 10.0
    while time.monotonic() < (deadline or give_up):
        data, ts = inlet.pull_chunk(timeout=0.2)
        if ts:
            chunks.append(np.asarray(data, dtype=float))
            stamps.extend(ts)
            if deadline is None:
                deadline = time.monotonic() + seconds
    assert stamps, 'no samples arrived'
    return np.concatenate(chunks), np.array(stamps)


def pull_until(inlet: pylsl.StreamInlet, predicate, timeout: float = 10.0):
    """Pull until predicate(samples, stamps) of one chunk holds; return all pulled."""
    chunks, stamps = [], []
    give_up = time.monotonic() + timeout
    while time.monotonic() < give_up:
        data, ts = inlet.pull_chunk(timeout=0.2)
        if ts:
            chunks.append(np.asarray(data, dtype=float))
            stamps.extend(ts)
            if predicate(chunks[-1], np.array(ts)):
                return np.concatenate(chunks), np.array(stamps)
    raise AssertionError(f'condition not met within {timeout} s')


@pytest.fixture
def make_streamer():
    """Build GazeStreamers with unique ids and stop them after the test."""
    made = []

    def make(**kwargs):
        kwargs.setdefault('source_id', unique('sim-gaze-test'))
        kwargs.setdefault('name', unique('sim_gaze_test'))
        streamer = GazeStreamer(**kwargs)
        made.append(streamer)
        return streamer

    yield make
    for streamer in made:
        streamer.stop()


@pytest.mark.lsl
def test_streams_at_the_tracker_rate_in_source_pixels_with_acquisition_timestamps(
        make_streamer):
    target = np.array([300.0, 900.0])
    streamer = make_streamer(params=EXACT, seed=1, initial_xy=target).start()
    streamer.set_target(target)
    inlet = open_inlet(streamer.info.source_id())
    info = inlet.info()
    assert (info.type(), info.channel_count(), info.channel_format()) == \
        ('Gaze', 2, pylsl.cf_float32)
    assert info.nominal_srate() == pytest.approx(90.0)

    first_pull = time.monotonic()
    samples, stamps = pull_for(inlet, 1.0)
    received_at = pylsl.local_clock()
    # Wall-clock counts vary with load: only a wide band around ~1 s worth.
    assert 0.4 * 90 <= len(stamps) <= 1.5 * 90 * (time.monotonic() - first_pull + 0.5)
    # The timestamps themselves carry the tracker's rate.
    assert (len(stamps) - 1) / (stamps[-1] - stamps[0]) == pytest.approx(90.0, rel=0.05)
    assert np.all(np.diff(stamps) > 0)
    assert np.all(stamps <= received_at) and np.all(stamps > received_at - 10.0)
    np.testing.assert_allclose(samples, np.broadcast_to(target * SCALE, samples.shape),
                               atol=1e-3)
    assert streamer.samples_pushed >= len(stamps) and streamer.error is None


@pytest.mark.lsl
def test_the_bridge_profile_reads_the_stream_back_onto_the_screen(make_streamer):
    target = np.array([1234.0, 345.0])
    streamer = make_streamer(params=EXACT, initial_xy=target).start()
    inlet = open_inlet(streamer.info.source_id())
    info = inlet.info(5.0)
    config = build_config({'profile': 'xy_pixels', 'source_id': info.source_id()})
    assert stream_matches(config, info.type(), info.name(), info.source_id())
    samples, _ = pull_for(inlet, 0.3)
    batch = convert(samples, resolve_mapping(config, [], info.channel_count()))
    assert batch.keep.all()
    np.testing.assert_allclose(batch.xy, np.broadcast_to(target, batch.xy.shape), atol=1e-3)


@pytest.mark.lsl
def test_set_target_moves_the_gaze_after_the_saccade_latency(make_streamer):
    start, goal = np.array([400.0, 400.0]), np.array([1500.0, 700.0])
    # Without spikes (single samples 2-6 deg off), which would land anywhere.
    params = ORIGINAL_TOBII_4C.with_changes(loss_prob=0.0, blink_rate_per_min=0.0,
                                            spike_prob=0.0)
    streamer = make_streamer(params=params, seed=2, initial_xy=start).start()
    streamer.set_target(start)
    inlet = open_inlet(streamer.info.source_id())
    before, _ = pull_for(inlet, 0.3)
    assert np.all(np.linalg.norm(before - start * SCALE, axis=1) < 100)

    moved_at = pylsl.local_clock()
    streamer.set_target(goal, moved_at)

    def near_goal(data, _):
        return np.median(np.linalg.norm(data - goal * SCALE, axis=1)) < 60

    samples, stamps = pull_until(inlet, near_goal)
    near = np.linalg.norm(samples - goal * SCALE, axis=1) < 100
    # Nothing near the new target before the shortest saccade latency.
    assert np.all(stamps[near] >= moved_at + params.person.latency_min_ms / 1e3)
    assert streamer.last_sample is not None


@pytest.mark.lsl
def test_lost_samples_are_sent_as_nan_or_left_out(make_streamer):
    params = EXACT.with_changes(loss_prob=0.3)
    with_nan = make_streamer(params=params, seed=3).start()
    samples, _ = pull_for(open_inlet(with_nan.info.source_id()), 1.0)
    lost = np.isnan(samples).any(axis=1)
    assert 0.1 < lost.mean() < 0.5
    assert np.array_equal(np.isnan(samples[:, 0]), np.isnan(samples[:, 1]))

    without = make_streamer(params=params, seed=3, send_lost=False).start()
    samples, stamps = pull_for(open_inlet(without.info.source_id()), 1.0)
    assert np.isfinite(samples).all()
    # Gaps in the timestamps where samples were left out.
    assert (len(stamps) - 1) / (stamps[-1] - stamps[0]) < 0.9 * 90


@pytest.mark.lsl
def test_stop_ends_the_stream(make_streamer):
    streamer = make_streamer(params=EXACT).start()
    source_id = streamer.info.source_id()
    inlet = open_inlet(source_id)
    pull_for(inlet, 0.2)
    assert streamer.running
    streamer.stop()
    stopped_at = pylsl.local_clock()
    assert not streamer.running and streamer.outlet is None
    # What was in flight may still arrive, nothing acquired after the stop: drain until a
    # second passes without a sample (or the inlet reports the stream lost).
    late = []
    give_up = time.monotonic() + 30.0
    try:
        while time.monotonic() < give_up:
            _, stamps = inlet.pull_chunk(timeout=1.0)
            if not stamps:
                break
            late.extend(stamps)
    except LostError:
        pass
    assert time.monotonic() < give_up, 'samples kept coming after the stop'
    assert all(stamp <= stopped_at for stamp in late), max(late) - stopped_at
    assert pylsl.resolve_byprop('source_id', source_id, 1, 1.0) == []


@pytest.mark.lsl
def test_per_sample_mode_pushes_each_sample_alone_with_its_own_stamp(make_streamer):
    received, calls = [], {'sample': 0, 'chunk': 0}
    sim = GazeSimulator(PRO_TRACKER, seed=5)   # 1200 Hz, as a lab's tracker
    streamer = make_streamer(simulator=sim, on_chunk=received.append, per_sample=True).start()
    outlet = streamer.outlet
    real_sample, real_chunk = outlet.push_sample, outlet.push_chunk

    def count_sample(*args):   # forwards to the real outlet: counts the calls only
        calls['sample'] += 1
        real_sample(*args)

    def count_chunk(*args):
        calls['chunk'] += 1
        real_chunk(*args)

    outlet.push_sample, outlet.push_chunk = count_sample, count_chunk
    samples, stamps = pull_for(open_inlet(streamer.info.source_id()), 0.5)
    streamer.stop()

    assert calls['chunk'] == 0 and calls['sample'] > 0.2 * 1200
    t = np.concatenate([c.t for c in received])
    xy = np.concatenate([c.xy for c in received])
    assert np.all(np.diff(t) > 0)
    # Each sample arrives with its own acquisition stamp, as the simulator made it.
    index = np.searchsorted(t, stamps)
    np.testing.assert_allclose(t[index], stamps, atol=1e-6)
    np.testing.assert_allclose(samples, (xy[index] * SCALE).astype(np.float32), atol=1e-3)
    assert (len(stamps) - 1) / (stamps[-1] - stamps[0]) == pytest.approx(1200.0, rel=0.1)


@pytest.mark.lsl
def test_the_streamer_sends_what_the_seeded_simulator_makes(make_streamer):
    received = []
    sim = GazeSimulator(CONSUMER_TRACKER, seed=21)
    streamer = make_streamer(simulator=sim, on_chunk=received.append).start()
    samples, stamps = pull_for(open_inlet(streamer.info.source_id()), 0.5)
    streamer.stop()
    t = np.concatenate([c.t for c in received])
    xy = np.concatenate([c.xy for c in received])
    index = np.searchsorted(t, stamps)
    np.testing.assert_allclose(t[index], stamps, atol=1e-6)
    np.testing.assert_allclose(samples, (xy[index] * SCALE).astype(np.float32), atol=1e-3)


@pytest.mark.lsl
def test_console_script_streams_a_fixed_target(capsys):
    source_id = unique('sim-gaze-cli')
    result = {}
    cli = threading.Thread(target=lambda: result.setdefault('rc', sim_gaze.main([
        '--target', '300,200', '--duration', '4', '--source-id', source_id,
        '--name', unique('sim_gaze_cli'), '--rate', '60', '--status-s', '1',
        '--offset-deg', '0.4', '--jitter-deg', '0.2', '--field-deg', '0', '--seed', '4'])))
    cli.start()
    try:
        inlet = open_inlet(source_id)
        assert inlet.info().nominal_srate() == pytest.approx(60.0)
        samples, _ = pull_for(inlet, 0.5)
    finally:
        cli.join(15.0)
    assert result.get('rc') == 0
    valid = np.isfinite(samples).all(axis=1)
    # 0.4 deg offset + jitter (no error varying over the screen, which is largest in a
    # corner): within ~1 deg (38 screen px, 27 source px).
    assert np.linalg.norm(np.median(samples[valid], axis=0) - (300 * SCALE[0], 200 * SCALE[1])) \
        < 30
    out = capsys.readouterr().out
    assert source_id in out and 'target: (300, 200) px' in out and '(stopped)' in out


def test_console_script_rejects_bad_options(capsys):
    with pytest.raises(SystemExit) as exc:
        sim_gaze.main(['--target', '300'])
    assert exc.value.code == 2
    with pytest.raises(SystemExit):
        sim_gaze.main(['--jitter-deg', '-1'])
    assert 'jitter_deg' in capsys.readouterr().err


def test_parse_script_reads_timed_targets_and_rejects_nonsense(tmp_path):
    entries, repeat = parse_script({'targets': [{'t': 0, 'xy': [960, 540]},
                                                [2.5, None], {'t': 3, 'xy': [1, 2]}],
                                    'repeat_s': 4})
    assert entries == [(0.0, (960.0, 540.0)), (2.5, None), (3.0, (1.0, 2.0))]
    assert repeat == 4.0
    path = tmp_path / 'script.yaml'
    path.write_text('- {t: 0, xy: [10, 20]}\n- {t: 1, xy: null}\n')
    assert sim_gaze.load_script(str(path)) == ([(0.0, (10.0, 20.0)), (1.0, None)], None)
    for bad, message in (([], 'non-empty'), ([{'t': 0}], 'target 0'),
                         ([[1, [0, 0]], [0, [0, 0]]], 'time order'),
                         ([[0, [0, 0, 0]]], 'target 0'),
                         ({'targets': [[0, None]], 'repeat_s': 0}, 'repeat_s'),
                         ({'target': []}, 'unknown')):
        with pytest.raises(ValueError, match=message):
            parse_script(bad)


def test_streamer_rejects_bad_settings():
    with pytest.raises(ValueError, match='source_size'):
        GazeStreamer(source_size=(0, 768))
    with pytest.raises(ValueError, match='chunk_ms'):
        GazeStreamer(chunk_ms=0.0)
    with pytest.raises(ValueError, match='target'):
        GazeStreamer().set_target((1.0, float('nan')))
