"""Visibility graphs (section 9.4) and simplified visibility graphs (section 9.5).

Both graphs live in the configuration space of :mod:`planners.space.expansion`: the robot is a
point, obstacles are expanded, and free space is closed (a segment may run along an
expanded edge or touch a vertex, never cross an interior).

Full visibility graph (VG)
    Nodes are every vertex of the free space's border (expanded obstacles and shrunk
    walls) plus start and goal; an edge joins every pair that sees each other.
Simplified visibility graph (SVG)
    Only the segments a shortest path can use: those *tangent* to the blocked region at
    each obstacle end (the line through the segment does not enter the obstacle next to
    that vertex). Between two obstacles these are the chapter's common tangents
    (step 1); from start and goal they go to the tangent hull vertices (step 2a); along an
    obstacle they are the edges joining two convex vertices (hull edges, or obstacle
    edges in a pocket, steps 2a and 2b). The chapter's rule for a start inside a convex
    hull (2b) keeps only vertices on the hull; the tangent rule also keeps a convex
    vertex inside a pocket when a path must wrap around it, which the chapter's wording
    would miss. Every shortest path of the VG is a path of the SVG, so both give the
    same length.

How a segment is tested. It is blocked when it properly crosses an edge of the border.
Otherwise the border's vertices that lie on it (within a tolerance ``eps``) cut it into
pieces, each of which is entirely free, entirely blocked or runs along an edge; the
middle of each piece decides. This is exact for collinear vertices, paths grazing a
vertex, start or goal on an edge, and obstacles touching at a point. Which edges a
segment may meet is found in bounded memory by :mod:`planners.visibility.sightlines` (an edge grid
the segments march through, disks inside obstacles that certainly block); node pairs
are screened block by block, and the vertex visibility is kept as the list of pairs
that see each other, so memory grows with the graph, not with n^2.

References
----------
T. Lozano-Perez and M. A. Wesley, "An algorithm for planning collision-free paths among
polyhedral obstacles", Communications of the ACM 22(10), 1979.
J. O'Rourke, Computational Geometry in C, 2nd ed., Cambridge University Press, 1999.
"""

from __future__ import annotations

__all__ = [
    "GraphArrays",
    "VisibilityResult",
    "plan_visibility",
    "segments_free",
    "shortest_path",
    "simplified_visibility_graph",
    "svg_node_reasons",
    "svg_reasons",
    "visibility_graph",
]

import dataclasses
import functools
import math
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, TypeVar

import networkx as nx
import numpy as np
import numpy.typing as npt
import shapely

from planners.space.border import ring_geometry
from planners.space.expansion import ConfigurationSpace
from planners.space.geometry import cross, take_rows, unit_rows
from planners.visibility.sightlines import (
    Disks,
    EdgeGrid,
    Edges,
    Marched,
    Segments,
    cover_table,
    crossings,
    edge_grid,
    inner_disks,
    march,
    occluded,
    occluded_pairs,
    sector_count,
)

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]
T = TypeVar("T")

# Node pairs screened by one call of the compiled screen (a block of rows against the
# columns after them): the screen has no temporaries, so this only bounds a block's size.
_SCREEN_ROWS_PAIRS = 1 << 18
# Pairs handed on at once, at most (plus one screened block's).
_BLOCK_PAIRS = 1 << 18
# Below this many segment x edge pairs, a bounding-box matrix beats the edge grid.
_DENSE_LIMIT = 100_000
# Directions closer than this (as a sine) to an edge count as running along it.
ANGLE_TOL = 1e-12


@dataclasses.dataclass(frozen=True, eq=False)
class GraphArrays:
    """A visibility graph as arrays: what the planner searches and the app draws.

    Building a :class:`networkx.Graph` costs more than finding the segments (about 2 us
    an edge), so the planner keeps this form and :meth:`to_networkx` builds the graph
    only when someone asks for it (:attr:`VisibilityResult.graph`).
    """

    points: FloatArray
    """Node positions, shape (n, 2) [m]: border vertices, then start and goal unless they
    sit on a vertex. No two are equal (a start or goal within eps of a node joins it)."""
    start: int
    """Index of the start node."""
    goal: int
    """Index of the goal node (the start's when the two coincide)."""
    i: IntArray
    """First node of each edge, shape (m,); ``i < j``, in row-major order."""
    j: IntArray
    """Second node of each edge, shape (m,)."""
    kept: BoolArray
    """Which nodes belong to the graph, shape (n,): the SVG leaves out the vertices
    without edges (reflex vertices cannot be on a shortest path)."""

    @functools.cached_property
    def weight(self) -> FloatArray:
        """Edge lengths, shape (m,) [m]."""
        return np.hypot(
            *(take_rows(self.points, self.j) - take_rows(self.points, self.i)).T
        )

    @property
    def nodes(self) -> int:
        """Number of nodes."""
        return int(np.count_nonzero(self.kept))

    @property
    def edges(self) -> int:
        """Number of edges."""
        return len(self.i)

    def segments(self) -> FloatArray:
        """Every edge as a segment, shape (m, 2, 2) [m]."""
        return np.stack(
            [take_rows(self.points, self.i), take_rows(self.points, self.j)], axis=1
        )

    def kind(self, node: int) -> str:
        """``"start"``, ``"goal"`` or ``"vertex"`` (``"start"`` when start is goal)."""
        if node == self.start:
            return "start"
        return "goal" if node == self.goal else "vertex"

    def to_networkx(self) -> nx.Graph:
        """Build the graph: (x, y) tuples as nodes (attribute ``kind``), ``weight``."""
        graph = nx.Graph()
        keys = list(map(tuple, self.points.tolist()))
        graph.add_nodes_from(
            (keys[n], {"kind": self.kind(n)})
            for n in np.flatnonzero(self.kept).tolist()
        )
        graph.add_weighted_edges_from(
            (keys[u], keys[v], w)
            for u, v, w in zip(
                self.i.tolist(), self.j.tolist(), self.weight.tolist(), strict=True
            )
        )
        return graph

    def _adjacency(self) -> tuple[IntArray, IntArray, FloatArray]:
        """Neighbours of each node in ascending order, as compressed rows.

        Node u's neighbours are ``other[first[u]:first[u + 1]]`` with the edges'
        lengths in ``weight``: the order of networkx's adjacency, whose edges are added
        in row-major order. With u as the larger end first, a stable sort by u alone
        lists each node's smaller neighbours, then its larger ones, each ascending
        (the edges are in row-major order); :func:`planners.kernels.compressed_rows`
        sorts so by counting.
        """
        from planners.kernels import compressed_rows  # noqa: PLC0415 - numba only where graphs are built

        return compressed_rows(self.i, self.j, self.weight, len(self.points))

    def shortest_path(
        self, settled: list[tuple[int, int, float]] | None = None
    ) -> tuple[FloatArray, float] | None:
        """Return the shortest (path, length) from start to goal, or None.

        A* with the straight-line distance as heuristic (admissible, so the path is
        optimal), compiled (:func:`planners.kernels.astar`). It is
        :func:`networkx.astar_path` step by step -- the same queue order, tie-breaking
        and floating-point sums -- on compressed rows instead of a graph, so it finds
        the very path :func:`shortest_path` finds in :meth:`to_networkx` (a property
        test holds the two together).

        ``settled``, when given, receives (node, parent, cost) for each node the search
        settles, in order (the parent is -1 for the start; the goal comes last when
        reached): what an explanation of the search shows (section 9.4).
        """
        s, g = self.start, self.goal
        if s == g:
            if settled is not None:
                settled.append((s, -1, 0.0))
            return self.points[[s]].copy(), 0.0
        from planners.kernels import astar  # noqa: PLC0415 - numba only where graphs are built

        first, other_of, weight_of = self._adjacency()
        target = tuple(self.points[g].tolist())
        # math.dist, as networkx's heuristic computes it (the same floats, the same order).
        heuristic = np.array(
            [math.dist(p, target) for p in map(tuple, self.points.tolist())]
        )
        steps, costs, order = astar(first, other_of, weight_of, heuristic, s, g)
        if settled is not None:
            settled.extend(
                (node, parent, cost)
                for (node, parent), cost in zip(
                    steps.tolist(), costs.tolist(), strict=True
                )
            )
        if not len(order):
            return None
        path = self.points[order]
        return path, float(np.hypot(*np.diff(path, axis=0).T).sum())


@dataclasses.dataclass(frozen=True, eq=False)
class VisibilityResult:
    """What the VG or SVG planner found, with everything the lesson shows."""

    planner: str
    """``"vg"`` or ``"svg"``."""
    status: str
    """``"ok"``, ``"unreachable"`` or ``"invalid"``."""
    path: FloatArray
    """Shortest path from start to goal, shape (N, 2) [m]; shape (0, 2) when none."""
    length: float | None
    """Length of ``path`` [m], or None when there is none."""
    arrays: GraphArrays
    """The graph as arrays (what the app draws); :attr:`graph` is it in networkx."""
    reason: str | None = None
    """Why there is no path, in words; None when there is one."""
    cspace: ConfigurationSpace | None = None
    """The configuration space the graph was built in."""
    ms: float = 0.0
    """Compute time [ms], set by :func:`planners.plan_all` (shared expansion included;
    building :attr:`graph` on first use is not)."""

    @functools.cached_property
    def graph(self) -> nx.Graph:
        """The graph as networkx, built on first use.

        Nodes are (x, y) tuples with attribute ``kind`` (start, goal, vertex); edges
        have ``weight``, the Euclidean length [m].
        """
        return self.arrays.to_networkx()

    @property
    def nodes(self) -> int:
        """Number of graph nodes."""
        return self.arrays.nodes

    @property
    def edges(self) -> int:
        """Number of graph edges."""
        return self.arrays.edges


# --------------------------------------------------------------------------- the border


@dataclasses.dataclass(frozen=True, eq=False)
class Border:
    """The free space's border as flat arrays, built once per configuration space."""

    points: FloatArray  # (n, 2) unique vertices
    edge_a: FloatArray  # (m, 2) edge starts; blocked space on the left of a -> b
    edge_b: FloatArray  # (m, 2)
    occ_node: IntArray  # (o,) node of each ring vertex occurrence
    occ_next: FloatArray  # (o, 2) unit direction to the next ring vertex
    occ_prev: FloatArray  # (o, 2) unit direction to the previous ring vertex
    occ_convex: BoolArray  # (o,) blocked wedge narrower than pi: a path can wrap here
    eps: float  # the configuration space's tolerance [m]

    @functools.cached_property
    def edges(self) -> Edges:
        return Edges.of(self.edge_a, self.edge_b)

    @functools.cached_property
    def grid(self) -> EdgeGrid:
        # Margin: the exact test's tolerance, with room for rounding in the traversal.
        return edge_grid(self.edge_a, self.edge_b, 4.0 * self.eps)

    @functools.cached_property
    def edge_boxes(self) -> tuple[FloatArray, FloatArray]:
        return np.minimum(self.edge_a, self.edge_b), np.maximum(
            self.edge_a, self.edge_b
        )

    @functools.cached_property
    def first_occurrence(self) -> IntArray:
        first = np.full(len(self.points), -1, dtype=np.intp)
        first[self.occ_node[::-1]] = np.arange(len(self.occ_node))[::-1]
        return first

    @functools.cached_property
    def pinch_nodes(self) -> BoolArray:
        """Vertices where obstacles touch (or a hole touches the outer ring).

        No single wedge tells the blocked directions there, and a path through one may
        bend either way.
        """
        count = np.bincount(self.occ_node, minlength=len(self.points))
        return count > 1

    @functools.cached_property
    def convex_nodes(self) -> BoolArray:
        convex = np.zeros(len(self.points), dtype=bool)
        convex[self.occ_node[self.occ_convex]] = True
        return convex

    @functools.cached_property
    def wedges(self) -> _Wedges:
        """The blocked wedge at each vertex; none at pinches (no single wedge there)."""
        occ = self.first_occurrence
        alone = ~self.pinch_nodes[:, None]
        return _Wedges(
            np.where(alone, self.occ_next[occ], 0.0),
            np.where(alone, self.occ_prev[occ], 0.0),
            cross(self.occ_next[occ], self.occ_prev[occ]) > ANGLE_TOL,
        )


@dataclasses.dataclass(frozen=True, eq=False)
class _Wedges:
    """Per node, the blocked wedge: it turns counter-clockwise from ``nxt`` to ``prv``.

    Zero vectors where no wedge applies (start, goal, pinches): nothing is inside.
    """

    nxt: FloatArray  # (n, 2) unit direction of the next ring vertex, or 0
    prv: FloatArray  # (n, 2) unit direction of the previous ring vertex, or 0
    narrow: BoolArray  # (n,) the wedge is narrower than pi (a convex vertex)

    def extended(self, count: int) -> _Wedges:
        """Return the same with ``count`` wedge-less nodes appended (start and goal)."""
        zeros = np.zeros((count, 2))
        return _Wedges(
            np.vstack([self.nxt, zeros]),
            np.vstack([self.prv, zeros]),
            np.append(self.narrow, np.ones(count, dtype=bool)),
        )


def _into_wedge(  # noqa: PLR0917 - a numeric kernel on broadcast arrays
    nxt: FloatArray,
    prv: FloatArray,
    narrow: BoolArray,
    dx: FloatArray,
    dy: FloatArray,
    tol: FloatArray,
    *,
    backward: bool = False,
) -> BoolArray:
    """Tell if direction (dx, dy) leaves a vertex strictly into its blocked wedge.

    ``nxt`` and ``prv`` are (..., 2) unit vectors, broadcast against ``dx`` and ``dy``;
    strictly means by more than ``tol`` (``ANGLE_TOL`` times the direction's length,
    an angle). A wedge narrower than pi is entered between its two sides; a wider one
    everywhere but the closed free wedge from ``prv`` to ``nxt``. ``backward`` tests
    the direction (-dx, -dy) instead: the same booleans as negating dx and dy (IEEE
    products and differences change sign exactly), without the two negated copies.
    """
    after_next = nxt[..., 0] * dy - nxt[..., 1] * dx  # cross(nxt, d)
    before_prev = dx * prv[..., 1] - dy * prv[..., 0]  # cross(d, prv)
    if backward:
        low = -tol
        after_next, before_prev = after_next < low, before_prev < low
    else:
        after_next, before_prev = after_next > tol, before_prev > tol
    if narrow.all():
        return after_next & before_prev
    if not narrow.any():
        return after_next | before_prev
    return np.where(narrow, after_next & before_prev, after_next | before_prev)


def build_border(cspace: ConfigurationSpace) -> Border:
    # The border model every planner reads, with every vertex as expanded (module
    # docstring of planners.space.border): its edges, and at each vertex the directions to
    # the next and the previous vertex of its ring.
    geo = ring_geometry(cspace, cleaned=False)
    if not geo.rings:
        empty = np.zeros((0, 2))
        none = np.zeros(0, dtype=np.intp)
        no = np.zeros(0, dtype=bool)
        return Border(empty, empty, empty, none, empty, empty, no, cspace.eps)
    # Vertices shared by several rings (obstacles touching at a point) become one node.
    points, occ_node = _unique_points(geo.start)
    to_next = unit_rows(geo.step)
    to_prev = unit_rows(geo.start[geo.prev_edge] - geo.start)
    # Blocked space is on the left of each ring: the blocked wedge at a vertex turns
    # counter-clockwise from the next edge to the previous one.
    convex = cross(to_next, to_prev) > ANGLE_TOL
    return Border(
        points, geo.start, geo.end, occ_node, to_next, to_prev, convex, cspace.eps
    )


# --------------------------------------------------------------------------- segment test


def segments_free(
    cspace: ConfigurationSpace, a: npt.ArrayLike, b: npt.ArrayLike
) -> BoolArray:
    """Tell, for each segment a[k] -> b[k], whether it lies in the closed free space.

    Parameters
    ----------
    cspace
        The configuration space.
    a, b
        Segment end points, shape (S, 2) [m].

    Returns
    -------
    numpy.ndarray
        Boolean array of shape (S,).

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> segments_free(space, [[-1, 0], [-1, -1], [0, 0]], [[2, 0], [2, 2], [1, 1]])
    array([ True, False, False])
    """
    a = np.atleast_2d(np.asarray(a, dtype=np.float64))
    b = np.atleast_2d(np.asarray(b, dtype=np.float64))
    return _segments_free(cspace, cspace.derive(build_border), a, b)


def _segments_free(
    cspace: ConfigurationSpace, border: Border, a: FloatArray, b: FloatArray
) -> BoolArray:
    s, m = len(a), len(border.edge_a)
    if s == 0:
        return np.zeros(0, dtype=bool)
    if m == 0:
        # No obstacles and no walls: only the (unbounded) plane.
        return np.ones(s, dtype=bool)
    starts = _runs_of_equal_starts(a)
    if len(starts) - 1 > s // 16:  # few segments per start: the filter would not pay
        return exact_free(cspace, border, a, b)
    # Cheap first: segments that certainly pass through a disk inside an obstacle.
    free = ~occluded(cspace.derive(_inner_disks), a, b, starts)
    test = np.flatnonzero(free)
    free[test] = exact_free(cspace, border, take_rows(a, test), take_rows(b, test))
    return free


def _inner_disks(cspace: ConfigurationSpace) -> Disks:
    """Return a disk inside each expanded obstacle and each merged one, shrunk a few eps.

    A merged obstacle made of a single expanded one is that one (its disk would be a
    copy), so only the merged obstacles of several get a disk of their own.
    """
    expanded = np.asarray(cspace.expanded, dtype=object)
    merged = np.asarray(cspace.merged.geoms, dtype=object)
    if len(expanded) and len(merged):
        _, part = shapely.STRtree(merged).query(expanded, predicate="intersects")
        merged = merged[np.bincount(part, minlength=len(merged)) > 1]
    return inner_disks([*expanded, *merged], 8.0 * cspace.eps)


def _unique_points(points: FloatArray) -> tuple[FloatArray, IntArray]:
    """Return ``np.unique(points, axis=0, return_inverse=True)``, ten times faster.

    The rows as complex numbers x + iy (a view of the same bits; numpy orders them by
    x, then y, as ``unique`` orders rows). For finite coordinates (a scene's are:
    :func:`planners.scene.scene_problems`); NaN would sort differently.

    Examples
    --------
    >>> u, inverse = _unique_points(np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 0.0]]))
    >>> u.tolist(), inverse.tolist()
    ([[0.0, 2.0], [1.0, 0.0]], [1, 0, 1])
    """
    z = np.ascontiguousarray(points, dtype=np.float64).view(np.complex128)[:, 0]
    unique, inverse = np.unique(z, return_inverse=True)
    return unique.view(np.float64).reshape(-1, 2), inverse.reshape(-1)


def _runs_of_equal_starts(a: FloatArray) -> IntArray:
    """Boundaries of the runs of consecutive segments that start at the same point."""
    change = np.flatnonzero(np.any(a[1:] != a[:-1], axis=1)) + 1
    return np.concatenate([[0], change, [len(a)]]).astype(np.intp)


def exact_free(
    cspace: ConfigurationSpace, border: Border, a: FloatArray, b: FloatArray
) -> BoolArray:
    """Tell which segments a[k] -> b[k] are free, by the exact test (module docstring)."""
    s, m = len(a), len(border.edge_a)
    if s == 0:
        return np.zeros(0, dtype=bool)
    segs = Segments.of(a, b)
    if s * m <= _DENSE_LIMIT:
        seg, edge = _overlapping_boxes(a, b, border, cspace.eps)
        crossed_seg, t_seg, t_val = crossings(segs, border.edges, seg, edge, cspace.eps)
        free = np.ones(s, dtype=bool)
        free[crossed_seg] = False
        keep = free[t_seg]
        t_seg, t_val = t_seg[keep], t_val[keep]
        order = np.lexsort((t_val, t_seg))  # few: as the march hands them on
        t_seg, t_val = t_seg[order], t_val[order]
        return _decide_pieces(cspace, segs, free, t_seg, t_val)
    return _marched_free(cspace, border, segs)


def _exact_free_pairs(
    cspace: ConfigurationSpace,
    border: Border,
    points: FloatArray,
    i: IntArray,
    j: IntArray,
) -> BoolArray:
    """Tell which segments points[i[k]] -> points[j[k]] are free: :func:`exact_free`.

    The marched segments are made from the points' coordinate columns (the same
    numbers as :meth:`Segments.of` on the gathered rows, without gathering (N, 2) rows).
    """
    marching = _march_pairs(border, points, i, j, cspace.eps)
    return _finish(cspace, border, points, marching)


@dataclasses.dataclass(frozen=True, eq=False)
class _Marching:
    """Segments points[i] -> points[j] on their way through the exact test.

    Marched through the edge grid (on any thread), or, few segments against few edges,
    left to the dense test (``segs`` and ``marched`` None).
    """

    i: IntArray
    j: IntArray
    segs: Segments | None
    marched: Marched | None


def _march_pairs(
    border: Border, points: FloatArray, i: IntArray, j: IntArray, eps: float
) -> _Marching:
    """March segments points[i] -> points[j], unless the dense test is the cheaper."""
    if len(i) * len(border.edge_a) <= _DENSE_LIMIT:
        return _Marching(i, j, None, None)
    x, y = points[:, 0], points[:, 1]
    ax, ay = x[i], y[i]
    dx, dy = x[j] - ax, y[j] - ay
    segs = Segments(ax, ay, dx, dy, np.hypot(dx, dy))
    return _Marching(i, j, segs, march(border.grid, border.edges, segs, eps))


def _finish(
    cspace: ConfigurationSpace, border: Border, points: FloatArray, m: _Marching
) -> BoolArray:
    """Tell which of the segments on their way are free (shapely: the caller's thread)."""
    if m.segs is None or m.marched is None:
        return exact_free(
            cspace, border, take_rows(points, m.i), take_rows(points, m.j)
        )
    crossed = m.marched
    return _decide_pieces(
        cspace, m.segs, ~crossed.crossed, crossed.touch_seg, crossed.touch_t
    )


def _marched_free(
    cspace: ConfigurationSpace, border: Border, segs: Segments
) -> BoolArray:
    """Do :func:`exact_free` with the edge grid's march."""
    marched = march(border.grid, border.edges, segs, cspace.eps)
    return _decide_pieces(
        cspace, segs, ~marched.crossed, marched.touch_seg, marched.touch_t
    )


def _decide_pieces(
    cspace: ConfigurationSpace,
    segs: Segments,
    free: BoolArray,
    t_seg: IntArray,
    t_val: FloatArray,
) -> BoolArray:
    """Cut the uncrossed segments at the vertices on them; a blocked piece blocks.

    ``free`` is False where an edge crosses a segment; (``t_seg``, ``t_val``) are the
    vertices on the others, ordered by segment, then t. Updated and returned.
    """
    survivors = np.flatnonzero(free)
    if len(survivors) == 0:
        return free
    # Each survivor is cut at the border vertices lying on it; every piece is free,
    # blocked or along an edge, and its middle tells which.
    piece_seg, mid_t = _pieces(survivors, t_seg, t_val)
    # a + t (b - a) per coordinate, from the segments' 1-D rows (the same numbers:
    # their direction is b - a; gathers of (N, 2) rows are several times slower).
    mids = np.empty((len(piece_seg), 2))
    mids[:, 0] = segs.ax[piece_seg] + mid_t * segs.dx[piece_seg]
    mids[:, 1] = segs.ay[piece_seg] + mid_t * segs.dy[piece_seg]
    blocked_piece = cspace.contains_blocked(mids)
    free[piece_seg[blocked_piece]] = False
    return free


def _pieces(
    survivors: IntArray, t_seg: IntArray, t_val: FloatArray
) -> tuple[IntArray, FloatArray]:
    """Cut each survivor at the parameters t of the vertices on it; give each piece's middle.

    ``survivors`` ascending; (``t_seg``, ``t_val``) the vertices on them, ordered by
    segment, then t, each t in (0, 1). Survivor s with vertices at t1 < ... < tk has
    the pieces [0, t1], [t1, t2], ..., [tk, 1]. Returns (segment, middle t) per piece, in
    that order: laid out in place instead of sorted (a sort of the ends costs more than
    all the rest on scenes with many collinear vertices).
    """
    rank = np.searchsorted(survivors, t_seg)  # each vertex's survivor
    count = np.bincount(rank, minlength=len(survivors)) + 2  # ends: 0, the ts, 1
    last = np.cumsum(count) - 1
    first = last - count + 1
    ts = np.empty(int(last[-1]) + 1)
    ts[first] = 0.0
    ts[last] = 1.0
    # The vertices of survivor r fill first[r] + 1, ... in their order.
    before = np.cumsum(count - 2) - (count - 2)
    ts[first[rank] + 1 + np.arange(len(t_seg)) - before[rank]] = t_val
    starts = np.ones(len(ts), dtype=bool)
    starts[last] = False
    mid = 0.5 * (ts[:-1] + ts[1:])
    return np.repeat(survivors, count - 1), mid[starts[:-1]]


def _overlapping_boxes(
    a: FloatArray, b: FloatArray, border: Border, eps: float
) -> tuple[IntArray, IntArray]:
    """(segment, edge) index pairs whose bounding boxes overlap, from a dense matrix."""
    lo, hi = np.minimum(a, b) - eps, np.maximum(a, b) + eps
    elo, ehi = border.edge_boxes
    overlap = (lo[:, None, 0] <= ehi[None, :, 0]) & (hi[:, None, 0] >= elo[None, :, 0])
    overlap &= (lo[:, None, 1] <= ehi[None, :, 1]) & (hi[:, None, 1] >= elo[None, :, 1])
    seg, edge = np.nonzero(overlap)
    return seg.astype(np.intp), edge.astype(np.intp)


# --------------------------------------------------------------------------- graphs


@dataclasses.dataclass(frozen=True, eq=False)
class _Query:
    points: FloatArray  # (n, 2): border vertices, then start and goal if new
    node: IntArray  # (n,) border vertex id, or -1 for start/goal
    start: int
    goal: int


def _query(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> tuple[Border, _Query]:
    """Return the border and the graph nodes: its vertices plus start and goal."""
    border = cspace.derive(build_border)
    eps = cspace.eps
    points = border.points
    node = np.arange(len(points), dtype=np.intp)
    ends = []
    for p in (np.asarray(start, dtype=np.float64), np.asarray(goal, dtype=np.float64)):
        hit = np.flatnonzero(np.hypot(*(points - p).T) <= eps) if len(points) else []
        if len(hit):
            ends.append(int(hit[0]))
            # Start and goal are free to leave in any direction, even from a vertex.
            node[hit[0]] = -1
        else:
            points = np.vstack([points, p[None, :]])
            node = np.append(node, -1)
            ends.append(len(points) - 1)
    return border, _Query(points, node, ends[0], ends[1])


def _graph_arrays(
    q: _Query, i: IntArray, j: IntArray, *, drop_isolated: bool = False
) -> GraphArrays:
    """Make the graph on the query's nodes with edges (i, j).

    ``drop_isolated`` leaves out the border vertices without an edge (start and goal
    always stay).
    """
    kept = np.ones(len(q.points), dtype=bool)
    if drop_isolated:
        kept = np.zeros(len(q.points), dtype=bool)
        kept[i] = kept[j] = True
        kept[q.node < 0] = True
    return GraphArrays(q.points, q.start, q.goal, i, j, kept)


def _query_wedges(border: Border, q: _Query) -> _Wedges:
    """Return the blocked wedge at each of the query's nodes (none at start and goal)."""
    wedges = border.wedges.extended(len(q.points) - len(border.points))
    free = np.flatnonzero(q.node < 0)
    if len(free):
        nxt, prv = wedges.nxt.copy(), wedges.prv.copy()
        # Start and goal are free to leave in any direction, even from a vertex.
        nxt[free] = prv[free] = 0.0
        wedges = _Wedges(nxt, prv, wedges.narrow)
    return wedges


def leaves_blocked(
    wedges: _Wedges, i: IntArray, j: IntArray, dx: FloatArray, dy: FloatArray
) -> BoolArray:
    """Tell if segment i -> j (direction (dx, dy)) leaves i or j into their wedges.

    ``i`` and ``j`` index the wedges and broadcast like ``dx`` and ``dy`` (rows against
    columns for a block of pairs).
    """
    tol = ANGLE_TOL * np.hypot(dx, dy)
    nxt, prv, narrow = wedges.nxt, wedges.prv, wedges.narrow
    return _into_wedge(
        take_rows(nxt, i), take_rows(prv, i), narrow.take(i), dx, dy, tol
    ) | _into_wedge(
        take_rows(nxt, j), take_rows(prv, j), narrow.take(j), dx, dy, tol, backward=True
    )


def _not_tangent(
    wedges: _Wedges, i: IntArray, j: IntArray, dx: FloatArray, dy: FloatArray
) -> BoolArray:
    """Tell if the line through i and j enters the narrow wedge at i or at j.

    Both directions at once: d enters a wedge narrower than pi when it lies strictly
    between the sides, -d when it lies strictly outside both; such a segment is either
    blocked at that end or not tangent there (section 9.5). Only for narrow wedges (the
    SVG's candidates are convex vertices, start, goal and pinches).
    """
    tol = ANGLE_TOL * np.hypot(dx, dy)
    enters = np.zeros(np.broadcast_shapes(np.shape(dx), np.shape(i), np.shape(j)), bool)
    for k in (i, j):
        nxt, prv = take_rows(wedges.nxt, k), take_rows(wedges.prv, k)
        a = nxt[..., 0] * dy - nxt[..., 1] * dx  # cross(nxt, d)
        b = dx * prv[..., 1] - dy * prv[..., 0]  # cross(d, prv)
        enters |= ((a > tol) & (b > tol)) | ((a < -tol) & (b < -tol))
    return enters


def _visible(
    cspace: ConfigurationSpace, border: Border, q: _Query, i: IntArray, j: IntArray
) -> BoolArray:
    """Tell which node pairs (i, j) of the query see each other.

    Cheap first: a segment that leaves a vertex strictly into its obstacle is blocked.
    This only saves work (the exact test decides the rest) and skips the vertices
    where rings touch.
    """
    d = take_rows(q.points, j) - take_rows(q.points, i)
    ok = ~leaves_blocked(_query_wedges(border, q), i, j, d[:, 0], d[:, 1])
    idx = np.flatnonzero(ok)
    ok[idx] = _segments_free(
        cspace, border, take_rows(q.points, i[idx]), take_rows(q.points, j[idx])
    )
    return ok


def _candidate_pairs(
    points: FloatArray, wedges: _Wedges, nodes: IntArray, *, tangent: bool
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield, block by block, the pairs of ``nodes`` that may see each other.

    A pair (nodes[r], nodes[c]), r < c, is left out when the segment leaves either end
    strictly into its blocked wedge; with ``tangent``, also when its extension beyond
    either end does (the line enters the obstacle there: not a tangent, section 9.5).
    A compiled loop (:func:`planners.kernels.screened_pairs`) screens about
    ``_SCREEN_ROWS_PAIRS`` pairs at a time; they are handed on in blocks of about
    ``_BLOCK_PAIRS``, so memory does not grow with n^2; pairs come in row-major order of
    ``nodes`` (which must be ascending).
    """
    from planners.kernels import screened_pairs  # noqa: PLC0415 - numba only where graphs are built

    arrays = (wedges.nxt, wedges.prv, wedges.narrow)
    k = len(nodes)
    found: list[tuple[IntArray, IntArray]] = []
    count = 0
    r0 = 0
    while r0 < k - 1:
        r1 = min(k - 1, r0 + max(1, _SCREEN_ROWS_PAIRS // (k - r0)))
        block = screened_pairs(nodes[r0:r1], nodes, points, arrays, ANGLE_TOL, tangent)
        found.append(block)
        count += len(block[0])
        r0 = r1
        if count >= _BLOCK_PAIRS or r0 >= k - 1:
            yield _joined(found)
            found, count = [], 0


def visibility_graph(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> nx.Graph:
    """Build the full visibility graph of section 9.4.

    Parameters
    ----------
    cspace
        Configuration space (expanded obstacles, shrunk walls).
    start, goal
        Points of shape (2,) [m], in free space.

    Returns
    -------
    networkx.Graph
        Every pair of nodes that see each other, with ``weight`` = length.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> g = visibility_graph(space, (-1, 0.5), (2, 0.5))
    >>> g.number_of_nodes(), g.number_of_edges()
    (6, 8)
    """
    return _vg_arrays(cspace, start, goal).to_networkx()


def _vg_arrays(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> GraphArrays:
    border, q = _query(cspace, start, goal)
    i, j = _visibility(cspace, border, q)
    return _graph_arrays(q, i, j)


@dataclasses.dataclass(frozen=True, eq=False)
class Sight:
    """Which border vertices see each other: the pairs that do, i < j, row-major.

    Memory grows with the visibility graph's edges, not with n^2.
    """

    n: int
    """Number of border vertices."""
    i: IntArray
    j: IntArray

    @functools.cached_property
    def keys(self) -> npt.NDArray[np.int64]:
        """``i * n + j`` per pair, ascending (for lookups)."""
        return self.i.astype(np.int64) * self.n + self.j

    def sees(self, i: IntArray, j: IntArray) -> BoolArray:
        """Tell, for each pair of border vertices (i, j), whether they see each other."""
        lo, hi = np.minimum(i, j), np.maximum(i, j)
        key = lo.astype(np.int64) * self.n + hi
        at = np.minimum(np.searchsorted(self.keys, key), max(len(self.keys) - 1, 0))
        return (self.keys[at] == key) if len(self.keys) else np.zeros(len(i), bool)


def vertex_visibility(cspace: ConfigurationSpace) -> Sight:
    """Which border vertices see each other (section 9.4), block by block.

    It depends on the configuration space alone, so it is derived once per configuration
    space (:meth:`ConfigurationSpace.derive`): while the start or the goal is dragged
    each query only adds its start's and goal's rows, and the SVG of a scene whose VG was
    built reads its vertex pairs from it. Visibility is a function of the two points (the
    exact segment test decides), so the rows of a vertex the start or goal sits on hold
    for them too. A cold build finds it with the start's and goal's rows
    (:func:`_cold_sights`).
    """
    border = cspace.derive(build_border)
    none = np.zeros(0, dtype=np.intp)
    return _sights(cspace, border, border.points, none, none)[0]


def _sights(
    cspace: ConfigurationSpace,
    border: Border,
    points: FloatArray,
    extra_i: IntArray,
    extra_j: IntArray,
) -> tuple[Sight, BoolArray]:
    """Find the border vertices that see each other, and which extra pairs are free.

    ``points`` are the border vertices, then any others (start and goal); the extra
    pairs (i, j) of ``points``, already screened by the caller, are tested with the
    last block of border pairs (one exact test, not two). Returns the vertex visibility
    and, per extra pair, whether it is free.

    On a big border (``_PIPELINED_VERTICES``) the work runs on two threads: each builds
    half the cover table; then this one screens the pairs and decides the marched
    segments' pieces, and a helper, block by block, looks the pairs up in the table and
    marches the rest (compiled loops, which let go of the interpreter). A block that
    comes while the helper is still busy is looked up here. The blocks are taken in
    their order, so the answer is the one a single thread gives.
    """
    n = len(border.points)
    found_i, found_j = [np.zeros(0, dtype=np.intp)], [np.zeros(0, dtype=np.intp)]
    rings = cspace.derive(_convex_ring_of)
    apart = bool(np.any(rings.ring >= 0))
    blocks = (
        _candidate_pairs_apart(border, rings)
        if apart
        else _candidate_pairs(
            border.points, border.wedges, np.arange(n, dtype=np.intp), tangent=False
        )
    )
    disks = cspace.derive(_inner_disks)
    # The disks' cover around every point, so that each pair is looked up from both of
    # its ends (after the wedge screen about a quarter of the n - 1 others per vertex).
    sectors = sector_count(n / 4)
    extra_free = np.zeros(0, dtype=bool)
    with _Helper(n >= _PIPELINED_VERTICES) as helper:
        if helper.threaded and len(border.edge_a):  # built here, not on the helper's
            _ = border.grid, border.edges.length  # cached properties, filled in now
        table = _cover_on_both(helper, disks, points, sectors)
        pending: list[tuple[bool, int, IntArray, IntArray, Future[_Looked]]] = []
        for last, (bi, bj) in _last_marked(blocks):
            i = np.concatenate([bi, extra_i]) if last else bi
            j = np.concatenate([bj, extra_j]) if last else bj
            # The helper looks the block up, unless it is still busy with the one
            # before: then this thread does it rather than wait.
            busy = any(not job.done() for *_, job in pending)
            run = helper.now if busy else helper.submit
            looked = run(_look_up, table, border, points, i, j, cspace.eps)
            pending.append((last, len(bi), bi, bj, looked))
            while len(pending) > (0 if last else 1):  # one block ahead at most
                was_last, count, pi, pj, job = pending.pop(0)
                ok = _decided(cspace, border, points, job)
                if was_last:
                    extra_free = ok[count:]
                found_i.append(pi[ok[:count]])
                found_j.append(pj[ok[:count]])
    i, j = np.concatenate(found_i), np.concatenate(found_j)
    if apart:  # found ring by ring: back to row-major order
        order = np.argsort(i.astype(np.int64) * n + j)
        i, j = i[order], j[order]
    return Sight(n, i, j), extra_free


_PIPELINED_VERTICES = 2000
"""Border vertices from which :func:`_sights` runs on two threads (below, the helper
thread would cost more than it saves)."""


@dataclasses.dataclass(frozen=True, eq=False)
class _Looked:
    """A block's pairs looked up in the cover table, the rest on their way (:func:`_look_up`)."""

    ok: BoolArray  # (k,) not flagged by the cover table
    test: IntArray  # the indices of ok's True entries
    marching: _Marching  # those pairs


def _look_up(  # noqa: PLR0917 - a job's arguments, passed by position
    table: FloatArray,
    border: Border,
    points: FloatArray,
    i: IntArray,
    j: IntArray,
    eps: float,
) -> _Looked:
    """Flag the pairs the cover blocks; march the others through the edge grid.

    What of :func:`_exact_free_pairs` needs no shapely, so it may run on the helper.
    """
    ok = ~occluded_pairs(table, points, i, j)
    test = np.flatnonzero(ok)
    return _Looked(ok, test, _march_pairs(border, points, i[test], j[test], eps))


def _decided(
    cspace: ConfigurationSpace, border: Border, points: FloatArray, job: Future[_Looked]
) -> BoolArray:
    """Finish a block looked up by :func:`_look_up`: which of its pairs are free."""
    looked = job.result()
    looked.ok[looked.test] = _finish(cspace, border, points, looked.marching)
    return looked.ok


def _cover_on_both(
    helper: _Helper, disks: Disks, points: FloatArray, sectors: int
) -> FloatArray:
    """Build the cover table of ``points``: its first half on the helper thread, if any."""
    if not helper.threaded:
        return cover_table(disks, points, sectors)
    half = len(points) // 2
    first = helper.submit(cover_table, disks, points[:half], sectors)
    rest = cover_table(disks, points[half:], sectors)
    return np.vstack([first.result(), rest])


class _Helper:
    """One helper thread for a call's duration, or none: then each job runs at once.

    ``submit`` returns a :class:`concurrent.futures.Future` either way, so the caller
    reads its answers in one way.
    """

    def __init__(self, threaded: bool) -> None:
        self.threaded = threaded
        self._pool = ThreadPoolExecutor(1, "sights") if threaded else None

    def __enter__(self) -> _Helper:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)

    def submit(self, fn: Callable[..., T], *args: Any) -> Future[T]:
        """Run ``fn(*args)`` on the helper thread, or now."""
        if self._pool is not None:
            return self._pool.submit(fn, *args)
        return self.now(fn, *args)

    @staticmethod
    def now(fn: Callable[..., T], *args: Any) -> Future[T]:
        """Run ``fn(*args)`` on this thread; its answer as a done future."""
        done: Future[T] = Future()
        done.set_result(fn(*args))
        return done


def _point_of(q: _Query, node: int) -> tuple[float, float]:
    """Node ``node`` of the query as a key of :class:`_PointSights`."""
    return float(q.points[node, 0]), float(q.points[node, 1])


def _last_marked(
    blocks: Iterator[tuple[IntArray, IntArray]],
) -> Iterator[tuple[bool, tuple[IntArray, IntArray]]]:
    """Yield (is it the last, block) for each block; one empty last block if none."""
    none = np.zeros(0, dtype=np.intp)
    previous = None
    for block in blocks:
        if previous is not None:
            yield False, previous
        previous = block
    yield True, previous if previous is not None else (none, none)


_BIG_RING = 64
"""Rings of at least this many vertices are looked at by :func:`_convex_ring_of`."""
_CONVEX_MARGIN = 1e-9
"""Sine by which a ring's other vertices must lie inside each vertex's wedge (1000 times
the screen's angle tolerance, far above rounding)."""


@dataclasses.dataclass(frozen=True, eq=False)
class _ConvexRings:
    """The big strictly convex rings of :func:`_convex_ring_of`."""

    ring: IntArray  # (n,) per border vertex its ring, or -1
    edge_i: IntArray  # (e,) the rings' edges as node pairs, smaller node first
    edge_j: IntArray


def _convex_ring_of(cspace: ConfigurationSpace) -> _ConvexRings:
    """Per border vertex, the big strictly convex ring it lies on, or -1; their edges.

    A ring qualifies when it has at least ``_BIG_RING`` vertices, none shared with
    another ring, and from each vertex v the vertices v + 2 and v - 2 lie inside v's
    blocked wedge by a sine of ``_CONVEX_MARGIN`` from both sides. Along a convex ring
    the directions from v to v + 2, v + 3, ..., v - 2 turn one way from one side of the
    wedge to the other, and the sine of the angle to a side is concave on [0, pi], so
    every vertex but v's two neighbours lies inside by that margin: the wedge screen
    (:func:`leaves_blocked`) drops every such pair, and :func:`_candidate_pairs_apart`
    need not enumerate them (the circle of 10,000 vertices: 50 million pairs).
    """
    border = cspace.derive(build_border)
    geo = ring_geometry(cspace, cleaned=False)
    ring = np.full(len(border.points), -1, dtype=np.intp)
    edge_i, edge_j = [np.zeros(0, dtype=np.intp)], [np.zeros(0, dtype=np.intp)]
    for k in range(len(geo.rings)):
        occ = np.arange(geo.offset[k], geo.offset[k + 1])
        node = border.occ_node[occ]
        if len(occ) < _BIG_RING or border.pinch_nodes[node].any():
            continue
        if _inside_by_margin(border, occ):
            ring[node] = k
            after = np.roll(node, -1)  # each vertex's next one around the ring
            edge_i.append(np.minimum(node, after))
            edge_j.append(np.maximum(node, after))
    return _ConvexRings(ring, np.concatenate(edge_i), np.concatenate(edge_j))


def _inside_by_margin(border: Border, occ: IntArray) -> bool:
    """Tell if from every vertex of a ring its vertices two on lie inside its wedge."""
    p = border.points[border.occ_node[occ]]
    nxt, prv = border.occ_next[occ], border.occ_prev[occ]
    if not border.occ_convex[occ].all():
        return False
    for shift in (-2, 2):
        d = np.roll(p, shift, axis=0) - p
        length = np.hypot(d[:, 0], d[:, 1])
        from_next = (nxt[:, 0] * d[:, 1] - nxt[:, 1] * d[:, 0]) / length
        from_prev = (d[:, 0] * prv[:, 1] - d[:, 1] * prv[:, 0]) / length
        if not (
            np.all(from_next > _CONVEX_MARGIN) and np.all(from_prev > _CONVEX_MARGIN)
        ):
            return False
    return True


def _candidate_pairs_apart(
    border: Border, rings: _ConvexRings
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield the pairs :func:`_candidate_pairs` yields, without enumerating ring pairs.

    Pairs of two vertices of one ring of :func:`_convex_ring_of` other than its edges
    are left out before the screen (it would drop them all); each remaining pair (i < j)
    is screened as there. The blocks come ring by ring, not in row-major order.
    """
    ring = rings.ring
    nodes = np.arange(len(border.points), dtype=np.intp)
    points, wedges = border.points, border.wedges
    found: list[tuple[IntArray, IntArray]] = []
    count = 0
    for k in np.unique(ring).tolist():
        rows = nodes[ring == k]
        cols = nodes if k < 0 else nodes[ring != k]
        for block in _rows_against(points, wedges, rows, cols):
            found.append(block)
            count += len(block[0])
            if count >= _BLOCK_PAIRS:  # handed on in blocks, as _candidate_pairs does
                yield _joined(found)
                found, count = [], 0
    # The rings' own edges, screened like every other pair.
    i, j = rings.edge_i, rings.edge_j
    d = take_rows(points, j) - take_rows(points, i)
    keep = ~leaves_blocked(wedges, i, j, d[:, 0], d[:, 1])
    found.append((i[keep], j[keep]))
    yield _joined(found)


def _joined(blocks: list[tuple[IntArray, IntArray]]) -> tuple[IntArray, IntArray]:
    """Concatenate blocks of pairs (i, j)."""
    return np.concatenate([b[0] for b in blocks]), np.concatenate(
        [b[1] for b in blocks]
    )


def _rows_against(
    points: FloatArray, wedges: _Wedges, rows: IntArray, cols: IntArray
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield the pairs (r, c), r in ``rows``, c in ``cols``, r < c, that pass the screen.

    Both ascending; in blocks of about ``_SCREEN_ROWS_PAIRS`` screened pairs, as
    :func:`_candidate_pairs` screens them (:func:`leaves_blocked`, compiled).
    """
    from planners.kernels import screened_pairs  # noqa: PLC0415 - numba only where graphs are built

    arrays = (wedges.nxt, wedges.prv, wedges.narrow)
    k = 0
    while k < len(rows):
        first = int(np.searchsorted(cols, rows[k], side="right"))
        width = max(len(cols) - first, 1)
        r1 = min(len(rows), k + max(1, _SCREEN_ROWS_PAIRS // width))
        yield screened_pairs(rows[k:r1], cols, points, arrays, ANGLE_TOL, False)
        k = r1


def _visibility(
    cspace: ConfigurationSpace, border: Border, q: _Query
) -> tuple[IntArray, IntArray]:
    """Return the pairs (i < j, row-major) of the query's nodes that see each other."""
    if cspace.known(vertex_visibility) is None:
        _cold_sights(cspace, border, q)
    base = cspace.derive(vertex_visibility)
    n, total = base.n, len(q.points)
    if total == n:
        return base.i, base.j
    # The new nodes' rows: each against every border vertex (kept per point on the
    # configuration space), then start against goal when both are new.
    found_i, found_j = [base.i], [base.j]
    for node in range(n, total):
        rows = _point_rows(cspace, border, q, node)
        found_i.append(rows)
        found_j.append(np.full(len(rows), node, dtype=np.intp))
    if total == n + 2 and _ends_see_each_other(cspace, border, q):
        found_i.append(np.array([n]))
        found_j.append(np.array([n + 1]))
    # The border pairs are in row-major order already: merge the few new ones in.
    i, j = np.concatenate(found_i[1:]), np.concatenate(found_j[1:])
    order = np.lexsort((j, i))
    i, j = i[order], j[order]
    base_key = base.i.astype(np.int64) * total + base.j
    at = np.searchsorted(base_key, i.astype(np.int64) * total + j)
    return np.insert(base.i, at, i), np.insert(base.j, at, j)


def _cold_sights(cspace: ConfigurationSpace, border: Border, q: _Query) -> None:
    """Derive the vertex visibility and the new nodes' rows together, in one exact test.

    A cold build (a fresh configuration space, a new start and goal) needs the pairs of
    border vertices, each new node's row and the start-goal pair. Tested apart, the rows'
    few hundred segments pay the exact test's fixed costs again (a march, a cover table,
    a point-in-polygon call each); here they join the border pairs' last block. The
    candidates are screened as :func:`_point_rows` and :func:`_ends_see_each_other`
    screen them, each segment's answer is the exact test's whatever it is tested with,
    so what is kept (:meth:`ConfigurationSpace.adopt`, :class:`_PointSights`) is what
    those would compute. Nothing is done when a start or goal sits on a border vertex
    (its row is not kept, :func:`_point_rows`), nothing is new or there is no border.
    """
    n, total = len(border.points), len(q.points)
    if total == n or not len(border.edge_a) or not np.all(q.node[:n] >= 0):
        return
    store = cspace.derive(point_sights)
    wedges = _query_wedges(border, q)
    vertices = np.arange(n, dtype=np.intp)
    rows: list[tuple[tuple[float, float], IntArray]] = []
    extra_i, extra_j = [np.zeros(0, dtype=np.intp)], [np.zeros(0, dtype=np.intp)]
    for node in range(n, total):
        point = _point_of(q, node)
        if store.get(point) is not None:
            continue
        ends = np.full(n, node, dtype=np.intp)
        d = take_rows(q.points, ends) - take_rows(q.points, vertices)
        keep = ~leaves_blocked(wedges, vertices, ends, d[:, 0], d[:, 1])
        rows.append((point, vertices[keep]))
        extra_i.append(vertices[keep])
        extra_j.append(ends[keep])
    ends_pair = None
    if total == n + 2:
        a, b = _point_of(q, n), _point_of(q, n + 1)
        if store.pair(a, b) is None:
            ends_pair = (a, b)
            extra_i.append(np.array([n], dtype=np.intp))
            extra_j.append(np.array([n + 1], dtype=np.intp))
    sight, free = _sights(
        cspace, border, q.points, np.concatenate(extra_i), np.concatenate(extra_j)
    )
    cspace.adopt(vertex_visibility, sight)
    at = 0
    for point, candidates in rows:
        store.put(point, candidates[free[at : at + len(candidates)]])
        at += len(candidates)
    if ends_pair is not None:
        store.put_pair(*ends_pair, bool(free[at]))


class _PointSights:
    """Which border vertices each of the last few query points sees, on one space.

    Start and goal are no border vertices; the vertices each sees depend on the point
    and the configuration space alone (the exact segment test decides), so they are
    kept on the configuration space (:meth:`ConfigurationSpace.derive`) for the next
    query with the same point -- the SVG after the VG, the next obstacle drag, which
    carries them over (:mod:`planners.visibility.incremental`). Only the last
    :attr:`KEPT` points are kept, so dragging the start does not fill memory.
    """

    KEPT = 8

    def __init__(self) -> None:
        self._rows: OrderedDict[tuple[float, float], IntArray] = OrderedDict()
        self._pairs: OrderedDict[tuple[tuple[float, float], ...], bool] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, point: tuple[float, float]) -> IntArray | None:
        """Return the vertices ``point`` sees (ascending), or None if not kept."""
        with self._lock:
            rows = self._rows.get(point)
            if rows is not None:
                self._rows.move_to_end(point)
            return rows

    def put(self, point: tuple[float, float], rows: IntArray) -> None:
        """Keep ``rows`` (ascending border vertex ids) as what ``point`` sees."""
        rows.flags.writeable = False
        with self._lock:
            self._rows[point] = rows
            self._rows.move_to_end(point)
            while len(self._rows) > self.KEPT:
                self._rows.popitem(last=False)

    def items(self) -> list[tuple[tuple[float, float], IntArray]]:
        """Return every kept (point, rows), oldest first."""
        with self._lock:
            return list(self._rows.items())

    def pair(self, a: tuple[float, float], b: tuple[float, float]) -> bool | None:
        """Return whether the segment a -> b (start to goal) is free, or None."""
        with self._lock:
            return self._pairs.get((a, b))

    def put_pair(
        self, a: tuple[float, float], b: tuple[float, float], free: bool
    ) -> None:
        """Keep whether the segment a -> b is free."""
        with self._lock:
            self._pairs[a, b] = free
            self._pairs.move_to_end((a, b))
            while len(self._pairs) > self.KEPT:
                self._pairs.popitem(last=False)

    def pair_items(self) -> list[tuple[tuple[tuple[float, float], ...], bool]]:
        """Return every kept ((a, b), free), oldest first."""
        with self._lock:
            return list(self._pairs.items())


def point_sights(_cspace: ConfigurationSpace) -> _PointSights:
    """Make the configuration space's store of what query points see (empty)."""
    return _PointSights()


def _point_rows(
    cspace: ConfigurationSpace, border: Border, q: _Query, node: int
) -> IntArray:
    """Return the border vertices that the query's new node ``node`` sees, ascending.

    Kept per point on the configuration space when no start or goal sits on a border
    vertex (then the wedges screened are the border's own, as the store assumes).
    """
    n = len(border.points)
    point = (float(q.points[node, 0]), float(q.points[node, 1]))
    plain = bool(np.all(q.node[:n] >= 0))
    store = cspace.derive(point_sights)
    rows = store.get(point) if plain else None
    if rows is None:
        vertices = np.arange(n, dtype=np.intp)
        ends = np.full(n, node, dtype=np.intp)
        d = take_rows(q.points, ends) - take_rows(q.points, vertices)
        keep = ~leaves_blocked(
            _query_wedges(border, q), vertices, ends, d[:, 0], d[:, 1]
        )
        vertices = vertices[keep]
        ok = exact_free(
            cspace,
            border,
            take_rows(q.points, vertices),
            np.broadcast_to(q.points[node], (len(vertices), 2)),
        )
        rows = vertices[ok]
        if plain:
            store.put(point, rows)
    return rows


def _ends_see_each_other(cspace: ConfigurationSpace, border: Border, q: _Query) -> bool:
    """Tell if the start and the goal see each other, both new nodes (n and n + 1).

    Kept on the configuration space like the points' rows (:class:`_PointSights`).
    """
    n = len(border.points)
    a = (float(q.points[n, 0]), float(q.points[n, 1]))
    b = (float(q.points[n + 1, 0]), float(q.points[n + 1, 1]))
    store = cspace.derive(point_sights)
    free = store.pair(a, b)
    if free is None:
        free = bool(_visible(cspace, border, q, np.array([n]), np.array([n + 1]))[0])
        store.put_pair(a, b, free)
    return free


def _pairs_visible(
    cspace: ConfigurationSpace, border: Border, q: _Query, i: IntArray, j: IntArray
) -> BoolArray:
    """Tell which node pairs (i, j) see each other, reusing what is already known.

    Pairs of border vertices are read from the vertex visibility when this configuration
    space already has it (the VG was built on it), pairs of a vertex and the start or
    goal from what that point sees when it is kept (:class:`_PointSights`); the rest are
    tested.
    """
    base = cspace.known(vertex_visibility)
    if base is None:
        return _visible(cspace, border, q, i, j)
    n = base.n
    read = (i < n) & (j < n)
    ok = np.empty(len(i), dtype=bool)
    ok[read] = base.sees(i[read], j[read])
    for node in range(n, len(q.points)):
        rows = _known_rows(cspace, q, node, n)
        if rows is not None:
            at = (j == node) & (i < n)
            ok[at] = rows[i[at]]
            read |= at
    ends = (i == n) & (j == n + 1)
    if ends.any() and len(q.points) == n + 2:
        ok[ends] = _ends_see_each_other(cspace, border, q)
        read |= ends
    test = np.flatnonzero(~read)
    ok[test] = _visible(cspace, border, q, i[test], j[test])
    return ok


def _known_rows(
    cspace: ConfigurationSpace, q: _Query, node: int, n: int
) -> BoolArray | None:
    """Per border vertex, whether the new node ``node`` sees it, if that is kept."""
    store = cspace.known(point_sights)
    if store is None or not np.all(q.node[:n] >= 0):
        return None
    rows = store.get((float(q.points[node, 0]), float(q.points[node, 1])))
    if rows is None:
        return None
    sees = np.zeros(n, dtype=bool)
    sees[rows] = True
    return sees


def simplified_visibility_graph(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> nx.Graph:
    """Build the simplified visibility graph of section 9.5 (the tangent segments).

    A segment is kept when it is visible and, at each end that is an obstacle vertex,
    the line through it does not enter the blocked region next to that vertex (so the
    vertex is convex and the line is tangent there). Vertices where two obstacles touch
    keep all their visible segments. See the module docstring for how this realises the
    chapter's procedure.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> g = simplified_visibility_graph(space, (-1, 0.5), (2, 0.5))
    >>> g.number_of_nodes(), g.number_of_edges()
    (6, 8)
    """
    return _svg_arrays(cspace, start, goal).to_networkx()


def _svg_arrays(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> GraphArrays:
    return _svg_build(cspace, start, goal)[0]


def svg_reasons(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> tuple[GraphArrays, tuple[str, ...]]:
    """Build the SVG as :func:`plan_visibility` does and say why each node may have edges.

    The builder keeps a segment when both ends may carry one and the line through it is
    tangent at each obstacle end. The second value names, per node of the graph's
    ``points``, why it may carry segments: ``"start"``, ``"goal"``, ``"convex"`` (a convex
    vertex: a path can wrap around it) or ``"pinch"`` (obstacles touch there: every
    visible segment is kept); ``"reflex"`` for the rest (they carry none). This is what
    :func:`planners.explain_svg` tags with the chapter's rules.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> arrays, why = svg_reasons(space, (-1, 0.5), (2, 0.5))
    >>> arrays.edges, why
    (8, ('convex', 'convex', 'convex', 'convex', 'start', 'goal'))
    """
    arrays, border, q = _svg_build(cspace, start, goal)
    return arrays, _node_reasons(border, q)


def svg_node_reasons(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> tuple[FloatArray, tuple[str, ...]]:
    """Return the SVG's node points and why each may carry segments, without building it.

    The second value of :func:`svg_reasons`, from the border's flags the builder reads:
    for a caller that has the graph already (the planner's result), so the SVG of a big
    scene is not built a second time to explain it. The points come first, to be
    checked against the graph's.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> _, why = svg_node_reasons(space, (-1, 0.5), (2, 0.5))
    >>> why == svg_reasons(space, (-1, 0.5), (2, 0.5))[1]
    True
    """
    border, q = _query(cspace, start, goal)
    return q.points, _node_reasons(border, q)


def _node_reasons(border: Border, q: _Query) -> tuple[str, ...]:
    """Per query node: start, goal, pinch, convex or reflex (:func:`svg_reasons`)."""
    convex = np.append(border.convex_nodes, False)
    pinch = np.append(border.pinch_nodes, False)
    why = []
    for n, node in enumerate(q.node.tolist()):
        if node < 0:
            why.append("start" if n == q.start else "goal")
        elif pinch[node]:
            why.append("pinch")
        else:
            why.append("convex" if convex[node] else "reflex")
    return tuple(why)


def _svg_build(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> tuple[GraphArrays, Border, _Query]:
    border, q = _query(cspace, start, goal)
    # Index -1 (start, goal) reads the appended False.
    convex = np.append(border.convex_nodes, False)
    pinch = np.append(border.pinch_nodes, False)
    candidate = np.flatnonzero((q.node < 0) | convex[q.node] | pinch[q.node])
    # Tangent at both ends: the segment's extension beyond an obstacle vertex does not
    # enter the blocked wedge there. Where obstacles touch at a vertex (a pinch), the path
    # may bend around one obstacle while the extension points into the other, so no
    # per-segment condition holds there (no wedge) and every visible segment is kept.
    wedges = _query_wedges(border, q)
    known = cspace.known(vertex_visibility)
    found_i, found_j = [np.zeros(0, dtype=np.intp)], [np.zeros(0, dtype=np.intp)]
    if known is None:
        blocks = _candidate_pairs(q.points, wedges, candidate, tangent=True)
    else:
        # The VG's visible pairs kept when tangent: seen already, so not looked up.
        i, j = _tangents_of_known(known, q, wedges, candidate)
        found_i.append(i)
        found_j.append(j)
        blocks = _tangent_rows(known, q, wedges, candidate)
    for i, j in blocks:
        ok = _pairs_visible(cspace, border, q, i, j)
        found_i.append(i[ok])
        found_j.append(j[ok])
    i, j = np.concatenate(found_i), np.concatenate(found_j)
    keys = i.astype(np.int64) * len(q.points) + j
    order = np.argsort(keys, kind="stable")  # row-major, as lexsort
    # Reflex vertices cannot be on a shortest path: leave them out of the picture.
    return _graph_arrays(q, i[order], j[order], drop_isolated=True), border, q


def _tangents_of_known(
    known: Sight, q: _Query, wedges: _Wedges, candidate: IntArray
) -> tuple[IntArray, IntArray]:
    """Return the visible pairs of border vertices the SVG keeps, the VG's known.

    The pairs between candidates that are tangent at both ends, in the VG's order: work
    in proportion to the VG's edges, not n^2, in one compiled pass
    (:func:`planners.kernels.tangent_pairs`, the arithmetic of :func:`_not_tangent`).
    """
    from planners.kernels import tangent_pairs  # noqa: PLC0415 - numba only where graphs are built

    is_candidate = np.zeros(len(q.points), dtype=bool)
    is_candidate[candidate] = True
    sides = (wedges.nxt, wedges.prv)
    return tangent_pairs(known.i, known.j, is_candidate, q.points, sides, ANGLE_TOL)


def _tangent_rows(
    known: Sight, q: _Query, wedges: _Wedges, candidate: IntArray
) -> Iterator[tuple[IntArray, IntArray]]:
    """Yield each new node's (start's, goal's) tangent pairs with the candidates before it."""
    for new in range(known.n, len(q.points)):
        before = candidate[candidate < new]
        rows = np.full(len(before), new, dtype=np.intp)
        d = take_rows(q.points, rows) - take_rows(q.points, before)
        yield _tangent_only(wedges, before, rows, d)


def _tangent_only(
    wedges: _Wedges, i: IntArray, j: IntArray, d: FloatArray
) -> tuple[IntArray, IntArray]:
    keep = ~_not_tangent(wedges, i, j, d[:, 0], d[:, 1])
    return i[keep], j[keep]


def shortest_path(
    graph: nx.Graph, start: npt.ArrayLike, goal: npt.ArrayLike
) -> tuple[FloatArray, float] | None:
    """Return the shortest (path, length) from start to goal in ``graph``, or None.

    A* with the straight-line distance as heuristic (admissible, so the path is optimal).
    """
    s = _node_key(graph, start, "start")
    g = _node_key(graph, goal, "goal")
    if s == g:
        return np.asarray([s], dtype=np.float64), 0.0
    try:
        nodes = nx.astar_path(graph, s, g, heuristic=math.dist, weight="weight")
    except nx.NetworkXNoPath:
        return None
    path = np.asarray(nodes, dtype=np.float64)
    return path, float(np.hypot(*np.diff(path, axis=0).T).sum())


def _node_key(graph: nx.Graph, point: npt.ArrayLike, kind: str) -> tuple[float, float]:
    for node, data in graph.nodes(data=True):
        if data.get("kind") == kind:
            return node
    x, y = np.asarray(point, dtype=np.float64)
    return (float(x), float(y))


def plan_visibility(
    cspace: ConfigurationSpace,
    start: npt.ArrayLike,
    goal: npt.ArrayLike,
    *,
    simplified: bool = False,
) -> VisibilityResult:
    """Build the VG (or SVG) and search it for the shortest path.

    Start and goal must be free (the caller checks and reports ``invalid``).

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), 0.0)
    >>> result = plan_visibility(space, (-1, 1), (3, 1))
    >>> result.status, round(result.length, 6)  # around a corner: 2 * sqrt(2) + 2
    ('ok', 4.828427)
    """
    start = np.asarray(start, dtype=np.float64)
    goal = np.asarray(goal, dtype=np.float64)
    build = _svg_arrays if simplified else _vg_arrays
    graph = build(cspace, start, goal)
    name = "svg" if simplified else "vg"
    if math.dist(start, goal) <= cspace.eps:
        # Already there (the graph merged the two into one node).
        path = (
            start[None, :] if np.array_equal(start, goal) else np.stack([start, goal])
        )
        return VisibilityResult(
            name, "ok", path, math.dist(start, goal), graph, None, cspace
        )
    found = graph.shortest_path()
    if found is None:
        return VisibilityResult(
            name,
            "unreachable",
            np.zeros((0, 2)),
            None,
            graph,
            _unreachable_reason(cspace, start, goal),
            cspace,
        )
    path, length = found
    return VisibilityResult(name, "ok", path, length, graph, None, cspace)


def _unreachable_reason(
    cspace: ConfigurationSpace, start: FloatArray, goal: FloatArray
) -> str:
    """Say which obstacles cut the goal off from the start."""
    s, g = shapely.Point(start), shapely.Point(goal)
    for label, p in (("goal", g), ("start", s)):
        for merged in cspace.merged.geoms:
            outline = shapely.Polygon(merged.exterior)
            if outline.buffer(-cspace.eps).contains(p) and not outline.buffer(
                -cspace.eps
            ).contains(s if label == "goal" else g):
                names = [
                    f"{k + 1}"
                    for k, e in enumerate(cspace.expanded)
                    if e.intersects(merged)
                ]
                which = (
                    "obstacle " + names[0]
                    if len(names) == 1
                    else "obstacles " + ", ".join(names)
                )
                return f"the {label} is enclosed by {which} (merged after expansion)"
    return "start and goal lie in separate parts of the free space"
