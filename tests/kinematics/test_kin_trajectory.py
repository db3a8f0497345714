"""Trajectories (section 9.7): limits, rest at the ends, via points, no sway, dense paths."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from kinematics import (
    Limits,
    RobotParams,
    TrajectoryOptions,
    differential,
    peaks,
    plan_trajectory,
    trapezoidal_profile,
)
from kinematics.odometry import integrate_wheel_rates
from tests.kinematics.kin_helpers import (
    DIFFERENTIAL,
    HOLONOMIC,
    LECTURE_PATH,
    dense_trace,
    distance_to_polyline,
)

STOP = TrajectoryOptions(continuous=False)
CONTINUOUS = TrajectoryOptions(continuous=True)


# The fixtures are defined per module rather than in a conftest.py: with --doctest-modules
# every conftest.py is imported as a module named "conftest", and sibling ones collide.
@pytest.fixture(params=[HOLONOMIC, DIFFERENTIAL], ids=["holonomic", "differential"])
def robot(request) -> RobotParams:
    return request.param


@pytest.fixture
def lecture_path() -> np.ndarray:
    return LECTURE_PATH.copy()


def check_invariants(traj, path_end) -> None:
    """What every trajectory must satisfy, whatever the mode."""
    dt = traj.dt
    assert_allclose(traj.t, np.arange(len(traj.t)) * dt)
    assert traj.pose.shape == traj.velocity.shape == (len(traj.t), 3)
    assert (
        traj.wheel_rates.shape
        == traj.wheel_angles.shape
        == (len(traj.t), traj.robot.n_wheels)
    )
    # At rest at both ends, at the goal at the end.
    assert np.all(traj.velocity[0] == 0.0)
    assert np.all(traj.velocity[-1] == 0.0)
    assert np.all(traj.wheel_rates[[0, -1]] == 0.0)
    assert_allclose(traj.pose[-1, :2], path_end, atol=1e-9)
    # Every limit, with a relative slack for rounding only.
    assert peaks(traj).within(traj.limits, rtol=1e-6), peaks(traj)
    # Velocities are linear between samples: the poses are their trapezoid integral.
    assert_allclose(
        np.diff(traj.pose, axis=0),
        0.5 * dt * (traj.velocity[1:] + traj.velocity[:-1]),
        atol=1e-9,
    )
    # Wheel rates are the inverse kinematics of the velocity, eq. 9.5 / 9.9.
    v = traj.velocity
    assert_allclose(
        traj.wheel_rates,
        traj.robot.inverse(v[:, 0], v[:, 1], v[:, 2], traj.pose[:, 2]),
        atol=1e-9,
    )
    if traj.robot.kind == "differential":
        assert (
            np.max(
                np.abs(differential.sway_residual(v[:, 0], v[:, 1], traj.pose[:, 2]))
            )
            < 1e-9
        )


def rest_indices(traj) -> np.ndarray:
    return np.flatnonzero(np.all(traj.velocity == 0.0, axis=1))


# ---------------------------------------------------------------- trapezoidal profile


def test_trapezoid_hand_values():
    s, v = trapezoidal_profile(0.3, max_rate=0.5, max_acceleration=1.0, dt=0.1)
    assert_allclose(
        v, [0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.5, 0.4, 0.3, 0.2, 0.1, 0], atol=1e-12
    )
    assert_allclose(s[[0, -1]], [0.0, 0.3])


def test_short_distance_gives_a_triangle():
    _, v = trapezoidal_profile(0.09, max_rate=0.5, max_acceleration=1.0, dt=0.1)
    assert v.max() < 0.5  # never reaches the top speed
    assert np.count_nonzero(v == v.max()) == 1


def test_zero_distance_is_one_resting_sample():
    s, v = trapezoidal_profile(0.0, 1.0, 1.0, 0.05)
    assert s.tolist() == [0.0] and v.tolist() == [0.0]


@given(
    st.floats(1e-6, 20.0),
    st.floats(0.05, 3.0),
    st.floats(0.05, 5.0),
    st.sampled_from([0.01, 0.05, 0.1]),
)
def test_trapezoid_respects_limits_and_is_near_time_optimal(distance, vmax, amax, dt):
    s, v = trapezoidal_profile(distance, vmax, amax, dt)
    assert s[-1] == distance and s[0] == 0.0
    assert v[0] == 0.0 and v[-1] == 0.0
    assert np.all(np.diff(s) >= 0.0)
    assert v.max() <= vmax * (1 + 1e-8)
    assert np.max(np.abs(np.diff(v))) / dt <= amax * (1 + 1e-8)
    # Continuous time-optimal duration, plus at most two samples lost to rounding.
    t_opt = (
        distance / vmax + vmax / amax
        if distance >= vmax**2 / amax
        else 2 * math.sqrt(distance / amax)
    )
    assert (len(s) - 1) * dt <= t_opt + 2 * dt + 1e-9


def test_trapezoid_rejects_bad_arguments():
    with pytest.raises(ValueError, match="distance"):
        trapezoidal_profile(-1.0, 1.0, 1.0, 0.05)
    with pytest.raises(ValueError, match="max_rate"):
        trapezoidal_profile(1.0, 0.0, 1.0, 0.05)


# ---------------------------------------------------------------- stop mode


@pytest.mark.parametrize("heading", ["hold", "travel"])
def test_stop_mode_passes_and_stops_at_every_via_point(robot, lecture_path, heading):
    traj = plan_trajectory(
        lecture_path,
        robot,
        options=TrajectoryOptions(continuous=False, heading=heading),
    )
    check_invariants(traj, lecture_path[-1])
    assert not traj.continuous
    rest = traj.pose[rest_indices(traj), :2]
    for via in lecture_path:
        assert np.min(np.hypot(*(rest - via).T)) < 1e-9, via
    # Between via points the robot stays on the segment (straight-line motion).
    assert np.max(distance_to_polyline(traj.pose[:, :2], lecture_path)) < 1e-9


def test_stop_mode_duration_matches_the_sum_of_profiles():
    limits = Limits(max_speed=0.5, max_acceleration=0.5)
    path = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 0.1]])
    traj = plan_trajectory(path, HOLONOMIC, limits=limits, options=STOP)
    # 3 m: trapezoid 1 s + 6 s; 0.1 m: triangle 2 * sqrt(0.1 / 0.5) = 0.894 -> 0.9 s.
    n1 = len(trapezoidal_profile(3.0, 0.5, 0.5, 0.05)[0]) - 1
    n2 = len(trapezoidal_profile(0.1, 0.5, 0.5, 0.05)[0]) - 1
    assert traj.duration == pytest.approx((n1 + n2) * 0.05)
    assert traj.duration == pytest.approx(7.0 + 0.9)


def test_holonomic_hold_keeps_its_heading_and_translates_diagonally():
    path = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]])
    traj = plan_trajectory(
        path,
        HOLONOMIC,
        options=TrajectoryOptions(continuous=False, initial_heading=0.3),
    )
    assert np.all(traj.pose[:, 2] == 0.3)
    assert np.all(traj.velocity[:, 2] == 0.0)
    moving = np.hypot(traj.velocity[:, 0], traj.velocity[:, 1]) > 0
    # Sideways components: a holonomic robot may translate in any direction.
    assert (
        np.max(
            np.abs(
                differential.sway_residual(
                    traj.velocity[moving, 0], traj.velocity[moving, 1], 0.3
                )
            )
        )
        > 0.1
    )


def test_default_hold_heading_aligns_robot_and_world_frames():
    traj = plan_trajectory([[0, 0], [1, 0]], HOLONOMIC)
    assert_allclose(traj.pose[:, 2], math.pi / 2)


def test_holonomic_travel_faces_the_direction_of_travel():
    path = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]])
    traj = plan_trajectory(
        path, HOLONOMIC, options=TrajectoryOptions(continuous=False, heading="travel")
    )
    check_invariants(traj, path[-1])
    moving = np.hypot(traj.velocity[:, 0], traj.velocity[:, 1]) > 0
    sway = differential.sway_residual(
        traj.velocity[moving, 0], traj.velocity[moving, 1], traj.pose[moving, 2]
    )
    assert np.max(np.abs(sway)) < 1e-9
    assert traj.pose[-1, 2] == pytest.approx(-math.pi / 4)


def test_differential_turns_in_place_then_drives_straight():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    traj = plan_trajectory(path, DIFFERENTIAL, options=STOP)
    check_invariants(traj, path[-1])
    q = traj.wheel_rates
    speed = np.hypot(traj.velocity[:, 0], traj.velocity[:, 1])
    turning = (speed == 0.0) & (traj.velocity[:, 2] != 0.0)
    driving = (speed > 0.0) & (traj.velocity[:, 2] == 0.0)
    assert turning.any() and driving.any()
    assert not np.any(
        (speed > 0.0) & (traj.velocity[:, 2] != 0.0)
    )  # never both at once
    # Section 9.7.2: pure rotation is theta1_dot == theta2_dot; straight is theta1 == -theta2.
    assert_allclose(q[turning, 0], q[turning, 1], atol=1e-12)
    assert_allclose(
        q[turning, 0], DIFFERENTIAL.wheel_distance * traj.velocity[turning, 2] / 0.05
    )
    assert_allclose(q[driving, 0], -q[driving, 1], atol=1e-12)
    # The only turn is +90 degrees at (1, 0).
    assert_allclose(
        traj.pose[turning, :2], np.tile([1.0, 0.0], (turning.sum(), 1)), atol=1e-12
    )
    assert traj.pose[-1, 2] == pytest.approx(math.pi / 2)


def test_differential_turns_the_short_way_round():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, -1.0]])
    traj = plan_trajectory(path, DIFFERENTIAL, options=STOP)
    assert traj.pose[-1, 2] == pytest.approx(-math.pi / 2)
    assert np.all(traj.velocity[:, 2] <= 0.0)


def test_initial_and_final_heading_are_turned_to_in_place(robot):
    opts = TrajectoryOptions(
        continuous=False, heading="travel", initial_heading=math.pi, final_heading=0.5
    )
    traj = plan_trajectory([[0.0, 0.0], [0.0, 1.0]], robot, options=opts)
    check_invariants(traj, [0.0, 1.0])
    assert traj.pose[0, 2] == math.pi
    assert math.cos(traj.pose[-1, 2] - 0.5) == pytest.approx(1.0)
    assert np.hypot(*traj.velocity[1, :2]) == 0.0  # first it turns, it does not drive


def test_collinear_via_points_are_passed_without_stopping():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    traj = plan_trajectory(path, HOLONOMIC, options=STOP)
    assert rest_indices(traj).tolist() == [0, len(traj.t) - 1]
    assert (
        np.min(distance_to_polyline(np.array([[1.0, 0.0]]), traj.pose[:, :2])) < 1e-12
    )


# ---------------------------------------------------------------- continuous mode


def test_continuous_blends_corners_without_stopping(robot, lecture_path):
    traj = plan_trajectory(lecture_path, robot, options=CONTINUOUS)
    check_invariants(traj, lecture_path[-1])
    assert traj.continuous
    assert rest_indices(traj).tolist()[-1] == len(traj.t) - 1
    speed = np.hypot(traj.velocity[:, 0], traj.velocity[:, 1])
    assert np.all(speed[2:-2] > 0.0)  # no stop at the via points
    assert np.max(distance_to_polyline(traj.pose[:, :2], lecture_path)) <= 0.05 + 1e-6
    stop = plan_trajectory(lecture_path, robot, options=STOP)
    assert traj.duration < stop.duration


def test_corner_tolerance_bounds_the_deviation(robot):
    path = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    for tol in (0.01, 0.1):
        traj = plan_trajectory(
            path,
            robot,
            options=TrajectoryOptions(continuous=True, corner_tolerance=tol),
        )
        dev = np.max(distance_to_polyline(traj.pose[:, :2], path))
        assert 0.2 * tol < dev <= tol + 1e-6


def test_sharp_reversal_stops_even_in_continuous_mode(robot):
    path = np.array([[0.0, 0.0], [1.0, 0.0], [0.2, 0.1]])  # turns ~173 degrees
    traj = plan_trajectory(path, robot, options=CONTINUOUS)
    check_invariants(traj, path[-1])
    rest = traj.pose[rest_indices(traj), :2]
    assert np.min(np.hypot(*(rest - [1.0, 0.0]).T)) < 1e-9


def test_dense_trace_is_followed_continuously(robot):
    trace = dense_trace()
    traj = plan_trajectory(trace, robot)  # automatic mode detects the dense path
    check_invariants(traj, trace[-1])
    assert traj.continuous
    speed = np.hypot(traj.velocity[:, 0], traj.velocity[:, 1])
    assert np.all(speed[1:-1] > 0.0)  # never stops along the way
    assert np.max(distance_to_polyline(traj.pose[:, :2], trace)) <= 0.05 + 1e-6
    # Stopping at each of the 340 samples would take many times longer.
    stop = plan_trajectory(trace, robot, options=STOP)
    assert traj.duration < stop.duration / 5
    # The differential robot (and a holonomic robot facing its travel) turns smoothly.
    if robot.kind == "differential":
        assert peaks(traj).turn_rate > 0.1


def test_automatic_mode_keeps_stops_for_a_short_visibility_path(robot, lecture_path):
    assert not plan_trajectory(lecture_path, robot).continuous


def test_dense_zigzag_is_smoothed():
    x = np.linspace(0.0, 3.0, 200)
    zigzag = np.column_stack([x, 0.02 * (np.arange(200) % 2)])
    traj = plan_trajectory(zigzag, DIFFERENTIAL)
    check_invariants(traj, zigzag[-1])
    assert traj.continuous
    assert traj.duration < 15.0


# ---------------------------------------------------------------- degenerate paths


@pytest.mark.parametrize(
    "path",
    [
        [[1.0, 2.0]],
        [1.0, 2.0],
        [[1.0, 2.0], [1.0, 2.0], [1.0, 2.0]],
        [[0.0, 0.0], [1e-12, 0.0]],
    ],
    ids=["single", "flat-point", "repeated", "sub-nanometre"],
)
@pytest.mark.parametrize(
    "options",
    [STOP, CONTINUOUS, TrajectoryOptions()],
    ids=["stop", "continuous", "auto"],
)
def test_degenerate_paths_give_a_motion_at_rest(robot, path, options):
    traj = plan_trajectory(path, robot, options=options)
    assert len(traj.t) == 1 and traj.duration == 0.0
    assert np.all(traj.velocity == 0.0) and np.all(traj.wheel_rates == 0.0)
    assert_allclose(traj.pose[0, :2], np.reshape(path, (-1, 2))[0])
    pose, angles = traj.sample([0.0, 1.0, 5.0])
    assert pose.shape == (3, 3) and angles.shape == (3, robot.n_wheels)
    assert_allclose(pose, np.tile(traj.pose[0], (3, 1)))


@pytest.mark.parametrize("options", [STOP, CONTINUOUS], ids=["stop", "continuous"])
def test_zero_length_segments_are_skipped(robot, options):
    path = np.array(
        [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 1.0]]
    )
    traj = plan_trajectory(path, robot, options=options)
    check_invariants(traj, [1.0, 1.0])
    assert traj.path.shape == (3, 2)


def test_single_point_with_final_heading_turns_in_place():
    traj = plan_trajectory(
        [[2.0, 3.0]],
        DIFFERENTIAL,
        options=TrajectoryOptions(initial_heading=0.0, final_heading=1.0),
    )
    check_invariants(traj, [2.0, 3.0])
    assert traj.pose[-1, 2] == pytest.approx(1.0)
    assert_allclose(traj.wheel_rates[:, 0], traj.wheel_rates[:, 1])


@pytest.mark.parametrize(
    ("path", "match"),
    [
        (np.zeros((0, 2)), "N >= 1"),
        (np.zeros((3, 3)), r"\(N, 2\)"),
        ([[0.0, 0.0], [np.nan, 1.0]], "NaN"),
    ],
)
def test_malformed_paths_raise(path, match):
    with pytest.raises(ValueError, match=match):
        plan_trajectory(path, HOLONOMIC)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dt": 0.0}, "dt"),
        ({"heading": "sideways"}, "heading"),
        ({"final_heading": math.inf}, "final_heading"),
    ],
)
def test_bad_options_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        TrajectoryOptions(**kwargs)


def test_bad_limits_raise():
    with pytest.raises(ValueError, match="max_turn_rate"):
        Limits(max_turn_rate=-1.0)


# ---------------------------------------------------------------- sampling and data


def test_sample_at_sample_times_returns_the_samples(robot, lecture_path):
    traj = plan_trajectory(lecture_path, robot, options=STOP)
    pose, angles = traj.sample(traj.t)
    assert_allclose(pose, traj.pose, atol=1e-12)
    assert_allclose(angles, traj.wheel_angles, atol=1e-9)


def test_sample_between_samples_follows_the_velocity(robot, lecture_path):
    traj = plan_trajectory(lecture_path, robot, options=CONTINUOUS)
    k = np.arange(1, len(traj.t) - 1)
    eps = 1e-6
    p1, a1 = traj.sample(traj.t[k] + eps)
    p0, a0 = traj.sample(traj.t[k] - eps)
    assert_allclose((p1 - p0) / (2 * eps), traj.velocity[k], atol=1e-5)
    assert_allclose((a1 - a0) / (2 * eps), traj.wheel_rates[k], atol=1e-3)
    # Midpoints lie between neighbouring samples (no overshoot on a straight stretch).
    mid, _ = traj.sample(traj.t[:-1] + traj.dt / 2)
    step = np.hypot(*np.diff(traj.pose[:, :2], axis=0).T)
    assert np.all(np.hypot(*(mid[:, :2] - traj.pose[:-1, :2]).T) <= step + 1e-12)


def test_sample_clamps_outside_the_motion(lecture_path):
    traj = plan_trajectory(lecture_path, HOLONOMIC)
    before, _ = traj.sample(-3.0)
    after, angles = traj.sample(traj.duration + 10.0)
    assert_allclose(before, traj.pose[0])
    assert_allclose(after, traj.pose[-1])
    assert_allclose(angles, traj.wheel_angles[-1])


def test_wheel_angles_integrate_the_rates(lecture_path):
    traj = plan_trajectory(lecture_path, DIFFERENTIAL)
    steps = 0.5 * traj.dt * (traj.wheel_rates[1:] + traj.wheel_rates[:-1])
    assert_allclose(np.diff(traj.wheel_angles, axis=0), steps, atol=1e-12)
    assert np.all(traj.wheel_angles[0] == 0.0)
    # Driving forward a distance d turns wheel 1 by +d/r and wheel 2 by -d/r (plus turns).
    assert traj.wheel_angles[-1, 0] - traj.wheel_angles[-1, 1] == pytest.approx(
        2
        * np.sum(np.hypot(*np.diff(lecture_path, axis=0).T))
        / DIFFERENTIAL.wheel_radius
    )


def test_arrays_are_read_only(lecture_path):
    traj = plan_trajectory(lecture_path, HOLONOMIC)
    with pytest.raises(ValueError, match="read-only"):
        traj.pose[0, 0] = 5.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        traj.dt = 1.0  # type: ignore[misc]


def test_configurable_sample_period(lecture_path):
    traj = plan_trajectory(
        lecture_path, DIFFERENTIAL, options=TrajectoryOptions(dt=0.02)
    )
    check_invariants(traj, lecture_path[-1])
    assert traj.dt == 0.02
    assert_allclose(np.diff(traj.t), 0.02)


def test_robot_params_validate():
    with pytest.raises(ValueError, match="kind"):
        RobotParams("tracked")  # pyright: ignore[reportArgumentType]
    with pytest.raises(ValueError, match="fixed wheel angles"):
        RobotParams("differential", betas=(0.0, 1.0))
    with pytest.raises(ValueError, match="singular"):
        RobotParams("holonomic", betas=(0.0, 0.0, 1.0))
    # A list is normalised to a tuple, so equal robots compare equal.
    as_list = RobotParams(betas=[0.1, 2.0, 4.0])  # pyright: ignore[reportArgumentType]
    assert as_list == RobotParams(betas=(0.1, 2.0, 4.0))


# ---------------------------------------------------------------- properties

coordinate = st.floats(-5.0, 5.0, allow_nan=False)
paths = st.lists(st.tuples(coordinate, coordinate), min_size=1, max_size=6).map(
    np.array
)
limits = st.builds(
    Limits,
    max_speed=st.floats(0.1, 2.0),
    max_acceleration=st.floats(0.1, 3.0),
    max_turn_rate=st.floats(0.3, 4.0),
    max_angular_acceleration=st.floats(0.3, 8.0),
)
robots = st.sampled_from([HOLONOMIC, DIFFERENTIAL, RobotParams(betas=(0.0, 2.0, 4.0))])
options = st.builds(
    TrajectoryOptions,
    continuous=st.sampled_from([False, True, None]),
    heading=st.sampled_from(["hold", "travel"]),
    initial_heading=st.none() | st.floats(-4.0, 4.0),
)


@settings(max_examples=120, deadline=None)
@given(paths, robots, limits, options)
def test_every_trajectory_respects_limits_rests_at_ends_and_reaches_the_goal(
    path, robot, lim, opts
):
    traj = plan_trajectory(path, robot, limits=lim, options=opts)
    check_invariants(traj, path[-1])
    assert_allclose(traj.pose[0, :2], path[0])
    if not traj.continuous:
        rest = traj.pose[rest_indices(traj), :2]
        for via in traj.path:
            on_path = np.min(distance_to_polyline(via[None], traj.pose[:, :2])) < 1e-9
            stopped = np.min(np.hypot(*(rest - via).T)) < 1e-9
            assert on_path and (stopped or len(traj.path) > 2)
    # The odometry check: the wheel rates, integrated, are the motion.
    assert np.max(np.abs(integrate_wheel_rates(traj) - traj.pose)) < 1e-6


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 1000), robots, st.floats(0.0005, 0.01))
def test_dense_random_traces_are_continuous_within_limits(seed, robot, noise):
    trace = dense_trace(n=200, noise=noise, seed=seed)
    traj = plan_trajectory(trace, robot)
    check_invariants(traj, trace[-1])
    assert traj.continuous
    assert np.max(distance_to_polyline(traj.pose[:, :2], trace)) <= 0.05 + 1e-6
