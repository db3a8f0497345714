"""Obstacle expansion, as Figs. 9.7 and 9.8 draw it (section 9.3).

"To expand each obstacle, every point along its perimeter is expanded by the radius of
the disk" (Fig. 9.7); the chapter's simplified model places the robot's enclosing square
instead (Fig. 9.8). :func:`explain_expansion` shows the construction for one obstacle:
the robot's shape placed at each vertex in turn, the edges pushed out by the robot, and
the union, which is the expanded obstacle the planners use
(:func:`planners.space.expansion.expand_polygon`, the same call).
"""

from __future__ import annotations

__all__ = ["explain_expansion"]

import dataclasses
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import shapely
from shapely import Polygon

from planners.explain._steps import (
    Explanation,
    Lazy,
    Step,
    as_segments,
    circle_segments,
    marks,
    point_mark,
    ring_segments,
    segment_mark,
)
from planners.registry import PlanOptions
from planners.space.expansion import expand_polygon

if TYPE_CHECKING:
    from planners.scene import Scene

FloatArray = npt.NDArray[np.float64]

_FIGURE = MappingProxyType({"disk": "Fig. 9.7", "square": "Fig. 9.8"})
_SHAPE = MappingProxyType({"disk": "disk", "square": "enclosing square"})
_ARTICLE = MappingProxyType({"disk": "a", "square": "an"})


def explain_expansion(
    scene: Scene,
    options: PlanOptions | None = None,
    *,
    obstacle: int = 1,
    model: str | None = None,
) -> Explanation:
    """Explain how obstacle ``obstacle`` (1-based) is expanded (Figs. 9.7, 9.8).

    Parameters
    ----------
    scene
        The scene (its robot radius).
    options
        Planner settings (the disk model's arc step); None for the defaults.
    obstacle
        Which obstacle, numbered from 1 as in the app.
    model
        ``"disk"`` or ``"square"``; None shows both, the disk first (the chapter's order).

    Returns
    -------
    Explanation
        Per model: the obstacle, the shape at each vertex, the offset edges, the union.

    Examples
    --------
    >>> import planners
    >>> scene = planners.load_scene("static_scenarios/02_three_obstacles.json")
    >>> ex = planners.explain_expansion(scene, obstacle=1, model="square")
    >>> print(ex.steps[1].text)  # doctest: +ELLIPSIS
    Fig. 9.8(b): place the robot's enclosing square (side 2r = ... m) at vertex 1 of obstacle 1.
    >>> ex.steps[-1].kind
    'expansion:union'
    """
    options = options or PlanOptions()
    title = f"Obstacle expansion (section 9.3), obstacle {obstacle}"
    if not 1 <= obstacle <= len(scene.obstacles):
        text = f"There is no obstacle {obstacle}: the scene has {len(scene.obstacles)}."
        return Explanation("expansion", title, (Step("expansion:none", text),))
    polygon = shapely.orient_polygons(scene.obstacles[obstacle - 1])
    models = (model,) if model is not None else ("disk", "square")
    parts = [
        _Construction.of(polygon, obstacle, scene.robot.radius, m, options)
        for m in models
    ]
    starts = np.cumsum([0, *(part.count for part in parts)])

    def step(k: int) -> Step:
        i = int(np.searchsorted(starts, k, side="right")) - 1
        return parts[i].step(k - int(starts[i]))

    return Explanation("expansion", title, Lazy(int(starts[-1]), step))


@dataclasses.dataclass(frozen=True, eq=False)
class _Construction:
    """One model's construction of one expanded obstacle, step by step.

    The steps are made when shown: step k draws the shapes placed at the first k
    vertices, so all of them at once would hold a number of shapes quadratic in the
    vertices (4.9 GB for an obstacle of 2,000 vertices). Here every shape is made once,
    and a step draws the first of them.
    """

    polygon: Polygon
    obstacle: int
    radius: float
    model: str
    options: PlanOptions
    ring: FloatArray
    """The obstacle's vertices, counter-clockwise, open (n, 2) [m]."""
    outline: FloatArray
    """Its edges as segments (n, 2, 2) [m]."""
    placed: FloatArray
    """The robot's shape at each vertex in turn, as segments, one block per vertex."""
    per_vertex: int
    """Segments of one shape."""

    @classmethod
    def of(
        cls,
        polygon: Polygon,
        obstacle: int,
        radius: float,
        model: str,
        options: PlanOptions,
    ) -> _Construction:
        ring = np.asarray(polygon.exterior.coords, dtype=np.float64)[:-1]
        pieces = [_shape_at(v, radius, model) for v in ring]
        placed = np.concatenate([np.zeros((0, 2, 2)), *pieces])
        per_vertex = len(pieces[0]) if pieces else 0
        return cls(
            polygon,
            obstacle,
            radius,
            model,
            options,
            ring,
            ring_segments(ring),
            placed,
            per_vertex,
        )

    @property
    def count(self) -> int:
        """Steps: the polygon, one per vertex, the offset edges, the union."""
        return len(self.ring) + 3

    def step(self, k: int) -> Step:
        """Make step ``k`` of this model's construction."""
        fig, shape = _FIGURE[self.model], _SHAPE[self.model]
        size = (
            f"radius r = {self.radius:g} m"
            if self.model == "disk"
            else f"side 2r = {2 * self.radius:g} m"
        )
        if k == 0:
            return Step(
                f"expansion:{self.model}",
                f"{fig}(a): obstacle {self.obstacle} as a polygon; the robot, modelled "
                f"as {_ARTICLE[self.model]} {shape} ({size}), shrinks to a point.",
                marks(current=self.outline),
            )
        if k <= len(self.ring):
            v = self.ring[k - 1]
            return Step(
                f"expansion:{self.model}:vertex",
                f"{fig}(b): place the robot's {shape} ({size}) at vertex {k} of "
                f"obstacle {self.obstacle}.",
                marks(
                    done=self.outline,
                    shape=self.placed[: k * self.per_vertex],
                    focus=point_mark(
                        "focus", [v], ((f"{k}", (float(v[0]), float(v[1]))),)
                    ),
                ),
            )
        if k == len(self.ring) + 1:
            return Step(
                f"expansion:{self.model}:edges",
                f"{fig}(b): push every edge out by the robot ({size}): the robot's "
                "centre may not come closer.",
                marks(
                    done=self.outline,
                    shape=self.placed,
                    offset=_offset_edges(self.ring, self.radius, self.model),
                ),
            )
        expanded = expand_polygon(
            self.polygon, self.radius, self.model, self.options.arc_step
        )
        return Step(
            "expansion:union",
            f"{fig}(c): the union of the obstacle, the shapes and the swept edges is the "
            f"expanded obstacle {self.obstacle} ({len(expanded.exterior.coords) - 1} "
            "vertices): the robot is now a point.",
            marks(done=self.outline, result=segment_mark("result", _outline(expanded))),
        )


def _shape_at(v: FloatArray, radius: float, model: str) -> FloatArray:
    if model == "disk":
        return circle_segments(v, radius, 48)
    corners = v + radius * np.array(
        [[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=np.float64
    )
    return ring_segments(corners)


def _offset_edges(ring: FloatArray, radius: float, model: str) -> FloatArray:
    """Each edge of a counter-clockwise ring moved outward by the robot."""
    nxt = np.roll(ring, -1, axis=0)
    d = nxt - ring
    normal = np.stack([d[:, 1], -d[:, 0]], axis=1) / np.hypot(*d.T)[:, None]
    if model == "disk":
        shift = radius * normal
    else:
        # The square's corner farthest along the outward normal leads the swept edge.
        shift = radius * np.where(np.abs(normal) > 1e-12, np.sign(normal), 0.0)
    return as_segments(np.stack([ring + shift, nxt + shift], axis=1))


def _outline(polygon: Polygon) -> FloatArray:
    parts = [ring_segments(polygon.exterior.coords)]
    parts.extend(ring_segments(r.coords) for r in polygon.interiors)
    return np.concatenate(parts)
