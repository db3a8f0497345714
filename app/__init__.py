"""The interactive planner in the browser: a viser app over :mod:`planners` and :mod:`kinematics`.

Start it with ``python -m app`` or from Python::

    from app import start_app
    planner = start_app("01_two_convex", port=8080)
    print(planner.url)

Rooms, each a folder of a few modules that imports only the rooms below it:

- :mod:`app.session`: one scene for one audience, without viser: the controller and its
  parts (state, history, mouse tools, scheduler, worker processes, frames, playback,
  the robot's kinematics glue, the scenes folder).
- :mod:`app.ui`: what a browser sees: the 3-D view, the panel, colours, thinning, scoped
  drawing, text shown as text.
- :mod:`app.guard`: browsers are not trusted: the door, the fair callback pool, the edit
  gate.
- :mod:`app.explain`: Explain mode's panel and drawing.
- :mod:`app.media`: pictures, videos and pages through a headless browser, and their
  command-line jobs.

On top: :mod:`app.server` (wiring: :func:`start_app`), :mod:`app.classroom` (presenter
mode, private copies), :mod:`app.live` (the *Live DSB* robot) and :mod:`app.__main__`
(the command line).

The names below are imported on first use, so that a worker process that needs only
:mod:`app.session.controller` does not load viser.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from app.server import (
        DEFAULT_SCENARIO,
        PlannerApp,
        list_scenarios,
        resolve_scenario,
        start_app,
    )
    from app.session.controller import Controller, Frame, RobotPose, Selection

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
    "Controller": "app.session.controller",
    "Frame": "app.session.controller",
    "RobotPose": "app.session.controller",
    "Selection": "app.session.controller",
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
