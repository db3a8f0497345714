"""Slide pictures (app.media.slides, app.media.pictures): legible labels at projector and paper sizes.

The browser tests draw 02_three_obstacles at 1920 x 1080 (a projector) and 800 x 500 (a
two-column paper figure) and measure the labels' text in the picture's pixels; the layout
tests check, without a browser, that the camera puts the scene where the layout says and
that every shipped scenario's labels are placed (the browser's boxes are checked for
every scenario by tests/test_snapshots.py).
"""

from __future__ import annotations

import io
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import planners
from app import live, start_app
from app.__main__ import main as app_main
from app.media.camera import frame_camera, picture_bounds
from app.media.jobs import batch, run_with_browser
from app.media.pictures import open_studio
from app.media.slides import (
    MOVING_ROUTE,
    SlideOptions,
    font_px,
    layout,
    legend_rows,
    project,
    slide_camera,
)
from app.ui.labels import Box
from planners.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((ROOT / "static_scenarios").glob("*.json"))
NAME = "02_three_obstacles"

LABEL_BOXES_JS = """() => [...document.querySelectorAll('.planner-label')].map(e => {
    const r = e.getBoundingClientRect();
    return {text: e.textContent, kind: e.className, box: [r.left, r.top, r.right, r.bottom]};
})"""


def text_height(picture: np.ndarray, box: list[float]) -> int:
    """Height [px] of the dark text inside a label's box (rows holding dark pixels)."""
    x0, y0, x1, y1 = (round(v) for v in box)
    border = 4  # stay off the box's border
    inner = picture[y0 + border : y1 - border, x0 + border : x1 - border]
    dark = (inner.max(axis=2) < 90).any(axis=1)
    rows = np.flatnonzero(dark)
    return int(rows[-1] - rows[0] + 1) if len(rows) else 0


@pytest.fixture(scope="module")
def planner_app() -> Iterator:
    """One app of NAME for both sizes: each picture's studio stages it anew."""
    running = start_app(NAME, print_url=False)
    yield running
    running.stop()


@pytest.mark.parametrize(("width", "height"), [(1920, 1080), (800, 500)])
def test_labels_are_a_fixed_share_of_the_picture_height(
    browser, planner_app, width, height
) -> None:
    with open_studio(planner_app, browser, width=width, height=height) as studio:
        png = studio.picture()
        labels = studio.shown.page.evaluate(LABEL_BOXES_JS)
        legend = studio.shown.page.evaluate(
            "() => !!document.querySelector('.planner-legend')"
        )
        gizmos = studio.app.view.gizmos.handles
    picture = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    assert picture.shape == (height, width, 3)
    assert legend
    assert all(g.disable_axes and g.disable_sliders for g in gizmos.values())
    # Capital letters and digits of every event label: 2.0 % of the picture's height or
    # more (the app's own 3-D labels were about 10 px, 0.9 %, at 1080), and never so big
    # that a label fills a slide (3 %).
    events = [d for d in labels if "event" in d["kind"]]
    assert {d["text"] for d in events} >= {"H2", "D2", "H3", "M3", "L3"}
    for d in events:
        measured = text_height(picture, d["box"])
        assert 0.02 * height <= measured <= 0.03 * height, (d["text"], measured)
    # The label boxes are the font's size: 1.8 em tall (text and padding).
    for d in labels:
        assert d["box"][3] - d["box"][1] == pytest.approx(1.8 * font_px(height), abs=1)


def test_a_batch_keeps_one_page_and_names_files_by_scenario_and_view(
    browser, tmp_path
) -> None:
    jobs = [
        (str(SCENARIOS[0]), "top", tmp_path / "a-top.png"),
        (str(SCENARIOS[0]), "perspective", tmp_path / "a-perspective.png"),
        (str(SCENARIOS[1]), "top", tmp_path / "b-top.png"),
    ]
    planner_app = start_app(SCENARIOS[0], print_url=False)
    contexts_before = len(browser.contexts)
    try:
        written = batch(planner_app, browser, jobs, width=480, height=300)
    finally:
        planner_app.stop()
    assert written == [j[2] for j in jobs]
    assert len(browser.contexts) == contexts_before  # its one page is closed again
    a, persp, b = (np.asarray(Image.open(p).convert("RGB")) for p in written)
    assert a.shape == persp.shape == b.shape == (300, 480, 3)
    # Another view and another scenario are other pictures.
    assert (np.abs(a.astype(int) - persp).max(axis=2) > 16).mean() > 0.05
    assert (np.abs(a.astype(int) - b).max(axis=2) > 16).mean() > 0.05


def test_the_browser_is_launched_while_the_app_starts_and_both_stop() -> None:
    seen = {}

    def work(planner_app, browser):
        seen["connected"] = browser.is_connected()
        seen["port"] = planner_app.port
        return "done"

    assert run_with_browser(lambda: start_app(NAME, print_url=False), work) == "done"
    assert seen["connected"]


def test_an_app_that_fails_to_start_stops_the_browser_and_raises_its_error() -> None:
    def start():
        raise ValueError("no such scenario")

    with pytest.raises(ValueError, match="no such scenario"):
        run_with_browser(start, lambda a, b: None)


# --------------------------------------------------------------------------- no browser


def test_projection_matches_the_top_camera_of_the_snapshots() -> None:
    pose = frame_camera((0.0, 0.0, 10.0, 8.0), 1000, 800)
    px = project(pose, 1000, 800, [[5.0, 4.0, 0.0], [10.0, 4.0, 0.0], [5.0, 8.0, 0.0]])
    assert px[0] == pytest.approx([500, 400])
    assert px[1][0] > 500 and px[1][1] == pytest.approx(400)  # +x is right
    assert px[2][1] < 400 and px[2][0] == pytest.approx(500)  # +y is up


def test_slide_camera_fits_the_scene_in_its_area() -> None:
    bounds = (0.0, 0.0, 12.0, 6.0)
    area = Box(20, 80, 1400, 1060)
    pose = slide_camera(bounds, 1920, 1080, area)
    corners = project(pose, 1920, 1080, [[0, 0, 0], [12, 6, 0]])
    xs, ys = sorted(corners[:, 0]), sorted(corners[:, 1])
    assert area.x0 <= xs[0] and xs[1] <= area.x1
    assert area.y0 <= ys[0] and ys[1] <= area.y1
    # It fills the area's limiting side, less the 3 % margins.
    assert xs[1] - xs[0] == pytest.approx(area.width / (1 + 2 * 0.03), rel=1e-6)


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
@pytest.mark.parametrize(("width", "height"), [(1920, 1080), (800, 500)])
def test_every_shipped_scenario_gets_all_its_labels_without_overlaps(
    path, width, height
) -> None:
    scene = load_scene(path)
    plans = planners.plan_all(scene, ("vg", "svg", "dsb", "bug2"))
    slide = layout(scene, plans, {"bug2_path": True}, width, height)
    assert not slide.labels.dropped
    boxes = [p.box for p in slide.labels.placed]
    reserved = [
        b
        for b in (slide.title and slide.title[1], slide.legend and slide.legend[1])
        if b
    ]
    for k, box in enumerate(boxes):
        assert box.inside(width, height)
        assert not any(box.overlaps(o) for o in boxes[k + 1 :])
        assert not any(box.overlaps(m) for m in [*slide.markers, *reserved])
    # Every event of both trace planners is named, plus the numbers, start and goal.
    events = sum(len(getattr(plans[n], "events", ())) for n in ("dsb", "bug2"))
    assert len(boxes) == events + len(scene.obstacles) + 2
    # The scene stays clear of the title and the legend.
    x0, y0, x1, y1 = picture_bounds(scene)
    corners = project(slide.camera, width, height, [[x0, y0, 0], [x1, y1, 0]])
    scene_box = Box(
        min(corners[:, 0]), min(corners[:, 1]), max(corners[:, 0]), max(corners[:, 1])
    )
    for other in reserved:
        assert not scene_box.overlaps(other)


def test_options_turn_the_legend_title_and_labels_off() -> None:
    scene = load_scene(SCENARIOS[0])
    plans = planners.plan_all(scene, ("vg", "dsb"))
    bare = layout(
        scene,
        plans,
        {},
        800,
        500,
        options=SlideOptions(legend=False, title="", labels=False),
    )
    assert bare.legend is None and bare.title is None and not bare.labels.placed
    named = layout(scene, plans, {}, 800, 500, options=SlideOptions(title="Lecture 9"))
    assert named.title is not None and named.title[0] == "Lecture 9"
    assert [r.text for r in legend_rows(plans, {})][-1].startswith("H hit")
    assert "DSB" not in " ".join(
        r.text for r in legend_rows(plans, {"dsb_path": False})
    )


def test_snapshot_dir_on_the_command_line(tmp_path) -> None:
    out = tmp_path / "pictures"
    result = subprocess.run(
        [sys.executable, "-m", "app", "--snapshot-dir", str(out), "--scenario",
         "01,02_three_obstacles", "--views", "top,perspective", "--width", "320",
         "--height", "200", "--no-legend"],
        capture_output=True, text=True, cwd=ROOT, timeout=300, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout == "" and result.stderr == ""
    assert sorted(p.name for p in out.iterdir()) == [
        "01_two_convex-perspective.png",
        "01_two_convex-top.png",
        "02_three_obstacles-perspective.png",
        "02_three_obstacles-top.png",
    ]
    assert Image.open(out / "01_two_convex-top.png").size == (320, 200)


BAD_SNAPSHOT_DIR_ARGS = [
    (["--views", "side"], "views must be among top, perspective"),
    (["--scenario", "no_such_thing"], "cannot load scenario"),
    (["--width", "3"], "width must be a whole number"),
]


@pytest.mark.parametrize(("args", "message"), BAD_SNAPSHOT_DIR_ARGS)
def test_snapshot_dir_bad_arguments_are_one_line(
    tmp_path, capsys, args, message
) -> None:
    # The command line's own function (``python -m app`` is ``sys.exit(main())``), in
    # this process; the real command line is run below.
    code = app_main(["--snapshot-dir", str(tmp_path / "x"), *args])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("error: ") and message in err
    assert err.count("\n") == 1
    assert not (tmp_path / "x").exists()


def test_snapshot_dir_bad_arguments_on_the_command_line(tmp_path) -> None:
    args, message = BAD_SNAPSHOT_DIR_ARGS[0]
    result = subprocess.run(
        [sys.executable, "-m", "app", "--snapshot-dir", str(tmp_path / "x"), *args],
        capture_output=True, text=True, cwd=ROOT, timeout=120, check=False,
    )  # fmt: skip
    assert result.returncode == 2
    assert result.stderr.startswith("error: ") and message in result.stderr
    assert result.stderr.count("\n") == 1
    assert not (tmp_path / "x").exists()


def test_the_legend_names_a_moving_obstacles_route_when_the_scene_has_one() -> None:
    assert MOVING_ROUTE == live._MOVING  # the colour the route is drawn in
    for path in SCENARIOS:
        scene = load_scene(path)
        plans = planners.plan_all(scene, ("vg", "svg", "dsb"))
        slide = layout(scene, plans, {}, 1920, 1080)
        assert slide.legend is not None
        rows = {r.text: r for r in slide.legend[0]}
        route = rows.get("moving obstacle's route")
        assert (route is not None) == bool(scene.motions), path.stem
        if route is not None:
            assert route.swatches == (("#cc79a7", "dashed"),)


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_a_time_stamp_box_is_kept_clear_of_the_title_legend_and_labels(path) -> None:
    scene = load_scene(path)
    plans = planners.plan_all(scene, ("vg", "svg", "dsb"))
    options = SlideOptions(time_stamp=True)
    for width, height in ((1920, 1080), (640, 360)):
        slide = layout(scene, plans, {}, width, height, options=options)
        plain = layout(scene, plans, {}, width, height)
        stamp = slide.stamp
        assert stamp is not None and plain.stamp is None
        assert stamp.inside(width, height)
        # As tall as the title's line, wide enough for "t = 000.0 s" in the labels' font.
        assert stamp.height == pytest.approx(1.3 * 1.2 * slide.font_px)
        assert stamp.width >= 11 * 0.62 * slide.font_px
        others = [p.box for p in slide.labels.placed]
        if slide.title:
            others.append(slide.title[1])
        if slide.legend:
            others.append(slide.legend[1])
        assert not any(stamp.overlaps(o) for o in others)
        assert not slide.labels.dropped


def _room_of_triangles(count: int, room: float, side: float) -> planners.Scene:
    """``count`` equal triangles on a jittered lattice of a ``room`` metres square room."""
    rng = np.random.default_rng(7)
    per_row = int(np.ceil(np.sqrt(count)))
    cell = room / per_row
    obstacles = []
    for k in range(count):
        x, y = (np.array([k % per_row, k // per_row]) + 0.5) * cell
        x, y = (x, y) + rng.uniform(-0.2, 0.2, 2) * cell
        obstacles.append([[x, y], [x + side, y], [x, y + side]])
    return planners.load_scene(
        {
            "format": 1,
            "boundary": [[0, 0], [room, 0], [room, room], [0, room]],
            "obstacles": obstacles,
            "start": [0.3 * cell, 0.3 * cell],
            "goal": [room - 0.3 * cell, room - 0.3 * cell],
            "robot": {"radius": 0.1},
        }
    )


@pytest.mark.parametrize(("width", "height"), [(1920, 1080), (800, 500)])
def test_obstacles_smaller_than_their_number_are_not_numbered(width, height) -> None:
    """400 specks in a big room get no numbers (500 boxes with leader lines would bury
    the scene); obstacles as big as their number on the picture keep theirs."""
    specks = _room_of_triangles(400, 100.0, 0.6)
    slide = layout(specks, {}, {}, width, height)
    assert [p.request.text for p in slide.labels.placed] == ["start", "goal"]
    assert not slide.labels.dropped
    blocks = _room_of_triangles(16, 20.0, 3.0)
    slide = layout(blocks, {}, {}, width, height)
    numbers = {p.request.text for p in slide.labels.placed} - {"start", "goal"}
    assert numbers == {str(k + 1) for k in range(16)}
