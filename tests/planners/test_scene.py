import copy
import json
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import Polygon

from planners import ScenarioError, load_scene, save_scene, scene_problems
from planners.scene import (
    Scene,
    add_obstacle,
    delete_obstacle,
    delete_vertex,
    insert_vertex,
    move_goal,
    move_obstacle,
    move_start,
    move_vertex,
    replace_robot,
    scene_from_text,
    scene_to_dict,
)
from tests.conftest import SCENARIOS

GOOD = {
    "format": 1,
    "name": "Two convex obstacles",
    "description": "Chapter 9, first example environment.",
    "boundary": [[0, 0], [10, 0], [10, 8], [0, 8]],
    "obstacles": [[[2, 2], [4, 2], [4, 5], [2, 5]], [[6, 3], [8, 3], [7, 6]]],
    "start": [1, 1],
    "goal": [9, 7],
    "robot": {
        "kind": "holonomic",
        "radius": 0.3,
        "wheel_radius": 0.05,
        "wheel_distance": 0.25,
    },
    "expansion": "disk",
    "sensor_range": 2.0,
}


def test_design_example_loads():
    scene = load_scene(GOOD)
    assert scene.name == "Two convex obstacles"
    assert scene.start == (1.0, 1.0) and scene.goal == (9.0, 7.0)
    assert scene.robot.radius == 0.3 and scene.robot.wheel_distance == 0.25
    assert scene.boundary is not None and scene.boundary.area == 80
    assert [o.area for o in scene.obstacles] == [6.0, 3.0]


def test_every_shipped_scenario_loads_with_name_and_description(scenario_path):
    scene = load_scene(scenario_path)
    assert scene.name and len(scene.description) > 40
    assert scene_problems(scene) == []


def test_shipped_scenarios_cover_the_chapter():
    stems = [p.stem for p in SCENARIOS]
    assert len(stems) >= 8
    for key in ("two_convex", "three_obstacles", "pocket", "sensor", "enclosed", "gap"):
        assert any(key in s for s in stems), key


def test_closed_ring_is_accepted():
    data = copy.deepcopy(GOOD)
    data["obstacles"][0].append([2, 2])
    assert load_scene(data).obstacles[0] == load_scene(GOOD).obstacles[0]


def test_save_then_load_round_trips(tmp_path):
    scene = load_scene(GOOD)
    path = save_scene(scene, tmp_path / "scene.json")
    assert load_scene(path) == scene
    assert json.loads(path.read_text())["format"] == 1
    assert not list(tmp_path.glob(".*tmp")), "temporary file left behind"


def test_save_is_atomic_and_refuses_invalid_scene(tmp_path):
    path = save_scene(load_scene(GOOD), tmp_path / "scene.json")
    before = path.read_text()
    broken = move_vertex(load_scene(GOOD), 0, 0, (4, 5.5))  # bow-tie
    with pytest.raises(ScenarioError, match="obstacle 1"):
        save_scene(broken, path)
    assert path.read_text() == before


def test_save_into_missing_folder_names_the_file(tmp_path):
    with pytest.raises(ScenarioError, match="nope"):
        save_scene(load_scene(GOOD), tmp_path / "nope" / "scene.json")


def _mutate(path, value):
    data = copy.deepcopy(GOOD)
    target = data
    for key in path[:-1]:
        target = target[key]
    if value is KeyError:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return data


@pytest.mark.parametrize(
    ("path", "value", "field", "message"),
    [
        (("colour",), "red", "colour", "unknown key"),
        (("robot", "speed"), 1, "robot.speed", "unknown key"),
        (("start",), [1, "a"], "start[1]", "expected a number"),
        (("start",), [1], "start", "expected a point"),
        (("goal",), [1, True], "goal[1]", "expected a number"),
        (("obstacles",), {"a": 1}, "obstacles", "list of polygons"),
        (("obstacles", 1), [[6, 3], [8, 3]], "obstacles[1]", "at least 3 distinct"),
        (
            ("obstacles", 1),
            [[6, 3], [8, 3], [6, 3]],
            "obstacles[1]",
            "at least 3 distinct",
        ),
        (
            ("obstacles", 0),
            [[2, 2], [4, 5], [4, 2], [2, 5]],
            "obstacles[0]",
            "intersects itself",
        ),
        (("obstacles", 0), [[0, 0], [1, 1], [2, 2]], "obstacles[0]", "zero area"),
        (("obstacles", 0, 1), [4, float("nan")], "obstacles[0][1][1]", "finite"),
        (("obstacles", 0, 1), [float("inf"), 2], "obstacles[0][1][0]", "finite"),
        (("boundary",), [[0, 0], [10, 0]], "boundary", "at least 3 distinct"),
        (("robot", "radius"), -0.1, "robot.radius", "non-negative"),
        (("robot", "wheel_radius"), 0, "robot.wheel_radius", "positive"),
        (("robot", "kind"), "tank", "robot.kind", "holonomic, differential"),
        (("robot",), [1, 2], "robot", "expected an object"),
        (("expansion",), "circle", "expansion", "disk, square"),
        (("sensor_range",), 0, "sensor_range", "positive"),
        (("sensor_range",), "far", "sensor_range", "expected a number"),
        (("format",), 2, "format", "expected 1"),
        (("name",), 3, "name", "expected a string"),
        (("goal",), KeyError, "goal", "missing"),
    ],
)
def test_malformed_scenario_names_file_and_field(tmp_path, path, value, field, message):
    file = tmp_path / "bad.json"
    file.write_text(json.dumps(_mutate(path, value)))
    with pytest.raises(ScenarioError) as error:
        load_scene(file)
    text = str(error.value)
    assert text.startswith(f"{file}: {field}: "), text
    assert message in text


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"format": 1,', "not valid JSON"),
        (
            '{"format": 1, "obstacles": [], "start": [NaN, 0], "goal": [1, 1]}',
            "start\\[0\\]: expected a finite number",
        ),
        ("[1, 2]", "expected a JSON object"),
    ],
)
def test_unreadable_file_is_named(tmp_path, text, message):
    file = tmp_path / "broken.json"
    file.write_text(text)
    with pytest.raises(ScenarioError, match=message) as error:
        load_scene(file)
    assert str(file) in str(error.value)


def test_missing_file_is_named(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scene(tmp_path / "absent.json")


def test_edits_return_new_scenes_and_leave_the_old_one():
    scene = load_scene(GOOD)
    moved = move_vertex(scene, 1, 2, (7.5, 6.5))
    assert scene.obstacles[1].exterior.coords[2] == (7.0, 6.0)
    assert moved.obstacles[1].exterior.coords[2] == (7.5, 6.5)
    assert move_start(scene, (0.5, 0.5)).start == (0.5, 0.5)
    assert move_goal(scene, (9.5, 7.5)).goal == (9.5, 7.5)
    inserted = insert_vertex(scene, 0, 0)
    assert inserted.obstacles[0].exterior.coords[1] == (3.0, 2.0)
    assert len(delete_vertex(inserted, 0, 1).obstacles[0].exterior.coords) == 5
    with pytest.raises(ValueError, match="only 3 vertices"):
        delete_vertex(scene, 1, 0)
    grown = add_obstacle(scene, [(5, 6), (6, 6), (6, 7)])
    assert len(grown.obstacles) == 3
    with pytest.raises(ScenarioError, match="intersects itself"):
        add_obstacle(scene, [(0, 0), (1, 1), (1, 0), (0, 1)])
    assert len(delete_obstacle(scene, 0).obstacles) == 1
    assert move_obstacle(scene, 0, (1, -1)).obstacles[0].bounds == (3.0, 1.0, 5.0, 4.0)
    assert replace_robot(scene, radius=0.1).robot.radius == 0.1
    assert hash(scene) == hash(load_scene(GOOD)) and scene == load_scene(GOOD)


def test_self_intersecting_edit_is_reported_not_raised():
    scene = move_vertex(load_scene(GOOD), 0, 1, (2, 6))
    problems = scene_problems(scene)
    assert problems and problems[0].startswith("obstacle 1: polygon intersects itself")


def test_scene_to_dict_is_the_file_format():
    data = scene_to_dict(load_scene(GOOD))
    assert data == {**GOOD, "start": [1.0, 1.0], "goal": [9.0, 7.0]} | {
        "boundary": [[0.0, 0.0], [10.0, 0.0], [10.0, 8.0], [0.0, 8.0]],
        "obstacles": [
            [[2.0, 2.0], [4.0, 2.0], [4.0, 5.0], [2.0, 5.0]],
            [[6.0, 3.0], [8.0, 3.0], [7.0, 6.0]],
        ],
    }


def test_the_map_name_is_kept_and_written_only_when_there_is_one(tmp_path):
    scene = load_scene({**GOOD, "map": "lab 2.yaml"})
    assert scene.map == "lab 2.yaml"
    assert scene_to_dict(scene)["map"] == "lab 2.yaml"
    assert load_scene(save_scene(scene, tmp_path / "lab.json")) == scene
    assert "map" not in scene_to_dict(load_scene(GOOD))


@pytest.mark.parametrize(
    "name", ["../lab.yaml", "maps/lab.yaml", "C:\\lab.yaml", "/lab.yaml", "lab.pgm", ""]
)
def test_a_map_name_is_never_a_path(name):
    with pytest.raises(ScenarioError) as info:
        load_scene({**GOOD, "map": name})
    assert info.value.field == "map" and "plain file name" in info.value.problem


def test_scene_value_semantics():
    a = Scene(obstacles=(Polygon([(0, 0), (1, 0), (0, 1)]),), start=(2, 2), goal=(3, 3))
    b = Scene(obstacles=(Polygon([(0, 0), (1, 0), (0, 1)]),), start=(2, 2), goal=(3, 3))
    assert a == b and hash(a) == hash(b)
    assert not math.isnan(a.sensor_range)


@pytest.mark.parametrize(
    "text",
    [
        "[" * 5000 + "]" * 5000,  # a list nested deeper than the parser goes
        '{"format": 1, "obstacles": ' + "[" * 3000 + "]" * 3000 + "}",
        '{"a": ' * 3000 + "1" + "}" * 3000,
    ],
    ids=["lists", "in-a-field", "objects"],
)
def test_deep_nesting_is_one_clean_error(tmp_path, text):
    path = tmp_path / "deep.json"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: (file): nested too deeply to be a scenario"
    with pytest.raises(ScenarioError, match=r"upload: \(file\): nested too deeply"):
        scene_from_text(text.encode(), "upload")


def test_nesting_the_parser_takes_is_a_field_error(tmp_path):
    data = copy.deepcopy(GOOD)
    data["start"] = json.loads("[" * 400 + "]" * 400)
    path = tmp_path / "nested.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ScenarioError, match=r"nested\.json: start: "):
        load_scene(path)


def _problems_one_by_one(scene):
    """The slow, obvious reference: each polygon's vertices counted, then its validity."""
    from planners.scene._scene import _polygon_problem

    named = [(f"obstacle {i + 1}", o) for i, o in enumerate(scene.obstacles)]
    if scene.boundary is not None:
        named.append(("boundary", scene.boundary))
    problems = []
    for label, polygon in named:
        coords = polygon.exterior.coords[:-1] if not polygon.is_empty else []
        if len(set(coords)) < 3:
            problems.append(f"{label}: needs at least 3 distinct vertices")
        elif not polygon.is_valid:
            problems.append(f"{label}: {_polygon_problem(polygon)}")
    return problems


_LATTICE = st.tuples(st.integers(0, 3), st.integers(0, 3))


@settings(max_examples=300)
@given(
    rings=st.lists(st.lists(_LATTICE, min_size=0, max_size=6), max_size=4),
    boundary=st.booleans(),
)
def test_scene_problems_name_what_a_polygon_by_polygon_check_names(rings, boundary):
    """On a small lattice (repeated, collinear and crossing vertices, empty and
    degenerate rings), the vectorised check says what checking each polygon says."""
    from planners.scene import Scene

    obstacles = tuple(Polygon(r) if len(r) >= 3 else Polygon() for r in rings)
    walls = Polygon([(-1, -1), (5, -1), (5, 5), (-1, 5)]) if boundary else None
    scene = Scene(obstacles=obstacles, start=(4, 4), goal=(4.5, 4.5), boundary=walls)
    assert [p for p in scene_problems(scene) if ":" in p] == _problems_one_by_one(scene)


def test_scene_problems_are_kept_per_scene_and_each_edit_asks_afresh():
    """The list is made once per scene (the app asks three times per edit): the same
    words each time, a copy the caller may change, and a new answer after an edit."""
    from planners.scene import Scene, move_vertex

    square = Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
    scene = Scene(obstacles=(square,), start=(2, 2), goal=(3, 3))
    first = scene_problems(scene)
    assert first == [] and scene_problems(scene) == []
    first.append("changed by the caller")
    assert scene_problems(scene) == []
    bowtie = move_vertex(scene, 0, 2, (1.0, -1.0))  # the ring now crosses itself
    assert scene_problems(bowtie) == ["obstacle 1: polygon intersects itself [0.5 0]"]
    assert scene_problems(scene) == []
    assert bowtie == move_vertex(scene, 0, 2, (1.0, -1.0))  # the kept list is no field


def test_a_scene_pickles_without_its_kept_problems_while_another_thread_asks():
    """The app sends scenes to a worker process (pickle) while its fast lane asks for
    the problems of the same scene. Here the other thread's question comes at the worst
    moment, deterministically: while the pickler walks the scene's attributes. The
    state is a copy made first, and the kept list is not part of it."""
    import io
    import pickle

    from planners.scene import Scene

    square = Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
    scene = Scene(obstacles=(square,), start=(2, 2), goal=(3, 3))

    class AskingMidway(pickle.Pickler):
        def persistent_id(self, obj):
            if obj is scene.obstacles:  # the pickler is inside the scene's attributes
                scene_problems(scene)

    out = io.BytesIO()
    AskingMidway(out, protocol=pickle.HIGHEST_PROTOCOL).dump(scene)
    back = pickle.loads(out.getvalue())
    assert back == scene and "_problems" not in back.__dict__
    assert "_problems" in scene.__dict__  # asked midway: kept on the original only


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            '{"format": 1, "obstacles": [], "start": [%s, 0], "goal": [1, 1]}'
            % ("9" * 5000),
            "big.json: (file): a number too long to read (more than 4,300 digits)",
        ),
        (
            '{"format": 1, "obstacles": [], "start": [%s, 0], "goal": [1, 1]}'
            % ("9" * 400),
            "big.json: start[0]: expected a finite number, got an integer of 400 digits",
        ),
    ],
)
def test_integers_too_big_for_a_float_are_one_line(text, expected):
    with pytest.raises(ScenarioError) as error:
        scene_from_text(text, "big.json")
    assert str(error.value) == expected
