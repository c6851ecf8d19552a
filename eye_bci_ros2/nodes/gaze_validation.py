"""
Node ``gaze_validation``: validate the tracker through the running nodes, fit and apply a fix.

The procedure (:mod:`eye_bci_ros2.gaze.validation` holds the arithmetic):

1. refuses at once, before any target, when ``output`` cannot be written
   (:mod:`eye_bci_ros2.base.output_files`); waits for gaze on
   ``gaze/samples`` (at most ``gaze_wait_s``) and refuses at once, before
   any target is shown, when none arrives (no bridge, or no tracker
   streaming); waits for ``camera/pose`` (at most ``camera_wait_s``)
   and reads the bridge's ``gaze_correction`` over its parameter service
   (``bridge_node``);
2. shows ``targets`` (5 or 9) targets one after the other, ``target_s`` each,
   laid out over the RViz render panel (``margin`` of its size from the
   edges): each as a white disc with a black centre on
   ``validation/targets`` (visualization_msgs/MarkerArray, frame
   ``world_frame``, ``target_depth_m`` in front of the camera, unprojected
   from its screen point with the camera model of the running
   ``marker_projector``'s parameters, read at each start (``projector_node``;
   this node's own parameters of the same names when it does not answer),
   ``target_size_deg`` across; re-placed when the camera moves) and as its
   screen point on ``validation/target`` (geometry_msgs/PointStamped, frame
   ``screen``, px; NaN when none; the simulated person follows it);
3. collects ``gaze/samples`` from ``settle_s`` after each onset to its end,
   and logs accuracy and precision per target and overall, in degrees (for
   ``screen_width_mm`` x ``screen_height_mm`` seen from
   ``viewing_distance_mm``) and px;
4. fits a correction (``kind``; with ``auto`` the kind that does best at
   targets left out of the fit: offset, affine or, with 9 targets,
   second-order, :func:`eye_bci_ros2.gaze.validation.fit_correction`); when a
   target got fewer than ``min_samples`` samples, the fit is implausible
   anywhere on the screen or it would not reduce the error it refuses: one
   line with the reason, nothing saved or applied (a more flexible fit that
   is implausible falls back to a simpler one, and the outcome's ``note``
   says why);
5. otherwise composes it with the bridge's current correction, saves it as a
   parameter file (``output``; ``--params-file`` for the bridge; when that
   fails after all, in a file of the temp directory named in a warning and
   in the outcome's ``output``), sets the
   bridge's ``gaze_correction`` (what ``ros2 param set`` does) and validates
   again (``validate_again``), logging the residual;
6. publishes the outcome on ``validation/result`` (std_msgs/String: one JSON
   line, :class:`eye_bci_ros2.gaze.validation.ValidationOutcome`, with a
   ``summary``).

With ``on_request`` false (the default) it runs once at start and exits:
status 0 when the correction was applied, 1 when it was refused.  With
``on_request`` true it waits for ``validation/start`` (std_msgs/Empty; the
menu's ``validate_first`` sends it) and answers each on ``validation/result``.
"""

from dataclasses import replace
import math
import os
import time
from typing import Any, Callable, Dict, Iterator, List, Optional

from geometry_msgs.msg import Point, PointStamped, PoseStamped
import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Empty, Header, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.base.output_files import save_or_fallback, unwritable
from eye_bci_ros2.gaze.validation import (as_matrix, compose_corrections, correction_values,
                                          CorrectionRefused, error_model, fit_correction, IDENTITY,
                                          implausibility, KINDS, measure, MIN_SAMPLES, MIN_TARGETS,
                                          NODE, PARAMETER, samples_per_target, save_correction,
                                          SETTLE_S, target_layout, ValidationOutcome)
from eye_bci_ros2.nodes.marker_projector import (camera_from_parameters,
                                                 PARAMETERS as PROJECTOR_PARAMETERS)
from eye_bci_ros2.projection.visual_angle import degrees_to_px, ScreenGeometry
from eye_bci_ros2.ros.conversions import (arrays_to_pose, gaze_batch_arrays, ns_to_stamp,
                                          pose_to_arrays, SCREEN_FRAME)
from eye_bci_ros2.ros.log_throttle import WARN_PERIOD_S
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node
from eye_bci_ros2.ros.screen_parameters import person_screen, person_screen_parameters
from eye_bci_ros2.ros.topics import (CAMERA_POSE_TOPIC, EVENT_QOS, GAZE_QOS, GAZE_SAMPLES_TOPIC,
                                     LATCHED_QOS, VALIDATION_RESULT_TOPIC,
                                     VALIDATION_START_TOPIC, VALIDATION_TARGET_TOPIC,
                                     VALIDATION_TARGETS_TOPIC)

#: Step of the procedure's timer, s.
TICK_S = 0.02
#: After the last target, wait at most this long for its samples to arrive, s.
TAIL_WAIT_S = 1.0
#: After publishing the result, stay this long before exiting (so it is delivered), s.
LINGER_S = 0.5
#: What a refusal for want of gaze says (before any target is shown).
NO_GAZE = f'no gaze on {GAZE_SAMPLES_TOPIC}'
#: Marker namespace of the targets on ``validation/targets``.
MARKER_NS = 'validation'

_CAMERA_NAMES = ('world_frame', 'image_width', 'image_height', 'fov_y_deg', 'intrinsic_matrix',
                 'screen_offset_x', 'screen_offset_y', 'projection', 'ortho_scale',
                 'rviz_config')


def _check_count(value: Any) -> Optional[str]:
    return None if value in (5, 9) else f'{value} targets: use 5 or 9'


def _check_node_name(value: Any) -> Optional[str]:
    return None if str(value).strip() else 'must name the bridge node, e.g. /lsl_gaze_bridge'


#: The projector whose panel geometry the targets use (parameter ``projector_node``).
PROJECTOR_NODE = '/marker_projector'
#: Longest wait for the projector's parameter service at a validation's start, s (its
#: discovery runs from the node's start, in parallel with the wait for camera/pose).
PROJECTOR_WAIT_S = 2.0

#: Longest wait for the arbiter's parameter service after a validation, s.
ARBITER_WAIT_S = 1.0


PARAMETERS: List[ParamSpec] = [
    ParamSpec('targets', 9, 'Number of targets: 5 (centre, corners; offset fit) or 9 '
              '(3x3 grid; offset, affine or second-order fit)', value_range=(5, 9),
              check=_check_count),
    ParamSpec('target_s', 1.5, 'How long each target is shown, s', value_range=(0.2, 60.0)),
    ParamSpec('settle_s', SETTLE_S, 'Gaze from this long after a target appears is used '
              '(saccade latency and landing), s', value_range=(0.0, 30.0)),
    ParamSpec('margin', 0.1, 'Outer targets this far from the render panel edges, as a '
              'fraction of its size', value_range=(0.01, 0.49)),
    ParamSpec('kind', 'auto', 'Correction: offset, affine or quadratic (second-order; these '
              'two need 9 targets), or auto: the one with the least error at targets left out '
              'of the fit (the simplest within one standard error), plausible over the whole '
              'screen', choices=('auto',) + KINDS),
    ParamSpec('min_samples', MIN_SAMPLES, 'A target with fewer gaze samples after settle_s '
              'refuses the correction', value_range=(2, 100000)),
    ParamSpec('output', 'gaze_correction.yaml',
              "Parameter file written for the bridge (--params-file); '' = none"),
    ParamSpec('bridge_node', NODE, 'The bridge whose gaze_correction is read and set '
              '(its parameter service)', check=_check_node_name),
    ParamSpec('arbiter_node', '/choice_arbiter',
              "After the second pass, set this choice_arbiter's accuracy_deg and "
              'precision_deg to the residual error measured (the tolerant rule then fits '
              "the corrected tracker); '' = leave the arbiter alone"),
    ParamSpec('bridge_timeout_s', 5.0, "Longest wait for the bridge's parameter service, s",
              value_range=(0.1, 600.0)),
    ParamSpec('validate_again', True, 'After applying a correction, validate again and report '
              'the residual'),
    ParamSpec('on_request', False, 'false: run once at start and exit (0 applied, 1 refused); '
              'true: run on each validation/start and keep running'),
    ParamSpec('gaze_wait_s', 5.0, 'Longest wait for gaze on gaze/samples before the first '
              'target: without it the validation is refused at once (is lsl_gaze_bridge '
              'running and the tracker streaming?); 0 = show the targets without waiting, s',
              value_range=(0.0, 600.0)),
    ParamSpec('camera_wait_s', 5.0, 'Longest wait for camera/pose before the targets are shown '
              '(without it they are only on validation/target, not in RViz), s',
              value_range=(0.0, 600.0)),
    ParamSpec('target_depth_m', 2.0, 'Targets are placed this far in front of the RViz camera, '
              'm', value_range=(1e-3, 1e4)),
    ParamSpec('target_size_deg', 1.0, 'Diameter of a target disc, degrees of visual angle',
              value_range=(0.1, 10.0)),
    ParamSpec('projector_node', PROJECTOR_NODE,
              'The marker_projector whose panel geometry (image size, screen offset, field of '
              'view, projection, rviz_config) the targets are laid out in, read over its '
              "parameter service at each validation; '' or not answering = this node's own "
              'parameters of the same names'),
] + list(person_screen_parameters()) + [
    replace(spec, description='RViz fixed frame: the targets are placed in it; camera/pose '
            'must be in it.') if spec.name == 'world_frame' else spec
    for spec in PROJECTOR_PARAMETERS if spec.name in _CAMERA_NAMES]


def _check_all(values: Dict[str, Any]) -> Optional[str]:
    if values['settle_s'] >= values['target_s']:
        return (f"settle_s ({values['settle_s']:g} s) must be shorter than target_s "
                f"({values['target_s']:g} s)")
    if values['kind'] in MIN_TARGETS and values['targets'] < MIN_TARGETS[values['kind']]:
        return f"kind {values['kind']} needs {MIN_TARGETS[values['kind']]} or more targets"
    try:
        camera_from_parameters(values)
    except ValueError as error:
        return str(error)
    return None


def screen_geometry(values: Dict[str, Any]) -> ScreenGeometry:
    """Return the person's screen of the parameters."""
    return person_screen(values)


class GazeValidation(Node):
    """Run the validation procedure (module doc) through the running nodes."""

    def __init__(self, **kwargs):
        """Declare parameters and topics; start the procedure unless ``on_request``."""
        super().__init__('gaze_validation', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, self._params_changed, _check_all)
        #: Set when the job is done and the process should end (runner.spin_nodes).
        self.exit_status: Optional[int] = None
        #: The last outcome (None before the first run ends).
        self.outcome: Optional[ValidationOutcome] = None
        self._camera = None           # the camera at the last camera/pose, or None
        self._target_pub = self.create_publisher(PointStamped, VALIDATION_TARGET_TOPIC,
                                                 LATCHED_QOS)
        self._markers_pub = self.create_publisher(MarkerArray, VALIDATION_TARGETS_TOPIC,
                                                  LATCHED_QOS)
        self._result_pub = self.create_publisher(String, VALIDATION_RESULT_TOPIC, EVENT_QOS)
        self.create_subscription(PointCloud2, GAZE_SAMPLES_TOPIC, self._on_gaze, GAZE_QOS)
        self.create_subscription(PoseStamped, CAMERA_POSE_TOPIC, self._on_pose, LATCHED_QOS)
        self.create_subscription(Empty, VALIDATION_START_TOPIC, self._on_start, EVENT_QOS)
        self._bridge = AsyncParameterClient(self, self._params['bridge_node'])
        self._arbiter = self._arbiter_client()
        self._projector = self._projector_client()
        # The projector's panel geometry read at the last validation's start ({} = own).
        self._geometry: Dict[str, Any] = {}
        self._pose: Optional[tuple] = None          # the last camera/pose (eye, rotation)
        # The gaze received while a pass collects: lists of (stamps (N,), xy (N, 2)).
        self._gaze: Optional[List[tuple]] = None
        self._newest_stamp = -math.inf
        self._gaze_arrived = -math.inf              # monotonic s of the last gaze batch
        self._target: Optional[np.ndarray] = None    # screen px shown now
        self._run: Optional[Iterator[None]] = None
        self._timer = self.create_timer(TICK_S, self._step)
        self._publish_target(None)
        if not self._params['on_request']:
            self._run = self._procedure()
        else:
            self.get_logger().info(f'waiting for {VALIDATION_START_TOPIC}')

    @property
    def running(self) -> bool:
        """Tell whether a validation is under way."""
        return self._run is not None

    # -- inputs ------------------------------------------------------------------------------

    def _params_changed(self, changed: Dict[str, Any]) -> None:
        self._params.update(changed)
        if 'bridge_node' in changed:
            self._bridge = AsyncParameterClient(self, self._params['bridge_node'])
        if 'arbiter_node' in changed:
            self._arbiter = self._arbiter_client()
        if 'projector_node' in changed:
            self._projector = self._projector_client()

    def _projector_client(self) -> Optional[AsyncParameterClient]:
        """Return the parameter client of ``projector_node`` (None when it is '')."""
        name = self._params['projector_node']
        return AsyncParameterClient(self, name) if name else None

    def _panel_values(self) -> Dict[str, Any]:
        """Return the parameters with the projector's panel geometry over this node's own."""
        return dict(self._params, **self._geometry)

    def _make_camera(self):
        """Return the camera of the panel geometry in force, at the last camera/pose."""
        camera = camera_from_parameters(self._panel_values())
        return camera.with_pose(*self._pose) if self._pose is not None else camera

    def _arbiter_client(self) -> Optional[AsyncParameterClient]:
        """Return the parameter client of ``arbiter_node`` (None when it is '')."""
        name = self._params['arbiter_node']
        return AsyncParameterClient(self, name) if name else None

    def _on_start(self, _message: Empty) -> None:
        if self._run is not None:
            self.get_logger().warning(f'{VALIDATION_START_TOPIC}: a validation is already '
                                      'running; request ignored')
            return
        self._run = self._procedure()

    def _on_gaze(self, message: PointCloud2) -> None:
        self._gaze_arrived = time.monotonic()
        if self._gaze is None:
            return
        try:
            stamps, xy = gaze_batch_arrays(message)
        except ValueError as error:
            self.get_logger().warning(str(error), throttle_duration_sec=WARN_PERIOD_S)
            return
        if len(stamps):
            self._gaze.append((stamps, xy))
            self._newest_stamp = max(self._newest_stamp, float(stamps[-1]))

    def _on_pose(self, message: PoseStamped) -> None:
        frame = self._params['world_frame']
        if message.header.frame_id and message.header.frame_id != frame:
            self.get_logger().warning(f"camera/pose in frame '{message.header.frame_id}', not "
                                      f"'{frame}': ignored", throttle_duration_sec=WARN_PERIOD_S)
            return
        try:
            self._pose = pose_to_arrays(message.pose)
            self._camera = self._make_camera()
            if self._target is not None:
                self._publish_markers(self._target)   # keep the target where it is on screen
        except ValueError as error:
            self.get_logger().warning(f'camera/pose ignored: {error}',
                                      throttle_duration_sec=WARN_PERIOD_S)

    # -- the procedure -----------------------------------------------------------------------

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _step(self) -> None:
        """Advance the procedure to its next wait (the timer's callback)."""
        if self._run is None:
            return
        try:
            next(self._run)
        except StopIteration:
            self._run = None
        except Exception as error:  # noqa: B902 - report, never die in a callback
            self._run = None
            self._publish_target(None)
            self._finish(ValidationOutcome(False, f'validation failed: {error}'))

    def _wait(self, done: Callable[[], bool], timeout_s: float) -> Iterator[None]:
        """Yield until ``done()`` or ``timeout_s`` passed."""
        end = time.monotonic() + timeout_s
        while not done() and time.monotonic() < end:
            yield

    def _procedure(self) -> Iterator[None]:
        """Run the whole validation (module doc), one step per timer tick."""
        params = dict(self._params)
        screen = screen_geometry(params)
        # Checked before the first target: the person's minutes are not lost at the last step.
        output = os.path.abspath(params['output']) if params['output'] else ''
        problem = unwritable(output) if output else None
        if problem:
            self._finish(ValidationOutcome(
                False, f"{problem}: set output to a writable file ('' = none); no target shown"))
            return
        self.get_logger().info(f"validation: {params['targets']} targets, "
                               f"{params['target_s']:g} s each")
        if params['gaze_wait_s'] > 0:
            asked = time.monotonic()
            yield from self._wait(lambda: self._gaze_arrived >= asked, params['gaze_wait_s'])
            if self._gaze_arrived < asked:
                self._finish(ValidationOutcome(False, f'{NO_GAZE} in {params["gaze_wait_s"]:g} '
                                               's: is lsl_gaze_bridge running and the tracker '
                                               'streaming?'))
                return
        yield from self._wait(lambda: self._camera is not None, params['camera_wait_s'])
        if self._camera is None:
            self.get_logger().warning('no camera/pose: the targets are not shown in RViz, only '
                                      f'on {VALIDATION_TARGET_TOPIC}')
        yield from self._read_panel()
        params.update(self._geometry)
        current = yield from self._read_correction(params['bridge_timeout_s'])
        camera = self._make_camera()
        if self._pose is not None:
            self._camera = camera
        offset = np.asarray(camera.screen_offset, dtype=float)
        targets = target_layout(params['targets'], *camera.image_size, params['margin']) + offset

        report = yield from self._pass(targets, params, screen)
        for line in report.lines():
            self.get_logger().info(line)
        base = ValidationOutcome(False, targets=len(targets), accuracy_deg=report.accuracy_deg,
                                 precision_deg=report.precision_deg,
                                 correction=correction_values(current))
        try:
            fit = fit_correction(targets, self._samples(targets, params), params['kind'],
                                 screen, params['min_samples'])
            total = compose_corrections(fit.matrix, current, screen)
            reason = implausibility(total, screen)
            if reason:
                raise CorrectionRefused(f'no correction: with the current one {reason}')
        except CorrectionRefused as refused:
            base.reason = str(refused)
            self._finish(base)
            return
        values = correction_values(total)
        if output:
            output = self._save(output, values, params['bridge_node'])
        problem = yield from self._set_correction(values, params['bridge_timeout_s'])
        if problem:
            base.reason = problem + (f' (saved to {output})' if output else '')
            base.output = output
            self._finish(base)
            return
        held = ', '.join(f'{kind} {deg:.2f}' for kind, deg in fit.candidates.items())
        self.get_logger().info(
            f'{fit.kind} correction applied: {values} (on the fitted data '
            f'{fit.residual_before_deg:.2f} -> {fit.residual_after_deg:.2f} deg'
            + (f'; at targets left out of the fit, deg: {held}' if held else '') + ')'
            + (f'; {fit.note}' if fit.note else ''))
        outcome = ValidationOutcome(True, '', fit.kind, len(targets), report.accuracy_deg,
                                    report.precision_deg, correction=values, output=output,
                                    held_out_deg=fit.held_out_deg, note=fit.note)
        if params['validate_again']:
            self.get_logger().info('validating again with the correction applied')
            again = yield from self._pass(targets, params, screen)
            for line in again.lines():
                self.get_logger().info(f'residual: {line}')
            outcome.residual_deg, outcome.residual_px = again.accuracy_deg, again.accuracy_px
            if self._arbiter is not None:
                # A pipeline without an arbiter is fine: do not wait long for one.
                yield from self._set_error_model(again, min(params['bridge_timeout_s'],
                                                            ARBITER_WAIT_S))
        self._finish(outcome)
        yield from self._wait(lambda: False, LINGER_S)
        if not params['on_request']:
            self.exit_status = 0

    def _save(self, output: str, values: List[float], bridge: str) -> str:
        """Save the correction to ``output``, else to a named fallback file; return which."""
        try:
            output = save_or_fallback(
                output, lambda path: save_correction(path, values, bridge), 'the correction',
                self.get_name(), self.get_logger().warning)
        except OSError as error:
            self.get_logger().error(f'the correction is applied but not saved: {error}')
            return ''
        self.get_logger().info(f'saved {output}: start the bridge with --params-file {output}')
        return output

    def _pass(self, targets: np.ndarray, params: Dict[str, Any],
              screen: ScreenGeometry) -> Iterator[None]:
        """Show every target and collect its gaze; returns the report."""
        self._gaze, self._newest_stamp = [], -math.inf
        self._onsets, self._ends = [], []
        for target in targets:
            self._target = target
            onset = self._now()
            self._publish_target(target, onset)
            self._publish_markers(target)
            yield from self._wait(lambda: False, params['target_s'])
            self._onsets.append(onset)
            self._ends.append(self._now())
        self._target = None
        self._publish_target(None)
        self._publish_markers(None)
        last = self._ends[-1]
        yield from self._wait(lambda: self._newest_stamp >= last, TAIL_WAIT_S)
        return measure(targets, self._samples(targets, params), screen, params['min_samples'])

    def _samples(self, targets: np.ndarray, params: Dict[str, Any]) -> List[np.ndarray]:
        """Return the gaze of the last pass, per target (after settle_s)."""
        if self._gaze:
            stamps = np.concatenate([s for s, _ in self._gaze])
            xy = np.concatenate([p for _, p in self._gaze])
            order = np.argsort(stamps, kind='stable')
            stamps, xy = stamps[order], xy[order]
        else:
            stamps, xy = np.zeros(0), np.zeros((0, 2))
        return samples_per_target(stamps, xy, self._onsets, self._ends, params['settle_s'])

    def _read_panel(self) -> Iterator[None]:
        """
        Take the panel geometry from the projector (``projector_node``).

        The targets are then where the projector puts the options: a screen offset set on the
        projector
        (``find_panel``'s panel.yaml, ``ros2 param set``) but not here would otherwise be
        "corrected" into the gaze.  Keeps this node's own values when it cannot be read.
        """
        self._geometry = {}
        name = self._params['projector_node']
        if self._projector is None:
            return
        yield from self._wait(self._projector.services_are_ready, PROJECTOR_WAIT_S)
        names = list(_CAMERA_NAMES)
        problem = f'{name} does not answer (not running?)'
        if self._projector.services_are_ready():
            future = self._projector.get_parameters(names)
            yield from self._wait(future.done, PROJECTOR_WAIT_S)
            result = future.result() if future.done() else None
            values = list(result.values) if result is not None else []
            if len(values) == len(names):
                geometry = {key: parameter_value_to_python(value)
                            for key, value in zip(names, values)}
                geometry = {key: list(value) if isinstance(value, (list, tuple)) else value
                            for key, value in geometry.items()}
                try:
                    camera = camera_from_parameters(dict(self._params, **geometry))
                except ValueError as error:
                    problem = f'its geometry is unusable: {error}'
                else:
                    self._geometry = geometry
                    width, height = camera.image_size
                    x, y = camera.screen_offset
                    self.get_logger().info(
                        f'panel geometry from {name}: {width:g}x{height:g} px at screen '
                        f'offset ({x:g}, {y:g}) px')
                    return
            else:
                problem = f'{name} did not return its panel parameters'
        values = self._params
        self.get_logger().warning(
            f"cannot read the panel geometry of {name}: {problem}; using this node's own "
            f"({values['image_width']}x{values['image_height']} px at screen offset "
            f"({values['screen_offset_x']:g}, {values['screen_offset_y']:g}) px)")

    def _read_correction(self, timeout_s: float) -> Iterator[None]:
        """Return the bridge's gaze_correction as (2, 6) (identity when it cannot be read)."""
        name = self._params['bridge_node']
        yield from self._wait(self._bridge.services_are_ready, timeout_s)
        if self._bridge.services_are_ready():
            future = self._bridge.get_parameters([PARAMETER])
            yield from self._wait(future.done, timeout_s)
            if future.done() and future.result() is not None and future.result().values:
                value = parameter_value_to_python(future.result().values[0])
                try:
                    return as_matrix(value if value is not None else IDENTITY)
                except ValueError:
                    pass
        self.get_logger().warning(f'cannot read {PARAMETER} of {name}: taking it as none')
        return as_matrix(IDENTITY)

    def _set_correction(self, values: List[float], timeout_s: float) -> Iterator[None]:
        """Set the bridge's gaze_correction; returns '' or why it failed."""
        return (yield from self._set(self._bridge, self._params['bridge_node'], 'lsl_gaze_bridge',
                                     [Parameter(PARAMETER, value=values)], timeout_s))

    def _set_error_model(self, report, timeout_s: float) -> Iterator[None]:
        """Give the arbiter the residual error model; a failure is a warning, not a refusal."""
        model = error_model(report)
        name = self._params['arbiter_node']
        problem = yield from self._set(
            self._arbiter, name, 'choice_arbiter',
            [Parameter('accuracy_deg', value=float(model.accuracy_deg)),
             Parameter('precision_deg', value=float(model.precision_deg))], timeout_s)
        if problem:
            self.get_logger().warning(f'{problem}; the arbiter keeps its error model')
        else:
            self.get_logger().info(f'{name}: accuracy_deg {model.accuracy_deg:.2f}, '
                                   f'precision_deg {model.precision_deg:.2f} (the residual)')

    def _set(self, client: AsyncParameterClient, name: str, what: str,
             parameters: List[Parameter], timeout_s: float) -> Iterator[None]:
        """Set parameters of another node through its service; returns '' or why it failed."""
        names = ', '.join(parameter.name for parameter in parameters)
        yield from self._wait(client.services_are_ready, timeout_s)
        if not client.services_are_ready():
            return (f'could not set {names}: the parameter service of {name} does not '
                    f'answer (is {what} running with that name?)')
        future = client.set_parameters(parameters)
        yield from self._wait(future.done, timeout_s)
        if not future.done() or future.result() is None:
            return f'could not set {names}: {name} did not answer'
        for parameter, result in zip(parameters, future.result().results):
            if not result.successful:
                return f'{name} refused {parameter.name}: {result.reason}'
        return ''

    # -- outputs -----------------------------------------------------------------------------

    def _finish(self, outcome: ValidationOutcome) -> None:
        """Log and publish the outcome; in run-once mode a refusal ends with status 1."""
        self.outcome = outcome
        self._gaze = None
        if outcome.accepted:
            self.get_logger().info(outcome.summary())
        else:
            self.get_logger().error(outcome.summary())
        self._result_pub.publish(String(data=outcome.to_json()))
        if not outcome.accepted and not self._params['on_request']:
            self.exit_status = 1

    def _publish_target(self, target: Optional[np.ndarray], stamp_s: Optional[float] = None
                        ) -> None:
        message = PointStamped()
        message.header = Header(frame_id=SCREEN_FRAME, stamp=ns_to_stamp(
            round((self._now() if stamp_s is None else stamp_s) * 1e9)))
        if target is None:
            message.point = Point(x=math.nan, y=math.nan, z=0.0)
        else:
            message.point = Point(x=float(target[0]), y=float(target[1]), z=0.0)
        self._target_pub.publish(message)

    def _publish_markers(self, target: Optional[np.ndarray]) -> None:
        """Show the target as a disc with a centre dot in front of the camera (or none)."""
        frame = self._params['world_frame']
        clear = Marker(ns=MARKER_NS, action=Marker.DELETEALL)
        clear.header.frame_id = frame
        array = MarkerArray(markers=[clear])
        camera = self._camera
        if target is not None and camera is not None:
            depth = self._params['target_depth_m']
            size_px = float(degrees_to_px(self._params['target_size_deg'], target[None],
                                          screen_geometry(self._params))[0])
            uv = camera.to_image(np.array([target, target + [size_px, 0.0]]))
            centre, edge = camera.unproject(uv, depth)
            diameter = float(np.linalg.norm(edge - centre))
            # The dot sits on the camera side of the disc, so it is drawn on top.
            dot = camera.unproject(uv[:1], depth - 0.6 * diameter)[0]
            stamp = self.get_clock().now().to_msg()
            for index, (where, size, colour) in enumerate((
                    (centre, diameter, (1.0, 1.0, 1.0, 1.0)),
                    (dot, 0.2 * diameter, (0.0, 0.0, 0.0, 1.0)))):
                marker = Marker(ns=MARKER_NS, id=index, type=Marker.SPHERE, action=Marker.ADD)
                marker.header.frame_id = frame
                marker.header.stamp = stamp
                marker.pose = arrays_to_pose(where, (0.0, 0.0, 0.0, 1.0))
                marker.scale.x = marker.scale.y = marker.scale.z = size
                (marker.color.r, marker.color.g, marker.color.b, marker.color.a) = colour
                array.markers.append(marker)
        self._markers_pub.publish(array)


def main(args=None):
    """Run one validation (or serve requests with on_request:=true)."""
    spin_node(GazeValidation, args, help_modules=[__name__])


if __name__ == '__main__':
    main()
