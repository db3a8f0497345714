"""One call that runs every planner on a scene: what the app, the CLI and students use."""

from __future__ import annotations

__all__ = ["PLANNERS", "InvalidResult", "PlanOptions", "plan_all", "result_to_json"]

import dataclasses
import math
import time  # the only clock in planners/: plan_all reports compute times (DESIGN.md)
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np

from planners.expansion import DEFAULT_ARC_STEP, ConfigurationSpace, configuration_space
from planners.scene import Scene, scene_problems
from planners.tangent_bug import BugTrace, plan_tangent_bug
from planners.visibility import VisibilityResult, plan_visibility


@dataclasses.dataclass(frozen=True)
class PlanOptions:
    """Settings shared by the planners (a scene's own fields are used where None)."""

    sensor_range: float | None = None
    """Range R of the DSB planner's sensor [m]; None uses the scene's. ``math.inf`` is unlimited."""
    arc_step: float = DEFAULT_ARC_STEP
    """Resolution of the disk model's arcs [rad]."""
    leave_rule: str = "tangent_bug"
    """DSB leave rule: ``"tangent_bug"`` (d_reach < d_followed) or ``"chapter"`` (d(r, g) < d(M, g))."""


@dataclasses.dataclass(frozen=True, eq=False)
class InvalidResult:
    """A planner's answer when the scene itself is not plannable."""

    planner: str
    reason: str
    status: str = "invalid"
    length: float | None = None
    path: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2)))
    ms: float = 0.0


# A planner takes (scene, configuration space, options) and returns its result.
Planner = Callable[[Scene, ConfigurationSpace, PlanOptions], Any]


def _vg(
    scene: Scene, cspace: ConfigurationSpace, options: PlanOptions
) -> VisibilityResult:
    return plan_visibility(cspace, scene.start, scene.goal)


def _svg(
    scene: Scene, cspace: ConfigurationSpace, options: PlanOptions
) -> VisibilityResult:
    return plan_visibility(cspace, scene.start, scene.goal, simplified=True)


def _dsb(scene: Scene, cspace: ConfigurationSpace, options: PlanOptions) -> BugTrace:
    radius = (
        scene.sensor_range if options.sensor_range is None else options.sensor_range
    )
    return plan_tangent_bug(
        cspace, scene.start, scene.goal, radius, leave_rule=options.leave_rule
    )


PLANNERS: dict[str, Planner] = {"vg": _vg, "svg": _svg, "dsb": _dsb}
"""Every planner by its short name, in the order they are drawn and reported."""


def _timed(result: Any, ms: float) -> Any:
    # Results are frozen; the time is measured around the call and attached afterwards.
    object.__setattr__(result, "ms", ms)
    return result


def plan_all(
    scene: Scene,
    which: Iterable[str] | None = None,
    options: PlanOptions | None = None,
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
        Planner names, a subset of :data:`PLANNERS`; None runs them all
        (``("vg", "svg", "dsb")``).
    options
        Shared settings; None for the defaults.

    Returns
    -------
    dict
        Planner name -> result. Each result has ``status``, ``length`` (float or None),
        ``path`` ((N, 2) array, (0, 2) when there is none), ``reason`` and ``ms`` (time
        to compute, including the shared expansion), plus the planner's own detail:
        ``graph`` for VG/SVG. ``"cspace"`` holds the configuration space when built.

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
    names = list(PLANNERS if which is None else which)
    unknown = [n for n in names if n not in PLANNERS]
    if unknown:
        raise ValueError(
            f"unknown planner {unknown[0]!r} (known: {', '.join(PLANNERS)})"
        )
    results: dict[str, Any] = {}
    problems = scene_problems(scene)
    if problems:
        reason = "; ".join(problems)
        return {n: InvalidResult(n, reason) for n in names}
    t0 = time.perf_counter()
    cspace = configuration_space(
        scene.obstacles,
        scene.robot.radius,
        scene.expansion,
        scene.boundary,
        options.arc_step,
        extra_points=[scene.start, scene.goal],
    )
    shared_ms = (time.perf_counter() - t0) * 1e3
    reason = _endpoint_problem(scene, cspace)
    if reason is not None:
        results = {n: InvalidResult(n, reason) for n in names}
    else:
        for name in names:
            t1 = time.perf_counter()
            result = PLANNERS[name](scene, cspace, options)
            results[name] = _timed(result, shared_ms + (time.perf_counter() - t1) * 1e3)
    results["cspace"] = cspace
    return results


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


def result_to_json(name: str, result: Any) -> dict[str, Any]:
    """Turn one planner result into the CLI's JSON object (DESIGN.md contract)."""
    path = np.asarray(result.path, dtype=np.float64).reshape(-1, 2)
    length = result.length
    out: dict[str, Any] = {
        "status": result.status,
        "length": None
        if length is None or not math.isfinite(length)
        else float(length),
        "path": path.tolist(),
    }
    if name in ("vg", "svg"):
        out["nodes"] = getattr(result, "nodes", 0)
        out["edges"] = getattr(result, "edges", 0)
    events = getattr(result, "events", None)
    if name == "dsb":
        out["events"] = [_event_json(e) for e in (events or ())]
    out["ms"] = round(float(getattr(result, "ms", 0.0)), 3)
    out["reason"] = result.reason
    return out


def _event_json(event: Any) -> dict[str, Any]:
    if isinstance(event, Mapping):
        kind, at = event["kind"], event["at"]
    else:
        kind, at = event.kind, event.at
    return {"kind": kind, "at": [float(at[0]), float(at[1])]}
