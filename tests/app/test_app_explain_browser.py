"""Explain mode end to end in headless Chromium: choose, step, edit the scene.

These tests FAIL (never skip) when Chromium cannot start.
"""

from __future__ import annotations

import io
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose

from app import start_app
from app.explain.panel import METHOD_TITLES
from tests.app.app_helpers import wait_until
from tests.app.test_app_browser import (
    CAMERA,
    DPR,
    HEIGHT,
    PLANE_OFFSET,
    WIDTH,
    choose,
    mouse_drag,
    settle,
)


@pytest.fixture
def planner() -> Iterator[Any]:
    app = start_app("01_two_convex", port=0, print_url=False)
    CAMERA.apply(app.server)
    yield app
    app.stop()


def _open(browser: Any, planner: Any) -> Any:
    page = browser.new_page(
        viewport={"width": WIDTH, "height": HEIGHT}, device_scale_factor=1
    )
    page.goto(f"{planner.url}?fixedDpr={DPR}")  # reads the scene, not pixels
    page.wait_for_function(
        "() => window.__viserMutable && ('/explain/current' in window.__viserMutable.nodeRefFromName)"
        " && ('/handles/goal' in window.__viserMutable.nodeRefFromName)",
        timeout=60_000,
    )
    time.sleep(1.0)
    return page


_SEGMENTS_JS = """(name) => {
    const n = window.__viserMutable.nodeRefFromName[name];
    if (!n) return null;
    let shown = true;
    for (let o = n; o; o = o.parent) { if (!o.visible) shown = false; }
    let found = null;
    n.traverse(o => {
        if (found === null && o.geometry && o.geometry.attributes.instanceStart) {
            const s = o.geometry.attributes.instanceStart, e = o.geometry.attributes.instanceEnd;
            const out = [];
            for (let i = 0; i < s.count; i++) out.push([[s.getX(i), s.getY(i)], [e.getX(i), e.getY(i)]]);
            found = out;
        }
    });
    return {shown: shown, segments: found || []};
}"""


def browser_segments(page: Any, role: str) -> np.ndarray | None:
    """The segments the browser draws for ``role`` (x, y), or None when hidden."""
    settle(page, 4)
    got = page.evaluate(_SEGMENTS_JS, f"/explain/{role}")
    if got is None or not got["shown"]:
        return None
    return np.asarray(got["segments"], dtype=np.float64).reshape(-1, 2, 2)


def server_segments(planner: Any, role: str) -> np.ndarray:
    handle = planner.explain._view._layers[role].handle
    if not handle.visible:
        return np.zeros((0, 2, 2))
    return np.asarray(handle.points, dtype=np.float64)[:, :, :2]


def wait_shown(page: Any, planner: Any, role: str = "current") -> np.ndarray:
    """Wait until the browser draws what the server holds for ``role``; return it."""
    expected = server_segments(planner, role)

    def same() -> bool:
        got = browser_segments(page, role)
        if got is None:
            return len(expected) == 0
        return got.shape == expected.shape and np.allclose(got, expected, atol=1e-5)

    assert wait_until(same, 20), (role, expected[:2], browser_segments(page, role))
    return expected


def ready(planner: Any) -> None:
    assert planner.wait_idle(30)
    assert planner.explain.explainer.wait_ready(30)
    assert planner.wait_idle(30)


def panel_text(page: Any) -> str:
    return page.locator("body").inner_text()


def test_explain_steps_forward_in_the_browser_and_follows_an_edit(browser, planner):
    page = _open(browser, planner)
    explainer = planner.explain.explainer
    # The lecturer opens the Explain folder and picks the SVG.
    page.get_by_text("Explain", exact=True).first.click()
    choose(page, METHOD_TITLES["off"], METHOD_TITLES["svg"])
    assert wait_until(lambda: explainer.method == "svg", 20)
    ready(planner)
    assert explainer.step == 0 and explainer.explanation is not None
    assert wait_until(lambda: "step 1 of" in panel_text(page), 20)
    # The plans' own SVG layer is hidden; the explanation draws the hulls.
    assert not planner.controller.frame.layers["svg_edges"]
    hull = wait_shown(page, planner, "hull")
    assert len(hull) > 0

    seen_text, seen_current = [], []
    for k in range(1, 4):
        page.get_by_role("button", name=">", exact=True).click()
        assert wait_until(lambda k=k: explainer.step == k, 20)
        ready(planner)
        step = explainer.explanation.steps[k]
        assert wait_until(lambda k=k: f"step {k + 1} of" in panel_text(page), 20)
        assert step.text.split(":")[0] in panel_text(page)
        current = wait_shown(page, planner, "current")
        assert len(current) > 0
        assert_allclose(current, step.segments("current"), atol=1e-5)
        seen_text.append(step.text)
        seen_current.append(current)
    # Each step says and highlights something else.
    assert len(set(seen_text)) == 3
    assert not np.array_equal(seen_current[0], seen_current[1])
    assert not np.array_equal(seen_current[1], seen_current[2])
    assert seen_text[0].startswith("Step 1:") and seen_text[1].startswith("Step 2(a)")
    # The earlier steps' segments are drawn dimmed ("done") under the current ones.
    done = wait_shown(page, planner, "done")
    assert len(done) >= len(seen_current[0]) + len(seen_current[1])

    _drag_the_goal_while_explaining(page, planner)
    page.close()


def _drag_the_goal_while_explaining(page: Any, planner: Any) -> None:
    # A student drags the goal while Explain is on: the new scene is explained, at the
    # same step number.
    explainer = planner.explain.explainer
    before_goal = planner.controller.scene.goal
    before = explainer.explanation
    target = (9.0, 1.0)
    grab = CAMERA.pixel((before_goal[0] + PLANE_OFFSET, before_goal[1] + PLANE_OFFSET))
    drop = CAMERA.pixel((target[0] + PLANE_OFFSET, target[1] + PLANE_OFFSET))
    mouse_drag(page, grab, drop)
    assert wait_until(lambda: planner.controller.frame.dragging == frozenset(), 20)
    ready(planner)
    goal = planner.controller.scene.goal
    assert np.hypot(goal[0] - target[0], goal[1] - target[1]) < 0.1, goal
    assert wait_until(lambda: explainer.explanation is not before, 20)
    ready(planner)
    assert explainer.step == 3 and explainer.method == "svg"
    after = explainer.explanation
    # The explanation is of the new scene: its end step's path ends at the new goal.
    end = after.steps[-1].segments("path")
    assert_allclose(end[-1, 1], goal, atol=1e-9)
    assert wait_until(lambda: f"step 4 of {len(after.steps)}" in panel_text(page), 20)
    wait_shown(page, planner, "current")
    # Back to the start, then off: the plans' layers come back.
    page.get_by_role("button", name="|<", exact=True).click()
    assert wait_until(lambda: explainer.step == 0, 20)
    choose(page, METHOD_TITLES["svg"], METHOD_TITLES["off"])
    assert wait_until(lambda: explainer.method == "off", 20)
    ready(planner)
    assert planner.controller.frame.layers["svg_edges"]
    assert browser_segments(page, "current") is None


# The label font of viser's client (label/GlyphAtlas.ts), measured by the browser itself.
_MEASURE_JS = """(texts) => document.fonts.ready.then(() => {
    const ctx = document.createElement('canvas').getContext('2d');
    ctx.font = '100px -apple-system, BlinkMacSystemFont, "Segoe UI", "Roboto", ' +
               '"Helvetica Neue", Arial, sans-serif';
    return texts.map(t => {
        const m = ctx.measureText(t);
        return [m.width / 100, (m.fontBoundingBoxAscent + m.fontBoundingBoxDescent) / 100];
    });
})"""


def _text_lines(pixels: np.ndarray, box: tuple[int, int, int, int]) -> list[int]:
    """Heights [px] of the runs of rows holding dark text pixels inside ``box``."""
    x0, y0, x1, y1 = box
    dark = (pixels[y0:y1, x0:x1].max(axis=2) < 80).sum(axis=1) > 2
    runs, start = [], None
    for k, on in enumerate([*dark, False]):
        if on and start is None:
            start = k
        elif not on and start is not None:
            runs.append(k - start)
            start = None
    return runs


def test_the_live_caption_and_labels_read_from_the_back_of_the_hall(browser):
    """DSB step 20 of 06 with R = 0.6 m at 1920 x 1080, in the first view of the scene.

    What the browser drew: the caption's lines in the screenshot, each at least 2 % of
    the screen's height (the caption was one line of about 10 px); and every label's text
    as the browser's own font measures it fits the box the placer kept for it (the boxes
    are apart: tests/app/test_floor_text.py), so no label covers another.
    """
    from PIL import Image

    from app.media.camera import CameraPose
    from app.media.slides import project
    from app.ui.floor_text import floor_caption, floor_font
    from app.ui.labels import label_size
    from app.ui.view import floor_bounds

    app = start_app("06_four_obstacles_sensor", port=0, print_url=False)
    try:
        assert app.explain is not None
        app.controller.edits.set_sensor_range(0.6)
        assert app.wait_idle(30)
        app.explain.choose("dsb")
        ready(app)
        app.explain.explainer.go(19)
        ready(app)
        page = browser.new_page(
            viewport={"width": 1920, "height": 1080}, device_scale_factor=1
        )
        page.goto(f"{app.url}?fixedDpr=1")
        page.wait_for_function(
            "() => window.__viserMutable && "
            "('/explain/caption/0' in window.__viserMutable.nodeRefFromName)",
            timeout=60_000,
        )
        page.add_style_tag(content="body * { visibility: hidden !important; } "
                           "canvas { visibility: visible !important; }")  # fmt: skip
        page.evaluate("() => document.fonts.ready.then(() => true)")
        client = next(iter(app.server.get_clients().values()))
        camera = client.camera
        pose = CameraPose(
            tuple(camera.position), tuple(camera.look_at), tuple(camera.up_direction),
            camera.fov, 0.1, 1000.0,
        )  # fmt: skip
        scene = app.controller.scene
        bounds = floor_bounds(scene)
        font = floor_font(bounds)
        explanation = app.explain.explainer.explanation
        assert explanation is not None
        text = f"20/{len(explanation.steps)}  {explanation.steps[19].text}"
        caption = floor_caption(text, font, bounds)
        x0, y0, x1, y1 = caption.box
        corners = project(pose, 1920, 1080, [[x0, y0, 0.12], [x1, y1, 0.12]])
        box = (
            max(0, int(corners[:, 0].min())),
            max(0, int(corners[:, 1].min()) - 4),
            min(1920, int(corners[:, 0].max()) + 1),
            min(1080, int(corners[:, 1].max()) + 4),
        )
        # The client draws a label once its glyphs are rasterized: wait until it has.
        lines: list[int] = []

        def drawn() -> bool:
            settle(page, 2)
            shot = Image.open(io.BytesIO(page.screenshot())).convert("RGB")
            lines[:] = _text_lines(np.asarray(shot), box)
            return len(lines) == len(caption.lines)

        assert wait_until(drawn, 30), (lines, caption.lines)
        assert all(h >= 0.02 * 1080 for h in lines), lines
        # Every label's text, in the browser's font, fits the box kept for it.
        labels = [h.text for h in app.explain._view._labels.handles if h.visible]
        assert any(t.startswith("O_") for t in labels), labels
        for label, (width, height) in zip(
            labels, page.evaluate(_MEASURE_JS, labels), strict=True
        ):
            kept_w, kept_h = label_size(label, 1.0)
            pad = 0.2 * height  # viser's background: a fifth of a line
            assert width + pad <= kept_w and height + pad <= kept_h, (label, width)
        page.close()
    finally:
        app.stop()
