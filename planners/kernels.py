"""Compiled loops: the grid march, the A* search, an edit's pair listings, the sweep.

Three computations of the visibility graphs (sections 9.4 and 9.5) are loops that numpy
can only run as many small array operations: the march of a segment through the cells
of the edge grid (a few cells per segment, a few edges per cell, a branch per edge),
the A* search (one node at a time), and, after an edit, the listing of the vertex pairs
whose segment meets the changed region (k^2 / 2 pairs, most ruled out at once). On the
scenes students build they took a third of an edit's time in numpy and Python.
The fourth is the range sensor's angular sweep (section 9.6): a few dozen critical
angles, a ray through each interval against each facing edge, which Python ran float by
float; TangentBug senses at every probe of a decision, and the sweep was half of its
time. Smaller passes, each a dozen array operations in numpy on a few hundred to a few
thousand rows, add up over an edit: bucketing the border's edges in the grid, listing a
graph's neighbours in compressed rows (a counting sort), and in the incremental VG the
pairs an edit carries over, the changed vertices' screened rows, which segments meet the
changed box and which vertices face it; and the SVG's tangent test over the VG's
visible pairs. A cold build of a big scene (an occupancy map: ten thousand vertices, 45
million pairs) lists the pairs that pass the wedge screen and looks each up in the
disks' cover table, a few operations per pair that numpy ran through n^2 temporaries.
numba compiles them here.

The rules that keep the compiled loops exactly the code they replace:

- the same floating-point operations in the same order on float64, no ``fastmath``
  (so no reassociation and no fused multiply-add): every sign test and every parameter
  t comes out bit for bit as the numpy expression gives it; the sweep's angles come from
  the C library's ``atan2``, ``cos`` and ``sin``, as its reference's do. The one
  exception is the disks' cover, only a filter before the exact test: its angles come
  from the C library too, where numpy has an ``arctan2`` of its own that can differ in the
  last bit, so a direction within rounding of a sector's side may fall in either sector
  (tests hold it to numpy's everywhere else); a rough polynomial atan2 decides the
  sector unless the direction is within ``ATAN_ERROR`` of a side;
- tests hold each loop to the code it replaced, kept in the tests
  (``tests/planners/march_reference.py``, ``astar_reference.py``,
  ``incremental_reference.py``, ``screen_reference.py``, ``cover_reference.py``,
  ``sweep_reference.py``; and networkx's A*), on random
  and degenerate scenes, result for result;
- ``cache=True``: compiled once per machine (about 20 s for all of them), then loaded
  from ``__pycache__`` (or numba's user cache where that is read-only) in a fraction of
  a second; ``nogil=True``: while a loop runs, the server's other threads run;
- no state: a dispatcher holds its machine code, nothing a call could leave behind;
- imported on first use by its callers: numba and LLVM take about 160 MB of resident
  memory, which only the processes that build graphs or run TangentBug pay, not one
  that only imports the planners, checks a scenario or runs Bug2.

The functions here take and return plain arrays; :func:`planners.visibility.sightlines.march`,
:func:`planners.visibility.sightlines.edge_grid`,
:meth:`planners.visibility.GraphArrays.shortest_path` (and ``_adjacency``),
:func:`planners.visibility.incremental._crossing_box`, ``_pairs_to_test``, ``_kept_pairs``,
``_meets_box`` and ``_facing``, :func:`planners.visibility._graphs._tangents_of_known`,
``_candidate_pairs`` and ``_rows_against``, :func:`planners.visibility.sightlines.cover_table`
and ``occluded_pairs``, and :func:`planners.bug.sensor._sweep` wrap them.
"""

from __future__ import annotations

__all__ = [
    "astar",
    "box_pairs",
    "bucket_edges",
    "compressed_rows",
    "cover_sectors",
    "facing",
    "kept_pairs",
    "march_cells",
    "occluded_by_cover",
    "row_pairs",
    "screened_pairs",
    "segments_meet_box",
    "sweep_intervals",
    "tangent_pairs",
    "warm_up",
]

import math

import numpy as np
import numpy.typing as npt
from numba import njit

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

# Compiled functions take their arguments by position (numba has no keyword-only
# parameters), hence the noqa: PLR0917 on the longer ones.

# --------------------------------------------------------------------------- the march


@njit(cache=True, nogil=True)
def _clip(p: float, d: float, low: float, high: float) -> tuple[float, float]:
    """Return the parameter range (enter, leave) of p + t d inside the slab [low, high]."""
    if d != 0:
        ta, tb = (low - p) / d, (high - p) / d
        return min(ta, tb), max(ta, tb)
    enter = -np.inf if p >= low else np.inf
    leave = np.inf if p <= high else -np.inf
    return enter, leave


@njit(cache=True, nogil=True)
def _axis_start(  # noqa: PLR0917
    p: float, d: float, t0: float, low: float, cell: float, count: int
) -> tuple[int, int, float, float]:
    """On one axis: the first cell, its step, where it is left (t) and t per cell."""
    at = min(max(math.floor((p + t0 * d - low) / cell), 0.0), count - 1.0)
    if d == 0:
        return int(at), 0, np.inf, np.inf
    step = 1 if d > 0 else -1
    border = low + (at + (1.0 if step > 0 else 0.0)) * cell
    return int(at), step, (border - p) / d, cell / abs(d)


@njit(cache=True, nogil=True)
def _crosses(  # noqa: PLR0917
    oc: float,
    w: float,
    tol_pq: float,
    cpx: float,
    cpy: float,
    vx: float,
    vy: float,
    tol_cd: float,
) -> bool:
    """Tell whether the edge c -> c + v properly crosses the segment p -> p + u.

    ``oc`` is u x (c - p) and ``w`` is u x v; ``cpx, cpy`` is c - p; the tolerances are
    eps |u| and eps |v|. The arithmetic of :func:`planners.visibility.sightlines.crossings`.
    """
    od = oc + w
    if not (max(oc, od) > tol_pq and min(oc, od) < -tol_pq):
        return False
    op = cpx * vy - cpy * vx
    oq = op - w
    return (op > tol_cd and oq < -tol_cd) or (op < -tol_cd and oq > tol_cd)


@njit(cache=True, nogil=True)
def _grow_int(values: IntArray, count: int) -> IntArray:
    """Return ``values`` with twice the room, its first ``count`` entries kept."""
    more = np.empty(2 * len(values), dtype=np.intp)
    more[:count] = values[:count]
    return more


@njit(cache=True, nogil=True)
def _grow_float(values: FloatArray, count: int) -> FloatArray:
    """Return ``values`` with twice the room, its first ``count`` entries kept."""
    more = np.empty(2 * len(values), dtype=np.float64)
    more[:count] = values[:count]
    return more


@njit(cache=True, nogil=True)
def march_cells(  # noqa: PLR0912, PLR0915, PLR0917
    grid_lo: tuple[float, float],
    cell: float,
    shape: tuple[int, int],
    offsets: IntArray,
    grid_edges: IntArray,
    edges: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    segs: tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray],
    eps: float,
    clip: bool,
) -> tuple[BoolArray, IntArray, FloatArray]:
    """Walk each segment through the grid's cells; test it against each cell's edges.

    Parameters
    ----------
    grid_lo, cell, shape, offsets, grid_edges
        The edge grid (:class:`planners.visibility.sightlines.EdgeGrid`): lower-left corner (x, y),
        side of a cell, (nx, ny), and cell c = ix ny + iy listing
        ``grid_edges[offsets[c]:offsets[c + 1]]``.
    edges
        (ex, ey, edx, edy, length) of the border edges, 1-D arrays each.
    segs
        (ax, ay, dx, dy, length) of the segments, 1-D arrays each.
    eps
        Within ``eps`` of a line counts as on it.
    clip
        Whether some segment reaches outside the grid (then each is clipped to it).

    Returns
    -------
    crossed : bool array
        Per segment, whether some edge properly crosses it (its walk stops in that
        cell).
    touch_seg, touch_t : arrays
        For each border vertex (an edge's start) lying inside a segment no edge crosses,
        the segment and the parameter t in (0, 1) where it lies: one entry per edge
        that starts there, unsorted (the caller sorts and drops repeats: where two
        rings share a vertex, two edges start there).

    Notes
    -----
    The traversal of Amanatides and Woo (ties go to y; a step outside the grid ends
    the walk), with the arithmetic of the vectorised walk it replaced for each
    (segment, edge) pair. That walk listed the last few walkers' remaining cells at
    once (a superset of the cells) and clipped per block: the cells visited may differ,
    the answers do not (the tests hold them equal).
    """
    ex, ey, edx, edy, elen = edges
    ax, ay, dx, dy, slen = segs
    nx, ny = shape
    lo_x, lo_y = grid_lo
    hi_x, hi_y = lo_x + cell * nx, lo_y + cell * ny
    crossed = np.zeros(len(ax), dtype=np.bool_)
    # The segment that last tested each edge: an edge listed in several cells of one
    # walk is tested once (the same test gives the same answer: not crossed, else the
    # walk had stopped; its touching vertex is listed once).
    tested_by = np.full(len(ex), -1, dtype=np.intp)
    touch_seg = np.empty(256, dtype=np.intp)
    touch_t = np.empty(256, dtype=np.float64)
    count = 0
    for s in range(len(ax)):
        px, py, ux, uy, length = ax[s], ay[s], dx[s], dy[s], slen[s]
        t0, t1 = 0.0, 1.0
        if clip:
            enter_x, leave_x = _clip(px, ux, lo_x, hi_x)
            enter_y, leave_y = _clip(py, uy, lo_y, hi_y)
            t0 = max(t0, enter_x, enter_y)
            t1 = min(t1, leave_x, leave_y)
            if not t0 <= t1:
                continue  # the segment misses the grid
        ix, sx, next_x, delta_x = _axis_start(px, ux, t0, lo_x, cell, nx)
        iy, sy, next_y, delta_y = _axis_start(py, uy, t0, lo_y, cell, ny)
        c = ix * ny + iy
        tol_pq = eps * length
        square = length * length if length > 0 else 1.0
        first = count
        while True:
            hit = False
            for k in range(offsets[c], offsets[c + 1]):
                e = int(grid_edges[k])
                if tested_by[e] == s:
                    continue
                tested_by[e] = s
                vx, vy = edx[e], edy[e]
                cpx, cpy = ex[e] - px, ey[e] - py
                oc = ux * cpy - uy * cpx
                w = ux * vy - uy * vx
                if _crosses(oc, w, tol_pq, cpx, cpy, vx, vy, eps * elen[e]):
                    hit = True
                if abs(oc) <= tol_pq:
                    t = (cpx * ux + cpy * uy) / square
                    along = t * length
                    if along > eps and along < length - eps:
                        if count == len(touch_seg):
                            touch_seg = _grow_int(touch_seg, count)
                            touch_t = _grow_float(touch_t, count)
                        touch_seg[count], touch_t[count] = s, t
                        count += 1
            if hit:
                crossed[s] = True
                count = first  # a crossed segment's touching vertices do not matter
                break
            if next_x < next_y:
                t_next, c, next_x = next_x, c + sx * ny, next_x + delta_x
            else:
                t_next, c, next_y = next_y, c + sy, next_y + delta_y
            if not (t_next <= t1 and 0 <= c < nx * ny):
                break
    return crossed, touch_seg[:count], touch_t[:count]


@njit(cache=True, nogil=True)
def _cell_index(value: float, count: int) -> int:
    """np.clip(np.floor(value), 0, count - 1) as an int: a coordinate's cell."""
    k = np.floor(value)
    return int(min(max(k, 0.0), count - 1.0))


@njit(cache=True, nogil=True)
def _edge_rows(  # noqa: PLR0917
    a: FloatArray, b: FloatArray, k: int, ix: int, grid: FloatArray, ny: int
) -> tuple[int, int]:
    """Return the rows of column ``ix`` that edge k's cells span (:func:`bucket_edges`)."""
    lo_x, lo_y, cell, margin = grid[0], grid[1], grid[2], grid[3]
    ax, ay, bx, by = a[k, 0], a[k, 1], b[k, 0], b[k, 1]
    left = max(lo_x + ix * cell - margin, min(ax, bx))
    right = min(lo_x + (ix + 1) * cell + margin, max(ax, bx))
    dx = bx - ax
    t0, t1 = 0.0, 1.0
    if dx != 0:
        t0 = min(max((left - ax) / dx, 0.0), 1.0)
        t1 = min(max((right - ax) / dx, 0.0), 1.0)
    dy = by - ay
    y0 = ay + min(t0, t1) * dy
    y1 = ay + max(t0, t1) * dy
    r0 = _cell_index((min(y0, y1) - margin - lo_y) / cell, ny)
    r1 = _cell_index((max(y0, y1) + margin - lo_y) / cell, ny)
    return r0, r1


@njit(cache=True, nogil=True)
def bucket_edges(
    a: FloatArray, b: FloatArray, grid: FloatArray, nx: int, ny: int
) -> tuple[IntArray, IntArray]:
    """List the edges a[k] -> b[k] cell by cell: the edge grid's compressed rows.

    ``grid`` is (lo_x, lo_y, cell, margin). Edge k is listed in every cell
    ``ix * ny + iy`` that :func:`planners.visibility.sightlines._edge_cells` gives it (its columns
    widened by the margin, in each its y range over the column widened by the margin),
    by the same float operations; within a cell, the edges ascend. Two passes: count
    per cell, then fill.
    """
    lo_x, cell, margin = grid[0], grid[2], grid[3]
    counts = np.zeros(nx * ny + 1, dtype=np.intp)
    at = np.zeros(0, dtype=np.intp)
    edges = np.zeros(0, dtype=np.intp)
    for phase in range(2):
        if phase == 1:
            for c in range(nx * ny):
                counts[c + 1] += counts[c]
            at = counts[:-1].copy()
            edges = np.empty(counts[-1], dtype=np.intp)
        for k in range(len(a)):
            x0 = min(a[k, 0], b[k, 0]) - margin
            x1 = max(a[k, 0], b[k, 0]) + margin
            c0 = _cell_index((x0 - lo_x) / cell, nx)
            c1 = _cell_index((x1 - lo_x) / cell, nx)
            for ix in range(c0, c1 + 1):
                r0, r1 = _edge_rows(a, b, k, ix, grid, ny)
                for iy in range(r0, r1 + 1):
                    if phase == 0:
                        counts[ix * ny + iy + 1] += 1
                    else:
                        edges[at[ix * ny + iy]] = k
                        at[ix * ny + iy] += 1
    return counts, edges


# --------------------------------------------------------------------------- A*


@njit(cache=True, nogil=True)
def compressed_rows(
    i: IntArray, j: IntArray, weight: FloatArray, n: int
) -> tuple[IntArray, IntArray, FloatArray]:
    """List each node's neighbours of an undirected graph: compressed rows, by counting.

    The edge ends in the order (j, i) of every edge, then (i, j) of every edge, are
    placed row by row (a stable counting sort by the first end): node u's neighbours
    are ``other[first[u]:first[u + 1]]``, in the order the ends came, with their edge's
    length in ``weights``. It is the stable argsort by node of those ends, in one pass.
    """
    m = len(i)
    first = np.zeros(n + 1, dtype=np.intp)
    for k in range(m):
        first[j[k] + 1] += 1
        first[i[k] + 1] += 1
    for u in range(n):
        first[u + 1] += first[u]
    at = first[:n].copy()
    other = np.empty(2 * m, dtype=np.intp)
    weights = np.empty(2 * m)
    for k in range(m):
        u = j[k]
        other[at[u]], weights[at[u]] = i[k], weight[k]
        at[u] += 1
    for k in range(m):
        u = i[k]
        other[at[u]], weights[at[u]] = j[k], weight[k]
        at[u] += 1
    return first, other, weights


@njit(cache=True, nogil=True)
def _before(f: FloatArray, a: int, b: int) -> bool:
    """Tell whether heap entry a comes before entry b: by f, then by insertion order."""
    return f[a] < f[b] or (f[a] == f[b] and a < b)


@njit(cache=True, nogil=True)
def _push(heap: IntArray, size: int, f: FloatArray, entry: int) -> int:
    """Put ``entry`` in the binary heap ``heap[:size]``; return the new size."""
    k = size
    heap[k] = entry
    while k > 0:
        up = (k - 1) // 2
        if not _before(f, heap[k], heap[up]):
            break
        heap[k], heap[up] = heap[up], heap[k]
        k = up
    return size + 1


@njit(cache=True, nogil=True)
def _pop(heap: IntArray, size: int, f: FloatArray) -> tuple[int, int]:
    """Take the least entry from ``heap[:size]``; return it and the new size."""
    top = heap[0]
    size -= 1
    heap[0] = heap[size]
    k = 0
    while True:
        least, left, right = k, 2 * k + 1, 2 * k + 2
        if left < size and _before(f, heap[left], heap[least]):
            least = left
        if right < size and _before(f, heap[right], heap[least]):
            least = right
        if least == k:
            return top, size
        heap[k], heap[least] = heap[least], heap[k]
        k = least


@njit(cache=True, nogil=True)
def astar(  # noqa: PLR0915, PLR0917
    first: IntArray,
    other: IntArray,
    weight: FloatArray,
    heuristic: FloatArray,
    start: int,
    goal: int,
) -> tuple[IntArray, FloatArray, IntArray]:
    """Search from ``start`` to ``goal`` by A* on a graph in compressed rows.

    Node u's neighbours are ``other[first[u]:first[u + 1]]``, the edges' lengths in
    ``weight``; ``heuristic[u]`` is u's straight-line distance to the goal.

    Step by step :func:`networkx.astar_path`: entries (f = cost + h, insertion count,
    node, cost, parent) leave the queue least first (f, then the count, so no two tie
    and any heap gives the same order); a node is settled once (the start never again,
    another node again only by a way no longer than the one known); a neighbour is
    queued when its way is shorter than the one known.

    Returns
    -------
    settled : (k, 2) int array and (k,) float array
        (node, parent) and cost of each node settled, in order; parent -1 for the start;
        the goal last when reached.
    path : int array
        The nodes from start to goal, or empty when the goal is not reached.
    """
    n = len(first) - 1
    cap = 16 + 2 * len(other)  # queue entries: room for one per edge end at first
    f = np.empty(cap)
    cost_of = np.empty(cap)
    node_of = np.empty(cap, dtype=np.intp)
    parent_of = np.empty(cap, dtype=np.intp)
    heap = np.empty(cap, dtype=np.intp)
    known = np.full(n, np.inf)  # cost of the best way queued so far
    queued = np.zeros(n, dtype=np.bool_)
    explored = np.full(n, -2, dtype=np.intp)  # parent once settled (-1: the start)
    settled = np.empty((n + 1, 2), dtype=np.intp)
    settled_cost = np.empty(n + 1)
    done = 0
    f[0], cost_of[0], node_of[0], parent_of[0] = 0.0, 0.0, start, -1
    heap[0] = 0
    size, entries = 1, 1
    while size:
        entry, size = _pop(heap, size, f)
        node, cost, parent = node_of[entry], cost_of[entry], parent_of[entry]
        if done == len(settled):  # nodes settled again by shorter ways: more room
            settled = np.concatenate((settled, np.empty_like(settled)))
            settled_cost = np.concatenate((settled_cost, np.empty_like(settled_cost)))
        if node == goal:
            settled[done, 0], settled[done, 1], settled_cost[done] = node, parent, cost
            path = [node, parent]
            while path[-1] != start:
                path.append(explored[path[-1]])
            return settled[: done + 1], settled_cost[: done + 1], np.array(path[::-1])
        if explored[node] != -2:
            if explored[node] < 0:
                continue  # the start: never worth visiting again
            if known[node] < cost:
                continue  # a shorter way here is already known
        explored[node] = parent
        settled[done, 0], settled[done, 1], settled_cost[done] = node, parent, cost
        done += 1
        for k in range(first[node], first[node + 1]):
            nxt = other[k]
            new = cost + weight[k]
            if queued[nxt] and known[nxt] <= new:
                continue
            queued[nxt], known[nxt] = True, new
            if entries == cap:
                f, cost_of = _grow_float(f, entries), _grow_float(cost_of, entries)
                node_of = _grow_int(node_of, entries)
                parent_of = _grow_int(parent_of, entries)
                heap = _grow_int(heap, size)
                cap *= 2
            f[entries], cost_of[entries] = new + heuristic[nxt], new
            node_of[entries], parent_of[entries] = nxt, node
            size = _push(heap, size, f, entries)
            entries += 1
    return settled[:done], settled_cost[:done], np.empty(0, dtype=np.intp)


# --------------------------------------------------------------------------- pairs


@njit(cache=True, nogil=True)
def _into_wedge(  # noqa: PLR0917
    nxt: FloatArray, prv: FloatArray, narrow: bool, dx: float, dy: float, tol: float
) -> bool:
    """Tell if (dx, dy) leaves a vertex by more than ``tol`` into its blocked wedge.

    The arithmetic of :func:`planners.visibility._graphs._into_wedge`.
    """
    after_next = nxt[0] * dy - nxt[1] * dx > tol
    before_prev = dx * prv[1] - dy * prv[0] > tol
    return (after_next and before_prev) if narrow else (after_next or before_prev)


@njit(cache=True, nogil=True)
def _out_of_wedge(  # noqa: PLR0917
    nxt: FloatArray, prv: FloatArray, narrow: bool, dx: float, dy: float, tol: float
) -> bool:
    """Tell if (-dx, -dy) leaves a vertex by more than ``tol`` into its blocked wedge.

    The backward test of :func:`planners.visibility._graphs._into_wedge`.
    """
    after_next = nxt[0] * dy - nxt[1] * dx < -tol
    before_prev = dx * prv[1] - dy * prv[0] < -tol
    return (after_next and before_prev) if narrow else (after_next or before_prev)


@njit(cache=True, nogil=True)
def _line_misses_box(  # noqa: PLR0917
    ax: float, ay: float, dx: float, dy: float, box: FloatArray, scale: float
) -> bool:
    """Tell if all four corners of the box lie strictly on one side of a line.

    The line through (ax, ay) in direction (dx, dy); "strictly": farther than
    ``scale`` times |dx| + |dy| (the arithmetic of the numpy test it replaced,
    ``_line_meets_box`` in ``tests/planners/incremental_reference.py``). Corners
    closer than that count as on the line: a few more pairs are tested again, never
    fewer.
    """
    tol = (abs(dx) + abs(dy)) * scale
    above, below = True, True
    for cx, cy in (
        (box[0], box[1]),
        (box[2], box[1]),
        (box[0], box[3]),
        (box[2], box[3]),
    ):
        side = dx * (cy - ay) - dy * (cx - ax)
        above = above and side > tol
        below = below and side < -tol
    return above or below


@njit(cache=True, nogil=True)
def _meets_box(ax: float, ay: float, bx: float, by: float, box: FloatArray) -> bool:
    """Tell if the segment a -> b meets the closed box (x0, y0, x1, y1).

    Axis by axis, the parameters where the segment enters and leaves the slab (a
    direction of 0: inside for all t or for none), with the arithmetic of the numpy
    test it replaced (``meets_box_reference`` in
    ``tests/planners/incremental_reference.py``). The same answers wherever the
    parameters are numbers or +-inf; where both ends' parameters overflow on one axis
    (coordinates near 1e308), numpy's NaN said no and this says yes: the segment does
    meet the box there.
    """
    t0, t1 = 0.0, 1.0
    for axis in range(2):
        p, d = (ax, bx - ax) if axis == 0 else (ay, by - ay)
        # A direction of 0 inside the slab gives (-inf, inf), outside it an empty
        # range: within [0, 1] the same as numpy's (0, 1) and (inf, -inf).
        enter, leave = _clip(p, d, box[axis], box[axis + 2])
        t0, t1 = max(t0, enter), min(t1, leave)
    return t0 <= t1


@njit(cache=True, nogil=True)
def segments_meet_box(a: FloatArray, b: FloatArray, box: FloatArray) -> BoolArray:
    """Tell which segments a[k] -> b[k] meet the closed box (x0, y0, x1, y1)."""
    meets = np.empty(len(a), dtype=np.bool_)
    for k in range(len(a)):
        meets[k] = _meets_box(a[k, 0], a[k, 1], b[k, 0], b[k, 1], box)
    return meets


@njit(cache=True, nogil=True)
def facing(
    points: FloatArray,
    wedges: tuple[FloatArray, FloatArray, BoolArray],
    box: FloatArray,
    angle_tol: float,
) -> BoolArray:
    """Tell the vertices from which a segment may leave towards the box unscreened.

    Not facing: a vertex strictly beyond a side of the box whose wedge is narrower than
    pi and holds the direction to each corner by more than twice ``angle_tol`` times
    its length (:func:`planners.visibility.incremental._facing` says why).
    """
    nxt, prv, narrow = wedges
    out = np.empty(len(points), dtype=np.bool_)
    for k in range(len(points)):
        x, y = points[k, 0], points[k, 1]
        beyond = x < box[0] or x > box[2] or y < box[1] or y > box[3]
        behind = narrow[k] and beyond
        for cx, cy in ((0, 1), (2, 1), (0, 3), (2, 3)):
            if not behind:
                break
            dx, dy = box[cx] - x, box[cy] - y
            tol = 2.0 * angle_tol * math.hypot(dx, dy)
            behind = _into_wedge(nxt[k], prv[k], narrow[k], dx, dy, tol)
        out[k] = not behind
    return out


@njit(cache=True, nogil=True)
def kept_pairs(  # noqa: PLR0917
    to_new: IntArray,
    stable: BoolArray,
    i: IntArray,
    j: IntArray,
    points: FloatArray,
    box: FloatArray,
) -> tuple[IntArray, IntArray]:
    """Carry visible pairs over an edit: those of stable vertices clear of the box.

    Pair k (``i[k]``, ``j[k]``, old numbering) is kept, in the new numbering as
    (lower, higher), when both ends have a new vertex (``to_new`` >= 0), both are
    stable and, unless ``box`` is empty (nothing changed), the segment between them
    does not meet the box. The pairs keep their order.
    """
    out_i = np.empty(len(i), dtype=np.intp)
    out_j = np.empty(len(i), dtype=np.intp)
    count = 0
    for k in range(len(i)):
        u, v = to_new[i[k]], to_new[j[k]]
        if u < 0 or v < 0 or not (stable[u] and stable[v]):
            continue
        if len(box) and _meets_box(
            points[u, 0], points[u, 1], points[v, 0], points[v, 1], box
        ):
            continue
        out_i[count], out_j[count] = min(u, v), max(u, v)
        count += 1
    return out_i[:count], out_j[:count]


@njit(cache=True, nogil=True)
def box_pairs(  # noqa: PLR0917
    points: FloatArray,
    nodes: IntArray,
    code: npt.NDArray[np.uint8],
    box: FloatArray,
    wedges: tuple[FloatArray, FloatArray, BoolArray],
    angle_tol: float,
) -> tuple[IntArray, IntArray]:
    """Return the pairs of ``nodes`` whose segment meets the box and leaves no end blocked.

    Pairs (nodes[r], nodes[c]), r < c, in that order: both ends not beyond one side of
    the box (their Cohen-Sutherland ``code`` shares no bit), the line not missing the
    box, and the segment leaving neither end into its blocked wedge (``wedges``: the
    unit directions to the next and the previous ring vertex and whether the wedge is
    narrower than pi, per vertex; tolerance ``angle_tol`` times the segment's length).
    What :func:`planners.visibility.incremental._crossing_box` lists, without the k^2 arrays.
    """
    nxt, prv, narrow = wedges
    scale = 1e-9 * (1.0 + np.abs(box).max())
    out_i = np.empty(1024, dtype=np.intp)
    out_j = np.empty(1024, dtype=np.intp)
    count = 0
    for r in range(len(nodes)):
        i = int(nodes[r])
        ax, ay = points[i, 0], points[i, 1]
        for c in range(r + 1, len(nodes)):
            if code[r] & code[c]:
                continue  # both ends beyond one side of the box
            j = int(nodes[c])
            dx, dy = points[j, 0] - ax, points[j, 1] - ay
            if _line_misses_box(ax, ay, dx, dy, box, scale):
                continue
            tol = angle_tol * math.hypot(dx, dy)
            if _into_wedge(nxt[i], prv[i], narrow[i], dx, dy, tol) or _out_of_wedge(
                nxt[j], prv[j], narrow[j], dx, dy, tol
            ):
                continue  # screened: the segment leaves an end into its wedge
            if count == len(out_i):
                out_i, out_j = _grow_int(out_i, count), _grow_int(out_j, count)
            out_i[count], out_j[count] = i, j
            count += 1
    return out_i[:count], out_j[:count]


@njit(cache=True, nogil=True)
def _enters(  # noqa: PLR0917
    nx: float, ny: float, qx: float, qy: float, dx: float, dy: float, tol: float
) -> bool:
    """Tell if the line along (dx, dy) enters a narrow wedge (sides n, q) by more than tol.

    The arithmetic of one end of :func:`planners.visibility._graphs._not_tangent`.
    """
    a = nx * dy - ny * dx  # cross(nxt, d)
    b = dx * qy - dy * qx  # cross(d, prv)
    return (a > tol and b > tol) or (a < -tol and b < -tol)


@njit(cache=True, nogil=True)
def tangent_pairs(  # noqa: PLR0917
    i: IntArray,
    j: IntArray,
    candidate: BoolArray,
    points: FloatArray,
    wedges: tuple[FloatArray, FloatArray],
    angle_tol: float,
) -> tuple[IntArray, IntArray]:
    """Keep the pairs of candidates whose line is tangent at both ends (section 9.5).

    Pair k (``i[k]``, ``j[k]``) is kept, in order, when both ends are candidates and
    the line along ``points[j] - points[i]`` enters neither end's narrow wedge by more
    than ``angle_tol`` times its length (``wedges``: the unit directions to the next
    and the previous ring vertex; zero at start and goal). What
    :func:`planners.visibility._graphs._tangents_of_known` keeps of the VG's visible pairs.
    """
    nxt, prv = wedges
    out_i = np.empty(len(i), dtype=np.intp)
    out_j = np.empty(len(i), dtype=np.intp)
    count = 0
    for k in range(len(i)):
        u, v = i[k], j[k]
        if not (candidate[u] and candidate[v]):
            continue
        dx, dy = points[v, 0] - points[u, 0], points[v, 1] - points[u, 1]
        tol = angle_tol * math.hypot(dx, dy)
        if _enters(nxt[u, 0], nxt[u, 1], prv[u, 0], prv[u, 1], dx, dy, tol):
            continue
        if _enters(nxt[v, 0], nxt[v, 1], prv[v, 0], prv[v, 1], dx, dy, tol):
            continue
        out_i[count], out_j[count] = u, v
        count += 1
    return out_i[:count], out_j[:count]


@njit(cache=True, nogil=True)
def _beyond(c: float, bound: float, dx: float, dy: float, angle_tol: float) -> bool:
    """Tell if ``c > angle_tol * hypot(dx, dy)``, computing the hypot only near it.

    ``bound`` is a little above ``angle_tol * (|dx| + |dy|)``, which is at least the
    tolerance: a ``c`` above it, or not above 0, is decided without the hypot (a slow
    call, and most sines are far from the tolerance).
    """
    if c <= 0.0:
        return False
    if c > bound:
        return True
    return c > angle_tol * math.hypot(dx, dy)


@njit(cache=True, nogil=True)
def screened_pairs(  # noqa: PLR0917 - one loop over the pairs, kept whole
    rows: IntArray,
    cols: IntArray,
    points: FloatArray,
    wedges: tuple[FloatArray, FloatArray, BoolArray],
    angle_tol: float,
    tangent: bool,
) -> tuple[IntArray, IntArray]:
    """Return the pairs (r, c), r in ``rows``, c in ``cols``, r < c, that pass the screen.

    Both ascending; pairs in row-major order. A pair is screened out when the segment
    from r to c leaves either end into its blocked wedge (``wedges`` as for
    :func:`box_pairs`), or, with ``tangent``, when the line through them enters either
    end's narrow wedge (section 9.5). The decisions of
    :func:`planners.visibility._graphs.leaves_blocked` and ``_not_tangent``, without
    their n^2 temporaries: what a cold visibility graph lists before its sight tests.
    """
    nxt, prv, narrow = wedges
    slack = angle_tol * (1.0 + 1e-6)  # rounding of the sum and the product, and more
    out_i = np.empty(1024, dtype=np.intp)
    out_j = np.empty(1024, dtype=np.intp)
    count = 0
    for k in range(len(rows)):
        i = int(rows[k])
        ax, ay = points[i, 0], points[i, 1]
        n0, n1, p0, p1, thin = nxt[i, 0], nxt[i, 1], prv[i, 0], prv[i, 1], narrow[i]
        for c in range(np.searchsorted(cols, i, side="right"), len(cols)):
            j = int(cols[c])
            dx, dy = points[j, 0] - ax, points[j, 1] - ay
            bound = slack * (abs(dx) + abs(dy))
            a = n0 * dy - n1 * dx  # cross(nxt, d) at i
            b = dx * p1 - dy * p0  # cross(d, prv) at i
            fwd_a = _beyond(a, bound, dx, dy, angle_tol)
            fwd_b = _beyond(b, bound, dx, dy, angle_tol)
            if tangent or thin:
                blocked = fwd_a and fwd_b
            else:
                blocked = fwd_a or fwd_b
            if tangent and not blocked:  # the line's extension behind i
                blocked = _beyond(-a, bound, dx, dy, angle_tol) and _beyond(
                    -b, bound, dx, dy, angle_tol
                )
            if blocked:
                continue
            a = nxt[j, 0] * dy - nxt[j, 1] * dx
            b = dx * prv[j, 1] - dy * prv[j, 0]
            back_a = _beyond(-a, bound, dx, dy, angle_tol)
            back_b = _beyond(-b, bound, dx, dy, angle_tol)
            if tangent or narrow[j]:
                blocked = back_a and back_b
            else:
                blocked = back_a or back_b
            if tangent and not blocked:  # the line's extension beyond j
                blocked = _beyond(a, bound, dx, dy, angle_tol) and _beyond(
                    b, bound, dx, dy, angle_tol
                )
            if blocked:
                continue
            if count == len(out_i):
                out_i, out_j = _grow_int(out_i, count), _grow_int(out_j, count)
            out_i[count], out_j[count] = i, j
            count += 1
    return out_i[:count], out_j[:count]


@njit(cache=True, nogil=True)
def row_pairs(
    moved: IntArray,
    stable: BoolArray,
    points: FloatArray,
    wedges: tuple[FloatArray, FloatArray, BoolArray],
    angle_tol: float,
) -> tuple[IntArray, IntArray]:
    """Return the pairs of each vertex in ``moved`` with every vertex, less the screened.

    Row r of ``moved`` (ascending) against columns 0, 1, ..., n - 1, in that order: the
    pair (min, max) of the two, unless they are one vertex or the column is a moved
    vertex before the row's (a pair of two moved vertices comes once, from its lower
    end), or the segment from the lower to the higher end leaves an end into its
    blocked wedge (``wedges`` as for :func:`box_pairs`). What
    :func:`planners.visibility.incremental._pairs_to_test` tests again at the vertices an edit
    changed.
    """
    nxt, prv, narrow = wedges
    n = len(points)
    out_i = np.empty(1024, dtype=np.intp)
    out_j = np.empty(1024, dtype=np.intp)
    count = 0
    for k in range(len(moved)):
        r = int(moved[k])
        for c in range(n):
            if c == r or not (stable[c] or c > r):
                continue
            i, j = min(r, c), max(r, c)
            dx, dy = points[j, 0] - points[i, 0], points[j, 1] - points[i, 1]
            tol = angle_tol * math.hypot(dx, dy)
            if _into_wedge(nxt[i], prv[i], narrow[i], dx, dy, tol) or _out_of_wedge(
                nxt[j], prv[j], narrow[j], dx, dy, tol
            ):
                continue
            if count == len(out_i):
                out_i, out_j = _grow_int(out_i, count), _grow_int(out_j, count)
            out_i[count], out_j[count] = i, j
            count += 1
    return out_i[:count], out_j[:count]


# --------------------------------------------------------------------------- the disks' cover


@njit(cache=True, nogil=True)
def cover_sectors(
    centers: FloatArray, radii: FloatArray, sources: FloatArray, sectors: int
) -> FloatArray:
    """Per source and sector, the nearest distance to a disk whose cone holds the sector.

    Sector k of a source holds the directions at angles in [k w - pi, (k + 1) w - pi],
    w = 2 pi / ``sectors``; shape (len(sources), sectors), inf where no disk's cone
    holds the sector [m]. The arithmetic of
    :func:`planners.visibility.sightlines.cover_table`'s numpy version, disk by disk.
    """
    width = 2.0 * math.pi / sectors
    table = np.full((len(sources), sectors), np.inf)
    for s in range(len(sources)):
        for d in range(len(radii)):
            cx = centers[d, 0] - sources[s, 0]
            cy = centers[d, 1] - sources[s, 1]
            dist = math.hypot(cx, cy)
            if not dist > radii[d]:
                continue  # the source is inside the disk
            half = math.asin(min(radii[d] / max(dist, 1e-300), 1.0))
            mid = math.atan2(cy, cx) + math.pi  # in [0, 2 pi]
            # Sectors k with [k w, (k + 1) w] inside the cone (mid - half, mid + half).
            first = math.ceil((mid - half) / width)
            last = math.floor((mid + half) / width) - 1
            for k in range(first, last + 1):
                sector = k % sectors
                table[s, sector] = min(table[s, sector], dist)
    return table


ATAN_ERROR = 1e-5
"""A bound [rad] on the error of :func:`rough_atan2` (it is within 1.7e-6; a test sweeps
the circle), with room to spare: the sector of a direction farther than this from a
sector's side is the one the C library's atan2 gives."""


@njit(cache=True, nogil=True)
def rough_atan2(y: float, x: float) -> float:
    """Return atan2(y, x) within :data:`ATAN_ERROR`, a few times faster than the C library.

    The octant is reduced to an argument z in [0, 1] and atan z taken from a minimax
    polynomial in z^2 (Hastings' 11th-degree approximation).
    """
    ax, ay = abs(x), abs(y)
    if ax == 0.0 and ay == 0.0:
        return math.atan2(y, x)  # the signs of zeros decide
    z = min(ax, ay) / max(ax, ay)
    z2 = z * z
    r = z * (
        0.99997726
        + z2
        * (
            -0.33262347
            + z2
            * (0.19354346 + z2 * (-0.11643287 + z2 * (0.05265332 - 0.01172120 * z2)))
        )
    )
    if ay > ax:
        r = 0.5 * math.pi - r
    if x < 0.0:
        r = math.pi - r
    return math.copysign(r, y)  # the sign of a zero y too, as atan2 reads it


@njit(cache=True, nogil=True)
def _sector(dx: float, dy: float, width: float, sectors: int) -> int:
    """Return the sector of direction (dx, dy), as :func:`cover_sectors` numbers them.

    Exactly ``(atan2(dy, dx) + pi) // width`` with the C library's atan2; that is only
    computed for a direction within :data:`ATAN_ERROR` of a sector's side.
    """
    q = (rough_atan2(dy, dx) + math.pi) / width
    k = math.floor(q)
    margin = 2.0 * ATAN_ERROR / width
    if q - k < margin or k + 1 - q < margin:
        k = int((math.atan2(dy, dx) + math.pi) // width)
    return min(k, sectors - 1)


@njit(cache=True, nogil=True)
def _longer(dx: float, dy: float, squared: float, limit: float) -> bool:
    """Tell if ``hypot(dx, dy) > limit``, computing the hypot only near the limit.

    ``squared`` is ``dx * dx + dy * dy``; within rounding it is the square of the
    length, and far from ``limit`` squared it decides alone.
    """
    if limit == np.inf:
        return False
    if squared > (limit * (1.0 + 1e-9)) ** 2:
        return True
    if squared < (limit * (1.0 - 1e-9)) ** 2:
        return False
    return math.hypot(dx, dy) > limit


@njit(cache=True, nogil=True)
def occluded_by_cover(
    table: FloatArray, points: FloatArray, i: IntArray, j: IntArray
) -> BoolArray:
    """Tell which segments points[i] -> points[j] are longer than the cover either way.

    ``table`` is :func:`cover_sectors` of every point; from j the direction is reversed
    (half a turn of sectors on). The decisions of
    :func:`planners.visibility.sightlines.occluded_pairs`'s numpy version, with the C
    library's atan2 (which numpy's own can differ from in the last bit).
    """
    sectors: int = table.shape[1]
    width = 2.0 * math.pi / sectors
    blocked = np.zeros(len(i), dtype=np.bool_)
    for k in range(len(i)):
        a, b = i[k], j[k]
        dx = points[b, 0] - points[a, 0]
        dy = points[b, 1] - points[a, 1]
        sector = _sector(dx, dy, width, sectors)
        squared = dx * dx + dy * dy
        blocked[k] = _longer(dx, dy, squared, table[a, sector]) or _longer(
            dx, dy, squared, table[b, (sector + sectors // 2) % sectors]
        )
    return blocked


# --------------------------------------------------------------------------- the sensor's sweep

PIECE, FREE, BLOCKED = 0, 1, 2
"""Kinds of a sweep interval (:func:`sweep_intervals`): a visible piece of an edge, free
range, or the blocked wedge at the robot's feet."""
TAU = 2.0 * math.pi
ANGLE_TOL = 1e-12
"""Critical angles closer than this [rad] are always merged: what the interval between
them could show is below 1e-12 times the range, far under the touching tolerance."""


@njit(cache=True, nogil=True)
def _py_max(a: float, b: float) -> float:
    """Python's ``max(a, b)``: ``a`` unless ``b`` is greater."""
    return b if b > a else a


@njit(cache=True, nogil=True)
def _py_min(a: float, b: float) -> float:
    """Python's ``min(a, b)``: ``a`` unless ``b`` is smaller."""
    return b if b < a else a


@njit(cache=True, nogil=True)
def _disk_span(  # noqa: PLR0917
    ax: float, ay: float, dx: float, dy: float, len2: float, r2: float
) -> tuple[float, float]:
    """(t_in, t_out) of :func:`planners.bug.sensor.disk_span`, the same arithmetic."""
    qb = 2.0 * (ax * dx + ay * dy)
    qc = ax * ax + ay * ay - r2
    disc = qb * qb - 4.0 * len2 * qc
    root = math.sqrt(_py_max(disc, 0.0))
    t_in = _py_max(0.0, (-qb - root) / (2.0 * len2))
    t_out = _py_min(1.0, (-qb + root) / (2.0 * len2))
    return t_in, t_out


@njit(cache=True, nogil=True)
def _clip_to_disk(  # noqa: PLR0917
    ids: IntArray,
    a: FloatArray,
    cr: FloatArray,
    dist: FloatArray,
    step: FloatArray,
    lengths: tuple[FloatArray, FloatArray],
    radius: float,
    eps: float,
) -> tuple[FloatArray, IntArray]:
    """Clip the facing edges to the sensing disk; drop parts shorter than eps.

    Returns the parts as rows (ax, ay, dx, dy, cross, t_in, t_out, inx, iny, outx,
    outy, dist): the edge's start relative to the robot, its step, cross(a, d), the
    part's parameters and end points relative to the robot, the edge's distance; and
    each part's flat edge index.
    """
    len2, length = lengths
    finite = math.isfinite(radius)
    r2 = radius * radius
    parts = np.empty((len(ids), 12))
    edges = np.empty(len(ids), dtype=np.intp)
    m = 0
    for r in range(len(ids)):
        e = int(ids[r])
        ax, ay = a[r, 0], a[r, 1]
        dx, dy = step[e, 0], step[e, 1]
        t_in, t_out = 0.0, 1.0
        if finite:
            t_in, t_out = _disk_span(ax, ay, dx, dy, len2[e], r2)
            if not (t_out - t_in) * length[e] > eps:
                continue
        row = parts[m]
        row[0], row[1], row[2], row[3], row[4] = ax, ay, dx, dy, cr[r]
        row[5], row[6] = t_in, t_out
        row[7], row[8] = ax + t_in * dx, ay + t_in * dy
        row[9], row[10] = ax + t_out * dx, ay + t_out * dy
        row[11] = dist[r]
        edges[m] = e
        m += 1
    return parts[:m], edges[:m]


@njit(cache=True, nogil=True)
def _critical_angles(
    parts: FloatArray, wedges: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Return the critical angles in [0, 2 pi) and how far each one's point lies.

    Where each part begins, then where each ends, then each wedge's clockwise side, then
    its counter-clockwise side (a direction: NaN distance).
    """
    m, w = len(parts), len(wedges)
    theta = np.empty(2 * m + 2 * w)
    reach = np.full(2 * m + 2 * w, np.nan)
    for i in range(m):
        for k, col in ((i, 7), (m + i, 9)):
            px, py = parts[i, col], parts[i, col + 1]
            theta[k] = math.atan2(py, px) % TAU
            reach[k] = math.hypot(px, py)
    for i in range(w):
        theta[2 * m + i] = math.atan2(wedges[i, 1], wedges[i, 0]) % TAU
        theta[2 * m + w + i] = math.atan2(wedges[i, 3], wedges[i, 2]) % TAU
    return theta, reach


@njit(cache=True, nogil=True)
def _ccw_gaps(theta: FloatArray) -> FloatArray:
    """Return the gap from each sorted angle to the next counter-clockwise (last to first)."""
    n = len(theta)
    gap = np.empty(n)
    for i in range(n - 1):
        gap[i] = theta[i + 1] - theta[i]
    gap[n - 1] = theta[0] + TAU - theta[n - 1]
    return gap


@njit(cache=True, nogil=True)
def _rank(dist: FloatArray, i: int) -> float:
    """How far point i lies; a wedge's side (a direction) ranks first."""
    return np.inf if math.isnan(dist[i]) else dist[i]


@njit(cache=True, nogil=True)
def _merge_close_angles(
    theta: FloatArray, reach: FloatArray, nearest: float, eps: float
) -> FloatArray:
    """Sort the critical angles (in [0, 2 pi)) and merge those that are one up to eps.

    The robot touches the border within eps, and the wedges at its feet are drawn as if
    it stood exactly on the border: a wedge's side and the angle of a vertex on that
    side's line differ by up to eps / d, d the vertex's distance. Generally two critical
    angles are the same when the rays along them pass within eps of the points that
    define them, i.e. when they differ by at most eps / d for the farther point; the
    sliver between them would show nothing the tolerance can tell. A wedge's side (exact)
    absorbs every point that is the same as it; of each run of neighbouring points that
    are the same, the farthest point's angle (the most precise) is kept
    (:func:`_merge_runs`).

    ``reach`` gives the distance of the point that defines each angle, NaN for a wedge's
    side (a direction, no point); ``nearest`` is a lower bound of those distances: when
    no gap is within eps even at the nearest point, nothing more merges.

    Angles closer than :data:`ANGLE_TOL` are merged first, keeping the first of them
    (stable sort): mostly the two copies of a vertex that two edges share, where there
    is nothing to choose.
    """
    order = np.argsort(theta, kind="mergesort")
    theta = theta[order]
    n = len(theta)
    if n < 2:
        return theta
    gap = _ccw_gaps(theta)
    keep = np.empty(n, dtype=np.bool_)
    keep[0] = True
    for i in range(1, n):
        keep[i] = not gap[i - 1] <= ANGLE_TOL
    if gap[n - 1] <= ANGLE_TOL:
        keep[n - 1] = False
    widest = eps / nearest if nearest > 0 else np.inf
    close = False
    for i in range(n):
        close = close or (gap[i] <= widest and not gap[i] <= ANGLE_TOL)
    if not close:
        return theta[keep]
    theta, dist = theta[keep], reach[order[keep]]
    absorbed = np.zeros(len(theta), dtype=np.bool_)
    for s in range(len(theta)):
        if math.isnan(dist[s]):  # a wedge's side absorbs the points it passes by
            for i in range(len(theta)):
                off = abs((theta[i] - theta[s] + math.pi) % TAU - math.pi)
                absorbed[i] = absorbed[i] or off * dist[i] <= eps
    theta, dist = theta[~absorbed], dist[~absorbed]
    return _merge_runs(theta, dist, eps)


@njit(cache=True, nogil=True)
def _merge_runs(  # noqa: PLR0912 - one pass over the runs, kept whole
    theta: FloatArray, dist: FloatArray, eps: float
) -> FloatArray:
    """Merge runs of neighbouring angles whose rays pass within eps at the farther point."""
    n = len(theta)
    if n < 2:
        return theta
    gap = _ccw_gaps(theta)
    pairs = np.empty(n, dtype=np.intp)
    count = 0
    for i in range(n):
        # np.fmax: NaN (a wedge's side) gives way. (A point within eps of a side's ray
        # was absorbed by it above, so no pair with a side merges either way.)
        a, b = dist[i], dist[(i + 1) % n]
        far = b if math.isnan(a) else (a if math.isnan(b) else max(a, b))
        if gap[i] * far <= eps:
            pairs[count] = i
            count += 1
    if count == 0:
        return theta
    if count == n:
        best = 0
        for i in range(1, n):
            if _rank(dist, i) > _rank(dist, best):
                best = i
        return theta[best : best + 1]
    first = 0  # start at a run that does not go on across angle 0
    if pairs[0] == 0 and pairs[count - 1] == n - 1:
        first = 1
        while pairs[first] == pairs[first - 1] + 1:
            first += 1
    keep = np.ones(n, dtype=np.bool_)
    end = best = -1
    for k in range(count):
        i = pairs[(first + k) % count]
        if i != end:  # a new run
            best = i
        end = (i + 1) % n
        if _rank(dist, end) > _rank(dist, best):  # keep the first of equals
            keep[best] = False
            best = end
        else:
            keep[end] = False
    return theta[keep]


@njit(cache=True, nogil=True)
def _in_wedge(wedges: FloatArray, ux: float, uy: float) -> bool:
    """Whether (ux, uy) points strictly into a blocked wedge (rows nx, ny, qx, qy)."""
    for k in range(len(wedges)):
        nx, ny, qx, qy = wedges[k, 0], wedges[k, 1], wedges[k, 2], wedges[k, 3]
        if nx * qy - ny * qx > 0:  # narrower than a half turn
            if nx * uy - ny * ux > 0 and ux * qy - uy * qx > 0:
                return True
        elif not (qx * uy - qy * ux >= 0 and ux * ny - uy * nx >= 0):
            return True
    return False


@njit(cache=True, nogil=True)
def _first_hit(parts: FloatArray, ux: float, uy: float) -> int:
    """Return the part a ray from the robot along (ux, uy) meets first (-1: none).

    Among the parts whose angular span holds the ray strictly, the least distance
    cross / (u x d); the first of equals.
    """
    hit, best = -1, np.inf
    for i in range(len(parts)):
        dx, dy, cr = parts[i, 2], parts[i, 3], parts[i, 4]
        inx, iny, outx, outy = parts[i, 7], parts[i, 8], parts[i, 9], parts[i, 10]
        if outx * uy - outy * ux > 0 and ux * iny - uy * inx > 0:
            denom = ux * dy - uy * dx
            s = cr / denom if denom != 0 else np.inf
            if 0 < s < best:
                hit, best = i, s
    return hit


@njit(cache=True, nogil=True)
def _t_at(angle: float, part: FloatArray, eps: float) -> float:
    """Return the parameter along a part's edge where the ray at ``angle`` meets it.

    Snapped to the nearer end of the part when the ray passes within eps of it (the
    sweep's angles come from those very end points, or were merged with them).
    """
    ax, ay, dx, dy = part[0], part[1], part[2], part[3]
    t_in, t_out = part[5], part[6]
    ux, uy = math.cos(angle), math.sin(angle)
    denom = ux * dy - uy * dx
    t = (ax * uy - ay * ux) / denom if denom != 0 else t_in
    t = _py_min(_py_max(t, t_in), t_out)
    end = t_in if t - t_in <= t_out - t else t_out
    px, py = ax + end * dx, ay + end * dy
    return end if abs(ux * py - uy * px) <= eps else t


@njit(cache=True, nogil=True)
def _cast_rays(
    lo: FloatArray, parts: FloatArray, wedges: FloatArray
) -> tuple[IntArray, IntArray, FloatArray]:
    """One ray through the middle of each interval: what it sees, alike ones joined.

    Returns each interval's kind, part (-1: none) and (lo, hi) angles; the first and
    last are joined across angle 0 when they are alike.
    """
    n = len(lo)
    kinds = np.empty(n, dtype=np.intp)
    part = np.empty(n, dtype=np.intp)
    span = np.empty((n, 2))
    count = 0
    for j in range(n):
        hi = lo[j + 1] if j + 1 < n else lo[0] + TAU
        mid = 0.5 * (lo[j] + hi)
        ux, uy = math.cos(mid), math.sin(mid)
        if len(wedges) > 0 and _in_wedge(wedges, ux, uy):
            kind, p = BLOCKED, -1
        else:
            p = _first_hit(parts, ux, uy)
            kind = PIECE if p >= 0 else FREE
        if count > 0 and kinds[count - 1] == kind and part[count - 1] == p:
            span[count - 1, 1] = hi
        else:
            kinds[count], part[count] = kind, p
            span[count, 0], span[count, 1] = lo[j], hi
            count += 1
    first = 0
    if count > 1 and kinds[0] == kinds[count - 1] and part[0] == part[count - 1]:
        span[count - 1, 1] = span[0, 1] + TAU
        first = 1
    return kinds[first:count], part[first:count], span[first:count]


@njit(cache=True, nogil=True)
def sweep_intervals(  # noqa: PLR0917
    facing: tuple[IntArray, FloatArray, FloatArray, FloatArray],
    border: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
    wedges: FloatArray,
    robot: tuple[float, float],
    radius: float,
    eps: float,
) -> tuple[IntArray, IntArray, FloatArray]:
    """Cut the full turn at the critical angles and say what each interval sees.

    The middle of :func:`planners.bug.sensor._sweep` (section 9.6's range sensor): the
    facing edges clipped to the sensing disk, their end points' angles and the wedges'
    sides, merged where they are one up to eps, a ray through each interval, and the
    part of the edge it sees.

    Parameters
    ----------
    facing
        (flat edge indices, starts relative to the robot (k, 2), cross(a, d),
        distances) of the edges that face the robot within R.
    border
        (start, step, len2, length) of every border edge (:class:`RingGeometry`).
    wedges
        The blocked wedges at the robot's feet, rows (nx, ny, qx, qy): the unit
        directions of each wedge's clockwise and counter-clockwise side.
    robot
        Its position (x, y) [m].
    radius, eps
        R (``inf``: unlimited) and the touching tolerance [m].

    Returns
    -------
    tuple
        Per interval, counter-clockwise: its kind (:data:`PIECE`, :data:`FREE`,
        :data:`BLOCKED`), its flat edge (-1 unless a piece), and (lo, hi, t0, t1,
        p0x, p0y, p1x, p1y): its angles, the piece's parameters at its first and last
        point and those points [m] (for other kinds, 0 and the robot's position).
    """
    ids, a, cr, dist = facing
    start, step, len2, length = border
    parts, edges = _clip_to_disk(ids, a, cr, dist, step, (len2, length), radius, eps)
    theta, reach = _critical_angles(parts, wedges)
    if len(theta) == 0:
        return np.empty(0, dtype=np.intp), np.empty(0, dtype=np.intp), np.empty((0, 8))
    nearest = np.inf
    for i in range(len(parts)):
        nearest = _py_min(nearest, parts[i, 11])
    lo = _merge_close_angles(theta, reach, nearest, eps)
    kinds, part, span = _cast_rays(lo, parts, wedges)
    out = np.empty((len(kinds), 8))
    edge = np.full(len(kinds), -1, dtype=np.intp)
    for k in range(len(kinds)):
        row = out[k]
        row[0], row[1] = span[k, 0], span[k, 1]
        row[2], row[3] = 0.0, 0.0
        row[4], row[5], row[6], row[7] = robot[0], robot[1], robot[0], robot[1]
        if kinds[k] == PIECE:
            p = part[k]
            e = edges[p]
            t0 = _t_at(span[k, 0], parts[p], eps)
            t1 = _t_at(span[k, 1], parts[p], eps)
            dx, dy = parts[p, 2], parts[p, 3]
            row[2], row[3] = t0, t1
            row[4], row[5] = start[e, 0] + t0 * dx, start[e, 1] + t0 * dy
            row[6], row[7] = start[e, 0] + t1 * dx, start[e, 1] + t1 * dy
            edge[k] = e
    return kinds, edge, out


# --------------------------------------------------------------------------- warming up


def warm_up() -> None:
    """Compile (or load from the cache) every loop here, on a tiny input.

    The first call of a compiled loop in a process compiles it (about 3 s each, once per
    machine) or loads it from numba's cache (a fraction of a second). Calling this ahead
    -- ``make`` after installing, the app at start in a background thread -- keeps that
    wait out of the first edit.

    Examples
    --------
    >>> warm_up()
    """
    unit = np.array([1.0, 1.0])
    zero = np.zeros(2)
    edges = (np.zeros(1), np.zeros(1), np.ones(1), np.zeros(1), np.ones(1))
    segs = (np.full(2, 0.5), np.array([-1.0, 1.0]), np.zeros(2), unit, unit)
    offsets = np.array([0, 1], dtype=np.intp)
    one = np.zeros(1, dtype=np.intp)
    march_cells((-1.0, -2.0), 4.0, (1, 1), offsets, one, edges, segs, 1e-9, True)
    corners = np.array([[0.0, 0.0]])
    bucket_edges(corners, corners + 1.0, np.array([-1.0, -1.0, 4.0, 1e-9]), 1, 1)
    first, other, weight = compressed_rows(
        np.zeros(1, dtype=np.intp), np.ones(1, dtype=np.intp), unit[:1], 2
    )
    astar(first, other, weight, zero, 0, 1)
    points = np.array([[0.0, 0.0], [1.0, 1.0]])
    wedges = (np.zeros((2, 2)), np.zeros((2, 2)), np.ones(2, dtype=np.bool_))
    nodes = np.array([0, 1], dtype=np.intp)
    box = np.array([0.2, 0.2, 0.8, 0.8])
    box_pairs(points, nodes, np.zeros(2, dtype=np.uint8), box, wedges, 1e-12)
    kept_pairs(nodes, np.ones(2, dtype=np.bool_), one, one + 1, points, box)
    row_pairs(one, np.zeros(2, dtype=np.bool_), points, wedges, 1e-12)
    screened_pairs(nodes, nodes, points, wedges, 1e-12, False)
    table = cover_sectors(points, np.ones(2), points, 64)
    occluded_by_cover(table, points, nodes, nodes[::-1].copy())
    segments_meet_box(points, points[::-1].copy(), box)
    facing(points, wedges, box, 1e-12)
    tangent_pairs(one, one + 1, wedges[2], points, wedges[:2], 1e-12)
    # A unit square's left side, seen from (-1, 0.5) standing on nothing.
    start = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    step = np.roll(start, -1, axis=0) - start
    seen = (
        np.array([3], dtype=np.intp),
        start[3:] - (-1.0, 0.5),
        -unit[:1],
        unit[:1],
    )
    border = (start, step, np.ones(4), np.ones(4))
    sweep_intervals(seen, border, np.zeros((0, 4)), (-1.0, 0.5), 2.0, 1e-9)
