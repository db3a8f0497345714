"""Maps as scenarios: a scenario drawn into a map comes back; default endpoints; the CLI."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely import Polygon

import planners
from planners.__main__ import main
from planners.maps import (
    OCCUPIED,
    OccupancyMap,
    cell_centres,
    default_endpoints,
    free_cells,
    read_map,
    scene_from_map,
)
from planners.scene import ScenarioError
from tests.conftest import ROOT, run_module
from tests.maps import synthetic
from tests.maps.reference import blocked_space

# --------------------------------------------------------------------------- round trip


def _rasterised(scene: planners.Scene, resolution: float, yaw: float) -> OccupancyMap:
    """The scene drawn into a map turned by ``yaw``, centred on it, a margin all round.

    A cell is free when its centre is in the scene's free space.
    """
    assert scene.boundary is not None
    free = scene.boundary.difference(shapely.union_all(scene.obstacles))
    minx, miny, maxx, maxy = scene.boundary.bounds
    side = math.ceil(max(maxx - minx, maxy - miny) * 1.6 / resolution)
    half = side * resolution / 2
    turn = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    corner = np.array(scene.boundary.centroid.coords[0]) - turn @ [half, half]
    origin = (float(corner[0]), float(corner[1]), yaw)
    m = OccupancyMap(np.zeros((side, side), np.uint8), resolution, origin, "drawn.yaml")
    centres = cell_centres(m, np.argwhere(np.ones((side, side), bool)))
    inside = shapely.contains_xy(free, centres[:, 0], centres[:, 1])
    grid = np.where(inside, 0, OCCUPIED).astype(np.uint8).reshape(side, side)
    return OccupancyMap(grid, resolution, origin, "drawn.yaml", "drawn.pgm")


@pytest.mark.parametrize("yaw", [0.0, 0.4, -math.pi / 2])
@pytest.mark.parametrize("tolerance", [None, 0.0, 0.1])
def test_a_scenario_drawn_into_a_map_comes_back_within_the_tolerance(
    tmp_path, yaw, tolerance
):
    scene = planners.load_scene(ROOT / "static_scenarios" / "01_two_convex.json")
    resolution = 0.05
    drawn = _rasterised(scene, resolution, yaw)
    # Through the files, as a user would have it.
    (tmp_path / "drawn.pgm").write_bytes(
        synthetic.encode_pgm(synthetic.picture_of(drawn.cells))
    )
    (tmp_path / "drawn.yaml").write_text(
        synthetic.map_yaml("drawn.pgm", resolution=resolution, origin=drawn.origin)
    )
    m = read_map(tmp_path / "drawn.yaml")
    np.testing.assert_array_equal(m.cells, drawn.cells)
    data = scene_from_map(
        m, scene.start, scene.goal, robot_radius=scene.robot.radius, tolerance=tolerance
    )
    back = planners.load_scene(data)
    assert scene.boundary is not None and back.boundary is not None
    t = resolution if tolerance is None else tolerance
    bound = t + resolution * math.sqrt(2)
    assert len(back.obstacles) == len(scene.obstacles)
    for original in scene.obstacles:
        twin = min(back.obstacles, key=lambda o: o.distance(original.centroid))
        assert twin.hausdorff_distance(original) <= bound
        assert twin.symmetric_difference(original).area <= original.length * bound
    assert back.boundary.hausdorff_distance(scene.boundary) <= bound
    lengths = [planners.plan_all(s, ("vg",))["vg"].length for s in (scene, back)]
    assert lengths[1] == pytest.approx(lengths[0], abs=4 * bound)


# --------------------------------------------------------------------------- endpoints


def _maps() -> dict[str, OccupancyMap]:
    grids = {
        "room": synthetic.room(30, 40, pillars=3, seed=2),
        "maze": synthetic.maze(5, corridor=8, seed=1),
        "noisy": synthetic.noisy_room(50, 60, seed=3),
        "thin walls": synthetic.thin_walls(30, 40),
    }
    return {
        name: OccupancyMap(grid, 0.05, (-1.0, 2.0, 0.25), f"{name}.yaml", f"{name}.pgm")
        for name, grid in grids.items()
    }


@pytest.mark.parametrize("name", list(_maps()))
def test_default_endpoints_are_roomy_free_and_lead_to_a_plan(name):
    m = _maps()[name]
    radius = 0.1
    start, goal = default_endpoints(m, radius)
    assert math.dist(start, goal) > 0.5
    blocked = blocked_space(m, ~free_cells(m))
    clearance = shapely.distance(blocked, shapely.points([start, goal]))
    assert (clearance >= radius + 0.5 * m.resolution - 1e-9).all(), clearance
    scene = planners.load_scene(scene_from_map(m, start, goal, robot_radius=radius))
    plans = planners.plan_all(scene)
    assert plans["vg"].status == "ok" and plans["svg"].status == "ok"
    assert plans["dsb"].status == "reached"


def test_a_map_without_free_cells_has_no_endpoints():
    m = OccupancyMap(np.full((3, 3), OCCUPIED, np.uint8), 1.0, (0, 0, 0), "full.yaml")
    with pytest.raises(
        ScenarioError, match=r"full.yaml: image: no free cell in the map"
    ):
        default_endpoints(m)


# --------------------------------------------------------------------------- errors

ENDPOINT_ERRORS = [
    (
        (-5.0, 0.5),
        (0.5, 0.5),
        "start",
        r"\(-5, 0.5\) is off the map: cell \(row 0, column -5",
    ),
    (
        (0.5, 0.5),
        (0.5, 99.0),
        "goal",
        r"is off the map: .* the map has 6 rows and 6 columns",
    ),
    (
        (2.5, 2.5),
        (0.5, 0.5),
        "start",
        r"\(2.5, 2.5\) is in an occupied cell \(row 2, column 2",
    ),
    (
        (0.5, 0.5),
        (4.5, 4.5),
        "goal",
        r"is in an unknown cell .*unknown cells count as occupied unless told",
    ),
    ((0.5, 0.5), (float("nan"), 1.0), "goal", r"expected a finite point"),
    ((0.5, 0.5, 1.0), (0.5, 0.5), "start", r"expected a finite point"),
]


@pytest.mark.parametrize(("start", "goal", "field", "problem"), ENDPOINT_ERRORS)
def test_a_start_or_goal_off_the_free_space_is_one_line_naming_it(
    start, goal, field, problem
):
    grid = np.zeros((6, 6), np.uint8)
    grid[2, 2] = OCCUPIED
    grid[4, 4] = 2
    m = OccupancyMap(grid, 1.0, (0.0, 0.0, 0.0), "cells.yaml")
    with pytest.raises(ScenarioError) as info:
        scene_from_map(m, start, goal)
    error = info.value
    assert error.field == field and "\n" not in str(error)
    assert str(error).startswith(f"cells.yaml: {field}: ")
    assert re.search(problem, error.problem), error.problem


def test_bad_options_are_refused():
    m = OccupancyMap(np.zeros((3, 3), np.uint8), 1.0, (0, 0, 0))
    with pytest.raises(ValueError):
        scene_from_map(m, (0.5, 0.5), (2.5, 2.5), robot_radius=-1.0)
    with pytest.raises(ValueError):
        scene_from_map(m, (0.5, 0.5), (2.5, 2.5), tolerance=math.nan)
    with pytest.raises(ValueError):
        scene_from_map(m, (0.5, 0.5), (2.5, 2.5), unknown="maybe")
    with pytest.raises(ValueError):
        scene_from_map(m, (0.5, 0.5), (2.5, 2.5), map_file="../lab.yaml")


# --------------------------------------------------------------------------- the command line


@pytest.fixture
def lab(tmp_path) -> Path:
    grid = synthetic.room(40, 50, pillars=2, seed=4)
    grid[30:34, 5:9] = 2  # unknown
    return synthetic.write_map(
        tmp_path, "lab", grid, resolution=0.1, origin=(-2.0, -1.0, 0.0)
    )


def test_import_map_writes_a_scenario_beside_the_map_that_names_it(lab, capsys):
    out = lab.parent / "lab scene.json"
    code = main(
        [
            "import-map",
            str(lab),
            "--start",
            "-1.2",
            "-0.2",
            "--goal",
            "2.5",
            "2.5",
            "--robot-radius",
            "0.2",
            "-o",
            str(out),
        ]
    )
    assert code == 0, capsys.readouterr().err
    assert "wrote" in capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["map"] == "lab.yaml" and data["name"] == "lab"
    assert data["robot"]["radius"] == 0.2 and data["start"] == [-1.2, -0.2]
    assert "0.1 m" in data["description"] and "50 x 40 cells" in data["description"]
    scene = planners.load_scene(out)
    assert scene.map == "lab.yaml"
    assert main(["plan", str(out)]) == 0
    planned = json.loads(capsys.readouterr().out)
    assert planned["vg"]["status"] == "ok"


def test_import_map_elsewhere_names_no_map_and_says_so(lab, tmp_path, capsys):
    out = tmp_path / "elsewhere" / "scene.json"
    out.parent.mkdir()
    assert main(["import-map", str(lab), "-o", str(out), "--unknown", "free"]) == 0
    assert "names no map" in capsys.readouterr().err
    data = json.loads(out.read_text())
    assert "map" not in data and "unknown cells counted as free" in data["description"]


@pytest.mark.parametrize(
    ("arguments", "line"),
    [
        (["nope.yaml"], r"^error: .*nope.yaml: \(file\): cannot read: No such file"),
        (
            ["{lab}", "--start", "-1.95", "-0.95", "--goal", "1", "1"],
            r"^error: .*lab.yaml: start: .* occupied",
        ),
        (
            ["{lab}", "--start", "0", "0"],
            r"^error: give both --start and --goal, or neither",
        ),
        (
            ["{lab}", "--tolerance", "-1"],
            r"error: argument --tolerance: must be a number >= 0",
        ),
    ],
)
def test_import_map_errors_are_one_line_and_exit_2(
    lab, tmp_path, capsys, arguments, line
):
    argv = [
        "import-map",
        *[a.format(lab=lab) for a in arguments],
        "-o",
        str(tmp_path / "s.json"),
    ]
    try:
        code = main(argv)
    except SystemExit as done:  # argparse's refusals
        code = done.code
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert re.search(line, err.strip()), err
    assert not (tmp_path / "s.json").exists()


def test_the_real_command_writes_a_loadable_file(lab):
    out = lab.parent / "real.json"
    done = run_module("planners", "import-map", str(lab), "-o", str(out), timeout=300)
    assert done.returncode == 0, done.stderr
    assert planners.load_scene(out).map == "lab.yaml"
    planned = run_module("planners", "plan", str(out), timeout=300)
    assert (
        planned.returncode == 0 and json.loads(planned.stdout)["vg"]["status"] == "ok"
    )


def test_polygons_written_are_simple_and_the_start_inside():
    m = OccupancyMap(synthetic.noisy_room(50, 60, seed=9), 0.05, (3, 4, 2.0), "n.yaml")
    start, goal = default_endpoints(m, 0.1)
    data = scene_from_map(m, start, goal, robot_radius=0.1, tolerance=0.1)
    rings = [data["boundary"], *data["obstacles"]]
    assert all(Polygon(r).is_valid and len(r) >= 3 for r in rings)
    assert Polygon(data["boundary"]).contains(shapely.Point(start))


def test_the_shipped_example_is_the_documented_import_of_its_map(tmp_path, capsys):
    # docs/maps.md: import-map lab.yaml --start 0.5 0.5 --goal 8.5 4.0 -o lab.json
    folder = ROOT / "static_scenarios" / "maps"
    for name in ("lab.yaml", "lab.pgm"):
        (tmp_path / name).write_bytes((folder / name).read_bytes())
    argv = ["import-map", str(tmp_path / "lab.yaml"), "--start", "0.5", "0.5"]
    argv += ["--goal", "8.5", "4.0", "-o", str(tmp_path / "lab.json")]
    assert main(argv) == 0
    assert capsys.readouterr().out.startswith(
        f"wrote {tmp_path / 'lab.json'}: a boundary of 30 vertices and 8 obstacles"
    )
    assert (tmp_path / "lab.json").read_text() == (folder / "lab.json").read_text()
    import jsonschema

    schema = json.loads(
        (ROOT / "static_scenarios/schema/scenario.schema.json").read_text()
    )
    jsonschema.validate(json.loads((folder / "lab.json").read_text()), schema)
    plans = planners.plan_all(planners.load_scene(folder / "lab.json"))
    assert [plans[p].status for p in ("vg", "svg", "dsb")] == ["ok", "ok", "reached"]
