r"""Velocity kinematics of the holonomic robot with omni-wheels (section 9.2.1).

Wheel numbering and angles (Fig. 9.4): wheel ``i`` (0-based in code, ``i + 1`` in the
chapter) sits at distance ``L`` from the robot's centre, at angle ``beta_i`` measured in the
robot frame from the sway axis ``x_m`` (to the right) towards the forward axis ``y_m``. The
default is the symmetric configuration ``beta = (30, 150, 270)`` degrees: two wheels at the
front left/right, one at the back. The heading ``phi`` is the world angle of ``y_m``.

Rate sign (eq. 9.1): a positive rate ``theta_dot_i`` rolls the robot, at wheel ``i``, in the
direction :math:`(-\sin\beta_i, \cos\beta_i)` of the robot frame, i.e. counter-clockwise
around the robot's centre. So a pure rotation :math:`\dot\phi > 0` spins every wheel at
:math:`L\dot\phi / r > 0`.

.. math::

    \dot\theta_i = \frac{1}{r}\left(-\dot x_m \sin\beta_i + \dot y_m \cos\beta_i
    + L\dot\phi\right) \qquad (9.1)

References
----------
Chapter 9, "Mobile Robots", eq. 9.1-9.6 and Fig. 9.4-9.6. R. Rojas and A. Forster,
"Holonomic Control of a Robot with an Omni-directional Drive".
"""

from __future__ import annotations

__all__ = [
    "DEFAULT_BETAS",
    "forward",
    "forward_robot_frame",
    "inverse",
    "inverse_jacobian",
    "inverse_robot_frame",
    "roller_speeds",
]

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from kinematics._arrays import (
    FloatArray,
    broadcast_floats,
    check_positive,
    rates_array,
    unwrap_scalar,
)
from kinematics.frames import robot_to_world

DEFAULT_BETAS: tuple[float, float, float] = (
    math.radians(30.0),
    math.radians(150.0),
    math.radians(270.0),
)
"""Wheel angles of the symmetric three-wheel configuration [rad] (30, 150, 270 degrees)."""

# Smallest singular value of J_m^{-1} (relative to the largest) still treated as invertible.
# Two wheels at the same angle give exactly 0; anything this close is numerically useless.
_SINGULAR_RTOL = 1e-9


def _betas_array(betas: Sequence[float] | npt.ArrayLike) -> FloatArray:
    b = np.asarray(betas, dtype=np.float64)
    if b.ndim != 1 or b.size == 0 or not np.all(np.isfinite(b)):
        raise ValueError(
            f"betas must be a non-empty 1-d sequence of finite angles [rad], got {betas!r}"
        )
    return b


def inverse_jacobian(
    *, r: float, L: float, betas: Sequence[float] | npt.ArrayLike = DEFAULT_BETAS
) -> FloatArray:
    r"""Return :math:`\mathbf J_m^{-1}` of eq. 9.3 (robot frame), shape (k, 3).

    .. math::

        \mathbf J_m^{-1} = \frac{1}{r}
        \begin{bmatrix} -\sin\beta_1 & \cos\beta_1 & L \\ \vdots & \vdots & \vdots \\
        -\sin\beta_k & \cos\beta_k & L \end{bmatrix}

    Parameters
    ----------
    r
        Wheel radius [m].
    L
        Distance from the robot's centre to each wheel [m].
    betas
        Wheel angles in the robot frame [rad], k of them.

    Returns
    -------
    numpy.ndarray
        Shape (k, 3); row i maps ``(xdot_m, ydot_m, phidot)`` to wheel rate i [rad/s].

    Examples
    --------
    >>> inverse_jacobian(r=1.0, L=0.5, betas=[0.0, math.pi]).round(12)
    array([[-0. ,  1. ,  0.5],
           [-0. , -1. ,  0.5]])
    """
    r = check_positive("r (wheel radius)", r)
    L = check_positive("L (centre-to-wheel distance)", L)
    b = _betas_array(betas)
    return np.column_stack([-np.sin(b), np.cos(b), np.full_like(b, L)]) / r


def inverse_robot_frame(
    xdot_m: npt.ArrayLike,
    ydot_m: npt.ArrayLike,
    phidot: npt.ArrayLike,
    *,
    r: float,
    L: float,
    betas: Sequence[float] | npt.ArrayLike = DEFAULT_BETAS,
) -> FloatArray:
    r"""Compute wheel rates from a robot-frame velocity (eq. 9.3).

    .. math::

        \begin{bmatrix} \dot\theta_1 \\ \vdots \\ \dot\theta_k \end{bmatrix}
        = \frac{1}{r}
        \begin{bmatrix} -\sin\beta_1 & \cos\beta_1 & L \\ \vdots & \vdots & \vdots \\
        -\sin\beta_k & \cos\beta_k & L \end{bmatrix}
        \begin{bmatrix} \dot x_m \\ \dot y_m \\ \dot\phi \end{bmatrix}

    Parameters
    ----------
    xdot_m
        Sway velocity, to the robot's right [m/s]; scalar or array of shape S.
    ydot_m
        Surge velocity, forward [m/s]; broadcasts with the others.
    phidot
        Yaw rate, counter-clockwise [rad/s].
    r
        Wheel radius [m].
    L
        Distance from the robot's centre to each wheel [m].
    betas
        Wheel angles in the robot frame [rad]; default 30, 150, 270 degrees.

    Returns
    -------
    numpy.ndarray
        Wheel rates [rad/s], shape S + (k,): (k,) for scalars, (N, k) for inputs of shape (N,).

    Examples
    --------
    Driving forward at 1 m/s with r = 0.05 m: the back wheel (270 degrees) only rolls on
    its rollers, the front wheels turn in opposite directions.

    >>> inverse_robot_frame(0.0, 1.0, 0.0, r=0.05, L=0.25).round(4)
    array([ 17.3205, -17.3205,  -0.    ])
    """
    jinv = inverse_jacobian(r=r, L=L, betas=betas)
    (x, y, w), _ = broadcast_floats(xdot_m, ydot_m, phidot)
    return np.stack([x, y, w], axis=-1) @ jinv.T


def inverse(
    xdot: npt.ArrayLike,
    ydot: npt.ArrayLike,
    phidot: npt.ArrayLike,
    phi: npt.ArrayLike,
    *,
    r: float,
    L: float,
    betas: Sequence[float] | npt.ArrayLike = DEFAULT_BETAS,
) -> FloatArray:
    r"""Compute wheel rates from a world-frame velocity (eq. 9.5).

    This is :math:`\mathbf J_m^{-1}\mathbf R` with R of eq. 9.4, which multiplies out to
    the chapter's printed matrix (checked in the tests):

    .. math::

        \begin{bmatrix} \dot\theta_1 \\ \vdots \\ \dot\theta_k \end{bmatrix}
        = \frac{1}{r}
        \begin{bmatrix} \cos(\phi+\beta_1) & \sin(\phi+\beta_1) & L \\
        \vdots & \vdots & \vdots \\
        \cos(\phi+\beta_k) & \sin(\phi+\beta_k) & L \end{bmatrix}
        \begin{bmatrix} \dot x \\ \dot y \\ \dot\phi \end{bmatrix}

    Parameters
    ----------
    xdot, ydot
        World velocity of the robot's centre [m/s]; scalars or arrays of shape S.
    phidot
        Yaw rate [rad/s].
    phi
        Heading [rad]: world angle of the robot's forward axis ``y_m``.
    r
        Wheel radius [m].
    L
        Distance from the robot's centre to each wheel [m].
    betas
        Wheel angles in the robot frame [rad]; default 30, 150, 270 degrees.

    Returns
    -------
    numpy.ndarray
        Wheel rates [rad/s], shape S + (k,).

    Examples
    --------
    A pure rotation turns every wheel at ``L * phidot / r``:

    >>> inverse(0.0, 0.0, 1.0, 0.3, r=0.05, L=0.25)
    array([5., 5., 5.])

    Arrays of N samples give (N, k):

    >>> inverse(np.zeros(4), np.ones(4), 0.0, np.pi / 2, r=0.05, L=0.25).shape
    (4, 3)
    """
    r = check_positive("r (wheel radius)", r)
    L = check_positive("L (centre-to-wheel distance)", L)
    b = _betas_array(betas)
    (x, y, w, p), _ = broadcast_floats(xdot, ydot, phidot, phi)
    angle = p[..., None] + b  # S + (k,)
    return (
        np.cos(angle) * x[..., None] + np.sin(angle) * y[..., None] + L * w[..., None]
    ) / r


def _pseudo_inverse(jinv: FloatArray, betas: FloatArray) -> FloatArray:
    """Left inverse of J_m^{-1} (the Jacobian J_m); ValueError if the wheels are singular."""
    if jinv.shape[0] < 3:
        raise ValueError(
            f"a holonomic robot needs at least 3 wheels to control x_m, y_m and phi, got {jinv.shape[0]}"
        )
    sv = np.linalg.svd(jinv, compute_uv=False)
    if sv[-1] <= _SINGULAR_RTOL * sv[0]:
        raise ValueError(
            "wheel angles betas = "
            f"{np.round(np.degrees(betas), 6).tolist()} deg give a singular J_m^-1 "
            "(two wheels at the same angle?): the forward kinematics (eq. 9.6) does not exist"
        )
    # For k = 3 this is the plain matrix inverse of eq. 9.6; for k > 3 the least-squares one.
    return np.asarray(np.linalg.pinv(jinv), dtype=np.float64)


def forward_robot_frame(
    rates: npt.ArrayLike,
    *,
    r: float,
    L: float,
    betas: Sequence[float] | npt.ArrayLike = DEFAULT_BETAS,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    r"""Compute the robot-frame velocity from wheel rates (inverse of eq. 9.3).

    .. math::

        \begin{bmatrix} \dot x_m \\ \dot y_m \\ \dot\phi \end{bmatrix}
        = \mathbf J_m \dot{\mathbf q}, \qquad \mathbf J_m = (\mathbf J_m^{-1})^{-1}

    Parameters
    ----------
    rates
        Wheel rates [rad/s], shape (k,) or S + (k,).
    r
        Wheel radius [m].
    L
        Distance from the robot's centre to each wheel [m].
    betas
        Wheel angles in the robot frame [rad].

    Returns
    -------
    tuple
        ``(xdot_m, ydot_m, phidot)``, each a scalar or an array of shape S.

    Raises
    ------
    ValueError
        If fewer than 3 wheels, or two wheels share an angle (singular J_m^-1).

    Examples
    --------
    >>> xm, ym, w = forward_robot_frame([5.0, 5.0, 5.0], r=0.05, L=0.25)
    >>> abs(round(float(xm), 12)), abs(round(float(ym), 12)), round(float(w), 12)
    (0.0, 0.0, 1.0)
    """
    b = _betas_array(betas)
    jinv = inverse_jacobian(r=r, L=L, betas=b)
    q = rates_array(rates, b.size)
    v = q @ _pseudo_inverse(jinv, b).T
    return unwrap_scalar(v[..., 0]), unwrap_scalar(v[..., 1]), unwrap_scalar(v[..., 2])


def forward(
    rates: npt.ArrayLike,
    phi: npt.ArrayLike,
    *,
    r: float,
    L: float,
    betas: Sequence[float] | npt.ArrayLike = DEFAULT_BETAS,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    r"""Compute the world velocity from wheel rates (eq. 9.6).

    .. math::

        \begin{bmatrix} \dot x \\ \dot y \\ \dot\phi \end{bmatrix}
        = r \begin{bmatrix} \cos(\phi+\beta_1) & \sin(\phi+\beta_1) & L \\
        \cos(\phi+\beta_2) & \sin(\phi+\beta_2) & L \\
        \cos(\phi+\beta_3) & \sin(\phi+\beta_3) & L \end{bmatrix}^{-1}
        \begin{bmatrix} \dot\theta_1 \\ \dot\theta_2 \\ \dot\theta_3 \end{bmatrix}

    Computed as :math:`\mathbf R^T \mathbf J_m \dot{\mathbf q}`: the same matrix, with the
    constant part inverted once. It is the exact inverse of :func:`inverse`.

    Parameters
    ----------
    rates
        Wheel rates [rad/s], shape (k,) or (N, k) (any S + (k,)).
    phi
        Heading [rad]; scalar or broadcastable to S.
    r
        Wheel radius [m].
    L
        Distance from the robot's centre to each wheel [m].
    betas
        Wheel angles in the robot frame [rad]; default 30, 150, 270 degrees.

    Returns
    -------
    tuple
        ``(xdot, ydot, phidot)`` [m/s, m/s, rad/s], scalars or arrays of shape S.

    Raises
    ------
    ValueError
        If the wheel angles are singular (e.g. two wheels at the same angle).

    Examples
    --------
    >>> q = inverse(0.3, -0.2, 0.5, 1.0, r=0.05, L=0.25)
    >>> [round(float(v), 12) for v in forward(q, 1.0, r=0.05, L=0.25)]
    [0.3, -0.2, 0.5]
    """
    xm, ym, w = forward_robot_frame(rates, r=r, L=L, betas=betas)
    (xm_a, ym_a, w_a, p), _ = broadcast_floats(xm, ym, w, phi)
    x, y = robot_to_world(xm_a, ym_a, p)
    return (
        unwrap_scalar(np.asarray(x)),
        unwrap_scalar(np.asarray(y)),
        unwrap_scalar(w_a),
    )


def roller_speeds(
    xdot_m: npt.ArrayLike,
    ydot_m: npt.ArrayLike,
    *,
    betas: Sequence[float] | npt.ArrayLike = DEFAULT_BETAS,
) -> FloatArray:
    r"""Return the free rollers' sliding speed at each wheel (section 9.2.1, Fig. 9.6).

    The component of the wheel's velocity along its axle, which the rollers absorb:

    .. math::

        v_{\mathrm{roller}, i} = \dot x_m \cos\beta_i + \dot y_m \sin\beta_i

    A rotation about the robot's centre adds nothing here (it moves each wheel along its
    rolling direction), so ``phidot`` is not an argument. Positive values point outward,
    along :math:`(\cos\beta_i, \sin\beta_i)`.

    Parameters
    ----------
    xdot_m, ydot_m
        Robot-frame velocity [m/s]; scalars or arrays of shape S.
    betas
        Wheel angles in the robot frame [rad].

    Returns
    -------
    numpy.ndarray
        Speeds [m/s], shape S + (k,). Divide by the roller radius for the roller rate.

    Examples
    --------
    Driving forward, the back wheel (270 degrees) slides entirely on its rollers:

    >>> roller_speeds(0.0, 1.0).round(4)
    array([ 0.5,  0.5, -1. ])
    """
    b = _betas_array(betas)
    (x, y), _ = broadcast_floats(xdot_m, ydot_m)
    return x[..., None] * np.cos(b) + y[..., None] * np.sin(b)
