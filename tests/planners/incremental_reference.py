"""The incremental VG's pair listing as numpy ran it before it was compiled (reference).

:func:`planners.incremental._crossing_box` lists the stable pairs whose segment meets
the changed box with a compiled loop (:func:`planners.kernels.box_pairs`). This is the
blockwise numpy listing it replaced, kept verbatim; a test holds the two equal.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import numpy.typing as npt

from planners.geometry import take_rows
from planners.incremental import _facing, _outcodes, _screened
from planners.visibility import _Border

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

_BLOCK = 1 << 20
"""Vertex pairs checked against the changed box at once."""


def crossing_box_reference(
    new_b: _Border, stable: BoolArray, box: FloatArray
) -> Iterator[tuple[IntArray, IntArray, BoolArray]]:
    """Yield, block by block, the screened stable pairs whose segment meets the box.

    Only vertices that face the box can be ends of such a pair (:func:`_facing`).
    """
    points = new_b.points
    nodes = np.flatnonzero(stable & _facing(new_b, box))
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
