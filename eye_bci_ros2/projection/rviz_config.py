"""
Read an RViz2 ``.rviz`` file: the current view and the render panel size.

Pure (numpy and PyYAML).  What RViz2 (Jazzy) does with each stored view, from
its sources (ros2/rviz, branch jazzy), is reproduced exactly:

* ``Visualization Manager: Views: Current:`` holds the view controller's
  ``Class`` and its properties (radians, metres), written by
  ``ViewManager::save`` (rviz_common/src/rviz_common/view_manager.cpp).  A
  property that is absent keeps the controller's default, as in RViz.  Numbers
  are clamped to the property's limits as ``FloatProperty::setValue`` does
  (rviz_common/src/rviz_common/properties/float_property.cpp).
* Orbit, XYOrbit and ThirdPersonFollower are perspective; the eye orbits the
  focal point (:func:`orbit_view`, :func:`xy_orbit_view`).  FPS is
  perspective from a position (:func:`fps_view`).  TopDownOrtho is
  orthographic from 500 m above (:func:`top_down_ortho_view`).  No RViz2 code
  sets the field of view: Ogre's default, 45 degrees vertical
  (:data:`eye_bci_ros2.projection.camera_model.RVIZ_FOV_Y_DEG`).
* The view follows its ``Target Frame``; only ``<Fixed Frame>`` (or the
  fixed frame's own name) can be turned into a static view without tf2.
* ``Window Geometry: QMainWindow State`` is Qt's ``QMainWindow::saveState``
  as hex (``VisualizationFrame::saveWindowGeometry``,
  rviz_common/src/rviz_common/visualization_frame.cpp).  It holds the central
  widget's size; the central widget is the render panel between two 16 px
  wide hide-dock buttons in a layout without margins or spacing
  (``VisualizationFrame::initialize``), so the panel is (width - 32) x height.
  That is the size when the file was saved; where the panel sits on the
  screen is stored nowhere.
"""

from dataclasses import dataclass
import math
from pathlib import Path
import struct
from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import yaml

from eye_bci_ros2.projection.camera_model import (look_at_pose, OrthographicCamera,
                                                  top_down_external)
from eye_bci_ros2.projection.geometry import quaternion_to_matrix

#: The view controllers RViz2 Jazzy ships (rviz_default_plugins/plugins_description.xml)
#: and the Jazzy port of the animated view controller.
ORBIT = 'rviz_default_plugins/Orbit'
XY_ORBIT = 'rviz_default_plugins/XYOrbit'
THIRD_PERSON_FOLLOWER = 'rviz_default_plugins/ThirdPersonFollower'
FPS = 'rviz_default_plugins/FPS'
TOP_DOWN_ORTHO = 'rviz_default_plugins/TopDownOrtho'
ANIMATED = 'Animated (rviz_plugin_view_animated)'
VIEW_CONTROLLERS = (ORBIT, XY_ORBIT, THIRD_PERSON_FOLLOWER, FPS, TOP_DOWN_ORTHO, ANIMATED)

#: ``Target Frame`` value meaning "the fixed frame" (TfFrameProperty::FIXED_FRAME_STRING).
FIXED_FRAME_STRING = '<Fixed Frame>'

#: XYOrbit lifts the eye by this fraction of Distance along the camera's up axis
#: (``CAMERA_OFFSET``, xy_orbit/xy_orbit_view_controller.cpp).
XY_ORBIT_CAMERA_OFFSET = 0.2

#: Orbit's Pitch limit, rad (``pitch_property_->setMax(HALF_PI - 0.001)``), and
#: FPS's (``PITCH_LIMIT_HIGH``): the same value.
PITCH_LIMIT = math.pi / 2 - 0.001

#: Orbit's minimum Distance, m (``distance_property_->setMin(0.001f)``).
MIN_DISTANCE = 0.001

#: Width of each of the two hide-dock buttons beside the render panel, px
#: (``setFixedWidth(16)`` in VisualizationFrame::initialize).
HIDE_DOCK_BUTTON_PX = 16


@dataclass(frozen=True)
class RvizView:
    """
    What an ``.rviz`` file says about the view.

    :ivar controller: the view controller's class, one of :data:`VIEW_CONTROLLERS`.
    :ivar fixed_frame: ``Global Options: Fixed Frame`` without a leading '/'.
    :ivar projection: 'perspective' or 'orthographic'.
    :ivar eye: camera position, world (fixed) frame, shape (3,), m.
    :ivar focus: a point on the optical axis in front of the eye, shape (3,), m
        (the orbit's focal point where the controller has one).
    :ivar up: world direction that is up on the panel, shape (3,).
    :ivar ortho_scale: px per m of an orthographic view, else None.
    :ivar panel_size: render panel (W, H) px from the window state, or None
        when the file has none or it does not decode.
    """

    controller: str
    fixed_frame: str
    projection: str
    eye: np.ndarray
    focus: np.ndarray
    up: np.ndarray
    ortho_scale: Optional[float] = None
    panel_size: Optional[Tuple[int, int]] = None

    def optical_pose(self) -> Tuple[np.ndarray, np.ndarray]:
        """Optical camera pose of the view: ``(position (3,), quaternion_xyzw (4,))``."""
        return look_at_pose(self.eye, self.focus, self.up)


def orbit_view(focal_point, distance: float, yaw: float, pitch: float,
               invert_z: bool = False) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """
    Eye, focus and up of an Orbit view.

    ``OrbitViewController::updateCamera`` (rviz_default_plugins/src/
    rviz_default_plugins/view_controllers/orbit/orbit_view_controller.cpp):
    with Invert Z Axis, yaw and pitch change sign and the up axis is -Z; then
    ``eye = F + d (cos yaw cos pitch, sin yaw cos pitch, sin pitch)``, the
    camera looks at F with the up axis as fixed yaw axis (Ogre
    ``setFixedYawAxis`` + ``setDirection``: the same as look-at with that up).

    :param focal_point: F, shape (3,), m.
    :param distance: d, m (clamped to >= 0.001 as RViz does).
    :param yaw: rad, about Z.
    :param pitch: rad, clamped to +-(pi/2 - 0.001) as RViz does.
    :param invert_z: the ``Invert Z Axis`` property.
    :returns: ``(eye, focus, up)``, each shape (3,).
    """
    focal_point = _vector('Focal Point', focal_point)
    distance = max(float(distance), MIN_DISTANCE)
    pitch = min(max(float(pitch), -PITCH_LIMIT), PITCH_LIMIT)
    yaw = float(yaw)
    up = np.array([0.0, 0.0, 1.0])
    if invert_z:
        yaw, pitch, up = -yaw, -pitch, -up
    offset = distance * np.array([math.cos(yaw) * math.cos(pitch),
                                  math.sin(yaw) * math.cos(pitch), math.sin(pitch)])
    return focal_point + offset, focal_point, up


def xy_orbit_view(focal_point, distance: float, yaw: float, pitch: float,
                  invert_z: bool = False) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """
    Eye, focus and up of an XYOrbit (and ThirdPersonFollower) view.

    ``XYOrbitViewController::updateCamera`` (xy_orbit/xy_orbit_view_controller.cpp)
    runs the Orbit update, then moves the eye by ``CAMERA_OFFSET * Distance``
    (0.2 d) along the camera's own up axis without turning it: the view
    direction stays ``F - eye_orbit``, so the focal point sits below the panel
    centre.  ThirdPersonFollower is an XYOrbit whose target frame also turns
    with the target's yaw (follower/third_person_follower_view_controller.cpp),
    which is the identity when the target is the fixed frame.

    :returns: ``(eye, focus, up)``: focus is a point on the optical axis
        (``eye + (F - eye_orbit)``), not the focal point.
    """
    eye, focus, up = orbit_view(focal_point, distance, yaw, pitch, invert_z)
    direction = focus - eye
    forward = direction / np.linalg.norm(direction)
    camera_up = up - (up @ forward) * forward
    camera_up /= np.linalg.norm(camera_up)
    lifted = eye + XY_ORBIT_CAMERA_OFFSET * max(float(distance), MIN_DISTANCE) * camera_up
    return lifted, lifted + direction, up


def fps_view(position, yaw: float, pitch: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """
    Eye, focus and up of an FPS view.

    ``FPSViewController::getOrientation`` (fps/fps_view_controller.cpp) is
    ``Rz(yaw) * Ry(pitch) * ROBOT_TO_CAMERA_ROTATION`` with
    ``ROBOT_TO_CAMERA_ROTATION = Ry(-pi/2) * Rz(-pi/2)``: the Ogre camera's
    forward (-Z) and up (+Y) become the robot's x and z.  So forward =
    ``(cos yaw cos pitch, sin yaw cos pitch, -sin pitch)`` (positive pitch looks
    down) and up = ``Rz(yaw) Ry(pitch) z``.

    :param position: the ``Position`` property, shape (3,), m.
    :param yaw: rad.
    :param pitch: rad, clamped to +-(pi/2 - 0.001) as RViz does.
    :returns: ``(eye, focus, up)``: focus one metre ahead.
    """
    position = _vector('Position', position)
    pitch = min(max(float(pitch), -PITCH_LIMIT), PITCH_LIMIT)
    rotation = quaternion_to_matrix(_quaternion_z(yaw)) @ quaternion_to_matrix(
        _quaternion_y(pitch)) @ quaternion_to_matrix(_ROBOT_TO_CAMERA)
    forward = rotation @ np.array([0.0, 0.0, -1.0])
    up = rotation @ np.array([0.0, 1.0, 0.0])
    return position, position + forward, up


def top_down_ortho_view(x: float, y: float, angle: float,
                        scale: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """
    Eye, focus, up and scale of a TopDownOrtho view.

    See :func:`eye_bci_ros2.projection.camera_model.top_down_external`: the camera at
    (X, Y, 500) looks straight down, turned by Angle about Z; its up on the
    panel is ``(-sin Angle, cos Angle, 0)``; Scale is px per m.

    :returns: ``(eye, focus, up, scale)``: focus is the point (X, Y, 0) below.
    :raises ValueError: a Scale <= 0.
    """
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f'TopDownOrtho Scale must be a positive number of px per m, got {scale}')
    rotation = top_down_external(x, y, angle)[:3, :3]
    eye = np.array([x, y, OrthographicCamera.CAMERA_Z], dtype=float)
    return eye, np.array([x, y, 0.0], dtype=float), -rotation[1], float(scale)


def read_rviz_config(path) -> RvizView:
    """
    Read an ``.rviz`` file.

    :param path: file path.
    :raises ValueError: a missing or unreadable file, a malformed file, a view
        controller class other than :data:`VIEW_CONTROLLERS`, or a Target Frame
        other than the fixed frame; the message names the file.
    """
    try:
        text = Path(path).read_text(encoding='utf-8')
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"cannot read rviz_config '{path}': {error}") from None
    return parse_rviz_config(text, str(path))


def parse_rviz_config(text: str, source: str = '<rviz config>') -> RvizView:
    """Parse the text of an ``.rviz`` file; see :func:`read_rviz_config`."""
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ValueError(f'{source}: not a valid .rviz (YAML) file: '
                         f'{" ".join(str(error).split())}') from None
    manager = _child(document, 'Visualization Manager', source, 'the file')
    views = _child(manager, 'Views', source, 'Visualization Manager')
    current = _child(views, 'Current', source, 'Visualization Manager: Views')
    # RViz's default Fixed Frame is base_link (visualization_manager.cpp).
    fixed_frame = str(_mapping_or_empty(manager.get('Global Options')).get(
        'Fixed Frame', 'base_link')).lstrip('/')
    controller = current.get('Class')
    if controller not in VIEW_CONTROLLERS:
        hint = ''
        if isinstance(controller, str) and controller.startswith('rviz/'):
            hint = ' (a ROS 1 RViz config? RViz2 names it rviz_default_plugins/...)'
        known = ', '.join(VIEW_CONTROLLERS)
        raise ValueError(f'{source}: unknown view controller class {controller!r}{hint}; '
                         f'known: {known}')
    where = f'{source}: Views: Current ({controller})'
    target = str(current.get('Target Frame', FIXED_FRAME_STRING))
    if controller != ANIMATED and target != FIXED_FRAME_STRING and \
            target.lstrip('/') != fixed_frame:
        raise ValueError(f"{where}: Target Frame '{target}' is not the fixed frame "
                         f"'{fixed_frame}': the view moves with that frame, which needs tf2; "
                         f'set Target Frame to {FIXED_FRAME_STRING} in RViz')
    props = _Properties(current, where)
    scale = None
    projection = 'perspective'
    if controller in (ORBIT, XY_ORBIT, THIRD_PERSON_FOLLOWER):
        view = orbit_view if controller == ORBIT else xy_orbit_view
        eye, focus, up = view(props.vector('Focal Point', (0.0, 0.0, 0.0)),
                              props.number('Distance', 10.0), props.number('Yaw', math.pi / 4),
                              props.number('Pitch', math.pi / 4),
                              props.flag('Invert Z Axis', False))
    elif controller == FPS:
        eye, focus, up = fps_view(props.vector('Position', (5.0, 5.0, 10.0)),
                                  props.number('Yaw', 0.0), props.number('Pitch', 0.0))
    elif controller == TOP_DOWN_ORTHO:
        projection = 'orthographic'
        try:
            eye, focus, up, scale = top_down_ortho_view(
                props.number('X', 0.0), props.number('Y', 0.0), props.number('Angle', 0.0),
                props.number('Scale', 10.0))
        except ValueError as error:
            raise ValueError(f'{where}: {error}') from None
    else:
        eye, focus, up = _animated_view(props)
    try:
        look_at_pose(eye, focus, up)
    except ValueError as error:
        raise ValueError(f'{where}: the view defines no camera: {error}') from None
    state = _mapping_or_empty(document.get('Window Geometry')).get('QMainWindow State')
    panel = panel_size_from_window_state(state) if isinstance(state, str) else None
    return RvizView(controller, fixed_frame, projection, eye, focus, up, scale, panel)


def _animated_view(props: '_Properties') -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """
    Eye, focus and up of the Jazzy port's animated view controller.

    ``UpdateViewPose`` (weraleiso/ias_rviz_plugins,
    rviz_plugin_view_animated/source/rviz_plugin_view_animated.cpp) puts the
    camera at ``Eye (Fixed)`` looking at ``Focus (Fixed)`` (Mode ORBIT) or
    along it (Mode FPS: the focus property is the direction), with
    ``Up Axis (Fixed)`` as fixed yaw axis; all in the fixed frame.
    """
    eye = props.vector('Eye (Fixed)', (3.0, 3.0, 3.0))
    focus = props.vector('Focus (Fixed)', (0.0, 0.0, 0.0))
    up = props.vector('Up Axis (Fixed)', (0.0, 0.0, 1.0))
    mode = str(props.values.get('Mode', 'ORBIT'))
    if mode == 'FPS':
        focus = eye + focus
    elif mode != 'ORBIT':
        raise ValueError(f"{props.where}: Mode '{mode}' is not ORBIT or FPS")
    return eye, focus, up


class _Properties:
    """Typed access to a view controller's stored properties, defaults as in RViz."""

    def __init__(self, values: Dict[str, Any], where: str):
        self.values = values
        self.where = where

    def number(self, name: str, default: float) -> float:
        value = self.values.get(name, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value):
            raise ValueError(f'{self.where}: {name} must be a finite number, got {value!r}')
        return float(value)

    def flag(self, name: str, default: bool) -> bool:
        value = self.values.get(name, default)
        if not isinstance(value, bool):
            raise ValueError(f'{self.where}: {name} must be true or false, got {value!r}')
        return value

    def vector(self, name: str, default) -> np.ndarray:
        value = self.values.get(name)
        if value is None:
            return np.array(default, dtype=float)
        if not isinstance(value, dict):
            raise ValueError(f'{self.where}: {name} must hold X, Y and Z, got {value!r}')
        nested = _Properties(value, f'{self.where}: {name}')
        return np.array([nested.number(axis, 0.0) for axis in ('X', 'Y', 'Z')])


def _child(mapping: Any, key: str, source: str, parent: str) -> Dict[str, Any]:
    """Return ``mapping[key]`` as a dict, or raise ValueError naming what is missing."""
    if not isinstance(mapping, dict):
        raise ValueError(f'{source}: not an .rviz file: {parent} is not a mapping')
    value = mapping.get(key)
    if not isinstance(value, dict):
        raise ValueError(f"{source}: not an .rviz file with a view: no '{key}:' under {parent}")
    return value


def _mapping_or_empty(value: Any) -> Dict[str, Any]:
    return value if isinstance(value, dict) else {}


def _vector(name: str, value) -> np.ndarray:
    array = np.array(value, dtype=float).reshape(-1)
    if array.size != 3 or not np.all(np.isfinite(array)):
        raise ValueError(f'{name} needs 3 finite numbers, got {array.tolist()}')
    return array


def _quaternion_z(angle: float) -> np.ndarray:
    """Quaternion x, y, z, w of a turn by ``angle`` rad about Z."""
    return np.array([0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2)])


def _quaternion_y(angle: float) -> np.ndarray:
    """Quaternion x, y, z, w of a turn by ``angle`` rad about Y."""
    return np.array([0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2)])


def _product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions x, y, z, w."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz])


#: ``ROBOT_TO_CAMERA_ROTATION`` of fps_view_controller.cpp: Ry(-pi/2) * Rz(-pi/2).
_ROBOT_TO_CAMERA = _product(_quaternion_y(-math.pi / 2), _quaternion_z(-math.pi / 2))


# --- Qt QMainWindow::saveState -------------------------------------------------------------

#: Markers of Qt 5's QMainWindow / QDockAreaLayout state streams (qmainwindowlayout.cpp,
#: qdockarealayout.cpp): the stream starts with VersionMarker and the version number,
#: then the dock areas (DockWidgetStateMarker), each a tree of Sequence/Tab infos.
_VERSION_MARKER = 0xff
_DOCK_WIDGET_STATE_MARKER = 0xfd
_SEQUENCE_MARKER = 0xfc
_TAB_MARKER = 0xfa
_WIDGET_MARKER = 0xfb


@dataclass(frozen=True)
class WindowState:
    """
    The parts of a QMainWindow state that fix the central widget's size.

    :ivar docks: {area: (width, height)} px of each non-empty dock area
        (0 left, 1 right, 2 top, 3 bottom).
    :ivar central_size: (width, height) of the central widget, px.
    """

    docks: Dict[int, Tuple[int, int]]
    central_size: Tuple[int, int]

    @property
    def panel_size(self) -> Tuple[int, int]:
        """Render panel (W, H), px: the central widget minus the two hide-dock buttons."""
        width, height = self.central_size
        return width - 2 * HIDE_DOCK_BUTTON_PX, height


class _Reader:
    """Big-endian QDataStream reader over bytes."""

    def __init__(self, data: bytes):
        self.data = data
        self.at = 0

    def take(self, count: int) -> bytes:
        if self.at + count > len(self.data):
            raise ValueError('state ends early')
        chunk = self.data[self.at:self.at + count]
        self.at += count
        return chunk

    def byte(self) -> int:
        return self.take(1)[0]

    def int32(self) -> int:
        return struct.unpack('>i', self.take(4))[0]

    def string(self) -> None:
        length = struct.unpack('>I', self.take(4))[0]
        if length != 0xffffffff:
            self.take(length)


def _skip_dock_info(reader: _Reader, depth: int = 0) -> None:
    """Skip one QDockAreaLayoutInfo::saveState record (and its nested ones)."""
    if depth > 16:
        raise ValueError('dock layout nested too deeply')
    marker = reader.byte()
    if marker == _TAB_MARKER:
        reader.int32()  # index of the current tab
    elif marker != _SEQUENCE_MARKER:
        raise ValueError(f'unexpected dock info marker {marker:#x}')
    reader.byte()  # orientation
    count = reader.int32()
    if not 0 <= count <= 1000:
        raise ValueError(f'implausible dock item count {count}')
    for _ in range(count):
        kind = reader.byte()
        if kind == _WIDGET_MARKER:
            reader.string()  # objectName
            reader.byte()  # flags (visible, floating)
            reader.take(16)  # pos, size, min, max -- or x, y, w, h when floating
        elif kind == _SEQUENCE_MARKER:
            reader.take(16)  # pos, size, min, max of the nested area
            _skip_dock_info(reader, depth + 1)
        else:
            raise ValueError(f'unexpected dock item marker {kind:#x}')


def decode_window_state(state_hex: str) -> WindowState:
    """
    Decode the dock areas and central widget size of a Qt 5 ``QMainWindow::saveState``.

    :param state_hex: the ``QMainWindow State`` value (hex).
    :raises ValueError: not hex, or not a QMainWindow state this reader knows.
    """
    try:
        reader = _Reader(bytes.fromhex(state_hex.strip()))
    except ValueError:
        raise ValueError('QMainWindow State is not hex') from None
    if reader.int32() != _VERSION_MARKER:
        raise ValueError('QMainWindow State does not start with the version marker')
    reader.int32()  # the application's version number
    if reader.byte() != _DOCK_WIDGET_STATE_MARKER:
        raise ValueError('QMainWindow State holds no dock layout')
    count = reader.int32()
    if not 0 <= count <= 4:
        raise ValueError(f'implausible dock area count {count}')
    docks = {}
    for _ in range(count):
        area = reader.int32()
        docks[area] = (reader.int32(), reader.int32())
        _skip_dock_info(reader)
    central = (reader.int32(), reader.int32())
    if min(central) <= 2 * HIDE_DOCK_BUTTON_PX or max(central) > 65536:
        raise ValueError(f'implausible central widget size {central}')
    return WindowState(docks, central)


def panel_size_from_window_state(state_hex: str) -> Optional[Tuple[int, int]]:
    """Render panel (W, H) px of a ``QMainWindow State`` value, or None when it does not decode."""
    try:
        return decode_window_state(state_hex).panel_size
    except ValueError:
        return None


def encode_window_state(docks: Dict[int, List[Tuple[str, int]]],
                        panel_size: Tuple[int, int], dock_depth: Dict[int, int]) -> str:
    """
    Write a Qt 5 ``QMainWindow::saveState`` with given dock panels and render panel size.

    The inverse of :func:`decode_window_state` for a simple layout: each dock
    area holds one row (top/bottom) or column (left/right) of visible,
    docked panels.  RViz names each panel's dock widget after the panel
    (``VisualizationFrame::addPanelByName``), which is how Qt's
    ``restoreState`` finds them.  No toolbar state is written (Qt keeps the
    toolbars as they are).

    :param docks: {area: [(panel name, extent px along the area), ...]},
        area 0 left, 1 right, 2 top, 3 bottom.
    :param panel_size: render panel (W, H), px.
    :param dock_depth: {area: width px of a side area / height px of a top or
        bottom area}.
    :returns: the state, lower-case hex as RViz writes it.
    """
    width, height = (int(v) for v in panel_size)
    central = (width + 2 * HIDE_DOCK_BUTTON_PX, height)
    sides = sum(dock_depth[area] + _SEPARATOR_PX for area in (0, 1) if docks.get(area))
    out = bytearray(struct.pack('>iiB', _VERSION_MARKER, 0, _DOCK_WIDGET_STATE_MARKER))
    areas = sorted(area for area, panels in docks.items() if panels)
    out += struct.pack('>i', len(areas))
    for area in areas:
        vertical = area in (0, 1)
        size = (dock_depth[area], height) if vertical else (central[0] + sides, dock_depth[area])
        out += struct.pack('>iii', area, *size)
        out += struct.pack('>BBi', _SEQUENCE_MARKER, 2 if vertical else 1, len(docks[area]))
        position = 0
        for name, extent in docks[area]:
            encoded = name.encode('utf-16-be')
            out += struct.pack('>BI', _WIDGET_MARKER, len(encoded)) + encoded
            out += struct.pack('>Biiii', 1, position, int(extent), 0, _QWIDGETSIZE_MAX)
            position += int(extent) + _SEPARATOR_PX
    out += struct.pack('>ii', *central)
    out += struct.pack('>iiii', 4, 4, 8, 8)  # corners: top to top/bottom, sides to their area
    return bytes(out).hex()


#: Width of a dock separator in Qt's default style, px.
_SEPARATOR_PX = 4

#: QWIDGETSIZE_MAX, the maximum size Qt writes for unconstrained dock items.
_QWIDGETSIZE_MAX = (1 << 24) - 1
