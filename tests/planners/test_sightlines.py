"""planners.visibility.sightlines against brute force: the grid march and the disk filter."""

import dataclasses
import functools
import itertools
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from shapely import Polygon

from planners import plan_all
from planners.scene import load_scene
from planners.space.expansion import configuration_space
from planners.visibility._graphs import _inner_disks, build_border, visibility_graph
from planners.visibility.sightlines import (
    Disks,
    Edges,
    Segments,
    cover_table,
    crossings,
    edge_grid,
    inner_disks,
    march,
    occluded,
    occluded_pairs,
    sector_count,
)
from tests.conftest import random_scenes, reference_segment_free
from tests.planners.cover_reference import (
    cover_table_reference,
    occluded_pairs_reference,
)
from tests.planners.march_reference import edge_grid_reference, march_reference

EPS = 1e-9


def _lattice_points(draw, count):
    # Small integer and half-integer lattice: collinear, axis-aligned and shared points.
    coords = st.integers(0, 16).map(lambda k: k / 2.0)
    return np.array([[draw(coords), draw(coords)] for _ in range(count)], dtype=float)


@st.composite
def segments_and_edges(draw):
    edges_a = _lattice_points(draw, draw(st.integers(1, 12)))
    edges_b = _lattice_points(draw, len(edges_a))
    keep = np.any(edges_a != edges_b, axis=1)
    assume(keep.any())
    seg_a = _lattice_points(draw, draw(st.integers(1, 12)))
    seg_b = _lattice_points(draw, len(seg_a))
    # Segments of length zero too (a start on a border vertex): never crossed.
    return edges_a[keep], edges_b[keep], seg_a, seg_b


def _brute(edges, segs, count_s, count_e):
    seg, edge = (a.ravel() for a in np.indices((count_s, count_e)))
    return crossings(segs, edges, seg.astype(np.intp), edge.astype(np.intp), EPS)


MARCHES = {
    "compiled": march,
    # The numpy walk it replaced: every segment walked cell by cell (tail 0), the last
    # few walkers listed at once (2), every segment's cells listed at once (a million).
    **{
        f"reference, tail {tail}": functools.partial(
            march_reference, block=3, tail=tail
        )
        for tail in (0, 2, 1 << 20)
    },
}


@pytest.mark.parametrize("name", list(MARCHES))
@given(case=segments_and_edges())
def test_march_finds_what_testing_every_pair_finds(name, case):
    ea, eb, sa, sb = case
    edges, segs = Edges.of(ea, eb), Segments.of(sa, sb)
    crossed_seg, touch_seg, touch_t = _brute(edges, segs, len(sa), len(ea))
    crossed = np.zeros(len(sa), dtype=bool)
    crossed[crossed_seg] = True
    # Cells of every size: one cell, about one edge a cell, tiny cells.
    grid = edge_grid(ea, eb, 4 * EPS)
    marched = MARCHES[name](grid, edges, segs, EPS)
    np.testing.assert_array_equal(marched.crossed, crossed)
    # Each vertex on a segment once, as testing every pair finds it (t bit for bit).
    want = sorted(
        {(s, t) for s, t in zip(touch_seg, touch_t, strict=True) if not crossed[s]}
    )
    got = list(zip(marched.touch_seg.tolist(), marched.touch_t.tolist(), strict=True))
    assert got == [(int(s), float(t)) for s, t in want]


def _assert_same_march(grid, edges, segs, eps):
    compiled, reference = (
        march(grid, edges, segs, eps),
        march_reference(grid, edges, segs, eps),
    )
    for field in ("crossed", "touch_seg", "touch_t"):
        np.testing.assert_array_equal(
            getattr(compiled, field), getattr(reference, field), err_msg=field
        )


@settings(max_examples=40, deadline=None)
@given(scene=st.booleans().flatmap(lambda grid: random_scenes(grid=grid)))
def test_compiled_march_equals_the_numpy_walk_on_every_vertex_pair(scene):
    # Every pair of border vertices and every vertex to start and goal, as a VG from
    # scratch would march them (before its filters): crossed, touches, t bit for bit.
    cspace = configuration_space(
        scene.obstacles, scene.robot.radius, scene.expansion, scene.boundary
    )
    border = build_border(cspace)
    points = np.vstack([border.points, [scene.start, scene.goal]])
    i, j = np.triu_indices(len(points), 1)
    segs = Segments.of(points[i], points[j])
    _assert_same_march(border.grid, border.edges, segs, cspace.eps)


@pytest.mark.parametrize(
    "name", ["grid_of_rectangles", "collinear_boxes", "circle_2000"]
)
def test_compiled_march_equals_the_numpy_walk_on_collinear_and_long_borders(name):
    # Collinear edges shared by many rectangles (vertices on segments, grazing corners),
    # and a big circle (segments that cross thousands of cells); segments that start
    # outside the grid are clipped.
    if name == "circle_2000":
        k = np.arange(2000) * 2.0 * math.pi / 2000
        ring = 50.0 * np.column_stack([np.cos(k), np.sin(k)])
        rings = [ring]
    else:
        gap = 1.0 if name == "grid_of_rectangles" else 0.0
        rings = [
            np.array([[x, y], [x + 2, y], [x + 2, y + 1], [x, y + 1]], dtype=float)
            for x in np.arange(6) * (2 + gap)
            for y in np.arange(6) * 2.0
        ]
    a = np.vstack(rings)
    b = np.vstack([np.roll(r, -1, axis=0) for r in rings])
    grid, edges = edge_grid(a, b, 4 * EPS), Edges.of(a, b)
    rng = np.random.default_rng(7)
    picks = rng.integers(0, len(a), (4000, 2))
    outside = rng.uniform(-80.0, 80.0, (500, 2))
    starts = np.vstack([a[picks[:, 0]], outside])
    ends = np.vstack([a[picks[:, 1]], a[picks[:500, 1]]])
    ends[:20] = starts[:20]  # a few of length zero, at border vertices
    _assert_same_march(grid, edges, Segments.of(starts, ends), EPS)


def test_march_covers_segments_leaving_and_entering_the_grid():
    # An edge in the middle; segments from far outside the grid through it, along it and
    # past its corner.
    ea, eb = np.array([[0.0, 0.0]]), np.array([[1.0, 1.0]])
    sa = np.array([[-100.0, 1.0], [-5.0, -5.0], [2.0, 0.0], [0.5, -50.0]])
    sb = np.array([[100.0, 0.0], [5.0, 5.0], [0.0, 1.5], [0.5, -40.0]])
    marched = march(
        edge_grid(ea, eb, 4 * EPS), Edges.of(ea, eb), Segments.of(sa, sb), EPS
    )
    assert marched.crossed.tolist() == [True, False, True, False]
    # The diagonal segment runs through the edge's start, a border vertex on it.
    assert marched.touch_seg.tolist() == [1]
    np.testing.assert_allclose(marched.touch_t, [0.5])


def test_inner_disks_lie_inside_their_polygons():
    square = Polygon([(0, 0), (4, 0), (4, 4), (0, 4)])
    ring = Polygon(square.exterior, [[(1, 1), (3, 1), (3, 3), (1, 3)]])
    crescent = Polygon(
        [(0, 0), (6, 0), (6, 1), (1, 1), (1, 5), (0, 5)]
    )  # centroid outside
    disks = inner_disks([square, ring, crescent], 0.01)
    assert len(disks.radius) == 3
    # Each centre is inside its polygon and the disk does not reach the boundary.
    for shape, (x, y), r in zip(
        (square, ring, crescent), disks.center, disks.radius, strict=True
    ):
        centre = Polygon([(x - 1e-9, y - 1e-9), (x + 1e-9, y - 1e-9), (x, y + 1e-9)])
        assert shape.contains(centre)
        assert shape.boundary.distance(centre.centroid) >= r > 0


@settings(max_examples=60)
@given(scene=random_scenes(), picks=st.data())
def test_disks_flag_only_blocked_segments(scene, picks):
    plans = plan_all(scene, ("vg",))
    assume(plans["vg"].status != "invalid")
    space = plans["cspace"]
    disks = inner_disks([*space.expanded, *space.merged.geoms], 8 * space.eps)
    grid = [(x, y) for x in np.linspace(-1, 11, 13) for y in np.linspace(-1, 11, 13)]
    starts = picks.draw(st.lists(st.sampled_from(grid), min_size=1, max_size=3))
    a = np.array([s for s in starts for _ in grid], dtype=float)
    b = np.array([g for _ in starts for g in grid], dtype=float)
    runs = np.arange(0, len(a) + 1, len(grid), dtype=np.intp)
    flagged = np.flatnonzero(occluded(disks, a, b, runs))
    for k in flagged.tolist():
        assert not reference_segment_free(space, a[k], b[k]), (a[k], b[k])


def _lattice_scene(columns, rows):
    """Rectangles on a lattice with shared edge lines, plus walls: a collinear maze."""
    obstacles = []
    for i, j in itertools.product(range(columns), range(rows)):
        x, y = 1.0 + 2.0 * i, 1.0 + 2.0 * j
        w = 1.0 if (i + j) % 3 else 1.5  # some close the gap to the next column
        obstacles.append([[x, y], [x + w, y], [x + w, y + 1.0], [x, y + 1.0]])
    side_x, side_y = 2.0 * columns + 1.0, 2.0 * rows + 1.0
    return load_scene(
        {
            "format": 1,
            "boundary": [[0, 0], [side_x, 0], [side_x, side_y], [0, side_y]],
            "obstacles": obstacles,
            "start": [0.5, 0.5],
            "goal": [side_x - 0.5, side_y - 0.5],
            "robot": {"radius": 0.0},
        }
    )


def test_lattice_of_rectangles_vg_has_exactly_the_reference_edges():
    """Collinear edges across many rectangles, the grid march path (forced by size)."""
    scene = _lattice_scene(5, 4)
    space = configuration_space(
        scene.obstacles,
        0.0,
        "disk",
        scene.boundary,
        extra_points=[scene.start, scene.goal],
    )
    graph = visibility_graph(space, scene.start, scene.goal)
    nodes = list(graph.nodes)
    assert len(nodes) > 60
    for i, a in enumerate(nodes):
        for b in nodes[i + 1 :]:
            assert graph.has_edge(a, b) == reference_segment_free(space, a, b), (a, b)


def test_lattice_with_a_disk_robot_plans_the_same_length_in_vg_and_svg():
    scene = _lattice_scene(6, 5)
    scene = dataclasses.replace(
        scene, robot=dataclasses.replace(scene.robot, radius=0.2)
    )
    plans = plan_all(scene, ("vg", "svg"))
    assert plans["vg"].status == "ok"
    assert plans["svg"].length == plans["vg"].length


def test_disks_flag_a_segment_through_an_obstacle_and_not_one_past_it():
    space = configuration_space((Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), 0.0)
    disks = inner_disks([*space.expanded, *space.merged.geoms], 8 * space.eps)
    a = np.array([[-1.0, 1.0], [-1.0, 2.0], [-1.0, 2.5], [-1.0, 1.0]])
    b = np.array([[3.0, 1.0], [3.0, 2.0], [3.0, 2.1], [0.5, 1.0]])
    # Through the middle; along the top edge (free); above it; stopping short of the
    # centre (blocked, but the filter leaves that to the exact test).
    flagged = occluded(disks, a, b, np.array([0, 1, 2, 3, 4], dtype=np.intp))
    assert flagged.tolist() == [True, False, False, False]


@settings(max_examples=60)
@given(scene=random_scenes(), picks=st.data())
def test_both_ends_cover_flags_only_blocked_segments(scene, picks):
    # The lookup from j turns the direction half a turn: a wrong sector there would
    # flag a free segment, which the reference would tell.
    plans = plan_all(scene, ("vg",))
    assume(plans["vg"].status != "invalid")
    space = plans["cspace"]
    points = np.array(
        [(x, y) for x in np.linspace(-1, 11, 9) for y in np.linspace(-1, 11, 9)]
    )
    sectors = picks.draw(st.sampled_from([64, 128, 512]))
    table = cover_table(space.derive(_inner_disks), points, sectors)
    i, j = (k.ravel() for k in np.triu_indices(len(points), 1))
    flagged = np.flatnonzero(occluded_pairs(table, points, i, j))
    for k in flagged.tolist():
        assert not reference_segment_free(space, points[i[k]], points[j[k]])


def _slow_cover(disks, source, sectors):
    """Per sector, the nearest disk centre whose cone holds the whole sector (math)."""
    width = 2 * math.pi / sectors
    near = [math.inf] * sectors
    for (cx, cy), r in zip(disks.center.tolist(), disks.radius.tolist(), strict=True):
        dist = math.hypot(cx - source[0], cy - source[1])
        if dist <= r:
            continue
        half = math.asin(r / dist)
        mid = math.atan2(cy - source[1], cx - source[0]) + math.pi
        for k in range(sectors):
            # Sector k (shifted by whole turns) inside (mid - half, mid + half).
            for turn in (-2 * math.pi, 0.0, 2 * math.pi):
                lo, hi = k * width + turn, (k + 1) * width + turn
                if mid - half < lo and hi < mid + half:
                    near[k] = min(near[k], dist)
    return near


@settings(max_examples=40)
@given(
    centers=st.lists(
        st.tuples(st.floats(-5, 5), st.floats(-5, 5)), min_size=1, max_size=4
    ),
    radii=st.lists(st.floats(0.1, 2.0), min_size=4, max_size=4),
    source=st.tuples(st.floats(-6, 6), st.floats(-6, 6)),
    sectors=st.sampled_from([64, 128]),
)
def test_cover_table_matches_a_sector_by_sector_reference(
    centers, radii, source, sectors
):
    disks = Disks(np.array(centers), np.array(radii[: len(centers)]))
    got = cover_table(disks, np.array([source]), sectors)[0]
    want = _slow_cover(disks, source, sectors)
    # Sectors whose side lies within rounding of a cone's side may go either way: the
    # table must never claim more than the reference up to that, and agree elsewhere.
    for k in range(sectors):
        # The same distance up to rounding (numpy's hypot against math's), or a sector
        # on a cone's side.
        if not math.isclose(got[k], want[k], rel_tol=1e-12):
            assert _side_gap(disks, source, k, sectors) < 1e-9, (k, got[k], want[k])


def _side_gap(disks, source, k, sectors) -> float:
    """Angle [rad] between a side of sector k of ``source`` and the nearest cone side."""
    width = 2 * math.pi / sectors
    lo = k * width - math.pi
    sides = []
    for (cx, cy), r in zip(disks.center.tolist(), disks.radius.tolist(), strict=True):
        dist = math.hypot(cx - source[0], cy - source[1])
        if dist > r:
            mid = math.atan2(cy - source[1], cx - source[0])
            half = math.asin(r / dist)
            sides += [mid - half, mid + half]
    return min(
        (
            abs(math.remainder(edge - side, 2 * math.pi))
            for side in sides
            for edge in (lo, lo + width)
        ),
        default=math.inf,
    )


def _direction_gap(d, sectors) -> float:
    """Angle [rad] between direction d and the nearest side of a sector."""
    width = 2 * math.pi / sectors
    angle = math.atan2(d[1], d[0]) + math.pi
    return abs(math.remainder(angle, width))


def test_sector_count_grows_with_segments_per_start_within_bounds():
    assert [sector_count(x) for x in (0.5, 64, 100, 300, 5000)] == [
        64,
        64,
        128,
        256,
        512,
    ]


def test_a_merged_obstacle_of_one_gets_no_second_disk():
    apart = (
        Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),
        Polygon([(5, 0), (7, 0), (7, 2), (5, 2)]),
    )
    overlapping = (*apart, Polygon([(1, 1), (3, 1), (3, 3), (1, 3)]))
    assert len(_inner_disks(configuration_space(apart, 0.0)).radius) == 2
    # The first and the third merge: their union gets a disk of its own.
    assert len(_inner_disks(configuration_space(overlapping, 0.0)).radius) == 4


def _same_grid(a, b, margin):
    compiled, reference = edge_grid(a, b, margin), edge_grid_reference(a, b, margin)
    assert (compiled.nx, compiled.ny, compiled.cell) == (
        reference.nx,
        reference.ny,
        reference.cell,
    )
    np.testing.assert_array_equal(compiled.lo, reference.lo)
    np.testing.assert_array_equal(compiled.offsets, reference.offsets)
    np.testing.assert_array_equal(compiled.edges, reference.edges)


@given(case=segments_and_edges(), margin=st.sampled_from([4 * EPS, 0.05, 0.5, 3.0]))
def test_compiled_grid_lists_the_cells_numpy_listed(case, margin):
    """Every edge in the very cells, each cell's edges ascending: the grid of
    :func:`_edge_cells` sorted by cell, on lattice edges (horizontal, vertical,
    diagonal, along cell lines) with margins from eps to wider than a cell."""
    ea, eb, _, _ = case
    _same_grid(ea, eb, margin)


@settings(max_examples=25, deadline=None)
@given(scene=random_scenes(grid=True))
def test_compiled_grid_of_a_border_is_numpy_s(scene):
    """The grid of a configuration space's border, as the planners build it."""
    space = configuration_space(scene.obstacles, 0.25, boundary=scene.boundary)
    border = build_border(space)
    _same_grid(border.edge_a, border.edge_b, 4.0 * space.eps)


def test_compiled_grid_of_long_and_zero_length_edges():
    """Among a hundred short edges (small cells): a long diagonal over many cells, a
    point edge, an edge along a cell line, a vertical one."""
    x, y = np.meshgrid(np.arange(10.0), np.arange(10.0))
    short_a = np.column_stack([x.ravel() * 4, y.ravel() * 4])
    a = np.vstack([[[0.0, 0.0], [5.0, 5.0], [0.0, 2.0], [-3.0, 7.5]], short_a])
    b = np.vstack(
        [[[40.0, 13.0], [5.0, 5.0], [40.0, 2.0], [-3.0, -9.0]], short_a + 0.5]
    )
    grid = edge_grid(a, b, 4 * EPS)
    _same_grid(a, b, 4 * EPS)
    assert grid.nx * grid.ny > 50
    assert set(grid.edges.tolist()) == set(range(len(a)))
    per_edge = np.bincount(grid.edges, minlength=len(a))
    assert per_edge[0] > 10 and per_edge[1] >= 1


def _same_cover_but_on_sides(disks, points, sectors):
    """Hold the compiled cover to numpy's: equal but where an angle is within rounding.

    The compiled loops take atan2 and asin from the C library, numpy its own arctan2,
    which can differ in the last bit: a sector whose side is within rounding of a cone's
    side may be covered in one and not the other, and a direction within rounding of a
    sector's side may be looked up in either sector. Only a filter: the exact test
    decides what it does not flag.
    """
    table = cover_table(disks, points, sectors)
    want = cover_table_reference(disks, points, sectors)
    for s, k in np.argwhere(table != want).tolist():
        assert _side_gap(disks, points[s], k, sectors) < 1e-12, (s, k)
    i, j = (k.ravel() for k in np.triu_indices(len(points), 1))
    # Both lookups on one table: a direction within rounding of a sector's side alone
    # may be looked up in the other sector.
    got = occluded_pairs(want, points, i, j)
    for m in np.flatnonzero(got != occluded_pairs_reference(want, points, i, j)):
        assert _direction_gap(points[j[m]] - points[i[m]], sectors) < 1e-12, m
    return got


@settings(max_examples=60, deadline=None)
@given(scene=random_scenes(), picks=st.data())
def test_compiled_cover_is_numpys_table_and_flags(scene, picks):
    # Sources on a lattice (some inside disks, some on a disk's axis), on the scene's
    # vertices, and the disks' own centres; every sector count the planners use.
    space = configuration_space(
        scene.obstacles, scene.robot.radius, scene.expansion, scene.boundary
    )
    disks = space.derive(_inner_disks)
    lattice = [(x, y) for x in np.linspace(-1, 11, 7) for y in np.linspace(-1, 11, 7)]
    points = np.vstack(
        [lattice, space.derive(build_border).points, disks.center]
    ).astype(np.float64)
    sectors = picks.draw(st.sampled_from([64, 128, 256, 512]))
    _same_cover_but_on_sides(disks, points, sectors)


def test_compiled_cover_on_sector_sides_and_axes():
    # Directions exactly along the axes and the diagonals, where the sector is decided
    # by a rounding, and a cone whose side is a sector's side (from (3, 3), the disk at
    # (2, 0): numpy's arctan2 and the C library's differ by an ulp there).
    disks = Disks(
        np.array([[2.0, 0.0], [0.0, 3.0], [-1.0, -1.0]]), np.array([1.0, 0.5, 2**0.5])
    )
    points = np.array(
        [[0.0, 0.0], [4.0, 0.0], [0.0, 5.0], [-3.0, -3.0], [3.0, 3.0], [1.0, 0.0]]
    )
    for sectors in (64, 128, 512):
        flags = _same_cover_but_on_sides(disks, points, sectors)
        assert flags[0]  # (0, 0) -> (4, 0) passes through the disk at (2, 0)
