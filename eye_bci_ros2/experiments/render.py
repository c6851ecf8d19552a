"""
Pictures of the demo and the accuracy test (matplotlib, Agg back end, no display).

Pure numpy + matplotlib: no rclpy, no pyplot (figures are drawn on the Agg
canvas directly, so nothing needs a display).  Every picture of a selection is the
person's screen itself: a PNG of ``screen_size`` pixels (1920x1080 by default)
in which one image pixel is one screen pixel (frame ``screen``: origin
top-left, x right, y down), so positions can be read off directly.
"""

from dataclasses import dataclass, field
import math
import os
from typing import Dict, List, Optional, Sequence, Tuple

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Polygon, Rectangle
import numpy as np

#: Colours of the drawings (matplotlib colour specs).
PANEL_COLOUR = '#30343c'
SCREEN_COLOUR = '#e8e8e8'
FLOOR_EDGE = '#8a8f99'
IN_REGION_COLOUR = '#10c040'
OUT_REGION_COLOUR = '#ff5050'
CORRECT_COLOUR = '#20e060'
WRONG_COLOUR = '#ff3030'
TARGET_COLOUR = '#ffe000'
MEAN_COLOUR = '#00c8ff'


@dataclass
class ScreenPicture:
    """
    What the screen showed during one selection, and where the gaze fell.

    All coordinates are screen px (x right, y down).

    :ivar title: first line of the caption.
    :ivar details: further caption lines.
    :ivar screen_size: (width, height) of the screen, px; the PNG has this size.
    :ivar panel: RViz render panel (x0, y0, width, height), px.
    :ivar floors: (name, polygon (K, 2)) floor areas for orientation, drawn
        clipped to the panel.
    :ivar regions: label -> polygon (K, 2): the regions the system offered
        at the decision (the choices/regions outlines).
    :ivar colours: label -> (r, g, b, a) in [0, 1], the markers' colours.
    :ivar gaze: gaze samples of the selection, shape (N, 2).
    :ivar gaze_in_region: shape (N,) bool, each sample counted for an option
        by the decision's rule, against the regions shown at its own time.
    :ivar rule: one line naming the decision rule (the legend's heading).
    :ivar mean_point: the decision's mean of the in-region samples, or None.
    :ivar chosen: label the system chose, or None.
    :ivar intended: label the person meant.
    :ivar target_path: where the intended marker's centre was over the
        selection, shape (M, 2) (the last row is the target at the decision).
    :ivar halos: the feedback the person saw at the decision (``choices/feedback``):
        (screen polygon (K, 2), rgba) per halo.
    """

    title: str
    details: Sequence[str] = ()
    screen_size: Tuple[int, int] = (1920, 1080)
    panel: Tuple[float, float, float, float] = (320.0, 180.0, 1280.0, 720.0)
    floors: Sequence[Tuple[str, np.ndarray]] = ()
    regions: Dict[str, np.ndarray] = field(default_factory=dict)
    colours: Dict[str, Tuple[float, float, float, float]] = field(default_factory=dict)
    gaze: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    gaze_in_region: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    mean_point: Optional[Sequence[float]] = None
    chosen: Optional[str] = None
    intended: Optional[str] = None
    target_path: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    rule: str = ''
    halos: Sequence[Tuple[np.ndarray, Tuple[float, float, float, float]]] = ()


def _screen_figure(size: Tuple[int, int], dpi: float = 100.0):
    """Return (figure, axes) where one data unit is one output pixel, y down."""
    width, height = int(size[0]), int(size[1])
    if width <= 0 or height <= 0:
        raise ValueError(f'screen size must be positive, got {width} x {height} px')
    figure = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)
    FigureCanvasAgg(figure)
    axes = figure.add_axes((0.0, 0.0, 1.0, 1.0))
    axes.set_xlim(0, width)
    axes.set_ylim(height, 0)
    axes.set_axis_off()
    return figure, axes


def _outline(polygon) -> Optional[np.ndarray]:
    """Return the finite, de-duplicated vertices of a polygon (K, 2), or None."""
    polygon = np.asarray(polygon, dtype=float).reshape(-1, 2)
    polygon = polygon[np.all(np.isfinite(polygon), axis=1)]
    if len(polygon) > 1:
        keep = np.ones(len(polygon), dtype=bool)
        keep[1:] = np.any(np.diff(polygon, axis=0) != 0, axis=1)
        polygon = polygon[keep]
    return polygon if len(polygon) >= 3 else None


def render_screen(picture: ScreenPicture, path: str) -> str:
    """
    Draw one selection as the person's screen and save it as a PNG.

    :param picture: what to draw.
    :param path: output file (directories are created).
    :returns: ``path``.
    """
    figure, axes = _screen_figure(picture.screen_size)
    width, height = picture.screen_size
    axes.add_patch(Rectangle((0, 0), width, height, facecolor=SCREEN_COLOUR, zorder=0))
    x0, y0, panel_w, panel_h = picture.panel
    panel = Rectangle((x0, y0), panel_w, panel_h, facecolor=PANEL_COLOUR,
                      edgecolor='black', linewidth=2, zorder=1)
    axes.add_patch(panel)
    axes.text(x0 + 8, y0 + panel_h - 10, f'RViz render panel {panel_w:.0f}x{panel_h:.0f} px '
              f'at ({x0:.0f}, {y0:.0f})', color='#c0c4cc', fontsize=11, zorder=2)

    for name, polygon in picture.floors:
        outline = _outline(polygon)
        if outline is None:
            continue
        floor = Polygon(outline, closed=True, facecolor='#3c414b', edgecolor=FLOOR_EDGE,
                        linewidth=1, zorder=2)
        axes.add_patch(floor)
        floor.set_clip_path(panel)
        # Name the floor at its corner nearest the top-left that is on the panel.
        on_panel = ((outline[:, 0] >= x0) & (outline[:, 0] <= x0 + panel_w - 60)
                    & (outline[:, 1] >= y0) & (outline[:, 1] <= y0 + panel_h - 30))
        if np.any(on_panel):
            corner = outline[on_panel][np.argmin(outline[on_panel].sum(axis=1))]
            axes.text(corner[0] + 12, corner[1] + 8, name, color='#9aa0aa', fontsize=12,
                      ha='left', va='top', style='italic', zorder=2)

    for label, polygon in picture.regions.items():
        outline = _outline(polygon)
        if outline is None:
            continue
        colour = picture.colours.get(label, (0.6, 0.6, 0.6, 0.8))
        axes.add_patch(Polygon(outline, closed=True, facecolor=colour[:3], alpha=0.55,
                               edgecolor='none', zorder=3))
        chosen = label == picture.chosen
        edge = 'white'
        if chosen:
            edge = CORRECT_COLOUR if picture.chosen == picture.intended else WRONG_COLOUR
        axes.add_patch(Polygon(outline, closed=True, fill=False, edgecolor=edge,
                               linewidth=5 if chosen else 1.5, zorder=4))
        top = outline[np.argmin(outline[:, 1])]
        caption = label + ('  [chosen]' if chosen else '')
        axes.text(outline[:, 0].mean(), top[1] - 8, caption, color='white', fontsize=12,
                  ha='center', va='bottom', weight='bold' if chosen else 'normal', zorder=6,
                  bbox={'facecolor': 'black', 'alpha': 0.5, 'edgecolor': 'none', 'pad': 2})

    for index, (polygon, colour) in enumerate(picture.halos):
        outline = _outline(polygon)
        if outline is None:
            continue
        axes.add_patch(Polygon(outline, closed=True, fill=False, edgecolor=colour[:3],
                               linewidth=4, linestyle=':', zorder=4,
                               label='feedback halo (choices/feedback): yellow = gazed, '
                                     'green = chosen, size = progress' if index == 0 else None))

    gaze = np.asarray(picture.gaze, dtype=float).reshape(-1, 2)
    inside = np.asarray(picture.gaze_in_region, dtype=bool).reshape(-1)
    if len(inside) != len(gaze):
        raise ValueError(f'{len(gaze)} gaze samples but {len(inside)} in-region flags')
    if len(gaze):
        axes.scatter(gaze[~inside, 0], gaze[~inside, 1], s=14, c=OUT_REGION_COLOUR,
                     edgecolors='none', alpha=0.8, zorder=5,
                     label=f'gaze counted for no option ({int(np.sum(~inside))})')
        axes.scatter(gaze[inside, 0], gaze[inside, 1], s=14, c=IN_REGION_COLOUR,
                     edgecolors='none', alpha=0.8, zorder=5,
                     label=f'gaze counted for an option, regions at its time '
                           f'({int(np.sum(inside))})')

    path_xy = np.asarray(picture.target_path, dtype=float).reshape(-1, 2)
    if len(path_xy):
        if np.ptp(path_xy, axis=0).max() > 3.0:
            axes.plot(path_xy[:, 0], path_xy[:, 1], color=TARGET_COLOUR, linewidth=1.5,
                      linestyle='--', zorder=6, label='intended target since the options appeared')
        axes.scatter(path_xy[-1:, 0], path_xy[-1:, 1], s=420, marker='*', c=TARGET_COLOUR,
                     edgecolors='black', linewidths=1, zorder=7,
                     label=f'intended target: {picture.intended}')
    if picture.mean_point is not None:
        axes.scatter([picture.mean_point[0]], [picture.mean_point[1]], s=260, marker='X',
                     c=MEAN_COLOUR, edgecolors='black', linewidths=1, zorder=8,
                     label='mean of the in-region gaze (decision)')

    lines = [picture.title] + list(picture.details)
    axes.text(20, 20, '\n'.join(lines), fontsize=15, va='top', ha='left', family='monospace',
              zorder=9)
    if axes.get_legend_handles_labels()[0]:
        legend = axes.legend(loc='lower left', bbox_to_anchor=(20 / width, 12 / height),
                             fontsize=12, framealpha=0.9, title=picture.rule or None)
        if picture.rule:
            legend.get_title().set_fontsize(12)
    return _save(figure, path)


@dataclass
class DrivePicture:
    """
    A drive of the robot, seen from above (map frame, m; x right, y up).

    :ivar title: first line of the caption.
    :ivar details: further caption lines.
    :ivar occupancy: the map's cells (H, W), 0 free, 100 occupied, -1 unknown, row 0 at
        ``origin``'s y (nav_msgs/OccupancyGrid order), or None.
    :ivar origin: the map's lower-left corner (x, y), m.
    :ivar resolution: the map's cell size, m.
    :ivar tables: (label, (x, y)) of the tables, for orientation.
    :ivar path: the robot's positions in the map frame (the navigation's feedback), (N, 2), m.
    :ivar plan: the planned path (M, 2), m.
    :ivar goal: the goal x, y (m), yaw (rad), or None.
    :ivar robot: the robot's last pose x, y, yaw, or None.
    :ivar radius: the robot's radius, m.
    """

    title: str
    details: Sequence[str] = ()
    occupancy: Optional[np.ndarray] = None
    origin: Tuple[float, float] = (0.0, 0.0)
    resolution: float = 0.05
    tables: Sequence[Tuple[str, Tuple[float, float]]] = ()
    path: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    plan: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    goal: Optional[np.ndarray] = None
    robot: Optional[np.ndarray] = None
    radius: float = 0.3


def render_drive(picture: DrivePicture, path: str, size: Tuple[int, int] = (1400, 960)) -> str:
    """Draw a drive from above: the map, the plan, the path driven, the goal and the robot."""
    figure = Figure(figsize=(size[0] / 100.0, size[1] / 100.0), dpi=100.0)
    FigureCanvasAgg(figure)
    axes = figure.add_axes((0.05, 0.06, 0.9, 0.8))
    if picture.occupancy is not None:
        rows, columns = picture.occupancy.shape
        shade = np.where(picture.occupancy >= 50, 0.25,
                         np.where(picture.occupancy < 0, 0.6, 0.95))
        x0, y0 = picture.origin
        axes.imshow(shade, cmap='gray', vmin=0.0, vmax=1.0, origin='lower',
                    extent=(x0, x0 + columns * picture.resolution, y0,
                            y0 + rows * picture.resolution))
    for label, (x, y) in picture.tables:
        axes.annotate(label.split('/')[-1], (x, y), ha='center', va='center', fontsize=9,
                      color='#a05000')
    if len(picture.plan):
        axes.plot(picture.plan[:, 0], picture.plan[:, 1], '--', color='#4060ff', lw=1.5,
                  label='plan')
    if len(picture.path):
        axes.plot(picture.path[:, 0], picture.path[:, 1], '-', color=CORRECT_COLOUR, lw=3,
                  label='driven (feedback)')
        axes.plot(*picture.path[0], 'o', color='#606060', ms=8, label='start')
    for pose, colour, name in ((picture.goal, TARGET_COLOUR, 'goal'),
                               (picture.robot, MEAN_COLOUR, 'robot')):
        if pose is None:
            continue
        x, y, yaw = (float(v) for v in pose)
        if name == 'robot':
            axes.add_patch(_circle((x, y), picture.radius, colour))
        axes.arrow(x, y, 0.6 * math.cos(yaw), 0.6 * math.sin(yaw), width=0.06,
                   color=colour if name == 'goal' else '#004060', label=name,
                   length_includes_head=True)
    axes.set_aspect('equal')
    axes.set_xlabel('x, m (map frame)')
    axes.set_ylabel('y, m')
    axes.legend(loc='upper right', fontsize=10, framealpha=0.9)
    figure.text(0.05, 0.95, picture.title, fontsize=14, weight='bold')
    for row, line in enumerate(picture.details):
        figure.text(0.05, 0.92 - 0.025 * row, line, fontsize=11)
    return _save(figure, path)


@dataclass
class TimelinePicture:
    """
    A session over time: one lane per kind of event (times s from the session's start).

    :ivar title: the caption.
    :ivar spans: lane -> [(start, end, colour, label)]: questions, drives.
    :ivar ticks: lane -> [(time, colour, label)]: choices, rounds without one, answers.
    :ivar rate: (times (T,), samples per s (T,)) of the gaze, or None.
    """

    title: str
    spans: Dict[str, List[Tuple[float, float, str, str]]] = field(default_factory=dict)
    ticks: Dict[str, List[Tuple[float, str, str]]] = field(default_factory=dict)
    rate: Optional[Tuple[np.ndarray, np.ndarray]] = None


def render_timeline(picture: TimelinePicture, path: str, width_px: int = 1800) -> str:
    """Draw a session's timeline: lanes of spans and ticks, and the gaze rate beneath."""
    lanes = list(picture.spans) + [lane for lane in picture.ticks if lane not in picture.spans]
    figure = Figure(figsize=(width_px / 100.0, 1.6 + 0.7 * len(lanes)), dpi=100.0)
    FigureCanvasAgg(figure)
    axes = figure.add_axes((0.1, 0.3 if picture.rate is not None else 0.15, 0.87, 0.55))
    for row, lane in enumerate(lanes):
        y = len(lanes) - 1 - row
        for start, end, colour, label in picture.spans.get(lane, ()):
            axes.add_patch(Rectangle((start, y - 0.35), max(end - start, 1e-3), 0.7,
                                     facecolor=colour, edgecolor='black', linewidth=0.5))
            if label:
                axes.text(start, y + 0.38, label, fontsize=7, va='bottom', ha='left',
                          rotation=30)
        for time_s, colour, label in picture.ticks.get(lane, ()):
            axes.plot([time_s, time_s], [y - 0.4, y + 0.4], color=colour, linewidth=2)
            if label:
                axes.text(time_s, y - 0.45, label, fontsize=7, va='top', ha='center',
                          rotation=30)
    axes.set_yticks(range(len(lanes)))
    axes.set_yticklabels(list(reversed(lanes)))
    axes.set_ylim(-1, max(len(lanes), 1))
    axes.autoscale(axis='x')
    axes.grid(True, axis='x', alpha=0.3)
    figure.text(0.1, 0.93, picture.title, fontsize=13, weight='bold')
    if picture.rate is not None:
        below = figure.add_axes((0.1, 0.07, 0.87, 0.15), sharex=axes)
        below.plot(picture.rate[0], picture.rate[1], color='#4060ff', linewidth=1)
        below.set_ylabel('gaze\nsamples/s', fontsize=8)
        below.set_xlabel('time since the session started, s')
    else:
        axes.set_xlabel('time since the session started, s')
    return _save(figure, path)


def _circle(centre, radius: float, colour) -> Circle:
    return Circle(centre, radius, color=colour, alpha=0.8)


def _save(figure: Figure, path: str) -> str:
    """Write the figure as a PNG, creating the directory."""
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
    figure.savefig(path, dpi=figure.dpi, format='png')
    return path


def wilson_interval(correct, trials, z: float = 1.96) -> Tuple[np.ndarray, np.ndarray]:
    """
    Wilson score interval of a proportion (95 % by default).

    :param correct: successes, scalar or shape (S,).
    :param trials: trials, same shape, > 0.
    :returns: (low, high), each the shape of ``correct``.
    """
    k = np.asarray(correct, dtype=float)
    n = np.asarray(trials, dtype=float)
    if np.any(n <= 0):
        raise ValueError('every proportion needs at least one trial')
    p = k / n
    denominator = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    return np.clip(centre - half, 0, 1), np.clip(centre + half, 0, 1)


def plot_accuracy_curve(path: str, sizes, curves: Dict[str, Tuple[np.ndarray, np.ndarray]],
                        thresholds: Optional[Dict[str, float]] = None, title: str = '',
                        note: str = '', reference_px: Optional[float] = 16.0) -> str:
    """
    Plot accuracy against on-screen marker size, one line per method.

    :param path: output PNG.
    :param sizes: marker sizes, px, shape (S,).
    :param curves: method -> (correct (S,), trials (S,)); drawn with a 95 %
        Wilson interval band.
    :param thresholds: method -> smallest size found by the binary search, px
        (vertical lines).
    :param title: plot title.
    :param note: small text under the title (the set-up).
    :param reference_px: the original report's finding (about 16 px), drawn
        as a grey line; None to omit.
    :returns: ``path``.
    """
    sizes = np.asarray(sizes, dtype=float)
    figure = Figure(figsize=(10, 6), dpi=110)
    FigureCanvasAgg(figure)
    axes = figure.add_subplot(1, 1, 1)
    # Rules often agree exactly: distinct line styles keep every curve visible.
    styles = {'mean': ('#1f77b4', '-', 'o', 2.5), 'vote': ('#d62728', '--', 's', 1.5),
              'early': ('#2ca02c', ':', '^', 1.5)}
    for index, (method, (correct, trials)) in enumerate(curves.items()):
        correct = np.asarray(correct, dtype=float)
        trials = np.asarray(trials, dtype=float)
        colour, line, marker, width = styles.get(method, (f'C{index + 3}', '-', 'd', 1.5))
        low, high = wilson_interval(correct, trials)
        axes.fill_between(sizes, 100 * low, 100 * high, color=colour, alpha=0.12, linewidth=0)
        axes.plot(sizes, 100 * correct / trials, marker=marker, markersize=4, color=colour,
                  linestyle=line, linewidth=width, label=f'{method} (95 % interval shaded)')
        if thresholds and method in thresholds and math.isfinite(thresholds[method]):
            axes.axvline(thresholds[method], color=colour, linestyle='--', linewidth=1.2,
                         label=f'{method}: binary search threshold {thresholds[method]:g} px')
    if reference_px is not None:
        axes.axvline(reference_px, color='grey', linestyle=':', linewidth=1.5,
                     label=f'original report: about {reference_px:g} px')
    axes.set_xscale('log')
    ticks = [t for t in (4, 8, 16, 32, 64, 128, 256, 512, 1024)
             if sizes.min() <= t <= sizes.max()]
    axes.set_xticks(ticks)
    axes.set_xticklabels([str(t) for t in ticks])
    axes.set_xlabel('marker size on the screen, px (side of a square of equal area)')
    axes.set_ylabel('choices identified correctly, %')
    axes.set_ylim(-2, 102)
    axes.grid(True, which='both', alpha=0.3)
    axes.legend(loc='lower right', fontsize=9)
    axes.set_title(title or 'Accuracy against marker size (room scenario)', fontsize=12)
    if note:
        figure.text(0.5, 0.005, note, ha='center', va='bottom', fontsize=8, color='#404040')
    figure.subplots_adjust(bottom=0.16)
    return _save(figure, path)


def png_size(path: str) -> Tuple[int, int]:
    """Read (width, height) px from a PNG header, raising ValueError if not a PNG."""
    with open(path, 'rb') as stream:
        header = stream.read(24)
    if len(header) < 24 or header[:8] != b'\x89PNG\r\n\x1a\n' or header[12:16] != b'IHDR':
        raise ValueError(f'{path} is not a PNG file')
    return int.from_bytes(header[16:20], 'big'), int.from_bytes(header[20:24], 'big')


def summarise_counts(counts: Dict[str, int]) -> List[str]:
    """Format per-label sample counts, largest first, as 'label n'."""
    return [f'{label} {n}' for label, n in sorted(counts.items(), key=lambda kv: -kv[1])]


def json_default(value):
    """Make numpy values JSON-serialisable (``json.dump(..., default=json_default)``)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f'cannot serialise {type(value).__name__}')
