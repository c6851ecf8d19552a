"""
Find RViz2's render panel on a screenshot: its offset (X0, Y0) and size (W, H).

RViz2 clears its render panel to the display's background colour, (48, 48, 48)
by default (``Global Options: Background Color`` in an ``.rviz`` file); the
widgets around it (docks, tool bar, hide-dock buttons, the window frame) are
other colours.  The panel is found as the axis-aligned rectangle whose rows
and columns hold background pixels:

1. ``mask``: pixels within ``tolerance`` of the background colour on every
   channel (PNG screenshots are exact; the tolerance absorbs a colour-managed
   capture).
2. Alternately, the column profile (share of background pixels in each
   column, over the current row span) and the row profile (over the current
   column span) are cut where they fall below :data:`MIN_SHARE`; runs closer
   than ``max_gap`` px are joined (grid lines and thin markers drawn over the
   background, including lines along an edge in a top-down view) and the run
   holding the most background is kept (a title bar of the same colour, a
   second small patch).  Two rounds usually settle; at most
   :data:`MAX_ROUNDS` run.
3. The rectangle is accepted when it is at least ``min_size`` px on each side
   and at least :data:`MIN_FILL` of it is background (markers may cover the
   rest).

Markers drawn across a panel edge, or a dock of exactly the background colour
next to the panel, move that edge, and a marker across the whole panel splits
it (the larger part is reported, with a note naming the other part): take the
screenshot with the scene empty or its markers inside the view.

Everything is in screenshot pixels: (x right, y down, origin top-left of the
image); for a screen captured at another scale than the gaze coordinates,
divide by the scale (:func:`scaled`).
"""

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

#: RViz2's default background colour, RGB 0..255.
RVIZ_BACKGROUND = (48, 48, 48)
#: Default largest difference per channel still counted as background.
DEFAULT_TOLERANCE = 2
#: A row or column belongs to the panel when at least this share of it is background.
MIN_SHARE = 0.05
#: The panel must be at least this share background (markers cover the rest).
MIN_FILL = 0.3
#: Default smallest panel side, px.
DEFAULT_MIN_SIZE = 64
#: Default widest run of non-background rows/columns joined inside the panel, px.
DEFAULT_MAX_GAP = 12
#: Most profile rounds.
MAX_ROUNDS = 8


@dataclass(frozen=True)
class Panel:
    """
    A render panel found on a screenshot.

    :ivar x: screen x of the panel's left edge (X0, ``screen_offset_x``), px.
    :ivar y: screen y of the panel's top edge (Y0, ``screen_offset_y``), px.
    :ivar width: panel width W (``image_width``), px.
    :ivar height: panel height H (``image_height``), px.
    :ivar fill: share of the panel's pixels that are background, 0..1.
    :ivar note: a doubt to show the user ('' = none).
    """

    x: float
    y: float
    width: float
    height: float
    fill: float
    note: str = ''


class NoPanelError(ValueError):
    """No render panel on the screenshot; the message says what was seen."""


def background_mask(image: np.ndarray, colour: Sequence[int] = RVIZ_BACKGROUND,
                    tolerance: int = DEFAULT_TOLERANCE) -> np.ndarray:
    """
    Mark the pixels of the background colour.

    :param image: (H, W, 3) or (H, W, 4) RGB(A), 0..255 (alpha ignored).
    :param colour: background (R, G, B).
    :param tolerance: largest difference per channel, 0..255.
    :returns: (H, W) bool.
    :raises ValueError: not an RGB(A) image, or a bad colour/tolerance.
    """
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] not in (3, 4) or 0 in image.shape[:2]:
        raise ValueError(f'expected an RGB or RGBA image (H, W, 3|4), got shape {image.shape}')
    colour = np.asarray(colour, dtype=float)
    if colour.shape != (3,) or not np.all((colour >= 0) & (colour <= 255)):
        raise ValueError(f'background colour must be 3 values 0..255, got {colour.tolist()}')
    if not 0 <= tolerance <= 255:
        raise ValueError(f'tolerance must be 0..255, got {tolerance}')
    difference = np.abs(image[..., :3].astype(np.int16) - colour.astype(np.int16))
    return np.all(difference <= tolerance, axis=2)


def _runs(inside: np.ndarray, max_gap: int) -> np.ndarray:
    """
    Return the [start, stop) of the runs of True, joining gaps of <= ``max_gap``.

    :param inside: (N,) bool.
    :returns: (R, 2) int.
    """
    padded = np.concatenate(([False], inside, [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    runs = edges.reshape(-1, 2)
    if len(runs) > 1:
        gaps = runs[1:, 0] - runs[:-1, 1]
        keep = np.concatenate(([True], gaps > max_gap))
        starts = runs[keep, 0]
        stops = np.append(runs[np.flatnonzero(keep)[1:] - 1, 1], runs[-1, 1])
        runs = np.stack([starts, stops], axis=1)
    return runs


def _best_run(counts: np.ndarray, length: int, max_gap: int) -> Optional[Tuple[int, int]]:
    """
    Pick the run of rows (or columns) that holds the most background.

    :param counts: (N,) background pixels per row/column, over ``length`` pixels.
    :returns: [start, stop), or None when no row/column qualifies.
    """
    if length <= 0:
        return None
    runs = _runs(counts >= MIN_SHARE * length, max_gap)
    if not len(runs):
        return None
    cumulative = np.concatenate(([0], np.cumsum(counts)))
    mass = cumulative[runs[:, 1]] - cumulative[runs[:, 0]]
    start, stop = runs[int(np.argmax(mass))]
    return int(start), int(stop)


def find_panel(image: np.ndarray, colour: Sequence[int] = RVIZ_BACKGROUND,
               tolerance: int = DEFAULT_TOLERANCE, min_size: int = DEFAULT_MIN_SIZE,
               max_gap: int = DEFAULT_MAX_GAP) -> Panel:
    """
    Find the render panel: the background-coloured rectangle described above.

    :param image: (H, W, 3|4) RGB(A) screenshot, 0..255.
    :param colour: the display's background colour (R, G, B).
    :param tolerance: largest difference per channel still background.
    :param min_size: smallest panel side accepted, px.
    :param max_gap: widest run of covered rows/columns joined inside the panel, px.
    :returns: the panel, in screenshot px.
    :raises NoPanelError: nothing of that colour is large and rectangular enough.
    :raises ValueError: bad arguments.
    """
    mask = background_mask(image, colour, tolerance)
    height, width = mask.shape
    colour_text = '({}, {}, {})'.format(*(int(c) for c in colour))
    if not mask.any():
        raise NoPanelError(f'no pixel of the background colour {colour_text} '
                           f'(tolerance {tolerance}) on the {width}x{height} screenshot')
    rows, cols = (0, height), (0, width)
    for _ in range(MAX_ROUNDS):
        found = _best_run(mask[rows[0]:rows[1], :].sum(axis=0), rows[1] - rows[0], max_gap)
        if found is None:
            break
        new_cols = found
        found = _best_run(mask[:, new_cols[0]:new_cols[1]].sum(axis=1),
                          new_cols[1] - new_cols[0], max_gap)
        if found is None:
            break
        new_rows = found
        if (new_rows, new_cols) == (rows, cols):
            break
        rows, cols = new_rows, new_cols
    panel_w, panel_h = cols[1] - cols[0], rows[1] - rows[0]
    fill = float(mask[rows[0]:rows[1], cols[0]:cols[1]].mean()) if panel_w and panel_h else 0.0
    if (rows, cols) == ((0, height), (0, width)) and fill < MIN_FILL:
        raise NoPanelError(f'no rectangle of the background colour {colour_text} on the '
                           f'{width}x{height} screenshot')
    if panel_w < min_size or panel_h < min_size:
        raise NoPanelError(
            f'the largest area of the background colour {colour_text} is {panel_w}x{panel_h} '
            f'px at ({cols[0]}, {rows[0]}), smaller than {min_size} px: no render panel')
    if fill < MIN_FILL:
        raise NoPanelError(
            f'the {panel_w}x{panel_h} px area at ({cols[0]}, {rows[0]}) is only '
            f'{100 * fill:.0f} % background colour {colour_text}: not a render panel')
    note = _split_note(mask, rows, cols, min_size, max_gap) or \
        _split_note(mask.T, cols, rows, min_size, max_gap, axis='y')
    return Panel(float(cols[0]), float(rows[0]), float(panel_w), float(panel_h), fill, note)


def _split_note(mask: np.ndarray, rows: Tuple[int, int], cols: Tuple[int, int],
                min_size: int, max_gap: int, axis: str = 'x') -> str:
    """
    Name another background area beside the panel with exactly its rows, if any.

    That is what a marker drawn across the whole panel leaves (or a second,
    tiled RViz window): the panel may be larger than reported.  Called with
    the transposed mask (``axis='y'``) it looks above and below instead.
    """
    counts = mask[rows[0]:rows[1], :].sum(axis=0)
    for start, stop in _runs(counts >= MIN_SHARE * (rows[1] - rows[0]), max_gap):
        if stop - start < min_size or (start, stop) == tuple(cols):
            continue
        other = _best_run(mask[:, start:stop].sum(axis=1), stop - start, max_gap)
        if other is not None and abs(other[0] - rows[0]) <= 1 and abs(other[1] - rows[1]) <= 1:
            side = 'height' if axis == 'x' else 'width'
            return (f"another background area of the panel's {side} at {axis} = {start}..{stop}"
                    ': if a marker splits the panel there, take the screenshot with the '
                    'markers inside the view (or none)')
    return ''


def scaled(panel: Panel, scale: float) -> Panel:
    """
    Express a panel in coordinates ``scale`` times smaller than the screenshot's.

    A screenshot of a Qt-scaled (HiDPI) screen is in device pixels; when the
    gaze is in logical pixels (``screen_width`` = the logical width), pass the
    scale factor to get X0, Y0, W, H in those (X0, Y0 may then be fractional).

    :param panel: in screenshot px.
    :param scale: screenshot px per gaze px, > 0.
    :raises ValueError: scale not positive and finite.
    """
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError(f'scale must be a positive number, got {scale}')
    return Panel(panel.x / scale, panel.y / scale, panel.width / scale, panel.height / scale,
                 panel.fill, panel.note)
