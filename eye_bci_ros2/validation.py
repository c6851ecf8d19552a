"""
Calibration validation and drift correction: accuracy and precision in degrees, a fitted fix.

Pure numpy (+ yaml for the parameter file).  Frame: ``screen`` px (x right, y
down, origin top-left); angles in degrees of visual angle for the person's
screen and viewing distance (:class:`eye_bci_ros2.visual_angle.ScreenGeometry`,
default :data:`eye_bci_ros2.visual_angle.DEFAULT_VIEWING`).

Procedure (what an executable or a menu step runs through the real nodes):

1. show the targets of :func:`target_layout` (5 or 9) one after the other;
2. collect the gaze of each, from ``settle_s`` after its onset to its end
   (:func:`samples_per_target`: the eye needs a saccade latency and a
   landing, ~0.3-0.5 s);
3. :func:`measure`: per target and overall accuracy (the angle between the
   target and the mean gaze point: the systematic error, as Tobii and Pupil
   define it) and precision (RMS of the angles between successive samples),
   in degrees and px;
4. :func:`fit_correction`: a screen-px map ``corrected = A @ [x, y, 1]`` (A
   2 x 3) taking each target's mean gaze point to the target, by least
   squares: an offset (translation) always possible, an affine map with 6 or
   more targets; refused (:class:`CorrectionRefused`, with the reason) when a
   target got too little gaze or the fit is implausible (scale far from 1,
   shear or rotation, a shift larger than :data:`MAX_SHIFT_DEG`, or a residual
   not smaller than before);
5. :func:`save_correction`: a ROS 2 parameter file setting
   ``/lsl_gaze_bridge``'s ``gaze_correction`` (6 doubles, row-major 2 x 3;
   :data:`IDENTITY` = none); the bridge calls :func:`apply_correction` on
   every sample after its screen scaling;
6. validate again with the correction applied and show the residual.

The executable ``gaze_validation`` (:mod:`eye_bci_ros2.nodes.gaze_validation`)
runs it through the nodes; because the gaze it measures is already corrected
by the bridge, the fit is combined with the bridge's correction
(:func:`compose_corrections`) before it is saved and set, and the outcome
goes out as one JSON line (:class:`ValidationOutcome`).
"""

from dataclasses import dataclass, field, fields
import json
import math
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np
import yaml

from eye_bci_ros2.tolerance import GazeErrorModel
from eye_bci_ros2.visual_angle import DEFAULT_VIEWING, ScreenGeometry

#: The correction that changes nothing: row-major 2 x 3 affine.
IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
#: Name of the bridge's parameter and the node it belongs to.
PARAMETER = 'gaze_correction'
NODE = '/lsl_gaze_bridge'
#: Fewest samples a target needs after its settle time.
MIN_SAMPLES = 10
#: Default time from a target's onset to the first sample used, s.
SETTLE_S = 0.5
#: Plausibility: singular values of the 2 x 2 part within [1/MAX_SCALE, MAX_SCALE] ...
MAX_SCALE = 1.15
#: ... rotation at most this, degrees ...
MAX_ROTATION_DEG = 5.0
#: ... and the shift of the screen centre at most this, degrees of visual angle.
MAX_SHIFT_DEG = 5.0
#: Affine fits need at least this many targets.
AFFINE_MIN_TARGETS = 6

Correction = Union[Sequence[float], np.ndarray]


class CorrectionRefused(ValueError):
    """A correction cannot be trusted; the message says why."""


def target_layout(count: int = 9, width_px: int = 1920, height_px: int = 1080,
                  margin: float = 0.1) -> np.ndarray:
    """
    Return the validation targets on the screen.

    :param count: 5 (centre and four corners) or 9 (3 x 3 grid).
    :param width_px: screen width, px.
    :param height_px: screen height, px.
    :param margin: distance of the outer targets from the screen edges, as a
        fraction of the screen size, in (0, 0.5).
    :returns: shape (count, 2), screen px, the centre first, then row by row.
    """
    if count not in (5, 9):
        raise ValueError(f'a validation layout has 5 or 9 targets, got {count}')
    if not 0.0 < margin < 0.5:
        raise ValueError(f'margin must be in (0, 0.5), got {margin}')
    xs = np.array([margin, 0.5, 1.0 - margin]) * width_px
    ys = np.array([margin, 0.5, 1.0 - margin]) * height_px
    grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    centre = grid[4:5]
    others = np.delete(grid, 4, axis=0)
    if count == 5:
        others = others[[0, 2, 5, 7]]
    return np.concatenate([centre, others])


def samples_per_target(stamps, points, onsets, ends, settle_s: float = SETTLE_S
                       ) -> List[np.ndarray]:
    """
    Split a gaze stream into the samples of each target, after its settle time.

    :param stamps: sample times, s, shape (N,), increasing.
    :param points: gaze, screen px, shape (N, 2); NaN samples (lost) are dropped.
    :param onsets: when each target appeared, s, shape (T,).
    :param ends: when each disappeared, s, shape (T,).
    :param settle_s: samples before ``onset + settle_s`` are not used, s (>= 0).
    :returns: T arrays of shape (M_t, 2), px.
    """
    stamps = np.asarray(stamps, dtype=float)
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    onsets, ends = np.asarray(onsets, dtype=float), np.asarray(ends, dtype=float)
    if len(stamps) != len(points) or onsets.shape != ends.shape:
        raise ValueError('need one stamp per point and one end per onset')
    if not settle_s >= 0:
        raise ValueError(f'settle_s must be >= 0 s, got {settle_s}')
    valid = np.all(np.isfinite(points), axis=1)
    stamps, points = stamps[valid], points[valid]
    lo = np.searchsorted(stamps, onsets + settle_s, side='left')
    hi = np.searchsorted(stamps, ends, side='left')
    return [points[a:max(a, b)] for a, b in zip(lo, hi)]


@dataclass
class TargetResult:
    """Accuracy and precision at one target (module doc); NaN without samples."""

    target_px: Tuple[float, float]
    samples: int
    mean_px: Tuple[float, float]
    accuracy_deg: float
    accuracy_px: float
    precision_deg: float
    precision_px: float


@dataclass
class ValidationReport:
    """
    A validation: per target and overall (mean over the targets with gaze).

    :ivar missing: indices of targets with fewer than ``min_samples`` samples.
    """

    targets: List[TargetResult]
    accuracy_deg: float
    accuracy_px: float
    precision_deg: float
    precision_px: float
    missing: List[int] = field(default_factory=list)

    def lines(self) -> List[str]:
        """Human lines: one per target, then the overall figures."""
        out = []
        for index, t in enumerate(self.targets):
            where = f'({t.target_px[0]:.0f}, {t.target_px[1]:.0f}) px'
            if index in self.missing:
                out.append(f'target {index + 1} {where}: {t.samples} samples (too few)')
                continue
            out.append(f'target {index + 1} {where}: accuracy {t.accuracy_deg:.2f} deg '
                       f'({t.accuracy_px:.1f} px), precision {t.precision_deg:.2f} deg RMS '
                       f'({t.precision_px:.1f} px), {t.samples} samples')
        out.append(f'overall: accuracy {self.accuracy_deg:.2f} deg ({self.accuracy_px:.1f} px), '
                   f'precision {self.precision_deg:.2f} deg RMS ({self.precision_px:.1f} px)')
        return out


def error_model(report: ValidationReport, k_sigma: float = 2.0) -> GazeErrorModel:
    """
    Return the tolerant decision rule's gaze-error model measured by a validation.

    Accuracy = the overall accuracy; precision (standard deviation per axis)
    = the RMS sample-to-sample angle / 2 (the difference of two independent
    samples has sqrt(2) sigma per axis, so 2 sigma over both axes).

    :raises ValueError: the report has no overall figures (no target had gaze).
    """
    if not (math.isfinite(report.accuracy_deg) and math.isfinite(report.precision_deg)):
        raise ValueError('the validation measured nothing: no target had gaze')
    return GazeErrorModel(accuracy_deg=report.accuracy_deg,
                          precision_deg=report.precision_deg / 2.0, k_sigma=k_sigma)


def _targets(targets) -> np.ndarray:
    """Return targets as float (T, 2)."""
    array = np.asarray(targets, dtype=float)
    if array.ndim != 2 or array.shape[1] != 2 or not np.all(np.isfinite(array)):
        raise ValueError(f'targets must be finite screen points of shape (T, 2), got '
                         f'{array.shape}')
    return array


def measure(targets, samples: Sequence[np.ndarray], screen: ScreenGeometry = DEFAULT_VIEWING,
            min_samples: int = MIN_SAMPLES) -> ValidationReport:
    """
    Accuracy and precision per target and overall (module doc).

    :param targets: shape (T, 2), screen px.
    :param samples: T arrays (M_t, 2) px (:func:`samples_per_target`).
    :param screen: the person's screen and viewing distance.
    :param min_samples: a target with fewer samples is reported missing.
    """
    targets = _targets(targets)
    if len(samples) != len(targets):
        raise ValueError(f'{len(samples)} sample sets for {len(targets)} targets')
    results, missing = [], []
    for index, (target, points) in enumerate(zip(targets, samples)):
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        if len(points) < max(min_samples, 2):
            missing.append(index)
            nan = math.nan
            results.append(TargetResult(tuple(target), len(points), (nan, nan), nan, nan, nan,
                                        nan))
            continue
        mean = points.mean(axis=0)
        steps_px = np.hypot(*np.diff(points, axis=0).T)
        steps_deg = screen.angle_between_deg(points[1:], points[:-1])
        results.append(TargetResult(
            tuple(target), len(points), (float(mean[0]), float(mean[1])),
            float(screen.angle_between_deg(mean, target)), float(np.hypot(*(mean - target))),
            float(np.sqrt(np.mean(steps_deg ** 2))), float(np.sqrt(np.mean(steps_px ** 2)))))
    good = [r for i, r in enumerate(results) if i not in missing]

    def overall(name):
        return float(np.mean([getattr(r, name) for r in good])) if good else math.nan

    return ValidationReport(results, overall('accuracy_deg'), overall('accuracy_px'),
                            overall('precision_deg'), overall('precision_px'), missing)


def as_matrix(correction: Correction) -> np.ndarray:
    """
    Return a correction as a (2, 3) array (from 6 row-major doubles or a (2, 3) array).

    :raises ValueError: not 6 finite numbers.
    """
    matrix = np.asarray(correction, dtype=float)
    if matrix.size != 6 or not np.all(np.isfinite(matrix)):
        raise ValueError(f'{PARAMETER} must be 6 finite numbers (row-major 2x3 affine, '
                         f'{list(IDENTITY)} = none), got {np.ravel(matrix).tolist()}')
    return matrix.reshape(2, 3)


def apply_correction(xy, correction: Correction) -> np.ndarray:
    """
    Apply a correction to gaze points: ``corrected = A[:, :2] @ p + A[:, 2]``.

    :param xy: screen px, shape (N, 2) (or (2,)); a row with a NaN comes out all NaN.
    :param correction: 6 doubles, row-major 2 x 3, or a (2, 3) array.
    :returns: corrected screen px, same shape as ``xy``.
    """
    matrix = as_matrix(correction)
    xy = np.asarray(xy, dtype=float)
    return xy @ matrix[:, :2].T + matrix[:, 2]


def is_identity(correction: Correction) -> bool:
    """Tell whether a correction changes nothing (exactly :data:`IDENTITY`)."""
    return bool(np.array_equal(as_matrix(correction), np.reshape(IDENTITY, (2, 3))))


def compose_corrections(outer: Correction, inner: Correction) -> np.ndarray:
    """
    Return the correction that applies ``inner`` first, then ``outer``.

    A validation measures gaze the bridge has already corrected with
    ``inner``; the fit to it (``outer``) replaces the bridge's parameter by
    this composition, so the new correction acts on the tracker's points.

    :returns: (2, 3) affine.
    """
    a, b = as_matrix(outer), as_matrix(inner)
    return np.hstack([a[:, :2] @ b[:, :2], (a[:, :2] @ b[:, 2] + a[:, 2])[:, None]])


def implausibility(correction: Correction, screen: ScreenGeometry = DEFAULT_VIEWING) -> str:
    """
    Say why a correction is implausible for a calibrated tracker ('' when it is plausible).

    Checks: the 2 x 2 part's singular values within ``[1/MAX_SCALE,
    MAX_SCALE]``, its rotation at most :data:`MAX_ROTATION_DEG`, the shift it
    gives the screen centre at most :data:`MAX_SHIFT_DEG`.  The bridge can use
    it to refuse a ``gaze_correction`` parameter.
    """
    matrix = as_matrix(correction)
    linear = matrix[:, :2]
    singular = np.linalg.svd(linear, compute_uv=False)
    if np.linalg.det(linear) <= 0:
        return 'the correction mirrors or flattens the screen'
    if singular.max() > MAX_SCALE or singular.min() < 1.0 / MAX_SCALE:
        return (f'the correction scales the gaze by {singular.min():.2f}..{singular.max():.2f} '
                f'(more than x{MAX_SCALE} from 1): recalibrate the tracker instead')
    rotation = math.degrees(math.atan2(linear[1, 0] - linear[0, 1],
                                       linear[0, 0] + linear[1, 1]))
    if abs(rotation) > MAX_ROTATION_DEG:
        return f'the correction rotates the gaze by {rotation:.1f} deg: recalibrate instead'
    centre = screen.centre_px
    moved = apply_correction(centre, matrix)
    shift = float(screen.angle_between_deg(moved, centre))
    if shift > MAX_SHIFT_DEG:
        return (f'the correction moves the gaze by {shift:.1f} deg at the screen centre (more '
                f'than {MAX_SHIFT_DEG:g}): recalibrate the tracker instead')
    return ''


@dataclass
class CorrectionFit:
    """
    A fitted correction.

    :ivar matrix: (2, 3) affine.
    :ivar kind: 'offset' or 'affine'.
    :ivar residual_before_deg: mean angle between the targets and their mean gaze point.
    :ivar residual_after_deg: the same after the correction (on the fitted data).
    """

    matrix: np.ndarray
    kind: str
    residual_before_deg: float
    residual_after_deg: float

    @property
    def values(self) -> List[float]:
        """Return the 6 doubles of the ``gaze_correction`` parameter (row-major)."""
        return [float(v) for v in self.matrix.ravel()]


def fit_correction(targets, samples: Sequence[np.ndarray], kind: str = 'auto',
                   screen: ScreenGeometry = DEFAULT_VIEWING,
                   min_samples: int = MIN_SAMPLES) -> CorrectionFit:
    """
    Fit the correction taking each target's mean gaze point to the target (least squares).

    :param targets: shape (T, 2), screen px.
    :param samples: T arrays (M_t, 2) px.
    :param kind: 'offset', 'affine' (needs >= 6 targets) or 'auto' (affine
        with >= 6 targets, else offset).
    :param screen: for the residuals in degrees.
    :raises CorrectionRefused: a target with fewer than ``min_samples``
        samples, too few targets for the kind, an implausible fit
        (:func:`implausibility`) or no improvement.
    """
    targets = _targets(targets)
    report = measure(targets, samples, screen, min_samples)
    if report.missing:
        which = ', '.join(str(i + 1) for i in report.missing)
        raise CorrectionRefused(f'no correction: target(s) {which} got fewer than '
                                f'{min_samples} gaze samples after the settle time (was the '
                                'person looking, is the tracker streaming?)')
    if kind == 'auto':
        kind = 'affine' if len(targets) >= AFFINE_MIN_TARGETS else 'offset'
    if kind not in ('offset', 'affine'):
        raise ValueError(f"kind must be 'offset', 'affine' or 'auto', got {kind!r}")
    measured = np.array([t.mean_px for t in report.targets])
    if kind == 'offset':
        matrix = np.hstack([np.eye(2), (targets - measured).mean(axis=0)[:, None]])
    else:
        if len(targets) < AFFINE_MIN_TARGETS:
            raise CorrectionRefused(f'no affine correction from {len(targets)} targets: it '
                                    f'needs at least {AFFINE_MIN_TARGETS} (use 9, or an offset)')
        design = np.hstack([measured, np.ones((len(measured), 1))])
        solution, *_ = np.linalg.lstsq(design, targets, rcond=None)
        matrix = solution.T
    reason = implausibility(matrix, screen)
    if reason:
        raise CorrectionRefused(f'no correction: {reason}')
    before = float(np.mean(screen.angle_between_deg(measured, targets)))
    after = float(np.mean(screen.angle_between_deg(apply_correction(measured, matrix),
                                                   targets)))
    if not after < before:
        raise CorrectionRefused(f'no correction: it would not reduce the error ({before:.2f} '
                                f'deg before, {after:.2f} deg after)')
    return CorrectionFit(matrix, kind, before, after)


def correction_yaml(correction: Correction, node: str = NODE) -> str:
    """Return a ROS 2 parameter file (YAML text) setting ``gaze_correction`` of ``node``."""
    values = [float(v) for v in as_matrix(correction).ravel()]
    return yaml.safe_dump({node: {'ros__parameters': {PARAMETER: values}}},
                          default_flow_style=None, sort_keys=False)


def save_correction(path: str, correction: Correction, node: str = NODE) -> str:
    """Write :func:`correction_yaml` to ``path``; returns ``path``."""
    with open(path, 'w', encoding='utf-8') as stream:
        stream.write(correction_yaml(correction, node))
    return path


def load_correction(path: str, node: str = NODE) -> np.ndarray:
    """
    Read ``gaze_correction`` of ``node`` from a ROS 2 parameter file.

    :returns: (2, 3) array (identity when the file does not set it).
    :raises ValueError: the file is not a parameter file or the value is malformed.
    """
    with open(path, encoding='utf-8') as stream:
        data = yaml.safe_load(stream)
    try:
        parameters = (data.get(node) or data.get(node.lstrip('/')) or {})['ros__parameters']
    except (AttributeError, KeyError, TypeError):
        raise ValueError(f'{path}: not a ROS 2 parameter file for {node} '
                         "(expected '<node>: ros__parameters: ...')") from None
    return as_matrix(parameters.get(PARAMETER, IDENTITY))


def validate_and_correct(targets, samples: Sequence[np.ndarray],
                         screen: ScreenGeometry = DEFAULT_VIEWING, kind: str = 'auto',
                         min_samples: int = MIN_SAMPLES
                         ) -> Tuple[ValidationReport, Optional[CorrectionFit], str]:
    """
    Measure, then fit a correction if one can be trusted.

    :returns: ``(report, fit or None, reason)``: ``reason`` says why there is
        no fit ('' with one).
    """
    report = measure(targets, samples, screen, min_samples)
    try:
        return report, fit_correction(targets, samples, kind, screen, min_samples), ''
    except CorrectionRefused as refused:
        return report, None, str(refused)


@dataclass
class ValidationOutcome:
    """
    What a validation run ended with: the ``validation/result`` message (one JSON line).

    :ivar accepted: a correction was fitted, saved and applied.
    :ivar reason: why not ('' when accepted), one line.
    :ivar kind: 'offset' or 'affine' ('' when refused).
    :ivar targets: number of targets shown.
    :ivar accuracy_deg: overall accuracy before the correction, degrees (NaN: no gaze).
    :ivar precision_deg: overall precision (RMS sample to sample) before, degrees.
    :ivar residual_deg: overall accuracy of the validation after the correction, degrees
        (NaN when refused).
    :ivar residual_px: the same in px.
    :ivar correction: the bridge's ``gaze_correction`` now (6 doubles).
    :ivar output: the parameter file written ('' when none).
    """

    accepted: bool
    reason: str = ''
    kind: str = ''
    targets: int = 0
    accuracy_deg: float = math.nan
    precision_deg: float = math.nan
    residual_deg: float = math.nan
    residual_px: float = math.nan
    correction: List[float] = field(default_factory=lambda: list(IDENTITY))
    output: str = ''

    def summary(self) -> str:
        """One human line."""
        before = (f'accuracy {self.accuracy_deg:.2f} deg, precision {self.precision_deg:.2f} '
                  f'deg RMS over {self.targets} targets')
        if not self.accepted:
            return f'validation refused ({before}): {self.reason}'
        saved = f', saved to {self.output}' if self.output else ''
        residual = (f'; residual accuracy {self.residual_deg:.2f} deg ({self.residual_px:.1f} '
                    'px)' if math.isfinite(self.residual_deg) else '')
        return f'validation accepted: {before}; {self.kind} correction applied{saved}{residual}'

    def to_json(self) -> str:
        """Return the outcome as one JSON line (NaN as null), with its ``summary``."""
        data = {key: (None if isinstance(value, float) and not math.isfinite(value) else value)
                for key, value in self.__dict__.items()}
        data['summary'] = self.summary()
        return json.dumps(data)

    @classmethod
    def from_json(cls, text: str) -> 'ValidationOutcome':
        """
        Read :meth:`to_json`'s line.

        :raises ValueError: not such a line.
        """
        texts = ('reason', 'kind', 'output')
        numbers = ('accuracy_deg', 'precision_deg', 'residual_deg', 'residual_px')
        try:
            data = json.loads(text)
            if not isinstance(data, dict) or not isinstance(data.get('accepted'), bool):
                raise ValueError('no accepted: true/false')
            names = {f.name for f in fields(cls)}
            values = {k: (math.nan if v is None and k in numbers else v)
                      for k, v in data.items() if k in names}
            outcome = cls(**values)
            if not (all(isinstance(getattr(outcome, k), str) for k in texts)
                    and all(isinstance(getattr(outcome, k), (int, float)) for k in numbers)
                    and isinstance(outcome.targets, int)
                    and len(as_matrix(outcome.correction).ravel()) == 6):
                raise ValueError('a field of the wrong type')
        except (TypeError, ValueError) as error:
            raise ValueError(f'not a validation result: {text[:80]!r} ({error})') from None
        outcome.correction = [float(v) for v in outcome.correction]
        return outcome
