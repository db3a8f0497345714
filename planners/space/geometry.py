"""Small plane geometry every planner measures with: one copy of each helper.

Points are float64 arrays of shape (2,), or ``(x, y)`` tuples where a record keeps them;
rows of vectors are arrays of shape (N, 2).
"""

from __future__ import annotations

__all__ = [
    "as_point",
    "clean_ring",
    "cross",
    "segment_closest",
    "take_rows",
    "unit",
    "unit_rows",
]

import math
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float]


def as_point(p: npt.ArrayLike) -> Point:
    """Return ``p`` as an ``(x, y)`` tuple of Python floats (for records and labels).

    Examples
    --------
    >>> as_point(np.array([1, 2]))
    (1.0, 2.0)
    """
    x, y = np.asarray(p, dtype=np.float64).reshape(2)
    return (float(x), float(y))


def take_rows(
    a: npt.NDArray[Any], index: npt.NDArray[np.integer[Any]]
) -> npt.NDArray[Any]:
    """Return ``a[index]`` for integer indices of any shape: the rows of ``a`` they name.

    The same values as fancy indexing, by :func:`numpy.take`: numpy copies an (N, 2)
    array's rows one at a time when indexed with an array, some twenty times slower
    than ``take`` (the pairs of a visibility graph gather points and wedges by the
    thousand on every edit). ``index`` must hold integers, never booleans.

    Examples
    --------
    >>> take_rows(np.array([[0.0, 1.0], [2.0, 3.0], [4.0, 5.0]]), np.array([2, 0]))
    array([[4., 5.],
           [0., 1.]])
    """
    return a.take(index, axis=0)


def cross(u: FloatArray, v: FloatArray) -> FloatArray:
    """Return the z component of u x v, row by row (> 0: v turns left of u).

    Examples
    --------
    >>> float(cross(np.array([1.0, 0.0]), np.array([0.0, 1.0])))
    1.0
    """
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def unit(v: FloatArray) -> FloatArray:
    """Return the vector ``v`` (2,) scaled to length 1 (a zero vector stays zero)."""
    n = math.hypot(*v)
    return v / n if n > 0 else v


def unit_rows(v: FloatArray) -> FloatArray:
    """Return each row of ``v`` (N, 2) scaled to length 1 (zero rows stay zero)."""
    n = np.hypot(v[:, 0], v[:, 1])
    return v / np.where(n > 0, n, 1.0)[:, None]


def segment_closest(
    segments: FloatArray, p: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Distance from ``p`` to each segment (K, 2, 2) and the closest points (K, 2).

    Examples
    --------
    >>> d, q = segment_closest(np.array([[[0.0, 0.0], [2.0, 0.0]]]), np.array([1.0, 1.0]))
    >>> d.tolist(), q.tolist()
    ([1.0], [[1.0, 0.0]])
    """
    a, b = segments[:, 0], segments[:, 1]
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    closest = a + t[:, None] * d
    return np.hypot(*(closest - p).T), closest


def clean_ring(ring: npt.ArrayLike, tol: float, *, repeats: bool = True) -> FloatArray:
    """Drop the vertices of an open ring (N, 2) that lie on the segment joining their neighbours.

    A vertex is dropped when it lies between its neighbours within ``tol`` of their
    chord (relative to the chord's length), never two neighbours in one pass (dropping
    one changes the other's test); passes repeat until none is dropped or three vertices
    remain. With ``repeats``, a vertex within ``tol`` of the next one is dropped first.

    Examples
    --------
    >>> clean_ring([(0, 0), (1, 0), (2, 0), (2, 2), (2, 2), (0, 2)], 1e-9).tolist()
    [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]
    >>> clean_ring([(0, 0), (1, 0), (2, 0), (2, 2), (0, 2)], 1e-9, repeats=False).tolist()
    [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]
    """
    pts = np.asarray(ring, dtype=np.float64)
    changed = True
    while changed and len(pts) > 3:
        changed = False
        if repeats:
            step = np.roll(pts, -1, axis=0) - pts
            short = np.hypot(step[:, 0], step[:, 1]) <= tol
            if short.any():
                pts = pts[~short]
                changed = True
                continue
        prev, nxt = np.roll(pts, 1, axis=0), np.roll(pts, -1, axis=0)
        chord = nxt - prev
        length = np.hypot(chord[:, 0], chord[:, 1])
        cross = chord[:, 0] * (pts[:, 1] - prev[:, 1]) - chord[:, 1] * (
            pts[:, 0] - prev[:, 0]
        )
        # Between its neighbours: a positive projection on the chord, so a chord of length 0 never.
        between = np.einsum("ij,ij->i", pts - prev, chord) > 0
        flat = (np.abs(cross) <= tol * np.maximum(length, tol)) & between
        flat &= ~np.roll(flat, 1)  # never two neighbours at once
        if flat.any():
            pts = pts[~flat]
            changed = True
    return pts
