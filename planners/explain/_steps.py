"""Explanations: each method of Chapter 9 as a sequence of steps a lecturer can show.

The planners compute answers; an explanation says *how* the chapter's procedure gets
there, one step at a time, in the chapter's words and numbering (obstacle expansion,
section 9.3, Figs. 9.7 / 9.8; the visibility graph, section 9.4; the simplified
visibility graph's procedure, section 9.5; the distance-sensor-based robot's flowchart,
Fig. 9.15, with the decisions of Figs. 9.16-9.18).

Every explanation is an :class:`Explanation`: a method name, a title, and a tuple of
:class:`Step` records. A step carries one line of text and the geometry to highlight,
as named :class:`Mark` records (segments, points, labels) with a *role* that says what
they are (``"current"``, ``"done"``, ``"blocked"``, ...: :data:`ROLES`). The app draws
each role in its own style; it never decides anything itself.

Explanations are computed on demand (they are not part of :func:`planners.plan_all`),
so they never slow an edit down. They read the planners' own records (the SVG builder's
kept pairs, the A* search's settled order, TangentBug's :class:`~planners.bug._context.Decision`
records, the expansion's own polygons) rather than deciding anything again.

Examples
--------
>>> import planners
>>> scene = planners.load_scene("static_scenarios/01_two_convex.json")
>>> svg = planners.explain_svg(scene)
>>> svg.steps[1].text  # doctest: +ELLIPSIS
'Step 1: ...common tangent...'
>>> sorted({tag.rule for tag in svg.tags})
['1', '2a']
"""

from __future__ import annotations

__all__ = [
    "METHODS",
    "ROLES",
    "Abandoned",
    "Explanation",
    "Lazy",
    "Mark",
    "Step",
    "keep_going",
    "marks",
]

import dataclasses
import functools
import operator
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar, overload

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
T = TypeVar("T")

ROLES = (
    "done",
    "current",
    "blocked",
    "blocker",
    "hull",
    "path",
    "focus",
    "candidate",
    "chosen",
    "heading",
    "sensor",
    "seen",
    "shape",
    "offset",
    "result",
)
"""What a :class:`Mark` is, which the view draws in its own style:

- ``"done"``: what earlier steps added (dimmed);
- ``"current"``: what this step adds (bold);
- ``"blocked"``: a line of sight an obstacle cuts (VG);
- ``"blocker"``: the obstacle edge that cuts it;
- ``"hull"``: a convex hull (section 9.5, Fig. 9.11);
- ``"path"``: the shortest path found, or the robot's path so far;
- ``"focus"``: the vertex being examined, or the robot r;
- ``"candidate"``: the O_i in view (Fig. 9.16);
- ``"chosen"``: r_next, the line r -> O_i;
- ``"heading"``: the rest of the estimate, O_i -> g (a straight line, through
  whatever lies between: d(O_i, g) ignores obstacles);
- ``"sensor"``: the circle of radius R around the robot;
- ``"seen"``: the border the sensor sees;
- ``"shape"``: the robot model placed at an obstacle vertex (Figs. 9.7b / 9.8b);
- ``"offset"``: an obstacle edge pushed out by the robot (Figs. 9.7b / 9.8b);
- ``"result"``: the expanded obstacle (Figs. 9.7c / 9.8c).
"""

METHODS = ("expansion", "vg", "svg", "dsb")
"""The methods that can be explained, in the chapter's order."""


@dataclasses.dataclass(frozen=True, eq=False)
class Mark:
    """Geometry to highlight in one role, with optional labels."""

    role: str
    """One of :data:`ROLES`."""
    segments: FloatArray
    """Segments, shape (k, 2, 2) [m]."""
    points: FloatArray
    """Points, shape (p, 2) [m]."""
    labels: tuple[tuple[str, tuple[float, float]], ...] = ()
    """Text placed at points [m]."""


@dataclasses.dataclass(frozen=True, eq=False)
class Step:
    """One step of a procedure: what it does in words and what to highlight."""

    kind: str
    """What sort of step, e.g. ``"svg:2a"``, ``"vg:vertex"``, ``"dsb:choose_O_i"``."""
    text: str
    """One line, in the chapter's words and numbering."""
    marks: tuple[Mark, ...] = ()
    """What to draw, by role."""
    detail: tuple[tuple[str, str], ...] = ()
    """Extra facts as (name, value) rows (a DSB step's table of the O_i, for instance)."""

    def mark(self, role: str) -> Mark | None:
        """Return the mark of ``role``, or None."""
        return next((m for m in self.marks if m.role == role), None)

    def segments(self, role: str) -> FloatArray:
        """Return the segments of ``role``, shape (k, 2, 2) (empty when none)."""
        found = self.mark(role)
        return found.segments if found is not None else np.zeros((0, 2, 2))


class Lazy(Sequence[T]):
    """A sequence whose items are made when asked for; the last few are kept.

    The visibility graph of a big scene has thousands of steps, each with thousands of
    segments: made all at once they would fill the memory (a scene of 400 vertices took
    seconds and a quarter of a gigabyte, one of 10,000 could not finish). Each item is
    ``make(k)``, a pure function of its position, so an item made again is the same.
    It holds a function, so it does not pickle (nothing sends an explanation to another
    process).

    Examples
    --------
    >>> squares = Lazy(4, lambda k: k * k)
    >>> len(squares), squares[3], squares[-1], list(squares[1:3])
    (4, 9, 9, [1, 4])
    """

    def __init__(self, count: int, make: Callable[[int], T], keep: int = 16) -> None:
        self._count = int(count)
        self._make = functools.lru_cache(maxsize=keep)(make)

    def __len__(self) -> int:
        return self._count

    @overload
    def __getitem__(self, k: int) -> T: ...

    @overload
    def __getitem__(self, k: slice) -> tuple[T, ...]: ...

    def __getitem__(self, k: int | slice) -> T | tuple[T, ...]:
        if isinstance(k, slice):
            return tuple(self[i] for i in range(*k.indices(self._count)))
        i = operator.index(k)  # numpy integers too; a float is refused here
        i = i + self._count if i < 0 else i
        if not 0 <= i < self._count:
            raise IndexError(k)
        return self._make(i)

    def __iter__(self) -> Iterator[T]:
        return (self[i] for i in range(self._count))

    def __repr__(self) -> str:
        return f"Lazy({self._count} items)"


@dataclasses.dataclass(frozen=True, eq=False)
class Explanation:
    """A method as a sequence of steps."""

    method: str
    """One of :data:`METHODS`."""
    title: str
    """What is explained, e.g. ``"Simplified visibility graph (section 9.5)"``."""
    steps: Sequence[Step]
    """The steps in order (at least one): a tuple, or :class:`Lazy` when there are
    many (the visibility graph's, one per node)."""
    tags: tuple[Any, ...] = ()
    """Per-element records of the method (the SVG's tagged segments, for instance)."""
    data: Any = None
    """The method's own record (a DSB :class:`~planners.explain.dsb.DsbExplanation`, ...)."""

    def step(self, n: int) -> Step:
        """Return step ``n``, clamped to the steps there are (0-based)."""
        return self.steps[min(max(int(n), 0), len(self.steps) - 1)]


def as_segments(segments: Any) -> FloatArray:
    """Return segments as a float array of shape (k, 2, 2)."""
    arr = np.asarray(
        list(segments) if not isinstance(segments, np.ndarray) else segments
    )
    return arr.astype(np.float64).reshape(-1, 2, 2)


def as_points(points: Any) -> FloatArray:
    """Return points as a float array of shape (p, 2)."""
    arr = np.asarray(list(points) if not isinstance(points, np.ndarray) else points)
    return arr.astype(np.float64).reshape(-1, 2)


def marks(**roles: Any) -> tuple[Mark, ...]:
    """Build marks from keyword arguments ``role=segments`` (or a :class:`Mark`).

    A value may be a (k, 2, 2) array of segments or a Mark; empty values are dropped.
    """
    out = []
    for role, value in roles.items():
        if role not in ROLES:
            raise ValueError(f"unknown role {role!r}")
        mark = value if isinstance(value, Mark) else segment_mark(role, value)
        if len(mark.segments) or len(mark.points) or mark.labels:
            out.append(mark)
    return tuple(out)


def segment_mark(role: str, segments: Any) -> Mark:
    """Return a mark of segments only."""
    return Mark(role, as_segments(segments), np.zeros((0, 2)))


def point_mark(
    role: str,
    points: Any,
    labels: Sequence[tuple[str, tuple[float, float]]] = (),
    segments: Any = (),
) -> Mark:
    """Return a mark of points (and optionally labels and segments)."""
    return Mark(role, as_segments(segments), as_points(points), tuple(labels))


def ring_segments(coords: Any) -> FloatArray:
    """Return a closed ring (k, 2) (last point may repeat the first) as (k, 2, 2) segments."""
    ring = np.asarray(coords, dtype=np.float64).reshape(-1, 2)
    if len(ring) > 1 and np.array_equal(ring[0], ring[-1]):
        ring = ring[:-1]
    if len(ring) < 2:
        return np.zeros((0, 2, 2))
    return np.stack([ring, np.roll(ring, -1, axis=0)], axis=1)


def circle_segments(center: Any, radius: float, n: int = 64) -> FloatArray:
    """Return a circle of ``radius`` [m] around ``center`` as ``n`` segments."""
    theta = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    c = np.asarray(center, dtype=np.float64).reshape(2)
    return ring_segments(c + radius * np.stack([np.cos(theta), np.sin(theta)], axis=1))


class Abandoned(Exception):
    """An explanation given up part way: its caller asked for another one.

    On a big scene some parts take a second or more (the SVG's tags of 10,000 edges, a
    VG vertex's blocked lines of sight); they ask the caller's ``abandoned`` function
    between pieces of work and raise this when it answers True. Nothing half made is
    returned or kept (a :class:`Lazy` step that raised is made afresh when asked again).
    """


Abandoned.__module__ = "planners.explain"  # its public name, in tracebacks too


def keep_going(abandoned: Callable[[], bool] | None) -> None:
    """Raise :class:`Abandoned` when ``abandoned`` (if any) says the work is not wanted.

    Examples
    --------
    >>> keep_going(None), keep_going(lambda: False)
    (None, None)
    >>> keep_going(lambda: True)
    Traceback (most recent call last):
    ...
    planners.explain.Abandoned
    """
    if abandoned is not None and abandoned():
        raise Abandoned
