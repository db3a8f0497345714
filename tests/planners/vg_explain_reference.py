"""The visibility graph's explanation as it was first written: every step at once, each
blocked segment against every border edge (dense (segments, edges) arrays, shapely's
distance on every pair). Slow and obviously correct: the reference that the lazy,
grid-backed :func:`planners.explain.vg.explain_vg` is compared with, step for step.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import shapely

from planners.explain import Explanation, Step, as_segments, marks, point_mark
from planners.explain.vg import VertexLook
from planners.space.border import ring_geometry

if TYPE_CHECKING:
    from planners.registry import PlanOptions
    from planners.scene import Scene
    from planners.space.expansion import ConfigurationSpace
    from planners.visibility import GraphArrays

FloatArray = npt.NDArray[np.float64]

# Points along a blocked segment tested to find where it first enters an obstacle.
_SAMPLES = 129


def explain_vg_reference(
    scene: Scene,
    options: PlanOptions | None = None,
    *,
    plans: dict[str, Any] | None = None,
) -> Explanation:
    """The VG explanation as first written: every step made at once (see above)."""
    from planners.api import plan_all

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
    looks = tuple(_look(cspace, arrays, n) for n in order)
    steps = [
        *_vertex_steps(arrays, looks),
        *_search_steps(arrays),
        _path_step(arrays, result),
    ]
    return Explanation("vg", title, tuple(steps), data=looks)


def _stepping_order(arrays: GraphArrays) -> list[int]:
    """Start first, then every border vertex in the border's order, then the goal."""
    ends = {arrays.start, arrays.goal}
    middle = [n for n in range(len(arrays.points)) if n not in ends]
    last = [arrays.goal] if arrays.goal != arrays.start else []
    return [arrays.start, *middle, *last]


def _name(arrays: GraphArrays, n: int) -> str:
    kind = arrays.kind(n)
    return kind if kind != "vertex" else f"vertex {n + 1}"


def _neighbours(arrays: GraphArrays, n: int) -> np.ndarray:
    return np.concatenate([arrays.j[arrays.i == n], arrays.i[arrays.j == n]])


def _look(cspace: ConfigurationSpace, arrays: GraphArrays, n: int) -> VertexLook:
    """Return what node n sees (read from the graph) and what blocks the rest."""
    seen = _neighbours(arrays, n)
    others = np.setdiff1d(np.arange(len(arrays.points)), np.append(seen, n))
    p = arrays.points[n]
    visible = as_segments([(p, arrays.points[m]) for m in seen.tolist()])
    blocked = as_segments([(p, arrays.points[m]) for m in others.tolist()])
    blockers = _blockers(cspace, blocked)
    return VertexLook(n, _name(arrays, n), visible, blocked, blockers)


def _blockers(cspace: ConfigurationSpace, blocked: FloatArray) -> FloatArray:
    """For each blocked segment, the border edge where it first enters blocked space.

    The first edge it properly crosses; a segment that crosses none enters blocked space
    at a vertex (it leaves a vertex straight into its own obstacle, or grazes a corner
    inward), and the edge nearest where its first blocked point lies is taken.
    """
    if len(blocked) == 0:
        return np.zeros((0, 2, 2))
    geo = ring_geometry(cspace, cleaned=False)
    edge = _first_crossing(blocked, geo.start, geo.end, cspace.eps)
    rest = np.flatnonzero(edge < 0)
    if len(rest):
        edge[rest] = _entry_edges(cspace, blocked[rest], geo.start, geo.end)
    return np.stack([geo.start[edge], geo.end[edge]], axis=1)


def _first_crossing(
    segs: FloatArray, start: FloatArray, end: FloatArray, eps: float
) -> npt.NDArray[np.intp]:
    """Per segment, the edge it properly crosses nearest its first end (-1: none)."""
    p, r = segs[:, None, 0], (segs[:, 1] - segs[:, 0])[:, None, :]  # (s, 1, 2)
    q, e = start[None], (end - start)[None]  # (1, m, 2)
    denom = r[..., 0] * e[..., 1] - r[..., 1] * e[..., 0]
    qp = q - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[..., 0] * e[..., 1] - qp[..., 1] * e[..., 0]) / denom
        u = (qp[..., 0] * r[..., 1] - qp[..., 1] * r[..., 0]) / denom
    tol = eps / np.maximum(np.hypot(*segs[:, 1].T - segs[:, 0].T), eps)[:, None]
    crossing = (
        (np.abs(denom) > 0) & (t > tol) & (t < 1 - tol) & (u > 1e-12) & (u < 1 - 1e-12)
    )
    t = np.where(crossing, t, np.inf)
    best = np.argmin(t, axis=1)
    return np.where(np.isfinite(t[np.arange(len(segs)), best]), best, -1).astype(
        np.intp
    )


def _entry_edges(
    cspace: ConfigurationSpace, segs: FloatArray, start: FloatArray, end: FloatArray
) -> npt.NDArray[np.intp]:
    """Return, per segment that crosses no edge, the border edge where it enters blocked space.

    Such a segment passes through a vertex (or leaves one) into an obstacle: of the edges
    it touches, the one nearest its first blocked point.
    """
    t = np.linspace(0.0, 1.0, _SAMPLES)[1:-1]
    pts = segs[:, None, 0] + t[None, :, None] * (segs[:, 1] - segs[:, 0])[:, None, :]
    inside = cspace.contains_blocked(pts.reshape(-1, 2)).reshape(len(segs), -1)
    entry = pts[np.arange(len(segs)), np.argmax(inside, axis=1)]  # (f, 2)
    lines = np.asarray(shapely.linestrings(segs), dtype=object)
    edges = np.asarray(
        shapely.linestrings(np.stack([start, end], axis=1)), dtype=object
    )
    touching = np.asarray(
        shapely.dwithin(lines[:, None], edges[None, :], 10.0 * cspace.eps), dtype=bool
    )
    gap = _point_edge_distances(entry, start, end)  # (f, m)
    # A blocked segment touches the border; should none be found, the nearest edge.
    gap = np.where(touching | ~touching.any(axis=1, keepdims=True), gap, np.inf)
    return np.argmin(gap, axis=1).astype(np.intp)


def _point_edge_distances(
    p: FloatArray, start: FloatArray, end: FloatArray
) -> FloatArray:
    """Return the distance of each point to each edge, shape (points, edges) [m]."""
    d = end - start
    len2 = np.maximum((d * d).sum(axis=1), 1e-300)
    rel = p[:, None, :] - start[None, :, :]
    u = np.clip((rel * d[None]).sum(axis=2) / len2, 0.0, 1.0)
    closest = start[None] + u[..., None] * d[None]
    return np.hypot(*np.moveaxis(p[:, None, :] - closest, -1, 0))


def _vertex_steps(arrays: GraphArrays, looks: tuple[VertexLook, ...]) -> list[Step]:
    steps = []
    found: list[FloatArray] = []
    for look in looks:
        p = arrays.points[look.node]
        text = (
            f"Section 9.4: from {_the(look.name)}, draw a segment to every vertex it sees: "
            f"{len(look.visible)} visible, {len(look.blocked)} intercepted by an obstacle."
        )
        done = np.concatenate(found) if found else np.zeros((0, 2, 2))
        steps.append(
            Step(
                "vg:vertex",
                text,
                marks(
                    done=done,
                    blocked=look.blocked,
                    blocker=look.blockers,
                    current=look.visible,
                    focus=point_mark(
                        "focus", [p], ((look.name, (float(p[0]), float(p[1]))),)
                    ),
                ),
                (
                    ("visible", str(len(look.visible))),
                    ("blocked", str(len(look.blocked))),
                ),
            )
        )
        found.append(look.visible)
    return steps


def _search_steps(arrays: GraphArrays) -> list[Step]:
    settled: list[tuple[int, int, float]] = []
    arrays.shortest_path(settled)
    graph = arrays.segments()
    steps = []
    tree: list[tuple[Any, Any]] = []
    for count, (node, parent, cost) in enumerate(settled, start=1):
        p = arrays.points[node]
        if parent >= 0:
            tree.append((arrays.points[parent], p))
        text = (
            f"Search (section 9.4): settle {_the(_name(arrays, node))} at path length "
            f"{cost:.2f} m from the start ({count} of the nodes settled so far)."
        )
        steps.append(
            Step(
                "vg:search",
                text,
                marks(
                    done=graph,
                    current=as_segments(tree),
                    focus=point_mark(
                        "focus",
                        [p],
                        ((_name(arrays, node), (float(p[0]), float(p[1]))),),
                    ),
                ),
                (("settled", str(count)), ("cost [m]", f"{cost:.2f}")),
            )
        )
    return steps


def _path_step(arrays: GraphArrays, result: Any) -> Step:
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
    return Step("vg:path", text, marks(done=arrays.segments(), path=segs))


def _the(name: str) -> str:
    return f"the {name}" if name in ("start", "goal") else name
