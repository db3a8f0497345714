r"""Wheel speed and acceleration limits (section 9.7.3).

"Wheel slip is typically the most significant [problem], but can be limited by limiting
the commanded wheel accelerations." A :class:`WheelLimits` bounds every driven wheel's
angular rate :math:`|\dot\theta_i| \le \dot\theta_{max}` and angular acceleration
:math:`|\ddot\theta_i| \le \ddot\theta_{max}`. Two consumers:

- :func:`centre_limits` turns them into limits on the robot's centre
  (:class:`kinematics.trajectory.Limits`) under which every trajectory of
  :func:`kinematics.trajectory.plan_trajectory` keeps each wheel within them. It uses the
  bound that both wheel matrices share (eq. 9.5 and 9.9): each wheel's rate is
  :math:`\dot\theta_i = (\mathbf{u}_i(\phi)\cdot\dot{\mathbf{p}} + s_i L\dot\phi)/r` with
  a unit vector :math:`\mathbf{u}_i` and :math:`|s_i| = 1`, so
  :math:`|\dot\theta_i| \le (|\dot{\mathbf{p}}| + L|\dot\phi|)/r` and, between two samples
  :math:`\Delta t` apart,
  :math:`|\Delta\dot\theta_i| \le (|\Delta\dot{\mathbf{p}}| + |\dot{\mathbf{p}}|\,|\Delta\phi|
  + L|\Delta\dot\phi|)/r`.
- :func:`within` checks commanded rates sample by sample (the tests and the live
  controller, :mod:`planners.live`, use it).
"""

from __future__ import annotations

__all__ = ["WheelLimits", "centre_limits", "wheel_peaks", "within"]

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from kinematics._arrays import FloatArray
from kinematics.robot import RobotParams
from kinematics.trajectory import Limits


@dataclasses.dataclass(frozen=True)
class WheelLimits:
    """Limits on every driven wheel (section 9.7.3); ``math.inf`` for none.

    Examples
    --------
    >>> WheelLimits(max_acceleration=20.0).max_rate
    inf
    """

    max_rate: float = math.inf
    """Largest wheel angular rate [rad/s]."""
    max_acceleration: float = math.inf
    """Largest wheel angular acceleration [rad/s^2] (the slip limit of section 9.7.3)."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if not value > 0:  # also rejects NaN
                raise ValueError(f"{f.name} must be positive, got {value!r}")


def centre_limits(
    robot: RobotParams, wheels: WheelLimits, base: Limits | None = None
) -> Limits:
    r"""Return centre limits no tighter than needed for ``wheels`` (and within ``base``).

    Speed and turn rate each get half of the wheel rate budget
    (:math:`r\\dot\theta_{max}/2` and :math:`r\\dot\theta_{max}/(2L)`); the acceleration
    budget :math:`r\\ddot\theta_{max}` is split in thirds between the centre's acceleration,
    the turning of the wheel directions (:math:`v_{max}\\,\\omega_{max}`) and the angular
    acceleration. Trajectories sample velocities every dt with a first-order hold, so
    these bounds hold at the commands (see the module docstring).

    Examples
    --------
    >>> robot = RobotParams("differential", wheel_radius=0.05, wheel_distance=0.2)
    >>> lim = centre_limits(robot, WheelLimits(max_rate=10.0, max_acceleration=6.0))
    >>> lim.max_speed, round(lim.max_acceleration, 9), round(lim.max_angular_acceleration, 9)
    (0.25, 0.1, 0.5)
    """
    base = base if base is not None else Limits()
    r, L = robot.wheel_radius, robot.wheel_distance
    speed = min(base.max_speed, r * wheels.max_rate / 2.0)
    turn = min(base.max_turn_rate, r * wheels.max_rate / (2.0 * L))
    third = r * wheels.max_acceleration / 3.0
    turn = min(turn, third / speed)
    return Limits(
        max_speed=speed,
        max_acceleration=min(base.max_acceleration, third),
        max_turn_rate=turn,
        max_angular_acceleration=min(base.max_angular_acceleration, third / L),
    )


def wheel_peaks(rates: npt.ArrayLike, dt: float) -> tuple[float, float]:
    """Return the largest ``|rate|`` and ``|rate change| / dt`` of sampled wheel rates.

    Parameters
    ----------
    rates
        Commanded wheel rates, shape (T, k) [rad/s], one row every ``dt`` seconds.
    dt
        Sample period [s].

    Examples
    --------
    >>> wheel_peaks([[0.0, 0.0], [1.0, -0.5], [1.5, 0.0]], 0.05)
    (1.5, 20.0)
    """
    a: FloatArray = np.atleast_2d(np.asarray(rates, dtype=np.float64))
    if a.size == 0:
        return 0.0, 0.0
    rate = float(np.abs(a).max())
    acc = float(np.abs(np.diff(a, axis=0)).max() / dt) if len(a) > 1 else 0.0
    return rate, acc


def within(
    rates: npt.ArrayLike, dt: float, wheels: WheelLimits, rtol: float = 1e-9
) -> bool:
    """Tell whether sampled wheel rates respect ``wheels`` (within ``rtol``).

    Examples
    --------
    >>> within([[0.0], [1.0]], 0.05, WheelLimits(max_acceleration=20.0))
    True
    >>> within([[0.0], [1.1]], 0.05, WheelLimits(max_acceleration=20.0))
    False
    """
    rate, acc = wheel_peaks(rates, dt)
    return rate <= wheels.max_rate * (1 + rtol) and acc <= wheels.max_acceleration * (
        1 + rtol
    )
