"""The distance-sensor-based robot, decision by decision (section 9.6, Figs. 9.15-9.18).

TangentBug already records every sensing step of a run as a
:class:`~planners.bug._context.Decision` (:attr:`planners.BugTrace.decisions`): the box
of the flowchart of Fig. 9.15, the O_i in view with d(r, O_i) and d(O_i, g), the chosen
r_next, and the leave rule's quantities. :func:`explain_dsb` turns each into a
:class:`DsbStep` in the chapter's words: which box, which arrow it takes and why, with
the numbers; and into a :class:`~planners.explain.Step` with the geometry to draw (the
robot r with its sensor circle of radius R, the border it sees, the O_i with their
distances, the line r -> r_next -> g, the path so far and the stretch this decision
governs). The records are made at once (they are the explanation's ``tags``); each
step's drawing when it is shown (:class:`~planners.explain.Lazy`).
"""

from __future__ import annotations

__all__ = ["FLOWCHART", "DsbCandidate", "DsbStep", "explain_dsb"]

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from planners.api import plan_all
from planners.explain._steps import (
    Explanation,
    Lazy,
    Step,
    as_segments,
    circle_segments,
    marks,
    point_mark,
)

if TYPE_CHECKING:
    from planners.bug.tangent_bug import BugTrace, Decision
    from planners.registry import PlanOptions
    from planners.scene import Scene

FloatArray = npt.NDArray[np.float64]

FLOWCHART = (
    ("goal_visible", "Goal seeking: is the path to g clear within R? Yes: move to g"),
    (
        "toward_obstacle_ahead",
        "Goal seeking: nothing in the way within R: move toward g",
    ),
    ("choose_O_i", "Goal seeking: r_next = the O_i minimising d(r, O_i) + d(O_i, g)"),
    ("local_minimum", "Local minimum? Every O_i moves away from g: M, switch mode"),
    ("follow_boundary", "Boundary following: leave condition false: keep following"),
    ("leave", "Leave condition true (d(r, g) < d(M, g)): back to goal seeking"),
    ("reached", "r = g: stop"),
    ("unreachable", "Round the whole border: the goal cannot be reached"),
)
"""The boxes of Fig. 9.15 as the app draws them, in order: (box, what it says)."""


@dataclasses.dataclass(frozen=True)
class DsbCandidate:
    """One O_i of a decision, with the distances of Fig. 9.16."""

    label: str
    """``"O_1"``, ``"O_2"``, ... numbered counter-clockwise around r as sensed."""
    point: tuple[float, float]
    """O_i [m]."""
    d_robot: float
    """d(r, O_i) [m]."""
    d_goal: float
    """d(O_i, g) [m]."""
    total: float
    """d(r, O_i) + d(O_i, g) [m]."""
    valid: bool
    """Whether it could be chosen (it brings the robot closer to the goal)."""
    chosen: bool
    """Whether it is r_next."""


@dataclasses.dataclass(frozen=True)
class DsbStep:
    """One sensing step of the run in the chapter's terms (one :class:`Decision`)."""

    s: float
    """Path length travelled [m]."""
    r: tuple[float, float]
    """The robot [m]."""
    mode: str
    """``"goal seeking"`` or ``"boundary following"``: the mode from here on."""
    box: str
    """The flowchart box (first items of :data:`FLOWCHART`)."""
    arrow: str
    """Where the flowchart goes from this box, in words."""
    candidates: tuple[DsbCandidate, ...]
    """The O_i in view when the robot had to choose."""
    r_next: tuple[float, float] | None
    """The point the robot heads for (an O_i or g), None while following."""
    local_minimum: bool
    """Whether a local minimum M was declared here."""
    why: str
    """One line in the chapter's words with the numbers."""
    d_goal: float
    """d(r, g) [m]."""
    leave_test: tuple[tuple[str, float], ...] = ()
    """The leave rule's quantities while following: (name, value) [m]."""


def explain_dsb(
    scene: Scene,
    options: PlanOptions | None = None,
    *,
    plans: dict[str, Any] | None = None,
) -> Explanation:
    """Explain the DSB run on ``scene``: one step per sensing step (Fig. 9.15).

    Parameters
    ----------
    scene
        The scene.
    options
        Planner settings (sensor range R, leave rule); None for the defaults.
    plans
        Results of :func:`planners.plan_all` including ``"dsb"``, or None to compute.

    Returns
    -------
    Explanation
        One step per :class:`~planners.bug._context.Decision` of the trace; ``tags``
        holds the :class:`DsbStep` records, ``data`` the trace.

    Examples
    --------
    >>> import planners
    >>> scene = planners.load_scene("static_scenarios/06_four_obstacles_sensor.json")
    >>> dsb = planners.explain_dsb(scene, planners.PlanOptions(sensor_range=0.6))
    >>> [t.box for t in dsb.tags if t.local_minimum]
    ['local_minimum']
    >>> first = next(t for t in dsb.tags if t.box == "choose_O_i")
    >>> print(first.why)  # doctest: +ELLIPSIS
    Fig. 9.16: an obstacle is in the way; O_1 has the least d(r, O_i) + d(O_i, g) = ...
    """
    plans = plans if plans is not None else plan_all(scene, ("dsb",), options)
    trace = plans["dsb"]
    title = "Distance-sensor-based planning (section 9.6, Fig. 9.15)"
    if trace.status == "invalid" or not getattr(trace, "decisions", ()):
        reason = getattr(trace, "reason", None) or "the scene is not plannable"
        return Explanation(
            "dsb", title, (Step("dsb:invalid", f"Nothing to run: {reason}."),)
        )
    decisions = trace.decisions
    records = tuple(_record(trace, d) for d in decisions)
    ends = [*[d.s for d in decisions[1:]], trace.travelled]
    # A step's drawing (what the sensor sees there, the O_i, the lines) is made when it
    # is shown: a run round a 10,000-vertex border has thousands of decisions.
    steps = Lazy(
        len(records), lambda k: _step(trace, decisions[k], records[k], ends[k])
    )
    return Explanation("dsb", title, steps, records, trace)


# --------------------------------------------------------------------------- records


def _record(trace: BugTrace, d: Decision) -> DsbStep:
    candidates = tuple(
        DsbCandidate(
            f"O_{k}",
            (float(c.point[0]), float(c.point[1])),
            float(c.d_robot),
            float(c.d_goal),
            float(c.heuristic),
            bool(c.valid),
            d.chosen is not None and tuple(c.point) == tuple(d.chosen),
        )
        for k, c in enumerate(d.candidates, start=1)
    )
    mode = "goal seeking" if d.mode == "seek" else "boundary following"
    why, arrow = _words(trace, d, candidates)
    return DsbStep(
        s=float(d.s),
        r=(float(d.position[0]), float(d.position[1])),
        mode=mode,
        box=d.box,
        arrow=arrow,
        candidates=candidates,
        r_next=None if d.chosen is None else (float(d.chosen[0]), float(d.chosen[1])),
        local_minimum=d.box == "local_minimum",
        why=why,
        d_goal=float(d.d_goal),
        leave_test=_leave_test(trace, d),
    )


def _leave_test(trace: BugTrace, d: Decision) -> tuple[tuple[str, float], ...]:
    if d.box not in ("follow_boundary", "leave", "local_minimum"):
        return ()
    if trace.leave_rule == "chapter":
        pairs = (("d(r, g)", d.d_goal), ("d(M, g)", d.d_local_min))
    else:
        pairs = (("d_reach", d.d_reach), ("d_followed", d.d_followed))
    return tuple((name, float(v)) for name, v in pairs if v is not None)


def _m(x: float | None) -> str:
    return "unknown" if x is None else ("inf" if math.isinf(x) else f"{x:.2f} m")


def _words(
    trace: BugTrace, d: Decision, candidates: tuple[DsbCandidate, ...]
) -> tuple[str, str]:
    """Return the step's line of text and the flowchart arrow it takes."""
    if d.box == "choose_O_i":
        return _choose_words(d, candidates)
    if d.box == "local_minimum":
        return _local_min_words(d, candidates)
    if d.box in ("follow_boundary", "leave"):
        return _follow_words(trace, d)
    return _plain_words(trace, d)


def _plain_words(trace: BugTrace, d: Decision) -> tuple[str, str]:
    """Return the words of the boxes that need no candidates or leave test."""
    words = {
        "goal_visible": (
            f"Fig. 9.15: nothing the sensor sees blocks the line to g (R = "
            f"{_m(trace.sensor_range)}): move straight to the goal, d(r, g) = "
            f"{_m(d.d_goal)}.",
            "goal seeking -> move to g",
        ),
        "toward_obstacle_ahead": (
            f"Fig. 9.15: no obstacle crosses the line to g within R = "
            f"{_m(trace.sensor_range)}: move toward the goal until one comes into range.",
            "goal seeking -> move toward g",
        ),
        "reached": ("Fig. 9.15: r = g: the robot has reached the goal.", "stop"),
    }
    return words.get(
        d.box,
        (
            "Fig. 9.15: the robot went all the way round the border that cuts it off "
            "from the goal: the goal cannot be reached.",
            "stop",
        ),
    )


def _choose_words(d: Decision, candidates: tuple[DsbCandidate, ...]) -> tuple[str, str]:
    chosen = next((c for c in candidates if c.chosen), None)
    if chosen is None:  # heading for the goal itself
        return (
            "Fig. 9.16: the goal is the best point in view: r_next = g.",
            "goal seeking -> move to r_next",
        )
    others = len(candidates) - 1
    slide = (
        " (two O_i equally good: the robot slides between them)" if d.sliding else ""
    )
    return (
        f"Fig. 9.16: an obstacle is in the way; {chosen.label} has the least "
        f"d(r, O_i) + d(O_i, g) = {chosen.d_robot:.2f} + {chosen.d_goal:.2f} = "
        f"{chosen.total:.2f} m of the {others + 1} O_i in view, so r_next = "
        f"{chosen.label}{slide}.",
        "goal seeking -> move to r_next",
    )


def _local_min_words(
    d: Decision, candidates: tuple[DsbCandidate, ...]
) -> tuple[str, str]:
    if candidates:
        best = min(c.d_goal for c in candidates)
        reason = (
            f"every O_i in view is at least as far from g (nearest d(O_i, g) = "
            f"{best:.2f} m) as r is (d(r, g) = {d.d_goal:.2f} m)"
        )
    else:
        reason = "no O_i is in view, and the goal direction is blocked"
    return (
        f"Fig. 9.17: local minimum M: {reason}; switch to boundary following.",
        "local minimum? yes -> boundary following",
    )


def _follow_words(trace: BugTrace, d: Decision) -> tuple[str, str]:
    leave = d.box == "leave"
    if trace.leave_rule == "chapter":
        test = f"d(r, g) = {_m(d.d_goal)} {'<' if leave else '>='} d(M, g) = {_m(d.d_local_min)}"
    else:
        test = (
            f"d_reach = {_m(d.d_reach)} {'<' if leave else '>='} d_followed = "
            f"{_m(d.d_followed)} (TangentBug's leave rule)"
        )
    if leave:
        return (
            f"Fig. 9.18: {test}: leave the boundary, back to goal seeking.",
            "leave condition? yes -> goal seeking",
        )
    return (
        f"Boundary following (Fig. 9.15): {test}: keep following the boundary.",
        "leave condition? no -> keep following",
    )


# --------------------------------------------------------------------------- geometry


def _step(trace: BugTrace, d: Decision, rec: DsbStep, end: float) -> Step:
    r = np.asarray(rec.r)
    sensing = trace.sensing_at(d.s) if trace.cspace is not None else None
    sensor = (
        circle_segments(r, trace.sensor_range)
        if math.isfinite(trace.sensor_range)
        else np.zeros((0, 2, 2))
    )
    cand = point_mark(
        "candidate",
        [c.point for c in rec.candidates],
        tuple(
            (f"{c.label} {c.d_robot:.2f}+{c.d_goal:.2f}={c.total:.2f}", c.point)
            for c in rec.candidates
        ),
    )
    none = np.zeros((0, 2, 2))
    chosen = as_segments([(rec.r, rec.r_next)]) if rec.r_next is not None else none
    heading = (
        as_segments([(rec.r_next, trace.goal)]) if rec.r_next is not None else none
    )
    focus = _focus(trace, rec)
    table = tuple(
        (
            c.label + (" *" if c.chosen else "") + ("" if c.valid else " (away)"),
            f"{c.d_robot:.2f} + {c.d_goal:.2f} = {c.total:.2f}",
        )
        for c in rec.candidates
    ) + tuple((name, f"{value:.2f}") for name, value in rec.leave_test)
    return Step(
        f"dsb:{rec.box}",
        rec.why,
        marks(
            done=_piece(trace, 0.0, d.s),
            current=_piece(trace, d.s, end),
            sensor=sensor,
            seen=sensing.segments if sensing is not None else np.zeros((0, 2, 2)),
            candidate=cand,
            chosen=chosen,
            heading=heading,
            focus=focus,
        ),
        (
            ("mode", rec.mode),
            ("box", rec.box),
            ("arrow", rec.arrow),
            ("d(r, g)", f"{rec.d_goal:.2f}"),
            *table,
        ),
    )


def _focus(trace: BugTrace, rec: DsbStep) -> Any:
    """Return the robot r as a focus mark, and the M it follows a border from.

    r is named M or L where it declares a local minimum or leaves, with the leave
    test's numbers while it follows a border.
    """
    name = "M" if rec.local_minimum else "L" if rec.box == "leave" else "r"
    if rec.leave_test and rec.box != "local_minimum":
        (a, x), (b, y) = rec.leave_test[0], rec.leave_test[-1]
        sign = "<" if rec.box == "leave" else ">="
        name = f"{name}: {a} {x:.2f} {sign} {b} {y:.2f}"
    points, labels = [rec.r], [(name, rec.r)]
    m = _last_local_min(trace, rec.s)
    far = m is not None and math.dist(m, rec.r) > 0.25 * min(trace.sensor_range, 1.0)
    if (
        m is not None
        and far
        and rec.mode == "boundary following"
        and not rec.local_minimum
    ):
        points.append(m)
        labels.append(("M", m))
    return point_mark("focus", points, labels)


def _last_local_min(trace: BugTrace, s: float) -> tuple[float, float] | None:
    ms = [e.at for e in trace.events if e.kind == "local_min" and e.s <= s + 1e-12]
    return (float(ms[-1][0]), float(ms[-1][1])) if ms else None


def _piece(trace: BugTrace, s0: float, s1: float) -> FloatArray:
    """Return the trace's path between arclengths s0 and s1 as segments."""
    if s1 - s0 <= 0.0:
        return np.zeros((0, 2, 2))
    cum = np.asarray(trace.arclength)
    inner = trace.path[(cum > s0) & (cum < s1)]
    pts = np.vstack(
        [trace.position_at(s0)[None, :], inner, trace.position_at(s1)[None, :]]
    )
    return np.stack([pts[:-1], pts[1:]], axis=1)
