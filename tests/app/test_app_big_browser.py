"""A student's 32-obstacle room in headless Chromium while an obstacle is dragged.

Both of ``bench_student``'s kinds of room: obstacles that merge once expanded (443
configuration-space vertices) and obstacles kept apart (612, the largest).

The browser watches (top view) while an obstacle is dragged through the middle of the
room through the controller -- the gizmo's call -- and the graph layers follow. The
pictures (during and after the drag, and with "VG edges: all") are saved in the test's
``tmp_path`` (``H3_PICTURES=DIR`` keeps a copy) to be looked at; the test checks what
the page shows: the thinned graph's note in the panel, and the full graph on request.

FAILS (never skips) when Chromium cannot start.
"""

from __future__ import annotations

import os
import re
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

import planners
from app import start_app
from app.media.browser import open_page
from app.ui.thinning import edges_to_draw
from tests.app.app_helpers import TopCamera, wait_until
from tests.benchmarks.bench_student import drag_points, student_layout

WIDTH, HEIGHT = 1280, 800
# Straight down at the 20 m room, left of the panel.
CAMERA = TopCamera(
    look_at=(12.5, 10.0), height=26.0, fov_deg=50.0, width=WIDTH, px_height=HEIGHT
)


def _shot(page: Any, path: Path) -> np.ndarray:
    page.evaluate(
        "() => new Promise(done => { let n = 5; const tick = () => (n-- > 0 ?"
        " requestAnimationFrame(tick) : done()); tick(); })"
    )
    page.screenshot(path=str(path))
    keep = os.environ.get("H3_PICTURES")
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        shutil.copy(path, Path(keep) / path.name)
    return np.asarray(Image.open(path).convert("RGB"), dtype=np.int16)


@pytest.mark.parametrize("layout", ["merging", "apart"])
def test_dragging_an_obstacle_of_a_student_room_in_the_browser(
    browser, tmp_path, layout
):
    room = planners.load_scene(student_layout(32, layout=layout))
    app = start_app(room, port=0, print_url=False)
    try:
        CAMERA.apply(app.server)
        controller = app.controller
        assert app.wait_idle(120)
        with open_page(app, browser, width=WIDTH, height=HEIGHT) as shown:
            page = shown.page
            vg = _frame(controller).plans["vg"]
            thinned = edges_to_draw(vg, all_edges=False)
            assert thinned.thinned
            note = page.get_by_text(f"of {vg.edges:,} drawn", exact=False)
            assert wait_until(lambda: note.count() == 1, 30)

            handle, points = drag_points(controller.scene, "move", 40)
            controller.edits.drag_handle(handle, points[0], "start")
            for xy in points[:12]:  # to the middle of the room
                controller.edits.drag_handle(handle, xy, "update")
            assert app.wait_idle(60)
            during = _shot(page, tmp_path / f"h3_{layout}_drag_during.png")
            for xy in points[12:]:
                controller.edits.drag_handle(handle, xy, "update")
            controller.edits.drag_handle(handle, points[-1], "end")
            assert app.wait_idle(60)
            after = _shot(page, tmp_path / f"h3_{layout}_drag_after.png")
            # The obstacle moved between the two pictures; the graph followed it.
            assert np.abs(during - after).max() > 60
            frame = _frame(controller)
            assert frame.plans["vg"].status == "ok"
            drawn = controller_view_points(app)
            assert drawn == len(edges_to_draw(frame.plans["vg"], False).segments)

            page.locator("label").filter(
                has_text=re.compile(r"^VG edges: all$")
            ).click()
            assert wait_until(lambda: frame_layer(controller, "vg_edges_all"), 30)
            assert app.wait_idle(60)
            assert wait_until(lambda: note.count() == 0, 30)
            time.sleep(0.5)
            everything = _shot(page, tmp_path / f"h3_{layout}_all_edges.png")
            assert controller_view_points(app) == frame.plans["vg"].edges
            # Every edge drawn covers more of the room in the graph's blue than the
            # thinned layer does.
            assert _blue(everything) > _blue(after)
    finally:
        app.stop()


def _frame(controller: Any) -> Any:
    frame = controller.frame
    assert frame is not None
    return frame


def frame_layer(controller: Any, key: str) -> bool:
    frame = controller.frame
    return frame is not None and bool(frame.layers.get(key))


def controller_view_points(app: Any) -> int:
    """Edges the 3-D view sent for the VG layer (the server's copy of the node)."""
    view = app.controller.views._views[0]
    return len(view.graphs["vg"].edges.points())


def _blue(picture: np.ndarray) -> int:
    """Count the pixels of the room (left of the panel) that are VG-edge blue-ish."""
    room = picture[:, : int(WIDTH * 0.7)]
    r, b = room[..., 0], room[..., 2]
    return int(np.count_nonzero((b - r > 40) & (b > 150)))
