r"""Odometry: integrate wheel rates through the forward kinematics (section 9.7.3).

The check that makes the animation honest: the wheel rates a :class:`Trajectory` commands,
pushed through eq. 9.6 (holonomic) or eq. 9.11 (differential) and integrated, reproduce its
poses. The yaw rate from the wheels does not depend on the heading (R of eq. 9.4 leaves
:math:`\dot\phi` alone), so the heading is integrated first and the world velocity is then
evaluated at the integrated heading:

.. math::

    \phi_{k+1} = \phi_k + \tfrac{\Delta t}{2}(\dot\phi_k + \dot\phi_{k+1}), \qquad
    p_{k+1} = p_k + \tfrac{\Delta t}{2}\big(\dot p(\dot{\mathbf q}_k, \phi_k)
    + \dot p(\dot{\mathbf q}_{k+1}, \phi_{k+1})\big)

(``method="trapezoid"``, the scheme the trajectories are generated with: rates linear
between samples). ``method="euler"`` holds each sample's velocity until the next one
(zero-order hold); it drifts by O(dt) and is there to compare.
"""

from __future__ import annotations

__all__ = ["integrate_rates", "integrate_wheel_rates"]

from typing import Literal

import numpy as np
import numpy.typing as npt

from kinematics._arrays import FloatArray
from kinematics.robot import RobotParams
from kinematics.trajectory import Trajectory


def _cumulative(dt: FloatArray, values: FloatArray, method: str) -> FloatArray:
    steps = (
        0.5 * dt * (values[1:] + values[:-1])
        if method == "trapezoid"
        else dt * values[:-1]
    )
    return np.concatenate([[0.0], np.cumsum(steps)])


def integrate_rates(
    t: npt.ArrayLike,
    wheel_rates: npt.ArrayLike,
    robot: RobotParams,
    initial_pose: npt.ArrayLike,
    *,
    method: Literal["trapezoid", "euler"] = "trapezoid",
) -> FloatArray:
    """Integrate sampled wheel rates into poses (dead reckoning).

    Parameters
    ----------
    t
        Sample times [s], shape (T,), increasing.
    wheel_rates
        Wheel rates [rad/s], shape (T, k).
    robot
        The robot (kind, r, L, betas).
    initial_pose
        ``(x, y, phi)`` at ``t[0]`` [m, m, rad].
    method
        ``"trapezoid"`` (rates linear between samples) or ``"euler"`` (held).

    Returns
    -------
    numpy.ndarray
        Poses ``(x, y, phi)``, shape (T, 3).

    Examples
    --------
    Both wheels of a differential robot at 10 and -10 rad/s drive it forward at 0.5 m/s:

    >>> robot = RobotParams("differential", wheel_radius=0.05, wheel_distance=0.2)
    >>> rates = np.tile([10.0, -10.0], (3, 1))
    >>> integrate_rates([0.0, 1.0, 2.0], rates, robot, [0.0, 0.0, 0.0]).round(12).tolist()
    [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]]
    """
    if method not in ("trapezoid", "euler"):
        raise ValueError(f"method must be 'trapezoid' or 'euler', got {method!r}")
    tt = np.asarray(t, dtype=np.float64)
    q = np.asarray(wheel_rates, dtype=np.float64)
    if tt.ndim != 1 or q.shape != (tt.size, robot.n_wheels):
        raise ValueError(
            f"need t of shape (T,) and wheel_rates of shape (T, {robot.n_wheels}), "
            f"got {tt.shape} and {q.shape}"
        )
    x0, y0, phi0 = (float(v) for v in np.asarray(initial_pose, dtype=np.float64))
    dt = np.diff(tt)
    _, _, phidot = robot.forward(q, 0.0)  # independent of the heading
    phi = phi0 + _cumulative(dt, np.asarray(phidot), method)
    xdot, ydot, _ = robot.forward(q, phi)
    x = x0 + _cumulative(dt, np.asarray(xdot), method)
    y = y0 + _cumulative(dt, np.asarray(ydot), method)
    return np.column_stack([x, y, phi])


def integrate_wheel_rates(
    traj: Trajectory, *, method: Literal["trapezoid", "euler"] = "trapezoid"
) -> FloatArray:
    """Integrate a trajectory's wheel rates from its first pose (odometry check).

    Parameters
    ----------
    traj
        A trajectory from :func:`kinematics.trajectory.plan_trajectory`.
    method
        ``"trapezoid"`` (consistent with how samples are generated) or ``"euler"``.

    Returns
    -------
    numpy.ndarray
        Poses, shape (T, 3), to compare with ``traj.pose``.

    Examples
    --------
    >>> from kinematics.trajectory import plan_trajectory
    >>> traj = plan_trajectory([[0, 0], [2, 0], [2, 1]], RobotParams())
    >>> float(np.abs(integrate_wheel_rates(traj) - traj.pose).max()) < 1e-9
    True
    """
    return integrate_rates(
        traj.t, traj.wheel_rates, traj.robot, traj.pose[0], method=method
    )
