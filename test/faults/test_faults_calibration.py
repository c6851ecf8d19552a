"""
Bad calibration input, through the API and the ``calibrate`` command.

Every case must end in a ``ValueError`` (API) or exit status 2 with one
``calibrate: error:`` line (CLI) that names the problem, never a traceback,
a crash inside numpy or a silently wrong intrinsic.
"""

import math
import re
import subprocess
import sys

import numpy as np
from paths import REPO
import pytest
import yaml

from eye_bci_ros2.projection import calibration
from eye_bci_ros2.projection.geometry import look_at, project_points
from eye_bci_ros2.tools.calibrate import EXIT_BAD_INPUT, main

ROOT = str(REPO)
CAMERA = {'eye': [-7.0, -6.0, 8.0], 'focus': [0.0, 0.0, 0.0], 'up': [0.0, 0.0, 1.0]}
EXTERNAL = look_at(CAMERA['eye'], CAMERA['focus'], CAMERA['up'])
INTRINSIC = calibration.rviz_intrinsic(1280, 720)


def scene(count=10, max_height=2.0, seed=5):
    """World points (N, 3) spread over a room and their exact pixels (N, 2)."""
    rng = np.random.default_rng(seed)
    points = np.column_stack([rng.uniform(-3.0, 3.0, (count, 2)),
                              rng.uniform(0.0, max_height, count)])
    pixels, _ = project_points(points, INTRINSIC, EXTERNAL)
    return points, pixels


def collinear(count=8):
    """Points on one straight line through the room (not through the camera)."""
    t = np.linspace(-2.0, 2.0, count)[:, None]
    points = np.array([0.5, -1.0, 0.3]) + t * np.array([1.0, 0.7, 0.2])
    pixels, _ = project_points(points, INTRINSIC, EXTERNAL)
    return points, pixels


def with_row(array, row, value):
    """Copy of ``array`` with ``array[row] = value``."""
    array = np.array(array, dtype=float)
    array[row] = value
    return array


def _api_cases():
    points, pixels = scene()
    flat_points, flat_pixels = scene(max_height=0.0)
    line_points, line_pixels = collinear()
    duplicated = with_row(points, 3, points[7])
    return {
        'DLT with 5 points': (calibration.fit_projection, (points[:5], pixels[:5]),
                              'at least 6 points, got 5'),
        'direct fit with 2 points': (calibration.fit_intrinsic,
                                     (points[:2], pixels[:2], EXTERNAL), 'at least 3 points'),
        'no points at all': (calibration.fit_intrinsic,
                             (np.zeros((0, 3)), np.zeros((0, 2)), EXTERNAL), 'at least 3'),
        'duplicated world point (DLT)': (calibration.fit_projection, (duplicated, pixels),
                                         'points 3 and 7 are the same world point'),
        'duplicated world point (direct fit)': (
            calibration.fit_intrinsic, (duplicated, pixels, EXTERNAL), 'same world point'),
        'collinear points (DLT)': (calibration.fit_projection, (line_points, line_pixels),
                                   'collinear'),
        'collinear points (full model)': (
            calibration.fit_intrinsic,
            (line_points, line_pixels, EXTERNAL, 'full'), 'one straight line in the image'),
        'coplanar points (DLT)': (calibration.fit_projection, (flat_points, flat_pixels),
                                  'coplanar'),
        'NaN world point': (calibration.fit_intrinsic,
                            (with_row(points, 4, [math.nan, 0.0, 0.0]), pixels, EXTERNAL),
                            r'points contains NaN or infinite values \(rows \[4\]\)'),
        'infinite pixel': (calibration.fit_projection,
                           (points, with_row(pixels, 2, [math.inf, 1.0])),
                           r'pixels contains NaN or infinite values \(rows \[2\]\)'),
        'NaN in the External': (calibration.fit_intrinsic,
                                (points, pixels, with_row(EXTERNAL, 0, math.nan)),
                                'external contains NaN'),
        'points and pixels of different length': (
            calibration.fit_intrinsic, (points, pixels[:-1], EXTERNAL), 'must pair up'),
        'pixels with 3 columns': (calibration.fit_projection,
                                  (points, np.column_stack([pixels, pixels[:, 0]])),
                                  r'pixels must have shape \(N, 2\)'),
        'text instead of numbers': (calibration.fit_projection, (points, [['a', 'b']] * 10),
                                    'pixels must be numbers'),
        'points behind the camera': (
            calibration.fit_intrinsic,
            (with_row(points, 0, CAMERA['eye'] + np.array([-1.0, -1.0, 1.0])), pixels,
             EXTERNAL), r'points \[0\] are behind the camera'),
        'non-rigid External': (calibration.fit_intrinsic,
                               (points, pixels, EXTERNAL * 2.0), 'homogeneous transform'),
        'unknown model': (calibration.fit_intrinsic, (points, pixels, EXTERNAL, 'magic'),
                          'model must be one of'),
        'fit mask of the wrong length': (
            calibration.calibrate, (points, pixels, EXTERNAL, 'rviz', [True] * 3),
            'fit_mask must be 10 booleans'),
    }


API_CASES = _api_cases()


@pytest.mark.parametrize('name', sorted(API_CASES))
def test_api_rejects_bad_correspondences_with_a_reason(fault, name):
    function, args, message = API_CASES[name]
    with fault('calibration', f'API: {name}'):
        with pytest.raises(ValueError, match=message):
            function(*args)


def test_coplanar_points_still_calibrate_with_the_direct_fit(fault):
    """A flat map defeats the DLT but not the RViz-model fit: the right answer, not an error."""
    points, pixels = scene(count=8, max_height=0.0)
    with fault('calibration', 'API: coplanar points (direct fit)'):
        intrinsic = calibration.fit_intrinsic(points, pixels, EXTERNAL)
        np.testing.assert_allclose(intrinsic, INTRINSIC, atol=1e-6)


def test_three_points_are_enough_for_the_direct_fit(fault):
    points, pixels = scene(count=3)
    with fault('calibration', 'API: minimum of 3 points (direct fit)'):
        np.testing.assert_allclose(calibration.fit_intrinsic(points, pixels, EXTERNAL),
                                   INTRINSIC, atol=1e-6)


# -- the command ----------------------------------------------------------------------------


def document(points=None, pixels=None, **changes):
    """Build the correspondences of the scene as a dict, with ``changes`` applied."""
    if points is None:
        points, pixels = scene()
    entries = [{'world': [float(v) for v in p], 'pixel': [float(v) for v in q]}
               for p, q in zip(points, pixels)]
    content = {'image_width': 1280, 'image_height': 720, 'camera': dict(CAMERA),
               'points': entries}
    content.update(changes)
    return content


def _cli_cases():
    points, pixels = scene()
    line_points, line_pixels = collinear()
    duplicated = with_row(points, 2, points[5])
    nan_doc = document()
    nan_doc['points'][1]['world'][0] = math.nan
    inf_doc = document()
    inf_doc['points'][4]['pixel'][1] = math.inf
    text_doc = document()
    text_doc['points'][0]['pixel'] = ['u', 'v']
    short_doc = document()
    short_doc['points'][3]['world'] = [1.0, 2.0]
    return {
        'malformed YAML (unclosed bracket)': ('image_width: 1280\npoints: [{world: [1, 2\n',
                                              'not valid YAML'),
        'malformed YAML (tab indentation)': ('image_width: 1280\ncamera:\n\teye: [1, 2, 3]\n',
                                             'not valid YAML'),
        'empty file': ('', 'expected a mapping'),
        'YAML list instead of a mapping': ('- 1\n- 2\n', 'expected a mapping'),
        'binary garbage': (b'\x00\xff\xfe\x89PNG\r\n', "can't decode byte 0xff"),
        'too few points (2)': (document(points[:2], pixels[:2]), 'at least 3 points, got 2'),
        'duplicated points': (document(duplicated, pixels),
                              'points 2 and 5 are the same world point'),
        'collinear points (full model)': (document(line_points, line_pixels),
                                          'one straight line', ['--model', 'full']),
        'NaN world coordinate': (nan_doc, r'points\[1\]\.world: NaN or infinite'),
        'infinite pixel': (inf_doc, r'points\[4\]\.pixel: NaN or infinite'),
        'text instead of a pixel': (text_doc, r'points\[0\]\.pixel: expected a list of 2'),
        'world point with 2 numbers': (short_doc, r'points\[3\]\.world: expected a list of 3'),
        'image_width as text': (document(image_width='wide'), 'image_width: expected a '
                                'positive whole number'),
        'camera up parallel to the view': (
            document(camera={'eye': [0, 0, 5], 'focus': [0, 0, 0], 'up': [0, 0, 1]}),
            'parallel to the view'),
        'missing file': (None, 'cannot read'),
        'negative tolerance': (document(), 'must be positive', ['--focal-tolerance', '-1']),
    }


CLI_CASES = _cli_cases()


def write(path, content):
    """Write a document (dict), text or bytes to ``path``; None writes nothing."""
    if isinstance(content, dict):
        path.write_text(yaml.safe_dump(content))
    elif isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content)
    return str(path)


@pytest.mark.parametrize('name', sorted(CLI_CASES))
def test_command_rejects_bad_input_with_a_clear_message(tmp_path, capsys, fault, name):
    content, message, *extra = CLI_CASES[name]
    path = write(tmp_path / 'correspondences.yaml', content)
    output = tmp_path / 'calibrated.yaml'
    with fault('calibration', f'CLI: {name}'):
        assert main([path, '--output', str(output)] + (extra[0] if extra else [])) == \
            EXIT_BAD_INPUT
        captured = capsys.readouterr()
        error = captured.err.strip()
        assert error.startswith('calibrate: error: '), error
        assert re.search(message, error), error
        assert 'Traceback' not in captured.err
        assert not output.exists(), 'a parameter file was written from bad input'


def test_coplanar_points_calibrate_and_say_the_dlt_is_impossible(tmp_path, capsys, fault):
    path = write(tmp_path / 'flat.yaml', document(*scene(count=8, max_height=0.0)))
    output = tmp_path / 'calibrated.yaml'
    with fault('calibration', 'CLI: coplanar points'):
        assert main([path, '--output', str(output)]) == 0
        report = capsys.readouterr().out
        assert 'not possible: the points are coplanar' in report
        matrix = yaml.safe_load(output.read_text())['/marker_projector']['ros__parameters']
        np.testing.assert_allclose(np.reshape(matrix['intrinsic_matrix'], (3, 4)), INTRINSIC,
                                   atol=1e-6)


def test_too_few_points_for_the_dlt_still_calibrate_directly(tmp_path, capsys, fault):
    path = write(tmp_path / 'four.yaml', document(*scene(count=4)))
    with fault('calibration', 'CLI: 4 points (too few for the DLT)'):
        assert main([path]) == 0
        assert 'not possible: the DLT needs at least 6 points, got 4' in capsys.readouterr().out


def test_malformed_yaml_through_the_installed_entry_point(tmp_path, fault):
    path = write(tmp_path / 'broken.yaml', 'camera: {eye: [1, 2, 3]\npoints: ]\n')
    with fault('calibration', 'CLI process: malformed YAML'):
        done = subprocess.run([sys.executable, '-m', 'eye_bci_ros2.tools.calibrate', path],
                              capture_output=True, text=True, timeout=60, cwd=ROOT)
        assert done.returncode == EXIT_BAD_INPUT
        assert 'not valid YAML' in done.stderr and 'Traceback' not in done.stderr
        assert done.stdout == ''
