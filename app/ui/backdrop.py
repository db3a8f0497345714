"""An occupancy map drawn on the floor, under the obstacles traced from it.

A scene imported from a map (:mod:`planners.maps`) is a boundary and obstacles traced
from the map's cells; the view lays the map itself on the floor beneath them, so a person
sees that the trace follows the map. The picture shows the cells as the importer read
them (free, occupied, unknown), in the colours of map_server's pictures, and is reduced
to at most :data:`MAX_SIDE` pixels a side, a block showing its most obstructed cell, so
a thin wall never disappears from view. A small map is enlarged cell by cell to at least
:data:`MIN_SIDE` pixels: the browser smooths a picture it magnifies, and a wall's shade
would bleed a whole cell into the free floor beside it. Pure numpy: the view hands the
result to viser.
"""

from __future__ import annotations

__all__ = ["MAX_SIDE", "MIN_SIDE", "Backdrop", "backdrop_of"]

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from planners.maps import FREE, OCCUPIED, UNKNOWN, OccupancyMap, grid_to_world

MAX_SIDE = 2048
"""Largest side of the picture sent to browsers [px]: a 50 m hall at 3 cm cells is
drawn at about 2.5 cm a pixel."""
MIN_SIDE = 1024
"""Smallest longer side of the picture [px] a map is enlarged to (by whole pixels a cell)."""

_RANK = np.zeros(256, np.uint8)
_RANK[[FREE, UNKNOWN, OCCUPIED]] = (0, 1, 2)
"""Order of the states when a block of cells is one pixel: occupied shows first."""
_COLOURS = np.array([(254, 254, 254), (205, 205, 205), (0, 0, 0)], np.uint8)
"""Free, unknown, occupied by rank: map_server's own shades (map_saver writes these)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Backdrop:
    """A map's picture and where it lies on the floor."""

    rgb: npt.NDArray[np.uint8]
    """The picture, (H, W, 3), row 0 at the map's bottom (-y of the grid): viser lays an
    image's first row along its plane's -y edge, as the cells' row 0."""
    size: tuple[float, float]
    """Its width and height on the floor [m]: the map's, and a block's part beyond the
    map's last row or column when the reduction's blocks do not divide it."""
    centre: tuple[float, float]
    """The map's centre in the world [m]."""
    yaw: float
    """The map's turn [rad] (its origin's yaw)."""
    step: int
    """Cells per pixel along each side (1: one pixel a cell, or several)."""
    scale: int
    """Pixels per cell along each side, for a small map enlarged (1 otherwise)."""


def backdrop_of(
    occupancy_map: OccupancyMap, max_side: int = MAX_SIDE, min_side: int = MIN_SIDE
) -> Backdrop:
    """Return the picture of ``occupancy_map`` to lay on the floor.

    Examples
    --------
    >>> cells = np.zeros((4, 6), np.uint8)
    >>> cells[0, 0] = OCCUPIED
    >>> b = backdrop_of(OccupancyMap(cells, 0.5, (1.0, 2.0, 0.0)), max_side=3)
    >>> b.rgb.shape, b.step, b.scale, b.size, b.centre
    ((2, 3, 3), 2, 1, (3.0, 2.0), (2.5, 3.0))
    >>> b.rgb[0, 0].tolist(), b.rgb[-1, 0].tolist()  # bottom-left: the occupied cell
    ([0, 0, 0], [254, 254, 254])
    >>> backdrop_of(OccupancyMap(cells, 0.5, (1.0, 2.0, 0.0)), max_side=2).size  # 3 x 3 blocks
    (3.0, 3.0)
    """
    cells = occupancy_map.cells
    step = max(1, math.ceil(max(cells.shape) / max_side))
    ranks = _worst_of_blocks(_RANK[cells], step)
    scale = max(1, min_side // max(ranks.shape)) if step == 1 else 1
    big = np.repeat(np.repeat(ranks, scale, axis=0), scale, axis=1)
    rgb = np.ascontiguousarray(_COLOURS[big])  # row 0 stays the map's bottom row
    rows, cols = ranks.shape[0] * step, ranks.shape[1] * step  # in cells, blocks whole
    centre = grid_to_world(occupancy_map, [[cols / 2, rows / 2]])[0]
    resolution = occupancy_map.resolution
    return Backdrop(
        rgb=rgb,
        size=(cols * resolution, rows * resolution),
        centre=(float(centre[0]), float(centre[1])),
        yaw=float(occupancy_map.origin[2]),
        step=step,
        scale=scale,
    )


def _worst_of_blocks(ranks: npt.NDArray[np.uint8], step: int) -> npt.NDArray[np.uint8]:
    """Reduce ``ranks`` by ``step`` along both axes, a block taking its highest rank."""
    if step == 1:
        return ranks
    rows, cols = ranks.shape
    padded = np.zeros((-(-rows // step) * step, -(-cols // step) * step), np.uint8)
    padded[:rows, :cols] = ranks
    blocks = padded.reshape(
        padded.shape[0] // step, step, padded.shape[1] // step, step
    )
    return blocks.max(axis=(1, 3))
