"""Two presenter browsers at once (the laptop and the projector), through viser's protocol.

A lecturer opens the presenter's URL twice: on the laptop and on the projector's screen,
or once more after a reload. Both are the presenter: one scene, one Explain, one live
robot (:mod:`app.classroom`, "Several presenter browsers"). Each test connects websocket
clients that speak viser's wire format (:mod:`tests.viser_client`) to the real app in
presenter mode, and checks what each browser is sent:

- what one presenter browser does in Explain (method, step) the other's folder shows;
- the live robot's status reaches every presenter browser, whichever closed;
- closing (or reloading) one leaves the other's tools, Explain and live robot working,
  and the banners count the presenter browsers there are.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import pytest

from app import start_app
from app.explain.panel import METHOD_TITLES
from tests.app.app_helpers import classroom_client as client
from tests.app.app_helpers import live_time, markdowns, wait_until
from tests.viser_client import ViserClient

GOAL = "/handles/goal"
SVG = METHOD_TITLES["svg"]


@pytest.fixture(scope="module")
def room_app() -> Iterator[Any]:
    app = start_app("01_two_convex", port=0, print_url=False, presenter=True)
    yield app
    app.stop()


@pytest.fixture
def planner(room_app: Any) -> Iterator[Any]:
    """The module's app on its first scene, the live robot reset, nobody connected."""
    app = room_app
    yield app
    assert wait_until(lambda: not app.server.get_clients(), 20)
    app.live.reset()
    if app.explain is not None:
        app.explain.choose("off")
    app.controller.files.load_scenario("01_two_convex")
    assert app.wait_idle(30)


@contextlib.contextmanager
def _presenter(app: Any) -> Iterator[ViserClient]:
    """A presenter's browser whose seat, panel and Explain and Live folders are built."""
    with client(app, presenter=True) as c:
        labels = ("Step no.", "Live", "Replay t [s]")
        assert c.wait_for(lambda: all(_has(c, label) for label in labels), 30)
        yield c


def _has(c: ViserClient, label: str) -> bool:
    return any(e["label"] == label for e in c.gui.values())


def _value(c: ViserClient, label: str) -> Any:
    return c.element(label)["value"]


def _texts(c: ViserClient, start: str) -> list[str]:
    return [h for h in markdowns(c) if h.startswith(start)]


def _step_text(c: ViserClient) -> str:
    """The Explain folder's line ("**title**, step n of N ...")."""
    with_step = [h for h in markdowns(c) if ", step " in h and h.startswith("**")]
    return with_step[0] if with_step else ""


def _explanation_shown(c: ViserClient) -> bool:
    with c._lock:  # the client's reader thread adds nodes meanwhile
        nodes = list(c.nodes.items())
    return any(
        owner == "" and name.startswith("/explain/") and node["visible"]
        for (owner, name), node in nodes
        if name not in ("/explain/labels", "/explain/caption")
    )


def _banner(c: ViserClient) -> str:
    return next((h for h in c.html() if "Presenter</div>" in h), "")


def _own_goal(c: ViserClient) -> Any:
    with c._lock:
        return (c.nodes.get((str(c.client_id), "/own" + GOAL)) or {}).get("position")


def test_both_presenter_browsers_are_presenters_and_counted(planner):
    room = planner.classroom
    with _presenter(planner) as b:
        with _presenter(planner) as a:
            assert room.mode(a.client_id) == room.mode(b.client_id) == "presenter"
            assert room.counts()["presenter"] == 2
            for c in (a, b):
                assert c.wait_for(lambda c=c: "2 presenter browsers" in _banner(c), 20)
            with client(planner) as watcher:
                for c in (a, b):
                    assert c.wait_for(lambda c=c: "1 following" in _banner(c), 20)
                assert room.mode(watcher.client_id) == "watching"
            assert b.wait_for(lambda: "0 following" in _banner(b), 20)
            aid = a.client_id
        # A's tab closed: B's banner says B is the one presenter browser left.
        assert wait_until(lambda: room.seat(aid) is None, 20)
        assert room.counts()["presenter"] == 1
        assert b.wait_for(lambda: "presenter browsers" not in _banner(b), 20)
        assert "Presenter</div>" in _banner(b)
    assert wait_until(lambda: room.counts()["presenter"] == 0, 20)


def test_explain_is_one_for_both_presenter_browsers(planner):
    with _presenter(planner) as a, _presenter(planner) as b:
        a.set_gui(a.uuid("Method"), SVG)
        assert a.wait_for(lambda: "step 1 of" in _step_text(a), 30), markdowns(a)
        # B's folder shows A's choice and its first step, and the class sees it.
        assert b.wait_for(lambda: _value(b, "Method") == SVG, 20)
        assert b.wait_for(lambda: "step 1 of" in _step_text(b), 20), markdowns(b)
        assert b.wait_for(lambda: _explanation_shown(b), 20)
        assert planner.wait_idle(30)
        assert not planner.controller.frame.layers["svg_edges"]
        # B steps forward: A's slider and text follow.
        b.set_gui(b.uuid("Step"), ">")
        assert b.wait_for(lambda: "step 2 of" in _step_text(b), 20), markdowns(b)
        assert a.wait_for(lambda: "step 2 of" in _step_text(a), 20), markdowns(a)
        assert a.wait_for(lambda: _value(a, "Step no.") == 2, 20)
        assert planner.explain.explainer.step == 1
        sid = a.client_id
    # A left (B stays, then B left too: the fixture's order). Checked in the next test.
    assert wait_until(lambda: planner.classroom.seat(sid) is None, 20)


def test_closing_one_presenter_browser_leaves_the_others_explain(planner):
    explainer = planner.explain.explainer
    with _presenter(planner) as b:
        with _presenter(planner) as a:
            a.set_gui(a.uuid("Method"), SVG)
            assert wait_until(lambda: explainer.method == "svg", 20)
            assert explainer.wait_ready(30)
            a.set_gui(a.uuid("Step"), ">")
            assert wait_until(lambda: explainer.step == 1, 20)
            assert b.wait_for(lambda: "step 2 of" in _step_text(b), 20)
            aid = a.client_id
        # A's tab closed: the explanation, its step and the hidden layers stay for B.
        assert wait_until(lambda: planner.classroom.seat(aid) is None, 20)
        assert planner.wait_idle(30) and explainer.wait_ready(30)
        assert explainer.method == "svg" and explainer.step == 1
        assert b.wait_for(lambda: _explanation_shown(b), 20)  # B's messages arrive
        assert not planner.controller.frame.layers["svg_edges"]
        # B still drives it: a step forward, then off, which gives the layers back.
        b.set_gui(b.uuid("Step"), ">")
        assert wait_until(lambda: explainer.step == 2, 20)
        assert b.wait_for(lambda: "step 3 of" in _step_text(b), 20)
        b.set_gui(b.uuid("Method"), METHOD_TITLES["off"])
        assert wait_until(lambda: explainer.method == "off", 20)
        assert explainer.wait_ready(30) and planner.wait_idle(30)
        assert planner.controller.frame.layers["svg_edges"]
        assert b.wait_for(lambda: not _explanation_shown(b), 20)


def test_the_last_presenter_browser_leaving_turns_explain_off(planner):
    explainer = planner.explain.explainer
    with _presenter(planner) as a:
        a.set_gui(a.uuid("Method"), SVG)
        assert wait_until(lambda: explainer.method == "svg", 20)
        assert explainer.wait_ready(30) and planner.wait_idle(30)
        assert not planner.controller.frame.layers["svg_edges"]
    # Nobody can switch it off any more: it goes off, the layers come back.
    assert wait_until(lambda: explainer.method == "off", 20)
    assert explainer.wait_ready(30) and planner.wait_idle(30)
    assert planner.controller.frame.layers["svg_edges"]
    with _presenter(planner) as again:
        assert _value(again, "Method") == METHOD_TITLES["off"]
        assert not _explanation_shown(again)


def _updates(c: ViserClient, timeout: float = 20.0) -> bool:
    """Whether the live time ``c`` shows moves on (twice) within ``timeout``."""
    first = live_time(c)
    if not c.wait_for(lambda: (live_time(c) or -1) > (first or -1), timeout):
        return False
    second = live_time(c)
    return c.wait_for(lambda: (live_time(c) or -1) > (second or -1), timeout)


def test_the_live_robot_reaches_every_presenter_browser_whichever_closes(planner):
    live = planner.live
    with _presenter(planner) as a:
        with _presenter(planner) as b:
            # A (the first to connect) starts the robot: both see it run.
            a.set_gui(a.uuid("Live"), "Start live")
            assert wait_until(lambda: live.running, 20)
            assert _updates(a) and _updates(b)
            bid = b.client_id
        # B (the last to connect) closed: A still gets every update.
        assert wait_until(lambda: planner.classroom.seat(bid) is None, 20)
        assert live.running
        assert _updates(a)
        # B reloads: its new panel shows the running robot at once and follows it.
        with _presenter(planner) as b2:
            assert b2.wait_for(lambda: bool(_texts(b2, "**Live (running)")), 20), (
                markdowns(b2)
            )
            assert _updates(b2)
            aid = a.client_id
            a.close()
            assert wait_until(lambda: planner.classroom.seat(aid) is None, 20)
            # A closed too: B's tab goes on, and its buttons still drive the robot.
            assert _updates(b2)
            b2.set_gui(b2.uuid("Live"), "Stop")
            assert wait_until(lambda: not live.running, 20)
            assert b2.wait_for(lambda: bool(_texts(b2, "**Live (stopped)")), 20)
            assert planner.classroom.counts()["presenter"] == 1
            assert b2.wait_for(lambda: "2 presenter" not in _banner(b2), 20)


def test_a_reloaded_presenter_browser_has_every_tool(planner):
    """Close B, open it again: it edits, explains and sees A's edits; A sees B's."""
    explainer = planner.explain.explainer
    with _presenter(planner) as a:
        with _presenter(planner):
            pass
        with _presenter(planner) as b:
            assert planner.classroom.counts()["presenter"] == 2
            # B drags the goal with its own gizmo: the scene changes, A's copy follows.
            owner = str(b.client_id)
            for phase in ("start", "update", "end"):
                b.drag("/own" + GOAL, (8.5, 1.5), phase, owner)
            assert wait_until(lambda: planner.controller.scene.goal == (8.5, 1.5), 20)
            assert a.wait_for(lambda: _own_goal(a) == (8.5, 1.5, 0.0), 20)
            # B explains, A's folder follows; A switches it off, B's folder follows.
            b.set_gui(b.uuid("Method"), METHOD_TITLES["vg"])
            assert wait_until(lambda: explainer.method == "vg", 20)
            assert a.wait_for(lambda: _value(a, "Method") == METHOD_TITLES["vg"], 20)
            assert a.wait_for(lambda: "step 1 of" in _step_text(a), 30)
            a.set_gui(a.uuid("Method"), METHOD_TITLES["off"])
            assert wait_until(lambda: explainer.method == "off", 20)
            assert b.wait_for(lambda: _value(b, "Method") == METHOD_TITLES["off"], 20)
            assert explainer.wait_ready(30) and planner.wait_idle(30)
            assert planner.controller.frame.layers["vg_edges"]
            # A's edit (the robot's radius in the panel) reaches B's panel.
            a.set_gui(a.uuid("Radius [m]"), 0.5)
            assert wait_until(lambda: planner.controller.scene.robot.radius == 0.5, 20)
            assert b.wait_for(lambda: _value(b, "Radius [m]") == 0.5, 20)


def test_the_other_presenter_browser_sees_a_drag_as_it_goes(planner):
    """The projector's tab moves the goal while the laptop's mouse still holds it."""
    with _presenter(planner) as a, _presenter(planner) as b:
        owner = str(a.client_id)
        a.drag("/own" + GOAL, (8.0, 1.5), "start", owner)
        a.drag("/own" + GOAL, (8.0, 1.5), "update", owner)
        assert b.wait_for(lambda: _own_goal(b) == (8.0, 1.5, 0.0), 20), _own_goal(b)
        # Still held (a frame the slow lane finishes may carry an older snapshot's UI).
        assert wait_until(
            lambda: planner.controller.frame.dragging == frozenset({("goal",)}), 20
        )
        a.drag("/own" + GOAL, (8.2, 1.6), "update", owner)
        assert b.wait_for(lambda: _own_goal(b) == (8.2, 1.6, 0.0), 20), _own_goal(b)
        a.drag("/own" + GOAL, (8.2, 1.6), "end", owner)
        assert wait_until(lambda: planner.controller.frame.dragging == frozenset(), 20)
        assert planner.controller.scene.goal == (8.2, 1.6)


def test_the_live_robot_drives_on_when_every_presenter_browser_left(planner):
    live = planner.live
    with _presenter(planner) as a:
        a.set_gui(a.uuid("Live"), "Start live")
        assert wait_until(lambda: live.running, 20)
        assert _updates(a)
        aid = a.client_id
    assert wait_until(lambda: planner.classroom.seat(aid) is None, 20)
    state = live.state
    assert state is not None and live.running
    # Nobody's folder is told, and the robot goes on for the class.
    assert wait_until(lambda: (live.state or state).t > state.t + 0.5, 20)
    with _presenter(planner) as back:
        assert back.wait_for(lambda: bool(_texts(back, "**Live (running)")), 20)
        assert _updates(back)
        back.set_gui(back.uuid("Live"), "Stop")
        assert wait_until(lambda: not live.running, 20)


def test_the_replay_slider_scrubbed_in_one_browser_moves_in_the_other(planner):
    live = planner.live
    with _presenter(planner) as a, _presenter(planner) as b:
        a.set_gui(a.uuid("Live"), "Start live")
        assert wait_until(lambda: live.running, 20)
        assert _updates(b)
        a.set_gui(a.uuid("Live"), "Stop")
        assert wait_until(lambda: not live.running, 20)
        assert b.wait_for(lambda: bool(_texts(b, "**Live (stopped)")), 20)
        end = live_time(b)
        assert end is not None and end > 0.2
        a.set_gui(a.uuid("Replay t [s]"), 0.2)
        assert b.wait_for(lambda: _value(b, "Replay t [s]") == 0.2, 20)
        # The robot is drawn where it was then (for every browser), and B scrubs back.
        b.set_gui(b.uuid("Replay t [s]"), end)
        assert a.wait_for(lambda: _value(a, "Replay t [s]") == end, 20)
