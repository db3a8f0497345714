"""Robots, paths and reference helpers shared by the kinematics tests."""

from __future__ import annotations

import math

import numpy as np

from kinematics import RobotParams

HOLONOMIC = RobotParams("holonomic", wheel_radius=0.05, wheel_distance=0.25, radius=0.3)
DIFFERENTIAL = RobotParams(
    "differential", wheel_radius=0.05, wheel_distance=0.2, radius=0.3
)

# A visibility-graph-like path in the 10 m x 8 m lecture room of the first scenario.
LECTURE_PATH = np.array([[1.0, 1.0], [2.0, 1.7], [4.3, 5.3], [6.2, 5.6], [9.0, 7.0]])


def dense_trace(n: int = 300, noise: float = 0.003, seed: int = 0) -> np.ndarray:
    """A TangentBug-like trace: a straight run, then hundreds of short steps around a disk."""
    rng = np.random.default_rng(seed)
    run = np.column_stack([np.linspace(0.0, 2.0, 40), np.zeros(40)])
    th = np.linspace(-math.pi / 2, math.pi, n)
    arc = np.column_stack([2.0 + 1.0 * np.cos(th), 1.0 + 1.0 * np.sin(th)])
    arc += rng.normal(0.0, noise, arc.shape)  # sensor noise makes the trace jagged
    return np.vstack([run, arc[1:]])


def distance_to_polyline(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Distance from each point (P, 2) to the polyline (M, 2), brute force."""
    if len(path) == 1:
        return np.hypot(*(points - path[0]).T)
    a, b = path[:-1], path[1:]
    ab = b - a
    len2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    ap = points[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("pij,ij->pi", ap, ab) / len2, 0.0, 1.0)
    closest = a[None] + t[..., None] * ab[None]
    return np.min(np.hypot(*(points[:, None, :] - closest).transpose(2, 0, 1)), axis=1)
