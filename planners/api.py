"""One call that runs every planner on a scene: what the app, the CLI and students use."""

from __future__ import annotations

__all__ = [
    "PLANNERS",
    "REGISTRY",
    "InvalidResult",
    "PlanOptions",
    "plan_all",
    "result_to_json",
]

import dataclasses
import time  # the only clock in planners/: plan_all reports compute times
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from planners.memo import Memo
from planners.registry import (
    REGISTRY,
    PlannerSpec,
    PlanOptions,
    default_planners,
    finite_length,
)
from planners.scene import Scene, scene_problems
from planners.space.expansion import ConfigurationSpace, configuration_space
from planners.visibility.incremental import carry_visibility

PLANNERS: tuple[str, ...] = tuple(REGISTRY)
"""Every registered planner's name, in the order they are drawn and reported."""


@dataclasses.dataclass(frozen=True, eq=False)
class InvalidResult:
    """A planner's answer when the scene itself is not plannable."""

    planner: str
    reason: str
    status: str = "invalid"
    length: float | None = None
    path: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2)))
    ms: float = 0.0


def plan_all(
    scene: Scene,
    which: Iterable[str] | None = None,
    options: PlanOptions | None = None,
    memo: Memo | None = None,
    registry: Mapping[str, PlannerSpec] = REGISTRY,
) -> dict[str, Any]:
    """Run the chosen planners on ``scene``.

    The configuration space (expansion by the robot's radius, merging, shrunk walls) is
    built once and shared. A start or goal inside an obstacle or outside the walls gives
    every planner the status ``"invalid"`` with a reason naming the obstacle; a point on a
    border is valid.

    Parameters
    ----------
    scene
        The scene.
    which
        Planner names from :data:`planners.registry.REGISTRY`; None runs the default ones
        (``("vg", "svg", "dsb")``).
    options
        Shared settings; None for the defaults.
    memo
        The caller's :class:`planners.memo.Memo`: work it already holds for the same
        geometry is reused (an app keeps one per scene it edits). None: all cold.
    registry
        Where planner names are looked up: :data:`planners.registry.REGISTRY`, or a
        mapping that adds planners of the caller's own (a test's, a student's).

    Returns
    -------
    dict
        Planner name -> result (the :class:`planners.registry.PlanResult` protocol):
        ``status``, ``length`` (float or None), ``path`` ((N, 2) array, (0, 2) when there
        is none), ``reason`` and ``ms`` (time to compute, including the shared expansion),
        plus the planner's own detail: ``graph`` for VG/SVG, the trace for DSB and
        Bug2.
        ``"cspace"`` holds the configuration space when built.

    Examples
    --------
    >>> from planners.scene import load_scene
    >>> scene = load_scene({"format": 1, "obstacles": [[[0, 0], [2, 0], [2, 2], [0, 2]]],
    ...                     "start": [-1, 1], "goal": [3, 1], "robot": {"radius": 0}})
    >>> plans = plan_all(scene)
    >>> plans["vg"].status, round(plans["vg"].length, 6), round(plans["svg"].length, 6)
    ('ok', 4.828427, 4.828427)
    >>> plans["dsb"].status, [e.kind for e in plans["dsb"].events]
    ('reached', ['hit', 'leave'])
    """
    options = options or PlanOptions()
    names = default_planners(registry) if which is None else tuple(which)
    unknown = [n for n in names if n not in registry]
    if unknown:
        raise ValueError(
            f"unknown planner {unknown[0]!r} (known: {', '.join(registry)})"
        )
    problems = scene_problems(scene)
    if problems:
        reason = "; ".join(problems)
        return {n: InvalidResult(n, reason) for n in names}
    t0 = time.perf_counter()
    previous = memo.latest("cspace") if memo is not None else None
    cspace = configuration_space(
        scene.obstacles,
        scene.robot.radius,
        scene.expansion,
        scene.boundary,
        options.arc_step,
        extra_points=[scene.start, scene.goal],
        memo=memo,
    )
    if previous is not None and previous is not cspace:
        # An edit: the vertex visibility follows from the one before it.
        carry_visibility(cspace, previous)
    shared_ms = (time.perf_counter() - t0) * 1e3
    reason = _endpoint_problem(scene, cspace)
    results: dict[str, Any] = {}
    for name in names:
        if reason is not None:
            results[name] = InvalidResult(name, reason)
            continue
        t1 = time.perf_counter()
        result = registry[name].run(cspace, scene, options)
        ms = shared_ms + (time.perf_counter() - t1) * 1e3
        if not _is_plan_result(result):
            raise TypeError(
                f"planner {name!r} returned {type(result).__name__}, not a dataclass "
                "with an 'ms' field (planners.registry.PlanResult)"
            )
        # Planners cannot read a clock (docs/architecture.md, "Conventions"), so the time is measured around the
        # call and the complete result is a copy with it.
        results[name] = dataclasses.replace(result, ms=ms)
    results["cspace"] = cspace
    return results


def _is_plan_result(result: Any) -> bool:
    """Tell whether ``result`` is a dataclass instance with an ``ms`` field to set."""
    return (
        dataclasses.is_dataclass(result)
        and not isinstance(result, type)
        and any(f.name == "ms" for f in dataclasses.fields(result))
    )


def _endpoint_problem(scene: Scene, cspace: ConfigurationSpace) -> str | None:
    blocked = cspace.contains_blocked([scene.start, scene.goal])
    for label, point, is_blocked in zip(
        ("start", "goal"), (scene.start, scene.goal), blocked, strict=True
    ):
        if is_blocked:
            names = cspace.blockers(point)
            if not names:
                return f"the {label} is not in free space"
            where = " and ".join(names)
            if where.startswith("obstacle"):
                radius = scene.robot.radius
                grown = (
                    f" (expanded by the robot's radius {radius:g} m)"
                    if radius > 0
                    else ""
                )
                return f"the {label} is inside {where}{grown}"
            return f"the {label} is {where} (shrunk by the robot's radius)"
    return None


def result_to_json(
    name: str, result: Any, registry: Mapping[str, PlannerSpec] = REGISTRY
) -> dict[str, Any]:
    """Turn one planner result into the CLI's JSON object (docs/api.md, "Command line")."""
    path = np.asarray(result.path, dtype=np.float64).reshape(-1, 2)
    out: dict[str, Any] = {
        "status": result.status,
        "length": finite_length(result.length),
        "path": path.tolist(),
    }
    kind = registry[name].kind
    if kind == "graph":
        out["nodes"] = getattr(result, "nodes", 0)
        out["edges"] = getattr(result, "edges", 0)
    else:
        out["events"] = [
            {"kind": e.kind, "at": [float(e.at[0]), float(e.at[1])]}
            for e in getattr(result, "events", ())
        ]
    out["ms"] = round(float(result.ms), 3)
    out["reason"] = result.reason
    return out
