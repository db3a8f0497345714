"""Explain mode end to end in headless Chromium: choose, step, edit the scene.

These tests FAIL (never skip) when Chromium cannot start.
"""

from __future__ import annotations

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
    page.goto(f"{planner.url}?fixedDpr=1")
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
