"""The scene's robot driving a planned path: the trajectory of section 9.7.

The one place where a scene's robot and a path become a timed motion, with wheel rates
from eq. 9.5 (holonomic) or 9.9 (differential). The app's robot animates this trajectory
and :mod:`planners.export` writes it for a robot's controller, so both show the same
motion.
"""

from __future__ import annotations

__all__ = [
    "LONG_PATH_M",
    "MAX_SAMPLES",
    "least_duration",
    "robot_params",
    "sample_period",
    "trajectory",
]

import math

import numpy as np
import numpy.typing as npt

import kinematics
from kinematics import RobotParams
from kinematics.wheel_limits import WheelLimits, centre_limits
from planners.scene import Robot, Scene

LONG_PATH_M = 500.0
"""Paths longer than this [m] are sampled more sparsely, so that a scene with its goal
kilometres away (a hostile upload) cannot fill a server's memory with samples."""


MAX_SAMPLES = 20_000
"""Most samples a trajectory is planned with (1,000 s at 0.05 s): a robot with wheel
limits near zero (a hostile scene's) crawls for days, and its samples would fill the
memory; its period is stretched instead (:func:`least_duration`)."""


def robot_params(robot: Robot) -> RobotParams:
    """Convert the scene's robot to :class:`kinematics.RobotParams`."""
    return RobotParams(
        kind=robot.kind,  # type: ignore[arg-type]
        wheel_radius=robot.wheel_radius,
        wheel_distance=robot.wheel_distance,
        radius=robot.radius,
    )


def sample_period(path: npt.NDArray[np.float64], dt: float = 0.05) -> float:
    """Return the trajectory's sample period: ``dt``, stretched past :data:`LONG_PATH_M`.

    Examples
    --------
    >>> sample_period(np.array([[0.0, 0.0], [100.0, 0.0]]))
    0.05
    >>> sample_period(np.array([[0.0, 0.0], [1e5, 0.0]]))
    10.0
    """
    length = float(np.sum(np.hypot(*np.diff(path, axis=0).T))) if len(path) > 1 else 0.0
    return dt * max(1.0, length / LONG_PATH_M)


def least_duration(path: npt.NDArray[np.float64], limits: kinematics.Limits) -> float:
    """Return a lower bound [s] of the time the centre needs for ``path`` within ``limits``.

    Driving the length at most at the top speed, or speeding up and slowing down once,
    and likewise turning through every corner of the path (a differential robot turns
    at each; a holonomic one may not, which only makes the bound lower).

    Examples
    --------
    >>> limits = kinematics.Limits(max_speed=0.5, max_acceleration=1e6)
    >>> round(least_duration(np.array([[0.0, 0.0], [10.0, 0.0]]), limits), 6)
    20.0
    """
    steps = np.diff(path, axis=0) if len(path) > 1 else np.zeros((0, 2))
    length = float(np.sum(np.hypot(*steps.T)))
    headings = np.arctan2(steps[:, 1], steps[:, 0])
    turns = np.angle(np.exp(1j * np.diff(headings))) if len(headings) > 1 else []
    turning = float(np.sum(np.abs(turns)))

    def least(amount: float, top: float, acceleration: float) -> float:
        return max(amount / top, 2.0 * math.sqrt(amount / acceleration))

    return least(length, limits.max_speed, limits.max_acceleration) + least(
        turning, limits.max_turn_rate, limits.max_angular_acceleration
    )


def trajectory(
    scene: Scene, path: npt.ArrayLike, dt: float = 0.05
) -> kinematics.Trajectory:
    """Plan the timed motion of the scene's robot along ``path`` (section 9.7).

    Parameters
    ----------
    scene
        Gives the robot: its kind, wheels and wheel limits (section 9.7.3).
    path
        The path's points (N, 2) [m], e.g. a planner's ``result.path``.
    dt
        Sample period [s]; stretched for paths longer than :data:`LONG_PATH_M`.

    Examples
    --------
    >>> import planners
    >>> s = planners.load_scene({"format": 1, "obstacles": [], "start": [0, 0], "goal": [1, 0]})
    >>> float(round(trajectory(s, [[0, 0], [1, 0]]).pose[-1, 0], 9))
    1.0
    """
    params = robot_params(scene.robot)
    limits = None
    if (
        scene.robot.max_wheel_rate is not None
        or scene.robot.max_wheel_acceleration is not None
    ):
        # Section 9.7.3: the centre's limits are derived so every wheel keeps within its own.
        wheels = WheelLimits(
            max_rate=scene.robot.max_wheel_rate or math.inf,
            max_acceleration=scene.robot.max_wheel_acceleration or math.inf,
        )
        limits = centre_limits(params, wheels)
    # With wheel limits, long turns in place are costly: the differential robot may
    # reverse instead (stop mode).
    points = np.asarray(path, dtype=np.float64)
    least = least_duration(points, limits or kinematics.Limits())
    options = kinematics.TrajectoryOptions(
        reverse=limits is not None,
        dt=max(sample_period(points, dt), least / MAX_SAMPLES),
    )
    return kinematics.plan_trajectory(points, params, limits=limits, options=options)
