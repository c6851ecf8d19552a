"""
Shortest collision-free paths for a round robot on an occupancy grid.

The planner searches the grid inflated by the robot's radius
(:meth:`eye_bci_ros2.navigation.occupancy.Grid.inflate`), 8-connected
(diagonal steps cost sqrt(2) cells), for the shortest cell path, then
shortcuts it: from each kept point, the farthest later point that a straight
segment reaches over free cells only (checked every
:data:`SEGMENT_STEP_CELLS`).  The search is Dijkstra's algorithm in compiled
code (scipy.sparse.csgraph) on a graph built once per map: it finds a path as
short as A*'s (``make bench``, section "robot", checks the lengths agree), and
its time does not depend on how well a heuristic guides it: a plan across the
shipped scene takes about 12 ms (the first on a new map about 75 ms, with the
graph; ``python -m bench.robot``), a few times faster than A* in Python there.

A goal it cannot plan to raises :class:`NoPath` with the reason a user
needs (off the map, in an obstacle, too close to one for the robot, not
reachable) and nav2's planner error code for it
(:mod:`eye_bci_ros2.navigation.nav2_codes`); x, y in metres in the grid's frame.
:meth:`Plan.poses` gives the path as nav2's planners publish it: a heading on every pose
(along the path, the goal's own at the end).

The segment checks (the shortcut) index the inflated grid directly, without
:meth:`~eye_bci_ros2.navigation.occupancy.Grid.cells`'s general checks: they were two thirds
of a plan's time.
"""

from dataclasses import dataclass
import math
from typing import Optional

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from eye_bci_ros2.navigation import nav2_codes
from eye_bci_ros2.navigation.frames import wrap
from eye_bci_ros2.navigation.occupancy import Grid

#: Segment checks sample a straight move every this many cells (see
#: :data:`eye_bci_ros2.navigation.occupancy.INFLATION_MARGIN_CELLS`).
SEGMENT_STEP_CELLS = 0.25

#: The shortcut checks this many candidate segments in one numpy call.
SHORTCUT_BATCH = 16

#: A start inside the inflated obstacles (pushed there, or the drive's tracking error)
#: is moved to the nearest free cell within this many robot radii before planning.
START_SNAP_RADII = 1.0

#: nav2's codes (outside the map, occupied) for a bad start and a bad goal: a cell within
#: the robot's radius of an obstacle is "occupied" for nav2's planners too (inscribed cost).
_CODES = {'start': (nav2_codes.START_OUTSIDE_MAP, nav2_codes.START_OCCUPIED),
          'goal': (nav2_codes.GOAL_OUTSIDE_MAP, nav2_codes.GOAL_OCCUPIED)}

#: The 8 neighbours (row, col) and the cost of stepping to each, cells.
_STEPS = ((0, 1), (1, 0), (0, -1), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1))


class NoPath(ValueError):
    """
    No plan: the message says why (one line, for a user).

    :ivar code: nav2's ComputePathToPose error code for the cause
        (:mod:`eye_bci_ros2.navigation.nav2_codes`).
    """

    def __init__(self, message: str, code: int = nav2_codes.NO_VALID_PATH):
        """Keep the message and nav2's code for it."""
        super().__init__(message)
        self.code = code


@dataclass(frozen=True, eq=False)
class Plan:
    """
    A path from the start to the goal.

    :ivar points: x, y of the corners, from the start to the goal, shape (n, 2), n >= 2, m.
    """

    points: np.ndarray

    @property
    def length(self) -> float:
        """Return the path's length, m."""
        return float(np.sum(np.hypot(*np.diff(self.points, axis=0).T)))

    def poses(self, goal_yaw: float) -> np.ndarray:
        """
        Return the path with a heading on every pose, shape (n, 3): x, y m, yaw rad.

        Each corner faces along the segment that leaves it (where the robot heads from
        there), the last one the goal's heading ``goal_yaw``; a zero-length segment keeps
        the heading before it.
        """
        steps = np.diff(self.points, axis=0)
        headings = np.arctan2(steps[:, 1], steps[:, 0])
        for index in range(1, len(steps)):
            if not np.any(steps[index]):
                headings[index] = headings[index - 1]
        yaw = [wrap(float(angle)) for angle in np.append(headings, goal_yaw)]
        return np.column_stack([self.points, yaw])


class Planner:
    """
    Plans on one map for one robot radius (the graph is built once, on first use).

    :param grid: the occupancy grid (not inflated).
    :param radius_m: the robot's radius, m.
    """

    def __init__(self, grid: Grid, radius_m: float):
        """Inflate the grid by the radius."""
        self.grid = grid
        self.radius_m = float(radius_m)
        #: Where the robot's centre may be.
        self.free_space = grid.inflate(self.radius_m)
        self._graph: Optional[csr_matrix] = None

    def plan(self, start: np.ndarray, goal: np.ndarray) -> Plan:
        """
        Return a shortest collision-free path from ``start`` to ``goal``.

        :param start: x, y, m (the robot's centre).
        :param goal: x, y, m.
        :raises NoPath: the reason, e.g. 'the goal (3.00, 6.00) is inside a wall or table'.
        """
        start = np.asarray(start, dtype=float)[:2]
        goal = np.asarray(goal, dtype=float)[:2]
        self._check_point(goal, 'goal')
        self._check_point(start, 'start', snap=True)
        start_cell = self._start_cell(start)
        goal_cell = self._cell(goal)
        graph = self._graph_of_free_cells()
        cols = self.grid.shape[1]
        source, target = (self.node_of(cell) for cell in (start_cell, goal_cell))
        if source == target:
            return Plan(points=np.array([start, goal]))
        distance, previous = dijkstra(graph, indices=source, return_predecessors=True)
        if not np.isfinite(distance[target]):
            raise NoPath(f'the goal {_xy(goal)} is not reachable from {_xy(start)}: no passage '
                         f'wide enough for a robot of radius {self.radius_m:g} m',
                         nav2_codes.NO_VALID_PATH)
        chain = [target]
        while chain[-1] != source:
            chain.append(int(previous[chain[-1]]))
        cells = self._cells[np.array(chain[::-1])]
        points = self.free_space.centers(np.stack([cells // cols, cells % cols], axis=1))
        points = np.concatenate([[start], points[1:-1], [goal]])
        return Plan(points=self.shortcut(points))

    def warm(self) -> None:
        """Build the graph of the free cells now (else the first plan does)."""
        self._graph_of_free_cells()

    def shortcut(self, points: np.ndarray) -> np.ndarray:
        """Return the corners left when each straight free run is one segment, shape (m, 2)."""
        kept = [0]
        index = 0
        while index < len(points) - 1:
            index = self._reach(points, index)
            kept.append(index)
        return points[kept]

    def _reach(self, points: np.ndarray, index: int) -> int:
        """
        Return the farthest later point reached straight from ``points[index]``.

        Greedy, as a walk along the points would go: the point before the first one that
        a straight segment from ``points[index]`` cannot reach; the segments are checked
        :data:`SHORTCUT_BATCH` at a time (one numpy call each).
        """
        reach = index + 1
        while reach + 1 < len(points):
            stop = min(len(points), reach + 1 + SHORTCUT_BATCH)
            blocked = np.flatnonzero(~self._segments_free(points[index], points[reach + 1:stop]))
            if blocked.size:
                return reach + int(blocked[0])
            reach = stop - 1
        return reach

    def segment_free(self, start: np.ndarray, end: np.ndarray) -> bool:
        """Tell whether the robot's centre may move straight from ``start`` to ``end``."""
        return bool(self._segments_free(np.asarray(start, dtype=float),
                                        np.asarray(end, dtype=float).reshape(1, 2))[0])

    def _segments_free(self, start: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """
        Tell for each end whether the straight move from ``start`` to it is free, shape (k,).

        :param ends: shape (k, 2), m.  Each segment is sampled every SEGMENT_STEP_CELLS
            from ``start`` and at its end, however many are checked together.
        """
        deltas = ends - start
        lengths = np.hypot(deltas[:, 0], deltas[:, 1])
        step = SEGMENT_STEP_CELLS * self.grid.resolution
        along = np.arange(int(math.ceil(float(np.max(lengths)) / step)) + 1) * step
        # Fraction of each segment at each sample, the end repeated past it.
        fraction = (np.minimum(along[None, :], lengths[:, None])
                    / np.maximum(lengths, 1e-12)[:, None])
        # Cells as Grid.cells finds them (floor of the offset over the resolution).
        cols = np.floor((start[0] + fraction * deltas[:, :1] - self.grid.origin[0])
                        / self.grid.resolution).astype(np.intp)
        rows = np.floor((start[1] + fraction * deltas[:, 1:] - self.grid.origin[1])
                        / self.grid.resolution).astype(np.intp)
        height, width = self.grid.shape
        inside = (cols >= 0) & (rows >= 0) & (cols < width) & (rows < height)
        blocked = self.free_space.blocked[np.clip(rows, 0, height - 1),
                                          np.clip(cols, 0, width - 1)]
        return np.all(inside & ~blocked, axis=1)

    def _check_point(self, point: np.ndarray, name: str, snap: bool = False) -> None:
        outside, occupied = _CODES[name]
        if not np.all(np.isfinite(point)):
            raise NoPath(f'the {name} {_xy(point)} is not a finite position', outside)
        if not self.grid.cells(point)[1][0]:
            x0, y0, x1, y1 = self.grid.extent
            raise NoPath(f'the {name} {_xy(point)} is off the map (x in [{x0:.2f}, {x1:.2f}], '
                         f'y in [{y0:.2f}, {y1:.2f}] m)', outside)
        if not self.grid.is_free(point)[0]:
            raise NoPath(f'the {name} {_xy(point)} is inside a wall or table', occupied)
        if not self.free_space.is_free(point)[0] and not (
                snap and self._near_free(point) is not None):
            raise NoPath(f'the {name} {_xy(point)} is closer to a wall or table than the '
                         f"robot's radius {self.radius_m:g} m allows", occupied)

    def _cell(self, point: np.ndarray) -> np.ndarray:
        return self.grid.cells(point)[0][0]

    def _near_free(self, point: np.ndarray) -> Optional[np.ndarray]:
        """Return the nearest free cell within START_SNAP_RADII radii of ``point``, or None."""
        reach = int(math.ceil(START_SNAP_RADII * self.radius_m / self.grid.resolution))
        center = self._cell(point)
        rows, cols = self.grid.shape
        low = np.maximum(center - reach, 0)
        high = np.minimum(center + reach + 1, [rows, cols])
        window = ~self.free_space.blocked[low[0]:high[0], low[1]:high[1]]
        if not window.any():
            return None
        found = np.argwhere(window) + low
        return found[np.argmin(np.hypot(*(found - center).T))]

    def _start_cell(self, start: np.ndarray) -> np.ndarray:
        if self.free_space.is_free(start)[0]:
            return self._cell(start)
        return self._near_free(start)

    def node_of(self, cell: np.ndarray) -> int:
        """Return the graph's node of a free cell (row, col) (:meth:`_graph_of_free_cells`)."""
        self._graph_of_free_cells()
        return int(self._nodes[int(cell[0]), int(cell[1])])

    def _graph_of_free_cells(self) -> csr_matrix:
        """
        Return the 8-connected graph of the free cells (built on first use).

        Its nodes are the free cells only (numbered row by row: ``node_of``; ``_cells``
        holds each node's flat cell index): a third of the scene's cells are blocked, and
        Dijkstra's set-up is per node.
        """
        if self._graph is None:
            free = ~self.free_space.blocked
            rows, cols = free.shape
            self._cells = np.flatnonzero(free.ravel())
            index = np.full((rows, cols), -1, dtype=np.int64)
            index.ravel()[self._cells] = np.arange(len(self._cells))
            self._nodes = index
            sources, targets, costs = [], [], []
            for d_row, d_col in _STEPS:
                # Pairs (cell, cell + step) with both cells on the map and free.
                row_a = slice(max(0, -d_row), rows - max(0, d_row))
                col_a = slice(max(0, -d_col), cols - max(0, d_col))
                row_b = slice(max(0, d_row), rows - max(0, -d_row))
                col_b = slice(max(0, d_col), cols - max(0, -d_col))
                both = free[row_a, col_a] & free[row_b, col_b]
                sources.append(index[row_a, col_a][both])
                targets.append(index[row_b, col_b][both])
                costs.append(np.full(int(both.sum()), math.hypot(d_row, d_col)))
            self._graph = csr_matrix(
                (np.concatenate(costs), (np.concatenate(sources), np.concatenate(targets))),
                shape=(len(self._cells), len(self._cells)))
        return self._graph


def _xy(point: np.ndarray) -> str:
    return f'({point[0]:.2f}, {point[1]:.2f})'
