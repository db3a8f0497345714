"""The planner contract: one result protocol and one registry of planner specifications.

Everything that lists planners -- :func:`planners.plan_all`, the command line, the app's
layers, legend, results table and colours -- iterates over :data:`REGISTRY`. Adding a
planner is one module in ``planners/`` plus one :class:`PlannerSpec` here.

Kinds of planner
    ``"graph"``: builds a graph over the whole (known) configuration space and searches it
    (VG, SVG). The result adds ``arrays`` / ``graph``, ``nodes`` and ``edges``.
    ``"trace"``: a robot that senses as it goes (DSB, Bug2). The result adds the timed
    trace: ``modes``, ``events``, ``aim_at(s)``, ``decisions``.

Examples
--------
>>> [spec.name for spec in REGISTRY.values()]
['vg', 'svg', 'dsb', 'bug2']
>>> REGISTRY["svg"].title, REGISTRY["svg"].kind, REGISTRY["svg"].section
('Simplified visibility graph (SVG)', 'graph', '9.5')
>>> default_planners()
('vg', 'svg', 'dsb')
"""

from __future__ import annotations

__all__ = [
    "KINDS",
    "REGISTRY",
    "STATUSES",
    "PlanOptions",
    "PlanResult",
    "PlannerSpec",
    "default_planners",
    "planners_of_kind",
]

import dataclasses
import math
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from planners.bug.bug2 import plan_bug2
from planners.bug.tangent_bug import plan_tangent_bug
from planners.scene import Scene
from planners.space.expansion import DEFAULT_ARC_STEP, ConfigurationSpace
from planners.visibility import plan_visibility

STATUSES = ("ok", "reached", "unreachable", "invalid")
"""Every result's ``status``: a graph planner found a path (``"ok"``), a trace reached the
goal (``"reached"``), there is none or the robot gave up (``"unreachable"``), or the scene
cannot be planned (``"invalid"``: start or goal blocked, a bad polygon)."""

KINDS = ("graph", "trace")
"""``"graph"``: searches a graph of the whole known space; ``"trace"``: senses as it goes."""


@runtime_checkable
class PlanResult(Protocol):
    """What every planner returns: a frozen dataclass, built complete.

    :func:`planners.plan_all` returns a copy with ``ms`` set (planners read no clock).
    """

    @property
    def planner(self) -> str:
        """The planner's registry name."""
        ...

    @property
    def status(self) -> str:
        """One of :data:`STATUSES`."""
        ...

    @property
    def length(self) -> float | None:
        """Path length [m], or None when there is no path."""
        ...

    @property
    def path(self) -> npt.NDArray[np.float64]:
        """The path, shape (N, 2) [m].

        (0, 2) when a graph finds none; a trace's walk until it stopped, also when it
        gave up.
        """
        ...

    @property
    def reason(self) -> str | None:
        """Why there is no path, in words; None when there is one."""
        ...

    @property
    def ms(self) -> float:
        """Compute time [ms] (set by :func:`planners.plan_all`, shared expansion included)."""
        ...


@dataclasses.dataclass(frozen=True)
class PlanOptions:
    """Settings shared by the planners (a scene's own fields are used where None)."""

    sensor_range: float | None = None
    """Range R of the sensing planners [m]; None uses the scene's. ``math.inf`` is unlimited."""
    arc_step: float = DEFAULT_ARC_STEP
    """Resolution of the disk model's arcs [rad]."""
    leave_rule: str = "tangent_bug"
    """DSB leave rule: ``"tangent_bug"`` (d_reach < d_followed) or ``"chapter"`` (d(r, g) < d(M, g))."""

    def range_for(self, scene: Scene) -> float:
        """Return the sensor range R to use on ``scene`` [m]."""
        return float(
            scene.sensor_range if self.sensor_range is None else self.sensor_range
        )


RunFn = Callable[[ConfigurationSpace, Scene, PlanOptions], Any]
"""``run(cspace, scene, options) -> result``: pure; start and goal are known to be free."""


@dataclasses.dataclass(frozen=True)
class PlannerSpec:
    """One planner: how to run it and how to present it."""

    name: str
    """Short name: the key in results, the CLI's ``--planners``, the app's layer id."""
    title: str
    """Name for people, as in the chapter."""
    kind: str
    """``"graph"`` or ``"trace"`` (:data:`KINDS`)."""
    run: RunFn
    """Computes the result (see :data:`RunFn`)."""
    section: str
    """Where the method is taught (chapter section), or ``""`` for additions."""
    default: bool = True
    """Whether it runs unless the user chooses otherwise."""
    summary: str = ""
    """One sentence for the legend and the CLI's help."""


def _vg(cspace: ConfigurationSpace, scene: Scene, options: PlanOptions) -> Any:
    return plan_visibility(cspace, scene.start, scene.goal)


def _svg(cspace: ConfigurationSpace, scene: Scene, options: PlanOptions) -> Any:
    return plan_visibility(cspace, scene.start, scene.goal, simplified=True)


def _dsb(cspace: ConfigurationSpace, scene: Scene, options: PlanOptions) -> Any:
    return plan_tangent_bug(
        cspace,
        scene.start,
        scene.goal,
        options.range_for(scene),
        leave_rule=options.leave_rule,
    )


def _bug2(cspace: ConfigurationSpace, scene: Scene, options: PlanOptions) -> Any:
    return plan_bug2(cspace, scene.start, scene.goal)


REGISTRY: Mapping[str, PlannerSpec] = MappingProxyType(
    {
        spec.name: spec
        for spec in (
            PlannerSpec(
                "vg",
                "Visibility graph (VG)",
                "graph",
                _vg,
                "9.4",
                summary="every segment between mutually visible vertices; the shortest path",
            ),
            PlannerSpec(
                "svg",
                "Simplified visibility graph (SVG)",
                "graph",
                _svg,
                "9.5",
                summary="only the tangent segments (rules 1, 2a, 2b); the same shortest path",
            ),
            PlannerSpec(
                "dsb",
                "Distance-sensor-based (DSB, TangentBug)",
                "trace",
                _dsb,
                "9.6",
                summary="senses within R; goal seeking and boundary following (Fig. 9.15)",
            ),
            PlannerSpec(
                "bug2",
                "Bug2 (contact sensor)",
                "trace",
                _bug2,
                "",
                default=False,
                summary="along the M-line; round each obstacle it touches until back on it",
            ),
        )
    }
)
"""Every planner by name, in the order they are drawn and reported."""


def default_planners(
    registry: Mapping[str, PlannerSpec] = REGISTRY,
) -> tuple[str, ...]:
    """Return the names of the planners that run unless the user chooses otherwise."""
    return tuple(name for name, spec in registry.items() if spec.default)


def planners_of_kind(
    kind: str,
    names: tuple[str, ...] | None = None,
    registry: Mapping[str, PlannerSpec] = REGISTRY,
) -> tuple[str, ...]:
    """Return the planners of ``kind`` among ``names`` (default: all), in registry order.

    ``registry`` may be a caller's own mapping (a test's or a student's planners added).

    Examples
    --------
    >>> planners_of_kind("graph"), planners_of_kind("trace", ("vg", "dsb"))
    (('vg', 'svg'), ('dsb',))
    """
    if kind not in KINDS:
        raise ValueError(f"unknown planner kind {kind!r} (expected one of {KINDS})")
    chosen = registry if names is None else names
    return tuple(n for n in chosen if registry[n].kind == kind)


def finite_length(length: float | None) -> float | None:
    """Return ``length`` as a float, None for no path (for JSON and tables)."""
    return None if length is None or not math.isfinite(length) else float(length)
