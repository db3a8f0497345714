"""The scenario files' JSON Schema agrees with the loader, ``planners.load_scene``.

``static_scenarios/schema/scenario.schema.json`` describes the format for editors and
other tools; the loader is what the planners and the app use. Every shipped scenario
must validate, and on every file of a corpus of good, bad and edge-case files (and on
Hypothesis' variations of them) the schema must accept exactly what the loader accepts,
except for the refusals no JSON Schema can express, listed in ``LOADER_ONLY`` and in
docs/scenario-format.md ("What only the loader checks"). There the schema accepts, the
loader refuses, and the test checks that the loader's reason is that one.

A file is given to the schema as a strict JSON parser reads it: NaN and Infinity are
not JSON (Python's parser reads them; the loader then refuses them by field).
"""

from __future__ import annotations

import copy
import dataclasses
import json
import re
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from hypothesis import given
from hypothesis import strategies as st

import planners

ROOT = Path(__file__).resolve().parents[1]
SCHEMA_PATH = ROOT / "static_scenarios" / "schema" / "scenario.schema.json"
SHIPPED = sorted((ROOT / "static_scenarios").glob("*.json"))

SCHEMA = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)

# What the loader refuses and a JSON Schema cannot say, each with the words the loader
# uses. docs/scenario-format.md lists the same.
LOADER_ONLY = {
    "fewer than 3 distinct vertices": r"a polygon needs at least 3 distinct vertices",
    "self-intersecting polygon": r"polygon intersects itself",
    "polygon of zero area": r"polygon has zero area",
    "other invalid polygon": r"invalid polygon \(",
    "motion's obstacle beyond the list": r"no obstacle \d+ \(the file has \d+",
    "two motions for one obstacle": r"obstacle \d+ already has a motion",
    "index written with a decimal point": r"expected an index, got float",
}

MINIMAL = {"format": 1, "obstacles": [], "start": [0, 0], "goal": [3, 4]}

FULL = {
    "format": 1,
    "name": "Corridor with a door",
    "description": "Everything the format has.",
    "boundary": [[0, 0], [10, 0], [10, 6], [0, 6]],
    "obstacles": [
        [[4, 0], [4.4, 0], [4.4, 2.4], [4, 2.4]],
        [[4, 3.6], [4.4, 3.6], [4.4, 6], [4, 6]],
        [[4.05, 3.6], [4.35, 3.6], [4.35, 4.8], [4.05, 4.8]],
    ],
    "start": [1, 3],
    "goal": [9, 3],
    "robot": {
        "kind": "differential",
        "radius": 0.3,
        "wheel_radius": 0.05,
        "wheel_distance": 0.2,
        "max_wheel_rate": 12.0,
        "max_wheel_acceleration": 20.0,
    },
    "expansion": "square",
    "sensor_range": 1.5,
    "motions": [
        {
            "obstacle": 2,
            "waypoints": [[0, -1.2]],
            "speed": 0.3,
            "mode": "back_and_forth",
            "pause": 2.0,
        }
    ],
    "map": "corridor.yaml",
}


def _with(base: dict, path: tuple, value: Any = ...) -> dict:
    """A deep copy of ``base`` with the item at ``path`` set (or removed: ``...``)."""
    data = copy.deepcopy(base)
    *parents, last = path
    target = data
    for key in parents:
        target = target[key]
    if value is ...:
        del target[last]
    else:
        target[last] = value
    return data


def _text(data: Any) -> str:
    return json.dumps(data)


# name -> the file's text. Each is decided by both; they must agree unless the loader's
# reason is one of LOADER_ONLY.
CORPUS: dict[str, str] = {
    # Good files, and edges that are still good.
    "minimal": _text(MINIMAL),
    "full": _text(FULL),
    "format written 1.0": _text(_with(MINIMAL, ("format",), 1.0)),
    "boundary null": _text(_with(MINIMAL, ("boundary",), None)),
    "robot empty": _text(_with(MINIMAL, ("robot",), {})),
    "point robot": _text(_with(MINIMAL, ("robot",), {"radius": 0})),
    "wheel limits null": _text(
        _with(
            MINIMAL,
            ("robot",),
            {"max_wheel_rate": None, "max_wheel_acceleration": None},
        )
    ),
    "closed ring": _text(
        _with(MINIMAL, ("obstacles",), [[[1, 1], [2, 1], [1, 2], [1, 1]]])
    ),
    "repeated vertex": _text(
        _with(MINIMAL, ("obstacles",), [[[1, 1], [2, 1], [2, 1], [1, 2]]])
    ),
    "clockwise polygon": _text(
        _with(MINIMAL, ("obstacles",), [[[1, 1], [1, 2], [2, 1]]])
    ),
    "overlapping obstacles": _text(
        _with(
            MINIMAL,
            ("obstacles",),
            [[[1, 1], [3, 1], [3, 3], [1, 3]], [[2, 2], [4, 2], [4, 4], [2, 4]]],
        )
    ),
    "non-convex boundary": _text(
        _with(MINIMAL, ("boundary",), [[-1, -1], [5, -1], [5, 5], [2, 2], [-1, 5]])
    ),
    "start inside an obstacle (planners say invalid)": _text(
        _with(MINIMAL, ("obstacles",), [[[-1, -1], [1, -1], [1, 1], [-1, 1]]])
    ),
    "huge but finite": _text(_with(MINIMAL, ("goal",), [1e308, -1e308])),
    "integers and floats": _text(_with(MINIMAL, ("start",), [0.5, 1])),
    "motion defaults": _text(
        _with(FULL, ("motions",), [{"obstacle": 0, "waypoints": [[1, 0]], "speed": 1}])
    ),
    "motion loop mode": _text(_with(FULL, ("motions", 0, "mode"), "loop")),
    "motion pause 0": _text(_with(FULL, ("motions", 0, "pause"), 0)),
    "motions empty": _text(_with(MINIMAL, ("motions",), [])),
    "unicode name": _text(_with(MINIMAL, ("name",), "Salle 3 \u2013 \u00e9t\u00e9")),
    # Not JSON, or not an object.
    "not JSON": '{"format": 1, "obstacles": [] "start": [0, 0], "goal": [1, 1]}',
    "empty file": "",
    "top level a list": "[1, 2]",
    "top level null": "null",
    "NaN coordinate": '{"format": 1, "obstacles": [], "start": [NaN, 0], "goal": [1, 1]}',
    "Infinity coordinate": '{"format": 1, "obstacles": [], "start": [0, 0], "goal": [Infinity, 1]}',
    "number beyond float64": '{"format": 1, "obstacles": [], "start": [1e400, 0], "goal": [1, 1]}',
    # Top-level keys.
    "missing format": _text(_with(MINIMAL, ("format",))),
    "missing obstacles": _text(_with(MINIMAL, ("obstacles",))),
    "missing start": _text(_with(MINIMAL, ("start",))),
    "missing goal": _text(_with(MINIMAL, ("goal",))),
    "unknown key": _text(_with(MINIMAL, ("colour",), "red")),
    "a $schema key": _text(_with(MINIMAL, ("$schema",), "scenario.schema.json")),
    "format 2": _text(_with(MINIMAL, ("format",), 2)),
    "format true": _text(_with(MINIMAL, ("format",), True)),
    "format string": _text(_with(MINIMAL, ("format",), "1")),
    "name null": _text(_with(MINIMAL, ("name",), None)),
    "name a number": _text(_with(MINIMAL, ("name",), 3)),
    "description a list": _text(_with(MINIMAL, ("description",), ["a"])),
    "expansion unknown": _text(_with(MINIMAL, ("expansion",), "circle")),
    "expansion null": _text(_with(MINIMAL, ("expansion",), None)),
    "sensor range 0": _text(_with(MINIMAL, ("sensor_range",), 0)),
    "sensor range negative": _text(_with(MINIMAL, ("sensor_range",), -1)),
    "sensor range a string": _text(_with(MINIMAL, ("sensor_range",), "2")),
    "sensor range null": _text(_with(MINIMAL, ("sensor_range",), None)),
    # Points.
    "start three numbers": _text(_with(MINIMAL, ("start",), [1, 2, 3])),
    "start one number": _text(_with(MINIMAL, ("start",), [1])),
    "start an object": _text(_with(MINIMAL, ("start",), {"x": 1, "y": 2})),
    "start a string coordinate": _text(_with(MINIMAL, ("start",), ["1", 2])),
    "goal a boolean coordinate": _text(_with(MINIMAL, ("goal",), [True, 2])),
    "goal null": _text(_with(MINIMAL, ("goal",), None)),
    # Polygons.
    "obstacles an object": _text(_with(MINIMAL, ("obstacles",), {"a": 1})),
    "obstacle a point": _text(_with(MINIMAL, ("obstacles",), [[1, 2]])),
    "obstacle two vertices": _text(_with(MINIMAL, ("obstacles",), [[[0, 0], [1, 1]]])),
    "obstacle empty": _text(_with(MINIMAL, ("obstacles",), [[]])),
    "obstacle vertex of three numbers": _text(
        _with(MINIMAL, ("obstacles",), [[[0, 0, 0], [1, 0], [0, 1]]])
    ),
    "obstacle 3 vertices, 2 distinct": _text(
        _with(MINIMAL, ("obstacles",), [[[0, 0], [1, 0], [0, 0]]])
    ),
    "obstacle 4 vertices, 2 distinct": _text(
        _with(MINIMAL, ("obstacles",), [[[0, 0], [1, 0], [0, 0], [1, 0]]])
    ),
    "obstacle self-intersecting": _text(
        _with(MINIMAL, ("obstacles",), [[[0, 0], [1, 1], [1, 0], [0, 1]]])
    ),
    "obstacle on one line": _text(
        _with(MINIMAL, ("obstacles",), [[[0, 0], [1, 0], [2, 0]]])
    ),
    "boundary two vertices": _text(_with(MINIMAL, ("boundary",), [[0, 0], [5, 5]])),
    "boundary self-intersecting": _text(
        _with(MINIMAL, ("boundary",), [[0, 0], [5, 5], [5, 0], [0, 5]])
    ),
    "boundary an object": _text(_with(MINIMAL, ("boundary",), {})),
    # The robot.
    "robot null": _text(_with(MINIMAL, ("robot",), None)),
    "robot a list": _text(_with(MINIMAL, ("robot",), [])),
    "robot unknown key": _text(_with(MINIMAL, ("robot",), {"mass": 3})),
    "robot kind unknown": _text(_with(MINIMAL, ("robot",), {"kind": "tank"})),
    "robot negative radius": _text(_with(MINIMAL, ("robot",), {"radius": -0.1})),
    "robot radius a string": _text(_with(MINIMAL, ("robot",), {"radius": "0.3"})),
    "robot radius null": _text(_with(MINIMAL, ("robot",), {"radius": None})),
    "robot wheel radius 0": _text(_with(MINIMAL, ("robot",), {"wheel_radius": 0})),
    "robot wheel distance negative": _text(
        _with(MINIMAL, ("robot",), {"wheel_distance": -0.2})
    ),
    "robot max wheel rate 0": _text(_with(MINIMAL, ("robot",), {"max_wheel_rate": 0})),
    "robot max wheel acceleration negative": _text(
        _with(MINIMAL, ("robot",), {"max_wheel_acceleration": -1})
    ),
    "robot max wheel rate a string": _text(
        _with(MINIMAL, ("robot",), {"max_wheel_rate": "fast"})
    ),
    # Moving obstacles.
    "motions an object": _text(_with(FULL, ("motions",), {"obstacle": 2})),
    "motion a list": _text(_with(FULL, ("motions",), [[2]])),
    "motion unknown key": _text(_with(FULL, ("motions", 0, "rotate"), 1)),
    "motion missing obstacle": _text(_with(FULL, ("motions", 0, "obstacle"))),
    "motion missing waypoints": _text(_with(FULL, ("motions", 0, "waypoints"))),
    "motion missing speed": _text(_with(FULL, ("motions", 0, "speed"))),
    "motion obstacle negative": _text(_with(FULL, ("motions", 0, "obstacle"), -1)),
    "motion obstacle a string": _text(_with(FULL, ("motions", 0, "obstacle"), "2")),
    "motion obstacle true": _text(_with(FULL, ("motions", 0, "obstacle"), True)),
    "motion obstacle 1.5": _text(_with(FULL, ("motions", 0, "obstacle"), 1.5)),
    "motion obstacle 2.0": _text(_with(FULL, ("motions", 0, "obstacle"), 2.0)),
    "motion obstacle beyond the list": _text(
        _with(FULL, ("motions", 0, "obstacle"), 3)
    ),
    "two motions for one obstacle": _text(
        _with(FULL, ("motions",), [FULL["motions"][0], FULL["motions"][0]])
    ),
    "motion waypoints empty": _text(_with(FULL, ("motions", 0, "waypoints"), [])),
    "motion waypoints a point": _text(_with(FULL, ("motions", 0, "waypoints"), [0, 1])),
    "motion waypoint of one number": _text(
        _with(FULL, ("motions", 0, "waypoints"), [[1]])
    ),
    "motion speed 0": _text(_with(FULL, ("motions", 0, "speed"), 0)),
    "motion speed negative": _text(_with(FULL, ("motions", 0, "speed"), -0.5)),
    "motion speed null": _text(_with(FULL, ("motions", 0, "speed"), None)),
    "motion mode unknown": _text(_with(FULL, ("motions", 0, "mode"), "pingpong")),
    "motion pause negative": _text(_with(FULL, ("motions", 0, "pause"), -1)),
    "motion pause null": _text(_with(FULL, ("motions", 0, "pause"), None)),
    # The map's file name.
    "map .yml": _text(_with(MINIMAL, ("map",), "Lab 2_b-v1.0.yml")),
    "map .YAML": _text(_with(MINIMAL, ("map",), "LAB.YAML")),
    "map of 64 characters": _text(_with(MINIMAL, ("map",), "m" * 59 + ".yaml")),
    "map of 65 characters": _text(_with(MINIMAL, ("map",), "m" * 60 + ".yaml")),
    "map empty": _text(_with(MINIMAL, ("map",), "")),
    "map null": _text(_with(MINIMAL, ("map",), None)),
    "map a number": _text(_with(MINIMAL, ("map",), 3)),
    "map not YAML": _text(_with(MINIMAL, ("map",), "room.pgm")),
    "map in a folder": _text(_with(MINIMAL, ("map",), "maps/room.yaml")),
    "map with a backslash": _text(_with(MINIMAL, ("map",), "maps\\room.yaml")),
    "map absolute": _text(_with(MINIMAL, ("map",), "/etc/room.yaml")),
    "map with a drive": _text(_with(MINIMAL, ("map",), "C:room.yaml")),
    "map up a folder": _text(_with(MINIMAL, ("map",), "..yaml")),
    "map with two dots": _text(_with(MINIMAL, ("map",), "a..b.yaml")),
    "map hidden": _text(_with(MINIMAL, ("map",), ".room.yaml")),
    "map a device": _text(_with(MINIMAL, ("map",), "NUL.yaml")),
    "map with a newline": _text(_with(MINIMAL, ("map",), "room.yaml\n")),
}

# The corpus's documented exceptions: the schema accepts these, the loader refuses them.
EXPECTED_LOADER_ONLY = {
    "obstacle 3 vertices, 2 distinct": "fewer than 3 distinct vertices",
    "obstacle 4 vertices, 2 distinct": "fewer than 3 distinct vertices",
    "obstacle self-intersecting": "self-intersecting polygon",
    "obstacle on one line": "polygon of zero area",
    "boundary self-intersecting": "self-intersecting polygon",
    "motion obstacle beyond the list": "motion's obstacle beyond the list",
    "two motions for one obstacle": "two motions for one obstacle",
    "motion obstacle 2.0": "index written with a decimal point",
}


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not JSON")


def schema_accepts(text: str) -> bool:
    """Whether a strict JSON parser reads ``text`` and the schema accepts what it read."""
    try:
        data = json.loads(text, parse_constant=_refuse_constant)
    except ValueError:  # JSONDecodeError is one
        return False
    return VALIDATOR.is_valid(data)


def loader_decision(text: str, folder: Path) -> planners.ScenarioError | None:
    """The loader's refusal of the file with this text, or None when it loads it."""
    path = folder / "case.json"
    path.write_text(text, encoding="utf-8")
    try:
        planners.load_scene(path)
    except planners.ScenarioError as error:
        assert str(path) in str(error) and "\n" not in str(error)
        return error
    return None


def loader_only_kind(error: planners.ScenarioError) -> str | None:
    """Which documented exception the loader's refusal is, if any."""
    for kind, pattern in LOADER_ONLY.items():
        if re.search(pattern, error.problem):
            return kind
    return None


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("scenarios")


def test_the_schema_is_a_valid_draft_2020_12_schema():
    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    assert SCHEMA["$schema"] == "https://json-schema.org/draft/2020-12/schema"


def test_there_are_shipped_scenarios_and_the_schema_is_not_one():
    assert len(SHIPPED) >= 10
    assert SCHEMA_PATH not in SHIPPED


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_every_shipped_scenario_validates(path: Path):
    data = json.loads(path.read_text(encoding="utf-8"), parse_constant=_refuse_constant)
    errors = [e.message for e in VALIDATOR.iter_errors(data)]
    assert errors == []
    planners.load_scene(path)


@pytest.mark.parametrize("name", list(CORPUS))
def test_schema_and_loader_agree(name: str, folder: Path):
    text = CORPUS[name]
    refused = loader_decision(text, folder)
    accepted = schema_accepts(text)
    if name in EXPECTED_LOADER_ONLY:
        assert accepted, "the schema was expected to accept this file"
        assert refused is not None, "the loader was expected to refuse this file"
        assert loader_only_kind(refused) == EXPECTED_LOADER_ONLY[name], str(refused)
    else:
        assert accepted == (refused is None), (
            f"schema {'accepts' if accepted else 'refuses'}, "
            f"loader {'refuses: ' + str(refused) if refused else 'accepts'}"
        )


def test_the_corpus_has_every_kind_of_file(folder: Path):
    decisions = [loader_decision(t, folder) is None for t in CORPUS.values()]
    assert sum(decisions) >= 15 and decisions.count(False) >= 60
    # Every documented exception is met at least once.
    assert set(EXPECTED_LOADER_ONLY.values()) >= set(LOADER_ONLY) - {
        "other invalid polygon"
    }


def test_the_schema_names_the_loaders_keys():
    """The schema's properties are the keys the loader knows, no more, no fewer."""
    scene = planners.load_scene(FULL)  # FULL has every key the schema names
    robot_keys = {f.name for f in dataclasses.fields(planners.Robot)}
    motion_keys = {f.name for f in dataclasses.fields(type(scene.motions[0]))}
    assert set(SCHEMA["$defs"]["robot"]["properties"]) == robot_keys
    assert set(SCHEMA["$defs"]["motion"]["properties"]) == motion_keys
    assert set(SCHEMA["properties"]) == set(FULL)


def test_the_schemas_defaults_are_the_loaders():
    scene = planners.load_scene(MINIMAL)
    top = SCHEMA["properties"]
    assert scene.name == top["name"]["default"]
    assert scene.description == top["description"]["default"]
    assert scene.boundary is None and top["boundary"]["default"] is None
    assert scene.expansion == top["expansion"]["default"]
    assert scene.sensor_range == top["sensor_range"]["default"]
    assert scene.motions == () and top["motions"]["default"] == []
    robot = SCHEMA["$defs"]["robot"]["properties"]
    for field in dataclasses.fields(planners.Robot):
        assert getattr(scene.robot, field.name) == robot[field.name]["default"], (
            field.name
        )
    motion = planners.load_scene(json.loads(CORPUS["motion defaults"])).motions[0]
    for key in ("mode", "pause"):
        assert (
            getattr(motion, key)
            == SCHEMA["$defs"]["motion"]["properties"][key]["default"]
        )


# --------------------------------------------------------------------- variations

_ANY_JSON = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-5, 5)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=4),
    lambda children: (
        st.lists(children, max_size=4)
        | st.dictionaries(st.text(max_size=3), children, max_size=3)
    ),
    max_leaves=8,
)
_NUMBER = st.one_of(
    st.integers(-3, 12),
    st.floats(-3, 12),
    st.sampled_from([0, 0.0, -0.0, 1.0, 1e308, float("inf"), float("nan")]),
)
_POINT = st.one_of(
    st.tuples(_NUMBER, _NUMBER).map(list),
    st.lists(_NUMBER, max_size=3),
    _ANY_JSON,
)
_POLYGON = st.one_of(
    st.lists(
        st.tuples(st.integers(0, 4), st.integers(0, 4)).map(list),
        min_size=0,
        max_size=6,
    ),
    st.lists(_POINT, max_size=5),
    _ANY_JSON,
)
_ROBOT = st.dictionaries(
    st.sampled_from(
        [
            "kind",
            "radius",
            "wheel_radius",
            "wheel_distance",
            "max_wheel_rate",
            "max_wheel_acceleration",
            "mass",
        ]
    ),
    st.one_of(_NUMBER, st.sampled_from(["holonomic", "differential", "tank", None])),
    max_size=5,
)
_MOTION = st.dictionaries(
    st.sampled_from(["obstacle", "waypoints", "speed", "mode", "pause", "turn"]),
    st.one_of(
        st.integers(-1, 3),
        st.sampled_from([0.0, 1.0, 2.5, None, "loop", "back_and_forth", "spin"]),
        st.lists(_POINT, max_size=3),
        _NUMBER,
    ),
    max_size=6,
)
_FIELD = {
    "format": st.one_of(st.sampled_from([1, 1.0, 2, True, "1", None]), _ANY_JSON),
    "name": st.one_of(st.text(max_size=8), _ANY_JSON),
    "description": st.one_of(st.text(max_size=8), _ANY_JSON),
    "boundary": st.one_of(st.none(), _POLYGON),
    "obstacles": st.one_of(st.lists(_POLYGON, max_size=3), _ANY_JSON),
    "start": _POINT,
    "goal": _POINT,
    "robot": st.one_of(_ROBOT, _ANY_JSON),
    "expansion": st.one_of(
        st.sampled_from(["disk", "square", "Disk", None]), _ANY_JSON
    ),
    "sensor_range": _NUMBER,
    "motions": st.one_of(st.lists(_MOTION, max_size=3), _ANY_JSON),
    "map": st.one_of(
        st.sampled_from(["room.yaml", "a b.yml", "../room.yaml", "room.yaml\n"]),
        st.text(max_size=8).map(lambda t: t + ".yaml"),
        _ANY_JSON,
    ),
    "extra": _ANY_JSON,
}


@st.composite
def scenario_variations(draw) -> dict:
    """FULL or MINIMAL with a few fields replaced, dropped or added."""
    data = copy.deepcopy(draw(st.sampled_from([FULL, MINIMAL])))
    for key in draw(st.lists(st.sampled_from(sorted(_FIELD)), max_size=3, unique=True)):
        if draw(st.integers(0, 5)) == 0:
            data.pop(key, None)
        else:
            data[key] = draw(_FIELD[key])
    return data


@given(data=scenario_variations())
def test_schema_and_loader_agree_on_variations(data: dict, folder: Path):
    text = json.dumps(data)  # NaN and inf become NaN and Infinity: not JSON
    refused = loader_decision(text, folder)
    accepted = schema_accepts(text)
    if refused is None:
        assert accepted, "the loader accepts a file the schema refuses"
    elif accepted:
        assert loader_only_kind(refused) is not None, (
            f"the schema accepts a file the loader refuses: {refused}"
        )
