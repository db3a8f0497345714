"""A robot description as plain data, with its kinematics dispatched by kind."""

from __future__ import annotations

__all__ = ["ROBOT_KINDS", "RobotParams"]

import dataclasses
import math
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from kinematics import differential, holonomic
from kinematics._arrays import FloatArray, check_positive

ROBOT_KINDS: tuple[str, ...] = ("holonomic", "differential")
"""The two drive designs of section 9.2."""


@dataclasses.dataclass(frozen=True)
class RobotParams:
    """Kinematic and drawing parameters of one robot (Fig. 9.4 and 9.7).

    The defaults match the scenario files' defaults (``planners.scene.Robot``).

    Examples
    --------
    >>> robot = RobotParams("differential", wheel_radius=0.05, wheel_distance=0.2)
    >>> robot.n_wheels
    2
    >>> robot.inverse(0.0, 0.0, 1.0, 0.0)  # turn in place: both rates L * phidot / r
    array([4., 4.])
    """

    kind: Literal["holonomic", "differential"] = "holonomic"
    """``"holonomic"`` (omni-wheels, eq. 9.3-9.6) or ``"differential"`` (eq. 9.7-9.11)."""
    wheel_radius: float = 0.05
    """Wheel radius r [m]."""
    wheel_distance: float = 0.25
    """Distance L from the robot's centre to each wheel [m]."""
    betas: tuple[float, ...] | None = None
    """Wheel angles [rad] (holonomic only); None means 30, 150, 270 degrees."""
    radius: float = 0.3
    """Radius of the robot's disk [m], for drawing; 0 (a point robot) is allowed."""

    def __post_init__(self) -> None:
        if self.kind not in ROBOT_KINDS:
            raise ValueError(
                f"robot kind must be one of {ROBOT_KINDS}, got {self.kind!r}"
            )
        check_positive("wheel_radius", self.wheel_radius)
        check_positive("wheel_distance", self.wheel_distance)
        if not (math.isfinite(self.radius) and self.radius >= 0.0):
            raise ValueError(
                f"radius must be a finite number >= 0, got {self.radius!r}"
            )
        if self.betas is not None:
            if self.kind == "differential":
                raise ValueError(
                    "a differential robot has fixed wheel angles (0, 180 deg); leave betas=None"
                )
            # Normalise to a tuple of floats so equal robots compare (and hash) equal.
            object.__setattr__(self, "betas", tuple(float(b) for b in self.betas))
            # Fails early, with the library's message, for too few or coincident wheels.
            holonomic.forward_robot_frame(
                np.zeros(len(self.betas)), r=1.0, L=1.0, betas=self.betas
            )

    @property
    def wheel_angles(self) -> tuple[float, ...]:
        """Wheel angles beta_i in the robot frame [rad], resolved for the kind."""
        if self.kind == "differential":
            return differential.BETAS
        return holonomic.DEFAULT_BETAS if self.betas is None else self.betas

    @property
    def n_wheels(self) -> int:
        """Number of driven wheels k (the caster is not driven)."""
        return len(self.wheel_angles)

    def inverse(
        self,
        xdot: npt.ArrayLike,
        ydot: npt.ArrayLike,
        phidot: npt.ArrayLike,
        phi: npt.ArrayLike,
        *,
        check: bool = True,
    ) -> FloatArray:
        """Return wheel rates [rad/s] for a world velocity (eq. 9.5 or 9.9), shape S + (k,).

        Parameters
        ----------
        xdot, ydot
            World velocity [m/s].
        phidot
            Yaw rate [rad/s].
        phi
            Heading [rad].
        check
            Differential only: raise on a sideways velocity (see
            :func:`kinematics.differential.inverse`).

        Returns
        -------
        numpy.ndarray
            Wheel rates, shape S + (k,).
        """
        r, L = self.wheel_radius, self.wheel_distance
        if self.kind == "differential":
            return differential.inverse(xdot, ydot, phidot, phi, r=r, L=L, check=check)
        return holonomic.inverse(
            xdot, ydot, phidot, phi, r=r, L=L, betas=self.wheel_angles
        )

    def forward(
        self, rates: npt.ArrayLike, phi: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Return the world velocity ``(xdot, ydot, phidot)`` for wheel rates (eq. 9.6 or 9.11).

        Parameters
        ----------
        rates
            Wheel rates [rad/s], shape S + (k,).
        phi
            Heading [rad].

        Returns
        -------
        tuple
            ``(xdot, ydot, phidot)``, each of shape S.
        """
        r, L = self.wheel_radius, self.wheel_distance
        if self.kind == "differential":
            return differential.forward(rates, phi, r=r, L=L)
        return holonomic.forward(rates, phi, r=r, L=L, betas=self.wheel_angles)

    @classmethod
    def from_robot(cls, robot: Any) -> RobotParams:
        """Build from any object with ``kind``, ``radius``, ``wheel_radius``, ``wheel_distance``.

        Duck-typed so that ``kinematics`` need not import ``planners`` (e.g. pass
        ``scene.robot``). A mapping such as a scenario file's ``"robot"`` entry works too.

        Parameters
        ----------
        robot
            The source object or mapping.

        Returns
        -------
        RobotParams
            The kinematic description.

        Examples
        --------
        >>> RobotParams.from_robot({"kind": "differential", "radius": 0.3,
        ...                         "wheel_radius": 0.05, "wheel_distance": 0.25}).kind
        'differential'
        """

        def get(name: str) -> Any:
            return robot[name] if isinstance(robot, dict) else getattr(robot, name)

        return cls(
            kind=get("kind"),
            wheel_radius=float(get("wheel_radius")),
            wheel_distance=float(get("wheel_distance")),
            radius=float(get("radius")),
        )
