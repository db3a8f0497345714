"""Occupancy maps in the app: opened from the scenes folder, the command line or a zip
upload, laid on the floor under their trace, and the robot's motion downloaded.

An upload is hostile: a zip is read in memory within bounds, its folder names are
ignored, and nothing of it reaches the disk; each refusal is one line in the panel and
the scene is kept.
"""

from __future__ import annotations

import csv
import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import planners
from app import Frame, PlannerApp, start_app
from app.server import open_scenario
from app.session import files
from app.session.files import (
    MAX_UNZIPPED_BYTES,
    MAX_UPLOAD_MAP_EDGES,
    MAX_UPLOAD_PICTURE_BYTES,
    MAX_UPLOAD_PIXELS,
    MAX_ZIP_ENTRIES,
    ScenesFolder,
    map_scene,
    read_zip,
)
from app.ui.backdrop import backdrop_of
from app.ui.view import yaw_quaternion
from planners import export, maps
from planners.drive import trajectory
from planners.scene import ScenarioError
from tests.app.app_helpers import has_label, wait_until
from tests.maps.synthetic import encode_pgm, map_yaml, picture_of, room, write_map
from tests.viser_client import ViserClient

UPLOAD = "Upload a scenario (.json) or map (.zip)"
ORIGIN = (
    -1.5,
    2.0,
    0.3,
)  # a map turned by 0.3 rad about a corner off the world's origin


@pytest.fixture
def scenes(tmp_path: Path) -> Path:
    folder = tmp_path / "scenes"
    folder.mkdir()
    write_map(
        folder, "lab", room(40, 60, pillars=3, seed=1), resolution=0.1, origin=ORIGIN
    )
    return folder


def _zip(files: dict[str, bytes]) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in files.items():
            archive.writestr(name, data)
    return out.getvalue()


def _lab_zip(grid: np.ndarray | None = None, folder: str = "") -> bytes:
    grid = room(40, 60, pillars=3, seed=1) if grid is None else grid
    return _zip(
        {
            f"{folder}lab.yaml": map_yaml(
                "lab.pgm", resolution=0.1, origin=ORIGIN
            ).encode(),
            f"{folder}lab.pgm": encode_pgm(picture_of(grid)),
        }
    )


def _tree(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def _frame(planner: PlannerApp) -> Frame:
    """The app's last frame (start_app returns once the first is drawn)."""
    frame = planner.controller.frame
    assert frame is not None
    return frame


# --------------------------------------------------------------------------- opening


def test_a_map_in_the_scenes_folder_opens_with_its_trace_and_its_picture(
    make_controller, scene, scenes
):
    folder = ScenesFolder(scenes)
    assert "lab.yaml" in folder.names()
    controller, _ = make_controller(scene, folder=folder)
    controller.files.load_from_folder("lab.yaml")
    assert controller.wait_idle(30)
    frame = controller.frame
    floor_map = maps.read_map(scenes / "lab.yaml")
    # The scene is the map's import around the chosen endpoints, with the robot kept.
    start, goal = maps.default_endpoints(floor_map, scene.robot.radius)
    expected = maps.scene_from_map(
        floor_map, start, goal, robot_radius=scene.robot.radius, map_file="lab.yaml"
    )
    assert frame.scene.map == "lab.yaml"
    assert frame.scene.boundary == planners.load_scene(expected).boundary
    assert frame.scene.obstacles == planners.load_scene(expected).obstacles
    assert frame.scene.robot == scene.robot
    assert np.array_equal(frame.floor_map.cells, floor_map.cells)
    assert frame.floor_map.origin == ORIGIN
    assert {frame.plans[n].status for n in ("vg", "svg")} == {"ok"}
    assert "Loaded lab.yaml from the folder." in frame.message
    # One undo step takes the map away with the scene it came with.
    controller.undo()
    assert controller.wait_idle(30)
    assert controller.frame.scene == scene and controller.frame.floor_map is None
    controller.redo()
    assert controller.wait_idle(30)
    assert controller.frame.floor_map is not None


def test_edits_keep_the_map_under_the_scene(make_controller, scene, scenes):
    controller, _ = make_controller(scene, folder=ScenesFolder(scenes))
    controller.files.load_from_folder("lab.yaml")
    assert controller.wait_idle(30)
    shown = controller.frame.floor_map
    controller.edits.move_goal(controller.scene.start)
    assert controller.wait_idle(30)
    assert controller.frame.floor_map is shown


def test_a_scenario_beside_its_map_shows_the_map(make_controller, scene, scenes):
    floor_map = maps.read_map(scenes / "lab.yaml")
    start, goal = maps.default_endpoints(floor_map)
    data = maps.scene_from_map(floor_map, start, goal, map_file="lab.yaml")
    (scenes / "lab scene.json").write_text(json.dumps(data))
    controller, _ = make_controller(scene, folder=ScenesFolder(scenes))
    controller.files.load_from_folder("lab scene.json")
    assert controller.wait_idle(30)
    assert controller.frame.floor_map is not None
    assert controller.frame.scene.start == tuple(start)
    # Without its map the scene still opens, and the panel says why there is no picture.
    (scenes / "lab.pgm").unlink()
    controller.files.load_from_folder("lab scene.json")
    assert controller.wait_idle(30)
    frame = controller.frame
    assert frame.floor_map is None and frame.scene.map == "lab.yaml"
    assert "Its map is not shown: lab.yaml: image: " in frame.message


def test_the_command_line_opens_a_map_or_a_scenario_naming_one(scenes):
    scene, floor_map = open_scenario(scenes / "lab.yaml")
    assert scene.map == "lab.yaml" and floor_map.origin == ORIGIN
    planners.save_scene(scene, scenes / "saved.json")
    again, floor_map = open_scenario(scenes / "saved.json")
    assert again == scene and floor_map is not None
    with pytest.raises(ScenarioError, match=r"nope.yaml: \(file\): cannot read"):
        open_scenario(scenes / "nope.yaml")


def test_a_map_is_never_saved_over(make_controller, scene, scenes):
    controller, _ = make_controller(scene, folder=ScenesFolder(scenes))
    before = _tree(scenes)
    controller.files.save_to_folder("lab.yaml")
    assert controller.wait_idle(30)
    assert "is a map; save the scene as a .json file" in controller.frame.message
    assert _tree(scenes) == before


# --------------------------------------------------------------------------- uploads


def test_a_zip_upload_opens_the_map(make_controller, scene):
    controller, _ = make_controller(scene)
    controller.files.load_text(_lab_zip(folder="my maps/"), "lab.zip")
    assert controller.wait_idle(30)
    frame = controller.frame
    assert frame.message == "Loaded lab.zip."
    assert frame.scene.map == "lab.yaml" and frame.floor_map is not None
    assert frame.floor_map.source == "lab.zip/lab.yaml"


def test_a_zip_with_a_scenario_opens_that_scenario_on_the_map(
    make_controller, scene, scenes
):
    floor_map = maps.read_map(scenes / "lab.yaml")
    start, goal = maps.default_endpoints(floor_map)
    data = maps.scene_from_map(floor_map, goal, start, map_file="lab.yaml")  # reversed
    files = {
        "lab.yaml": (scenes / "lab.yaml").read_bytes(),
        "lab.pgm": (scenes / "lab.pgm").read_bytes(),
        "lab scene.json": json.dumps(data).encode(),
    }
    controller, _ = make_controller(scene)
    controller.files.load_text(_zip(files), "class.zip")
    assert controller.wait_idle(30)
    assert controller.frame.scene == planners.load_scene(data)
    assert controller.frame.floor_map is not None


def test_a_plain_scenario_upload_naming_a_map_shows_none(
    make_controller, scene, scenes
):
    # An upload never names a file of the server's disk, not even one of the folder.
    floor_map = maps.read_map(scenes / "lab.yaml")
    data = maps.scene_from_map(
        floor_map, *maps.default_endpoints(floor_map), map_file="lab.yaml"
    )
    controller, _ = make_controller(scene, folder=ScenesFolder(scenes))
    controller.files.load_text(json.dumps(data), "lab scene.json")
    assert controller.wait_idle(30)
    assert (
        controller.frame.scene.map == "lab.yaml" and controller.frame.floor_map is None
    )


def _specks(side: int) -> np.ndarray:
    """A free square with an occupied cell every other cell: a speck a cell."""
    grid = np.zeros((side, side), np.uint8)
    grid[1:-1:2, 1:-1:2] = maps.OCCUPIED
    return grid


def _gif() -> bytes:
    out = io.BytesIO()
    Image.new("L", (4, 4), 254).save(out, "GIF")
    return out.getvalue()


def _bomb() -> bytes:
    # 40 MB of one byte packs into about 40 kB, and the header says so honestly.
    return _zip({"lab.yaml": b"image: lab.pgm\n", "lab.pgm": b"\0" * 40_000_000})


def _lying_bomb() -> bytes:
    # The same, its central directory claiming 100 bytes: the unpacking stops at 100
    # and the checksum gives it away.
    data = bytearray(_bomb())
    central = bytes(data).rfind(b"PK\x01\x02")  # the last entry's: lab.pgm
    assert bytes(data[central + 46 : central + 53]) == b"lab.pgm"
    data[central + 24 : central + 28] = (100).to_bytes(4, "little")  # uncompressed size
    return bytes(data)


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        (b"PK\x03\x04 not really a zip", "x.zip: (file): not a zip file"),
        (_bomb(), f"x.zip: (file): more than {MAX_UNZIPPED_BYTES:,} bytes unpacked"),
        (_lying_bomb(), "x.zip: (file): lab.pgm: Bad CRC-32"),
        (
            _zip({f"f{k}.txt": b"" for k in range(MAX_ZIP_ENTRIES + 1)}),
            f"x.zip: (file): more than {MAX_ZIP_ENTRIES} files in the zip",
        ),
        (
            _zip({"a/lab.pgm": b"1", "b/lab.pgm": b"2", "lab.yaml": b""}),
            "two files named 'lab.pgm'",
        ),
        (_zip({"notes.txt": b"hello"}), "holds one map (.yaml and its picture)"),
        (
            _zip({"lab.yaml": map_yaml("lab.pgm").encode()}),
            "x.zip/lab.yaml: image: no picture named 'lab.pgm'",
        ),
        (
            _zip({"lab.yaml": map_yaml("../../etc/lab.pgm").encode(), "x.pgm": b""}),
            "x.zip/lab.yaml: image: no picture named 'lab.pgm'",
        ),
        (
            _zip(
                {
                    "lab.yaml": map_yaml("lab.pgm").encode(),
                    "lab.pgm": encode_pgm(np.zeros((2001, 2000), np.uint8)),
                }
            ),
            f"x.zip/lab.yaml: image: 2000 x 2001 pixels, more than the {MAX_UPLOAD_PIXELS:,}",
        ),
        (
            _zip(
                {
                    "lab.yaml": map_yaml("lab.pgm").encode(),
                    "lab.pgm": encode_pgm(picture_of(_specks(400))),
                }
            ),
            f"x.zip/lab.yaml: image: 158,404 cell edges between free and blocked cells, more than the {MAX_UPLOAD_MAP_EDGES:,}",
        ),
        (
            _zip(
                {
                    "lab.yaml": map_yaml("lab.pgm").encode(),
                    "lab.pgm": encode_pgm(picture_of(room(20, 20))),
                    "s.json": b" " * 1_000_001,
                }
            ),
            "x.zip/s.json: (file): 1,000,001 bytes, more than the 1,000,000",
        ),
        (
            _zip(
                {
                    "lab.yaml": map_yaml("lab.pgm").encode(),
                    "lab.pgm": b"P2" + b" " * 5_000_000 + b"1 1\n255\n254\n",
                }
            ),
            "x.zip/lab.yaml: image: lab.pgm: a PNM header of more than 4096 bytes",
        ),
        (
            _zip(
                {
                    "lab.yaml": map_yaml("lab.pgm").encode(),
                    "lab.pgm": b"P5 1 1 255\n" + b"\xfe" * 17_000_000,
                }
            ),
            f"x.zip/lab.yaml: image: 17,000,011 bytes, more than the {MAX_UPLOAD_PICTURE_BYTES:,}",
        ),
        (
            _zip({"lab.yaml": map_yaml("lab.gif").encode(), "lab.gif": _gif()}),
            "x.zip/lab.yaml: image: lab.gif: not a PNG, PGM, PPM, PBM or BMP picture",
        ),
        (
            _zip({"lab.yaml": b"image: [1, 2]\n", "lab.pgm": b""}),
            "x.zip/lab.yaml: image: expected a file name",
        ),
        (
            _zip(
                {
                    "lab.yaml": map_yaml("lab.pgm").encode(),
                    "lab.pgm": encode_pgm(picture_of(room(20, 20))),
                    "s.json": b'{"format": 1, "obstacles": [], "start": [1, 1], "goal": [2, 2]}',
                }
            ),
            "x.zip/s.json: map: expected the zip's map 'lab.yaml', got ''",
        ),
    ],
    ids=[
        "not-zip",
        "bomb",
        "lying-bomb",
        "entries",
        "twins",
        "no-map",
        "no-picture",
        "picture-path",
        "pixels",
        "specks",
        "big-scenario",
        "padded-header",
        "big-picture",
        "gif",
        "yaml-field",
        "scenario-other-map",
    ],
)
def test_a_bad_zip_is_one_line_and_the_scene_is_kept(
    make_controller, scene, data, expected
):
    controller, _ = make_controller(scene)
    before = controller.frame
    controller.files.load_text(data, "x.zip")
    assert controller.wait_idle(30)
    frame = controller.frame
    assert frame.scene == before.scene and frame.floor_map is None
    assert frame.message.startswith("Not loaded, the scene is kept: ")
    assert expected in frame.message and "\n" not in frame.message, frame.message


@pytest.mark.parametrize("name", ["lab (2).yaml", "étage.yaml", "x" * 80 + ".yaml"])
def test_a_zip_whose_map_has_no_plain_name_opens_naming_no_map(
    make_controller, scene, name
):
    files = zipfile.ZipFile(io.BytesIO(_lab_zip()))
    renamed = {name: files.read("lab.yaml"), "lab.pgm": files.read("lab.pgm")}
    controller, _ = make_controller(scene)
    controller.files.load_text(_zip(renamed), "x.zip")
    assert controller.wait_idle(30)
    frame = controller.frame
    assert frame.message == "Loaded x.zip."
    assert frame.floor_map is not None and frame.scene.map == ""


def test_a_map_tracing_to_too_many_vertices_is_refused(
    make_controller, scene, monkeypatch
):
    # Behind the counts made before the trace (edges, islands): the traced scene's size.
    monkeypatch.setattr(files, "MAX_UPLOAD_MAP_VERTICES", 10)
    controller, _ = make_controller(scene)
    controller.files.load_text(_lab_zip(), "x.zip")
    assert controller.wait_idle(30)
    frame = controller.frame
    assert frame.scene == scene and frame.floor_map is None
    assert "x.zip/lab.yaml: image: the map traces to " in frame.message
    assert "vertices, more than the 10 an upload may have" in frame.message


def test_read_zip_ignores_folders_and_mac_copies():
    files = read_zip(
        _zip(
            {"a/b/lab.yaml": b"y", "__MACOSX/a/._lab.yaml": b"junk", "c\\lab.pgm": b"p"}
        ),
        "x.zip",
    )
    assert files == {"lab.yaml": b"y", "lab.pgm": b"p"}


# --------------------------------------------------------------------------- the picture


def test_the_picture_lies_on_the_map_cell_for_cell():
    cells = np.zeros((3, 5), np.uint8)
    cells[0, 0] = maps.OCCUPIED  # bottom-left
    cells[2, 4] = maps.UNKNOWN  # top-right
    floor_map = maps.OccupancyMap(cells, 0.5, ORIGIN)
    shown = backdrop_of(floor_map, min_side=1)
    assert shown.step == 1 and shown.rgb.shape == (3, 5, 3) and shown.size == (2.5, 1.5)
    assert shown.rgb[0, 0].tolist() == [0, 0, 0]  # row 0 is the map's bottom row
    assert shown.rgb[2, 4].tolist() == [205, 205, 205]
    assert shown.rgb[1, 2].tolist() == [254, 254, 254]
    # The picture's centre is the map's centre, turned with it.
    centre = maps.grid_to_world(floor_map, [[2.5, 1.5]])[0]
    assert np.allclose(shown.centre, centre) and shown.yaw == ORIGIN[2]
    # A small map is enlarged by whole pixels a cell: the same picture, cell for cell.
    big = backdrop_of(floor_map)
    assert big.scale == 1024 // 5 and big.size == shown.size
    assert np.array_equal(big.rgb[:: big.scale, :: big.scale], shown.rgb)


def test_a_big_map_is_reduced_and_a_thin_wall_stays_in_the_picture():
    cells = np.zeros((5000, 3000), np.uint8)
    cells[:, 1501] = maps.OCCUPIED  # a wall one cell thick
    shown = backdrop_of(maps.OccupancyMap(cells, 0.03, (0.0, 0.0, 0.0)))
    assert max(shown.rgb.shape[:2]) <= 2048 and shown.step == 3
    assert (shown.rgb[:, 1501 // 3] == 0).all()
    assert shown.size == (3000 * 0.03, 5001 * 0.03)  # whole blocks: one row more


def test_the_app_lays_the_map_on_the_floor_for_every_browser(scenes):
    planner = start_app(scenes / "lab.yaml", print_url=False, scenes_dir=scenes)
    try:
        client = ViserClient(planner.port)
        try:
            assert client.wait_for(lambda: ("", "/floor_map") in client.nodes, 30)
            node = client.nodes[("", "/floor_map")]
            shown = backdrop_of(_frame(planner).floor_map)
            assert node["type"] == "ImageMessage"
            assert node["props"]["render_width"] == pytest.approx(shown.size[0])
            assert node["props"]["render_height"] == pytest.approx(shown.size[1])
            assert node["props"]["_format"] == "png"
            handle = planner.view._floor_map_node
            assert np.allclose(handle.position[:2], shown.centre)
            assert np.allclose(handle.wxyz, yaw_quaternion(ORIGIN[2]))
            # The layer switch takes it away, and brings it back.
            planner.controller.set_layer("map", False)
            assert client.wait_for(lambda: ("", "/floor_map") not in client.nodes, 30)
            planner.controller.set_layer("map", True)
            assert client.wait_for(lambda: ("", "/floor_map") in client.nodes, 30)
        finally:
            client.close()
    finally:
        planner.stop()


def test_a_zip_uploaded_through_the_page_opens_and_a_bomb_does_not(scenes):
    planner = start_app("01_two_convex", print_url=False)
    try:
        client = ViserClient(planner.port)
        try:
            assert client.wait_for(lambda: has_label(client, UPLOAD), 30)
            client.upload(UPLOAD, "bomb.zip", _bomb())
            assert wait_until(
                lambda: "bytes unpacked" in (_frame(planner).message or ""), 30
            ), _frame(planner).message
            assert _frame(planner).floor_map is None
            client.upload(UPLOAD, "lab.zip", _lab_zip())
            assert wait_until(lambda: _frame(planner).floor_map is not None, 30)
            assert client.wait_for(lambda: ("", "/floor_map") in client.nodes, 30)
        finally:
            client.close()
    finally:
        planner.stop()


# --------------------------------------------------------------------------- paths out


def test_the_motion_downloads_are_what_the_robot_drives(scenes):
    planner = start_app(scenes / "lab.yaml", print_url=False)
    try:
        client = ViserClient(planner.port)
        try:
            assert client.wait_for(
                lambda: has_label(client, "Download the path .csv"), 30
            )
            frame = _frame(planner)
            path = frame.plans[frame.follow].path
            for kind in ("path .csv", "motion .csv", "path and motion .json"):
                client.set_gui(client.uuid(f"Download the {kind}"), True)
            assert client.wait_for(lambda: len(client.downloads) == 3, 30)
        finally:
            client.close()
    finally:
        planner.stop()
    stem = f"{frame.scene.name}_{frame.follow}"
    files = client.downloads
    assert files[f"{stem}_path.csv"].decode() == export.path_csv(path)
    assert files[f"{stem}_motion.csv"].decode() == export.trajectory_csv(
        frame.trajectory
    )
    # The trajectory the robot is animated along is the one planners.drive plans.
    again = trajectory(frame.scene, path)
    assert np.array_equal(again.wheel_rates, frame.trajectory.wheel_rates)
    rows = list(csv.reader(io.StringIO(files[f"{stem}_motion.csv"].decode())))
    assert rows[0][:4] == ["t", "x", "y", "phi"]
    # In the map's world frame: the first pose is the start, on a free cell of the map.
    first = np.array([float(v) for v in rows[1][1:3]])
    assert np.allclose(first, frame.scene.start)
    cell = maps.world_to_cell(frame.floor_map, [first])[0]
    assert frame.floor_map.cells[cell[0], cell[1]] == maps.FREE
    out = json.loads(files[f"{stem}.json"])
    assert out["map"] == "lab.yaml" and out["planner"] == frame.follow


def test_nothing_to_download_is_said_to_the_asker_only(make_controller, scene):
    controller, _ = make_controller(
        planners.load_scene(
            {
                "format": 1,
                "obstacles": [[[-1, -1], [1, -1], [1, 1], [-1, 1]]],
                "start": [0, 0],
                "goal": [3, 0],
            }
        )
    )
    assert controller.motion_file("path .csv") is None
    assert controller.frame.message is None


def test_map_scene_keeps_the_robot_and_settings(scenes):
    like = planners.load_scene(
        {
            "format": 1,
            "obstacles": [],
            "start": [0, 0],
            "goal": [1, 1],
            "robot": {"kind": "differential", "radius": 0.2},
            "expansion": "square",
            "sensor_range": 1.5,
        }
    )
    scene = map_scene(maps.read_map(scenes / "lab.yaml"), like, "lab.yaml")
    assert (scene.robot, scene.expansion, scene.sensor_range) == (
        like.robot,
        "square",
        1.5,
    )
