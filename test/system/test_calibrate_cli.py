"""The `calibrate` command: report, parameter file, diagnoses and input errors."""

import os
import re
import subprocess
import sys

import numpy as np
from paths import REPO
import pytest
import yaml

from eye_bci_ros2.projection.camera_model import rviz_intrinsic
from eye_bci_ros2.projection.geometry import look_at, project_points
from eye_bci_ros2.tools.calibrate import main

ROOT = str(REPO)
EXAMPLE = os.path.join(ROOT, 'config', 'calibration_example.yaml')
CAMERA = {'eye': [-7.0, -6.0, 8.0], 'focus': [0.0, 0.0, 0.0], 'up': [0.0, 0.0, 1.0]}


def write_correspondences(path, max_height=2.0, render=(1280, 720), declared=(1280, 720),
                          shift=(0.0, 0.0), count=10, **extra):
    """Write a correspondence file whose pixels come from a ``render`` px panel, plus ``shift``."""
    rng = np.random.default_rng(11)
    points = np.column_stack([rng.uniform(-3.0, 3.0, (count, 2)),
                              rng.uniform(0.0, max_height, count)])
    pixels, _ = project_points(points, rviz_intrinsic(*render),
                               look_at(CAMERA['eye'], CAMERA['focus'], CAMERA['up']))
    pixels = pixels + np.asarray(shift) + rng.normal(0.0, 0.5, pixels.shape)
    document = {'image_width': declared[0], 'image_height': declared[1], 'camera': CAMERA,
                'points': [{'world': p.tolist(), 'pixel': q.tolist()}
                           for p, q in zip(points, pixels)]}
    document.update(extra)
    path.write_text(yaml.safe_dump(document))
    return str(path)


def _views(document):
    """(external, points, pixels) of every view of a correspondence document."""
    views = [(document['camera'], document['points'])]
    views += [(v['camera'], v['points']) for v in document.get('validation_views', [])]
    return [(look_at(c['eye'], c['focus'], c.get('up', [0, 0, 1])),
             np.array([p['world'] for p in pts], dtype=float),
             np.array([p['pixel'] for p in pts], dtype=float)) for c, pts in views]


def test_example_file_calibrates_and_writes_a_loadable_parameter_file(tmp_path, capsys):
    output = tmp_path / 'calibrated.yaml'
    assert main([EXAMPLE, '--output', str(output)]) == 0
    report = capsys.readouterr().out
    for expected in ('direct fit, rviz model', 'original method: 11-parameter DLT',
                     'held-out points: RMS', 'second view: RMS', 'analytic RViz model',
                     'OK: the fit agrees', f'wrote {output}'):
        assert expected in report
    assert 'WARNING' not in report

    parameters = yaml.safe_load(output.read_text())['/marker_projector']['ros__parameters']
    assert (parameters['image_width'], parameters['image_height']) == (1280, 720)
    matrix = parameters['intrinsic_matrix']
    assert len(matrix) == 12 and all(isinstance(v, float) for v in matrix)
    intrinsic = np.reshape(matrix, (3, 4))
    np.testing.assert_allclose(intrinsic, rviz_intrinsic(1280, 720), rtol=0.01, atol=3.0)
    for external, points, pixels in _views(yaml.safe_load(open(EXAMPLE))):
        predicted, depth = project_points(points, intrinsic, external)
        assert np.all(depth > 0)
        assert np.linalg.norm(predicted - pixels, axis=1).max() < 4.0


def test_full_model_and_per_point_use(tmp_path, capsys):
    path = write_correspondences(tmp_path / 'c.yaml', count=12)
    document = yaml.safe_load(open(path))
    for entry in document['points'][::3]:
        entry['use'] = 'test'
    (tmp_path / 'c.yaml').write_text(yaml.safe_dump(document))
    assert main([path, '--model', 'full']) == 0
    report = capsys.readouterr().out
    assert 'direct fit, full model' in report
    assert '(8 fit, 4 held out)' in report
    assert 'intrinsic_matrix:' in report  # printed when no --output


def test_flat_map_reports_that_the_dlt_is_impossible(tmp_path, capsys):
    assert main([write_correspondences(tmp_path / 'flat.yaml', max_height=0.0)]) == 0
    report = capsys.readouterr().out
    assert 'not possible: the points are coplanar' in report
    assert 'OK: the fit agrees' in report


def test_nearly_flat_map_warns_that_the_dlt_is_unreliable(tmp_path, capsys):
    assert main([write_correspondences(tmp_path / 'flat.yaml', max_height=0.01)]) == 0
    assert 'nearly coplanar' in capsys.readouterr().out


def test_hidpi_readings_are_diagnosed(tmp_path, capsys):
    path = write_correspondences(tmp_path / 'hidpi.yaml', render=(2560, 1440),
                                 declared=(1280, 720))
    assert main([path]) == 0
    report = capsys.readouterr().out
    assert 'WARNING' in report and 'HiDPI' in report and 'outside the 1280x720' in report


def test_screen_pixels_with_offset(tmp_path, capsys):
    shifted = write_correspondences(tmp_path / 'screen.yaml', shift=(64.0, 100.0),
                                    pixel_frame='screen', screen_offset=[64, 100])
    assert main([shifted]) == 0
    assert 'OK: the fit agrees' in capsys.readouterr().out
    # The same readings taken as image px: the offset shows in the principal point.
    unshifted = write_correspondences(tmp_path / 'image.yaml', shift=(64.0, 100.0))
    assert main([unshifted]) == 0
    report = capsys.readouterr().out
    assert 'WARNING: principal point' in report and 'X0 +64, Y0 +100' in report


def test_malformed_yaml_fails_cleanly(tmp_path, capsys):
    path = tmp_path / 'bad.yaml'
    path.write_text('image_width: 1280\nimage_height: [720\n')
    assert main([str(path)]) == 2
    error = capsys.readouterr().err
    assert 'not valid YAML' in error and 'line' in error and 'Traceback' not in error


@pytest.mark.parametrize('change, message', [
    ({'points': None}, 'points: expected a non-empty list'),
    ({'image_width': 0}, 'image_width: expected a positive whole number'),
    ({'camera': {'eye': [0, 0, 1]}}, 'camera: missing focus'),
    ({'camera': {'eye': [0, 0, 1], 'focus': [0, 0, 1]}}, 'eye .* equals focus'),
    ({'fit_count': 20}, r'fit_count: expected a whole number in \[1, 10\]'),
    ({'pixel_frame': 'screen'}, 'needs screen_offset'),
    ({'colour': 'red'}, 'unknown keys'),
    ({'fit_count': 2}, 'needs at least 3 points'),
])
def test_bad_input_exits_with_a_clear_message(tmp_path, capsys, change, message):
    path = write_correspondences(tmp_path / 'c.yaml')
    document = yaml.safe_load(open(path))
    document.update(change)
    (tmp_path / 'c.yaml').write_text(yaml.safe_dump(document))
    assert main([path]) == 2
    error = capsys.readouterr().err
    assert error.startswith('calibrate: error: ')
    assert re.search(message, error), error


def test_too_few_points_fails_as_a_command(tmp_path):
    path = write_correspondences(tmp_path / 'few.yaml', count=2)
    done = subprocess.run([sys.executable, '-m', 'eye_bci_ros2.tools.calibrate', path],
                          capture_output=True, text=True, timeout=60, cwd=ROOT)
    assert done.returncode == 2
    assert 'needs at least 3 points, got 2' in done.stderr
    assert 'Traceback' not in done.stderr
