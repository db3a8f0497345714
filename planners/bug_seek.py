"""Goal seeking, the left half of the chapter's Fig. 9.15 (section 9.6).

"Move toward the goal; obstacle in the way? choose r_next = O_i minimising
d(r, O_i) + d(O_i, g); local minimum? switch to boundary following." The robot moves
straight toward the goal while nothing blocks it within R, else toward the best O_i of
the local tangent graph (Fig. 9.16), re-deciding as the view changes; at a local minimum
M (Fig. 9.17) it hands over to boundary following by returning a state in the
``"follow"`` mode (:func:`_start_following`). This module never imports
:mod:`planners.bug_follow`.
"""

from __future__ import annotations

__all__: list[str] = []

import dataclasses
import math
from typing import Any

import numpy as np

from planners.bug_context import (
    FOLLOW,
    REACHED,
    SEEK,
    BugEvent,
    BugState,
    FloatArray,
    Follow,
    Move,
    _Context,
    _evolve,
    _finish,
    _label,
    _moved,
    _obstacle_at,
    _pt,
    _segment_distances,
    _sigma_on_ring,
    _tangents,
    _unit,
)
from planners.sensor import (
    RANGE,
    RingGeometry,
    Sensing,
    free_extent,
    measure_border,
    sense,
)


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
