"""Differential drive: eq. 9.7-9.11, the factor-two fix of eq. 9.10, and sway handling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from kinematics import differential, holonomic
from kinematics.differential import (
    BETAS,
    forward,
    inverse,
    inverse_robot_frame,
    sway_residual,
)

R, L = 0.05, 0.2

speeds = st.floats(-3.0, 3.0, allow_nan=False)
angles = st.floats(-10.0, 10.0, allow_nan=False)


def test_straight_ahead_wheels_turn_opposite():
    # eq. 9.7: theta = (ydot_m / r, -ydot_m / r).
    assert_allclose(inverse_robot_frame(0.0, 0.5, 0.0, r=R, L=L), [10.0, -10.0])


def test_turn_in_place_wheels_turn_equal_at_l_phidot_over_r():
    # Section 9.7.2: a pure rotation is theta1_dot == theta2_dot.
    q = inverse_robot_frame(0.0, 0.0, 1.5, r=R, L=L)
    assert q[0] == q[1]
    assert_allclose(q, [L * 1.5 / R] * 2)


def test_world_frame_eq_9_9_hand_values():
    # Facing 30 degrees, driving forward at 1 m/s while turning at 0.5 rad/s.
    phi = math.radians(30.0)
    q = inverse(math.cos(phi), math.sin(phi), 0.5, phi, r=R, L=L)
    assert_allclose(q, [(1.0 + L * 0.5) / R, (-1.0 + L * 0.5) / R], atol=1e-12)


@given(speeds, speeds, angles)
def test_eq_9_9_is_eq_9_5_with_betas_0_and_180(v, phidot, phi):
    # The chapter derives eq. 9.9 by substituting beta = (0, 180 deg) into eq. 9.5.
    x, y = v * math.cos(phi), v * math.sin(phi)
    assert_allclose(
        inverse(x, y, phidot, phi, r=R, L=L),
        holonomic.inverse(x, y, phidot, phi, r=R, L=L, betas=BETAS),
        atol=1e-9,
    )


def test_forward_yaw_rate_uses_2l_not_the_chapters_l():
    # eq. 9.10 prints phidot = r (t1 + t2) / L; eq. 9.7 gives r (t1 + t2) / (2 L).
    q = np.array([4.0, 4.0])
    _, _, phidot = forward(q, 0.0, r=R, L=L)
    assert phidot == pytest.approx(R * 8.0 / (2 * L))  # 1.0 rad/s
    chapter = R * 8.0 / L  # 2.0 rad/s: would not invert eq. 9.7
    assert inverse(0.0, 0.0, chapter, 0.0, r=R, L=L) == pytest.approx(
        [8.0, 8.0]
    )  # not q


def test_forward_hand_values():
    xdot, ydot, phidot = forward([10.0, -10.0], math.pi, r=R, L=L)
    assert_allclose((xdot, ydot, phidot), (-0.5, 0.0, 0.0), atol=1e-12)  # facing -x


@given(speeds, speeds, angles)
def test_round_trip_on_the_executable_subspace(v, phidot, phi):
    # Executable world velocities: along the heading, any yaw rate.
    world = (v * math.cos(phi), v * math.sin(phi), phidot)
    q = inverse(*world, phi, r=R, L=L)
    assert_allclose(forward(q, phi, r=R, L=L), world, atol=1e-9)


@given(st.floats(-100, 100), st.floats(-100, 100), angles)
def test_inverse_inverts_forward(q1, q2, phi):
    world = forward([q1, q2], phi, r=R, L=L)
    assert (
        abs(sway_residual(world[0], world[1], phi)) < 1e-9
    )  # forward is always executable
    assert_allclose(inverse(*world, phi, r=R, L=L), [q1, q2], atol=1e-8)


def test_sideways_request_raises_naming_sway():
    with pytest.raises(ValueError, match=r"sway \(sideways, x_m\) velocity 0\.3"):
        inverse(0.3, 0.0, 0.0, math.pi / 2, r=R, L=L)
    with pytest.raises(ValueError, match="sway"):
        inverse_robot_frame(0.1, 1.0, 0.0, r=R, L=L)


def test_sway_error_names_the_worst_sample():
    x = np.array([0.0, 0.0, 0.2, 0.0])
    with pytest.raises(ValueError, match=r"worst at index \(2,\)"):
        inverse(x, 0.0, 0.0, math.pi / 2, r=R, L=L)


def test_sway_below_tolerance_is_accepted():
    q = inverse(1e-9, 1.0, 0.0, math.pi / 2, r=R, L=L)
    assert_allclose(q, [20.0, -20.0], atol=1e-6)
    with pytest.raises(ValueError):
        inverse(1e-3, 1.0, 0.0, math.pi / 2, r=R, L=L, tol=1e-4)


def test_check_false_drops_the_sway_explicitly():
    # Asked for (0.3 right, 1.0 forward): only the forward part is executed...
    q = inverse(0.3, 1.0, 0.0, math.pi / 2, r=R, L=L, check=False)
    assert_allclose(forward(q, math.pi / 2, r=R, L=L), (0.0, 1.0, 0.0), atol=1e-12)
    # ...and the residual says exactly what was dropped.
    assert sway_residual(0.3, 1.0, math.pi / 2) == pytest.approx(0.3)


@given(speeds, speeds, angles)
def test_sway_residual_is_what_forward_inverse_loses(xdot, ydot, phi):
    q = inverse(xdot, ydot, 0.0, phi, r=R, L=L, check=False)
    fx, fy, _ = forward(q, phi, r=R, L=L)
    lost = np.array([xdot - fx, ydot - fy])
    right = np.array([math.sin(phi), -math.cos(phi)])  # x_m in the world
    assert_allclose(lost, sway_residual(xdot, ydot, phi) * right, atol=1e-9)


def test_array_inputs_give_n_by_2():
    phi = np.linspace(0.0, 3.0, 5)
    v = np.linspace(-1.0, 1.0, 5)
    q = inverse(v * np.cos(phi), v * np.sin(phi), 0.2, phi, r=R, L=L)
    assert q.shape == (5, 2)
    xdot, ydot, phidot = forward(q, phi, r=R, L=L)
    assert xdot.shape == (5,)
    assert_allclose(phidot, np.full(5, 0.2), atol=1e-12)
    assert sway_residual(xdot, ydot, phi).shape == (5,)


def test_scalar_inputs_give_two_rates_and_scalar_outputs():
    assert inverse(0.0, 0.0, 1.0, 0.0, r=R, L=L).shape == (2,)
    assert all(np.ndim(v) == 0 for v in forward([1.0, 2.0], 0.3, r=R, L=L))


def test_forward_robot_frame_never_sways():
    xm, ym, w = differential.forward_robot_frame(
        np.array([[3.0, 1.0], [-2.0, 5.0]]), r=R, L=L
    )
    assert_allclose(xm, [0.0, 0.0])
    assert_allclose(ym, [R * 1.0, R * -3.5])
    assert_allclose(w, [R * 4.0 / (2 * L), R * 3.0 / (2 * L)])


def test_wrong_number_of_rates_raises():
    with pytest.raises(ValueError, match="k=2"):
        forward([1.0, 2.0, 3.0], 0.0, r=R, L=L)
