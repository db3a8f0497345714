"""What every sensing planner's run has in common: a path walked in modes, with aims.

A *trace* planner (DSB, Bug2) does not search a map: a robot walks, and its result is the
walk. :class:`WalkedPath` gives such a result the questions the app and a lesson ask at a
distance ``s`` along the walk: where was the robot, in which mode, heading for what, and
the path cut into its modes.
"""

from __future__ import annotations

__all__ = ["FOLLOW", "SEEK", "WalkedPath", "arclength", "simplify_walk"]

import functools

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float]

SEEK = "seek"
"""The mode of a robot heading for the goal (or for a point on the way to it)."""
FOLLOW = "follow"
"""The mode of a robot following a border."""


class WalkedPath:
    """Mixin for frozen trace results with ``path`` (N, 2), ``modes`` and ``aims`` (N - 1).

    ``modes[i]`` and ``aims[i]`` describe the segment ``path[i] -> path[i + 1]``: the mode
    the robot was in, and the point it was heading for while seeking (None while it
    follows a border).
    """

    path: FloatArray
    modes: tuple[str, ...]
    aims: tuple[Point | None, ...]
    start: Point

    @functools.cached_property
    def arclength(self) -> FloatArray:
        """Cumulative arclength at each path vertex, shape (N,) [m]."""
        return arclength(self.path)

    def _segment_at(self, s: float) -> int:
        """Index of the path segment the robot is on after ``s`` metres (clamped)."""
        i = int(np.searchsorted(self.arclength, float(s), side="right")) - 1
        return min(max(i, 0), max(len(self.path) - 2, 0))

    def position_at(self, s: float) -> FloatArray:
        """Return the robot's position after travelling ``s`` metres (clamped to the run) [m]."""
        if len(self.path) == 0:
            return np.asarray(self.start, dtype=np.float64)
        if len(self.path) == 1:
            return self.path[0].copy()
        cum = self.arclength
        s = min(max(float(s), 0.0), float(cum[-1]))
        i = self._segment_at(s)
        span = cum[i + 1] - cum[i]
        t = (s - cum[i]) / span if span > 0 else 0.0
        return self.path[i] + t * (self.path[i + 1] - self.path[i])

    def mode_at(self, s: float) -> str:
        """Return the mode of the path at arclength ``s`` (``"seek"`` before any move)."""
        if not self.modes:
            return SEEK
        return self.modes[min(self._segment_at(s), len(self.modes) - 1)]

    def aim_at(self, s: float) -> Point | None:
        """Return the point the robot was heading for at arclength ``s``.

        None while it follows a border. For DSB this is the chosen O_i (or the goal), the
        planner's own decision: the app draws it, never a re-derivation.
        """
        if not self.aims:
            return None
        return self.aims[min(self._segment_at(s), len(self.aims) - 1)]

    @property
    def pieces(self) -> tuple[tuple[str, FloatArray], ...]:
        """The path cut where the mode changes: (mode, polyline (k, 2)) in order."""
        out: list[tuple[str, FloatArray]] = []
        begin = 0
        for i in range(1, len(self.modes) + 1):
            if i == len(self.modes) or self.modes[i] != self.modes[begin]:
                out.append((self.modes[begin], self.path[begin : i + 1].copy()))
                begin = i
        return tuple(out)


def arclength(path: FloatArray) -> FloatArray:
    """Cumulative arclength at each vertex of ``path`` (N, 2), shape (N,) [m].

    Examples
    --------
    >>> arclength(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]])).tolist()
    [0.0, 5.0, 6.0]
    """
    if len(path) == 0:
        return np.zeros(0)
    steps = np.hypot(*np.diff(path, axis=0).T)
    return np.concatenate([[0.0], np.cumsum(steps)])


def simplify_walk(
    path: FloatArray, modes: list[str], aims: list[Point | None]
) -> tuple[FloatArray, list[str], list[Point | None]]:
    """Drop path vertices where the robot went straight on (same mode, same aim).

    Steps end wherever the robot looked again; where nothing changed, the vertex
    carries no information. Arclengths, and hence event positions, are unchanged.

    Examples
    --------
    >>> path = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0]])
    >>> p, m, a = simplify_walk(path, ["seek"] * 3, [(2.0, 1.0)] * 3)
    >>> p.tolist(), m
    ([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]], ['seek', 'seek'])
    """
    if len(path) < 3:
        return path, modes, aims
    keep = [0]
    for i in range(1, len(path) - 1):
        a, b, c = path[keep[-1]], path[i], path[i + 1]
        u, v = b - a, c - b
        straight = abs(float(u[0] * v[1] - u[1] * v[0])) <= 1e-12 * max(
            float(np.dot(u, u) + np.dot(v, v)), 1e-300
        )
        if not (
            straight
            and float(np.dot(u, v)) > 0
            and modes[i - 1] == modes[i]
            and aims[i - 1] == aims[i]
        ):
            keep.append(i)
    keep.append(len(path) - 1)
    seg = keep[:-1]
    return path[keep], [modes[i] for i in seg], [aims[i] for i in seg]
