"""The occupancy map as a value: its cells, where they are in the world, and the conversions.

A map is a grid of square cells of side ``resolution`` [m]. Its *grid frame* counts in
cells: cell (row r, column c) is the square ``[c, c + 1] x [r, r + 1]``, row 0 at the
bottom, so that grid coordinates (u, v) = (along a row, up the columns) grow with the
world's x and y when the map is not turned. The grid frame sits in the world at
``origin`` = (x, y, yaw), ROS map_server's ``origin``: the world position of the lower-left
corner of the lower-left cell, and the map's turn about it, counter-clockwise [rad]::

    world = (x, y) + resolution * R(yaw) @ (u, v)

A point on the line between two cells belongs to the cell above it or to its right (the
floor of its grid coordinates).
"""

from __future__ import annotations

__all__ = [
    "FREE",
    "OCCUPIED",
    "STATE_NAMES",
    "UNKNOWN",
    "OccupancyMap",
    "cell_centres",
    "contains_cells",
    "grid_to_world",
    "world_to_cell",
    "world_to_grid",
]

import dataclasses
import math

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

FREE = 0
"""A cell the robot may cross."""
OCCUPIED = 1
"""A cell with an obstacle."""
UNKNOWN = 2
"""A cell nobody saw (map_server's -1), or one between the thresholds."""
STATE_NAMES = ("free", "occupied", "unknown")
"""The states' names, by value."""


@dataclasses.dataclass(frozen=True, eq=False)
class OccupancyMap:
    """An occupancy grid in the world: what :func:`planners.maps.read_map` reads.

    Two maps are equal only when they are the same object (the cells are an array).

    Examples
    --------
    >>> cells = np.array([[FREE, OCCUPIED], [UNKNOWN, FREE]], dtype=np.uint8)
    >>> m = OccupancyMap(cells, 0.5, (1.0, 2.0, 0.0), "lab.yaml", "lab.pgm")
    >>> m.rows, m.cols, m.width, m.height
    (2, 2, 1.0, 1.0)
    """

    cells: npt.NDArray[np.uint8]
    """States (``FREE``, ``OCCUPIED``, ``UNKNOWN``), shape (rows, cols), row 0 at the
    bottom (the image's last row); read-only."""
    resolution: float
    """Side of a cell [m]."""
    origin: tuple[float, float, float]
    """(x, y, yaw): where the lower-left corner of cell (0, 0) is in the world [m], and
    the map's turn about it, counter-clockwise [rad]."""
    source: str = "<map>"
    """What to call the map in messages: its YAML file's path or name."""
    image_name: str = ""
    """The file name of the map's image."""

    def __post_init__(self) -> None:
        cells = np.asarray(self.cells)
        if cells.ndim != 2 or cells.dtype != np.uint8 or 0 in cells.shape:
            raise ValueError(
                f"cells must be a non-empty 2-D uint8 array, got {cells.dtype} {cells.shape}"
            )
        if not (math.isfinite(self.resolution) and self.resolution > 0):
            raise ValueError(f"resolution must be positive, got {self.resolution!r}")
        if len(self.origin) != 3 or not all(math.isfinite(v) for v in self.origin):
            raise ValueError(f"origin must be 3 finite numbers, got {self.origin!r}")
        cells = cells.view()
        cells.flags.writeable = False
        object.__setattr__(self, "cells", cells)
        object.__setattr__(self, "origin", tuple(float(v) for v in self.origin))

    @property
    def rows(self) -> int:
        """Number of rows (the image's height in pixels)."""
        return int(self.cells.shape[0])

    @property
    def cols(self) -> int:
        """Number of columns (the image's width in pixels)."""
        return int(self.cells.shape[1])

    @property
    def width(self) -> float:
        """Extent along the map's rows [m]."""
        return self.cols * self.resolution

    @property
    def height(self) -> float:
        """Extent along the map's columns [m]."""
        return self.rows * self.resolution


def _frame(occupancy_map: OccupancyMap) -> tuple[FloatArray, FloatArray]:
    """Return the origin (2,) and the matrix (2, 2) taking grid coordinates to the world."""
    x, y, yaw = occupancy_map.origin
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([x, y]), occupancy_map.resolution * np.array([[c, -s], [s, c]])


def grid_to_world(occupancy_map: OccupancyMap, uv: npt.ArrayLike) -> FloatArray:
    """Return world points [m] of grid coordinates ``uv`` (N, 2) [cells].

    Examples
    --------
    >>> m = OccupancyMap(np.zeros((2, 3), np.uint8), 0.5, (1.0, 2.0, np.pi / 2))
    >>> grid_to_world(m, [[0, 0], [2, 0]]).round(12).tolist()
    [[1.0, 2.0], [1.0, 3.0]]
    """
    origin, matrix = _frame(occupancy_map)
    return np.asarray(uv, dtype=np.float64).reshape(-1, 2) @ matrix.T + origin


def world_to_grid(occupancy_map: OccupancyMap, points: npt.ArrayLike) -> FloatArray:
    """Return grid coordinates [cells] (N, 2) of world points (N, 2) [m].

    Examples
    --------
    >>> m = OccupancyMap(np.zeros((2, 3), np.uint8), 0.5, (1.0, 2.0, np.pi / 2))
    >>> world_to_grid(m, [[1.0, 3.0]]).round(12).tolist()
    [[2.0, 0.0]]
    """
    origin, matrix = _frame(occupancy_map)
    xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    return np.asarray(np.linalg.solve(matrix, (xy - origin).T).T, dtype=np.float64)


def world_to_cell(occupancy_map: OccupancyMap, points: npt.ArrayLike) -> IntArray:
    """Return the (row, col) of the cell holding each world point, (N, 2).

    Rows and columns outside the map are returned as they are (negative, or beyond the
    last); :func:`contains_cells` says which are in it.

    Examples
    --------
    >>> m = OccupancyMap(np.zeros((2, 3), np.uint8), 0.5, (1.0, 2.0, 0.0))
    >>> world_to_cell(m, [[1.2, 2.7], [0.0, 0.0]]).tolist()
    [[1, 0], [-4, -2]]
    """
    uv = np.floor(world_to_grid(occupancy_map, points))
    big = float(np.iinfo(np.intp).max // 2)  # a point far away is far away, not wrapped
    return np.clip(uv[:, ::-1], -big, big).astype(np.intp)


def cell_centres(occupancy_map: OccupancyMap, cells: npt.ArrayLike) -> FloatArray:
    """Return the world centres [m] (N, 2) of cells given as (row, col) (N, 2).

    Examples
    --------
    >>> m = OccupancyMap(np.zeros((2, 3), np.uint8), 0.5, (1.0, 2.0, 0.0))
    >>> cell_centres(m, [[1, 0]]).tolist()
    [[1.25, 2.75]]
    """
    rc = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
    return grid_to_world(occupancy_map, rc[:, ::-1] + 0.5)


def contains_cells(
    occupancy_map: OccupancyMap, cells: npt.ArrayLike
) -> npt.NDArray[np.bool_]:
    """Return whether each (row, col) (N, 2) is a cell of the map."""
    rc = np.asarray(cells).reshape(-1, 2)
    return (
        (rc[:, 0] >= 0)
        & (rc[:, 0] < occupancy_map.rows)
        & (rc[:, 1] >= 0)
        & (rc[:, 1] < occupancy_map.cols)
    )
