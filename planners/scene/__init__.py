"""The scene: obstacles, start, goal and robot as one immutable value, and its files.

- ``_scene``: the :class:`Scene` value, its pure edits, scenario files (load, check,
  save) and :func:`scene_at`, the scene at a time; its names are public here.
- :mod:`planners.scene.motion`: how an obstacle moves (the ``"motions"`` of a file).

Nothing here plans: the scene is what every planner and the app read.
"""

from __future__ import annotations

__all__ = [
    "EXPANSION_MODES",
    "MOTION_MODES",
    "ROBOT_KINDS",
    "Motion",
    "Robot",
    "Scenario",
    "ScenarioError",
    "Scene",
    "add_obstacle",
    "delete_obstacle",
    "delete_vertex",
    "insert_vertex",
    "is_map_name",
    "load_scene",
    "motion_offset",
    "move_goal",
    "move_obstacle",
    "move_start",
    "move_vertex",
    "replace_robot",
    "save_scene",
    "scene_at",
    "scene_from_dict",
    "scene_from_text",
    "scene_problems",
    "scene_to_dict",
]

from planners.scene._scene import (
    EXPANSION_MODES,
    ROBOT_KINDS,
    Robot,
    Scenario,
    ScenarioError,
    Scene,
    add_obstacle,
    delete_obstacle,
    delete_vertex,
    insert_vertex,
    is_map_name,
    load_scene,
    move_goal,
    move_obstacle,
    move_start,
    move_vertex,
    replace_robot,
    save_scene,
    scene_at,
    scene_from_dict,
    scene_from_text,
    scene_problems,
    scene_to_dict,
)
from planners.scene.motion import MOTION_MODES, Motion, motion_offset
