"""The vertex visibility carried over an edit equals the one built from scratch (issue 15).

Random edit sequences (vertex drags that merge and split obstacles, vertex inserts and
deletes, obstacle moves, inserts and deletes, edits that make the scene invalid and back)
run through ``plan_all`` with one memo, as the app's fast lane does; after every edit the
graphs must equal a cold build's edge for edge and the paths must have equal length.
"""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import Polygon

from planners import Memo, plan_all
from planners.expansion import configuration_space
from planners.incremental import carry_visibility
from planners.scene import (
    ScenarioError,
    add_obstacle,
    delete_obstacle,
    delete_vertex,
    insert_vertex,
    load_scene,
    move_obstacle,
    move_vertex,
)
from planners.visibility import (
    _point_rows,
    _point_sights,
    _query,
    _vertex_visibility,
    plan_visibility,
)
from tests.conftest import SCENARIOS, random_scenes

HALVES = st.integers(-2, 22).map(lambda k: k / 2.0)  # a lattice: collinear, touching


@st.composite
def edits(draw):
    kind = draw(
        st.sampled_from(
            ["vertex", "vertex", "move", "insert", "remove", "add", "delete"]
        )
    )
    return (
        kind,
        draw(st.integers(0, 10)),
        draw(st.integers(0, 10)),
        (draw(HALVES), draw(HALVES)),
    )


def _apply(scene, edit):
    kind, i, j, xy = edit
    if kind == "add":
        x, y = xy
        return add_obstacle(scene, [(x, y), (x + 1, y), (x, y + 1)])
    if not scene.obstacles:
        return scene
    i %= len(scene.obstacles)
    j %= len(scene.obstacles[i].exterior.coords) - 1
    apply = {
        # A vertex drag may self-intersect: invalid, and a later edit may repair it.
        "vertex": lambda: move_vertex(scene, i, j, xy),
        "move": lambda: move_obstacle(scene, i, (xy[0] / 4, xy[1] / 4)),
        "insert": lambda: insert_vertex(scene, i, j),
        "remove": lambda: delete_vertex(scene, i, j),
        "delete": lambda: delete_obstacle(scene, i),
    }
    return apply[kind]()


def _same_as_cold(scene, memo):
    warm = plan_all(scene, ("vg", "svg"), memo=memo)
    cold = plan_all(scene, ("vg", "svg"))
    for name in ("vg", "svg"):
        assert warm[name].status == cold[name].status
        assert warm[name].length == cold[name].length
        if warm[name].status != "invalid":
            a, b = warm[name].arrays, cold[name].arrays
            np.testing.assert_array_equal(a.points, b.points)
            np.testing.assert_array_equal(a.i, b.i)
            np.testing.assert_array_equal(a.j, b.j)
            np.testing.assert_array_equal(warm[name].path, cold[name].path)
    if "cspace" in warm and warm["cspace"].known(_vertex_visibility) is not None:
        mine = warm["cspace"].known(_vertex_visibility)
        fresh = cold["cspace"].derive(_vertex_visibility)
        np.testing.assert_array_equal(mine.i, fresh.i)
        np.testing.assert_array_equal(mine.j, fresh.j)
        _same_point_rows(warm["cspace"], cold["cspace"])


def _same_point_rows(warm_space, cold_space):
    """What the warm space keeps per point (start, goal; carried) is a fresh answer."""
    store = warm_space.known(_point_sights)
    for point, rows in store.items() if store is not None else []:
        border, q = _query(cold_space, point, point)
        if len(q.points) == len(border.points):
            continue  # the point sits on a vertex: it has no rows of its own
        fresh = _point_rows(cold_space, border, q, len(border.points))
        np.testing.assert_array_equal(rows, fresh)


@settings(max_examples=60, deadline=None)
@given(
    scene=random_scenes(grid=True),
    steps=st.lists(edits(), min_size=1, max_size=6),
    radius=st.sampled_from([0.0, 0.25]),
)
def test_edit_sequences_give_the_graphs_of_a_cold_build(scene, steps, radius):
    scene = dataclasses.replace(
        scene, robot=dataclasses.replace(scene.robot, radius=radius)
    )
    memo = Memo()
    _same_as_cold(scene, memo)
    for edit in steps:
        try:
            scene = _apply(scene, edit)
        except (ValueError, ScenarioError):
            continue  # the app refuses such an edit with a message
        _same_as_cold(scene, memo)


@settings(max_examples=30, deadline=None)
@given(
    scene=random_scenes(),
    steps=st.lists(edits(), min_size=1, max_size=4),
)
def test_edit_sequences_on_random_polygons(scene, steps):
    memo = Memo()
    _same_as_cold(scene, memo)
    for edit in steps:
        try:
            scene = _apply(scene, edit)
        except (ValueError, ScenarioError):
            continue
        _same_as_cold(scene, memo)


def _square(x, y, side=2.0):
    return Polygon([(x, y), (x + side, y), (x + side, y + side), (x, y + side)])


def test_a_drag_that_merges_then_splits_is_carried_exactly():
    a, b = _square(2, 2), _square(6, 2)
    start, goal = (0.5, 3.0), (11.0, 3.0)
    before = configuration_space((a, b), 0.5, extra_points=[start, goal])
    plan_visibility(before, start, goal)
    # Drag a's right edge onto b: the expanded squares merge, a pocket closes.
    for x in (5.0, 6.5, 3.0):
        moved = Polygon([(2, 2), (x, 2), (x, 4), (2, 4)])
        after = configuration_space((moved, b), 0.5, extra_points=[start, goal])
        assert carry_visibility(after, before)
        cold = configuration_space(
            (moved, b), 0.5, extra_points=[start, goal], memo=Memo()
        )
        mine, fresh = after.known(_vertex_visibility), cold.derive(_vertex_visibility)
        assert mine is not None
        np.testing.assert_array_equal(mine.i, fresh.i)
        np.testing.assert_array_equal(mine.j, fresh.j)
        assert (
            plan_visibility(after, start, goal).length
            == plan_visibility(cold, start, goal).length
        )
        before = after


def test_carrying_needs_the_visibility_before_and_the_same_tolerance():
    small = configuration_space((_square(0, 0, 1),), 0.0)
    large = configuration_space((_square(0, 0, 100),), 0.0)
    assert not carry_visibility(large, small)  # nothing known before
    plan_visibility(small, (-1, 0), (2, 2))
    assert not carry_visibility(large, small)  # another tolerance (scale)


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_every_shipped_scenario_under_vertex_drags(path):
    """The degenerate lecture scenes (pockets, touching, narrow gaps) through the carry."""
    scene = load_scene(path)
    memo = Memo()
    _same_as_cold(scene, memo)
    for i, obstacle in enumerate(scene.obstacles):
        x, y = obstacle.exterior.coords[0]
        for dx, dy in ((0.3, 0.0), (0.3, 0.4), (0.0, 0.0)):
            try:
                scene = move_vertex(scene, i, 0, (x + dx, y + dy))
            except (ValueError, ScenarioError):
                continue
            _same_as_cold(scene, memo)
