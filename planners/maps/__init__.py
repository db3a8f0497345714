"""ROS map_server occupancy maps, imported as scenarios (docs/maps.md).

- :mod:`planners.maps.grid`: the :class:`OccupancyMap` value (cells ``FREE``,
  ``OCCUPIED``, ``UNKNOWN``, row 0 at the bottom) and its world <-> cell conversions;
- :mod:`planners.maps.metadata`: the map's YAML file, checked key by key;
- :mod:`planners.maps.pixels`: the picture, decoded within bounds and read pixel by pixel
  as map_server reads it;
- :mod:`planners.maps.reading`: :func:`read_map` (from disk) and :func:`read_map_bytes`
  (from memory: a browser's upload never reaches the filesystem);
- :mod:`planners.maps.trace`: the free space as polygons, traced exactly along cell edges
  and simplified inward (free space may shrink by the tolerance, never grow);
- :mod:`planners.maps.importing`: :func:`scene_from_map` (a scenario mapping in the map's
  world coordinates) and :func:`default_endpoints`;
- ``_loops``: the compiled loops of the trace (numba, loaded on first use).

Every bad input raises :class:`planners.scene.ScenarioError` naming the map and the field.

>>> import numpy as np
>>> from planners.maps import FREE, OCCUPIED, OccupancyMap, scene_from_map
>>> cells = np.full((5, 6), FREE, np.uint8)
>>> cells[2, 2:4] = OCCUPIED
>>> room = OccupancyMap(cells, 0.5, (0.0, 0.0, 0.0), "room.yaml", "room.pgm")
>>> scene = scene_from_map(room, (0.25, 0.25), (2.75, 2.25), robot_radius=0.0)
>>> scene["boundary"], scene["obstacles"]
([[0.0, 0.0], [3.0, 0.0], [3.0, 2.5], [0.0, 2.5]], [[[1.0, 1.0], [1.0, 1.5], [2.0, 1.5], [2.0, 1.0]]])
"""

from __future__ import annotations

__all__ = [
    "FREE",
    "MAP_MODES",
    "MAX_PIXELS",
    "OCCUPIED",
    "STATE_NAMES",
    "UNKNOWN",
    "FreeSpace",
    "MapMetadata",
    "OccupancyMap",
    "Picture",
    "blocked_islands",
    "cell_centres",
    "cell_states",
    "contains_cells",
    "decode_picture",
    "default_endpoints",
    "free_cells",
    "grid_to_world",
    "map_metadata",
    "occupancy_values",
    "read_map",
    "read_map_bytes",
    "scene_from_map",
    "trace_free_space",
    "warm_up",
    "world_to_cell",
    "world_to_grid",
]

from planners.maps.grid import (
    FREE,
    OCCUPIED,
    STATE_NAMES,
    UNKNOWN,
    OccupancyMap,
    cell_centres,
    contains_cells,
    grid_to_world,
    world_to_cell,
    world_to_grid,
)
from planners.maps.importing import default_endpoints, scene_from_map
from planners.maps.metadata import MAP_MODES, MapMetadata, map_metadata
from planners.maps.pixels import (
    MAX_PIXELS,
    Picture,
    cell_states,
    decode_picture,
    occupancy_values,
)
from planners.maps.reading import read_map, read_map_bytes
from planners.maps.trace import (
    FreeSpace,
    blocked_islands,
    free_cells,
    trace_free_space,
)


def warm_up() -> None:
    """Compile the trace's loops once (or load them from numba's cache)."""
    from planners.maps import _loops  # noqa: PLC0415 - numba only when asked

    _loops.warm_up()
