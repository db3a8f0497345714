"""The pieces TangentBug's two modes share (section 9.6, Fig. 9.15).

Goal seeking (:mod:`planners.bug._seek`) and boundary following (:mod:`planners.bug._follow`)
never import each other: what passes between them is a :class:`BugState` built from the
records here, and the :class:`Context` built once per (configuration space, parameters).
The records of the run (:class:`BugParams`, :class:`BugEvent`, :class:`Move`,
:class:`Follow`, :class:`BugState`) and of its decisions are public through
:mod:`planners.bug.tangent_bug`; the small geometry below (points, polylines, disks) is what
both modes and the leave rules (:mod:`planners.bug._leave`) measure with.
"""

from __future__ import annotations

__all__ = [
    "BOXES",
    "FOLLOW",
    "LEAVE_RULES",
    "REACHED",
    "SEEK",
    "UNREACHABLE",
    "BugEvent",
    "BugParams",
    "BugState",
    "Candidate",
    "Decision",
    "Follow",
    "LeaveCheck",
    "LeaveRule",
    "Move",
    "make_context",
]

import dataclasses
import math
from typing import Any, NamedTuple, Protocol, TypeVar

import numpy as np
import numpy.typing as npt
import shapely

from planners.bug.trace import FOLLOW, SEEK
from planners.space.border import RingGeometry, ring_geometry
from planners.space.expansion import ConfigurationSpace
from planners.space.geometry import as_point as _pt
from planners.space.geometry import segment_closest as _segment_closest

FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float]

LEAVE_RULES = ("tangent_bug", "chapter")
REACHED = "reached"
UNREACHABLE = "unreachable"


# --------------------------------------------------------------------------- values


@dataclasses.dataclass(frozen=True)
class BugParams:
    """What the robot knows before it starts: the goal, its sensor, its leave rule."""

    goal: Point
    """Goal (x, y) [m]."""
    sensor_range: float = math.inf
    """Sensor range R [m], positive; ``math.inf`` for unlimited."""
    leave_rule: str = "tangent_bug"
    """``"tangent_bug"`` (d_reach < d_followed) or ``"chapter"`` (d(r, g) < d(M, g))."""
    step_fraction: float = 0.5
    """Longest straight move between two sensor readings, as a fraction of R."""
    refine: int = 7
    """Bisection iterations that locate where a decision changes within a step (to
    within 1/128 of the step; exactly where a range point turns into a corner)."""
    max_steps: int | None = None
    """Hard cap on steps; None derives a generous one from the scene's size."""


@dataclasses.dataclass(frozen=True)
class BugEvent:
    """A labelled point of the run, as in Fig. 9.19."""

    kind: str
    """``"hit"`` (H_i), ``"leave"`` (L_i after boundary following, D_i when the goal
    comes free again while seeking) or ``"local_min"`` (M_i)."""
    at: Point
    """Where the robot was [m]."""
    label: str
    """Figure label: ``"H2"``, ``"D2"``, ``"M3"``, ``"L3"``; the number is the scene's
    obstacle (1-based), ``"w"`` for the walls."""
    obstacle: int | None
    """The obstacle concerned (1-based, scene order), None for the walls."""
    s: float
    """Arclength along the path where it happened [m]."""


class Move(NamedTuple):
    """One piece of motion within a step."""

    mode: str
    """``"seek"`` or ``"follow"``."""
    path: FloatArray
    """Polyline (k, 2) from where the robot was [m]."""
    aim: Point | None
    """Where the robot was heading while seeking (the chosen O_i or the goal), else None."""


@dataclasses.dataclass(frozen=True)
class Follow:
    """Memory of the boundary-following mode."""

    ring: int
    """Followed border ring (index into :attr:`RingGeometry.rings`)."""
    direction: int
    """+1: walk the ring forward (blocked space on the left), -1: backward."""
    local_min: Point
    """M, where the local minimum was found [m]."""
    d_local_min: float
    """d(M, g) [m]."""
    d_followed: float
    """Least distance to the goal of the followed border sensed so far [m]."""
    target: Point | None
    """While approaching the border: the point of the border the robot heads for."""
    target_sigma: float
    """Arclength of ``target`` along the ring [m]."""
    sigma: float
    """While walking: the robot's arclength along the ring [m]."""
    walked: float
    """Distance walked along the ring since joining it [m]."""
    obstacle: int | None
    """The followed obstacle's number (1-based), None for the walls."""
    exit_sigma: float | None = None
    """After a futile full round: where the robot will leave (the border's point closest
    to the goal)."""
    risen: bool = False
    """Chapter rule: the robot has been farther from the goal than M since it began
    following (before that, d(r, g) < d(M, g) does not count)."""
    d_reach: float | None = None
    """TangentBug rule: d_reach where the robot last looked at the followed border [m];
    None where the view could not matter (not sensed)."""


@dataclasses.dataclass(frozen=True, eq=False)
class BugState:
    """Where the robot is, what mode it is in, and what the last step did."""

    position: Point
    """The robot [m]."""
    mode: str
    """``"seek"``, ``"follow"``, or a final ``"reached"`` / ``"unreachable"``."""
    steps: int = 0
    """Steps taken."""
    travelled: float = 0.0
    """Path length so far [m]."""
    blocking: int = -1
    """Ring that blocked the goal direction at the last goal-seeking decision (-1: none)."""
    blocking_obstacle: int | None = None
    """Its obstacle number, for the labels."""
    quiet_depart: bool = False
    """After a leave, the goal coming free is not a new departure D_i."""
    follow: Follow | None = None
    """Boundary-following memory, None while seeking."""
    moves: tuple[Move, ...] = ()
    """What the last step did, each move starting where the previous one ended."""
    events: tuple[BugEvent, ...] = ()
    """Events of the last step."""
    decisions: tuple[Decision, ...] = ()
    """Decisions of the last step (one, plus a leave or the final one)."""
    reason: str | None = None
    """Why the run ended unsuccessfully."""
    terminated: str | None = None
    """``"goal"``, ``"loop"`` or ``"step_cap"`` once final."""
    left: tuple[Follow, float] | None = None
    """The boundary-following memory when the robot last left a border, and the path
    length then: if it stops at a local minimum on the same border again without having
    moved, the round it is going continues (ties between equally distant minima would
    otherwise let it circle an enclosure for ever)."""
    heading: Point | None = None
    """Unit direction of the last goal-seeking move (boundary following continues it)."""
    cache: Any = None
    """The goal-seeking decision at ``position`` if already computed (a pure function of
    the position; kept only to avoid sensing twice)."""


BOXES = (
    "goal_visible",
    "toward_obstacle_ahead",
    "choose_O_i",
    "local_minimum",
    "follow_boundary",
    "leave",
    "reached",
    "unreachable",
)
"""The boxes of the chapter's flowchart (Fig. 9.15) a :class:`Decision` can be in:

- ``"goal_visible"``: nothing blocks the segment to the goal: move straight to it;
- ``"toward_obstacle_ahead"``: nothing blocks the goal direction within R (an obstacle
  lies beyond): move toward the goal until it comes into range;
- ``"choose_O_i"``: an obstacle is in the way: r_next is the candidate O_i that minimises
  d(r, O_i) + d(O_i, g) (Fig. 9.16);
- ``"local_minimum"``: every O_i would take the robot away from the goal (Fig. 9.17):
  switch to boundary following (mode ``"follow"`` from here);
- ``"follow_boundary"``: follow the border; the leave rule does not hold;
- ``"leave"``: the leave rule holds (Fig. 9.18): back to goal seeking (mode ``"seek"``
  from here);
- ``"reached"``: the robot is at the goal;
- ``"unreachable"``: it went all the way round a border that separates it from the goal.
"""


class Candidate(NamedTuple):
    """One discontinuity point O_i of the local tangent graph (Fig. 9.16) at a decision.

    A named tuple rather than a dataclass: a run makes a few hundred of them.
    """

    point: Point
    """O_i [m]."""
    kind: str
    """``"occluding"``, ``"occluded"`` (a corner) or ``"range"`` (where the border leaves
    the sensing circle), as in :class:`planners.bug.sensor.Sensing`."""
    d_robot: float
    """d(r, O_i) [m]."""
    d_goal: float
    """d(O_i, g) [m]."""
    heuristic: float
    """d(r, O_i) + d(O_i, g) [m], the quantity minimised."""
    valid: bool
    """Whether it was a candidate: closer to the goal than the robot, or the O_i the robot
    was heading for while that still brought it closer."""


@dataclasses.dataclass(frozen=True)
class Decision:
    """One sensing and decision step of the run: which box of Fig. 9.15, on what grounds."""

    s: float
    """Arclength along the path where it was taken [m]."""
    position: Point
    """The robot r [m]."""
    mode: str
    """``"seek"`` or ``"follow"``: the mode the robot moves in from here (a local minimum
    switches to following, a leave to seeking)."""
    box: str
    """The flowchart box (:data:`BOXES`)."""
    d_goal: float
    """d(r, g) [m]."""
    chosen: Point | None = None
    """r_next: the O_i (or the goal) the robot heads for while seeking, else None."""
    candidates: tuple[Candidate, ...] = ()
    """The O_i in view when the robot had to choose (``"choose_O_i"``,
    ``"local_minimum"``), else empty."""
    sliding: bool = False
    """Two O_i were equally good: the robot moves between them (a sliding mode) while
    heading for ``chosen``."""
    d_local_min: float | None = None
    """d(M, g) while following [m]."""
    d_followed: float | None = None
    """TangentBug rule: least distance to the goal of the followed border sensed since M [m]."""
    d_reach: float | None = None
    """TangentBug rule: least distance to the goal of the followed border in view here
    (0 when the goal is in view) [m]; None where not sensed."""


_Record = TypeVar("_Record", "BugState", "Follow")


def evolve(record: _Record, **changes: Any) -> _Record:
    """Return a copy of a frozen ``BugState`` or ``Follow`` with ``changes``.

    What :func:`dataclasses.replace` does, five times faster: it re-reads the fields and
    runs ``__init__`` on every call, and a run makes a few hundred copies. These
    records have no ``__post_init__`` to skip.
    """
    # A frozen dataclass without slots keeps exactly its fields in __dict__.
    if not changes.keys() <= record.__dict__.keys():
        raise TypeError(f"unknown fields {set(changes) - record.__dict__.keys()}")
    new = object.__new__(type(record))
    new.__dict__.update(record.__dict__)
    new.__dict__.update(changes)
    return new


# --------------------------------------------------------------------------- context


class LeaveCheck(NamedTuple):
    """What the leave rule found on a walked piece of path."""

    follow: Follow
    """The boundary-following memory, updated with what the rule saw on the way."""
    stop: float | None
    """Arclength along the piece where the rule first holds [m], None if nowhere."""
    d_reach: float | None = None
    """TangentBug rule: d_reach where the rule holds (None: not that rule)."""


class LeaveRule(Protocol):
    """The leave rule of boundary following: the one thing the two variants differ in.

    Implementations are stateless (their memory lives in :class:`Follow`: d_followed,
    ``risen``), so one instance serves every run.
    """

    name: str
    """The name in ``BugParams.leave_rule``."""

    def walk_length(self, ctx: Context, f: Follow, remaining: float) -> float:
        """Return how far to walk along the ring before asking again [m].

        ``remaining`` is what is left of the round (or up to Bug1's exit) [m].
        """
        ...

    def check(
        self, ctx: Context, f: Follow, path: FloatArray, cum: FloatArray
    ) -> LeaveCheck:
        """Find where on ``path`` (k, 2), arclengths ``cum`` (k,), the rule first holds."""
        ...

    def after_leave(self, ctx: Context, f: Follow, p: FloatArray) -> Move | None:
        """Return the move the robot makes right after leaving at ``p``, if any."""
        ...

    def measures(self, f: Follow) -> tuple[float | None, float | None]:
        """Return the rule's quantities in ``f`` for the decision records: d_reach, d_followed."""
        ...


@dataclasses.dataclass(frozen=True, eq=False)
class Context:
    """Everything derived once per (configuration space, parameters)."""

    cspace: ConfigurationSpace
    geo: RingGeometry
    goal: FloatArray
    radius: float
    rule: str  # the leave rule's name, as in BugParams
    leave: LeaveRule  # ... and the rule itself
    seek_step: float
    follow_step: float
    tol: float  # points closer than this coincide [m]
    margin: float  # how far inside the range an obstacle must be to be seen [m]
    slide_band: float  # two heuristic distances this close are equally good [m]
    stay_band: float  # ... and while already sliding between them [m]
    max_steps: int
    refine: int
    labels: tuple[Any, ...]  # expanded obstacles, walls (for naming events)
    # Per ring: the distances from the goal to its edges, ascending, and those edges.
    edges_by_goal: tuple[tuple[list[float], list[int]], ...]


def make_context(
    cspace: ConfigurationSpace, params: BugParams, leave: LeaveRule
) -> Context:
    """Derive the step sizes, tolerances and border tables of a run (pure).

    ``leave`` is the rule ``params.leave_rule`` names (:func:`planners.bug._leave.leave_rule`).
    """
    radius = float(params.sensor_range)
    if not radius > 0:
        raise ValueError(f"sensor_range must be positive, got {params.sensor_range}")
    geo = ring_geometry(cspace)
    goal = np.asarray(params.goal, dtype=np.float64)
    pts = np.vstack([geo.start, goal[None, :]]) if len(geo.start) else goal[None, :]
    extent = float(np.hypot(*(pts.max(axis=0) - pts.min(axis=0))))
    extent = max(extent, 1e3 * cspace.eps)
    finite = math.isfinite(radius)
    seek_step = params.step_fraction * radius if finite else extent / 4.0
    seek_step = min(seek_step, extent / 4.0)
    follow_step = max(seek_step, extent / 100.0)
    tol = 10.0 * cspace.eps
    margin = min(
        1e-6 * max(radius if finite else extent, 1.0),
        1e-3 * radius if finite else math.inf,
    )
    if params.max_steps is not None:
        max_steps = params.max_steps
    else:
        # Every boundary-following round costs at most perimeter / step + a few steps per
        # corner; TangentBug's path is bounded by d + sum of perimeters * (1 + local minima).
        rounds = float(np.sum(geo.perimeter)) / follow_step + len(geo.start)
        max_steps = int(2000 + 40 * rounds + 40 * extent / seek_step)
    walls = cspace.boundary.boundary if cspace.boundary is not None else None
    labels = (tuple(e.exterior for e in cspace.expanded), walls)
    # Where a choice changes within a move, bisection finds the switch to within
    # seek_step / 2**refine; heuristic distances change at most twice as fast as the robot
    # moves, so there the two choices differ by less than this band.
    slide_band = 4.0 * seek_step / 2.0**params.refine + 10.0 * tol
    return Context(
        cspace=cspace,
        geo=geo,
        goal=goal,
        radius=radius,
        rule=params.leave_rule,
        leave=leave,
        seek_step=seek_step,
        follow_step=follow_step,
        tol=tol,
        margin=margin,
        slide_band=slide_band,
        stay_band=0.05 * seek_step,
        max_steps=max_steps,
        refine=params.refine,
        labels=labels,
        edges_by_goal=_edges_by_goal(geo, goal),
    )


def _edges_by_goal(
    geo: RingGeometry, goal: FloatArray
) -> tuple[tuple[list[float], list[int]], ...]:
    """Per ring: the distances from the goal to its edges, ascending, and those edges."""
    goal_edge = segment_distances(np.stack([geo.start, geo.end], axis=1), goal)
    out = []
    for k in range(len(geo.rings)):
        lo, hi = int(geo.offset[k]), int(geo.offset[k + 1])
        order = lo + np.argsort(goal_edge[lo:hi], kind="stable")
        out.append((goal_edge[order].tolist(), order.tolist()))
    return tuple(out)


def obstacle_at(ctx: Context, point: FloatArray) -> int | None:
    """Name the scene obstacle (1-based) whose expanded border is nearest ``point``.

    None when the walls are nearer.
    """
    outlines, walls = ctx.labels
    p = shapely.Point(point)
    best, which = math.inf, None
    if outlines:
        dist = shapely.distance(np.asarray(outlines, dtype=object), p)
        k = int(np.argmin(dist))
        best, which = float(dist[k]), k + 1
    if walls is not None and float(shapely.distance(walls, p)) < best:
        return None
    return which


def event_label(prefix: str, obstacle: int | None) -> str:
    return f"{prefix}{'w' if obstacle is None else obstacle}"


# --------------------------------------------------------------------------- helpers


def moved(
    state: BugState, moves: tuple[Move, ...], events: tuple[BugEvent, ...]
) -> BugState:
    length = sum(
        float(np.hypot(*np.diff(m.path, axis=0).T).sum())
        for m in moves
        if len(m.path) > 1
    )
    end = moves[-1].path[-1] if moves else np.asarray(state.position)
    return evolve(
        state,
        position=_pt(end),
        moves=moves,
        events=events,
        steps=state.steps + 1,
        travelled=state.travelled + length,
    )


def finish(
    state: BugState,
    end: FloatArray,
    moves: tuple[Move, ...],
    events: tuple[BugEvent, ...],
    *,
    mode: str = REACHED,
    reason: str | None = None,
    terminated: str = "goal",
) -> BugState:
    """Make the final state after ``moves``: at the goal unless told otherwise."""
    out = moved(state, moves, events)
    return evolve(
        out,
        position=_pt(end),
        mode=mode,
        reason=reason,
        terminated=terminated,
        follow=None,
    )


def segment_distances(segments: FloatArray, p: FloatArray) -> FloatArray:
    return _segment_closest(segments, p)[0]


def sigma_on_ring(
    geo: RingGeometry, x: FloatArray, ring: int, tol: float
) -> float | None:
    """Arclength of ``x`` along ``ring`` if it lies on it (within ``tol``)."""
    if ring < 0:
        return None
    lo, hi = int(geo.offset[ring]), int(geo.offset[ring + 1])
    segs = np.stack([geo.start[lo:hi], geo.end[lo:hi]], axis=1)
    dist, closest = _segment_closest(segs, x)
    k = int(np.argmin(dist))
    if dist[k] > tol:
        return None
    t = float(np.hypot(*(closest[k] - segs[k, 0])) / geo.length[lo + k])
    return geo.sigma(lo + k, min(max(t, 0.0), 1.0))


def tangents(
    geo: RingGeometry, ring: int, sigma: float
) -> tuple[FloatArray, FloatArray]:
    """Return the unit directions along ``ring`` at arclength ``sigma``: forward, backward."""
    _, e, t = geo.locate(ring, sigma)
    tol = 1e-9
    if t <= tol:
        return geo.unit[e], geo.prev_dir[e]
    if t >= 1.0 - tol:
        k = int(geo.ring[e])
        nxt = geo.edge_index(k, e - int(geo.offset[k]) + 1)
        return geo.unit[nxt], -geo.unit[e]
    return geo.unit[e], -geo.unit[e]


def point_along(path: FloatArray, cum: FloatArray, s: float) -> FloatArray:
    i = min(max(int(np.searchsorted(cum, s, side="right")) - 1, 0), len(path) - 2)
    span = cum[i + 1] - cum[i]
    t = (s - cum[i]) / span if span > 0 else 0.0
    return path[i] + min(max(t, 0.0), 1.0) * (path[i + 1] - path[i])


def cut_path(path: FloatArray, cum: FloatArray, s: float) -> FloatArray:
    """Cut the polyline ``path`` at arclength ``s``."""
    keep = path[: int(np.searchsorted(cum, s, side="left"))]
    end = point_along(path, cum, s)
    out = np.vstack([keep, end[None, :]]) if len(keep) else np.array([path[0], end])
    return out


def first_within(
    path: FloatArray, cum: FloatArray, g: FloatArray, radius: float, start: float = 0.0
) -> float | None:
    """First arclength >= ``start`` along ``path`` within ``radius`` of ``g`` (None if never)."""
    if radius <= 0:
        return None
    for i in range(len(path) - 1):
        if cum[i + 1] < start:
            continue
        p = path[i] if cum[i] >= start else point_along(path, cum, start)
        s = enter_disk(p, path[i + 1], g, radius)
        if s is not None:
            return max(float(cum[i]), start) + s
    return None


def first_outside(
    path: FloatArray, cum: FloatArray, g: FloatArray, radius: float
) -> float | None:
    """First arclength along ``path`` farther than ``radius`` from ``g`` (None if never)."""
    for i in range(len(path) - 1):
        p, q = path[i], path[i + 1]
        if math.hypot(*(p - g)) > radius:
            return float(cum[i])
        d = q - p
        length = math.hypot(*d)
        if length == 0 or math.hypot(*(q - g)) <= radius:
            continue
        # The segment leaves the disk: the larger root of |p + s u - g| = radius.
        u = d / length
        f = p - g
        b = float(np.dot(f, u))
        c = float(np.dot(f, f)) - radius * radius
        return float(cum[i]) + (-b + math.sqrt(max(b * b - c, 0.0)))
    return None


def enter_disk(
    p: FloatArray, q: FloatArray, g: FloatArray, radius: float
) -> float | None:
    """Distance along segment p -> q where it first comes within ``radius`` of ``g``."""
    d = q - p
    length = math.hypot(*d)
    f = p - g
    if math.hypot(*f) <= radius:
        return 0.0
    if length == 0:
        return None
    u = d / length
    b = float(np.dot(f, u))
    c = float(np.dot(f, f)) - radius * radius
    disc = b * b - c
    if disc < 0:
        return None
    s = -b - math.sqrt(disc)
    if 0.0 <= s <= length:
        return s
    return None
