"""An occupancy map as a scenario: the free space around the start, in the map's world.

:func:`scene_from_map` traces the free space that holds the start
(:mod:`planners.maps.trace`): its outer border becomes the scenario's ``boundary`` and
the blocked areas inside it the ``obstacles``, in world coordinates (metres, the map's
origin and yaw applied), simplified inward within ``tolerance``. The result is a
scenario mapping in the format of docs/scenario-format.md, which
:func:`planners.load_scene` reads.

:func:`default_endpoints` chooses a start and a goal for a map opened without them.
"""

from __future__ import annotations

__all__ = ["default_endpoints", "scene_from_map"]

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
from shapely import Polygon

from planners.maps.grid import (
    FREE,
    OCCUPIED,
    STATE_NAMES,
    OccupancyMap,
    contains_cells,
    grid_to_world,
    world_to_cell,
    world_to_grid,
)
from planners.maps.trace import (
    UNKNOWN_AS,
    connected_cells,
    free_cells,
    trace_free_space,
)
from planners.scene import ScenarioError, is_map_name

FloatArray = npt.NDArray[np.float64]
_DECIMALS = 12


def scene_from_map(
    occupancy_map: OccupancyMap,
    start: Sequence[float],
    goal: Sequence[float],
    *,
    robot_radius: float = 0.3,
    tolerance: float | None = None,
    unknown: str = "occupied",
    map_file: str = "",
) -> dict[str, Any]:
    """Return the scenario of the free space around ``start`` on the map.

    Parameters
    ----------
    occupancy_map
        The map (:func:`planners.maps.read_map`).
    start, goal
        World points [m]; each must lie on the map in a free cell (or an unknown one
        with ``unknown="free"``), and the goal in the start's free space.
    robot_radius
        The scenario's robot radius [m].
    tolerance
        How far [m] the simplified borders may move into the free space; default one
        cell (the map's resolution); 0 keeps the cells' exact border.
    unknown
        ``"occupied"`` (default) or ``"free"``: how unknown cells count.
    map_file
        The scenario's ``map`` key (the YAML file's name, when the scenario will lie
        beside it); ``""`` leaves the key out.

    Returns
    -------
    dict
        ``format``, ``name`` (the YAML file's name without extension), ``description``,
        ``boundary``, ``obstacles``, ``start``, ``goal``, ``robot`` (its radius) and
        ``map`` when given.

    Raises
    ------
    ScenarioError
        Field ``start`` or ``goal``: the point is off the map, in an occupied cell or an
        unknown one (the message says which cell and its state), or the goal is in free
        space the start cannot reach through free cells (4-connected).
    ValueError
        For a negative or non-finite radius or tolerance, another ``unknown``, or a
        ``map_file`` that is not a plain YAML file name.
    """
    _check_options(robot_radius, tolerance, unknown)
    if map_file and not is_map_name(map_file):
        raise ValueError(f"map_file must be a plain YAML file name, got {map_file!r}")
    source = occupancy_map.source
    start_cell = _endpoint_cell(occupancy_map, "start", start, unknown)
    goal_cell = _endpoint_cell(occupancy_map, "goal", goal, unknown)
    tolerance_m = occupancy_map.resolution if tolerance is None else tolerance
    ends = world_to_grid(occupancy_map, [start, goal])
    space = trace_free_space(
        occupancy_map,
        start_cell,
        tolerance=tolerance_m / occupancy_map.resolution,
        unknown=unknown,
        protected=ends,
        clearance=robot_radius / occupancy_map.resolution,
    )
    if not space.region[goal_cell]:
        raise ScenarioError(
            source, "goal", _unreachable(occupancy_map, start_cell, goal, unknown)
        )
    data: dict[str, Any] = {
        "format": 1,
        "name": _map_name(source),
        "description": _description(occupancy_map, unknown, tolerance_m),
        "boundary": _world_ring(occupancy_map, space.outer),
        "obstacles": [_world_ring(occupancy_map, h) for h in space.holes],
        "start": [float(v) for v in start],
        "goal": [float(v) for v in goal],
        "robot": {"radius": float(robot_radius)},
    }
    if map_file:
        data["map"] = map_file
    return data


def _unreachable(
    occupancy_map: OccupancyMap,
    start_cell: tuple[int, int],
    goal: Sequence[float],
    unknown: str,
) -> str:
    """Say why the goal's cell is not in the start's traced region."""
    connected = connected_cells(free_cells(occupancy_map, unknown), start_cell)
    cell = tuple(world_to_cell(occupancy_map, [goal])[0])
    if connected[cell]:  # the way there passed between two cells meeting at a corner
        return (
            f"{_shown(goal)} is reached from the start only through a gap where free"
            " cells meet at a corner, which the trace closes"
        )
    return (
        f"{_shown(goal)} is in free space the start cannot reach (through cells side"
        f" by side, unknown cells counted as {unknown})"
    )


def _check_options(robot_radius: float, tolerance: float | None, unknown: str) -> None:
    if unknown not in UNKNOWN_AS:
        raise ValueError(f"unknown must be one of {UNKNOWN_AS}, got {unknown!r}")
    for label, value in (("robot_radius", robot_radius), ("tolerance", tolerance)):
        if value is not None and not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{label} must be a non-negative number, got {value!r}")


def _shown(point: Sequence[float] | FloatArray) -> str:
    return f"({float(point[0]):.6g}, {float(point[1]):.6g})"


def _endpoint_cell(
    occupancy_map: OccupancyMap, field: str, point: Sequence[float], unknown: str
) -> tuple[int, int]:
    """Return the (row, col) of a start or goal, which must be free on the map."""
    xy = np.asarray(point, dtype=np.float64)
    source = occupancy_map.source
    if xy.shape != (2,) or not np.isfinite(xy).all():
        raise ScenarioError(
            source, field, f"expected a finite point [x, y], got {point!r}"
        )
    cell = world_to_cell(occupancy_map, xy)
    row, col = int(cell[0, 0]), int(cell[0, 1])
    where = f"cell (row {row}, column {col}; rows counted from the bottom)"
    if not contains_cells(occupancy_map, cell)[0]:
        raise ScenarioError(
            source,
            field,
            f"{_shown(xy)} is off the map: {where}, and the map has"
            f" {occupancy_map.rows} rows and {occupancy_map.cols} columns",
        )
    state = int(occupancy_map.cells[row, col])
    if state == OCCUPIED or (state != FREE and unknown != "free"):
        hint = (
            ""
            if state == OCCUPIED
            else " (unknown cells count as occupied unless told)"
        )
        raise ScenarioError(
            source, field, f"{_shown(xy)} is in an {STATE_NAMES[state]} {where}{hint}"
        )
    return row, col


def _file_name(source: str) -> str:
    return source.replace("\\", "/").rpartition("/")[2]


def _map_name(source: str) -> str:
    name = _file_name(source)
    stem, dot, extension = name.rpartition(".")
    return stem if dot and extension.lower() in ("yaml", "yml") else name


def _description(occupancy_map: OccupancyMap, unknown: str, tolerance: float) -> str:
    m = occupancy_map
    picture = f"{m.image_name}: " if m.image_name else ""
    return (
        f"Imported from the occupancy map {_file_name(m.source)} ({picture}{m.cols} x"
        f" {m.rows} cells of {m.resolution:g} m, {m.width:g} m x {m.height:g} m);"
        f" unknown cells counted as {unknown}; borders traced within {tolerance:g} m."
    )


def _world_ring(occupancy_map: OccupancyMap, ring: FloatArray) -> list[list[float]]:
    """Return the ring in world coordinates, to 12 decimals where it stays simple so.

    ``-1 + 12 * 0.05`` is -0.3999999999999999 in floating point; rounded it is -0.4.
    Rounding moves a vertex by less than 1e-12 m, far below any map's cell.
    """
    exact = grid_to_world(occupancy_map, ring)
    rounded = np.round(exact, _DECIMALS)
    if len(np.unique(rounded, axis=0)) == len(rounded) and Polygon(rounded).is_valid:
        return rounded.tolist()
    return exact.tolist()


def default_endpoints(
    occupancy_map: OccupancyMap,
    robot_radius: float = 0.3,
    *,
    tolerance: float | None = None,
    unknown: str = "occupied",
) -> tuple[tuple[float, float], tuple[float, float]]:
    """Choose a start and a goal for a map opened without them.

    The free space of the largest 4-connected set of free cells is traced as
    :func:`scene_from_map` traces it (same ``tolerance`` and ``unknown``), then shrunk
    by the robot's radius and half a cell (less when nothing would be left). The start
    is the centre of the largest disk inside what is left (its most open spot), the goal
    the corner of what is left farthest from the start, in a straight line. Both are
    where the robot fits, half a cell clear of the walls, whenever it fits anywhere.

    Returns
    -------
    (start, goal)
        World points [m].

    Raises
    ------
    ScenarioError
        Field ``image`` when the map has no free cell.
    """
    _check_options(robot_radius, tolerance, unknown)
    from planners.maps import _loops  # noqa: PLC0415 - numba only when a map is traced

    free = free_cells(occupancy_map, unknown)
    labels, sizes = _loops.label_components(free.astype(np.uint8))
    if len(sizes) < 2:
        raise ScenarioError(
            occupancy_map.source,
            "image",
            f"no free cell in the map (unknown cells counted as {unknown})",
        )
    largest = int(np.argmax(sizes))
    seed = np.unravel_index(int(np.argmax(labels == largest)), labels.shape)
    resolution = occupancy_map.resolution
    tolerance_cells = (resolution if tolerance is None else tolerance) / resolution
    space = trace_free_space(
        occupancy_map,
        (int(seed[0]), int(seed[1])),
        tolerance=tolerance_cells,
        unknown=unknown,
    )
    inner = _shrunk(space.polygon(), robot_radius / resolution + 0.5)
    centre = np.asarray(shapely.maximum_inscribed_circle(inner).coords[0])
    corners = shapely.get_coordinates(inner)
    far = corners[np.argmax(np.hypot(*(corners - centre).T))]
    start, goal = grid_to_world(occupancy_map, [centre, far])
    return (float(start[0]), float(start[1])), (float(goal[0]), float(goal[1]))


def _shrunk(free: shapely.Geometry, clearance: float) -> Polygon:
    """Return the largest piece of ``free`` shrunk by ``clearance`` [cells] (less if empty)."""
    for depth in (clearance, clearance / 2, 0.5, 0.0):
        shrunk = shapely.buffer(free, -depth, join_style="mitre") if depth > 0 else free
        pieces = [p for p in shapely.get_parts(shrunk) if isinstance(p, Polygon)]
        pieces = [p for p in pieces if p.area > 0]
        if pieces:
            return max(pieces, key=lambda p: p.area)
    raise ValueError("a traced free space has an area")  # pragma: no cover
