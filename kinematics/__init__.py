"""Wheel kinematics, trajectories and robot geometry (Chapter 9, sections 9.2 and 9.7).

Pure functions on plain data: numpy (and trimesh for the meshes), no viser, no drawing,
no clocks, no global random state.

>>> import kinematics
>>> kinematics.holonomic.inverse(0.0, 0.0, 1.0, 0.0, r=0.05, L=0.25)  # pure rotation
array([5., 5., 5.])
"""

from __future__ import annotations

from kinematics import differential, frames, holonomic, odometry, robot, trajectory
from kinematics.odometry import integrate_rates, integrate_wheel_rates
from kinematics.robot import ROBOT_KINDS, RobotParams
from kinematics.trajectory import (
    Limits,
    Peaks,
    Trajectory,
    TrajectoryOptions,
    peaks,
    plan_trajectory,
    trapezoidal_profile,
)

__all__ = [
    "ROBOT_KINDS",
    "Limits",
    "Peaks",
    "RobotParams",
    "Trajectory",
    "TrajectoryOptions",
    "differential",
    "frames",
    "holonomic",
    "integrate_rates",
    "integrate_wheel_rates",
    "odometry",
    "peaks",
    "plan_trajectory",
    "robot",
    "trajectory",
    "trapezoidal_profile",
]
