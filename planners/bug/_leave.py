"""When boundary following ends: the leave rule as one interchangeable object.

Boundary following (:mod:`planners.bug._follow`) asks the rule on the context three
things (:class:`~planners.bug._context.LeaveRule`): how far to walk before asking again, where on a walked
piece of path the rule first holds (updating the rule's memory on the way), and what the
robot does right after leaving. ``BugParams.leave_rule`` names the rule:

``"tangent_bug"`` (:class:`TangentBugLeave`; Kamon et al., Choset et al.)
    Leave as soon as d_reach < d_followed: the robot *sees* part of the followed
    obstacle closer to the goal than anything seen before; then head for that point.
``"chapter"`` (:class:`ChapterLeave`; Fig. 9.15 and 9.18)
    Leave when d(r, g) < d(M, g), counting only once the robot has been farther from
    the goal than M.
"""

from __future__ import annotations

__all__ = ["ChapterLeave", "TangentBugLeave", "leave_rule"]

import bisect
import math

import numpy as np

from planners.bug._context import (
    LEAVE_RULES,
    SEEK,
    Context,
    FloatArray,
    Follow,
    LeaveCheck,
    LeaveRule,
    Move,
    enter_disk,
    evolve,
    first_outside,
    first_within,
    point_along,
)
from planners.bug.sensor import (
    IntArray,
    RingGeometry,
    disk_span,
    free_extent,
    measure_border,
    visible_pieces,
)
from planners.space.geometry import as_point as _pt
from planners.space.geometry import segment_closest as _segment_closest


def _reach(ctx: Context, y: FloatArray, ring: int) -> tuple[float, FloatArray]:
    """Compute d_reach at ``y`` and the point achieving it.

    d_reach is the least distance to the goal of the followed border in view, 0 when the
    goal itself is in view within R.
    """
    g = ctx.goal
    dg = float(math.hypot(*(g - y)))
    if dg <= ctx.tol:
        return 0.0, g.copy()
    near = measure_border(ctx.geo, y, ctx.radius)
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


def _leaves(ctx: Context, f: Follow, y: FloatArray) -> tuple[bool, float | None]:
    """Tell whether the leave rule holds at ``y``: (leave, d_reach at ``y``).

    d_reach is None where the view cannot matter (:func:`_may_come_closer`): not sensed.
    """
    if not _may_come_closer(ctx, f, y):
        return False, None
    d_reach, _ = _reach(ctx, y, f.ring)
    return d_reach < f.d_followed - ctx.tol, d_reach


def _may_come_closer(ctx: Context, f: Follow, y: FloatArray) -> bool:
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
    closer = edges[: bisect.bisect_left(distance, f.d_followed + slack)]
    r2 = (ctx.radius + slack) ** 2
    bound = f.d_followed + slack
    if len(closer) >= _MANY_EDGES:
        return _any_in_view_closer(
            geo, np.array(closer, dtype=np.intp), y, g, r2, bound
        )
    for e in closer:
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
        if math.hypot(sx + t * dx - gx, sy + t * dy - gy) < bound:
            return True
    return False


_MANY_EDGES = 48
"""With this many edges to test or more, :func:`_may_come_closer` tests them as arrays
(:func:`_any_in_view_closer`) instead of one by one."""


def _any_in_view_closer(  # noqa: PLR0917 - the loop's quantities, as arrays
    geo: RingGeometry,
    edges: IntArray,
    y: FloatArray,
    g: FloatArray,
    r2: float,
    bound: float,
) -> bool:
    """Tell whether some edge's part within sqrt(``r2``) of ``y`` comes closer than ``bound`` to ``g``.

    :func:`_may_come_closer`'s loop over ``edges`` as array arithmetic: the same
    operations (:func:`planners.bug.sensor.disk_span`, then the point of the part closest
    to the goal), numpy's hypot for the distance (it may differ from the math module's
    in the last bit, far inside the bound's slack).
    """
    yx, yy = float(y[0]), float(y[1])
    gx, gy = float(g[0]), float(g[1])
    sx, sy = geo.start[edges, 0], geo.start[edges, 1]
    dx, dy = geo.step_x[edges], geo.step_y[edges]
    qa = geo.len2[edges]
    ax, ay = sx - yx, sy - yy
    qb = 2.0 * (ax * dx + ay * dy)
    qc = ax * ax + ay * ay - r2
    disc = qb * qb - 4.0 * qa * qc
    root = np.sqrt(np.maximum(disc, 0.0))
    t_in = np.maximum(0.0, (-qb - root) / (2.0 * qa))
    t_out = np.minimum(1.0, (-qb + root) / (2.0 * qa))
    t = ((gx - sx) * dx + (gy - sy) * dy) / qa
    t = np.minimum(np.maximum(t, t_in), t_out)
    near = np.hypot(sx + t * dx - gx, sy + t * dy - gy) < bound
    return bool(np.any(near & (disc >= 0) & (t_in <= t_out)))


def _refine_leave(
    ctx: Context, f: Follow, path: FloatArray, cum: FloatArray, d_end: float | None
) -> tuple[float, float | None]:
    """Locate (bisection, then the ring vertices nearby) where the leave rule first holds.

    The rule holds at the end of ``path``, where d_reach is ``d_end``. Returns the
    arclength and d_reach there.
    """
    total = float(cum[-1])
    fires, d_reach = _leaves(ctx, f, path[0])
    if fires:
        return 0.0, d_reach
    lo, hi, d_hi = 0.0, total, d_end
    for _ in range(ctx.refine):
        mid = 0.5 * (lo + hi)
        fires, d_reach = _leaves(ctx, f, point_along(path, cum, mid))
        if fires:
            hi, d_hi = mid, d_reach
        else:
            lo = mid
    # New border comes into view when the robot rounds a corner: prefer the corner itself.
    inner = np.flatnonzero((cum > lo) & (cum < hi))
    for i in inner.tolist():
        fires, d_reach = _leaves(ctx, f, path[i])
        if fires:
            return float(cum[i]), d_reach
    return hi, d_hi


# --------------------------------------------------------------------------- the rules


class TangentBugLeave:
    """TangentBug's rule: leave as soon as d_reach < d_followed (Kamon et al.).

    d_followed is the least distance to the goal of the followed border sensed since M;
    d_reach that of the followed border in view now (0 when the goal is in view). The
    robot senses at the end of each piece of the walk (rounding corners, where new border
    comes into view), locates where the rule first held within the piece, and then heads
    for the point that made it hold until it is closer to the goal than d_followed.

    Examples
    --------
    A square of side 2 in the way, the robot at M = (0, 1) on its left side, the goal at
    (3, 1). From its top-left corner the robot sees the whole top side, whose right end
    (2, 2) is closer to the goal than anything it saw at M:

    >>> from shapely import Polygon
    >>> from planners.bug._context import BugParams, Follow, make_context
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), 0.0)
    >>> ctx = make_context(space, BugParams(goal=(3.0, 1.0)), TangentBugLeave())
    >>> f = Follow(ring=0, direction=1, local_min=(0.0, 1.0), d_local_min=3.0,
    ...            d_followed=3.0, target=None, target_sigma=0.0, sigma=0.0, walked=0.0,
    ...            obstacle=1)
    >>> d_reach, at = _reach(ctx, np.array([0.0, 2.0]), 0)
    >>> round(d_reach, 6), at.tolist()
    (1.414214, [2.0, 2.0])
    >>> _leaves(ctx, f, np.array([0.0, 2.0]))[0]
    True
    """

    name = "tangent_bug"

    def walk_length(self, ctx: Context, f: Follow, remaining: float) -> float:
        """Return one follow step, shortened to the next corner ahead."""
        s = min(ctx.follow_step, max(remaining, 0.0))
        # New border comes into view as the robot rounds a corner: look there (though
        # not at every vertex of a polygonal arc).
        return min(
            s, ctx.geo.to_corner(f.ring, f.sigma, f.direction, 0.25 * ctx.follow_step)
        )

    def check(
        self, ctx: Context, f: Follow, path: FloatArray, cum: FloatArray
    ) -> LeaveCheck:
        """Sense at the end of ``path``; where the rule holds there, locate where it began."""
        fires, d_reach = _leaves(ctx, f, path[-1])
        if fires:
            return LeaveCheck(f, *_refine_leave(ctx, f, path, cum, d_reach))
        # d_followed takes in what the robot saw; min() as the definition reads.
        d_followed = f.d_followed if d_reach is None else min(f.d_followed, d_reach)
        return LeaveCheck(evolve(f, d_followed=d_followed, d_reach=d_reach), None)

    def after_leave(self, ctx: Context, f: Follow, p: FloatArray) -> Move | None:
        """Head for the point that made the rule hold until closer to the goal than d_followed."""
        g = ctx.goal
        _, target = _reach(ctx, p, f.ring)
        radius = f.d_followed - ctx.tol
        if math.hypot(*(p - g)) < radius:
            return None
        s = enter_disk(p, target, g, radius)
        if s is None:
            return None
        span = math.hypot(*(target - p))
        s = min(span, s + min(ctx.tol, 0.5 * (span - s)))
        q = p + s * (target - p) / span if span > 0 else p
        return Move(SEEK, np.array([p, q]), _pt(target))

    def measures(self, f: Follow) -> tuple[float | None, float | None]:
        """Return d_reach where the robot last looked, and d_followed."""
        return f.d_reach, f.d_followed


class ChapterLeave:
    """The chapter's rule: leave when d(r, g) < d(M, g) (Fig. 9.15 and 9.18).

    It ignores what the robot sees, so the crossing of the circle d(r, g) = d(M, g) is
    found exactly on the walked path, and the walk need not stop to look. Where the
    border leads downhill from M (into a pocket toward the goal) the inequality holds at
    once, so it counts only once the robot has been farther from the goal than M
    (``Follow.risen``).

    Examples
    --------
    M = (0, 1) at distance 3 from the goal (3, 1). Walking up the left side of a square of
    side 2 the robot rises at once; along the top it comes back within 3 of the goal at
    x = 3 - sqrt(8), 1 + 0.171573 m along the walk:

    >>> from planners.bug._context import BugParams, Follow, make_context
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((), 0.0)
    >>> ctx = make_context(space, BugParams(goal=(3.0, 1.0)), ChapterLeave())
    >>> f = Follow(ring=0, direction=1, local_min=(0.0, 1.0), d_local_min=3.0,
    ...            d_followed=3.0, target=None, target_sigma=0.0, sigma=0.0, walked=0.0,
    ...            obstacle=1)
    >>> path = np.array([[0.0, 1.0], [0.0, 2.0], [2.0, 2.0], [2.0, 1.0]])
    >>> cum = np.array([0.0, 1.0, 3.0, 4.0])
    >>> found = ChapterLeave().check(ctx, f, path, cum)
    >>> found.follow.risen, round(found.stop, 6)
    (True, 1.171573)
    """

    name = "chapter"

    def walk_length(self, ctx: Context, f: Follow, remaining: float) -> float:
        """Return the rest of the round: the crossing is found exactly on the way."""
        return max(remaining, 0.0)

    def check(
        self, ctx: Context, f: Follow, path: FloatArray, cum: FloatArray
    ) -> LeaveCheck:
        """Find where the robot, having been farther than M, comes closer than M."""
        g = ctx.goal
        s_rise = (
            0.0 if f.risen else first_outside(path, cum, g, f.d_local_min + ctx.tol)
        )
        if s_rise is None:
            return LeaveCheck(f, None)
        f = evolve(f, risen=True)
        return LeaveCheck(
            f, first_within(path, cum, g, f.d_local_min - ctx.tol, start=s_rise)
        )

    def after_leave(self, ctx: Context, f: Follow, p: FloatArray) -> Move | None:
        """Nothing: goal seeking decides from the leave point."""
        return None

    def measures(self, f: Follow) -> tuple[float | None, float | None]:
        """Return nothing: the rule compares d(r, g) with d(M, g) only."""
        return None, None


def leave_rule(name: str) -> LeaveRule:
    """Return the leave rule called ``name`` (``BugParams.leave_rule``).

    Examples
    --------
    >>> leave_rule("chapter").name
    'chapter'
    """
    if name == TangentBugLeave.name:
        return TangentBugLeave()
    if name == ChapterLeave.name:
        return ChapterLeave()
    raise ValueError(f"unknown leave rule {name!r} (expected one of {LEAVE_RULES})")
