"""The Explain panel's logic without a browser, and Explain mode's headless pictures."""

from __future__ import annotations

import base64
import dataclasses
import html
import importlib
import itertools
import math
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import GifImagePlugin, Image
from shapely import Polygon

import planners
from app import start_app
from app.explain import panel as explain_panel
from app.explain.panel import HIDDEN_LAYERS, Explainer, flowchart_html, table_html
from app.explain.view import ROLE_LOOKS, role_segments
from app.media.explain_pictures import (
    explain_record,
    explain_snapshots,
    parse_step,
    step_bounds,
)
from app.session.big import BIG_SCENE_VERTICES
from app.session.frames import Frame
from app.session.scheduler import Failed, Pending
from planners import Scene, load_scene, plan_all
from planners.explain import ROLES, Abandoned
from planners.visibility._graphs import build_border
from tests.app.app_helpers import wait_until
from tests.conftest import ROOT, scene_dict

SCENARIO = ROOT / "static_scenarios" / "05_pocket_start.json"
EXPLAIN_DSB = importlib.import_module(
    "planners.explain.dsb"
)  # the name is a function too


def _frame(scene, version: int, dragging: frozenset = frozenset()) -> Frame:
    return Frame(
        version=version,
        scene=scene,
        plans={},
        problems=(),
        message=None,
        tool="drag",
        layers={},
        selection=None,
        draft=(),
        dragging=dragging,
        can_undo=False,
        can_redo=False,
        follow="vg",
        trajectory=None,
        other_expanded=None,
        scenario="",
        compute_ms=0.0,
    )


class Drawn:
    """Records what the explainer draws, from its thread."""

    def __init__(self) -> None:
        self.calls: list[tuple[Any, Any]] = []
        self.lock = threading.Lock()

    def __call__(self, step, explanation) -> None:
        with self.lock:
            self.calls.append((step, explanation))


@pytest.fixture
def explainer() -> Iterator[tuple[Explainer, Drawn]]:
    drawn = Drawn()
    ex = Explainer(drawn)
    yield ex, drawn
    ex.close()


def test_off_computes_nothing(explainer):
    ex, drawn = explainer
    ex.render(_frame(load_scene(SCENARIO), 1))
    assert ex.wait_ready(5)
    assert drawn.calls == [] and ex.explanation is None


def test_its_thread_runs_only_while_there_is_work(monkeypatch):
    """Off, it holds no thread; a request starts one, which ends once idle; the next
    request starts another and is served as the first was."""
    monkeypatch.setattr(explain_panel, "IDLE_S", 0.2)
    drawn = Drawn()
    ex = Explainer(drawn)
    try:
        scene = load_scene(SCENARIO)
        ex.render(_frame(scene, 1))  # off: nothing to do
        assert ex._runner.threads == 0
        ex.choose("svg")
        assert ex._runner.threads == 1
        assert ex.wait_ready(30) and ex.explanation is not None
        assert wait_until(lambda: ex._runner.threads == 0, 20)
        ex.move(1)
        assert ex._runner.threads == 1
        assert ex.wait_ready(30) and ex.step == 1
        assert drawn.calls[-1][0] is ex.explanation.steps[1]
    finally:
        ex.close()
    assert ex._runner.threads == 0


def test_steps_clamp_and_survive_an_edit_at_the_same_number(explainer):
    ex, drawn = explainer
    scene = load_scene(SCENARIO)
    ex.render(_frame(scene, 1))
    ex.choose("svg")
    assert ex.wait_ready(30)
    first = ex.explanation
    assert first is not None and drawn.calls[-1][0] is first.steps[0]
    ex.move(3)
    assert ex.wait_ready(30) and ex.step == 3
    assert drawn.calls[-1][0] is first.steps[3]
    ex.move(-1)
    assert ex.wait_ready(30) and ex.step == 2
    ex.to_end()
    assert ex.wait_ready(30) and ex.step == len(first.steps) - 1
    ex.go(3)
    assert ex.wait_ready(30)
    # An edit: the goal moves; the new scene is explained at the same step number.
    moved = dataclasses.replace(scene, goal=(9.0, 6.5))
    ex.render(_frame(moved, 2))
    assert wait_until(lambda: ex.explanation is not first, 30)
    assert ex.wait_ready(30)
    assert ex.step == 3 and drawn.calls[-1][0] is ex.explanation.steps[3]
    # A scene with fewer steps keeps the last one.
    ex.go(999)
    assert ex.wait_ready(30)
    last = ex.step
    bare = dataclasses.replace(scene, obstacles=scene.obstacles[:1])
    ex.render(_frame(bare, 3))
    assert wait_until(
        lambda: ex.explanation is not None and len(ex.explanation.steps) < last + 1, 30
    )
    assert ex.wait_ready(30)
    assert ex.step == len(ex.explanation.steps) - 1


def test_nothing_is_computed_or_shown_while_dragging(explainer):
    ex, drawn = explainer
    scene = load_scene(SCENARIO)
    ex.render(_frame(scene, 1))
    ex.choose("vg")
    assert ex.wait_ready(30)
    shown = ex.explanation
    ex.render(
        _frame(dataclasses.replace(scene, goal=(9.0, 6.0)), 2, frozenset({("goal",)}))
    )
    assert ex.wait_ready(30)
    assert drawn.calls[-1] == (None, None)  # hidden, not a stale story
    assert ex.explanation is shown  # and nothing computed during the drag
    ex.render(_frame(dataclasses.replace(scene, goal=(9.0, 6.0)), 3))
    assert ex.wait_ready(30)
    assert ex.explanation is not shown and drawn.calls[-1][0] is not None


def _big_ring(*more) -> Scene:
    """A scene just over the big-scene threshold: a circle, and ``more`` obstacles."""
    ring = [
        (10 + 5 * math.cos(a), 10 + 5 * math.sin(a))
        for a in np.linspace(0, 2 * math.pi, BIG_SCENE_VERTICES + 10, endpoint=False)
    ]
    data = scene_dict([ring], (1.0, 1.0), (19.0, 19.0))
    scene = load_scene(data)
    return dataclasses.replace(scene, obstacles=(*scene.obstacles, *more))


def _no_planning(*args, **kwargs):
    raise AssertionError("the explainer planned the scene again")


@pytest.mark.parametrize("method", ["vg", "svg", "dsb"])
def test_the_frames_own_plans_are_explained_without_planning_again(
    explainer, monkeypatch, method
):
    """What the screen shows is explained: the frame's plans, not a second computation."""
    ex, drawn = explainer
    scene = load_scene(SCENARIO)
    plans = plan_all(scene, ("vg", "svg", "dsb"))
    monkeypatch.setattr("app.explain.panel.plan_all", _no_planning)
    ex.render(dataclasses.replace(_frame(scene, 1), plans=plans))
    ex.choose(method)
    assert ex.wait_ready(30)
    assert ex.error is None and ex.explanation is not None
    assert ex.explanation.method == method and drawn.calls[-1][0] is not None
    if method == "vg":
        arrays = plans["vg"].arrays
        assert ex.explanation.data[0].node == arrays.start
        assert len(ex.explanation.data) == len(arrays.points)


def test_plans_of_an_older_scene_or_still_computing_are_planned_afresh(explainer):
    """A lagging or pending slow result is not this scene's: the explainer plans it."""
    ex, _ = explainer
    scene = load_scene(SCENARIO)
    moved = dataclasses.replace(scene, goal=(9.0, 6.0))
    old = plan_all(scene, ("vg", "dsb"))
    fresh = plan_all(moved, ("dsb",))
    assert old["dsb"].path.tolist() != fresh["dsb"].path.tolist()
    lagging = dataclasses.replace(
        _frame(moved, 2), plans=old, lagging=frozenset({"dsb"})
    )
    ex.render(lagging)
    ex.choose("dsb")
    assert ex.wait_ready(30)
    assert ex.explanation.data.path.tolist() == fresh["dsb"].path.tolist()
    pending = dict(old, dsb=Pending("dsb"))
    ex.render(dataclasses.replace(_frame(moved, 3), plans=pending))
    assert ex.wait_ready(30)
    assert ex.explanation.data.path.tolist() == fresh["dsb"].path.tolist()


def test_a_big_scene_is_explained_from_its_workers_plans_never_planned_here(
    explainer, monkeypatch
):
    """While a big scene's worker computes (a stale frame showing progress), Explain
    shows nothing and plans nothing in the server's process; the worker's plans, when
    they come, are explained."""
    ex, drawn = explainer
    scene = _big_ring()
    monkeypatch.setattr("app.explain.panel.plan_all", _no_planning)
    computing = dataclasses.replace(
        _frame(scene, 1),
        stale=True,
        progress="Computing VG, SVG... (12 vertices, 0.4 s)",
    )
    ex.render(computing)
    ex.choose("vg")
    assert ex.wait_ready(30)
    assert drawn.calls[-1] == (None, None)
    assert ex.explanation is None and ex.error is None
    done = dataclasses.replace(_frame(scene, 1), plans=plan_all(scene, ("vg",)))
    ex.render(done)
    assert ex.wait_ready(30)
    assert ex.error is None
    assert ex.explanation is not None and ex.explanation.method == "vg"
    assert drawn.calls[-1][0] is not None


def test_a_big_scene_whose_planner_is_off_says_so_and_plans_nothing_here(
    explainer, monkeypatch
):
    """A big scene with DSB switched off: its worker computed no DSB, and Explain does
    not plan it in the server either; it says how to get one. Switched on (the same
    scene version with the plan), it is explained."""
    ex, drawn = explainer
    scene = _big_ring()
    plans = plan_all(scene, ("vg", "dsb"))
    monkeypatch.setattr("app.explain.panel.plan_all", _no_planning)
    off = {k: v for k, v in plans.items() if k != "dsb"}
    ex.render(dataclasses.replace(_frame(scene, 1), plans=off))
    ex.choose("dsb")
    assert ex.wait_ready(30)
    assert ex.explanation is None and drawn.calls[-1] == (None, None)
    assert ex.error == (
        f"Switch on DSB (9.6, Fig. 9.15) to explain it: a scene of "
        f"{BIG_SCENE_VERTICES + 10:,} vertices is planned by its worker only."
    )
    ex.render(dataclasses.replace(_frame(scene, 1), plans=plans))
    assert ex.wait_ready(30)
    assert ex.error is None
    assert ex.explanation is not None and ex.explanation.method == "dsb"


def test_a_failed_planners_result_is_planned_again_on_a_small_scene(explainer):
    """A planner that raised in its lane (``Failed``): not explained as if it were a
    graph; the explainer plans the scene itself (its own error, if any, is shown)."""
    ex, _ = explainer
    scene = load_scene(SCENARIO)
    plans = dict(plan_all(scene, ("vg",)), vg=Failed("vg", "boom"))
    ex.render(dataclasses.replace(_frame(scene, 1), plans=plans))
    ex.choose("vg")
    assert ex.wait_ready(30)
    assert ex.error is None
    assert ex.explanation is not None and ex.explanation.steps[-1].kind == "vg:path"


def test_a_big_scene_that_failed_or_is_invalid_says_so(explainer, monkeypatch):
    """On a big scene: a failed planner's reason in one line, nothing planned here; an
    invalid scene's answer explained (nothing to build, and why)."""
    ex, drawn = explainer
    monkeypatch.setattr("app.explain.panel.plan_all", _no_planning)
    scene = _big_ring()
    failed = {"vg": Failed("vg", "boom")}
    frame = dataclasses.replace(
        _frame(scene, 1), plans=failed, enabled=frozenset({"vg"})
    )
    ex.render(frame)
    ex.choose("vg")
    assert ex.wait_ready(30)
    assert ex.error == "Visibility graph (9.4) has nothing to explain here: boom"
    assert ex.explanation is None and drawn.calls[-1] == (None, None)
    bowtie = Polygon([(0, 0), (1, 1), (1, 0), (0, 1)])
    invalid = _big_ring(bowtie)
    plans = planners.plan_all(invalid, ("vg",))
    assert plans["vg"].status == "invalid" and "cspace" not in plans
    ex.render(dataclasses.replace(_frame(invalid, 2), plans=plans))
    assert ex.wait_ready(30)
    assert ex.error is None and ex.explanation is not None
    assert ex.explanation.steps[0].text.startswith("Nothing to build: obstacle 2:")


def test_the_frames_geometry_is_left_to_the_threads_that_own_it(explainer, monkeypatch):
    """GEOS's prepared geometries are not safe in two threads at once: the explainer
    explains a copy of the frame's plans (geometry of its own, nothing derived), and
    the frame's are left to the fast lane, the views and the live robot."""
    ex, _ = explainer
    scene = load_scene(SCENARIO)
    plans = plan_all(scene, ("vg", "svg"))
    given = []
    real = explain_panel._explain

    def spy(scene, method, obstacle, memo, *, plans=None, abandoned=None):
        given.append(plans)
        return real(scene, method, obstacle, memo, plans=plans, abandoned=abandoned)

    monkeypatch.setattr(explain_panel, "_explain", spy)
    ex.render(dataclasses.replace(_frame(scene, 1), plans=plans))
    ex.choose("vg")
    assert ex.wait_ready(30)
    assert ex.explanation is not None and ex.error is None
    (copy,) = given
    assert copy["cspace"] is not plans["cspace"] and copy["vg"] is not plans["vg"]
    assert copy["cspace"].known(build_border) is None  # nothing derived comes along
    assert plans["cspace"].known(build_border) is not None
    assert np.array_equal(copy["vg"].arrays.i, plans["vg"].arrays.i)


def test_a_failing_explanation_is_one_line_not_a_crash(explainer, monkeypatch):
    ex, drawn = explainer

    def broken(*args, **kwargs):
        raise RuntimeError("boom\nsecond line")

    monkeypatch.setattr("app.explain.panel._explain", broken)
    ex.render(_frame(load_scene(SCENARIO), 1))
    ex.choose("svg")
    assert ex.wait_ready(30)
    assert ex.error == "RuntimeError: boom" and ex.explanation is None
    assert drawn.calls[-1] == (None, None)


def test_unknown_method_is_refused(explainer):
    ex, _ = explainer
    with pytest.raises(ValueError, match="unknown method"):
        ex.choose("rrt")


def test_every_role_has_a_look_and_roles_draw_their_points():
    assert set(ROLE_LOOKS) == set(ROLES)
    from planners.explain import Step, point_mark

    step = Step("k", "t", (point_mark("focus", [(1.0, 2.0)]),))
    segs = role_segments(step, "focus", 0.3)
    # A ring of 24 segments around the point, at the role's radius.
    assert segs.shape == (24, 2, 3)
    r = np.hypot(segs[:, 0, 0] - 1.0, segs[:, 0, 1] - 2.0)
    assert np.allclose(r, ROLE_LOOKS["focus"].point_size) and np.allclose(
        segs[..., 2], 0.3
    )


def test_flowchart_highlights_exactly_the_current_box():
    html = flowchart_html("local_minimum")
    assert html.count("background:#E69F00") == 1
    assert "Local minimum?" in html.split("background:#E69F00")[1].split("</div>")[0]
    # The O_i table escapes what it prints.
    from planners.explain import Step

    assert "&lt;" in table_html(Step("k", "t", (), (("d_reach", "4.45 < 4.50"),)))


def _layers(app) -> Any:
    frame = app.controller.frame
    assert frame is not None
    return frame.layers


def test_the_app_hides_the_plans_layers_and_restores_them():
    app = start_app(SCENARIO, port=0, print_url=False)
    try:
        layers = _layers(app)
        assert all(layers[k] for k in HIDDEN_LAYERS if k in layers)
        assert app.explain is not None  # one person at a laptop: the app's own panel
        app.explain.choose("dsb")
        assert app.wait_idle(30) and app.explain.explainer.wait_ready(30)
        assert app.wait_idle(30)
        layers = _layers(app)
        assert not any(layers[k] for k in HIDDEN_LAYERS if k in layers)
        shown = app.explain.explainer.explanation
        assert shown is not None and shown.method == "dsb"
        # The flowchart of Fig. 9.15 with the first decision's box highlighted.
        first = shown.tags[0]
        folder = app.explain.folder
        assert folder is not None
        assert folder.flowchart.content == flowchart_html(first.box)
        assert folder.flowchart.content.count("background:#E69F00") == 1
        assert "step 1 of" in folder.text.content
        app.explain.choose("off")
        assert app.wait_idle(30) and app.explain.explainer.wait_ready(30)
        assert app.wait_idle(30)
        layers = _layers(app)
        assert all(layers[k] for k in HIDDEN_LAYERS if k in layers)
        assert not app.explain._view._layers["current"].handle.visible
    finally:
        app.stop()


# --------------------------------------------------------------------------- headless


def test_parse_step():
    assert parse_step("7") == 7 and parse_step("ALL") is None
    for bad in ("0", "-2", "x"):
        with pytest.raises(ValueError, match="step must be"):
            parse_step(bad)


def test_dsb_pictures_frame_the_robot_others_the_scene():
    from types import SimpleNamespace as NS

    from planners.explain import Step, point_mark

    step = Step("k", "t", (point_mark("focus", [(2.0, 3.0)]),))
    whole = (0.0, 0.0, 10.0, 8.0)
    dsb = NS(method="dsb", data=NS(sensor_range=2.0), step=lambda n: step)
    assert step_bounds(dsb, 0, whole) == (-3.0, -2.0, 7.0, 8.0)
    svg = NS(method="svg", data=(), step=lambda n: step)
    assert step_bounds(svg, 0, whole) == whole
    unlimited = NS(
        method="dsb", data=NS(sensor_range=float("inf")), step=lambda n: step
    )
    assert step_bounds(unlimited, 0, whole) == whole


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"method": "rrt"}, "explain must be one of"),
        ({"method": "svg", "step": "zero"}, "step must be"),
        ({"method": "dsb", "sensor_range": -1.0}, "sensor range must be"),
    ],
)
def test_bad_explain_arguments_exit_2(tmp_path, capsys, kwargs, message):
    assert explain_snapshots(SCENARIO, tmp_path / "x.png", **kwargs) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err and err.count("\n") == 1


@pytest.mark.usefixtures("browser")  # fails, never skips, without Chromium
def test_a_step_that_does_not_exist_exits_2(tmp_path, capsys):
    code = explain_snapshots(
        ROOT / "static_scenarios" / "08_narrow_gap.json",
        tmp_path / "x.png",
        method="svg",
        step=99,
    )
    assert code == 2
    assert "step 99 does not exist" in capsys.readouterr().err


@pytest.mark.usefixtures("browser")  # fails, never skips, without Chromium
def test_one_step_and_all_steps_pictures(tmp_path):
    one = tmp_path / "one.png"
    assert (
        explain_snapshots(SCENARIO, one, method="svg", step=2, width=320, height=200)
        == 0
    )
    folder = tmp_path / "all"
    code = explain_snapshots(
        ROOT / "static_scenarios" / "01_two_convex.json",
        folder,
        method="svg",
        step="all",
        width=320,
        height=200,
    )
    assert code == 0
    pictures = sorted(folder.glob("*.png"))
    lines = (folder / "steps.txt").read_text().splitlines()
    assert len(pictures) == len(lines) >= 4
    assert [p.name for p in pictures] == [
        f"{k:03d}.png" for k in range(1, len(lines) + 1)
    ]
    assert lines[1].startswith("002 Step 1:")
    images = [np.asarray(Image.open(p).convert("RGB")) for p in pictures]
    assert all(im.shape == (200, 320, 3) for im in images)
    # Each step draws something else.
    assert all(not np.array_equal(a, b) for a, b in itertools.pairwise(images))
    assert np.asarray(Image.open(one)).shape[:2] == (200, 320)
    # The page to step through holds every picture, in order, and each step's text.
    page = (folder / "index.html").read_text()
    for picture in pictures:
        assert base64.b64encode(picture.read_bytes()).decode() in page
    assert page.count('<img class="step"') == len(pictures)
    assert html.escape(lines[1][4:]) in page


@pytest.mark.usefixtures("browser")  # fails, never skips, without Chromium
def test_every_step_into_a_video(tmp_path):
    out = tmp_path / "svg.gif"
    scenario = ROOT / "static_scenarios" / "01_two_convex.json"
    code = explain_record(
        scenario, out, method="svg", width=320, height=200, fps=10, seconds=0.2
    )
    assert code == 0
    steps = len(planners.explain_svg(load_scene(scenario)).steps)
    with Image.open(out) as video:
        assert isinstance(video, GifImagePlugin.GifImageFile)
        # Pillow keeps a frame repeated as one frame shown as long: each step is one
        # picture shown 0.2 s (two frames at 10 frames a second).
        assert video.n_frames == steps
        frames, durations = [], []
        for k in range(video.n_frames):
            video.seek(k)
            durations.append(video.info["duration"])
            frames.append(np.asarray(video.convert("RGB")))
    assert durations == [200] * steps
    assert all(not np.array_equal(a, b) for a, b in itertools.pairwise(frames))


def test_cli_explain_writes_the_picture(tmp_path):
    from tests.conftest import run_module

    out = tmp_path / "step.png"
    done = run_module(
        "app",
        "--scenario",
        "08",
        "--snapshot",
        str(out),
        "--explain",
        "vg",
        "--step",
        "1",
        "--width",
        "320",
        "--height",
        "200",
        timeout=180,
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == "" and Path(out).is_file()


def test_cli_explain_video_arguments_are_checked_before_anything_starts(
    tmp_path, capsys
):
    from app.__main__ import main as app_main
    from tests.conftest import run_module

    video = str(tmp_path / "steps.mp4")
    one = run_module(
        "app", "--scenario", "08", "--record", video, "--explain", "svg", "--step", "3"
    )
    assert one.returncode == 2 and "records every step" in one.stderr
    # The command line's own function (``python -m app`` is ``sys.exit(main())``), in
    # this process: one interpreter start is enough for the line above.
    odd = app_main(
        ["--scenario", "08", "--record", video, "--explain", "svg", "--width", "321"]
    )
    assert odd == 2 and "even width" in capsys.readouterr().err
    short = explain_record(SCENARIO, video, method="svg", fps=10, seconds=0.01)
    assert short == 2
    assert not Path(video).exists()


class LongExplanation:
    """Its first SVG explanation runs until it is abandoned (as a big scene's would run
    for seconds); later ones are the real thing. Started on scenario 05 at version 1."""

    def __init__(self, ex: Explainer, monkeypatch: Any) -> None:
        self.scene = load_scene(SCENARIO)
        self.plans = plan_all(self.scene, ("vg", "svg"))
        self.started, self.stopped = threading.Event(), threading.Event()
        self.real = explain_panel.explain_svg
        monkeypatch.setattr(explain_panel, "explain_svg", self._explain)
        ex.render(self.frame(1))
        ex.choose("svg")
        assert self.started.wait(30)

    def frame(self, version: int, dragging: frozenset = frozenset()) -> Frame:
        return dataclasses.replace(
            _frame(self.scene, version, dragging), plans=self.plans
        )

    def _explain(self, scene, options, *, plans=None, abandoned=None):
        if self.started.is_set():
            return self.real(scene, options, plans=plans, abandoned=abandoned)
        self.started.set()
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            if abandoned is not None and abandoned():
                self.stopped.set()
                raise Abandoned
            time.sleep(0.005)
        raise AssertionError("the explanation was never abandoned")


def test_an_edit_abandons_a_long_explanation_at_once(explainer, monkeypatch):
    """A big scene's explanation takes a second or more; an edit meanwhile stops it
    (a long computation is cancelled by the next edit), and the new scene is
    explained next."""
    ex, drawn = explainer
    long = LongExplanation(ex, monkeypatch)
    ex.render(long.frame(2))
    assert ex.wait_ready(30)
    assert long.stopped.is_set()  # abandoned: else it would have run 30 s and failed
    assert ex.error is None and ex.explanation is not None
    assert drawn.calls[-1][1] is ex.explanation
    assert len(ex.explanation.tags) == long.plans["svg"].edges


def test_a_drag_abandons_an_explanation_and_its_release_explains_again(
    explainer, monkeypatch
):
    # Abandoned for a drag, the same scene version comes back undragged: it is
    # explained then (nothing of the abandoned attempt is kept as its answer).
    ex, drawn = explainer
    long = LongExplanation(ex, monkeypatch)
    ex.render(long.frame(1, frozenset({("start",)})))
    assert ex.wait_ready(30) and long.stopped.is_set()
    ex.render(long.frame(1))
    assert ex.wait_ready(30)
    assert ex.error is None and ex.explanation is not None
    assert ex.explanation.method == "svg" and drawn.calls[-1][1] is ex.explanation


def test_another_method_abandons_an_explanation_and_coming_back_explains_it(
    explainer, monkeypatch
):
    ex, drawn = explainer
    long = LongExplanation(ex, monkeypatch)
    ex.choose("vg")
    assert ex.wait_ready(30) and long.stopped.is_set()
    assert ex.explanation is not None and ex.explanation.method == "vg"
    ex.choose("svg")
    assert ex.wait_ready(30)
    assert ex.error is None and ex.explanation is not None
    assert ex.explanation.method == "svg" and drawn.calls[-1][1] is ex.explanation


def test_a_step_that_fails_says_why_and_explain_goes_on(explainer, monkeypatch):
    # DSB's steps are made when shown: one that fails shows its error, and the next
    # step is shown as usual (the explain thread lives on).
    ex, drawn = explainer
    scene = load_scene(ROOT / "static_scenarios" / "06_four_obstacles_sensor.json")
    plans = plan_all(scene, ("dsb",))
    step = EXPLAIN_DSB._step
    failing = [True]

    def fails_once(trace, d, rec, end):
        if failing:
            failing.clear()
            raise ValueError("boom")
        return step(trace, d, rec, end)

    ex.render(dataclasses.replace(_frame(scene, 1), plans=plans))
    ex.choose("dsb")
    assert ex.wait_ready(30) and ex.explanation is not None
    monkeypatch.setattr(EXPLAIN_DSB, "_step", fails_once)
    ex.go(3)
    assert ex.wait_ready(30)
    assert ex.error == "ValueError: boom" and drawn.calls[-1][0] is None
    ex.go(4)
    assert ex.wait_ready(30)
    assert ex.error is None and drawn.calls[-1][0] is ex.explanation.step(4)
