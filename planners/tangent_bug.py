"""Distance-sensor-based path planning (section 9.6): TangentBug.

The robot is a point in the configuration space of :mod:`planners.expansion`. It knows
where it is and where the goal g is, but not the map: every decision uses only what its
360-degree range sensor of range R sees (:mod:`planners.sensor`): the visible border
within R and the discontinuity points O_i. Two modes alternate (the chapter's Fig. 9.15;
Kamon, Rivlin and Rimon 1998; Choset et al. 2005, section 2.3).

Goal seeking (motion to goal)
    If nothing blocks the segment toward g within min(R, d(r, g)), move straight toward
    g. Otherwise move toward the O_i that minimises the heuristic distance
    d(r, O_i) + d(O_i, g) among the candidates: the O_i closer to the goal than the robot
    (Kamon et al.), and the O_i the robot is already heading for as long as heading for
    it still brings the robot closer to the goal. The choice is re-made as the view
    changes. A local minimum M (Fig. 9.17) is where no candidate is left ("all of the
    vertex points available to the robot would force the robot to move away from the
    goal"), or where the O_i the robot heads for, still the best of all, stops bringing
    it closer (Choset et al.: "the direction that minimizes the heuristic begins to
    increase d(x, q_goal)"). While seeking, d(r, g) never increases.
Boundary following
    From M the robot follows the border that blocks the goal direction, continuing the
    direction of its last motion: if it is not on that border yet, it heads for the end
    of the visible piece of it on that side, then walks along the border itself (it may
    touch it: obstacles are already expanded). When the leave rule holds it goes back to
    goal seeking.

Leave rules (``leave_rule``):

``"tangent_bug"`` (default; Kamon et al., Choset et al.)
    d_followed is the least distance to the goal of any point of the followed border the
    robot has sensed since M (and d(M, g)); d_reach the least distance to the goal of the
    followed border in view now (0 if the goal itself is in view within R). The robot
    leaves as soon as d_reach < d_followed, that is, as soon as it *sees* part of the
    obstacle closer to the goal than anything seen before, and heads for that point until
    it is closer to the goal than d_followed. With R = 0 this is the chapter's rule.
``"chapter"`` (Fig. 9.15 and 9.18)
    The robot leaves when it *is* closer to the goal than M: d(r, g) < d(M, g). It ignores
    what it sees, so it walks on along the far side of an obstacle until it is level with
    M, where TangentBug would already have cut across toward the point it saw. Where the
    border leads downhill from M (into a pocket toward the goal) the inequality holds at
    once, so it only counts once the robot has been farther from the goal than M.

Termination: ``"reached"`` when the robot is at the goal (it ends exactly on it);
``"unreachable"`` when boundary following goes all the way round the followed border
without meeting the leave rule and that border separates robot and goal (the robot has
walked the whole border, so it knows that it is closed around the goal or around itself).
Should a full round end otherwise (the leave rule never met although the border does not
enclose the goal), the robot walks on to the border's point closest to the goal and
leaves there (Bug1's rule), so a reachable goal is never given up. A hard cap on the
number of steps, derived from the size of the scene and never met on the lecture
scenarios, stops a run that would not end and says so (status ``"unreachable"``, reason
"gave up ... not a proof").

Stepping is event-driven: the robot moves straight until the next point where its
decision can change (the obstacle ahead coming into range, arriving at O_i, the closest
approach to the goal) or at most a fraction of R; where the decision changes within a
move, a bisection on the sensor locates the switch point (its first probes are where the
chosen range point would turn into a corner, the most common switch, which is then
found exactly rather than to a bisection step). Where two choices are equally
good the continuous algorithm would chatter between them; the robot then moves like a
sliding mode, along the combination of both headings that keeps them equal. A run is
:func:`run`, a loop over the pure :func:`step`; it returns a :class:`BugTrace` that the
app can scrub, and that answers what the robot saw anywhere along the run
(:meth:`BugTrace.sensing_at`) and where it was heading (:meth:`BugTrace.aim_at`).

References
----------
I. Kamon, E. Rivlin and E. Rimon, "TangentBug: A range-sensor-based navigation algorithm",
International Journal of Robotics Research 17(9), 934-953, 1998.
H. Choset, K. Lynch, S. Hutchinson, G. Kantor, W. Burgard, L. Kavraki and S. Thrun,
Principles of Robot Motion, MIT Press, 2005, section 2.3 (Tangent Bug).
"""

from __future__ import annotations

__all__ = [
    "LEAVE_RULES",
    "BugEvent",
    "BugParams",
    "BugState",
    "BugTrace",
    "Follow",
    "Move",
    "heuristic_distances",
    "initial_state",
    "plan_tangent_bug",
    "run",
    "step",
]

import bisect
import dataclasses
import functools
import math
from typing import Any, NamedTuple, TypeVar

import numpy as np
import numpy.typing as npt
import shapely

from planners.expansion import ConfigurationSpace
from planners.sensor import (
    RANGE,
    RingGeometry,
    Sensing,
    disk_span,
    free_extent,
    measure_border,
    ring_geometry,
    sense,
    visible_pieces,
)

FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float]

LEAVE_RULES = ("tangent_bug", "chapter")
SEEK = "seek"
FOLLOW = "follow"
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


@dataclasses.dataclass(frozen=True, eq=False)
class BugTrace:
    """A whole DSB run: the path, its modes and events, and what the robot saw along it."""

    status: str
    """``"reached"`` or ``"unreachable"`` (``"invalid"`` from :func:`planners.plan_all`)."""
    path: FloatArray
    """The robot's path, shape (N, 2) [m]; for ``"unreachable"`` the walk until it gave up."""
    length: float | None
    """Path length when the goal is reached [m], else None."""
    reason: str | None
    """Why the goal was not reached, in words; None when it was."""
    events: tuple[BugEvent, ...]
    """Hit, leave and local-minimum points in order."""
    modes: tuple[str, ...]
    """Mode of each path segment (N - 1 entries): ``"seek"`` or ``"follow"``."""
    aims: tuple[Point | None, ...]
    """For each path segment, the point the robot was heading for while seeking (the
    chosen O_i, or the goal), None while following a border."""
    travelled: float
    """Length of ``path`` [m]."""
    start: Point
    """Start [m]."""
    goal: Point
    """Goal [m]."""
    sensor_range: float
    """R [m]."""
    leave_rule: str
    """The leave rule used."""
    steps: int
    """Number of :func:`step` calls."""
    terminated: str
    """``"goal"``, ``"loop"`` (went round an enclosing border), ``"step_cap"`` or ``"invalid"``."""
    cspace: ConfigurationSpace | None = None
    """The configuration space the robot moved in (for :meth:`sensing_at`)."""
    planner: str = "dsb"
    """The planner's short name."""
    ms: float = 0.0
    """Compute time [ms], set by :func:`planners.plan_all` (shared expansion included)."""

    @functools.cached_property
    def arclength(self) -> FloatArray:
        """Cumulative arclength at each path vertex, shape (N,) [m]."""
        if len(self.path) == 0:
            return np.zeros(0)
        steps = np.hypot(*np.diff(self.path, axis=0).T)
        return np.concatenate([[0.0], np.cumsum(steps)])

    def position_at(self, s: float) -> FloatArray:
        """Return the robot's position after travelling ``s`` metres (clamped to the run) [m]."""
        if len(self.path) == 0:
            return np.asarray(self.start, dtype=np.float64)
        cum = self.arclength
        s = min(max(float(s), 0.0), float(cum[-1]))
        i = min(int(np.searchsorted(cum, s, side="right")) - 1, len(cum) - 2)
        if i < 0:
            return self.path[0].copy()
        span = cum[i + 1] - cum[i]
        t = (s - cum[i]) / span if span > 0 else 0.0
        return self.path[i] + t * (self.path[i + 1] - self.path[i])

    def mode_at(self, s: float) -> str:
        """Return the mode (``"seek"`` or ``"follow"``) of the path at arclength ``s``."""
        if not self.modes:
            return SEEK
        cum = self.arclength
        i = int(np.searchsorted(cum, float(s), side="right")) - 1
        return self.modes[min(max(i, 0), len(self.modes) - 1)]

    def aim_at(self, s: float) -> Point | None:
        """Return the O_i (or the goal) the robot was heading for at arclength ``s``.

        None while it follows a border. Together with :meth:`sensing_at` this is the
        local tangent graph of Fig. 9.16 with the robot's choice.
        """
        if not self.aims:
            return None
        cum = self.arclength
        i = int(np.searchsorted(cum, float(s), side="right")) - 1
        return self.aims[min(max(i, 0), len(self.aims) - 1)]

    def sensing_at(self, s: float) -> Sensing:
        """Return what the robot's sensor saw after travelling ``s`` metres.

        The sensor is pure, so this recomputes it at :meth:`position_at`; the result is
        what the robot used wherever it took a decision.
        """
        if self.cspace is None:
            raise ValueError("this trace carries no configuration space")
        return sense(self.cspace, self.position_at(s), self.sensor_range)

    @property
    def pieces(self) -> tuple[tuple[str, FloatArray], ...]:
        """The path cut where the mode changes: (mode, polyline (k, 2)) in order."""
        out: list[tuple[str, FloatArray]] = []
        begin = 0
        for i in range(1, len(self.modes) + 1):
            if i == len(self.modes) or self.modes[i] != self.modes[begin]:
                out.append((self.modes[begin], self.path[begin : i + 1].copy()))
                begin = i
        return tuple(out)


def heuristic_distances(sensing: Sensing, goal: npt.ArrayLike) -> FloatArray:
    """Heuristic distance d(r, O_i) + d(O_i, g) of each discontinuity point, shape (M,).

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> seen = sense(space, (-1.0, 0.5), 5.0)
    >>> heuristic_distances(seen, (2.0, 0.5)).round(4).tolist()  # both corners alike
    [3.1796, 3.1796]
    """
    g = np.asarray(goal, dtype=np.float64)
    if len(sensing.points) == 0:
        return np.zeros(0)
    return np.hypot(*(sensing.points - sensing.position).T) + np.hypot(
        *(sensing.points - g).T
    )


_Record = TypeVar("_Record", "BugState", "Follow")


def _evolve(record: _Record, **changes: Any) -> _Record:
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


@dataclasses.dataclass(frozen=True, eq=False)
class _Context:
    """Everything derived once per (configuration space, parameters)."""

    cspace: ConfigurationSpace
    geo: RingGeometry
    goal: FloatArray
    radius: float
    rule: str
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


def _context(cspace: ConfigurationSpace, params: BugParams) -> _Context:
    """Return the context of ``params`` on ``cspace``, built once and kept on ``cspace``."""
    return cspace.derive(_build_context, params)


def _build_context(cspace: ConfigurationSpace, params: BugParams) -> _Context:
    if params.leave_rule not in LEAVE_RULES:
        raise ValueError(
            f"unknown leave rule {params.leave_rule!r} (expected one of {LEAVE_RULES})"
        )
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
    goal_edge = _segment_distances(np.stack([geo.start, geo.end], axis=1), goal)
    edges_by_goal = []
    for k in range(len(geo.rings)):
        lo, hi = int(geo.offset[k]), int(geo.offset[k + 1])
        order = lo + np.argsort(goal_edge[lo:hi], kind="stable")
        edges_by_goal.append((goal_edge[order].tolist(), order.tolist()))
    return _Context(
        cspace, geo, goal, radius, params.leave_rule, seek_step, follow_step, tol, margin, slide_band, 0.05 * seek_step,
        max_steps, params.refine, labels, tuple(edges_by_goal),
    )  # fmt: skip


def _obstacle_at(ctx: _Context, point: FloatArray) -> int | None:
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


def _label(prefix: str, obstacle: int | None) -> str:
    return f"{prefix}{'w' if obstacle is None else obstacle}"


# --------------------------------------------------------------------------- goal seeking


@dataclasses.dataclass(frozen=True, eq=False)
class _Seek:
    """The goal-seeking decision at one position (a pure function of it)."""

    kind: str  # "reached" | "goal" | "ahead" | "toward" | "local_min"
    key: tuple[Any, ...]
    blocking: int  # ring stopping the goal ray within R, -1 if none
    hit: FloatArray | None  # where it stops
    ahead: float = 0.0  # "ahead": distance to move straight toward the goal
    target: FloatArray | None = None  # "toward": the chosen O_i
    index: int = -1  # its index in the sensing
    sensing: Sensing | None = None
    sibling: int = -1  # an equally good second choice
    slide: bool = False  # slide between target and sibling
    direction: FloatArray | None = None  # the sliding direction


def _decide(
    ctx: _Context, x: FloatArray, prefer: tuple[Any, ...] | None = None
) -> _Seek:
    g = ctx.goal
    dg = float(math.hypot(*(g - x)))
    if dg <= ctx.tol:
        return _Seek("reached", ("reached",), -1, None)
    u = (g - x) / dg
    # Two questions from x: the goal ray, then (if blocked within R) the full view.
    near = measure_border(ctx.geo, x)
    extent, ring = free_extent(ctx.geo, x, u, dg, near=near)
    if extent >= dg - ctx.tol:
        return _Seek("goal", ("goal",), -1, None)
    hit = x + extent * u
    if extent > ctx.radius - 0.5 * ctx.margin:
        # Free within the range: straight on until the obstacle ahead is just in range
        # (a little inside it, so that the sensor sees a piece of it, not a point).
        return _Seek(
            "ahead", ("goal",), -1, None, ahead=extent - ctx.radius + ctx.margin
        )
    seen = sense(ctx.geo, x, ctx.radius, near=near)
    n = len(seen.points)
    dist = np.hypot(*(seen.points - x).T) if n else np.zeros(0)
    to_goal = np.hypot(*(seen.points - g).T) if n else np.zeros(0)
    h = dist + to_goal
    slope = (
        ((seen.points - x) @ (x - g)) / (np.where(dist > 0, dist, 1.0) * dg)
        if n
        else np.zeros(0)
    )
    keys = [("toward", ring, *_o_key(ctx.geo, seen, i)) for i in range(n)]
    # Candidates are the O_i closer to the goal than the robot (Kamon et al.), plus the one
    # it is heading for while that still brings it closer to the goal. With none left,
    # "all of the vertex points available to the robot would force the robot to move
    # away from the goal" (Fig. 9.17): a local minimum. So is the point where the O_i it
    # is heading for, still the best of all, stops bringing it closer (Choset et al.:
    # "the direction that minimizes the heuristic begins to increase d(x, q_goal)").
    seen_ok = dist > ctx.tol
    closer = seen_ok & (to_goal < dg - ctx.tol)
    members: tuple[Any, ...] = ()
    if prefer is not None and prefer[0] == "toward":
        members = prefer[3:] if prefer[2] == "pair" else (prefer[2:],)
    going = (
        np.array([keys[i][2:] in members for i in range(n)], dtype=bool) & seen_ok
        if n
        else np.zeros(0, dtype=bool)
    )
    downhill = going & (slope < -1e-9)
    if going.any() and not downhill.any():
        overall = int(np.argmin(np.where(seen_ok, h, np.inf)))
        if going[overall]:
            return _Seek(
                "local_min",
                ("local_min", ring),
                ring,
                hit,
                target=seen.points[overall],
                index=overall,
                sensing=seen,
            )
    valid = closer | downhill
    if not valid.any():
        return _Seek("local_min", ("local_min", ring), ring, hit, sensing=seen)
    # Least heuristic distance. Exact ties (symmetric scenes) keep the previous choice,
    # else go to the left-hand one.
    h = np.where(valid, h, np.inf)
    tied = np.flatnonzero(h <= h.min() + ctx.tol)
    best = int(tied[0])
    if len(tied) > 1:
        same = [
            int(i)
            for i in tied
            if prefer is not None
            and (
                keys[i] == prefer or (prefer[2] == "pair" and keys[i][2:] in prefer[3:])
            )
        ]
        if same:
            best = same[0]
        else:
            rel = seen.points[tied] - x
            left = u[0] * rel[:, 1] - u[1] * rel[:, 0]
            best = int(tied[int(np.argmax(left))])
    target = seen.points[best]
    # When a second choice is (about) as good, the continuous algorithm would chatter
    # between the two: moving toward either makes the other the better. Like a sliding
    # mode, the robot then moves between them (see _seek_move) until one clearly wins.
    others = np.where(np.arange(n) == best, np.inf, h)
    second = int(np.argmin(others)) if n > 1 else -1
    if second >= 0:
        pair = tuple(sorted((keys[best][2:], keys[second][2:]), key=repr))
        key = ("toward", ring, "pair", *pair)
        gap = float(others[second] - h[best])
        # Enter the sliding mode within a narrow band; once in it, stay in a wider one
        # (a straight step along the sliding direction drifts off the curved switching line).
        if gap <= ctx.slide_band or (prefer == key and gap <= ctx.stay_band):
            f = _sliding_direction(ctx, seen, x, best, second)
            if f is not None:
                if float(np.dot(f, g - x)) <= 1e-9 * dg:
                    return _Seek(
                        "local_min",
                        ("local_min", ring),
                        ring,
                        hit,
                        target=target,
                        index=best,
                        sensing=seen,
                    )
                return _Seek(
                    "toward",
                    key,
                    ring,
                    hit,
                    target=target,
                    index=best,
                    sensing=seen,
                    sibling=second,
                    slide=True,
                    direction=f,
                )
    return _Seek(
        "toward", keys[best], ring, hit, target=target, index=best, sensing=seen
    )


def _heuristic_gradient(
    ctx: _Context, seen: Sensing, x: FloatArray, i: int
) -> FloatArray:
    """Gradient of d(x, O_i) + d(O_i, g) with respect to the robot's position x.

    A corner stays put as the robot moves; a range point slides along its edge with the
    sensing circle: O = A + t D with |O - x| = R gives dO = D (O - x)^T dx / ((O - x).D).
    """
    o = seen.points[i]
    to_goal = _unit(o - ctx.goal)
    if seen.kinds[i] == RANGE:
        d = ctx.geo.step[int(seen.edge[i])]
        rel = o - x
        denom = float(np.dot(rel, d))
        if abs(denom) > 1e-12 * math.hypot(*rel) * math.hypot(*d):
            # d|x - O| = 0 on the circle (R is constant); only d(O, g) changes.
            return rel * float(np.dot(d, to_goal)) / denom
    return _unit(x - o)


def _sliding_direction(
    ctx: _Context, seen: Sensing, x: FloatArray, a: int, b: int
) -> FloatArray | None:
    """Direction of the sliding motion between two equally good choices, or None.

    Filippov's convex combination of the two headings that keeps the two heuristic
    distances equal, when each heading makes the other choice the better one (that is,
    when the continuous algorithm would chatter); None otherwise.
    """
    fa, fb = _unit(seen.points[a] - x), _unit(seen.points[b] - x)
    grad = _heuristic_gradient(ctx, seen, x, a) - _heuristic_gradient(ctx, seen, x, b)
    ga, gb = float(np.dot(grad, fa)), float(np.dot(grad, fb))
    if not (ga > 0 > gb):
        return None
    lam = -gb / (ga - gb)
    f = lam * fa + (1.0 - lam) * fb
    norm = math.hypot(*f)
    return f / norm if norm > 1e-12 else None


def _unit(v: FloatArray) -> FloatArray:
    n = math.hypot(*v)
    return v / n if n > 0 else v


def _o_key(geo: RingGeometry, seen: Sensing, i: int) -> tuple[Any, ...]:
    """Identity of an O_i across readings: a corner by its vertex, else by ring and side."""
    kind = seen.kinds[i]
    if kind != RANGE:
        e, t = int(seen.edge[i]), float(seen.t[i])
        if t <= 0.0 or t >= 1.0:
            k = int(geo.ring[e])
            vertex = e if t <= 0.0 else geo.edge_index(k, e - int(geo.offset[k]) + 1)
            return ("vertex", vertex)
    return (kind, int(seen.ring[i]), int(seen.follow[i]))


def _seek_step(ctx: _Context, state: BugState) -> BugState:
    x = np.asarray(state.position, dtype=np.float64)
    dec = state.cache if isinstance(state.cache, _Seek) else _decide(ctx, x)
    events: list[BugEvent] = []
    blocking, blocking_obstacle, quiet = (
        state.blocking,
        state.blocking_obstacle,
        state.quiet_depart,
    )
    if dec.blocking != blocking and dec.kind != "reached":
        if blocking >= 0 and not quiet:
            events.append(
                BugEvent(
                    "leave",
                    _pt(x),
                    _label("D", blocking_obstacle),
                    blocking_obstacle,
                    state.travelled,
                )
            )
        if dec.blocking >= 0:
            assert dec.hit is not None
            blocking_obstacle = _obstacle_at(ctx, dec.hit)
            events.append(
                BugEvent(
                    "hit",
                    _pt(x),
                    _label("H", blocking_obstacle),
                    blocking_obstacle,
                    state.travelled,
                )
            )
            quiet = False
        else:
            blocking_obstacle = None
        blocking = dec.blocking
    base = _evolve(
        state,
        blocking=blocking,
        blocking_obstacle=blocking_obstacle,
        quiet_depart=quiet,
        cache=None,
    )

    if dec.kind == "reached":
        # Within the tolerance: step onto the goal itself, so the path ends there exactly.
        move = Move(SEEK, np.array([x, ctx.goal]), _pt(ctx.goal))
        return _finish(
            base, ctx.goal.copy(), (move,), tuple(events), REACHED, None, "goal"
        )
    if dec.kind == "goal":
        move = Move(SEEK, np.array([x, ctx.goal]), _pt(ctx.goal))
        return _finish(
            base, ctx.goal.copy(), (move,), tuple(events), REACHED, None, "goal"
        )
    if dec.kind == "ahead":
        u = (ctx.goal - x) / math.hypot(*(ctx.goal - x))
        y = x + dec.ahead * u
        out = _moved(
            base, (Move(SEEK, np.array([x, y]), _pt(ctx.goal)),), tuple(events)
        )
        return _evolve(out, heading=_pt(u))
    if dec.kind == "local_min":
        return _start_following(ctx, base, x, dec, events)

    # Toward the best O_i: until it, the closest approach to the goal, or one step.
    assert dec.target is not None and dec.sensing is not None
    w, s = _seek_move(ctx, x, dec)
    y = x + s * w
    nxt = _decide(ctx, y, dec.key)
    if nxt.key != dec.key:
        # The decision changes within this move: find where (bisection on the sensor).
        gap = max(100.0 * ctx.tol, 1e-6 * s)
        before = s - gap
        if before > 0 and _decide(ctx, x + before * w, dec.key).key != dec.key:
            lo, hi, at_hi = 0.0, before, None
            # Most often the chosen range point turns into the corner that ends its
            # border as that corner enters the sensing disk: look there first.
            guess = _corner_in_range(ctx, x, w, dec, before)
            if guess is not None and lo < guess - gap and guess + gap < hi:
                d_lo = _decide(ctx, x + (guess - gap) * w, dec.key)
                if d_lo.key != dec.key:
                    hi, at_hi = guess - gap, d_lo
                else:
                    lo = guess - gap
                    d_hi = _decide(ctx, x + (guess + gap) * w, dec.key)
                    if d_hi.key != dec.key:
                        hi, at_hi = guess + gap, d_hi
                    else:
                        lo = guess + gap
            resolution = before / 2.0**ctx.refine
            while hi - lo > resolution:
                mid = 0.5 * (lo + hi)
                d_mid = _decide(ctx, x + mid * w, dec.key)
                if d_mid.key == dec.key:
                    lo = mid
                else:
                    hi, at_hi = mid, d_mid
            y = x + hi * w
            nxt = at_hi if at_hi is not None else _decide(ctx, y, dec.key)
    out = _moved(base, (Move(SEEK, np.array([x, y]), _pt(dec.target)),), tuple(events))
    return _evolve(out, cache=nxt, heading=_pt(w))


def _corner_in_range(
    ctx: _Context, x: FloatArray, w: FloatArray, dec: _Seek, limit: float
) -> float | None:
    """Where, moving from ``x`` along ``w``, the chosen range point becomes a corner.

    The range point slides along the border, away from the piece in view, as the robot
    advances. It turns into an occluding corner (another O_i) when the first vertex
    beyond it after which the border turns away from the robot comes within R. Returns
    the distance along ``w`` at which that happens, or None (not a range point, or not
    before ``limit``). It is only a first guess for the search: the sensor decides.
    """
    seen = dec.sensing
    if seen is None or dec.index < 0 or seen.kinds[dec.index] != RANGE:
        return None
    geo = ctx.geo
    e, follow = int(seen.edge[dec.index]), int(seen.follow[dec.index])
    ring = int(geo.ring[e])
    local = e - int(geo.offset[ring])
    radius2 = ctx.radius * ctx.radius
    for _ in range(int(geo.offset[ring + 1] - geo.offset[ring])):
        # The vertex at the far end of edge e (in the direction of travel along the ring)
        # and the edge after it.
        if follow > 0:
            corner = geo.end[e]
            local += 1
        else:
            corner = geo.start[e]
            local -= 1
        after = geo.edge_index(ring, local)
        rel = x - corner
        b = float(np.dot(w, rel))
        c = float(np.dot(rel, rel)) - radius2
        disc = b * b - c
        if disc < 0:
            return None  # never comes within R on this line
        t = -b - math.sqrt(disc)
        if t > limit:
            return None
        p = x + max(t, 0.0) * w
        a = geo.start[after] - p
        d = geo.step[after]
        faces = a[0] * d[1] - a[1] * d[0] < -geo.eps * float(geo.length[after])
        if not faces:
            return t if t > 0 else None
        e = after
    return None


def _seek_move(ctx: _Context, x: FloatArray, dec: _Seek) -> tuple[FloatArray, float]:
    """Direction and length of the next straight move toward the chosen O_i.

    The move ends at O_i, at the closest approach to the goal along the way (so that the
    distance to the goal never grows while seeking), or after one step. Between two
    equally good choices the robot moves along the bisector of their directions, if that
    leads closer to the goal and is free; otherwise toward the better one.
    """
    g = ctx.goal
    assert dec.target is not None and dec.sensing is not None
    seen = dec.sensing
    w = _unit(dec.target - x)
    limit = min(math.hypot(*(dec.target - x)), ctx.seek_step)
    if dec.slide and dec.direction is not None:
        wb = dec.direction
        reach = min(limit, math.hypot(*(seen.points[dec.sibling] - x)))
        ext, _ = free_extent(ctx.geo, x, wb, reach)
        if ext > ctx.tol:
            return wb, min(ext, float(np.dot(g - x, wb)), reach)
    return w, max(min(limit, float(np.dot(g - x, w))), 0.0)


def _start_following(
    ctx: _Context, state: BugState, x: FloatArray, dec: _Seek, events: list[BugEvent]
) -> BugState:
    """Local minimum M at ``x``: pick the border and direction to follow (Choset, sec. 2.3)."""
    geo, g = ctx.geo, ctx.goal
    seen = dec.sensing if dec.sensing is not None else sense(geo, x, ctx.radius)
    ring = dec.blocking
    obstacle = _obstacle_at(ctx, dec.hit) if dec.hit is not None else None
    events.append(
        BugEvent("local_min", _pt(x), _label("M", obstacle), obstacle, state.travelled)
    )
    d_m = float(math.hypot(*(g - x)))
    on_ring = seen.segment_ring == ring
    d_followed = d_m
    if on_ring.any():
        d_followed = min(
            d_followed, float(_segment_distances(seen.segments[on_ring], g).min())
        )
    # The continuous piece of border in view that blocks the goal, and its two ends.
    direction, target, target_edge, target_t = 1, None, -1, 0.0
    chain = -1
    if dec.hit is not None and on_ring.any():
        idx = np.flatnonzero(on_ring)
        near = _segment_distances(seen.segments[idx], dec.hit)
        chain = int(seen.segment_chain[idx[int(np.argmin(near))]])
    ends = (
        np.flatnonzero((seen.chain == chain) & (seen.ring == ring))
        if chain >= 0
        else np.zeros(0, dtype=np.intp)
    )
    heading = (
        np.asarray(state.heading, dtype=np.float64)
        if state.heading is not None
        else None
    )
    sigma_here = _sigma_on_ring(geo, x, ring, ctx.tol)
    if len(ends):
        pick = -1
        if heading is not None:
            # Continue in the direction of the most recent motion (Choset et al., sec. 2.3).
            align = [
                float(np.dot(_unit(seen.points[i] - x), heading)) for i in ends.tolist()
            ]
            pick = int(ends[int(np.argmax(align))])
        elif dec.index >= 0 and dec.index in ends.tolist():
            pick = dec.index  # the chosen O_i ends this very piece of border
        elif dec.target is not None:
            # The chosen O_i is elsewhere: go round on its side of the goal direction.
            u = (g - x) / d_m
            rel = dec.target - x
            side = -1 if float(u[0] * rel[1] - u[1] * rel[0]) > 0 else 1
            match = [i for i in ends.tolist() if int(seen.follow[i]) == side]
            pick = match[0] if match else int(ends[0])
        else:
            pick = int(ends[0])
        direction = int(seen.follow[pick])
        target, target_edge, target_t = (
            seen.points[pick],
            int(seen.edge[pick]),
            float(seen.t[pick]),
        )
    if sigma_here is not None and heading is not None:
        forward, backward = _tangents(geo, ring, sigma_here)
        direction = (
            1
            if float(np.dot(forward, heading)) >= float(np.dot(backward, heading))
            else -1
        )
    if sigma_here is not None:
        walked = 0.0
        prev = state.left
        if (
            prev is not None
            and prev[0].ring == ring
            and prev[0].direction == direction
            and state.travelled - prev[1] <= 100.0 * ctx.tol
        ):
            walked = prev[0].walked
        follow = Follow(
            ring,
            direction,
            _pt(x),
            d_m,
            d_followed,
            None,
            0.0,
            sigma_here,
            walked,
            obstacle,
        )
    else:
        if target is None:
            # The whole border in view is one closed piece (a pocket): walk it from where
            # the goal direction meets it.
            assert dec.hit is not None
            target = dec.hit
            sig = _sigma_on_ring(geo, dec.hit, ring, math.inf)
            target_sigma = float(sig) if sig is not None else 0.0
        else:
            target_sigma = geo.sigma(target_edge, target_t)
        follow = Follow(
            ring,
            direction,
            _pt(x),
            d_m,
            d_followed,
            _pt(target),
            target_sigma,
            target_sigma,
            0.0,
            obstacle,
        )
    return _evolve(
        state,
        mode=FOLLOW,
        follow=follow,
        moves=(),
        events=tuple(events),
        steps=state.steps + 1,
    )


# --------------------------------------------------------------------------- boundary following


def _reach(ctx: _Context, y: FloatArray, ring: int) -> tuple[float, FloatArray]:
    """Compute d_reach at ``y`` and the point achieving it.

    d_reach is the least distance to the goal of the followed border in view, 0 when the
    goal itself is in view within R.
    """
    g = ctx.goal
    dg = float(math.hypot(*(g - y)))
    if dg <= ctx.tol:
        return 0.0, g.copy()
    near = measure_border(ctx.geo, y)
    if dg <= ctx.radius:
        extent, _ = free_extent(ctx.geo, y, (g - y) / dg, dg, near=near)
        if extent >= dg - ctx.tol:
            return 0.0, g.copy()
    mine = visible_pieces(ctx.geo, y, ctx.radius, ring, near=near)
    if len(mine) == 0:
        return dg, y.copy()
    dist, closest = _segment_closest(mine, g)
    k = int(np.argmin(dist))
    return float(dist[k]), closest[k]


def _leaves(ctx: _Context, f: Follow, y: FloatArray) -> tuple[bool, float]:
    """Tell whether the leave rule holds at ``y``: (leave, d_followed updated with y's view)."""
    if not _may_come_closer(ctx, f, y):
        return False, f.d_followed
    d_reach, _ = _reach(ctx, y, f.ring)
    return d_reach < f.d_followed - ctx.tol, min(f.d_followed, d_reach)


def _may_come_closer(ctx: _Context, f: Follow, y: FloatArray) -> bool:
    """Tell whether d_reach at ``y`` may be less than d_followed, without sensing.

    The followed border in view lies within R of ``y``: on the ring's edges that pass
    within R. When the goal is out of range and neither those edges nor ``y`` itself
    (d_reach when nothing of the ring is in view) come closer to the goal than
    d_followed, the view cannot change d_followed nor make the leave rule hold. Then
    sensing is not needed; this saves most readings on the far side of an obstacle.
    A bound with room for rounding: the pieces the sensor reports lie on these edges.
    """
    g, geo = ctx.goal, ctx.geo
    slack = 1e-9 * geo.scale
    gx, gy = float(g[0]), float(g[1])
    yx, yy = float(y[0]), float(y[1])
    dg = math.hypot(gx - yx, gy - yy)
    if dg <= ctx.radius + slack or dg < f.d_followed + slack:
        return True
    # Only the ring's edges that come closer to the goal than d_followed matter: the
    # first ones in the order of their distance to the goal.
    distance, edges = ctx.edges_by_goal[f.ring]
    r2 = (ctx.radius + slack) ** 2
    for e in edges[: bisect.bisect_left(distance, f.d_followed + slack)]:
        # The part of the edge within R of y, t in [t_in, t_out], and its point
        # closest to the goal.
        sx, sy = geo.start_list[e]
        dx, dy = geo.step_list[e]
        qa = geo.len2_list[e]
        t_in, t_out, meets = disk_span(sx - yx, sy - yy, dx, dy, qa, r2)
        if not meets or t_in > t_out:
            continue
        t = ((gx - sx) * dx + (gy - sy) * dy) / qa
        t = min(max(t, t_in), t_out)
        if math.hypot(sx + t * dx - gx, sy + t * dy - gy) < f.d_followed + slack:
            return True
    return False


def _follow_step(ctx: _Context, state: BugState) -> BugState:
    f = state.follow
    assert f is not None
    x = np.asarray(state.position, dtype=np.float64)
    geo = ctx.geo
    if f.target is not None:
        # Approach: straight to where the followed piece of border ends in view.
        target = np.asarray(f.target, dtype=np.float64)
        v = target - x
        dist = math.hypot(*v)
        s = min(dist, ctx.follow_step)
        path = np.array([x, x + s * v / dist]) if dist > 0 else np.array([x, x])
        arrived = s >= dist
        return _walk_and_check(
            ctx, state, path, arrived_sigma=f.target_sigma if arrived else None
        )
    # Walking along the ring.
    perimeter = float(geo.perimeter[f.ring])
    remaining = perimeter - f.walked
    if f.exit_sigma is not None:
        remaining = geo.ring_distance(f.ring, f.sigma, f.exit_sigma, f.direction)
    s = min(ctx.follow_step, max(remaining, 0.0))
    if ctx.rule == "chapter":
        s = max(remaining, 0.0)  # the crossing d(r, g) = d(M, g) is found exactly below
    else:
        # New border comes into view as the robot rounds a corner: look there (though
        # not at every vertex of a polygonal arc).
        s = min(s, geo.to_corner(f.ring, f.sigma, f.direction, 0.25 * ctx.follow_step))
    path, _ = geo.walk(f.ring, f.sigma, f.direction, s)
    return _walk_and_check(ctx, state, path, walked=s)


def _walk_and_check(
    ctx: _Context,
    state: BugState,
    path: FloatArray,
    *,
    arrived_sigma: float | None = None,
    walked: float | None = None,
) -> BugState:
    """Move along ``path`` (approach segment or ring walk) and check the leave rule.

    The move stops where the goal is met or the leave rule first holds; a completed
    round around the border is handled too.
    """
    f = state.follow
    assert f is not None
    g = ctx.goal
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    total = float(cum[-1])
    # The goal on the way (it may lie on the border).
    s_goal = _first_within(path, cum, g, ctx.tol)
    stop_at: float | None = None
    leave = False
    if ctx.rule == "chapter":
        # Where following starts downhill (into a pocket toward the goal), d(r, g) < d(M, g)
        # at once; the rule counts only once the robot has gone round, i.e. after it has
        # been farther from the goal than M.
        s_rise = (
            0.0 if f.risen else _first_outside(path, cum, g, f.d_local_min + ctx.tol)
        )
        if s_rise is not None:
            f = _evolve(f, risen=True)
            rest = _first_within(path, cum, g, f.d_local_min - ctx.tol, start=s_rise)
            if rest is not None:
                stop_at, leave = rest, True
    else:
        end = path[-1]
        fires, d_followed = _leaves(ctx, f, end)
        if fires:
            stop_at, leave = _refine_leave(ctx, f, path, cum), True
        elif d_followed != f.d_followed:
            f = _evolve(f, d_followed=d_followed)
    if s_goal is not None and (stop_at is None or s_goal <= stop_at):
        piece = _cut(path, cum, s_goal)
        piece[-1] = g
        return _finish(
            state, g.copy(), (Move(FOLLOW, piece, None),), (), REACHED, None, "goal"
        )
    if leave:
        assert stop_at is not None
        return _leave(ctx, state, f, _cut(path, cum, stop_at), stop_at)

    end = path[-1]
    moves = (Move(FOLLOW, path, None),)
    if arrived_sigma is not None:
        f = _evolve(f, target=None, sigma=arrived_sigma, walked=0.0)
        return _moved(_evolve(state, follow=f), moves, ())
    if f.target is not None:
        return _moved(_evolve(state, follow=f), moves, ())
    assert walked is not None
    sigma = (f.sigma + f.direction * walked) % float(ctx.geo.perimeter[f.ring])
    f = _evolve(f, sigma=sigma, walked=f.walked + walked)
    if (
        f.exit_sigma is not None
        and ctx.geo.ring_distance(f.ring, f.sigma, f.exit_sigma, f.direction) <= ctx.tol
    ):
        # Bug1's exit after a futile round: leave from the border's closest point.
        return _leave(ctx, _evolve(state, follow=f), f, path, total)
    if f.exit_sigma is None and f.walked >= float(ctx.geo.perimeter[f.ring]) - ctx.tol:
        return _full_round(ctx, _evolve(state, follow=f), f, moves)
    return _moved(_evolve(state, follow=f), moves, ())


def _refine_leave(ctx: _Context, f: Follow, path: FloatArray, cum: FloatArray) -> float:
    """Locate (bisection, then the ring vertices nearby) where the leave rule first holds."""
    total = float(cum[-1])
    if _leaves(ctx, f, path[0])[0]:
        return 0.0
    lo, hi = 0.0, total
    for _ in range(ctx.refine):
        mid = 0.5 * (lo + hi)
        if _leaves(ctx, f, _point_along(path, cum, mid))[0]:
            hi = mid
        else:
            lo = mid
    # New border comes into view when the robot rounds a corner: prefer the corner itself.
    inner = np.flatnonzero((cum > lo) & (cum < hi))
    for i in inner.tolist():
        if _leaves(ctx, f, path[i])[0]:
            return float(cum[i])
    return hi


def _leave(
    ctx: _Context,
    state: BugState,
    f: Follow,
    walked_path: FloatArray,
    walked_len: float,
) -> BugState:
    """Leave the border at the end of ``walked_path`` and go back to goal seeking."""
    p = walked_path[-1]
    g = ctx.goal
    events = (
        BugEvent(
            "leave",
            _pt(p),
            _label("L", f.obstacle),
            f.obstacle,
            state.travelled + walked_len,
        ),
    )
    left = (
        _evolve(f, walked=f.walked + (walked_len if f.target is None else 0.0)),
        state.travelled + walked_len,
    )
    moves: list[Move] = [Move(FOLLOW, walked_path, None)]
    q = p
    if ctx.rule == "tangent_bug" and f.exit_sigma is None:
        # Head for the point that made the rule hold until closer to the goal than d_followed.
        _, target = _reach(ctx, p, f.ring)
        radius = f.d_followed - ctx.tol
        if math.hypot(*(p - g)) >= radius:
            s = _enter_disk(p, target, g, radius)
            if s is not None:
                span = math.hypot(*(target - p))
                s = min(span, s + min(ctx.tol, 0.5 * (span - s)))
                q = p + s * (target - p) / span if span > 0 else p
                moves.append(Move(SEEK, np.array([p, q]), _pt(target)))
    out = _moved(state, tuple(moves), events)
    last = moves[-1].path
    heading = (
        _unit(last[-1] - last[-2])
        if len(last) > 1 and math.hypot(*(last[-1] - last[-2])) > 0
        else state.heading
    )
    return _evolve(
        out, mode=SEEK, follow=None, blocking=f.ring, blocking_obstacle=f.obstacle, quiet_depart=True, position=_pt(q),
        heading=None if heading is None else _pt(heading), left=left, cache=None,
    )  # fmt: skip


def _full_round(
    ctx: _Context, state: BugState, f: Follow, moves: tuple[Move, ...]
) -> BugState:
    """Back where boundary following began without meeting the leave rule."""
    geo, g = ctx.geo, ctx.goal
    ring = geo.rings[f.ring]
    inside = bool(shapely.contains_xy(shapely.Polygon(ring), float(g[0]), float(g[1])))
    encloses_blocked = float(geo.area[f.ring]) > 0
    separated = inside if encloses_blocked else not inside
    if separated:
        who = _label("", f.obstacle) if f.obstacle is not None else "the walls"
        what = f"obstacle {who}" if f.obstacle is not None else who
        if encloses_blocked:
            reason = f"the goal is enclosed: the robot went all the way round {what} (expanded, merged) without a way to leave"
        else:
            reason = f"the robot is enclosed: it went all the way round the pocket bounded by {what} without a way out"
        out = _moved(_evolve(state, follow=f), moves, ())
        return _evolve(out, mode=UNREACHABLE, reason=reason, terminated="loop")
    # Not a proof of unreachability: walk on to the closest point and leave there (Bug1).
    a = geo.start[geo.offset[f.ring] : geo.offset[f.ring + 1]]
    b = geo.end[geo.offset[f.ring] : geo.offset[f.ring + 1]]
    dist, closest = _segment_closest(np.stack([a, b], axis=1), g)
    k = int(np.argmin(dist))
    t = float(np.dot(closest[k] - a[k], b[k] - a[k]) / np.dot(b[k] - a[k], b[k] - a[k]))
    exit_sigma = geo.sigma(int(geo.offset[f.ring]) + k, min(max(t, 0.0), 1.0))
    out = _moved(
        _evolve(state, follow=_evolve(f, exit_sigma=exit_sigma)),
        moves,
        (),
    )
    return out


# --------------------------------------------------------------------------- the step


def initial_state(start: npt.ArrayLike) -> BugState:
    """Put the robot at ``start``, seeking the goal.

    Examples
    --------
    >>> initial_state((0, 0)).mode
    'seek'
    """
    x, y = np.asarray(start, dtype=np.float64).reshape(2)
    return BugState(position=(float(x), float(y)), mode=SEEK)


def step(state: BugState, cspace: ConfigurationSpace, params: BugParams) -> BugState:
    """Advance the robot by one event-driven step (pure: same inputs, same output).

    Parameters
    ----------
    state
        The current state; a final state (``"reached"``, ``"unreachable"``) is returned as is.
    cspace
        The configuration space the robot moves in (it only ever *senses* it).
    params
        Goal, sensor range and leave rule.

    Returns
    -------
    BugState
        The next state; ``moves`` and ``events`` say what this step did.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> params = BugParams(goal=(3.0, 0.5), sensor_range=10.0)
    >>> state = step(initial_state((-1.0, 0.5)), space, params)
    >>> state.mode, [e.label for e in state.events], state.moves[0].aim  # for a corner
    ('seek', ['H1'], (0.0, 1.0))

    References
    ----------
    I. Kamon, E. Rivlin and E. Rimon, "TangentBug: A range-sensor-based navigation
    algorithm", International Journal of Robotics Research 17(9), 1998.
    """
    if state.mode not in (SEEK, FOLLOW):
        return state
    ctx = _context(cspace, params)
    if state.mode == SEEK:
        return _seek_step(ctx, state)
    return _follow_step(ctx, state)


def run(
    cspace: ConfigurationSpace, start: npt.ArrayLike, params: BugParams
) -> BugTrace:
    """Run TangentBug from ``start`` until the goal is reached or proven unreachable.

    Parameters
    ----------
    cspace
        Configuration space; ``start`` and ``params.goal`` must be free (the caller checks).
    start
        Start, shape (2,) [m].
    params
        Goal, sensor range R and leave rule.

    Returns
    -------
    BugTrace
        Path, mode of each piece, events, and :meth:`BugTrace.sensing_at`.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), 0.0)
    >>> trace = run(space, (-1.0, 1.0), BugParams(goal=(3.0, 1.0), sensor_range=math.inf))
    >>> trace.status, round(trace.length, 6)  # over a corner, along a side, down: optimal
    ('reached', 4.828427)
    >>> trace.path.tolist()
    [[-1.0, 1.0], [0.0, 2.0], [2.0, 2.0], [3.0, 1.0]]
    >>> [e.label for e in trace.events]
    ['H1', 'D1']

    References
    ----------
    I. Kamon, E. Rivlin and E. Rimon, "TangentBug: A range-sensor-based navigation
    algorithm", International Journal of Robotics Research 17(9), 1998.
    """
    ctx = _context(cspace, params)
    state = initial_state(start)
    points: list[FloatArray] = [np.asarray(state.position, dtype=np.float64)]
    modes: list[str] = []
    aims: list[Point | None] = []
    events: list[BugEvent] = []
    while state.mode in (SEEK, FOLLOW) and state.steps < ctx.max_steps:
        state = step(state, cspace, params)
        for move in state.moves:
            for p in move.path[1:]:
                if math.hypot(*(p - points[-1])) > 0.0:
                    points.append(np.asarray(p, dtype=np.float64))
                    modes.append(move.mode)
                    aims.append(move.aim)
        events.extend(state.events)
    path, modes, aims = _simplify(
        np.asarray(points, dtype=np.float64).reshape(-1, 2), modes, aims
    )
    travelled = (
        float(np.hypot(*np.diff(path, axis=0).T).sum()) if len(path) > 1 else 0.0
    )
    if state.mode == REACHED:
        status, length, reason, terminated = REACHED, travelled, None, "goal"
    elif state.mode == UNREACHABLE:
        status, length, reason, terminated = (
            UNREACHABLE,
            None,
            state.reason,
            state.terminated or "loop",
        )
    else:
        status, length, terminated = UNREACHABLE, None, "step_cap"
        reason = (
            f"gave up after {state.steps} steps (the step cap for this scene) without reaching "
            "the goal; this is not a proof that the goal is unreachable"
        )
    return BugTrace(
        status=status,
        path=path,
        length=length,
        reason=reason,
        events=tuple(events),
        modes=tuple(modes),
        aims=tuple(aims),
        travelled=travelled,
        start=_pt(np.asarray(start, dtype=np.float64)),
        goal=_pt(ctx.goal),
        sensor_range=ctx.radius,
        leave_rule=ctx.rule,
        steps=state.steps,
        terminated=terminated,
        cspace=cspace,
    )


def plan_tangent_bug(
    cspace: ConfigurationSpace,
    start: npt.ArrayLike,
    goal: npt.ArrayLike,
    sensor_range: float = math.inf,
    leave_rule: str = "tangent_bug",
) -> BugTrace:
    """Plan with the distance-sensor-based method (TangentBug) of section 9.6.

    Parameters
    ----------
    cspace
        Configuration space (expanded obstacles, shrunk walls).
    start, goal
        Points of shape (2,) [m].
    sensor_range
        R [m]; ``math.inf`` for unlimited.
    leave_rule
        ``"tangent_bug"`` or ``"chapter"`` (see the module docstring).

    Returns
    -------
    BugTrace
        ``status`` ``"reached"``, ``"unreachable"`` or ``"invalid"`` (start or goal blocked).

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), 0.0)
    >>> plan_tangent_bug(space, (1, 1), (3, 1)).status
    'invalid'
    """
    s = np.asarray(start, dtype=np.float64).reshape(2)
    g = np.asarray(goal, dtype=np.float64).reshape(2)
    blocked = cspace.contains_blocked(np.array([s, g]))
    if blocked.any():
        which = "start" if blocked[0] else "goal"
        return BugTrace(
            status="invalid", path=np.zeros((0, 2)), length=None, reason=f"the {which} is not in free space",
            events=(), modes=(), aims=(), travelled=0.0, start=_pt(s), goal=_pt(g), sensor_range=float(sensor_range),
            leave_rule=leave_rule, steps=0, terminated="invalid", cspace=cspace,
        )  # fmt: skip
    return run(
        cspace,
        s,
        BugParams(goal=_pt(g), sensor_range=float(sensor_range), leave_rule=leave_rule),
    )


# --------------------------------------------------------------------------- helpers


def _simplify(
    path: FloatArray, modes: list[str], aims: list[Point | None]
) -> tuple[FloatArray, list[str], list[Point | None]]:
    """Drop path vertices where the robot went straight on (same mode, same aim).

    Steps end wherever the robot looked again; where nothing changed, the vertex
    carries no information. Arclengths, and hence event positions, are unchanged.
    """
    if len(path) < 3:
        return path, modes, aims
    keep = [0]
    for i in range(1, len(path) - 1):
        a, b, c = path[keep[-1]], path[i], path[i + 1]
        u, v = b - a, c - b
        straight = abs(float(u[0] * v[1] - u[1] * v[0])) <= 1e-12 * max(
            float(np.dot(u, u) + np.dot(v, v)), 1e-300
        )
        if not (
            straight
            and float(np.dot(u, v)) > 0
            and modes[i - 1] == modes[i]
            and aims[i - 1] == aims[i]
        ):
            keep.append(i)
    keep.append(len(path) - 1)
    seg = keep[:-1]
    return path[keep], [modes[i] for i in seg], [aims[i] for i in seg]


def _pt(p: npt.ArrayLike) -> Point:
    x, y = np.asarray(p, dtype=np.float64).reshape(2)
    return (float(x), float(y))


def _moved(
    state: BugState, moves: tuple[Move, ...], events: tuple[BugEvent, ...]
) -> BugState:
    length = sum(
        float(np.hypot(*np.diff(m.path, axis=0).T).sum())
        for m in moves
        if len(m.path) > 1
    )
    end = moves[-1].path[-1] if moves else np.asarray(state.position)
    return _evolve(
        state,
        position=_pt(end),
        moves=moves,
        events=events,
        steps=state.steps + 1,
        travelled=state.travelled + length,
    )


def _finish(
    state: BugState, end: FloatArray, moves: tuple[Move, ...], events: tuple[BugEvent, ...],
    mode: str, reason: str | None, terminated: str,
) -> BugState:  # fmt: skip
    out = _moved(state, moves, events)
    return _evolve(
        out,
        position=_pt(end),
        mode=mode,
        reason=reason,
        terminated=terminated,
        follow=None,
    )


def _segment_closest(
    segments: FloatArray, p: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Distance from ``p`` to each segment (K, 2, 2) and the closest points (K, 2)."""
    a, b = segments[:, 0], segments[:, 1]
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    closest = a + t[:, None] * d
    return np.hypot(*(closest - p).T), closest


def _segment_distances(segments: FloatArray, p: FloatArray) -> FloatArray:
    return _segment_closest(segments, p)[0]


def _sigma_on_ring(
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


def _tangents(
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


def _point_along(path: FloatArray, cum: FloatArray, s: float) -> FloatArray:
    i = min(max(int(np.searchsorted(cum, s, side="right")) - 1, 0), len(path) - 2)
    span = cum[i + 1] - cum[i]
    t = (s - cum[i]) / span if span > 0 else 0.0
    return path[i] + min(max(t, 0.0), 1.0) * (path[i + 1] - path[i])


def _cut(path: FloatArray, cum: FloatArray, s: float) -> FloatArray:
    """Cut the polyline ``path`` at arclength ``s``."""
    keep = path[: int(np.searchsorted(cum, s, side="left"))]
    end = _point_along(path, cum, s)
    out = np.vstack([keep, end[None, :]]) if len(keep) else np.array([path[0], end])
    return out


def _first_within(
    path: FloatArray, cum: FloatArray, g: FloatArray, radius: float, start: float = 0.0
) -> float | None:
    """First arclength >= ``start`` along ``path`` within ``radius`` of ``g`` (None if never)."""
    if radius <= 0:
        return None
    for i in range(len(path) - 1):
        if cum[i + 1] < start:
            continue
        p = path[i] if cum[i] >= start else _point_along(path, cum, start)
        s = _enter_disk(p, path[i + 1], g, radius)
        if s is not None:
            return max(float(cum[i]), start) + s
    return None


def _first_outside(
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


def _enter_disk(
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
