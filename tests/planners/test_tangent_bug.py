"""The distance-sensor-based planner (TangentBug): hand-built cases, one per behaviour."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from planners import PlanOptions, load_scene, plan_all, result_to_json
from planners.__main__ import main
from planners.bug._context import evolve
from planners.bug.sensor import ring_geometry
from planners.bug.tangent_bug import (
    BugParams,
    BugState,
    BugTrace,
    Follow,
    initial_state,
    plan_tangent_bug,
    run,
    step,
)
from planners.visibility import segments_free
from tests.conftest import SCENARIOS, scene_dict, square

FIG_9_19 = next(p for p in SCENARIOS if p.stem.startswith("06_"))
ENCLOSED = next(p for p in SCENARIOS if p.stem.startswith("07_"))
U_TRAP = next(p for p in SCENARIOS if p.stem.startswith("04_"))


def box(x0, y0, x1, y1):
    return list(square(x0, y0, x1, y1).exterior.coords)[:-1]


def plan(obstacles, start, goal, sensor_range=math.inf, rule="tangent_bug", **kw):
    scene = load_scene(scene_dict(obstacles, start, goal, **kw))
    plans = plan_all(
        scene, ("vg", "dsb"), PlanOptions(sensor_range=sensor_range, leave_rule=rule)
    )
    return plans["dsb"], plans


def labels(trace: BugTrace) -> list[str]:
    return [e.label for e in trace.events]


def assert_valid(trace: BugTrace, plans) -> None:
    """The path stays in the closed free space and starts at the start."""
    space = plans["cspace"]
    path = trace.path
    assert_allclose(path[0], trace.start, atol=0)
    if len(path) > 1:
        assert segments_free(space, path[:-1], path[1:]).all()
    assert len(trace.modes) == len(trace.aims) == max(len(path) - 1, 0)


WALL = [box(-3, 0, 3, 1)]  # a wide wall between start and goal, seen head on


# --------------------------------------------------------------------------- goal seeking


def test_nothing_in_the_way_goes_straight():
    trace, plans = plan([], (0, 0), (3, 4), 1.0)
    assert trace.status == "reached" and trace.length == 5.0
    assert trace.path.tolist() == [[0.0, 0.0], [3.0, 4.0]]
    assert trace.events == () and trace.modes == ("seek",)
    assert_valid(trace, plans)


def test_around_a_square_with_unlimited_range_is_optimal():
    trace, plans = plan([box(0, 0, 2, 2)], (-1, 1), (3, 1))
    assert trace.length == pytest.approx(2 * math.sqrt(2) + 2, abs=1e-12)
    assert trace.length == pytest.approx(plans["vg"].length, abs=1e-12)
    assert labels(trace) == ["H1", "D1"]


def test_obstacle_is_hit_where_it_comes_into_range():
    # Straight toward the goal until the square's side x = 0 is R = 2 away: H1 at (-2, 1).
    trace, plans = plan([box(0, 0, 2, 2)], (-5, 1), (5, 1), 2.0)
    hit = trace.events[0]
    assert (hit.kind, hit.label) == ("hit", "H1")
    assert_allclose(hit.at, (-2.0, 1.0), atol=1e-5)
    assert hit.s == pytest.approx(3.0, abs=1e-5)
    assert_valid(trace, plans)


def test_goal_direction_free_again_is_a_departure():
    # Round the square over its top: at the corner (2, 2) the goal is in view (D1).
    trace, _ = plan([box(0, 0, 2, 2)], (-5, 1), (5, 1), 2.0)
    depart = trace.events[1]
    assert (depart.kind, depart.label) == ("leave", "D1")
    assert_allclose(depart.at, (2.0, 2.0), atol=1e-9)
    assert trace.modes == ("seek",) * len(trace.modes)  # no boundary following needed


def test_heads_for_the_discontinuity_point_of_least_heuristic_distance():
    # From (-1, 0.2) the lower corner (0, 0) is better: d(r, O) + d(O, g) is smaller.
    space_plans = plan([box(0, 0, 2, 2)], (-1, 0.2), (3, 1))
    trace = space_plans[0]
    assert trace.aims[0] == (0.0, 0.0)
    assert trace.path[1].tolist() == [0.0, 0.0]


@pytest.mark.parametrize("goal", [(3.0, 0.5), (3.0, 0.1), (3.0, 0.9)])
def test_range_point_turns_into_a_corner_where_the_corner_enters_the_disk(goal):
    # Heading for where the side x = 0 leaves the sensing disk (R = 1.2), the robot
    # switches to the corner when the corner comes within R; that switch is located
    # exactly (to ~1e-6), not one bisection step (step / 128 = 5 mm) later.
    trace, plans = plan([box(0, 0, 1, 1)], (-3, 0.5), goal, 1.2)
    assert trace.status == "reached" and labels(trace) == ["H1", "D1"]
    corner = (0.0, 0.0) if goal[1] < 0.5 else (0.0, 1.0)
    switch = trace.path[2]
    assert trace.aims[2] == corner
    assert math.dist(switch, corner) == pytest.approx(1.2, abs=1e-5)
    assert math.dist(switch, corner) <= 1.2
    assert_valid(trace, plans)


# --------------------------------------------------------------------------- local minima


def test_wall_head_on_local_minimum_then_boundary_following():
    trace, plans = plan(WALL, (-0.2, -2), (0.3, 3), 0.5)
    assert trace.status == "reached"
    assert labels(trace) == ["H1", "M1", "L1"]
    _, minimum, leave = trace.events
    # The robot slides to where the wall is closest to the goal, the foot (0.3, 0), to
    # within the resolution of its event search (a small fraction of R = 0.5).
    assert_allclose(minimum.at, (0.3, 0.0), atol=0.03)
    # It follows the wall (its previous heading leaned right) and leaves at the corner
    # (3, 1), from where it sees the top side closer to the goal than anything so far.
    assert "follow" in trace.modes
    assert_allclose(leave.at, (3.0, 1.0), atol=1e-9)
    follow = [m for m, _ in trace.pieces]
    assert follow == ["seek", "follow", "seek"]
    assert_valid(trace, plans)


def test_leave_rules_differ_as_documented():
    tangent, _ = plan(WALL, (-0.2, -2), (0.3, 3), 0.5, "tangent_bug")
    chapter, plans = plan(WALL, (-0.2, -2), (0.3, 3), 0.5, "chapter")
    assert tangent.leave_rule == "tangent_bug" and chapter.leave_rule == "chapter"
    goal = np.array((0.3, 3))
    m_t = next(e for e in tangent.events if e.kind == "local_min")
    m_c = next(e for e in chapter.events if e.kind == "local_min")
    l_t = next(e for e in tangent.events if e.label.startswith("L"))
    l_c = next(e for e in chapter.events if e.label.startswith("L"))
    d = lambda p: float(np.hypot(*(np.asarray(p) - goal)))  # noqa: E731
    # TangentBug leaves as soon as it *sees* the top side closer to the goal than the
    # wall it followed: it is still farther from the goal than M when it leaves.
    assert d(l_t.at) > d(m_t.at) + 0.3
    # The chapter's rule leaves only once the robot itself is closer than M.
    assert d(l_c.at) == pytest.approx(d(m_c.at), abs=1e-6)
    assert l_t.s < l_c.s
    assert_valid(chapter, plans)


def test_chapter_rule_waits_until_the_robot_has_gone_round():
    # In the U of scenario 04 the robot meets a local minimum in the mouth of the U; the
    # border it follows may first lead downhill (deeper in). The rule counts only after
    # the robot has been farther from the goal than M, so it goes round the lip instead
    # of leaving into the trap again.
    scene = load_scene(U_TRAP)
    plans = plan_all(
        scene, ("dsb",), PlanOptions(sensor_range=2.0, leave_rule="chapter")
    )
    trace = plans["dsb"]
    assert trace.status == "reached"
    assert labels(trace) == ["H2", "M2", "L2"]
    minimum, leave = trace.events[1], trace.events[2]
    goal = np.asarray(scene.goal)
    d_m = np.hypot(*(np.asarray(minimum.at) - goal))
    assert np.hypot(*(np.asarray(leave.at) - goal)) == pytest.approx(d_m, abs=1e-6)
    between = [trace.position_at(s) for s in np.linspace(minimum.s, leave.s, 200)]
    assert max(np.hypot(*(p - goal)) for p in between) > d_m + 0.5


@pytest.mark.parametrize("rule", ["tangent_bug", "chapter"])
def test_u_trap_reaches_the_goal_with_both_rules(rule):
    plans = plan_all(
        load_scene(U_TRAP),
        ("vg", "dsb"),
        PlanOptions(sensor_range=2.0, leave_rule=rule),
    )
    trace = plans["dsb"]
    assert trace.status == "reached"
    assert trace.length >= plans["vg"].length
    assert_valid(trace, plans)


# --------------------------------------------------------------------------- unreachable


RING = [box(2, 2, 6, 2.5), box(2, 5.5, 6, 6), box(2, 2, 2.5, 6), box(5.5, 2, 6, 6)]


@pytest.mark.parametrize("rule", ["tangent_bug", "chapter"])
@pytest.mark.parametrize("sensor_range", [0.5, 1.0, math.inf])
def test_goal_enclosed_by_obstacles_is_unreachable(rule, sensor_range):
    trace, plans = plan(RING, (0, 0), (4, 4), sensor_range, rule)
    assert plans["vg"].status == "unreachable"
    assert trace.status == "unreachable" and trace.length is None
    assert trace.terminated == "loop"
    assert "goal is enclosed" in trace.reason
    assert_valid(trace, plans)
    # The robot went once round the ring (the walk is in the path, for the app).
    assert trace.travelled > 4 * 3.0
    assert "follow" in trace.modes


def test_robot_enclosed_in_a_pocket_is_unreachable():
    trace, plans = plan(RING, (4, 4), (0, 0), 1.0)
    assert trace.status == "unreachable" and "robot is enclosed" in trace.reason
    assert_valid(trace, plans)


@pytest.mark.parametrize("rule", ["tangent_bug", "chapter"])
def test_enclosed_goal_scenario(rule):
    plans = plan_all(load_scene(ENCLOSED), ("vg", "dsb"), PlanOptions(leave_rule=rule))
    assert plans["vg"].status == plans["dsb"].status == "unreachable"
    assert plans["dsb"].terminated == "loop"


def test_invalid_start_is_reported_by_plan_all():
    trace, _ = plan([box(0, 0, 2, 2)], (1, 1), (3, 1))
    assert trace.status == "invalid" and "start" in trace.reason


def test_step_cap_is_reported_honestly():
    scene = load_scene(scene_dict(WALL, (-0.2, -2), (0.3, 3)))
    space = plan_all(scene, ())["cspace"]
    trace = run(
        space, scene.start, BugParams(goal=scene.goal, sensor_range=0.5, max_steps=3)
    )
    assert trace.status == "unreachable" and trace.terminated == "step_cap"
    assert "not a proof" in (trace.reason or "")


def test_default_step_cap_is_generous():
    # Every shipped scenario ends well before its cap, at any range.
    for path in SCENARIOS:
        scene = load_scene(path)
        plans = plan_all(scene, ("vg",))
        if plans["vg"].status == "invalid":
            continue
        for sensor_range in (0.3, scene.sensor_range, math.inf):
            trace = plan_tangent_bug(
                plans["cspace"], scene.start, scene.goal, sensor_range
            )
            assert trace.terminated in ("goal", "loop"), (path.stem, sensor_range)
            assert trace.status == (
                "reached" if plans["vg"].status == "ok" else "unreachable"
            )


# --------------------------------------------------------------------------- Fig. 9.19


def _story(scene, ranges):
    space = plan_all(scene, ())["cspace"]
    out = []
    for sensor_range in ranges:
        trace = plan_tangent_bug(space, scene.start, scene.goal, sensor_range)
        assert trace.status == "reached"
        minima = sum(e.kind == "local_min" for e in trace.events)
        out.append((trace.length, minima, "follow" in trace.modes))
    return out


def test_fig_9_19_story_on_the_shipped_scenario():
    # q_goal sits level with the L-shaped obstacle: small R meets a local minimum and
    # follows a boundary, large R does not, and the path gets shorter as the range grows.
    scene = load_scene(FIG_9_19)
    (small, minima_s, follow_s), (medium, minima_m, _), (large, minima_l, follow_l) = (
        _story(scene, (0.6, 2.0, math.inf))
    )
    assert small > medium > large
    assert minima_s >= 1 and follow_s
    assert minima_m == minima_l == 0 and not follow_l


def test_shipped_fig_9_19_scenario_what_holds():
    scene = load_scene(FIG_9_19)
    story = _story(scene, (0.3, scene.sensor_range, 3.0, math.inf))
    assert all(minima == 0 for _, minima, _ in story[2:])
    vg = plan_all(scene, ("vg",))["vg"].length
    assert all(length >= vg for length, _, _ in story)


# --------------------------------------------------------------------------- the trace


def test_trace_answers_what_the_robot_saw_along_the_way():
    trace, _ = plan(WALL, (-0.2, -2), (0.3, 3), 0.5)
    assert_allclose(trace.position_at(0.0), trace.start)
    assert_allclose(trace.position_at(trace.length), trace.goal)
    assert_allclose(trace.position_at(1e9), trace.goal)
    for event in trace.events:
        assert_allclose(trace.position_at(event.s), event.at, atol=1e-9)
    minimum = next(e for e in trace.events if e.kind == "local_min")
    seen = trace.sensing_at(minimum.s)
    assert_allclose(seen.position, minimum.at, atol=1e-9)
    assert seen.radius == 0.5 and len(seen.segments) and len(seen.points)
    # At M every O_i in view lies farther along the wall than the robot can go downhill.
    assert trace.mode_at(minimum.s + 0.1) == "follow"
    assert trace.mode_at(0.1) == "seek"
    assert trace.aim_at(minimum.s + 0.1) is None
    assert trace.aim_at(0.1) == (0.3, 3.0)  # straight for the goal at first
    assert [e.s for e in trace.events] == sorted(e.s for e in trace.events)
    assert trace.arclength[-1] == pytest.approx(trace.length)


def test_step_is_pure_and_final_states_stay():
    scene = load_scene(scene_dict(WALL, (-0.2, -2), (0.3, 3)))
    space = plan_all(scene, ())["cspace"]
    params = BugParams(goal=scene.goal, sensor_range=0.5)
    a = step(initial_state(scene.start), space, params)
    b = step(initial_state(scene.start), space, params)
    assert a.position == b.position and a.mode == b.mode and a.events == b.events
    state = initial_state(scene.start)
    while state.mode in ("seek", "follow"):
        state = step(state, space, params)
    assert state.mode == "reached" and step(state, space, params) is state


def test_records_are_copied_with_their_changes_only():
    state = initial_state((1.0, 2.0))
    moved = evolve(state, position=(3.0, 4.0), steps=5)
    assert moved is not state and type(moved) is BugState
    assert (moved.position, moved.steps, moved.mode) == ((3.0, 4.0), 5, state.mode)
    assert (state.position, state.steps) == ((1.0, 2.0), 0)  # the original stays
    with pytest.raises(dataclasses.FrozenInstanceError):
        moved.steps = 6  # type: ignore[misc]
    with pytest.raises(TypeError, match="stpes"):
        evolve(state, stpes=5)


def test_run_equals_stepping():
    scene = load_scene(scene_dict(WALL, (-0.2, -2), (0.3, 3)))
    space = plan_all(scene, ())["cspace"]
    params = BugParams(goal=scene.goal, sensor_range=0.5)
    state = initial_state(scene.start)
    points = [np.asarray(scene.start)]
    while state.mode in ("seek", "follow"):
        state = step(state, space, params)
        points.extend(p for move in state.moves for p in move.path[1:])
    trace = run(space, scene.start, params)
    walked = float(sum(np.hypot(*np.diff(np.asarray(points), axis=0).T)))
    assert walked == pytest.approx(trace.travelled, abs=1e-9)
    assert state.steps == trace.steps


# --------------------------------------------------------------------------- API and CLI


def test_plan_all_uses_the_scene_range_unless_told():
    scene = load_scene(FIG_9_19)
    assert plan_all(scene, ("dsb",))["dsb"].sensor_range == scene.sensor_range
    assert (
        plan_all(scene, ("dsb",), PlanOptions(sensor_range=math.inf))[
            "dsb"
        ].sensor_range
        == math.inf
    )


def test_result_json_follows_the_contract():
    scene = load_scene(scene_dict(WALL, (-0.2, -2), (0.3, 3), sensor_range=0.5))
    result = plan_all(scene, ("dsb",))["dsb"]
    out = result_to_json("dsb", result)
    assert set(out) == {"status", "length", "path", "events", "ms", "reason"}
    assert out["status"] == "reached" and out["reason"] is None
    assert [e["kind"] for e in out["events"]] == ["hit", "local_min", "leave"]
    assert all(len(e["at"]) == 2 for e in out["events"])
    assert out["ms"] > 0
    json.dumps(out)


def test_cli_includes_dsb_by_default(capsys):
    assert main(["plan", str(FIG_9_19)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"vg", "svg", "dsb"} <= set(out)
    assert (
        out["dsb"]["status"] == "reached"
        and out["dsb"]["length"] >= out["vg"]["length"]
    )


def test_cli_sensor_range_reaches_dsb(capsys):
    assert (
        main(["plan", str(ENCLOSED), "--planners", "dsb", "--sensor-range", "inf"]) == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"scene", "dsb"}
    assert out["dsb"]["status"] == "unreachable" and out["dsb"]["length"] is None
    assert "enclosed" in out["dsb"]["reason"]


def test_a_futile_round_that_encloses_nothing_falls_back_to_the_closest_point():
    # Bug1's safety net, driven through the pure step: a robot following the square with
    # an unbeatable d_followed goes once round, finds that the square does not enclose
    # the goal, walks on to the square's point closest to the goal and leaves there.
    scene = load_scene(scene_dict([box(0, 0, 2, 2)], (-1, 1), (3, 1)))
    space = plan_all(scene, ())["cspace"]
    geo = ring_geometry(space)
    here = np.array([0.0, 1.0])
    a, b = geo.start, geo.end
    t = np.einsum("ij,ij->i", here - a, b - a) / np.einsum("ij,ij->i", b - a, b - a)
    e = int(np.argmin(np.hypot(*(a + np.clip(t, 0, 1)[:, None] * (b - a) - here).T)))
    follow = Follow(
        ring=0, direction=1, local_min=(0.0, 1.0), d_local_min=3.0, d_followed=0.0,
        target=None, target_sigma=0.0, sigma=geo.sigma(e, float(t[e])), walked=0.0, obstacle=1,
    )  # fmt: skip
    state = BugState(position=(0.0, 1.0), mode="follow", follow=follow)
    params = BugParams(goal=scene.goal, sensor_range=1.0)
    events = []
    while state.mode in ("seek", "follow") and state.steps < 100:
        state = step(state, space, params)
        events.extend(state.events)
    assert state.mode == "reached"
    assert [e.label for e in events] == ["L1"]
    assert_allclose(events[0].at, (2.0, 1.0), atol=1e-9)  # closest to the goal (3, 1)
    # One round (8 m), then on round the bottom to (2, 1) (1 + 2 + 1 m).
    assert events[0].s == pytest.approx(8.0 + 4.0)
