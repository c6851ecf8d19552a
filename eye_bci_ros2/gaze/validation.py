"""
Calibration validation and drift correction: accuracy and precision in degrees, a fitted fix.

Pure numpy (+ yaml for the parameter file).  Frame: ``screen`` px (x right, y
down, origin top-left); angles in degrees of visual angle for the person's
screen and viewing distance (:class:`eye_bci_ros2.projection.visual_angle.ScreenGeometry`,
default :data:`eye_bci_ros2.projection.visual_angle.DEFAULT_VIEWING`).

Procedure (what an executable or a menu step runs through the real nodes):

1. show the targets of :func:`target_layout` (5 or 9) one after the other;
2. collect the gaze of each, from ``settle_s`` after its onset to its end
   (:func:`samples_per_target`: the eye needs a saccade latency and a
   landing, ~0.3-0.5 s);
3. :func:`measure`: per target and overall accuracy (the angle between the
   target and the mean gaze point: the systematic error, as Tobii and Pupil
   define it) and precision (RMS of the angles between successive samples),
   in degrees and px;
4. :func:`fit_correction`: a screen-px map taking each target's mean gaze
   point to the target, by least squares, of one of :data:`KINDS`: an offset
   (translation, always possible), an affine map (6 or more targets) or a
   second-order map (9 targets in a grid: the error of real trackers varies
   over the screen in ways an affine map cannot follow).  With ``kind='auto'``
   the data choose: each kind's error at each target when that target is
   left out of the fit (leave-one-target-out, what a fit does where it was
   not fitted), and the simplest kind within one standard error of the best
   (the "one-standard-error rule" of cross-validation: a more flexible fit
   must earn its extra terms on held-out targets).  A kind whose held-out
   fits are not determined (targets not spread in a grid) is not a
   candidate.  Refused (:class:`CorrectionRefused`, with the reason) when a
   target got too little gaze, when the fit is implausible anywhere on the
   screen (:func:`implausibility`: local scale far from 1, fold, rotation, a
   shift larger than :data:`MAX_SHIFT_DEG`; with ``'auto'`` a more flexible
   kind that fails falls back to a simpler one, saying why in
   :attr:`CorrectionFit.note`), or when it would not reduce the error, on
   the fitted targets or on held-out ones;
5. :func:`save_correction`: a ROS 2 parameter file setting
   ``/lsl_gaze_bridge``'s ``gaze_correction`` (:func:`as_matrix`: 6 doubles,
   the affine map row-major 2 x 3; or 12: those 6, then the second-order
   terms row-major 2 x 3; :data:`IDENTITY` = none); the bridge calls
   :func:`apply_correction` on every sample after its screen scaling;
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
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import yaml

from eye_bci_ros2.decision.tolerance import GazeErrorModel
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING, ScreenGeometry

#: The correction that changes nothing: row-major 2 x 3 affine.
IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
#: Name of the bridge's parameter and the node it belongs to.
PARAMETER = 'gaze_correction'
NODE = '/lsl_gaze_bridge'
#: Fewest samples a target needs after its settle time.
MIN_SAMPLES = 10
#: Default time from a target's onset to the first sample used, s.
SETTLE_S = 0.5
#: Plausibility, everywhere on the screen: singular values of the map's local linear part
#: within [1/MAX_SCALE, MAX_SCALE] ...
MAX_SCALE = 1.15
#: ... rotation at most this, degrees ...
MAX_ROTATION_DEG = 5.0
#: ... and the shift of any point of the screen at most this, degrees of visual angle.
MAX_SHIFT_DEG = 5.0
#: Kinds of correction, simplest first (the order ``'auto'`` prefers on a tie).
KINDS = ('offset', 'affine', 'quadratic')
#: Fewest targets each kind needs (a second-order map has 6 terms per axis, and its
#: held-out fits need 8 targets that still determine them: a 3 x 3 grid).
MIN_TARGETS = {'offset': 1, 'affine': 6, 'quadratic': 9}
#: Affine fits need at least this many targets.
AFFINE_MIN_TARGETS = MIN_TARGETS['affine']
#: The correction acts on these monomials of a screen point (x, y in px): the first three
#: columns of :func:`as_matrix` are the affine map, the last three the second-order terms.
MONOMIALS = ('x', 'y', '1', 'x^2', 'x*y', 'y^2')
#: Points per side of the grid over the screen where a map's plausibility is checked.
CHECK_GRID = 9

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
    Return a correction as a (2, 6) array on :data:`MONOMIALS`.

    ``corrected = M @ [x, y, 1, x^2, x*y, y^2]``.  Accepted: the parameter's
    6 doubles (row-major 2 x 3 affine; second-order terms 0), its 12 doubles
    (those 6, then the second-order terms row-major 2 x 3), or a (2, 3) or
    (2, 6) array.

    :raises ValueError: not 6 or 12 finite numbers.
    """
    matrix = np.asarray(correction, dtype=float)
    if matrix.size not in (6, 12) or not np.all(np.isfinite(matrix)):
        raise ValueError(f'{PARAMETER} must be 6 finite numbers (row-major 2x3 affine, '
                         f'{list(IDENTITY)} = none) or 12 (those, then the x^2, x*y, y^2 '
                         f'terms row-major 2x3), got {np.ravel(matrix).tolist()}')
    if matrix.shape == (2, 6):
        return matrix.copy()
    if matrix.shape == (2, 3) or matrix.size == 6:
        return np.hstack([matrix.reshape(2, 3), np.zeros((2, 3))])
    flat = matrix.ravel()
    return np.hstack([flat[:6].reshape(2, 3), flat[6:].reshape(2, 3)])


def correction_values(correction: Correction) -> List[float]:
    """
    Return the ``gaze_correction`` parameter of a correction (:func:`as_matrix`'s inverse).

    :returns: 6 doubles when it has no second-order terms, else 12.
    """
    matrix = as_matrix(correction)
    values = matrix[:, :3].ravel().tolist()
    if np.any(matrix[:, 3:]):
        values += matrix[:, 3:].ravel().tolist()
    return [float(v) for v in values]


def _monomials(xy: np.ndarray) -> np.ndarray:
    """Return :data:`MONOMIALS` of points (N, 2) as (N, 6)."""
    x, y = xy[..., 0], xy[..., 1]
    return np.stack([x, y, np.ones_like(x), x * x, x * y, y * y], axis=-1)


def _lift(affine: np.ndarray) -> np.ndarray:
    """
    Return L (6, 6) with ``monomials(affine(p)) = L @ monomials(p)`` for an affine (2, 3).

    Lets a second-order map be composed exactly with an affine one, and a fit
    made in centred, scaled coordinates be expressed on screen px.
    """
    rows = [affine[0], affine[1], np.array([0.0, 0.0, 1.0])]
    lift = np.zeros((6, 6))
    lift[:3, :3] = rows
    for out, (a, b) in zip(range(3, 6), ((0, 0), (0, 1), (1, 1))):
        u, v = rows[a], rows[b]       # linear forms in (x, y, 1); their product:
        lift[out] = [u[0] * v[2] + u[2] * v[0], u[1] * v[2] + u[2] * v[1], u[2] * v[2],
                     u[0] * v[0], u[0] * v[1] + u[1] * v[0], u[1] * v[1]]
    return lift


def apply_correction(xy, correction: Correction) -> np.ndarray:
    """
    Apply a correction to gaze points: ``corrected = M @ [x, y, 1, x^2, x*y, y^2]``.

    :param xy: screen px, shape (N, 2) (or (2,)); a row with a NaN comes out all NaN.
    :param correction: the parameter's 6 or 12 doubles, or an array (:func:`as_matrix`).
    :returns: corrected screen px, same shape as ``xy``.
    """
    matrix = as_matrix(correction)
    xy = np.asarray(xy, dtype=float)
    out = xy @ matrix[:, :2].T + matrix[:, 2]
    if np.any(matrix[:, 3:]):
        out = out + _monomials(xy)[..., 3:] @ matrix[:, 3:].T
    return out


def is_identity(correction: Correction) -> bool:
    """Tell whether a correction changes nothing (exactly :data:`IDENTITY`)."""
    return bool(np.array_equal(as_matrix(correction), as_matrix(IDENTITY)))


def _screen_grid(screen: ScreenGeometry, count: int = CHECK_GRID) -> np.ndarray:
    """Return ``count`` x ``count`` points over the whole screen, corners included, (N, 2) px."""
    xs = np.linspace(0.0, screen.width_px, count)
    ys = np.linspace(0.0, screen.height_px, count)
    return np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)


def _fit_map(measured: np.ndarray, targets: np.ndarray, kind: str) -> np.ndarray:
    """
    Least-squares map of ``kind`` taking ``measured`` (T, 2) px to ``targets``; (2, 6).

    Affine and second-order maps are fitted in coordinates centred on the
    measured points and scaled to about 1 (well conditioned), then expressed
    on screen px with :func:`_lift`.
    """
    if kind == 'offset':
        return as_matrix(np.hstack([np.eye(2), (targets - measured).mean(axis=0)[:, None]]))
    centre = measured.mean(axis=0)
    scale = max(float(np.abs(measured - centre).max()), 1.0)
    normalise = np.hstack([np.eye(2) / scale, -centre[:, None] / scale])
    terms = 3 if kind == 'affine' else 6
    design = _monomials((measured - centre) / scale)[:, :terms]
    solution, *_ = np.linalg.lstsq(design, targets, rcond=None)
    matrix = np.zeros((2, 6))
    matrix[:, :terms] = solution.T
    return matrix @ _lift(normalise)


def _determined(measured: np.ndarray, kind: str) -> bool:
    """Tell whether ``measured`` points (T, 2) determine a fit of ``kind``, and without each."""
    if len(measured) < MIN_TARGETS[kind]:
        return False
    if kind == 'offset':
        return True
    terms = 3 if kind == 'affine' else 6
    centre = measured.mean(axis=0)
    design = _monomials((measured - centre) / max(float(np.abs(measured - centre).max()),
                                                  1.0))[:, :terms]
    keep = ~np.eye(len(measured), dtype=bool)
    return all(np.linalg.matrix_rank(design[row]) == terms for row in keep)


def held_out_errors(measured, targets, kind: str,
                    screen: ScreenGeometry = DEFAULT_VIEWING) -> np.ndarray:
    """
    Return each target's error when the fit of ``kind`` is made without it (leave-one-out).

    :param measured: the targets' mean gaze points, (T, 2) px.
    :param targets: (T, 2) px.
    :returns: (T,) degrees: the angle between target t and the point the fit
        to the other targets makes of its gaze.
    """
    measured, targets = _targets(measured), _targets(targets)
    errors = np.empty(len(targets))
    for index in range(len(targets)):
        others = np.arange(len(targets)) != index
        matrix = _fit_map(measured[others], targets[others], kind)
        errors[index] = screen.angle_between_deg(
            apply_correction(measured[index], matrix), targets[index])
    return errors


def compose_corrections(outer: Correction, inner: Correction,
                        screen: ScreenGeometry = DEFAULT_VIEWING) -> np.ndarray:
    """
    Return the correction that applies ``inner`` first, then ``outer``.

    A validation measures gaze the bridge has already corrected with
    ``inner``; the fit to it (``outer``) replaces the bridge's parameter by
    this composition, so the new correction acts on the tracker's points.
    Exact when either is affine; two second-order maps compose to a
    fourth-order one, which is replaced by its least-squares second-order
    map over a grid on ``screen`` (both are small corrections, so the
    dropped terms are smaller still).

    :returns: (2, 6) (:func:`as_matrix`).
    """
    a, b = as_matrix(outer), as_matrix(inner)
    if not np.any(b[:, 3:]):
        return a @ _lift(b[:, :3])
    if not np.any(a[:, 3:]):
        total = a[:, :2] @ b
        total[:, 2] += a[:, 2]
        return total
    grid = _screen_grid(screen)
    return _fit_map(grid, apply_correction(apply_correction(grid, b), a), 'quadratic')


def _jacobians(matrix: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Return the map's Jacobians at points (N, 2): (N, 2, 2)."""
    x, y = xy[:, 0], xy[:, 1]
    zero = np.zeros_like(x)
    # d[x^2, x*y, y^2]/dx and /dy, (N, 3) each.
    d_dx = np.stack([2 * x, y, zero], axis=1)
    d_dy = np.stack([zero, x, 2 * y], axis=1)
    quadratic = matrix[:, 3:]
    return np.stack([matrix[:, 0] + d_dx @ quadratic.T,
                     matrix[:, 1] + d_dy @ quadratic.T], axis=2)


def implausibility(correction: Correction, screen: ScreenGeometry = DEFAULT_VIEWING) -> str:
    """
    Say why a correction is implausible for a calibrated tracker ('' when it is plausible).

    Checked on a :data:`CHECK_GRID` x :data:`CHECK_GRID` grid over the whole
    screen, corners included (a second-order map is judged where it
    extrapolates, not only at the targets): the local linear part (the
    Jacobian) keeps orientation, its singular values lie within
    ``[1/MAX_SCALE, MAX_SCALE]`` and its rotation is at most
    :data:`MAX_ROTATION_DEG`; no point moves more than
    :data:`MAX_SHIFT_DEG`.  The bridge uses it to refuse a
    ``gaze_correction`` parameter.
    """
    matrix = as_matrix(correction)
    grid = np.concatenate([[screen.centre_px], _screen_grid(screen)])
    jacobians = _jacobians(matrix, grid)
    if np.any(np.linalg.det(jacobians) <= 0):
        return 'the correction mirrors or flattens the screen'
    singular = np.linalg.svd(jacobians, compute_uv=False)
    if singular.max() > MAX_SCALE or singular.min() < 1.0 / MAX_SCALE:
        return (f'the correction scales the gaze by {singular.min():.2f}..{singular.max():.2f} '
                f'(more than x{MAX_SCALE} from 1): recalibrate the tracker instead')
    rotation = np.degrees(np.arctan2(jacobians[:, 1, 0] - jacobians[:, 0, 1],
                                     jacobians[:, 0, 0] + jacobians[:, 1, 1]))
    worst = int(np.argmax(np.abs(rotation)))
    if abs(rotation[worst]) > MAX_ROTATION_DEG:
        return (f'the correction rotates the gaze by {rotation[worst]:.1f} deg: recalibrate '
                'instead')
    shifts = screen.angle_between_deg(apply_correction(grid, matrix), grid)
    worst = int(np.argmax(shifts))
    if shifts[worst] > MAX_SHIFT_DEG:
        where = ('the screen centre' if worst == 0 else
                 f'({grid[worst][0]:.0f}, {grid[worst][1]:.0f}) px')
        return (f'the correction moves the gaze by {shifts[worst]:.1f} deg at {where} (more '
                f'than {MAX_SHIFT_DEG:g}): recalibrate the tracker instead')
    return ''


@dataclass
class CorrectionFit:
    """
    A fitted correction.

    :ivar matrix: (2, 6) (:func:`as_matrix`).
    :ivar kind: one of :data:`KINDS`.
    :ivar residual_before_deg: mean angle between the targets and their mean gaze point.
    :ivar residual_after_deg: the same after the correction (on the fitted data).
    :ivar held_out_deg: mean error at each target of the fit made without it
        (leave-one-target-out), degrees: what to expect away from the targets;
        NaN when the kind was asked for and not chosen by the data.
    :ivar candidates: each kind considered -> its ``held_out_deg``.
    :ivar note: why a kind the data preferred was not used ('' when none), one line.
    """

    matrix: np.ndarray
    kind: str
    residual_before_deg: float
    residual_after_deg: float
    held_out_deg: float = math.nan
    candidates: Dict[str, float] = field(default_factory=dict)
    note: str = ''

    @property
    def values(self) -> List[float]:
        """Return the ``gaze_correction`` parameter: :func:`correction_values`."""
        return correction_values(self.matrix)


def choose_kind(held_out: Dict[str, np.ndarray]) -> str:
    """
    Return the kind held-out errors support: the simplest within one standard error of the best.

    :param held_out: kind -> per-target held-out errors (T,), degrees (:func:`held_out_errors`).
    """
    means = {kind: float(np.mean(errors)) for kind, errors in held_out.items()}
    best = min(means, key=means.get)
    errors = held_out[best]
    margin = float(np.std(errors, ddof=1) / math.sqrt(len(errors))) if len(errors) > 1 else 0.0
    return next(kind for kind in KINDS if kind in means and means[kind] <= means[best] + margin)


def fit_correction(targets, samples: Sequence[np.ndarray], kind: str = 'auto',
                   screen: ScreenGeometry = DEFAULT_VIEWING,
                   min_samples: int = MIN_SAMPLES) -> CorrectionFit:
    """
    Fit the correction taking each target's mean gaze point to the target (module doc, 4).

    :param targets: shape (T, 2), screen px.
    :param samples: T arrays (M_t, 2) px.
    :param kind: one of :data:`KINDS` (affine needs >= 6 targets, quadratic 9
        in a grid) or 'auto': the kind the held-out errors choose
        (:func:`choose_kind`) among those the targets allow; an implausible
        choice falls back to the next simpler kind, with a :attr:`CorrectionFit.note`.
    :param screen: for the residuals in degrees and the plausibility checks.
    :raises CorrectionRefused: a target with fewer than ``min_samples``
        samples, too few targets for the kind, an implausible fit
        (:func:`implausibility`) or no improvement (on the fitted targets,
        or, with 'auto', on held-out ones).
    """
    targets = _targets(targets)
    report = measure(targets, samples, screen, min_samples)
    if report.missing:
        which = ', '.join(str(i + 1) for i in report.missing)
        raise CorrectionRefused(f'no correction: target(s) {which} got fewer than '
                                f'{min_samples} gaze samples after the settle time (was the '
                                'person looking, is the tracker streaming?)')
    if kind not in KINDS + ('auto',):
        raise ValueError(f"kind must be one of {', '.join(KINDS)} or 'auto', got {kind!r}")
    measured = np.array([t.mean_px for t in report.targets])
    before = float(np.mean(screen.angle_between_deg(measured, targets)))
    if kind != 'auto':
        if len(targets) < MIN_TARGETS[kind] or not _determined(measured, kind):
            raise CorrectionRefused(f'no {kind} correction from {len(targets)} targets: it '
                                    f'needs at least {MIN_TARGETS[kind]} spread over the '
                                    'screen (use 9, or an offset)')
        held_out: Dict[str, np.ndarray] = {}
        allowed = [kind]
    else:
        allowed = [k for k in KINDS if _determined(measured, k)]
        held_out = {k: held_out_errors(measured, targets, k, screen) for k in allowed}
    candidates = {k: float(np.mean(e)) for k, e in held_out.items()}
    notes = []
    while True:
        # The kind the held-out errors choose among those left; an implausible one is
        # dropped with every more flexible kind.
        name = choose_kind({k: held_out[k] for k in allowed}) if held_out else allowed[0]
        matrix = _fit_map(measured, targets, name)
        reason = implausibility(matrix, screen)
        if not reason:
            break
        allowed = allowed[:allowed.index(name)]
        if not allowed:
            raise CorrectionRefused(f'no correction: {reason}'
                                    + (f" (and {'; '.join(notes)})" if notes else ''))
        notes.append(f'{name} fit refused: {reason}')
    note = '; '.join(notes)
    held = candidates.get(name, math.nan)
    after = float(np.mean(screen.angle_between_deg(apply_correction(measured, matrix),
                                                   targets)))
    if not after < before:
        raise CorrectionRefused(f'no correction: it would not reduce the error ({before:.2f} '
                                f'deg before, {after:.2f} deg after)'
                                + (f'; {note}' if note else ''))
    if not held < before and math.isfinite(held):
        raise CorrectionRefused(f'no correction: it would not reduce the error at targets it '
                                f'was not fitted to ({before:.2f} deg before, {held:.2f} deg '
                                'after, leaving each target out in turn)'
                                + (f'; {note}' if note else ''))
    return CorrectionFit(matrix, name, before, after, held, candidates, note)


def correction_yaml(correction: Correction, node: str = NODE) -> str:
    """Return a ROS 2 parameter file (YAML text) setting ``gaze_correction`` of ``node``."""
    values = correction_values(correction)
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

    :returns: (2, 6) array (:func:`as_matrix`; identity when the file does not set it).
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
    :ivar kind: one of :data:`KINDS` ('' when refused).
    :ivar targets: number of targets shown.
    :ivar accuracy_deg: overall accuracy before the correction, degrees (NaN: no gaze).
    :ivar precision_deg: overall precision (RMS sample to sample) before, degrees.
    :ivar residual_deg: overall accuracy of the validation after the correction, degrees
        (NaN when refused).
    :ivar residual_px: the same in px.
    :ivar correction: the bridge's ``gaze_correction`` now (6 or 12 doubles).
    :ivar held_out_deg: the fit's mean error at targets left out of it, degrees
        (:attr:`CorrectionFit.held_out_deg`; NaN when refused or not measured).
    :ivar note: why a more flexible kind the data preferred was not used ('').
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
    held_out_deg: float = math.nan
    note: str = ''

    def summary(self) -> str:
        """One human line."""
        before = (f'accuracy {self.accuracy_deg:.2f} deg, precision {self.precision_deg:.2f} '
                  f'deg RMS over {self.targets} targets')
        if not self.accepted:
            # Refused before a target was shown (no gaze): nothing was measured.
            measured = f' ({before})' if self.targets else ''
            return f'validation refused{measured}: {self.reason}'
        saved = f', saved to {self.output}' if self.output else ''
        residual = (f'; residual accuracy {self.residual_deg:.2f} deg ({self.residual_px:.1f} '
                    'px)' if math.isfinite(self.residual_deg) else '')
        held = (f', {self.held_out_deg:.2f} deg at targets left out of the fit'
                if math.isfinite(self.held_out_deg) else '')
        note = f' ({self.note})' if self.note else ''
        return (f'validation accepted: {before}; {self.kind} correction applied{held}{note}'
                f'{saved}{residual}')

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
        texts = ('reason', 'kind', 'output', 'note')
        numbers = ('accuracy_deg', 'precision_deg', 'residual_deg', 'residual_px',
                   'held_out_deg')
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
                    and len(outcome.correction) in (6, 12)):
                raise ValueError('a field of the wrong type')
            as_matrix(outcome.correction)
        except (TypeError, ValueError) as error:
            raise ValueError(f'not a validation result: {text[:80]!r} ({error})') from None
        outcome.correction = [float(v) for v in outcome.correction]
        return outcome
