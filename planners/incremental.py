"""The vertex visibility after an edit, from the one before it (issue 15, item 1).

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

The result is the same list of pairs a build from scratch gives, edge for edge (property-
tested with random edit sequences in ``tests/planners/test_incremental.py``). The SVG and
both paths follow from it (:func:`planners.visibility.plan_visibility`).
"""

from __future__ import annotations

__all__ = ["carry_visibility"]

from collections.abc import Iterator

import numpy as np
import numpy.typing as npt
import shapely

from planners.expansion import ConfigurationSpace
from planners.visibility import (
    _Border,
    _build_border,
    _leaves_blocked,
    _segments_free,
    _Sight,
    _vertex_visibility,
)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

_BLOCK = 1 << 20
"""Vertex pairs checked against the changed box at once."""


def carry_visibility(new: ConfigurationSpace, old: ConfigurationSpace) -> bool:
    """Give ``new`` its vertex visibility, updated from ``old``'s where that is known.

    Returns True when ``new`` has its vertex visibility afterwards (carried over now or
    already there), False when ``old`` had none to start from or the tolerance changed
    (then the VG builds it from scratch, as without this call).

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.expansion import configuration_space
    >>> from planners.visibility import plan_visibility
    >>> a = configuration_space((Polygon([(0, 0), (1, 0), (1, 1)]),), 0.0)
    >>> b = configuration_space((Polygon([(0, 0), (1, 0), (0.5, 1)]),), 0.0)
    >>> _ = plan_visibility(a, (-1, 0), (2, 2))  # the VG on a: its visibility is known
    >>> carry_visibility(b, a), plan_visibility(b, (-1, 0), (2, 2)).status
    (True, 'ok')
    """
    if new.known(_vertex_visibility) is not None:
        return True
    before = old.known(_vertex_visibility)
    if before is None or old.eps != new.eps:
        return False
    new.adopt(_vertex_visibility, _carried(new, old, before))
    return True


def _carried(
    new: ConfigurationSpace, old: ConfigurationSpace, before: _Sight
) -> _Sight:
    old_b, new_b = old.derive(_build_border), new.derive(_build_border)
    match = _match(old_b.points, new_b.points)
    stable = _stable(old_b, new_b, match)
    box = _changed_box(old, new, match, stable)
    # Old visible pairs of stable vertices clear of the box, in the new numbering.
    to_new = np.full(len(old_b.points), -1, dtype=np.intp)
    to_new[match[match >= 0]] = np.flatnonzero(match >= 0)
    i, j = to_new[before.i], to_new[before.j]
    keep = (i >= 0) & (j >= 0)
    i, j = i[keep], j[keep]
    keep = stable[i] & stable[j]
    i, j = i[keep], j[keep]
    keep = ~_meets_box(new_b.points[i], new_b.points[j], box)
    found_i, found_j = [np.minimum(i, j)[keep]], [np.maximum(i, j)[keep]]
    # Every other pair again: at an unstable vertex, or crossing the box.
    for ti, tj in _pairs_to_test(new_b, stable, box):
        ok = _segments_free(new, new_b, new_b.points[ti], new_b.points[tj])
        found_i.append(ti[ok])
        found_j.append(tj[ok])
    i, j = np.concatenate(found_i), np.concatenate(found_j)
    order = np.lexsort((j, i))
    return _Sight(len(new_b.points), i[order], j[order])


def _match(old_points: FloatArray, new_points: FloatArray) -> IntArray:
    """For each new vertex, the old vertex at exactly the same place, or -1."""
    index = {p: k for k, p in enumerate(map(tuple, old_points.tolist()))}
    return np.array(
        [index.get(p, -1) for p in map(tuple, new_points.tolist())], dtype=np.intp
    )


def _stable(old_b: _Border, new_b: _Border, match: IntArray) -> BoolArray:
    """Which new vertices were vertices before with the very same wedge."""
    stable = match >= 0
    k = np.flatnonzero(stable)
    o = match[k]
    ow, nw = old_b.wedges, new_b.wedges
    same = (
        np.all(ow.nxt[o] == nw.nxt[k], axis=1)
        & np.all(ow.prv[o] == nw.prv[k], axis=1)
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
    old_b, new_b = old.derive(_build_border), new.derive(_build_border)
    before = old.free if old.free is not None else old.merged
    after = new.free if new.free is not None else new.merged
    parts = []
    if (old.free is None) != (new.free is None):
        parts.append(np.vstack([old_b.points, new_b.points]))
    else:
        diff = shapely.symmetric_difference(before, after)
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


def _meets_box(a: FloatArray, b: FloatArray, box: FloatArray | None) -> BoolArray:
    """Tell which segments a[k] -> b[k] meet the closed box (x0, y0, x1, y1)."""
    if box is None:
        return np.zeros(len(a), dtype=bool)
    t0, t1 = np.zeros(len(a)), np.ones(len(a))
    for axis in (0, 1):
        p, d = a[:, axis], b[:, axis] - a[:, axis]
        low, high = box[axis], box[axis + 2]
        safe = np.where(d != 0, d, 1.0)
        with np.errstate(over="ignore"):  # a subnormal direction: t is +-inf, as meant
            ta, tb = (low - p) / safe, (high - p) / safe
        inside = (p >= low) & (p <= high)
        enter = np.where(d != 0, np.minimum(ta, tb), np.where(inside, 0.0, np.inf))
        leave = np.where(d != 0, np.maximum(ta, tb), np.where(inside, 1.0, -np.inf))
        t0, t1 = np.maximum(t0, enter), np.minimum(t1, leave)
    return t0 <= t1


def _pairs_to_test(
    new_b: _Border, stable: BoolArray, box: FloatArray | None
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield, block by block, the pairs whose visibility must be tested again.

    Those at a vertex that is not stable and those whose segment meets the box, less
    the ones that leave an end into its wedge (the screening of a full build).
    """
    points = new_b.points
    n = len(points)
    r0 = 0
    while r0 < n - 1:
        r1 = min(n - 1, r0 + max(1, _BLOCK // (n - r0)))
        rows, cols = np.arange(r0, r1)[:, None], np.arange(r0 + 1, n)[None, :]
        again = ~(stable[rows] & stable[cols])
        if box is not None:
            again |= _may_meet_box(points[rows], points[cols], box)
        r, c = np.nonzero(again & (cols > rows))
        i, j = r0 + r, r0 + 1 + c
        near = ~(stable[i] & stable[j])
        near |= _meets_box(points[i], points[j], box)
        i, j = i[near], j[near]
        d = points[j] - points[i]
        keep = ~_leaves_blocked(new_b.wedges, i, j, d[:, 0], d[:, 1])
        yield i[keep], j[keep]
        r0 = r1


def _may_meet_box(a: FloatArray, b: FloatArray, box: FloatArray) -> BoolArray:
    """Rule out the segments with both ends on one outer side of the box (broadcast)."""
    away = (a[..., 0] < box[0]) & (b[..., 0] < box[0])
    away |= (a[..., 0] > box[2]) & (b[..., 0] > box[2])
    away |= (a[..., 1] < box[1]) & (b[..., 1] < box[1])
    away |= (a[..., 1] > box[3]) & (b[..., 1] > box[3])
    return ~away
