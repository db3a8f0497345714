"""Properties of the DSB planner on random scenes, checked against the visibility graph."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from planners import PlanOptions, load_scene, plan_all
from planners.bug._leave import _may_come_closer, _reach
from planners.bug.tangent_bug import (
    BugParams,
    Follow,
    _context,
    plan_tangent_bug,
)
from tests.conftest import check_walk, random_scenes, scene_dict


def _check(scene, sensor_range, rule):
    plans = plan_all(
        scene, ("vg", "dsb"), PlanOptions(sensor_range=sensor_range, leave_rule=rule)
    )
    vg, dsb = plans["vg"], plans["dsb"]
    assume(vg.status != "invalid")
    space = plans["cspace"]
    # Complete and sound: reached exactly when the visibility graph finds a path.
    assert dsb.status == ("reached" if vg.status == "ok" else "unreachable"), dsb.reason
    assert dsb.terminated == ("goal" if vg.status == "ok" else "loop")
    check_walk(space, scene, dsb, vg)


@given(
    scene=random_scenes(),
    sensor_range=st.sampled_from([0.5, 1.5, math.inf]),
    rule=st.sampled_from(["tangent_bug", "chapter"]),
)
def test_random_scenes_agree_with_the_visibility_graph(scene, sensor_range, rule):
    _check(scene, sensor_range, rule)


@given(
    scene=random_scenes(grid=True),
    sensor_range=st.sampled_from([0.5, 1.5, math.inf]),
    rule=st.sampled_from(["tangent_bug", "chapter"]),
)
def test_degenerate_grid_scenes_agree_with_the_visibility_graph(
    scene, sensor_range, rule
):
    # Collinear edges, touching obstacles, start and goal on borders and corners.
    _check(scene, sensor_range, rule)


def _convex_scene(rng):
    n = int(rng.integers(3, 9))
    cx, cy = rng.uniform(2, 8, 2)
    r = rng.uniform(0.4, 2.5)
    angles = np.linspace(0, 2 * math.pi, n, endpoint=False) + rng.uniform(0, 1)
    pts = list(zip(cx + r * np.cos(angles), cy + r * np.sin(angles), strict=True))
    radius = float(rng.choice([0.0, 0.2, 0.4]))
    expansion = str(rng.choice(["disk", "square"]))
    boundary = [(-2, -2), (12, -2), (12, 12), (-2, 12)] if rng.random() < 0.5 else None
    start, goal = tuple(rng.uniform(-1, 11, 2)), tuple(rng.uniform(-1, 11, 2))
    return load_scene(
        scene_dict(
            [pts], start, goal, radius=radius, expansion=expansion, boundary=boundary
        )
    )


def test_unlimited_range_around_one_convex_obstacle_is_near_optimal_almost_always():
    # Section 9.6: "If the sensing range is large enough to include the entire surface of
    # all of the obstacles then the lines through the graph vertices, O_i, will be
    # tangential lines and the DSB method can produce similar results to the SVG method."
    # Similar, not always within 2%: the heuristic d(r, O_i) + d(O_i, g) measures
    # d(O_i, g) straight through the obstacle and now and then picks the longer way round
    # (see the next test). On 300 random scenes (fixed seed) with one convex obstacle DSB
    # is within 2% of the optimum in at least 98% of them, and exactly optimal in most.
    rng = np.random.default_rng(2024)
    ratios = []
    while len(ratios) < 300:
        scene = _convex_scene(rng)
        plans = plan_all(scene, ("vg", "dsb"), PlanOptions(sensor_range=math.inf))
        if plans["vg"].status != "ok":
            continue
        assert plans["dsb"].status == "reached"
        ratios.append(plans["dsb"].length / plans["vg"].length)
    ratios = np.array(ratios)
    assert ratios.min() >= 1 - 1e-9
    assert np.mean(ratios <= 1.02) >= 0.98
    assert np.median(ratios) <= 1 + 1e-9


@pytest.mark.parametrize(
    ("obstacles", "start", "goal", "radius", "expansion", "excess"),
    [
        # An equilateral triangle pointing away from the start: the lower corner looks
        # better (its straight line to the goal cuts through the triangle), and from there
        # the way on is back up the near side.
        ([[(4, 2), (1, 3.732), (1, 0.268)]], (0, 0), (3, 4), 0.0, "disk", (1.10, 1.12)),
        # A start almost in line with the top side: once the robot has set off for the
        # right way round (below), the near top corner comes into view and looks better.
        (
            [[(3.755, 2.959), (0.292, 3.041), (1.953, 0.0006)]],
            (5, 3),
            (0, 1),
            0.0,
            "disk",
            (1.04, 1.06),
        ),
        # Two convex obstacles: it goes round the wrong side of the first.
        (
            [
                [
                    (4.451, 5.047),
                    (3.638, 5.746),
                    (2.569, 5.666),
                    (1.87, 4.853),
                    (1.95, 3.785),
                    (2.762, 3.085),
                    (3.831, 3.165),
                    (4.531, 3.978),
                ],
                [
                    (5.997, 4.003),
                    (5.459, 4.264),
                    (5.045, 3.833),
                    (5.327, 3.306),
                    (5.915, 3.411),
                ],
            ],
            (8.455, 5.121),
            (1.16, 4.63),
            0.15,
            "square",
            (1.11, 1.13),
        ),
    ],
)
def test_unlimited_range_is_not_optimal_in_general(
    obstacles, start, goal, *, radius, expansion, excess
):
    # Known limitation, shown rather than hidden: the heuristic d(r, O_i) + d(O_i, g)
    # ignores what lies between O_i and the goal.
    scene = load_scene(
        scene_dict(obstacles, start, goal, radius=radius, expansion=expansion)
    )
    plans = plan_all(scene, ("vg", "dsb"), PlanOptions(sensor_range=math.inf))
    assert plans["dsb"].status == "reached"
    assert excess[0] < plans["dsb"].length / plans["vg"].length < excess[1]


@given(scene=random_scenes(), rule=st.sampled_from(["tangent_bug", "chapter"]))
def test_trace_is_consistent(scene, rule):
    plans = plan_all(scene, ("vg",))
    assume(plans["vg"].status != "invalid")
    trace = plan_tangent_bug(plans["cspace"], scene.start, scene.goal, 1.0, rule)
    assert len(trace.modes) == len(trace.aims) == len(trace.path) - 1
    assert set(trace.modes) <= {"seek", "follow"}
    assert {e.kind for e in trace.events} <= {"hit", "leave", "local_min"}
    assert [e.s for e in trace.events] == sorted(e.s for e in trace.events)
    for event in trace.events:
        assert np.hypot(*(trace.position_at(event.s) - event.at)) <= 1e-6
    # Boundary following starts at a local minimum, and goal seeking resumes at a leave.
    minima = [e.s for e in trace.events if e.kind == "local_min"]
    leaves = [e.s for e in trace.events if e.label.startswith("L")]
    for i, mode in enumerate(trace.modes):
        if i and mode != trace.modes[i - 1]:
            s = trace.arclength[i]
            assert any(
                abs(s - m) <= 1e-6 for m in (minima if mode == "follow" else leaves)
            ), (i, mode)
    assert len(trace.pieces) == (
        1 + sum(a != b for a, b in zip(trace.modes[:-1], trace.modes[1:], strict=True))
        if trace.modes
        else 0
    )


@given(
    scene=random_scenes(),
    sensor_range=st.sampled_from([0.5, 1.5, 4.0]),
    where=st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=8),
    slack=st.floats(-0.5, 1.0),
)
def test_skipped_readings_could_not_have_changed_boundary_following(
    scene, sensor_range, where, slack
):
    # Boundary following senses only where the view may bring the followed border closer
    # to the goal than d_followed (_may_come_closer). Wherever it skips, the reading it
    # skipped must show nothing closer: d_reach >= d_followed.
    plans = plan_all(scene, ("vg",))
    assume(plans["vg"].status != "invalid")
    ctx = _context(plans["cspace"], BugParams(scene.goal, sensor_range))
    geo = ctx.geo
    assume(len(geo.rings))
    for u, v in where:
        ring = min(int(u * len(geo.rings)), len(geo.rings) - 1)
        y, _, _ = geo.locate(ring, v * float(geo.perimeter[ring]))
        d_now = _reach(ctx, y, ring)[0]
        # d_followed around the value that decides: below, at and above d_reach.
        follow = Follow(
            ring=ring,
            direction=1,
            local_min=(0.0, 0.0),
            d_local_min=0.0,
            d_followed=d_now + slack,
            target=None,
            target_sigma=0.0,
            sigma=0.0,
            walked=0.0,
            obstacle=None,
        )
        if not _may_come_closer(ctx, follow, y):
            assert d_now >= follow.d_followed, (y, ring, d_now, follow.d_followed)
