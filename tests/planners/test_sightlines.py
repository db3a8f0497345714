"""planners.sightlines against brute force: the grid march and the disk filter (issue 15)."""

import dataclasses
import itertools

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from shapely import Polygon

from planners import plan_all
from planners.expansion import configuration_space
from planners.scene import load_scene
from planners.sightlines import (
    Edges,
    Segments,
    crossings,
    edge_grid,
    inner_disks,
    march,
    occluded,
)
from planners.visibility import visibility_graph
from tests.conftest import random_scenes, reference_segment_free

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
    keep_s = np.any(seg_a != seg_b, axis=1)
    assume(keep_s.any())
    return edges_a[keep], edges_b[keep], seg_a[keep_s], seg_b[keep_s]


def _brute(edges, segs, count_s, count_e):
    seg, edge = (a.ravel() for a in np.indices((count_s, count_e)))
    return crossings(segs, edges, seg.astype(np.intp), edge.astype(np.intp), EPS)


@given(segments_and_edges())
def test_march_finds_what_testing_every_pair_finds(case):
    ea, eb, sa, sb = case
    edges, segs = Edges.of(ea, eb), Segments.of(sa, sb)
    crossed_seg, touch_seg, touch_t = _brute(edges, segs, len(sa), len(ea))
    crossed = np.zeros(len(sa), dtype=bool)
    crossed[crossed_seg] = True
    # Cells of every size: one cell, about one edge a cell, tiny cells.
    grid = edge_grid(ea, eb, 4 * EPS)
    marched = march(grid, edges, segs, EPS, block=3)
    np.testing.assert_array_equal(marched.crossed, crossed)
    # Each vertex on a segment once, as testing every pair finds it (t bit for bit).
    want = sorted(
        {(s, t) for s, t in zip(touch_seg, touch_t, strict=True) if not crossed[s]}
    )
    got = list(zip(marched.touch_seg.tolist(), marched.touch_t.tolist(), strict=True))
    assert got == [(int(s), float(t)) for s, t in want]


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
