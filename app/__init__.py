"""The interactive planner in the browser: a viser app over :mod:`planners` and :mod:`kinematics`.

Start it with ``python -m app`` or from Python::

    from app import start_app
    planner = start_app("01_two_convex", port=8080)
    print(planner.url)

Modules: :mod:`app.controller` (one session: a small facade, no viser) over
:mod:`app.session` (scene, version, history and UI state under one lock),
:mod:`app.history` (undo/redo, pure), :mod:`app.tools` (mouse tools and picking, pure),
:mod:`app.scheduler` (planning lanes, coalescing, frames), :mod:`app.lanes` (the slow
planners' process), :mod:`app.playback` (the robot's motion) and :mod:`app.frames` (what
views draw); :mod:`app.view` (the 3-D scene), :mod:`app.panels` (the GUI panel),
:mod:`app.robot` (kinematics glue), :mod:`app.server` (wiring), :mod:`app.headless`
(snapshots through a browser) and, for a class, :mod:`app.classroom` (presenter mode,
private copies) with :mod:`app.scoped`, :mod:`app.gate` and :mod:`app.pool`.

The names below are imported on first use, so that a worker process that needs only
:mod:`app.controller` does not load viser.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from app.controller import Controller, Frame, RobotPose, Selection
    from app.server import (
        DEFAULT_SCENARIO,
        PlannerApp,
        list_scenarios,
        resolve_scenario,
        start_app,
    )

__all__ = [
    "DEFAULT_SCENARIO",
    "Controller",
    "Frame",
    "PlannerApp",
    "RobotPose",
    "Selection",
    "list_scenarios",
    "resolve_scenario",
    "start_app",
]

_WHERE = {
    "Controller": "app.controller",
    "Frame": "app.controller",
    "RobotPose": "app.controller",
    "Selection": "app.controller",
    "DEFAULT_SCENARIO": "app.server",
    "PlannerApp": "app.server",
    "list_scenarios": "app.server",
    "resolve_scenario": "app.server",
    "start_app": "app.server",
}


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'app' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
