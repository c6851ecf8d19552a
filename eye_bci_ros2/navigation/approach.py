"""
Where the robot goes for a chosen table: an approach pose in front of it, facing it.

A pose is ``[x, y, yaw]``: metres in the map frame (the scene's ``frame_id``),
yaw in radians about z, counter-clockwise from x (the heading of the robot's
front).  The robot stands ``standoff_m`` from the table's edge (gap between
the table and its footprint), on the side that faces the room's centre when
that side is free, else on the next side that is: a place where a robot of
the given radius fits (the inflated grid) and that the robot can reach from
the rooms' doors.

For a user's own task (options that are not the shipped scene's tables),
:func:`approach_from_marker` gives the same standoff from an option's marker
pose and size, without a map: the side facing ``toward`` (e.g. the room's
centre or the robot), else the marker's +x side.
"""

import math
from typing import Dict, Optional

import numpy as np
from scipy import ndimage

from eye_bci_ros2.navigation.frames import wrap
from eye_bci_ros2.navigation.occupancy import (
    DEFAULT_RESOLUTION_M, Grid, marker_box, scene_grid)
from eye_bci_ros2.task.scene import Scene

#: Gap between a table's edge and the robot's footprint at its approach pose, m: close
#: enough to reach the table top, far enough for the map's cells (INFLATION_MARGIN_CELLS).
DEFAULT_STANDOFF_M = 0.2


def approach_candidates(center_xy: np.ndarray, yaw: float, size_xy: np.ndarray,
                        radius_m: float, standoff_m: float = DEFAULT_STANDOFF_M,
                        toward_xy: Optional[np.ndarray] = None) -> np.ndarray:
    """
    Return the four poses facing a rectangle's sides, best first, shape (4, 3).

    :param center_xy: the rectangle's centre, x, y, m.
    :param yaw: its rotation about z, rad.
    :param size_xy: its full side lengths along its own x and y, m.
    :param radius_m: the robot's radius, m.
    :param standoff_m: gap between the rectangle's edge and the robot, m.
    :param toward_xy: the sides facing this point come first; None: +x, +y, -x, -y.
    """
    center = np.asarray(center_xy, dtype=float)[:2]
    half = np.asarray(size_xy, dtype=float)[:2] / 2
    poses = []
    for side, (axis, sign) in enumerate(((0, 1), (1, 1), (0, -1), (1, -1))):
        outward = yaw + axis * math.pi / 2 + (math.pi if sign < 0 else 0.0)
        normal = np.array([math.cos(outward), math.sin(outward)])
        position = center + normal * (half[axis] + standoff_m + radius_m)
        poses.append([position[0], position[1], wrap(outward + math.pi)])
    poses = np.array(poses)
    if toward_xy is not None:
        facing = (poses[:, :2] - center) @ (np.asarray(toward_xy, dtype=float)[:2] - center)
        poses = poses[np.argsort(-facing, kind='stable')]
    return poses


def approach_from_marker(pose_xyyaw: np.ndarray, size_xy: np.ndarray, radius_m: float,
                         standoff_m: float = DEFAULT_STANDOFF_M,
                         toward_xy: Optional[np.ndarray] = None) -> np.ndarray:
    """
    Return the approach pose of an option's marker, without a map, shape (3,).

    :param pose_xyyaw: the marker's x, y (m) and yaw (rad), map frame (yaw from its
        quaternion: :func:`eye_bci_ros2.navigation.occupancy.yaw_of`).
    :param size_xy: the marker's side lengths along its x and y (its scale), m.
    :param radius_m: the robot's radius, m.
    :param standoff_m: gap between the marker's edge and the robot, m.
    :param toward_xy: face the side towards this point; None: the marker's +x side.
    """
    pose = np.asarray(pose_xyyaw, dtype=float)
    return approach_candidates(pose[:2], float(pose[2]), size_xy, radius_m, standoff_m,
                               toward_xy)[0]


def reachable_space(grid: Grid, radius_m: float, doors_xy: np.ndarray) -> Grid:
    """
    Return the free space a robot can reach: connected to a door, else the largest part.

    :param grid: the occupancy grid (not inflated).
    :param doors_xy: door centres, shape (n, 2), m (may be empty).
    :return: a grid blocked wherever the robot's centre cannot be or cannot get to.
    """
    free_space = grid.inflate(radius_m)
    labels, count = ndimage.label(~free_space.blocked, structure=np.ones((3, 3), dtype=bool))
    doors_xy = np.asarray(doors_xy, dtype=float).reshape(-1, 2)
    index, inside = free_space.cells(doors_xy)
    keep = set(labels[index[inside, 0], index[inside, 1]].tolist()) - {0}
    if not keep and count:
        keep = {int(np.argmax(np.bincount(labels.ravel())[1:])) + 1}
    return Grid(blocked=~np.isin(labels, list(keep)), resolution=grid.resolution,
                origin=grid.origin)


def scene_goals(scene: Scene, radius_m: float, standoff_m: float = DEFAULT_STANDOFF_M,
                resolution: float = DEFAULT_RESOLUTION_M) -> Dict[str, np.ndarray]:
    """
    Return each table's approach pose, ``{label: [x, y, yaw]}``, labels as on ``choice``.

    :param scene: the scene (its floor plan and tables; map frame ``scene.frame_id``).
    :param radius_m: the robot's radius, m.
    :param standoff_m: gap between a table's edge and the robot, m.
    :param resolution: of the grid the poses are checked on, m per cell.
    :raises ValueError: a table with no side where the robot fits and that it can reach.
    """
    grid = scene_grid(scene, resolution)
    doors = ([door.center for door in scene.floor_plan.doors]
             if scene.floor_plan is not None else [])
    space = reachable_space(grid, radius_m, np.array(doors))
    goals = {}
    for room in scene.rooms:
        for table in room.tables:
            box = marker_box(table.marker)
            candidates = approach_candidates(box.center, box.yaw, 2 * box.half, radius_m,
                                             standoff_m, toward_xy=room.marker.position[:2])
            fits = space.is_free(candidates[:, :2])
            if not fits.any():
                raise ValueError(
                    f'{scene.source}: {table.marker.text}: no side of the table where a robot '
                    f'of radius {radius_m:g} m fits at {standoff_m:g} m and can get to')
            goals[table.marker.text] = candidates[int(np.argmax(fits))]
    return goals
