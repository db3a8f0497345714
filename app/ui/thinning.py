"""Which of a big graph's edges the view draws: all, or those at the path's nodes.

A visibility graph of a student's 32-obstacle room has some 6,000 edges (Fig. 9.9's
graph, section 9.4, grown fifty-fold): drawn all at once they cover the room in a grey
web in which neither the path nor an obstacle can be read, and every redraw during a drag
sends all of them to every browser (about 140 KiB an event). So beyond
:data:`THIN_ABOVE` edges the layer is *thinned*, a drawing choice only: it draws the
edges at the start, the goal and every node of the shortest path -- the edges the
search weighed where the path turns (section 9.4.3) -- and the panel says how many of
how many it shows. The layer "VG edges: all" draws every edge again. Which edges exist
is the planner's decision (:class:`planners.visibility.GraphArrays`); nothing here adds
or removes one.
"""

from __future__ import annotations

__all__ = [
    "THIN_ABOVE",
    "EdgeCount",
    "EdgeDrawing",
    "edges_counted",
    "edges_to_draw",
    "frame_note",
    "thinning_note",
]

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

THIN_ABOVE = 2000
"""A graph with more edges than this is drawn thinned unless its "all" layer is on."""


@dataclasses.dataclass(frozen=True)
class EdgeCount:
    """How many of a graph's edges a layer draws, and how many the graph has."""

    drawn: int
    """Edges drawn."""
    total: int
    """Edges of the graph."""

    @property
    def thinned(self) -> bool:
        """Whether some of the graph's edges are left out."""
        return self.drawn < self.total


@dataclasses.dataclass(frozen=True, eq=False)
class EdgeDrawing:
    """The edges a graph layer draws, and how many the graph has."""

    segments: npt.NDArray[np.float64]
    """Edges to draw, shape (k, 2, 2) [m], in the planner's order."""
    total: int
    """Edges of the graph."""
    at_ends: npt.NDArray[np.bool_]
    """Per edge drawn, whether it has an end at the start or the goal node, shape (k,):
    the edges a drag of the start or the goal changes (the others stay as they are)."""

    @property
    def thinned(self) -> bool:
        """Whether some of the graph's edges are left out."""
        return len(self.segments) < self.total

    @property
    def count(self) -> EdgeCount:
        """How many edges are drawn, of how many."""
        return EdgeCount(len(self.segments), self.total)


def _on_path(arrays: Any, path: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Per node of the graph, whether the path passes through it (start, goal: yes).

    A path of a graph planner runs from node to node, so its corners are node positions
    exactly (the planner copies them); a corner that is not a node matches nothing.
    """
    points = np.asarray(arrays.points, dtype=np.float64).reshape(-1, 2)
    corners = np.asarray(path, dtype=np.float64).reshape(-1, 2)
    # Exact matches through sorting (x + iy as one number), not an n-by-m comparison: a
    # path around a 10,000-vertex circle has thousands of corners.
    on_path = np.isin(
        points[:, 0] + 1j * points[:, 1], corners[:, 0] + 1j * corners[:, 1]
    )
    on_path[[arrays.start, arrays.goal]] = True
    return on_path


def edges_to_draw(result: Any, all_edges: bool, limit: int = THIN_ABOVE) -> EdgeDrawing:
    """Return the edges of a graph planner's ``result`` to draw.

    Every edge when ``all_edges`` is on or the graph has at most ``limit`` edges; else
    only the edges with an end at the start, the goal or a node of the shortest path.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> pts = np.array([[0.0, 0], [1, 0], [2, 0], [3, 0]])
    >>> arrays = SimpleNamespace(points=pts, start=0, goal=1,
    ...     i=np.array([0, 2, 1]), j=np.array([1, 3, 2]))
    >>> arrays.segments = lambda: np.stack([pts[arrays.i], pts[arrays.j]], axis=1)
    >>> r = SimpleNamespace(arrays=arrays, path=pts[:2])
    >>> d = edges_to_draw(r, all_edges=False, limit=2)
    >>> len(d.segments), d.total, d.thinned
    (2, 3, True)
    >>> d.at_ends.tolist()  # edge 0-1 joins start and goal, 1-2 leaves the goal
    [True, True]
    """
    arrays = result.arrays
    total = len(arrays.i)
    ends = _at_ends(arrays)
    if all_edges or total <= limit:
        return EdgeDrawing(arrays.segments(), total, ends)
    keep = _at_path(result)
    points = np.asarray(arrays.points, dtype=np.float64)
    segments = np.stack([points[arrays.i[keep]], points[arrays.j[keep]]], axis=1)
    return EdgeDrawing(segments, total, ends[keep])


def _at_ends(arrays: Any) -> npt.NDArray[np.bool_]:
    """Per edge of the graph, whether one of its nodes is the start or the goal."""
    i, j = np.asarray(arrays.i), np.asarray(arrays.j)
    ends = [arrays.start, arrays.goal]
    return np.isin(i, ends) | np.isin(j, ends)


def edges_counted(result: Any, all_edges: bool, limit: int = THIN_ABOVE) -> EdgeCount:
    """Return how many edges :func:`edges_to_draw` draws, without making them.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> g = SimpleNamespace(points=np.arange(8.0).reshape(4, 2), start=0, goal=1,
    ...     i=np.array([0, 2]), j=np.array([1, 3]))  # edge 2-3 is away from the path
    >>> edges_counted(SimpleNamespace(arrays=g, path=g.points[:2]), False, limit=1)
    EdgeCount(drawn=1, total=2)
    """
    total = len(result.arrays.i)
    if all_edges or total <= limit:
        return EdgeCount(total, total)
    return EdgeCount(int(np.count_nonzero(_at_path(result))), total)


def _at_path(result: Any) -> npt.NDArray[np.bool_]:
    """Per edge of a graph planner's ``result``, whether an end is on its path."""
    arrays = result.arrays
    at_path = _on_path(arrays, result.path)
    return at_path[arrays.i] | at_path[arrays.j]


def frame_note(plans: Mapping[str, Any], layers: Mapping[str, bool]) -> str | None:
    """Say which of a frame's graph layers are thinned (None when none is).

    ``plans`` maps planner names to results: those with a graph (``arrays``) and a
    status with edges to show count.
    """
    drawn = {
        name: edges_counted(result, all_edges=False)
        for name, result in plans.items()
        if hasattr(result, "arrays")
        and getattr(result, "status", "") in ("ok", "unreachable")
        and len(result.arrays.i) > THIN_ABOVE  # else nothing is thinned: no work
        and not layers.get(f"{name}_edges_all", False)
    }
    return thinning_note(drawn, layers)


def thinning_note(
    drawn: Mapping[str, EdgeCount], layers: Mapping[str, bool]
) -> str | None:
    """Say which graph layers are thinned, for the panel (None when none is).

    Examples
    --------
    >>> print(thinning_note({"vg": EdgeCount(469, 6388)}, {"vg_edges": True}))
    VG edges: 469 of 6,388 drawn (those at the path's nodes); tick *VG edges: all* under Layers for every edge.
    """
    parts = [
        f"{name.upper()} edges: {d.drawn:,} of {d.total:,} drawn"
        f" (those at the path's nodes); tick *{name.upper()} edges: all* under Layers"
        " for every edge."
        for name, d in drawn.items()
        if d.thinned and layers.get(f"{name}_edges", True)
    ]
    return "  \n".join(parts) if parts else None
