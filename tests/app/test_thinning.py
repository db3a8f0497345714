"""Thinning of big graph layers (app.ui.thinning): a drawing choice, never a planner's decision."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import planners
from app.ui.thinning import (
    THIN_ABOVE,
    edges_counted,
    edges_to_draw,
    frame_note,
)
from tests.app.app_helpers import view_and_controller
from tests.benchmarks.bench_student import student_layout


def _reference(arrays, path) -> list[tuple[tuple[float, ...], tuple[float, ...]]]:
    """Slow and obvious: each edge with an end at the start, the goal or a path corner."""
    corners = {tuple(map(float, p)) for p in np.asarray(path).reshape(-1, 2)}
    ends = {tuple(map(float, arrays.points[k])) for k in (arrays.start, arrays.goal)}
    out = []
    for a, b in zip(arrays.i, arrays.j, strict=True):
        pa = tuple(map(float, arrays.points[a]))
        pb = tuple(map(float, arrays.points[b]))
        if pa in corners | ends or pb in corners | ends:
            out.append((pa, pb))
    return out


def _as_pairs(segments) -> list[tuple[tuple[float, ...], tuple[float, ...]]]:
    return [
        (tuple(map(float, s[0])), tuple(map(float, s[1]))) for s in np.asarray(segments)
    ]


@st.composite
def graphs(draw):
    """A random graph on grid points (repeats of coordinates avoided), with a path."""
    n = draw(st.integers(2, 30))
    flat = draw(st.lists(st.integers(0, 99), min_size=n, max_size=n, unique=True))
    points = np.array([[k % 10, k // 10] for k in flat], dtype=np.float64)
    pairs = draw(
        st.lists(
            st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)).filter(
                lambda p: p[0] < p[1]
            ),
            unique=True,
            max_size=60,
        )
    )
    i = np.array([p[0] for p in pairs], dtype=np.intp)
    j = np.array([p[1] for p in pairs], dtype=np.intp)
    start, goal = draw(st.integers(0, n - 1)), draw(st.integers(0, n - 1))
    middle = draw(st.lists(st.integers(0, n - 1), max_size=5))
    reachable = draw(st.booleans())
    path = points[[start, *middle, goal]] if reachable else np.zeros((0, 2))
    arrays = SimpleNamespace(points=points, start=start, goal=goal, i=i, j=j)
    arrays.segments = lambda: np.stack([points[i], points[j]], axis=1).reshape(-1, 2, 2)
    return SimpleNamespace(arrays=arrays, path=path, status="ok")


@settings(max_examples=200, deadline=None)
@given(graphs(), st.integers(0, 40))
def test_thinned_edges_are_the_reference_ones(result, limit):
    drawn = edges_to_draw(result, all_edges=False, limit=limit)
    everything = _as_pairs(result.arrays.segments())
    assert drawn.total == len(everything)
    if len(everything) <= limit:
        assert _as_pairs(drawn.segments) == everything
    else:
        assert _as_pairs(drawn.segments) == _reference(result.arrays, result.path)


@settings(max_examples=200, deadline=None)
@given(graphs(), st.integers(0, 40), st.booleans())
def test_the_panel_counts_what_the_view_draws(result, limit, all_edges):
    # The panel's note counts without making the segments; the counts are the drawing's.
    drawn = edges_to_draw(result, all_edges=all_edges, limit=limit)
    assert edges_counted(result, all_edges=all_edges, limit=limit) == drawn.count


@settings(max_examples=100, deadline=None)
@given(graphs())
def test_all_edges_draws_the_whole_graph(result):
    drawn = edges_to_draw(result, all_edges=True, limit=0)
    assert _as_pairs(drawn.segments) == _as_pairs(result.arrays.segments())
    assert not drawn.thinned


def test_the_path_nodes_of_an_unreachable_goal_are_start_and_goal():
    # No path: the edges drawn are those at the start (node 2) and the goal (node 0).
    points = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    i, j = np.array([0, 1, 2]), np.array([1, 3, 3])
    arrays = SimpleNamespace(points=points, start=2, goal=0, i=i, j=j)
    result = SimpleNamespace(arrays=arrays, path=np.zeros((0, 2)))
    drawn = edges_to_draw(result, all_edges=False, limit=0)
    assert _as_pairs(drawn.segments) == [
        ((0.0, 0.0), (1.0, 0.0)),
        ((2.0, 0.0), (3.0, 0.0)),
    ]


def test_a_student_layout_is_thinned_to_the_planners_edges_at_the_path():
    scene = planners.load_scene(student_layout(32))
    vg = planners.plan_all(scene, ("vg",))["vg"]
    assert vg.edges > THIN_ABOVE
    drawn = edges_to_draw(vg, all_edges=False)
    assert drawn.thinned and drawn.total == vg.edges
    everything = set(_as_pairs(vg.arrays.segments()))
    assert set(_as_pairs(drawn.segments)) <= everything  # never an edge of its own
    assert _as_pairs(drawn.segments) == _reference(vg.arrays, vg.path)
    # Every leg of the path is among the edges drawn.
    legs = set(_as_pairs(np.stack([vg.path[:-1], vg.path[1:]], axis=1)))
    shown = {frozenset(e) for e in _as_pairs(drawn.segments)}
    assert {frozenset(leg) for leg in legs} <= shown
    note = frame_note({"vg": vg}, {"vg_edges": True})
    assert note is not None
    assert f"of {vg.edges:,} drawn" in note and "VG edges: all" in note
    assert frame_note({"vg": vg}, {"vg_edges": True, "vg_edges_all": True}) is None
    assert frame_note({"vg": vg}, {"vg_edges": False}) is None


def test_the_view_draws_a_big_graph_thinned_and_all_on_request():
    import viser

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    view, controller = view_and_controller(
        server, planners.load_scene(student_layout(32))
    )
    try:
        assert controller.wait_idle(60)
        frame = controller.frame
        assert frame is not None
        vg = frame.plans["vg"]
        edges = view.graphs["vg"].edges
        thinned = edges_to_draw(vg, all_edges=False)
        assert len(edges.points()) == len(thinned.segments) < vg.edges
        # The view draws the rest, then the edges at the start and goal (GraphEdges).
        ends = thinned.at_ends
        expected = np.concatenate([thinned.segments[~ends], thinned.segments[ends]])
        np.testing.assert_allclose(edges.points()[:, :, :2], expected, atol=1e-5)
        controller.set_layer("vg_edges_all", True)
        assert controller.wait_idle(60)
        assert len(edges.points()) == vg.edges
        controller.set_layer("vg_edges_all", False)
        assert controller.wait_idle(60)
        assert len(edges.points()) == len(thinned.segments)
    finally:
        controller.close()
        server.stop()
