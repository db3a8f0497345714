"""The vertex visibility after an edit, from the one before it.

A drag changes one obstacle; the visibility graph of section 9.4 changes only near it.
Whether two border vertices see each other depends on the blocked space along their
segment (within the tolerance eps) and on the blocked wedges at the two vertices, nothing
else (module docstring of :mod:`planners.visibility`). So, between the configuration
space before an edit and the one after it:

- a vertex is *stable* when it is a vertex of both borders with the same wedge (the same
  directions to its ring neighbours, the same convexity, not a pinch in one only);
- the *changed box* bounds everything that differs: the symmetric difference of the
  blocked spaces (a moved, inserted or deleted obstacle, merging and splitting, pockets
  opening or closing, the walls), the vertices of one border only and the vertices whose
  wedge changed, widened by a few eps;
- a pair of stable vertices whose segment keeps clear of the changed box sees (or does
  not see) as before; every other pair -- at a vertex that is not stable, or crossing
  the box -- is tested again, exactly as a build from scratch would.

The same holds for a query point (start, goal: no wedge) and a vertex, and for start and
goal: what they see is kept on the configuration space (``visibility._PointSights``) and
carried the same way. The pairs tested again are found without screening all n^2 / 2
pairs against the box (:func:`_pairs_to_test`), and all of them go through one exact
test. An edit that changes most of a big border is left to a build from scratch.

The result is the same list of pairs a build from scratch gives, edge for edge (property-
tested with random edit sequences in ``tests/planners/test_incremental.py``). The SVG and
both paths follow from it (:func:`planners.visibility.plan_visibility`).
"""

from __future__ import annotations

__all__ = ["carry_visibility"]

import dataclasses
from collections.abc import Iterator, Sequence

import numpy as np
import numpy.typing as npt
import shapely
from shapely.geometry.base import BaseGeometry as Geometry

from planners.space.expansion import ConfigurationSpace
from planners.space.geometry import take_rows
from planners.visibility._graphs import (
    ANGLE_TOL,
    Border,
    Sight,
    build_border,
    exact_free,
    leaves_blocked,
    point_sights,
    vertex_visibility,
)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

_MOSTLY = 0.5
"""Carry only when at least this share of the vertices is stable (else build afresh)..."""
_SMALL = 256
"""... unless there are at most this many vertices (then the carry is cheap anyway)."""


def carry_visibility(new: ConfigurationSpace, old: ConfigurationSpace) -> bool:
    """Give ``new`` its vertex visibility, updated from ``old``'s where that is known.

    Returns True when ``new`` has its vertex visibility afterwards (carried over now or
    already there), False when ``old`` had none to start from or the tolerance changed
    (then the VG builds it from scratch, as without this call).

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> from planners.visibility import plan_visibility
    >>> a = configuration_space((Polygon([(0, 0), (1, 0), (1, 1)]),), 0.0)
    >>> b = configuration_space((Polygon([(0, 0), (1, 0), (0.5, 1)]),), 0.0)
    >>> _ = plan_visibility(a, (-1, 0), (2, 2))  # the VG on a: its visibility is known
    >>> carry_visibility(b, a), plan_visibility(b, (-1, 0), (2, 2)).status
    (True, 'ok')
    """
    if new.known(vertex_visibility) is not None:
        return True
    before = old.known(vertex_visibility)
    if before is None or old.eps != new.eps:
        return False
    change = _change(old, new)
    n = len(change.stable)
    if n > _SMALL and np.count_nonzero(change.stable) < _MOSTLY * n:
        return False  # most of a big border changed: a build from scratch is cheaper
    sight, points = _carried(new, old, before, change)
    new.adopt(vertex_visibility, sight)
    store = new.derive(point_sights)
    for point, rows in points:
        store.put(point, rows)
    kept = old.known(point_sights)
    for (a, b), free in kept.pair_items() if kept is not None else []:
        ends = np.array([a]), np.array([b])
        if not _meets_box(*ends, change.box)[0]:
            store.put_pair(a, b, free)  # the changes are away from the segment
    return True


@dataclasses.dataclass(frozen=True, eq=False)
class _Change:
    """How the border after an edit relates to the one before it."""

    to_new: IntArray
    """Per old vertex, the new vertex at the same place, or -1."""
    stable: BoolArray
    """Per new vertex, whether it was a vertex before with the same wedge."""
    box: FloatArray | None
    """(x0, y0, x1, y1) bounding everything that differs, or None if nothing does."""


def _change(old: ConfigurationSpace, new: ConfigurationSpace) -> _Change:
    old_b, new_b = old.derive(build_border), new.derive(build_border)
    match = _match(old_b.points, new_b.points)
    stable = _stable(old_b, new_b, match)
    box = _changed_box(old, new, match, stable)
    to_new = np.full(len(old_b.points), -1, dtype=np.intp)
    to_new[match[match >= 0]] = np.flatnonzero(match >= 0)
    return _Change(to_new, stable, box)


def _carried(
    new: ConfigurationSpace, old: ConfigurationSpace, before: Sight, change: _Change
) -> tuple[Sight, list[tuple[tuple[float, float], IntArray]]]:
    """Return the vertex visibility in ``new`` and what each point ``old`` kept sees.

    Every pair to test again -- between vertices, and between a vertex and a kept
    point (start, goal) -- goes through one exact test (one march of the edge grid).
    """
    new_b = new.derive(build_border)
    kept_i, kept_j = _kept_pairs(new_b, change, before)
    # Every other pair again: at an unstable vertex, or crossing the box.
    tests = [*_pairs_to_test(new_b, change.stable, change.box)]
    ti = np.concatenate([np.zeros(0, dtype=np.intp), *(t[0] for t in tests)])
    tj = np.concatenate([np.zeros(0, dtype=np.intp), *(t[1] for t in tests)])
    a, b = [take_rows(new_b.points, ti)], [take_rows(new_b.points, tj)]
    # The points old kept: rows of stable vertices clear of the box stay.
    kept = old.known(point_sights)
    carried = []
    for point, rows in kept.items() if kept is not None else []:
        stay, again = _point_change(new_b, change, point, rows)
        carried.append((point, stay, again))
        a.append(take_rows(new_b.points, again))
        b.append(np.broadcast_to(np.asarray(point), (len(again), 2)))
    ok = exact_free(new, new_b, np.vstack(a), np.vstack(b))
    i = np.concatenate([kept_i, ti[ok[: len(ti)]]])
    j = np.concatenate([kept_j, tj[ok[: len(ti)]]])
    # Row-major: one key per pair (each pair comes once); the kept pairs come in
    # order already, and a stable sort runs through such runs fast.
    order = np.argsort(i.astype(np.int64) * len(new_b.points) + j, kind="stable")
    at, points = len(ti), []
    for point, stay, again in carried:
        seen = again[ok[at : at + len(again)]]
        at += len(again)
        points.append((point, np.sort(np.concatenate([stay, seen]))))
    return Sight(len(new_b.points), i[order], j[order]), points


def _kept_pairs(
    new_b: Border, change: _Change, before: Sight
) -> tuple[IntArray, IntArray]:
    """Old visible pairs of stable vertices clear of the box, in the new numbering.

    One compiled pass over the old pairs (:func:`planners.kernels.kept_pairs`).
    """
    from planners.kernels import kept_pairs  # noqa: PLC0415 - numba only where graphs are built

    box = change.box if change.box is not None else np.zeros(0)
    return kept_pairs(
        change.to_new, change.stable, before.i, before.j, new_b.points, box
    )


def _point_change(
    new_b: Border, change: _Change, point: tuple[float, float], rows: IntArray
) -> tuple[IntArray, IntArray]:
    """Split a kept point's vertices: those that still see it, those to test again.

    Again: the vertices not stable, and those whose segment to the point meets the
    box, less the ones the screen rules out.
    """
    n = len(new_b.points)
    p = np.asarray(point, dtype=np.float64)
    # Per vertex, whether its segment to the point meets the box (row by row, so the
    # rows of the vertices that still saw it are the same answers).
    meets = _meets_box(new_b.points, np.broadcast_to(p, (n, 2)), change.box)
    v = change.to_new[rows]
    v = v[v >= 0]
    v = v[change.stable[v]]
    stay = v[~meets[v]]
    again = np.flatnonzero(~change.stable | meets)
    d = p - take_rows(new_b.points, again)
    ends = np.full(len(again), n, dtype=np.intp)  # the point: no wedge
    keep = ~leaves_blocked(new_b.wedges.extended(1), again, ends, d[:, 0], d[:, 1])
    return stay, again[keep]


def _match(old_points: FloatArray, new_points: FloatArray) -> IntArray:
    """For each new vertex, the old vertex at exactly the same place, or -1.

    Exactly as a dict from each old point's (x, y) to its index would answer (the last
    index of a point that comes more than once; -0.0 is 0.0): the old points sorted as
    complex numbers (by x, then y; stably), each new point found by bisection.
    """
    old, new = _complex(old_points), _complex(new_points)
    if not len(old):
        return np.full(len(new), -1, dtype=np.intp)
    order = np.argsort(old, kind="stable")
    keys = old[order]
    at = np.searchsorted(keys, new, side="right") - 1
    hit = (at >= 0) & (keys[np.maximum(at, 0)] == new)
    return np.where(hit, order[np.maximum(at, 0)], -1).astype(np.intp)


def _complex(points: FloatArray) -> npt.NDArray[np.complex128]:
    """Return (n, 2) points as x + iy, bit for bit."""
    z = np.empty(len(points), dtype=np.complex128)
    z.real, z.imag = points[:, 0], points[:, 1]
    return z


def _stable(old_b: Border, new_b: Border, match: IntArray) -> BoolArray:
    """Which new vertices were vertices before with the very same wedge."""
    stable = match >= 0
    k = np.flatnonzero(stable)
    o = match[k]
    ow, nw = old_b.wedges, new_b.wedges
    same = (
        np.all(take_rows(ow.nxt, o) == take_rows(nw.nxt, k), axis=1)
        & np.all(take_rows(ow.prv, o) == take_rows(nw.prv, k), axis=1)
        & (ow.narrow[o] == nw.narrow[k])
        & (old_b.pinch_nodes[o] == new_b.pinch_nodes[k])
        & (old_b.convex_nodes[o] == new_b.convex_nodes[k])
    )
    stable[k[~same]] = False
    return stable


def _changed_box(
    old: ConfigurationSpace, new: ConfigurationSpace, match: IntArray, stable: BoolArray
) -> FloatArray | None:
    """Bound all that differs between the two spaces, widened by 8 eps; None if nothing."""
    old_b, new_b = old.derive(build_border), new.derive(build_border)
    parts = []
    if (old.free is None) != (new.free is None):
        parts.append(np.vstack([old_b.points, new_b.points]))
    else:
        diff = _blocked_difference(old, new)
        if not diff.is_empty:
            x0, y0, x1, y1 = diff.bounds
            parts.append(np.array([[x0, y0], [x1, y1]]))
    gone = np.ones(len(old_b.points), dtype=bool)
    gone[match[match >= 0]] = False
    parts += [old_b.points[gone], new_b.points[~stable]]
    points = np.vstack([np.zeros((0, 2)), *parts])
    if not len(points):
        return None
    margin = 8.0 * new.eps
    return np.concatenate([points.min(axis=0) - margin, points.max(axis=0) + margin])


def _blocked_difference(old: ConfigurationSpace, new: ConfigurationSpace) -> Geometry:
    """Return a region that holds every point blocked in one space and free in the other.

    With the same walls, that is within the symmetric difference of the expanded
    obstacles that differ (a point of one union only lies in a changed obstacle of that
    side and outside every obstacle of the other): a few small polygons, not the union of
    all. Else the symmetric difference of the free spaces (or of the merged obstacles).
    """
    same_walls = old.boundary is new.boundary or (
        old.boundary is not None
        and new.boundary is not None
        and shapely.equals_exact(old.boundary, new.boundary, 0.0)
    )
    if not same_walls:
        before = old.free if old.free is not None else old.merged
        after = new.free if new.free is not None else new.merged
        return shapely.symmetric_difference(before, after)
    kept = {id(e) for e in new.expanded} & {id(e) for e in old.expanded}
    gone = [e for e in old.expanded if id(e) not in kept]
    added = [e for e in new.expanded if id(e) not in kept]
    return shapely.symmetric_difference(_union(gone), _union(added))


def _union(polygons: Sequence[Geometry]) -> Geometry:
    """Return the union of valid polygons (one alone as it is: a drag's usual case)."""
    return polygons[0] if len(polygons) == 1 else shapely.union_all(polygons)


def _meets_box(a: FloatArray, b: FloatArray, box: FloatArray | None) -> BoolArray:
    """Tell which segments a[k] -> b[k] meet the closed box (x0, y0, x1, y1).

    Axis by axis, the parameters where each segment enters and leaves the box's slab
    (:func:`planners.kernels.segments_meet_box`).
    """
    if box is None:
        return np.zeros(len(a), dtype=bool)
    from planners.kernels import segments_meet_box  # noqa: PLC0415 - numba only where graphs are built

    return segments_meet_box(
        np.ascontiguousarray(a, dtype=np.float64),
        np.ascontiguousarray(b, dtype=np.float64),
        box,
    )


def _pairs_to_test(
    new_b: Border, stable: BoolArray, box: FloatArray | None
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield the pairs (i < j) whose visibility must be tested again, in batches.

    The rows of the vertices that are not stable (each against every vertex), then the
    stable pairs whose segment meets the box; less, in both, the pairs that leave an end
    into its wedge (the screening of a full build). Work is about k n for k vertices
    that are not stable, plus the stable pairs the box's outcodes cannot rule out; both
    listings are compiled loops (:func:`planners.kernels.row_pairs`,
    :func:`planners.kernels.box_pairs`).
    """
    from planners.kernels import row_pairs  # noqa: PLC0415 - numba only where graphs are built

    moved = np.flatnonzero(~stable)
    w = new_b.wedges
    yield row_pairs(moved, stable, new_b.points, (w.nxt, w.prv, w.narrow), ANGLE_TOL)
    if box is not None:
        yield from _crossing_box(new_b, stable, box)


def _crossing_box(
    new_b: Border, stable: BoolArray, box: FloatArray
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield the screened stable pairs whose segment meets the box.

    Only vertices that face the box can be ends of such a pair (:func:`_facing`). The
    pairs of those are listed by a compiled loop (:func:`planners.kernels.box_pairs`):
    the outcodes' test, whether the line meets the box, and the screen, pair by pair.
    """
    from planners.kernels import box_pairs  # noqa: PLC0415 - numba only where graphs are built

    nodes = np.flatnonzero(stable & _facing(new_b, box))
    code = _outcodes(take_rows(new_b.points, nodes), box)
    w = new_b.wedges
    i, j = box_pairs(
        new_b.points, nodes, code, box, (w.nxt, w.prv, w.narrow), ANGLE_TOL
    )
    yield i, j


def _facing(new_b: Border, box: FloatArray) -> BoolArray:
    """Tell the vertices from which a segment may leave towards the box unscreened.

    A vertex outside the box whose blocked wedge is narrower than pi (a convex cone)
    and holds the directions to all four corners strictly holds the direction to every
    point of the box, with the screen's tolerance (it grows with the direction's
    length, which the triangle inequality bounds): every segment from it that meets
    the box leaves into its wedge and is screened out. The corners are held to twice
    the tolerance, so rounding never makes a vertex look behind that is not. A
    compiled loop (:func:`planners.kernels.facing`).
    """
    from planners.kernels import facing  # noqa: PLC0415 - numba only where graphs are built

    w = new_b.wedges
    return facing(new_b.points, (w.nxt, w.prv, w.narrow), box, ANGLE_TOL)


def _outcodes(points: FloatArray, box: FloatArray) -> npt.NDArray[np.uint8]:
    """Per point, a bit for each side of the box it lies strictly beyond (Cohen-Sutherland)."""
    x, y = points[:, 0], points[:, 1]
    code = (x < box[0]).astype(np.uint8)
    code |= (x > box[2]).astype(np.uint8) << 1
    code |= (y < box[1]).astype(np.uint8) << 2
    code |= (y > box[3]).astype(np.uint8) << 3
    return code
