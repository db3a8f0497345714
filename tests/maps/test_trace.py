"""Tracing the free space: exact along cell edges, then simplified inward only.

Random grids (speckles, thin walls with gaps, diagonal walls whose cells meet at
corners, unknown areas, holes) on random origins with yaw. The references are shapely's:
the union of the cells' squares, and distances to the blocked cells' squares.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from shapely import Polygon
from shapely.geometry.base import BaseGeometry

import planners
from planners.maps import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    OccupancyMap,
    cell_centres,
    free_cells,
    scene_from_map,
    trace_free_space,
    world_to_grid,
)
from planners.maps.trace import region_cells, trace_region
from planners.scene import ScenarioError
from tests.maps import synthetic
from tests.maps.reference import blocked_space, component, sample_path, union_of_cells


@st.composite
def grids(draw, min_side: int = 3, max_side: int = 16) -> np.ndarray:
    """A random grid: a room of blocks and speckles, thin walls with gaps, a diagonal
    wall whose cells meet at their corners, unknown patches; or cell-by-cell noise."""
    rows, cols = (
        draw(st.integers(min_side, max_side)),
        draw(st.integers(min_side, max_side)),
    )
    if draw(st.integers(0, 4)) == 0:  # noise, cell by cell: pinches and specks abound
        states = st.sampled_from([FREE, FREE, FREE, OCCUPIED, UNKNOWN])
        return draw(arrays(np.uint8, (rows, cols), elements=states))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    grid = np.full((rows, cols), FREE, np.uint8)
    for _ in range(draw(st.integers(0, 6))):  # blocks, most of them clear of the edges
        h, w = rng.integers(1, 5, size=2)
        r, c = rng.integers(0, max(1, rows - 2)), rng.integers(0, max(1, cols - 2))
        grid[r : r + h, c : c + w] = OCCUPIED
    density = draw(st.sampled_from([0.0, 0.02, 0.08]))
    grid[rng.random((rows, cols)) < density] = OCCUPIED  # speckles
    if draw(st.booleans()):  # a thin wall across, with gaps
        line = rng.integers(0, cols)
        grid[:, line] = OCCUPIED
        grid[rng.integers(0, rows, size=rng.integers(0, 3)), line] = FREE
    if draw(st.booleans()):  # a diagonal wall: its cells meet at their corners only
        r0, c0 = rng.integers(0, rows), rng.integers(0, cols)
        for k in range(max(rows, cols)):
            if r0 + k < rows and c0 + k < cols:
                grid[r0 + k, c0 + k] = OCCUPIED
    for _ in range(draw(st.integers(0, 2))):  # unknown patches
        r0, c0 = rng.integers(0, rows), rng.integers(0, cols)
        grid[r0 : r0 + rng.integers(1, 4), c0 : c0 + rng.integers(1, 4)] = UNKNOWN
    if draw(st.booleans()):  # walls all round
        grid[[0, -1], :] = OCCUPIED
        grid[:, [0, -1]] = OCCUPIED
    return grid


@st.composite
def imports(draw, min_side: int = 3, max_side: int = 16):
    """A map, how to import it, and a start and goal in the start's free space.

    The start and goal are preferably cells with room for the robot around them, the
    goal as far from the start as the start's free cells go.
    """
    grid = draw(grids(min_side, max_side))
    resolution = draw(st.sampled_from([0.05, 0.1, 0.25, 1.0]))
    origin = (
        draw(st.floats(-20, 20)),
        draw(st.floats(-20, 20)),
        draw(st.sampled_from([0.0, math.pi / 2, -math.pi, 0.3, -2.0, 1e-9])),
    )
    m = OccupancyMap(grid, resolution, origin, "random.yaml", "random.pgm")
    unknown = draw(st.sampled_from(["occupied", "free"]))
    radius = draw(st.sampled_from([0.0, 0.5, 1.5]))
    free = free_cells(m, unknown)
    roomy = _roomy(free, math.ceil(radius + 0.5))
    cells = np.argwhere(roomy) if roomy.any() else np.argwhere(free)
    assume(len(cells) > 0)
    if draw(st.booleans()):  # the roomy cell nearest the lower-left corner
        start_cell = tuple(cells[int(np.argmin(cells.sum(axis=1)))])
    else:
        start_cell = tuple(cells[draw(st.integers(0, len(cells) - 1))])
    reach = component(free, start_cell)
    targets = (
        np.argwhere(reach & roomy) if (reach & roomy).any() else np.argwhere(reach)
    )
    if draw(st.integers(0, 3)):
        far = np.hypot(*(targets - start_cell).T)
        goal_cell = tuple(targets[int(np.argmax(far))])
    else:
        goal_cell = tuple(targets[draw(st.integers(0, len(targets) - 1))])

    def point_in(cell):
        fraction = [draw(st.floats(0.02, 0.98)), draw(st.floats(0.02, 0.98))]
        return cell_centres(m, [cell])[0] + (np.array(fraction) - 0.5) @ _axes(m)

    tolerance = draw(st.sampled_from([None, 0.0, 0.5, 2.0]))
    options = {
        "robot_radius": radius * resolution,
        "tolerance": None if tolerance is None else tolerance * resolution,
        "unknown": unknown,
    }
    return m, point_in(start_cell), point_in(goal_cell), options


def _roomy(free: np.ndarray, k: int) -> np.ndarray:
    """Free cells whose (2k + 1)-cell square neighbourhood is free, on the map."""
    padded = np.pad(free, k)
    out = np.ones_like(free)
    rows, cols = free.shape
    for dr in range(-k, k + 1):
        for dc in range(-k, k + 1):
            out &= padded[k + dr : k + dr + rows, k + dc : k + dc + cols]
    return out


def _imported(m: OccupancyMap, start, goal, options) -> dict:
    """``scene_from_map``, the example dropped when the only way to the goal is a pinch.

    A way through a gap where two free cells meet at a corner only, with no cell to give
    up there that keeps both sides together, is closed: that is the documented answer.
    """
    try:
        return scene_from_map(m, start, goal, **options)
    except ScenarioError as error:
        assume("meet at a corner" not in error.problem)
        raise


def _axes(m: OccupancyMap) -> np.ndarray:
    """The world vectors of one cell along a row and up a column, as rows."""
    yaw = m.origin[2]
    return m.resolution * np.array(
        [[math.cos(yaw), math.sin(yaw)], [-math.sin(yaw), math.cos(yaw)]]
    )


def _free_space(scene: dict) -> BaseGeometry:
    free = Polygon(scene["boundary"])
    holes = [Polygon(o) for o in scene["obstacles"]]
    return free.difference(shapely.union_all(holes)) if holes else free


def _blocked(m: OccupancyMap, unknown: str) -> np.ndarray:
    return ~free_cells(m, unknown)


def _pinches(region: np.ndarray) -> int:
    p = np.pad(region, 1)
    a, b, c, d = p[:-1, :-1], p[:-1, 1:], p[1:, :-1], p[1:, 1:]
    return int(((a & d & ~b & ~c) | (b & c & ~a & ~d)).sum())


# --------------------------------------------------------------------------- properties


@settings(max_examples=80)
@given(case=imports())
def test_the_free_space_is_within_the_free_cells_and_gives_up_at_most_the_tolerance(
    case,
):
    m, start, goal, options = case
    scene = _imported(m, start, goal, options)
    loaded = planners.load_scene(scene)  # boundary and obstacles are simple polygons
    assert planners.scene_problems(loaded) == []
    free = _free_space(scene)
    cell_area = m.resolution**2
    # Within the union of the cells that count as free: a subset, never more.
    allowed = union_of_cells(m, free_cells(m, options["unknown"]))
    assert free.difference(allowed).area <= 1e-9 * cell_area
    # No blocked cell's centre is in it, on its border neither.
    blocked = np.argwhere(_blocked(m, options["unknown"]))
    centres = cell_centres(m, blocked)
    assert not shapely.intersects_xy(free, centres[:, 0], centres[:, 1]).any()
    # The start and the goal are in it.
    assert shapely.intersects_xy(free, [start[0], goal[0]], [start[1], goal[1]]).all()
    # It gives up only what lies within the tolerance of the exactly traced region.
    tolerance = m.resolution if options["tolerance"] is None else options["tolerance"]
    exact = trace_free_space(
        m,
        _cell_of(m, start),
        tolerance=0.0,
        unknown=options["unknown"],
        protected=world_to_grid(m, [start, goal]),
    )
    region = union_of_cells(m, exact.region)
    lattice = _lattice(m, exact.region, 4)
    inside = shapely.contains_xy(region, lattice[:, 0], lattice[:, 1])
    depth = shapely.distance(region.boundary, shapely.points(lattice[inside]))
    deep = lattice[inside][depth > tolerance + 1e-9 * m.resolution]
    assert shapely.intersects_xy(free, deep[:, 0], deep[:, 1]).all()


def _cell_of(m: OccupancyMap, point) -> tuple[int, int]:
    u, v = np.floor(world_to_grid(m, [point])[0])
    return int(v), int(u)


def _lattice(m: OccupancyMap, cells: np.ndarray, k: int) -> np.ndarray:
    """k x k points in each cell of ``cells`` (their sub-cells' centres), world."""
    offsets = (np.arange(k) + 0.5) / k - 0.5
    du, dv = np.meshgrid(offsets, offsets)
    centres = cell_centres(m, np.argwhere(cells))
    steps = np.column_stack([du.ravel(), dv.ravel()]) @ _axes(m)
    return (centres[:, None, :] + steps[None, :, :]).reshape(-1, 2)


@settings(max_examples=80)
@given(case=imports())
def test_with_no_tolerance_the_trace_is_exactly_the_regions_cells(case):
    m, start, goal, options = case
    options = {**options, "tolerance": 0.0}
    scene = _imported(m, start, goal, options)
    protected = world_to_grid(m, [start, goal])
    space = trace_free_space(
        m,
        _cell_of(m, start),
        tolerance=0.0,
        unknown=options["unknown"],
        protected=protected,
    )
    region = space.region
    reach = component(free_cells(m, options["unknown"]), _cell_of(m, start))
    assert not (region & ~reach).any()  # only the start's free cells ...
    assert _pinches(region) == 0  # ... none meeting another at a corner only
    assert region[_cell_of(m, start)] and region[_cell_of(m, goal)]
    exact = union_of_cells(m, region)
    free = _free_space(scene)
    assert free.symmetric_difference(exact).area <= 1e-9 * m.resolution**2


@settings(max_examples=40)
@given(case=imports(min_side=8, max_side=20))
def test_planned_paths_keep_the_robots_radius_from_every_blocked_cell(case):
    m, start, goal, options = case
    scene = planners.load_scene(_imported(m, start, goal, options))
    plans = planners.plan_all(scene, ("vg", "svg", "dsb"))
    blocked = blocked_space(m, _blocked(m, options["unknown"]))
    radius = options["robot_radius"]
    for name in ("vg", "svg", "dsb"):
        path = np.asarray(plans[name].path, dtype=float)
        if len(path) == 0:
            continue
        points = sample_path(path, m.resolution / 8)
        clearance = shapely.distance(blocked, shapely.points(points)).min()
        assert clearance >= radius - 1e-6 * max(1.0, radius), (name, clearance, radius)


# --------------------------------------------------------------------------- cases


def test_a_room_with_pillars_is_a_boundary_and_an_obstacle_each():
    grid = synthetic.room(20, 30, pillars=0)
    grid[5:8, 5:9] = OCCUPIED
    grid[12:14, 20:22] = OCCUPIED
    m = OccupancyMap(grid, 0.1, (0.0, 0.0, 0.0), "room.yaml")
    scene = scene_from_map(m, (1.5, 1.5), (2.5, 1.5), tolerance=0.0)
    np.testing.assert_allclose(
        scene["boundary"], [[0.1, 0.1], [2.9, 0.1], [2.9, 1.9], [0.1, 1.9]], atol=1e-12
    )
    assert sorted(Polygon(o).area for o in scene["obstacles"]) == pytest.approx(
        [0.04, 0.12]
    )


def test_occupied_specks_are_never_dropped_nor_shrunk():
    grid = np.full((12, 12), FREE, np.uint8)
    specks = [(2, 3), (5, 5), (5, 7), (9, 2), (10, 10)]
    for cell in specks:
        grid[cell] = OCCUPIED
    m = OccupancyMap(grid, 0.05, (1.0, -1.0, 0.7), "specks.yaml")
    scene = scene_from_map(
        m, cell_centres(m, [(0, 0)])[0], cell_centres(m, [(11, 11)])[0]
    )
    assert len(scene["obstacles"]) == len(specks)
    for obstacle in scene["obstacles"]:
        assert Polygon(obstacle).area == pytest.approx(0.05**2)


def test_free_pockets_and_specks_apart_from_the_start_are_filled():
    grid = np.full((10, 10), FREE, np.uint8)
    grid[3:8, 3:8] = OCCUPIED
    grid[5, 5] = FREE  # a free pocket in the blob
    m = OccupancyMap(grid, 1.0, (0.0, 0.0, 0.0), "pocket.yaml")
    scene = scene_from_map(m, (0.5, 0.5), (9.5, 9.5), tolerance=0.0)
    assert len(scene["obstacles"]) == 1 and Polygon(scene["obstacles"][0]).area == 25.0
    with pytest.raises(ScenarioError) as info:
        scene_from_map(m, (0.5, 0.5), (5.5, 5.5))
    assert info.value.field == "goal" and "the start cannot reach" in info.value.problem


def test_a_ring_pinched_at_a_corner_gives_up_a_cell():
    # Free cells going round a blocked one, the ends of the C meeting at a corner.
    grid = np.array(
        [
            [1, 1, 1, 1, 1],
            [1, 0, 0, 1, 1],
            [1, 0, 1, 0, 1],
            [1, 0, 0, 0, 1],
            [1, 1, 1, 1, 1],
        ],
        np.uint8,
    )
    assert _pinches(component(grid == FREE, (1, 1))) == 1
    region = region_cells(grid == FREE, (1, 1))
    assert _pinches(region) == 0 and region.sum() == (grid == FREE).sum() - 1
    space = trace_region(region)
    assert Polygon(space.outer).is_valid
    assert all(Polygon(h).is_valid for h in space.holes)


def test_the_start_and_the_goal_are_never_given_up_at_a_pinch():
    grid = np.array([[0, 1], [1, 0]], np.uint8)  # two free cells meeting at a corner
    region = region_cells(grid == FREE, (0, 0), keep=[(1, 1)])
    assert region.tolist() == [[True, False], [False, False]]
    grid = np.array([[0, 0, 1], [0, 1, 0], [0, 0, 0]], np.uint8)
    region = region_cells(grid == FREE, (0, 0), keep=[(1, 2)])
    assert region[1, 2] and _pinches(region) == 0


def test_simplification_removes_staircases_and_keeps_the_start():
    # A diagonal wall drawn in steps of one cell: the trace has a corner per step.
    n = 40
    grid = np.full((n, n), FREE, np.uint8)
    for r in range(n):
        grid[r, r:] = OCCUPIED
    m = OccupancyMap(grid, 0.05, (0.0, 0.0, 0.0), "stairs.yaml")
    exact = scene_from_map(m, (0.2, 1.5), (0.1, 1.9), tolerance=0.0)
    simple = scene_from_map(m, (0.2, 1.5), (0.1, 1.9))
    assert len(exact["boundary"]) > 2 * n - 4
    assert len(simple["boundary"]) <= 6


def test_unknown_counts_as_free_only_when_asked():
    grid = np.full((6, 6), FREE, np.uint8)
    grid[:, 3] = UNKNOWN
    m = OccupancyMap(grid, 1.0, (0.0, 0.0, 0.0), "u.yaml")
    with pytest.raises(
        ScenarioError, match=r"goal: \(3.5, 0.5\) is in an unknown cell"
    ):
        scene_from_map(m, (0.5, 0.5), (3.5, 0.5))
    with pytest.raises(
        ScenarioError, match=r"goal: \(5.5, 0.5\) is in free space the start"
    ):
        scene_from_map(m, (0.5, 0.5), (5.5, 0.5))
    scene = scene_from_map(m, (0.5, 0.5), (5.5, 0.5), unknown="free")
    assert Polygon(scene["boundary"]).area == 36.0
