import contextlib
import dataclasses
import itertools
import math

import numpy as np
import pytest
import shapely
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from shapely import Polygon

from planners import load_scene, plan_all
from planners.space.expansion import configuration_space
from planners.visibility import _graphs as visibility
from planners.visibility import (
    segments_free,
    shortest_path,
    simplified_visibility_graph,
    visibility_graph,
)
from tests.conftest import (
    SCENARIOS,
    random_scenes,
    reference_segment_free,
    reference_shortest_length,
    scene_dict,
    square,
)
from tests.planners.astar_reference import assert_same_search

SQRT2 = math.sqrt(2)


def plan(obstacles, start, goal, **kw):
    return plan_all(load_scene(scene_dict(obstacles, start, goal, **kw)))


def both(obstacles, start, goal, **kw):
    plans = plan(obstacles, start, goal, **kw)
    return plans["vg"], plans["svg"]


# --------------------------------------------------------------------------- by hand


def test_straight_line_when_nothing_is_in_the_way():
    vg, svg = both([], (0, 0), (3, 4))
    assert vg.status == svg.status == "ok"
    assert vg.length == svg.length == 5.0
    assert_allclose(vg.path, [[0, 0], [3, 4]])


def test_around_a_square_by_hand():
    vg, svg = both([square(0, 0, 2, 2).exterior.coords[:-1]], (-1, 1), (3, 1))
    assert vg.length == pytest.approx(2 * SQRT2 + 2, abs=1e-12)
    assert svg.length == pytest.approx(vg.length, abs=1e-12)
    assert vg.path.shape == (4, 2)


def test_expanded_square_by_hand():
    # Square expansion of [0,2]^2 by 0.5 is [-0.5,2.5]^2: from (-1,1) over a corner.
    vg, _ = both(
        [square(0, 0, 2, 2).exterior.coords[:-1]],
        (-1, 1),
        (3, 1),
        radius=0.5,
        expansion="square",
    )
    assert vg.length == pytest.approx(2 * math.hypot(0.5, 1.5) + 3, abs=1e-12)


def test_disk_expansion_path_hugs_tangent_edges():
    # Around a point-like triangle the path length approaches the exact arc path from above.
    vg, svg = both(
        [[(0, -0.01), (0.01, 0.01), (-0.01, 0.01)]], (-2, 0), (2, 0), radius=1.0
    )
    exact = (
        2 * math.sqrt(3) + math.pi / 3
    )  # two tangents of length sqrt(3) + a 60-degree arc
    assert exact < vg.length < exact * 1.01
    assert svg.length == pytest.approx(vg.length, rel=1e-12)


def test_counts_by_hand():
    space = configuration_space((square(0, 0, 1, 1),), 0.0)
    vg = visibility_graph(space, (-1, 0.5), (2, 0.5))
    svg = simplified_visibility_graph(space, (-1, 0.5), (2, 0.5))
    # 4 sides + 2 from the start + 2 from the goal; diagonals and start-goal are blocked.
    assert vg.number_of_edges() == 8
    assert svg.number_of_edges() == 8


def test_svg_has_fewer_edges_than_vg():
    vg, svg = both(
        [
            square(0, 0, 1, 1).exterior.coords[:-1],
            square(3, 0, 4, 1).exterior.coords[:-1],
        ],
        (-1, 3),
        (5, -2),
    )
    assert svg.edges < vg.edges
    assert svg.length == pytest.approx(vg.length, rel=1e-12)


# --------------------------------------------------------------------------- degenerate geometry


def test_collinear_vertices_along_the_path():
    row = [square(x, 0, x + 1, 1).exterior.coords[:-1] for x in (0, 2, 4)]
    vg, svg = both(row, (-1, 0), (6, 0))
    assert vg.length == svg.length == 7.0
    assert vg.path.shape == (2, 2)  # straight along the three bottom edges


def test_collinear_vertices_inside_one_polygon():
    # A rectangle with extra vertices on its bottom edge.
    rect = [(0, 0), (1, 0), (2, 0), (3, 0), (3, 1), (0, 1)]
    vg, svg = both([rect], (-1, -1), (4, 2))
    assert vg.length == pytest.approx(math.hypot(4, 1) + math.hypot(1, 2), abs=1e-12)
    assert svg.length == pytest.approx(vg.length, abs=1e-12)


def test_path_grazing_a_vertex():
    # The line y = -x touches the square's corner (0, 0) and nothing else.
    vg, svg = both([square(0, 0, 1, 1).exterior.coords[:-1]], (-1, 1), (1, -1))
    assert vg.length == svg.length == pytest.approx(2 * SQRT2, abs=1e-12)


def test_line_through_two_vertices_crosses_the_interior():
    # The line x + y = 1 passes through (1, 0) and (0, 1): between them it is a diagonal.
    space = configuration_space((square(0, 0, 1, 1),), 0.0)
    assert not segments_free(space, [[-1, 2]], [[2, -1]])[0]
    vg, _ = both([square(0, 0, 1, 1).exterior.coords[:-1]], (-1, 2), (2, -1))
    assert vg.length > 3 * SQRT2


@pytest.mark.parametrize(
    ("start", "goal", "length"),
    [
        ((0.5, 0), (0.5, -1), 1.0),  # start on an edge, leaving outward
        ((0, 0), (-1, -1), SQRT2),  # start on a vertex
        ((1, 0.5), (3, 0.5), 2.0),  # start on an edge
        ((0, 0.5), (0, 1), 0.5),  # start and goal on the same edge
        ((0, 0), (1, 1), 2.0),  # opposite corners: along the border, not through
    ],
)
def test_start_or_goal_on_an_obstacle_border_is_valid(start, goal, length):
    vg, svg = both([square(0, 0, 1, 1).exterior.coords[:-1]], start, goal)
    assert vg.status == svg.status == "ok"
    assert vg.length == pytest.approx(length, abs=1e-12)
    assert svg.length == pytest.approx(length, abs=1e-12)


def test_start_on_the_shrunk_boundary_is_valid():
    room = square(0, 0, 4, 4).exterior.coords[:-1]
    vg, svg = both([], (0.5, 2), (3.5, 2), radius=0.5, boundary=room)
    assert vg.status == "ok" and vg.length == pytest.approx(3.0)
    assert svg.length == pytest.approx(3.0)


def test_start_equals_goal():
    vg, svg = both([square(0, 0, 1, 1).exterior.coords[:-1]], (2, 2), (2, 2))
    assert vg.status == svg.status == "ok"
    assert vg.length == svg.length == 0.0
    assert vg.path.shape == (1, 2)


def test_obstacles_touching_at_a_corner_let_the_point_pass_the_pinch():
    a, b = (
        square(0, 0, 1, 1).exterior.coords[:-1],
        square(1, 1, 2, 2).exterior.coords[:-1],
    )
    vg, svg = both([a, b], (0, 2), (2, 0))
    assert vg.length == svg.length == pytest.approx(2 * SQRT2)


def test_obstacles_sharing_an_edge_merge():
    a, b = (
        square(0, 0, 1, 1).exterior.coords[:-1],
        square(1, 0, 2, 1).exterior.coords[:-1],
    )
    vg, svg = both([a, b], (-1, 0.5), (3, 0.5))
    # No slit between them: around the merged 2 x 1 block.
    assert vg.length == pytest.approx(2 * math.hypot(1, 0.5) + 2, abs=1e-12)
    assert svg.length == pytest.approx(vg.length, abs=1e-12)


def test_overlapping_obstacles():
    a, b = (
        square(0, 0, 2, 2).exterior.coords[:-1],
        square(1, 1, 3, 3).exterior.coords[:-1],
    )
    vg, svg = both([a, b], (-1, 3), (4, 0))
    reference = reference_shortest_length(
        plan([a, b], (-1, 3), (4, 0))["cspace"], (-1, 3), (4, 0)
    )
    assert vg.length == pytest.approx(reference, abs=1e-12)
    assert svg.length == pytest.approx(reference, abs=1e-12)


@pytest.mark.parametrize("which", ["start", "goal"])
def test_inside_an_obstacle_is_invalid_and_names_it(which):
    obstacles = [
        square(0, 0, 1, 1).exterior.coords[:-1],
        square(3, 0, 4, 1).exterior.coords[:-1],
    ]
    points: dict[str, tuple[float, float]] = {"start": (-1, -1), "goal": (5, 5)}
    points[which] = (3.5, 0.5)
    for result in plan(obstacles, points["start"], points["goal"]).values():
        if hasattr(result, "status"):
            assert result.status == "invalid"
            assert result.reason == f"the {which} is inside obstacle 2"
            assert result.length is None and result.path.shape == (0, 2)


def test_inside_the_expanded_obstacle_names_the_radius():
    plans = plan(
        [square(0, 0, 1, 1).exterior.coords[:-1]], (1.2, 0.5), (3, 3), radius=0.3
    )
    assert plans["vg"].status == "invalid"
    assert (
        "inside obstacle 1 (expanded by the robot's radius 0.3 m)" in plans["vg"].reason
    )


def test_outside_the_boundary_is_invalid():
    room = square(0, 0, 4, 4).exterior.coords[:-1]
    plans = plan([], (0.2, 2), (3, 2), radius=0.3, boundary=room)
    assert plans["vg"].status == "invalid"
    assert (
        plans["vg"].reason
        == "the start is outside the boundary (shrunk by the robot's radius)"
    )


def test_enclosed_goal_is_unreachable_with_a_reason():
    walls = [
        square(0, 0, 3, 0.5),
        square(2.5, 0, 3, 3),
        square(0, 2.5, 3, 3),
        square(0, 0, 0.5, 3),
    ]
    plans = plan([w.exterior.coords[:-1] for w in walls], (-1, -1), (1.5, 1.5))
    for name in ("vg", "svg"):
        assert plans[name].status == "unreachable"
        assert plans[name].path.shape == (0, 2) and plans[name].length is None
        assert (
            plans[name].reason
            == "the goal is enclosed by obstacles 1, 2, 3, 4 (merged after expansion)"
        )


def test_gap_closed_by_expansion_is_unreachable():
    # Two obstacles 0.5 apart, inside walls: radius 0.3 closes the only passage.
    room = square(0, 0, 6, 4).exterior.coords[:-1]
    wall_a = square(2.8, -1, 3.2, 1.75).exterior.coords[:-1]
    wall_b = square(2.8, 2.25, 3.2, 5).exterior.coords[:-1]
    assert (
        both([wall_a, wall_b], (1, 2), (5, 2), boundary=room, radius=0.2)[0].status
        == "ok"
    )
    vg, svg = both([wall_a, wall_b], (1, 2), (5, 2), boundary=room, radius=0.3)
    assert vg.status == svg.status == "unreachable"


@pytest.mark.parametrize("offset", [0.0, 1e4, -3.7e4])
def test_large_coordinates_give_the_same_answer(offset):
    shift = np.array([offset, offset])
    obstacles = [square(0, 0, 2, 2), Polygon([(3, -1), (5, 0), (4, 2)])]
    moved = [np.asarray(o.exterior.coords[:-1]) + shift for o in obstacles]
    vg, svg = both(
        moved, np.array([-1, 1]) + shift, np.array([6, 1]) + shift, radius=0.25
    )
    base, _ = both(
        [o.exterior.coords[:-1] for o in obstacles], (-1, 1), (6, 1), radius=0.25
    )
    assert vg.length == pytest.approx(base.length, rel=1e-9)
    assert svg.length == pytest.approx(base.length, rel=1e-9)


def test_pocket_start_exits_through_the_mouth():
    u = [(5, 2), (8, 2), (8, 6), (5, 6), (5, 5), (7, 5), (7, 3), (5, 3)]
    vg, svg = both([u], (6, 4), (9, 4))
    reference = reference_shortest_length(
        plan([u], (6, 4), (9, 4))["cspace"], (6, 4), (9, 4)
    )
    assert vg.length == pytest.approx(reference, abs=1e-12)
    assert svg.length == pytest.approx(reference, abs=1e-12)


def test_pocket_with_an_inner_convex_vertex_is_kept_by_the_svg():
    # A spiral-like pocket: the path must wrap around a convex vertex that lies inside
    # the obstacle's convex hull, which the chapter's hull-only wording would miss.
    # A pocket opening left, with a tooth hanging from its ceiling.
    spiral = [
        (0, 0),
        (5, 0),
        (5, 4),
        (0, 4),
        (0, 3),
        (1.8, 3),
        (1.8, 2),
        (2.2, 2),
        (2.2, 3),
        (4, 3),
        (4, 1),
        (0, 1),
    ]
    assume_valid = Polygon(spiral)
    assert assume_valid.is_valid
    vg, svg = both([spiral], (3.0, 2.8), (-1, 3.5))
    assert vg.status == "ok"
    assert svg.length == pytest.approx(vg.length, abs=1e-12)
    hull = assume_valid.convex_hull
    assert isinstance(hull, Polygon)
    inner_bends = [
        p for p in svg.path[1:-1] if hull.exterior.distance(shapely.Point(p)) > 1e-9
    ]
    assert inner_bends, "the shortest path bends at vertices inside the hull"


# --------------------------------------------------------------------------- shipped scenarios


def test_every_shipped_scenario_vg_equals_svg_and_reference(scenario_path):
    scene = load_scene(scenario_path)
    for mode in ("disk", "square"):
        plans = plan_all(dataclasses.replace(scene, expansion=mode))
        vg, svg = plans["vg"], plans["svg"]
        assert vg.status == svg.status
        reference = reference_shortest_length(plans["cspace"], scene.start, scene.goal)
        if reference is None:
            assert vg.status == "unreachable"
        else:
            assert vg.length == pytest.approx(reference, rel=1e-12)
            assert svg.length == pytest.approx(reference, rel=1e-12)
            assert svg.edges < vg.edges


def test_narrow_gap_scenario_disk_passes_square_blocks():
    scene = load_scene(
        next(
            p
            for p in __import__("tests.conftest").conftest.SCENARIOS
            if "gap" in p.stem
        )
    )
    assert plan_all(dataclasses.replace(scene, expansion="disk"))["vg"].status == "ok"
    assert (
        plan_all(dataclasses.replace(scene, expansion="square"))["vg"].status
        == "unreachable"
    )


# --------------------------------------------------------------------------- properties


@contextlib.contextmanager
def candidate_search(kind):
    """Force how segment/edge candidates are found: small scenes use the dense box test.

    Every plan_all without a memo builds its configuration space afresh, so nothing
    computed with the other search answers inside the block.
    """
    saved = visibility._DENSE_LIMIT
    visibility._DENSE_LIMIT = {"dense": 10**12, "grid": 0}[kind]
    try:
        yield
    finally:
        visibility._DENSE_LIMIT = saved


def _edge_set(graph):
    return {frozenset(e) for e in graph.edges}


def _check_against_reference(scene):
    plans = plan_all(scene)
    vg, svg = plans["vg"], plans["svg"]
    assume(vg.status != "invalid")
    space = plans["cspace"]
    # The planner searches its graph as arrays; networkx's A* on the same graph (built
    # from them) finds the very same path.
    for result in (vg, svg):
        if math.dist(scene.start, scene.goal) > space.eps:  # else one node, no search
            found = shortest_path(result.graph, scene.start, scene.goal)
            assert (found is None) == (result.status == "unreachable")
            if found is not None:
                np.testing.assert_array_equal(found[0], result.path)
                assert found[1] == result.length
        assert result.graph.number_of_nodes() == result.nodes
        assert result.graph.number_of_edges() == result.edges
    reference = reference_shortest_length(space, scene.start, scene.goal)
    if reference is None:
        assert vg.status == svg.status == "unreachable"
        return
    assert vg.status == svg.status == "ok"
    assert vg.length == pytest.approx(reference, rel=1e-9, abs=1e-9)
    assert svg.length == pytest.approx(vg.length, rel=1e-9, abs=1e-9)
    assert vg.length >= math.dist(scene.start, scene.goal) - 1e-12
    # No segment of either path, and no VG edge, enters an obstacle's interior.
    for path in (vg.path, svg.path):
        for a, b in itertools.pairwise(path):
            assert reference_segment_free(space, a, b)
    for a, b in vg.graph.edges:
        assert reference_segment_free(space, a, b)
    assert svg.edges <= vg.edges
    # The edge grid used on large scenes finds exactly the same graphs.
    for kind in ("dense", "grid"):
        with candidate_search(kind):
            assert _edge_set(
                visibility_graph(space, scene.start, scene.goal)
            ) == _edge_set(vg.graph)
            assert _edge_set(
                simplified_visibility_graph(space, scene.start, scene.goal)
            ) == _edge_set(svg.graph)


@settings(max_examples=60, deadline=None)
@given(scene=st.booleans().flatmap(lambda grid: random_scenes(grid=grid)))
def test_compiled_search_settles_what_the_python_loop_settled(scene):
    # Node by node, with parents and costs bit for bit: what Explain shows of the search.
    plans = plan_all(scene, ("vg", "svg"))
    for name in ("vg", "svg"):
        if plans[name].status != "invalid":
            assert_same_search(plans[name].arrays)


def test_compiled_search_settles_what_the_python_loop_settled_on_scenarios():
    for path in SCENARIOS:
        plans = plan_all(load_scene(path), ("vg", "svg"))
        for name in ("vg", "svg"):
            if plans[name].status != "invalid":
                assert_same_search(plans[name].arrays)


@given(scene=random_scenes())
def test_random_scenes_match_the_reference(scene):
    _check_against_reference(scene)


@given(scene=random_scenes(grid=True))
def test_degenerate_grid_scenes_match_the_reference(scene):
    _check_against_reference(scene)


@given(scene=random_scenes(grid=True))
def test_vg_has_exactly_the_reference_edges_on_grid_scenes(scene):
    plans = plan_all(
        dataclasses.replace(scene, robot=dataclasses.replace(scene.robot, radius=0.0))
    )
    assume(plans["vg"].status != "invalid")
    space = plans["cspace"]
    with candidate_search("grid"):
        graph = visibility_graph(space, scene.start, scene.goal)
    assert _edge_set(graph) == _edge_set(plans["vg"].graph)
    nodes = list(graph.nodes)
    for i, a in enumerate(nodes):
        for b in nodes[i + 1 :]:
            assert graph.has_edge(a, b) == reference_segment_free(space, a, b), (a, b)


@given(scene=random_scenes(grid=True), picks=st.data())
def test_later_queries_in_the_same_space_reuse_the_vertex_visibility_exactly(
    scene, picks
):
    """While the start or goal is dragged, only their rows are tested again: still exact."""
    scene = dataclasses.replace(
        scene, robot=dataclasses.replace(scene.robot, radius=0.0)
    )
    plans = plan_all(scene)  # fills the cache of vertex-to-vertex visibility
    assume(plans["vg"].status != "invalid")
    space = plans["cspace"]
    vertices = [tuple(p) for p in space.derive(visibility.build_border).points.tolist()]
    grid = [(x, y) for x in range(-1, 11) for y in range(-1, 11)]
    grid = [p for p, b in zip(grid, space.contains_blocked(grid), strict=True) if not b]
    for _ in range(3):
        # A start or goal on a border vertex, on a free grid point, or where it was.
        start = picks.draw(st.sampled_from([scene.start, *vertices, *grid]))
        goal = picks.draw(st.sampled_from([scene.goal, *vertices, *grid]))
        graph = visibility_graph(space, start, goal)
        svg = simplified_visibility_graph(space, start, goal)
        nodes = list(graph.nodes)
        for i, a in enumerate(nodes):
            for b in nodes[i + 1 :]:
                assert graph.has_edge(a, b) == reference_segment_free(space, a, b)
        # The same geometry, built afresh: nothing derived yet, every pair tested.
        fresh = plan_all(scene, ("svg",))["cspace"]
        assert fresh is not space and fresh.known(visibility.vertex_visibility) is None
        assert _edge_set(svg) == _edge_set(
            simplified_visibility_graph(fresh, start, goal)
        )


def test_hole_touching_the_outer_ring_at_a_vertex():
    # Four obstacles merge into one whose hole [4,5]x[5,6] touches the outside at (4, 5):
    # the vertex appears in two rings, and the free directions there are two quadrants.
    obstacles = [
        [(0, 5), (4, 5), (4, 6), (1, 6), (1, 7), (0, 7)],
        [(5, 4), (6, 4), (6, 7), (5, 7)],
        [(4, 2), (5, 2), (5, 5), (4, 5)],
        [(2, 6), (5, 6), (5, 7), (2, 7)],
    ]
    space = plan(obstacles, (0, 0), (0, 0))["cspace"]
    assert len(space.merged.geoms) == 1 and len(space.merged.geoms[0].interiors) == 1
    graph = visibility_graph(space, (0, 0), (0, 0))
    assert graph.has_edge(
        (0.0, 5.0), (4.0, 5.0)
    )  # along an edge into the touching vertex
    assert graph.has_edge((4.0, 5.0), (4.0, 2.0))
    assert not segments_free(space, [[4, 5]], [[3, 6]])[0]  # into the L
    assert segments_free(space, [[4, 5]], [[3, 4]])[0]  # into the free quadrant


def test_path_bending_at_a_pinch_point_is_in_the_svg():
    # Triangle and square touch at (1, 1); the shortest path bends there around the
    # triangle while its outgoing segment extended points into the square.
    obstacles = [[(0, 1), (1, 1), (0, 2)], [(1, 0), (2, 0), (2, 1), (1, 1)]]
    vg, svg = both(obstacles, (1, 0), (0, 3))
    assert vg.length == pytest.approx(1 + math.sqrt(5), abs=1e-12)
    assert svg.length == pytest.approx(vg.length, abs=1e-12)


@st.composite
def survivors_and_vertices(draw):
    """Ascending survivors; vertices on some of them (t in (0, 1), repeats allowed)."""
    survivors = sorted(draw(st.sets(st.integers(0, 40), min_size=1, max_size=12)))
    ts = st.sampled_from([0.125, 0.25, 0.5, 0.75]) | st.floats(
        0.0, 1.0, exclude_min=True, exclude_max=True
    )
    pairs = draw(st.lists(st.tuples(st.sampled_from(survivors), ts), max_size=20))
    pairs.sort()
    seg = np.array([p[0] for p in pairs], dtype=np.intp)
    t = np.array([p[1] for p in pairs], dtype=float)
    return np.array(survivors, dtype=np.intp), seg, t


@given(survivors_and_vertices())
def test_pieces_are_what_sorting_every_cut_gives(case):
    survivors, t_seg, t_val = case
    # The obvious way: every survivor's ends and its vertices, sorted by (segment, t);
    # a piece between each two neighbours of one segment.
    seg_ids = np.concatenate([survivors, survivors, t_seg])
    ts = np.concatenate([np.zeros(len(survivors)), np.ones(len(survivors)), t_val])
    order = np.lexsort((ts, seg_ids))
    seg_ids, ts = seg_ids[order], ts[order]
    same = seg_ids[1:] == seg_ids[:-1]
    want_seg, want_mid = seg_ids[:-1][same], 0.5 * (ts[:-1][same] + ts[1:][same])
    got_seg, got_mid = visibility._pieces(survivors, t_seg, t_val)
    np.testing.assert_array_equal(got_seg, want_seg)
    np.testing.assert_array_equal(got_mid, want_mid)


@st.composite
def scenes_with_a_big_ring(draw):
    """A random scene plus a polygon of 64 to 120 vertices: convex, or with a dent."""
    scene = draw(random_scenes())
    k = draw(st.integers(64, 120))
    cx, cy = draw(st.floats(2, 8)), draw(st.floats(2, 8))
    radius = draw(st.floats(0.5, 3))
    angles = 2 * np.pi * np.arange(k) / k + draw(st.floats(0, 1))
    radii = np.full(k, radius)
    if draw(st.integers(0, 3)) == 0:
        radii[draw(st.integers(0, k - 1))] *= 0.7  # a reflex vertex: not skipped
    ring = np.column_stack([cx + radii * np.cos(angles), cy + radii * np.sin(angles)])
    return dataclasses.replace(scene, obstacles=(*scene.obstacles, Polygon(ring)))


@settings(max_examples=60, deadline=None)
@given(scene=scenes_with_a_big_ring())
def test_skipping_pairs_of_a_big_convex_ring_finds_the_same_graph(scene):
    plans = plan_all(scene, ("vg",))
    assume(plans["vg"].status != "invalid")
    space = plans["cspace"]
    saved = visibility._BIG_RING
    visibility._BIG_RING = 10**9  # no ring is big: every pair is enumerated
    try:
        everything = visibility_graph(
            configuration_space(
                scene.obstacles,
                scene.robot.radius,
                scene.expansion,
                scene.boundary,
                extra_points=[scene.start, scene.goal],
            ),
            scene.start,
            scene.goal,
        )
    finally:
        visibility._BIG_RING = saved
    # plan_all built its own space (rings skipped where they qualify): same arrays.
    vg = plans["vg"].graph
    assert list(vg.edges) == list(everything.edges)
    rings = space.derive(visibility._convex_ring_of)
    # Every pair of one skipped ring that is not one of its edges is blocked.
    on = np.flatnonzero(rings.ring >= 0)
    border = space.derive(visibility.build_border)
    points = border.points
    for a, b in itertools.combinations(on[:: max(1, len(on) // 12)].tolist(), 2):
        if rings.ring[a] == rings.ring[b] and not vg.has_edge(
            tuple(points[a]), tuple(points[b])
        ):
            assert not reference_segment_free(space, points[a], points[b])


@settings(max_examples=60, deadline=None)
@given(scene=st.booleans().flatmap(lambda grid: random_scenes(grid=grid)))
def test_compiled_tangent_filter_keeps_what_numpy_kept(scene):
    """The SVG's tangent pairs among the VG's visible ones, by the compiled pass, are
    the pairs (same order) numpy's filter kept: the candidates' pairs less those whose
    line enters a narrow wedge at an end (_not_tangent)."""
    plans = plan_all(scene)
    assume(plans["vg"].status != "invalid")
    space = plans["cspace"]
    known = space.known(visibility.vertex_visibility)
    border, q = visibility._query(space, scene.start, scene.goal)
    wedges = visibility._query_wedges(border, q)
    convex = np.append(border.convex_nodes, False)
    pinch = np.append(border.pinch_nodes, False)
    candidate = np.flatnonzero((q.node < 0) | convex[q.node] | pinch[q.node])
    got = visibility._tangents_of_known(known, q, wedges, candidate)
    is_candidate = np.zeros(len(q.points), dtype=bool)
    is_candidate[candidate] = True
    both = np.flatnonzero(is_candidate[known.i] & is_candidate[known.j])
    i, j = known.i[both], known.j[both]
    d = q.points[j] - q.points[i]
    keep = ~visibility._not_tangent(wedges, i, j, d[:, 0], d[:, 1])
    np.testing.assert_array_equal(got[0], i[keep])
    np.testing.assert_array_equal(got[1], j[keep])
