"""Compiled loops: the grid march, the A* search, the incremental VG's pair listing.

Three computations of the visibility graphs (sections 9.4 and 9.5) are loops that numpy
can only run as many small array operations: the march of a segment through the cells
of the edge grid (a few cells per segment, a few edges per cell, a branch per edge),
the A* search (one node at a time), and, after an edit, the listing of the vertex pairs
whose segment meets the changed region (k^2 / 2 pairs, most ruled out at once). On the
scenes students build they took a third of an edit's time in numpy and Python (issue
15). numba compiles them here.

The rules that keep the compiled loops exactly the code they replace:

- the same floating-point operations in the same order on float64, no ``fastmath``
  (so no reassociation and no fused multiply-add): every sign test and every parameter
  t comes out bit for bit as the numpy expression gives it;
- tests hold each loop to the code it replaced, kept in the tests
  (``tests/planners/march_reference.py``, ``astar_reference.py``,
  ``incremental_reference.py``; and networkx's A*), on random and degenerate scenes,
  result for result;
- ``cache=True``: compiled once per machine (about 3 s per loop), then loaded from
  ``__pycache__`` (or numba's user cache where that is read-only) in a fraction of a
  second; ``nogil=True``: while a loop runs, the server's other threads run;
- no state: a dispatcher holds its machine code, nothing a call could leave behind;
- imported on first use by its callers: numba and LLVM take about 160 MB of resident
  memory, which only the processes that build graphs pay (the app's own process, a big
  scene's worker), not the workers of TangentBug and Bug2.

The functions here take and return plain arrays; :func:`planners.sightlines.march`,
:meth:`planners.visibility.GraphArrays.shortest_path` and
:func:`planners.incremental._crossing_box` wrap them.
"""

from __future__ import annotations

__all__ = ["astar", "box_pairs", "march_cells", "warm_up"]

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
    eps |u| and eps |v|. The arithmetic of :func:`planners.sightlines.crossings`.
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
        The edge grid (:class:`planners.sightlines.EdgeGrid`): lower-left corner (x, y),
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
        the segment and the parameter t in (0, 1) where it lies: one entry per cell the
        edge was met in, unsorted (the caller sorts and drops repeats).

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


# --------------------------------------------------------------------------- A*


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

    The arithmetic of :func:`planners.visibility._into_wedge`.
    """
    after_next = nxt[0] * dy - nxt[1] * dx > tol
    before_prev = dx * prv[1] - dy * prv[0] > tol
    return (after_next and before_prev) if narrow else (after_next or before_prev)


@njit(cache=True, nogil=True)
def _out_of_wedge(  # noqa: PLR0917
    nxt: FloatArray, prv: FloatArray, narrow: bool, dx: float, dy: float, tol: float
) -> bool:
    """Tell if (-dx, -dy) leaves a vertex by more than ``tol`` into its blocked wedge.

    The backward test of :func:`planners.visibility._into_wedge`.
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
    What :func:`planners.incremental._crossing_box` lists, without the k^2 arrays.
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
    first = np.array([0, 1, 2], dtype=np.intp)
    astar(first, np.array([1, 0], dtype=np.intp), unit, zero, 0, 1)
    points = np.array([[0.0, 0.0], [1.0, 1.0]])
    wedges = (np.zeros((2, 2)), np.zeros((2, 2)), np.ones(2, dtype=np.bool_))
    nodes = np.array([0, 1], dtype=np.intp)
    box = np.array([0.2, 0.2, 0.8, 0.8])
    box_pairs(points, nodes, np.zeros(2, dtype=np.uint8), box, wedges, 1e-12)
