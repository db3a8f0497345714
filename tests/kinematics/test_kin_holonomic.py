"""Holonomic robot: eq. 9.1-9.6 against hand-computed values and as exact inverses."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from kinematics import frames, holonomic
from kinematics.holonomic import (
    DEFAULT_BETAS,
    forward,
    inverse,
    inverse_robot_frame,
    roller_speeds,
)

R, L = 0.05, 0.25
S3 = math.sqrt(3.0)

speeds = st.floats(-3.0, 3.0, allow_nan=False)
angles = st.floats(-10.0, 10.0, allow_nan=False)


def test_default_betas_are_the_symmetric_configuration():
    assert_allclose(np.degrees(DEFAULT_BETAS), [30.0, 150.0, 270.0])


@pytest.mark.parametrize("phi", [0.0, 0.4, math.pi / 2, -2.5, 7.0])
@pytest.mark.parametrize(
    "betas",
    [DEFAULT_BETAS, (0.1, 1.9, 4.0), (0.0, math.pi / 2, math.pi, 1.5 * math.pi)],
)
def test_printed_eq_9_5_equals_eq_9_3_times_eq_9_4(phi, betas):
    # The chapter's printed matrix of eq. 9.5 against the product J_m^-1 R it claims.
    b = np.asarray(betas)
    printed = (
        np.column_stack([np.cos(phi + b), np.sin(phi + b), np.full_like(b, L)]) / R
    )
    product = holonomic.inverse_jacobian(
        r=R, L=L, betas=b
    ) @ frames.rotation_world_to_robot(phi)
    assert_allclose(printed, product, atol=1e-12)


@given(speeds, speeds, speeds, angles)
def test_inverse_is_jinv_times_r_times_v(xdot, ydot, phidot, phi):
    expected = (
        holonomic.inverse_jacobian(r=R, L=L)
        @ frames.rotation_world_to_robot(phi)
        @ [xdot, ydot, phidot]
    )
    assert_allclose(inverse(xdot, ydot, phidot, phi, r=R, L=L), expected, atol=1e-9)


def test_pure_forward_motion_robot_frame():
    # ydot_m = v: theta_i = v cos(beta_i) / r = v/r * (sqrt3/2, -sqrt3/2, 0).
    v = 0.4
    assert_allclose(
        inverse_robot_frame(0.0, v, 0.0, r=R, L=L),
        v / R * np.array([S3 / 2, -S3 / 2, 0.0]),
        atol=1e-12,
    )


def test_pure_forward_motion_world_frame_facing_x():
    # Heading phi = 0: forward is world +x.
    v = 0.4
    assert_allclose(
        inverse(v, 0.0, 0.0, 0.0, r=R, L=L),
        v / R * np.array([S3 / 2, -S3 / 2, 0.0]),
        atol=1e-12,
    )


def test_pure_rotation_turns_every_wheel_at_l_phidot_over_r():
    assert_allclose(inverse(0.0, 0.0, 2.0, 1.234, r=R, L=L), np.full(3, L * 2.0 / R))
    assert_allclose(inverse_robot_frame(0.0, 0.0, -1.0, r=R, L=L), np.full(3, -L / R))


def test_sway_to_the_right():
    # xdot_m = v: theta_i = -v sin(beta_i) / r = v/r * (-1/2, -1/2, 1).
    v = 0.3
    assert_allclose(
        inverse_robot_frame(v, 0.0, 0.0, r=R, L=L),
        v / R * np.array([-0.5, -0.5, 1.0]),
        atol=1e-12,
    )


def test_world_frame_at_phi_90_degrees_is_the_robot_frame():
    v = (0.3, -0.2, 0.7)
    assert_allclose(
        inverse(*v, math.pi / 2, r=R, L=L),
        inverse_robot_frame(*v, r=R, L=L),
        atol=1e-12,
    )


@given(speeds, speeds, angles)
def test_symmetric_configuration_rates_sum_to_zero_for_pure_translation(
    xdot, ydot, phi
):
    assert abs(inverse(xdot, ydot, 0.0, phi, r=R, L=L).sum()) < 1e-9


@given(speeds, speeds, speeds, angles)
def test_forward_inverts_inverse(xdot, ydot, phidot, phi):
    q = inverse(xdot, ydot, phidot, phi, r=R, L=L)
    assert_allclose(forward(q, phi, r=R, L=L), (xdot, ydot, phidot), atol=1e-9)


@given(st.lists(st.floats(-100.0, 100.0), min_size=3, max_size=3), angles)
def test_inverse_inverts_forward(rates, phi):
    v = forward(np.array(rates), phi, r=R, L=L)
    assert_allclose(inverse(*v, phi, r=R, L=L), rates, atol=1e-8)


@given(
    st.tuples(speeds, speeds, speeds),
    angles,
    st.floats(0.0, 2 * math.pi),
    st.floats(0.5, 2.5),
)
def test_round_trip_for_other_wheel_layouts(v, phi, b0, spread):
    betas = (b0, b0 + spread, b0 + 2 * spread + 0.3)  # three distinct angles
    q = inverse(v[0], v[1], v[2], phi, r=0.03, L=0.4, betas=betas)
    assert_allclose(forward(q, phi, r=0.03, L=0.4, betas=betas), v, atol=1e-7)


def test_four_wheels_round_trip():
    betas = np.radians([45.0, 135.0, 225.0, 315.0])
    q = inverse(0.2, -0.1, 0.5, 0.3, r=R, L=L, betas=betas)
    assert q.shape == (4,)
    assert_allclose(
        forward(q, 0.3, r=R, L=L, betas=betas), (0.2, -0.1, 0.5), atol=1e-12
    )


def test_forward_robot_frame_hand_values():
    # Rates of pure forward motion at 1 m/s map back to (0, 1, 0).
    q = np.array([S3 / 2, -S3 / 2, 0.0]) / R
    assert_allclose(
        holonomic.forward_robot_frame(q, r=R, L=L), (0.0, 1.0, 0.0), atol=1e-12
    )


def test_array_inputs_give_n_by_k_and_match_scalars():
    rng = np.random.default_rng(1)
    x, y, w, phi = rng.normal(size=(4, 7))
    q = inverse(x, y, w, phi, r=R, L=L)
    assert q.shape == (7, 3)
    for i in range(7):
        assert_allclose(q[i], inverse(x[i], y[i], w[i], phi[i], r=R, L=L))
    xdot, ydot, phidot = forward(q, phi, r=R, L=L)
    assert xdot.shape == ydot.shape == phidot.shape == (7,)
    assert_allclose(
        np.column_stack([xdot, ydot, phidot]), np.column_stack([x, y, w]), atol=1e-12
    )


def test_scalars_broadcast_against_arrays():
    # A whole trajectory at one heading, or one velocity at many headings.
    assert inverse(np.ones(5), 0.0, 0.0, 0.3, r=R, L=L).shape == (5, 3)
    assert inverse(1.0, 0.0, 0.0, np.linspace(0, 1, 4), r=R, L=L).shape == (4, 3)
    assert inverse_robot_frame(np.zeros(6), 1.0, 0.0, r=R, L=L).shape == (6, 3)
    xdot, _, _ = forward(np.ones((5, 3)), 0.0, r=R, L=L)
    assert xdot.shape == (5,)


def test_scalar_inputs_give_k_rates_and_scalar_outputs():
    assert inverse(0.1, 0.2, 0.3, 0.4, r=R, L=L).shape == (3,)
    out = forward([1.0, 2.0, 3.0], 0.4, r=R, L=L)
    assert all(np.ndim(v) == 0 for v in out)


@pytest.mark.parametrize("betas", [(0.0, 0.0, 1.0), (0.5, 0.5 + 2 * math.pi, 2.0)])
def test_singular_wheel_angles_raise(betas):
    with pytest.raises(ValueError, match="singular"):
        forward([1.0, 1.0, 1.0], 0.0, r=R, L=L, betas=betas)


def test_too_few_wheels_raise():
    with pytest.raises(ValueError, match="at least 3 wheels"):
        forward([1.0, 1.0], 0.0, r=R, L=L, betas=(0.0, math.pi))


@pytest.mark.parametrize(
    ("r", "length"), [(0.0, 0.25), (-0.05, 0.25), (0.05, 0.0), (math.nan, 0.25)]
)
def test_bad_dimensions_raise(r, length):
    with pytest.raises(ValueError, match="must be a finite number > 0"):
        inverse(1.0, 0.0, 0.0, 0.0, r=r, L=length)


def test_wrong_number_of_rates_raises():
    with pytest.raises(ValueError, match="k=3"):
        forward([1.0, 2.0], 0.0, r=R, L=L)


def test_roller_speeds_hand_values():
    # Forward: the back wheel slides sideways at the full speed, the front ones at half.
    assert_allclose(roller_speeds(0.0, 1.0), [0.5, 0.5, -1.0], atol=1e-12)
    # Sway right: cos(beta) = (sqrt3/2, -sqrt3/2, 0).
    assert_allclose(roller_speeds(2.0, 0.0), [S3, -S3, 0.0], atol=1e-12)


@given(speeds, speeds)
def test_rolling_and_rollers_make_up_the_wheel_velocity(xm, ym):
    # Without rotation every wheel moves with the body: r*theta_i along the rolling
    # direction plus the roller speed along the axle direction must give (xm, ym).
    q = inverse_robot_frame(xm, ym, 0.0, r=R, L=L)
    rollers = roller_speeds(xm, ym)
    b = np.asarray(DEFAULT_BETAS)
    rolling_dir = np.column_stack([-np.sin(b), np.cos(b)])
    radial = np.column_stack([np.cos(b), np.sin(b)])
    wheel_velocity = R * q[:, None] * rolling_dir + rollers[:, None] * radial
    assert_allclose(wheel_velocity, np.tile([xm, ym], (3, 1)), atol=1e-9)


def test_frames_round_trip():
    xm, ym = frames.world_to_robot(0.3, -0.4, 1.1)
    assert_allclose(frames.robot_to_world(xm, ym, 1.1), (0.3, -0.4), atol=1e-12)
    # Facing +y (phi = 90 deg), world +x is the robot's right.
    assert_allclose(
        frames.world_to_robot(1.0, 0.0, math.pi / 2), (1.0, 0.0), atol=1e-12
    )
