"""End to end: the real app in headless Chromium, driven with the mouse.

These tests FAIL (never skip) when Chromium cannot start: an end-to-end suite that quietly
does nothing looks exactly like one that passes.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose
from shapely import LineString

from app import start_app
from app.session.controller import TOOLS
from tests.app.app_helpers import TopCamera, mouse_drag, settle, shown_mesh, wait_until

DPR = 0.5  # a coarser canvas in the same layout: these tests read the scene, not pixels

WIDTH, HEIGHT = 1280, 800
# Straight down at the floor of 01_two_convex (10 m x 8 m), left of the panel.
CAMERA = TopCamera(
    look_at=(7.0, 4.0), height=14.0, fov_deg=50.0, width=WIDTH, px_height=HEIGHT
)
GIZMO_SCALE = 0.9  # app.ui.view: start/goal transform controls
PLANE_OFFSET = 0.24 * GIZMO_SCALE  # where the XY-plane square of the gizmo sits [m]


@pytest.fixture
def planner() -> Iterator[Any]:
    app = start_app("01_two_convex", port=0, print_url=False)
    CAMERA.apply(app.server)
    yield app
    app.stop()


def open_page(browser: Any, planner: Any) -> Any:
    page = browser.new_page(
        viewport={"width": WIDTH, "height": HEIGHT}, device_scale_factor=1
    )
    page.goto(f"{planner.url}?fixedDpr={DPR}")
    page.wait_for_function(
        "() => window.__viserMutable && ('/handles/goal' in window.__viserMutable.nodeRefFromName)"
        " && ('/vg/path' in window.__viserMutable.nodeRefFromName)",
        timeout=60_000,
    )
    # The canvas covers the whole page; the panel floats over it.
    box = page.evaluate(
        "() => { const r = document.querySelector('canvas').getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; }"
    )
    assert box == [0, 0, WIDTH, HEIGHT]
    time.sleep(1.0)  # let the first frames render
    return page


def click(page: Any, xy: tuple[float, float]) -> None:
    settle(page)
    page.mouse.click(*CAMERA.pixel(xy))


def choose(page: Any, current: str, option: str) -> None:
    """Pick ``option`` in the panel's dropdown that now shows ``current``."""
    boxes = page.locator("input[role=combobox]")
    matching = [
        boxes.nth(k)
        for k in range(boxes.count())
        if boxes.nth(k).input_value() == current
    ]
    assert matching, f"no dropdown shows {current!r}"
    matching[0].click()
    page.get_by_role("option", name=option).click()


def node_xy(page: Any, name: str) -> tuple[float, float]:
    return tuple(
        page.evaluate(
            f"() => {{ const n = window.__viserMutable.nodeRefFromName['{name}']; return [n.position.x, n.position.y]; }}"
        )
    )


def vg_path(planner: Any) -> np.ndarray:
    return np.asarray(planner.controller.frame.plans["vg"].path).reshape(-1, 2)


def test_dragging_the_goal_with_the_mouse_replans_for_every_browser(browser, planner):
    page = open_page(browser, planner)
    other = open_page(browser, planner)  # a second browser: the projector and a laptop
    scene = planner.controller.scene
    before_nodes = np.asarray(planner.view.graphs["vg"].path.handle.points).copy()
    before_path = vg_path(planner)
    assert_allclose(before_path[-1], scene.goal)

    target = (9.0, 1.0)
    grab = CAMERA.pixel((scene.goal[0] + PLANE_OFFSET, scene.goal[1] + PLANE_OFFSET))
    drop = CAMERA.pixel((target[0] + PLANE_OFFSET, target[1] + PLANE_OFFSET))
    mouse_drag(page, grab, drop)
    # The browser sends the end of the drag after the mouse is released: wait for it.
    assert wait_until(lambda: planner.controller.frame.dragging == frozenset(), 20)
    assert planner.wait_idle(20)

    goal = planner.controller.scene.goal
    tolerance = 3 * CAMERA.metres_per_pixel()  # a few pixels of mouse rounding
    assert (
        abs(goal[0] - target[0]) < tolerance and abs(goal[1] - target[1]) < tolerance
    ), goal
    frame = planner.controller.frame
    assert frame.scene.goal == goal and frame.dragging == frozenset()
    assert frame.plans["vg"].status == "ok" and frame.plans["svg"].status == "ok"
    after_path = vg_path(planner)
    assert_allclose(after_path[-1], goal)
    after_nodes = np.asarray(planner.view.graphs["vg"].path.handle.points)
    assert after_nodes.shape != before_nodes.shape or not np.allclose(
        after_nodes, before_nodes
    )
    assert_allclose(
        after_nodes[-1, 1, :2], goal, atol=1e-5
    )  # the drawn path ends at the new goal
    # One drag is one undo step, and the panel's Undo button takes it back.
    assert frame.can_undo
    page.get_by_role("button", name="Undo").click()
    assert wait_until(lambda: planner.controller.scene.goal == scene.goal), (
        planner.controller.scene.goal
    )
    assert planner.wait_idle(20)
    assert_allclose(vg_path(planner), before_path)
    page.get_by_role("button", name="Redo").click()
    assert wait_until(lambda: planner.controller.scene.goal == goal)
    assert planner.wait_idle(20)

    # The other browser shows the goal where it now is (the dragging one moved its own).
    assert wait_until(
        lambda: np.allclose(node_xy(other, "/handles/goal"), goal, atol=1e-3)
    ), node_xy(other, "/handles/goal")
    page.close()
    other.close()


def test_clicking_the_floor_adds_an_obstacle_the_planners_avoid(browser, planner):
    page = open_page(browser, planner)
    controller = planner.controller
    before = controller.frame
    path = vg_path(planner)
    # Drop the block on the middle of the longest leg of the shortest path.
    legs = np.linalg.norm(np.diff(path, axis=0), axis=1)
    k = int(np.argmax(legs))
    spot = (path[k] + path[k + 1]) / 2
    # The lecturer picks the tool in the panel.
    choose(page, TOOLS["drag"], TOOLS["block"])
    assert wait_until(lambda: controller.frame.tool == "block"), (
        "the panel did not switch the tool"
    )
    assert planner.wait_idle(10)
    click(page, spot)
    assert wait_until(
        lambda: len(controller.scene.obstacles) == len(before.scene.obstacles) + 1
    ), "the click added no obstacle"
    assert planner.wait_idle(20)
    frame = controller.frame
    block = frame.scene.obstacles[-1]
    assert_allclose(
        np.asarray(block.centroid.coords[0]), spot, atol=3 * CAMERA.metres_per_pixel()
    )
    # The robot's disk around the block (the true Minkowski sum), a centimetre inside.
    keep_out = block.buffer(frame.scene.robot.radius - 0.01, quad_segs=64)
    for name in ("vg", "svg"):
        result = frame.plans[name]
        assert result.status == "ok", result.reason
        assert not LineString(result.path).intersects(keep_out), name
        assert result.length > before.plans[name].length + 1e-6
    dsb = frame.plans.get("dsb")
    if dsb is not None:  # the sensor-based robot walks around it too
        assert dsb.status == "reached", dsb.reason
        assert not LineString(dsb.path).intersects(keep_out)
    # And the drawn obstacle prisms now include it: more triangles than before.
    assert len(shown_mesh(planner.view.obstacles)[1]) > 0
    page.close()


def test_clicking_corners_draws_a_new_polygon(browser, planner):
    page = open_page(browser, planner)
    controller = planner.controller
    controller.tools.set_tool("polygon")
    assert planner.wait_idle(10)
    corners = [(5.0, 6.6), (6.0, 6.6), (5.5, 7.4)]
    for k, xy in enumerate(corners):
        click(page, xy)
        assert wait_until(lambda k=k: len(controller.frame.draft) == k + 1), (
            f"click {k + 1} was not seen"
        )
    click(page, corners[0])  # back on the first corner closes it
    assert wait_until(lambda: len(controller.scene.obstacles) == 3)
    assert planner.wait_idle(10)
    added = np.asarray(controller.scene.obstacles[-1].exterior.coords)[:-1]
    assert_allclose(added, corners, atol=3 * CAMERA.metres_per_pixel())
    assert controller.frame.draft == ()
    page.close()


def test_download_upload_and_the_scenes_folder_in_the_browser(browser, tmp_path):
    """The panel's file buttons end to end: nothing names a server path."""
    import planners
    from planners.scene import scene_from_text

    folder = tmp_path / "scenes"
    folder.mkdir()
    app = start_app("02_three_obstacles", port=0, print_url=False, scenes_dir=folder)
    try:
        page = browser.new_page(
            viewport={"width": WIDTH, "height": HEIGHT}, accept_downloads=True
        )
        page.goto(f"{app.url}?fixedDpr=1")
        download_button = page.get_by_text("Download this scene (.json)")
        download_button.wait_for(timeout=30_000)
        with page.expect_download(timeout=20_000) as info:
            download_button.click()
        saved = tmp_path / info.value.suggested_filename
        info.value.save_as(saved)
        assert scene_from_text(saved.read_bytes()) == app.controller.scene
        # Save by a plain name: the file lands in the folder and the list shows it.
        page.get_by_text("Save to the scenes folder").click()
        wait_until((folder / "my scene.json").is_file, 10)
        assert sorted(p.name for p in tmp_path.rglob("*.json")) == [
            saved.name,
            "my scene.json",
        ]
        # Upload a shipped scenario through the page's file input.
        shipped = planners.load_scene  # noqa: F841 - the module is used below
        page.locator("input[type=file]").set_input_files(str(saved.parent / saved.name))
        wait_until(
            lambda: (app.controller.message or "").startswith("Loaded"),
            10,
        )
        assert app.controller.message == f"Loaded {saved.name}."
        page.close()
    finally:
        app.stop()
