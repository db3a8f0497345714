"""Which segments the border of free space blocks, in memory linear in the answer.

The visibility graphs of sections 9.4 and 9.5 test up to n^2 / 2 segments against the m
edges of the border. Testing every (segment, edge) pair costs n^2 m; holding them, or an
n x n matrix, costs gigabytes at ten thousand vertices. This module does the same exact
test (module docstring of :mod:`planners.visibility`) with two devices:

Uniform grid of the edges (:class:`EdgeGrid`)
    The border's edges are bucketed in square cells (about one edge a cell), each edge
    in every cell that a disk of radius ``margin`` around it meets. A segment can only
    cross or touch the edges listed in the cells it passes through.
Marching segments (:func:`march`)
    Each segment walks its cells from its start to its end, one cell a step (the grid
    traversal of Amanatides and Woo, compiled in :mod:`planners.kernels`): at each step
    it is tested against the edges of its current cell, and a segment that an edge
    crosses stops. Most blocked segments stop in their first cells, so the work is
    about the cells a segment crosses before it is blocked, not the whole border; a
    free segment is tested against every edge near it, which is all the exact test
    needs.

Disks that certainly block (:func:`occluded`, :func:`cover_table`, :func:`occluded_pairs`)
    Before marching in a cold build, a segment that passes through a disk inside an
    obstacle is blocked for certain; only the others are marched. Around each start a
    table keeps, per angular sector, the nearest disk that covers it; the full
    visibility graph builds it for every vertex and looks each pair up from both ends.
    A filter: it never decides a free one.

The march keeps only the touching points of the survivors, so its memory is the answer.
Where pairs are listed as arrays (:func:`near_pairs`), they are tested in slices of
``_PAIRS_AT_ONCE``: arrays of 128 KiB and more come from fresh pages, a page fault
every 4 KiB, which cost a fifth of a cold visibility graph of 300 vertices.

References
----------
J. Amanatides and A. Woo, "A fast voxel traversal algorithm for ray tracing",
Eurographics 1987.
"""

from __future__ import annotations

__all__ = [
    "Disks",
    "EdgeGrid",
    "Edges",
    "Marched",
    "Segments",
    "cover_table",
    "crossings",
    "edge_grid",
    "inner_disks",
    "march",
    "near_pairs",
    "occluded",
    "occluded_pairs",
    "sector_count",
]

import dataclasses
import functools
import itertools
import math
from collections.abc import Iterator, Sequence

import numpy as np
import numpy.typing as npt
import shapely
from shapely import Polygon

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

_EDGES_PER_CELL = 1.0
"""Cell size: about this many edges a cell if they were spread evenly."""
_MAX_CELLS_PER_EDGE = 4
"""At most this many cells per edge in the grid (bounds its memory)."""
_PAIRS_AT_ONCE = 1 << 13
"""(segment, edge) pairs tested at once: each temporary array stays under 128 KiB, which
the allocator hands out again from its heap instead of fresh (zeroed) pages."""


@dataclasses.dataclass(frozen=True, eq=False)
class Edges:
    """Border edges as 1-D coordinate arrays: start (ex, ey), direction (edx, edy)."""

    ex: FloatArray
    ey: FloatArray
    edx: FloatArray
    edy: FloatArray

    @classmethod
    def of(cls, a: FloatArray, b: FloatArray) -> Edges:
        """Make the arrays of edges a[k] -> b[k], shape (m, 2) each [m]."""
        return cls(
            np.ascontiguousarray(a[:, 0]),
            np.ascontiguousarray(a[:, 1]),
            np.ascontiguousarray(b[:, 0] - a[:, 0]),
            np.ascontiguousarray(b[:, 1] - a[:, 1]),
        )

    @functools.cached_property
    def length(self) -> FloatArray:
        """Edge lengths, shape (m,) [m]."""
        return np.hypot(self.edx, self.edy)


@dataclasses.dataclass(frozen=True, eq=False)
class Segments:
    """Segments as 1-D coordinate arrays (start, direction, length)."""

    ax: FloatArray
    ay: FloatArray
    dx: FloatArray
    dy: FloatArray
    length: FloatArray

    @classmethod
    def of(cls, a: FloatArray, b: FloatArray) -> Segments:
        """Make the arrays of segments a[k] -> b[k], shape (S, 2) each [m]."""
        d = b - a
        dx, dy = np.ascontiguousarray(d[:, 0]), np.ascontiguousarray(d[:, 1])
        return cls(
            np.ascontiguousarray(a[:, 0]),
            np.ascontiguousarray(a[:, 1]),
            dx,
            dy,
            np.hypot(dx, dy),
        )


def crossings(
    segs: Segments, edges: Edges, seg: IntArray, edge: IntArray, eps: float
) -> tuple[IntArray, IntArray, FloatArray]:
    """Proper crossings and touching vertices for (segment, edge) index pairs.

    Returns the segments of the pairs where the edge properly crosses the segment, and
    for each border vertex (the edge's start) lying inside a segment: the segment and
    the parameter t in (0, 1) where it lies. Within ``eps`` of a line counts as on it.
    """
    # Plain 1-D arrays: gathers and arithmetic on them are several times faster than on
    # (N, 2) rows, and this runs over millions of pairs on large scenes.
    px, py = segs.ax[seg], segs.ay[seg]
    ux, uy, len_pq = segs.dx[seg], segs.dy[seg], segs.length[seg]
    vx, vy = edges.edx[edge], edges.edy[edge]
    cpx, cpy = edges.ex[edge] - px, edges.ey[edge] - py
    oc = ux * cpy - uy * cpx  # side of c from the line p -> q, times |pq|
    w = ux * vy - uy * vx
    od = oc + w  # side of d
    tol_pq = eps * len_pq
    # c and d strictly on either side: one above tol, the other below -tol (the same
    # booleans as testing both orders, in fewer passes over millions of pairs).
    split_cd = (np.maximum(oc, od) > tol_pq) & (np.minimum(oc, od) < -tol_pq)
    # Only where c and d lie on either side: p and q on either side of the edge's line.
    cand = np.flatnonzero(split_cd)
    op = cpx[cand] * vy[cand] - cpy[cand] * vx[cand]  # side of p, times |cd|
    oq = op - w[cand]  # side of q
    tol_cd = eps * edges.length[edge[cand]]
    split_pq = ((op > tol_cd) & (oq < -tol_cd)) | ((op < -tol_cd) & (oq > tol_cd))
    blocked = cand[split_pq]
    # Border vertex c on the open segment p -> q.
    near = np.flatnonzero(np.abs(oc) <= tol_pq)
    t = (cpx[near] * ux[near] + cpy[near] * uy[near]) / np.where(
        len_pq[near] > 0, len_pq[near] ** 2, 1.0
    )
    along = t * len_pq[near]
    on = (along > eps) & (along < len_pq[near] - eps)
    return seg[blocked], seg[near[on]], t[on]


# --------------------------------------------------------------------------- the grid


@dataclasses.dataclass(frozen=True, eq=False)
class EdgeGrid:
    """Border edges bucketed in a uniform grid of square cells (compressed rows)."""

    lo: FloatArray
    """Lower-left corner of the grid, shape (2,) [m]."""
    cell: float
    """Side of a cell [m]."""
    nx: int
    """Cells along x."""
    ny: int
    """Cells along y."""
    offsets: IntArray
    """Cell c lists ``edges[offsets[c]:offsets[c + 1]]``; c = ix * ny + iy."""
    edges: IntArray
    """Edge indices, cell after cell."""

    @property
    def hi(self) -> FloatArray:
        """Upper-right corner of the grid, shape (2,) [m]."""
        return self.lo + self.cell * np.array([self.nx, self.ny], dtype=np.float64)


def edge_grid(a: FloatArray, b: FloatArray, margin: float) -> EdgeGrid:
    """Bucket the edges a[k] -> b[k] in a uniform grid.

    An edge is listed in every cell that contains a point within ``margin`` of it
    (found column by column, so a long edge costs cells in proportion to its length:
    :func:`_edge_cells`, whose cells a compiled loop lists,
    :func:`planners.kernels.bucket_edges`).

    Examples
    --------
    >>> a = np.array([[0.0, 0.0], [4.0, 0.0]])
    >>> g = edge_grid(a, np.roll(a, -1, axis=0), 0.1)
    >>> g.nx * g.ny >= 1, sorted(set(g.edges.tolist()))
    (True, [0, 1])
    """
    from planners.kernels import bucket_edges  # noqa: PLC0415 - numba only where graphs are built

    points = np.vstack([a, b])
    lo = points.min(axis=0) - 2.0 * margin
    size = np.maximum(points.max(axis=0) + 2.0 * margin - lo, margin)
    cell = _cell_size(size, np.hypot(*(b - a).T), len(a))
    nx, ny = (int(k) for k in np.maximum(np.ceil(size / cell), 1).astype(np.int64))
    setting = np.array([lo[0], lo[1], cell, margin])
    # The types the warm-up compiled (a read-only or float32 array would compile anew).
    a, b = (np.require(e, np.float64, ["C", "W"]) for e in (a, b))
    offsets, edges = bucket_edges(a, b, setting, nx, ny)
    return EdgeGrid(lo, cell, nx, ny, offsets, edges)


def _cell_size(size: FloatArray, lengths: FloatArray, m: int) -> float:
    # About _EDGES_PER_CELL edges a cell over the bounding box, but no smaller than the
    # edges' median length over _MAX_CELLS_PER_EDGE (then an edge spans few cells).
    spread = math.sqrt(float(size[0] * size[1]) * _EDGES_PER_CELL / max(m, 1))
    typical = float(np.median(lengths)) / _MAX_CELLS_PER_EDGE if m else spread
    return max(spread, typical, float(size.max()) / 4096.0)


def _edge_cells(
    a: FloatArray,
    b: FloatArray,
    lo: FloatArray,
    cell: float,
    *,
    margin: float,
    shape: tuple[int, int],
) -> tuple[IntArray, IntArray, IntArray]:
    """Every (edge, column, row) whose cell has a point within ``margin`` of the edge."""
    nx, ny = shape
    x0 = np.minimum(a[:, 0], b[:, 0]) - margin
    x1 = np.maximum(a[:, 0], b[:, 0]) + margin
    c0 = np.clip(np.floor((x0 - lo[0]) / cell), 0, nx - 1).astype(np.intp)
    c1 = np.clip(np.floor((x1 - lo[0]) / cell), 0, nx - 1).astype(np.intp)
    cols = c1 - c0 + 1
    edge = np.repeat(np.arange(len(a), dtype=np.intp), cols)
    ix = c0[edge] + _ramp(cols)
    # The edge's y range over the column widened by the margin, plus the margin.
    left = np.maximum(lo[0] + ix * cell - margin, np.minimum(a[edge, 0], b[edge, 0]))
    right = np.minimum(
        lo[0] + (ix + 1) * cell + margin, np.maximum(a[edge, 0], b[edge, 0])
    )
    dx = b[edge, 0] - a[edge, 0]
    safe = np.where(dx != 0, dx, 1.0)
    t0 = np.where(dx != 0, np.clip((left - a[edge, 0]) / safe, 0, 1), 0.0)
    t1 = np.where(dx != 0, np.clip((right - a[edge, 0]) / safe, 0, 1), 1.0)
    dy = b[edge, 1] - a[edge, 1]
    y0 = a[edge, 1] + np.minimum(t0, t1) * dy
    y1 = a[edge, 1] + np.maximum(t0, t1) * dy
    r0 = np.clip(np.floor((np.minimum(y0, y1) - margin - lo[1]) / cell), 0, ny - 1)
    r1 = np.clip(np.floor((np.maximum(y0, y1) + margin - lo[1]) / cell), 0, ny - 1)
    rows = (r1 - r0 + 1).astype(np.intp)
    return (
        np.repeat(edge, rows),
        np.repeat(ix, rows),
        np.repeat(r0.astype(np.intp), rows) + _ramp(rows),
    )


def near_pairs(
    grid: EdgeGrid, a: FloatArray, b: FloatArray, margin: float
) -> tuple[IntArray, IntArray]:
    """Return (segment, edge) pairs: each segment a[k] -> b[k] with the edges near it.

    Every edge listed in a cell that has a point within ``margin`` of the segment: all
    the edges closer to it than the grid's own margin, and some farther ones (a
    superset, for an exact test to decide). Memory in proportion to the pairs.

    Examples
    --------
    >>> ring = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    >>> grid = edge_grid(ring, np.roll(ring, -1, axis=0), 0.1)
    >>> seg, edge = near_pairs(grid, np.array([[1.0, -1.0]]), np.array([[1.0, 1.0]]), 0.1)
    >>> 0 in edge[seg == 0]  # the segment crosses edge 0, the bottom
    True
    """
    shape = (grid.nx, grid.ny)
    k, ix, iy = _edge_cells(a, b, grid.lo, grid.cell, margin=margin, shape=shape)
    found = list(_pairs_in_cells(grid, k, ix * grid.ny + iy))
    empty = np.zeros(0, dtype=np.intp)
    return (
        np.concatenate([empty, *(seg for seg, _ in found)]),
        np.concatenate([empty, *(edge for _, edge in found)]),
    )


def _ramp(counts: IntArray) -> IntArray:
    """0, 1, ..., counts[0] - 1, 0, 1, ..., counts[1] - 1, ... (one run per count)."""
    total = int(counts.sum())
    starts = np.cumsum(counts) - counts
    return np.arange(total, dtype=np.intp) - np.repeat(starts, counts)


# --------------------------------------------------------------------------- marching


@dataclasses.dataclass(frozen=True, eq=False)
class Marched:
    """What marching found: which segments an edge crosses, which vertices lie on them."""

    crossed: npt.NDArray[np.bool_]
    """Per segment: some border edge properly crosses it (it is blocked)."""
    touch_seg: IntArray
    """Segments that a border vertex lies on (not crossed ones), one entry per vertex."""
    touch_t: FloatArray
    """Where that vertex lies, as the parameter in (0, 1) along the segment."""


def march(grid: EdgeGrid, edges: Edges, segs: Segments, eps: float) -> Marched:
    """Test segments against the edges of the cells they pass through.

    Each segment walks its cells from start to end (Amanatides and Woo) and stops in the
    first cell where an edge properly crosses it; the others are tested against every
    edge within the grid's margin, so their touching vertices are complete. The walk is
    compiled (:func:`planners.kernels.march_cells`); memory is the answer alone.

    Examples
    --------
    >>> ring = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    >>> after = np.roll(ring, -1, axis=0)
    >>> grid, edges = edge_grid(ring, after, 0.1), Edges.of(ring, after)
    >>> a, b = np.array([[1.0, -1.0], [-1.0, 0.0]]), np.array([[1.0, 1.0], [5.0, 0.0]])
    >>> marched = march(grid, edges, Segments.of(a, b), 1e-9)
    >>> marched.crossed.tolist(), marched.touch_seg.tolist(), marched.touch_t.tolist()
    ([True, False], [1, 1], [0.16666666666666666, 0.8333333333333334])
    """
    from planners.kernels import march_cells  # noqa: PLC0415 - numba only where graphs are built

    clip = not _all_inside(grid, segs.ax, segs.ay, segs.ax + segs.dx, segs.ay + segs.dy)
    crossed, seg_all, t_all = march_cells(
        (float(grid.lo[0]), float(grid.lo[1])),
        float(grid.cell),
        (grid.nx, grid.ny),
        grid.offsets,
        grid.edges,
        (edges.ex, edges.ey, edges.edx, edges.edy, edges.length),
        (segs.ax, segs.ay, segs.dx, segs.dy, segs.length),
        float(eps),
        clip,
    )
    return Marched(crossed, *_unique_touches(seg_all, t_all))


def _unique_touches(seg: IntArray, t: FloatArray) -> tuple[IntArray, FloatArray]:
    """Order touching vertices by segment, then t, each (segment, t) once.

    A vertex that two rings share (a pinch) starts two edges and is met once for each:
    the same vertex at the very same t, kept once. Ordered by t,
    then stably by segment (faster than np.lexsort on floats; the order among equal
    (segment, t) is moot, they are one).
    """
    order = np.argsort(t)
    order = order[np.argsort(seg[order], kind="stable")]
    seg, t = seg[order], t[order]
    new = np.ones(len(seg), dtype=bool)
    new[1:] = (seg[1:] != seg[:-1]) | (t[1:] != t[:-1])
    return seg[new], t[new]


def _all_inside(
    grid: EdgeGrid, ax: FloatArray, ay: FloatArray, bx: FloatArray, by: FloatArray
) -> bool:
    """Tell if every segment's two ends lie strictly inside the grid's box.

    Then no clipping is needed: each runs from t = 0 to t = 1 in the grid (the grid
    reaches twice its margin past every edge, far beyond rounding; a clip that ends a
    segment an ulp before t = 1 only spares a cell that the exact test finds empty).
    """
    if not len(ax):
        return True
    lo, hi = grid.lo, grid.hi
    return bool(
        min(ax.min(), bx.min()) > lo[0]
        and max(ax.max(), bx.max()) < hi[0]
        and min(ay.min(), by.min()) > lo[1]
        and max(ay.max(), by.max()) < hi[1]
    )


def _pairs_in_cells(
    grid: EdgeGrid, seg: IntArray, cell: IntArray
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield (segment, edge) pairs: each segment with the edges of its cell.

    In slices of about ``_PAIRS_AT_ONCE`` pairs (whole cells each).
    """
    first = grid.offsets[cell]
    count = grid.offsets[cell + 1] - first
    ends = np.cumsum(count)
    total = int(ends[-1]) if len(ends) else 0
    cuts = np.searchsorted(ends, np.arange(_PAIRS_AT_ONCE, total, _PAIRS_AT_ONCE))
    bounds = [0, *np.unique(cuts).tolist(), len(count)]
    for lo, hi in itertools.pairwise(bounds):
        if hi <= lo:
            continue
        c = count[lo:hi]
        yield (
            np.repeat(seg[lo:hi], c),
            grid.edges[np.repeat(first[lo:hi], c) + _ramp(c)],
        )


# --------------------------------------------------------------------------- occluders


@dataclasses.dataclass(frozen=True, eq=False)
class Disks:
    """Disks inside blocked space: any segment through one's interior is blocked."""

    center: FloatArray
    """Centres, shape (D, 2) [m]."""
    radius: FloatArray
    """Radii, shape (D,) [m], already shrunk by a margin: a segment that passes closer
    than this to a centre has a point deeper than the margin in blocked space."""


def inner_disks(polygons: Sequence[Polygon], margin: float) -> Disks:
    """One disk inside each polygon: around its centroid (or a point on its surface).

    Examples
    --------
    >>> from shapely import Polygon
    >>> d = inner_disks([Polygon([(0, 0), (2, 0), (2, 2), (0, 2)])], 0.0)
    >>> d.center.tolist(), d.radius.tolist()
    ([[1.0, 1.0]], [1.0])
    """
    shapes = np.asarray(polygons, dtype=object)
    if not len(shapes):
        return Disks(np.zeros((0, 2)), np.zeros(0))
    center = shapely.centroid(shapes)
    outside = ~shapely.contains(shapes, center)
    center[outside] = shapely.point_on_surface(shapes[outside])
    radius = shapely.distance(shapely.boundary(shapes), center) - margin
    keep = radius > 0
    return Disks(shapely.get_coordinates(center[keep]), radius[keep])


_SECTORS = (64, 512)
"""Fewest and most angular sectors around each start in :func:`occluded`: about as many
as segments per start (the table costs starts x sectors, finer sectors flag more)."""
_SEGMENTS_AT_ONCE = 1 << 13
"""Segments looked up in the cover table at once."""


def sector_count(per_start: float) -> int:
    """Return the number of sectors for about ``per_start`` segments per start.

    Examples
    --------
    >>> sector_count(10.0), sector_count(300.0), sector_count(1e6)
    (64, 256, 512)
    """
    return int(np.clip(2 ** round(math.log2(max(per_start, 1.0))), *_SECTORS))


def cover_table(disks: Disks, sources: FloatArray, sectors: int) -> FloatArray:
    """Return, per source and sector, the length beyond which a segment is blocked.

    Sector k of a source holds the directions at angles in [k w - pi, (k + 1) w - pi],
    w = 2 pi / ``sectors``. A segment from the source in that sector and longer than
    the table's entry passes through a disk (inf where no disk covers the sector);
    shape (len(sources), sectors) [m]. A compiled loop over (source, disk) pairs
    (:func:`planners.kernels.cover_sectors`).

    Examples
    --------
    >>> d = Disks(np.array([[2.0, 0.0]]), np.array([1.0]))
    >>> t = cover_table(d, np.zeros((1, 2)), 64)
    >>> t[0, 32].item(), t[0, 0].item()  # straight ahead (angle 0) and behind
    (2.0, inf)
    """
    from planners.kernels import cover_sectors  # noqa: PLC0415 - numba only where graphs are built

    centers = np.ascontiguousarray(disks.center, dtype=np.float64).reshape(-1, 2)
    radii = np.ascontiguousarray(disks.radius, dtype=np.float64)
    sources = np.ascontiguousarray(sources, dtype=np.float64).reshape(-1, 2)
    return cover_sectors(centers, radii, sources, int(sectors))


def _sectors_of(dx: FloatArray, dy: FloatArray, sectors: int) -> IntArray:
    """Sector of each direction (dx, dy), as :func:`cover_table` numbers them."""
    width = 2.0 * np.pi / sectors
    sector = ((np.arctan2(dy, dx) + np.pi) // width).astype(np.intp)
    return np.minimum(sector, sectors - 1)


def occluded(disks: Disks, a: FloatArray, b: FloatArray, starts: IntArray) -> BoolArray:
    """Tell which segments a[k] -> b[k] certainly pass through a disk (are blocked).

    ``starts`` bounds the runs of segments that share a start point. Around each start
    the directions are cut into sectors; a sector lies inside the cone under which a
    disk is seen, at distance r to its centre, and a segment in that sector longer than
    r passes closer to the centre than the radius (the closest point is at most r
    along it). Each sector keeps the nearest such r (:func:`cover_table`). Only a
    filter: a segment it does not flag is tested exactly.
    """
    blocked = np.zeros(len(a), dtype=bool)
    if not len(disks.radius) or not len(a):
        return blocked
    sources = a[starts[:-1]]
    sectors = sector_count(len(a) / max(len(sources), 1))
    table = cover_table(disks, sources, sectors).ravel()
    src = np.repeat(np.arange(len(sources), dtype=np.intp) * sectors, np.diff(starts))
    for s0 in range(0, len(a), _SEGMENTS_AT_ONCE):
        s1 = min(s0 + _SEGMENTS_AT_ONCE, len(a))
        dx, dy = b[s0:s1, 0] - a[s0:s1, 0], b[s0:s1, 1] - a[s0:s1, 1]
        near = table[src[s0:s1] + _sectors_of(dx, dy, sectors)]
        blocked[s0:s1] = np.hypot(dx, dy) > near
    return blocked


def occluded_pairs(
    table: FloatArray, points: FloatArray, i: IntArray, j: IntArray
) -> BoolArray:
    """Tell which segments points[i] -> points[j] certainly pass through a disk.

    ``table`` is :func:`cover_table` of every point: the segment is looked up from both
    ends (from j its direction is reversed, half a turn of sectors on). Only a filter,
    like :func:`occluded`, which looks from the start alone and flags fewer. A compiled
    loop (:func:`planners.kernels.occluded_by_cover`).

    Examples
    --------
    >>> d = Disks(np.array([[2.0, 0.0]]), np.array([1.0]))
    >>> p = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0]])
    >>> occluded_pairs(cover_table(d, p, 64), p, np.array([0, 0]), np.array([1, 2]))
    array([ True, False])
    """
    from planners.kernels import occluded_by_cover  # noqa: PLC0415 - numba only where graphs are built

    points = np.ascontiguousarray(points, dtype=np.float64)
    i = np.ascontiguousarray(i, dtype=np.intp)
    j = np.ascontiguousarray(j, dtype=np.intp)
    return occluded_by_cover(table, points, i, j)
