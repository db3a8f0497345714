r"""Velocity kinematics of the differential-drive robot with a caster (section 9.2.2).

Wheel numbering and angles (Fig. 9.7): wheel 1 (index 0) at :math:`\beta_1 = 0` on the
robot's right (+x_m), wheel 2 (index 1) at :math:`\beta_2 = 180^\circ` on its left, both at
distance ``L`` from the centre; a free caster carries the back. The heading ``phi`` is the
world angle of the forward axis ``y_m``.

Rate sign (eq. 9.1, same as the holonomic robot): a positive rate rolls the robot, at that
wheel, in the direction :math:`(-\sin\beta_i, \cos\beta_i)`: forward for wheel 1, backward
for wheel 2. So driving forward gives :math:`\dot\theta_1 = -\dot\theta_2 > 0` and a pure
counter-clockwise rotation gives :math:`\dot\theta_1 = \dot\theta_2 = L\dot\phi / r`
(section 9.7.2: "a pure rotation, i.e. :math:`\dot\theta_1 = \dot\theta_2`").

Sway is not executable: the x_m column of :math:`\mathbf J_m^{-1}` is zero (eq. 9.7), so a
requested sideways velocity cannot be produced by any wheel rates. :func:`inverse` raises
a ValueError naming it instead of silently dropping it; :func:`sway_residual` returns it.

**Known inconsistency in the chapter.** Eq. 9.10 writes :math:`\dot\phi = r(\dot\theta_1 +
\dot\theta_2)/L`, but eq. 9.7 with L the centre-to-wheel distance gives
:math:`\dot\theta_1 + \dot\theta_2 = 2L\dot\phi / r`, i.e. :math:`\dot\phi = r(\dot\theta_1
+ \dot\theta_2)/(2L)`. (The chapter's form would hold if L were the distance *between* the
wheels.) This module implements the second form, the only one for which :func:`forward`
and :func:`inverse` are exact inverses. The chapter also numbers two equations 9.9; here
"eq. 9.9" is the world-frame inverse kinematics and "eq. 9.9b" the geometric relation
:math:`\dot x = \dot y_m\cos\phi`, :math:`\dot y = \dot y_m\sin\phi`.

References
----------
Chapter 9, "Mobile Robots", eq. 9.7-9.11 and Fig. 9.7. J. Mireles, "Kinematic Models of
Mobile Robots".
"""

from __future__ import annotations

__all__ = [
    "BETAS",
    "DEFAULT_SWAY_TOL",
    "forward",
    "forward_robot_frame",
    "inverse",
    "inverse_robot_frame",
    "sway_residual",
]

import math

import numpy as np
import numpy.typing as npt

from kinematics._arrays import (
    FloatArray,
    broadcast_floats,
    check_positive,
    rates_array,
    unwrap_scalar,
)
from kinematics.frames import world_to_robot

BETAS: tuple[float, float] = (0.0, math.pi)
"""Wheel angles of the differential drive [rad]: wheel 1 on the right, wheel 2 on the left."""

DEFAULT_SWAY_TOL = 1e-6
"""Largest sideways velocity [m/s] accepted as zero (float rounding of world velocities)."""


def _check_sway(sway: FloatArray, tol: float) -> None:
    bad = np.abs(sway) > tol
    if np.any(bad):
        idx = (
            np.unravel_index(int(np.argmax(np.abs(sway))), sway.shape)
            if sway.ndim
            else ()
        )
        worst = float(sway[idx])
        where = f" (worst at index {tuple(int(i) for i in idx)})" if sway.ndim else ""
        raise ValueError(
            f"requested sway (sideways, x_m) velocity {worst:.6g} m/s exceeds tol={tol:g} m/s"
            f"{where}: a differential-drive robot cannot move sideways (eq. 9.7: the x_m column "
            "of J_m^-1 is zero). Use sway_residual() to inspect it, or check=False to drop it."
        )


def inverse_robot_frame(
    xdot_m: npt.ArrayLike,
    ydot_m: npt.ArrayLike,
    phidot: npt.ArrayLike,
    *,
    r: float,
    L: float,
    check: bool = True,
    tol: float = DEFAULT_SWAY_TOL,
) -> FloatArray:
    r"""Compute the two wheel rates from a robot-frame velocity (eq. 9.7).

    .. math::

        \begin{bmatrix} \dot\theta_1 \\ \dot\theta_2 \end{bmatrix}
        = \frac{1}{r} \begin{bmatrix} 0 & 1 & L \\ 0 & -1 & L \end{bmatrix}
        \begin{bmatrix} \dot x_m \\ \dot y_m \\ \dot\phi \end{bmatrix}

    Parameters
    ----------
    xdot_m
        Requested sway velocity [m/s]; must be 0 (within ``tol``) when ``check``.
    ydot_m
        Surge velocity, forward [m/s].
    phidot
        Yaw rate [rad/s]. Scalars or arrays that broadcast to a shape S.
    r
        Wheel radius [m].
    L
        Distance from the robot's centre to each wheel [m].
    check
        Raise if ``|xdot_m| > tol``. With ``check=False`` the sway is knowingly ignored.
    tol
        Sway tolerance [m/s].

    Returns
    -------
    numpy.ndarray
        ``(theta1_dot, theta2_dot)`` [rad/s], shape S + (2,).

    Raises
    ------
    ValueError
        If ``check`` and the requested sway exceeds ``tol``.

    Examples
    --------
    >>> inverse_robot_frame(0.0, 0.5, 0.0, r=0.05, L=0.2)  # straight ahead
    array([ 10., -10.])
    >>> inverse_robot_frame(0.0, 0.0, 1.0, r=0.05, L=0.2)  # turn in place
    array([4., 4.])
    """
    r = check_positive("r (wheel radius)", r)
    L = check_positive("L (centre-to-wheel distance)", L)
    (x, y, w), _ = broadcast_floats(xdot_m, ydot_m, phidot)
    if check:
        _check_sway(x, tol)
    return np.stack([y + L * w, -y + L * w], axis=-1) / r


def sway_residual(
    xdot: npt.ArrayLike, ydot: npt.ArrayLike, phi: npt.ArrayLike
) -> FloatArray:
    r"""Return the part of a world velocity the differential drive cannot execute.

    The sway (sideways, to the robot's right) component of eq. 9.4,
    :math:`\dot x_m = \dot x \sin\phi - \dot y \cos\phi`.

    Parameters
    ----------
    xdot, ydot
        World velocity [m/s]; scalars or arrays of shape S.
    phi
        Heading [rad].

    Returns
    -------
    numpy.ndarray
        Sway velocity [m/s], shape S (a scalar for scalars); 0 means executable.

    Examples
    --------
    >>> float(sway_residual(1.0, 0.0, np.pi / 2))  # facing +y, asked to move +x: to the right
    1.0
    >>> abs(float(sway_residual(np.cos(0.4), np.sin(0.4), 0.4))) < 1e-15
    True
    """
    xm, _ = world_to_robot(xdot, ydot, phi)
    return xm


def inverse(
    xdot: npt.ArrayLike,
    ydot: npt.ArrayLike,
    phidot: npt.ArrayLike,
    phi: npt.ArrayLike,
    *,
    r: float,
    L: float,
    check: bool = True,
    tol: float = DEFAULT_SWAY_TOL,
) -> FloatArray:
    r"""Compute the two wheel rates from a world-frame velocity (eq. 9.9).

    .. math::

        \begin{bmatrix} \dot\theta_1 \\ \dot\theta_2 \end{bmatrix}
        = \frac{1}{r} \begin{bmatrix} \cos\phi & \sin\phi & L \\
        -\cos\phi & -\sin\phi & L \end{bmatrix}
        \begin{bmatrix} \dot x \\ \dot y \\ \dot\phi \end{bmatrix}

    The matrix silently maps any sideways part of ``(xdot, ydot)`` to zero, so the sway
    (:func:`sway_residual`) is checked first.

    Parameters
    ----------
    xdot, ydot
        World velocity [m/s]; scalars or arrays of shape S.
    phidot
        Yaw rate [rad/s].
    phi
        Heading [rad]: world angle of the robot's forward axis ``y_m``.
    r
        Wheel radius [m].
    L
        Distance from the robot's centre to each wheel [m].
    check
        Raise if the sway exceeds ``tol``; ``check=False`` knowingly drops it.
    tol
        Sway tolerance [m/s].

    Returns
    -------
    numpy.ndarray
        Wheel rates [rad/s], shape S + (2,).

    Raises
    ------
    ValueError
        If ``check`` and the requested velocity has a sideways component above ``tol``.

    Examples
    --------
    >>> inverse(0.0, 0.5, 0.0, np.pi / 2, r=0.05, L=0.2).round(12)
    array([ 10., -10.])
    >>> inverse(0.5, 0.0, 0.0, np.pi / 2, r=0.05, L=0.2)
    Traceback (most recent call last):
    ...
    ValueError: requested sway (sideways, x_m) velocity 0.5 m/s exceeds tol=1e-06 m/s: a differential-drive robot cannot move sideways (eq. 9.7: the x_m column of J_m^-1 is zero). Use sway_residual() to inspect it, or check=False to drop it.
    """
    r = check_positive("r (wheel radius)", r)
    L = check_positive("L (centre-to-wheel distance)", L)
    (x, y, w, p), _ = broadcast_floats(xdot, ydot, phidot, phi)
    if check:
        _check_sway(np.asarray(sway_residual(x, y, p)), tol)
    c, s = np.cos(p), np.sin(p)
    surge = c * x + s * y
    return np.stack([surge + L * w, -surge + L * w], axis=-1) / r


def forward_robot_frame(
    rates: npt.ArrayLike, *, r: float, L: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    r"""Compute the robot-frame velocity from the two wheel rates (eq. 9.10, corrected).

    .. math::

        \dot x_m = 0, \qquad
        \begin{bmatrix} \dot y_m \\ \dot\phi \end{bmatrix}
        = r \begin{bmatrix} 1/2 & -1/2 \\ 1/(2L) & 1/(2L) \end{bmatrix}
        \begin{bmatrix} \dot\theta_1 \\ \dot\theta_2 \end{bmatrix}

    The chapter prints ``1/L`` in the second row; ``1/(2L)`` is what eq. 9.7 implies (see
    the module docstring).

    Parameters
    ----------
    rates
        ``(theta1_dot, theta2_dot)`` [rad/s], shape (2,) or S + (2,).
    r
        Wheel radius [m].
    L
        Distance from the robot's centre to each wheel [m].

    Returns
    -------
    tuple
        ``(xdot_m, ydot_m, phidot)``; ``xdot_m`` is always 0.

    Examples
    --------
    >>> [float(v) for v in forward_robot_frame([4.0, 4.0], r=0.05, L=0.2)]
    [0.0, 0.0, 1.0]
    """
    r = check_positive("r (wheel radius)", r)
    L = check_positive("L (centre-to-wheel distance)", L)
    q = rates_array(rates, 2)
    ym = r * (q[..., 0] - q[..., 1]) / 2.0
    w = r * (q[..., 0] + q[..., 1]) / (2.0 * L)
    return unwrap_scalar(np.zeros_like(ym)), unwrap_scalar(ym), unwrap_scalar(w)


def forward(
    rates: npt.ArrayLike, phi: npt.ArrayLike, *, r: float, L: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    r"""Compute the world velocity from the two wheel rates (eq. 9.11, made consistent).

    .. math::

        \begin{bmatrix} \dot x \\ \dot y \\ \dot\phi \end{bmatrix}
        = r \begin{bmatrix} \cos\phi / 2 & -\cos\phi / 2 \\
        \sin\phi / 2 & -\sin\phi / 2 \\ 1/(2L) & 1/(2L) \end{bmatrix}
        \begin{bmatrix} \dot\theta_1 \\ \dot\theta_2 \end{bmatrix}

    The chapter's eq. 9.11 has ``1/L`` in the last row (from eq. 9.10); with L the
    centre-to-wheel distance of eq. 9.7 the consistent value is ``1/(2L)``, which makes
    ``forward(inverse(v)) == v`` for every executable (sway-free) velocity ``v``.

    Parameters
    ----------
    rates
        ``(theta1_dot, theta2_dot)`` [rad/s], shape (2,) or (N, 2) (any S + (2,)).
    phi
        Heading [rad]; scalar or broadcastable to S.
    r
        Wheel radius [m].
    L
        Distance from the robot's centre to each wheel [m].

    Returns
    -------
    tuple
        ``(xdot, ydot, phidot)`` [m/s, m/s, rad/s], scalars or arrays of shape S.

    Examples
    --------
    >>> q = inverse(0.3, 0.4, 0.7, math.atan2(0.4, 0.3), r=0.05, L=0.2)
    >>> [round(float(v), 12) for v in forward(q, math.atan2(0.4, 0.3), r=0.05, L=0.2)]
    [0.3, 0.4, 0.7]
    """
    _, ym, w = forward_robot_frame(rates, r=r, L=L)
    (ym_a, w_a, p), _ = broadcast_floats(ym, w, phi)
    return (
        unwrap_scalar(ym_a * np.cos(p)),
        unwrap_scalar(ym_a * np.sin(p)),
        unwrap_scalar(w_a),
    )
