"""Path planners for a disk robot among polygon obstacles (Chapter 9, sections 9.3-9.6).

Pure functions on plain data: no viser, no drawing, no clocks inside the algorithms.

The rooms, each importing only those below it (docs/architecture.md):

- :mod:`planners.api` (:func:`plan_all`), :mod:`planners.registry` (the planners),
  the command line (``python -m planners``);
- :mod:`planners.maps`: ROS map_server occupancy maps read and traced into scenarios;
- :mod:`planners.explain`: each method as steps a lecturer can show;
- :mod:`planners.visibility` (VG, SVG) and :mod:`planners.bug` (TangentBug, Bug2, the
  sensor, the live robot);
- :mod:`planners.space` (the configuration space and its border) and
  :mod:`planners.scene` (the scene value and its files);
- shared by all: :mod:`planners.memo` (the caller's caches), :mod:`planners.kernels`
  (the compiled loops), :mod:`planners.allocator` (the process's memory).

>>> import planners
>>> scene = planners.load_scene({"format": 1, "obstacles": [], "start": [0, 0], "goal": [3, 4]})
>>> planners.plan_all(scene)["vg"].length
5.0
"""

from __future__ import annotations

from planners import api, maps, memo, registry, scene, visibility
from planners.api import PLANNERS, InvalidResult, plan_all, result_to_json
from planners.bug import bug2, live, sensor, tangent_bug
from planners.bug.sensor import Sensing, sense
from planners.bug.tangent_bug import (
    BugEvent,
    BugParams,
    BugState,
    BugTrace,
    plan_tangent_bug,
)
from planners.explain import Explanation, Mark, Step, explain
from planners.explain.dsb import explain_dsb
from planners.explain.expansion import explain_expansion
from planners.explain.svg import explain_svg
from planners.explain.vg import explain_vg
from planners.memo import Memo
from planners.registry import REGISTRY, PlannerSpec, PlanOptions, PlanResult
from planners.scene import (
    Robot,
    ScenarioError,
    Scene,
    load_scene,
    motion,
    save_scene,
    scene_problems,
)
from planners.space import border, expansion
from planners.space.expansion import (
    ConfigurationSpace,
    configuration_space,
    expand_disk,
    expand_polygon,
    expand_square,
)
from planners.visibility import (
    VisibilityResult,
    plan_visibility,
    segments_free,
    shortest_path,
    simplified_visibility_graph,
    visibility_graph,
)

__all__ = [
    "PLANNERS",
    "REGISTRY",
    "BugEvent",
    "BugParams",
    "BugState",
    "BugTrace",
    "ConfigurationSpace",
    "Explanation",
    "InvalidResult",
    "Mark",
    "Memo",
    "PlanOptions",
    "PlanResult",
    "PlannerSpec",
    "Robot",
    "ScenarioError",
    "Scene",
    "Sensing",
    "Step",
    "VisibilityResult",
    "api",
    "border",
    "bug2",
    "configuration_space",
    "expand_disk",
    "expand_polygon",
    "expand_square",
    "expansion",
    "explain",
    "explain_dsb",
    "explain_expansion",
    "explain_svg",
    "explain_vg",
    "live",
    "load_scene",
    "maps",
    "memo",
    "motion",
    "plan_all",
    "plan_tangent_bug",
    "plan_visibility",
    "registry",
    "result_to_json",
    "save_scene",
    "scene",
    "scene_problems",
    "segments_free",
    "sense",
    "sensor",
    "shortest_path",
    "simplified_visibility_graph",
    "tangent_bug",
    "visibility",
    "visibility_graph",
]
