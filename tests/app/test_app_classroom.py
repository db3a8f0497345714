"""Presenter mode and private copies, through viser's protocol.

Each test runs the real app (server, shared view, per-browser panels) in presenter mode
on 127.0.0.1 (``presenter=True``, the flag a classroom on ``--host 0.0.0.0`` turns on by
itself) and connects websocket clients that speak viser's wire format
(:mod:`tests.viser_client`): the presenter's (the token in its websocket path) and
watchers'. A client can send what no page would: a watcher's edit of a disabled widget,
a drag of a gizmo it does not have, a click on the floor. The server must refuse every
one of them; the same message from the presenter must go through, so each refusal test
can fail.
"""

from __future__ import annotations

import contextlib
import inspect
import json
import os
import threading
from collections.abc import Iterator
from typing import Any

import pytest

import planners
from app import start_app
from app.classroom import (
    PRESENTER_PATH,
    banner_html,
    connection_path,
    is_presenter_path,
    presenter_url,
)
from app.classroom.room import COPY_NICE
from app.explain.panel import METHOD_TITLES
from app.guard.gate import GatedController, Refusals
from app.server import _is_loopback
from app.session.big import SharedWorkers
from app.session.scheduler import SLOW_NICE
from tests.app.app_helpers import classroom_client as client
from tests.app.app_helpers import has_label as _has
from tests.app.app_helpers import live_time, markdowns, reset_classroom, wait_until
from tests.benchmarks.bench_big import circle_scene
from tests.viser_client import ViserClient

GOAL = "/handles/goal"


@pytest.fixture(scope="module")
def classroom_app() -> Iterator[Any]:
    app = start_app("01_two_convex", port=0, print_url=False, presenter=True)
    yield app
    app.stop()


@pytest.fixture
def planner(classroom_app: Any) -> Iterator[Any]:
    """The module's classroom app, back on its first scene, closed, with no browsers."""
    app = classroom_app
    yield app
    reset_classroom(app)


def _state(app: Any) -> tuple[Any, int]:
    assert app.wait_idle(30)
    return app.controller.scene, app.controller.version


# --------------------------------------------------------------------------- pure parts


@pytest.mark.parametrize(
    ("host", "loopback"),
    [
        ("127.0.0.1", True),
        ("127.0.0.2", True),
        ("::1", True),
        ("[::1]", True),
        ("localhost", True),
        ("0.0.0.0", False),
        ("::", False),
        ("", False),
        ("10.1.2.3", False),
        ("lecture-laptop.local", False),
    ],
)
def test_only_loopback_hosts_keep_everyone_editing(host, loopback):
    assert _is_loopback(host) is loopback


def test_the_presenter_path_needs_the_whole_token():
    token = "Ab3_-xyz"
    assert is_presenter_path(f"{PRESENTER_PATH}{token}", token)
    assert is_presenter_path(f"{PRESENTER_PATH}{token}?x=1", token)
    for path in (
        "",
        "/",
        PRESENTER_PATH,
        f"{PRESENTER_PATH}{token[:-1]}",
        f"{PRESENTER_PATH}{token}x",
        f"/other/{token}",
        f"{PRESENTER_PATH}{token.upper()}",
    ):
        assert not is_presenter_path(path, token), path
    url = presenter_url("http://10.0.0.5:8080/", token)
    assert (
        url
        == f"http://10.0.0.5:8080/?websocket=ws://10.0.0.5:8080{PRESENTER_PATH}{token}"
    )


def test_every_mode_has_its_own_banner():
    texts = {
        m: banner_html(m, {}, False)
        for m in ("presenter", "watching", "together", "private")
    }
    assert len(set(texts.values())) == 4
    assert "Watching the presenter" in texts["watching"]
    assert "Your own copy" in texts["private"]


class _Recorder:
    """A stand-in controller that records every call (the gate's tests)."""

    def __init__(self) -> None:
        self.calls: list[str] = []
        self.version = 7
        for group in ("edits", "tools", "files", "playback"):
            setattr(self, group, _RecorderGroup(self.calls, group))

    def undo(self) -> None:
        self.calls.append("undo")

    def motion_file(self, kind: str) -> None:
        self.calls.append("motion_file")

    def redo(self) -> None:
        self.calls.append("redo")

    def set_layer(self, *args: Any) -> None:
        self.calls.append("set_layer")

    def set_planner_enabled(self, *args: Any) -> None:
        self.calls.append("set_planner_enabled")


class _RecorderGroup:
    def __init__(self, calls: list[str], group: str) -> None:
        self._calls, self._group = calls, group

    def __getattr__(self, name: str) -> Any:
        return lambda *a, **k: self._calls.append(f"{self._group}.{name}")


def _entry_points() -> list[tuple[str, str]]:
    """Every public method of the controller and its groups: each is an edit entry point."""
    from app.session.controller import Controller, MouseTools, ScenarioFiles, SceneEdits

    points = [
        ("", n)
        for n, m in inspect.getmembers(Controller, inspect.isfunction)
        if not n.startswith("_")
        and n not in ("add_view", "remove_views", "wait_idle", "close", "motion_file")
    ]
    for group, cls in (
        ("edits", SceneEdits),
        ("tools", MouseTools),
        ("files", ScenarioFiles),
    ):
        points += [
            (group, n)
            for n, m in inspect.getmembers(cls, inspect.isfunction)
            if not n.startswith("_") and n != "download"
        ]
    # The robot's motion is shared too: what the panel's motion controls call.
    motion = ("play", "pause", "restart", "set_speed", "set_robot_time", "set_follow")
    return points + [("playback", n) for n in motion]


@pytest.mark.parametrize(("group", "name"), _entry_points())
def test_the_gate_refuses_every_edit_entry_point(group, name):
    recorder = _Recorder()
    allowed = [False]
    refusals = Refusals()
    gated = GatedController(recorder, lambda: allowed[0], refusals)
    target = getattr(gated, group) if group else gated
    getattr(target, name)()
    assert recorder.calls == [] and refusals.count == 1
    allowed[0] = True
    getattr(target, name)()
    assert recorder.calls == [f"{group}.{name}" if group else name]


def test_a_students_gate_never_writes_the_folder_even_when_allowed():
    recorder = _Recorder()
    gated = GatedController(recorder, lambda: True, never=frozenset({"save_to_folder"}))
    gated.files.save_to_folder("x")
    gated.files.load_from_folder("x")
    assert recorder.calls == ["files.load_from_folder"] and gated.refusals.count == 1


def test_the_gate_lets_reading_and_downloading_through():
    recorder = _Recorder()
    gated = GatedController(recorder, lambda: False)
    assert gated.version == 7
    gated.files.download()
    gated.motion_file("path .csv")  # a watcher downloads the path for its own robot
    assert recorder.calls == ["files.download", "motion_file"]
    assert gated.refusals.count == 0


# --------------------------------------------------------------------------- the server


def test_loopback_is_unchanged_one_panel_for_everyone():
    app = start_app("01_two_convex", port=0, print_url=False)
    try:
        assert app.classroom is None and app.presenter_url is None
        assert app.panels is not None
        assert "/handles/goal" in app.server.scene._handle_from_transform_controls_name
    finally:
        app.stop()


def test_the_presenter_url_makes_the_presenter_and_the_plain_url_a_watcher(planner):
    room = planner.classroom
    with client(planner, presenter=True) as pres, client(planner) as watch:
        assert connection_path(planner.server, pres.client_id).startswith(
            PRESENTER_PATH
        )
        assert room.mode(pres.client_id) == "presenter"
        assert room.mode(watch.client_id) == "watching"
        assert room.may_edit(pres.client_id) and not room.may_edit(watch.client_id)
        # Each sees its banner; the watcher's controls are disabled, the presenter's not.
        assert pres.wait_for(lambda: any("Presenter" in h for h in pres.html()))
        assert watch.wait_for(
            lambda: any("Watching the presenter" in h for h in watch.html())
        )
        assert watch.wait_for(lambda: watch.element("Radius [m]")["props"]["disabled"])
        assert not pres.element("Radius [m]")["props"]["disabled"]
        # Only the presenter has gizmos: its own, in its client scope, and nothing else
        # there: it sees the class's one drawing, which nothing of its own hides.
        assert (str(pres.client_id), f"/own{GOAL}") in pres.nodes
        own = _own_drawing(pres)
        assert own and all(n == "/own" or n.startswith("/own/handles") for n in own)
        assert (str(pres.client_id), "/shared") not in pres.nodes
        assert ("", "/shared" + GOAL) in pres.nodes
        assert not any(owner for owner, _ in watch.nodes)
    with client(planner) as plain:
        assert connection_path(planner.server, plain.client_id) == "/"


def test_a_wrong_token_watches(planner):
    room = planner.classroom
    c = ViserClient(planner.port, f"{PRESENTER_PATH}{room.token}0")
    try:
        assert wait_until(lambda: room.counts()["watching"] == 1, 30)
        assert room.counts()["presenter"] == 0
    finally:
        c.close()


def refusals(app) -> int:
    """Edits refused so far, by the door (a widget nobody may use) or by the gate."""
    assert app.door is not None
    return app.classroom.refusals.count + sum(app.door.refused.values())


def _crafted_edits(c: ViserClient, owner: str) -> None:
    """Every kind of edit a browser can send, for the panel of client ``c``."""
    c.set_gui(c.uuid("Radius [m]"), 0.55)
    c.set_gui(c.uuid("Sensor R [m]"), 7.0)
    c.set_gui(c.uuid("Robot", "Dropdown"), "differential")
    c.set_gui(c.uuid("Expansion"), "square")
    c.set_gui(c.uuid("Scenario", "Dropdown"), "08_narrow_gap")
    c.set_gui(c.uuid("Mouse"), "Click to add a polygon")
    c.click_floor((5.0, 4.0))
    c.set_gui(c.uuid("Edits"), "Undo")
    for name in ("/shared" + GOAL, "/own" + GOAL, GOAL):
        c.drag(name, (8.5, 1.5), "start", owner)
        c.drag(name, (8.5, 1.5), "update", owner)
        c.drag(name, (8.5, 1.5), "end", owner)


def test_crafted_edits_from_a_watcher_are_refused_on_the_server(planner):
    room = planner.classroom
    with client(planner, presenter=True) as pres, client(planner) as watch:
        scene, version = _state(planner)
        ui = planner.controller._state.ui
        refused = refusals(planner)
        # The watcher's (disabled) widgets, gizmo names in every scope it may claim,
        # and the presenter's widgets' ids (another connection's: viser never routes them).
        for owner in ("", str(watch.client_id), str(pres.client_id)):
            _crafted_edits(watch, owner)
        for uuid in list(pres.gui):
            watch.set_gui(uuid, 0.5)
        assert wait_until(lambda: refusals(planner) >= refused + 8, 20)
        assert planner.wait_idle(30)
        assert planner.controller.scene == scene
        assert planner.controller.version == version
        assert planner.controller._state.ui.tool == ui.tool
        assert room.mode(watch.client_id) == "watching"
        # The same messages from the presenter go through (so the test above can fail).
        pres.set_gui(pres.uuid("Radius [m]"), 0.55)
        assert wait_until(lambda: planner.controller.scene.robot.radius == 0.55, 20)
        pres.drag("/own" + GOAL, (8.5, 1.5), "start", str(pres.client_id))
        pres.drag("/own" + GOAL, (8.5, 1.5), "update", str(pres.client_id))
        pres.drag("/own" + GOAL, (8.5, 1.5), "end", str(pres.client_id))
        assert wait_until(lambda: planner.controller.scene.goal == (8.5, 1.5), 20)


def test_the_lab_switch_hands_editing_to_everyone_and_takes_it_back(planner):
    room = planner.classroom
    with client(planner, presenter=True) as pres, client(planner) as watch:
        switch = pres.uuid("Let everyone edit")
        # A watcher cannot flip the presenter's switch (not its connection's widget).
        watch.set_gui(switch, True)
        assert not wait_until(lambda: room.open, 1.0)
        pres.set_gui(switch, True)
        assert wait_until(lambda: room.open, 20)
        assert room.mode(watch.client_id) == "together"
        assert watch.wait_for(
            lambda: any("Editing together" in h for h in watch.html())
        )
        assert watch.wait_for(
            lambda: not watch.element("Radius [m]")["props"]["disabled"]
        )
        # Now the watcher has gizmos of its own and its edits reach the shared scene.
        assert watch.wait_for(
            lambda: (str(watch.client_id), f"/own{GOAL}") in watch.nodes
        )
        watch.set_gui(watch.uuid("Radius [m]"), 0.45)
        assert wait_until(lambda: planner.controller.scene.robot.radius == 0.45, 20)
        watch.drag("/own" + GOAL, (8.0, 2.0), "start", str(watch.client_id))
        watch.drag("/own" + GOAL, (8.0, 2.0), "update", str(watch.client_id))
        watch.drag("/own" + GOAL, (8.0, 2.0), "end", str(watch.client_id))
        assert wait_until(lambda: planner.controller.scene.goal == (8.0, 2.0), 20)
        # Taken back: the watcher watches again, and its edits are refused again.
        pres.set_gui(switch, False)
        assert wait_until(lambda: not room.open, 20)
        assert room.mode(watch.client_id) == "watching"
        assert watch.wait_for(lambda: watch.element("Radius [m]")["props"]["disabled"])
        scene, version = _state(planner)
        watch.set_gui(watch.uuid("Radius [m]"), 0.2)
        watch.drag("/own" + GOAL, (2.0, 2.0), "update", str(watch.client_id))
        assert not wait_until(lambda: planner.controller.version != version, 1.0)
        assert planner.controller.scene == scene


def _own_drawing(c: ViserClient) -> list[str]:
    """The nodes drawn for this browser alone under ``/own`` (a copy's or editor's view)."""
    with c._lock:  # the client's reader thread adds nodes meanwhile
        names = [name for owner, name in c.nodes if owner == str(c.client_id)]
    return [name for name in names if name == "/own" or name.startswith("/own/")]


def test_a_private_copy_is_a_session_of_its_own_freed_when_the_browser_leaves(planner):
    room = planner.classroom
    with client(planner, presenter=True) as pres:
        with client(planner) as student:
            sid = student.client_id
            shared_before, _ = _state(planner)
            student.click("Make my own copy")
            assert wait_until(lambda: room.mode(sid) == "private", 20)
            assert room.counts()["sessions"] == 1
            seat = room.seat(sid)
            private = seat.private
            assert private is not None and private.scene == shared_before
            assert private.wait_idle(60)
            assert student.wait_for(
                lambda: any("Your own copy" in h for h in student.html())
            )
            assert not student.element("Radius [m]")["props"]["disabled"]
            # Its edits stay in its session...
            student.set_gui(student.uuid("Radius [m]"), 0.6)
            assert wait_until(lambda: private.scene.robot.radius == 0.6, 20)
            student.drag("/own" + GOAL, (7.5, 2.5), "start", str(sid))
            student.drag("/own" + GOAL, (7.5, 2.5), "update", str(sid))
            student.drag("/own" + GOAL, (7.5, 2.5), "end", str(sid))
            assert wait_until(lambda: private.scene.goal == (7.5, 2.5), 20)
            assert planner.controller.scene == shared_before
            # ... with its own undo history...
            student.set_gui(student.uuid("Edits"), "Undo")
            assert wait_until(lambda: private.scene.goal == shared_before.goal, 20)
            assert private.scene.robot.radius == 0.6
            assert planner.controller.scene == shared_before
            # ... and the presenter's edits do not reach it.
            pres.drag("/own" + GOAL, (1.5, 6.5), "start", str(pres.client_id))
            pres.drag("/own" + GOAL, (1.5, 6.5), "update", str(pres.client_id))
            pres.drag("/own" + GOAL, (1.5, 6.5), "end", str(pres.client_id))
            assert wait_until(lambda: planner.controller.scene.goal == (1.5, 6.5), 20)
            assert private.wait_idle(60)
            assert private.scene.goal == shared_before.goal
            # Its DSB ran in the shared pool, not a process of its own.
            assert private.frame is not None and "dsb" in private.frame.plans
            assert (
                private.scheduler.slow_planners
                and room.shared.pool.processes <= room.shared.pool.size
            )
            # Follow the presenter again: the copy is closed, the panel follows.
            student.click("Follow the presenter again")
            assert wait_until(lambda: room.mode(sid) == "watching", 20)
            assert room.counts()["sessions"] == 0
            assert student.wait_for(
                lambda: student.element("Radius [m]")["props"]["disabled"]
            )
            # The copy's drawing is gone from its browser; the presenter's is shown.
            assert student.wait_for(lambda: not _own_drawing(student), 20)
            # A second copy is seeded from the presenter's scene as it is now.
            student.click("Make my own copy")
            assert wait_until(lambda: room.mode(sid) == "private", 20)
            second = room.seat(sid).private
            assert second is not None and second is not private
            assert second.scene.goal == (1.5, 6.5)
        # The browser closed: its seat and its session are gone.
        assert wait_until(lambda: room.seat(sid) is None, 20)
        assert room.counts()["sessions"] == 0
        assert (
            wait_until(lambda: not second._scheduler._threads_alive(), 20)
            if hasattr(second._scheduler, "_threads_alive")
            else True
        )


def test_private_copies_share_a_bounded_pool_of_workers(planner):
    room = planner.classroom
    with contextlib.ExitStack() as stack:
        students = [stack.enter_context(client(planner)) for _ in range(3)]
        for s in students:
            s.click("Make my own copy")
        assert wait_until(lambda: room.counts()["sessions"] == 3, 30)
        for k, s in enumerate(students):
            # A student drags the gizmo once its page has it.
            owner = str(s.client_id)
            assert s.wait_for(lambda s=s, o=owner: (o, "/own" + GOAL) in s.nodes, 30)
            s.drag("/own" + GOAL, (7.0 + 0.3 * k, 2.0), "start", str(s.client_id))
            s.drag("/own" + GOAL, (7.0 + 0.3 * k, 2.0), "update", str(s.client_id))
            s.drag("/own" + GOAL, (7.0 + 0.3 * k, 2.0), "end", str(s.client_id))
        for k, s in enumerate(students):
            private = room.seat(s.client_id).private
            assert wait_until(
                lambda p=private, k=k: p.scene.goal == (7.0 + 0.3 * k, 2.0), 20
            )
            assert private.wait_idle(90)
            assert private.frame.plans["dsb"].status in ("reached", "unreachable")
        assert 1 <= room.shared.pool.processes <= room.shared.pool.size
        # The copies plan below the presenter's DSB worker, itself below the server.
        assert COPY_NICE > SLOW_NICE
        for pid in room.shared.pool.pids:
            niceness = os.getpriority(os.PRIO_PROCESS, pid)
            assert niceness == min(19, os.nice(0) + COPY_NICE)
    assert wait_until(lambda: room.counts()["sessions"] == 0, 20)


def test_private_copies_plan_big_scenes_in_the_shared_pool(planner):
    """Students who all open a CAD-sized scene start at most
    ``copy_workers`` processes for its graphs, not one each; an edit of one copy gives
    its own computation up, and every copy ends with its own scene's plans."""
    room = planner.classroom
    big = circle_scene()  # 10,004 vertices: planned in a worker (app.session.big)
    with contextlib.ExitStack() as stack:
        students = [stack.enter_context(client(planner)) for _ in range(2)]
        for s in students:
            s.click("Make my own copy")
        assert wait_until(lambda: room.counts()["sessions"] == 2, 30)
        copies = [room.seat(s.client_id).private for s in students]
        for k, copy in enumerate(copies):
            copy.files.load_text(json.dumps(big), f"circle-{k}.json")
        copies[0].edits.move_goal((37.0, 19.0))  # while both compute or wait
        for copy in copies:
            assert copy.wait_idle(240)
        assert room.shared.big_pool.processes == 1 <= room.shared.big_pool.size
        for copy in copies:
            big_workers = copy.scheduler._fast.big  # no process of its own: the pool
            assert isinstance(big_workers, SharedWorkers)
            assert big_workers.pool is room.shared.big_pool
            final = copy.frame
            assert final is not None and not final.stale and final.progress is None
            fresh = planners.plan_all(final.scene, ("vg", "svg"))
            for name in ("vg", "svg"):
                assert final.plans[name].length == pytest.approx(fresh[name].length)
                assert final.plans[name].edges == fresh[name].edges
        assert copies[0].frame.scene.goal == (37.0, 19.0)
        assert copies[1].frame.scene.goal == planners.load_scene(big).goal
    assert wait_until(lambda: room.counts()["sessions"] == 0, 20)


def test_a_student_never_writes_the_scenes_folder_even_on_a_copy(tmp_path):
    """Item 1's rule, for the ways in that a classroom adds: a watcher, a lab seat and a
    private copy each press *Save to the scenes folder*; only the presenter's save writes."""
    folder = tmp_path / "scenes"
    folder.mkdir()
    app = start_app(
        "01_two_convex", port=0, print_url=False, presenter=True, scenes_dir=folder
    )
    room = app.classroom
    assert room is not None
    try:
        with client(app, presenter=True) as pres, client(app) as student:
            # A watcher's panel (the class's one) has no scenes folder at all.
            assert pres.wait_for(lambda: "Save to the scenes folder" in pres.labels())
            assert student.wait_for(lambda: "Radius [m]" in student.labels())
            assert "Save to the scenes folder" not in student.labels()

            def try_save(c: ViserClient, name: str, panel: ViserClient) -> None:
                c.set_gui(panel.uuid("Save as"), name)
                c.set_gui(panel.uuid("Save to the scenes folder"), True)

            refused = refusals(app)
            try_save(student, "watching", pres)  # watching: the presenter's widgets
            pres.set_gui(pres.uuid("Let everyone edit"), True)
            assert wait_until(lambda: room.mode(student.client_id) == "together", 20)
            # Its own panel now, to edit with; the save button greyed out from the start.
            assert student.wait_for(
                lambda: (
                    "Save as" in student.labels()
                    and student.element("Save to the scenes folder")["props"][
                        "disabled"
                    ]
                )
            )
            try_save(student, "together", student)  # editing together
            pres.set_gui(pres.uuid("Let everyone edit"), False)
            student.click("Make my own copy")
            assert wait_until(lambda: room.mode(student.client_id) == "private", 20)
            # On its copy the student edits, but the save button stays greyed out.
            assert student.wait_for(
                lambda: not student.element("Radius [m]")["props"]["disabled"]
            )
            assert student.element("Save to the scenes folder")["props"]["disabled"]
            try_save(student, "private", student)  # on its own copy
            assert wait_until(lambda: refusals(app) >= refused + 3, 20)
            assert sorted(p.name for p in tmp_path.rglob("*")) == ["scenes"]
            try_save(pres, "lecture", pres)
            assert wait_until((folder / "lecture.json").is_file, 20)
            assert sorted(p.name for p in folder.iterdir()) == ["lecture.json"]
    finally:
        app.stop()


def test_watchers_see_the_goal_move_during_the_presenters_drag(planner):
    with client(planner, presenter=True) as pres, client(planner) as watch:
        owner = str(pres.client_id)
        pres.drag("/own" + GOAL, (8.0, 1.5), "start", owner)
        pres.drag("/own" + GOAL, (8.0, 1.5), "update", owner)
        # Not released yet: the shared marker follows anyway (no gizmo is held there).
        assert watch.wait_for(
            lambda: (
                (watch.nodes.get(("", "/shared" + GOAL)) or {}).get("position")
                == (8.0, 1.5, 0.0)
            ),
            20,
        ), watch.nodes.get(("", "/shared" + GOAL))
        assert planner.controller.frame.dragging == frozenset({("goal",)})
        pres.drag("/own" + GOAL, (8.0, 1.5), "end", owner)
        assert wait_until(lambda: planner.controller.frame.dragging == frozenset(), 20)


def test_explain_and_live_are_the_presenters_and_drawn_for_the_class(planner):
    """The presenter's panel has Explain and Live DSB; the class sees what they draw."""
    room = planner.classroom
    with client(planner, presenter=True) as pres, client(planner) as watch:
        assert pres.wait_for(lambda: _has(pres, "Step no.") and _has(pres, "Live"))
        # A watcher has neither folder: nothing to step, nothing to start.
        assert not _has(watch, "Step no.") and not _has(watch, "Live")
        # One Explain and one live robot for the classroom (every presenter's browser).
        assert planner.explain is not None and planner.live is not None
        # The presenter chooses the SVG: every browser sees the explanation's nodes.
        pres.set_gui(pres.uuid("Method"), "Simplified VG (9.5)")
        assert planner.wait_idle(30)
        assert wait_until(
            lambda: any(
                owner == "" and name.startswith("/explain/") and node["visible"]
                for (owner, name), node in watch.nodes.items()
            ),
            30,
        ), {k: v for k, v in watch.nodes.items() if "/explain" in k[1]}
        # Explain hid the layer (the frame that says so may come after its drawing).
        assert wait_until(lambda: not planner.controller.frame.layers["svg_edges"], 20)
        # A student's own copy hides the presenter's explanation and live robot.
        sid = watch.client_id
        watch.click("Make my own copy")
        assert wait_until(lambda: room.mode(sid) == "private", 20)
        for root in ("/explain", "/live"):
            assert watch.wait_for(
                lambda root=root: (
                    (watch.nodes.get((str(sid), root)) or {}).get("visible") is False
                ),
                20,
            ), root
        # Back to following: the shadows go, the explanation shows again.
        watch.click("Follow the presenter again")
        assert wait_until(lambda: room.mode(sid) == "watching", 20)
        assert watch.wait_for(lambda: (str(sid), "/explain") not in watch.nodes, 20)
    # The presenter's browser left while explaining: it left the audience, and the last
    # presenter's Explain folder gone, Explain went off, gave the plans' layers back and
    # hid its drawing.
    # Only the class's one watcher panel is left (app.classroom.watch).
    assert wait_until(lambda: len(room.audience) == 1, 20)
    explainer = planner.explain.explainer
    assert wait_until(lambda: explainer.method == "off", 20)
    assert explainer.wait_ready(30) and planner.wait_idle(30)
    frame = planner.controller.frame
    assert frame is not None and frame.layers["svg_edges"]
    with client(planner) as late:
        shown = [
            name
            for (owner, name), node in late.nodes.items()
            if owner == "" and name.startswith("/explain/") and node["visible"]
        ]
        # The label pools' roots are plain frames; what they hold is hidden.
        shown = [n for n in shown if n not in ("/explain/labels", "/explain/caption")]
        assert not shown, shown


def _scoped_explain_nodes(c: ViserClient, owner: str) -> list[str]:
    """Names of the visible Explain drawing nodes ``c`` holds under ``owner``'s scope."""
    with c._lock:  # the client's reader thread adds nodes meanwhile
        nodes = list(c.nodes.items())
    return [
        name
        for (who, name), node in nodes
        if who == owner
        and name.startswith("/own_explain/")
        and "/explain/" in name
        and node["visible"]
    ]


def test_a_private_copy_has_an_explain_mode_of_its_own(planner):
    """A student explains the SVG on its copy: the folder and the drawing are its own
    (in its browser's scope, never broadcast), the presenter's Explain and layers are
    untouched, and following the presenter again takes both away."""
    room = planner.classroom
    svg = METHOD_TITLES["svg"]
    with client(planner, presenter=True) as pres, client(planner) as student:
        sid = student.client_id
        assert not _has(student, "Step no.")  # a follower has no Explain folder
        student.click("Make my own copy")
        assert wait_until(lambda: room.mode(sid) == "private", 20)
        assert student.wait_for(lambda: _has(student, "Step no."))
        private, first = room.seat(sid).private, room.seat(sid).explain
        assert private is not None and private.wait_idle(60)
        # Its explanations take turns with the other copies' (the classroom's bound).
        assert (
            first is not None
            and first.panel.explainer._turns is room.shared.explain_turns
        )
        student.set_gui(student.uuid("Method"), svg)
        assert student.wait_for(lambda: bool(_scoped_explain_nodes(student, str(sid))))
        assert student.wait_for(
            lambda: any(", step 1 of" in h for h in markdowns(student))
        )
        # The copy's plan layers are hidden while it explains; the presenter's are not.
        assert wait_until(lambda: not private.frame.layers["svg_edges"], 20)
        assert planner.controller.frame.layers["svg_edges"]
        assert planner.explain is None or planner.explain.explainer.method == "off"
        # Nothing of it reaches the presenter's browser.
        assert not _scoped_explain_nodes(pres, str(sid))
        with pres._lock:
            assert not any(n.startswith("/own_explain") for _, n in pres.nodes)
        # Following the presenter again closes the copy and its Explain mode.
        student.click("Follow the presenter again")
        assert wait_until(lambda: room.mode(sid) == "watching", 20)
        assert student.wait_for(lambda: not _has(student, "Step no."))
        assert student.wait_for(lambda: not _scoped_explain_nodes(student, str(sid)))
        assert room.seat(sid).explain is None
        assert planner.controller.frame.layers["svg_edges"]
        # A new copy draws under a root of its own: the old one's closing never
        # touches it.
        student.click("Make my own copy")
        assert wait_until(lambda: room.mode(sid) == "private", 20)
        again = room.seat(sid).explain
        assert again is not None and again.root != first.root


def test_a_copys_explain_mode_stops_when_its_browser_leaves(planner):
    room = planner.classroom
    with client(planner) as student:
        sid = student.client_id
        student.click("Make my own copy")
        # Longer than elsewhere: the copy is built while the previous test's copy and
        # its Explain are still being closed, which a loaded machine has once taken
        # more than 20 s to do.
        assert wait_until(lambda: room.mode(sid) == "private", 60)
        assert student.wait_for(lambda: _has(student, "Step no."))
        explain = room.seat(sid).explain
        assert explain is not None
        student.set_gui(student.uuid("Method"), METHOD_TITLES["vg"])
        assert wait_until(lambda: explain.panel.explainer.method == "vg", 20)
        explainer = explain.panel.explainer
        # It explains the VG in a thread of its own (idle after, for IDLE_S).
        assert wait_until(lambda: explainer.explanation is not None, 30)
    assert wait_until(lambda: room.seat(sid) is None, 20)
    assert wait_until(lambda: explainer._closed, 20)
    # Its thread ended with it, and a closed explainer starts none.
    assert wait_until(lambda: explainer._runner.threads == 0, 20)
    explainer.choose("svg")
    assert explainer._runner.threads == 0


def _live_nodes(c: ViserClient) -> list[tuple[str, str]]:
    """The (scope, name) of the copies' live drawings ``c`` holds."""
    with c._lock:  # the client's reader thread adds nodes meanwhile
        return [key for key in c.nodes if key[1].startswith("/own_live/")]


def test_copies_drive_live_robots_of_their_own_on_one_shared_thread(planner):
    """Two students start the live robot on their copies: each drives in its own page
    only, the presenter's robot does not move, and all the copies' robots are stepped by
    one thread, which ends when the last copy goes."""
    room = planner.classroom
    ticker = room.shared.ticker
    with (
        client(planner, presenter=True) as pres,
        client(planner) as a,
        client(planner) as b,
    ):
        for student in (a, b):
            student.click("Make my own copy")
            sid = student.client_id
            assert wait_until(lambda sid=sid: room.mode(sid) == "private", 60)
            assert student.wait_for(lambda student=student: _has(student, "Live"))
        assert not _has(pres, "Make my own copy") and planner.live is not None
        runs = [room.seat(s.client_id).live.run for s in (a, b)]
        for student in (a, b):
            student.set_gui(student.uuid("Live"), "Start live")
        assert wait_until(lambda: all(run.running for run in runs), 20)
        for student in (a, b):  # each page's own status moves on
            first = live_time(student) or 0.0
            assert student.wait_for(
                lambda s=student, t=first: (live_time(s) or 0.0) > t + 0.1, 30
            ), markdowns(student)
        # Each robot and trail is drawn in its own browser's scope, never broadcast.
        for student in (a, b):
            mine = str(student.client_id)
            assert student.wait_for(
                lambda s=student, m=mine: any(
                    scope == m and name.endswith("/live/trail")
                    for scope, name in _live_nodes(s)
                )
            )
        assert not _live_nodes(pres)
        assert not planner.live.running and planner.live.state is None
        assert ticker.alive
        stepping = [t for t in threading.enumerate() if t.name == "copies-robots"]
        assert len(stepping) == 1, stepping
        # One follows the presenter again: its robot stops, the other drives on.
        a.click("Follow the presenter again")
        assert wait_until(lambda: room.mode(a.client_id) == "watching", 20)
        assert a.wait_for(lambda: not _has(a, "Live"))
        assert a.wait_for(lambda: not _live_nodes(a))
        assert not runs[0].running
        t = runs[1].state.t
        assert wait_until(lambda: runs[1].state.t > t, 20)
    # The last copy left with its browser: the copies' ticker holds no thread.
    assert wait_until(lambda: not ticker.alive, 20)
    assert not [t for t in threading.enumerate() if t.name == "copies-robots"]
