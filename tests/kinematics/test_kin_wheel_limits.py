"""Wheel limits (section 9.7.3) on planned trajectories: centre limits derived from them."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kinematics import RobotParams, plan_trajectory
from kinematics.wheel_limits import WheelLimits, centre_limits, wheel_peaks, within
from tests.kinematics.kin_helpers import LECTURE_PATH, dense_trace


@settings(max_examples=25, deadline=None)
@given(
    kind=st.sampled_from(["holonomic", "differential"]),
    rate=st.floats(2.0, 60.0),
    acc=st.floats(1.0, 80.0),
    dense=st.booleans(),
)
def test_trajectories_within_centre_limits_respect_the_wheels(kind, rate, acc, dense):
    robot = RobotParams(kind, wheel_radius=0.05, wheel_distance=0.2)
    wheels = WheelLimits(max_rate=rate, max_acceleration=acc)
    path = dense_trace(120) if dense else LECTURE_PATH
    traj = plan_trajectory(path, robot, limits=centre_limits(robot, wheels))
    peak_rate, peak_acc = wheel_peaks(traj.wheel_rates, traj.dt)
    assert peak_rate <= rate * (1 + 1e-6)
    assert peak_acc <= acc * (1 + 1e-6)
    assert within(traj.wheel_rates, traj.dt, wheels, rtol=1e-6)


def test_limits_must_be_positive():
    with pytest.raises(ValueError, match="max_acceleration must be positive"):
        WheelLimits(max_acceleration=0.0)
    with pytest.raises(ValueError, match="max_rate must be positive"):
        WheelLimits(max_rate=math.nan)


def test_peaks_by_hand():
    rate, acc = wheel_peaks(np.array([[0.0, 0.0], [0.5, -1.0], [0.5, -1.0]]), 0.1)
    assert (rate, acc) == (1.0, 10.0)


def test_the_differential_robot_may_reverse_where_the_turn_is_shorter():
    from kinematics import TrajectoryOptions
    from kinematics.differential import sway_residual
    from kinematics.odometry import integrate_wheel_rates

    robot = RobotParams("differential", wheel_radius=0.05, wheel_distance=0.2)
    path = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.05]])  # back almost the same way
    plain = plan_trajectory(path, robot, options=TrajectoryOptions(continuous=False))
    back = plan_trajectory(
        path, robot, options=TrajectoryOptions(continuous=False, reverse=True)
    )
    assert back.duration < plain.duration
    turned = np.abs(np.diff(back.pose[:, 2])).sum()
    assert turned < 0.1  # a few degrees, not half a turn
    forward = (
        np.cos(back.pose[:, 2]) * back.velocity[:, 0]
        + np.sin(back.pose[:, 2]) * back.velocity[:, 1]
    )
    assert forward.min() < -0.1  # it drove backwards
    assert_allclose = np.testing.assert_allclose
    assert_allclose(back.pose[-1, :2], path[-1], atol=1e-9)
    assert_allclose(integrate_wheel_rates(back), back.pose, atol=1e-9)
    residual = sway_residual(back.velocity[:, 0], back.velocity[:, 1], back.pose[:, 2])
    assert np.abs(residual).max() < 1e-9
