"""The cold full build: vertex pairs, the start's and goal's rows in one exact test.

A fresh configuration space with a new start and goal finds the vertex visibility, both
rows and the start-goal pair together (`visibility._cold_sights`). These properties hold
it to the slow reference (shapely's predicates, pair by pair) and, edge for edge, to the
build in steps it replaces (vertex visibility first, then each row on its own).
"""

import dataclasses
import threading
import time

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from shapely import Polygon

from planners.scene import Scene, load_scene
from planners.space.expansion import ConfigurationSpace, configuration_space
from planners.visibility import _graphs as visibility
from planners.visibility import visibility_graph
from tests.conftest import SCENARIOS, random_scenes, reference_segment_free
from tests.planners.test_visibility import candidate_search


def _fresh(scene: Scene, start, goal) -> ConfigurationSpace:
    """A configuration space built afresh, nothing derived on it (as run.py times)."""
    return configuration_space(
        scene.obstacles,
        scene.robot.radius,
        scene.expansion,
        scene.boundary,
        extra_points=[start, goal],
    )


def _ends(scene, space, picks):
    """Start and goal: where the scene has them, on a free lattice point or on a vertex."""
    vertices = [tuple(p) for p in space.derive(visibility.build_border).points.tolist()]
    lattice = [(x / 2.0, y / 2.0) for x in range(-2, 22) for y in range(-2, 22)]
    blocked = space.contains_blocked(lattice)
    free = [p for p, b in zip(lattice, blocked, strict=True) if not b]
    start = picks.draw(st.sampled_from([scene.start, *free, *vertices]))
    goal = picks.draw(st.sampled_from([scene.goal, *free, *vertices]))
    return start, goal


def _arrays(space, start, goal):
    return visibility._vg_arrays(space, start, goal)


def _in_steps(scene, start, goal):
    """The graph built as before the cold build: vertex visibility, then each row."""
    space = _fresh(scene, start, goal)
    space.derive(visibility.vertex_visibility)  # known: _cold_sights does nothing
    return _arrays(space, start, goal)


@settings(max_examples=60, deadline=None)
@given(scene=random_scenes(grid=True), picks=st.data())
def test_cold_build_has_exactly_the_reference_edges(scene, picks):
    """Collinear edges, shared corners, start or goal on a vertex or on an edge line."""
    scene = dataclasses.replace(
        scene, robot=dataclasses.replace(scene.robot, radius=0.0)
    )
    probe = _fresh(scene, scene.start, scene.goal)
    assume(not probe.contains_blocked([scene.start, scene.goal]).any())
    start, goal = _ends(scene, probe, picks)
    space = _fresh(scene, start, goal)
    graph = visibility_graph(space, start, goal)
    nodes = list(graph.nodes)
    for k, a in enumerate(nodes):
        for b in nodes[k + 1 :]:
            assert graph.has_edge(a, b) == reference_segment_free(space, a, b), (a, b)


@pytest.mark.parametrize("kind", ["dense", "grid"])
@settings(max_examples=80, deadline=None)
@given(scene=st.one_of(random_scenes(), random_scenes(grid=True)), picks=st.data())
def test_cold_build_equals_the_build_in_steps_edge_for_edge(kind, scene, picks):
    """The same arrays as the vertex visibility and the rows tested apart, disk robots too.

    Either way of finding the edges a segment meets: on small scenes the rows alone
    take the matrix and the joined test the march, so "grid" forces the march on both.
    """
    probe = _fresh(scene, scene.start, scene.goal)
    assume(not probe.contains_blocked([scene.start, scene.goal]).any())
    start, goal = _ends(scene, probe, picks)
    space = _fresh(scene, start, goal)
    with candidate_search(kind):
        cold = _arrays(space, start, goal)
        steps = _in_steps(scene, start, goal)
    np.testing.assert_array_equal(cold.points, steps.points)
    np.testing.assert_array_equal(cold.i, steps.i)
    np.testing.assert_array_equal(cold.j, steps.j)
    # What the cold build kept is what the separate tests compute on a fresh space.
    apart = _fresh(scene, start, goal)
    sight = space.known(visibility.vertex_visibility)
    assert sight is not None
    want = visibility.vertex_visibility(apart)
    np.testing.assert_array_equal(sight.i, want.i)
    np.testing.assert_array_equal(sight.j, want.j)
    kept = space.known(visibility.point_sights)
    if kept is not None:
        # Each kept row against the row tested on its own (the fresh space keeps none).
        border, q = visibility._query(apart, start, goal)
        for point, rows in kept.items():
            node = int(np.flatnonzero((q.points == point).all(axis=1))[-1])
            np.testing.assert_array_equal(
                rows, visibility._point_rows(apart, border, q, node)
            )
        for (a, b), free in kept.pair_items():
            assert free == visibility._ends_see_each_other(apart, border, q), (a, b)


def test_cold_build_keeps_rows_and_pair_for_the_next_query():
    """Start and goal see each other past a square; their rows are kept once, read after."""
    square = Polygon([(1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 2.0)])
    space = configuration_space((square,), 0.0, extra_points=[(0.0, 0.0), (3.0, 0.0)])
    arrays = _arrays(space, (0.0, 0.0), (3.0, 0.0))
    store = space.known(visibility.point_sights)
    assert store is not None
    rows = dict(store.items())
    # The start sees the square's two lower corners and the upper left one (the upper
    # right is behind it); the goal the two lower and the upper right.
    points = space.derive(visibility.build_border).points.tolist()
    seen = {p: sorted(tuple(points[k]) for k in r.tolist()) for p, r in rows.items()}
    assert seen[(0.0, 0.0)] == [(1.0, 1.0), (1.0, 2.0), (2.0, 1.0)]
    assert seen[(3.0, 0.0)] == [(1.0, 1.0), (2.0, 1.0), (2.0, 2.0)]
    assert store.pair((0.0, 0.0), (3.0, 0.0)) is True
    # 4 square edges, 3 + 3 rows, the start-goal pair.
    assert arrays.edges == 4 + 3 + 3 + 1


def test_cold_build_without_obstacles_and_on_a_vertex():
    """No border: the plane; the start on a vertex: its row is not kept (not plain)."""
    empty = configuration_space((), 0.0, extra_points=[(0.0, 0.0), (1.0, 1.0)])
    arrays = _arrays(empty, (0.0, 0.0), (1.0, 1.0))
    assert arrays.edges == 1
    square = Polygon([(1, 1), (2, 1), (2, 2), (1, 2)])
    ends = [(1.0, 1.0), (3.0, 3.0)]
    space = configuration_space((square,), 0.0, extra_points=ends)
    on_vertex = _arrays(space, *ends)
    store = space.known(visibility.point_sights)
    assert store is None or not store.items()  # no row kept, so none joined
    steps = configuration_space((square,), 0.0, extra_points=ends)
    steps.derive(visibility.vertex_visibility)
    want = _arrays(steps, *ends)
    np.testing.assert_array_equal(on_vertex.i, want.i)
    np.testing.assert_array_equal(on_vertex.j, want.j)


def test_last_marked_flags_the_last_block_and_stands_in_for_none():
    a = (np.array([0]), np.array([1]))
    b = (np.array([2]), np.array([3]))
    got = list(visibility._last_marked(iter([a, b])))
    assert [last for last, _ in got] == [False, True]
    assert got[1][1] is b
    (only,) = visibility._last_marked(iter([]))
    assert only[0] is True and len(only[1][0]) == len(only[1][1]) == 0


@pytest.mark.parametrize("kind", ["dense", "grid"])
@settings(max_examples=60, deadline=None)
@given(scene=random_scenes(grid=True), picks=st.data())
def test_exact_free_pairs_is_the_exact_test_and_the_reference(kind, scene, picks):
    """Pairs of points from their coordinate columns: the same answers as from rows."""
    space = _fresh(scene, scene.start, scene.goal)
    border = space.derive(visibility.build_border)
    lattice = np.array(
        [(x / 2.0, y / 2.0) for x in range(-2, 22) for y in range(-2, 22)]
    )
    points = np.vstack([border.points, lattice])
    count = picks.draw(st.integers(1, 40))
    index = st.integers(0, len(points) - 1)
    i = np.array([picks.draw(index) for _ in range(count)], dtype=np.intp)
    j = np.array([picks.draw(index) for _ in range(count)], dtype=np.intp)
    with candidate_search(kind):
        got = visibility._exact_free_pairs(space, border, points, i, j)
        rows = visibility.exact_free(space, border, points[i], points[j])
    np.testing.assert_array_equal(got, rows)
    want = [
        reference_segment_free(space, points[a], points[b])
        for a, b in zip(i, j, strict=True)
    ]
    assert got.tolist() == want


@settings(max_examples=40, deadline=None)
@given(scene=random_scenes(grid=True), picks=st.data())
def test_cold_build_on_two_threads_is_the_build_on_one(scene, picks):
    # Every border pipelined (a helper thread looks up and marches each block): the
    # same pairs, in the same order, and the same start and goal rows.
    start, goal = _ends(scene, _fresh(scene, scene.start, scene.goal), picks)
    one = _arrays(_fresh(scene, start, goal), start, goal)
    before = visibility._PIPELINED_VERTICES
    visibility._PIPELINED_VERTICES = 0
    try:
        two = _arrays(_fresh(scene, start, goal), start, goal)
    finally:
        visibility._PIPELINED_VERTICES = before
    np.testing.assert_array_equal(one.i, two.i)
    np.testing.assert_array_equal(one.j, two.j)
    np.testing.assert_array_equal(one.kept, two.kept)


def test_cold_build_on_two_threads_with_blocks_to_hand_on(monkeypatch):
    # Small blocks: several in flight, the last with the start's and goal's rows. The
    # helper is slowed, so blocks that come while it is busy are looked up by the
    # caller: both threads look blocks up, and the graph is still the one-thread graph.
    scene = load_scene(SCENARIOS[5])
    one = _arrays(_fresh(scene, scene.start, scene.goal), scene.start, scene.goal)
    looked_up_on: list[str] = []
    look_up = visibility._look_up

    def slow_on_the_helper(*args):
        looked_up_on.append(threading.current_thread().name)
        if threading.current_thread() is not threading.main_thread():
            time.sleep(0.02)
        return look_up(*args)

    monkeypatch.setattr(visibility, "_look_up", slow_on_the_helper)
    monkeypatch.setattr(visibility, "_PIPELINED_VERTICES", 0)
    monkeypatch.setattr(visibility, "_BLOCK_PAIRS", 64)
    monkeypatch.setattr(visibility, "_SCREEN_ROWS_PAIRS", 64)
    two = _arrays(_fresh(scene, scene.start, scene.goal), scene.start, scene.goal)
    assert threading.main_thread().name in looked_up_on
    assert any(name.startswith("sights") for name in looked_up_on)
    np.testing.assert_array_equal(one.i, two.i)
    np.testing.assert_array_equal(one.j, two.j)
    np.testing.assert_array_equal(one.kept, two.kept)
