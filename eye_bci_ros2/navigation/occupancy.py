"""
The scene's floor plan and tables as obstacles, and as an occupancy grid.

Frame: the scene's ``frame_id`` (the map frame), x and y in metres.  The grid
follows nav2's map_server (nav_msgs/OccupancyGrid): row-major, row 0 at the
bottom (smallest y), column 0 at the left (smallest x); ``origin`` is the
lower-left corner of cell (0, 0); a cell is 0 (free) or 100 (occupied).

A cell is occupied when an obstacle comes within half its diagonal of the
cell's centre (the obstacle touches the cell's circumscribed circle), so every
point of an obstacle lies within ``resolution * sqrt(2) / 2`` of an occupied
cell's centre.  :meth:`Grid.inflate` keeps a robot's centre out of the cells
where its footprint could touch an obstacle (see :data:`INFLATION_MARGIN_CELLS`).
"""

from dataclasses import dataclass
import math
from typing import Optional, Tuple

import numpy as np
from scipy import ndimage

from eye_bci_ros2.task.scene import CubeMarker, FloorPlan, Scene, wall_coordinates

#: Cell values, as map_server publishes them.
FREE = 0
OCCUPIED = 100

#: Default grid resolution, m per cell (map_server's usual 0.05).
DEFAULT_RESOLUTION_M = 0.05

#: How far beyond the robot's radius a free cell's centre stays from every occupied
#: cell's centre, in cells.  Any point of a free cell is within sqrt(2)/2 cells of its
#: centre, and any obstacle within sqrt(2)/2 cells of an occupied cell's centre; 1.6 > 2 *
#: 0.707 leaves 0.19 cells for the path checks, which sample segments every 1/4 cell
#: (:data:`eye_bci_ros2.navigation.planner.SEGMENT_STEP_CELLS`): a robot whose centre stays
#: on free cells and on checked segments keeps at least its radius from every obstacle.
INFLATION_MARGIN_CELLS = 1.6

#: Without a floor plan, the map reaches this far beyond the rooms and tables, m.
OPEN_MARGIN_M = 1.0


@dataclass(frozen=True, eq=False)
class Box:
    """
    A table seen from above: a rectangle.

    :ivar center: x, y, shape (2,), m.
    :ivar yaw: rotation about z, rad.
    :ivar half: half side lengths along the box's own x and y, shape (2,), m.
    :ivar label: the table's label (its marker text).
    """

    center: np.ndarray
    yaw: float
    half: np.ndarray
    label: str = ''

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Return each point's distance to the rectangle, shape (n,), m (0 inside)."""
        local = _rotate(np.asarray(points, dtype=float) - self.center, -self.yaw)
        outside = np.maximum(np.abs(local) - self.half, 0.0)
        return np.hypot(outside[:, 0], outside[:, 1])


@dataclass(frozen=True, eq=False)
class Obstacles:
    """
    What a robot must keep away from: wall pieces (doors cut out) and tables.

    :ivar walls: wall pieces, shape (n, 4): x0, y0, x1, y1, m, each a rectangle
        ``wall_thickness`` thick, centred on its segment, with flat ends.
    :ivar wall_thickness: m.
    :ivar boxes: the tables.
    :ivar bounds: the mapped area, x_min, y_min, x_max, y_max, m.
    """

    walls: np.ndarray
    wall_thickness: float
    boxes: Tuple[Box, ...]
    bounds: Tuple[float, float, float, float]

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """
        Return each point's distance to the nearest obstacle, m (0 on or inside one).

        :param points: x, y, shape (n, 2), m.
        :return: shape (n,).
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        nearest = np.full(len(points), np.inf)
        for box in self.wall_boxes() + self.boxes:
            nearest = np.minimum(nearest, box.distance(points))
        return nearest

    def wall_boxes(self) -> Tuple[Box, ...]:
        """Return the wall pieces as rectangles: flat ends, so a door is as wide as said."""
        return tuple(Box(center=(wall[:2] + wall[2:]) / 2,
                         yaw=math.atan2(wall[3] - wall[1], wall[2] - wall[0]),
                         half=np.array([np.hypot(*(wall[2:] - wall[:2])) / 2,
                                        self.wall_thickness / 2]))
                     for wall in self.walls)


@dataclass(frozen=True, eq=False)
class Grid:
    """
    An occupancy grid (see the module doc for its conventions).

    :ivar blocked: shape (rows, cols), True where occupied.
    :ivar resolution: m per cell.
    :ivar origin: x, y of the lower-left corner of cell (0, 0), shape (2,), m.
    """

    blocked: np.ndarray
    resolution: float
    origin: np.ndarray

    @property
    def shape(self) -> Tuple[int, int]:
        """Return (rows, cols): (height, width) in cells."""
        return self.blocked.shape

    @property
    def extent(self) -> Tuple[float, float, float, float]:
        """Return the mapped area x_min, y_min, x_max, y_max, m."""
        rows, cols = self.shape
        return (float(self.origin[0]), float(self.origin[1]),
                float(self.origin[0] + cols * self.resolution),
                float(self.origin[1] + rows * self.resolution))

    def cells(self, points: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """
        Return the cell of each point and whether it lies on the map.

        :param points: x, y, shape (n, 2), m.
        :return: (row, col) indices, shape (n, 2) (clipped onto the map), and
            on-map flags, shape (n,) (False also for NaN).
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        scaled = (points - self.origin) / self.resolution
        with np.errstate(invalid='ignore'):
            finite = np.all(np.isfinite(scaled), axis=1)
            index = np.floor(np.where(finite[:, None], scaled, 0.0)).astype(int)[:, ::-1]
        rows, cols = self.shape
        inside = finite & (index[:, 0] >= 0) & (index[:, 0] < rows) & (index[:, 1] >= 0) & (
            index[:, 1] < cols)
        return np.clip(index, 0, [rows - 1, cols - 1]), inside

    def centers(self, cells: np.ndarray) -> np.ndarray:
        """Return the centres of cells (row, col), shape (n, 2) -> x, y, shape (n, 2), m."""
        cells = np.asarray(cells).reshape(-1, 2)
        return self.origin + (cells[:, ::-1] + 0.5) * self.resolution

    def is_free(self, points: np.ndarray) -> np.ndarray:
        """Return whether each point lies on a free cell of the map, shape (n,)."""
        index, inside = self.cells(points)
        return inside & ~self.blocked[index[:, 0], index[:, 1]]

    def values(self) -> np.ndarray:
        """Return the cells as map_server sends them: int8 0/100, row-major, shape (rows*cols,)."""
        return np.where(self.blocked, OCCUPIED, FREE).astype(np.int8).ravel()

    def inflate(self, radius_m: float) -> 'Grid':
        """
        Return the grid of where a robot of radius ``radius_m`` may put its centre.

        A cell stays free when every occupied cell's centre is more than
        ``radius_m + INFLATION_MARGIN_CELLS * resolution`` from its centre.
        """
        distance = ndimage.distance_transform_edt(~self.blocked) * self.resolution
        return Grid(blocked=distance <= radius_m + INFLATION_MARGIN_CELLS * self.resolution,
                    resolution=self.resolution, origin=self.origin)


def scene_obstacles(scene: Scene) -> Obstacles:
    """Return the scene's walls (doors cut out) and tables as obstacles."""
    boxes = tuple(marker_box(table.marker) for room in scene.rooms for table in room.tables)
    plan = scene.floor_plan
    if plan is not None:
        walls = cut_doors(plan)
        half = plan.wall_thickness / 2
        corners = np.concatenate([plan.walls[:, :2], plan.walls[:, 2:]])
        low, high = corners.min(axis=0) - half, corners.max(axis=0) + half
        return Obstacles(walls=walls, wall_thickness=plan.wall_thickness, boxes=boxes,
                         bounds=(*low, *high))
    # No walls: an open floor around the rooms and tables.
    points = [box.center + sign * np.hypot(*box.half) for box in boxes for sign in (-1, 1)]
    points += [np.array(room.area[i:i + 2]) for room in scene.rooms if room.area is not None
               for i in (0, 2)]
    points += [room.marker.position[:2] for room in scene.rooms]
    points = np.array(points)
    low, high = points.min(axis=0) - OPEN_MARGIN_M, points.max(axis=0) + OPEN_MARGIN_M
    return Obstacles(walls=np.zeros((0, 4)), wall_thickness=0.0, boxes=boxes,
                     bounds=(*low, *high))


def marker_box(marker: CubeMarker) -> Box:
    """Return a table marker's footprint: its x, y sides about its yaw."""
    return Box(center=np.array(marker.position[:2], dtype=float),
               yaw=yaw_of(marker.orientation), half=np.array(marker.scale[:2]) / 2,
               label=marker.text)


def yaw_of(quaternion: np.ndarray) -> float:
    """Return the rotation about z of a quaternion (x, y, z, w), rad."""
    x, y, z, w = (float(v) for v in quaternion)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def cut_doors(plan: FloorPlan) -> np.ndarray:
    """
    Return the wall pieces left when the doors are cut out, shape (m, 4).

    Each door removes ``width`` of the wall it lies on, centred on its centre
    (the scene parser has checked that it lies within one wall).
    """
    pieces = []
    for wall in plan.walls:
        start, end = wall[:2], wall[2:]
        length = float(np.hypot(*(end - start)))
        gaps = []
        for door in plan.doors:
            along, across, _ = wall_coordinates(wall, door.center)
            if abs(across) <= plan.wall_thickness / 2 and -1e-9 <= along <= length + 1e-9:
                gaps.append((along - door.width / 2, along + door.width / 2))
        position = 0.0
        for gap_start, gap_end in sorted(gaps) + [(length, length)]:
            if gap_start > position:
                pieces.append(np.concatenate([start + (end - start) * position / length,
                                              start + (end - start) * gap_start / length]))
            position = max(position, gap_end)
    return np.array(pieces).reshape(-1, 4)


def rasterise(obstacles: Obstacles, resolution: float = DEFAULT_RESOLUTION_M) -> Grid:
    """
    Return the occupancy grid of ``obstacles`` (see the module doc).

    The map covers ``obstacles.bounds`` and one cell more on every side.

    :param resolution: m per cell, > 0.
    """
    if not (resolution > 0 and math.isfinite(resolution)):
        raise ValueError(f'map resolution must be > 0 m, got {resolution!r}')
    low = np.array(obstacles.bounds[:2]) - resolution
    size = np.array(obstacles.bounds[2:]) + resolution - low
    cols, rows = (int(n) for n in np.ceil(size / resolution - 1e-9))
    grid = Grid(blocked=np.zeros((rows, cols), dtype=bool), resolution=float(resolution),
                origin=low)
    row, col = np.indices((rows, cols))
    centers = grid.centers(np.stack([row.ravel(), col.ravel()], axis=1))
    touched = obstacles.clearance(centers) <= resolution * math.sqrt(2) / 2
    return Grid(blocked=touched.reshape(rows, cols), resolution=grid.resolution, origin=low)


def scene_grid(scene: Scene, resolution: float = DEFAULT_RESOLUTION_M) -> Grid:
    """Return the occupancy grid of a scene's floor plan and tables."""
    return rasterise(scene_obstacles(scene), resolution)


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    """Rotate points (n, 2) by ``angle`` rad about the origin."""
    cos, sin = math.cos(angle), math.sin(angle)
    return points @ np.array([[cos, sin], [-sin, cos]])


def room_of(scene: Scene, point: np.ndarray) -> Optional[str]:
    """Return the label of the room whose area holds ``point`` (x, y), or None."""
    for room in scene.rooms:
        if room.area is not None and (room.area[0] <= point[0] <= room.area[2]
                                      and room.area[1] <= point[1] <= room.area[3]):
            return room.marker.text
    return None
