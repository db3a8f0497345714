"""Boundary following, the right half of the chapter's Fig. 9.15 (section 9.6).

From the local minimum M the robot follows the border that blocks the goal direction,
continuing the direction of its last motion; after each piece of the walk it asks the
leave rule (:mod:`planners.bug._leave`, one interchangeable object on the context)
whether it may go back to goal seeking, and hands over by returning a state in the
``"seek"`` mode. Going all the way round the border without meeting the rule ends the
run when the border separates robot and goal, else the robot leaves from the border's
point closest to the goal (Bug1's rule). This module never imports
:mod:`planners.bug._seek`.
"""

from __future__ import annotations

__all__: list[str] = []

import math

import numpy as np
import shapely

from planners.bug._context import (
    FOLLOW,
    SEEK,
    UNREACHABLE,
    BugEvent,
    BugState,
    Context,
    Decision,
    FloatArray,
    Follow,
    Move,
    cut_path,
    event_label,
    evolve,
    finish,
    first_within,
    moved,
)
from planners.space.geometry import as_point as _pt
from planners.space.geometry import segment_closest as _segment_closest
from planners.space.geometry import unit as _unit


def boundary_following_step(ctx: Context, state: BugState) -> BugState:
    """One boundary-following step from ``state`` (mode ``"follow"``)."""
    f = state.follow
    assert f is not None
    x = np.asarray(state.position, dtype=np.float64)
    geo = ctx.geo
    d_reach, d_followed = ctx.leave.measures(f)
    record = Decision(
        s=state.travelled,
        position=state.position,
        mode=FOLLOW,
        box="follow_boundary",
        d_goal=float(math.hypot(*(ctx.goal - x))),
        d_local_min=f.d_local_min,
        d_followed=d_followed,
        d_reach=d_reach,
    )
    state = evolve(state, decisions=(record,))
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
    s = ctx.leave.walk_length(ctx, f, remaining)
    path, _ = geo.walk(f.ring, f.sigma, f.direction, s)
    return _walk_and_check(ctx, state, path, walked=s)


def _walk_and_check(
    ctx: Context,
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
    s_goal = first_within(path, cum, g, ctx.tol)
    f, stop_at, d_reach = ctx.leave.check(ctx, f, path, cum)
    if s_goal is not None and (stop_at is None or s_goal <= stop_at):
        piece = cut_path(path, cum, s_goal)
        piece[-1] = g
        out = finish(state, g.copy(), (Move(FOLLOW, piece, None),), ())
        return _closing(out, "reached", 0.0)
    if stop_at is not None:
        cut = cut_path(path, cum, stop_at)
        return _leave(ctx, state, f, cut, stop_at, d_reach=d_reach)
    return _walk_on(
        ctx, state, f, path, arrived_sigma=arrived_sigma, walked=walked, total=total
    )


def _walk_on(
    ctx: Context,
    state: BugState,
    f: Follow,
    path: FloatArray,
    *,
    arrived_sigma: float | None,
    walked: float | None,
    total: float,
) -> BugState:
    """Nothing stopped the move along ``path``: keep track of where on the border it ended.

    Arriving at the border, the robot starts walking it; a walk that reaches Bug1's exit
    leaves there, one that completes the round ends in :func:`_full_round`.
    """
    moves = (Move(FOLLOW, path, None),)
    if arrived_sigma is not None:
        f = evolve(f, target=None, sigma=arrived_sigma, walked=0.0)
        return moved(evolve(state, follow=f), moves, ())
    if f.target is not None:
        return moved(evolve(state, follow=f), moves, ())
    assert walked is not None
    sigma = (f.sigma + f.direction * walked) % float(ctx.geo.perimeter[f.ring])
    f = evolve(f, sigma=sigma, walked=f.walked + walked)
    if (
        f.exit_sigma is not None
        and ctx.geo.ring_distance(f.ring, f.sigma, f.exit_sigma, f.direction) <= ctx.tol
    ):
        # Bug1's exit after a futile round: leave from the border's closest point.
        return _leave(ctx, evolve(state, follow=f), f, path, total)
    if f.exit_sigma is None and f.walked >= float(ctx.geo.perimeter[f.ring]) - ctx.tol:
        return _full_round(ctx, evolve(state, follow=f), f, moves)
    return moved(evolve(state, follow=f), moves, ())


def _leave(
    ctx: Context,
    state: BugState,
    f: Follow,
    walked_path: FloatArray,
    walked_len: float,
    *,
    d_reach: float | None = None,
) -> BugState:
    """Leave the border at the end of ``walked_path`` and go back to goal seeking.

    ``d_reach``: the leave rule's d_reach there, for the record.
    """
    p = walked_path[-1]
    at = state.travelled + walked_len
    events = (BugEvent("leave", _pt(p), event_label("L", f.obstacle), f.obstacle, at),)
    left = (evolve(f, walked=f.walked + (walked_len if f.target is None else 0.0)), at)
    moves: list[Move] = [Move(FOLLOW, walked_path, None)]
    # What the rule does right after leaving (not after Bug1's exit: nothing).
    after = ctx.leave.after_leave(ctx, f, p) if f.exit_sigma is None else None
    if after is not None:
        moves.append(after)
    record = Decision(
        s=state.travelled + _length(walked_path),
        position=_pt(p),
        mode=SEEK,
        box="leave",
        d_goal=float(math.hypot(*(p - ctx.goal))),
        chosen=None if after is None else after.aim,
        d_local_min=f.d_local_min,
        d_followed=ctx.leave.measures(f)[1],
        d_reach=d_reach,
    )
    state = evolve(state, decisions=(*state.decisions, record))
    out = moved(state, tuple(moves), events)
    last = moves[-1].path
    heading = (
        _unit(last[-1] - last[-2])
        if len(last) > 1 and math.hypot(*(last[-1] - last[-2])) > 0
        else state.heading
    )
    return evolve(
        out,
        mode=SEEK,
        follow=None,
        blocking=f.ring,
        blocking_obstacle=f.obstacle,
        quiet_depart=True,
        position=_pt(last[-1]),
        left=left,
        cache=None,
        heading=None if heading is None else _pt(heading),
    )


def _full_round(
    ctx: Context, state: BugState, f: Follow, moves: tuple[Move, ...]
) -> BugState:
    """Back where boundary following began without meeting the leave rule."""
    geo, g = ctx.geo, ctx.goal
    ring = geo.rings[f.ring]
    inside = bool(shapely.contains_xy(shapely.Polygon(ring), float(g[0]), float(g[1])))
    encloses_blocked = float(geo.area[f.ring]) > 0
    separated = inside if encloses_blocked else not inside
    if separated:
        who = event_label("", f.obstacle) if f.obstacle is not None else "the walls"
        what = f"obstacle {who}" if f.obstacle is not None else who
        if encloses_blocked:
            reason = f"the goal is enclosed: the robot went all the way round {what} (expanded, merged) without a way to leave"
        else:
            reason = f"the robot is enclosed: it went all the way round the pocket bounded by {what} without a way out"
        out = moved(evolve(state, follow=f), moves, ())
        out = evolve(out, mode=UNREACHABLE, reason=reason, terminated="loop")
        return _closing(
            out, "unreachable", float(math.hypot(*(np.asarray(out.position) - g)))
        )
    # Not a proof of unreachability: walk on to the closest point and leave there (Bug1).
    a = geo.start[geo.offset[f.ring] : geo.offset[f.ring + 1]]
    b = geo.end[geo.offset[f.ring] : geo.offset[f.ring + 1]]
    dist, closest = _segment_closest(np.stack([a, b], axis=1), g)
    k = int(np.argmin(dist))
    t = float(np.dot(closest[k] - a[k], b[k] - a[k]) / np.dot(b[k] - a[k], b[k] - a[k]))
    exit_sigma = geo.sigma(int(geo.offset[f.ring]) + k, min(max(t, 0.0), 1.0))
    out = moved(
        evolve(state, follow=evolve(f, exit_sigma=exit_sigma)),
        moves,
        (),
    )
    return out


def _length(path: FloatArray) -> float:
    """Length of a polyline, summed as :func:`moved` sums the path travelled [m].

    A decision's arclength must order with the next step's: the leave rule's own
    arclength along the walk may differ from it in the last bits.
    """
    return float(np.hypot(*np.diff(path, axis=0).T).sum())


def _closing(state: BugState, box: str, d_goal: float) -> BugState:
    """Add the run's last decision (``"reached"`` or ``"unreachable"``) where it ended."""
    record = Decision(
        s=state.travelled, position=state.position, mode=FOLLOW, box=box, d_goal=d_goal
    )
    return evolve(state, decisions=(*state.decisions, record))
