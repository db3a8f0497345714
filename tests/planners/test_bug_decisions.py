"""TangentBug shaped like Fig. 9.15: its decision records, leave rules and module layout."""

from __future__ import annotations

import ast
import functools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

import planners
from planners import PlanOptions, load_scene, plan_all
from planners.bug._context import BOXES, FOLLOW, SEEK, BugParams, Follow, make_context
from planners.bug._leave import ChapterLeave, TangentBugLeave, leave_rule
from planners.bug.tangent_bug import Decision, run
from planners.space.expansion import configuration_space
from tests.conftest import SCENARIOS, random_scenes, square

RANGES = (0.6, 1.0, 1.5, 2.0, math.inf)
RULES = ("tangent_bug", "chapter")
BUG_DIR = Path(planners.__file__).parent / "bug"


@functools.cache
def _trace(path: Path, sensor_range: float, rule: str):
    options = PlanOptions(sensor_range=sensor_range, leave_rule=rule)
    return plan_all(load_scene(path), ("dsb",), options)["dsb"]


def _check_decisions_agree_with_trace(trace) -> None:
    decisions = trace.decisions
    assert decisions, "a run that moved took decisions"
    assert all(d.box in BOXES and d.mode in (SEEK, FOLLOW) for d in decisions)
    assert [d.s for d in decisions] == sorted(d.s for d in decisions)
    cum = trace.arclength
    # On every path segment the decision in force has the segment's mode, and while
    # seeking its r_next is the segment's aim; while following it chooses no O_i.
    for i, (mode, aim) in enumerate(zip(trace.modes, trace.aims, strict=True)):
        for t in (0.25, 0.5, 0.75):
            s = cum[i] + t * (cum[i + 1] - cum[i])
            d = trace.decision_at(s)
            assert d is not None and d.mode == mode == trace.mode_at(s), (i, s, d)
            assert d.chosen == aim == trace.aim_at(s), (i, s, d)
            if mode == FOLLOW:
                assert d.chosen is None
    # ... at the vertices, where the choice changes, and wherever an animation samples.
    for s in [*cum[:-1], *np.linspace(0.0, cum[-1], 301)]:
        d = trace.decision_at(s)
        assert d is not None and d.chosen == trace.aim_at(s), (s, d)
        assert d.mode == trace.mode_at(s), (s, d)
    # Where a choice is in force over a stretch of path, the path heads for r_next.
    following = [*decisions[1:], None]
    for d, nxt in zip(decisions, following, strict=True):
        if d.mode != SEEK or d.chosen is None or d.sliding:
            continue
        end = nxt.s if nxt is not None else float(cum[-1])
        if end - d.s < 1e-6 or math.dist(d.chosen, d.position) < 1e-6:
            continue
        here = trace.position_at(d.s)
        ahead = trace.position_at(d.s + min(1e-3, 0.5 * (end - d.s)))
        assert_allclose(here, d.position, atol=1e-9)
        u = (ahead - here) / np.linalg.norm(ahead - here)
        v = np.subtract(d.chosen, d.position) / math.dist(d.chosen, d.position)
        assert float(np.dot(u, v)) > 1 - 1e-9, (d, u, v)
    # Every local minimum M of the events is a "local minimum?" decision, and back.
    ms = [(e.at, e.s) for e in trace.events if e.kind == "local_min"]
    found = [(d.position, d.s) for d in decisions if d.box == "local_minimum"]
    assert len(ms) == len(found)
    for (at, s), (position, s_d) in zip(ms, found, strict=True):
        assert at == position and s == pytest.approx(s_d, abs=1e-9)
    assert all(
        d.mode == FOLLOW and d.chosen is None
        for d in decisions
        if d.box == "local_minimum"
    )
    # So is every L_i a "leave" decision.
    leaves = [e.at for e in trace.events if e.kind == "leave" and e.label[0] == "L"]
    assert leaves == [d.position for d in decisions if d.box == "leave"]
    # The run ends in the box its status names.
    if trace.status == "reached" or trace.terminated == "loop":
        assert decisions[-1].box == trace.status
        assert trace.decision_at(float(cum[-1])) == decisions[-1]


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("sensor_range", RANGES)
@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_decisions_agree_with_the_trace(path, sensor_range, rule):
    trace = _trace(path, sensor_range, rule)
    if trace.status == "invalid":
        pytest.skip("start or goal blocked")
    _check_decisions_agree_with_trace(trace)


@settings(max_examples=40, deadline=None)
@given(
    scene=random_scenes(),
    sensor_range=st.sampled_from([0.5, 1.5, 4.0, math.inf]),
    rule=st.sampled_from(RULES),
)
def test_decisions_agree_with_the_trace_on_random_scenes(scene, sensor_range, rule):
    options = PlanOptions(sensor_range=sensor_range, leave_rule=rule)
    trace = plan_all(scene, ("dsb",), options)["dsb"]
    assume(trace.status != "invalid" and len(trace.modes) > 0)
    _check_decisions_agree_with_trace(trace)


def test_decision_records_the_choice_of_fig_9_16():
    # A square between start and goal, seen whole: two corners O_1, O_2 with their
    # heuristic distances d(r, O_i) + d(O_i, g); the upper one chosen (left-hand tie).
    space = configuration_space((square(0, 0, 2, 2),), 0.0)
    trace = run(space, (-1.0, 1.0), BugParams(goal=(3.0, 1.0)))
    first = trace.decisions[0]
    assert (first.s, first.position, first.mode, first.box) == (
        0.0,
        (-1.0, 1.0),
        SEEK,
        "choose_O_i",
    )
    assert first.d_goal == 4.0 and first.chosen == (0.0, 2.0)
    corners = {c.point: c for c in first.candidates}
    assert set(corners) == {(0.0, 0.0), (0.0, 2.0)}
    for c in corners.values():
        assert_allclose(
            [c.d_robot, c.d_goal, c.heuristic],
            [math.sqrt(2), math.sqrt(10), math.sqrt(2) + math.sqrt(10)],
        )
        assert c.valid and c.kind == "occluding"
    # Over the corner, along the top side (a step at a time), down to the goal.
    boxes = [(d.box, d.chosen) for d in trace.decisions]
    assert boxes == [("choose_O_i", (0.0, 2.0))] * 2 + [
        ("choose_O_i", (2.0, 2.0))
    ] * 3 + [
        ("goal_visible", (3.0, 1.0)),
        ("reached", (3.0, 1.0)),
    ]
    assert trace.decision_at(-1.0) == first  # clamped to the run, as aim_at


def test_decisions_while_following_carry_the_leave_rule_quantities():
    trace = _trace(
        next(p for p in SCENARIOS if p.stem.startswith("04_")), 2.0, "tangent_bug"
    )
    follow = [d for d in trace.decisions if d.box == "follow_boundary"]
    assert follow
    for d in follow:
        assert d.d_local_min is not None and d.d_followed is not None
        assert d.d_followed <= d.d_local_min
    leave = next(d for d in trace.decisions if d.box == "leave")
    assert leave.d_reach is not None and leave.d_reach < leave.d_followed
    chapter = _trace(
        next(p for p in SCENARIOS if p.stem.startswith("04_")), 2.0, "chapter"
    )
    assert all(
        d.d_reach is None and d.d_followed is None
        for d in chapter.decisions
        if d.mode == FOLLOW
    )
    left = next(d for d in chapter.decisions if d.box == "leave")
    assert left.d_goal < left.d_local_min  # d(r, g) < d(M, g)


# --------------------------------------------------------------------------- leave rules


@pytest.fixture
def square_space():
    """A square of side 2 in the way of the goal (3, 1); M = (0, 1) on its left side."""
    return configuration_space((square(0, 0, 2, 2),), 0.0)


def _follow(**changes) -> Follow:
    follow = Follow(
        ring=0, direction=1, local_min=(0.0, 1.0), d_local_min=3.0, d_followed=3.0,
        target=None, target_sigma=0.0, sigma=0.0, walked=0.0, obstacle=1,
    )  # fmt: skip
    return Follow(**{**follow.__dict__, **changes})


def test_tangent_bug_rule_leaves_where_it_sees_the_far_corner(square_space):
    rule = TangentBugLeave()
    ctx = make_context(square_space, BugParams(goal=(3.0, 1.0)), rule)
    # Up the left side: at the top-left corner the whole top side comes into view, and its
    # far end (2, 2) is closer to the goal (sqrt 2) than d_followed = 3.
    path = np.array([[0.0, 1.0], [0.0, 2.0]])
    found = rule.check(ctx, _follow(), path, np.array([0.0, 1.0]))
    assert found.stop is not None and 0.0 < found.stop <= 1.0
    assert found.d_reach == pytest.approx(math.sqrt(2))
    # Right after leaving it heads for (2, 2) until within d_followed of the goal.
    move = rule.after_leave(ctx, _follow(), np.array([0.0, 2.0]))
    assert move is not None and move.mode == SEEK and move.aim == (2.0, 2.0)
    assert math.dist(move.path[-1], (3.0, 1.0)) < 3.0
    # With nothing closer in view the memory takes in what was seen, and it walks on.
    seen = _follow(d_followed=1.0)
    stays = rule.check(ctx, seen, path, np.array([0.0, 1.0]))
    assert stays.stop is None and stays.follow.d_followed == 1.0
    assert rule.measures(stays.follow) == (stays.follow.d_reach, 1.0)


def test_chapter_rule_counts_only_after_rising_above_m(square_space):
    rule = ChapterLeave()
    ctx = make_context(square_space, BugParams(goal=(3.0, 1.0)), rule)
    # Up the left side (rising above d(M, g) = 3 at once), along the top: back within 3 of
    # the goal at x = 3 - sqrt(8).
    path = np.array([[0.0, 1.0], [0.0, 2.0], [2.0, 2.0]])
    found = rule.check(ctx, _follow(), path, np.array([0.0, 1.0, 3.0]))
    assert found.follow.risen
    assert found.stop == pytest.approx(1.0 + 3.0 - math.sqrt(8.0))
    assert rule.after_leave(ctx, found.follow, path[-1]) is None
    assert rule.measures(found.follow) == (None, None)
    # Downhill from M (into a pocket toward the goal) the inequality holds at once, but
    # it does not count before the robot has been farther than M.
    downhill = np.array([[0.0, 1.0], [1.0, 1.0]])
    early = rule.check(ctx, _follow(), downhill, np.array([0.0, 1.0]))
    assert early.stop is None and not early.follow.risen
    # The chapter's rule walks the rest of the round in one piece; TangentBug's looks
    # again at the next corner.
    assert rule.walk_length(ctx, _follow(), 5.0) == 5.0
    assert TangentBugLeave().walk_length(ctx, _follow(), 5.0) <= ctx.follow_step


def test_leave_rule_names():
    assert leave_rule("tangent_bug").name == "tangent_bug"
    assert isinstance(leave_rule("chapter"), ChapterLeave)
    with pytest.raises(ValueError, match="unknown leave rule"):
        leave_rule("bug2")


# --------------------------------------------------------------------------- layout


def _imported_modules(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module is not None:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


@pytest.mark.parametrize(
    ("module", "other"), [("_seek", "_follow"), ("_follow", "_seek")]
)
def test_the_two_modes_do_not_import_each_other(module, other):
    imported = _imported_modules(BUG_DIR / f"{module}.py")
    assert not any(other in name for name in imported), imported


def test_the_modes_do_not_branch_on_the_leave_rule():
    for module in ("_seek", "_follow"):
        assert ".rule" not in (BUG_DIR / f"{module}.py").read_text()


# Decision records are frozen values.
def test_a_decision_is_a_frozen_value():
    d = Decision(s=0.0, position=(0.0, 0.0), mode=SEEK, box="reached", d_goal=0.0)
    with pytest.raises(AttributeError):
        d.s = 1.0  # type: ignore[misc]


def test_an_invalid_trace_has_no_decisions():
    space = configuration_space((square(0, 0, 2, 2),), 0.0)
    trace = planners.plan_tangent_bug(space, (1.0, 1.0), (3.0, 1.0))
    assert trace.status == "invalid"
    assert trace.decisions == () and trace.decision_at(0.0) is None
