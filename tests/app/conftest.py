"""Fixtures for the app tests: controllers with a fake view that always stop, a scene."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

import planners
from app.session.controller import Controller
from app.session.pool import Runner
from tests.app.app_helpers import SCENARIO_DIR, FakeView


@pytest.fixture
def scene() -> planners.Scene:
    return planners.load_scene(SCENARIO_DIR / "01_two_convex.json")


@pytest.fixture
def runners() -> tuple[Runner, Runner] | None:
    """Where the controllers' schedulers run: None, threads of their own.

    A module overrides it with :func:`both_lanes` to run its tests both ways.
    """
    return None


@pytest.fixture(params=["own threads", "shared runners"])
def both_lanes(
    request: pytest.FixtureRequest,
) -> Iterator[tuple[Runner, Runner] | None]:
    """Threads of each scheduler's own, then runners shared as a classroom's copies do."""
    if request.param == "own threads":
        yield None
        return
    shared = (Runner(1, name="test-rounds"), Runner(2, name="test-slow"))
    yield shared
    for runner in shared:
        runner.close()


@pytest.fixture
def make_controller(
    runners: tuple[Runner, Runner] | None,
) -> Iterator[Callable[..., tuple[Controller, FakeView]]]:
    made: list[Controller] = []

    def make(scene: planners.Scene, **kwargs: Any) -> tuple[Controller, FakeView]:
        view = FakeView()
        kwargs.setdefault(
            "scenarios", {p.stem: p for p in sorted(SCENARIO_DIR.glob("*.json"))}
        )
        # Slow planners in a thread: a worker process per test costs a second to spawn;
        # the process lane has its own tests (test_app_dsb.py).
        kwargs.setdefault("slow_process", False)
        kwargs.setdefault("runners", runners)
        controller = Controller(view, scene, **kwargs)
        made.append(controller)
        assert controller.wait_idle(20), "first frame not drawn"
        return controller, view

    yield make
    for controller in made:
        controller.close()
