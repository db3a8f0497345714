"""Obstacle expansion: from the robot's workspace to its configuration space (section 9.3).

The robot is shrunk to a point and every obstacle grows by the robot's shape (Minkowski
sum); the walls of the environment shrink by the same amount. Two models of the robot:

``"disk"``
    The exact model. Arcs of the Minkowski sum are replaced by polylines whose edges are
    *tangent* to the circle, so the polygon encloses the exact sum (the chapter: models
    "must enclose the true geometry"). Straight parts are exact.
``"square"``
    The chapter's simplified, conservative model: the robot's axis-aligned enclosing square
    (side = diameter). The Minkowski sum is exact, also for non-convex polygons.

Overlapping expanded obstacles merge into one region, which can enclose pockets of free
space (holes). :class:`ConfigurationSpace` carries everything the planners need.
"""

from __future__ import annotations

__all__ = [
    "DEFAULT_ARC_STEP",
    "ConfigurationSpace",
    "configuration_space",
    "expand_disk",
    "expand_polygon",
    "expand_square",
    "shrink_boundary",
]

import dataclasses
import math
from collections.abc import Callable, Hashable, Iterable
from typing import Any, NamedTuple, TypeVar

import numpy as np
import numpy.typing as npt
import shapely
from shapely import MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry

from planners.memo import Memo
from planners.space.geometry import clean_ring

DEFAULT_ARC_STEP = math.pi / 8
"""Largest angle [rad] one tangent edge of an expanded arc spans (22.5 degrees)."""

# Relative tolerance of the geometry: points closer than EPS * scale count as touching.
EPS = 1e-9

FloatArray = npt.NDArray[np.float64]
T = TypeVar("T")


def _ccw_rings(polygon: Polygon) -> list[FloatArray]:
    """Rings of ``polygon`` as open (k, 2) arrays with the polygon's interior on the left."""
    oriented = shapely.geometry.polygon.orient(polygon, sign=1.0)
    rings = [oriented.exterior, *oriented.interiors]
    return [_open_ring(np.asarray(r.coords, dtype=np.float64)) for r in rings]


def _all_ccw_rings(polygons: Iterable[BaseGeometry]) -> list[FloatArray]:
    """Every ring of every polygon, as :func:`_ccw_rings` gives them, in a few calls.

    One vectorised orientation, one coordinate array, and the repeated vertices and
    closing points dropped with masks: a configuration space of forty obstacles spent
    more time in per-polygon calls than in its union.
    """
    shapes = np.asarray(list(polygons), dtype=object)
    if not len(shapes):
        return []
    oriented = shapely.orient_polygons(shapes)
    rings = shapely.get_rings(oriented)
    coords, ring = shapely.get_coordinates(rings, return_index=True)
    starts = np.flatnonzero(np.r_[True, ring[1:] != ring[:-1]])
    ends = np.r_[starts[1:], len(ring)]
    # A ring's closing point repeats its first: dropped (as _open_ring does).
    closed = (ends - starts > 1) & np.all(coords[starts] == coords[ends - 1], axis=1)
    keep = np.ones(len(coords), dtype=bool)
    keep[(ends - 1)[closed]] = False
    coords, ring = coords[keep], ring[keep]
    starts = np.flatnonzero(np.r_[True, ring[1:] != ring[:-1]])
    ends = np.r_[starts[1:], len(ring)]
    # Each vertex against the one before it in its ring, the first against the last.
    before = np.arange(len(coords)) - 1
    before[starts] = ends - 1
    new = np.any(coords != coords[before], axis=1)
    whole = np.add.reduceat(new, starts) > 0  # a ring of one repeated point: keep one
    new[starts[~whole]] = True
    return np.split(coords[new], np.flatnonzero(np.diff(ring[new])) + 1)


def _open_ring(coords: FloatArray) -> FloatArray:
    coords = (
        coords[:-1]
        if len(coords) > 1 and np.array_equal(coords[0], coords[-1])
        else coords
    )
    # Drop repeated consecutive vertices: they carry no geometry and have no edge direction.
    keep = np.any(coords != np.roll(coords, 1, axis=0), axis=1)
    return coords[keep] if keep.any() else coords[:1]


def _tangent_arc(
    center: FloatArray, n0: FloatArray, n1: FloatArray, radius: float, arc_step: float
) -> FloatArray:
    """Outer vertices of a polyline tangent to the circle from normal ``n0`` to ``n1``.

    The arc turns counter-clockwise by less than pi. With k edges of angle delta each, the
    vertices sit at radius ``radius / cos(delta / 2)``: every edge touches the circle at
    its middle, so the polyline lies on or outside the circle, never inside it.
    """
    turn = math.atan2(float(n0[0] * n1[1] - n0[1] * n1[0]), float(np.dot(n0, n1)))
    k = max(1, math.ceil(turn / arc_step - 1e-12))
    delta = turn / k
    a0 = math.atan2(n0[1], n0[0])
    angles = a0 + delta * (np.arange(k) + 0.5)
    reach = radius / math.cos(delta / 2.0)
    return center + reach * np.column_stack([np.cos(angles), np.sin(angles)])


def _edge_normals(ring: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return unit outward normals of each edge i -> i+1 and the turn (cross) at each vertex."""
    edges = np.roll(ring, -1, axis=0) - ring
    lengths = np.hypot(edges[:, 0], edges[:, 1])
    normals = np.column_stack([edges[:, 1], -edges[:, 0]]) / lengths[:, None]
    incoming = np.roll(edges, 1, axis=0)
    turns = incoming[:, 0] * edges[:, 1] - incoming[:, 1] * edges[:, 0]
    return normals, turns


def expand_disk(
    polygon: Polygon, radius: float, arc_step: float = DEFAULT_ARC_STEP
) -> Polygon:
    """Expand ``polygon`` by a disk of ``radius``: a polygon enclosing the Minkowski sum.

    Straight parts of the boundary are offset exactly by ``radius``. Around each convex
    corner the circular arc is replaced by edges tangent to the circle, each spanning at
    most ``arc_step`` radians, so the result contains the exact sum. Worst-case overshoot
    (distance beyond the exact sum) is ``radius * (1 / cos(arc_step / 2) - 1)``: 1.96 % of
    the radius for the default step of 22.5 degrees, 0.48 % for 11.25 degrees.

    Parameters
    ----------
    polygon
        A valid polygon, any orientation, holes allowed [m].
    radius
        Disk radius [m]; 0 returns the polygon unchanged.
    arc_step
        Largest angle of one tangent edge [rad], in (0, pi/2].

    Returns
    -------
    Polygon
        The expanded polygon (holes that close up disappear).

    Examples
    --------
    >>> square = Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
    >>> grown = expand_disk(square, 0.5)
    >>> grown.bounds  # straight sides are exact
    (-0.5, -0.5, 1.5, 1.5)
    >>> round(grown.area, 4)  # a little more than 1 + 4 * 0.5 + pi * 0.25 = 3.7854
    3.7956

    References
    ----------
    T. Lozano-Perez and M. A. Wesley, "An algorithm for planning collision-free paths among
    polyhedral obstacles", Communications of the ACM 22(10), 1979.
    """
    if radius < 0:
        raise ValueError(f"radius must be non-negative, got {radius}")
    if not 0 < arc_step <= math.pi / 2:
        raise ValueError(f"arc_step must be in (0, pi/2], got {arc_step}")
    if radius == 0:
        return polygon
    rings = _ccw_rings(polygon)
    if len(rings) == 1:
        ring = rings[0]
        normals, turns = _edge_normals(ring)
        scale = _scale(ring)
        if np.all(turns > -EPS * scale * scale):
            # Convex polygon: walk the corners; consecutive corner arcs are joined by the
            # exactly offset straight edges, so no union is needed.
            parts = []
            for i in range(len(ring)):
                if turns[i] > EPS * scale * scale:
                    parts.append(
                        _tangent_arc(
                            ring[i], normals[i - 1], normals[i], radius, arc_step
                        )
                    )
                else:  # a straight-through vertex: nothing to round off
                    parts.append(ring[i] + radius * normals[i][None, :])
            return Polygon(np.vstack(parts))
    pieces: list[BaseGeometry] = [polygon]
    for ring in rings:
        normals, turns = _edge_normals(ring)
        following = np.roll(ring, -1, axis=0)
        offset = radius * normals
        quads = np.stack([ring, following, following + offset, ring + offset], axis=1)
        pieces.extend(np.asarray(shapely.polygons(quads)).tolist())
        for i in np.flatnonzero(turns > 0):
            arc = _tangent_arc(ring[i], normals[i - 1], normals[i], radius, arc_step)
            fan = np.vstack(
                [ring[i], ring[i] + offset[i - 1], arc, ring[i] + offset[i]]
            )
            pieces.append(Polygon(fan))
    merged = shapely.union_all(pieces)
    return _largest_polygon(_drop_collinear(merged))


def expand_square(polygon: Polygon, radius: float) -> Polygon:
    """Expand ``polygon`` by the axis-aligned square of half-side ``radius``: exactly.

    This is the chapter's enclosing-square model of a disk robot (Fig. 9.8): the square's
    side is the disk's diameter. For a region A and a convex kernel K containing the
    origin, A + K = A united with (edge + K) for every boundary edge, and each edge + K is
    the convex hull of two translated squares, so the result is exact for non-convex
    polygons too.

    Examples
    --------
    >>> triangle = Polygon([(0, 0), (2, 0), (0, 2)])
    >>> list(expand_square(triangle, 0.5).exterior.coords)
    [(-0.5, -0.5), (2.5, -0.5), (2.5, 0.5), (0.5, 2.5), (-0.5, 2.5), (-0.5, -0.5)]
    """
    if radius < 0:
        raise ValueError(f"radius must be non-negative, got {radius}")
    if radius == 0:
        return polygon
    corners = radius * np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    rings = _ccw_rings(polygon)
    if len(rings) == 1 and polygon.equals(polygon.convex_hull):
        points = (rings[0][:, None, :] + corners[None, :, :]).reshape(-1, 2)
        return _clean_convex(shapely.MultiPoint(points).convex_hull)
    pieces: list[BaseGeometry] = [polygon]
    for ring in rings:
        following = np.roll(ring, -1, axis=0)
        for a, b in zip(ring, following, strict=True):
            pieces.append(
                shapely.MultiPoint(np.vstack([a + corners, b + corners])).convex_hull
            )
    return _largest_polygon(_drop_collinear(shapely.union_all(pieces)))


def _clean_convex(geometry: BaseGeometry) -> Polygon:
    if not isinstance(geometry, Polygon):  # a hull of 4+ squares' corners has area
        raise TypeError(f"expected a polygon, got {geometry.geom_type}")
    return shapely.geometry.polygon.orient(geometry, sign=1.0)


def expand_polygon(
    polygon: Polygon,
    radius: float,
    mode: str = "disk",
    arc_step: float = DEFAULT_ARC_STEP,
) -> Polygon:
    """Expand one obstacle by the robot: ``mode`` is ``"disk"`` or ``"square"``."""
    if mode == "disk":
        return expand_disk(polygon, float(radius), float(arc_step))
    if mode == "square":
        return expand_square(polygon, float(radius))
    raise ValueError(f"unknown expansion mode {mode!r} (expected 'disk' or 'square')")


def shrink_boundary(
    boundary: Polygon,
    radius: float,
    mode: str = "disk",
    arc_step: float = DEFAULT_ARC_STEP,
) -> Polygon | MultiPolygon:
    """Shrink the walls by the robot: the region where the robot's centre may go.

    It is the boundary minus the expansion of everything outside it (a Minkowski
    erosion), so it is conservative exactly when the expansion is. A narrow part of the
    room can pinch off: the result is then a MultiPolygon, or empty.

    Examples
    --------
    >>> room = Polygon([(0, 0), (4, 0), (4, 3), (0, 3)])
    >>> shrink_boundary(room, 0.5).bounds
    (0.5, 0.5, 3.5, 2.5)
    """
    if radius == 0:
        return boundary
    minx, miny, maxx, maxy = boundary.bounds
    margin = 2.0 * radius + 1.0
    frame = shapely.box(minx - margin, miny - margin, maxx + margin, maxy + margin)
    # The frame minus a simple boundary is one polygon with the room as its hole.
    outside = _largest_polygon(frame.difference(boundary))
    grown = expand_polygon(outside, radius, mode, arc_step)
    shrunk = boundary.difference(grown)
    return shrunk if isinstance(shrunk, (Polygon, MultiPolygon)) else MultiPolygon()


def _scale(points: FloatArray) -> float:
    return max(1.0, float(np.abs(points).max(initial=0.0)))


def _drop_collinear(geometry: BaseGeometry) -> BaseGeometry:
    """Remove vertices on the straight line through their neighbours, and sliver holes.

    Unions of offset pieces leave such vertices where pieces meet, and sometimes holes of
    area ~1e-17 from rounding; both would become useless visibility-graph nodes. The
    tolerance is relative (1e-12 of the coordinate scale), far below anything a user can
    see or a test measures. A cleaning that would make a polygon invalid is not applied.
    """
    polygons = list(getattr(geometry, "geoms", [geometry]))
    cleaned = []
    for polygon in polygons:
        if not isinstance(polygon, Polygon) or polygon.is_empty:
            continue
        scale = _scale(np.asarray(polygon.exterior.coords))
        holes = [
            np.asarray(r.coords)
            for r in polygon.interiors
            if Polygon(r).area > 1e-12 * scale * scale
        ]
        original = Polygon(polygon.exterior, holes)
        rings = [_cleaned(np.asarray(polygon.exterior.coords))] + [
            _cleaned(h) for h in holes
        ]
        if len(rings[0]) < 3:
            continue
        candidate = Polygon(rings[0], [r for r in rings[1:] if len(r) >= 3])
        cleaned.append(candidate if candidate.is_valid else original)
    if len(cleaned) == 1:
        return cleaned[0]
    return MultiPolygon(cleaned)


def _cleaned(coords: FloatArray) -> FloatArray:
    ring = _open_ring(coords)
    return clean_ring(ring, 1e-12 * _scale(ring), repeats=False)


def _largest_polygon(geometry: BaseGeometry) -> Polygon:
    # The expansion of one connected polygon is connected; a MultiPolygon here can only
    # come from numerical slivers of the union, which are dropped.
    if isinstance(geometry, Polygon):
        return geometry
    parts = [g for g in getattr(geometry, "geoms", []) if isinstance(g, Polygon)]
    return max(parts, key=lambda p: p.area)


@dataclasses.dataclass(frozen=True, eq=False)
class ConfigurationSpace:
    """The robot's configuration space: where its centre may and may not go.

    The blocked region is the union of the expanded obstacles plus everything outside
    the shrunk boundary. Free space is the closed complement: its boundary is free, so a
    path may run along an expanded edge or touch a vertex, never cut through an interior.
    """

    expanded: tuple[Polygon, ...]
    """Each obstacle expanded by the robot, in the scene's order (for drawing) [m]."""
    merged: MultiPolygon
    """Union of the expanded obstacles; overlapping ones merge, pockets become holes."""
    boundary: Polygon | MultiPolygon | None
    """The shrunk walls, or None on an unbounded floor."""
    free: Polygon | MultiPolygon | None
    """Shrunk walls minus the merged obstacles, or None on an unbounded floor."""
    rings: tuple[FloatArray, ...]
    """Every ring of the free space's border, open (k, 2), with blocked space on the left."""
    eps: float
    """Distance [m] below which two things count as touching (relative to the scene)."""

    def derive(self, fn: Callable[..., T], *args: Hashable) -> T:
        """Return ``fn(self, *args)``, computed once for this configuration space.

        What the planners derive from a configuration space (the border's arrays, which
        vertices see each other) is kept on it, not in a module-level cache, and goes
        away with it. ``fn`` must be pure and a module-level function (the key is the
        function itself: a new lambda each call would never be found again); two threads
        asking at once may both compute it, and either answer is the same. What is kept
        is not pickled with the configuration space (a worker process derives it again).

        Examples
        --------
        >>> from planners.space.border import ring_geometry
        >>> space = configuration_space((Polygon([(0, 0), (1, 0), (1, 1)]),), 0.0)
        >>> ring_geometry(space) is ring_geometry(space)  # derived once, then kept
        True
        """
        store: dict[Any, Any] = self.__dict__.setdefault("_derived", {})
        key = (fn, args)
        try:
            return store[key]
        except KeyError:
            value = store[key] = fn(self, *args)
            return value

    def known(self, fn: Callable[..., T], *args: Hashable) -> T | None:
        """Return ``fn(self, *args)`` if :meth:`derive` already computed it, else None."""
        return self.__dict__.get("_derived", {}).get((fn, args))

    def adopt(self, fn: Callable[..., T], value: T, *args: Hashable) -> None:
        """Keep ``value`` as what :meth:`derive` would compute for ``fn(self, *args)``.

        For a value found another way that is proven equal (the vertex visibility
        carried over from the space before an edit: :mod:`planners.visibility.incremental`). What
        was derived already stays.
        """
        self.__dict__.setdefault("_derived", {}).setdefault((fn, args), value)

    def __getstate__(self) -> dict[str, Any]:
        """Pickle the configuration space without what was derived from it."""
        state = dict(self.__dict__)
        state.pop("_derived", None)
        return state

    def contains_blocked(self, points: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """Tell, for each point of shape (2,) or (N, 2), if it is strictly in blocked space.

        Points on the border of free space (within ``eps``) are free.
        """
        xy = np.atleast_2d(np.asarray(points, dtype=np.float64))
        x, y = xy[:, 0], xy[:, 1]
        if self.free is not None:
            blocked = ~shapely.intersects_xy(self.free, x, y)
        else:
            blocked = shapely.contains_xy(self.merged, x, y)
        if blocked.any():
            idx = np.flatnonzero(blocked)
            border = self.derive(_prepared_border)
            near = shapely.dwithin(border, shapely.points(xy[idx]), self.eps)
            blocked[idx[near]] = False
        return blocked

    def blockers(self, point: npt.ArrayLike) -> list[str]:
        """Name what blocks ``point``: ``"obstacle 2"``, ``"outside the boundary"``, ..."""
        p = shapely.Point(np.asarray(point, dtype=np.float64))
        names = [
            f"obstacle {i + 1}"
            for i, e in enumerate(self.expanded)
            if e.contains(p) and e.exterior.distance(p) > self.eps
        ]
        if self.boundary is not None and not self.boundary.buffer(self.eps).covers(p):
            names.append("outside the boundary")
        return names

    def obstacle_near(self, point: npt.ArrayLike) -> int | None:
        """Name the obstacle whose expanded outline is nearest ``point`` (1-based).

        This is how a robot's events are labelled (H2, M3: Fig. 9.19). None when the
        walls are nearer than any obstacle.

        Examples
        --------
        >>> a, b = Polygon([(0, 0), (1, 0), (1, 1)]), Polygon([(3, 0), (4, 0), (4, 1)])
        >>> configuration_space((a, b), 0.0).obstacle_near((2.9, 0.2))
        2
        """
        p = shapely.Point(np.asarray(point, dtype=np.float64).reshape(2))
        best, which = math.inf, None
        if self.expanded:
            outlines = np.asarray([e.exterior for e in self.expanded], dtype=object)
            dist = shapely.distance(outlines, p)
            k = int(np.argmin(dist))
            best, which = float(dist[k]), k + 1
        if (
            self.boundary is not None
            and float(shapely.distance(self.boundary.boundary, p)) < best
        ):
            return None
        return which


def _prepared_border(cspace: ConfigurationSpace) -> BaseGeometry:
    """Return the free space's border (or the merged obstacles'), prepared for distances."""
    region = cspace.free if cspace.free is not None else cspace.merged
    border = region.boundary
    shapely.prepare(border)
    return border


def configuration_space(
    obstacles: tuple[Polygon, ...],
    radius: float,
    mode: str = "disk",
    boundary: Polygon | None = None,
    arc_step: float = DEFAULT_ARC_STEP,
    *,
    extra_points: npt.ArrayLike | None = None,
    memo: Memo | None = None,
) -> ConfigurationSpace:
    """Expand every obstacle, merge overlaps, shrink the boundary.

    With a ``memo`` (owned by the caller), work is reused by value: while a user drags
    the start or the goal the same configuration space (and everything the planners
    derived from it) comes back, and while one obstacle is dragged only that obstacle is
    expanded again. Without one, everything is computed afresh.

    Parameters
    ----------
    obstacles
        Valid obstacle polygons [m].
    radius
        Robot radius [m].
    mode
        ``"disk"`` or ``"square"``.
    boundary
        Walls, or None for an unbounded floor.
    arc_step
        Resolution of the disk model's arcs [rad].
    extra_points
        Points (start, goal) that take part in setting the tolerance scale.
    memo
        The caller's memo, or None for cold work.

    Examples
    --------
    >>> a = Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
    >>> b = Polygon([(1.2, 0), (2, 0), (2, 1), (1.2, 1)])
    >>> space = configuration_space((a, b), 0.2, "square")
    >>> len(space.merged.geoms), space.merged.geoms[0].bounds  # the gap closed
    (1, (-0.2, -0.2, 2.2, 1.2))
    """
    # Every ring's coordinates in one call (a polygon's largest |coordinate| is on its
    # exterior, so the holes change nothing).
    shapes = [*obstacles, *([boundary] if boundary is not None else [])]
    coords = [shapely.get_coordinates(np.asarray(shapes, dtype=object))]
    if extra_points is not None:
        coords.append(np.atleast_2d(np.asarray(extra_points, dtype=np.float64)))
    scale = _scale(np.vstack(coords))
    # The tolerance grows with the coordinates' magnitude, in powers of two so that
    # moving the start a little keeps the same (cached) configuration space.
    eps = EPS * 2.0 ** math.ceil(math.log2(scale))
    memo = memo if memo is not None else Memo()
    key = _SpaceKey(
        tuple(obstacles), float(radius), mode, boundary, float(arc_step), eps
    )
    return memo.get("cspace", key, lambda: _build(key, memo))


class _SpaceKey(NamedTuple):
    """Everything a configuration space depends on (hashable, compared by value)."""

    obstacles: tuple[Polygon, ...]
    radius: float
    mode: str
    boundary: Polygon | None
    arc_step: float
    eps: float


def _build(key: _SpaceKey, memo: Memo) -> ConfigurationSpace:
    obstacles, radius, mode, boundary, arc_step, eps = key
    # Polygons hash by value, so during a drag only the dragged obstacle is expanded again.
    expanded = tuple(
        memo.get(
            "expanded",
            (o, radius, mode, arc_step),
            lambda o=o: expand_polygon(o, radius, mode, arc_step),
        )
        for o in obstacles
    )
    union = _merge(expanded, memo.latest("cspace"))
    merged = union.geometry
    shrunk = (
        memo.get(
            "shrunk",
            (boundary, radius, mode, arc_step),
            lambda: shrink_boundary(boundary, radius, mode, arc_step),
        )
        if boundary is not None
        else None
    )
    if shrunk is not None:
        free = (
            _as_multipolygon(shrunk.difference(merged))
            if not merged.is_empty
            else _as_multipolygon(shrunk)
        )
        shapely.prepare(free)
        # Free space on the left of its oriented rings; reversed, blocked space is.
        rings = tuple(r[::-1].copy() for r in _all_ccw_rings(free.geoms))
        free_region: Polygon | MultiPolygon | None = free
    else:
        rings = tuple(_all_ccw_rings(merged.geoms))
        free_region = None
    shapely.prepare(merged)
    for ring in rings:
        ring.flags.writeable = False  # shared through the cache: nobody may change it
    space = ConfigurationSpace(
        expanded=expanded,
        merged=merged,
        boundary=shrunk,
        free=free_region,
        rings=rings,
        eps=eps,
    )
    space.adopt(_group_unions, union.groups)
    return space


@dataclasses.dataclass(frozen=True)
class _Merged:
    """The union of the expanded obstacles, and the union of each group it was made of."""

    geometry: MultiPolygon
    """The union: every group's parts, groups in the order of their first members."""
    groups: dict[tuple[int, ...], MultiPolygon]
    """Per group of overlapping expanded obstacles, its union, keyed by the members'
    identities (in the scene's order): the configuration space holds the members, so
    while it lives no other object has their ids."""


def _merge(
    expanded: tuple[Polygon, ...], previous: ConfigurationSpace | None
) -> _Merged:
    """Unite the expanded obstacles one group of overlapping ones at a time.

    Obstacles that do not intersect stay apart in the union, so the union is the
    union of each connected group (two obstacles are connected when they intersect,
    touching included): the same region as one union of everything, up to rounding
    (where a group's obstacles cross, the crossing points are computed within the
    group). It is computed so even without an edit, because uniting each group is
    both cheaper than one union of everything (GEOS nodes all the disjoint groups
    together) and the same function of the group whatever else changed: a group that
    an edit left alone is taken from the configuration space before it, bit for bit
    what it would be afresh.

    Parameters
    ----------
    expanded
        The expanded obstacles, in the scene's order.
    previous
        The configuration space before this one (from the caller's memo), or None.

    Returns
    -------
    _Merged
        The union, and each group's union (kept on the new configuration space).
    """
    # Both spaces are alive here, so a member of ``previous`` with a new member's id is
    # that very polygon (an expansion the memo kept, unchanged by the edit); by value
    # it is no different, and comparing identities spares hashing every polygon.
    known = previous.known(_group_unions) if previous is not None else None
    groups: dict[tuple[int, ...], MultiPolygon] = {}
    parts: list[Polygon] = []
    for group in _overlapping_groups(expanded):
        members = tuple(expanded[i] for i in group)
        key = tuple(map(id, members))
        union = known.get(key) if known is not None else None
        if union is None:
            union = _as_multipolygon(
                shapely.union_all(np.asarray(members, dtype=object))
            )
        groups[key] = union
        parts.extend(union.geoms)
    return _Merged(MultiPolygon(parts), groups)


def _overlapping_groups(shapes: tuple[Polygon, ...]) -> list[list[int]]:
    """Split ``shapes`` into groups connected by intersection, each in ascending order.

    Groups come in the order of their first members.

    Examples
    --------
    >>> a, b = shapely.box(0, 0, 1, 1), shapely.box(1, 0, 2, 1)  # touching
    >>> _overlapping_groups((a, shapely.box(5, 5, 6, 6), b))
    [[0, 2], [1]]
    """
    if not shapes:
        return []
    array = np.asarray(shapes, dtype=object)
    first, second = shapely.STRtree(array).query(array, predicate="intersects")
    root = list(range(len(shapes)))

    def find(i: int) -> int:
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    for i, j in zip(first.tolist(), second.tolist(), strict=True):
        ri, rj = find(i), find(j)
        if ri != rj:
            root[max(ri, rj)] = min(ri, rj)
    groups: dict[int, list[int]] = {}
    for i in range(len(shapes)):
        groups.setdefault(find(i), []).append(i)
    return list(groups.values())


def _group_unions(space: ConfigurationSpace) -> dict[tuple[int, ...], MultiPolygon]:
    """Return the union of each group of ``space``'s overlapping expanded obstacles."""
    return _merge(space.expanded, None).groups


def _as_multipolygon(geometry: BaseGeometry) -> MultiPolygon:
    if isinstance(geometry, MultiPolygon):
        return geometry
    if isinstance(geometry, Polygon):
        return MultiPolygon([geometry]) if not geometry.is_empty else MultiPolygon()
    parts = [
        g
        for g in getattr(geometry, "geoms", [])
        if isinstance(g, Polygon) and not g.is_empty
    ]
    return MultiPolygon(parts)
