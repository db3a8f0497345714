"""Glue between the scene's robot and :mod:`kinematics`: trajectories, samples, meshes.

The controller calls :func:`trajectory` (:mod:`planners.drive`'s, so that an exported
trajectory is the one the app animates) when a path changes and :func:`sample` for every
animation frame; the view calls :func:`robot_model` when the robot changes. Nothing here
imports viser.
"""

from __future__ import annotations

__all__ = [
    "MeshPiece",
    "RobotModel",
    "robot_model",
    "robot_params",
    "sample",
    "sample_period",
    "trajectory",
]

import dataclasses
import functools
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

import kinematics
from kinematics import RobotParams
from planners.drive import robot_params, sample_period, trajectory
from planners.scene import Robot, Scene

FloatArray = npt.NDArray[np.float64]
MeshPiece = tuple[tuple[FloatArray, npt.NDArray[np.uint32]], tuple[int, int, int]]
"""((vertices (V, 3), faces (F, 3)), colour)."""

# The body is built once at this radius and scaled to the robot's: building the
# holonomic robot's rollers takes ~80 ms, too slow to redo for every step of a slider.
_REFERENCE_RADIUS = 1.0


@dataclasses.dataclass(frozen=True, eq=False)
class RobotModel:
    """The robot's meshes, ready for the view."""

    body: tuple[MeshPiece, ...]
    """Body, heading marker and caster, in the robot frame, drawn at :attr:`body_scale`."""
    body_scale: float
    """Scale of the body pieces in x and y (1 at the reference radius)."""
    wheels: tuple[tuple[FloatArray, FloatArray, tuple[MeshPiece, ...]], ...]
    """(hub (3,), axle (3,), pieces in the wheel-local frame) for each driven wheel."""


def sample(
    traj: kinematics.Trajectory, t: float, scene: Scene, result: Any
) -> Mapping[str, Any]:
    """Return the robot's pose, wheel angles and rates at time ``t`` [s] of ``traj``.

    Wheel rates and the velocity are linear between samples, as in the trajectory.
    For a DSB result that can say what the robot senses, ``sensing`` carries it.
    """
    duration = traj.duration
    tt = min(max(float(t), 0.0), duration)
    pose, angles = traj.sample(tt)
    if len(traj.t) > 1:
        k = min(int(tt / traj.dt), len(traj.t) - 2)
        w = (tt - traj.t[k]) / traj.dt
        rates = (1 - w) * traj.wheel_rates[k] + w * traj.wheel_rates[k + 1]
        velocity = (1 - w) * traj.velocity[k] + w * traj.velocity[k + 1]
    else:
        rates, velocity = traj.wheel_rates[0], traj.velocity[0]
    xy = (float(pose[0]), float(pose[1]))
    return {
        "duration": duration,
        "xy": xy,
        "phi": float(pose[2]),
        "wheel_angles": tuple(float(a) for a in angles),
        "wheel_rates": tuple(float(r) for r in rates),
        "velocity": (float(velocity[0]), float(velocity[1]), float(velocity[2])),
        "sensing": sensing_at(result, traj, tt, scene),
    }


def sensing_at(
    result: Any, traj: kinematics.Trajectory, t: float, scene: Scene
) -> Mapping[str, Any] | None:
    """Describe what a DSB robot senses at time ``t``: sensor disk, borders, tangent graph.

    Returns None for results that cannot tell (VG, SVG, Bug2). A DSB trace
    (:class:`planners.bug.tangent_bug.BugTrace`) is asked at the arclength the robot has
    travelled along it, so the picture is what the robot used for its decisions there
    (Fig. 9.16: the visible border within R, the points O_i and the lines r-O_i). The
    chosen r_next is the planner's own decision there (:meth:`BugTrace.aim_at`), never
    worked out again here: the planner also filters candidates, slides between two equal
    ones and breaks ties, and while it follows a border it chooses none (``chosen`` is
    then None).
    """
    if getattr(result, "sensing_at", None) is None or len(result.path) < 2:
        return None
    s = travelled_fraction(traj, t) * float(result.travelled)
    seen = result.sensing_at(s)
    position = np.asarray(result.position_at(s), dtype=np.float64)
    points = np.asarray(seen.points, dtype=np.float64).reshape(-1, 2)
    tangents = (
        np.stack([np.broadcast_to(position, points.shape), points], axis=1)
        if len(points)
        else np.zeros((0, 2, 2))
    )
    aim = result.aim_at(s)  # the planner's: None while it follows a border
    return {
        "center": (float(position[0]), float(position[1])),
        "radius": float(seen.radius),
        "seen": np.asarray(seen.segments, dtype=np.float64).reshape(-1, 2, 2),
        "tangents": tangents,
        "points": points,
        "chosen": aim,
        "goal": (float(scene.goal[0]), float(scene.goal[1])),
    }


@functools.lru_cache(maxsize=8)
def _travelled(traj: kinematics.Trajectory) -> FloatArray:
    # Distance travelled along the trajectory at each sample (trapezoid rule on the speed).
    speed = np.hypot(traj.velocity[:, 0], traj.velocity[:, 1])
    return np.concatenate([[0.0], np.cumsum(0.5 * traj.dt * (speed[1:] + speed[:-1]))])


def travelled_fraction(traj: kinematics.Trajectory, t: float) -> float:
    """Fraction of the trajectory's distance travelled by time ``t`` [s], in [0, 1].

    The robot may cut corners a little (continuous mode), so its distance is mapped onto
    the planned path in proportion, which keeps both ends in step.
    """
    cum = _travelled(traj)
    if len(cum) < 2 or cum[-1] <= 0:
        return 1.0 if t >= traj.duration else 0.0
    return float(np.interp(t, traj.t, cum) / cum[-1])


@functools.lru_cache(maxsize=16)
def _geometry(
    kind: str, wheel_radius: float, wheel_distance: float
) -> kinematics.RobotGeometry:
    params = RobotParams(
        kind="differential" if kind == "differential" else "holonomic",
        wheel_radius=wheel_radius,
        wheel_distance=wheel_distance,
        radius=_REFERENCE_RADIUS,
    )  # type: ignore[arg-type]
    return kinematics.robot_geometry(params)


def _piece(mesh: Any, color: Sequence[int]) -> MeshPiece:
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.uint32)
    return ((vertices, faces), (int(color[0]), int(color[1]), int(color[2])))


@functools.lru_cache(maxsize=16)
def _model(
    kind: str, wheel_radius: float, wheel_distance: float
) -> tuple[tuple[MeshPiece, ...], tuple[Any, ...]]:
    g = _geometry(kind, wheel_radius, wheel_distance)
    body = [_piece(g.body, g.body_color), _piece(g.heading, g.heading_color)]
    if g.caster is not None:
        body.append(_piece(g.caster, g.caster_color))
    wheels = tuple(
        (
            np.asarray(w.hub, dtype=np.float64),
            np.asarray(w.axle, dtype=np.float64),
            (_piece(w.mesh, w.color), _piece(w.marking, w.marking_color)),
        )
        for w in g.wheels
    )
    return tuple(body), wheels


def robot_model(robot: Robot) -> tuple[Any, RobotModel]:
    """Return (key, model) of the robot's meshes; the key changes only when the meshes do.

    A point robot (radius 0) is drawn with a body just around its wheels.
    """
    body, wheels = _model(robot.kind, robot.wheel_radius, robot.wheel_distance)
    radius = (
        robot.radius if robot.radius > 0 else robot.wheel_distance + robot.wheel_radius
    )
    key = (robot.kind, robot.wheel_radius, robot.wheel_distance)
    return key, RobotModel(
        body=body, body_scale=radius / _REFERENCE_RADIUS, wheels=wheels
    )
