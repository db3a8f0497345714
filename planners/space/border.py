"""The border of the free space: one model that every planner reads (section 9.3).

The configuration space's rings (:attr:`ConfigurationSpace.rings`, blocked space on the
left of every directed edge) as flat edge arrays with arclength along each ring. The
sensor and TangentBug walk and measure it; Bug2 follows it; the visibility graphs take
their nodes and the edges they test from it. There are two readings of the same rings:

- as the sensor needs them (the default): repeated and collinear vertices dropped within
  the configuration space's tolerance, so every vertex is a real corner and a robot
  walking the border turns only there;
- exactly as expanded (``cleaned=False``): every vertex of the expanded obstacles is a
  node of the visibility graph (section 9.4 connects "all vertices"), also one that a
  union left a hair's breadth off a straight edge.

Each is built once per configuration space (:meth:`ConfigurationSpace.derive`).

The edge index (:class:`EdgeIndex`, ``RingGeometry.index``) names the border edges that
can matter to a question asked near a point (below).
"""

from __future__ import annotations

__all__ = ["EdgeIndex", "RingGeometry", "edge_index", "ring_geometry"]

import dataclasses
import functools
import math

import numpy as np
import numpy.typing as npt
import shapely

from planners.space.expansion import ConfigurationSpace
from planners.space.geometry import clean_ring, cross

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

# Two visible pieces whose ends are closer than this (relative to the scene's size) are
# one continuous piece of border: the range function does not jump there.
_JOIN_REL = 1e-7


@dataclasses.dataclass(frozen=True, eq=False)
class RingGeometry:
    """The free space's border as flat edge arrays with arclength along each ring.

    Rings are those of :attr:`ConfigurationSpace.rings` (blocked space on the left of each
    directed edge), by default with repeated and collinear vertices removed, so that every
    vertex is a real corner. Edge ``e`` of ring ``k`` is edge ``offset[k] + i`` of the flat
    arrays; it starts at vertex ``i`` of the ring. What only walking the border needs
    (arclengths, perimeters, areas) is computed on first use.
    """

    rings: tuple[FloatArray, ...]
    """Open rings, shape (n_k, 2) [m]."""
    start: FloatArray
    """(m, 2) start of each edge [m]."""
    end: FloatArray
    """(m, 2) end of each edge [m]."""
    length: FloatArray
    """(m,) edge lengths [m]."""
    ring: IntArray
    """(m,) ring of each edge."""
    offset: IntArray
    """(n_rings + 1,) index of each ring's first edge; the last entry is m."""
    prev_dir: FloatArray
    """(m, 2) unit direction from each edge's start vertex back to the previous vertex."""
    step: FloatArray
    """(m, 2) end - start of each edge [m]."""
    unit: FloatArray
    """(m, 2) unit direction of each edge."""
    len2: FloatArray
    """(m,) squared edge lengths [m^2]."""
    prev_edge: IntArray
    """(m,) flat index of the previous edge of the same ring."""
    eps: float
    """Touching tolerance [m] (that of the configuration space)."""
    scale: float
    """Size of the scene [m] (largest extent of the border, at least 1)."""

    @functools.cached_property
    def cum(self) -> tuple[FloatArray, ...]:
        """Per ring, (n_k + 1,) arclength at each vertex; the last entry is the perimeter [m]."""
        offset, length = self.offset, self.length
        return tuple(
            np.concatenate([[0.0], np.cumsum(length[offset[k] : offset[k + 1]])])
            for k in range(len(self.rings))
        )

    @functools.cached_property
    def perimeter(self) -> FloatArray:
        """(n_rings,) ring lengths [m]."""
        return np.array([c[-1] for c in self.cum])

    @functools.cached_property
    def area(self) -> FloatArray:
        """(n_rings,) signed areas [m^2].

        > 0 when the ring encloses blocked space (an obstacle), < 0 when it encloses free
        space (the walls, or a pocket).
        """
        return np.array(
            [
                0.5
                * float(
                    np.sum(
                        r[:, 0] * np.roll(r[:, 1], -1) - np.roll(r[:, 0], -1) * r[:, 1]
                    )
                )
                for r in self.rings
            ]
        )

    @functools.cached_property
    def join_tol(self) -> float:
        """Ends of visible pieces closer than this [m] are one continuous piece."""
        return max(_JOIN_REL * self.scale, 100.0 * self.eps)

    @functools.cached_property
    def eps_length(self) -> FloatArray:
        """(m,) eps times each edge's length: bound on ``|cross|`` within eps of its line."""
        return self.eps * self.length

    @functools.cached_property
    def step_x(self) -> FloatArray:
        """(m,) x component of each edge's step (contiguous, for speed)."""
        return np.ascontiguousarray(self.step[:, 0])

    @functools.cached_property
    def step_y(self) -> FloatArray:
        """(m,) y component of each edge's step."""
        return np.ascontiguousarray(self.step[:, 1])

    @functools.cached_property
    def index(self) -> EdgeIndex:
        """A spatial index of the edges, for questions asked near a point (built on first use)."""
        return edge_index(self)

    @functools.cached_property
    def next_edge(self) -> IntArray:
        """(m,) flat index of the next edge of the same ring."""
        out = np.empty_like(self.prev_edge)
        out[self.prev_edge] = np.arange(len(self.prev_edge))
        return out

    @functools.cached_property
    def start_convex(self) -> BoolArray:
        """(m,) whether each edge's start vertex is a corner (blocked wedge under a half turn)."""
        return cross(self.unit, self.prev_dir) > 0

    @functools.cached_property
    def eroded_start(self) -> FloatArray:
        """(m, 2) the corner at each edge's start vertex moved eps into blocked space [m].

        It is where the two edges' lines, each shifted by eps into blocked space, cross:
        the apex of the corner's blocked wedge shrunk by eps (the touching tolerance). Only
        meaningful at convex corners, where it lies eps / sin(half the wedge) from the
        vertex along the wedge's bisector.
        """
        d_out, d_in = self.unit, -self.prev_dir
        nu_out = np.column_stack([-d_out[:, 1], d_out[:, 0]])
        nu_in = np.column_stack([-d_in[:, 1], d_in[:, 0]])
        with np.errstate(divide="ignore", invalid="ignore"):  # inf, NaN where straight
            k = self.eps / (1.0 + np.einsum("ij,ij->i", nu_in, nu_out))
            return self.start + k[:, None] * (nu_in + nu_out)

    @functools.cached_property
    def corner_list(self) -> list[bool]:
        """:attr:`start_convex` as Python booleans."""
        return self.start_convex.tolist()

    @functools.cached_property
    def eroded_list(self) -> list[tuple[float, float]]:
        """:attr:`eroded_start` as Python float pairs [m]."""
        return list(map(tuple, self.eroded_start.tolist()))

    @functools.cached_property
    def start_list(self) -> list[tuple[float, float]]:
        """Edge starts as Python float pairs [m]."""
        return list(map(tuple, self.start.tolist()))

    @functools.cached_property
    def step_list(self) -> list[tuple[float, float]]:
        """Edge steps as Python float pairs [m]."""
        return list(map(tuple, self.step.tolist()))

    @functools.cached_property
    def ring_list(self) -> list[int]:
        """The ring of each edge, as Python ints."""
        return self.ring.tolist()

    @functools.cached_property
    def len2_list(self) -> list[float]:
        """Squared edge lengths as Python floats [m^2]."""
        return self.len2.tolist()

    @functools.cached_property
    def length_list(self) -> list[float]:
        """Edge lengths as Python floats [m]."""
        return self.length.tolist()

    def edge_index(self, ring: int, i: int) -> int:
        """Flat index of edge ``i`` (taken cyclically) of ``ring``."""
        n = int(self.offset[ring + 1] - self.offset[ring])
        return int(self.offset[ring]) + i % n

    def sigma(self, edge: int, t: float) -> float:
        """Arclength along its ring of the point at parameter ``t`` of flat edge ``edge``."""
        k = int(self.ring[edge])
        return float(self.cum[k][edge - int(self.offset[k])] + t * self.length[edge])

    def locate(self, ring: int, sigma: float) -> tuple[FloatArray, int, float]:
        """Point, flat edge index and edge parameter at arclength ``sigma`` of ``ring``."""
        cum = self.cum[ring]
        sigma = float(sigma) % float(cum[-1])
        i = int(np.searchsorted(cum, sigma, side="right")) - 1
        i = min(max(i, 0), len(cum) - 2)
        e = int(self.offset[ring]) + i
        t = min(max((sigma - float(cum[i])) / float(self.length[e]), 0.0), 1.0)
        return self.start[e] + t * (self.end[e] - self.start[e]), e, t

    def walk(
        self, ring: int, sigma: float, direction: int, distance: float
    ) -> tuple[FloatArray, float]:
        """Walk ``distance`` along ``ring`` from arclength ``sigma`` (+1 forward, -1 back).

        Returns the polyline walked, shape (n, 2) with both ends, and the arclength reached.
        Forward means with blocked space on the left.
        """
        cum = self.cum[ring]
        perimeter = float(cum[-1])
        verts = self.rings[ring]
        n = len(verts)
        s0 = float(sigma) % perimeter
        points = [self.locate(ring, s0)[0]]
        if direction > 0:
            # Vertices strictly ahead, in order, until the distance is used up.
            i = int(
                np.searchsorted(cum, s0, side="right")
            )  # next vertex index (may be n)
            travelled = 0.0
            at = s0
            while True:
                nxt = float(cum[i]) if i <= n else perimeter
                gap = nxt - at
                if travelled + gap >= distance:
                    break
                travelled += gap
                points.append(verts[i % n])
                at = nxt
                if i >= n:
                    at = 0.0
                    i = 1
                else:
                    i += 1
        else:
            i = (
                int(np.searchsorted(cum, s0, side="left")) - 1
            )  # previous vertex index (may be -1)
            travelled = 0.0
            at = s0
            while True:
                prv = float(cum[i]) if i >= 0 else 0.0
                gap = at - prv
                if i < 0:  # wrap: s0 was exactly at vertex 0
                    i = n - 1
                    at = perimeter
                    continue
                if travelled + gap >= distance:
                    break
                travelled += gap
                points.append(verts[i])
                at = prv
                if i == 0:
                    at = perimeter
                    i = n - 1
                else:
                    i -= 1
        s1 = (s0 + direction * distance) % perimeter
        points.append(self.locate(ring, s1)[0])
        return np.asarray(points, dtype=np.float64), s1

    @functools.cached_property
    def convex(self) -> tuple[FloatArray, ...]:
        """Per ring, the arclengths of its corners.

        A corner is a vertex where the border turns round blocked space (the blocked
        wedge there is narrower than a half turn): the robot rounds it.
        """
        out = []
        for k in range(len(self.rings)):
            lo, hi = int(self.offset[k]), int(self.offset[k + 1])
            out.append(self.cum[k][:-1][self.start_convex[lo:hi]])
        return tuple(out)

    def to_corner(self, ring: int, sigma: float, direction: int, gap: float) -> float:
        """Return the arclength from ``sigma`` to the next corner in ``direction``.

        Corners closer than ``gap`` are skipped; ``inf`` when there is none.
        """
        corners = self.convex[ring]
        if len(corners) == 0:
            return math.inf
        ahead = ((corners - sigma) * direction) % float(self.perimeter[ring])
        ahead = ahead[ahead >= gap]
        return float(ahead.min()) if len(ahead) else math.inf

    def ring_distance(
        self, ring: int, sigma0: float, sigma1: float, direction: int
    ) -> float:
        """Arclength from ``sigma0`` to ``sigma1`` walking in ``direction`` along ``ring``."""
        perimeter = float(self.perimeter[ring])
        return ((sigma1 - sigma0) * direction) % perimeter


def ring_geometry(cspace: ConfigurationSpace, *, cleaned: bool = True) -> RingGeometry:
    """Return (built once per configuration space) the border arrays the planners read.

    Kept on the configuration space (:meth:`ConfigurationSpace.derive`), not in a module
    cache, so that it goes away with it. ``cleaned`` drops repeated and collinear
    vertices within the configuration space's tolerance (the sensor's reading); False
    keeps the rings exactly as expanded (the visibility graph's). See the module
    docstring.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> geo = ring_geometry(space)
    >>> len(geo.rings), float(geo.perimeter[0]), float(geo.area[0])
    (1, 4.0, 1.0)
    >>> ring_geometry(space) is geo
    True
    """
    return cspace.derive(_build_ring_geometry, cleaned)


def _build_ring_geometry(cspace: ConfigurationSpace, cleaned: bool) -> RingGeometry:
    """Build the border arrays of :func:`ring_geometry` (pure)."""
    rings = []
    for r in cspace.rings:
        ring = clean_ring(r, cspace.eps) if cleaned else np.asarray(r)
        if len(ring) >= 3:
            rings.append(ring)
    if not rings:
        empty = np.zeros((0, 2))
        none = np.zeros(0, dtype=np.intp)
        return RingGeometry(
            rings=(),
            start=empty,
            end=empty,
            length=np.zeros(0),
            ring=none,
            offset=np.zeros(1, dtype=np.intp),
            prev_dir=empty,
            step=empty,
            unit=empty,
            len2=np.zeros(0),
            prev_edge=none,
            eps=cspace.eps,
            scale=1.0,
        )
    start = np.vstack(rings)
    sizes = [len(r) for r in rings]
    offset = np.concatenate([[0], np.cumsum(sizes)]).astype(np.intp)
    ring = np.repeat(np.arange(len(rings)), sizes).astype(np.intp)
    # Each ring's next and previous vertex, by index (each ring wraps round at its end).
    first, last = offset[:-1], offset[1:] - 1
    following = np.arange(1, len(start) + 1, dtype=np.intp)
    following[last] = first
    prev_edge = np.arange(-1, len(start) - 1, dtype=np.intp)
    prev_edge[first] = last
    end = start[following]
    step = end - start
    length = np.hypot(step[:, 0], step[:, 1])
    back = start[prev_edge] - start
    prev_dir = back / np.hypot(back[:, 0], back[:, 1])[:, None]
    scale = max(1.0, float(np.abs(start).max()))
    return RingGeometry(
        rings=tuple(rings),
        start=start,
        end=end,
        length=length,
        ring=ring,
        offset=offset,
        prev_dir=prev_dir,
        step=step,
        unit=step / length[:, None],
        len2=length * length,
        prev_edge=prev_edge,
        eps=cspace.eps,
        scale=scale,
    )


# --------------------------------------------------------------------------- edge index
#
# Which border edges can matter to a question asked near a point (section 9.6).
#
# The range sensor of :mod:`planners.bug.sensor` answers from one position: what lies within
# the range R (:func:`planners.bug.sensor.sense`), how far a ray goes
# (:func:`planners.bug.sensor.free_extent`), whether the robot touches the border. Its exact
# tests are arithmetic per edge; run over every edge of the border they cost O(m) numpy
# work per question, and TangentBug asks tens of thousands of questions on a big scene (a
# circle of ten thousand vertices: seconds). :class:`EdgeIndex` names, per question, a
# superset of the edges the test can flag; the exact test then runs on those only, in the
# same order (ascending edge index), so the answer is the very same.
#
# - :meth:`EdgeIndex.near_disk`: every edge with a point within ``r`` of ``x`` (a box query
#   on a shapely ``STRtree`` of the edges, padded), plus the edges of the *wide corners*.
# - :meth:`EdgeIndex.near_segment`: every edge within the pad of a segment.
#
# Wide corners. The sensor treats the robot as touching a corner when it lies within eps of
# both of the corner's edges' lines (:func:`planners.bug.sensor.measure_border`). Those points
# form a rhombus around the vertex reaching eps / sin(phi / 2) <= 2 eps / sin(phi) from it,
# phi the angle between the lines: far when the border hardly turns. Corners whose rhombus
# can reach farther than the pad are listed once and always included.


PAD_REL = 1e-3
"""Padding of every query, relative to the scene's size: far above the rounding of the
distances and of the sensor's tolerance tests (eps is about 1e-9 of the scene)."""


@dataclasses.dataclass(frozen=True, eq=False)
class EdgeIndex:
    """A spatial index of border edges a[k] -> b[k] (see the comment above :data:`PAD_REL`)."""

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
    >>> from planners.space.border import ring_geometry
    >>> from planners.space.expansion import configuration_space
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
