"""Bug2: the classic M-line bug algorithm with a contact sensor (a contrast to section 9.6).

The chapter's distance-sensor-based method (DSB, TangentBug) sees the border within a
range R and cuts corners toward the best point O_i it sees. Bug2 is what a robot does with
R = 0, a bumper instead of a range sensor (Lumelsky and Stepanov 1987; Choset et al. 2005,
section 2.2):

Motion to goal
    Move along the *M-line*, the straight segment from the start to the goal, until the
    goal is reached or the robot touches an obstacle: a *hit point* H_i.
Boundary following
    Walk along the obstacle's border, turning left at the hit (the obstacle on the robot's
    right), until the robot is back on the M-line at a point closer to the goal than
    H_i from which it can move toward the goal: a *leave point* L_i. Then motion to goal
    again. Back at H_i without such a point, the goal is unreachable: the border the
    robot went round separates it from the goal.

Because every leave point is closer to the goal than the hit before it, the run ends.
In a lecture Bug2 shows what the range sensor buys: Bug2 walks the whole far side of an
obstacle that TangentBug leaves as soon as it sees round it.

Like every planner here it works in the configuration space of
:mod:`planners.space.expansion`: the robot is a point, obstacles are expanded, and the border is
free, so the robot may walk along it. Where borders touch at a single point (a *pinch*),
the robot passes onto the other border and walks round the whole connected obstacle. Its
one blind spot is free space joined to the rest *only* through pinches (zero-width gaps):
a pocket whose every way in is a pinch is not entered, and the goal in it is reported
unreachable where the visibility graph slips through the point.

References
----------
V. J. Lumelsky and A. A. Stepanov, "Path-planning strategies for a point mobile automaton
moving amidst unknown obstacles of arbitrary shape", Algorithmica 2, 403-430, 1987.
H. Choset et al., Principles of Robot Motion, MIT Press, 2005, section 2.2 (Bug2).
"""

from __future__ import annotations

__all__ = ["Bug2Decision", "Bug2Trace", "plan_bug2"]

import dataclasses
import math

import numpy as np
import numpy.typing as npt
import shapely

from planners.bug.sensor import free_extent
from planners.bug.tangent_bug import BugEvent
from planners.bug.trace import FOLLOW, SEEK, WalkedPath, simplify_walk
from planners.space.border import RingGeometry, ring_geometry
from planners.space.expansion import ConfigurationSpace
from planners.space.geometry import as_point as _pt
from planners.space.geometry import unit as _unit

FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float]


@dataclasses.dataclass(frozen=True)
class Bug2Decision:
    """One decision of the run: where the robot hit or left a border, and why."""

    s: float
    """Arclength along the path where it was taken [m]."""
    position: Point
    """Where the robot was [m]."""
    box: str
    """``"hit"`` (touched a border on the M-line), ``"leave"`` (back on the M-line,
    closer to the goal, free to move toward it), ``"reached"`` or ``"unreachable"``."""
    d_goal: float
    """d(r, g) at that point [m]."""
    d_hit: float | None
    """While following: d(H_i, g), what a leave point must beat [m]; None otherwise."""
    text: str
    """The decision in one sentence."""


@dataclasses.dataclass(frozen=True, eq=False)
class Bug2Trace(WalkedPath):
    """A whole Bug2 run: the path, its modes, hit and leave points, and the decisions."""

    status: str
    """``"reached"`` or ``"unreachable"`` (``"invalid"`` from :func:`planners.plan_all`)."""
    path: FloatArray
    """The robot's path, shape (N, 2) [m]; for ``"unreachable"`` the walk until it gave up."""
    length: float | None
    """Path length when the goal is reached [m], else None."""
    reason: str | None
    """Why the goal was not reached, in words; None when it was."""
    events: tuple[BugEvent, ...]
    """Hit (H_i) and leave (L_i) points in order."""
    modes: tuple[str, ...]
    """Mode of each path segment: ``"seek"`` (on the M-line) or ``"follow"``."""
    aims: tuple[Point | None, ...]
    """Per segment: the goal while on the M-line, None while following a border."""
    decisions: tuple[Bug2Decision, ...]
    """Every hit and leave, and the end, in order."""
    travelled: float
    """Length of ``path`` [m]."""
    start: Point
    """Start [m]."""
    goal: Point
    """Goal [m]."""
    planner: str = "bug2"
    """The planner's short name."""
    ms: float = 0.0
    """Compute time [ms], set by :func:`planners.plan_all` (shared expansion included)."""


@dataclasses.dataclass(frozen=True, eq=False)
class _Run:
    """What stays the same over a run: the space, its border, the M-line, the tolerance."""

    cspace: ConfigurationSpace
    geo: RingGeometry
    start: FloatArray
    goal: FloatArray
    tol: float


@dataclasses.dataclass(frozen=True)
class _Walk:
    """The run so far (an immutable accumulator)."""

    points: tuple[Point, ...]
    modes: tuple[str, ...] = ()
    aims: tuple[Point | None, ...] = ()
    events: tuple[BugEvent, ...] = ()
    decisions: tuple[Bug2Decision, ...] = ()
    travelled: float = 0.0

    @property
    def at(self) -> FloatArray:
        return np.asarray(self.points[-1], dtype=np.float64)

    def go(self, polyline: FloatArray, mode: str, aim: Point | None) -> _Walk:
        """Append a polyline that starts where the robot is."""
        points, modes, aims = list(self.points), list(self.modes), list(self.aims)
        travelled = self.travelled
        for p in polyline[1:]:
            step = math.dist(p, points[-1])
            if step > 0.0:
                points.append((float(p[0]), float(p[1])))
                modes.append(mode)
                aims.append(aim)
                travelled += step
        return dataclasses.replace(
            self,
            points=tuple(points),
            modes=tuple(modes),
            aims=tuple(aims),
            travelled=travelled,
        )

    def mark(self, event: BugEvent | None, decision: Bug2Decision) -> _Walk:
        events = self.events if event is None else (*self.events, event)
        return dataclasses.replace(
            self, events=events, decisions=(*self.decisions, decision)
        )


def plan_bug2(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> Bug2Trace:
    """Plan with Bug2: along the M-line, round every obstacle it touches (module docstring).

    Parameters
    ----------
    cspace
        Configuration space (expanded obstacles, shrunk walls).
    start, goal
        Points of shape (2,) [m], in free space (the caller checks).

    Returns
    -------
    Bug2Trace
        ``status`` ``"reached"`` or ``"unreachable"``, the path, hit and leave events.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), 0.0)
    >>> trace = plan_bug2(space, (-1.0, 1.0), (3.0, 1.0))
    >>> trace.status, round(trace.length, 6)  # turn left: up, across the top, down
    ('reached', 6.0)
    >>> trace.path.tolist()
    [[-1.0, 1.0], [0.0, 1.0], [0.0, 2.0], [2.0, 2.0], [2.0, 1.0], [3.0, 1.0]]
    >>> [e.label for e in trace.events]
    ['H1', 'L1']

    References
    ----------
    V. J. Lumelsky and A. A. Stepanov, Algorithmica 2, 403-430, 1987.
    """
    s = np.asarray(start, dtype=np.float64).reshape(2)
    g = np.asarray(goal, dtype=np.float64).reshape(2)
    run = _Run(cspace, ring_geometry(cspace), s, g, _tolerance(cspace))
    walk = _Walk(points=(_pt(s),))
    # Every leave point is a crossing of the M-line with the border, closer to the goal
    # than the hit before it: there are at most as many hits as such crossings.
    for _ in range(2 * len(run.geo.start) + 2):
        walk, hit = _motion_to_goal(run, walk)
        if hit is None:
            return _trace(run, walk, "reached", None)
        walk, left = _follow(run, walk, hit)
        if not left:
            return _trace(run, walk, "unreachable", walk.decisions[-1].text)
    reason = "gave up: more hits than the M-line has crossings (a numerical problem)"
    return _trace(run, walk, "unreachable", reason)


def _motion_to_goal(
    run: _Run, walk: _Walk
) -> tuple[_Walk, tuple[int, FloatArray] | None]:
    """Move toward the goal until it is reached (None) or a border is hit: (ring, point)."""
    geo, g, tol = run.geo, run.goal, run.tol
    x = walk.at
    aim = (float(g[0]), float(g[1]))
    d = math.dist(x, g)
    if d <= tol:
        walk = walk.go(np.array([x, g]), SEEK, aim)
        return walk.mark(
            None, _decision(walk, "reached", g, g, d_hit=None, text="At the goal.")
        ), None
    extent, ring = free_extent(geo, x, (g - x) / d, d)
    if ring < 0 or extent >= d - tol:
        walk = walk.go(np.array([x, g]), SEEK, aim)
        text = "Nothing touched on the M-line: the robot reaches the goal."
        return walk.mark(
            None, _decision(walk, "reached", g, g, d_hit=None, text=text)
        ), None
    hit = x + extent * (g - x) / d
    walk = walk.go(np.array([x, hit]), SEEK, aim)
    return walk, (ring, hit)


def _follow(run: _Run, walk: _Walk, hit: tuple[int, FloatArray]) -> tuple[_Walk, bool]:
    """Follow the hit border to the first leave point; False if back at the hit point."""
    geo, s, g, tol = run.geo, run.start, run.goal, run.tol
    ring, h = hit
    obstacle = run.cspace.obstacle_near(h)
    name = "the walls" if obstacle is None else f"obstacle {obstacle}"
    label = "w" if obstacle is None else str(obstacle)
    d_hit = math.dist(h, g)
    text = (
        f"H{label}: the robot touches {name} on the M-line, {d_hit:.2f} m from the "
        "goal; it turns left and follows the border."
    )
    walk = walk.mark(
        BugEvent("hit", _pt(h), f"H{label}", obstacle, walk.travelled),
        _decision(walk, "hit", h, g, d_hit=d_hit, text=text),
    )
    pinches = run.cspace.derive(_pinch_map)
    pieces = _border_walk(geo, ring, h, _unit(g - s), tol, pinches)
    for k, e, t in _m_line_crossings(run, pieces):
        p = geo.start[e] + t * geo.step[e]
        if math.dist(p, h) <= tol or math.dist(p, g) >= d_hit - tol:
            continue  # the hit point itself, or not closer to the goal than it
        if not _can_head_for_goal(geo, p, g, tol):
            continue
        walk = walk.go(_polyline(geo, pieces, k, t), FOLLOW, None)
        text = (
            f"L{label}: back on the M-line {math.dist(p, g):.2f} m from the goal, closer "
            f"than H{label} ({d_hit:.2f} m), and free toward the goal: the robot leaves."
        )
        event = BugEvent("leave", _pt(p), f"L{label}", obstacle, walk.travelled)
        return walk.mark(
            event, _decision(walk, "leave", p, g, d_hit=d_hit, text=text)
        ), True
    walk = walk.go(_polyline(geo, pieces, len(pieces) - 1, pieces[-1][2]), FOLLOW, None)
    text = (
        f"Back at H{label} without meeting the M-line closer to the goal: {name} "
        "(expanded) separates the robot from the goal, which is unreachable."
    )
    return walk.mark(
        None, _decision(walk, "unreachable", h, g, d_hit=d_hit, text=text)
    ), False


_Piece = tuple[int, float, float]
"""(flat edge, parameter walked from, parameter walked to): turned left, the robot walks
each edge backward, from t0 down to t1."""

_Spot = tuple[int, float]
"""A place on the border as the robot leaves it walking backward: (edge, t), 0 < t <= 1.
A vertex is (the edge ending there, 1.0)."""


def _border_walk(  # noqa: PLR0917 - the walk's six inputs, all needed
    geo: RingGeometry,
    ring: int,
    h: FloatArray,
    u: FloatArray,
    tol: float,
    pinches: dict[_Spot, _Spot],
) -> list[_Piece]:
    """Return the pieces of border the robot walks from ``h`` until it is back at ``h``.

    The robot keeps the blocked space on its right. Where borders touch at a single point
    (a *pinch*: two obstacles touching at a vertex, a vertex on another obstacle's side,
    a pocket touching the outside), it passes onto the other border and comes back after
    going round it, so it walks round the whole connected obstacle, as a robot with a
    bumper does. ``u`` is the direction the robot came in along the M-line; ``pinches``
    is :func:`_pinches` of the border.
    """
    # Where the hit is itself a pinch, the robot goes on in the free sector it came from:
    # the first direction it can leave in, turning clockwise from the way back.
    back = math.atan2(-float(u[1]), -float(u[0]))
    here = [spot for spot in pinches if math.dist(_point(geo, spot), h) <= tol]
    home = min(
        [*here, _spot(geo, *_nearest_edge(geo, ring, h))],
        key=lambda spot: (back - _leaving_angle(geo, spot)) % (2.0 * math.pi),
    )
    stops: dict[int, list[float]] = {}
    for e, t_pinch in pinches:
        stops.setdefault(e, []).append(t_pinch)
    stops.setdefault(home[0], []).append(home[1])
    pieces: list[_Piece] = []
    e, t = home
    for _ in range(4 * len(geo.start) + 4):  # every edge, split at most at each pinch
        t_next = max((x for x in stops.get(e, ()) if x < t), default=0.0)
        pieces.append((e, t, t_next))
        arrived = _spot(geo, e, t_next)
        e, t = pinches.get(arrived, arrived)
        if (e, t) == home:  # back where it began, every border through a pinch walked
            return pieces
    raise RuntimeError("the border walk did not close")  # a bug, never a scene


def _spot(geo: RingGeometry, e: int, t: float) -> _Spot:
    """Return the place at parameter ``t`` of edge ``e`` in :data:`_Spot` form."""
    return (int(geo.prev_edge[e]), 1.0) if t <= 0.0 else (int(e), float(t))


def _pinch_map(cspace: ConfigurationSpace) -> dict[_Spot, _Spot]:
    """Return :func:`_pinches` of the configuration space's border (derived once per space).

    A run with several hits walks several borders; the pinches are found once.
    """
    return _pinches(ring_geometry(cspace), _tolerance(cspace))


def _tolerance(cspace: ConfigurationSpace) -> float:
    """Points closer than this coincide [m] (TangentBug's tolerance too)."""
    return 10.0 * cspace.eps


def _pinches(geo: RingGeometry, tol: float) -> dict[_Spot, _Spot]:
    """Map each place where borders touch to the next one at the same point.

    Every vertex is checked against every other edge within ``tol`` (a spatial index
    keeps it near linear). The places at one point form a cycle: arriving at one, the
    robot leaves from the next.
    """
    lines = np.asarray(shapely.linestrings(np.stack([geo.start, geo.end], axis=1)))
    vertex, edge = shapely.STRtree(lines).query(
        shapely.points(geo.start), predicate="dwithin", distance=tol
    )
    groups: dict[_Spot, set[_Spot]] = {}
    for v, e in zip(vertex.tolist(), edge.tolist(), strict=True):
        own = _spot(geo, v, 0.0)
        if e in (v, own[0]):
            continue  # the vertex's own two edges
        t = float(np.dot(geo.start[v] - geo.start[e], geo.step[e]) / geo.len2[e])
        near_end = tol / float(geo.length[e])
        other = _spot(
            geo, e, 0.0 if t <= near_end else 1.0 if t >= 1.0 - near_end else t
        )
        if other == own:
            continue
        group = groups.get(own, {own}) | groups.get(other, {other})
        for spot in group:
            groups[spot] = group
    cycles: dict[_Spot, _Spot] = {}
    for group in {frozenset(g) for g in groups.values()}:
        # Round the point in the order of the directions the robot leaves in, so that
        # with more than two borders at one point each is visited once.
        ordered = sorted(group, key=lambda spot: _leaving_angle(geo, spot))
        for a, b in zip(ordered, ordered[1:] + ordered[:1], strict=True):
            cycles[a] = b
    return cycles


def _point(geo: RingGeometry, spot: _Spot) -> FloatArray:
    return geo.start[spot[0]] + spot[1] * geo.step[spot[0]]


def _leaving_angle(geo: RingGeometry, spot: _Spot) -> float:
    """Return the direction [rad] in which the robot leaves ``spot`` (walking backward)."""
    ux, uy = geo.unit[spot[0]]
    return math.atan2(-float(uy), -float(ux))


def _m_line_crossings(run: _Run, pieces: list[_Piece]) -> list[tuple[int, int, float]]:
    """Points where the walked pieces meet the M-line, in walking order: (piece, edge, t)."""
    geo = run.geo
    found: list[tuple[int, int, float]] = []
    for k, (e, t0, t1) in enumerate(pieces):
        meets = _meets(geo.start[e], geo.step[e], run)
        found.extend((k, e, t) for t in sorted(meets, reverse=True) if t1 <= t <= t0)
    return found


def _polyline(
    geo: RingGeometry, pieces: list[_Piece], last: int, t: float
) -> FloatArray:
    """Return the walked polyline from the hit point to parameter ``t`` of piece ``last``."""
    points = []
    for e, t0, t1 in pieces[:last]:
        points.extend(
            [geo.start[e] + t0 * geo.step[e], geo.start[e] + t1 * geo.step[e]]
        )
    e, t0, _ = pieces[last]
    points.extend([geo.start[e] + t0 * geo.step[e], geo.start[e] + t * geo.step[e]])
    return np.asarray(points)


def _meets(a: FloatArray, d: FloatArray, run: _Run) -> list[float]:
    """Parameters t in [0, 1] where edge a + t d meets the M-line."""
    s, tol = run.start, run.tol
    m = run.goal - s
    m_len = math.hypot(*m)
    d_len = math.hypot(*d)
    if d_len == 0 or m_len == 0:
        return []
    cross = d[0] * m[1] - d[1] * m[0]
    w = s - a
    if abs(cross) <= 1e-12 * d_len * m_len:
        # Parallel: only a collinear edge meets it, along the overlap of the two.
        if abs(w[0] * d[1] - w[1] * d[0]) > tol * d_len:
            return []
        t0 = float(np.dot(w, d)) / d_len**2
        t1 = float(np.dot(w + m, d)) / d_len**2
        lo, hi = max(min(t0, t1), 0.0), min(max(t0, t1), 1.0)
        return [lo, hi] if lo <= hi else []
    t = (w[0] * m[1] - w[1] * m[0]) / cross
    u = (w[0] * d[1] - w[1] * d[0]) / cross
    slack_t, slack_u = tol / d_len, tol / m_len
    if -slack_t <= t <= 1 + slack_t and -slack_u <= u <= 1 + slack_u:
        return [min(max(float(t), 0.0), 1.0)]
    return []


def _can_head_for_goal(
    geo: RingGeometry, p: FloatArray, g: FloatArray, tol: float
) -> bool:
    """Whether the robot at ``p`` (on the border) can move toward the goal."""
    d = math.dist(p, g)
    if d <= tol:
        return True
    extent, _ = free_extent(geo, p, (g - p) / d, d)
    return extent > tol


def _nearest_edge(geo: RingGeometry, ring: int, point: FloatArray) -> tuple[int, float]:
    """Return the edge of ``ring`` nearest ``point`` and the parameter of that point on it."""
    lo, hi = int(geo.offset[ring]), int(geo.offset[ring + 1])
    a, d = geo.start[lo:hi], geo.step[lo:hi]
    t = np.clip(np.einsum("ij,ij->i", point - a, d) / geo.len2[lo:hi], 0.0, 1.0)
    k = int(np.argmin(np.hypot(*(a + t[:, None] * d - point).T)))
    return lo + k, float(t[k])


def _decision(
    walk: _Walk,
    box: str,
    at: FloatArray,
    g: FloatArray,
    *,
    d_hit: float | None,
    text: str,
) -> Bug2Decision:
    return Bug2Decision(walk.travelled, _pt(at), box, math.dist(at, g), d_hit, text)


def _trace(run: _Run, walk: _Walk, status: str, reason: str | None) -> Bug2Trace:
    path, modes, aims = simplify_walk(
        np.asarray(walk.points, dtype=np.float64).reshape(-1, 2),
        list(walk.modes),
        list(walk.aims),
    )
    return Bug2Trace(
        status=status,
        path=path,
        length=walk.travelled if status == "reached" else None,
        reason=reason,
        events=walk.events,
        modes=tuple(modes),
        aims=tuple(aims),
        decisions=walk.decisions,
        travelled=walk.travelled,
        start=_pt(run.start),
        goal=_pt(run.goal),
    )
