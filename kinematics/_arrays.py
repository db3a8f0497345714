"""Private array helpers shared by the kinematics modules (broadcasting, validation)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def broadcast_floats(
    *values: npt.ArrayLike,
) -> tuple[tuple[FloatArray, ...], tuple[int, ...]]:
    """Convert ``values`` to float64 arrays broadcast to one common shape S."""
    arrays = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in values))
    return tuple(arrays), arrays[0].shape


def unwrap_scalar(a: FloatArray) -> FloatArray:
    """Return a 0-d array as a numpy scalar, any other array unchanged."""
    return a[()] if a.ndim == 0 else a


def check_positive(name: str, value: float) -> float:
    """Return ``value`` as float, or raise ValueError unless it is finite and > 0."""
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def rates_array(rates: npt.ArrayLike, k: int) -> FloatArray:
    """Check that wheel ``rates`` have shape S + (k,) and return them as float64."""
    q = np.asarray(rates, dtype=np.float64)
    if q.ndim == 0 or q.shape[-1] != k:
        raise ValueError(
            f"wheel rates must have shape (k,) or (N, k) with k={k}, got shape {q.shape}"
        )
    return q
