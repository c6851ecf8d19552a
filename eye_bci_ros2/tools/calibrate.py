"""
Calibrate the RViz camera intrinsic from world/pixel correspondences.

Reads a YAML file of map points and the pixels where they appear in the RViz
render panel (see config/calibration_example.yaml), fits the intrinsic with
the direct RViz-model fit (default, or ``--model full``) and with the original
report's DLT + ``C . External^-1``, prints a residual report (per point, RMS,
max; fit, held-out and validation views), checks the fit against the analytic
RViz intrinsic and warns about a wrong panel size, HiDPI scaling or screen
offset, and writes a marker_projector parameter file with ``--output``.

Usage::

    calibrate config/calibration_example.yaml --output calibrated.yaml
    python -m eye_bci_ros2.tools.calibrate config/calibration_example.yaml
"""

import argparse
from dataclasses import dataclass
import math
import sys
from typing import List, Optional, Tuple

import numpy as np
import yaml

from eye_bci_ros2.projection import calibration
from eye_bci_ros2.projection.geometry import look_at

#: Exit status for bad input (malformed YAML, bad values, too few points).
EXIT_BAD_INPUT = 2
#: Exit status when the output file cannot be written.
EXIT_WRITE_FAILED = 1

_TOP_KEYS = {'image_width', 'image_height', 'fov_y_deg', 'pixel_frame', 'screen_offset',
             'fit_count', 'camera', 'points', 'validation_views'}


@dataclass
class View:
    """One camera view: its External and its correspondences."""

    name: str
    #: World -> camera, shape (4, 4).
    external: np.ndarray
    #: World points, shape (N, 3), m.
    points: np.ndarray
    #: Image pixels (render panel), shape (N, 2), px.
    pixels: np.ndarray


@dataclass
class CalibrationInput:
    """A parsed correspondence file."""

    image_width: int
    image_height: int
    fov_y_deg: float
    #: The calibration view.
    view: View
    #: Which points of the calibration view fit, shape (N,) bool.
    fit_mask: np.ndarray
    #: Views used only to validate.
    validation: List[View]


def _numbers(where: str, value, count: int) -> np.ndarray:
    """Parse a list of ``count`` finite numbers."""
    if not isinstance(value, (list, tuple)) or len(value) != count or \
            not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise ValueError(f'{where}: expected a list of {count} numbers, got {value!r}')
    array = np.array(value, dtype=float)
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{where}: NaN or infinite value in {value!r}')
    return array


def _mapping(where: str, value) -> dict:
    """Check that ``value`` is a YAML mapping."""
    if not isinstance(value, dict):
        raise ValueError(f'{where}: expected a mapping (key: value), got {value!r}')
    return value


def _camera(where: str, value) -> np.ndarray:
    """Parse ``{eye, focus, up}`` into an External."""
    camera = _mapping(where, value)
    missing = {'eye', 'focus'} - set(camera)
    if missing:
        raise ValueError(f'{where}: missing {", ".join(sorted(missing))} (camera needs eye, '
                         'focus and optionally up, world frame, m)')
    eye = _numbers(f'{where}.eye', camera['eye'], 3)
    focus = _numbers(f'{where}.focus', camera['focus'], 3)
    up = _numbers(f'{where}.up', camera.get('up', [0.0, 0.0, 1.0]), 3)
    try:
        return look_at(eye, focus, up)
    except ValueError as error:
        raise ValueError(f'{where}: {error}') from None


def _points(where: str, value, offset: np.ndarray) -> Tuple[np.ndarray, np.ndarray, list]:
    """Parse a list of ``{world, pixel, use}`` into points, image pixels and uses."""
    if not isinstance(value, list) or not value:
        raise ValueError(f'{where}: expected a non-empty list of {{world: [x, y, z], '
                         f'pixel: [u, v]}} entries, got {value!r}')
    points, pixels, uses = [], [], []
    for index, entry in enumerate(value):
        here = f'{where}[{index}]'
        entry = _mapping(here, entry)
        for key in ('world', 'pixel'):
            if key not in entry:
                raise ValueError(f'{here}: missing {key!r}')
        points.append(_numbers(f'{here}.world', entry['world'], 3))
        pixels.append(_numbers(f'{here}.pixel', entry['pixel'], 2) - offset)
        use = entry.get('use')
        if use not in (None, 'fit', 'test'):
            raise ValueError(f'{here}.use: expected fit or test, got {use!r}')
        uses.append(use)
    return np.array(points), np.array(pixels), uses


def parse_input(document) -> CalibrationInput:
    """
    Check and convert a loaded correspondence YAML document.

    :raises ValueError: with the offending key and what was expected.
    """
    document = _mapping('file', document)
    unknown = set(document) - _TOP_KEYS
    if unknown:
        raise ValueError(f'unknown keys {sorted(unknown)}; expected some of {sorted(_TOP_KEYS)}')
    for key in ('image_width', 'image_height', 'camera', 'points'):
        if key not in document:
            raise ValueError(f'missing required key {key!r}')
    size = []
    for key in ('image_width', 'image_height'):
        value = document[key]
        if not isinstance(value, int) or isinstance(value, bool) or value <= 0:
            raise ValueError(f'{key}: expected a positive whole number of px (the RViz render '
                             f'panel), got {value!r}')
        size.append(value)
    fov = document.get('fov_y_deg', 45.0)
    if not isinstance(fov, (int, float)) or isinstance(fov, bool) or not 0 < fov < 180:
        raise ValueError(f'fov_y_deg: expected degrees in (0, 180), got {fov!r}')
    frame = document.get('pixel_frame', 'image')
    if frame == 'image':
        if 'screen_offset' in document:
            raise ValueError('screen_offset is given but pixel_frame is image: set pixel_frame: '
                             'screen if the pixels were read on the whole screen')
        offset = np.zeros(2)
    elif frame == 'screen':
        if 'screen_offset' not in document:
            raise ValueError('pixel_frame: screen needs screen_offset: [X0, Y0], the screen px '
                             "of the render panel's top-left corner")
        offset = _numbers('screen_offset', document['screen_offset'], 2)
    else:
        raise ValueError(f'pixel_frame: expected image or screen, got {frame!r}')

    points, pixels, uses = _points('points', document['points'], offset)
    view = View('calibration view', _camera('camera', document['camera']), points, pixels)
    fit_mask = _fit_mask(document.get('fit_count'), uses)

    validation = []
    views = document.get('validation_views', [])
    if not isinstance(views, list):
        raise ValueError(f'validation_views: expected a list of views, got {views!r}')
    for index, entry in enumerate(views):
        where = f'validation_views[{index}]'
        entry = _mapping(where, entry)
        for key in ('camera', 'points'):
            if key not in entry:
                raise ValueError(f'{where}: missing {key!r}')
        extra_points, extra_pixels, extra_uses = _points(f'{where}.points', entry['points'],
                                                         offset)
        if any(extra_uses):
            raise ValueError(f'{where}.points: use: applies to the calibration view only')
        validation.append(View(str(entry.get('name', f'validation view {index + 1}')),
                               _camera(f'{where}.camera', entry['camera']),
                               extra_points, extra_pixels))
    return CalibrationInput(size[0], size[1], float(fov), view, fit_mask, validation)


def _fit_mask(fit_count, uses: list) -> np.ndarray:
    """Fit mask from ``fit_count`` (first N points) or per-point ``use``."""
    if fit_count is not None and any(uses):
        raise ValueError('give either fit_count or per-point use: fit|test, not both')
    if fit_count is not None:
        if not isinstance(fit_count, int) or isinstance(fit_count, bool) or \
                not 1 <= fit_count <= len(uses):
            raise ValueError(f'fit_count: expected a whole number in [1, {len(uses)}] (the '
                             f'first fit_count points fit, the rest are held out), got '
                             f'{fit_count!r}')
        return np.arange(len(uses)) < fit_count
    return np.array([use != 'test' for use in uses])


def load_input(path: str) -> CalibrationInput:
    """Read and parse a correspondence YAML file; raise ValueError on any problem."""
    try:
        with open(path, encoding='utf-8') as stream:
            document = yaml.safe_load(stream)
    except OSError as error:
        raise ValueError(f'cannot read {path}: {error.strerror or error}') from None
    except yaml.YAMLError as error:
        raise ValueError(f'{path} is not valid YAML: {error}') from None
    try:
        return parse_input(document)
    except ValueError as error:
        raise ValueError(f'{path}: {error}') from None


def _point_table(view: View, errors: np.ndarray, projection: np.ndarray,
                 mask: Optional[np.ndarray]) -> List[str]:
    """Per-point lines: use, world, measured and predicted pixel, error."""
    predicted = calibration.project(projection, view.points)
    lines = [f'    {"#":>3} {"use":<5} {"world (m)":<26} {"pixel (px)":<17} '
             f'{"predicted (px)":<17} {"error (px)":>10}']
    for index, (point, pixel, guess, error) in enumerate(
            zip(view.points, view.pixels, predicted, errors)):
        use = '' if mask is None else ('fit' if mask[index] else 'test')
        world = ', '.join(f'{c:.3f}' for c in point)
        lines.append(f'    {index:>3} {use:<5} {world:<26} {pixel[0]:7.1f}, {pixel[1]:7.1f}  '
                     f'{_px(guess[0])}, {_px(guess[1])}  {_px(error, 10)}')
    return lines


def _px(value: float, width: int = 7) -> str:
    """Format a pixel value, showing huge or infinite values compactly."""
    if not math.isfinite(value):
        return f'{"inf":>{width}}'
    return f'{value:{width}.1f}' if abs(value) < 1e6 else f'{value:{width}.1e}'


def _summary(label: str, residuals: calibration.Residuals) -> str:
    """One line: RMS and max of a set of residuals."""
    if not residuals.count:
        return f'  {label}: no points'
    return (f'  {label}: RMS {_px(residuals.rms).strip()} px, max '
            f'{_px(residuals.maximum).strip()} px ({residuals.count} points)')


def _method_report(title: str, result: calibration.CalibrationResult,
                   data: CalibrationInput) -> List[str]:
    """Report lines of one fitted intrinsic on every view."""
    p = result.parameters
    lines = [f'== {title} ==',
             f'  intrinsic: fx {p["fx"]:.2f}, fy {p["fy"]:.2f}, skew {p["skew"]:.2f}, '
             f'cx {p["cx"]:.2f}, cy {p["cy"]:.2f} px',
             _summary('calibration view, fit points', result.fit),
             _summary('calibration view, held-out points', result.held_out)]
    lines += _point_table(data.view, result.errors, result.intrinsic @ data.view.external,
                          result.fit_mask)
    for view in data.validation:
        projection = result.intrinsic @ view.external
        errors = calibration.pixel_errors(projection, view.points, view.pixels)
        lines.append(_summary(view.name, calibration.Residuals(errors)))
        lines += _point_table(view, errors, projection, None)
    return lines


def _input_warnings(data: CalibrationInput) -> List[str]:
    """Warnings about the readings themselves (outside the panel, behind the camera)."""
    warnings = []
    for view in [data.view] + data.validation:
        outside = np.flatnonzero((view.pixels[:, 0] < 0) | (view.pixels[:, 0] > data.image_width)
                                 | (view.pixels[:, 1] < 0)
                                 | (view.pixels[:, 1] > data.image_height))
        if len(outside):
            warnings.append(f'{view.name}: pixels of points {outside.tolist()} are outside the '
                            f'{data.image_width}x{data.image_height} px render panel: pixels '
                            "must be image px (from the panel's top-left corner); if they are "
                            'screen px, set pixel_frame: screen and screen_offset: [X0, Y0]')
    return warnings


def parameter_yaml(intrinsic: np.ndarray, width: int, height: int, header: str = '') -> str:
    """
    Text of a marker_projector parameter file.

    :param intrinsic: shape (3, 4), written row-major as 12 doubles.
    """
    parameters = {'/marker_projector': {'ros__parameters': {
        'image_width': int(width), 'image_height': int(height),
        'intrinsic_matrix': [float(v) for v in np.asarray(intrinsic, dtype=float).ravel()],
    }}}
    return header + yaml.safe_dump(parameters, default_flow_style=None, sort_keys=False)


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line parser."""
    parser = argparse.ArgumentParser(
        prog='calibrate',
        description='Fit the RViz camera intrinsic from world/pixel correspondences, report '
                    'residuals, check against the analytic RViz model and write a '
                    'marker_projector parameter file.',
        epilog='Pixels are image px of the RViz render panel (origin at its top-left corner), '
               'unless the file says pixel_frame: screen with screen_offset: [X0, Y0]. '
               'Example: calibrate config/calibration_example.yaml --output calibrated.yaml')
    parser.add_argument('correspondences', help='YAML file of correspondences (see '
                        'config/calibration_example.yaml)')
    parser.add_argument('--model', choices=sorted(calibration.MODELS), default='rviz',
                        help='intrinsic model of the direct fit that is written: rviz = f, '
                             'cx, cy (default); full = fx, fy, skew, cx, cy')
    parser.add_argument('--output', '-o', metavar='FILE',
                        help='write the marker_projector parameter YAML here')
    parser.add_argument('--focal-tolerance', type=float, default=0.02, metavar='FRACTION',
                        help='warn when the focal length differs from the analytic one by '
                             'more than this fraction (default 0.02)')
    parser.add_argument('--principal-tolerance', type=float, default=4.0, metavar='PX',
                        help='warn when the principal point is further than this from the '
                             'panel centre (default 4 px)')
    return parser


def run(args: argparse.Namespace, out=None) -> int:
    """
    Run the calibration of parsed arguments, printing the report to ``out`` (default stdout).

    :raises ValueError: bad input, with a message for the user.
    """
    out = sys.stdout if out is None else out
    if not args.focal_tolerance > 0 or not args.principal_tolerance > 0:
        raise ValueError('--focal-tolerance and --principal-tolerance must be positive')
    data = load_input(args.correspondences)
    view = data.view
    try:
        chosen = calibration.calibrate(view.points, view.pixels, view.external, args.model,
                                       data.fit_mask)
    except ValueError as error:
        raise ValueError(f'{args.correspondences}: direct {args.model} fit failed: '
                         f'{error}') from None
    fit_points = int(data.fit_mask.sum())
    lines = [f'Calibration of {args.correspondences}: {len(view.points)} points in the '
             f'calibration view ({fit_points} fit, {len(view.points) - fit_points} held out), '
             f'{len(data.validation)} validation view(s); render panel {data.image_width}x'
             f'{data.image_height} px, pixels in image px', '']
    lines += _method_report(f'direct fit, {args.model} model: {calibration.MODELS[args.model]} '
                            '[written]', chosen, data)
    lines.append('')
    dlt_title = 'original method: 11-parameter DLT + C.External^-1'
    try:
        dlt = calibration.calibrate(view.points, view.pixels, view.external, 'dlt',
                                    data.fit_mask)
    except ValueError as error:
        dlt = None
        lines += [f'== {dlt_title} ==', f'  not possible: {error}']
    else:
        lines += _method_report(dlt_title, dlt, data)
    lines.append('')

    analytic = calibration.rviz_intrinsic(data.image_width, data.image_height, data.fov_y_deg)
    lines.append(f'== analytic RViz model ({data.image_width}x{data.image_height} px, FOV '
                 f'{data.fov_y_deg:g} deg: f {analytic[0, 0]:.2f}, cx {analytic[0, 2]:.2f}, '
                 f'cy {analytic[1, 2]:.2f} px), no fit ==')
    for check in [view] + data.validation:
        lines.append(_summary(check.name, calibration.residuals(
            analytic @ check.external, check.points, check.pixels)))
    lines.append('')

    comparison = calibration.compare_with_rviz(
        chosen.intrinsic, data.image_width, data.image_height, data.fov_y_deg,
        args.focal_tolerance, args.principal_tolerance)
    warnings = _input_warnings(data) + comparison.warnings
    if dlt is not None and dlt.flatness < 0.05:
        warnings.append(f'the fit points are nearly coplanar (flatness {dlt.flatness:.3g}): the '
                        'DLT is ill-conditioned and its intrinsic is unreliable; use the direct '
                        'fit')
    lines.append(f'== check against the analytic RViz model (tolerances {args.focal_tolerance:g} '
                 f'focal, {args.principal_tolerance:g} px principal point) ==')
    lines.append(f'  focal ratio fitted/analytic {comparison.focal_ratio:.4f}, principal point '
                 f'offset ({comparison.principal_offset[0]:+.1f}, '
                 f'{comparison.principal_offset[1]:+.1f}) px')
    lines += [f'  WARNING: {warning}' for warning in warnings] or \
        ['  OK: the fit agrees with the analytic RViz model (the analytic intrinsic, the '
         'default of marker_projector, is good enough)']
    lines.append('')

    rms = chosen.fit.rms
    header = (f'# marker_projector parameters from: calibrate {args.correspondences} '
              f'--model {args.model}\n# fit RMS {rms:.2f} px on {fit_points} points; '
              'intrinsic_matrix is the 3x4 intrinsic, row-major\n')
    text = parameter_yaml(chosen.intrinsic, data.image_width, data.image_height, header)
    if args.output:
        try:
            with open(args.output, 'w', encoding='utf-8') as stream:
                stream.write(text)
        except OSError as error:
            print('\n'.join(lines), file=out)
            print(f'calibrate: error: cannot write {args.output}: {error.strerror or error}',
                  file=sys.stderr)
            return EXIT_WRITE_FAILED
        lines.append(f'wrote {args.output} (load with --ros-args --params-file {args.output})')
    else:
        lines += ['marker_projector parameters (write them with --output FILE):', text]
    print('\n'.join(lines), file=out)
    return 0


def main(argv: Optional[List[str]] = None) -> int:
    """Run the ``calibrate`` command; return the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return run(args)
    except ValueError as error:
        print(f'calibrate: error: {error}', file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == '__main__':
    sys.exit(main())
