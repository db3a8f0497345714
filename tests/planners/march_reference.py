"""The grid march as numpy walked it before it was compiled: the reference of the tests.

:func:`planners.visibility.sightlines.march` runs the same traversal compiled
(:func:`planners.kernels.march_cells`). This is the vectorised walk it replaced, kept
verbatim but for its last step, ordering the touching vertices, which both share
(:func:`planners.visibility.sightlines._unique_touches`): all segments of a block step through
their cells at once, and the last few walkers list their remaining cells in one go (a
superset, which the exact test makes harmless). The tests hold the two to equal
answers, and both to the brute force of testing every pair.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt

from planners.visibility.sightlines import (
    EdgeGrid,
    Edges,
    Marched,
    Segments,
    _all_inside,
    _cell_size,
    _edge_cells,
    _pairs_in_cells,
    _unique_touches,
    crossings,
)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


@dataclasses.dataclass
class _Walk:
    """The grid traversal state of the segments still walking (one entry each)."""

    seg: IntArray
    cell: IntArray  # ix * ny + iy
    step_x: IntArray  # change of cell to the next column: +-ny (or 0)
    step_y: IntArray  # ... to the next row: +-1 (or 0)
    next_x: FloatArray  # parameter t where the segment leaves the cell's column
    next_y: FloatArray  # ... and its row
    delta_x: FloatArray  # t to cross one column
    delta_y: FloatArray
    end: FloatArray  # t where the segment leaves the grid (or ends)
    enter: FloatArray  # t where the segment entered its current cell


_TAIL = 512
"""When no more segments than this still walk, each one's remaining cells are listed at
once: a step costs a few dozen numpy calls whatever its size, and the last walkers,
mostly long free segments, would take as many steps as they cross cells."""


def march_reference(
    grid: EdgeGrid,
    edges: Edges,
    segs: Segments,
    eps: float,
    block: int = 1 << 18,
    *,
    tail: int = _TAIL,
) -> Marched:
    """Test segments against the edges of the cells they pass through.

    A segment stops at the first cell where an edge properly crosses it; the others are
    tested against every edge within the grid's margin, so their touching vertices are
    complete. Segments are walked ``block`` at a time; once no more than ``tail`` of a
    block still walk, they are tested against all their remaining cells at once.
    """
    crossed = np.zeros(len(segs.ax), dtype=bool)
    touch_seg: list[IntArray] = []
    touch_t: list[FloatArray] = []
    for first in range(0, len(segs.ax), block):
        walk = _start_walk(
            grid, segs, np.arange(first, min(first + block, len(segs.ax)))
        )
        while len(walk.seg):
            rest = len(walk.seg) <= tail
            cells = (
                _rest_cells(grid, segs, walk, eps) if rest else _cells_now(grid, walk)
            )
            for seg, edge in _pairs_in_cells(grid, *cells):
                blocked, t_seg, t_val = crossings(segs, edges, seg, edge, eps)
                crossed[blocked] = True
                touch_seg.append(t_seg)
                touch_t.append(t_val)
            if rest:
                break
            walk = _step(grid, walk, crossed)
    seg_all = np.concatenate(touch_seg) if touch_seg else np.zeros(0, dtype=np.intp)
    t_all = np.concatenate(touch_t) if touch_t else np.zeros(0)
    keep = np.flatnonzero(~crossed[seg_all])
    seg_all, t_all = seg_all[keep], t_all[keep]
    return Marched(crossed, *_unique_touches(seg_all, t_all))


def _start_walk(grid: EdgeGrid, segs: Segments, seg: IntArray) -> _Walk:
    """Clip each segment to the grid and find its first cell (Amanatides and Woo)."""
    px, py, dx, dy = segs.ax[seg], segs.ay[seg], segs.dx[seg], segs.dy[seg]
    t0, t1 = np.zeros(len(seg)), np.ones(len(seg))
    if not _all_inside(grid, px, py, px + dx, py + dy):
        t0, t1 = _clip(grid, px, py, dx, dy)
    inside = np.flatnonzero(t0 <= t1)
    seg, t1 = seg[inside], t1[inside]
    px, py, dx, dy, t0 = (v[inside] for v in (px, py, dx, dy, t0))
    axes = []
    for p, d, low, count in (
        (px, dx, grid.lo[0], grid.nx),
        (py, dy, grid.lo[1], grid.ny),
    ):
        at = np.clip(np.floor((p + t0 * d - low) / grid.cell), 0, count - 1)
        step = np.sign(d).astype(np.intp)
        safe = np.where(d != 0, d, 1.0)
        border = low + (at + (step > 0)) * grid.cell
        # A component so small that the quotient overflows never reaches the next
        # border along its axis: infinity is the right answer, not a warning.
        with np.errstate(over="ignore"):
            nxt = np.where(d != 0, (border - p) / safe, np.inf)
            delta = np.where(d != 0, grid.cell / np.abs(safe), np.inf)
        axes.append((at.astype(np.intp), step, nxt, delta))
    (ix, sx, nx_, ddx), (iy, sy, ny_, ddy) = axes
    return _Walk(seg, ix * grid.ny + iy, sx * grid.ny, sy, nx_, ny_, ddx, ddy, t1, t0)


def _clip(
    grid: EdgeGrid, px: FloatArray, py: FloatArray, dx: FloatArray, dy: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Return the parameter range (t0, t1) of each segment inside the grid (Liang-Barsky).

    Empty (t0 > t1) for a segment that misses the grid.
    """
    lo, hi = grid.lo, grid.hi
    t0, t1 = np.zeros(len(px)), np.ones(len(px))
    for p, d, low, high in ((px, dx, lo[0], hi[0]), (py, dy, lo[1], hi[1])):
        # The parameter range inside the slab low <= p + t d <= high.
        safe = np.where(d != 0, d, 1.0)
        with np.errstate(over="ignore"):  # a subnormal direction: t is +-inf, as meant
            ta, tb = (low - p) / safe, (high - p) / safe
        enter = np.where(
            d != 0, np.minimum(ta, tb), np.where(p >= low, -np.inf, np.inf)
        )
        leave = np.where(
            d != 0, np.maximum(ta, tb), np.where(p <= high, np.inf, -np.inf)
        )
        t0, t1 = np.maximum(t0, enter), np.minimum(t1, leave)
    return t0, t1


def _cells_now(grid: EdgeGrid, walk: _Walk) -> tuple[IntArray, IntArray]:
    """(segment, cell) of each walking segment: the cell it is in."""
    return walk.seg, walk.cell


def _rest_cells(
    grid: EdgeGrid, segs: Segments, walk: _Walk, eps: float
) -> tuple[IntArray, IntArray]:
    """(segment, cell) for every cell each walking segment has still to cross.

    The part of the segment from where it entered its current cell to its end, listed
    as :func:`_edge_cells` lists an edge's cells (a superset of the cells the traversal
    would step through: testing more pairs finds nothing false, the test is exact).
    """
    seg = walk.seg
    px, py, dx, dy = segs.ax[seg], segs.ay[seg], segs.dx[seg], segs.dy[seg]
    a = np.column_stack([px + walk.enter * dx, py + walk.enter * dy])
    b = np.column_stack([px + walk.end * dx, py + walk.end * dy])
    k, ix, iy = _edge_cells(
        a, b, grid.lo, grid.cell, margin=eps, shape=(grid.nx, grid.ny)
    )
    return seg[k], ix * grid.ny + iy


def _step(grid: EdgeGrid, walk: _Walk, crossed: npt.NDArray[np.bool_]) -> _Walk:
    """Move every segment to its next cell; drop the blocked and the finished ones.

    ``t_next <= end`` keeps a segment in the grid; rounding may still step it out. Out
    through a side of the grid in x, its cell number leaves [0, nx ny) and it stops;
    out in y it lands in a cell of a neighbouring column, which it does not cross:
    testing more pairs finds nothing false (the test is exact), and its t is at its end
    within rounding, so it stops within a step or two.
    """
    along_x = walk.next_x < walk.next_y
    t_next = np.where(along_x, walk.next_x, walk.next_y)
    cell = walk.cell + np.where(along_x, walk.step_x, walk.step_y)
    next_x = np.where(along_x, walk.next_x + walk.delta_x, walk.next_x)
    next_y = np.where(along_x, walk.next_y, walk.next_y + walk.delta_y)
    go = (t_next <= walk.end) & ~crossed[walk.seg]
    go &= (cell >= 0) & (cell < grid.nx * grid.ny)
    keep = np.flatnonzero(go)
    return _Walk(
        walk.seg[keep],
        cell[keep],
        walk.step_x[keep],
        walk.step_y[keep],
        next_x[keep],
        next_y[keep],
        walk.delta_x[keep],
        walk.delta_y[keep],
        walk.end[keep],
        t_next[keep],
    )


def edge_grid_reference(a: FloatArray, b: FloatArray, margin: float) -> EdgeGrid:
    """The edge grid as numpy bucketed it before the compiled loop: every (edge, cell)
    of :func:`_edge_cells`, sorted stably by cell."""
    points = np.vstack([a, b])
    lo = points.min(axis=0) - 2.0 * margin
    size = np.maximum(points.max(axis=0) + 2.0 * margin - lo, margin)
    cell = _cell_size(size, np.hypot(*(b - a).T), len(a))
    nx, ny = (int(k) for k in np.maximum(np.ceil(size / cell), 1).astype(np.int64))
    edge, ix, iy = _edge_cells(a, b, lo, cell, margin=margin, shape=(nx, ny))
    key = ix * ny + iy
    order = np.argsort(key, kind="stable")
    counts = np.bincount(key, minlength=nx * ny)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.intp)
    return EdgeGrid(lo, cell, nx, ny, offsets, edge[order])
