"""Odometry: integrating the commanded wheel rates reproduces the trajectory."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from kinematics import RobotParams, TrajectoryOptions, plan_trajectory
from kinematics.odometry import integrate_rates, integrate_wheel_rates
from tests.kinematics.kin_helpers import (
    DIFFERENTIAL,
    HOLONOMIC,
    LECTURE_PATH,
    dense_trace,
)


# The fixtures are defined per module rather than in a conftest.py: with --doctest-modules
# every conftest.py is imported as a module named "conftest", and sibling ones collide.
@pytest.fixture(params=[HOLONOMIC, DIFFERENTIAL], ids=["holonomic", "differential"])
def robot(request) -> RobotParams:
    return request.param


@pytest.fixture
def lecture_path() -> np.ndarray:
    return LECTURE_PATH.copy()


@pytest.mark.parametrize("continuous", [False, True], ids=["stop", "continuous"])
@pytest.mark.parametrize("heading", ["hold", "travel"])
def test_lecture_path_end_point_error_is_below_a_millimetre(
    robot, lecture_path, continuous, heading
):
    opts = TrajectoryOptions(dt=0.05, continuous=continuous, heading=heading)
    traj = plan_trajectory(lecture_path, robot, options=opts)
    odo = integrate_wheel_rates(traj)
    end_error = math.hypot(*(odo[-1, :2] - traj.pose[-1, :2]))
    assert end_error < 1e-3
    # In fact the whole motion agrees to rounding: the same scheme generated it.
    assert np.max(np.abs(odo - traj.pose)) < 1e-9
    assert_allclose(odo[-1, :2], lecture_path[-1], atol=1e-9)


def test_dense_trace_odometry(robot):
    trace = dense_trace()
    traj = plan_trajectory(trace, robot)
    assert np.max(np.abs(integrate_wheel_rates(traj) - traj.pose)) < 1e-9


def test_euler_odometry_drifts_at_first_order(lecture_path):
    # Holding each sample's rates (zero-order hold) is the cruder scheme: on the blended
    # path it is off by millimetres, and halving dt about halves the error.
    errors = []
    for dt in (0.05, 0.025):
        traj = plan_trajectory(
            lecture_path,
            DIFFERENTIAL,
            options=TrajectoryOptions(dt=dt, continuous=True),
        )
        odo = integrate_wheel_rates(traj, method="euler")
        errors.append(np.max(np.hypot(*(odo[:, :2] - traj.pose[:, :2]).T)))
    assert 1e-5 < errors[0] < 0.05
    assert errors[1] < 0.7 * errors[0]


def test_constant_rates_drive_a_circle():
    # v = 0.5 m/s, phidot = 0.5 rad/s: a circle of radius 1 m, closed after 4 pi s.
    r, L = DIFFERENTIAL.wheel_radius, DIFFERENTIAL.wheel_distance
    rates = np.array([(0.5 + L * 0.5) / r, (-0.5 + L * 0.5) / r])
    t = np.linspace(0.0, 4 * math.pi, 2001)
    pose = integrate_rates(
        t, np.tile(rates, (t.size, 1)), DIFFERENTIAL, [0.0, 0.0, 0.0]
    )
    assert_allclose(pose[-1], [0.0, 0.0, 2 * math.pi], atol=1e-4)
    # Centre of the circle at (0, 1): the robot starts facing +x and turns left.
    assert_allclose(np.hypot(pose[:, 0], pose[:, 1] - 1.0), 1.0, atol=1e-4)


def test_holonomic_spin_in_place():
    r, L = HOLONOMIC.wheel_radius, HOLONOMIC.wheel_distance
    t = np.linspace(0.0, 2.0, 41)
    rates = np.full((41, 3), L * 1.0 / r)  # phidot = 1 rad/s
    pose = integrate_rates(t, rates, HOLONOMIC, [1.0, 2.0, 0.0])
    assert_allclose(pose[:, :2], np.tile([1.0, 2.0], (41, 1)), atol=1e-12)
    assert_allclose(pose[:, 2], t, atol=1e-12)


def test_shape_and_method_errors():
    with pytest.raises(ValueError, match=r"\(T, 2\)"):
        integrate_rates([0.0, 1.0], np.zeros((2, 3)), DIFFERENTIAL, [0, 0, 0])
    with pytest.raises(ValueError, match="method"):
        integrate_rates(
            [0.0, 1.0],
            np.zeros((2, 2)),
            DIFFERENTIAL,
            [0, 0, 0],
            method="rk4",  # pyright: ignore[reportArgumentType]
        )
