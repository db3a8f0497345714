r"""Timed motions along planned paths, sampled every dt (section 9.7).

A planned path (an (N, 2) polyline from a planner) becomes a :class:`Trajectory`: samples
every ``dt`` seconds (0.05 s by default, as in the chapter) of the pose ``(x, y, phi)``, the
world velocity ``(xdot, ydot, phidot)`` and the wheel rates from eq. 9.5 or 9.9, within
:class:`Limits` on speed, acceleration, turn rate and angular acceleration. The heading
``phi`` is unwrapped (continuous, not folded into (-pi, pi]).

Motion modes (:class:`TrajectoryOptions`):

Stop at each via point (``continuous=False``)
    Straight segments with a trapezoidal speed profile (triangular when the segment is too
    short to reach the top speed) that stops at every via point, so the path is followed
    exactly (section 7.4). Exactly collinear via points are passed without stopping. The
    differential robot (and the holonomic robot with ``heading="travel"``) stops, turns in
    place (:math:`\dot\theta_1 = \dot\theta_2` for the differential drive) and then drives
    straight; it never has a sideways velocity. With ``heading="hold"`` the holonomic robot
    keeps its heading and just translates.
Continuous (``continuous=True``)
    Corners are blended: the path is smoothed within ``corner_tolerance`` (Gaussian
    smoothing of the arclength-resampled polyline, end points and end tangents kept), then
    a speed profile along the arclength keeps the speed under the curvature limits
    (:math:`|\kappa| v^2 \le 0.6\,a_{max}` lateral, :math:`|\kappa| v \le \omega_{max}`,
    :math:`|\kappa'| v^2 \le \alpha_{max}/2` when the heading follows the path) and the
    tangential acceleration under :math:`0.8\,a_{max}` (so the total stays under
    :math:`a_{max}`), by a forward and a backward pass. The robot stops only at the ends
    and at corners sharper than ``max_blend_angle``. This follows a dense path (a
    TangentBug trace with hundreds of short segments) without stopping at every sample.
    The robot passes near, not through, the via points ("deviations due to finite robot
    acceleration and deceleration", section 9.7.1).
Automatic (``continuous=None``, the default)
    Continuous for dense paths (at least ``dense_min_segments`` segments with a median
    length at most ``dense_segment_length``), stop mode otherwise.

How samples are generated (and why odometry reproduces them): velocities are linear
between samples (a first-order hold, like a motor controller ramping between commands), so
the pose advances by the trapezoid rule,
:math:`p_{k+1} = p_k + \tfrac{\Delta t}{2}(\dot p_k + \dot p_{k+1})`, and the
acceleration between samples is :math:`(\dot p_{k+1} - \dot p_k)/\Delta t`. Stop-mode
profiles put their corners on sample times, so this is exact and the via points are hit
exactly. In continuous mode a small speed correction (relative size typically 1e-5 to
1e-3, at most 1 %, checked) makes the integrated motion end exactly at the goal, and the
result is verified against the limits (slowed down if sampling pushed a peak over).
:func:`kinematics.odometry.integrate_wheel_rates` integrates the wheel rates the same way
and reproduces the poses to rounding error. Between samples the differential robot's
world velocity is interpolated linearly, so it is sway-free exactly at the samples (the
commands) and to second order in between.

References
----------
Chapter 9, section 9.7 (motion control of holonomic and non-holonomic robots) and
Chapter 7 (trapezoidal velocity profiles, via points).
"""

from __future__ import annotations

__all__ = [
    "Limits",
    "Peaks",
    "Trajectory",
    "TrajectoryOptions",
    "peaks",
    "plan_trajectory",
    "trapezoidal_profile",
]

import dataclasses
import itertools
import math
from typing import Literal

import numpy as np
import numpy.typing as npt

from kinematics._arrays import FloatArray, check_positive
from kinematics.robot import RobotParams

# Consecutive path points closer than this [m] are one point (repeated points, zero-length
# segments); a via point whose turn has |sin| below _COLLINEAR is passed without stopping.
_SAME_POINT = 1e-9
_COLLINEAR = 1e-9
# Continuous mode plans against limits shrunk by this factor, leaving room for the
# sampling of the continuous profile and the end correction; the result is then verified.
_PLAN_MARGIN = 0.97
# Split of the acceleration budget along a curve: 0.6^2 + 0.8^2 = 1, so the vector sum of
# lateral and tangential acceleration stays within max_acceleration.
_LATERAL_SHARE, _TANGENTIAL_SHARE = 0.6, 0.8
# A continuous piece shorter than this many samples is driven in stop mode instead: the
# first-order hold cannot represent a smooth start and stop with fewer samples.
_MIN_CONTINUOUS_STEPS = 6
_MAX_CURVE_NODES = 40_000


@dataclasses.dataclass(frozen=True)
class Limits:
    """Motion limits of the robot's centre (world frame).

    Examples
    --------
    >>> Limits(max_speed=1.0).max_speed
    1.0
    """

    max_speed: float = 0.5
    """Largest speed of the centre, ``hypot(xdot, ydot)`` [m/s]."""
    max_acceleration: float = 0.5
    """Largest magnitude of the centre's acceleration vector [m/s^2]."""
    max_turn_rate: float = math.pi / 2
    """Largest ``|phidot|`` [rad/s]."""
    max_angular_acceleration: float = math.pi
    """Largest ``|phi_ddot|`` [rad/s^2]."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            check_positive(f.name, getattr(self, f.name))


@dataclasses.dataclass(frozen=True)
class TrajectoryOptions:
    """How to turn a path into a timed motion (see the module docstring for the modes).

    Examples
    --------
    >>> TrajectoryOptions(dt=0.02, heading="travel").dt
    0.02
    """

    dt: float = 0.05
    """Sample period [s] (the chapter's typical 0.05 s)."""
    continuous: bool | None = None
    """True: blend through via points; False: stop at each; None: continuous if dense."""
    heading: Literal["hold", "travel"] = "hold"
    """Holonomic robot: keep the heading, or turn toward the direction of travel. The
    differential robot always travels forward along its heading."""
    initial_heading: float | None = None
    """Heading at the start [rad]; None: along the first segment when the heading follows
    the path, else pi/2 (robot frame aligned with the world frame)."""
    final_heading: float | None = None
    """Turn in place to this heading at the goal [rad]; None: no final turn."""
    corner_tolerance: float = 0.05
    """Continuous mode: largest distance [m] of the blended curve from the path."""
    max_blend_angle: float = math.radians(120.0)
    """Continuous mode: the robot stops at corners turning more than this [rad]."""
    dense_segment_length: float = 0.25
    """Automatic mode: a path is dense if its median segment is at most this long [m]..."""
    dense_min_segments: int = 8
    """... and it has at least this many segments."""
    reverse: bool = False
    """Stop mode, differential robot: at a via point, turn to face the next segment or
    its opposite, whichever turn is shorter, and drive backwards in the second case
    (section 9.7.3's limits make long turns costly)."""

    def __post_init__(self) -> None:
        check_positive("dt", self.dt)
        check_positive("corner_tolerance", self.corner_tolerance)
        check_positive("max_blend_angle", self.max_blend_angle)
        if self.heading not in ("hold", "travel"):
            raise ValueError(
                f"heading must be 'hold' or 'travel', got {self.heading!r}"
            )
        for name in ("initial_heading", "final_heading"):
            value = getattr(self, name)
            if value is not None and not math.isfinite(value):
                raise ValueError(f"{name} must be finite or None, got {value!r}")


def _readonly(a: FloatArray) -> FloatArray:
    a = np.ascontiguousarray(a, dtype=np.float64)
    a.setflags(write=False)
    return a


@dataclasses.dataclass(frozen=True, eq=False)
class Trajectory:
    """A timed motion sampled every ``dt``; arrays are read-only.

    Between samples the velocities (and wheel rates) change linearly, so poses and wheel
    angles follow by the trapezoid rule; :meth:`sample` interpolates exactly that way.
    """

    t: FloatArray
    """Sample times [s], shape (T,), ``t[k] = k * dt``."""
    pose: FloatArray
    """``(x, y, phi)`` [m, m, rad], shape (T, 3); ``phi`` is unwrapped."""
    velocity: FloatArray
    """World velocity ``(xdot, ydot, phidot)`` [m/s, m/s, rad/s], shape (T, 3)."""
    wheel_rates: FloatArray
    """Wheel rates from eq. 9.5 (holonomic) or 9.9 (differential) [rad/s], shape (T, k)."""
    wheel_angles: FloatArray
    """Wheel angles, the integral of the rates from 0 [rad], shape (T, k)."""
    robot: RobotParams
    """The robot the rates are computed for."""
    limits: Limits
    """The limits the motion respects."""
    dt: float
    """Sample period [s]."""
    continuous: bool
    """True if corners were blended, False if the robot stopped at every via point."""
    path: FloatArray
    """The path after dropping repeated points, shape (M, 2) [m]."""

    @property
    def duration(self) -> float:
        """Time of the last sample [s] (0 for a motion at rest)."""
        return float(self.t[-1])

    def sample(self, time: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Interpolate the pose and the wheel angles at ``time``.

        Consistent with the samples: velocities and rates are linear between samples, so
        poses and wheel angles are quadratic. Times outside ``[0, duration]`` are clamped.

        Parameters
        ----------
        time
            Time [s], scalar or array of shape S.

        Returns
        -------
        tuple of numpy.ndarray
            ``pose`` of shape S + (3,) and ``wheel_angles`` of shape S + (k,) [rad].

        Examples
        --------
        >>> traj = plan_trajectory([[0.0, 0.0], [1.0, 0.0]], RobotParams())
        >>> pose, angles = traj.sample(traj.duration)
        >>> pose.round(9).tolist()
        [1.0, 0.0, 1.570796327]
        """
        tt = np.clip(np.asarray(time, dtype=np.float64), 0.0, self.t[-1])
        if self.t.size == 1:
            shape = tt.shape
            return (
                np.broadcast_to(self.pose[0], (*shape, 3)).copy(),
                np.broadcast_to(
                    self.wheel_angles[0], (*shape, self.wheel_angles.shape[1])
                ).copy(),
            )
        k = np.clip(np.floor(tt / self.dt).astype(np.intp), 0, self.t.size - 2)
        tau = (tt - self.t[k])[..., None]
        half = tau * tau / (2.0 * self.dt)
        pose = (
            self.pose[k]
            + tau * self.velocity[k]
            + half * (self.velocity[k + 1] - self.velocity[k])
        )
        angles = (
            self.wheel_angles[k]
            + tau * self.wheel_rates[k]
            + half * (self.wheel_rates[k + 1] - self.wheel_rates[k])
        )
        return pose, angles


@dataclasses.dataclass(frozen=True)
class Peaks:
    """Largest speed, acceleration, turn rate and angular acceleration of a trajectory.

    Accelerations are the differences of consecutive velocity samples over ``dt``, which
    is exact for the first-order hold between samples.
    """

    speed: float
    """Largest ``hypot(xdot, ydot)`` [m/s]."""
    acceleration: float
    """Largest acceleration magnitude [m/s^2]."""
    turn_rate: float
    """Largest ``|phidot|`` [rad/s]."""
    angular_acceleration: float
    """Largest ``|phi_ddot|`` [rad/s^2]."""

    def within(self, limits: Limits, rtol: float = 1e-6) -> bool:
        """Return True if every peak is within ``limits`` (relative tolerance ``rtol``).

        Parameters
        ----------
        limits
            The limits to compare with.
        rtol
            Relative slack for rounding.

        Returns
        -------
        bool
            Whether all four peaks are within their limits.
        """
        f = 1.0 + rtol
        return (
            self.speed <= limits.max_speed * f
            and self.acceleration <= limits.max_acceleration * f
            and self.turn_rate <= limits.max_turn_rate * f
            and self.angular_acceleration <= limits.max_angular_acceleration * f
        )


def _peaks_of(velocity: FloatArray, dt: float) -> Peaks:
    if velocity.shape[0] == 0:
        return Peaks(0.0, 0.0, 0.0, 0.0)
    dv = np.diff(velocity, axis=0) / dt
    return Peaks(
        speed=float(np.max(np.hypot(velocity[:, 0], velocity[:, 1]))),
        acceleration=float(np.max(np.hypot(dv[:, 0], dv[:, 1]), initial=0.0)),
        turn_rate=float(np.max(np.abs(velocity[:, 2]))),
        angular_acceleration=float(np.max(np.abs(dv[:, 2]), initial=0.0)),
    )


def peaks(traj: Trajectory) -> Peaks:
    """Measure the largest speed, acceleration, turn rate and angular acceleration.

    Parameters
    ----------
    traj
        A trajectory.

    Returns
    -------
    Peaks
        The measured peaks; ``peaks(traj).within(traj.limits)`` holds for every
        trajectory :func:`plan_trajectory` returns.

    Examples
    --------
    >>> traj = plan_trajectory([[0.0, 0.0], [2.0, 0.0]], RobotParams())
    >>> peaks(traj).within(traj.limits)
    True
    """
    return _peaks_of(traj.velocity, traj.dt)


def trapezoidal_profile(
    distance: float, max_rate: float, max_acceleration: float, dt: float
) -> tuple[FloatArray, FloatArray]:
    """Sample a rest-to-rest trapezoidal (or triangular) profile whose corners fall on samples.

    The continuous time-optimal profile accelerates for ``T_a = v_max / a_max`` (or
    ``sqrt(D / a_max)`` if the distance is too short to reach ``v_max``: a triangle),
    cruises, and decelerates. Here the acceleration phase and the total are rounded up to
    whole samples (``n_a`` and ``n_a + n_c``) and the peak rate is lowered to
    ``D / ((n_a + n_c) dt)``, which keeps both limits and makes the velocity linear between
    samples, so the trapezoid rule integrates it exactly.

    Parameters
    ----------
    distance
        Distance (or angle) to cover, >= 0 [m or rad].
    max_rate
        Largest rate [m/s or rad/s].
    max_acceleration
        Largest acceleration [m/s^2 or rad/s^2].
    dt
        Sample period [s].

    Returns
    -------
    tuple of numpy.ndarray
        ``(s, sdot)``, each of shape (n + 1,): position along the motion (``s[0] = 0``,
        ``s[-1] = distance``) and its rate, at rest at both ends. A distance of 0 gives
        one sample.

    Examples
    --------
    >>> s, v = trapezoidal_profile(0.3, max_rate=0.5, max_acceleration=1.0, dt=0.1)
    >>> v.round(3).tolist()  # trapezoid: accelerate, cruise at 0.5 m/s, brake
    [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.5, 0.4, 0.3, 0.2, 0.1, 0.0]
    >>> float(s[-1])
    0.3
    >>> trapezoidal_profile(0.09, 0.5, 1.0, 0.1)[1].round(3).tolist()  # short: a triangle
    [0.0, 0.1, 0.2, 0.3, 0.2, 0.1, 0.0]
    """
    d = float(distance)
    if not (math.isfinite(d) and d >= 0.0):
        raise ValueError(f"distance must be finite and >= 0, got {distance!r}")
    vmax = check_positive("max_rate", max_rate)
    amax = check_positive("max_acceleration", max_acceleration)
    dt = check_positive("dt", dt)
    if d == 0.0:
        return np.zeros(1), np.zeros(1)
    t_acc = vmax / amax if d >= vmax * vmax / amax else math.sqrt(d / amax)
    # The 1e-9 slack stops rounding noise from adding a whole sample; it can exceed a
    # limit by at most a relative 1e-9.
    n_a = max(1, math.ceil(t_acc / dt - 1e-9))
    n_ac = max(n_a, math.ceil(d / (vmax * dt) - 1e-9))
    n = n_a + n_ac
    v_peak = d / (n_ac * dt)
    k = np.arange(n + 1, dtype=np.float64)
    sdot = v_peak * np.minimum(np.minimum(k, n - k) / n_a, 1.0)
    s = np.concatenate([[0.0], np.cumsum(0.5 * dt * (sdot[1:] + sdot[:-1]))])
    s[-1] = d  # remove the last ulp of rounding: the motion ends exactly at the target
    return s, sdot


def _wrap(angle: float) -> float:
    """Wrap to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _clean_path(path: npt.ArrayLike) -> FloatArray:
    p = np.asarray(path, dtype=np.float64)
    if p.ndim == 1 and p.size == 2:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] == 0:
        raise ValueError(
            f"path must be an (N, 2) array of points with N >= 1, got shape {p.shape}"
        )
    if not np.all(np.isfinite(p)):
        raise ValueError("path contains NaN or infinite coordinates")
    keep = np.ones(len(p), dtype=bool)
    last = p[0]
    for i in range(1, len(p)):
        if math.hypot(p[i, 0] - last[0], p[i, 1] - last[1]) <= _SAME_POINT:
            keep[i] = False
        else:
            last = p[i]
    return p[keep]


def _turns(points: FloatArray) -> FloatArray:
    """Signed turn angle at each interior vertex [rad], shape (M - 2,)."""
    d = np.diff(points, axis=0)
    a, b = d[:-1], d[1:]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = np.einsum("ij,ij->i", a, b)
    return np.arctan2(cross, dot)


def _drop_collinear(points: FloatArray) -> FloatArray:
    """Remove interior vertices where the path goes straight on (no reason to stop)."""
    if len(points) < 3:
        return points
    d = np.diff(points, axis=0)
    n = np.hypot(d[:, 0], d[:, 1])
    u = d / n[:, None]
    a, b = u[:-1], u[1:]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    dot = np.einsum("ij,ij->i", a, b)
    straight = (np.abs(cross) <= _COLLINEAR) & (dot > 0.0)
    keep = np.concatenate([[True], ~straight, [True]])
    return points[keep]


def _is_dense(points: FloatArray, options: TrajectoryOptions) -> bool:
    if len(points) - 1 < options.dense_min_segments:
        return False
    lengths = np.hypot(*np.diff(points, axis=0).T)
    return bool(np.median(lengths) <= options.dense_segment_length)


class _Motion:
    """Accumulates rest-to-rest motion pieces that share their boundary samples."""

    def __init__(
        self, pose0: FloatArray, dt: float, limits: Limits, reverse: bool = False
    ) -> None:
        self.reverse = reverse  # may drive backwards (TrajectoryOptions.reverse)
        self.poses: list[FloatArray] = [pose0[None, :].copy()]
        self.vels: list[FloatArray] = [np.zeros((1, 3))]
        self.dt = dt
        self.limits = limits

    @property
    def pose(self) -> FloatArray:
        return self.poses[-1][-1]

    def append(self, pose: FloatArray, vel: FloatArray) -> None:
        # The first sample of a piece is the current (resting) sample: don't repeat it.
        self.poses.append(pose[1:])
        self.vels.append(vel[1:])

    def translate(self, target: FloatArray) -> None:
        """Drive straight to ``target`` keeping the heading (trapezoidal profile)."""
        x0, y0, phi0 = self.pose
        dx, dy = target[0] - x0, target[1] - y0
        dist = math.hypot(dx, dy)
        if dist <= _SAME_POINT:
            return
        lim = self.limits
        s, sdot = trapezoidal_profile(
            dist, lim.max_speed, lim.max_acceleration, self.dt
        )
        ux, uy = dx / dist, dy / dist
        pose = np.column_stack([x0 + s * ux, y0 + s * uy, np.full_like(s, phi0)])
        pose[-1, :2] = target  # exact via point (s[-1] == dist up to rounding)
        vel = np.column_stack([sdot * ux, sdot * uy, np.zeros_like(s)])
        self.append(pose, vel)

    def rotate_by(self, angle: float) -> None:
        """Turn in place by ``angle`` [rad] (trapezoidal profile in the heading)."""
        if abs(angle) <= 1e-12:
            return
        x0, y0, phi0 = self.pose
        lim = self.limits
        s, sdot = trapezoidal_profile(
            abs(angle), lim.max_turn_rate, lim.max_angular_acceleration, self.dt
        )
        sign = math.copysign(1.0, angle)
        pose = np.column_stack(
            [np.full_like(s, x0), np.full_like(s, y0), phi0 + sign * s]
        )
        vel = np.column_stack([np.zeros_like(s), np.zeros_like(s), sign * sdot])
        self.append(pose, vel)

    def turn_to(self, heading: float) -> None:
        """Turn in place the short way round to face world angle ``heading``."""
        self.rotate_by(_wrap(heading - float(self.pose[2])))


def _stop_mode(motion: _Motion, points: FloatArray, follow: bool) -> None:
    for target in _drop_collinear(points)[1:]:
        if follow:
            p = motion.pose
            ahead = math.atan2(target[1] - p[1], target[0] - p[0])
            turn = _wrap(ahead - float(p[2]))
            if motion.reverse:
                back = _wrap(ahead + math.pi - float(p[2]))
                turn = back if abs(back) < abs(turn) else turn
            motion.rotate_by(turn)
        motion.translate(target)


def _resample(points: FloatArray, n: int) -> tuple[FloatArray, float]:
    seg = np.hypot(*np.diff(points, axis=0).T)
    s_poly = np.concatenate([[0.0], np.cumsum(seg)])
    total = float(s_poly[-1])
    u = np.linspace(0.0, total, n + 1)
    return np.column_stack(
        [np.interp(u, s_poly, points[:, 0]), np.interp(u, s_poly, points[:, 1])]
    ), total


def _gaussian_smooth(p: FloatArray, sigma_nodes: float) -> FloatArray:
    """Smooth resampled points with a Gaussian of ``sigma_nodes`` node spacings.

    Point reflection at the ends keeps the end points and end tangents (a straight line
    maps to itself).
    """
    n = len(p) - 1
    m = min(n, math.ceil(4.0 * sigma_nodes))
    if m < 1:
        return p.copy()
    left = 2.0 * p[0] - p[1 : m + 1][::-1]
    right = 2.0 * p[-1] - p[n - m : n][::-1]
    padded = np.concatenate([left, p, right])
    k = np.arange(-m, m + 1, dtype=np.float64)
    g = np.exp(-0.5 * (k / sigma_nodes) ** 2)
    g /= g.sum()
    smooth = [np.convolve(padded[:, i], g, mode="valid") for i in range(2)]
    return np.column_stack(smooth).astype(np.float64)


def _blend_curve(points: FloatArray, tolerance: float) -> FloatArray:
    """Return a smooth curve within ``tolerance`` of the polyline, from first to last point.

    The deviation at a corner turning by delta is about ``0.8 sigma sin(delta / 2)``
    (the Gaussian's mean absolute offset); sigma starts from that estimate and is halved
    until the measured pointwise deviation (an upper bound of the distance to the path) is
    within the tolerance and the curve has no cusp (several turns inside one kernel
    width could otherwise cancel the tangent).
    """
    turns = np.abs(_turns(points)) if len(points) > 2 else np.zeros(0)
    seg = np.hypot(*np.diff(points, axis=0).T)
    total = float(seg.sum())
    delta = float(turns.max(initial=0.0))
    if delta <= _COLLINEAR:
        return _resample(points, 256)[0]
    sigma = min(total / 4.0, tolerance / (0.8 * math.sin(min(delta, math.pi) / 2.0)))
    curve = _resample(points, 256)[0]
    for _ in range(16):
        h = max(sigma / 10.0, total / _MAX_CURVE_NODES)
        n = max(256, math.ceil(total / h))
        base, _ = _resample(points, n)
        curve = _gaussian_smooth(base, sigma / (total / n))
        step = np.hypot(*np.diff(curve, axis=0).T)
        deviation = float(np.max(np.hypot(*(curve - base).T)))
        if deviation <= tolerance and float(step.min()) >= 0.5 * total / n:
            break
        sigma *= 0.5
    return curve


def _curve_geometry(
    curve: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Arclength, tangent angle, curvature and its derivative along the curve nodes."""
    ds = np.hypot(*np.diff(curve, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(ds)])
    tangent = np.gradient(curve, axis=0)
    theta = np.unwrap(np.arctan2(tangent[:, 1], tangent[:, 0]))
    kappa = np.gradient(theta, s)
    dkappa = np.gradient(kappa, s)
    return s, theta, kappa, dkappa


def _speed_profile(
    s: FloatArray, kappa: FloatArray, dkappa: FloatArray, lim: Limits, follow: bool
) -> FloatArray:
    """Largest speed at each node under the curvature limits, rest to rest (two passes)."""
    tiny = 1e-12
    k = np.abs(kappa) + tiny
    vlim = np.minimum(lim.max_speed, np.sqrt(_LATERAL_SHARE * lim.max_acceleration / k))
    acc = np.full_like(s, _TANGENTIAL_SHARE * lim.max_acceleration)
    if follow:
        # phi_ddot = kappa' v^2 + kappa a_t: give each term half the angular budget.
        vlim = np.minimum(vlim, lim.max_turn_rate / k)
        vlim = np.minimum(
            vlim, np.sqrt(0.5 * lim.max_angular_acceleration / (np.abs(dkappa) + tiny))
        )
        acc = np.minimum(acc, 0.5 * lim.max_angular_acceleration / k)
    acc_seg = np.minimum(acc[1:], acc[:-1]).tolist()
    ds = np.diff(s).tolist()
    vl = vlim.tolist()
    n = len(vl)
    v = [0.0] * n
    for i in range(n - 1):  # forward pass: accelerate as hard as allowed
        v[i + 1] = min(vl[i + 1], math.sqrt(v[i] * v[i] + 2.0 * acc_seg[i] * ds[i]))
    v[-1] = 0.0
    for i in range(n - 2, -1, -1):  # backward pass: be able to brake for what comes
        v[i] = min(v[i], math.sqrt(v[i + 1] * v[i + 1] + 2.0 * acc_seg[i] * ds[i]))
    v[0] = 0.0
    return np.asarray(v)


def _continuous_piece(  # noqa: PLR0915 - a numeric kernel: profile, sampling and end fix share its arrays
    motion: _Motion,
    points: FloatArray,
    follow: bool,
    differential: bool,
    tolerance: float,
) -> None:
    """Drive through ``points`` without stopping, rest to rest."""
    dt = motion.dt
    curve = _blend_curve(points, tolerance)
    s, theta, kappa, dkappa = _curve_geometry(curve)
    lim = motion.limits
    plan_lim = Limits(
        *(_PLAN_MARGIN * getattr(lim, f.name) for f in dataclasses.fields(lim))
    )
    v = _speed_profile(s, kappa, dkappa, plan_lim, follow)
    ds = np.diff(s)
    vsum = v[1:] + v[:-1]
    dtau = np.divide(2.0 * ds, vsum, out=np.zeros_like(ds), where=vsum > 0.0)
    tau_nodes = np.concatenate([[0.0], np.cumsum(dtau)])
    t_total = float(tau_nodes[-1])
    if t_total < _MIN_CONTINUOUS_STEPS * dt:
        _stop_mode(motion, points, follow)
        return
    if follow:
        motion.turn_to(float(theta[0]))
    x0, y0, phi0 = motion.pose
    node_acc = np.divide(
        v[1:] ** 2 - v[:-1] ** 2, 2.0 * ds, out=np.zeros_like(ds), where=ds > 0.0
    )
    w_end = points[-1] - np.array([x0, y0])

    def attempt(n_steps: int) -> tuple[FloatArray, FloatArray, bool]:
        """Sample the profile in ``n_steps`` steps; return velocity, heading, ok."""
        stretch = t_total / (n_steps * dt)  # <= 1: slowing down keeps every limit
        tau = np.arange(n_steps + 1) * dt * stretch
        i = np.clip(np.searchsorted(tau_nodes, tau, side="right") - 1, 0, len(ds) - 1)
        tp = tau - tau_nodes[i]
        sk = np.minimum(s[i] + v[i] * tp + 0.5 * node_acc[i] * tp * tp, s[-1])
        speed = stretch * np.maximum(v[i] + node_acc[i] * tp, 0.0)
        speed[0] = speed[-1] = 0.0
        th = np.interp(sk, s, theta)
        w = np.full_like(speed, dt)  # trapezoid weights
        w[0] = w[-1] = 0.5 * dt
        if follow:
            omega = np.interp(sk, s, kappa) * speed
            # Sampled kappa * v does not integrate exactly to the curve's total turn; add
            # the missing angle where the robot already turns (in proportion to |omega|),
            # so the heading drifts nowhere and ends along the curve's end tangent.
            turned = float(w @ np.abs(omega))
            if turned > 0.0:
                missing = float(theta[-1] - theta[0]) - float(w @ omega)
                omega = omega + missing * np.abs(omega) / turned
            phi = phi0 + np.concatenate(
                [[0.0], np.cumsum(0.5 * dt * (omega[1:] + omega[:-1]))]
            )
        else:
            omega = np.zeros_like(speed)
            phi = np.full_like(speed, phi0)
        # The differential robot moves exactly along its heading (no sway, ever); the
        # holonomic robot moves along the curve's tangent.
        direction = phi if differential else th
        u = np.column_stack([np.cos(direction), np.sin(direction)])
        # End correction: the sampled motion integrates to slightly off the goal (the
        # trapezoid rule on a curve). Scale the speeds by (1 + u . c), a smooth change
        # that vanishes at rest, with c solving the 2x2 linear end condition exactly.
        wv = w * speed
        error = w_end - (wv[:, None] * u).sum(axis=0)
        gram = (wv[:, None, None] * u[:, :, None] * u[:, None, :]).sum(axis=0)
        c = np.linalg.lstsq(gram, error, rcond=1e-9)[0]
        scale = u @ c
        speed = speed * (1.0 + scale)
        vel = np.column_stack([speed * u[:, 0], speed * u[:, 1], omega])
        ok = (
            _peaks_of(vel, dt).within(lim, rtol=0.0)
            and float(np.max(np.abs(scale))) <= 0.01
        )
        return vel, phi, ok

    n_steps = math.ceil(t_total / dt - 1e-9)
    for _ in range(12):
        vel, phi, ok = attempt(n_steps)
        if ok:
            break
        # Sampling too coarse for this curve: slow down (more samples) and try again.
        n_steps = math.ceil(n_steps * 1.15) + 1
    else:
        # Never met in the tests; stopping at every via point always keeps the limits.
        _stop_mode(motion, points, follow)
        return
    xy = np.array([x0, y0]) + np.concatenate(
        [np.zeros((1, 2)), np.cumsum(0.5 * dt * (vel[1:, :2] + vel[:-1, :2]), axis=0)]
    )
    motion.append(np.column_stack([xy, phi]), vel)


def _split_sharp(points: FloatArray, max_angle: float) -> list[FloatArray]:
    """Split the path at corners turning more than ``max_angle`` (the robot stops there)."""
    if len(points) < 3:
        return [points]
    sharp = np.flatnonzero(np.abs(_turns(points)) > max_angle) + 1
    cuts = [0, *sharp.tolist(), len(points) - 1]
    return [points[a : b + 1] for a, b in itertools.pairwise(cuts)]


def plan_trajectory(
    path: npt.ArrayLike,
    robot: RobotParams | None = None,
    *,
    limits: Limits | None = None,
    options: TrajectoryOptions | None = None,
) -> Trajectory:
    """Turn a planned path into a timed motion with wheel rates (section 9.7).

    Parameters
    ----------
    path
        Via points, shape (N, 2) [m], from start to goal. A single point, repeated points
        and zero-length segments are fine (a path with one distinct point gives a
        trajectory at rest).
    robot
        The robot; None means ``RobotParams()`` (the default holonomic robot).
    limits
        Motion limits; None means ``Limits()``.
    options
        Mode, sample period and headings; None means ``TrajectoryOptions()``.

    Returns
    -------
    Trajectory
        Starts and ends at rest, respects ``limits`` (see :func:`peaks`).

    Raises
    ------
    ValueError
        For a malformed path (not (N, 2), empty, NaN or infinite coordinates).

    Notes
    -----
    The differential robot ignores ``options.heading``: it can only move along its
    heading, so it always faces its direction of travel.

    Examples
    --------
    >>> robot = RobotParams("differential", wheel_radius=0.05, wheel_distance=0.2)
    >>> traj = plan_trajectory([[0, 0], [1, 0], [1, 1]], robot)
    >>> traj.pose[-1].round(6).tolist()  # at the goal, facing +y after the turn at (1, 0)
    [1.0, 1.0, 1.570796]
    >>> bool(np.all(traj.velocity[[0, -1]] == 0.0))  # at rest at both ends
    True
    """
    robot = RobotParams() if robot is None else robot
    limits = Limits() if limits is None else limits
    options = TrajectoryOptions() if options is None else options
    points = _clean_path(path)
    differential = robot.kind == "differential"
    follow = differential or options.heading == "travel"
    continuous = (
        _is_dense(points, options)
        if options.continuous is None
        else bool(options.continuous)
    )
    if len(points) < 2:
        continuous = False

    if options.initial_heading is not None:
        phi0 = float(options.initial_heading)
    elif follow and len(points) >= 2:
        # Start facing the first segment: no turn before driving off.
        phi0 = math.atan2(points[1, 1] - points[0, 1], points[1, 0] - points[0, 0])
    else:
        phi0 = math.pi / 2  # robot frame aligned with the world frame
    motion = _Motion(
        np.array([points[0, 0], points[0, 1], phi0]),
        options.dt,
        limits,
        reverse=options.reverse and differential,
    )

    if continuous:
        for piece in _split_sharp(points, options.max_blend_angle):
            _continuous_piece(
                motion, piece, follow, differential, options.corner_tolerance
            )
    else:
        _stop_mode(motion, points, follow)
    if options.final_heading is not None:
        motion.turn_to(float(options.final_heading))

    pose = np.concatenate(motion.poses)
    velocity = np.concatenate(motion.vels)
    t = np.arange(len(pose), dtype=np.float64) * options.dt
    rates = robot.inverse(velocity[:, 0], velocity[:, 1], velocity[:, 2], pose[:, 2])
    angles = np.concatenate(
        [
            np.zeros((1, rates.shape[1])),
            np.cumsum(0.5 * options.dt * (rates[1:] + rates[:-1]), axis=0),
        ]
    )
    return Trajectory(
        t=_readonly(t),
        pose=_readonly(pose),
        velocity=_readonly(velocity),
        wheel_rates=_readonly(rates),
        wheel_angles=_readonly(angles),
        robot=robot,
        limits=limits,
        dt=float(options.dt),
        continuous=continuous,
        path=_readonly(points),
    )
