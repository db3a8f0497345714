"""The visibility core: the visibility graph and the simplified one (sections 9.4, 9.5).

- ``_graphs``: the VG and SVG builders, the graph as index arrays and its A* search, the
  exact segment test; its public names are public here.
- :mod:`planners.visibility.incremental`: the VG carried over an edit (what
  :func:`planners.plan_all` with a memo uses).
- :mod:`planners.visibility.sightlines`: which border edges a segment may meet, in
  bounded memory (an edge grid), and the disks that rule pairs out.

The compiled loops these use are :mod:`planners.kernels` (shared with the sensor).
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

from planners.visibility._graphs import (
    GraphArrays,
    VisibilityResult,
    plan_visibility,
    segments_free,
    shortest_path,
    simplified_visibility_graph,
    svg_node_reasons,
    svg_reasons,
    visibility_graph,
)
