r"""
Find RViz2's render panel on a screenshot and write its marker_projector parameters.

Take a screenshot of the whole screen (the one the eye tracker is calibrated
on) with RViz2 where it will be during the experiment, then::

    find_panel screenshot.png --output panel.yaml
    ros2 run eye_bci_ros2 marker_projector --ros-args \\
        --params-file config/eye_bci.yaml --params-file panel.yaml

It prints (or writes) ``screen_offset_x/y`` (X0, Y0: the panel's top-left
corner on the screen) and ``image_width/height`` (the panel's size) as a ROS 2
parameter file for ``/marker_projector``, and a one-line summary on stderr.
The detection is :func:`eye_bci_ros2.projection.panel_finder.find_panel`.  Exit status
1 with a one-line reason when there is no panel or the file is not an image.
"""

import argparse
import sys
from typing import List, Optional, Sequence

import numpy as np
from PIL import Image, UnidentifiedImageError
import yaml

from eye_bci_ros2.projection.panel_finder import (DEFAULT_MAX_GAP, DEFAULT_MIN_SIZE,
                                                  DEFAULT_TOLERANCE, find_panel, Panel,
                                                  RVIZ_BACKGROUND, scaled)

#: Exit status for every error (no panel, unreadable file, bad option value).
EXIT_ERROR = 1


def _colour(text: str) -> Sequence[int]:
    try:
        values = [int(part) for part in text.replace(';', ',').split(',')]
    except ValueError:
        values = []
    if len(values) != 3 or not all(0 <= v <= 255 for v in values):
        raise argparse.ArgumentTypeError(
            f"'{text}' is not R,G,B with each 0..255 (RViz's 'Background Color', e.g. 48,48,48)")
    return values


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float('nan')
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"'{text}' is not a positive number")
    return value


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line parser."""
    parser = argparse.ArgumentParser(
        prog='find_panel',
        description="Find RViz2's render panel (its background colour) on a screenshot and "
                    'print screen_offset_x/y and image_width/height as a /marker_projector '
                    'parameter file.',
        epilog='Coordinates are screenshot pixels; if the gaze is in logical pixels of a '
               'scaled (HiDPI) screen, pass --scale (device px per logical px, e.g. 2).')
    parser.add_argument('screenshot', help='PNG (or any image Pillow reads) of the screen')
    parser.add_argument('--output', '-o', metavar='FILE',
                        help='write the parameter file here instead of stdout')
    parser.add_argument('--background', type=_colour, default=RVIZ_BACKGROUND,
                        metavar='R,G,B', help='background colour of the RViz display '
                        '(Global Options > Background Color); default %(default)s')
    parser.add_argument('--tolerance', type=int, default=DEFAULT_TOLERANCE, metavar='N',
                        help='largest difference per channel still background; '
                        'default %(default)s')
    parser.add_argument('--scale', type=_positive, default=1.0, metavar='S',
                        help='screenshot px per gaze px (Qt/desktop scale factor when the '
                        'gaze is in logical px); default %(default)s')
    parser.add_argument('--min-size', type=int, default=DEFAULT_MIN_SIZE, metavar='PX',
                        help='smallest panel side, screenshot px; default %(default)s')
    parser.add_argument('--max-gap', type=int, default=DEFAULT_MAX_GAP, metavar='PX',
                        help='widest band of grid lines or markers joined inside the panel, '
                        'screenshot px; default %(default)s')
    return parser


def load_rgb(path: str) -> np.ndarray:
    """
    Read an image file as (H, W, 3) uint8 RGB.

    :raises ValueError: missing, unreadable or not an image, with the reason.
    """
    try:
        with Image.open(path) as image:
            return np.asarray(image.convert('RGB'))
    except FileNotFoundError:
        raise ValueError(f'{path}: no such file')
    except UnidentifiedImageError:
        raise ValueError(f'{path}: not an image Pillow can read')
    except OSError as error:
        raise ValueError(f'{path}: cannot read it: {error.strerror or error}')


def parameter_yaml(panel: Panel, header: str = '') -> str:
    """
    Text of a /marker_projector parameter file for ``panel``.

    The offsets are doubles (fractional after ``--scale``), the size integers
    (rounded), as marker_projector declares them.
    """
    parameters = {'/marker_projector': {'ros__parameters': {
        'screen_offset_x': float(panel.x), 'screen_offset_y': float(panel.y),
        'image_width': int(round(panel.width)), 'image_height': int(round(panel.height)),
    }}}
    return header + yaml.safe_dump(parameters, default_flow_style=False, sort_keys=False)


def run(args: argparse.Namespace, out=None, err=None) -> int:
    """Find the panel and write the parameters (``out``, default stdout); return 0."""
    out, err = out or sys.stdout, err or sys.stderr
    image = load_rgb(args.screenshot)
    found = find_panel(image, args.background, args.tolerance, args.min_size, args.max_gap)
    panel = scaled(found, args.scale)
    height, width = image.shape[:2]
    scale_text = f', divided by --scale {args.scale:g}' if args.scale != 1.0 else ''
    summary = (f'render panel {found.width:g}x{found.height:g} px at ({found.x:g}, '
               f'{found.y:g}) on the {width}x{height} screenshot ({100 * found.fill:.0f} % '
               f'background){scale_text}')
    header = (f'# RViz2 render panel found by: find_panel {args.screenshot}'
              f'{f" --scale {args.scale:g}" if args.scale != 1.0 else ""}\n'
              f'# {summary}\n'
              '# Load after config/eye_bci.yaml: --ros-args --params-file config/eye_bci.yaml '
              '--params-file THIS_FILE\n')
    if found.note:
        print(f'find_panel: warning: {found.note}', file=err)
        header += f'# warning: {found.note}\n'
    text = parameter_yaml(panel, header)
    if args.output:
        try:
            with open(args.output, 'w', encoding='utf-8') as stream:
                stream.write(text)
        except OSError as error:
            raise ValueError(f'cannot write {args.output}: {error.strerror or error}')
        print(f'{summary}; wrote {args.output}', file=err)
    else:
        print(summary, file=err)
        out.write(text)
    return 0


def main(argv: Optional[List[str]] = None) -> int:
    """Run ``find_panel``; return the exit status."""
    args = build_parser().parse_args(argv)
    try:
        return run(args)
    except ValueError as error:   # NoPanelError included
        print(f'find_panel: error: {error}', file=sys.stderr)
        return EXIT_ERROR


if __name__ == '__main__':
    sys.exit(main())
