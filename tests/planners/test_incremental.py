"""The vertex visibility carried over an edit equals the one built from scratch.

Random edit sequences (vertex drags that merge and split obstacles, vertex inserts and
deletes, obstacle moves, inserts and deletes, edits that make the scene invalid and back)
run through ``plan_all`` with one memo, as the app's fast lane does; after every edit the
graphs must equal a cold build's edge for edge and the paths must have equal length.
"""

import contextlib
import dataclasses
import itertools

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import Polygon

import planners.api
from planners import Memo, plan_all
from planners.kernels import box_pairs
from planners.scene import (
    ScenarioError,
    add_obstacle,
    delete_obstacle,
    delete_vertex,
    insert_vertex,
    load_scene,
    move_obstacle,
    move_vertex,
    scene_problems,
)
from planners.space.expansion import configuration_space
from planners.visibility._graphs import (
    _point_rows,
    _query,
    build_border,
    leaves_blocked,
    plan_visibility,
    point_sights,
    segments_free,
    vertex_visibility,
)
from planners.visibility.incremental import (
    _change,
    _crossing_box,
    _facing,
    _kept_pairs,
    _match,
    _meets_box,
    _outcodes,
    _pairs_to_test,
    carry_visibility,
)
from tests.conftest import SCENARIOS, random_scenes, scene_dict
from tests.planners.incremental_reference import (
    _line_meets_box,
    crossing_box_reference,
    facing_reference,
    kept_pairs_reference,
    meets_box_reference,
    row_pairs_reference,
)

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
    if "cspace" in warm and warm["cspace"].known(vertex_visibility) is not None:
        mine = warm["cspace"].known(vertex_visibility)
        fresh = cold["cspace"].derive(vertex_visibility)
        np.testing.assert_array_equal(mine.i, fresh.i)
        np.testing.assert_array_equal(mine.j, fresh.j)
        _same_point_rows(warm["cspace"], cold["cspace"])


def _same_point_rows(warm_space, cold_space):
    """What the warm space keeps per point (start, goal; carried), and whether start
    and goal see each other, are a fresh build's answers."""
    store = warm_space.known(point_sights)
    for point, rows in store.items() if store is not None else []:
        border, q = _query(cold_space, point, point)
        if len(q.points) == len(border.points):
            continue  # the point sits on a vertex: it has no rows of its own
        fresh = _point_rows(cold_space, border, q, len(border.points))
        np.testing.assert_array_equal(rows, fresh)
    for (a, b), free in store.pair_items() if store is not None else []:
        assert free == segments_free(cold_space, [a], [b])[0]


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
        mine, fresh = after.known(vertex_visibility), cold.derive(vertex_visibility)
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


# --------------------------------------------------------------------------- degenerate geometry


def _sq(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


SPIRAL = [(0, 0), (5, 0), (5, 4), (0, 4), (0, 3), (1.8, 3), (1.8, 2), (2.2, 2)]
SPIRAL += [(2.2, 3), (4, 3), (4, 1), (0, 1)]
DEGENERATE = {
    # name: (obstacles, start, goal, extra scene fields); the cases of
    # tests/planners/test_visibility.py's "degenerate geometry" section.
    "collinear row": ([_sq(x, 0, x + 1, 1) for x in (0, 2, 4)], (-1, 0), (6, 0), {}),
    "collinear in one polygon": (
        [[(0, 0), (1, 0), (2, 0), (3, 0), (3, 1), (0, 1)]],
        (-1, -1),
        (4, 2),
        {},
    ),
    "grazing a vertex": ([_sq(0, 0, 1, 1)], (-1, 1), (1, -1), {}),
    "through two vertices": ([_sq(0, 0, 1, 1)], (-1, 2), (2, -1), {}),
    "start on a vertex": ([_sq(0, 0, 1, 1)], (0, 0), (-1, -1), {}),
    "start and goal on one edge": ([_sq(0, 0, 1, 1)], (0, 0.5), (0, 1), {}),
    "opposite corners": ([_sq(0, 0, 1, 1)], (0, 0), (1, 1), {}),
    "start on the shrunk walls": (
        [_sq(1.5, 1.5, 2.5, 2.5)],
        (0.5, 2),
        (3.5, 2),
        {"radius": 0.5, "boundary": _sq(0, 0, 4, 4)},
    ),
    "touching at a corner": ([_sq(0, 0, 1, 1), _sq(1, 1, 2, 2)], (0, 2), (2, 0), {}),
    "sharing an edge": ([_sq(0, 0, 1, 1), _sq(1, 0, 2, 1)], (-1, 0.5), (3, 0.5), {}),
    "overlapping": ([_sq(0, 0, 2, 2), _sq(1, 1, 3, 3)], (-1, 3), (4, 0), {}),
    "pocket": (
        [[(5, 2), (8, 2), (8, 6), (5, 6), (5, 5), (7, 5), (7, 3), (5, 3)]],
        (6, 4),
        (9, 4),
        {},
    ),
    "spiral pocket": ([SPIRAL], (3.0, 2.8), (-1, 3.5), {}),
    "hole touching the outside": (
        [
            [(0, 5), (4, 5), (4, 6), (1, 6), (1, 7), (0, 7)],
            _sq(5, 4, 6, 7),
            _sq(4, 2, 5, 5),
            _sq(2, 6, 5, 7),
        ],
        (0, 0),
        (3, 8),
        {},
    ),
    "bending at a pinch": (
        [[(0, 1), (1, 1), (0, 2)], [(1, 0), (2, 0), (2, 1), (1, 1)]],
        (1, 0),
        (0, 3),
        {},
    ),
}


@pytest.mark.parametrize("name", DEGENERATE)
def test_degenerate_scenes_reached_by_edits_are_carried_exactly(name, monkeypatch):
    """Each degenerate scene built by an edit from a neighbour, and left again.

    Its last obstacle arrives (added, or moved in from 3 m away), each of its vertices
    is dragged away and back, and it leaves: every step through the carry, every step
    equal to a cold build edge for edge.
    """
    carried = []

    def counting(new, old):
        carried.append(carry_visibility(new, old))
        return carried[-1]

    monkeypatch.setattr(planners.api, "carry_visibility", counting)
    obstacles, start, goal, extra = DEGENERATE[name]
    scene = load_scene(scene_dict(obstacles, start, goal, **extra))
    last = len(scene.obstacles) - 1
    apart = move_obstacle(scene, last, (3.0, 0.0))
    without = delete_obstacle(scene, last)
    coords = scene.obstacles[last].exterior.coords[:-1]
    for before in (without, apart):
        memo = Memo()
        _same_as_cold(before, memo)
        _same_as_cold(scene, memo)
        for j, (x, y) in enumerate(coords):
            for xy in ((x + 0.37, y + 0.21), (x, y)):
                with contextlib.suppress(ValueError, ScenarioError):
                    _same_as_cold(move_vertex(scene, last, j, xy), memo)
        _same_as_cold(before, memo)
    assert sum(carried) >= 2 * len(coords)  # the edits went through the carry


# --------------------------------------------------------------------------- the screening


def _spaces_after(scene, edit, radius):
    """The configuration spaces before and after ``edit`` and how they relate; None
    when the app refuses the edit or the scene it makes is invalid (a
    self-intersecting obstacle: the app plans nothing)."""
    try:
        edited = _apply(scene, edit)
    except (ValueError, ScenarioError):
        return None
    if scene_problems(edited):
        return None
    old, new = (
        configuration_space(s.obstacles, radius, boundary=s.boundary)
        for s in (scene, edited)
    )
    return old, new, _change(old, new)


def _after_a_random_edit(test):
    """Run ``test(scene, edit, radius)`` on random and lattice scenes and edits."""
    return settings(max_examples=60, deadline=None)(
        given(
            scene=st.booleans().flatmap(lambda grid: random_scenes(grid=grid)),
            edit=edits(),
            radius=st.sampled_from([0, 0.25]),
        )(test)
    )


@settings(max_examples=40, deadline=None)
@given(scene=random_scenes(grid=True), edit=edits(), radius=st.sampled_from([0, 0.25]))
def test_the_pairs_tested_again_hold_every_pair_a_slow_screen_names(
    scene, edit, radius
):
    """Every pair that may change (at a vertex that is not stable, or whose segment
    meets the changed box, shapely's intersects) and that the wedges do not rule out
    is among the pairs the carry tests again."""
    spaces = _spaces_after(scene, edit, radius)
    if spaces is None or spaces[0].eps != spaces[1].eps:
        return
    _, new, change = spaces
    border = new.derive(build_border)
    tested = {
        (i, j)
        for ti, tj in _pairs_to_test(border, change.stable, change.box)
        for i, j in zip(ti.tolist(), tj.tolist(), strict=True)
    }
    n = len(border.points)
    box = shapely.box(*change.box) if change.box is not None else None
    for i, j in itertools.combinations(range(n), 2):
        a, b = border.points[i], border.points[j]
        may_change = not (change.stable[i] and change.stable[j]) or (
            box is not None and shapely.LineString([a, b]).intersects(box)
        )
        d = b - a
        screened = leaves_blocked(
            border.wedges, np.array([i]), np.array([j]), d[:1], d[1:]
        )[0]
        if may_change and not screened:
            assert (i, j) in tested


@_after_a_random_edit
def test_compiled_box_pairs_equal_the_numpy_listing(scene, edit, radius):
    """The pairs crossing the changed box, listed by the compiled loop, are the very
    pairs (same order) the blockwise numpy listing gave, after a random edit."""
    spaces = _spaces_after(scene, edit, radius)
    if spaces is None or spaces[0].eps != spaces[1].eps:
        return
    _, new, change = spaces
    if change.box is None:
        return
    border = new.derive(build_border)
    got = list(_crossing_box(border, change.stable, change.box))
    want = list(crossing_box_reference(border, change.stable, change.box))
    for k in range(2):
        np.testing.assert_array_equal(
            np.concatenate([np.zeros(0, dtype=np.intp), *(g[k] for g in got)]),
            np.concatenate([np.zeros(0, dtype=np.intp), *(w[k] for w in want)]),
        )


@_after_a_random_edit
def test_compiled_row_pairs_equal_the_numpy_listing(scene, edit, radius):
    """The changed vertices' screened rows, listed by the compiled loop, are the very
    pairs (same order) numpy's blockwise listing gave, after a random edit."""
    spaces = _spaces_after(scene, edit, radius)
    if spaces is None:
        return
    _, new, change = spaces
    border = new.derive(build_border)
    got = next(_pairs_to_test(border, change.stable, None))
    want = list(row_pairs_reference(border, change.stable))
    for k in range(2):
        assert got[k].dtype == np.intp
        np.testing.assert_array_equal(
            got[k], np.concatenate([np.zeros(0, dtype=np.intp), *(w[k] for w in want)])
        )


@_after_a_random_edit
def test_compiled_kept_pairs_equal_the_numpy_filter(scene, edit, radius):
    """The visible pairs an edit carries over, filtered by the compiled pass, are the
    very pairs (same order) numpy's filter kept, after a random edit (nothing
    changed, vertices gone, a box to keep clear of)."""
    spaces = _spaces_after(scene, edit, radius)
    if spaces is None:
        return
    old, new, change = spaces
    border, before = new.derive(build_border), old.derive(vertex_visibility)
    got = _kept_pairs(border, change, before)
    want = kept_pairs_reference(border, change, before)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == np.intp
        np.testing.assert_array_equal(g, w)


_SUBNORMAL = 2.0**-1074
_ENDS = st.sampled_from([-3.0, -1.0, 0.0, _SUBNORMAL, 0.5, 1.0, 2.0, 1e300])


@given(
    st.lists(st.tuples(_ENDS, _ENDS, _ENDS, _ENDS), max_size=10),
    st.tuples(_ENDS, _ENDS, _ENDS, _ENDS),
)
def test_compiled_box_test_is_the_numpy_one(rows, box):
    """Segments meet a box as numpy's slab test said, row for row: subnormal and
    zero directions, ends on the box's sides, coordinates of 1e300 (t of +-inf)."""
    ends = np.array(rows, dtype=np.float64).reshape(-1, 4)
    corners = np.array(box, dtype=np.float64)
    a, b = ends[:, :2], ends[:, 2:]
    np.testing.assert_array_equal(
        _meets_box(a, b, corners), meets_box_reference(a, b, corners)
    )
    assert not _meets_box(a, b, None).any()


def test_a_segment_whose_box_parameters_overflow_meets_the_box():
    """Near 1e308 both of an axis's parameters overflow: numpy's NaN said the segment
    misses the box, the compiled test says it meets it, as shapely does."""
    a, b = np.array([[0.0, 1e308]]), np.array([[0.0, -8e307]])
    box = np.array([-1.0, -8e307, 1.0, 0.0])
    assert shapely.intersects(shapely.LineString([a[0], b[0]]), shapely.box(*box))
    assert _meets_box(a, b, box)[0]
    with np.errstate(over="ignore", invalid="ignore"):  # numpy's inf - inf, inf / inf
        assert not meets_box_reference(a, b, box)[0]  # the one known difference


@_after_a_random_edit
def test_compiled_facing_is_the_numpy_one(scene, edit, radius):
    """Which vertices face the changed box, after a random edit, as numpy said."""
    spaces = _spaces_after(scene, edit, radius)
    if spaces is None:
        return
    _, new, change = spaces
    if change.box is None:
        return
    border = new.derive(build_border)
    np.testing.assert_array_equal(
        _facing(border, change.box), facing_reference(border, change.box)
    )


@given(
    a=st.tuples(*[st.integers(-8, 8)] * 2),
    b=st.tuples(*[st.integers(-8, 8)] * 2),
    box=st.tuples(*[st.integers(-4, 4)] * 4),
)
def test_segments_meet_a_box_as_shapely_says(a, b, box):
    x0, x1 = sorted(box[::2])
    y0, y1 = sorted(box[1::2])
    corners = np.array([x0, y0, x1, y1], dtype=np.float64)
    pa, pb = np.array([a], dtype=np.float64), np.array([b], dtype=np.float64)
    outside = (_outcodes(pa, corners) & _outcodes(pb, corners))[0] != 0
    mine = not outside and _line_meets_box(pa, pb, corners)[0]
    assert mine == _meets_box(pa, pb, corners)[0]
    # The compiled listing on the same two ends, with no wedge to screen them.
    points = np.vstack([pa, pb])
    no_wedge = (np.zeros((2, 2)), np.zeros((2, 2)), np.ones(2, dtype=bool))
    code = _outcodes(points, corners)
    listed = box_pairs(points, np.array([0, 1]), code, corners, no_wedge, 1e-12)
    assert mine == (len(listed[0]) == 1)
    segment = shapely.LineString([a, b]) if a != b else shapely.Point(a)
    assert mine == segment.intersects(shapely.box(x0, y0, x1, y1))


# --------------------------------------------------------------------------- a student layout


def _student_room(obstacles, seed):
    """Convex obstacles jittered on circles in a 20 m room, a disk robot (as bench_student)."""
    rng = np.random.default_rng(seed)
    rings = []
    for _ in range(obstacles):
        centre = rng.uniform(3.0, 17.0, 2)
        k = int(rng.integers(4, 9))
        angles = rng.uniform(0, 2 * np.pi) + 2 * np.pi / k * np.arange(k)
        ring = centre + rng.uniform(0.5, 1.3) * np.column_stack(
            [np.cos(angles), np.sin(angles)]
        )
        rings.append(np.round(ring, 3).tolist())
    room = [(0, 0), (20, 0), (20, 20), (0, 20)]
    return load_scene(scene_dict(rings, (1, 1), (19, 19), radius=0.3, boundary=room))


@pytest.mark.parametrize("seed", [1, 2])
def test_drags_in_a_student_layout_are_carried_exactly(seed):
    """Disk-expanded obstacles (arcs of many vertices) merging and parting under random
    vertex drags and obstacle moves, at the size the benchmark drags."""
    scene = _student_room(10, seed)
    rng = np.random.default_rng(seed)
    memo = Memo()
    _same_as_cold(scene, memo)
    for _ in range(12):
        i = int(rng.integers(len(scene.obstacles)))
        if rng.random() < 0.5:
            j = int(rng.integers(len(scene.obstacles[i].exterior.coords) - 1))
            x, y = scene.obstacles[i].exterior.coords[j]
            edited = move_vertex(
                scene, i, j, (x + rng.normal(0, 0.5), y + rng.normal(0, 0.5))
            )
        else:
            edited = move_obstacle(scene, i, tuple(rng.normal(0, 1.0, 2)))
        if not scene_problems(edited):
            scene = edited
            _same_as_cold(scene, memo)


def test_the_benchmark_apart_rooms_keep_their_obstacles_apart_and_are_carried():
    """bench_student's ``apart`` rooms: no two expanded obstacles meet, so the
    configuration space has a ring per obstacle and the room's (612 vertices at 32
    obstacles, up to 600); the benchmark's two drags there are carried
    exactly."""
    from tests.benchmarks.bench_student import drag_points, student_layout

    scene = load_scene(student_layout(32, layout="apart"))
    rings = plan_all(scene, ())["cspace"].rings
    assert len(rings) == 32 + 1
    assert sum(len(r) for r in rings) == 612
    for drag in ("vertex", "move"):
        memo = Memo()
        handle, points = drag_points(scene, drag, 12)
        i = handle[1]
        centre = np.asarray(scene.obstacles[i].centroid.coords[0], dtype=np.float64)
        for xy in points:
            if drag == "vertex":
                edited = move_vertex(scene, i, 0, tuple(xy))
            else:
                edited = move_obstacle(scene, i, tuple(xy - centre))
            _same_as_cold(edited, memo)


_COORD = st.sampled_from([0.0, -0.0, 0.5, 1.0, -1.0, 1e-300, 2.0**-1074, 3.0])
_POINTS = st.lists(st.tuples(_COORD, _COORD), max_size=12).map(
    lambda p: np.array(p, dtype=np.float64).reshape(-1, 2)
)


@given(_POINTS, _POINTS)
def test_vertices_match_as_a_dict_of_points_says(old, new):
    """Bisection over the sorted old points answers as a dict from (x, y) to index:
    repeated points give their last index, -0.0 is 0.0, a subnormal is itself."""
    index = {p: k for k, p in enumerate(map(tuple, old.tolist()))}
    expected = [index.get(p, -1) for p in map(tuple, new.tolist())]
    found = _match(old, new)
    assert found.dtype == np.intp
    assert found.tolist() == expected
