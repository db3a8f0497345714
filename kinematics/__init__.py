"""Wheel kinematics, trajectories and robot geometry (Chapter 9, sections 9.2 and 9.7).

Pure functions on plain data: numpy (and trimesh for the meshes), no viser, no drawing,
no clocks, no global random state. Modules: :mod:`~kinematics.holonomic` (eq. 9.1-9.6),
:mod:`~kinematics.differential` (eq. 9.7-9.11), :mod:`~kinematics.trajectory` (section 9.7),
:mod:`~kinematics.odometry`, :mod:`~kinematics.geometry` (meshes for the app),
:mod:`~kinematics.frames` (eq. 9.4) and :mod:`~kinematics.robot` (:class:`RobotParams`).

>>> import kinematics
>>> kinematics.holonomic.inverse(0.0, 0.0, 1.0, 0.0, r=0.05, L=0.25)  # pure rotation
array([5., 5., 5.])
"""

from __future__ import annotations

from kinematics import (
    differential,
    frames,
    geometry,
    holonomic,
    odometry,
    robot,
    trajectory,
)
from kinematics.geometry import RobotGeometry, WheelGeometry, robot_geometry
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
    "RobotGeometry",
    "RobotParams",
    "Trajectory",
    "TrajectoryOptions",
    "WheelGeometry",
    "differential",
    "frames",
    "geometry",
    "holonomic",
    "integrate_rates",
    "integrate_wheel_rates",
    "odometry",
    "peaks",
    "plan_trajectory",
    "robot",
    "robot_geometry",
    "trajectory",
    "trapezoidal_profile",
]
