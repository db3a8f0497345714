r"""Robot frame and world frame (eq. 9.4 of the chapter).

The robot frame has ``x_m`` to the robot's right (sway) and ``y_m`` forward (surge), z up.
The heading ``phi`` is the world angle of the forward axis ``y_m``, so at ``phi = pi / 2``
the robot frame and the world frame coincide. Eq. 9.4 maps world velocities into the robot
frame:

.. math::

    \begin{bmatrix} \dot x_m \\ \dot y_m \\ \dot\phi \end{bmatrix}
    = \mathbf R \begin{bmatrix} \dot x \\ \dot y \\ \dot\phi \end{bmatrix},
    \qquad
    \mathbf R = \mathrm{Rot}(Z, 90^\circ - \phi) =
    \begin{bmatrix} \sin\phi & -\cos\phi & 0 \\ \cos\phi & \sin\phi & 0 \\
    0 & 0 & 1 \end{bmatrix}.
"""

from __future__ import annotations

__all__ = ["robot_to_world", "rotation_world_to_robot", "world_to_robot"]

import numpy as np
import numpy.typing as npt

from kinematics._arrays import FloatArray, broadcast_floats, unwrap_scalar


def rotation_world_to_robot(phi: npt.ArrayLike) -> FloatArray:
    """Return the matrix R of eq. 9.4 that maps world velocities into the robot frame.

    Parameters
    ----------
    phi
        Heading [rad], the world angle of the robot's forward axis ``y_m``; any shape S.

    Returns
    -------
    numpy.ndarray
        Shape S + (3, 3).

    Examples
    --------
    >>> rotation_world_to_robot(np.pi / 2).round(12)  # robot frame == world frame
    array([[ 1., -0.,  0.],
           [ 0.,  1.,  0.],
           [ 0.,  0.,  1.]])
    """
    phi_a = np.asarray(phi, dtype=np.float64)
    s, c = np.sin(phi_a), np.cos(phi_a)
    zero, one = np.zeros_like(phi_a), np.ones_like(phi_a)
    rows = [
        np.stack([s, -c, zero], -1),
        np.stack([c, s, zero], -1),
        np.stack([zero, zero, one], -1),
    ]
    return np.stack(rows, -2)


def world_to_robot(
    xdot: npt.ArrayLike, ydot: npt.ArrayLike, phi: npt.ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Express a world velocity ``(xdot, ydot)`` in the robot frame (eq. 9.4).

    Parameters
    ----------
    xdot, ydot
        World velocity [m/s]; scalars or arrays that broadcast together with ``phi``.
    phi
        Heading [rad].

    Returns
    -------
    tuple of numpy.ndarray
        ``(xdot_m, ydot_m)``: sway (to the right) and surge (forward) [m/s].

    Examples
    --------
    >>> xm, ym = world_to_robot(1.0, 0.0, 0.0)  # facing +x, moving +x: pure surge
    >>> float(xm), float(ym)
    (0.0, 1.0)
    """
    (x, y, p), _ = broadcast_floats(xdot, ydot, phi)
    s, c = np.sin(p), np.cos(p)
    return unwrap_scalar(s * x - c * y), unwrap_scalar(c * x + s * y)


def robot_to_world(
    xdot_m: npt.ArrayLike, ydot_m: npt.ArrayLike, phi: npt.ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Express a robot-frame velocity ``(xdot_m, ydot_m)`` in the world (inverse of eq. 9.4).

    Parameters
    ----------
    xdot_m, ydot_m
        Sway (right) and surge (forward) velocity [m/s].
    phi
        Heading [rad].

    Returns
    -------
    tuple of numpy.ndarray
        ``(xdot, ydot)`` [m/s].

    Examples
    --------
    >>> x, y = robot_to_world(0.0, 2.0, np.pi)  # facing -x, driving forward
    >>> round(float(x), 12), round(float(y), 12)
    (-2.0, 0.0)
    """
    (xm, ym, p), _ = broadcast_floats(xdot_m, ydot_m, phi)
    s, c = np.sin(p), np.cos(p)
    return unwrap_scalar(s * xm + c * ym), unwrap_scalar(-c * xm + s * ym)
