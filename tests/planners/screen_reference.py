"""The cold build's pair screen as numpy ran it before it was compiled.

:func:`planners.visibility._graphs._candidate_pairs` and ``_rows_against`` list the
vertex pairs a cold visibility graph tests, screened by the blocked wedges at both ends
(and, for the SVG, by tangency), with a compiled loop
(:func:`planners.kernels.screened_pairs`). These are the numpy versions they replaced,
kept verbatim but for the block size, a constant of their own here; tests hold the pairs
equal, in order.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import numpy.typing as npt

from planners.visibility._graphs import _not_tangent, _Wedges, leaves_blocked

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

_SCREEN_PAIRS = 1 << 14
"""Node pairs screened at once (a block of rows against the columns after them)."""


def candidate_pairs_reference(
    points: FloatArray, wedges: _Wedges, nodes: IntArray, *, tangent: bool
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield, block by block, the pairs of ``nodes`` that may see each other."""
    k = len(nodes)
    x, y = points[nodes, 0], points[nodes, 1]
    screen = _not_tangent if tangent else leaves_blocked
    r0 = 0
    while r0 < k - 1:
        r1 = min(k - 1, r0 + max(1, _SCREEN_PAIRS // (k - r0)))
        rows, cols = np.arange(r0, r1)[:, None], np.arange(r0 + 1, k)[None, :]
        dx, dy = x[cols] - x[rows], y[cols] - y[rows]
        out = screen(wedges, nodes[rows], nodes[cols], dx, dy)
        # Column c is node r0 + 1 + c: at or before row r only in the first r1 - r0.
        out[:, : r1 - r0] |= cols[:, : r1 - r0] <= rows
        r, c = np.nonzero(~out)
        yield nodes[r0 + r], nodes[r0 + 1 + c]
        r0 = r1


def rows_against_reference(
    points: FloatArray, wedges: _Wedges, rows: IntArray, cols: IntArray
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield the pairs (r, c), r in ``rows``, c in ``cols``, r < c, that pass the screen."""
    x, y = points[cols, 0], points[cols, 1]
    k = 0
    while k < len(rows):
        first = int(np.searchsorted(cols, rows[k], side="right"))
        width = max(len(cols) - first, 1)
        r1 = min(len(rows), k + max(1, _SCREEN_PAIRS // width))
        r = rows[k:r1, None]
        c = cols[None, first:]
        dx = x[None, first:] - points[r, 0]
        dy = y[None, first:] - points[r, 1]
        out = leaves_blocked(wedges, r, c, dx, dy) | (c <= r)
        a, b = np.nonzero(~out)
        yield rows[k + a], cols[first + b]
        k = r1
