"""
The choice-menu scene: rooms, their tables and camera views, from YAML.

Pure Python + numpy (no rclpy).  A scene file (see ``config/scene.yaml``)
holds::

    frame_id: map                 # optional, default 'map'
    overview: {eye: [x, y, z], focus: [x, y, z], up: [x, y, z]}
    rooms:
      - name: kitchen
        area: [x_min, y_min, x_max, y_max]   # optional, for drawings only
        marker: {position: [x, y, z], orientation: [x, y, z, w],
                 scale: [sx, sy, sz], color: [r, g, b, a]}
        view: {eye: ..., focus: ..., up: ...}
        tables:
          - name: table_1
            marker: {...}
    floor_plan:                   # optional: the walls the robot drives among
      wall_thickness: 0.1         # m, > 0
      walls: [[x0, y0, x1, y1], ...]                 # segments, m
      doors: [{center: [x, y], width: w}, ...]       # gaps cut in the walls

Units are metres in the world frame ``frame_id``; quaternions are ordered
x, y, z, w and must be unit length (within 1e-3); ``orientation`` defaults
to identity and ``color`` to opaque grey.  Labels (the markers' ``text``)
are derived from the names: ``'kitchen'`` for a room,
``'kitchen/table_1'`` for a table.  Any problem raises ``ValueError`` naming
the file, the line and the offending key.
"""

from dataclasses import dataclass
import os
from typing import Any, Dict, Optional, Tuple

import numpy as np
import yaml

from eye_bci_ros2.projection import geometry

#: File name of the default scene inside config/.
DEFAULT_SCENE_NAME = 'scene.yaml'

#: Allowed deviation of a quaternion's length from 1.
QUATERNION_TOLERANCE = 1e-3

#: Colour of a marker whose ``color`` is not given: opaque grey (r, g, b, a).
DEFAULT_COLOR = (0.6, 0.6, 0.6, 1.0)

_REQUIRED = object()


@dataclass(frozen=True, eq=False)
class View:
    """
    An RViz camera view, as RViz's orbit/animated view controllers hold it.

    :ivar eye: camera position, shape (3,), world frame, m.
    :ivar focus: point looked at, shape (3,), world frame, m.
    :ivar up: world direction that appears upwards on the screen, shape (3,).
    """

    eye: np.ndarray
    focus: np.ndarray
    up: np.ndarray

    def external(self) -> np.ndarray:
        """Return the External (world -> optical camera), shape (4, 4)."""
        return geometry.look_at(self.eye, self.focus, self.up)

    def as_tuple(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(eye, focus, up)``."""
        return self.eye, self.focus, self.up


@dataclass(frozen=True, eq=False)
class CubeMarker:
    """
    A thin cube marker offered as a choice.

    :ivar text: label of the choice (what ``choice`` reports).
    :ivar position: centre, shape (3,), world frame, m.
    :ivar orientation: quaternion x, y, z, w, shape (4,), unit length.
    :ivar scale: full side lengths, shape (3,), m, all > 0.
    :ivar color: r, g, b, a in [0, 1], shape (4,).
    """

    text: str
    position: np.ndarray
    orientation: np.ndarray
    scale: np.ndarray
    color: np.ndarray


@dataclass(frozen=True, eq=False)
class Table:
    """A table in a room: its name and marker (label ``room/table``)."""

    name: str
    marker: CubeMarker


@dataclass(frozen=True, eq=False)
class Room:
    """
    A room: its marker in the overview, its zoomed view and its tables.

    :ivar area: floor rectangle (x_min, y_min, x_max, y_max), m, or None;
        only for drawings.
    """

    name: str
    marker: CubeMarker
    view: View
    tables: Tuple[Table, ...]
    area: Optional[Tuple[float, float, float, float]] = None

    def table(self, label: str) -> Optional[Table]:
        """Return the table whose marker text is ``label``, or None."""
        return next((t for t in self.tables if t.marker.text == label), None)


@dataclass(frozen=True, eq=False)
class Door:
    """
    A gap in a wall.

    :ivar center: centre of the gap on its wall's centre line, shape (2,), m.
    :ivar width: width of the gap along the wall, m, > 0.
    """

    center: np.ndarray
    width: float


@dataclass(frozen=True, eq=False)
class FloorPlan:
    """
    The walls of the rooms, as a robot's map is drawn from them (eye_bci_ros2.navigation).

    :ivar wall_thickness: every wall's thickness, m, centred on its segment.
    :ivar walls: wall segments before the doors are cut, shape (n, 4): x0, y0, x1, y1, m.
    :ivar doors: gaps, each on one wall (checked when parsed).
    """

    wall_thickness: float
    walls: np.ndarray
    doors: Tuple[Door, ...]


@dataclass(frozen=True, eq=False)
class Scene:
    """
    The whole menu: an overview with rooms, each with its own view and tables.

    :ivar frame_id: world frame of every coordinate.
    :ivar source: where it was loaded from (for messages).
    """

    frame_id: str
    overview: View
    rooms: Tuple[Room, ...]
    source: str = '<string>'
    floor_plan: Optional['FloorPlan'] = None

    @property
    def room_labels(self) -> Tuple[str, ...]:
        """Return the labels of the rooms, in file order."""
        return tuple(room.marker.text for room in self.rooms)

    def room(self, label: str) -> Optional[Room]:
        """Return the room whose marker text is ``label``, or None."""
        return next((r for r in self.rooms if r.marker.text == label), None)


def load_scene(path) -> Scene:
    """
    Load and validate a scene file.

    :param path: path of the YAML file.
    :raises ValueError: unreadable file, malformed YAML or an invalid scene;
        the message names the file, line and key.
    """
    path = os.fspath(path)
    try:
        with open(path, encoding='utf-8') as stream:
            text = stream.read()
    except OSError as error:
        raise ValueError(f'cannot read scene file {path}: {error.strerror or error}') from None
    return parse_scene(text, path)


def parse_scene(text: str, source: str = '<string>') -> Scene:
    """
    Parse and validate a scene from YAML text.

    :param text: the YAML document.
    :param source: name used in error messages (the file path).
    :raises ValueError: malformed YAML or an invalid scene.
    """
    try:
        document = yaml.load(text, Loader=_LocatingLoader)  # a SafeLoader: no arbitrary objects
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        where = f'{source}:{mark.line + 1}' if mark is not None else source
        problem = error.problem or error.context or 'invalid YAML'
        raise ValueError(f'{where}: malformed YAML: {problem}') from None
    except yaml.YAMLError as error:
        raise ValueError(f'{source}: malformed YAML: {error}') from None
    return _Parser(source).scene(document)


class _LocatedDict(dict):
    """A YAML mapping that remembers the line of itself and of each value."""

    line = 0
    lines: Dict[Any, int]


class _LocatedList(list):
    """A YAML sequence that remembers the line of itself and of each item."""

    line = 0
    lines: list


class _LocatingLoader(yaml.SafeLoader):
    """SafeLoader whose mappings and sequences carry 1-based line numbers."""


def _construct_mapping(loader: _LocatingLoader, node: yaml.MappingNode) -> _LocatedDict:
    loader.flatten_mapping(node)
    mapping = _LocatedDict()
    mapping.line = node.start_mark.line + 1
    mapping.lines = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        if key in mapping:
            raise yaml.constructor.ConstructorError(
                None, None, f'duplicate key {key!r}', key_node.start_mark)
        mapping[key] = loader.construct_object(value_node, deep=True)
        mapping.lines[key] = value_node.start_mark.line + 1
    return mapping


def _construct_sequence(loader: _LocatingLoader, node: yaml.SequenceNode) -> _LocatedList:
    sequence = _LocatedList(loader.construct_object(item, deep=True) for item in node.value)
    sequence.line = node.start_mark.line + 1
    sequence.lines = [item.start_mark.line + 1 for item in node.value]
    return sequence


_LocatingLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG,
                                _construct_mapping)
_LocatingLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG,
                                _construct_sequence)


class _Parser:
    """Turn the located YAML tree into a :class:`Scene`, or a located ValueError."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, line: int, key: str, problem: str) -> None:
        where = f'{self.source}:{line}' if line else self.source
        raise ValueError(f'{where}: {key}: {problem}')

    def mapping(self, value, line: int, key: str) -> _LocatedDict:
        if not isinstance(value, dict):
            self.fail(line, key, f'expected a mapping, got {_kind(value)}')
        return value

    def field(self, mapping: _LocatedDict, name: str, key: str, default=_REQUIRED):
        """Return ``mapping[name]`` and its line; missing and no default: error."""
        if name not in mapping:
            if default is not _REQUIRED:
                return default, mapping.line
            self.fail(mapping.line, key, f"missing key '{name}'")
        return mapping[name], mapping.lines.get(name, mapping.line)

    def unknown_keys(self, mapping: _LocatedDict, allowed: Tuple[str, ...], key: str) -> None:
        extra = [k for k in mapping if k not in allowed]
        if extra:
            self.fail(mapping.lines.get(extra[0], mapping.line), key,
                      f"unknown key '{extra[0]}' (allowed: {', '.join(allowed)})")

    def vector(self, value, line: int, key: str, length: int) -> np.ndarray:
        if not isinstance(value, list) or len(value) != length or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            self.fail(line, key, f'expected a list of {length} numbers, got {value!r}')
        array = np.array(value, dtype=float)
        if not np.all(np.isfinite(array)):
            self.fail(line, key, f'contains NaN or infinite values: {value!r}')
        return array

    def name(self, value, line: int, key: str) -> str:
        if not isinstance(value, str) or not value.strip():
            self.fail(line, key, f'expected a non-empty name, got {value!r}')
        if '/' in value or value != value.strip():
            self.fail(line, key, f"name {value!r} must not contain '/' or surrounding spaces")
        return value

    def scene(self, document) -> Scene:
        if document is None:
            self.fail(0, 'scene', 'the file is empty')
        top = self.mapping(document, 1, 'scene')
        self.unknown_keys(top, ('frame_id', 'overview', 'rooms', 'floor_plan'), 'scene')
        frame_id, line = self.field(top, 'frame_id', 'scene', default=geometry.WORLD_FRAME)
        if not isinstance(frame_id, str) or not frame_id.strip():
            self.fail(line, 'frame_id', f'expected a frame name, got {frame_id!r}')
        overview = self.view(*self.field(top, 'overview', 'scene'), 'overview')
        rooms_value, line = self.field(top, 'rooms', 'scene')
        if not isinstance(rooms_value, list) or not rooms_value:
            self.fail(line, 'rooms', 'expected a non-empty list of rooms')
        rooms = tuple(self.room(item, rooms_value.lines[i], f'rooms[{i}]')
                      for i, item in enumerate(rooms_value))
        self.unique([room.name for room in rooms], rooms_value, 'rooms')
        plan_value, line = self.field(top, 'floor_plan', 'scene', default=None)
        floor_plan = None if plan_value is None else self.floor_plan(plan_value, line)
        return Scene(frame_id=frame_id, overview=overview, rooms=rooms, source=self.source,
                     floor_plan=floor_plan)

    def floor_plan(self, value, line: int) -> FloorPlan:
        key = 'floor_plan'
        mapping = self.mapping(value, line, key)
        self.unknown_keys(mapping, ('wall_thickness', 'walls', 'doors'), key)
        thickness, line = self.field(mapping, 'wall_thickness', key)
        if isinstance(thickness, bool) or not isinstance(thickness, (int, float)) or not (
                0 < thickness < 10):
            self.fail(line, f'{key}.wall_thickness',
                      f'expected a thickness in (0, 10) m, got {thickness!r}')
        walls_value, line = self.field(mapping, 'walls', key)
        if not isinstance(walls_value, list) or not walls_value:
            self.fail(line, f'{key}.walls', 'expected a non-empty list of [x0, y0, x1, y1]')
        walls = np.array([self.vector(item, walls_value.lines[i], f'{key}.walls[{i}]', 4)
                          for i, item in enumerate(walls_value)])
        for i, wall in enumerate(walls):
            if np.hypot(*(wall[2:] - wall[:2])) < thickness:
                self.fail(walls_value.lines[i], f'{key}.walls[{i}]',
                          f'a wall shorter than its thickness: {walls_value[i]!r}')
        doors_value, line = self.field(mapping, 'doors', key, default=[])
        if not isinstance(doors_value, list):
            self.fail(line, f'{key}.doors', 'expected a list of {center: [x, y], width: w}')
        doors = tuple(self.door(item, doors_value.lines[i], f'{key}.doors[{i}]', walls,
                                float(thickness))
                      for i, item in enumerate(doors_value))
        return FloorPlan(wall_thickness=float(thickness), walls=walls, doors=doors)

    def door(self, value, line: int, key: str, walls: np.ndarray, thickness: float) -> Door:
        mapping = self.mapping(value, line, key)
        self.unknown_keys(mapping, ('center', 'width'), key)
        center = self.vector(*self.field(mapping, 'center', key), f'{key}.center', 2)
        width, width_line = self.field(mapping, 'width', key)
        if isinstance(width, bool) or not isinstance(width, (int, float)) or not width > 0:
            self.fail(width_line, f'{key}.width', f'expected a width > 0 m, got {width!r}')
        for wall in walls:
            along, across, length = wall_coordinates(wall, center)
            if (abs(across) <= thickness / 2 and along - width / 2 >= -1e-9
                    and along + width / 2 <= length + 1e-9):
                return Door(center=center, width=float(width))
        self.fail(mapping.line, key, f'the door at {list(center)!r}, {width!r} m wide, does '
                  'not lie within one wall (centre on its centre line, the gap inside it)')

    def unique(self, names, items: _LocatedList, key: str) -> None:
        seen = set()
        for i, name in enumerate(names):
            if name in seen:
                self.fail(items.lines[i], f'{key}[{i}].name', f'duplicate name {name!r}')
            seen.add(name)

    def view(self, value, line: int, key: str) -> View:
        mapping = self.mapping(value, line, key)
        self.unknown_keys(mapping, ('eye', 'focus', 'up'), key)
        eye, focus, up = (self.vector(*self.field(mapping, name, key), f'{key}.{name}', 3)
                          for name in ('eye', 'focus', 'up'))
        try:
            geometry.look_at(eye, focus, up)
        except ValueError as error:
            self.fail(mapping.line, key, str(error))
        return View(eye=eye, focus=focus, up=up)

    def marker(self, value, line: int, key: str, text: str) -> CubeMarker:
        mapping = self.mapping(value, line, key)
        self.unknown_keys(mapping, ('position', 'orientation', 'scale', 'color'), key)
        position = self.vector(*self.field(mapping, 'position', key), f'{key}.position', 3)
        value, line = self.field(mapping, 'orientation', key, default=[0.0, 0.0, 0.0, 1.0])
        orientation = self.vector(value, line, f'{key}.orientation', 4)
        norm = float(np.linalg.norm(orientation))
        if abs(norm - 1.0) > QUATERNION_TOLERANCE:
            self.fail(line, f'{key}.orientation',
                      f'quaternion (x, y, z, w) {value!r} has length {norm:.6g}, expected 1')
        scale = self.vector(*self.field(mapping, 'scale', key), f'{key}.scale', 3)
        if np.any(scale <= 0):
            self.fail(mapping.lines['scale'], f'{key}.scale',
                      f'side lengths must be positive, got {mapping["scale"]!r}')
        value, line = self.field(mapping, 'color', key, default=list(DEFAULT_COLOR))
        color = self.vector(value, line, f'{key}.color', 4)
        if np.any((color < 0) | (color > 1)):
            self.fail(line, f'{key}.color', f'r, g, b, a must be in [0, 1], got {value!r}')
        return CubeMarker(text=text, position=position, orientation=orientation / norm,
                          scale=scale, color=color)

    def room(self, value, line: int, key: str) -> Room:
        mapping = self.mapping(value, line, key)
        self.unknown_keys(mapping, ('name', 'area', 'marker', 'view', 'tables'), key)
        name = self.name(*self.field(mapping, 'name', key), f'{key}.name')
        marker = self.marker(*self.field(mapping, 'marker', key), f'{key}.marker', name)
        view = self.view(*self.field(mapping, 'view', key), f'{key}.view')
        area_value, area_line = self.field(mapping, 'area', key, default=None)
        area = None
        if area_value is not None:
            area = self.vector(area_value, area_line, f'{key}.area', 4)
            if area[0] >= area[2] or area[1] >= area[3]:
                self.fail(area_line, f'{key}.area',
                          f'expected [x_min, y_min, x_max, y_max], got {area_value!r}')
            area = tuple(float(v) for v in area)
        tables_value, tables_line = self.field(mapping, 'tables', key)
        if not isinstance(tables_value, list) or not tables_value:
            self.fail(tables_line, f'{key}.tables', 'expected a non-empty list of tables')
        tables = []
        for i, item in enumerate(tables_value):
            table_key = f'{key}.tables[{i}]'
            table = self.mapping(item, tables_value.lines[i], table_key)
            self.unknown_keys(table, ('name', 'marker'), table_key)
            table_name = self.name(*self.field(table, 'name', table_key), f'{table_key}.name')
            tables.append(Table(name=table_name, marker=self.marker(
                *self.field(table, 'marker', table_key), f'{table_key}.marker',
                f'{name}/{table_name}')))
        self.unique([t.name for t in tables], tables_value, f'{key}.tables')
        return Room(name=name, marker=marker, view=view, tables=tuple(tables), area=area)


def _kind(value) -> str:
    """Name a YAML value's type for messages."""
    if value is None:
        return 'nothing'
    if isinstance(value, dict):
        return 'a mapping'
    if isinstance(value, list):
        return 'a list'
    return f'{type(value).__name__} {value!r}'


def wall_coordinates(wall: np.ndarray, point: np.ndarray) -> Tuple[float, float, float]:
    """
    Return where ``point`` lies relative to a wall segment.

    :param wall: x0, y0, x1, y1, m, shape (4,).
    :param point: x, y, m, shape (2,).
    :return: (distance along the wall from its start, signed distance across it, its length).
    """
    start, end = wall[:2], wall[2:]
    length = float(np.hypot(*(end - start)))
    direction = (end - start) / length
    offset = np.asarray(point, dtype=float) - start
    return (float(offset @ direction), float(direction[0] * offset[1] - direction[1] * offset[0]),
            length)
