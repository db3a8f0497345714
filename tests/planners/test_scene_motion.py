"""Moving obstacles in scenario files: validation, round trip, the scene at a time."""

from __future__ import annotations

import dataclasses
import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import Polygon

from planners.scene import (
    ScenarioError,
    delete_obstacle,
    load_scene,
    scene_at,
    scene_from_dict,
    scene_to_dict,
)
from planners.scene.motion import Motion, motion_offset
from tests.conftest import SCENARIOS

SQ = [[0, 0], [1, 0], [1, 1], [0, 1]]


def _data(motions, n=2):
    return {
        "format": 1,
        "obstacles": [[[x + 3 * i, y] for x, y in SQ] for i in range(n)],
        "start": [-2, 0],
        "goal": [9, 0],
        "motions": motions,
    }


@pytest.mark.parametrize(
    ("motions", "field", "problem"),
    [
        ("x", "motions", "expected a list of motions"),
        ([3], "motions[0]", "expected an object"),
        ([{"obstacle": 0, "waypoints": [[1, 0]]}], "motions[0].speed", "missing"),
        (
            [{"obstacle": 5, "waypoints": [[1, 0]], "speed": 1}],
            "motions[0].obstacle",
            "no obstacle 5",
        ),
        (
            [{"obstacle": True, "waypoints": [[1, 0]], "speed": 1}],
            "motions[0].obstacle",
            "expected an index",
        ),
        (
            [{"obstacle": 0, "waypoints": [], "speed": 1}],
            "motions[0].waypoints",
            "non-empty",
        ),
        (
            [{"obstacle": 0, "waypoints": [[1, "a"]], "speed": 1}],
            "motions[0].waypoints[0][1]",
            "expected a number",
        ),
        (
            [{"obstacle": 0, "waypoints": [[1, 0]], "speed": 0}],
            "motions[0].speed",
            "must be positive",
        ),
        (
            [{"obstacle": 0, "waypoints": [[1, 0]], "speed": 1, "mode": "spin"}],
            "motions[0].mode",
            "expected one of loop, back_and_forth",
        ),
        (
            [{"obstacle": 0, "waypoints": [[1, 0]], "speed": 1, "pause": -1}],
            "motions[0].pause",
            "must be >= 0",
        ),
        (
            [{"obstacle": 0, "waypoints": [[1, 0]], "speed": 1, "colour": 1}],
            "motions[0].colour",
            "unknown key",
        ),
        (
            [
                {"obstacle": 1, "waypoints": [[1, 0]], "speed": 1},
                {"obstacle": 1, "waypoints": [[0, 1]], "speed": 1},
            ],
            "motions[1].obstacle",
            "already has a motion",
        ),
    ],
)
def test_bad_motions_are_one_line_errors_naming_file_and_field(motions, field, problem):
    with pytest.raises(ScenarioError) as err:
        scene_from_dict(_data(motions), "door.json")
    text = str(err.value)
    assert text.startswith(f"door.json: {field}: ")
    assert problem in text
    assert "\n" not in text


def test_round_trip_and_static_files_unchanged():
    m = {
        "obstacle": 1,
        "waypoints": [[0.0, 2.0]],
        "speed": 0.5,
        "mode": "loop",
        "pause": 1.0,
    }
    scene = scene_from_dict(_data([m]))
    assert scene_from_dict(scene_to_dict(scene)) == scene
    assert scene_to_dict(scene)["motions"] == [m]
    static = scene_from_dict(_data([]))
    assert "motions" not in scene_to_dict(static)
    assert "max_wheel_rate" not in scene_to_dict(static)["robot"]


def test_scene_at_zero_is_the_file_and_shipped_motions_load():
    for path in SCENARIOS:
        scene = load_scene(path)
        assert scene_at(scene, 0.0).obstacles == scene.obstacles
    assert sum(1 for p in SCENARIOS if load_scene(p).motions) >= 2


def test_deleting_an_obstacle_renumbers_the_motions():
    scene = scene_from_dict(
        _data(
            [
                {"obstacle": 2, "waypoints": [[0, 1]], "speed": 1},
                {"obstacle": 0, "waypoints": [[0, 1]], "speed": 1},
            ],
            n=3,
        )
    )
    after = delete_obstacle(scene, 1)
    assert [m.obstacle for m in after.motions] == [1, 0]
    assert [m.obstacle for m in delete_obstacle(scene, 0).motions] == [1]
    assert [m.obstacle for m in delete_obstacle(scene, -1).motions] == [0]


def _reference_offset(m: Motion, t: float) -> tuple[float, float]:
    """Walk the cycle in small time steps (slow and obviously right)."""
    if t <= 0 or m.period <= 0:
        return (0.0, 0.0)
    t = t % m.period
    cycle = m.cycle
    clock = 0.0
    for a, b in itertools.pairwise(cycle):
        if t < clock + m.pause:
            return a
        clock += m.pause
        leg = math.dist(a, b) / m.speed
        if t < clock + leg:
            f = (t - clock) / leg
            return (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]))
        clock += leg
    return cycle[-1]


@settings(max_examples=200, deadline=None)
@given(
    pts=st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3)), min_size=1, max_size=4),
    speed=st.floats(0.1, 3.0),
    pause=st.floats(0.0, 2.0),
    mode=st.sampled_from(["loop", "back_and_forth"]),
    t=st.floats(0.0, 100.0),
)
def test_offsets_follow_the_waypoints(pts, speed, pause, mode, t):
    m = Motion(0, tuple(pts), speed=speed, mode=mode, pause=pause)
    got, want = motion_offset(m, t), _reference_offset(m, t)
    assert math.dist(got, want) <= 1e-6 * max(1.0, speed * m.period)
    # Never farther from the start than the farthest waypoint.
    far = max(math.hypot(*p) for p in pts)
    assert math.hypot(*got) <= far + 1e-9
    scene = scene_from_dict(_data([]))
    moved = scene_at(dataclasses.replace(scene, motions=(m,)), t)
    assert moved.obstacles[0].equals(Polygon([(x + got[0], y + got[1]) for x, y in SQ]))
