"""Goal seeking, the left half of the chapter's Fig. 9.15 (section 9.6).

"Move toward the goal; obstacle in the way? choose r_next = O_i minimising
d(r, O_i) + d(O_i, g); local minimum? switch to boundary following." The robot moves
straight toward the goal while nothing blocks it within R, else toward the best O_i of
the local tangent graph (Fig. 9.16), re-deciding as the view changes; at a local minimum
M (Fig. 9.17) it hands over to boundary following by returning a state in the
``"follow"`` mode (:func:`_start_following`). This module never imports
:mod:`planners.bug._follow`.
"""

from __future__ import annotations

__all__: list[str] = []

import dataclasses
import math
import types
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from planners.bug._context import (
    FOLLOW,
    SEEK,
    BugEvent,
    BugState,
    Candidate,
    Context,
    Decision,
    FloatArray,
    Follow,
    Move,
    event_label,
    evolve,
    finish,
    moved,
    obstacle_at,
    segment_distances,
    sigma_on_ring,
    tangents,
)
from planners.bug.sensor import (
    OCCLUDING,
    RANGE,
    RingGeometry,
    Sensing,
    free_extent,
    measure_border,
    nearby,
    sense,
)
from planners.space.geometry import as_point as _pt
from planners.space.geometry import unit as _unit

BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]

# --------------------------------------------------------------------------- decisions


_OKey = int | tuple[str, int, int]
"""Identity of an O_i across readings (:func:`_o_key`): a corner by its vertex (the index
of the edge it starts), a range point by (kind, ring, side). Only ever compared, never
taken apart; plain values, as a move's bisection makes thousands of them."""


class _Key(NamedTuple):
    """What a goal-seeking decision is, for telling when it changes along a move.

    Two positions with equal keys take the same decision; the robot moves straight on
    until the key changes (:func:`_switch_point`).
    """

    kind: str
    """``"reached"``, ``"goal"`` (straight to it, or on toward it), ``"local_min"`` or
    ``"toward"``."""
    ring: int = -1
    """The ring blocking the goal ray (``"local_min"``, ``"toward"``)."""
    aim: frozenset[_OKey] = frozenset()
    """``"toward"``: the O_i headed for, or the two of a sliding pair (unordered)."""
    pair: bool = False
    """``"toward"``: sliding between two equally good O_i."""


_REACHED = _Key("reached")
_GOAL = _Key("goal")


class _View(NamedTuple):
    """The local tangent graph's numbers at one position (Fig. 9.16), per O_i."""

    okeys: list[_OKey]  # identities
    dist: FloatArray  # d(r, O_i)
    to_goal: FloatArray  # d(O_i, g)
    h: FloatArray  # their sum
    seen_ok: BoolArray  # not at the robot's own position
    going: BoolArray  # the O_i the robot is heading for
    downhill: BoolArray  # ... while heading for it still brings it closer
    valid: BoolArray  # candidates: closer to the goal than r, or downhill


class _Ray(NamedTuple):
    """The goal ray from the robot, blocked within R."""

    u: FloatArray  # unit direction toward the goal
    ring: int  # the ring that blocks it
    hit: FloatArray  # where


@dataclasses.dataclass(frozen=True, eq=False)
class _Seek:
    """The goal-seeking decision at one position (a pure function of it)."""

    kind: str  # "reached" | "goal" | "ahead" | "toward" | "local_min"
    key: _Key
    blocking: int  # ring stopping the goal ray within R, -1 if none
    hit: FloatArray | None  # where it stops
    ahead: float = 0.0  # "ahead": distance to move straight toward the goal
    target: FloatArray | None = None  # "toward": the chosen O_i
    index: int = -1  # its index in the sensing
    sensing: Sensing | None = None
    view: _View | None = None  # the numbers the choice was made on
    sibling: int = -1  # an equally good second choice
    slide: bool = False  # slide between target and sibling
    direction: FloatArray | None = None  # the sliding direction


def _decide(
    ctx: Context,
    x: FloatArray,
    prefer: _Key | None = None,
    among: IntArray | None = None,
) -> _Seek:
    """Take the goal-seeking decision at ``x`` (pure; ``prefer``: the current decision).

    ``among``: :func:`planners.bug.sensor.nearby` for a disk that holds the sensing disk at
    ``x`` (the same decision, found sooner on a big border).

    "Obstacle in the way?" is the goal ray: free to the goal, free within R (move on
    toward the goal until the obstacle beyond comes into range), or blocked within R,
    when the robot looks around and chooses among the O_i (:func:`_choose`).
    """
    g = ctx.goal
    dg = float(math.hypot(*(g - x)))
    if dg <= ctx.tol:
        return _Seek("reached", _REACHED, -1, None)
    u = (g - x) / dg
    # Two questions from x: the goal ray, then (if blocked within R) the full view.
    near = measure_border(ctx.geo, x, ctx.radius, among=among)
    extent, ring = free_extent(ctx.geo, x, u, dg, near=near)
    if extent >= dg - ctx.tol:
        return _Seek("goal", _GOAL, -1, None)
    hit = x + extent * u
    if extent > ctx.radius - 0.5 * ctx.margin:
        # Free within the range: straight on until the obstacle ahead is just in range
        # (a little inside it, so that the sensor sees a piece of it, not a point).
        return _Seek("ahead", _GOAL, -1, None, ahead=extent - ctx.radius + ctx.margin)
    seen = sense(ctx.geo, x, ctx.radius, near=near)
    view = _tangent_graph(ctx, seen, x, dg, prefer)
    return _choose(ctx, x, _Ray(u, ring, hit), seen, view, prefer=prefer)


def _tangent_graph(
    ctx: Context, seen: Sensing, x: FloatArray, dg: float, prefer: _Key | None
) -> _View:
    """Measure every O_i in view and tell which are candidates.

    Candidates are the O_i closer to the goal than the robot (Kamon et al.), plus the one
    it is heading for while that still brings it closer to the goal.
    """
    g = ctx.goal
    n = len(seen.points)
    dist = np.hypot(*(seen.points - x).T) if n else np.zeros(0)
    to_goal = np.hypot(*(seen.points - g).T) if n else np.zeros(0)
    h = dist + to_goal
    slope = (
        ((seen.points - x) @ (x - g)) / (np.where(dist > 0, dist, 1.0) * dg)
        if n
        else np.zeros(0)
    )
    okeys = [_o_key(ctx.geo, seen, i) for i in range(n)]
    seen_ok = dist > ctx.tol
    closer = seen_ok & (to_goal < dg - ctx.tol)
    members = prefer.aim if prefer is not None and prefer.kind == "toward" else ()
    going = (
        np.array([k in members for k in okeys], dtype=bool) & seen_ok
        if n
        else np.zeros(0, dtype=bool)
    )
    downhill = going & (slope < -1e-9)
    return _View(
        okeys=okeys,
        dist=dist,
        to_goal=to_goal,
        h=h,
        seen_ok=seen_ok,
        going=going,
        downhill=downhill,
        valid=closer | downhill,
    )


def _choose(
    ctx: Context,
    x: FloatArray,
    ray: _Ray,
    seen: Sensing,
    view: _View,
    *,
    prefer: _Key | None,
) -> _Seek:
    """Choose r_next = the candidate O_i minimising d(r, O_i) + d(O_i, g), or find M.

    With no candidate left, "all of the vertex points available to the robot would force
    the robot to move away from the goal" (Fig. 9.17): a local minimum. So is the point
    where the O_i it is heading for, still the best of all, stops bringing it closer
    (Choset et al.: "the direction that minimizes the heuristic begins to increase
    d(x, q_goal)").
    """
    ring, hit = ray.ring, ray.hit
    local_min = _Key("local_min", ring)
    if view.going.any() and not view.downhill.any():
        overall = int(np.argmin(np.where(view.seen_ok, view.h, np.inf)))
        if view.going[overall]:
            return _Seek(
                "local_min",
                local_min,
                ring,
                hit,
                target=seen.points[overall],
                index=overall,
                sensing=seen,
                view=view,
            )
    if not view.valid.any():
        return _Seek("local_min", local_min, ring, hit, sensing=seen, view=view)
    h = np.where(view.valid, view.h, np.inf)
    best = _best(ctx, x, ray, seen, h, okeys=view.okeys, prefer=prefer)
    chosen = _Seek(
        "toward",
        _Key("toward", ring, frozenset((view.okeys[best],))),
        ring,
        hit,
        target=seen.points[best],
        index=best,
        sensing=seen,
        view=view,
    )
    # When a second choice is (about) as good, the continuous algorithm would chatter
    # between the two: moving toward either makes the other the better. Like a sliding
    # mode, the robot then moves between them (see _seek_move) until one clearly wins.
    n = len(seen.points)
    others = np.where(np.arange(n) == best, np.inf, h)
    second = int(np.argmin(others)) if n > 1 else -1
    if second < 0:
        return chosen
    gap = float(others[second] - h[best])
    return _slide(ctx, x, chosen, second, gap=gap, prefer=prefer)


def _slide(
    ctx: Context,
    x: FloatArray,
    chosen: _Seek,
    second: int,
    *,
    gap: float,
    prefer: _Key | None,
) -> _Seek:
    """Turn ``chosen`` into a sliding decision with the O_i ``second``, if they chatter.

    ``gap`` is how much worse ``second`` is. Sliding straight away from the goal is a
    local minimum.
    """
    assert chosen.sensing is not None and chosen.view is not None
    # Enter the sliding mode within a narrow band; once in it, stay in a wider one
    # (a straight step along the sliding direction drifts off the curved switching line).
    if gap > ctx.slide_band and (
        gap > ctx.stay_band or prefer is None or not prefer.pair
    ):
        return chosen  # (asked first: most decisions are far from a tie)
    okeys, ring = chosen.view.okeys, chosen.blocking
    # The pair is unordered: only equality and membership of keys are ever asked.
    both = frozenset((okeys[chosen.index], okeys[second]))
    key = _Key("toward", ring, both, pair=True)
    if gap > ctx.slide_band and prefer != key:
        return chosen
    f = _sliding_direction(ctx, chosen.sensing, x, chosen.index, second)
    if f is None:
        return chosen
    if float(np.dot(f, ctx.goal - x)) <= 1e-9 * float(math.hypot(*(ctx.goal - x))):
        return dataclasses.replace(
            chosen, kind="local_min", key=_Key("local_min", ring)
        )
    return dataclasses.replace(chosen, key=key, sibling=second, slide=True, direction=f)


def _best(
    ctx: Context,
    x: FloatArray,
    ray: _Ray,
    seen: Sensing,
    h: FloatArray,
    *,
    okeys: list[_OKey],
    prefer: _Key | None,
) -> int:
    """Return the index of the least heuristic distance ``h`` (inf: not a candidate).

    Exact ties (symmetric scenes) keep the previous choice, else go to the left-hand one.
    """
    tied = np.flatnonzero(h <= h.min() + ctx.tol)
    if len(tied) == 1:
        return int(tied[0])
    if prefer is not None and prefer.kind == "toward":
        # The O_i headed for (on the same blocking ring), or either of a sliding pair.
        same = [
            int(i)
            for i in tied
            if okeys[i] in prefer.aim and (prefer.pair or prefer.ring == ray.ring)
        ]
        if same:
            return same[0]
    u = ray.u
    rel = seen.points[tied] - x
    left = u[0] * rel[:, 1] - u[1] * rel[:, 0]
    return int(tied[int(np.argmax(left))])


def _heuristic_gradient(
    ctx: Context, seen: Sensing, x: FloatArray, i: int
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
    ctx: Context, seen: Sensing, x: FloatArray, a: int, b: int
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


def _o_key(geo: RingGeometry, seen: Sensing, i: int) -> _OKey:
    """Return the identity of an O_i across readings (corner: vertex; else ring, side)."""
    kind = seen.kinds[i]
    if kind != RANGE:
        e, t = int(seen.edge[i]), float(seen.t[i])
        if t <= 0.0 or t >= 1.0:
            k = int(geo.ring[e])
            vertex = e if t <= 0.0 else geo.edge_index(k, e - int(geo.offset[k]) + 1)
            return vertex
    return (kind, int(seen.ring[i]), int(seen.follow[i]))


# --------------------------------------------------------------------------- the step

# The box of Fig. 9.15 each kind of goal-seeking decision is in (read only).
_BOX = types.MappingProxyType(
    {
        "reached": "reached",
        "goal": "goal_visible",
        "ahead": "toward_obstacle_ahead",
        "toward": "choose_O_i",
        "local_min": "local_minimum",
    }
)


def goal_seeking_step(ctx: Context, state: BugState) -> BugState:
    """One goal-seeking step from ``state`` (mode ``"seek"``)."""
    x = np.asarray(state.position, dtype=np.float64)
    dec = state.cache if isinstance(state.cache, _Seek) else _decide(ctx, x)
    record = _record(ctx, state, x, dec) if dec.kind != "local_min" else None
    base, events = _crossings(ctx, state, x, dec, record)
    if dec.kind == "local_min":
        return _start_following(ctx, base, x, dec, events)
    if dec.kind in ("reached", "goal"):
        # Straight to the goal (from within the tolerance too: the path ends on it exactly).
        move = Move(SEEK, np.array([x, ctx.goal]), _pt(ctx.goal))
        out = finish(base, ctx.goal.copy(), (move,), tuple(events))
        if dec.kind == "reached":
            return out
        at_goal = Decision(
            s=out.travelled,
            position=out.position,
            mode=SEEK,
            box="reached",
            d_goal=0.0,
            chosen=_pt(ctx.goal),
        )
        return evolve(out, decisions=(*out.decisions, at_goal))
    if dec.kind == "ahead":
        u = (ctx.goal - x) / math.hypot(*(ctx.goal - x))
        y = x + dec.ahead * u
        out = moved(base, (Move(SEEK, np.array([x, y]), _pt(ctx.goal)),), tuple(events))
        return evolve(out, heading=_pt(u))
    # Toward the best O_i: until it, the closest approach to the goal, or one step.
    assert dec.target is not None and dec.sensing is not None
    w, s = _seek_move(ctx, x, dec)
    y, nxt = _switch_point(ctx, x, w, s, dec)
    out = moved(base, (Move(SEEK, np.array([x, y]), _pt(dec.target)),), tuple(events))
    return evolve(out, cache=nxt, heading=_pt(w))


def _crossings(
    ctx: Context,
    state: BugState,
    x: FloatArray,
    dec: _Seek,
    record: Decision | None,
) -> tuple[BugState, list[BugEvent]]:
    """Name where the obstacle blocking the goal direction changes: H_i, D_i (Fig. 9.19).

    Returns the state with the blocking obstacle and the step's ``record`` in it, and
    the events.
    """
    events: list[BugEvent] = []
    blocking, blocking_obstacle, quiet = (
        state.blocking,
        state.blocking_obstacle,
        state.quiet_depart,
    )
    s = state.travelled
    if dec.blocking != blocking and dec.kind != "reached":
        if blocking >= 0 and not quiet:
            label = event_label("D", blocking_obstacle)
            events.append(BugEvent("leave", _pt(x), label, blocking_obstacle, s))
        if dec.blocking >= 0:
            assert dec.hit is not None
            blocking_obstacle = obstacle_at(ctx, dec.hit)
            label = event_label("H", blocking_obstacle)
            events.append(BugEvent("hit", _pt(x), label, blocking_obstacle, s))
            quiet = False
        else:
            blocking_obstacle = None
        blocking = dec.blocking
    base = evolve(
        state,
        blocking=blocking,
        blocking_obstacle=blocking_obstacle,
        quiet_depart=quiet,
        cache=None,
        decisions=() if record is None else (record,),
    )
    return base, events


def _record(
    ctx: Context,
    state: BugState,
    x: FloatArray,
    dec: _Seek,
    *,
    mode: str = SEEK,
    follow: Follow | None = None,
) -> Decision:
    """Make the public record of the goal-seeking decision ``dec`` taken at ``x``.

    It keeps what :func:`_decide` computed (no more sensing). ``follow``: the memory
    boundary following starts with, at a local minimum.
    """
    g = ctx.goal
    if dec.kind == "toward":
        assert dec.target is not None
        chosen: tuple[float, float] | None = _pt(dec.target)
    else:
        chosen = _pt(g) if dec.kind != "local_min" else None
    d_reach, d_followed = (
        ctx.leave.measures(follow) if follow is not None else (None, None)
    )
    return Decision(
        s=state.travelled,
        position=state.position,
        mode=mode,
        box=_BOX[dec.kind],
        d_goal=float(math.hypot(*(g - x))),
        chosen=chosen,
        candidates=_candidates(dec),
        sliding=dec.slide,
        d_local_min=follow.d_local_min if follow is not None else None,
        d_followed=d_followed,
        d_reach=d_reach,
    )


def _candidates(dec: _Seek) -> tuple[Candidate, ...]:
    """Return the O_i of ``dec``'s view as records (none when the robot did not look)."""
    seen, view = dec.sensing, dec.view
    if seen is None or view is None:
        return ()
    # Candidate._make: a tuple from the values in field order, without parsing arguments.
    return tuple(
        map(
            Candidate._make,
            zip(
                map(tuple, seen.points.tolist()),
                seen.kinds,
                view.dist.tolist(),
                view.to_goal.tolist(),
                view.h.tolist(),
                view.valid.tolist(),
                strict=True,
            ),
        )
    )


def _switch_point(
    ctx: Context, x: FloatArray, w: FloatArray, s: float, dec: _Seek
) -> tuple[FloatArray, _Seek]:
    """Find where, moving ``s`` along ``w`` from ``x``, the decision first changes.

    Most switches are where the geometry says they are (:func:`_switch_guess`): a range
    point turning into a corner, or the border beyond the chosen corner coming into view.
    The sensor is asked on either side of that point first (two readings), and only when
    it disagrees does the search of :func:`_bisect_switch` run. Either way the switch is
    located to ``s / 2**refine``. Returns that point and the decision there; the whole
    move and the decision at its end when the decision does not change.
    """
    # Every probe lies on the move: the edges near it are found once (a short move).
    among = (
        nearby(ctx.geo, x + 0.5 * s * w, ctx.radius + 0.5 * s)
        if s <= ctx.radius
        else None
    )
    probe = _Probe(ctx, x, w, dec, among)
    gap = max(100.0 * ctx.tol, 1e-6 * s)
    guess = _switch_guess(ctx, x, w, dec, s - gap)
    if guess is not None:
        found = _at_guess(probe, guess, gap=gap, end=s)
        if found is not None:
            return found
    return _bisect_switch(probe, s, gap=gap, guess=guess)


class _Probe(NamedTuple):
    """The decision along one move: at ``x + s * w`` with ``dec``'s key preferred."""

    ctx: Context
    x: FloatArray
    w: FloatArray
    dec: _Seek
    among: IntArray | None

    def at(self, s: float) -> _Seek:
        """Return the decision after moving ``s`` [m]."""
        return _decide(self.ctx, self.x + s * self.w, self.dec.key, self.among)

    def holds(self, s: float) -> bool:
        """Tell whether the decision is still ``dec``'s after moving ``s`` [m]."""
        return self.at(s).key == self.dec.key


def _at_guess(
    probe: _Probe, guess: float, *, gap: float, end: float
) -> tuple[FloatArray, _Seek] | None:
    """Confirm a switch at ``guess``: the decision holds just before it, not just after.

    The two readings are at most one search resolution apart (``2 * half``, at most
    ``2 * gap``), so the switch is located as precisely as :func:`_bisect_switch` would
    locate it. It takes the first change along the move; the search, which reads the
    move's end first, would miss a change that reverts within the move. Returns
    the point just after and the decision there, or None when the sensor disagrees
    (or the guess lies too close to either end of the move, ``end`` long).
    """
    half = min(gap, 0.5 * (end - gap) / 2.0**probe.ctx.refine)
    if not (half < guess and guess + half < end - gap):
        return None
    if not probe.holds(guess - half):
        return None
    after = probe.at(guess + half)
    if after.key == probe.dec.key:
        return None
    return probe.x + (guess + half) * probe.w, after


def _bisect_switch(
    probe: _Probe, s: float, *, gap: float, guess: float | None
) -> tuple[FloatArray, _Seek]:
    """Search the whole move for the switch: its end, then a bisection.

    The bisection's first probes bracket ``guess`` (:func:`_corner_probe`).
    """
    x, w, key = probe.x, probe.w, probe.dec.key
    y = x + s * w
    nxt = probe.at(s)
    if nxt.key == key:
        return y, nxt
    before = s - gap
    if not (before > 0 and not probe.holds(before)):
        return y, nxt
    lo, hi, at_hi = _corner_probe(probe, guess, gap=gap, before=before)
    resolution = before / 2.0**probe.ctx.refine
    while hi - lo > resolution:
        mid = 0.5 * (lo + hi)
        d_mid = probe.at(mid)
        if d_mid.key == key:
            lo = mid
        else:
            hi, at_hi = mid, d_mid
    return x + hi * w, at_hi if at_hi is not None else probe.at(hi)


def _corner_probe(
    probe: _Probe, guess: float | None, *, gap: float, before: float
) -> tuple[float, float, _Seek | None]:
    """Bracket the switch in [0, ``before``] around ``guess`` (:func:`_switch_guess`).

    Returns (lo, hi, the decision at hi if known): the decision holds at lo, not at hi.
    """
    lo, hi = 0.0, before
    if guess is None or not (lo < guess - gap and guess + gap < hi):
        return lo, hi, None
    d_lo = probe.at(guess - gap)
    if d_lo.key != probe.dec.key:
        return lo, guess - gap, d_lo
    d_hi = probe.at(guess + gap)
    if d_hi.key != probe.dec.key:
        return guess - gap, guess + gap, d_hi
    return guess + gap, hi, None


def _switch_guess(
    ctx: Context, x: FloatArray, w: FloatArray, dec: _Seek, limit: float
) -> float | None:
    """Where, moving from ``x`` along ``w``, the chosen O_i is likely to stop being chosen.

    A range point turns into a corner (:func:`_corner_in_range`); at an occluding
    corner, the border beyond it comes into view (:func:`_beyond_corner`). None when
    neither happens before ``limit``. Only a first guess: the sensor decides.
    """
    seen = dec.sensing
    if seen is None or dec.index < 0:
        return None
    if seen.kinds[dec.index] == RANGE:
        return _corner_in_range(ctx, x, w, dec, limit)
    if seen.kinds[dec.index] == OCCLUDING:
        return _beyond_corner(ctx, x, w, dec, limit)
    return None


def _beyond_corner(
    ctx: Context, x: FloatArray, w: FloatArray, dec: _Seek, limit: float
) -> float | None:
    """Where, moving from ``x`` along ``w``, the edge beyond the chosen corner shows.

    The chosen O_i is a vertex where the border turns away from the robot; the edge
    after it (along the ring, away from the piece in view) is seen edge-on from its
    line. Moving straight at the vertex the robot reaches that line only there; but
    along the border, where it turns only slightly (a finely drawn arc), the robot comes
    within eps of the line, touching the corner, well before the vertex, and sees along
    the next edge from there (:func:`planners.bug.sensor.measure_border`). Returns the
    distance along ``w`` at which the robot comes within eps of that line, or None.
    """
    seen = dec.sensing
    assert seen is not None
    geo = ctx.geo
    e, t, follow = (
        int(seen.edge[dec.index]),
        float(seen.t[dec.index]),
        int(seen.follow[dec.index]),
    )
    if follow > 0 and t >= 1.0:
        after = int(geo.next_edge[e])
    elif follow < 0 and t <= 0.0:
        after = int(geo.prev_edge[e])
    else:
        return None  # not at a vertex
    sx, sy = geo.start_list[after]
    dx, dy = geo.step_list[after]
    # cross(start - p, step) along p = x + s w: positive while the edge does not face
    # the robot (it is on the edge's blocked side), below eps * length once it touches.
    c0 = (sx - float(x[0])) * dy - (sy - float(x[1])) * dx
    rate = float(w[0]) * dy - float(w[1]) * dx
    threshold = geo.eps * geo.length_list[after]
    if not (c0 > threshold and rate > 0):
        return None
    s = (c0 - threshold) / rate
    return s if s < limit else None


def _corner_in_range(
    ctx: Context, x: FloatArray, w: FloatArray, dec: _Seek, limit: float
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


def _seek_move(ctx: Context, x: FloatArray, dec: _Seek) -> tuple[FloatArray, float]:
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


# --------------------------------------------------------------------------- local minimum


def _start_following(
    ctx: Context, state: BugState, x: FloatArray, dec: _Seek, events: list[BugEvent]
) -> BugState:
    """Local minimum M at ``x``: pick the border and direction to follow (Choset, sec. 2.3).

    The flowchart's "local minimum?" box hands over to boundary following: the state
    returned is in the ``"follow"`` mode with the new :class:`Follow` memory.
    """
    g = ctx.goal
    seen = dec.sensing if dec.sensing is not None else sense(ctx.geo, x, ctx.radius)
    ring = dec.blocking
    obstacle = obstacle_at(ctx, dec.hit) if dec.hit is not None else None
    events.append(
        BugEvent(
            "local_min", _pt(x), event_label("M", obstacle), obstacle, state.travelled
        )
    )
    d_m = float(math.hypot(*(g - x)))
    on_ring = seen.segment_ring == ring
    d_followed, d_seen = d_m, None
    if on_ring.any():
        d_seen = float(segment_distances(seen.segments[on_ring], g).min())
        d_followed = min(d_followed, d_seen)
    heading = (
        np.asarray(state.heading, dtype=np.float64)
        if state.heading is not None
        else None
    )
    follow = _join(ctx, state, x, dec, seen=seen, on_ring=on_ring, heading=heading)
    follow = evolve(
        follow,
        local_min=_pt(x),
        d_local_min=d_m,
        d_followed=d_followed,
        d_reach=d_seen,
        obstacle=obstacle,
    )
    record = _record(ctx, state, x, dec, mode=FOLLOW, follow=follow)
    return evolve(
        state,
        mode=FOLLOW,
        follow=follow,
        moves=(),
        events=tuple(events),
        steps=state.steps + 1,
        decisions=(record,),
    )


def _join(
    ctx: Context,
    state: BugState,
    x: FloatArray,
    dec: _Seek,
    *,
    seen: Sensing,
    on_ring: BoolArray,
    heading: FloatArray | None,
) -> Follow:
    """Where and in which direction to join the blocking border (M and d's filled later).

    On the border already, the robot walks it from here; else it heads for the end of
    the visible piece of it on the side it goes round.
    """
    geo, ring = ctx.geo, dec.blocking
    direction, target, target_edge, target_t = _piece_end(
        ctx, x, dec, seen=seen, on_ring=on_ring, heading=heading
    )
    sigma_here = sigma_on_ring(geo, x, ring, ctx.tol)
    blank = Follow(
        ring=ring,
        direction=direction,
        local_min=(0.0, 0.0),
        d_local_min=0.0,
        d_followed=0.0,
        target=None,
        target_sigma=0.0,
        sigma=0.0,
        walked=0.0,
        obstacle=None,
    )
    if sigma_here is not None:
        if heading is not None:
            forward, backward = tangents(geo, ring, sigma_here)
            ahead = float(np.dot(forward, heading)) >= float(np.dot(backward, heading))
            direction = 1 if ahead else -1
        walked = 0.0
        prev = state.left
        if (
            prev is not None
            and prev[0].ring == ring
            and prev[0].direction == direction
            and state.travelled - prev[1] <= 100.0 * ctx.tol
        ):
            walked = prev[0].walked
        return evolve(blank, direction=direction, sigma=sigma_here, walked=walked)
    if target is None:
        # The whole border in view is one closed piece (a pocket): walk it from where
        # the goal direction meets it.
        assert dec.hit is not None
        target = dec.hit
        sig = sigma_on_ring(geo, dec.hit, ring, math.inf)
        target_sigma = float(sig) if sig is not None else 0.0
    else:
        target_sigma = geo.sigma(target_edge, target_t)
    return evolve(
        blank, target=_pt(target), target_sigma=target_sigma, sigma=target_sigma
    )


def _piece_end(
    ctx: Context,
    x: FloatArray,
    dec: _Seek,
    *,
    seen: Sensing,
    on_ring: BoolArray,
    heading: FloatArray | None,
) -> tuple[int, FloatArray | None, int, float]:
    """Find the end of the continuous piece of border in view that blocks the goal.

    Returns (direction to walk the ring, the end point or None, its edge, its parameter).
    """
    ring = dec.blocking
    chain = -1
    if dec.hit is not None and on_ring.any():
        idx = np.flatnonzero(on_ring)
        near = segment_distances(seen.segments[idx], dec.hit)
        chain = int(seen.segment_chain[idx[int(np.argmin(near))]])
    if chain < 0:
        return 1, None, -1, 0.0
    ends = np.flatnonzero((seen.chain == chain) & (seen.ring == ring))
    if not len(ends):
        return 1, None, -1, 0.0
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
        g = ctx.goal
        u = (g - x) / float(math.hypot(*(g - x)))
        rel = dec.target - x
        side = -1 if float(u[0] * rel[1] - u[1] * rel[0]) > 0 else 1
        match = [i for i in ends.tolist() if int(seen.follow[i]) == side]
        pick = match[0] if match else int(ends[0])
    else:
        pick = int(ends[0])
    return (
        int(seen.follow[pick]),
        seen.points[pick],
        int(seen.edge[pick]),
        float(seen.t[pick]),
    )
