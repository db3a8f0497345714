"""The sensor's sweep as Python ran it before it was compiled: the reference of the tests.

:func:`planners.bug.sensor._sweep` runs the middle of the sweep compiled
(:func:`planners.kernels.sweep_intervals`): clipping the facing edges to the sensing
disk, the critical angles, merging those that are one up to eps, casting a ray through
each interval, and the visible piece's parameters. This is the Python it replaced, kept
verbatim but for its second way of casting the rays (with 24 facing edges or more,
``_first_hits`` cast them all at once with numpy, naming the same edge for every ray
as the per-ray loop kept here) and three choices that make its arithmetic the compiled
loop's on any machine (each marked ``# libm`` or ``# stable`` below):

- the critical angles by the C library's ``atan2`` (``math.atan2``), not numpy's
  ``arctan2``, which on AVX-512 machines is SVML's and differs in the last bit for about
  one angle in fourteen;
- the interval's middle direction by ``math.cos`` and ``math.sin``;
- a stable sort of the angles, so that equal angles keep their order (numba's sort and
  numpy's order ties differently).

The wedges at the robot's feet are added after the loop by the shared
:func:`planners.bug.sensor._add_edge_on_pieces`. The tests hold the two sweeps to equal
items, field for field.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from planners.bug.sensor import (
    TAU,
    Near,
    _add_edge_on_pieces,
    _in_any_wedge,
    _Item,
    _measure,
    disk_span,
)
from planners.kernels import ANGLE_TOL
from planners.space.border import RingGeometry

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def sweep(  # noqa: PLR0912, PLR0915 - kept as it was
    geo: RingGeometry, x: FloatArray, radius: float, near: Near | None = None
) -> list[_Item]:
    """Cut the full turn at the critical angles and say what each interval sees."""
    finite = math.isfinite(radius)
    if len(geo.start) == 0:
        return []
    if near is None or (near.edges is not None and near.reach < radius):
        near = _measure(geo, x, radius)
    dist, cr, occ = near.dist, near.cr, near.occ
    front = cr < 0
    for o in occ:
        front[near.local(o.edge_n)] = front[near.local(o.edge_q)] = False
    if finite:
        front &= dist < radius
    facing = facing_parts(geo, near, np.flatnonzero(front), radius)
    px = [p.inx for p in facing] + [p.outx for p in facing]
    py = [p.iny for p in facing] + [p.outy for p in facing]
    angles = np.array([math.atan2(b, a) for a, b in zip(px, py, strict=True)])  # libm
    if occ:
        angles = np.concatenate(
            (
                angles,
                [math.atan2(o.n[1], o.n[0]) for o in occ]
                + [math.atan2(o.q[1], o.q[0]) for o in occ],
            )
        )
    if len(angles) == 0:
        return []
    theta = angles % TAU

    def reach() -> FloatArray:
        return np.concatenate(
            (np.hypot(np.array(px), np.array(py)), np.full(2 * len(occ), np.nan))
        )

    nearest = min(p.dist for p in facing) if facing else math.inf
    lo_l = merge_close_angles(theta, reach, nearest, geo.eps).tolist()
    hi_l = [*lo_l[1:], lo_l[0] + TAU]
    mid = (0.5 * (np.array(lo_l) + np.array(hi_l))).tolist()
    ux_l = [math.cos(m) for m in mid]  # libm
    uy_l = [math.sin(m) for m in mid]  # libm

    items: list[_Item] = []
    here = (float(x[0]), float(x[1]))
    for j in range(len(lo_l)):
        ux, uy = ux_l[j], uy_l[j]
        if occ and _in_any_wedge(occ, ux, uy):
            kind, e = "blocked", -1
        else:
            e = first_hit(facing, ux, uy)
            kind = "piece" if e >= 0 else "free"
        last = items[-1] if items else None
        if last is not None and last.kind == kind and last.edge == e:
            last.hi = hi_l[j]
        elif kind == "piece":
            items.append(_Item("piece", lo_l[j], hi_l[j], e))
        else:
            items.append(_Item(kind, lo_l[j], hi_l[j], p0=here, p1=here))
    if len(items) > 1:
        first, last = items[0], items[-1]
        if first.kind == last.kind and first.edge == last.edge:
            last.hi = first.hi + TAU
            items.pop(0)
    parts = {p.edge: p for p in facing}
    for it in items:
        if it.kind == "piece":
            p = parts[it.edge]
            args = (p.ax, p.ay, p.dx, p.dy, p.t_in, p.t_out, geo.eps)
            it.t0 = t_at(it.lo, *args)
            it.t1 = t_at(it.hi, *args)
            sx, sy = geo.start_list[it.edge]
            it.p0 = (sx + it.t0 * p.dx, sy + it.t0 * p.dy)
            it.p1 = (sx + it.t1 * p.dx, sy + it.t1 * p.dy)
    if occ:
        items = _add_edge_on_pieces(geo, x, radius, items, occ)
    return items


def first_hit(facing: list[Part], ux: float, uy: float) -> int:
    """Return the facing edge a ray from the robot along (ux, uy) meets first, or -1."""
    e, best = -1, math.inf
    for edge, _, _, dx, dy, cr, _, _, inx, iny, outx, outy, _ in facing:
        if outx * uy - outy * ux > 0 and ux * iny - uy * inx > 0:
            denom = ux * dy - uy * dx
            s = cr / denom if denom != 0 else math.inf
            if 0 < s < best:
                e, best = edge, s
    return e


class Part(NamedTuple):
    """The part of a facing edge inside the sensing disk, relative to the robot."""

    edge: int
    ax: float
    ay: float
    dx: float
    dy: float
    cross: float
    t_in: float
    t_out: float
    inx: float
    iny: float
    outx: float
    outy: float
    dist: float


def facing_parts(
    geo: RingGeometry, near: Near, f: IntArray, radius: float
) -> list[Part]:
    """Clip the facing edges ``f`` (positions in ``near``) to the sensing disk."""
    out: list[Part] = []
    finite = math.isfinite(radius)
    r2 = radius * radius
    eps = geo.eps
    steps, len2, lengths = geo.step_list, geo.len2_list, geo.length_list
    ids = f if near.edges is None else near.edges[f]
    for e, (ax, ay), c, d in zip(
        ids.tolist(),
        near.a[f].tolist(),
        near.cr[f].tolist(),
        near.dist[f].tolist(),
        strict=True,
    ):
        dx, dy = steps[e]
        qa, length = len2[e], lengths[e]
        t_in, t_out = 0.0, 1.0
        if finite:
            t_in, t_out, _ = disk_span(ax, ay, dx, dy, qa, r2)
            if not (t_out - t_in) * length > eps:
                continue
        out.append(
            Part(
                edge=e,
                ax=ax,
                ay=ay,
                dx=dx,
                dy=dy,
                cross=c,
                t_in=t_in,
                t_out=t_out,
                inx=ax + t_in * dx,
                iny=ay + t_in * dy,
                outx=ax + t_out * dx,
                outy=ay + t_out * dy,
                dist=d,
            )
        )
    return out


def merge_close_angles(
    theta: FloatArray,
    reach: Callable[[], FloatArray],
    nearest: float,
    eps: float,
) -> FloatArray:
    """Sort the critical angles (in [0, 2 pi)) and merge those that are one up to eps."""
    order = np.argsort(theta, kind="stable")  # stable
    theta = theta[order]
    if len(theta) < 2:
        return theta
    gap = ccw_gaps(theta)
    tiny = gap <= ANGLE_TOL
    keep = np.empty(len(theta), dtype=bool)
    keep[0] = True
    np.logical_not(tiny[:-1], out=keep[1:])
    if tiny[-1]:
        keep[-1] = False
    widest = eps / nearest if nearest > 0 else math.inf
    if not np.any((gap <= widest) & ~tiny):
        return theta[keep]
    theta = theta[keep]
    dist = reach()[order[keep]]
    absorbed = np.zeros(len(theta), dtype=bool)
    for side in theta[np.isnan(dist)].tolist():
        off = np.abs((theta - side + math.pi) % TAU - math.pi)
        absorbed |= off * dist <= eps
    theta, dist = theta[~absorbed], dist[~absorbed]
    n = len(theta)
    if n < 2:
        return theta
    far = np.fmax(dist, np.roll(dist, -1))
    pairs = np.flatnonzero(ccw_gaps(theta) * far <= eps).tolist()
    if not pairs:
        return theta
    far_l = dist.tolist()

    def rank(i: int) -> float:
        return math.inf if math.isnan(far_l[i]) else far_l[i]

    if len(pairs) == n:
        return theta[[max(range(n), key=rank)]]
    first = 0
    if pairs[0] == 0 and pairs[-1] == n - 1:
        first = next(j for j in range(1, len(pairs)) if pairs[j] != pairs[j - 1] + 1)
    drop: list[int] = []
    end = best = -1
    for i in pairs[first:] + pairs[:first]:
        if i != end:
            best = i
        end = (i + 1) % n
        if rank(end) > rank(best):
            drop.append(best)
            best = end
        else:
            drop.append(end)
    keep = np.ones(n, dtype=bool)
    keep[drop] = False
    return theta[keep]


def ccw_gaps(theta: FloatArray) -> FloatArray:
    """Return the gap from each sorted angle to the next counter-clockwise (last to first)."""
    gap = np.empty(len(theta))
    np.subtract(theta[1:], theta[:-1], out=gap[:-1])
    gap[-1] = theta[0] + TAU - theta[-1]
    return gap


def t_at(  # noqa: PLR0917
    angle: float,
    ax: float,
    ay: float,
    dx: float,
    dy: float,
    t_in: float,
    t_out: float,
    eps: float,
) -> float:
    """Return the parameter along an edge where the ray at ``angle`` meets it."""
    ux, uy = math.cos(angle), math.sin(angle)
    denom = ux * dy - uy * dx
    t = (ax * uy - ay * ux) / denom if denom != 0 else t_in
    t = min(max(t, t_in), t_out)
    end = t_in if t - t_in <= t_out - t else t_out
    px, py = ax + end * dx, ay + end * dy
    return end if abs(ux * py - uy * px) <= eps else t
