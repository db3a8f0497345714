"""Bug2 (the M-line bug algorithm): hand cases, degenerate geometry, shared properties."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given
from numpy.testing import assert_allclose
from shapely import Polygon

from planners import PlanOptions, load_scene, plan_all
from planners.bug.bug2 import _pinches, _point, plan_bug2
from planners.bug.sensor import ring_geometry
from planners.space.expansion import configuration_space
from tests.conftest import (
    check_walk,
    random_scenes,
    scene_dict,
    square,
)


def _bug2(obstacles, start, goal, boundary=None):
    space = configuration_space(tuple(obstacles), 0.0, boundary=boundary)
    return plan_bug2(space, start, goal)


def test_leaves_where_it_meets_the_m_line_again():
    # M-line y = 1 through a 2 x 2 square: hit the left side, turn left (up), along the
    # top, down the right side to the M-line at (2, 1), then straight to the goal.
    trace = _bug2([square(0, 0, 2, 2)], (-1.0, 1.0), (3.0, 1.0))
    assert trace.status == "reached"
    assert trace.path.tolist() == [
        [-1.0, 1.0], [0.0, 1.0], [0.0, 2.0], [2.0, 2.0], [2.0, 1.0], [3.0, 1.0],
    ]  # fmt: skip
    assert [(e.kind, e.label, e.at) for e in trace.events] == [
        ("hit", "H1", (0.0, 1.0)),
        ("leave", "L1", (2.0, 1.0)),
    ]
    assert trace.length == pytest.approx(6.0, abs=1e-12)
    assert trace.modes == ("seek", "follow", "follow", "follow", "seek")
    assert [d.box for d in trace.decisions] == ["hit", "leave", "reached"]
    assert trace.decisions[1].d_goal == pytest.approx(1.0)
    assert trace.decisions[1].d_hit == pytest.approx(3.0)


def test_meeting_the_m_line_farther_than_the_hit_is_no_leave_point():
    # A C open to the left: the robot enters the mouth along the M-line, hits the back
    # wall at x = 3, and following it (left = down) meets the M-line again at the mouth's
    # lower lip... never closer than the hit; it must go round the outside instead.
    c_shape = [(0, 0), (4, 0), (4, 4), (0, 4), (0, 3), (3, 3), (3, 1), (0, 1)]
    trace = _bug2([Polygon(c_shape)], (-1.0, 2.0), (6.0, 2.0))
    assert trace.status == "reached"
    hits = [e for e in trace.events if e.kind == "hit"]
    leaves = [e for e in trace.events if e.kind == "leave"]
    assert hits[0].at == pytest.approx((3.0, 2.0))
    # Every leave point lies on the M-line and closer to the goal than the hit before it.
    for hit, leave in zip(hits, leaves, strict=True):
        assert leave.at[1] == pytest.approx(2.0, abs=1e-9)
        assert math.dist(leave.at, (6.0, 2.0)) < math.dist(hit.at, (6.0, 2.0))
    assert leaves[0].at == pytest.approx((4.0, 2.0))
    assert_allclose(trace.path[-1], (6.0, 2.0))


def test_wanders_far_where_tangent_bug_does_not():
    # A long wall across the M-line whose near end is just right of it: Bug2 turns left
    # and walks the whole wall (about 20 m round it), TangentBug sees the near end within
    # R = 2 and goes round it.
    scene = load_scene(
        scene_dict([[(-10, 0), (1, 0), (1, 0.5), (-10, 0.5)]], (0, -1), (0, 3))
    )
    plans = plan_all(scene, ("vg", "dsb", "bug2"), PlanOptions(sensor_range=2.0))
    bug2, dsb, vg = plans["bug2"], plans["dsb"], plans["vg"]
    assert bug2.status == dsb.status == "reached"
    assert bug2.length > 20.0
    assert dsb.length < 5.0
    assert bug2.length > 4 * dsb.length >= 4 * vg.length - 1e-9
    assert min(bug2.path[:, 0]) == pytest.approx(-10.0)  # went round the far end


def test_m_line_along_an_edge_is_free():
    # The M-line runs along the square's bottom side: the border is free, no hit.
    trace = _bug2([square(0, 0, 2, 2)], (-1.0, 0.0), (3.0, 0.0))
    assert trace.status == "reached"
    assert trace.events == ()
    assert trace.path.tolist() == [[-1.0, 0.0], [3.0, 0.0]]


def test_m_line_grazing_a_vertex_is_free():
    trace = _bug2([square(0, 0, 2, 2)], (-1.0, -1.0), (3.0, 3.0))
    # The diagonal passes through the corners (0, 0) and (2, 2) and the square's
    # interior: it hits at (0, 0), not before.
    assert trace.events[0].at == pytest.approx((0.0, 0.0))
    touching = _bug2([square(0, 0, 2, 2)], (-1.0, 1.0), (1.0, 3.0))  # grazes (0, 2)
    assert touching.events == ()
    assert touching.length == pytest.approx(math.dist((-1, 1), (1, 3)))


def test_start_and_goal_on_the_border():
    trace = _bug2([square(0, 0, 2, 2)], (0.0, 1.0), (2.0, 1.0))
    assert trace.status == "reached"
    assert trace.events[0].at == pytest.approx((0.0, 1.0))  # touching, facing inside
    assert_allclose(trace.path[-1], (2.0, 1.0))
    assert trace.length == pytest.approx(4.0)  # up 1, across 2, down 1


def test_goal_enclosed_is_unreachable_after_one_round():
    ring = [(0, 0), (6, 0), (6, 6), (0, 6)]
    hole = [(2, 2), (2, 4), (4, 4), (4, 2)]
    walls = Polygon(ring, [hole])
    trace = _bug2([walls], (-1.0, 3.0), (3.0, 3.0))
    assert trace.status == "unreachable"
    assert "unreachable" in (trace.reason or "")
    assert [e.label for e in trace.events] == ["H1"]
    # It went once all the way round and stopped at the hit point.
    assert_allclose(trace.path[-1], (0.0, 3.0))
    assert trace.travelled == pytest.approx(1.0 + 24.0)


def test_hits_the_walls():
    boundary = [(0, 0), (10, 0), (10, 4), (0, 4)]
    inner = square(4, -1, 5, 3)  # reaches out of the room at the bottom
    scene = load_scene(
        scene_dict([inner.exterior.coords[:-1]], (1, 1), (9, 1), boundary=boundary)
    )
    plans = plan_all(scene, ("vg", "bug2"))
    assert plans["bug2"].status == "reached"
    assert plans["bug2"].length >= plans["vg"].length


def test_is_registered_off_by_default():
    scene = load_scene(scene_dict([], (0, 0), (3, 4)))
    assert "bug2" not in plan_all(scene)
    assert plan_all(scene, ("bug2",))["bug2"].length == pytest.approx(5.0)


@given(scene=random_scenes())
def test_random_scenes_agree_with_the_visibility_graph(scene):
    _check(scene, through_pinch_ok=False)


@given(scene=random_scenes(grid=True))
def test_degenerate_grid_scenes_agree_with_the_visibility_graph(scene):
    # Collinear edges, touching obstacles, start and goal on borders and corners.
    _check(scene, through_pinch_ok=True)


def test_a_pocket_open_only_at_two_points_is_not_entered():
    # The known limit: free space joined to the rest only through points where borders
    # touch (zero-width gaps). The robot passes a pinch on its way round, but a pocket
    # whose every way in is a pinch is not entered; the VG's path goes through one.
    scene = load_scene(
        scene_dict(
            [
                [(1, 0), (2, 0), (2, 2), (1, 2)],
                [(0, 2), (1, 2), (1, 3), (0, 3)],
                [(0, 0), (1, 0), (1, 1), (0, 1)],
                [(0, 0), (1, 0), (0, 2)],
            ],
            (0, 0),
            (1, 1),
        )
    )
    plans = plan_all(scene, ("vg", "bug2"))
    assert plans["vg"].status == "ok"
    assert plans["bug2"].status == "unreachable"
    assert _through_a_pinch(plans["cspace"], plans["vg"].path)


def _through_a_pinch(space, path) -> bool:
    geo = ring_geometry(space)
    pinch_points = [_point(geo, spot) for spot in _pinches(geo, 10 * space.eps)]
    return any(math.dist(p, q) <= 1e-9 for p in path[1:] for q in pinch_points)


def _check(scene, *, through_pinch_ok):
    plans = plan_all(scene, ("vg", "bug2"))
    vg, bug2 = plans["vg"], plans["bug2"]
    assume(vg.status != "invalid")
    space = plans["cspace"]
    if through_pinch_ok and vg.status == "ok" and bug2.status == "unreachable":
        # Only where every way to the goal goes through a point where borders touch.
        assert _through_a_pinch(space, vg.path), bug2.reason
        return
    # Complete: Bug2 reaches the goal exactly when a path exists.
    assert bug2.status == ("reached" if vg.status == "ok" else "unreachable"), (
        bug2.reason
    )
    check_walk(space, scene, bug2, vg)
    if vg.status == "ok":
        hits = [e for e in bug2.events if e.kind == "hit"]
        leaves = [e for e in bug2.events if e.kind == "leave"]
        for hit, leave in zip(hits, leaves, strict=False):
            assert math.dist(leave.at, scene.goal) < math.dist(hit.at, scene.goal)
