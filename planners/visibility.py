"""Visibility graphs (section 9.4) and simplified visibility graphs (section 9.5).

Both graphs live in the configuration space of :mod:`planners.expansion`: the robot is a
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
vertex, start or goal on an edge, and obstacles touching at a point.

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
    "svg_reasons",
    "visibility_graph",
]

import dataclasses
import functools
import heapq
import itertools
import math

import networkx as nx
import numpy as np
import numpy.typing as npt
import shapely

from planners.border import ring_geometry
from planners.expansion import ConfigurationSpace
from planners.geometry import cross, unit_rows

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]

# Segment/edge pairs tested at once; bounds memory to a few hundred MB in the worst case.
_CHUNK_PAIRS = 2_000_000
# Below this many segment x edge pairs, a bounding-box matrix beats a spatial index.
_DENSE_LIMIT = 3_000_000
# Directions closer than this (as a sine) to an edge count as running along it.
_ANGLE_TOL = 1e-12


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
        return np.hypot(*(self.points[self.j] - self.points[self.i]).T)

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
        return np.stack([self.points[self.i], self.points[self.j]], axis=1)

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

    def shortest_path(
        self, settled: list[tuple[int, int, float]] | None = None
    ) -> tuple[FloatArray, float] | None:
        """Return the shortest (path, length) from start to goal, or None.

        A* with the straight-line distance as heuristic (admissible, so the path is
        optimal). It is :func:`networkx.astar_path` step by step -- the same queue
        order, tie-breaking and floating-point sums -- on index lists instead of a
        graph, so it finds the very path :func:`shortest_path` finds in
        :meth:`to_networkx` (a property test holds the two together).

        ``settled``, when given, receives (node, parent, cost) for each node the search
        settles, in order (the parent is -1 for the start; the goal comes last when
        reached): what an explanation of the search shows (section 9.4).
        """
        s, g = self.start, self.goal
        record = settled.append if settled is not None else _ignore
        if s == g:
            record((s, -1, 0.0))
            return self.points[[s]].copy(), 0.0
        keys = list(map(tuple, self.points.tolist()))
        # Neighbours in ascending order, as the graph's adjacency has them (its edges
        # are added in row-major order).
        neighbours: list[list[tuple[int, float]]] = [[] for _ in keys]
        for u, v, w in zip(
            self.i.tolist(), self.j.tolist(), self.weight.tolist(), strict=True
        ):
            neighbours[u].append((v, w))
            neighbours[v].append((u, w))
        target = keys[g]
        count = itertools.count()
        queue = [(0.0, next(count), s, 0.0, -1)]
        enqueued: dict[int, tuple[float, float]] = {}  # node -> (cost, heuristic)
        explored: dict[int, int] = {}  # node -> parent (-1 for the start)
        while queue:
            _, _, node, cost, parent = heapq.heappop(queue)
            if node == g:
                record((node, parent, cost))
                order = [node, parent]
                while order[-1] != s:
                    order.append(explored[order[-1]])
                path = self.points[order[::-1]]
                return path, float(np.hypot(*np.diff(path, axis=0).T).sum())
            if node in explored:
                if explored[node] < 0:  # the start: never worth visiting again
                    continue
                if enqueued[node][0] < cost:  # a shorter way here is already known
                    continue
            explored[node] = parent
            record((node, parent, cost))
            for other, w in neighbours[node]:
                new = cost + w
                if other in enqueued:
                    known, h = enqueued[other]
                    if known <= new:
                        continue
                else:
                    h = math.dist(keys[other], target)
                enqueued[other] = new, h
                heapq.heappush(queue, (new + h, next(count), other, new, node))
        return None


def _ignore(_item: object) -> None:
    """Do nothing (a search nobody records)."""


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
class _Border:
    """The free space's border as flat arrays, built once per configuration space."""

    points: FloatArray  # (n, 2) unique vertices
    edge_a: FloatArray  # (m, 2) edge starts; blocked space on the left of a -> b
    edge_b: FloatArray  # (m, 2)
    occ_node: IntArray  # (o,) node of each ring vertex occurrence
    occ_next: FloatArray  # (o, 2) unit direction to the next ring vertex
    occ_prev: FloatArray  # (o, 2) unit direction to the previous ring vertex
    occ_convex: BoolArray  # (o,) blocked wedge narrower than pi: a path can wrap here

    @functools.cached_property
    def edge_tree(self) -> shapely.STRtree:
        lines = np.asarray(
            shapely.linestrings(np.stack([self.edge_a, self.edge_b], axis=1))
        )
        return shapely.STRtree(lines)

    @functools.cached_property
    def ex(self) -> FloatArray:
        return np.ascontiguousarray(self.edge_a[:, 0])

    @functools.cached_property
    def ey(self) -> FloatArray:
        return np.ascontiguousarray(self.edge_a[:, 1])

    @functools.cached_property
    def edx(self) -> FloatArray:
        return np.ascontiguousarray(self.edge_b[:, 0] - self.edge_a[:, 0])

    @functools.cached_property
    def edy(self) -> FloatArray:
        return np.ascontiguousarray(self.edge_b[:, 1] - self.edge_a[:, 1])

    @functools.cached_property
    def elength(self) -> FloatArray:
        return np.hypot(self.edx, self.edy)

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
    def extra_occurrences(self) -> IntArray:
        """Occurrences of vertices that appear more than once (obstacles touching there)."""
        seen = np.zeros(len(self.points), dtype=bool)
        extra = []
        for o, node in enumerate(self.occ_node):
            if seen[node]:
                extra.append(o)
            seen[node] = True
        return np.asarray(extra, dtype=np.intp)

    @functools.cached_property
    def touching_sectors(self) -> dict[int, tuple[FloatArray, BoolArray]]:
        """Sorted edge directions at each vertex that appears in several rings.

        Where obstacles touch at a vertex, or a hole touches the outer ring, no single
        wedge describes the blocked directions; the sectors between all the edges do.
        """
        sectors = {}
        for vertex in np.unique(self.occ_node[self.extra_occurrences]):
            occ = np.flatnonzero(self.occ_node == vertex)
            dirs = np.vstack([self.occ_next[occ], self.occ_prev[occ]])
            opens = np.concatenate(
                [np.ones(len(occ), dtype=bool), np.zeros(len(occ), dtype=bool)]
            )
            angles = np.arctan2(dirs[:, 1], dirs[:, 0]) % (2 * np.pi)
            order = np.argsort(angles)
            sectors[int(vertex)] = (angles[order], opens[order])
        return sectors

    @functools.cached_property
    def wedge_angles(self) -> tuple[FloatArray, FloatArray, BoolArray]:
        """Per vertex: where its blocked wedge starts [rad], its width, one ring only.

        The wedge turns counter-clockwise from the direction of the next ring vertex;
        the last array is False where rings touch (the wedge alone does not tell).
        """
        occ = self.first_occurrence
        start = np.arctan2(self.occ_next[occ, 1], self.occ_next[occ, 0])
        end = np.arctan2(self.occ_prev[occ, 1], self.occ_prev[occ, 0])
        single = np.ones(len(self.points), dtype=bool)
        single[self.occ_node[self.extra_occurrences]] = False
        return start, (end - start) % (2.0 * np.pi), single

    @functools.cached_property
    def convex_nodes(self) -> BoolArray:
        convex = np.zeros(len(self.points), dtype=bool)
        convex[self.occ_node[self.occ_convex]] = True
        return convex

    @functools.cached_property
    def pinch_nodes(self) -> BoolArray:
        """Vertices where obstacles touch: a path through them may bend either way."""
        pinch = np.zeros(len(self.points), dtype=bool)
        pinch[self.occ_node[self.extra_occurrences]] = True
        return pinch


def _build_border(cspace: ConfigurationSpace) -> _Border:
    # The border model every planner reads, with every vertex as expanded (module
    # docstring of planners.border): its edges, and at each vertex the directions to
    # the next and the previous vertex of its ring.
    geo = ring_geometry(cspace, cleaned=False)
    if not geo.rings:
        empty = np.zeros((0, 2))
        none = np.zeros(0, dtype=np.intp)
        return _Border(empty, empty, empty, none, empty, empty, np.zeros(0, dtype=bool))
    # Vertices shared by several rings (obstacles touching at a point) become one node.
    points, occ_node = np.unique(geo.start, axis=0, return_inverse=True)
    occ_node = occ_node.reshape(-1)
    to_next = unit_rows(geo.step)
    to_prev = unit_rows(geo.start[geo.prev_edge] - geo.start)
    # Blocked space is on the left of each ring: the blocked wedge at a vertex turns
    # counter-clockwise from the next edge to the previous one.
    convex = cross(to_next, to_prev) > _ANGLE_TOL
    return _Border(points, geo.start, geo.end, occ_node, to_next, to_prev, convex)


def _strictly_inside_wedge(
    nxt: FloatArray, prv: FloatArray, d: FloatArray
) -> BoolArray:
    """Tell if unit direction ``d`` points strictly into the blocked wedge at a vertex."""
    narrow = cross(nxt, prv) > _ANGLE_TOL
    inside_narrow = (cross(nxt, d) > _ANGLE_TOL) & (cross(d, prv) > _ANGLE_TOL)
    # A wedge of pi or more: inside unless in the closed free wedge from prv to nxt.
    in_free = (cross(prv, d) >= -_ANGLE_TOL) & (cross(d, nxt) >= -_ANGLE_TOL)
    return np.where(narrow, inside_narrow, ~in_free)


def _into_blocked(border: _Border, node: IntArray, d: FloatArray) -> BoolArray:
    """Tell, for each (node, unit direction), if stepping from the vertex along d enters blocked space."""
    result = np.zeros(len(node), dtype=bool)
    is_vertex = node >= 0
    if not is_vertex.any():
        return result
    occ = border.first_occurrence[node[is_vertex]]
    result[is_vertex] = _strictly_inside_wedge(
        border.occ_next[occ], border.occ_prev[occ], d[is_vertex]
    )
    for vertex, (angles, opens_blocked) in border.touching_sectors.items():
        hit = np.flatnonzero(node == vertex)
        if len(hit):
            result[hit] = _in_blocked_sector(angles, opens_blocked, d[hit])
    return result


def _in_blocked_sector(
    angles: FloatArray, opens_blocked: BoolArray, d: FloatArray
) -> BoolArray:
    """Classify directions at a vertex where the border touches itself.

    ``angles`` are the sorted directions of every border edge at the vertex; the sector
    from ``angles[k]`` counter-clockwise to the next one is blocked iff the edge at
    ``angles[k]`` has blocked space on its counter-clockwise side (an outgoing edge).
    A direction along an edge runs on the border, which is free.
    """
    a = np.arctan2(d[:, 1], d[:, 0]) % (2 * np.pi)
    k = np.searchsorted(angles, a, side="right") - 1  # -1 wraps to the last sector
    gap = np.minimum(
        np.abs(a[:, None] - angles[None, :]),
        2 * np.pi - np.abs(a[:, None] - angles[None, :]),
    )
    on_edge = gap.min(axis=1) <= _ANGLE_TOL
    return opens_blocked[k] & ~on_edge


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
    >>> from planners.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> segments_free(space, [[-1, 0], [-1, -1], [0, 0]], [[2, 0], [2, 2], [1, 1]])
    array([ True, False, False])
    """
    a = np.atleast_2d(np.asarray(a, dtype=np.float64))
    b = np.atleast_2d(np.asarray(b, dtype=np.float64))
    return _segments_free(cspace, cspace.derive(_build_border), a, b)


def _segments_free(
    cspace: ConfigurationSpace, border: _Border, a: FloatArray, b: FloatArray
) -> BoolArray:
    s, m = len(a), len(border.edge_a)
    if s == 0:
        return np.zeros(0, dtype=bool)
    if m == 0:
        # No obstacles and no walls: only the (unbounded) plane.
        return np.ones(s, dtype=bool)
    free = np.ones(s, dtype=bool)
    touch_seg: list[IntArray] = []
    touch_t: list[FloatArray] = []
    starts = _runs_of_equal_starts(a)
    if s * m <= _DENSE_LIMIT:
        chunks = [_overlapping_boxes(a, b, border, cspace.eps)]
    elif len(starts) - 1 <= s // 4:
        # Many segments share each start (a visibility graph): sweep angles per start.
        chunks = _angular_chunks(border, a, b, starts, cspace.eps)
    else:
        chunks = _index_chunks(border, a, b)
    segs = _Segments.of(a, b)
    for seg, edge in chunks:
        blocked, t_seg, t_val = _crossings(segs, border, seg, edge, cspace.eps)
        free[blocked] = False
        touch_seg.append(t_seg)
        touch_t.append(t_val)
    survivors = np.flatnonzero(free)
    if len(survivors) == 0:
        return free
    # Each survivor is cut at the border vertices lying on it; every piece is free,
    # blocked or along an edge, and its middle tells which.
    t_seg = np.concatenate(touch_seg) if touch_seg else np.zeros(0, dtype=np.intp)
    t_val = np.concatenate(touch_t) if touch_t else np.zeros(0)
    keep = free[t_seg]
    t_seg, t_val = t_seg[keep], t_val[keep]
    seg_ids = np.concatenate([survivors, survivors, t_seg])
    ts = np.concatenate([np.zeros(len(survivors)), np.ones(len(survivors)), t_val])
    order = np.lexsort((ts, seg_ids))
    seg_ids, ts = seg_ids[order], ts[order]
    same = seg_ids[1:] == seg_ids[:-1]
    piece_seg = seg_ids[:-1][same]
    mid_t = 0.5 * (ts[:-1][same] + ts[1:][same])
    mids = a[piece_seg] + mid_t[:, None] * (b[piece_seg] - a[piece_seg])
    blocked_piece = cspace.contains_blocked(mids)
    free[piece_seg[blocked_piece]] = False
    return free


def _overlapping_boxes(
    a: FloatArray, b: FloatArray, border: _Border, eps: float
) -> tuple[IntArray, IntArray]:
    """(segment, edge) index pairs whose bounding boxes overlap, from a dense matrix."""
    lo, hi = np.minimum(a, b) - eps, np.maximum(a, b) + eps
    elo, ehi = border.edge_boxes
    overlap = (lo[:, None, 0] <= ehi[None, :, 0]) & (hi[:, None, 0] >= elo[None, :, 0])
    overlap &= (lo[:, None, 1] <= ehi[None, :, 1]) & (hi[:, None, 1] >= elo[None, :, 1])
    seg, edge = np.nonzero(overlap)
    return seg.astype(np.intp), edge.astype(np.intp)


def _runs_of_equal_starts(a: FloatArray) -> IntArray:
    """Boundaries of the runs of consecutive segments that start at the same point."""
    change = np.flatnonzero(np.any(a[1:] != a[:-1], axis=1)) + 1
    return np.concatenate([[0], change, [len(a)]]).astype(np.intp)


def _angular_chunks(  # noqa: PLR0915 - one vectorised pass over (starts x edges) arrays
    border: _Border, a: FloatArray, b: FloatArray, starts: IntArray, eps: float
):
    """Yield (segment, edge) pairs where the edge spans the segment's direction.

    Seen from a start point p, a border edge covers an arc of directions. Only a
    segment from p whose direction lies in that arc can cross the edge or pass
    through its first vertex, so with the segments' directions sorted, each edge meets
    a contiguous range of them (found by binary search). The arcs are widened by the
    angle that ``eps`` subtends, so every pair the exact test could flag is produced.
    Pairs whose segment has both ends strictly on one side of the edge's line are
    dropped: such a segment can neither cross the edge nor pass through its vertex.

    All starts are handled at once: the segments are sorted by the key
    ``start_index * 8 + angle`` (angles shifted into [0, 2 pi]), so one binary search
    serves a whole batch of starts.
    """
    m = len(border.ex)
    two_pi = 2.0 * np.pi
    n_src = len(starts) - 1
    src_of_seg = np.repeat(np.arange(n_src), np.diff(starts))
    tvx, tvy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    key = src_of_seg * 8.0 + (np.arctan2(tvy, tvx) + np.pi)
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    sources = a[starts[:-1]]
    # Line of each edge: side(x) = normal . x - offset, |side| / length = distance.
    nx_, ny_ = -border.edy, border.edx
    offset = nx_ * border.ex + ny_ * border.ey
    on_line = eps * border.elength
    ex, ey, fx, fy = (
        border.ex,
        border.ey,
        border.ex + border.edx,
        border.ey + border.edy,
    )
    batch = max(1, 200_000 // max(m, 1))
    for b0 in range(0, n_src, batch):
        b1 = min(n_src, b0 + batch)
        px, py = sources[b0:b1, 0:1], sources[b0:b1, 1:2]
        cvx, cvy, dvx, dvy = ex - px, ey - py, fx - px, fy - py  # (B, m)
        rc, rd = np.hypot(cvx, cvy), np.hypot(dvx, dvy)
        ac, ad = np.arctan2(cvy, cvx), np.arctan2(dvy, dvx)
        diff = (ad - ac + np.pi) % two_pi - np.pi
        lo = np.where(diff >= 0, ac, ad)
        span = np.abs(diff)
        # An edge with an end at p, or passing through p, cannot be crossed properly by
        # a segment from p; only its first vertex can lie on one: a single direction.
        through = (rc <= eps) | (rd <= eps)
        through |= (np.abs(cvx * dvy - cvy * dvx) <= eps * (rc + rd)) & (
            cvx * dvx + cvy * dvy < 0
        )
        lo = np.where(through, np.where(rc <= eps, ad, ac), lo)
        span = np.where(through, 0.0, span)
        near = np.minimum(np.where(rc <= eps, rd, rc), np.where(rd <= eps, rc, rd))
        slack = np.minimum(eps / np.maximum(near, eps) + 1e-9, np.pi)
        lo = (lo - slack + np.pi) % two_pi  # shifted into [0, 2 pi)
        hi = lo + span + 2.0 * slack
        base = (np.arange(b0, b1) * 8.0)[:, None]
        first = np.searchsorted(sorted_key, (base + lo).ravel(), side="left")
        last = np.searchsorted(
            sorted_key, (base + np.minimum(hi, two_pi)).ravel(), side="right"
        )
        # Arcs that run past 2 pi continue from 0, that is from the start's first segment
        # (segments are sorted by start, so start k's block begins at starts[k]).
        wraps = np.flatnonzero((hi > two_pi).ravel())
        first2 = np.repeat(starts[b0:b1], m)
        last2 = first2.copy()
        if len(wraps):
            tail = (base + hi - two_pi).ravel()[wraps]
            last2[wraps] = np.searchsorted(sorted_key, tail, side="right")
        side_p = (nx_ * px + ny_ * py - offset).ravel()  # (B * m,)
        for begin, end in ((first, last), (first2, last2)):
            count = np.maximum(end - begin, 0)
            total = int(count.sum())
            if total == 0:
                continue
            offsets = np.repeat(np.cumsum(count) - count, count)
            pair = np.repeat(np.arange(len(count)), count)  # index into the (B, m) grid
            seg = order[np.repeat(begin, count) + (np.arange(total) - offsets)]
            edge = pair % m
            sp, tol = side_p[pair], on_line[edge]
            side_q = nx_[edge] * tvx[seg] + ny_[edge] * tvy[seg] + sp
            keep = ~(((sp > tol) & (side_q > tol)) | ((sp < -tol) & (side_q < -tol)))
            yield seg[keep], edge[keep]


def _index_chunks(border: _Border, a: FloatArray, b: FloatArray):
    """Yield (segment, edge) index pairs whose bounding boxes overlap, in bounded chunks."""
    tree = border.edge_tree
    lines = np.asarray(shapely.linestrings(np.stack([a, b], axis=1)))
    step = max(1, _CHUNK_PAIRS // max(1, min(len(border.edge_a), 400)))
    for lo in range(0, len(a), step):
        seg, edge = tree.query(lines[lo : lo + step])
        yield seg.astype(np.intp) + lo, edge.astype(np.intp)


def _crossings(
    segs: _Segments, border: _Border, seg: IntArray, edge: IntArray, eps: float
) -> tuple[IntArray, IntArray, FloatArray]:
    """Proper crossings and touching vertices for (segment, edge) index pairs.

    Returns the pair indices whose segment is blocked by a proper crossing, and for each
    border vertex (the edge's start) lying inside a segment: the segment and the
    parameter t in (0, 1) where it lies.
    """
    # Plain 1-D arrays: gathers and arithmetic on them are several times faster than on
    # (N, 2) rows, and this loop runs over millions of pairs on large scenes.
    px, py = segs.ax[seg], segs.ay[seg]
    ux, uy, len_pq = segs.dx[seg], segs.dy[seg], segs.length[seg]
    cx, cy = border.ex[edge], border.ey[edge]
    vx, vy, len_cd = border.edx[edge], border.edy[edge], border.elength[edge]
    cpx, cpy = cx - px, cy - py
    oc = ux * cpy - uy * cpx  # side of c from the line p -> q, times |pq|
    w = ux * vy - uy * vx
    od = oc + w  # side of d
    op = cpx * vy - cpy * vx  # side of p from the line c -> d, times |cd|
    oq = op - w  # side of q
    # |cross| / length is the distance to the line; within eps counts as on it.
    tol_pq = eps * len_pq
    tol_cd = eps * len_cd
    split_cd = ((oc > tol_pq) & (od < -tol_pq)) | ((oc < -tol_pq) & (od > tol_pq))
    split_pq = ((op > tol_cd) & (oq < -tol_cd)) | ((op < -tol_cd) & (oq > tol_cd))
    blocked = np.flatnonzero(split_cd & split_pq)
    # Border vertex c on the open segment p -> q.
    near = np.flatnonzero(np.abs(oc) <= tol_pq)
    t = (cpx[near] * ux[near] + cpy[near] * uy[near]) / np.where(
        len_pq[near] > 0, len_pq[near] ** 2, 1.0
    )
    along = t * len_pq[near]
    on = (along > eps) & (along < len_pq[near] - eps)
    return seg[blocked], seg[near[on]], t[on]


@dataclasses.dataclass(frozen=True, eq=False)
class _Segments:
    """Segments as 1-D coordinate arrays (start, direction, length)."""

    ax: FloatArray
    ay: FloatArray
    dx: FloatArray
    dy: FloatArray
    length: FloatArray

    @classmethod
    def of(cls, a: FloatArray, b: FloatArray) -> _Segments:
        d = b - a
        dx, dy = np.ascontiguousarray(d[:, 0]), np.ascontiguousarray(d[:, 1])
        return cls(
            np.ascontiguousarray(a[:, 0]),
            np.ascontiguousarray(a[:, 1]),
            dx,
            dy,
            np.hypot(dx, dy),
        )


# --------------------------------------------------------------------------- graphs


@dataclasses.dataclass(frozen=True, eq=False)
class _Query:
    points: FloatArray  # (n, 2): border vertices, then start and goal if new
    node: IntArray  # (n,) border vertex id, or -1 for start/goal
    start: int
    goal: int


def _query(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> tuple[_Border, _Query]:
    """Return the border and the graph nodes: its vertices plus start and goal."""
    border = cspace.derive(_build_border)
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


def _visible(
    cspace: ConfigurationSpace, border: _Border, q: _Query, i: IntArray, j: IntArray
) -> BoolArray:
    # Cheap first: a segment that leaves a vertex straight into its obstacle is blocked.
    # This only saves work (the exact test below decides), so it is done on angles and
    # skips vertices where rings touch.
    d = q.points[j] - q.points[i]
    theta = np.arctan2(d[:, 1], d[:, 0])
    ok = np.ones(len(i), dtype=bool)
    start_angle, width, single = border.wedge_angles
    for nodes, direction in ((q.node[i], theta), (q.node[j], theta + np.pi)):
        if not len(single):  # no border at all
            break
        at = np.flatnonzero((nodes >= 0) & single[np.maximum(nodes, 0)])
        k = nodes[at]
        rel = (direction[at] - start_angle[k]) % (2.0 * np.pi)
        ok[at[(rel > _ANGLE_TOL) & (rel < width[k] - _ANGLE_TOL)]] = False
    idx = np.flatnonzero(ok)
    ok[idx] = _segments_free(cspace, border, q.points[i[idx]], q.points[j[idx]])
    return ok


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
    >>> from planners.expansion import configuration_space
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
    i, j = np.nonzero(np.triu(_visibility(cspace, border, q), 1))
    return _graph_arrays(q, i, j)


def _vertex_visibility(cspace: ConfigurationSpace) -> BoolArray:
    """Which border vertices see each other: (n, n), symmetric, False on the diagonal.

    It depends on the configuration space alone, so it is derived once per configuration
    space (:meth:`ConfigurationSpace.derive`): while the start or the goal is dragged
    each query only adds its start's and goal's rows, and the SVG of a scene whose VG was
    built reads its vertex pairs from it. Visibility is a function of the two points (the
    exact segment test decides), so the rows of a vertex the start or goal sits on hold
    for them too.
    """
    border = cspace.derive(_build_border)
    n = len(border.points)
    q = _Query(border.points, np.arange(n, dtype=np.intp), -1, -1)
    i, j = np.triu_indices(n, 1)
    ok = _visible(cspace, border, q, i, j)
    vis = np.zeros((n, n), dtype=bool)
    vis[i[ok], j[ok]] = True
    vis |= vis.T
    vis.setflags(write=False)
    return vis


def _visibility(cspace: ConfigurationSpace, border: _Border, q: _Query) -> BoolArray:
    """Which of the query's nodes (border vertices, then start and goal) see each other.

    Returns the (N, N) symmetric matrix.
    """
    base = cspace.derive(_vertex_visibility)
    n, total = len(base), len(q.points)
    vis = np.zeros((total, total), dtype=bool)
    vis[:n, :n] = base
    if total > n:
        # The new nodes' rows: each against every node before it.
        new = np.arange(n, total)
        i = np.concatenate([np.arange(a) for a in new.tolist()])
        j = np.repeat(new, new)
        ok = _visible(cspace, border, q, i, j)
        vis[i[ok], j[ok]] = True
        vis[j[ok], i[ok]] = True
    return vis


def _pairs_visible(
    cspace: ConfigurationSpace, border: _Border, q: _Query, i: IntArray, j: IntArray
) -> BoolArray:
    """Tell which node pairs (i, j) see each other, reusing what is already known.

    Pairs of border vertices are read from the vertex matrix when this configuration
    space already has it (the VG was built on it); the rest are tested.
    """
    base = cspace.known(_vertex_visibility)
    if base is None:
        return _visible(cspace, border, q, i, j)
    n = len(base)
    read = (i < n) & (j < n)
    ok = np.empty(len(i), dtype=bool)
    ok[read] = base[i[read], j[read]]
    test = np.flatnonzero(~read)
    ok[test] = _visible(cspace, border, q, i[test], j[test])
    return ok


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
    >>> from planners.expansion import configuration_space
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
    >>> from planners.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> arrays, why = svg_reasons(space, (-1, 0.5), (2, 0.5))
    >>> arrays.edges, why
    (8, ('convex', 'convex', 'convex', 'convex', 'start', 'goal'))
    """
    arrays, border, q = _svg_build(cspace, start, goal)
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
    return arrays, tuple(why)


def _svg_build(
    cspace: ConfigurationSpace, start: npt.ArrayLike, goal: npt.ArrayLike
) -> tuple[GraphArrays, _Border, _Query]:
    border, q = _query(cspace, start, goal)
    # Index -1 (start, goal) reads the appended False.
    convex = np.append(border.convex_nodes, False)
    pinch = np.append(border.pinch_nodes, False)
    candidate = np.flatnonzero((q.node < 0) | convex[q.node] | pinch[q.node])
    ii, jj = np.triu_indices(len(candidate), 1)
    i, j = candidate[ii], candidate[jj]
    d = unit_rows(q.points[j] - q.points[i])
    # Tangent at both ends: the segment's extension beyond an obstacle vertex does not
    # enter the blocked wedge there. Where obstacles touch at a vertex (a pinch), the path
    # may bend around one obstacle while the extension points into the other, so no
    # per-segment condition holds there and every visible segment is kept.
    tangent = ~(
        (_into_blocked(border, q.node[i], -d) & ~pinch[q.node[i]])
        | (_into_blocked(border, q.node[j], d) & ~pinch[q.node[j]])
    )
    i, j = i[tangent], j[tangent]
    ok = _pairs_visible(cspace, border, q, i, j)
    # Reflex vertices cannot be on a shortest path: leave them out of the picture.
    return _graph_arrays(q, i[ok], j[ok], drop_isolated=True), border, q


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
    >>> from planners.expansion import configuration_space
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
