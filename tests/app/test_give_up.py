"""A big scene's slow planner in its worker: given up for a newer edit only once it has
run :data:`app.session.scheduler.GIVE_UP_AFTER_S`.

During a drag on a map the slow answers take a few tenths of a second: stopping the
worker for every edit would restart it (and empty its memo) and no answer would ever
arrive. A long computation is still given up, by a timer if no other edit comes.
The slow planner here sleeps ``scene.sensor_range`` seconds in the worker process.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

import planners
from app.session.big import BIG_SCENE_VERTICES, scene_vertices
from app.session.controller import Controller
from app.session.scheduler import GIVE_UP_AFTER_S
from planners.api import InvalidResult
from planners.registry import REGISTRY, PlannerSpec
from tests.app.app_helpers import FakeView, wait_until


def sleepy(cspace: Any, scene: planners.Scene, options: Any) -> Any:
    """A slow planner: sleeps ``scene.sensor_range`` seconds (in the worker)."""
    time.sleep(scene.sensor_range)
    return InvalidResult("sleepy", f"slept for the scene with its goal at {scene.goal}")


REG = {
    "vg": REGISTRY["vg"],
    "sleepy": PlannerSpec("sleepy", "Sleepy", "trace", sleepy, ""),
}


def _big_scene(sleep: float) -> planners.Scene:
    u = np.linspace(0.0, 2.0 * np.pi, BIG_SCENE_VERTICES + 200, endpoint=False)
    circle = np.column_stack([5.0 + 2.0 * np.cos(u), 5.0 + 2.0 * np.sin(u)])
    scene = planners.load_scene(
        {
            "format": 1,
            "obstacles": [circle.tolist()],
            "start": [1.0, 1.0],
            "goal": [9.0, 9.0],
            "sensor_range": sleep,
        }
    )
    assert scene_vertices(scene) > BIG_SCENE_VERTICES
    return scene


@pytest.fixture
def controller():
    view = FakeView()
    made = Controller(view, _big_scene(0.3), registry=REG, slow_process=True)
    made.view = view  # type: ignore[attr-defined]
    assert made.wait_idle(60)
    yield made
    made.close()


def _slow_versions(view: FakeView) -> set[int]:
    return {f.slow_version for f in list(view.frames)}


def test_short_slow_calls_are_not_given_up_during_a_drag(controller):
    worker = controller._scheduler.process
    first = worker.pid
    assert GIVE_UP_AFTER_S > 0.3
    controller.edits.drag_handle(("goal",), (9.0, 9.0), "start")
    for k in range(10):  # 0.5 s of edits, each a call of 0.3 s would be stale
        controller.edits.drag_handle(("goal",), (9.0, 9.0 - 0.1 * (k + 1)), "update")
        time.sleep(0.05)
    controller.edits.drag_handle(("goal",), (9.0, 8.0), "end")
    assert controller.wait_idle(60)
    assert worker.pid == first  # never stopped: its answers kept coming
    final = controller.frame
    assert final.slow_version == final.version and "sleepy" not in final.lagging
    assert str(final.scene.goal) in final.plans["sleepy"].reason


def test_a_long_slow_call_is_given_up_even_without_another_edit(controller):
    worker = controller._scheduler.process
    controller.edits.set_sensor_range(600.0)  # a call that would take ten minutes
    long_call = controller.version
    assert wait_until(lambda: controller._scheduler._slow_busy, 30)
    first = worker.pid
    controller.edits.set_sensor_range(0.2)  # one edit, then nothing
    assert controller.wait_idle(60)  # long before the ten minutes
    assert worker.pid != first  # the worker was stopped and a fresh one answered
    final = controller.frame
    assert final.slow_version == final.version == long_call + 1
    assert long_call not in _slow_versions(controller.view)
