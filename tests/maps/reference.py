"""Slow, obviously-correct references for the maps: map_server's loop, cells as squares.

- :func:`map_server_value` is ROS 1 map_server's ``loadMapFromFile`` loop body
  (``map_server/src/image_loader.cpp``, ros-planning/navigation noetic) for one pixel,
  line for line in Python floats (the same float64 operations as the C++ doubles);
- :func:`state_of_value` reads the value as docs/maps.md says;
- :func:`cell_squares` and :func:`union_of_cells` are cells as shapely squares in the
  world, one polygon per cell, united by shapely.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import shapely
from shapely import Polygon
from shapely.geometry.base import BaseGeometry

from planners.maps import FREE, OCCUPIED, UNKNOWN, OccupancyMap, grid_to_world


def map_server_value(  # noqa: PLR0917
    channels: list[int],
    has_alpha: bool,
    mode: str,
    negate: bool,
    occ_th: float,
    free_th: float,
) -> int:
    """One pixel's OccupancyGrid value, as map_server's loop computes it (signed byte)."""
    n_channels = len(channels)
    # if (mode==TRINARY || !img->format->Amask) avg_channels = n_channels; else n - 1
    if mode == "trinary" or not has_alpha:
        avg_channels = n_channels
    else:
        avg_channels = n_channels - 1
    color_sum = 0
    for k in range(avg_channels):
        color_sum += channels[k]
    color_avg = color_sum / float(avg_channels)
    alpha = 1 if n_channels == 1 else channels[n_channels - 1]
    if negate:
        color_avg = 255 - color_avg
    if mode == "raw":
        value = int(color_avg)  # unsigned char value = color_avg (>= 0: cut = floor)
        return value - 256 if value > 127 else value  # stored in an int8 array
    occ = (255 - color_avg) / 255.0
    if occ > occ_th:
        return 100
    if occ < free_th:
        return 0
    if mode == "trinary" or alpha < 1.0:
        return -1
    ratio = (occ - free_th) / (occ_th - free_th)
    return int(99 * ratio)


def state_of_value(value: int, mode: str, occ_th: float, free_th: float) -> int:
    """The cell's state for map_server's value (docs/maps.md, "How pixels are read")."""
    if value == 0:
        return FREE
    if value == 100:
        return OCCUPIED
    if mode == "raw" and 0 < value < 100:
        if value / 100.0 > occ_th:
            return OCCUPIED
        if value / 100.0 < free_th:
            return FREE
    return UNKNOWN


def cell_squares(occupancy_map: OccupancyMap, cells: np.ndarray) -> list[Polygon]:
    """The world squares of cells given as (row, col) rows."""
    out = []
    for r, c in np.asarray(cells).reshape(-1, 2):
        corners = [(c, r), (c + 1, r), (c + 1, r + 1), (c, r + 1)]
        out.append(Polygon(grid_to_world(occupancy_map, corners)))
    return out


def union_of_cells(occupancy_map: OccupancyMap, mask: np.ndarray) -> BaseGeometry:
    """The union of the squares of the cells where ``mask`` is true (world)."""
    squares = cell_squares(occupancy_map, np.argwhere(mask))
    return shapely.union_all(squares) if squares else Polygon()


def blocked_space(occupancy_map: OccupancyMap, blocked: np.ndarray) -> BaseGeometry:
    """The blocked cells' squares and everything off the map (within a wide frame)."""
    rows, cols = blocked.shape
    margin = 4 + max(rows, cols)
    frame = Polygon(
        grid_to_world(
            occupancy_map,
            [
                (-margin, -margin),
                (cols + margin, -margin),
                (cols + margin, rows + margin),
                (-margin, rows + margin),
            ],
        ),
        holes=[
            grid_to_world(occupancy_map, [(0, 0), (cols, 0), (cols, rows), (0, rows)])
        ],
    )
    return shapely.union_all([frame, union_of_cells(occupancy_map, blocked)])


def component(free: np.ndarray, seed: tuple[int, int]) -> np.ndarray:
    """The free cells 4-connected to ``seed``: a breadth-first search, cell by cell."""
    rows, cols = free.shape
    seen = np.zeros_like(free, dtype=bool)
    if not free[seed]:
        return seen
    queue = [seed]
    seen[seed] = True
    while queue:
        r, c = queue.pop()
        for rr, cc in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
            if 0 <= rr < rows and 0 <= cc < cols and free[rr, cc] and not seen[rr, cc]:
                seen[rr, cc] = True
                queue.append((rr, cc))
    return seen


def sample_path(path: np.ndarray, step: float) -> np.ndarray:
    """Points along a polyline no farther apart than ``step``, its vertices included."""
    points = [path[:1]]
    for a, b in itertools.pairwise(path):
        k = max(1, math.ceil(float(np.hypot(*(b - a))) / step))
        t = np.linspace(0.0, 1.0, k + 1)[1:, None]
        points.append(a + t * (b - a))
    return np.concatenate(points)
