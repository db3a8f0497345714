"""The visibility graph, vertex by vertex, then its search (section 9.4).

Section 9.4 connects "line segments between all vertices of the expanded polygonal
obstacles, and these vertices and the robot's start and goal locations, provided that the
lines are not intercepted by the obstacles", then searches the graph for the shortest
path. :func:`explain_vg` steps through the same graph the planner built
(:attr:`planners.visibility.VisibilityResult.arrays`): for each vertex in turn, the
segments it sees and those an obstacle blocks, with the edge that blocks each one; then
the nodes in the order the planner's A* search settles them
(:meth:`planners.visibility.GraphArrays.shortest_path`), then the path.

A step is made when it is shown (:class:`planners.explain.Lazy`): one step per node,
each with a segment to every other node, is quadratic in the scene, and a student's
scene of 32 obstacles has 500 nodes. What blocks a segment is found among the border
edges near it (:func:`planners.visibility.sightlines.near_pairs` on a grid of the edges), not
among all of them: one step costs about the work of its own segments.
"""

from __future__ import annotations

__all__ = ["VertexLook", "explain_vg"]

import dataclasses
import functools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import shapely

from planners.api import plan_all
from planners.explain._steps import (
    Explanation,
    Lazy,
    Step,
    as_segments,
    keep_going,
    marks,
    point_mark,
)
from planners.space.border import ring_geometry
from planners.visibility.sightlines import EdgeGrid, edge_grid, near_pairs

if TYPE_CHECKING:
    from planners.registry import PlanOptions
    from planners.scene import Scene
    from planners.space.expansion import ConfigurationSpace
    from planners.visibility import GraphArrays

FloatArray = npt.NDArray[np.float64]

IntArray = npt.NDArray[np.intp]

# Points along a blocked segment tested to find where it first enters an obstacle.
_SAMPLES = 129
_SAMPLES_AT_ONCE = 8
"""Samples of each segment tested at once while looking for its first blocked one."""
_TOUCH = 10.0
"""A segment within this many eps of a border edge touches it."""


@dataclasses.dataclass(frozen=True, eq=False)
class VertexLook:
    """What one node of the VG sees (section 9.4)."""

    node: int
    """Index into the graph's points."""
    name: str
    """``"start"``, ``"goal"`` or ``"vertex 7"``."""
    visible: FloatArray
    """Segments to the nodes it sees, shape (k, 2, 2) [m]."""
    blocked: FloatArray
    """Segments to the nodes it does not see, shape (b, 2, 2) [m]."""
    blockers: FloatArray
    """For each blocked segment, the border edge where it first enters blocked space,
    shape (b, 2, 2) [m]."""


def explain_vg(
    scene: Scene,
    options: PlanOptions | None = None,
    *,
    plans: dict[str, Any] | None = None,
    abandoned: Callable[[], bool] | None = None,
) -> Explanation:
    """Explain the VG of ``scene``: each vertex's lines of sight, then the search.

    Parameters
    ----------
    scene
        The scene.
    options
        Planner settings; None for the defaults.
    plans
        Results of :func:`planners.plan_all` including ``"vg"``, or None to compute.
    abandoned
        Asked while a vertex's step is made (between pieces of 1,024 blocked segments):
        True gives the step up (:class:`~planners.explain.Abandoned` is raised; the
        step is made afresh when it is asked for again).

    Returns
    -------
    Explanation
        One step per node (start, the obstacles' vertices, goal), one per node the search
        settles, and the path, each made when asked for. ``data`` holds the
        :class:`VertexLook` records, in the same order, also made when asked for.

    Examples
    --------
    >>> import planners
    >>> scene = planners.load_scene("static_scenarios/01_two_convex.json")
    >>> vg = planners.explain_vg(scene)
    >>> vg.steps[0].text  # doctest: +ELLIPSIS
    'Section 9.4: from the start, draw a segment to every vertex it sees: ...'
    >>> vg.steps[-1].kind
    'vg:path'
    """
    plans = plans if plans is not None else plan_all(scene, ("vg",), options)
    result = plans["vg"]
    title = "Visibility graph (section 9.4)"
    cspace = plans.get("cspace")
    if result.status == "invalid" or cspace is None:
        reason = getattr(result, "reason", None) or "the scene is not plannable"
        return Explanation(
            "vg", title, (Step("vg:invalid", f"Nothing to build: {reason}."),)
        )
    arrays = result.arrays
    order = _stepping_order(arrays)
    border = _BorderEdges.of(cspace)
    looks = Lazy(
        len(order), lambda k: _look(cspace, border, arrays, order[k], abandoned)
    )
    story = _Story.of(arrays, order)
    count = len(order) + len(story.settled) + 1

    def step(k: int) -> Step:
        if k < len(order):
            return _vertex_step(arrays, looks[k], story.done_before(k))
        if k < count - 1:
            return _search_step(arrays, story, k - len(order))
        return _path_step(arrays, result, story.graph)

    return Explanation("vg", title, Lazy(count, step), data=looks)


def _stepping_order(arrays: GraphArrays) -> list[int]:
    """Start first, then every border vertex in the border's order, then the goal."""
    ends = {arrays.start, arrays.goal}
    middle = [n for n in range(len(arrays.points)) if n not in ends]
    last = [arrays.goal] if arrays.goal != arrays.start else []
    return [arrays.start, *middle, *last]


def _name(arrays: GraphArrays, n: int) -> str:
    kind = arrays.kind(n)
    return kind if kind != "vertex" else f"vertex {n + 1}"


@dataclasses.dataclass(frozen=True, eq=False)
class _Story:
    """What the steps draw besides a node's own lines: the graph and the search."""

    graph: FloatArray
    """The VG's edges as segments (E, 2, 2), in the graph's order [m]."""
    first: IntArray
    """Per edge, the vertex step that draws it first (its earlier end's)."""
    settled: tuple[tuple[int, int, float], ...]
    """(node, parent, cost) in the order the A* search settles them."""

    @classmethod
    def of(cls, arrays: GraphArrays, order: list[int]) -> _Story:
        rank = np.empty(len(arrays.points), dtype=np.intp)
        rank[np.asarray(order, dtype=np.intp)] = np.arange(len(order))
        settled: list[tuple[int, int, float]] = []
        arrays.shortest_path(settled)
        return cls(
            arrays.segments(),
            np.minimum(rank[arrays.i], rank[arrays.j]),
            tuple(settled),
        )

    def done_before(self, k: int) -> FloatArray:
        """Return the edges that the vertex steps before step ``k`` drew, each once."""
        return self.graph[self.first < k]


@dataclasses.dataclass(frozen=True, eq=False)
class _BorderEdges:
    """The border's edges, their grid and their shapes: where blockers are looked for."""

    start: FloatArray
    """First end of each edge, shape (m, 2) [m] (:func:`planners.space.border.ring_geometry`)."""
    end: FloatArray
    """Second end of each edge, shape (m, 2) [m]."""
    grid: EdgeGrid
    """The edges bucketed in cells, within twice the touching distance."""
    eps: float
    """The configuration space's tolerance [m]."""

    @classmethod
    def of(cls, cspace: ConfigurationSpace) -> _BorderEdges:
        geo = ring_geometry(cspace, cleaned=False)
        margin = 2.0 * _TOUCH * cspace.eps
        grid = edge_grid(geo.start, geo.end, margin)
        return cls(geo.start, geo.end, grid, cspace.eps)

    @functools.cached_property
    def lines(self) -> npt.NDArray[np.object_]:
        """The edges as shapely line strings (for the distance test of touching)."""
        return np.asarray(
            shapely.linestrings(np.stack([self.start, self.end], axis=1)), dtype=object
        )

    def near(self, segs: FloatArray) -> tuple[IntArray, IntArray]:
        """(segment, edge) pairs: every edge within the touching distance, and more."""
        margin = 2.0 * _TOUCH * self.eps
        return near_pairs(self.grid, segs[:, 0], segs[:, 1], margin)


def _neighbours(arrays: GraphArrays, n: int) -> np.ndarray:
    return np.concatenate([arrays.j[arrays.i == n], arrays.i[arrays.j == n]])


_CHUNK = 1024
"""Blocked segments whose blockers are found between two questions to ``abandoned``
(from a vertex of the 10,000-vertex circle, about a tenth of a second's work)."""


def _look(
    cspace: ConfigurationSpace,
    border: _BorderEdges,
    arrays: GraphArrays,
    n: int,
    abandoned: Callable[[], bool] | None = None,
) -> VertexLook:
    """Return what node n sees (read from the graph) and what blocks the rest.

    The blocked segments' blockers are found :data:`_CHUNK` segments at a time (each
    segment's on its own), ``abandoned`` asked before each chunk.
    """
    seen = _neighbours(arrays, n)
    others = np.setdiff1d(np.arange(len(arrays.points)), np.append(seen, n))
    p = arrays.points[n]
    visible = _from_point(p, arrays.points[seen])
    blocked = _from_point(p, arrays.points[others])
    parts = [np.zeros((0, 2, 2))]
    for lo in range(0, len(blocked), _CHUNK):
        keep_going(abandoned)
        parts.append(_blockers(cspace, border, blocked[lo : lo + _CHUNK]))
    blockers = np.concatenate(parts)
    return VertexLook(n, _name(arrays, n), visible, blocked, blockers)


def _from_point(p: FloatArray, ends: FloatArray) -> FloatArray:
    """Segments (k, 2, 2) from ``p`` to each of ``ends``."""
    return np.stack([np.broadcast_to(p, ends.shape), ends], axis=1).astype(np.float64)


def _blockers(
    cspace: ConfigurationSpace, border: _BorderEdges, blocked: FloatArray
) -> FloatArray:
    """For each blocked segment, the border edge where it first enters blocked space.

    The first edge it properly crosses; a segment that crosses none enters blocked space
    at a vertex (it leaves a vertex straight into its own obstacle, or grazes a corner
    inward), and the edge nearest where its first blocked point lies is taken.
    """
    if len(blocked) == 0:
        return np.zeros((0, 2, 2))
    edge = _first_crossing(blocked, border)
    rest = np.flatnonzero(edge < 0)
    if len(rest):
        edge[rest] = _entry_edges(cspace, border, blocked[rest])
    return np.stack([border.start[edge], border.end[edge]], axis=1)


def _first_crossing(segs: FloatArray, border: _BorderEdges) -> IntArray:
    """Per segment, the edge it properly crosses nearest its first end (-1: none).

    Of equally near ones, the edge listed first. Only the edges near a segment can
    cross it, so only those pairs are computed.
    """
    seg, edge = border.near(segs)
    p, r = segs[seg, 0], segs[seg, 1] - segs[seg, 0]
    q, e = border.start[edge], border.end[edge] - border.start[edge]
    denom = r[:, 0] * e[:, 1] - r[:, 1] * e[:, 0]
    qp = q - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[:, 0] * e[:, 1] - qp[:, 1] * e[:, 0]) / denom
        u = (qp[:, 0] * r[:, 1] - qp[:, 1] * r[:, 0]) / denom
    eps = border.eps
    tol = (eps / np.maximum(np.hypot(*segs[:, 1].T - segs[:, 0].T), eps))[seg]
    crossing = (
        (np.abs(denom) > 0) & (t > tol) & (t < 1 - tol) & (u > 1e-12) & (u < 1 - 1e-12)
    )
    return _least_per_segment(len(segs), seg[crossing], edge[crossing], t[crossing])


def _least_per_segment(
    count: int, seg: IntArray, edge: IntArray, key: FloatArray
) -> IntArray:
    """Per segment 0 .. count - 1, the edge of its pairs with the least ``key`` (-1: none).

    Of pairs with equal keys, the edge listed first: what ``np.argmin`` over a dense
    (segments, edges) table of the keys gives.
    """
    found = np.full(count, -1, dtype=np.intp)
    first = np.lexsort((edge, key, seg))  # by segment, then key, then edge
    leads = (
        first[np.r_[True, seg[first][1:] != seg[first][:-1]]] if len(first) else first
    )
    found[seg[leads]] = edge[leads]
    return found


def _entry_edges(
    cspace: ConfigurationSpace, border: _BorderEdges, segs: FloatArray
) -> IntArray:
    """Return, per segment that crosses no edge, the border edge where it enters blocked space.

    Such a segment passes through a vertex (or leaves one) into an obstacle: of the edges
    it touches, the one nearest its first blocked point (of equally near ones, the edge
    listed first).
    """
    entry = _first_blocked_samples(cspace, segs)
    seg, edge = border.near(segs)
    lines = np.asarray(shapely.linestrings(segs), dtype=object)
    touching = np.asarray(
        shapely.dwithin(lines[seg], border.lines[edge], _TOUCH * cspace.eps), dtype=bool
    )
    seg, edge = seg[touching], edge[touching]
    gap = _point_edge_distances(entry[seg], border.start[edge], border.end[edge])
    found = _least_per_segment(len(segs), seg, edge, gap)
    # A blocked segment touches the border; should none be found, the nearest edge.
    lone = np.flatnonzero(found < 0)
    if len(lone):
        gaps = _point_edge_distances(
            entry[lone, None], border.start[None], border.end[None]
        )
        found[lone] = np.argmin(gaps, axis=1)
    return found


def _first_blocked_samples(cspace: ConfigurationSpace, segs: FloatArray) -> FloatArray:
    """Return, per segment, its first sample point in blocked space.

    Of ``_SAMPLES - 2`` points evenly spaced inside it; the first one when none is
    blocked.
    Samples are tested a few at a time, in order, only for the segments still looking:
    most segments that cross no edge enter blocked space at once (a chord of their own
    obstacle), so a chord of a 10,000-vertex obstacle costs a few samples, not 127.
    """
    t = np.linspace(0.0, 1.0, _SAMPLES)[1:-1]
    a, d = segs[:, 0], segs[:, 1] - segs[:, 0]
    first = np.zeros(len(segs), dtype=np.intp)
    looking = np.arange(len(segs))
    for lo in range(0, len(t), _SAMPLES_AT_ONCE):
        if not len(looking):
            break
        ts = t[lo : lo + _SAMPLES_AT_ONCE]
        pts = a[looking, None] + ts[None, :, None] * d[looking, None]
        inside = cspace.contains_blocked(pts.reshape(-1, 2)).reshape(len(looking), -1)
        hit = inside.any(axis=1)
        first[looking[hit]] = lo + np.argmax(inside[hit], axis=1)
        looking = looking[~hit]
    return a + t[first, None] * d


def _point_edge_distances(
    p: FloatArray, start: FloatArray, end: FloatArray
) -> FloatArray:
    """Return the distance of each point to each edge [m], broadcasting (..., 2) rows.

    Points (k, 2) with edges (k, 2): one distance per row; points (k, 1, 2) with edges
    (1, m, 2): the (k, m) table. Either way the same arithmetic for a (point, edge) pair.
    """
    d = end - start
    len2 = np.maximum(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1], 1e-300)
    rel = p - start
    u = np.clip((rel[..., 0] * d[..., 0] + rel[..., 1] * d[..., 1]) / len2, 0.0, 1.0)
    closest = start + u[..., None] * d
    return np.hypot(*np.moveaxis(p - closest, -1, 0))


def _vertex_step(arrays: GraphArrays, look: VertexLook, done: FloatArray) -> Step:
    p = arrays.points[look.node]
    text = (
        f"Section 9.4: from {_the(look.name)}, draw a segment to every vertex it sees: "
        f"{len(look.visible)} visible, {len(look.blocked)} intercepted by an obstacle."
    )
    return Step(
        "vg:vertex",
        text,
        marks(
            done=done,
            blocked=look.blocked,
            blocker=look.blockers,
            current=look.visible,
            focus=point_mark("focus", [p], ((look.name, (float(p[0]), float(p[1]))),)),
        ),
        (
            ("visible", str(len(look.visible))),
            ("blocked", str(len(look.blocked))),
        ),
    )


def _search_step(arrays: GraphArrays, story: _Story, k: int) -> Step:
    """Make the search's step ``k``: settle one more node; the tree so far in bold."""
    node, _, cost = story.settled[k]
    p = arrays.points[node]
    tree = [
        (arrays.points[parent], arrays.points[child])
        for child, parent, _ in story.settled[: k + 1]
        if parent >= 0
    ]
    text = (
        f"Search (section 9.4): settle {_the(_name(arrays, node))} at path length "
        f"{cost:.2f} m from the start ({k + 1} of the nodes settled so far)."
    )
    return Step(
        "vg:search",
        text,
        marks(
            done=story.graph,
            current=as_segments(tree),
            focus=point_mark(
                "focus", [p], ((_name(arrays, node), (float(p[0]), float(p[1]))),)
            ),
        ),
        (("settled", str(k + 1)), ("cost [m]", f"{cost:.2f}")),
    )


def _path_step(arrays: GraphArrays, result: Any, graph: FloatArray) -> Step:
    path = np.asarray(result.path, dtype=np.float64).reshape(-1, 2)
    if result.status == "ok" and result.length is not None:
        text = (
            f"The shortest path through the visibility graph: {result.length:.2f} m, "
            f"found among its {arrays.edges} segments."
        )
    else:
        text = f"No path: {result.reason}."
    segs = (
        np.stack([path[:-1], path[1:]], axis=1)
        if len(path) > 1
        else np.zeros((0, 2, 2))
    )
    return Step("vg:path", text, marks(done=graph, path=segs))


def _the(name: str) -> str:
    return f"the {name}" if name in ("start", "goal") else name
