"""The planning scheduler: lanes by registry kind, enabled planners, stale slow results.

Planners are injected through a registry dict (never by patching :mod:`planners`); their
run functions are module-level so that the worker process can run them too.
"""

from __future__ import annotations

import dataclasses
import threading
from typing import Any

import numpy as np
import pytest

import planners
from app.session.scheduler import Failed, Pending, SlowResults, lanes_for, merge_slow
from app.session.scheduler import _Computed as Computed
from app.session.scheduler import _PlanKey as PlanKey
from tests.app.app_helpers import SCENARIO_DIR, FakeView


@pytest.fixture
def runners(both_lanes: Any) -> Any:
    """Every test here runs with each scheduler's own threads and with shared runners."""
    return both_lanes


@dataclasses.dataclass(frozen=True)
class Straight:
    """A toy result: the straight segment from start to goal."""

    planner: str
    path: np.ndarray
    status: str = "ok"
    reason: str | None = None
    ms: float = 0.0

    @property
    def length(self) -> float:
        return float(np.hypot(*(self.path[-1] - self.path[0])))


def straight_graph(cspace, scene, options):
    return Straight("straight", np.array([scene.start, scene.goal], dtype=float))


def straight_trace(cspace, scene, options):
    return Straight("walk", np.array([scene.start, scene.goal], dtype=float))


def broken_graph(cspace, scene, options):
    raise RuntimeError("graph exploded")


def spec(name, kind, run, default=True):
    return planners.PlannerSpec(name, name.title(), kind, run, "", default=default)


def with_planners(*specs):
    return {**planners.REGISTRY, **{s.name: s for s in specs}}


@pytest.fixture
def scene() -> planners.Scene:
    return planners.load_scene(SCENARIO_DIR / "01_two_convex.json")


# ----------------------------------------------------------------------------- lanes


def test_registry_kinds_decide_the_lanes():
    registry = with_planners(
        spec("straight", "graph", straight_graph), spec("walk", "trace", straight_trace)
    )
    fast, slow = lanes_for(registry, slow_process=False)
    assert fast.names == ("vg", "svg", "straight")
    assert slow is not None and slow.names == ("dsb", "bug2", "walk")
    assert slow.process is None  # in a thread when asked
    graphs_only = {n: s for n, s in registry.items() if s.kind == "graph"}
    assert lanes_for(graphs_only, slow_process=False)[1] is None  # no second lane


def test_injected_planners_of_both_kinds_are_drawn(make_controller, scene):
    registry = with_planners(
        spec("straight", "graph", straight_graph), spec("walk", "trace", straight_trace)
    )
    controller, view = make_controller(scene, registry=registry)
    assert controller.slow_planners == ("dsb", "bug2", "walk")
    plans = view.last.plans
    assert plans["straight"].status == "ok" and plans["walk"].status == "ok"
    assert plans["straight"].length == pytest.approx(np.hypot(8.0, 6.0))
    assert plans["vg"].status == "ok" and plans["dsb"].status == "reached"


def test_a_broken_graph_planner_reports_its_error_while_the_others_draw(
    make_controller, scene
):
    registry = with_planners(spec("broken", "graph", broken_graph))
    _controller, view = make_controller(scene, registry=registry)
    frame = view.last
    assert frame.plans["broken"].status == "error"
    assert isinstance(frame.plans["broken"], Failed)
    assert any("graph exploded" in p for p in frame.problems)
    assert frame.plans["vg"].status == "ok" and frame.plans["svg"].status == "ok"
    assert frame.plans["dsb"].status == "reached"


def test_the_slow_lane_runs_injected_planners_in_its_worker_process(scene):
    registry = with_planners(spec("walk", "trace", straight_trace))
    view = FakeView()
    controller = planners_controller(view, scene, registry)
    try:
        assert controller.scheduler.process is not None
        assert controller.wait_idle(60)
        assert view.last.plans["walk"].status == "ok"
        assert view.last.plans["dsb"].status == "reached"
    finally:
        controller.close()


def planners_controller(view, scene, registry):
    from app.session.controller import Controller

    return Controller(view, scene, registry=registry)


# ----------------------------------------------------------------------------- enabled


def test_only_default_planners_run_until_one_is_switched_on(make_controller, scene):
    registry = with_planners(
        spec("straight", "graph", straight_graph, default=False),
        spec("walk", "trace", straight_trace, default=False),
    )
    controller, view = make_controller(scene, registry=registry)
    assert "straight" not in view.last.plans and "walk" not in view.last.plans
    assert view.last.enabled == {"vg", "svg", "dsb"}
    controller.set_planner_enabled("straight", True)
    controller.set_planner_enabled("walk", True)
    assert controller.wait_idle(10)
    assert view.last.plans["straight"].status == "ok"
    assert view.last.plans["walk"].status == "ok"
    controller.set_planner_enabled("dsb", False)
    assert controller.wait_idle(10)
    assert "dsb" not in view.last.plans and "walk" in view.last.plans
    controller.set_planner_enabled("nonsense", True)
    assert controller.wait_idle(10)
    assert "Unknown planner" in view.last.message


# ----------------------------------------------------------------------------- memo


def test_the_fast_lane_reuses_the_configuration_space_while_the_goal_moves(
    make_controller, scene
):
    controller, view = make_controller(scene)
    cspace = view.last.plans["cspace"]
    controller.edits.move_goal((8.9, 6.9))
    assert controller.wait_idle(10)
    assert view.last.scene.goal == (8.9, 6.9)
    assert view.last.plans["cspace"] is cspace  # the lane's memo answered
    controller.edits.set_robot(radius=0.2)
    assert controller.wait_idle(10)
    assert view.last.plans["cspace"] is not cspace


# ----------------------------------------------------------------------------- merging


def computed(scene, version, status="ok"):
    fast = {
        "vg": Straight("vg", np.array([scene.start, scene.goal]), status),
        "cspace": None,
    }
    return Computed(PlanKey(version, frozenset()), scene, fast, 1.0)


def test_a_slow_result_for_this_version_is_shown_as_it_is(scene):
    walk = Straight("dsb", np.array([scene.start, scene.goal]))
    merged = merge_slow(
        computed(scene, 7), SlowResults(7, scene, {"dsb": walk}), ("dsb",)
    )
    assert merged.plans["dsb"] is walk
    assert merged.lagging == frozenset() and merged.slow_version == 7


def test_an_older_slow_result_is_only_shown_marked_as_lagging(scene):
    walk = Straight("dsb", np.array([scene.start, scene.goal]))
    moved = dataclasses.replace(scene, goal=(8.5, 6.5))
    merged = merge_slow(
        computed(moved, 8), SlowResults(7, scene, {"dsb": walk}), ("dsb",)
    )
    assert merged.plans["dsb"] is walk
    assert merged.lagging == {"dsb"} and merged.slow_version == 7


def test_an_older_slow_result_that_tells_another_story_is_not_shown(scene):
    walk = Straight("dsb", np.array([scene.start, scene.goal]))
    cut_off = computed(scene, 8, status="unreachable")
    merged = merge_slow(cut_off, SlowResults(7, scene, {"dsb": walk}), ("dsb",))
    assert isinstance(merged.plans["dsb"], Pending) and not merged.lagging
    # Nor across a new scenario (other walls or another number of obstacles).
    fewer = dataclasses.replace(scene, obstacles=scene.obstacles[:1])
    merged = merge_slow(
        computed(fewer, 8), SlowResults(7, scene, {"dsb": walk}), ("dsb",)
    )
    assert isinstance(merged.plans["dsb"], Pending)


def test_an_invalid_scene_needs_no_slow_result(scene):
    invalid = computed(scene, 3, status="invalid")
    merged = merge_slow(invalid, SlowResults(), ("dsb",))
    assert merged.plans["dsb"].status == "invalid" and merged.slow_version == 3


def test_frames_never_go_back_to_an_older_slow_result(scene):
    """Slow results arrive out of step with the edits: every frame shows the newest one."""
    from app.session.controller import Controller

    gates = {k: threading.Event() for k in range(4)}
    calls: list[int] = []

    def slow(s):
        k = len(calls)
        calls.append(k)
        gates[min(k, 3)].wait(10)
        return {"dsb": Straight("dsb", np.array([s.start, s.goal]))}

    view = FakeView()
    controller = Controller(
        view,
        scene,
        plan=lambda s: {
            "vg": Straight("vg", np.array([s.start, s.goal])),
            "cspace": None,
        },
        slow_plan=slow,
        slow_names=("dsb",),
    )
    try:
        gates[0].set()
        assert controller.wait_idle(10)
        for k in range(1, 4):
            controller.edits.move_goal((9.0, 7.0 - 0.5 * k))
        for k in range(1, 4):
            gates[k].set()
        assert controller.wait_idle(10)
        shown = [f.slow_version for f in view.frames if f.slow_version >= 0]
        assert shown == sorted(shown)
        assert view.last.slow_version == view.last.version == controller.version
    finally:
        for gate in gates.values():
            gate.set()
        controller.close()
