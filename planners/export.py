"""A planned path and the robot's trajectory as files for a robot's controller.

Everything is in the scene's frame, which for a scene imported from an occupancy map is
the map's world frame (the map's origin and yaw already applied): a robot localised in
that map can follow the points as they are. Units: metres, radians, seconds, rad/s.

Two tables:

- the **path**: the planner's points ``x, y``, in order from start to goal;
- the **trajectory**: the robot driving the path as the app animates it
  (:func:`planners.drive.trajectory`), one row every ``dt``: time ``t``, pose
  ``x, y, phi``, world velocity ``vx, vy, omega`` and the wheel rates ``wheel_1 ...
  wheel_k`` of eq. 9.5 (holonomic: wheels at 30, 150 and 270 degrees) or eq. 9.9
  (differential: wheel 1 on the right, wheel 2 on the left).

CSV holds one table with a header row; JSON holds both, with the robot and the units.
"""

from __future__ import annotations

__all__ = [
    "EXPORT_FORMAT",
    "export_json",
    "path_csv",
    "trajectory_columns",
    "trajectory_csv",
    "trajectory_rows",
]

import io
import json
import math
from typing import Any

import numpy as np
import numpy.typing as npt

import kinematics
from planners.scene import Scene

EXPORT_FORMAT = 1
"""Version of the JSON export's layout (its ``format`` key)."""


def trajectory_columns(traj: kinematics.Trajectory) -> tuple[str, ...]:
    """Name the trajectory table's columns: t, pose, velocity, one per driven wheel."""
    wheels = tuple(f"wheel_{i + 1}" for i in range(traj.wheel_rates.shape[1]))
    return ("t", "x", "y", "phi", "vx", "vy", "omega", *wheels)


def trajectory_rows(traj: kinematics.Trajectory) -> npt.NDArray[np.float64]:
    """Return the trajectory table, one row per sample, columns :func:`trajectory_columns`.

    Examples
    --------
    >>> traj = kinematics.plan_trajectory([[0.0, 0.0], [1.0, 0.0]], kinematics.RobotParams())
    >>> rows = trajectory_rows(traj)
    >>> rows.shape[1], rows[-1, 1:3].round(9).tolist()
    (10, [1.0, 0.0])
    """
    return np.column_stack([traj.t, traj.pose, traj.velocity, traj.wheel_rates])


def _csv(columns: tuple[str, ...], rows: npt.NDArray[np.float64]) -> str:
    out = io.StringIO()
    out.write(",".join(columns) + "\n")
    for row in rows:
        out.write(",".join(repr(float(v)) for v in row) + "\n")
    return out.getvalue()


def path_csv(path: npt.ArrayLike) -> str:
    """Write the path's points as CSV: a header ``x,y``, then one point per line [m].

    Examples
    --------
    >>> print(path_csv([[0, 0], [1.5, 2]]), end="")
    x,y
    0.0,0.0
    1.5,2.0
    """
    return _csv(("x", "y"), np.asarray(path, dtype=np.float64).reshape(-1, 2))


def trajectory_csv(traj: kinematics.Trajectory) -> str:
    """Write the trajectory table as CSV, full float precision (``repr``)."""
    return _csv(trajectory_columns(traj), trajectory_rows(traj))


def _robot(traj: kinematics.Trajectory) -> dict[str, Any]:
    robot = traj.robot
    return {
        "kind": robot.kind,
        "radius": robot.radius,
        "wheel_radius": robot.wheel_radius,
        "wheel_distance": robot.wheel_distance,
        "wheel_angles_deg": [round(math.degrees(b), 9) for b in robot.wheel_angles],
    }


def export_json(
    scene: Scene,
    planner: str,
    path: npt.ArrayLike,
    traj: kinematics.Trajectory | None,
) -> str:
    """Write the path and the trajectory as one JSON object.

    Parameters
    ----------
    scene
        The scene the path was planned in (its name and map file are recorded).
    planner
        The planner's name (``"vg"``, ``"svg"``, ``"dsb"``, ...).
    path
        The planner's path (N, 2) [m].
    traj
        The robot's trajectory along it, or None when there is none (a path of one point).

    Examples
    --------
    >>> import planners
    >>> s = planners.load_scene({"format": 1, "obstacles": [], "start": [0, 0], "goal": [1, 0]})
    >>> out = json.loads(export_json(s, "vg", [[0, 0], [1, 0]], None))
    >>> out["frame"], out["path"], out["trajectory"]
    ('world', [[0.0, 0.0], [1.0, 0.0]], None)
    """
    points = np.asarray(path, dtype=np.float64).reshape(-1, 2)
    table = None
    if traj is not None:
        table = {
            "dt": traj.dt,
            "robot": _robot(traj),
            "columns": list(trajectory_columns(traj)),
            "rows": trajectory_rows(traj).tolist(),
        }
    out = {
        "format": EXPORT_FORMAT,
        "frame": "world",
        "units": {"length": "m", "angle": "rad", "time": "s", "wheel_rate": "rad/s"},
        "scene": scene.name,
        "map": scene.map or None,
        "planner": planner,
        "path": points.tolist(),
        "trajectory": table,
    }
    return json.dumps(out, allow_nan=False) + "\n"
