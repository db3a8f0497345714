"""The free space of an occupancy grid as polygons: traced exactly, then simplified inward.

1. **The region.** The free cells 4-connected to a seed cell (the start): a robot
   cannot slip between two blocked cells that meet at a corner, so cells that touch
   only diagonally are not connected. Free cells elsewhere (specks, pockets inside
   obstacles, other rooms) are not part of it: they are filled. There is no area
   threshold: every blocked cell inside the region stays an obstacle, however small.
2. **Pinches.** Where two of the region's cells still meet only at a corner (the region
   goes round and touches itself there), its border would touch itself, which no simple
   polygon can. One of the two cells is given up (:func:`planners.maps._loops.resolve_pinches`),
   never the seed's nor a protected point's unless both are; what is cut off by that is
   dropped too.
3. **Tracing.** The region's border is chained along cell edges into rings of corners
   (the outer ring and one ring per hole), exactly the border of the union of the
   region's cells: integer grid coordinates, no rounding.
4. **Simplifying inward.** Each ring is simplified within ``tolerance`` by
   Douglas-Peucker restricted so that only free space is given up
   (:func:`planners.maps._loops.simplify_ring`): a shortcut may cut off a piece of the
   region, never add to it, never a piece holding a protected point (the start, the
   goal), and never closer to one than the robot's radius. A shortcut that
   makes its ring cross or touch itself is undone. So the simplified free space is a
   subset of the traced one, and every point it loses is within ``tolerance`` of a
   blocked cell: free space shrinks by at most the tolerance and never grows. The
   outer ring and the holes may touch or overlap one another after this (a scenario's
   obstacles may touch or overlap its walls); each is a simple polygon.
"""

from __future__ import annotations

__all__ = [
    "UNKNOWN_AS",
    "FreeSpace",
    "connected_cells",
    "free_cells",
    "region_cells",
    "simplify_space",
    "trace_free_space",
    "trace_region",
]

import dataclasses
import itertools
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import shapely
from shapely import Polygon
from shapely.geometry.base import BaseGeometry

from planners.maps.grid import FREE, UNKNOWN, OccupancyMap

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
UNKNOWN_AS = ("occupied", "free")
"""How unknown cells count: as ``"occupied"`` (the default) or as ``"free"``."""


@dataclasses.dataclass(frozen=True, eq=False)
class FreeSpace:
    """A traced free region in the grid frame (cells, row 0 at the bottom).

    ``outer`` runs counter-clockwise and each hole clockwise (the free space on the
    left); the first vertex is not repeated.
    """

    region: BoolArray
    """The region's cells (rows, cols), after pinches were taken out."""
    outer: FloatArray
    """The outer ring (n, 2), grid coordinates (u, v)."""
    holes: tuple[FloatArray, ...]
    """The rings of the blocked areas inside."""

    def polygon(self) -> BaseGeometry:
        """Return the free space as one shapely polygon (overlapping holes merged)."""
        shell = Polygon(self.outer)
        if not self.holes:
            return shell
        holes = shapely.union_all([Polygon(h) for h in self.holes])
        return shell.difference(holes)


def free_cells(occupancy_map: OccupancyMap, unknown: str = "occupied") -> BoolArray:
    """Return which cells count as free: ``FREE``, and ``UNKNOWN`` when ``unknown="free"``."""
    if unknown not in UNKNOWN_AS:
        raise ValueError(f"unknown must be one of {UNKNOWN_AS}, got {unknown!r}")
    free = occupancy_map.cells == FREE
    if unknown == "free":
        free |= occupancy_map.cells == UNKNOWN
    return free


def blocked_islands(occupancy_map: OccupancyMap, unknown: str = "occupied") -> int:
    """Count the 4-connected groups of blocked cells (at most the obstacles a trace gives).

    Every obstacle of a traced scene holds one at least, so this is a bound on them,
    found in one pass over the cells without tracing (a caller that must refuse a map
    with too many obstacles asks this first).

    Examples
    --------
    >>> cells = np.zeros((3, 5), np.uint8)
    >>> cells[1, 1] = cells[1, 3] = 1  # OCCUPIED
    >>> blocked_islands(OccupancyMap(cells, 1.0, (0.0, 0.0, 0.0)))
    2
    """
    from planners.maps import _loops  # noqa: PLC0415 - numba only when a map is traced

    blocked = ~free_cells(occupancy_map, unknown)
    _, sizes = _loops.label_components(blocked.astype(np.uint8))
    return int(np.count_nonzero(sizes))


def connected_cells(free: BoolArray, seed: tuple[int, int]) -> BoolArray:
    """Return the free cells 4-connected to ``seed`` (row, col), pinches left as they are."""
    from planners.maps import _loops  # noqa: PLC0415 - numba only when a map is traced

    r0, c0 = seed
    return _loops.component(free.astype(np.uint8), r0, c0).astype(bool)


def region_cells(
    free: BoolArray, seed: tuple[int, int], keep: Sequence[tuple[int, int]] = ()
) -> BoolArray:
    """Return the free cells 4-connected to ``seed`` (row, col), pinches taken out.

    ``keep``: cells (row, col) not to give up at a pinch (the seed is one).

    Examples
    --------
    >>> free = np.array([[1, 1, 0], [1, 0, 1], [1, 1, 1]], bool)  # a ring pinched at a corner
    >>> region_cells(free, (0, 0)).astype(int).tolist()
    [[1, 0, 0], [1, 0, 1], [1, 1, 1]]
    """
    from planners.maps import _loops  # noqa: PLC0415 - numba only when a map is traced

    r0, c0 = seed
    padded = np.pad(free, 1).astype(np.uint8)
    region = _loops.component(padded, r0 + 1, c0 + 1)
    protected = np.zeros_like(region)
    for r, c in (seed, *keep):
        if 0 <= r < free.shape[0] and 0 <= c < free.shape[1]:
            protected[r + 1, c + 1] = 1
    if _loops.resolve_pinches(region, protected):
        region = _loops.component(region, r0 + 1, c0 + 1)
    return region[1:-1, 1:-1].astype(bool)


def trace_region(region: BoolArray) -> FreeSpace:
    """Trace the exact border of a 4-connected region without pinches (grid frame).

    Examples
    --------
    >>> region = np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]], bool)
    >>> space = trace_region(region)
    >>> space.outer.tolist(), [h.tolist() for h in space.holes]
    ([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0], [0.0, 3.0]], [[[1.0, 1.0], [1.0, 2.0], [2.0, 2.0], [2.0, 1.0]]])
    """
    from planners.maps import _loops  # noqa: PLC0415

    corners, starts = _loops.trace_rings(np.pad(region, 1).astype(np.uint8))
    rings = [
        corners[a:b].astype(np.float64) - 1.0 for a, b in itertools.pairwise(starts)
    ]
    areas = [_signed_area(r) for r in rings]
    outer = [r for r, a in zip(rings, areas, strict=True) if a > 0]
    if len(outer) != 1:
        raise ValueError(f"a 4-connected region has one outer ring, got {len(outer)}")
    holes = tuple(r for r, a in zip(rings, areas, strict=True) if a < 0)
    return FreeSpace(region, outer[0], holes)


def _signed_area(ring: FloatArray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def simplify_space(
    space: FreeSpace,
    tolerance: float,
    protected: FloatArray | None = None,
    clearance: float = 0.0,
) -> FreeSpace:
    """Simplify each ring of ``space`` within ``tolerance`` [cells], giving up free space only.

    ``protected``: points (k, 2) in the grid frame that stay in the free space, and no
    shortcut comes closer to them than ``clearance`` [cells]. Holes that the outer
    ring's shortcuts leave outside it are dropped (they lie in what is no longer free).
    See the module's docstring.
    """
    if tolerance <= 0:
        return space
    from planners.maps import _loops  # noqa: PLC0415

    padded = np.pad(space.region, 1).astype(np.uint8)
    points = np.zeros((0, 2)) if protected is None else np.asarray(protected, float)
    points = np.ascontiguousarray(points.reshape(-1, 2) + 1.0)

    def simplify(ring: FloatArray) -> FloatArray:
        shifted = ring + 1.0
        keep = _loops.simplify_ring(
            shifted[:, 0].copy(),
            shifted[:, 1].copy(),
            padded,
            float(tolerance),
            points,
            float(clearance),
        )
        return _untangled(ring, keep)

    outer = simplify(space.outer)
    holes = [simplify(h) for h in space.holes]
    if holes:
        inside = shapely.intersects(Polygon(outer), [Polygon(h) for h in holes])
        holes = [h for h, ok in zip(holes, inside, strict=True) if ok]
    return FreeSpace(space.region, outer, tuple(holes))


def _untangled(ring: FloatArray, keep: BoolArray) -> FloatArray:
    """Return the kept corners of ``ring``, shortcuts undone until the ring is simple.

    A shortcut (two kept corners with dropped corners between) that crosses or touches
    another edge of the ring gets its corners back; the exact ring is simple, so this
    ends, at worst with the exact ring.
    """
    keep = keep.copy()
    while True:
        kept = np.flatnonzero(keep)
        if len(kept) >= 3 and Polygon(ring[kept]).is_valid:
            return _without_straight_corners(ring[kept])
        bad = _tangled_edges(ring[kept])
        shortcut = np.diff(np.append(kept, kept[0] + len(ring))) > 1
        undo = bad & shortcut
        if len(kept) < 3 or not undo.any():
            return ring
        for e in np.flatnonzero(undo):
            start = kept[e]
            stop = kept[e + 1] if e + 1 < len(kept) else kept[0] + len(ring)
            keep[np.arange(start, stop) % len(ring)] = True


def _without_straight_corners(ring: FloatArray) -> FloatArray:
    """``ring`` without the corners where it goes straight on (exact: integer corners)."""
    before, after = ring - np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0) - ring
    turn = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    return ring[turn != 0] if np.count_nonzero(turn) >= 3 else ring


def _tangled_edges(points: FloatArray) -> BoolArray:
    """Which edges of a closed ring meet an edge other than at their shared corner."""
    n = len(points)
    ends = np.stack([points, np.roll(points, -1, axis=0)], axis=1)
    edges = np.asarray(shapely.linestrings(ends), dtype=object)
    tree = shapely.STRtree(edges)
    first, second = tree.query(edges, predicate="intersects")
    pair = first < second
    first, second = first[pair], second[pair]
    neighbours = (second - first == 1) | ((first == 0) & (second == n - 1))
    # Neighbours share a corner; they are tangled only when they overlap along a piece.
    overlap = np.zeros(len(first), dtype=bool)
    if neighbours.any():
        shared = shapely.intersection(
            edges[first[neighbours]], edges[second[neighbours]]
        )
        overlap[neighbours] = shapely.length(shared) > 0
    bad = np.zeros(n, dtype=bool)
    tangled = ~neighbours | overlap
    bad[first[tangled]] = True
    bad[second[tangled]] = True
    return bad


def trace_free_space(
    occupancy_map: OccupancyMap,
    seed: tuple[int, int],
    *,
    tolerance: float = 1.0,
    unknown: str = "occupied",
    protected: FloatArray | None = None,
    clearance: float = 0.0,
) -> FreeSpace:
    """Trace and simplify the free space around cell ``seed`` (row, col), grid frame.

    Parameters
    ----------
    occupancy_map
        The map.
    seed
        A free cell of the region to trace.
    tolerance
        How far [cells] the simplified border may move into the free space; 0 keeps the
        exact border of the cells.
    unknown
        ``"occupied"`` or ``"free"``: how unknown cells count.
    protected
        Points (k, 2) in the grid frame whose cells are never given up at a pinch and
        which stay in the simplified free space (the start and the goal).
    clearance
        How far [cells] the simplified borders stay from the protected points (the
        robot's radius: simplifying never takes its room at the start or the goal).
    """
    points = np.zeros((0, 2)) if protected is None else np.asarray(protected, float)
    cells = [(int(v), int(u)) for u, v in np.floor(points.reshape(-1, 2))]
    region = region_cells(free_cells(occupancy_map, unknown), seed, cells)
    return simplify_space(trace_region(region), tolerance, points, clearance)
