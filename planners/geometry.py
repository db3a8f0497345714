"""Small plane geometry every planner measures with: one copy of each helper.

Points are float64 arrays of shape (2,), or ``(x, y)`` tuples where a record keeps them;
rows of vectors are arrays of shape (N, 2).
"""

from __future__ import annotations

__all__ = ["as_point", "cross", "segment_closest", "take_rows", "unit", "unit_rows"]

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
