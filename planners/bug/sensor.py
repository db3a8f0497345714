"""A simulated 360-degree range sensor in the configuration space (section 9.6).

The robot is a point in the configuration space of :mod:`planners.space.expansion`. Its sensor
sees the border of the free space (expanded obstacles and shrunk walls) up to a range R.
:func:`sense` returns what it sees, computed exactly on the polygons:

- the visible border within R: the part of the border that a straight segment from the
  robot reaches without entering blocked space (a visibility polygon clipped to the
  sensing disk), as line segments;
- the discontinuity points O_i of the range function: the ends of every continuous piece of
  visible border, where the range jumps (an occluding vertex, or the occluded point behind
  it) or where the visible border meets the circle of radius R. With the robot they form
  the local tangent graph of the chapter (Fig. 9.16) and of TangentBug.

How. The border is a set of directed edges with blocked space on their left, so an edge
can be seen only from its right (it "faces" the robot). Around the robot, the angles of the
facing edges' end points and of their crossings with the sensing circle cut the full turn
into intervals inside which the order of the edges along a ray cannot change (edges of the
border never cross). One ray through the middle of each interval finds the nearest edge;
the interval's visible piece is that edge between the two bounding angles. This is an
exact angular sweep over the critical angles, compiled
(:func:`planners.kernels.sweep_intervals`). A robot standing on the border (it may
touch it) cannot look into the blocked wedge at its feet; the two edges along the wedge's
sides are seen edge-on and are added as pieces running straight away from the robot.

On a big border (:data:`_INDEX_MIN_EDGES` edges or more) only the edges that a spatial
index (:mod:`planners.space.border`) names near the robot, or near a ray, are measured:
every test here is per edge, so the answers are the same as over every edge.

Touching is up to eps (the configuration space's tolerance): a ray is blocked where it
goes more than eps deep into blocked space. Far from the robot that changes nothing
visible, but a vertex a few eps away does matter: the wedge at the robot's feet follows
the corner (the robot sees past a convex corner's tip thinner than eps, and a slight bend
of the border hides what lies behind it), and critical angles that are one up to eps are
merged rather than leave slivers between them.

References
----------
I. Kamon, E. Rivlin and E. Rimon, "TangentBug: A range-sensor-based navigation algorithm",
International Journal of Robotics Research 17(9), 1998.
H. Choset et al., Principles of Robot Motion, MIT Press, 2005, section 2.3.
"""

from __future__ import annotations

__all__ = [
    "RingGeometry",
    "Sensing",
    "disk_span",
    "free_extent",
    "measure_border",
    "nearby",
    "ring_geometry",
    "sense",
    "visible_pieces",
]

import dataclasses
import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from planners.space.border import RingGeometry, ring_geometry
from planners.space.expansion import ConfigurationSpace
from planners.space.geometry import cross

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

TAU = 2.0 * math.pi
# Rounding error allowed on a difference of two coordinates, relative to the scene's size
# (256 ulps: the sensor's arithmetic and GEOS's agree far better than that).
_ROUNDING = 2.0**-44


# --------------------------------------------------------------------------- what the sensor sees


OCCLUDING = "occluding"
OCCLUDED = "occluded"
RANGE = "range"


@dataclasses.dataclass(frozen=True, eq=False)
class Sensing:
    """What the range sensor sees from one position: plain arrays, ready to draw.

    Pieces and discontinuity points are listed counter-clockwise around the robot.
    """

    position: FloatArray
    """Where the robot stands, shape (2,) [m]."""
    radius: float
    """Sensing range R [m]; ``math.inf`` when unlimited."""
    segments: FloatArray
    """Visible border within R, shape (K, 2, 2): each piece from its first to its last
    point counter-clockwise [m]. Pieces along the border the robot stands on included."""
    segment_ring: IntArray
    """(K,) ring (index into :attr:`RingGeometry.rings`) of each piece."""
    segment_edge: IntArray
    """(K,) flat edge index of each piece."""
    points: FloatArray
    """The discontinuity points O_i, shape (M, 2) [m]."""
    kinds: tuple[str, ...]
    """For each O_i: ``"occluding"`` (the near end of a range jump, e.g. a corner seen
    edge-on), ``"occluded"`` (the far end of a jump, behind an occluding corner) or
    ``"range"`` (where the visible border meets the circle of radius R)."""
    ring: IntArray
    """(M,) ring of each O_i."""
    edge: IntArray
    """(M,) flat edge index of each O_i."""
    t: FloatArray
    """(M,) parameter of each O_i along its edge, in [0, 1]."""
    follow: IntArray
    """(M,) ring direction (+1 forward, -1 backward) that leads from the visible piece
    along the border to this O_i: the boundary-following direction "toward O_i"."""
    chain: IntArray
    """(M,) which continuous piece of visible border each O_i ends (its two ends share it)."""
    segment_chain: IntArray
    """(K,) the continuous piece of visible border each segment belongs to."""

    @property
    def blocked(self) -> bool:
        """Whether any border is in view."""
        return len(self.segments) > 0


@dataclasses.dataclass
class _Item:
    """One angular interval of the sweep: a visible piece, free range, or the blocked wedge."""

    kind: str  # "piece" | "free" | "blocked"
    lo: float
    hi: float
    edge: int = -1
    t0: float = 0.0  # edge parameter at the counter-clockwise first point
    t1: float = 0.0  # ... and at the last point
    p0: tuple[float, float] = (0.0, 0.0)
    p1: tuple[float, float] = (0.0, 0.0)


@dataclasses.dataclass(frozen=True)
class _Occurrence:
    """The robot touching the border: a blocked wedge counter-clockwise from ``n`` to ``q``.

    The wedge is where a ray from the robot enters blocked space shrunk by eps (the
    touching tolerance) right at the robot's feet. Along its two sides the border runs away
    from the robot, seen edge-on: ``edge_n`` from parameter ``t_n`` on (ring forward), and
    ``edge_q`` from ``t_q`` back (ring backward). Those points (the feet) are where the
    robot stands on the border: its own position up to eps, or the corner it touches.
    """

    n: tuple[float, float]  # unit direction of the wedge's clockwise side
    q: tuple[float, float]  # unit direction of the wedge's counter-clockwise side
    edge_n: int  # edge running away from the feet along (about) n, ring forward
    edge_q: int  # edge running away from the feet along (about) q, ring backward
    t_n: float  # parameter of the feet on edge_n
    t_q: float  # parameter of the feet on edge_q

    @property
    def narrow(self) -> bool:
        """Whether the blocked wedge is narrower than a half turn (a convex corner)."""
        return self.n[0] * self.q[1] - self.n[1] * self.q[0] > 0


_INDEX_MIN_EDGES = 512
"""Borders with at least this many edges are measured through their spatial index
(:mod:`planners.space.border`): only the edges near the question. Below, numpy over every
edge costs less than the index query. Either way the answer is the same."""


class Near(NamedTuple):
    """The border measured from one position (:func:`measure_border`).

    Per measured edge: its start relative to the position, its distance, and cross(a, b);
    then the blocked wedges at the robot's feet. Either every edge is measured
    (``edges`` None) or, on a big border, the edges near the position (``edges``, sorted
    flat indices): every edge within ``reach`` of it and every edge that can touch it.
    """

    edges: IntArray | None
    reach: float
    a: FloatArray
    dist: FloatArray
    cr: FloatArray
    occ: list[_Occurrence]

    def local(self, e: int) -> int:
        """Position of flat edge ``e`` in the measured arrays (``e`` is measured)."""
        return e if self.edges is None else int(np.searchsorted(self.edges, e))


def nearby(geo: RingGeometry, center: npt.ArrayLike, reach: float) -> IntArray | None:
    """Return the edges that may lie within ``reach`` of ``center``, or None for all.

    None when the border is measured whole anyway (small, or ``reach`` unlimited). For
    several questions asked near one place: :func:`measure_border` at a position p
    with ``among`` this set is exact when |p - center| + R <= ``reach``, R its reach.
    """
    if len(geo.start) < _INDEX_MIN_EDGES or not math.isfinite(reach):
        return None
    return geo.index.near_disk(np.asarray(center, dtype=np.float64).reshape(2), reach)


def measure_border(
    geo: RingGeometry,
    position: npt.ArrayLike,
    reach: float = math.inf,
    *,
    among: IntArray | None = None,
) -> Near:
    """Measure the border from ``position``, for several questions asked from there.

    A planner often asks two questions from the same position (one ray with
    :func:`free_extent`, then the full view with :func:`sense` or
    :func:`visible_pieces`); passing them this measurement as ``near`` spares the second
    one the work. ``reach`` is the farthest the questions look around (the sensing range
    R; a ray may go farther): on a big border only the edges that close are measured,
    looked for among the edges of :func:`nearby` if given (a superset found once for
    several positions). The value is read only, never changed by the functions it is passed to.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> geo = ring_geometry(configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0))
    >>> near = measure_border(geo, (-1.0, 0.5), 2.0)
    >>> free_extent(geo, (-1.0, 0.5), (1.0, 0.0), 5.0, near=near)
    (1.0, 0)
    """
    x = np.asarray(position, dtype=np.float64).reshape(2)
    return _measure(geo, x, float(reach), among=among)


def _measure(
    geo: RingGeometry,
    x: FloatArray,
    reach: float,
    *,
    indexed: bool | None = None,
    among: IntArray | None = None,
) -> Near:
    """Measure the border from ``x`` and find the blocked wedges at the robot's feet.

    Within eps of the border the robot touches it, and a ray is blocked only where it
    goes deeper than eps into blocked space. At the scale of eps the polygons' corners
    matter, so the wedges follow the corners near the robot:

    - a corner is touched when the robot lies within eps of both its edges' lines (for
      instance within eps of the vertex, or on one edge a few eps from a vertex where the
      border turns only slightly). The wedge is the corner's own, as if the robot stood on
      the vertex: between the two edges, which run away from the vertex edge-on;
    - otherwise an edge within eps of the robot blocks the half turn on its blocked side,
      its sides made exact toward the edge's ends (:func:`_side_toward`): narrowed toward
      a convex corner, past which the robot sees through the corner's tip where blocked
      space is thinner than eps; widened toward a reflex corner when the robot stands
      inside the edge's line, to the ray through the vertex.

    ``indexed`` (default: by the border's size, :data:`_INDEX_MIN_EDGES`) measures only
    the edges :meth:`EdgeIndex.near_disk` names within ``reach`` (at least eps), or
    ``among``, a superset of those; every test below is per edge, so the answer is the
    same.
    """
    if indexed is None:
        indexed = len(geo.start) >= _INDEX_MIN_EDGES
    edges = among
    if edges is None and indexed and math.isfinite(reach):
        edges = geo.index.near_disk(x, max(reach, geo.eps))
    rows = _edge_rows(geo, x, edges)
    along = (
        -(rows.ax * rows.dx + rows.ay * rows.dy) / rows.len2
    )  # foot of x on each line
    t = np.minimum(np.maximum(along, 0.0), 1.0)
    dist = np.hypot(rows.ax + t * rows.dx, rows.ay + t * rows.dy)
    cr = rows.ax * rows.dy - rows.ay * rows.dx
    # Edges whose line passes within eps of x (few): the robot may touch them.
    where = np.flatnonzero(np.abs(cr) <= rows.eps_length)
    occ = _occurrences(geo, x, edges, where, along, t, dist) if len(where) else []
    return Near(edges, reach, rows.a, dist, cr, occ)


class _Rows(NamedTuple):
    """The measured edges as columns: start relative to the robot, step, lengths."""

    a: FloatArray  # (k, 2) edge start - robot
    ax: FloatArray  # its columns (views)
    ay: FloatArray
    dx: FloatArray  # edge step
    dy: FloatArray
    len2: FloatArray  # squared edge length
    eps_length: FloatArray  # eps times the edge length


def _edge_rows(geo: RingGeometry, x: FloatArray, edges: IntArray | None) -> _Rows:
    """Gather the measured edges (every edge when ``edges`` is None) relative to ``x``."""
    if edges is None:
        a = geo.start - x
        return _Rows(
            a, a[:, 0], a[:, 1], geo.step_x, geo.step_y, geo.len2, geo.eps_length
        )
    # One gather of the index's packed rows: the same numbers.
    sx, sy, dx, dy, len2, eps_length = geo.index.packed[:, edges]
    a = np.empty((len(edges), 2))
    ax, ay = a[:, 0], a[:, 1]
    np.subtract(sx, x[0], out=ax)
    np.subtract(sy, x[1], out=ay)
    return _Rows(a, ax, ay, dx, dy, len2, eps_length)


def _occurrences(  # noqa: PLR0917 - the measured columns of the lined edges
    geo: RingGeometry,
    x: FloatArray,
    edges: IntArray | None,
    where: IntArray,
    along: FloatArray,
    t: FloatArray,
    dist: FloatArray,
) -> list[_Occurrence]:
    """Find the blocked wedges at the robot's feet among the edges it is lined up with.

    ``where``: positions (in the measured arrays) of the edges whose line passes within
    eps of ``x``; ``along``, ``t`` and ``dist`` the foot of ``x`` on every measured edge's
    line, clipped to the edge, and its distance. A touched corner gives its own wedge
    (:func:`_corner_wedge`); an edge touched elsewhere its half turn (:func:`_edge_wedge`).
    """
    lined = (where if edges is None else edges[where]).tolist()
    along_of = dict(zip(lined, along[where].tolist(), strict=True))
    corner = _touched_corners(geo, lined, along_of)
    touching = {
        e for e, d in zip(lined, dist[where].tolist(), strict=True) if d <= geo.eps
    }
    t_of = dict(zip(lined, t[where].tolist(), strict=True))
    nxt = geo.next_edge
    occ: list[_Occurrence] = []
    for e in sorted(touching | corner):
        if e in corner:
            occ.append(_corner_wedge(geo, e))
        if e in touching and e not in corner and int(nxt[e]) not in corner:
            occ.append(_edge_wedge(geo, x, e, t_of[e]))
    return occ


def _touched_corners(
    geo: RingGeometry, lined: list[int], along_of: dict[int, float]
) -> set[int]:
    """Return the corners (by the edge they start) whose two edges' lines pass within eps.

    The robot is not beyond the far end of either edge: it lies before the end of the
    edge the corner starts (``along`` < 1) and after the start of the one it ends (> 0).
    """
    prev = geo.prev_edge
    return {
        e
        for e in lined
        if int(prev[e]) in along_of
        and along_of[e] < 1.0
        and along_of[int(prev[e])] > 0.0
    }


def _corner_wedge(geo: RingGeometry, e: int) -> _Occurrence:
    """Return a touched corner's own wedge, as if the robot stood on the vertex.

    The corner is the start of edge ``e``; its two edges run away from it edge-on.
    """
    n = (float(geo.unit[e, 0]), float(geo.unit[e, 1]))
    q = (float(geo.prev_dir[e, 0]), float(geo.prev_dir[e, 1]))
    return _Occurrence(n, q, e, int(geo.prev_edge[e]), 0.0, 1.0)


def _edge_wedge(geo: RingGeometry, x: FloatArray, e: int, t: float) -> _Occurrence:
    """Return the half turn an edge touched at parameter ``t`` blocks, its sides made exact.

    Toward the edge's ends (:func:`_side_toward`): narrowed toward a convex corner,
    widened toward a reflex one.
    """
    ux, uy = float(geo.unit[e, 0]), float(geo.unit[e, 1])
    n = _side_toward(geo, x, int(geo.next_edge[e]), (ux, uy), -1.0)
    q = _side_toward(geo, x, e, (-ux, -uy), 1.0)
    return _Occurrence(n, q, e, e, t, t)


def _side_toward(
    geo: RingGeometry,
    x: FloatArray,
    vertex: int,
    side: tuple[float, float],
    turn: float,
) -> tuple[float, float]:
    """Return a touched edge's half-turn side toward the edge's end ``vertex``, made exact.

    The half turn is drawn as if the robot stood on the edge's line; it stands within eps
    of it, and near the end of the edge the difference shows. ``vertex`` is that end (the
    start of that flat edge); the half turn lies counter-clockwise of ``side`` when
    ``turn`` is -1 (its first side), clockwise when 1 (its last side).

    - At a convex corner, a ray passing just outside the corner, closer to it than eps,
      does not go eps deep: the side narrows to the ray grazing the corner shrunk by eps.
      That ray touches it, which the segment test counts as entering, so the side is
      turned outward by the angle's rounding error: whatever is seen past the corner stays
      clear of it. A side that would hardly move keeps the edge's direction.
    - At a reflex corner, a robot on the blocked side of the line sees the line cross
      beyond the vertex, into blocked space behind the vertex's other edge: the side
      widens to the ray through the vertex, where that edge (seen by the sweep) begins.
    """
    sx, sy = side
    convex = geo.corner_list[vertex]
    tx, ty = geo.eroded_list[vertex] if convex else geo.start_list[vertex]
    wx, wy = tx - float(x[0]), ty - float(x[1])
    # Angle from the ray to the side, positive when the ray lies inside the half turn.
    gap = turn * math.atan2(wx * sy - wy * sx, wx * sx + wy * sy)
    if not convex:
        return side if gap >= 0 else (wx / math.hypot(wx, wy), wy / math.hypot(wx, wy))
    margin = _ROUNDING * geo.scale / max(math.hypot(wx, wy), geo.eps)
    if not gap > margin:
        return side
    angle = math.atan2(wy, wx) + turn * margin
    return (math.cos(angle), math.sin(angle))


def _in_any_wedge(occ: list[_Occurrence], ux: float, uy: float) -> bool:
    """Tell whether the unit direction (ux, uy) points strictly into a blocked wedge."""
    for o in occ:
        (nx, ny), (qx, qy) = o.n, o.q
        if o.narrow:
            if nx * uy - ny * ux > 0 and ux * qy - uy * qx > 0:
                return True
        elif not (qx * uy - qy * ux >= 0 and ux * ny - uy * nx >= 0):
            return True
    return False


def sense(
    cspace: ConfigurationSpace | RingGeometry,
    position: npt.ArrayLike,
    sensor_range: float,
    *,
    near: Near | None = None,
) -> Sensing:
    """Compute what a 360-degree range sensor of range R sees from ``position``.

    Parameters
    ----------
    cspace
        The configuration space (or its :func:`ring_geometry`).
    position
        The robot, shape (2,), in closed free space (it may touch the border) [m].
    sensor_range
        R [m], positive; ``math.inf`` for an unlimited sensor.
    near
        :func:`measure_border` at ``position``, if the caller already has it.

    Returns
    -------
    Sensing
        The visible border pieces and the discontinuity points O_i.

    Examples
    --------
    A unit square seen from (-1, 0.5): its left side is visible, and its two left corners
    are occluding corners (the range jumps to "nothing" beyond them).

    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0)
    >>> seen = sense(space, (-1.0, 0.5), 5.0)
    >>> seen.segments.tolist()
    [[[0.0, 0.0], [0.0, 1.0]]]
    >>> seen.points.tolist(), seen.kinds
    ([[0.0, 0.0], [0.0, 1.0]], ('occluding', 'occluding'))

    From (-0.6, 0.5) with R = 0.75 only the middle of that side is within range; the O_i
    are where it meets the circle.

    >>> seen = sense(space, (-0.6, 0.5), 0.75)
    >>> seen.points.round(9).tolist(), seen.kinds
    ([[0.0, 0.05], [0.0, 0.95]], ('range', 'range'))

    References
    ----------
    I. Kamon, E. Rivlin and E. Rimon, "TangentBug: A range-sensor-based navigation
    algorithm", International Journal of Robotics Research 17(9), 1998.
    """
    geo = cspace if isinstance(cspace, RingGeometry) else ring_geometry(cspace)
    x = np.asarray(position, dtype=np.float64).reshape(2)
    radius = float(sensor_range)
    if not radius > 0:
        raise ValueError(f"sensor_range must be positive, got {sensor_range}")
    items = _sweep(geo, x, radius, near)
    return _assemble(geo, x, radius, items)


def visible_pieces(
    geo: RingGeometry,
    position: npt.ArrayLike,
    sensor_range: float,
    ring: int,
    *,
    near: Near | None = None,
) -> FloatArray:
    """Return the pieces of ``ring`` that :func:`sense` reports, shape (K, 2, 2) [m].

    For a caller that needs only what is in view of one ring (TangentBug's d_reach),
    not the discontinuity points: the same pieces, without joining them into chains.
    """
    x = np.asarray(position, dtype=np.float64).reshape(2)
    rings = geo.ring_list
    mine = [
        (it.p0, it.p1)
        for it in _sweep(geo, x, float(sensor_range), near)
        if it.kind == "piece" and rings[it.edge] == ring
    ]
    return np.array(mine, dtype=np.float64).reshape(-1, 2, 2)


_KINDS = ("piece", "free", "blocked")
"""Item kinds by the compiled sweep's codes (:data:`planners.kernels.PIECE` ...)."""


def _sweep(
    geo: RingGeometry, x: FloatArray, radius: float, near: Near | None = None
) -> list[_Item]:
    """Cut the full turn at the critical angles and say what each interval sees.

    The border is measured from the robot as arrays (:func:`_measure`); the edges that
    face it within R go to the compiled sweep (:func:`planners.kernels.sweep_intervals`):
    clipped to the sensing disk (parts shorter than eps dropped), the angles of their
    ends and of the wedges' sides at the robot's feet merged where they are one up to eps
    (the kernel's ``_merge_close_angles`` says how), one ray through the middle of
    each interval to the nearest edge whose part spans it, and that edge's visible piece
    between the interval's bounding angles. The pieces running edge-on away from the
    robot's feet are added here (:func:`_add_edge_on_pieces`).
    """
    if len(geo.start) == 0:
        return []
    from planners.kernels import sweep_intervals  # noqa: PLC0415 - numba on first use

    if near is None or (near.edges is not None and near.reach < radius):
        near = _measure(geo, x, radius)
    dist, cr, occ = near.dist, near.cr, near.occ
    # Every edge that faces the robot, however obliquely (an edge whose line passes within
    # eps of the robot still hides what lies behind it), except the edges of the wedges at
    # its feet, which include every edge it touches.
    front = cr < 0
    for o in occ:
        front[near.local(o.edge_n)] = front[near.local(o.edge_q)] = False
    if math.isfinite(radius):
        front &= dist < radius
    f = np.flatnonzero(front)
    ids = f if near.edges is None else near.edges[f]
    wedges = np.array([(*o.n, *o.q) for o in occ], dtype=np.float64).reshape(-1, 4)
    here = (float(x[0]), float(x[1]))
    kinds, edges, values = sweep_intervals(
        (ids, near.a[f], cr[f], dist[f]),
        (geo.start, geo.step, geo.len2, geo.length),
        wedges,
        here,
        radius,
        geo.eps,
    )
    items = [
        _Item(_KINDS[k], lo, hi, e, t0, t1, (p0x, p0y), (p1x, p1y))
        for k, e, (lo, hi, t0, t1, p0x, p0y, p1x, p1y) in zip(
            kinds.tolist(), edges.tolist(), values.tolist(), strict=True
        )
    ]
    if occ:
        items = _add_edge_on_pieces(geo, x, radius, items, occ)
    return items


def _add_edge_on_pieces(
    geo: RingGeometry,
    x: FloatArray,
    radius: float,
    items: list[_Item],
    occ: list[_Occurrence],
) -> list[_Item]:
    """Insert, at each side of a blocked wedge, the border running straight away from the robot.

    The wedge's ends become the feet of those pieces (where the robot stands on the
    border), so that the border runs on continuously through the wedge.
    """
    out: list[_Item] = []
    n = len(items)
    for i, it in enumerate(items):
        nxt = items[(i + 1) % n]
        out.append(it)
        if it.kind == "blocked" and nxt.kind != "blocked":
            # Leaving the wedge counter-clockwise: the border behind the robot (along q).
            o = min(occ, key=lambda o: _angle_gap(math.atan2(o.q[1], o.q[0]), it.hi))
            t_far = _leave_disk(geo, o.edge_q, x, radius, -1)
            out.append(_radial(geo, o.edge_q, o.t_q, min(o.t_q, t_far), it.hi))
            it.p1 = out[-1].p0
        elif it.kind != "blocked" and nxt.kind == "blocked":
            # Entering the wedge: the border ahead of the robot (along n), walked inward.
            o = min(occ, key=lambda o: _angle_gap(math.atan2(o.n[1], o.n[0]), it.hi))
            t_far = _leave_disk(geo, o.edge_n, x, radius, 1)
            out.append(_radial(geo, o.edge_n, max(o.t_n, t_far), o.t_n, it.hi))
            nxt.p0 = out[-1].p1
    return out


def _leave_disk(
    geo: RingGeometry, e: int, x: FloatArray, radius: float, direction: int
) -> float:
    """Return the parameter where edge ``e``, walked forward (1) or back (-1), leaves the disk.

    The edge runs through the robot's feet, inside the disk; 1 (or 0) when it ends first.
    Measured from the robot itself, not from the feet (a touched corner may be a few eps
    away).
    """
    if not math.isfinite(radius):
        return 1.0 if direction > 0 else 0.0
    sx, sy = geo.start_list[e]
    dx, dy = geo.step_list[e]
    t_in, t_out, _ = disk_span(
        sx - float(x[0]), sy - float(x[1]), dx, dy, geo.len2_list[e], radius * radius
    )
    return t_out if direction > 0 else t_in


def disk_span(  # noqa: PLR0917 - a scalar kernel, on Python floats
    ax: float, ay: float, dx: float, dy: float, len2: float, r2: float
) -> tuple[float, float, bool]:
    """Return where a segment lies in a disk: (t_in, t_out, whether its line meets it).

    The segment runs from (ax, ay) by the step (dx, dy), of squared length ``len2``,
    relative to the disk's centre; ``r2`` is the disk's squared radius. Points
    (ax, ay) + t (dx, dy) with t in [t_in, t_out] lie in the disk, t_in and t_out
    clipped to [0, 1] (t_in > t_out when the segment stops short of the disk). When the
    line misses the disk, both are its point closest to the centre, clipped.

    Examples
    --------
    >>> disk_span(-2.0, 0.0, 4.0, 0.0, 16.0, 1.0)  # from x = -2 to 2 through the unit disk
    (0.25, 0.75, True)
    >>> disk_span(-2.0, 3.0, 4.0, 0.0, 16.0, 1.0)[2]  # the line y = 3 misses it
    False
    """
    qb = 2.0 * (ax * dx + ay * dy)
    qc = ax * ax + ay * ay - r2
    disc = qb * qb - 4.0 * len2 * qc
    root = math.sqrt(max(disc, 0.0))
    return (
        max(0.0, (-qb - root) / (2.0 * len2)),
        min(1.0, (-qb + root) / (2.0 * len2)),
        disc >= 0,
    )


def _radial(geo: RingGeometry, e: int, t0: float, t1: float, angle: float) -> _Item:
    """Return the piece of edge ``e`` from parameter ``t0`` to ``t1``, seen edge-on at ``angle``."""
    sx, sy = geo.start_list[e]
    dx, dy = geo.step_list[e]
    return _Item(
        "piece",
        angle,
        angle,
        e,
        t0,
        t1,
        (sx + t0 * dx, sy + t0 * dy),
        (sx + t1 * dx, sy + t1 * dy),
    )


def _angle_gap(a: float, b: float) -> float:
    return abs((a - b + math.pi) % TAU - math.pi)


# A numeric kernel, kept whole: one pass over the sweep's items, joining chains.
def _assemble(
    geo: RingGeometry, x: FloatArray, radius: float, items: list[_Item]
) -> Sensing:
    """Join consecutive pieces into continuous chains; their ends are the O_i."""
    x0, y0 = float(x[0]), float(x[1])
    n = len(items)
    tol = geo.join_tol
    finite = math.isfinite(radius)

    def depth(p: tuple[float, float]) -> float:
        return math.hypot(p[0] - x0, p[1] - y0)

    # Consecutive items join when neither is free range and their ends meet (a blocked
    # wedge starts and ends at the robot's feet).
    joined = [False] * n
    if n > 1:
        for i in range(n):
            it, nxt = items[i], items[(i + 1) % n]
            if it.kind != "free" and nxt.kind != "free":
                p, q = it.p1, nxt.p0
                joined[i] = math.hypot(p[0] - q[0], p[1] - q[1]) <= tol
    chain_id = [0] * n
    breaks = [i for i in range(n) if not joined[i]]
    begin = (breaks[0] + 1) % n if breaks else 0
    current = 0
    for k in range(n):
        i = (begin + k) % n
        chain_id[i] = current
        if not joined[i]:
            current += 1

    def kind_of(
        p: tuple[float, float], other: _Item, other_point: tuple[float, float]
    ) -> str:
        dp = depth(p)
        if finite and dp >= radius * (1.0 - 1e-9) - geo.eps:
            return RANGE
        if other.kind == "free":
            return OCCLUDING
        return OCCLUDING if dp < depth(other_point) else OCCLUDED

    pts: list[tuple[float, float]] = []
    chain_of_o: list[int] = []
    kinds: list[str] = []
    edges: list[int] = []
    ts: list[float] = []
    follow: list[int] = []
    for i in range(n):
        if joined[i]:
            continue  # continuous: no O here
        it, nxt = items[i], items[(i + 1) % n]
        if it.kind == "piece":
            pts.append(it.p1)
            chain_of_o.append(chain_id[i])
            kinds.append(kind_of(it.p1, nxt, nxt.p0))
            edges.append(it.edge)
            ts.append(it.t1)
            follow.append(-1)
        if nxt.kind == "piece" and n > 1:
            pts.append(nxt.p0)
            chain_of_o.append(chain_id[(i + 1) % n])
            kinds.append(kind_of(nxt.p0, it, it.p1))
            edges.append(nxt.edge)
            ts.append(nxt.t0)
            follow.append(1)
    pieces = [it for it in items if it.kind == "piece"]
    seg_edge = np.array([it.edge for it in pieces], dtype=np.intp)
    edge_arr = np.array(edges, dtype=np.intp)
    return Sensing(
        position=x.copy(),
        radius=radius,
        segments=np.array([(it.p0, it.p1) for it in pieces], dtype=np.float64).reshape(
            -1, 2, 2
        ),
        segment_ring=geo.ring[seg_edge],
        segment_edge=seg_edge,
        points=np.array(pts, dtype=np.float64).reshape(-1, 2),
        kinds=tuple(kinds),
        ring=geo.ring[edge_arr],
        edge=edge_arr,
        t=np.array(ts, dtype=np.float64),
        follow=np.array(follow, dtype=np.intp),
        chain=np.array(chain_of_o, dtype=np.intp),
        segment_chain=np.array(
            [chain_id[i] for i, it in enumerate(items) if it.kind == "piece"],
            dtype=np.intp,
        ),
    )


# --------------------------------------------------------------------------- one ray


def free_extent(
    geo: RingGeometry,
    position: npt.ArrayLike,
    direction: npt.ArrayLike,
    limit: float,
    *,
    near: Near | None = None,
) -> tuple[float, int]:
    """How far the robot can go from ``position`` along a unit ``direction``, up to ``limit``.

    Exact on the polygons: the segment may run along the border or touch a vertex (that is
    free), it stops where it would enter blocked space: in a blocked wedge at the robot's
    feet, at the first proper crossing of an edge (:func:`_first_crossing`), or at a
    vertex on the way where it turns into blocked space (:func:`_first_vertex_turn`),
    whichever comes first. ``near`` is :func:`measure_border` at ``position``, if the
    caller already has it.

    Returns
    -------
    tuple
        (distance [m], ring that stops it or -1 when nothing does within ``limit``).

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.space.expansion import configuration_space
    >>> geo = ring_geometry(configuration_space((Polygon([(0, 0), (1, 0), (1, 1), (0, 1)]),), 0.0))
    >>> free_extent(geo, (-1.0, 0.5), (1.0, 0.0), 5.0)
    (1.0, 0)
    >>> free_extent(geo, (-1.0, 0.0), (1.0, 0.0), 5.0)  # along the bottom side: free
    (5.0, -1)
    """
    x = np.asarray(position, dtype=np.float64).reshape(2)
    u = np.asarray(direction, dtype=np.float64).reshape(2)
    if len(geo.start) == 0 or limit <= 0:
        return max(float(limit), 0.0), -1
    if near is None:
        near = _measure(geo, x, 0.0 if math.isfinite(limit) else math.inf)
    # At the robot's feet: touching the border, it may look straight into blocked space.
    ux, uy = float(u[0]), float(u[1])
    for o in near.occ:
        if _in_any_wedge([o], ux, uy):
            return 0.0, int(geo.ring[o.edge_n])
    ray = _ray_edges(geo, near, x, u, float(limit))
    best, ring = _first_crossing(geo, ray, float(limit))
    return _first_vertex_turn(geo, ray, best, ring)


class _RayEdges(NamedTuple):
    """The edges that may stop a ray, relative to its start."""

    u: FloatArray  # the ray's unit direction
    cand: IntArray | None  # their flat indices, None for every edge
    a: FloatArray  # (k, 2) edge start - ray start
    sub: slice | IntArray  # index of these edges into the flat arrays


def _ray_edges(
    geo: RingGeometry, near: Near, x: FloatArray, u: FloatArray, limit: float
) -> _RayEdges:
    """Return the edges that may stop the ray from ``x`` along ``u`` up to ``limit``.

    All, those measured (when the ray stays within their reach), or those near the ray
    (the same answer: every test is per edge).
    """
    cand, a = near.edges, near.a
    if cand is not None and not limit <= near.reach:
        cand = geo.index.near_segment(x, x + limit * u)
        a = geo.start[cand] - x
    return _RayEdges(u, cand, a, slice(None) if cand is None else cand)


def _first_crossing(
    geo: RingGeometry, ray: _RayEdges, limit: float
) -> tuple[float, int]:
    """Return the first proper crossing of the ray's segment with an edge: (distance, ring).

    (``limit``, -1) when there is none. Touching (within eps) is not crossing.
    """
    tol, sub = geo.eps, ray.sub
    ux, uy = float(ray.u[0]), float(ray.u[1])
    dx, dy = geo.step_x[sub], geo.step_y[sub]
    ax, ay = ray.a[:, 0], ray.a[:, 1]
    yx, yy = limit * ux, limit * uy
    oa = yx * ay - yy * ax
    ob = yx * (ay + dy) - yy * (ax + dx)
    ox = -(dx * ay - dy * ax)
    oy = dx * (yy - ay) - dy * (yx - ax)
    tol_y = tol * limit
    tol_d = tol * geo.length[sub]
    proper = (((oa > tol_y) & (ob < -tol_y)) | ((oa < -tol_y) & (ob > tol_y))) & (
        ((ox > tol_d) & (oy < -tol_d)) | ((ox < -tol_d) & (oy > tol_d))
    )
    if not proper.any():
        return limit, -1
    idx = np.flatnonzero(proper)
    s = (ax[idx] * dy[idx] - ay[idx] * dx[idx]) / (ux * dy[idx] - uy * dx[idx])
    k = int(np.argmin(s))
    if s[k] < limit:
        return float(s[k]), int(geo.ring[sub][idx[k]])
    return limit, -1


def _first_vertex_turn(
    geo: RingGeometry, ray: _RayEdges, best: float, ring: int
) -> tuple[float, int]:
    """Return the ray's stop: a vertex on it before ``best`` where it turns into blocked space.

    The ray may run along the border or touch a vertex (free); it stops at a vertex
    where it would pass into the blocked wedge between the vertex's two edges. Else
    (``best``, ``ring``), the stop found so far.
    """
    tol, u = geo.eps, ray.u
    ux, uy = float(u[0]), float(u[1])
    ax, ay = ray.a[:, 0], ray.a[:, 1]
    along = ax * ux + ay * uy
    off = np.abs(ux * ay - uy * ax)
    on = (off <= tol) & (along > tol) & (along < best + tol)
    if not on.any():
        return best, ring
    idx = np.flatnonzero(on)
    glob = idx if ray.cand is None else ray.cand[idx]
    nxt = geo.unit[glob]
    prv = geo.prev_dir[glob]
    narrow = cross(nxt, prv) > 0
    uu = np.broadcast_to(u, nxt.shape)
    inside = np.where(
        narrow,
        (cross(nxt, uu) > 1e-12) & (cross(uu, prv) > 1e-12),
        ~((cross(prv, uu) >= -1e-12) & (cross(uu, nxt) >= -1e-12)),
    )
    if not inside.any():
        return best, ring
    hit = idx[inside]
    k = int(np.argmin(along[hit]))
    if along[hit][k] < best:
        return float(along[hit][k]), int(geo.ring[ray.sub][hit[k]])
    return best, ring
