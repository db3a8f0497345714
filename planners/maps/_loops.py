"""The compiled loops of the trace: flood fills, pinches, edge chaining, simplification.

Each is a loop over cells or vertices that numpy cannot run as whole-array operations
(a flood fill, a walk along a border, a recursion over a ring). Like
:mod:`planners.kernels` they are compiled by numba with ``cache=True`` and ``nogil=True``,
keep no state, and are imported on first use by :mod:`planners.maps.trace`, so that
importing the planners does not load numba.

Masks are ``uint8`` arrays (1 in the region, 0 outside), row 0 at the bottom. The
*padded* mask has one more row and column of zeros on every side, so that every border
of the region lies between two cells of the array; vertex (x, y) of the padded grid is
the corner shared by cells (y - 1, x - 1), (y - 1, x), (y, x - 1) and (y, x).
"""

from __future__ import annotations

__all__ = [
    "component",
    "label_components",
    "resolve_pinches",
    "simplify_ring",
    "trace_rings",
    "warm_up",
]

import numpy as np
import numpy.typing as npt
from numba import njit

Mask = npt.NDArray[np.uint8]
FloatArray = npt.NDArray[np.float64]

# --------------------------------------------------------------------------- regions


@njit(cache=True, nogil=True)
def _fill(  # noqa: PLR0917
    mask: Mask,
    labels: npt.NDArray[np.int32] | Mask,
    stack: npt.NDArray[np.int32],
    r0: int,
    c0: int,
    label: int,
) -> int:
    """Give ``label`` to the 4-connected cells of ``mask`` around (r0, c0); return how many."""
    rows, cols = mask.shape
    top = 0
    stack[top] = r0 * cols + c0
    top += 1
    labels[r0, c0] = label
    count = 0
    while top > 0:
        top -= 1
        k = int(stack[top])
        r, c = k // cols, k % cols
        count += 1
        for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            rr, cc = r + dr, c + dc
            if (
                0 <= rr < rows
                and 0 <= cc < cols
                and mask[rr, cc]
                and not labels[rr, cc]
            ):
                labels[rr, cc] = label
                stack[top] = rr * cols + cc
                top += 1
    return count


@njit(cache=True, nogil=True)
def component(mask: Mask, r0: int, c0: int) -> Mask:
    """Return the 4-connected component of ``mask`` holding cell (r0, c0) (empty if none)."""
    labels = np.zeros(mask.shape, dtype=np.uint8)
    if mask[r0, c0]:
        stack = np.empty(mask.size, dtype=np.int32)  # 25 million cells at most
        _fill(mask, labels, stack, r0, c0, 1)
    return labels


@njit(cache=True, nogil=True)
def label_components(mask: Mask) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]:
    """Label the 4-connected components of ``mask`` 1, 2, ...; return labels and sizes.

    ``sizes[k]`` is the number of cells of label k (``sizes[0]`` is 0).
    """
    rows, cols = mask.shape
    labels = np.zeros(mask.shape, dtype=np.int32)
    stack = np.empty(mask.size, dtype=np.int32)
    sizes = np.zeros(
        mask.size // 2 + 2, dtype=np.int32
    )  # components, each a cell at least
    label = 0
    for r in range(rows):
        for c in range(cols):
            if mask[r, c] and not labels[r, c]:
                label += 1
                sizes[label] = _fill(mask, labels, stack, r, c, label)
    return labels, sizes[: label + 1].copy()


# --------------------------------------------------------------------------- pinches


@njit(cache=True, nogil=True)
def _pinched(m: Mask, r: int, c: int) -> int:
    """0, or which diagonal of the block of cells (r, c)..(r + 1, c + 1) alone is in ``m``.

    1: cells (r, c) and (r + 1, c + 1); 2: cells (r, c + 1) and (r + 1, c).
    """
    a, b, d, e = m[r, c], m[r, c + 1], m[r + 1, c], m[r + 1, c + 1]
    if a and e and not b and not d:
        return 1
    if b and d and not a and not e:
        return 2
    return 0


@njit(cache=True, nogil=True)
def _neighbours(m: Mask, r: int, c: int) -> int:
    return int(m[r - 1, c]) + int(m[r + 1, c]) + int(m[r, c - 1]) + int(m[r, c + 1])


@njit(cache=True, nogil=True)
def _cuts(m: Mask, r: int, c: int) -> bool:
    """Whether taking cell (r, c) out parts its side neighbours in the region, locally.

    Around the cell, its eight neighbours in turn (each shares a side with the next): the
    region's cells among them form runs; the cell holds its side neighbours together
    when they lie in two runs or more.
    """
    ring_r = (1, 1, 0, -1, -1, -1, 0, 1)  # N, NE, E, SE, S, SW, W, NW
    ring_c = (0, 1, 1, 1, 0, -1, -1, -1)
    runs = 0
    for k in range(8):
        here = m[r + ring_r[k], c + ring_c[k]]
        before = m[r + ring_r[(k + 7) % 8], c + ring_c[(k + 7) % 8]]
        if here and not before:  # a run starts here; does it reach a side neighbour?
            j = k
            while m[r + ring_r[j % 8], c + ring_c[j % 8]] and j < k + 8:
                if j % 2 == 0:
                    runs += 1
                    break
                j += 1
    return runs > 1


@njit(cache=True, nogil=True)
def resolve_pinches(m: Mask, keep: Mask) -> int:
    """Take cells out of the padded region ``m`` until no two of its cells meet at a corner only.

    Where the region's cells meet only diagonally (a 2 x 2 block holding just one
    diagonal), one of the two is taken out: one of ``keep`` only if both are; else one
    whose neighbours stay together without it (:func:`_cuts`) if only one does; else
    the one with fewer neighbours in the region, the first of the block on a tie. Each removal
    can pinch the blocks around the removed cell, which are looked at again. Changes
    ``m`` in place; returns the number of cells taken out.
    """
    rows, cols = m.shape
    n_blocks = (rows - 1) * (cols - 1)
    stack = np.empty(n_blocks, dtype=np.int32)
    queued = np.zeros(n_blocks, dtype=np.uint8)
    top = 0
    for r in range(rows - 1):
        for c in range(cols - 1):
            if _pinched(m, r, c):
                stack[top] = r * (cols - 1) + c
                queued[stack[top]] = 1
                top += 1
    removed = 0
    while top > 0:
        top -= 1
        k = int(stack[top])
        queued[k] = 0
        r, c = k // (cols - 1), k % (cols - 1)
        which = _pinched(m, r, c)
        if which == 0:
            continue
        if which == 1:
            r1, c1, r2, c2 = r, c, r + 1, c + 1
        else:
            r1, c1, r2, c2 = r, c + 1, r + 1, c
        cost1 = (
            _neighbours(m, r1, c1) + 8 * int(_cuts(m, r1, c1)) + 64 * int(keep[r1, c1])
        )
        cost2 = (
            _neighbours(m, r2, c2) + 8 * int(_cuts(m, r2, c2)) + 64 * int(keep[r2, c2])
        )
        rr, cc = (r1, c1) if cost1 <= cost2 else (r2, c2)
        m[rr, cc] = 0
        removed += 1
        for br in range(rr - 1, rr + 1):
            for bc in range(cc - 1, cc + 1):
                if 0 <= br < rows - 1 and 0 <= bc < cols - 1:
                    b = br * (cols - 1) + bc
                    if not queued[b]:
                        queued[b] = 1
                        stack[top] = b
                        top += 1
    return removed


# --------------------------------------------------------------------------- rings


@njit(cache=True, nogil=True)
def _out_direction(m: Mask, x: int, y: int) -> int:
    """Return the direction of the border leaving vertex (x, y), the region on its left.

    0: +x, 1: +y, 2: -x, 3: -y; -1 when no border leaves (the four cells agree).
    """
    tl, tr = m[y, x - 1], m[y, x]
    bl, br = m[y - 1, x - 1], m[y - 1, x]
    if tr and not br:
        return 0
    if tl and not tr:
        return 1
    if bl and not tl:
        return 2
    if br and not bl:
        return 3
    return -1


@njit(cache=True, nogil=True)
def trace_rings(m: Mask) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Chain the borders of the padded region ``m`` (no pinches) into rings of corners.

    Each ring follows cell edges with the region on its left (the outer ring
    counter-clockwise, the holes' clockwise) and lists its corners only, from its
    lowest-leftmost corner. Returns the corners (N, 2) as padded grid (x, y) and the
    offsets of the rings in them (k + 1,).
    """
    rows, cols = m.shape
    total = 0
    for y in range(1, rows):
        for x in range(1, cols):
            if _out_direction(m, x, y) >= 0:
                total += 1
    corners = np.empty((total, 2), dtype=np.int64)
    starts = np.empty(total + 1, dtype=np.int64)
    visited = np.zeros((rows + 1, cols + 1), dtype=np.uint8)
    n_corners = 0
    n_rings = 0
    steps = ((1, 0), (0, 1), (-1, 0), (0, -1))
    for y0 in range(1, rows):
        for x0 in range(1, cols):
            if visited[y0, x0] or _out_direction(m, x0, y0) < 0:
                continue
            starts[n_rings] = n_corners
            n_rings += 1
            x, y, previous = x0, y0, -1
            while True:
                d = _out_direction(m, x, y)
                visited[y, x] = 1
                if d != previous:
                    corners[n_corners, 0] = x
                    corners[n_corners, 1] = y
                    n_corners += 1
                    previous = d
                x += steps[d][0]
                y += steps[d][1]
                if x == x0 and y == y0:
                    break
    starts[n_rings] = n_corners
    return corners[:n_corners].copy(), starts[: n_rings + 1].copy()


# --------------------------------------------------------------------------- simplification


@njit(cache=True, nogil=True)
def _segment_in_region(x0: int, y0: int, x1: int, y1: int, m: Mask) -> bool:
    """Whether the segment between two grid vertices lies in the closed union of ``m``'s cells.

    Exact (integers only): the open segment must cross only cells of the region, and a
    piece running along a grid line must have a cell of the region on one side at least.
    """
    dx, dy = x1 - x0, y1 - y0
    if dy == 0:
        for x in range(min(x0, x1), max(x0, x1)):
            if not m[y0 - 1, x] and not m[y0, x]:
                return False
        return True
    if dx == 0:
        for y in range(min(y0, y1), max(y0, y1)):
            if not m[y, x0 - 1] and not m[y, x0]:
                return False
        return True
    sx = 1 if dx > 0 else -1
    sy = 1 if dy > 0 else -1
    adx, ady = abs(dx), abs(dy)
    cx = x0 if sx > 0 else x0 - 1
    cy = y0 if sy > 0 else y0 - 1
    while True:
        if not m[cy, cx]:
            return False
        nx = abs((cx + 1 if sx > 0 else cx) - x0)  # the segment leaves the cell at
        ny = abs((cy + 1 if sy > 0 else cy) - y0)  # t = nx / adx or ny / ady
        if nx >= adx and ny >= ady:
            return True
        across, up = nx * ady, ny * adx
        if across <= up:
            cx += sx
        if up <= across:
            cy += sy


@njit(cache=True, nogil=True)
def _on_segment(  # noqa: PLR0917
    qx: float, qy: float, ax: float, ay: float, bx: float, by: float
) -> bool:
    cross = (bx - ax) * (qy - ay) - (by - ay) * (qx - ax)
    return (
        cross == 0.0
        and min(ax, bx) <= qx <= max(ax, bx)
        and min(ay, by) <= qy <= max(ay, by)
    )


@njit(cache=True, nogil=True)
def _cut_holds(  # noqa: PLR0917
    qx: float, qy: float, px: FloatArray, py: FloatArray, i: int, j: int
) -> bool:
    """Whether point q is inside or on the polygon of ring vertices i..j (j may pass n).

    The polygon is closed by the segment from vertex j to vertex i; a point on that
    segment is not held (it stays on the new border).
    """
    n = px.shape[0]
    ax, ay = float(px[i % n]), float(py[i % n])
    bx, by = float(px[j % n]), float(py[j % n])
    if _on_segment(qx, qy, bx, by, ax, ay):
        return False
    inside = False
    for k in range(i, j + 1):
        x1, y1 = float(px[k % n]), float(py[k % n])
        if k < j:
            x2, y2 = float(px[(k + 1) % n]), float(py[(k + 1) % n])
        else:
            x2, y2 = ax, ay
        if _on_segment(qx, qy, x1, y1, x2, y2):
            return True
        if (y1 > qy) != (y2 > qy):
            if qx < x1 + (qy - y1) * (x2 - x1) / (y2 - y1):
                inside = not inside
    return inside


@njit(cache=True, nogil=True)
def _distance_to_segment(  # noqa: PLR0917
    qx: float, qy: float, ax: float, ay: float, bx: float, by: float
) -> float:
    dx, dy = bx - ax, by - ay
    t = ((qx - ax) * dx + (qy - ay) * dy) / (dx * dx + dy * dy)
    t = min(1.0, max(0.0, t))
    return np.hypot(qx - (ax + t * dx), qy - (ay + t * dy))


@njit(cache=True, nogil=True)
def _cut_threatens(  # noqa: PLR0917
    q: FloatArray,
    clearance: float,
    px: FloatArray,
    py: FloatArray,
    i: int,
    j: int,
    box: FloatArray,
) -> bool:
    """Whether the shortcut i -> j cuts off a protected point or comes within clearance."""
    n = px.shape[0]
    for k in range(q.shape[0]):
        qx, qy = q[k, 0], q[k, 1]
        ax, ay = float(px[i % n]), float(py[i % n])
        near = _distance_to_segment(qx, qy, ax, ay, float(px[j % n]), float(py[j % n]))
        if near < clearance:
            return True
        if box[0] <= qx <= box[2] and box[1] <= qy <= box[3]:
            if _cut_holds(qx, qy, px, py, i, j):
                return True
    return False


@njit(cache=True, nogil=True)
def _shortcut(  # noqa: PLR0917
    px: FloatArray,
    py: FloatArray,
    m: Mask,
    tolerance: float,
    protected: FloatArray,
    clearance: float,
    i: int,
    j: int,
) -> int:
    """Test the shortcut from corner i to corner j (j > i + 1, indices taken mod n).

    Returns -1 when it may replace the corners between, else the worst of them (the
    farthest on the region's side, else the farthest), where to split it.
    """
    n = px.shape[0]
    ax, ay = px[i % n], py[i % n]
    bx, by = px[j % n], py[j % n]
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    ok = True
    worst, worst_score = i + 1, -1.0
    box = np.empty(4, dtype=np.float64)
    box[0], box[1], box[2], box[3] = min(ax, bx), min(ay, by), max(ax, bx), max(ay, by)
    for k in range(i + 1, j):
        x, y = px[k % n], py[k % n]
        box[0], box[1] = min(box[0], x), min(box[1], y)
        box[2], box[3] = max(box[2], x), max(box[3], y)
        cross = dx * (y - ay) - dy * (x - ax)
        t = ((x - ax) * dx + (y - ay) * dy) / length2
        t = min(1.0, max(0.0, t))
        dist = np.hypot(x - (ax + t * dx), y - (ay + t * dy))
        score = dist
        if cross > 0.0:  # left of the shortcut: the region's side
            ok = False
            score += 1e9
        elif dist > tolerance:
            ok = False
        if score > worst_score:
            worst, worst_score = k, score
    if ok:
        ok = _segment_in_region(int(ax), int(ay), int(bx), int(by), m)
    if ok and protected.shape[0]:
        ok = not _cut_threatens(protected, clearance, px, py, i, j, box)
    return -1 if ok else worst


@njit(cache=True, nogil=True)
def simplify_ring(  # noqa: PLR0917
    px: FloatArray,
    py: FloatArray,
    m: Mask,
    tolerance: float,
    protected: FloatArray,
    clearance: float,
) -> npt.NDArray[np.bool_]:
    """Choose the corners of a ring to keep, giving up only the region's own space.

    Douglas-Peucker with three more conditions on each shortcut from corner i to corner
    j that replaces the corners between: (1) every corner between lies on the shortcut
    or to its right (outside the region: the region is on the ring's left), within
    ``tolerance`` of it; (2) the shortcut lies in the closed region ``m`` (padded mask,
    the ring's own grid); (3) no ``protected`` point lies in the piece cut off (or on
    the ring's part that the shortcut replaces), nor closer than ``clearance`` to the
    shortcut (the robot's room at the start and the goal stays). So the piece cut off
    is the region's, within ``tolerance`` of its border: the region only shrinks. A
    shortcut that fails is split at its worst corner. Douglas-Peucker splits where
    a corner is farthest, which along a ragged border is often a corner of a notch
    that a shortcut could have bridged; so then each kept corner is dropped, in turn
    round the ring, when the shortcut between its neighbours passes the same test,
    until none is.

    Parameters
    ----------
    px, py
        The ring's corners (padded grid, integers held as floats), region on the left.
    m
        The padded region.
    tolerance
        Largest distance [cells] of a dropped corner from its shortcut.
    protected
        Points (k, 2) in the padded grid that must stay in the region.
    clearance
        How far [cells] a shortcut must stay from each protected point.

    Returns
    -------
    Which corners are kept.
    """
    n = px.shape[0]
    keep = np.zeros(n, dtype=np.bool_)
    if n <= 4:
        keep[:] = True
        return keep
    far, far_d = 0, -1.0
    for k in range(n):
        d = (px[k] - px[0]) ** 2 + (py[k] - py[0]) ** 2
        if d > far_d:
            far, far_d = k, d
    keep[0] = True
    keep[far] = True
    stack = np.empty((2 * n + 2, 2), dtype=np.int64)
    stack[0, 0], stack[0, 1] = 0, far
    stack[1, 0], stack[1, 1] = far, n
    top = 2
    while top > 0:
        top -= 1
        i, j = stack[top, 0], stack[top, 1]
        if j - i < 2:
            continue
        worst = _shortcut(px, py, m, tolerance, protected, clearance, i, j)
        if worst < 0:
            continue
        keep[worst] = True
        stack[top, 0], stack[top, 1] = i, worst
        stack[top + 1, 0], stack[top + 1, 1] = worst, j
        top += 2
    _drop_corners(px, py, m, tolerance, protected, clearance, keep)
    return keep


@njit(cache=True, nogil=True)
def _drop_corners(  # noqa: PLR0917
    px: FloatArray,
    py: FloatArray,
    m: Mask,
    tolerance: float,
    protected: FloatArray,
    clearance: float,
    keep: npt.NDArray[np.bool_],
) -> None:
    """Drop kept corners whose neighbours' shortcut passes, round the ring until none does."""
    n = px.shape[0]
    kept = np.flatnonzero(keep)
    count = kept.shape[0]
    prev = np.empty(n, dtype=np.int64)
    nxt = np.empty(n, dtype=np.int64)
    for t in range(count):
        prev[kept[t]] = kept[(t - 1 + count) % count]
        nxt[kept[t]] = kept[(t + 1) % count]
    changed = True
    while changed and count > 4:
        changed = False
        for t in range(kept.shape[0]):
            k = kept[t]
            if not keep[k] or count <= 4:
                continue
            i, j = prev[k], nxt[k]
            if i >= k:  # the unrolled order i < k < j
                i -= n
            if j <= k:
                j += n
            if j - i < 2 or j - i >= n:
                continue
            if _shortcut(px, py, m, tolerance, protected, clearance, i + n, j + n) < 0:
                keep[k] = False
                nxt[prev[k]] = nxt[k]
                prev[nxt[k]] = prev[k]
                count -= 1
                changed = True


def warm_up() -> None:
    """Compile (or load from the cache) every loop here on a tiny region."""
    mask = np.zeros((4, 4), dtype=np.uint8)
    mask[1:3, 1:3] = 1
    component(mask, 1, 1)
    label_components(mask)
    resolve_pinches(mask.copy(), np.zeros_like(mask))
    corners, _ = trace_rings(mask)
    ring = corners.astype(np.float64)
    simplify_ring(
        ring[:, 0].copy(), ring[:, 1].copy(), mask, 1.0, np.zeros((1, 2)), 0.5
    )
