"""Big scenes in the real app : a worker computes, edits cancel it.

The circle of 10,000 vertices of ``tests/benchmarks/bench_big.py`` is uploaded into a
running app (real viser server, 3-D view, panel, controller; a second "browser" is a
websocket client). Its VG and SVG take seconds and its DSB more: computed in worker
processes (:mod:`app.session.big`), while the panel says what is computed, the scene stays
editable, and every edit gives the running computation up.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import threading
from typing import Any

import numpy as np
import pytest

import planners
from app import start_app
from app.session.big import BIG_SCENE_VERTICES, scene_vertices
from app.session.frames import Frame
from app.ui.style import planner_look
from app.ui.view import STALE_RGB
from tests.app.app_helpers import markdowns
from tests.benchmarks.bench_big import circle_scene
from tests.viser_client import ViserClient


class Recorder:
    """A view that keeps every frame drawn, in order."""

    def __init__(self) -> None:
        self.frames: list[Frame] = []
        self.seen: dict[int, Any] = {}  # id(frame) -> what ``look`` saw when it came
        self.look: Any = None
        self.cond = threading.Condition()

    def render(self, frame: Frame) -> None:
        # Views draw in order: the 3-D view has drawn this frame already.
        seen = None if self.look is None else self.look()
        with self.cond:
            self.frames.append(frame)
            self.seen[id(frame)] = seen
            self.cond.notify_all()

    def render_robot(self, pose: Any) -> None:
        pass

    def wait_for(self, test, timeout: float) -> Frame:
        with self.cond:
            found: list[Frame] = []

            def seen() -> bool:
                found[:] = [f for f in self.frames if test(f)]
                return bool(found)

            assert self.cond.wait_for(seen, timeout), "no such frame was drawn"
            return found[0]


def _planned_for(frame: Frame) -> bool:
    """Whether the graph planners' results in ``frame`` were computed for its scene."""
    for name in ("vg", "svg"):
        result = frame.plans.get(name)
        if result is None or result.status not in ("ok", "unreachable"):
            continue
        arrays = result.arrays
        goal = tuple(float(v) for v in arrays.points[arrays.goal])
        start = tuple(float(v) for v in arrays.points[arrays.start])
        if goal != frame.scene.goal or start != frame.scene.start:
            return False
    return True


@pytest.fixture
def app():
    with contextlib.redirect_stdout(io.StringIO()):
        running = start_app(port=0, print_url=False)
    yield running
    with contextlib.redirect_stdout(io.StringIO()):
        running.stop()


def test_a_big_scene_shows_progress_and_edits_cancel_its_computation(app):
    controller = app.controller
    recorder = Recorder()
    controller.add_view(recorder)
    watcher = ViserClient(app.port)  # a second browser
    try:
        assert watcher.wait_for(lambda: "Obstacles" in _labels(watcher), 30)
        big = circle_scene()
        scene = planners.load_scene(big)
        assert scene_vertices(scene) > BIG_SCENE_VERTICES
        controller.files.load_text(json.dumps(big), "circle.json")
        loaded = controller.version
        first = recorder.wait_for(lambda f: f.version == loaded and f.progress, 30)
        assert first.stale and first.progress is not None
        assert re.fullmatch(
            r"Computing VG, SVG\.\.\. \(10,004 vertices, \d+\.\d s\)", first.progress
        )
        # The panel shows it to every browser.
        assert watcher.wait_for(
            lambda: any("Computing VG, SVG..." in t for t in markdowns(watcher)), 30
        )

        # Edits while it computes: each gives the running computation up. A drag of the
        # goal: the planning waits for the mouse to rest.
        controller.edits.drag_handle(("goal",), (37.0, 20.5), "start")
        for y in (21.0, 22.0, 23.0):
            controller.edits.drag_handle(("goal",), (37.0, y), "update")
        last = controller.version
        waiting = recorder.wait_for(
            lambda f: (
                f.version == last and "Waiting for the drag" in (f.progress or "")
            ),
            30,
        )
        assert waiting.stale
        controller.edits.drag_handle(("goal",), (37.0, 23.0), "end")
        assert controller.version == last  # the end of a drag changes no scene
        # The second browser still works meanwhile: it hides the obstacles, and a frame
        # shows that while the final scene is still being computed.
        watcher.set_gui(watcher.uuid("Obstacles", "Checkbox"), False)
        hidden = recorder.wait_for(
            lambda f: f.version == last and not f.layers["obstacles"], 30
        )
        assert hidden.stale and hidden.progress

        assert app.wait_idle(180)
        frames = list(recorder.frames)
        final = controller.frame
        assert final is not None
        assert final.version == last and not final.stale and final.progress is None
        assert final.scene.goal == (37.0, 23.0)
        # Never a computed result of an earlier version of the big scene.
        planned = [f for f in frames if not f.stale]
        assert all(_planned_for(f) for f in planned)
        assert not [f for f in planned if loaded <= f.version < last]
        # The final plans are those of the last edit, computed from scratch here.
        fresh = planners.plan_all(final.scene, ("vg", "svg"))
        for name in ("vg", "svg"):
            assert final.plans[name].length == pytest.approx(fresh[name].length)
            assert final.plans[name].edges == fresh[name].edges
        # DSB too, for the last edit (its worker gave the older scenes up).
        assert final.slow_version == last and "dsb" not in final.lagging
        assert final.plans["dsb"].status == "reached"

        _check_the_last_picture_stays_grey(app, recorder, final)
    finally:
        watcher.close()


def _check_the_last_picture_stays_grey(app, recorder: Recorder, final: Frame) -> None:
    """One more edit: the big scene's plans stay on screen, grey, until the new ones."""
    controller = app.controller
    last = final.version
    view = controller.views._views[0]
    grey, blue = np.asarray(STALE_RGB), np.asarray(planner_look("vg").path)
    recorder.look = lambda: np.array(view.graphs["vg"].path.handle.colors)
    controller.edits.move_goal((37.0, 19.0))
    kept = recorder.wait_for(lambda f: f.version == last + 1 and f.stale, 30)
    assert kept.plans["vg"] is final.plans["vg"]  # the last picture, not a new one
    assert (recorder.seen[id(kept)] == grey).all()
    assert app.wait_idle(180)
    again = controller.frame
    assert again is not None and not again.stale and again.version == last + 1
    assert (np.asarray(view.graphs["vg"].path.handle.colors) == blue).all()


def _labels(client: ViserClient) -> set[str]:
    return {e["label"] for e in client.gui.values()}


def test_a_small_scene_never_starts_the_big_worker(app):
    scheduler = app.controller.scheduler
    app.controller.edits.move_goal((8.0, 5.0))
    assert app.wait_idle(30)
    big = scheduler._fast.big
    assert big is not None and big.pid is None  # started on first use only
