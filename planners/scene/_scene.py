"""Scene value, pure edits and scenario files.

A :class:`Scene` is an immutable value: every edit returns a new scene, so a scene can be
cached, compared, undone and shared between threads without locks. Scenario files are the
JSON format of ``docs/scenario-format.md``; :func:`load_scene` validates every field and names the file
and the field in its error, :func:`save_scene` writes atomically.
"""

from __future__ import annotations

__all__ = [
    "EXPANSION_MODES",
    "ROBOT_KINDS",
    "Robot",
    "Scenario",
    "ScenarioError",
    "Scene",
    "add_obstacle",
    "delete_obstacle",
    "delete_vertex",
    "insert_vertex",
    "is_map_name",
    "load_scene",
    "move_goal",
    "move_obstacle",
    "move_start",
    "move_vertex",
    "replace_robot",
    "save_scene",
    "scene_at",
    "scene_from_dict",
    "scene_from_text",
    "scene_problems",
    "scene_to_dict",
]

import dataclasses
import json
import math
import os
import re
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely import Polygon

from planners.scene.motion import MOTION_MODES, Motion, motion_offset

ROBOT_KINDS = ("holonomic", "differential")
EXPANSION_MODES = ("disk", "square")
FORMAT_VERSION = 1

Point = tuple[float, float]


class ScenarioError(ValueError):
    """A scenario that cannot be read: the message names the file and the field."""

    def __init__(self, source: str, field: str, problem: str) -> None:
        self.source = source
        self.field = field
        self.problem = problem
        super().__init__(f"{source}: {field}: {problem}")


ScenarioError.__module__ = "planners.scene"  # its public name, in tracebacks too


@dataclasses.dataclass(frozen=True)
class Robot:
    """The robot: its disk radius and its wheels (Fig. 9.4 and 9.7 of the chapter)."""

    kind: str = "holonomic"
    """``"holonomic"`` (three omni-wheels) or ``"differential"`` (two wheels and a caster)."""
    radius: float = 0.3
    """Radius of the robot's disk [m]; obstacles are expanded by it. 0 is a point robot."""
    wheel_radius: float = 0.05
    """Wheel radius r [m]."""
    wheel_distance: float = 0.25
    """Distance L from the robot's centre to each wheel [m]."""
    max_wheel_rate: float | None = None
    """Largest wheel angular rate [rad/s] (section 9.7.3), None for no limit."""
    max_wheel_acceleration: float | None = None
    """Largest wheel angular acceleration [rad/s^2] (limits wheel slip, section 9.7.3),
    None for no limit."""


@dataclasses.dataclass(frozen=True)
class Scene:
    """A planning problem: obstacles, start, goal, robot and the planners' settings.

    Polygons are kept exactly as given (any orientation, first vertex not repeated); a
    scene may hold a polygon that an edit made self-intersecting, which
    :func:`scene_problems` reports and the planners answer with status ``"invalid"``.
    """

    obstacles: tuple[Polygon, ...]
    """Obstacle polygons in the floor plane [m]."""
    start: Point
    """Start of the robot's centre (x, y) [m]."""
    goal: Point
    """Goal of the robot's centre (x, y) [m]."""
    boundary: Polygon | None = None
    """Walls of the environment, or None for an unbounded floor [m]."""
    robot: Robot = dataclasses.field(default_factory=Robot)
    """The robot; its radius drives the obstacle expansion."""
    expansion: str = "disk"
    """``"disk"`` (exact model, Fig. 9.7) or ``"square"`` (enclosing square, Fig. 9.8)."""
    sensor_range: float = 2.0
    """Range R of the 360-degree distance sensor used by the DSB planner [m]."""
    name: str = ""
    """Short title shown in the app."""
    description: str = ""
    """A sentence or two a lecturer can read aloud."""
    motions: tuple[Motion, ...] = ()
    """Moving obstacles (:mod:`planners.scene.motion`), at most one per obstacle, by obstacle
    index; ``obstacles`` is the scene at time 0."""
    map: str = ""
    """File name of the occupancy map (a map_server YAML file beside the scenario file) the
    scene was imported from, for drawing it under the obstacles; ``""`` for none. The
    planners ignore it."""

    def __getstate__(self) -> dict[str, Any]:
        """Pickle the fields only, not what :func:`scene_problems` kept on the scene.

        One copy of the attributes first (a single C call under the GIL): another thread
        may keep the problems on this scene while it is being sent to a worker.
        """
        state = dict(self.__dict__)
        state.pop("_problems", None)
        return state


Scenario = Scene  # the file format's name for the same value


# --------------------------------------------------------------------------- validation


_TOP_KEYS = frozenset(
    {
        "format",
        "name",
        "description",
        "boundary",
        "obstacles",
        "start",
        "goal",
        "robot",
        "expansion",
        "sensor_range",
        "motions",
        "map",
    }
)
_REQUIRED_KEYS = ("format", "obstacles", "start", "goal")
_ROBOT_KEYS = frozenset(
    {
        "kind",
        "radius",
        "wheel_radius",
        "wheel_distance",
        "max_wheel_rate",
        "max_wheel_acceleration",
    }
)
_MOTION_KEYS = frozenset({"obstacle", "waypoints", "speed", "mode", "pause"})
# A map's file name: one plain component (as the app's scenes folder names files) ending
# in .yaml or .yml, so that it can only ever name a file beside the scenario's.
_MAP_NAME = re.compile(
    r"(?!.*\.\.)[A-Za-z0-9][A-Za-z0-9 _.\-]{0,58}\.[yY][aA]?[mM][lL]"
)
_DEVICES = re.compile(r"(con|prn|aux|nul|com[0-9]|lpt[0-9])(\..*)?", re.IGNORECASE)


def _number(source: str, field: str, value: Any) -> float:
    # bool is an int in Python; a scenario that says `true` for a coordinate is wrong.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(source, field, f"expected a number, got {_describe(value)}")
    try:
        number = float(value)
    except OverflowError:  # an integer of hundreds of digits
        number = math.inf
    if not math.isfinite(number):
        shown = (
            repr(value)
            if isinstance(value, float)
            else f"an integer of {len(str(abs(value)))} digits"
        )
        raise ScenarioError(source, field, f"expected a finite number, got {shown}")
    return number


def _describe(value: Any) -> str:
    text = json.dumps(value) if not isinstance(value, float) else repr(value)
    if len(text) > 40:
        text = text[:37] + "..."
    return f"{type(value).__name__} {text}"


def _point(source: str, field: str, value: Any) -> Point:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ScenarioError(
            source, field, f"expected a point [x, y], got {_describe(value)}"
        )
    return (
        _number(source, f"{field}[0]", value[0]),
        _number(source, f"{field}[1]", value[1]),
    )


def _polygon(source: str, field: str, value: Any) -> Polygon:
    if not isinstance(value, (list, tuple)):
        raise ScenarioError(
            source, field, f"expected a list of [x, y] vertices, got {_describe(value)}"
        )
    points = [_point(source, f"{field}[{k}]", v) for k, v in enumerate(value)]
    return _polygon_from_points(source, field, points)


def _polygon_from_points(source: str, field: str, points: list[Point]) -> Polygon:
    # A ring given closed (first point repeated at the end) is accepted; so are repeated
    # consecutive vertices, which carry no geometry.
    ring: list[Point] = []
    for p in points:
        if not ring or p != ring[-1]:
            ring.append(p)
    if len(ring) > 1 and ring[0] == ring[-1]:
        ring.pop()
    if len(set(ring)) < 3:
        raise ScenarioError(
            source,
            field,
            f"a polygon needs at least 3 distinct vertices, got {len(set(ring))}",
        )
    polygon = Polygon(ring)
    if not polygon.is_valid:
        raise ScenarioError(source, field, _polygon_problem(polygon))
    return polygon


def _polygon_problem(polygon: Polygon) -> str:
    reason = shapely.is_valid_reason(polygon)
    if polygon.convex_hull.area == 0.0:
        return "polygon has zero area (all vertices on one line)"
    if reason.startswith(("Self-intersection", "Ring Self-intersection")):
        where = reason[reason.find("[") :] if "[" in reason else ""
        return f"polygon intersects itself {where}".rstrip()
    return f"invalid polygon ({reason})"


def scene_from_dict(data: Any, source: str = "<scenario>") -> Scene:
    """Validate a scenario mapping (the JSON format of docs/scenario-format.md) and build a Scene.

    Parameters
    ----------
    data
        The parsed JSON object.
    source
        What to call the scenario in error messages, usually its file path.

    Returns
    -------
    Scene

    Raises
    ------
    ScenarioError
        For unknown keys, wrong types, NaN or infinite numbers, fewer than 3 distinct
        vertices, self-intersecting polygons, a negative radius or range, or an unknown
        robot kind or expansion mode. The message names ``source`` and the field.

    Examples
    --------
    >>> scene = scene_from_dict({"format": 1, "obstacles": [[[0, 0], [1, 0], [0, 1]]],
    ...                          "start": [-1, -1], "goal": [2, 2]})
    >>> scene.start, len(scene.obstacles), scene.robot.kind
    ((-1.0, -1.0), 1, 'holonomic')
    """
    _check_top_level(source, data)
    # Fields are checked in the file format's order; the first problem is reported.
    name = _text(source, "name", data.get("name", ""))
    description = _text(source, "description", data.get("description", ""))
    boundary = None
    if data.get("boundary") is not None:
        boundary = _polygon(source, "boundary", data["boundary"])
    obstacles = _obstacles(source, data["obstacles"])
    return Scene(
        obstacles=obstacles,
        start=_point(source, "start", data["start"]),
        goal=_point(source, "goal", data["goal"]),
        boundary=boundary,
        robot=_robot(source, data.get("robot", {})),
        expansion=_choice(
            source, "expansion", data.get("expansion", "disk"), EXPANSION_MODES
        ),
        sensor_range=_positive(source, "sensor_range", data.get("sensor_range", 2.0)),
        name=name,
        description=description,
        motions=_motions(source, data.get("motions", []), len(obstacles)),
        map=_map_name(source, data["map"]) if "map" in data else "",
    )


def _check_top_level(source: str, data: Any) -> None:
    """Check that ``data`` is a mapping with the known keys, the required ones, format 1."""
    if not isinstance(data, Mapping):
        raise ScenarioError(
            source, "(top level)", f"expected a JSON object, got {_describe(data)}"
        )
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise ScenarioError(
            source, unknown[0], f"unknown key (allowed: {', '.join(sorted(_TOP_KEYS))})"
        )
    for key in _REQUIRED_KEYS:
        if key not in data:
            raise ScenarioError(source, key, "missing required key")
    if data["format"] != FORMAT_VERSION or isinstance(data["format"], bool):
        raise ScenarioError(
            source,
            "format",
            f"expected {FORMAT_VERSION}, got {_describe(data['format'])}",
        )


def _obstacles(source: str, value: Any) -> tuple[Polygon, ...]:
    if not isinstance(value, (list, tuple)):
        raise ScenarioError(
            source, "obstacles", f"expected a list of polygons, got {_describe(value)}"
        )
    return tuple(_polygon(source, f"obstacles[{i}]", o) for i, o in enumerate(value))


def _text(source: str, field: str, value: Any) -> str:
    if not isinstance(value, str):
        raise ScenarioError(source, field, f"expected a string, got {_describe(value)}")
    return value


def _choice(source: str, field: str, value: Any, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise ScenarioError(
            source,
            field,
            f"expected one of {', '.join(allowed)}, got {_describe(value)}",
        )
    return value


def _positive(source: str, field: str, value: Any) -> float:
    number = _number(source, field, value)
    if number <= 0:
        raise ScenarioError(source, field, f"must be positive, got {number!r}")
    return number


def is_map_name(name: str) -> bool:
    """Whether ``name`` may be a scenario's ``map``: a plain YAML file name, never a path.

    Examples
    --------
    >>> is_map_name("lab 2.yaml"), is_map_name("../lab.yaml"), is_map_name("lab.pgm")
    (True, False, False)
    """
    return bool(_MAP_NAME.fullmatch(name)) and not _DEVICES.fullmatch(name)


def _map_name(source: str, value: Any) -> str:
    """Check the optional ``map``: a plain YAML file name, never a path."""
    name = _text(source, "map", value)
    if not is_map_name(name):
        raise ScenarioError(
            source,
            "map",
            "expected a plain file name ending in .yaml or .yml (at most 64 letters,"
            f" digits, spaces, _ - and ., no folders), got {_describe(value)}",
        )
    return name


def _robot(source: str, data: Any) -> Robot:
    if not isinstance(data, Mapping):
        raise ScenarioError(
            source, "robot", f"expected an object, got {_describe(data)}"
        )
    unknown = sorted(set(data) - _ROBOT_KEYS)
    if unknown:
        raise ScenarioError(
            source,
            f"robot.{unknown[0]}",
            f"unknown key (allowed: {', '.join(sorted(_ROBOT_KEYS))})",
        )
    defaults = Robot()
    kind = data.get("kind", defaults.kind)
    if kind not in ROBOT_KINDS:
        raise ScenarioError(
            source,
            "robot.kind",
            f"expected one of {', '.join(ROBOT_KINDS)}, got {_describe(kind)}",
        )
    values = {}
    for key in ("radius", "wheel_radius", "wheel_distance"):
        value = _number(source, f"robot.{key}", data.get(key, getattr(defaults, key)))
        if value < 0 or (key != "radius" and value == 0):
            bound = "non-negative" if key == "radius" else "positive"
            raise ScenarioError(
                source, f"robot.{key}", f"must be {bound}, got {value!r}"
            )
        values[key] = value
    limits = {
        key: _positive(source, f"robot.{key}", data[key])
        for key in ("max_wheel_rate", "max_wheel_acceleration")
        if data.get(key) is not None
    }
    return Robot(kind=kind, **values, **limits)


def _motions(source: str, value: Any, n_obstacles: int) -> tuple[Motion, ...]:
    """Check the optional ``motions`` list (:mod:`planners.scene.motion`), one per obstacle."""
    if not isinstance(value, (list, tuple)):
        raise ScenarioError(
            source, "motions", f"expected a list of motions, got {_describe(value)}"
        )
    out = [
        _motion(source, f"motions[{k}]", m, n_obstacles) for k, m in enumerate(value)
    ]
    seen: set[int] = set()
    for k, m in enumerate(out):
        if m.obstacle in seen:
            raise ScenarioError(
                source,
                f"motions[{k}].obstacle",
                f"obstacle {m.obstacle} already has a motion",
            )
        seen.add(m.obstacle)
    return tuple(out)


def _motion(source: str, field: str, data: Any, n_obstacles: int) -> Motion:
    if not isinstance(data, Mapping):
        raise ScenarioError(source, field, f"expected an object, got {_describe(data)}")
    unknown = sorted(set(data) - _MOTION_KEYS)
    if unknown:
        raise ScenarioError(
            source,
            f"{field}.{unknown[0]}",
            f"unknown key (allowed: {', '.join(sorted(_MOTION_KEYS))})",
        )
    for key in ("obstacle", "waypoints", "speed"):
        if key not in data:
            raise ScenarioError(source, f"{field}.{key}", "missing required key")
    index = data["obstacle"]
    if isinstance(index, bool) or not isinstance(index, int):
        raise ScenarioError(
            source, f"{field}.obstacle", f"expected an index, got {_describe(index)}"
        )
    if not 0 <= index < n_obstacles:
        raise ScenarioError(
            source,
            f"{field}.obstacle",
            f"no obstacle {index} (the file has {n_obstacles}, numbered from 0)",
        )
    waypoints = data["waypoints"]
    if not isinstance(waypoints, (list, tuple)) or not waypoints:
        raise ScenarioError(
            source,
            f"{field}.waypoints",
            f"expected a non-empty list of [dx, dy], got {_describe(waypoints)}",
        )
    pause = _number(source, f"{field}.pause", data.get("pause", 0.0))
    if pause < 0:
        raise ScenarioError(source, f"{field}.pause", f"must be >= 0, got {pause!r}")
    return Motion(
        obstacle=index,
        waypoints=tuple(
            _point(source, f"{field}.waypoints[{k}]", w)
            for k, w in enumerate(waypoints)
        ),
        speed=_positive(source, f"{field}.speed", data["speed"]),
        mode=_choice(source, f"{field}.mode", data.get("mode", "loop"), MOTION_MODES),
        pause=pause,
    )


def load_scene(path_or_dict: str | os.PathLike[str] | Mapping[str, Any]) -> Scene:
    """Load a scenario from a JSON file (or an already parsed mapping) and validate it.

    Parameters
    ----------
    path_or_dict
        A path to a ``.json`` scenario file, or the parsed mapping itself.

    Returns
    -------
    Scene

    Raises
    ------
    ScenarioError
        If the file cannot be read, is not JSON, or any field is wrong; the message names
        the file and the field.
    """
    if isinstance(path_or_dict, Mapping):
        return scene_from_dict(path_or_dict)
    path = Path(path_or_dict)
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise ScenarioError(
            source, "(file)", f"cannot read: {error.strerror or error}"
        ) from None
    except UnicodeDecodeError:
        raise ScenarioError(source, "(file)", "not UTF-8 text") from None
    return scene_from_text(text, source)


def scene_from_text(text: str | bytes, source: str = "<scenario>") -> Scene:
    """Parse a scenario's JSON text (a file's, an upload's) and validate it.

    Every malformed text gives a :class:`ScenarioError` naming ``source`` and the field:
    bad JSON, JSON nested too deeply for the parser (which would otherwise end in a
    ``RecursionError``), any wrong field.

    Examples
    --------
    >>> scene_from_text('{"format": 1, "obstacles": [], "start": [0, 0], "goal": [1, 1]}').goal
    (1.0, 1.0)
    >>> scene_from_text("[" * 100000 + "]" * 100000, "deep.json")
    Traceback (most recent call last):
    ...
    planners.scene.ScenarioError: deep.json: (file): nested too deeply to be a scenario
    """
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError:
            raise ScenarioError(source, "(file)", "not UTF-8 text") from None
    try:
        # Python's json reads NaN and Infinity; they reach the field checks, which reject
        # them naming the field.
        data = json.loads(text)
        return scene_from_dict(data, source)
    except json.JSONDecodeError as error:
        raise ScenarioError(
            source, f"(line {error.lineno})", f"not valid JSON: {error.msg}"
        ) from None
    except ScenarioError:
        raise
    except ValueError:  # Python reads integers of at most 4,300 digits
        raise ScenarioError(
            source, "(file)", "a number too long to read (more than 4,300 digits)"
        ) from None
    except RecursionError:
        # No scenario field nests more than three lists deep; Python's parser (and any
        # repr of such a value) gives up at about a thousand levels.
        raise ScenarioError(
            source, "(file)", "nested too deeply to be a scenario"
        ) from None


def scene_to_dict(scene: Scene) -> dict[str, Any]:
    """Return the scenario mapping for ``scene`` (inverse of :func:`scene_from_dict`)."""
    data: dict[str, Any] = {
        "format": FORMAT_VERSION,
        "name": scene.name,
        "description": scene.description,
    }
    if scene.boundary is not None:
        data["boundary"] = _ring_list(scene.boundary)
    data["obstacles"] = [_ring_list(o) for o in scene.obstacles]
    data["start"] = list(scene.start)
    data["goal"] = list(scene.goal)
    # Wheel limits only when set: a scene without them is written as before.
    data["robot"] = {
        k: v for k, v in dataclasses.asdict(scene.robot).items() if v is not None
    }
    data["expansion"] = scene.expansion
    data["sensor_range"] = scene.sensor_range
    if scene.motions:  # only when there are: static scenes are written as before
        data["motions"] = [
            {
                "obstacle": m.obstacle,
                "waypoints": [list(w) for w in m.waypoints],
                "speed": m.speed,
                "mode": m.mode,
                "pause": m.pause,
            }
            for m in scene.motions
        ]
    if scene.map:  # only when there is one: scenes drawn by hand are written as before
        data["map"] = scene.map
    return data


def _ring_list(polygon: Polygon) -> list[list[float]]:
    return [[float(x), float(y)] for x, y in polygon.exterior.coords[:-1]]


def save_scene(scene: Scene, path: str | os.PathLike[str]) -> Path:
    """Write ``scene`` to ``path`` as a scenario file, atomically.

    The JSON goes to a temporary file in the same folder, is flushed to disk, and then
    renamed over ``path``: a crash leaves either the old file or the new one, never half.
    A scene that :func:`scene_problems` rejects is refused, so a saved file always loads.

    Raises
    ------
    ScenarioError
        If the scene has a problem (the file is then left untouched) or cannot be written.
    """
    path = Path(path)
    problems = scene_problems(scene)
    if problems:
        raise ScenarioError(str(path), "(scene)", "not saved: " + "; ".join(problems))
    text = json.dumps(scene_to_dict(scene), indent=2) + "\n"
    folder = path.parent if str(path.parent) else Path()
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as handle:
                handle.write(text)
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError as error:
        raise ScenarioError(
            str(path), "(file)", f"cannot write: {error.strerror or error}"
        ) from None
    return path


def scene_problems(scene: Scene) -> list[str]:
    """List what makes ``scene`` unplannable, in words a student understands.

    Edits may leave a polygon self-intersecting or with too few vertices; the app shows
    these messages and the planners answer ``"invalid"`` until the user fixes them.

    Examples
    --------
    >>> bowtie = Polygon([(0, 0), (1, 1), (1, 0), (0, 1)])
    >>> scene_problems(Scene(obstacles=(bowtie,), start=(2, 2), goal=(3, 3)))
    ['obstacle 1: polygon intersects itself [0.5 0.5]']

    A scene never changes, so its list is made once and kept on the scene (an edit
    makes a new scene): the app asks three times per edit (the edit, the planners, the
    frame), and the validity test of every polygon is the cost.
    """
    kept = scene.__dict__.get("_problems")
    if kept is None:
        kept = scene.__dict__["_problems"] = tuple(_problems_of(scene))
    return list(kept)


def _problems_of(scene: Scene) -> list[str]:
    problems = []
    named = [(f"obstacle {i + 1}", o) for i, o in enumerate(scene.obstacles)]
    if scene.boundary is not None:
        named.append(("boundary", scene.boundary))
    # One vectorised validity test: a valid polygon that is not empty has three distinct
    # vertices at least (a ring of fewer has no area), so only the others are looked at.
    shapes = np.array([polygon for _, polygon in named], dtype=object)
    sound = shapely.is_valid(shapes) & ~shapely.is_empty(shapes) if named else []
    for (label, polygon), ok in zip(named, sound, strict=True):
        if ok:
            continue
        coords = polygon.exterior.coords[:-1] if not polygon.is_empty else []
        if len(set(coords)) < 3:
            problems.append(f"{label}: needs at least 3 distinct vertices")
        else:
            problems.append(f"{label}: {_polygon_problem(polygon)}")
    for label, point in (("start", scene.start), ("goal", scene.goal)):
        if not all(math.isfinite(c) for c in point):
            problems.append(f"{label}: coordinates must be finite")
    if not (scene.robot.radius >= 0 and math.isfinite(scene.robot.radius)):
        problems.append("robot radius must be a non-negative number")
    if not scene.sensor_range > 0:
        problems.append("sensor range must be positive")
    return problems


# --------------------------------------------------------------------------- pure edits


def _coords(polygon: Polygon) -> list[Point]:
    return [(float(x), float(y)) for x, y in polygon.exterior.coords[:-1]]


def _xy(xy: Iterable[float]) -> Point:
    x, y = (float(v) for v in xy)
    return (x, y)


def _replace_obstacle(scene: Scene, i: int, coords: Sequence[Point]) -> Scene:
    obstacles = list(scene.obstacles)
    obstacles[i] = Polygon(coords)
    return dataclasses.replace(scene, obstacles=tuple(obstacles))


def move_start(scene: Scene, xy: Iterable[float]) -> Scene:
    """Return ``scene`` with the start moved to ``xy``."""
    return dataclasses.replace(scene, start=_xy(xy))


def move_goal(scene: Scene, xy: Iterable[float]) -> Scene:
    """Return ``scene`` with the goal moved to ``xy``."""
    return dataclasses.replace(scene, goal=_xy(xy))


def move_vertex(scene: Scene, i: int, j: int, xy: Iterable[float]) -> Scene:
    """Return ``scene`` with vertex ``j`` of obstacle ``i`` moved to ``xy``.

    The result may be self-intersecting; :func:`scene_problems` says so.

    Examples
    --------
    >>> s = Scene(obstacles=(Polygon([(0, 0), (1, 0), (0, 1)]),), start=(2, 2), goal=(3, 3))
    >>> list(move_vertex(s, 0, 1, (2, 0)).obstacles[0].exterior.coords)
    [(0.0, 0.0), (2.0, 0.0), (0.0, 1.0), (0.0, 0.0)]
    """
    coords = _coords(scene.obstacles[i])
    coords[j] = _xy(xy)
    return _replace_obstacle(scene, i, coords)


def insert_vertex(
    scene: Scene, i: int, j: int, xy: Iterable[float] | None = None
) -> Scene:
    """Return ``scene`` with a new vertex after vertex ``j`` of obstacle ``i``.

    Without ``xy`` the vertex goes to the middle of the edge from ``j`` to ``j + 1``.
    """
    coords = _coords(scene.obstacles[i])
    if xy is None:
        (x0, y0), (x1, y1) = coords[j], coords[(j + 1) % len(coords)]
        point = ((x0 + x1) / 2.0, (y0 + y1) / 2.0)
    else:
        point = _xy(xy)
    coords.insert(j + 1, point)
    return _replace_obstacle(scene, i, coords)


def delete_vertex(scene: Scene, i: int, j: int) -> Scene:
    """Return ``scene`` without vertex ``j`` of obstacle ``i``.

    Raises
    ------
    ValueError
        If the obstacle would be left with fewer than 3 vertices.
    """
    coords = _coords(scene.obstacles[i])
    if len(coords) <= 3:
        raise ValueError(
            f"obstacle {i + 1} has only 3 vertices; delete the obstacle instead"
        )
    del coords[j]
    return _replace_obstacle(scene, i, coords)


def add_obstacle(scene: Scene, coords: Sequence[Iterable[float]]) -> Scene:
    """Return ``scene`` with a new obstacle polygon appended.

    Raises
    ------
    ScenarioError
        If the polygon has fewer than 3 distinct vertices or intersects itself.
    """
    points = [_xy(c) for c in coords]
    polygon = _polygon_from_points("new obstacle", "vertices", points)
    return dataclasses.replace(scene, obstacles=(*scene.obstacles, polygon))


def delete_obstacle(scene: Scene, i: int) -> Scene:
    """Return ``scene`` without obstacle ``i`` (and its motion; later ones renumbered)."""
    obstacles = list(scene.obstacles)
    del obstacles[i]
    i = i % (len(obstacles) + 1)  # a negative index names the same obstacle
    motions = tuple(
        m if m.obstacle < i else dataclasses.replace(m, obstacle=m.obstacle - 1)
        for m in scene.motions
        if m.obstacle != i
    )
    return dataclasses.replace(scene, obstacles=tuple(obstacles), motions=motions)


def move_obstacle(scene: Scene, i: int, delta: Iterable[float]) -> Scene:
    """Return ``scene`` with obstacle ``i`` translated by ``delta`` = (dx, dy)."""
    dx, dy = _xy(delta)
    coords = [(x + dx, y + dy) for x, y in _coords(scene.obstacles[i])]
    return _replace_obstacle(scene, i, coords)


def replace_robot(scene: Scene, **changes: Any) -> Scene:
    """Return ``scene`` with robot fields changed, e.g. ``replace_robot(s, radius=0.2)``."""
    return dataclasses.replace(scene, robot=dataclasses.replace(scene.robot, **changes))


# --------------------------------------------------------------------------- moving obstacles


def _translated(polygon: Polygon, offset: Point) -> Polygon:
    if offset == (0.0, 0.0):
        return polygon  # the very polygon: t = 0 is the file's scene, bit for bit
    dx, dy = offset
    return shapely.transform(polygon, lambda xy: xy + np.array([dx, dy]))


def scene_at(scene: Scene, t: float) -> Scene:
    """Return the scene as it is at time ``t`` [s]: every moving obstacle where it is then.

    The result is static (no motions): what a sensor sees at that moment. A scene
    without motions is returned as is.

    Examples
    --------
    >>> from planners.scene import Scene
    >>> square = Polygon([(0, 0), (1, 0), (1, 1), (0, 1)])
    >>> s = Scene(obstacles=(square,), start=(-2, 0), goal=(3, 0),
    ...           motions=(Motion(0, ((0.0, 4.0),), speed=1.0),))
    >>> scene_at(s, 2.0).obstacles[0].bounds, scene_at(s, 2.0).motions
    ((0.0, 2.0, 1.0, 3.0), ())
    """
    if not scene.motions:
        return scene
    obstacles = list(scene.obstacles)
    for m in scene.motions:
        obstacles[m.obstacle] = _translated(obstacles[m.obstacle], motion_offset(m, t))
    return dataclasses.replace(scene, obstacles=tuple(obstacles), motions=())
