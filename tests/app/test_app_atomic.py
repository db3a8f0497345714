"""Every multi-step action is atomic: browsers editing at once never lose or double an edit.

A read-decide-edit step (finishing a polygon, a click that closes it, deleting the
selection) runs in one critical section of the session, so no other browser's edit can
come between the read and the edit.
"""

from __future__ import annotations

import math
import threading

import planners
from tests.app.app_helpers import SCENARIO_DIR


def run_together(*actions, repeat: int = 1) -> None:
    """Start every action on its own thread at the same moment; re-raise any error."""
    barrier = threading.Barrier(len(actions))
    errors: list[BaseException] = []

    def run(action):
        try:
            barrier.wait()
            for _ in range(repeat):
                action()
        except BaseException as error:  # pragma: no cover - reported below
            errors.append(error)

    threads = [threading.Thread(target=run, args=(a,)) for a in actions]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert not errors, errors


def ring(n: int, centre=(5.0, 4.0), radius=3.5) -> list[tuple[float, float]]:
    """Points on a circle in angular order: any run of 3 or more is a convex polygon."""
    return [
        (
            centre[0] + radius * math.cos(2 * math.pi * k / n),
            centre[1] + radius * math.sin(2 * math.pi * k / n),
        )
        for k in range(n)
    ]


def n_vertices(polygon) -> int:
    return len(polygon.exterior.coords) - 1


def test_browsers_finishing_one_polygon_at_once_add_it_once(make_controller):
    scene = planners.load_scene(SCENARIO_DIR / "01_two_convex.json")
    controller, view = make_controller(scene)
    controller.tools.set_tool("polygon")
    for round_ in range(6):
        for xy in ring(24)[4 * round_ : 4 * round_ + 3]:
            controller.tools.click_floor(xy)
        run_together(*[controller.tools.finish_polygon] * 4)
        assert len(controller.scene.obstacles) == len(scene.obstacles) + round_ + 1
    assert controller.wait_idle(10)
    assert view.last.draft == ()
    # One undo step per polygon, none doubled.
    for _ in range(6):
        controller.undo()
    assert controller.wait_idle(10)
    assert view.last.scene == scene


def test_corners_clicked_while_another_browser_finishes_are_never_lost(
    make_controller,
):
    scene = planners.load_scene(SCENARIO_DIR / "01_two_convex.json")
    controller, view = make_controller(scene)
    controller.tools.set_tool("polygon")
    corners = ring(60)
    clicks = iter(corners)
    run_together(
        lambda: controller.tools.click_floor(next(clicks)),
        controller.tools.finish_polygon,
        repeat=len(corners),
    )
    assert controller.wait_idle(10)
    final = view.last
    added = final.scene.obstacles[len(scene.obstacles) :]
    # Every corner is in an obstacle or still in the draft: a finish never dropped a
    # corner clicked between its reading the draft and its clearing it.
    assert sum(n_vertices(p) for p in added) + len(final.draft) == len(corners)
    assert all(p.is_valid for p in added)


def test_adding_and_deleting_at_once_never_loses_an_edit(make_controller):
    scene = planners.load_scene(SCENARIO_DIR / "01_two_convex.json")
    controller, _view = make_controller(scene)
    n = 40

    xs = iter(range(n))

    def add_block():
        x = 0.5 + 0.2 * next(xs)
        controller.edits.add_obstacle([(x, 7.0), (x + 0.1, 7.0), (x + 0.1, 7.1)])

    controller.tools.set_tool("block")
    spots = iter(ring(n, centre=(5.0, 4.0), radius=1.0))
    run_together(
        add_block,
        lambda: controller.tools.click_floor(next(spots)),
        lambda: controller.edits.set_sensor_range(1.5),
        repeat=n,
    )
    assert controller.wait_idle(20)
    assert len(controller.scene.obstacles) == len(scene.obstacles) + 2 * n
    # Each add is one undo step; undoing them all gives back the first scene's obstacles.
    for _ in range(2 * n + 1):
        controller.undo()
    assert controller.wait_idle(20)
    assert controller.scene.obstacles == scene.obstacles


def test_deleting_the_selection_from_two_browsers_deletes_one_obstacle(
    make_controller,
):
    scene = planners.load_scene(SCENARIO_DIR / "06_four_obstacles_sensor.json")
    controller, view = make_controller(scene)
    controller.tools.set_tool("edit")
    centre = scene.obstacles[0].representative_point()
    controller.tools.click_floor((centre.x, centre.y))
    run_together(*[controller.tools.delete_selected_obstacle] * 3)
    assert controller.wait_idle(10)
    # The first delete clears the selection in the same step: the others find nothing
    # selected instead of deleting whatever obstacle 1 has become.
    assert len(view.last.scene.obstacles) == len(scene.obstacles) - 1
    assert view.last.scene.obstacles == scene.obstacles[1:]
    assert "Select an obstacle first" in view.last.message
