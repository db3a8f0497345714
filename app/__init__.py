"""The interactive planner in the browser: a viser app over :mod:`planners` and :mod:`kinematics`.

Start it with ``python -m app`` or from Python::

    from app import start_app
    planner = start_app("01_two_convex", port=8080)
    print(planner.url)

Modules: :mod:`app.controller` (state and edits, no viser), :mod:`app.view` (the 3-D
scene), :mod:`app.panels` (the GUI panel), :mod:`app.robot` (kinematics glue),
:mod:`app.server` (wiring) and :mod:`app.headless` (snapshots through a browser).
"""

from __future__ import annotations

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
