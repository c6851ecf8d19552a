"""
Recorded gaze of people looking at known targets: loaders into one form (pure).

A :class:`GazeRecording` is what every consumer (the real-gaze benchmark, the
replay outlet, the simulated person's check against real data) reads: sample
stamps and screen points (the ``screen`` frame of docs/DESIGN.md: px, origin
top-left, x right, y down; NaN where the tracker lost the eyes), the screen
the person looked at (:class:`~eye_bci_ros2.projection.visual_angle.ScreenGeometry`) and
the target schedule (:class:`TargetSchedule`).

Formats read (``load_gaze`` picks by the file name, :func:`find_recordings`
lists a folder):

* ``human_samples_*.txt[.gz]`` with ``human_msgs_*.txt[.gz]`` beside it
  (Niehorster et al. 2020/2021, Tobii X2-60 "lookAtPoint"): tab-separated,
  ``Time`` in us, ``L POR X [px]`` ... ``R POR Y [px]`` in screen px; the
  messages give each target's onset (us, same clock) and place (px).  The
  dot jumps: a target is shown still from its onset.
* ``etdq_*.tsv[.gz]`` (ETDQualitizer 9-point validations): ``timestamp`` in
  ms, ``left_x`` ... (one or both eyes) in px relative to the screen centre;
  ``target_id`` >= 0 while a target is shown still, -1 while the dot glides
  there or shrinks.  A target's onset is the start of the glide towards it.
* ``*.gaze.csv`` with ``*.targets.csv`` beside it (a lab's own recordings):
  ``time_s,x_px,y_px`` (screen px, top-left origin; empty or NaN = lost) and
  ``onset_s,x_px,y_px[,still_s]`` (``still_s``: when the target stops moving,
  default its onset).  The screen comes from ``# screen_px: 1920x1080``,
  ``# screen_mm: 531.3x298.9`` and ``# distance_mm: 650`` comment lines at the
  top of the gaze file (defaults: :data:`~eye_bci_ros2.projection.visual_angle.DEFAULT_VIEWING`).
* ``*.xdf`` from LabRecorder: its gaze stream, in the layout of the tracker
  application that sent it (:mod:`eye_bci_ros2.recordings.xdf`; no targets).

Both eyes: the mean of the eyes that are valid at a sample (a binocular
tracker's combined gaze); one eye where the other is lost.
"""

import gzip
import io
from pathlib import Path
import re
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING, ScreenGeometry
from eye_bci_ros2.recordings.gaze_recording import (GazeRecording, PathLike, RecordingError,
                                                    TargetSchedule)
from eye_bci_ros2.recordings.xdf import load_xdf_gaze

#: The X2-60 "lookAtPoint" set-up (its README): 1920 x 1080 px, 510 x 288 mm, 565 mm.
X260_SCREEN = ScreenGeometry(width_px=1920, height_px=1080, width_mm=510.0, height_mm=288.0,
                             distance_mm=565.0)

#: The ETDQualitizer set-up (its README): 1920 x 1080 px, 528 x 297 mm, 650 mm.
ETDQ_SCREEN = ScreenGeometry(width_px=1920, height_px=1080, width_mm=528.0, height_mm=297.0,
                             distance_mm=650.0)


def _open_text(path: Path) -> io.TextIOBase:
    """Open a text file, gzip-compressed when its name ends in .gz."""
    if path.suffix == '.gz':
        return io.TextIOWrapper(gzip.open(path, 'rb'), encoding='utf-8', errors='replace')
    return open(path, encoding='utf-8', errors='replace')


def _stem(path: Path) -> str:
    """Return the file name without .gz and its format's extension."""
    name = path.name
    for ending in ('.gz', '.txt', '.tsv', '.csv', '.gaze', '.targets'):
        if name.endswith(ending):
            name = name[:-len(ending)]
    return name


def _table(path: Path, delimiter: Optional[str] = '\t') -> Tuple[List[str], np.ndarray]:
    """Read a delimited table with a header into (column names, float array (N, C))."""
    try:
        with _open_text(path) as handle:
            lines = [line for line in handle if line.strip() and not line.startswith('#')]
    except (OSError, EOFError) as error:
        raise RecordingError(f'{path}: cannot read it ({error})') from None
    if len(lines) < 2:
        raise RecordingError(f'{path}: no samples (a header and at least one row are needed)')
    header = [name.strip() for name in lines[0].rstrip('\r\n').split(delimiter)]
    try:
        values = np.genfromtxt(lines[1:], delimiter=delimiter, dtype=float,
                               missing_values=('', 'NaN', 'nan'), filling_values=np.nan)
    except ValueError as error:
        raise RecordingError(f'{path}: malformed rows ({error})') from None
    values = np.atleast_2d(values)
    if values.shape[1] != len(header):
        raise RecordingError(f'{path}: {values.shape[1]} columns but {len(header)} names in '
                             'its header')
    return header, values


def _column(header: Sequence[str], values: np.ndarray, name: str, path: Path) -> np.ndarray:
    """One named column of a table, or a one-line error naming what is there."""
    if name not in header:
        raise RecordingError(f"{path}: no column '{name}' (it has: {', '.join(header)})")
    return values[:, list(header).index(name)]


def combine_eyes(*eyes: np.ndarray) -> np.ndarray:
    """
    Combine per-eye gaze into one point per sample.

    :param eyes: one or more (N, 2) arrays, NaN where that eye was lost.
    :returns: (N, 2): the mean of the eyes valid at each sample, NaN when none is.
    """
    stack = np.stack([np.asarray(eye, dtype=float) for eye in eyes])      # (E, N, 2)
    valid = np.isfinite(stack).all(axis=2)                                # (E, N)
    count = valid.sum(axis=0)
    total = np.where(valid[..., None], stack, 0.0).sum(axis=0)
    with np.errstate(invalid='ignore', divide='ignore'):
        combined = total / count[:, None]
    combined[count == 0] = np.nan
    return combined


def _ordered(stamps: np.ndarray, points: np.ndarray, path: Path) -> Tuple[np.ndarray,
                                                                          np.ndarray]:
    """Drop rows without a stamp and sort by stamp (stable)."""
    keep = np.isfinite(stamps)
    stamps, points = stamps[keep], points[keep]
    if not len(stamps):
        raise RecordingError(f'{path}: no sample has a time stamp')
    order = np.argsort(stamps, kind='stable')
    return stamps[order], points[order]


def load_x260(samples_path: PathLike, messages_path: Optional[PathLike] = None,
              screen: ScreenGeometry = X260_SCREEN) -> GazeRecording:
    """
    Load a Tobii X2-60 "lookAtPoint" recording (module doc).

    :param samples_path: the ``human_samples_*`` file.
    :param messages_path: its ``human_msgs_*`` file; default: the same name
        with ``samples`` replaced by ``msgs``.
    :param screen: the screen of the recording.
    :raises RecordingError: a missing or malformed file.
    """
    samples_path = Path(samples_path)
    if messages_path is None:
        messages_path = samples_path.with_name(
            samples_path.name.replace('human_samples_', 'human_msgs_', 1))
    messages_path = Path(messages_path)
    header, values = _table(samples_path)
    stamps_us = _column(header, values, 'Time', samples_path)
    left = np.stack([_column(header, values, f'L POR {axis} [px]', samples_path)
                     for axis in 'XY'], axis=1)
    right = np.stack([_column(header, values, f'R POR {axis} [px]', samples_path)
                      for axis in 'XY'], axis=1)
    stamps, points = _ordered(stamps_us * 1e-6, combine_eyes(left, right), samples_path)
    try:
        with _open_text(messages_path) as handle:
            rows = [line.split() for line in handle if line.strip()]
        messages = np.array([[float(cell) for cell in row[:4]] for row in rows])
    except (OSError, EOFError, ValueError, IndexError) as error:
        raise RecordingError(f'{messages_path}: cannot read the target messages '
                             f'({error})') from None
    if messages.ndim != 2 or messages.shape[1] != 4 or not len(messages):
        raise RecordingError(f'{messages_path}: expected rows of onset (us), index, x, y')
    onsets = messages[:, 0] * 1e-6
    targets = _schedule(onsets, onsets, messages[:, 2:4], stamps)
    return _recording(_stem(samples_path).replace('human_samples_', ''), stamps, points,
                      screen, targets, 'Tobii X2-60', samples_path)


def load_etdq(path: PathLike, screen: ScreenGeometry = ETDQ_SCREEN) -> GazeRecording:
    """
    Load an ETDQualitizer 9-point validation recording (module doc).

    :param path: the ``etdq_*.tsv[.gz]`` file.
    :param screen: the screen of the recording.
    :raises RecordingError: a missing or malformed file.
    """
    path = Path(path)
    header, values = _table(path)
    stamps = _column(header, values, 'timestamp', path) * 1e-3
    eyes = [np.stack([values[:, header.index(f'{eye}_x')], values[:, header.index(f'{eye}_y')]],
                     axis=1)
            for eye in ('left', 'right') if f'{eye}_x' in header and f'{eye}_y' in header]
    if not eyes:
        raise RecordingError(f"{path}: no 'left_x'/'left_y' or 'right_x'/'right_y' columns")
    centre = screen.centre_px
    target_id = _column(header, values, 'target_id', path)
    place = np.stack([_column(header, values, 'tar_x', path),
                      _column(header, values, 'tar_y', path)], axis=1) + centre
    stamps, order_points = _ordered(stamps, np.concatenate(
        [combine_eyes(*eyes) + centre, target_id[:, None], place], axis=1), path)
    points, target_id, place = order_points[:, :2], order_points[:, 2], order_points[:, 3:]
    # Runs of one target id >= 0 are a target shown still; its onset is the end of the
    # previous still run (the dot starts gliding towards it), the first: the first sample.
    shown = target_id >= 0
    change = np.flatnonzero(np.diff(np.concatenate([[-1.0], np.where(shown, target_id, -1.0)])))
    starts = [i for i in change if shown[i]]
    if not starts:
        raise RecordingError(f'{path}: no target is shown still (every target_id is -1)')
    still = stamps[starts]
    run_ends = []
    for first in starts:
        last = first
        while last + 1 < len(stamps) and target_id[last + 1] == target_id[first]:
            last += 1
        run_ends.append(stamps[last])
    onsets = np.concatenate([[stamps[0]], np.asarray(run_ends[:-1])])
    targets = _schedule(onsets, still, place[starts], stamps)
    tracker = _stem(path).replace('etdq_', '').replace('_', ' ')
    return _recording(_stem(path), stamps, points, screen, targets, tracker, path)


def _screen_from_comments(path: Path) -> ScreenGeometry:
    """Return the screen of a CSV recording from its leading comment lines (module doc)."""
    found: Dict[str, str] = {}
    with _open_text(path) as handle:
        for line in handle:
            if not line.startswith('#'):
                break
            match = re.match(r'#\s*(screen_px|screen_mm|distance_mm)\s*:\s*(\S+)', line)
            if match:
                found[match.group(1)] = match.group(2)
    try:
        width_px, height_px = (DEFAULT_VIEWING.width_px, DEFAULT_VIEWING.height_px)
        if 'screen_px' in found:
            width_px, height_px = (int(v) for v in found['screen_px'].lower().split('x'))
        width_mm, height_mm = (DEFAULT_VIEWING.width_mm, DEFAULT_VIEWING.height_mm)
        if 'screen_mm' in found:
            width_mm, height_mm = (float(v) for v in found['screen_mm'].lower().split('x'))
        distance = float(found.get('distance_mm', DEFAULT_VIEWING.distance_mm))
        return ScreenGeometry(width_px, height_px, width_mm, height_mm, distance)
    except ValueError as error:
        raise RecordingError(f'{path}: malformed screen comment ({error}); write e.g. '
                             "'# screen_px: 1920x1080', '# screen_mm: 531.3x298.9', "
                             "'# distance_mm: 650'") from None


def load_csv(gaze_path: PathLike, targets_path: Optional[PathLike] = None,
             screen: Optional[ScreenGeometry] = None) -> GazeRecording:
    """
    Load a lab's own recording in the simple CSV form (module doc).

    :param gaze_path: the ``*.gaze.csv`` file.
    :param targets_path: its ``*.targets.csv``; default: beside it, same stem.
    :param screen: the screen; default: from the gaze file's comment lines.
    :raises RecordingError: a missing or malformed file.
    """
    gaze_path = Path(gaze_path)
    if targets_path is None:
        targets_path = gaze_path.with_name(_stem(gaze_path) + '.targets.csv')
    targets_path = Path(targets_path)
    header, values = _table(gaze_path, delimiter=',')
    stamps = _column(header, values, 'time_s', gaze_path)
    points = np.stack([_column(header, values, 'x_px', gaze_path),
                       _column(header, values, 'y_px', gaze_path)], axis=1)
    stamps, points = _ordered(stamps, points, gaze_path)
    t_header, t_values = _table(targets_path, delimiter=',')
    onsets = _column(t_header, t_values, 'onset_s', targets_path)
    places = np.stack([_column(t_header, t_values, 'x_px', targets_path),
                       _column(t_header, t_values, 'y_px', targets_path)], axis=1)
    still = t_values[:, t_header.index('still_s')] if 'still_s' in t_header else onsets
    screen = _screen_from_comments(gaze_path) if screen is None else screen
    targets = _schedule(onsets, still, places, stamps)
    return _recording(_stem(gaze_path), stamps, points, screen, targets, 'csv', gaze_path)


def _schedule(onsets, still, places, stamps: np.ndarray) -> TargetSchedule:
    """Build a TargetSchedule (sorted by onset) whose last target ends at the last sample."""
    onsets = np.asarray(onsets, dtype=float)
    order = np.argsort(onsets, kind='stable')
    onsets = onsets[order]
    still = np.maximum(np.asarray(still, dtype=float)[order], onsets)
    places = np.asarray(places, dtype=float).reshape(-1, 2)[order]
    ends = np.concatenate([onsets[1:], [max(float(stamps[-1]), float(onsets[-1]))]])
    return TargetSchedule(onsets, still, ends, places)


def _recording(name: str, stamps: np.ndarray, points: np.ndarray, screen: ScreenGeometry,
               targets: TargetSchedule, tracker: str, path: Path) -> GazeRecording:
    """Shift every time so the first sample is at 0 s and check the result."""
    if not np.isfinite(targets.places).all() or not np.isfinite(targets.onsets).all():
        raise RecordingError(f'{path}: a target without a finite onset or place')
    origin = float(stamps[0])
    shifted = TargetSchedule(targets.onsets - origin, targets.still - origin,
                             targets.ends - origin, targets.places)
    return GazeRecording(name, stamps - origin, points, screen, shifted, tracker)


#: File name patterns of the formats, and their loaders (module doc).
_FORMATS = (
    (re.compile(r'^human_samples_.*\.txt(\.gz)?$'), load_x260),
    (re.compile(r'^etdq_.*\.tsv(\.gz)?$'), load_etdq),
    (re.compile(r'^.*\.gaze\.csv(\.gz)?$'), load_csv),
    (re.compile(r'^.*\.xdfz?$'), load_xdf_gaze),
)


def load_gaze(path: PathLike) -> GazeRecording:
    """
    Load a recording of any known format, chosen by its file name (module doc).

    :raises RecordingError: an unknown name, or a missing or malformed file.
    """
    path = Path(path)
    for pattern, loader in _FORMATS:
        if pattern.match(path.name):
            return loader(path)
    raise RecordingError(f'{path}: not a known gaze recording (human_samples_*.txt[.gz], '
                         'etdq_*.tsv[.gz], *.gaze.csv or *.xdf)')


def find_recordings(folder: PathLike) -> List[Path]:
    """
    List the gaze recordings of known formats in a folder, sorted by name.

    :raises RecordingError: the folder does not exist.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise RecordingError(f'{folder}: no such folder')
    return sorted(path for path in folder.iterdir()
                  if any(pattern.match(path.name) for pattern, _ in _FORMATS))
