"""Random benchmark scenes: disjoint simple polygons in a square, plus start/goal queries.

Every scene is plain data (lists of floats) so that it can be sent as JSON to the peers'
interpreter, which runs another numpy. The generator is deterministic: the same
``(vertices, seed)`` gives the same scene on every machine.

Geometry
    Polygons are convex (vertices at jittered angles on a circle) or star-shaped
    (alternating outer and inner radius, so every other vertex is reflex). Each polygon
    lives in its own disk; disks are placed by rejection sampling with a gap between them,
    so polygons never touch or overlap. Rings are counter-clockwise, first vertex not
    repeated. The robot radius is 0: the polygons *are* the configuration-space obstacles,
    so all tools see the same geometry.
Queries
    Start and goal points are sampled in the square, outside every polygon and at least
    ``clearance`` away from every edge, with start and goal at least half the square apart.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

SIDE = 100.0
"""Side of the square the polygons are placed in [m]; pyvisgraph's ray casting needs < 10000."""
FILL = 0.22
"""Fraction of the square covered by the polygons' disks."""
GAP = 0.5
"""Smallest distance between two polygons' disks [m]."""
STAR_SHARE = 0.35
"""Fraction of star-shaped (non-convex) polygons."""


def _convex(
    rng: np.random.Generator, center: FloatArray, radius: float, k: int
) -> FloatArray:
    step = 2.0 * math.pi / k
    angles = rng.uniform(0.0, 2.0 * math.pi) + step * (
        np.arange(k) + rng.uniform(-0.35, 0.35, k)
    )
    return center + radius * np.column_stack([np.cos(angles), np.sin(angles)])


def _star(
    rng: np.random.Generator, center: FloatArray, radius: float, k: int
) -> FloatArray:
    # k is even: k / 2 spikes; inner vertices are reflex.
    step = 2.0 * math.pi / k
    angles = rng.uniform(0.0, 2.0 * math.pi) + step * (
        np.arange(k) + rng.uniform(-0.2, 0.2, k)
    )
    radii = np.where(np.arange(k) % 2 == 0, radius, radius * rng.uniform(0.3, 0.65, k))
    return center + radii[:, None] * np.column_stack([np.cos(angles), np.sin(angles)])


def _vertex_counts(rng: np.random.Generator, total: int) -> list[tuple[str, int]]:
    """Split ``total`` vertices into polygons: (kind, vertex count) pairs."""
    shapes: list[tuple[str, int]] = []
    left = total
    while left > 0:
        if rng.random() < STAR_SHARE and left >= 10:
            k = int(rng.choice([10, 12, 14]))
            kind = "star"
        else:
            k = int(rng.integers(3, 10))
            kind = "convex"
        if left - k < 3:  # never leave a remainder too small for a polygon
            k, kind = left, "convex"
        shapes.append((kind, k))
        left -= k
    return shapes


def _inside(point: FloatArray, ring: FloatArray) -> bool:
    x, y = point
    xi, yi = ring[:, 0], ring[:, 1]
    xj, yj = np.roll(xi, 1), np.roll(yi, 1)
    crosses = (yi > y) != (yj > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        at = xi + (y - yi) * (xj - xi) / (yj - yi)
    return bool(np.count_nonzero(crosses & (x < at)) % 2)


def _edge_distance(point: FloatArray, ring: FloatArray) -> float:
    a, b = ring, np.roll(ring, -1, axis=0)
    ab = b - a
    t = np.clip(
        np.einsum("ij,ij->i", point - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0
    )
    closest = a + t[:, None] * ab
    return float(np.hypot(*(closest - point).T).min())


def make_scene(
    vertices: int, seed: int = 0, queries: int = 4, clearance: float = 0.05
) -> dict[str, Any]:
    """Return a random scene with ``vertices`` polygon vertices in total.

    Parameters
    ----------
    vertices
        Total number of obstacle vertices (at least 3).
    seed
        Seed of ``numpy.random.default_rng``.
    queries
        Number of (start, goal) pairs.
    clearance
        Smallest distance from a start or goal to any obstacle edge [m].

    Returns
    -------
    dict
        ``{"name", "vertices", "seed", "side", "obstacles": [[[x, y], ...], ...],
        "queries": [[[sx, sy], [gx, gy]], ...]}``; rings counter-clockwise, open.
    """
    rng = np.random.default_rng(seed)
    shapes = _vertex_counts(rng, vertices)
    # Disk radius such that the disks cover about FILL of the square.
    mean_r = math.sqrt(FILL * SIDE * SIDE / (math.pi * len(shapes)))
    centers: list[FloatArray] = []
    radii: list[float] = []
    rings: list[FloatArray] = []
    for kind, k in shapes:
        for _attempt in range(10_000):
            r = mean_r * float(rng.uniform(0.6, 1.4))
            c = rng.uniform(r, SIDE - r, 2)
            if all(
                math.dist(c, c2) > r + r2 + GAP
                for c2, r2 in zip(centers, radii, strict=True)
            ):
                break
        else:
            raise RuntimeError(
                f"cannot place {len(shapes)} disjoint polygons (vertices={vertices})"
            )
        centers.append(c)
        radii.append(r)
        rings.append(_star(rng, c, r, k) if kind == "star" else _convex(rng, c, r, k))

    def free(p: FloatArray) -> bool:
        for c, r, ring in zip(centers, radii, rings, strict=True):
            if math.dist(p, c) < r + clearance and (
                _inside(p, ring) or _edge_distance(p, ring) < clearance
            ):
                return False
        return True

    pairs = []
    while len(pairs) < queries:
        s, g = rng.uniform(0.0, SIDE, 2), rng.uniform(0.0, SIDE, 2)
        if math.dist(s, g) >= SIDE / 2 and free(s) and free(g):
            pairs.append([s.tolist(), g.tolist()])
    return {
        "name": f"random-{vertices}-seed{seed}",
        "kind": "random",
        "vertices": int(sum(len(r) for r in rings)),
        "seed": seed,
        "side": SIDE,
        "obstacles": [r.tolist() for r in rings],
        "queries": pairs,
    }


def make_grid_scene(
    vertices: int, seed: int = 0, queries: int = 4, clearance: float = 0.05
) -> dict[str, Any]:
    """Return a grid-like scene: ``vertices // 4`` axis-aligned rectangles on a lattice.

    Each rectangle sits in its own lattice cell, its sides at one of two offsets and
    two sizes, so that rectangles in one lattice row or column share the lines of their
    edges: many collinear edges and vertices, the degenerate case of floor plans and
    shelves. Same keys as :func:`make_scene` (``"kind": "grid"``).
    """
    rng = np.random.default_rng(seed)
    count = max(1, vertices // 4)
    cols = math.ceil(math.sqrt(count))
    rows = math.ceil(count / cols)
    cells = sorted(rng.choice(cols * rows, size=count, replace=False).tolist())
    px, py = SIDE / cols, SIDE / rows
    rings = []
    for cell in cells:
        i, j = divmod(cell, rows)
        x0 = i * px + px * float(rng.choice([0.15, 0.25]))
        y0 = j * py + py * float(rng.choice([0.15, 0.25]))
        x1 = x0 + px * float(rng.choice([0.45, 0.6]))
        y1 = y0 + py * float(rng.choice([0.45, 0.6]))
        rings.append(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))

    def free(p: FloatArray) -> bool:
        return all(
            not (
                ring[0, 0] - clearance < p[0] < ring[1, 0] + clearance
                and ring[0, 1] - clearance < p[1] < ring[2, 1] + clearance
            )
            for ring in rings
        )

    pairs = []
    while len(pairs) < queries:
        s, g = rng.uniform(0.0, SIDE, 2), rng.uniform(0.0, SIDE, 2)
        if math.dist(s, g) >= SIDE / 2 and free(s) and free(g):
            pairs.append([s.tolist(), g.tolist()])
    return {
        "name": f"grid-{vertices}-seed{seed}",
        "kind": "grid",
        "vertices": 4 * len(rings),
        "seed": seed,
        "side": SIDE,
        "obstacles": [r.tolist() for r in rings],
        "queries": pairs,
    }


def validate(scene: dict[str, Any]) -> list[str]:
    """List what is wrong with a generated scene (uses shapely; empty when all is well)."""
    # Imported here: scenes.py itself needs only numpy.
    import shapely

    problems = []
    polygons = [shapely.Polygon(o) for o in scene["obstacles"]]
    for i, p in enumerate(polygons):
        if not p.is_valid:
            problems.append(f"obstacle {i} is not a valid polygon")
        if not shapely.LinearRing(scene["obstacles"][i]).is_ccw:
            problems.append(f"obstacle {i} is not counter-clockwise")
    tree = shapely.STRtree(polygons)
    a, b = tree.query(polygons, predicate="intersects")
    if np.any(a != b):
        problems.append("obstacles intersect")
    union = shapely.union_all(polygons)
    for q, (s, g) in enumerate(scene["queries"]):
        for label, p in (("start", s), ("goal", g)):
            if union.distance(shapely.Point(p)) <= 0.0:
                problems.append(f"query {q}: {label} is not in free space")
    return problems
