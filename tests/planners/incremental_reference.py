"""The incremental VG's pair listings as numpy ran them before they were compiled.

:func:`planners.visibility.incremental._crossing_box` lists the stable pairs whose segment meets
the changed box with a compiled loop (:func:`planners.kernels.box_pairs`),
:func:`planners.visibility.incremental._pairs_to_test` the changed vertices' rows
(:func:`planners.kernels.row_pairs`) and :func:`planners.visibility.incremental._kept_pairs` the
pairs carried over (:func:`planners.kernels.kept_pairs`); which segments meet the box
and which vertices face it are compiled too (:func:`planners.kernels.segments_meet_box`,
:func:`planners.kernels.facing`). These are the numpy versions they replaced, kept
verbatim; tests hold each pair equal.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import numpy.typing as npt

from planners.space.geometry import take_rows
from planners.visibility._graphs import Border, Sight, _into_wedge, leaves_blocked
from planners.visibility.incremental import ANGLE_TOL, _Change, _outcodes

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

_BLOCK = 1 << 20
"""Vertex pairs checked against the changed box at once."""


def crossing_box_reference(
    new_b: Border, stable: BoolArray, box: FloatArray
) -> Iterator[tuple[IntArray, IntArray, BoolArray]]:
    """Yield, block by block, the screened stable pairs whose segment meets the box.

    Only vertices that face the box can be ends of such a pair (:func:`_facing`).
    """
    points = new_b.points
    nodes = np.flatnonzero(stable & facing_reference(new_b, box))
    code = _outcodes(take_rows(points, nodes), box)
    k = len(nodes)
    r0 = 0
    while r0 < k - 1:
        r1 = min(k - 1, r0 + max(1, _BLOCK // (k - r0)))
        rows, cols = np.arange(r0, r1)[:, None], np.arange(r0 + 1, k)[None, :]
        # Both ends on one outer side of the box: the segment cannot meet it.
        maybe = ((code[rows] & code[cols]) == 0) & (cols > rows)
        r, c = np.nonzero(maybe)
        i, j = nodes[r0 + r], nodes[r0 + 1 + c]
        meets = _line_meets_box(take_rows(points, i), take_rows(points, j), box)
        i, j = _screened(new_b, i[meets], j[meets])
        yield i, j, np.zeros(len(i), dtype=bool)
        r0 = r1


def _line_meets_box(a: FloatArray, b: FloatArray, box: FloatArray) -> BoolArray:
    """Tell which lines through a[k] and b[k] may meet the box.

    Not all four corners strictly on one side: the separating axis test; with the
    outcodes' test of the bounding boxes it tells the segments that meet the box.

    Corners closer to a line than a relative 1e-9 of the scale count as on it: a few
    more pairs are tested again, never fewer.
    """
    d = b - a
    scale = np.abs(d[:, 0]) + np.abs(d[:, 1])
    scale *= 1e-9 * (1.0 + np.abs(box).max())
    above = np.ones(len(a), dtype=bool)
    below = np.ones(len(a), dtype=bool)
    for cx, cy in (
        (box[0], box[1]),
        (box[2], box[1]),
        (box[0], box[3]),
        (box[2], box[3]),
    ):
        side = d[:, 0] * (cy - a[:, 1]) - d[:, 1] * (cx - a[:, 0])
        above &= side > scale
        below &= side < -scale
    return ~(above | below)


def kept_pairs_reference(
    new_b: Border, change: _Change, before: Sight
) -> tuple[IntArray, IntArray]:
    """The pairs an edit carries over, as numpy filtered them before the compiled pass
    (:func:`planners.kernels.kept_pairs`)."""
    i, j = change.to_new[before.i], change.to_new[before.j]
    keep = (i >= 0) & (j >= 0)
    i, j = i[keep], j[keep]
    keep = change.stable[i] & change.stable[j]
    i, j = i[keep], j[keep]
    keep = ~meets_box_reference(
        take_rows(new_b.points, i), take_rows(new_b.points, j), change.box
    )
    return np.minimum(i, j)[keep], np.maximum(i, j)[keep]


def _screened(new_b: Border, i: IntArray, j: IntArray) -> tuple[IntArray, IntArray]:
    """Leave out the pairs whose segment leaves an end into its blocked wedge."""
    d = take_rows(new_b.points, j) - take_rows(new_b.points, i)
    keep = ~leaves_blocked(new_b.wedges, i, j, d[:, 0], d[:, 1])
    return i[keep], j[keep]


def row_pairs_reference(
    new_b: Border, stable: BoolArray
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield, block by block, the screened pairs of each vertex that is not stable."""
    n = len(new_b.points)
    moved = np.flatnonzero(~stable)
    per_block = max(1, _BLOCK // max(n, 1))
    for k in range(0, len(moved), per_block):
        rows = np.repeat(moved[k : k + per_block], n)
        cols = np.tile(np.arange(n, dtype=np.intp), len(moved[k : k + per_block]))
        # A pair of two such vertices once, from its lower end.
        once = (cols != rows) & (stable[cols] | (cols > rows))
        i, j = np.minimum(rows, cols)[once], np.maximum(rows, cols)[once]
        yield _screened(new_b, i, j)


def meets_box_reference(
    a: FloatArray, b: FloatArray, box: FloatArray | None
) -> BoolArray:
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


def facing_reference(new_b: Border, box: FloatArray) -> BoolArray:
    """Tell the vertices from which a segment may leave towards the box unscreened."""
    points = new_b.points
    wedges = new_b.wedges
    behind = wedges.narrow & (_outcodes(points, box) != 0)
    for cx, cy in ((0, 1), (2, 1), (0, 3), (2, 3)):
        dx, dy = box[cx] - points[:, 0], box[cy] - points[:, 1]
        tol = 2.0 * ANGLE_TOL * np.hypot(dx, dy)
        behind &= _into_wedge(wedges.nxt, wedges.prv, wedges.narrow, dx, dy, tol)
    return ~behind
