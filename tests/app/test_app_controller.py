"""The controller with a fake view: edits, undo/redo, coalescing, bad edits, tools, files."""

from __future__ import annotations

import json
import threading
import time
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose
from shapely import LineString, Polygon

import planners
from app.session.controller import Controller, Selection, default_plan, pick
from app.session.files import ScenesFolder
from tests.app.app_helpers import SCENARIO_DIR, FakeView, wait_until


@pytest.fixture
def runners(both_lanes: Any) -> Any:
    """Every test here runs with each scheduler's own threads and with shared runners."""
    return both_lanes


def path_of(frame, name="vg"):
    return np.asarray(frame.plans[name].path).reshape(-1, 2)


def test_first_frame_has_every_planner_and_paths(make_controller, scene):
    _controller, view = make_controller(scene)
    frame = view.last
    assert frame.version == 0
    assert frame.scene == scene
    for name in planners.registry.default_planners():
        assert name in frame.plans
    assert frame.plans["vg"].status == "ok"
    assert_allclose(path_of(frame)[0], scene.start)
    assert_allclose(path_of(frame)[-1], scene.goal)
    assert frame.problems == ()
    assert not frame.can_undo and not frame.can_redo


def test_move_goal_replans_and_is_undoable(make_controller, scene):
    controller, view = make_controller(scene)
    old_length = view.last.plans["vg"].length
    controller.edits.move_goal((9.0, 1.0))
    assert controller.wait_idle(10)
    frame = view.last
    assert frame.scene.goal == (9.0, 1.0)
    assert_allclose(path_of(frame)[-1], (9.0, 1.0))
    assert frame.plans["vg"].length != pytest.approx(old_length)
    assert frame.can_undo
    controller.undo()
    assert controller.wait_idle(10)
    assert view.last.scene == scene
    assert view.last.can_redo
    controller.redo()
    assert controller.wait_idle(10)
    assert view.last.scene.goal == (9.0, 1.0)


def test_a_whole_drag_is_one_undo_step(make_controller, scene):
    controller, view = make_controller(scene)
    controller.edits.drag_handle(("goal",), scene.goal, "start")
    for k in range(20):
        controller.edits.drag_handle(
            ("goal",), (9.0 - 0.1 * k, 7.0 - 0.05 * k), "update"
        )
    controller.edits.drag_handle(("goal",), (7.0, 6.0), "end")
    assert controller.wait_idle(10)
    assert view.last.scene.goal == (7.0, 6.0)
    assert view.last.dragging == frozenset()
    controller.undo()
    assert controller.wait_idle(10)
    assert view.last.scene.goal == scene.goal  # back before the drag, in one step
    assert not view.last.can_undo


def test_two_drags_of_the_same_handle_are_two_undo_steps(make_controller, scene):
    controller, view = make_controller(scene)
    for target in ((8.0, 7.0), (7.0, 7.0)):
        controller.edits.drag_handle(("start",), scene.start, "start")
        controller.edits.drag_handle(("start",), target, "update")
        controller.edits.drag_handle(("start",), target, "end")
    controller.undo()
    assert controller.wait_idle(10)
    assert view.last.scene.start == (8.0, 7.0)


def test_new_edit_clears_redo(make_controller, scene):
    controller, view = make_controller(scene)
    controller.edits.move_goal((9.0, 1.0))
    controller.undo()
    controller.edits.move_start((1.0, 2.0))
    controller.redo()  # nothing to redo any more
    assert controller.wait_idle(10)
    assert view.last.scene.goal == scene.goal
    assert view.last.message == "Nothing to redo."


def test_vertex_and_obstacle_drags(make_controller, scene):
    controller, view = make_controller(scene)
    x, y = scene.obstacles[0].exterior.coords[2]
    controller.edits.drag_handle(("vertex", 0, 2), (x, y), "start")
    controller.edits.drag_handle(("vertex", 0, 2), (x + 0.5, y + 0.2), "update")
    controller.edits.drag_handle(("vertex", 0, 2), (x + 0.5, y + 0.2), "end")
    c = scene.obstacles[1].centroid
    controller.edits.drag_handle(("obstacle", 1), (c.x, c.y), "start")
    controller.edits.drag_handle(("obstacle", 1), (c.x + 0.2, c.y), "update")
    controller.edits.drag_handle(("obstacle", 1), (c.x + 0.5, c.y - 0.25), "update")
    controller.edits.drag_handle(("obstacle", 1), (c.x + 0.5, c.y - 0.25), "end")
    assert controller.wait_idle(10)
    new = view.last.scene
    assert new.obstacles[0].exterior.coords[2] == (x + 0.5, y + 0.2)
    moved = np.asarray(new.obstacles[1].exterior.coords) - np.asarray(
        scene.obstacles[1].exterior.coords
    )
    assert_allclose(moved, np.tile([0.5, -0.25], (len(moved), 1)), atol=1e-12)
    controller.undo()
    controller.undo()
    assert controller.wait_idle(10)
    assert view.last.scene == scene


def test_recompute_is_coalesced_latest_edit_wins(make_controller, scene):
    gate = threading.Event()
    planned: list[tuple[float, float]] = []

    def slow_plan(s):
        planned.append(s.goal)
        if len(planned) > 1:
            gate.wait(10)  # hold the worker while edits pile up
        return default_plan(s)

    controller, view = make_controller(scene, plan=slow_plan)
    controller.edits.move_goal((9.0, 6.9))  # the worker starts on this one and blocks
    time.sleep(0.2)
    for k in range(50):
        controller.edits.move_goal((9.0, 6.0 - 0.05 * k))
    gate.set()
    assert controller.wait_idle(20)
    # Planned: the first scene, the edit that blocked, then only the newest one.
    assert len(planned) == 3
    assert planned[-1] == (9.0, 6.0 - 0.05 * 49)
    assert view.last.scene.goal == planned[-1]
    assert view.last.version == controller.version
    # Every frame drawn belongs to a newer version than the previous one, and its plans
    # were computed for exactly its scene.
    versions = [f.version for f in view.frames]
    assert versions == sorted(versions)
    for frame in view.frames:
        assert_allclose(path_of(frame)[-1], frame.scene.goal)


def test_many_users_dragging_at_once_never_corrupt_the_state(make_controller, scene):
    controller, view = make_controller(scene)
    errors: list[BaseException] = []

    def user(handle, xs):
        try:
            controller.edits.drag_handle(handle, (xs[0], 1.0), "start")
            for x in xs:
                controller.edits.drag_handle(
                    handle, (x, 1.0 if handle == ("start",) else 7.0), "update"
                )
            controller.edits.drag_handle(
                handle, (xs[-1], 1.0 if handle == ("start",) else 7.0), "end"
            )
        except BaseException as error:  # pragma: no cover - reported below
            errors.append(error)

    xs = list(np.linspace(0.5, 1.5, 60))
    threads = [
        threading.Thread(target=user, args=(("start",), xs)),
        threading.Thread(target=user, args=(("goal",), [9.5 - x / 2 for x in xs])),
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert controller.wait_idle(20)
    final = view.last.scene
    assert final.start == (xs[-1], 1.0)
    assert final.goal == (9.5 - xs[-1] / 2, 7.0)
    assert view.max_concurrent == 1  # views are never drawn from two threads at once
    assert [f.version for f in view.frames] == sorted(f.version for f in view.frames)


# ----------------------------------------------------------------------------- bad edits


def test_self_intersecting_drag_is_reported_and_kept_and_undoable(
    make_controller, scene
):
    controller, view = make_controller(scene)
    # Obstacle 1 is the rectangle (2,2) (4,2) (4,5.5) (2,5.5): pull vertex 1 past vertex 2.
    controller.edits.drag_handle(("vertex", 0, 1), (4.0, 2.0), "start")
    controller.edits.drag_handle(("vertex", 0, 1), (3.0, 7.0), "update")
    assert controller.wait_idle(10)
    frame = view.last
    assert any("obstacle 1" in p and "intersects itself" in p for p in frame.problems)
    for name in planners.registry.default_planners():
        assert frame.plans[name].status == "invalid"
        assert len(path_of(frame, name)) == 0  # no stale path
    # Nothing is lost: the vertex is where the user dragged it, and they can drag back.
    assert frame.scene.obstacles[0].exterior.coords[1] == (3.0, 7.0)
    controller.edits.drag_handle(("vertex", 0, 1), (4.0, 2.0), "update")
    controller.edits.drag_handle(("vertex", 0, 1), (4.0, 2.0), "end")
    assert controller.wait_idle(10)
    assert view.last.problems == ()
    assert view.last.plans["vg"].status == "ok"


def test_start_dragged_into_an_obstacle(make_controller, scene):
    controller, view = make_controller(scene)
    controller.edits.drag_handle(("start",), scene.start, "start")
    controller.edits.drag_handle(("start",), (3.0, 3.0), "update")
    controller.edits.drag_handle(("start",), (3.0, 3.0), "end")
    assert controller.wait_idle(10)
    frame = view.last
    assert any("start" in p and "inside obstacle 1" in p for p in frame.problems)
    for name in planners.registry.default_planners():
        assert frame.plans[name].status == "invalid"
        assert len(path_of(frame, name)) == 0


def test_goal_cut_off_by_merged_obstacles(make_controller):
    enclosed = planners.load_scene(SCENARIO_DIR / "07_goal_enclosed.json")
    _controller, view = make_controller(enclosed)
    frame = view.last
    assert frame.plans["vg"].status == "unreachable"
    assert len(path_of(frame)) == 0
    assert any("enclosed" in p for p in frame.problems)


@pytest.mark.parametrize(
    ("action", "words"),
    [
        (
            lambda c: c.edits.add_obstacle([(1, 1), (2, 2), (2, 1), (1, 2)]),
            "intersects itself",
        ),
        (lambda c: c.edits.delete_vertex(1, 0), "only 3 vertices"),
        (lambda c: c.edits.set_robot(radius=-1.0), "radius"),
        (lambda c: c.edits.set_sensor_range(0.0), "sensor range"),
        (lambda c: c.edits.set_expansion("circle"), "expansion"),
        (lambda c: c.edits.delete_obstacle(7), "index"),
    ],
)
def test_refused_edits_leave_the_scene_and_say_why(
    make_controller, scene, action, words
):
    controller, view = make_controller(scene)
    action(controller)
    assert controller.wait_idle(10)
    assert view.last.scene == scene
    assert view.last.message is not None
    assert words in view.last.message.lower()
    assert not view.last.can_undo


def test_a_planner_that_raises_does_not_stop_the_others(make_controller, scene):
    def broken(cspace, scene, options):
        raise RuntimeError("boom")

    spec = planners.PlannerSpec("broken", "Broken", "trace", broken, "")
    registry = {**planners.REGISTRY, "broken": spec}
    controller, view = make_controller(scene, registry=registry)
    frame = view.last
    assert frame.plans["vg"].status == "ok"
    assert frame.plans["broken"].status == "error"
    assert len(path_of(frame, "broken")) == 0
    assert any("boom" in p for p in frame.problems)
    controller.edits.move_goal((9.0, 1.0))  # and the app keeps working
    assert controller.wait_idle(10)
    assert view.last.plans["vg"].status == "ok"


def test_a_view_that_raises_does_not_kill_the_worker(make_controller, scene):
    controller, view = make_controller(scene)
    original = view.render
    calls = {"n": 0}

    def flaky(frame):
        calls["n"] += 1
        if calls["n"] == 1:
            raise RuntimeError("view broke")
        original(frame)

    view.render = flaky  # type: ignore[method-assign]
    controller.edits.move_goal((9.0, 1.0))
    assert controller.wait_idle(10)
    controller.edits.move_goal((9.0, 2.0))
    assert controller.wait_idle(10)
    assert view.last.scene.goal == (9.0, 2.0)


# ----------------------------------------------------------------------------- settings


def test_robot_expansion_and_sensor_settings_replan(make_controller, scene):
    controller, view = make_controller(scene)
    disk_cspace = view.last.plans["cspace"]
    controller.edits.set_expansion("square")
    assert controller.wait_idle(10)
    square = view.last.plans["cspace"]
    assert view.last.scene.expansion == "square"
    assert (
        square.merged.area > disk_cspace.merged.area
    )  # the square model is conservative
    controller.edits.set_robot(radius=0.1)
    controller.edits.set_robot(kind="differential")
    controller.edits.set_sensor_range(3.5)
    assert controller.wait_idle(10)
    s = view.last.scene
    assert (s.robot.radius, s.robot.kind, s.sensor_range) == (0.1, "differential", 3.5)


def test_slider_steps_merge_into_one_undo_step(make_controller, scene):
    controller, view = make_controller(scene)
    for r in (0.31, 0.32, 0.33, 0.34):
        controller.edits.set_robot(radius=r)
    controller.undo()
    assert controller.wait_idle(10)
    assert view.last.scene.robot.radius == scene.robot.radius


def test_other_expansion_layer(make_controller, scene):
    controller, view = make_controller(scene)
    assert view.last.other_expanded is None
    controller.set_layer("other_expansion", True)
    assert controller.wait_idle(10)
    other = view.last.other_expanded
    assert other is not None and len(other) == len(scene.obstacles)
    # The square model's outline of the rectangle is its bounding box grown by r.
    r = scene.robot.radius
    assert_allclose(other[0].bounds, (2 - r, 2 - r, 4 + r, 5.5 + r), atol=1e-9)


# ----------------------------------------------------------------------------- tools


def test_block_tool_adds_an_obstacle_the_planners_avoid(make_controller, scene):
    controller, view = make_controller(scene)
    path = path_of(view.last)
    mid = path[len(path) // 2] if len(path) > 2 else (path[0] + path[-1]) / 2
    controller.tools.set_tool("block")
    controller.tools.click_floor(mid)
    assert controller.wait_idle(10)
    frame = view.last
    assert len(frame.scene.obstacles) == len(scene.obstacles) + 1
    block = frame.scene.obstacles[-1]
    assert_allclose(
        block.bounds, (mid[0] - 0.5, mid[1] - 0.5, mid[0] + 0.5, mid[1] + 0.5)
    )
    new_path = path_of(frame)
    assert frame.plans["vg"].status == "ok"
    grown = block.buffer(scene.robot.radius * 0.99)
    assert not LineString(new_path).crosses(grown.buffer(-1e-6))
    assert not LineString(new_path).within(grown)
    assert frame.plans["vg"].length > view.frames[0].plans["vg"].length


def test_polygon_tool_closes_on_first_corner(make_controller, scene):
    controller, view = make_controller(scene)
    controller.tools.set_tool("polygon")
    for xy in ((6.0, 6.0), (7.0, 6.0), (7.0, 7.0)):
        controller.tools.click_floor(xy)
    assert controller.wait_idle(10)
    assert view.last.draft == ((6.0, 6.0), (7.0, 6.0), (7.0, 7.0))
    controller.tools.click_floor((6.05, 6.02))  # near the first corner: close
    assert controller.wait_idle(10)
    assert view.last.draft == ()
    assert list(view.last.scene.obstacles[-1].exterior.coords)[:3] == [
        (6.0, 6.0),
        (7.0, 6.0),
        (7.0, 7.0),
    ]


def test_finish_with_too_few_corners_says_so(make_controller, scene):
    controller, view = make_controller(scene)
    controller.tools.set_tool("polygon")
    controller.tools.click_floor((6.0, 6.0))
    controller.tools.finish_polygon()
    assert controller.wait_idle(10)
    assert "3 corners" in view.last.message
    assert view.last.scene == scene


def test_select_then_delete_and_insert(make_controller, scene):
    controller, view = make_controller(scene)
    controller.tools.set_tool("edit")
    controller.tools.click_floor((4.05, 5.45))  # near vertex 3 of obstacle 1
    assert controller.wait_idle(10)
    assert view.last.selection == Selection(0, vertex=2)
    controller.tools.insert_vertex_at_selection()
    assert controller.wait_idle(10)
    assert len(view.last.scene.obstacles[0].exterior.coords) - 1 == 5
    controller.tools.click_floor((3.0, 2.05))  # near edge 1 of obstacle 1
    controller.tools.delete_selected_obstacle()
    assert controller.wait_idle(10)
    assert len(view.last.scene.obstacles) == 1
    controller.undo()
    controller.undo()
    assert controller.wait_idle(10)
    assert view.last.scene == scene


def test_pick_prefers_vertex_then_edge_then_inside():
    s = planners.Scene(
        obstacles=(Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),),
        start=(5, 5),
        goal=(6, 6),
    )
    assert pick(s, (0.1, 0.1)) == Selection(0, vertex=0)
    assert pick(s, (1.0, 2.1)) == Selection(0, edge=2)
    assert pick(s, (1.0, 1.0)) == Selection(0)
    assert pick(s, (5.0, 5.0)) is None


# ----------------------------------------------------------------------------- files


def test_load_scenario_and_undo_the_switch(make_controller, scene):
    controller, view = make_controller(scene, scenario="01_two_convex")
    controller.files.load_scenario("06_four_obstacles_sensor")
    assert controller.wait_idle(10)
    assert view.last.scenario == "06_four_obstacles_sensor"
    assert len(view.last.scene.obstacles) == 4
    controller.undo()
    assert controller.wait_idle(10)
    assert view.last.scene == scene
    assert view.last.scenario == "01_two_convex"


def test_bad_files_keep_the_scene(make_controller, scene, tmp_path):
    folder = ScenesFolder(tmp_path)
    controller, view = make_controller(scene, folder=folder)
    controller.files.load_from_folder("missing")
    assert controller.wait_idle(10)
    assert "cannot read" in view.last.message and view.last.scene == scene
    bad = tmp_path / "bad.json"
    bad.write_text(
        json.dumps(
            {
                "format": 1,
                "obstacles": [[[0, 0], [1, 1], [1, 0], [0, 1]]],
                "start": [5, 5],
                "goal": [6, 6],
            }
        )
    )
    controller.files.load_from_folder("bad.json")
    assert controller.wait_idle(10)
    assert "obstacles[0]" in view.last.message and view.last.scene == scene
    controller.files.load_text("{not json", "upload.json")
    assert controller.wait_idle(10)
    assert "not valid JSON" in view.last.message and view.last.scene == scene


def test_save_and_load_round_trip(make_controller, scene, tmp_path):
    controller, view = make_controller(scene, folder=ScenesFolder(tmp_path))
    controller.edits.move_goal((8.5, 6.5))
    controller.files.save_to_folder("mine")
    assert controller.wait_idle(10)
    saved = tmp_path / "mine.json"
    assert "Saved mine.json" in view.last.message and saved.is_file()
    controller.edits.move_goal((1.0, 7.0))
    controller.files.load_from_folder("mine")
    assert controller.wait_idle(10)
    assert view.last.scene.goal == (8.5, 6.5)
    # The download is the same scene, for the browser.
    name, data = controller.files.download()
    assert name == "Two_convex_obstacles.json"
    assert planners.scene.scene_from_text(data) == view.last.scene
    # An invalid scene is refused and the file on disk is untouched.
    controller.edits.drag_handle(("vertex", 0, 1), (3.0, 7.0), "update")
    controller.files.save_to_folder("mine.json")
    assert controller.wait_idle(10)
    assert "Not saved" in view.last.message
    assert planners.load_scene(saved).goal == (8.5, 6.5)
    assert controller.files.download() is None
    assert controller.wait_idle(10)
    assert "Not downloaded" in view.last.message


# ----------------------------------------------------------------------------- robot


def test_robot_time_and_playback(make_controller, scene):
    from app.session import robot

    controller, view = make_controller(
        scene, trajectory=robot.trajectory, sample=robot.sample
    )
    trajectory = view.last.trajectory
    assert trajectory is not None and trajectory.duration > 1.0
    controller.playback.set_robot_time(2.0)
    assert controller.wait_idle(10)
    pose = view.poses[-1]
    assert pose is not None and pose.t == 2.0 and not pose.playing
    expected, angles = trajectory.sample(2.0)
    assert_allclose(pose.xy, expected[:2])
    assert_allclose(pose.wheel_angles, angles)
    controller.playback.set_robot_time(1e9)  # clamped to the end
    assert controller.wait_idle(10)
    assert view.poses[-1].t == pytest.approx(trajectory.duration)
    controller.playback.set_speed(4.0)
    controller.playback.restart()
    time.sleep(0.5)
    t, playing, speed = controller.playback.state
    assert playing and 0.5 < t < 4.0 and speed == 4.0
    controller.playback.pause()
    t_paused = controller.playback.state[0]
    time.sleep(0.2)
    assert controller.playback.state[0] == t_paused


def test_follow_choice_changes_the_trajectory(make_controller):
    from app.session import robot

    s = planners.load_scene(SCENARIO_DIR / "04_convex_nonconvex_b.json")
    controller, view = make_controller(
        s, trajectory=robot.trajectory, sample=robot.sample
    )
    first = view.last.trajectory
    controller.playback.set_follow("svg")
    assert controller.wait_idle(10)
    assert view.last.follow == "svg"
    assert view.last.trajectory is not first
    assert_allclose(view.last.trajectory.path[-1], s.goal)


def test_an_edit_that_keeps_the_path_keeps_the_trajectory(make_controller, scene):
    from app.session import robot

    controller, view = make_controller(
        scene, trajectory=robot.trajectory, sample=robot.sample
    )
    first = view.last.trajectory
    # A block in the bottom-right corner, far from the path, then one of its corners
    # dragged: VG's path is the same, so is the robot's trajectory (and its place in it).
    controller.edits.add_obstacle([(8.6, 0.6), (9.3, 0.6), (9.3, 1.1), (8.6, 1.1)])
    assert controller.wait_idle(10)
    assert len(view.last.scene.obstacles) == len(scene.obstacles) + 1
    assert view.last.trajectory is first
    controller.edits.drag_handle(
        ("vertex", len(scene.obstacles), 0), (8.5, 0.5), "start"
    )
    controller.edits.drag_handle(("vertex", len(scene.obstacles), 0), (8.4, 0.5), "end")
    assert controller.wait_idle(10)
    assert view.last.trajectory is first
    # The goal moved: a new path, a new trajectory.
    controller.edits.move_goal((8.8, 6.2))
    assert controller.wait_idle(10)
    assert view.last.trajectory is not first
    assert_allclose(view.last.trajectory.path[-1], (8.8, 6.2))


def test_the_paths_are_drawn_before_the_robot_trajectory_is_planned(
    make_controller, scene
):
    from app.session import robot

    planning = threading.Event()
    release = threading.Event()

    def slow_trajectory(s, path):
        if planning.is_set():
            release.wait(10)
        return robot.trajectory(s, path)

    controller, view = make_controller(
        scene, trajectory=slow_trajectory, sample=robot.sample
    )
    try:
        first = view.last.trajectory
        planning.set()
        controller.edits.move_goal((8.8, 6.2))
        # The new paths are drawn while the trajectory is still being planned; the robot
        # stays on its previous trajectory meanwhile.
        assert wait_until(lambda: view.last.version == controller.version)
        assert view.last.scene.goal == (8.8, 6.2)
        assert view.last.plans["vg"].path[-1].tolist() == [8.8, 6.2]
        assert view.last.trajectory is first
        release.set()
        assert controller.wait_idle(10)
        assert view.last.trajectory is not first
        assert_allclose(view.last.trajectory.path[-1], (8.8, 6.2))
    finally:
        release.set()


_GOAL_A, _GOAL_B = (8.8, 6.2), (8.6, 6.0)


def _goal_b_while_goal_a_is_drawn(make_controller, scene, robot_lag_s):
    """Move the goal to A; the edit to B arrives while A's layers are drawn.

    Returns the controller, its view and the goals the robot's trajectories were
    planned for, in order.
    """
    from app.session import robot

    planned: list[tuple[float, float]] = []

    def trajectory(s, path):
        planned.append((float(path[-1][0]), float(path[-1][1])))
        return robot.trajectory(s, path)

    controller, view = make_controller(
        scene, trajectory=trajectory, sample=robot.sample
    )

    class NextEditWhileDrawing:
        def render(self, frame):
            if frame.scene.goal == _GOAL_A and controller.scene.goal == _GOAL_A:
                controller.edits.move_goal(_GOAL_B)

        def render_robot(self, pose):
            pass

    controller.add_view(NextEditWhileDrawing())
    controller.scheduler.robot_lag_s = robot_lag_s
    planned.clear()
    controller.edits.move_goal(_GOAL_A)
    assert controller.wait_idle(10)
    return controller, view, planned


def test_a_newer_edit_comes_before_the_robot_of_the_one_it_overtakes(
    make_controller, scene
):
    """While a drag goes on, the planners' layers of each edit are drawn, and the robot's
    trajectory is planned only for an edit no newer one has overtaken (the
    next edit's layers do not wait for a trajectory nobody will see)."""
    # The robot was just drawn: it may wait (robot_lag_s long).
    controller, view, planned = _goal_b_while_goal_a_is_drawn(
        make_controller, scene, robot_lag_s=60.0
    )
    # The layers of A were drawn (its path ends there), its robot never planned.
    drawn_a = [f for f in view.frames if f.scene.goal == _GOAL_A]
    assert drawn_a and drawn_a[0].plans["vg"].path[-1].tolist() == list(_GOAL_A)
    assert planned == [_GOAL_B]
    last = view.last
    assert last.scene.goal == _GOAL_B and last.version == controller.version
    assert_allclose(last.trajectory.path[-1], _GOAL_B)
    assert view.poses[-1] is not None


def test_in_a_long_drag_the_robot_follows_at_least_every_robot_lag(
    make_controller, scene
):
    """With no slack (robot_lag_s 0), an overtaken edit's robot is planned as before."""
    _, _, planned = _goal_b_while_goal_a_is_drawn(make_controller, scene, 0.0)
    assert planned == [_GOAL_A, _GOAL_B]


def test_close_stops_the_threads(scene):
    from app.session import robot

    controller = Controller(
        FakeView(), scene, trajectory=robot.trajectory, sample=robot.sample
    )
    assert controller.wait_idle(10)
    controller.playback.play()  # the robot moves: its ticker's thread runs
    assert controller.playback.alive
    ticker = controller.playback._ticker
    controller.close()
    assert not controller.scheduler.alive
    assert not controller.playback.alive and not ticker.alive
