"""Which border edges can matter to a question asked near a point (section 9.6, issue 15).

The range sensor of :mod:`planners.sensor` answers from one position: what lies within
the range R (:func:`planners.sensor.sense`), how far a ray goes
(:func:`planners.sensor.free_extent`), whether the robot touches the border. Its exact
tests are arithmetic per edge; run over every edge of the border they cost O(m) numpy
work per question, and TangentBug asks tens of thousands of questions on a big scene (a
circle of ten thousand vertices: seconds). :class:`EdgeIndex` names, per question, a
superset of the edges the test can flag; the exact test then runs on those only, in the
same order (ascending edge index), so the answer is the very same.

- :meth:`EdgeIndex.near_disk`: every edge with a point within ``r`` of ``x`` (a box query
  on a shapely ``STRtree`` of the edges, padded), plus the edges of the *wide corners*.
- :meth:`EdgeIndex.near_segment`: every edge within the pad of a segment.

Wide corners. The sensor treats the robot as touching a corner when it lies within eps of
both of the corner's edges' lines (:func:`planners.sensor.measure_border`). Those points
form a rhombus around the vertex reaching eps / sin(phi / 2) <= 2 eps / sin(phi) from it,
phi the angle between the lines: far when the border hardly turns. Corners whose rhombus
can reach farther than the pad are listed once and always included.
"""

from __future__ import annotations

__all__ = ["EdgeIndex", "edge_index"]

import dataclasses
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import shapely

from planners.geometry import cross

if TYPE_CHECKING:
    from planners.border import RingGeometry

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

PAD_REL = 1e-3
"""Padding of every query, relative to the scene's size: far above the rounding of the
distances and of the sensor's tolerance tests (eps is about 1e-9 of the scene)."""


@dataclasses.dataclass(frozen=True, eq=False)
class EdgeIndex:
    """A spatial index of border edges a[k] -> b[k] (see the module docstring)."""

    tree: shapely.STRtree
    """The edges as line strings, in edge order."""
    pad: float
    """Every query is widened by this [m]."""
    wide: IntArray
    """Sorted edges of the corners whose touching rhombus reaches beyond the pad."""
    packed: FloatArray
    """(6, m) per edge: start x, start y, step x, step y, squared length, eps times the
    length (what the sensor measures, gathered at once for the edges a query names)."""

    def near_disk(self, x: FloatArray, r: float) -> IntArray:
        """Return, sorted, a superset of the edges with a point within ``r`` of ``x``."""
        reach = r + self.pad
        box = shapely.box(x[0] - reach, x[1] - reach, x[0] + reach, x[1] + reach)
        return self._with_wide(self.tree.query(box))

    def near_segment(self, p: FloatArray, q: FloatArray) -> IntArray:
        """Return, sorted, a superset of the edges within the pad of the segment p -> q.

        The edges whose boxes meet the segment's box widened by the pad: a box query
        costs little, and the sensor's numpy test over a long ray's box is cheaper than
        GEOS's distance to each edge in it.
        """
        lo, hi = np.minimum(p, q) - self.pad, np.maximum(p, q) + self.pad
        return self._with_wide(self.tree.query(shapely.box(lo[0], lo[1], hi[0], hi[1])))

    def _with_wide(self, found: npt.NDArray[np.integer]) -> IntArray:
        if len(self.wide):
            return np.union1d(found, self.wide).astype(np.intp, copy=False)
        return np.sort(found).astype(np.intp, copy=False)


def edge_index(geo: RingGeometry) -> EdgeIndex:
    """Index the border edges of ``geo`` (built once per border: ``geo.index``).

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.border import ring_geometry
    >>> from planners.expansion import configuration_space
    >>> geo = ring_geometry(configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0))
    >>> ix = geo.index
    >>> ix.near_disk(np.array([0.5, -0.5]), 0.4).tolist()  # nothing within 0.4
    []
    >>> geo.start[ix.near_disk(np.array([0.5, -0.5]), 0.55)].tolist()  # boxes: a superset
    [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    """
    pad = PAD_REL * geo.scale
    lines = np.asarray(shapely.linestrings(np.stack([geo.start, geo.end], axis=1)))
    tree = shapely.STRtree(lines)
    # 2 eps / sin(phi) bounds the rhombus; twice that, for safety, against the pad.
    sin_phi = np.abs(cross(geo.unit, geo.prev_dir))
    corner = np.flatnonzero(4.0 * geo.eps >= pad * sin_phi)
    # The corner at edge e's start joins e and the edge before it.
    wide = np.union1d(corner, geo.prev_edge[corner]).astype(np.intp)
    packed = np.stack(
        [
            geo.start[:, 0],
            geo.start[:, 1],
            geo.step_x,
            geo.step_y,
            geo.len2,
            geo.eps_length,
        ]
    )
    return EdgeIndex(tree, pad, wide, packed)
