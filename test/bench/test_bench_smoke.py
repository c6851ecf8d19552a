"""
Smoke tests of the benchmarks: tiny sizes, schema and numerical agreement.

No assertion here depends on how fast anything ran: only on what the
benchmarks compute and on the shape of ``bench_results.json``.
"""

import gc
import inspect
import io
import json
import math
import os
import sys
import threading
import types

import numpy as np
import pytest

from bench import arbitration, projection, reference_original, run_all, timing
from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import rviz_intrinsic

PROJECTION_KEYS = {'ms', 'ms_min', 'reference_ms', 'speedup', 'reference_markers',
                   'reference_extrapolated', 'max_difference_px', 'agrees', 'visible_markers'}
ARBITRATION_KEYS = {'samples_per_s', 'samples_per_s_best', 'per_message_samples_per_s',
                    'reference_samples_per_s', 'speedup', 'batch_samples', 'chunk',
                    'per_message_api', 'in_region_fraction', 'agrees'}


def _positive(value) -> bool:
    return isinstance(value, float) and math.isfinite(value) and value > 0


def test_projection_quick_agrees_with_reference_and_extrapolates_large_sizes():
    section = projection.run(quick=True, sizes=(4, 25), reference_markers=10)

    assert list(section) == ['4', '25']
    for key, row in section.items():
        assert PROJECTION_KEYS <= set(row), key
        assert _positive(row['ms']) and _positive(row['reference_ms'])
        assert row['ms_min'] <= row['ms']
        assert row['agrees'] is True
        assert row['max_difference_px'] <= projection.TOLERANCE_PX
        assert row['visible_markers'] == int(key)  # the scene is all in front of the camera
    assert section['4']['reference_markers'] == 4
    assert section['4']['reference_extrapolated'] is False
    assert section['25']['reference_markers'] == 10
    assert section['25']['reference_extrapolated'] is True


def test_original_external_is_the_look_at_external():
    eye = projection.orbit_eyes()[3]

    expected = geometry.look_at(eye, projection.FOCUS, projection.UP)
    original = reference_original.external_original(
        eye.tolist(), projection.FOCUS, projection.UP)

    np.testing.assert_allclose(original, expected, atol=1e-12)


def test_original_silhouettes_match_box_silhouettes_from_several_views():
    markers = projection.make_markers(40, seed=7)
    for eye in projection.orbit_eyes(4):
        polygons, visible = projection.reproject(markers, eye)
        reference = projection.reproject_reference(markers, eye)
        assert projection.polygon_mismatch(polygons, visible, reference) <= 1e-6


def test_polygon_mismatch_sees_a_moved_vertex_and_a_visibility_change():
    markers = projection.make_markers(3)
    eye = projection.orbit_eyes()[0]
    polygons, visible = projection.reproject(markers, eye)
    reference = projection.reproject_reference(markers, eye)

    moved = polygons.copy()
    moved[1, 0] += (0.5, 0.0)
    assert projection.polygon_mismatch(moved, visible, reference) == pytest.approx(0.5)
    hidden = visible.copy()
    hidden[2] = False
    assert projection.polygon_mismatch(polygons, hidden, reference) == math.inf


def test_reference_reports_a_marker_behind_the_camera_invisible():
    eye = np.array([0.0, 0.0, 5.0])
    positions = [[0.0, 0.0, 0.0], [0.0, 0.0, 8.0]]  # in front of, and behind, the eye
    quaternions = [[0.0, 0.0, 0.0, 1.0]] * 2
    scales = [[0.5, 0.5, 0.1]] * 2
    intrinsic = rviz_intrinsic(*projection.IMAGE_SIZE)

    regions = reference_original.silhouettes_original(positions, quaternions, scales,
                                                      intrinsic, eye, [0.0, 0.0, 0.0],
                                                      [0.0, 1.0, 0.0])
    polygons, visible = geometry.box_silhouettes(np.array(positions), np.array(quaternions),
                                                 np.array(scales), intrinsic,
                                                 geometry.look_at(eye, np.zeros(3), [0, 1, 0]))

    assert regions[1] is None and not visible[1]
    assert projection.polygon_mismatch(polygons[:1], visible[:1], regions[:1]) <= 1e-6


def test_arbitration_quick_schema_and_agreement():
    section = arbitration.run(quick=True, region_counts=(3, 10), samples=3000, chunk=1000)

    assert list(section) == ['3', '10']
    for row in section.values():
        assert ARBITRATION_KEYS <= set(row)
        for key in ('samples_per_s', 'per_message_samples_per_s', 'reference_samples_per_s'):
            assert _positive(row[key]), key
        assert row['batch_samples'] == 3000 and row['chunk'] == 1000
        assert row['agrees'] is True
        assert 0.05 < row['in_region_fraction'] < 0.95
        assert _positive(row['per_message_rounds_samples_per_s'])


def test_chunked_batch_classification_matches_the_python_reference():
    polygons = arbitration.make_regions(10, seed=3)
    points = arbitration.make_gaze(500, polygons, seed=4)
    # Vertices and edge midpoints lie on region boundaries: edges count as inside.
    on_edges = np.concatenate([polygons[:, 0], (polygons[:, 1] + polygons[:, 2]) / 2])
    points = np.concatenate([points, on_edges])

    labels = arbitration.classify_batch(geometry.PolygonSet(polygons), points, chunk=7)
    expected = reference_original.classify_original(points.tolist(), polygons.tolist())

    np.testing.assert_array_equal(labels, expected)
    assert np.all(labels[-len(on_edges):] == np.tile(np.arange(10), 2))


def test_per_message_path_classifies_like_the_batch_path():
    polygons = arbitration.make_regions(10, seed=5)
    points = arbitration.make_gaze(300, polygons, seed=6)
    _, classify_one = arbitration.per_message_classifier(polygons)

    labels = [classify_one(x, y) for x, y in points.tolist()]

    np.testing.assert_array_equal(
        labels, arbitration.classify_batch(geometry.PolygonSet(polygons), points))


@pytest.mark.parametrize('count', [3, 10, 100])
def test_regions_are_realistic_disjoint_convex_and_on_screen(count):
    polygons = arbitration.make_regions(count)

    assert polygons.shape == (count, 6, 2)
    assert np.all(polygons >= 0) and np.all(polygons <= arbitration.SCREEN_SIZE)
    spans = np.linalg.norm(polygons[:, :, None] - polygons[:, None, :], axis=-1).max(axis=(1, 2))
    assert np.all(spans <= 200.0 + 1e-9)
    assert np.all(spans >= 40.0)
    # Convex with one winding: every vertex on the inner side of every edge.
    inside = geometry.PolygonSet(polygons).contains(polygons.reshape(-1, 2))
    owner = np.repeat(np.arange(count), 6)
    np.testing.assert_array_equal(inside, owner[:, None] == np.arange(count)[None, :])


def test_projection_figures_from_known_timings(monkeypatch):
    # The fast path takes 2 ms per call (median; 1 ms at best), the reference 10 ms for the
    # markers it projects (at most 10): 25 markers cost the reference 25 ms, 12.5 x 2 ms.
    def known(func, repeat=7, number=0, warmup=2, min_batch_s=0.02):
        func()
        if number == 1:   # the reference: one call per batch
            return timing.Timing(0.010, 0.010, repeat, 1)
        return timing.Timing(0.001, 0.002, repeat, 100)
    monkeypatch.setattr(projection, 'measure', known)
    section = projection.run(quick=True, sizes=(4, 25), reference_markers=10)
    expected = {'4': (2.0, 1.0, 10.0, 5.0), '25': (2.0, 1.0, 25.0, 12.5)}
    for key, (ms, ms_min, reference_ms, speedup) in expected.items():
        row = section[key]
        assert (row['ms'], row['ms_min']) == pytest.approx((ms, ms_min)), key
        assert (row['reference_ms'], row['speedup']) == pytest.approx(
            (reference_ms, speedup)), key


def test_measure_reports_per_call_times_from_the_clock(monkeypatch):
    # Calls cost 3, 1 and 2 ms in the three timed batches (the warm-up ones nothing): the
    # fastest batch is 1 ms a call, the median 2 ms.
    clock = [0.0]
    costs = iter([0.0] * 2 + [0.003] * 5 + [0.001] * 5 + [0.002] * 5)

    def call():
        clock[0] += next(costs)
    monkeypatch.setattr(timing, 'time', types.SimpleNamespace(perf_counter=lambda: clock[0]))
    result = timing.measure(call, repeat=3, number=5, warmup=2)
    assert (result.min_s, result.median_s) == pytest.approx((0.001, 0.002))
    assert (result.min_ms, result.median_ms) == pytest.approx((1.0, 2.0))
    assert result.repeat == 3 and result.number == 5


def test_measure_reports_per_call_times_and_restores_the_gc():
    calls = []
    gc.enable()

    result = timing.measure(lambda: calls.append(gc.isenabled()), repeat=3, number=5, warmup=2)

    assert len(calls) == 2 + 3 * 5
    assert calls[2:] == [False] * 15  # the GC is off while timing
    assert gc.isenabled()
    assert result.repeat == 3 and result.number == 5
    assert 0 < result.min_s <= result.median_s


def test_machine_info_names_cpus_numpy_and_python(monkeypatch):
    monkeypatch.setenv('OPENBLAS_NUM_THREADS', '3')
    monkeypatch.delenv('OMP_NUM_THREADS', raising=False)
    own = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(own)})   # this process on one core, for the count
    try:
        info = timing.machine_info()
    finally:
        os.sched_setaffinity(0, own)

    with open('/proc/cpuinfo', encoding='utf-8') as cpuinfo:
        processors = sum(line.startswith('processor') for line in cpuinfo)
    assert info['cpu_count'] == processors and info['cpus_available'] == 1
    assert info['thread_environment']['OPENBLAS_NUM_THREADS'] == '3'
    assert info['thread_environment']['OMP_NUM_THREADS'] is None
    assert info['numpy'] == np.__version__
    assert info['python'] == '.'.join(map(str, sys.version_info[:3]))


def test_run_all_writes_json_and_keeps_other_sections_with_only(tmp_path, capsys):
    output = tmp_path / 'bench_results.json'
    output.write_text(json.dumps({'arbitration': {'10': {'samples_per_s': 1.0}}}))

    status = run_all.main(['--quick', '--only', 'projection', '--output', str(output)])

    assert status == 0
    results = json.loads(output.read_text())
    assert set(results['projection']) == {str(size) for size in projection.QUICK_SIZES}
    assert PROJECTION_KEYS <= set(results['projection']['100'])
    assert results['arbitration'] == {'10': {'samples_per_s': 1.0}}  # kept
    assert {'cpu_count', 'numpy', 'python'} <= set(results['machine'])
    assert results['run']['quick'] is True
    assert results['run']['benchmarks'] == ['projection']
    printed = capsys.readouterr().out
    assert 'projection' in printed and 'reference_ms' in printed


def test_run_all_skips_missing_modules_and_reports_failures(tmp_path, monkeypatch):
    def broken(quick=False):
        raise RuntimeError('benchmark broke')

    monkeypatch.setitem(sys.modules, 'bench_smoke_broken', types.SimpleNamespace(run=broken))
    monkeypatch.setitem(sys.modules, 'bench_smoke_fine', types.SimpleNamespace(
        run=lambda quick=False: {'1': {'value': 2.0, 'agrees': True}}))
    monkeypatch.setattr(run_all, 'REGISTRY', {'fine': 'bench_smoke_fine',
                                              'broken': 'bench_smoke_broken',
                                              'missing': 'bench.no_such_benchmark'})
    output = tmp_path / 'results.json'

    status = run_all.main(['--output', str(output)])

    assert status == 1
    results = json.loads(output.read_text())
    assert results['fine'] == {'1': {'value': 2.0, 'agrees': True}}
    assert 'broken' not in results and 'missing' not in results
    assert 'benchmark broke' in results['run']['errors']['broken']
    assert 'does not exist' in results['run']['skipped']['missing']


def test_run_all_fails_when_a_fast_path_disagrees_with_its_reference(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, 'bench_smoke_wrong', types.SimpleNamespace(
        run=lambda quick=False: {'1': {'ms': 1.0, 'agrees': False}}))
    monkeypatch.setattr(run_all, 'REGISTRY', {'wrong': 'bench_smoke_wrong'})

    assert run_all.main(['--output', str(tmp_path / 'r.json')]) == 1


def test_registry_has_slots_for_latency_and_decision():
    assert {'projection', 'arbitration', 'latency', 'decision'} <= set(run_all.REGISTRY)
    with pytest.raises(SystemExit):
        run_all.parse_args(['--only', 'no_such_benchmark'])
    assert run_all.parse_args(['--only', 'latency,decision']).only == ['latency', 'decision']


def test_table_has_one_row_per_size_and_the_chosen_columns():
    lines = run_all.format_table('projection', {'10': {'ms': 0.5, 'agrees': True},
                                                '100': {'ms': 1.25, 'agrees': False}},
                                 columns=['ms', 'agrees'])

    assert lines[0].split() == ['projection', 'ms', 'agrees']
    assert lines[2].split() == ['10', '0.500', 'yes']
    assert lines[3].split() == ['100', '1.250', 'no']
    assert run_all.format_table('latency', {'p50_ms': 3.0}) == ['latency: {"p50_ms": 3.0}']


def test_run_all_prints_each_section_as_it_finishes_with_progress(
        tmp_path, monkeypatch, capsys):
    output = tmp_path / 'results.json'
    seen = {}

    def first(quick=False, trials=100):
        return {'row': {'trials': float(trials)}}

    def second(quick=False):
        # By now the first section's table is out and its results are on disk.
        seen['printed'] = capsys.readouterr()
        seen['on_disk'] = json.loads(output.read_text())
        return {'row': {'value': 1.0}}

    monkeypatch.setitem(sys.modules, 'bench_smoke_first', types.SimpleNamespace(run=first))
    monkeypatch.setitem(sys.modules, 'bench_smoke_second', types.SimpleNamespace(run=second))
    monkeypatch.setattr(run_all, 'REGISTRY', {'first': 'bench_smoke_first',
                                              'second': 'bench_smoke_second'})
    monkeypatch.setattr(run_all, 'DEFAULT_RUN', {'first': ({'trials': 7}, '7 trials of 100')})

    assert run_all.main(['--output', str(output)]) == 0

    assert 'trials' in seen['printed'].out and '7 trials of 100' in seen['printed'].out
    assert '[1/2 0:00] first: running (7 trials of 100)' in seen['printed'].err
    assert '[1/2 0:00] first: done in' in seen['printed'].err
    assert seen['on_disk']['first'] == {'row': {'trials': 7.0}}
    assert seen['on_disk']['run']['shortened'] == {'first': '7 trials of 100'}
    results = json.loads(output.read_text())
    assert results['run']['mode'] == 'default' and set(results['run']['seconds']) == {
        'first', 'second'}
    assert '[2/2' in capsys.readouterr().err

    # --full: the complete run, nothing shortened.
    assert run_all.main(['--full', '--only', 'first', '--output', str(output)]) == 0
    results = json.loads(output.read_text())
    assert results['first'] == {'row': {'trials': 100.0}}
    assert results['run']['mode'] == 'full' and results['run']['shortened'] == {}


def test_run_all_skips_a_data_section_when_the_named_folder_is_absent(tmp_path, capsys):
    output = tmp_path / 'results.json'

    status = run_all.main(['--only', 'real_gaze,ssvep_real', '--output', str(output),
                           '--gaze-data', str(tmp_path / 'nowhere'),
                           '--eeg-data', str(tmp_path / 'nowhere')])

    assert status == 0
    skipped = json.loads(output.read_text())['run']['skipped']
    assert skipped == {'real_gaze': f'--gaze-data {tmp_path / "nowhere"} is not a folder',
                       'ssvep_real': f'--eeg-data {tmp_path / "nowhere"} is not a folder'}
    assert 'real_gaze: skipped (--gaze-data' in capsys.readouterr().out


def test_a_long_section_reports_that_it_is_still_running(monkeypatch):
    said = threading.Event()

    class Log(io.StringIO):
        def write(self, text):
            if 'slow still running' in text:
                said.set()
            return super().write(text)

    monkeypatch.setitem(sys.modules, 'bench_smoke_slow', types.SimpleNamespace(
        run=lambda quick=False: {'waited': {'said': said.wait(30.0)}}))
    monkeypatch.setattr(run_all, 'REGISTRY', {'slow': 'bench_smoke_slow'})

    outcome = run_all.run_benchmarks(['slow'], log=Log(), heartbeat_s=0.01)

    assert outcome['sections']['slow'] == {'waited': {'said': True}}


@pytest.mark.parametrize('name', sorted(run_all.DEFAULT_RUN))
def test_every_default_run_names_arguments_its_section_takes(name):
    module = run_all.load(name)
    kwargs, shortened = run_all.run_arguments(name, 'default', module)

    inspect.signature(module.run).bind(**kwargs)   # raises on an unknown argument
    assert kwargs and shortened   # a shortened run says what it left out
    assert run_all.run_arguments(name, 'full', module) == ({}, '')
