"""Where a goal-seeking move switches its decision: the geometric guess against the search.

:func:`planners.bug._seek._switch_point` asks the sensor on either side of a guessed
switch first (a range point turning into a corner, the border beyond the chosen corner
coming into view) and searches the whole move only when the sensor disagrees. The guess
is a shortcut, never a decision: with it switched off (the plain bisection on the
sensor, the slow reference) every run must take the same decisions, at the same
points up to the search's resolution.
"""

from __future__ import annotations

import math
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planners import load_scene
from planners.bug import _seek as bug_seek
from planners.bug._context import BugParams
from planners.bug.tangent_bug import BugTrace, _context, run
from planners.space.expansion import configuration_space
from tests.conftest import random_scenes, scene_dict


def _arc_scene(vertices: int, radius: float, *, robot: float):
    """A finely drawn circle between start and goal: each vertex is a decision."""
    angles = np.linspace(0.0, 2.0 * math.pi, vertices, endpoint=False)
    ring = np.column_stack([radius * np.cos(angles), radius * np.sin(angles)])
    start = (-radius - 2.0, 0.0)
    goal = (radius + 2.0, 0.1 * radius)
    return load_scene(scene_dict([ring.tolist()], start, goal, radius=robot))


def _space(scene):
    return configuration_space(
        scene.obstacles, scene.robot.radius, scene.expansion, scene.boundary
    )


def _runs(scene, sensor_range: float, rule: str) -> tuple[BugTrace, BugTrace, float]:
    """Run with the guess and without it; also return the search's resolution [m]."""
    space = _space(scene)
    params = BugParams(goal=scene.goal, sensor_range=sensor_range, leave_rule=rule)
    guessed = run(space, scene.start, params)
    return guessed, _searched(space, scene.start, params), _resolution(space, params)


def _searched(space, start, params: BugParams) -> BugTrace:
    """The run without the guess: every switch is found by the search."""
    with (
        mock.patch.object(bug_seek, "_at_guess", return_value=None),
        mock.patch.object(bug_seek, "_beyond_corner", return_value=None),
    ):
        return run(space, start, params)


def _resolution(space, params: BugParams) -> float:
    """The search's resolution [m]: its step, halved ``refine`` times."""
    return _context(space, params).seek_step / 2.0**params.refine


def _assert_same_decisions(guessed: BugTrace, searched: BugTrace, resolution: float):
    assert guessed.status == searched.status
    assert [d.box for d in guessed.decisions] == [d.box for d in searched.decisions]
    assert [e.label for e in guessed.events] == [e.label for e in searched.events]
    # Each decision is taken where the reference took it, up to the resolution of the
    # search (the reference's switch lies up to one resolution past the true one), and
    # heads for the same O_i (a range point slides with the robot, as far).
    slack = 2.0 * resolution + 1e-9
    for a, b in zip(guessed.decisions, searched.decisions, strict=True):
        assert math.dist(a.position, b.position) <= slack
        assert (a.chosen is None) == (b.chosen is None)
        if a.chosen is not None and b.chosen is not None:
            assert math.dist(a.chosen, b.chosen) <= 2.0 * slack
    if guessed.length is not None and searched.length is not None:
        # Each switch moved by up to the resolution changes the path by twice that.
        bound = 2.0 * resolution * len(guessed.decisions) + 1e-9
        assert abs(guessed.length - searched.length) <= bound


@settings(max_examples=25)
@given(
    vertices=st.integers(24, 400),
    radius=st.floats(0.5, 4.0),
    robot=st.sampled_from([0.0, 0.2]),
    sensor_range=st.sampled_from([0.5, 2.0, math.inf]),
    rule=st.sampled_from(["tangent_bug", "chapter"]),
)
def test_the_guessed_switch_takes_the_decisions_of_the_search(
    vertices, radius, robot, sensor_range, rule
):
    scene = _arc_scene(vertices, radius, robot=robot)
    guessed, searched, resolution = _runs(scene, sensor_range, rule)
    _assert_same_decisions(guessed, searched, resolution)


@settings(max_examples=40)
@given(
    scene=st.one_of(random_scenes(), random_scenes(grid=True)),
    sensor_range=st.sampled_from([0.5, 1.5, math.inf]),
    rule=st.sampled_from(["tangent_bug", "chapter"]),
)
def test_on_random_scenes_the_guess_takes_the_decisions_of_the_search(
    scene, sensor_range, rule
):
    space = _space(scene)
    if space.contains_blocked(np.array([scene.start, scene.goal])).any():
        return  # an invalid scene: nothing is planned
    guessed, searched, resolution = _runs(scene, sensor_range, rule)
    _assert_same_decisions(guessed, searched, resolution)


@pytest.mark.parametrize("sensor_range", [0.5, 1.0, 3.0, math.inf])
@pytest.mark.parametrize("rule", ["tangent_bug", "chapter"])
def test_shipped_scenarios_take_the_decisions_of_the_search(
    shipped_scenes, sensor_range, rule
):
    for scene in shipped_scenes:
        guessed, searched, resolution = _runs(scene, sensor_range, rule)
        _assert_same_decisions(guessed, searched, resolution)


@pytest.fixture(scope="module")
def shipped_scenes():
    from pathlib import Path

    root = Path(__file__).resolve().parents[2] / "static_scenarios"
    return [load_scene(str(p)) for p in sorted(root.glob("*.json"))]


def _room_circle(vertices: int):
    """The big-scene benchmark's circle (radius 10 m in a 40 m room), ``vertices`` fine."""
    angles = np.linspace(0.0, 2.0 * math.pi, vertices, endpoint=False)
    ring = np.column_stack([20 + 10 * np.cos(angles), 20 + 10 * np.sin(angles)])
    room = [[0, 0], [40, 0], [40, 40], [0, 40]]
    return load_scene(
        scene_dict(
            [ring.tolist()], (3.0, 20.0), (37.0, 20.5), radius=0.3, boundary=room
        )
    )


def test_rounding_a_fine_circle_the_guess_is_confirmed_at_most_corners():
    """On the big-scene benchmark's circle of 10,000 vertices (corners 6 mm apart) the
    robot touches the next edge's line, within eps, before it reaches the corner: nearly
    every switch is confirmed by the two readings around the guess (``_at_guess`` returns
    it), the sensor is read about twice a step, and the decisions are the search's.

    On coarser arcs (here at 5,000 vertices and fewer) the switch is at the corner, the
    end of the move, and the search finds it with two readings as before; where the guess
    falls within the last gap of its move, the search runs in full. The saving depends
    on the geometry."""
    scene = _room_circle(10_000)
    space = _space(scene)
    params = BugParams(goal=scene.goal, sensor_range=2.0)
    readings, confirmed = [], []
    decide, at_guess = bug_seek._decide, bug_seek._at_guess

    def counted(*args, **kwargs):
        readings.append(1)
        return decide(*args, **kwargs)

    def confirming(*args, **kwargs):
        found = at_guess(*args, **kwargs)
        confirmed.append(found is not None)
        return found

    with (
        mock.patch.object(bug_seek, "_decide", counted),
        mock.patch.object(bug_seek, "_at_guess", confirming),
    ):
        trace = run(space, scene.start, params)
    choices = sum(d.box == "choose_O_i" for d in trace.decisions)
    assert trace.status == "reached"
    assert choices > 2500  # one per corner on the way round
    assert sum(confirmed) >= 0.9 * choices
    assert len(readings) <= 2.2 * choices
    # The run counted above is the guessed one: the search's decisions are the same.
    searched = _searched(space, scene.start, params)
    _assert_same_decisions(trace, searched, _resolution(space, params))
