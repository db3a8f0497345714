"""Live DSB: the robot decides every dt in the scene as it is at that moment.

Proofs asked for: with static obstacles the live path is the planner's DSB path (same
events in the same order, positions within tracking tolerance); with moving obstacles the
robot is outside every expanded obstacle at every step (checked independently with
shapely), reaches the goal when the way opens, and repeats bit for bit; wheel limits are
never exceeded and odometry from the commanded rates reproduces the path.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from shapely import LineString, Polygon

from kinematics import RobotParams
from kinematics.wheel_limits import WheelLimits, within
from planners.api import plan_all
from planners.bug.live import LiveOptions, live_start, live_step, run_live
from planners.registry import PlanOptions
from planners.scene import Robot, Scene, load_scene, scene_at
from planners.scene.motion import Motion
from planners.space.expansion import DEFAULT_ARC_STEP
from tests.conftest import SCENARIOS

STATIC = [p for p in SCENARIOS if not load_scene(p).motions]
MOVING = [p for p in SCENARIOS if load_scene(p).motions]
# Hausdorff distance allowed between the live path and the planner's: the planner
# simplifies its walk (nearly collinear vertices merged), the live robot drives the raw one.
TRACKING = 1e-3


def _labels(events):
    return [e.label for e in events if e.kind in ("hit", "leave", "local_min")]


@pytest.mark.parametrize("rule", ["tangent_bug", "chapter"])
@pytest.mark.parametrize("sensor_range", [0.6, 2.0])
@pytest.mark.parametrize("path", STATIC, ids=[p.stem for p in STATIC])
def test_static_live_path_is_the_planners(path, sensor_range, rule):
    scene = dataclasses.replace(load_scene(path), sensor_range=sensor_range)
    planned = plan_all(scene, ["dsb"], PlanOptions(leave_rule=rule))["dsb"]
    live = run_live(scene, LiveOptions(leave_rule=rule), duration=600.0)
    assert live.status == planned.status
    assert _labels(live.events) == [e.label for e in planned.events]
    assert [d.box for d in live.decisions] == [d.box for d in planned.decisions]
    gap = LineString(planned.path).hausdorff_distance(LineString(live.path))
    assert gap <= TRACKING
    assert not any(s.over_limit for s in live.steps)


def _clearance(scene: Scene, t: float, xy) -> float:
    """Distance [m] from the robot's centre to the nearest obstacle at time t (shapely)."""
    now = scene_at(scene, t)
    p = shapely.Point(xy)
    d = min((o.distance(p) for o in now.obstacles), default=math.inf)
    if now.boundary is not None:
        d = min(d, now.boundary.exterior.distance(p))
    return d


def _robot_kinds(path):
    scene = load_scene(path)
    return [
        dataclasses.replace(scene, robot=dataclasses.replace(scene.robot, kind=k))
        for k in ("holonomic", "differential")
    ]


@pytest.mark.parametrize("kind", [0, 1], ids=["holonomic", "differential"])
@pytest.mark.parametrize("path", MOVING, ids=[p.stem for p in MOVING])
def test_moving_scenarios_keep_out_and_arrive(path, kind):
    scene = _robot_kinds(path)[kind]
    trace = run_live(scene, duration=120.0)
    assert trace.status == "reached", trace.events
    assert trace.path[-1].tolist() == list(scene.goal)
    # The disk model's arcs are polygons with every vertex on the true circle: the
    # robot keeps at least radius * cos(arc_step / 2) from every obstacle.
    need = scene.robot.radius * math.cos(DEFAULT_ARC_STEP / 2) - 1e-9
    for step in trace.steps:
        assert _clearance(scene, step.t, step.pose[:2]) >= need, step
    assert not any(s.over_limit for s in trace.steps)
    again = run_live(scene, duration=120.0)
    assert again.to_json() == trace.to_json()  # bit for bit


def test_the_door_makes_the_robot_wait_then_pass():
    scene = load_scene(next(p for p in MOVING if "door" in p.stem))
    trace = run_live(scene, duration=120.0)
    kinds = [e.kind for e in trace.events]
    assert "local_min" in kinds  # the door was shut when it came: it followed the wall
    door = scene.motions[0].obstacle
    # It went through the gap: it crossed the wall's line while the door was open.
    crossing = next(s for s in trace.steps if s.pose[0] > 5.0)
    offset = crossing.offsets[0]
    assert offset[1] > -0.6, "the door was open enough when it crossed"
    assert door == 2


def _slider(speed: float) -> Scene:
    """A block that sweeps over the robot's start, then up and round (a loop)."""
    block = Polygon([(-1.2, -0.25), (-0.7, -0.25), (-0.7, 0.25), (-1.2, 0.25)])
    return Scene(
        obstacles=(block,),
        start=(0.0, 0.0),
        goal=(3.0, 0.0),
        boundary=Polygon([(-4, -4), (5, -4), (5, 4), (-4, 4)]),
        robot=Robot(radius=0.2),
        sensor_range=1.0,
        motions=(Motion(0, ((1.5, 0.0), (1.5, 3.0), (0.0, 3.0)), speed=speed),),
    )


def test_an_obstacle_reaching_the_robot_stops_it_in_words_then_it_goes_on():
    scene = _slider(2.0)
    trace = run_live(scene, duration=60.0)
    blocked = [s for s in trace.steps if s.status == "blocked"]
    assert blocked
    assert blocked[0].message.startswith("stopped: obstacle reached the robot")
    assert "obstacle 1" in blocked[0].message
    kinds = [e.kind for e in trace.events]
    assert kinds.index("blocked") < kinds.index("clear")
    assert trace.status == "reached"
    # While blocked it does not move.
    for s in blocked:
        assert s.velocity == (0.0, 0.0, 0.0)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(speed=st.floats(0.05, 5.0), dx=st.floats(-2.0, 2.0))
def test_moving_obstacles_never_raise(speed, dx):
    scene = _slider(speed)
    scene = dataclasses.replace(scene, goal=(3.0 + dx * 0.4, dx))
    trace = run_live(scene, duration=15.0)
    assert trace.status in ("driving", "blocked", "waiting", "reached")


# --------------------------------------------------------------------------- wheels


def _odometry(trace, robot: Robot) -> np.ndarray:
    """Integrate the commanded wheel rates with the forward kinematics (eq. 9.6, 9.11)."""
    params = RobotParams.from_robot(robot)
    pose = np.array(trace.start, dtype=np.float64)
    out = [pose.copy()]
    for s in trace.steps:
        # Each period's command is constant; the holonomic robot holds its heading and
        # the differential one either turns in place or drives straight: one Euler step
        # is the exact motion.
        xdot, ydot, phidot = params.forward(np.asarray(s.rates), pose[2])
        pose = pose + trace.dt * np.array([float(xdot), float(ydot), float(phidot)])
        out.append(pose.copy())
    return np.array(out)


SQUARE = Polygon([(0, 0), (1.5, 0), (1.5, 1.5), (0, 1.5)])


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    kind=st.sampled_from(["holonomic", "differential"]),
    rate=st.one_of(st.just(math.inf), st.floats(3.0, 40.0)),
    acc=st.one_of(st.just(math.inf), st.floats(2.0, 60.0)),
    gy=st.floats(-1.0, 2.5),
    sensor_range=st.sampled_from([0.6, 2.0, math.inf]),
)
def test_wheel_limits_hold_and_odometry_reproduces_the_path(
    kind, rate, acc, gy, sensor_range
):
    robot = Robot(kind=kind, radius=0.2, wheel_radius=0.05, wheel_distance=0.2)
    scene = Scene(
        obstacles=(SQUARE,),
        start=(-1.0, 0.75),
        goal=(2.6, gy),
        robot=robot,
        sensor_range=sensor_range,
    )
    limits = WheelLimits(max_rate=rate, max_acceleration=acc)
    trace = run_live(scene, LiveOptions(wheels=limits), duration=200.0)
    assert trace.status == "reached"
    rates = np.vstack([np.zeros((1, len(trace.steps[0].rates))), trace.rates])
    assert within(rates, trace.dt, limits), "a commanded wheel rate broke a limit"
    assert not any(s.over_limit for s in trace.steps)
    np.testing.assert_allclose(_odometry(trace, robot), trace.poses, atol=1e-9)


def test_the_differential_robot_reverses_where_that_is_shorter():
    robot = Robot(
        kind="differential", radius=0.2, wheel_radius=0.05, wheel_distance=0.2
    )
    scene = Scene(obstacles=(), start=(0.0, 0.0), goal=(-2.0, 0.0), robot=robot)
    trace = run_live(scene, duration=30.0, phi=0.0)  # facing away from the goal
    assert trace.status == "reached"
    assert all(abs(p[2]) < 1e-12 for p in trace.poses)  # never turned: drove backwards
    forward = RobotParams("differential", wheel_radius=0.05, wheel_distance=0.2)
    assert forward.forward(np.asarray(trace.steps[20].rates), 0.0)[0] < 0


def test_a_step_is_pure():
    scene = load_scene(STATIC[0])
    s0 = live_start(scene)
    a, b = live_step(s0, scene), live_step(s0, scene)
    assert a.pose == b.pose and a.rates == b.rates
    assert s0.t == 0.0 and s0.pose == (scene.start[0], scene.start[1], s0.pose[2])


def test_the_record_is_json():
    scene = load_scene(MOVING[0])
    trace = run_live(scene, duration=5.0)
    data = json.loads(trace.to_json())
    assert data["format"] == "live-trace-1"
    assert len(data["steps"]) == len(trace.steps) == 100
    assert data["steps"][10]["offsets"] == [list(o) for o in trace.steps[10].offsets]
    assert trace.step_at(0.0) is None
    assert trace.step_at(0.5) is trace.steps[9]
