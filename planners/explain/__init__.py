"""Explanations: each method of Chapter 9 as a sequence of steps a lecturer can show.

- ``_steps``: the records (:class:`Explanation`, :class:`Step`, :class:`Mark`,
  :class:`Lazy`) and the helpers that make marks; public here.
- :mod:`planners.explain.expansion`, :mod:`planners.explain.vg`,
  :mod:`planners.explain.svg`, :mod:`planners.explain.dsb`: one method each (obstacle
  expansion, section 9.3; the VG, 9.4; the SVG, 9.5; the distance-sensor-based robot,
  9.6).
- ``_methods``: :func:`explain`, any of them by name (:data:`METHODS`); above the four.

Explanations read the planners' own records; nothing below imports this package.
"""

from __future__ import annotations

__all__ = [
    "METHODS",
    "ROLES",
    "Abandoned",
    "Explanation",
    "Lazy",
    "Mark",
    "Step",
    "as_points",
    "as_segments",
    "circle_segments",
    "explain",
    "keep_going",
    "marks",
    "point_mark",
    "ring_segments",
    "segment_mark",
]

from planners.explain._methods import explain
from planners.explain._steps import (
    METHODS,
    ROLES,
    Abandoned,
    Explanation,
    Lazy,
    Mark,
    Step,
    as_points,
    as_segments,
    circle_segments,
    keep_going,
    marks,
    point_mark,
    ring_segments,
    segment_mark,
)
