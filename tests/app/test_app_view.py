"""The view: pure drawing helpers as arrays, then the real view on a viser server (no browser)."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from shapely import Polygon

import planners
from app.session import robot
from app.session.controller import LAYERS, Controller, Frame, Pending, RobotPose
from app.ui.floor_text import floor_font
from app.ui.labels import label_size
from app.ui.panels import (
    floor_point,
    legend_html,
    results_markdown,
    status_markdown,
    wheel_rate_plot_data,
)
from app.ui.scoped import ScopedTarget
from app.ui.style import planner_look
from app.ui.view import (
    PlannerView,
    circle_segments,
    event_labels,
    floor_bounds,
    path_to_segments,
    polygon_to_mesh,
    prism_mesh,
    rings_to_segments,
    wall_mesh,
    yaw_quaternion,
)
from planners.bug.tangent_bug import BugEvent
from tests.app.app_helpers import SCENARIO_DIR, shown_mesh, view_and_controller

L_SHAPE = Polygon([(0, 0), (3, 0), (3, 1), (1, 1), (1, 3), (0, 3)])
WITH_HOLE = Polygon(
    [(0, 0), (4, 0), (4, 4), (0, 4)], [[(1, 1), (3, 1), (3, 3), (1, 3)]]
)


def mesh_area(vertices: np.ndarray, faces: np.ndarray) -> float:
    a, b, c = (vertices[faces[:, k], :2] for k in range(3))
    return float(
        np.sum(0.5 * ((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]))
    )


def test_path_to_segments_chains_the_points():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [2.0, 3.0]])
    segments = path_to_segments(path, 0.1)
    assert segments.shape == (3, 2, 3)
    assert_allclose(
        segments[:-1, 1], segments[1:, 0]
    )  # each segment starts where the last ended
    assert_allclose(segments[0, 0, :2], path[0])
    assert_allclose(segments[-1, 1, :2], path[-1])
    assert path_to_segments(np.zeros((1, 2))).shape == (0, 2, 3)
    assert path_to_segments(np.zeros((0, 2))).shape == (0, 2, 3)


def test_rings_to_segments_includes_holes_and_invalid_rings():
    assert rings_to_segments([WITH_HOLE]).shape == (8, 2, 3)
    assert rings_to_segments([WITH_HOLE], holes=False).shape == (4, 2, 3)
    bowtie = Polygon([(0, 0), (1, 1), (1, 0), (0, 1)])
    assert rings_to_segments([bowtie]).shape == (4, 2, 3)  # drawn as given


@pytest.mark.parametrize(
    "polygon", [L_SHAPE, WITH_HOLE, Polygon([(0, 0), (2, 0), (1, 1.5)])]
)
def test_polygon_to_mesh_covers_the_polygon_with_upward_triangles(polygon):
    vertices, faces = polygon_to_mesh(polygon, 0.05)
    assert vertices.shape[1] == 3 and faces.shape[1] == 3
    assert faces.max() < len(vertices)
    assert_allclose(vertices[:, 2], 0.05)
    a, b, c = (vertices[faces[:, k], :2] for k in range(3))
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    assert np.all(cross > 0)  # counter-clockwise from above: normals point up
    assert mesh_area(vertices, faces) == pytest.approx(polygon.area)
    # Every triangle lies inside the polygon (the hole stays open).
    centroids = (a + b + c) / 3
    assert shapely.contains_xy(polygon, centroids[:, 0], centroids[:, 1]).all()


def test_polygon_to_mesh_of_a_self_intersecting_polygon_does_not_fail():
    bowtie = Polygon([(0, 0), (2, 2), (2, 0), (0, 2)])
    vertices, faces = polygon_to_mesh(bowtie)
    assert mesh_area(vertices, faces) == pytest.approx(shapely.make_valid(bowtie).area)
    assert polygon_to_mesh([])[1].shape == (0, 3)


def test_prism_mesh_has_a_top_and_outward_walls():
    vertices, faces = prism_mesh([L_SHAPE], 0.4)
    assert set(np.round(vertices[:, 2], 9)) == {0.0, 0.4}
    top = faces[np.all(np.isclose(vertices[faces][:, :, 2], 0.4), axis=1)]
    assert mesh_area(vertices, top) == pytest.approx(L_SHAPE.area)
    n_edges = len(L_SHAPE.exterior.coords) - 1
    assert len(faces) == len(top) + 2 * n_edges
    # Wall normals point away from the polygon: a point just outside along the normal.
    sides = faces[~np.all(np.isclose(vertices[faces][:, :, 2], 0.4), axis=1)]
    tri = vertices[sides]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    mid = tri.mean(axis=1)
    probe = mid[:, :2] + 1e-3 * normal[:, :2] / np.linalg.norm(
        normal[:, :2], axis=1, keepdims=True
    )
    assert not shapely.contains_xy(L_SHAPE, probe[:, 0], probe[:, 1]).any()


def test_wall_mesh_rings_the_boundary():
    boundary = Polygon([(0, 0), (10, 0), (10, 8), (0, 8)])
    vertices, faces = wall_mesh(boundary, thickness=0.1, height=0.3)
    top = faces[np.all(np.isclose(vertices[faces][:, :, 2], 0.3), axis=1)]
    assert mesh_area(vertices, top) == pytest.approx(10.2 * 8.2 - 80)
    assert wall_mesh(None)[1].shape == (0, 3)


def test_circle_and_yaw():
    s = circle_segments((2, -1), 1.5, z=0.1, n=12)
    assert s.shape == (12, 2, 3)
    assert_allclose(np.hypot(s[..., 0] - 2, s[..., 1] + 1), 1.5)
    w, x, y, z = yaw_quaternion(math.pi / 2)
    assert_allclose((w, x, y, z), (math.sqrt(0.5), 0, 0, math.sqrt(0.5)))


def test_event_labels_read_the_trace_events():
    class Trace:
        events = (
            BugEvent("hit", (1.0, 2.0), "H1", 1, 0.0),
            BugEvent("local_min", (2.0, 2.0), "M2", 2, 1.0),
        )

    assert event_labels(Trace()) == [("H1", (1.0, 2.0)), ("M2", (2.0, 2.0))]
    assert event_labels(None) == []


def test_panel_helpers():
    assert floor_point((1.0, 2.0, 5.0), (0.6, 0.0, -0.8)) == pytest.approx((4.75, 2.0))
    assert floor_point((0.0, 0.0, 5.0), (0.0, 0.0, 1.0)) is None
    table = results_markdown({"vg": Pending("vg"), "cspace": None})
    assert "| VG | **computing** | - |" in table
    traj = robot.trajectory(
        planners.load_scene(SCENARIO_DIR / "01_two_convex.json"),
        [[1, 1], [4, 1], [4, 4]],
    )
    data = wheel_rate_plot_data(traj, max_points=50)
    assert data is not None and len(data) == 1 + 3 and len(data[0]) <= 51
    assert data[0][-1] == pytest.approx(traj.duration)


# ----------------------------------------------------------------------------- real view


@pytest.fixture(scope="module")
def server() -> Iterator[Any]:
    import viser

    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


@pytest.fixture
def drawn(server) -> Iterator[tuple[PlannerView, Controller]]:
    server.scene.reset()
    scene = planners.load_scene(SCENARIO_DIR / "04_convex_nonconvex_b.json")
    view, controller = view_and_controller(server, scene)
    assert controller.wait_idle(20)
    yield view, controller
    controller.close()


def test_view_layers_hold_exactly_what_was_planned(drawn):
    view, controller = drawn
    frame = controller.frame
    vg, svg = frame.plans["vg"], frame.plans["svg"]
    assert_allclose(
        view.graphs["vg"].path.handle.points[:, :, :2],
        path_to_segments(vg.path)[:, :, :2],
        atol=1e-5,
    )
    assert_allclose(
        view.graphs["svg"].path.handle.points[:, :, :2],
        path_to_segments(svg.path)[:, :, :2],
        atol=1e-5,
    )
    assert len(view.graphs["vg"].edges.points()) == vg.graph.number_of_edges()
    assert len(view.graphs["svg"].edges.points()) == svg.graph.number_of_edges()
    assert view.graphs["vg"].edges.visible and view.obstacles.shown()
    vertices, faces = shown_mesh(view.obstacles)
    top = faces[np.all(np.isclose(vertices[faces][:, :, 2], 0.4, atol=1e-6), axis=1)]
    assert mesh_area(vertices, top) == pytest.approx(
        sum(o.area for o in frame.scene.obstacles), rel=1e-5
    )
    # Start and goal handles sit on the scene's points; labels name the obstacles.
    assert_allclose(view.gizmos.handles["start"].position[:2], frame.scene.start)
    assert_allclose(view.gizmos.handles["goal"].position[:2], frame.scene.goal)
    labels = [h.text for h in view.obstacle_labels.handles if h.visible]
    assert labels == [str(i + 1) for i in range(len(frame.scene.obstacles))]


def test_view_follows_edits_and_hides_what_has_no_path(drawn):
    view, controller = drawn
    n_vertices = sum(len(o.exterior.coords) - 1 for o in controller.scene.obstacles)
    assert not any(h.visible for h in view.gizmos.vertex_handles)
    controller.tools.set_tool("edit")
    assert controller.wait_idle(10)
    assert sum(h.visible for h in view.gizmos.vertex_handles) == n_vertices
    assert sum(h.visible for h in view.gizmos.obstacle_handles) == len(
        controller.scene.obstacles
    )
    i, j = view.gizmos.vertex_slots[5]
    assert_allclose(
        view.gizmos.vertex_handles[5].position[:2],
        controller.scene.obstacles[i].exterior.coords[j],
    )
    # The start inside an obstacle: no path is drawn at all, not an old one.
    controller.edits.move_start((2.7, 1.7))
    assert controller.wait_idle(10)
    assert (
        not view.graphs["vg"].path.handle.visible
        and not view.graphs["svg"].path.handle.visible
    )
    assert not view.graphs["vg"].edges.visible
    controller.undo()
    assert controller.wait_idle(10)
    assert view.graphs["vg"].path.handle.visible
    # Layer toggles.
    controller.set_layer("vg_edges", False)
    controller.set_layer("expanded", False)
    assert controller.wait_idle(10)
    assert not view.graphs["vg"].edges.visible and not view.expanded_fill.shown()


def _gizmo_drag(
    view: PlannerView, handle: Any, xy: tuple[float, float], phase: str
) -> None:
    """What a gizmo of ``view`` reports when a user drags it (its callback, run as viser
    runs it: a coroutine on the event loop)."""
    event = SimpleNamespace(target=SimpleNamespace(position=(*xy, 0.0)), phase=phase)
    asyncio.run(view.gizmos._callback(lambda: handle)(event))


def test_dragged_handle_is_left_alone_until_the_drag_ends(drawn):
    """A gizmo held in one view is left alone there, and placed in every other view (a
    second presenter's browser sees the drag as it goes, like the class does)."""
    other, controller = drawn
    held = PlannerView(
        ScopedTarget(other.target, "/held"), on_drag=controller.edits.drag_handle
    )
    controller.add_view(held)
    assert controller.wait_idle(10)
    goal = controller.scene.goal
    _gizmo_drag(held, ("goal",), goal, "start")
    # The browser has moved the gizmo further than the controller has seen.
    held.gizmos.handles["goal"].position = (goal[0] - 1.0, goal[1], 0.0)
    _gizmo_drag(held, ("goal",), (goal[0] - 0.5, goal[1]), "update")
    assert controller.wait_idle(10)
    assert controller.frame.dragging == frozenset({("goal",)})
    assert_allclose(held.gizmos.handles["goal"].position[:2], (goal[0] - 1.0, goal[1]))
    assert_allclose(other.gizmos.handles["goal"].position[:2], (goal[0] - 0.5, goal[1]))
    _gizmo_drag(held, ("goal",), (goal[0] - 0.5, goal[1]), "end")
    assert controller.wait_idle(10)
    assert_allclose(held.gizmos.handles["goal"].position[:2], (goal[0] - 0.5, goal[1]))
    assert_allclose(other.gizmos.handles["goal"].position[:2], (goal[0] - 0.5, goal[1]))


def test_robot_is_posed_and_wheels_spin(drawn):
    view, controller = drawn
    controller.playback.set_robot_time(3.0)
    assert controller.wait_idle(10)
    trajectory = controller.frame.trajectory
    pose, angles = trajectory.sample(3.0)
    assert view.robot.visible
    assert_allclose(view.robot.position[:2], pose[:2])
    assert_allclose(view.robot.wxyz, yaw_quaternion(pose[2] - math.pi / 2), atol=1e-12)
    assert len(view.wheel_spins) == 3
    for (spin, axle), angle in zip(view.wheel_spins, angles, strict=True):
        # The spin frame turns about the axle by the wheel angle: w = cos(a/2), xyz = sin(a/2) axle.
        assert_allclose(
            spin.wxyz, (math.cos(angle / 2), *(math.sin(angle / 2) * axle)), atol=1e-12
        )
    controller.edits.set_robot(kind="differential")
    assert controller.wait_idle(20)
    assert len(view.wheel_spins) == 2
    controller.set_layer("robot", False)
    assert controller.wait_idle(10)
    assert not view.robot.visible


def test_view_draws_a_dsb_frame(server):
    """A hand-made DSB result: coloured by mode, labelled events, sensing disk around the robot."""
    server.scene.reset()
    view = PlannerView(server)
    scene = planners.load_scene(SCENARIO_DIR / "01_two_convex.json")
    plans = dict(planners.plan_all(scene))

    class Trace:
        status = "reached"
        path = np.array([[1.0, 1.0], [2.0, 1.0], [3.0, 1.5], [9.0, 7.0]])
        modes = ("seek", "follow", "seek")
        events = (
            BugEvent("hit", scene.start, "H1", 1, 0.0),
            BugEvent("leave", (3.0, 1.5), "L1", 1, 2.6),
        )
        length = 10.0
        reason = None
        ms = 1.0

    plans["dsb"] = Trace()
    frame = Frame(
        version=1, scene=scene, plans=plans, problems=(), message=None, tool="drag",
        layers={"dsb_path": True}, selection=None, draft=(), dragging=frozenset(),
        can_undo=False, can_redo=False, follow="dsb", trajectory=None, other_expanded=None,
        scenario="", compute_ms=1.0,
    )  # fmt: skip
    view.render(frame)
    colors = np.asarray(view.traces["dsb"].path.handle.colors)
    assert colors.shape == (3, 2, 3)
    assert not np.array_equal(colors[0], colors[1]) and np.array_equal(
        colors[0], colors[2]
    )
    labels = [h for h in view.traces["dsb"].labels.handles if h.visible]
    assert [h.text for h in labels] == ["H1", "L1"]
    # Sized in metres for a projector; each beside its event (the one at the start
    # beside the start marker, not on it) and clear of both events' crosses.
    font = floor_font(floor_bounds(scene))
    assert all(h.font_size_mode == "scene" for h in labels)
    assert all(h.font_scene_height == pytest.approx(font) for h in labels)
    radius = max(scene.robot.radius, 0.12)
    start = shapely.Point(scene.start).buffer(radius)
    for handle, at in zip(labels, [scene.start, (3.0, 1.5)], strict=True):
        w, h = label_size(handle.text, font)
        x, y = handle.position[:2]
        box = shapely.box(x - w / 2, y - h / 2, x + w / 2, y + h / 2)
        assert not box.intersects(start)
        assert 0 < box.distance(shapely.Point(at)) < radius + 1.5 * font
    sensing = {"center": (2.0, 1.0), "radius": 2.0, "seen": np.array([[[3.0, 1.0], [3.0, 2.0]]]),
               "tangents": np.array([[[2.0, 1.0], [3.0, 2.0]]])}  # fmt: skip
    pose = RobotPose(t=1.0, duration=5.0, xy=(2.0, 1.0), phi=0.0, wheel_angles=(), wheel_rates=(),
                     velocity=(0.0, 0.0, 0.0), playing=False, planner="dsb", sensing=sensing)  # fmt: skip
    view.render_robot(pose)
    circle = np.asarray(view.sensing_circle.handle.points)
    assert_allclose(
        np.hypot(circle[..., 0] - 2.0, circle[..., 1] - 1.0), 2.0, atol=1e-5
    )
    assert view.sensing_seen.handle.visible and view.sensing_graph.handle.visible


def test_status_markdown_lists_message_and_problems(drawn):
    _view, controller = drawn
    controller.edits.move_start((2.7, 1.7))
    assert controller.wait_idle(10)
    text = status_markdown(controller.frame)
    assert "the start is inside obstacle 1" in text


def test_labels_of_a_self_intersecting_obstacle_stay_on_it():
    from app.ui.view import _label_point

    bowtie = Polygon([(2, 2), (3, 7), (4, 5.5), (2, 5.5)])
    x, y, _ = _label_point(bowtie, 0.4)
    x0, y0, x1, y1 = bowtie.bounds
    assert x0 <= x <= x1 and y0 <= y <= y1


def test_line_layers_never_switch_colour_mode(server):
    # three.js must recompile a material when vertex colours are switched on; viser 1.1.1
    # does not, so a layer that switched could be drawn white.
    server.scene.reset()
    view = PlannerView(server)
    assert np.asarray(view.traces["dsb"].path.handle.colors).shape == (1, 2, 3)
    assert np.asarray(view.graphs["vg"].path.handle.colors).shape == (3,)
    scene = planners.load_scene(SCENARIO_DIR / "01_two_convex.json")
    controller = Controller(view, scene, slow_process=False)
    try:
        assert controller.wait_idle(30)
        assert np.asarray(view.graphs["vg"].path.handle.colors).shape == (3,)
        dsb = np.asarray(view.traces["dsb"].path.handle.colors)
        if view.traces["dsb"].path.handle.visible:
            assert dsb.shape == np.asarray(view.traces["dsb"].path.handle.points).shape
    finally:
        controller.close()


def test_bug2_is_drawn_when_switched_on_and_hidden_when_off(drawn):
    view, controller = drawn
    assert "bug2" not in controller.frame.plans  # off by default
    assert not view.traces["bug2"].path.handle.visible
    controller.set_planner_enabled("bug2", True)
    assert controller.wait_idle(20)
    frame = controller.frame
    bug2 = frame.plans["bug2"]
    assert "bug2" in frame.enabled and bug2.status == "reached"
    layer = view.traces["bug2"]
    assert layer.path.handle.visible
    np.testing.assert_allclose(
        np.asarray(layer.path.handle.points)[:, :, :2],
        np.stack([bug2.path[:-1], bug2.path[1:]], axis=1),
        atol=1e-5,
    )
    # Coloured by mode (on the M-line / following a border) and labelled H2, L2.
    colors = [tuple(c) for c in np.asarray(layer.path.handle.colors)[:, 0]]
    by_mode = {m: {c for c, mm in zip(colors, bug2.modes, strict=True) if mm == m}
               for m in ("seek", "follow")}  # fmt: skip
    assert len(by_mode["seek"]) == len(by_mode["follow"]) == 1
    assert by_mode["seek"] != by_mode["follow"]
    assert planner_look("bug2").follow != planner_look("bug2").path
    assert [h.text for h in layer.labels.handles if h.visible] == [
        e.label for e in bug2.events
    ]
    assert "| BUG2 | reached |" in results_markdown(frame.plans)
    controller.set_planner_enabled("bug2", False)
    assert controller.wait_idle(20)
    assert "bug2" not in controller.frame.plans
    assert not view.traces["bug2"].path.handle.visible


def test_the_legend_and_layers_list_every_registered_planner():
    html = legend_html()
    for name in planners.REGISTRY:
        assert f"{name.upper()} " in html
    assert "BUG2 path: goal seeking / boundary following" in html
    assert {"bug2_path", "dsb_path", "vg_edges", "svg_path"} <= set(LAYERS)


def test_a_scene_of_very_many_obstacles_shows_no_numbers(server):
    """Up to MAX_NUMBERED_OBSTACLES obstacles are numbered; beyond, none is (a maze of
    hundreds of numbers would bury the scene), and an edit back below numbers them."""
    from app.ui.view import MAX_NUMBERED_OBSTACLES

    server.scene.reset()
    view = PlannerView(server)
    side = int(np.ceil(np.sqrt(MAX_NUMBERED_OBSTACLES + 1)))
    squares = [
        [[3 * i, 3 * j], [3 * i + 1, 3 * j], [3 * i + 1, 3 * j + 1], [3 * i, 3 * j + 1]]
        for i in range(side)
        for j in range(side)
    ][: MAX_NUMBERED_OBSTACLES + 1]
    scene = planners.load_scene(
        {"format": 1, "obstacles": squares, "start": [-1, -1], "goal": [-2, -1]}
    )
    controller = Controller(view, scene, slow_process=False)
    try:
        assert controller.wait_idle(60)
        assert not any(h.visible for h in view.obstacle_labels.handles)
        controller.edits.delete_obstacle(0)
        assert controller.wait_idle(60)
        shown = [h.text for h in view.obstacle_labels.handles if h.visible]
        assert shown == [str(k + 1) for k in range(MAX_NUMBERED_OBSTACLES)]
    finally:
        controller.close()


_HALF = st.integers(-4, 4).map(lambda k: k / 2.0)


@st.composite
def _drawable_polygons(draw):
    """Lattice polygons (either orientation, holes, -0.0, bowties) and big circles."""
    if draw(st.integers(0, 9)) == 0:  # beyond the kept size: drawn afresh each time
        n = draw(st.sampled_from([150, 260]))
        return shapely.Point(0, 0).buffer(3.0, quad_segs=n // 4)
    shell = draw(st.lists(st.tuples(_HALF, _HALF), min_size=3, max_size=7))
    if draw(st.booleans()):
        shell = [(-0.0 if x == 0 else x, y) for x, y in shell]
    holes = [[(0.1, 0.1), (0.3, 0.1), (0.1, 0.3)]] if draw(st.booleans()) else []
    return Polygon(shell, holes)


@settings(max_examples=60, deadline=None)
@given(st.lists(_drawable_polygons(), min_size=1, max_size=5), st.randoms())
def test_kept_drawings_equal_fresh_ones(polygons, rnd):
    """Drawings kept by value (outline, fill, prism, label point) are what drawing the
    polygons afresh gives, over interleaved calls with equal polygons as new objects and
    with the same objects again (looked up by identity first, per argument); and a kept
    drawing cannot be changed by whoever received it."""
    from app.ui import view as v

    for _ in range(3):
        shuffled = [
            Polygon(p.exterior.coords, [h.coords for h in p.interiors])
            for p in polygons
        ]
        rnd.shuffle(shuffled)
        for p in shuffled + shuffled[::-1]:
            for z in (0.0, 0.25):
                assert_allclose(
                    v.rings_to_segments([p], z), v._make_outline(p, z, True), rtol=0
                )
            fill = v.polygon_to_mesh(p, 0.1)[0]
            fresh = v.lift(v._make_fill(p).reshape(-1, 2), 0.1)
            assert_allclose(fill, fresh.reshape(fill.shape), rtol=0)
            prism = v.prism_mesh([p], 0.4)[0]
            assert_allclose(prism, v._make_prism_vertices(p, 0.4), rtol=0)
            assert v._label_point(p, 0.3) == (*v._make_inner_point(p), 0.3)
    kept = v._outline(polygons[0], 0.0, True) if v._small(polygons[0]) else None
    if kept is not None and len(kept):
        with pytest.raises(ValueError):
            kept[0, 0, 0] = 99.0
