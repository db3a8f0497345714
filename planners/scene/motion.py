"""Moving obstacles: a scenario's optional motions and the scene at a time (section 9.6).

Section 9.6 says of the distance-sensor-based method that "the obstacles do not have to be
static". A scenario may give some obstacles a :class:`Motion`: the obstacle translates (it
does not turn) through a list of waypoints at a constant speed, pausing at each, and then
either starts again (``"loop"``: back to where the file puts it, then round again) or
retraces its way (``"back_and_forth"``). The polygon the file gives is the obstacle at
time 0, so every planner that plans once (VG, SVG, DSB, Bug2) plans the scene at t = 0;
:func:`planners.scene.scene_at` gives the scene at any time ``t``, which the live robot
(:mod:`planners.bug.live`) senses.

File format (top-level key ``"motions"``, optional)::

    "motions": [
      {"obstacle": 1, "waypoints": [[0, 1.5]], "speed": 0.4,
       "mode": "back_and_forth", "pause": 2.0}
    ]

``obstacle`` is the index into ``obstacles`` (0-based, as in the error messages'
``obstacles[1]``); ``waypoints`` are translations [m] of the obstacle relative to its
position in the file (the start, [0, 0], is implied); ``speed`` [m/s] is positive;
``mode`` is ``"loop"`` (default) or ``"back_and_forth"``; ``pause`` [s] (default 0) is
how long it waits at each waypoint and at its start.
"""

from __future__ import annotations

__all__ = [
    "MOTION_MODES",
    "Motion",
    "motion_offset",
]

import dataclasses
import itertools
import math

import numpy as np

Point = tuple[float, float]

MOTION_MODES = ("loop", "back_and_forth")


@dataclasses.dataclass(frozen=True)
class Motion:
    """How one obstacle moves: a translation through waypoints, over and over.

    Examples
    --------
    >>> m = Motion(obstacle=0, waypoints=((2.0, 0.0),), speed=1.0, mode="back_and_forth")
    >>> motion_offset(m, 0.5), motion_offset(m, 3.0), m.period
    ((0.5, 0.0), (1.0, 0.0), 4.0)
    """

    obstacle: int
    """Index of the obstacle in :attr:`planners.scene.Scene.obstacles` (0-based)."""
    waypoints: tuple[Point, ...]
    """Translations [m] of the obstacle from where the file puts it, in order; the start
    (0, 0) is implied and not listed."""
    speed: float
    """Speed of the translation between waypoints [m/s], positive."""
    mode: str = "loop"
    """``"loop"``: after the last waypoint, straight back to the start and round again;
    ``"back_and_forth"``: retrace the waypoints back to the start, and again."""
    pause: float = 0.0
    """Time spent at each waypoint and at the start before moving on [s], >= 0."""

    @property
    def cycle(self) -> tuple[Point, ...]:
        """The translations visited in one period, from (0, 0) back to (0, 0)."""
        there = ((0.0, 0.0), *self.waypoints)
        back = tuple(reversed(self.waypoints[:-1])) if self.mode != "loop" else ()
        return (*there, *back, (0.0, 0.0))

    @property
    def period(self) -> float:
        """Duration of one period [s] (moving plus pauses); 0 for a motion that never moves."""
        pts = np.asarray(self.cycle, dtype=np.float64)
        legs = np.hypot(*np.diff(pts, axis=0).T)
        return float(legs.sum() / self.speed + self.pause * len(legs))


def motion_offset(motion: Motion, t: float) -> Point:
    """Return the obstacle's translation [m] at time ``t`` [s] (t < 0 counts as 0).

    The obstacle first pauses ``pause`` seconds where it is, then moves to the first
    waypoint at ``speed``, pauses, and so on.

    Examples
    --------
    >>> m = Motion(obstacle=0, waypoints=((0.0, 2.0),), speed=0.5, pause=1.0)
    >>> [motion_offset(m, t) for t in (0.0, 1.0, 3.0, 5.0, 6.0, 10.0)]
    [(0.0, 0.0), (0.0, 0.0), (0.0, 1.0), (0.0, 2.0), (0.0, 2.0), (0.0, 0.0)]
    """
    period = motion.period
    if not period > 0.0 or t <= 0.0:
        return (0.0, 0.0)
    tau = math.fmod(float(t), period)
    cycle = motion.cycle
    for a, b in itertools.pairwise(cycle):
        if tau < motion.pause:
            return a
        tau -= motion.pause
        leg = math.hypot(b[0] - a[0], b[1] - a[1]) / motion.speed
        if tau < leg:
            f = tau / leg
            return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]))
        tau -= leg
    return cycle[-1]  # fmod's last bit of rounding: the end of the period is its start
