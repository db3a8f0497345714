"""Chunked layers: an edit sends only the chunks whose polygons changed.

First ``_Chunked`` alone, held to the drawing of every polygon at once over random
sequences of edits; then the real view on a viser server, where the messages queued for
the browsers are counted per node while one obstacle of a student room is moved.
"""

from __future__ import annotations

import collections
import dataclasses
from collections.abc import Iterator, Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import viser
import viser._scene_api
from hypothesis import example, given, settings
from hypothesis import strategies as st
from shapely import Polygon

import planners
from app.session.controller import Controller
from app.ui.scoped import ScopedTarget
from app.ui.style import HEIGHTS
from app.ui.view import (
    PlannerView,
    _Chunked,
    chunk_size,
    polygon_to_mesh,
    polygons_of,
    prism_mesh,
    rings_to_segments,
)
from planners.scene import add_obstacle
from tests.app.app_helpers import shown_mesh, view_and_controller
from tests.benchmarks.bench_student import student_layout


class _Layer:
    """A node's layer that records what it was given (as _Mesh/Segments are used)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.handle = SimpleNamespace(visible=False)
        self.drawing: list[Polygon] = []
        self.sent = 0

    def set(self, drawing: list[Polygon], visible: bool = True) -> None:
        self.drawing = drawing
        self.handle.visible = visible and bool(drawing)
        self.sent += 1


def _square(x: float) -> Polygon:
    return Polygon([(x, 0), (x + 1, 0), (x + 1, 1), (x, 1)])


_EDITS = st.lists(
    st.one_of(
        st.tuples(st.just("move"), st.integers(0, 99), st.integers(0, 3)),
        st.tuples(st.just("insert"), st.integers(0, 99), st.integers(0, 3)),
        st.tuples(st.just("delete"), st.integers(0, 99), st.just(0)),
        st.tuples(st.just("hide"), st.just(0), st.just(0)),
    ),
    max_size=25,
)


def _drawing(polygons: Sequence[Polygon]) -> list[Polygon]:
    """A chunk's drawing: its polygons, but none of a moved-to-103 one (draws nothing)."""
    return [p for p in polygons if not _blank(p)]


def _blank(polygon: Polygon) -> bool:
    return polygon.bounds[0] == 103.0


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 90), _EDITS)
@example(65, [("delete", 0, 0), ("insert", 3, 1), ("hide", 0, 0), ("hide", 0, 0)])
@example(8, [("move", 1, 3), ("move", 2, 3), ("move", 0, 3), ("move", 3, 3)])
def test_chunks_show_what_drawing_everything_shows_and_send_only_changes(n, edits):
    """After every edit the shown nodes, in order, hold the polygons in order (as one
    drawing of them all); a node is sent again only when its polygons or the layer's
    visibility changed. The examples cross 64 polygons (4 a node, then 5) and back, and
    make a node's whole drawing empty."""
    chunked = _Chunked(_Layer, "/p", _drawing)
    polygons = [_square(float(k)) for k in range(n)]
    visible = True
    previous: list[Any] = []
    for kind, where, value in [("start", 0, 0), *edits]:
        if kind == "move" and polygons:
            polygons[where % len(polygons)] = _square(100.0 + value)
        elif kind == "insert":
            polygons.insert(where % (len(polygons) + 1), _square(200.0 + value))
        elif kind == "delete" and polygons:
            del polygons[where % len(polygons)]
        elif kind == "hide":
            visible = not visible
        sent_before = [layer.sent for layer in chunked.layers]
        chunked.set(tuple(polygons), visible)
        shown = [
            p for layer in chunked.layers if layer.handle.visible for p in layer.drawing
        ]
        assert shown == ([p for p in polygons if not _blank(p)] if visible else [])
        size = chunk_size(len(polygons))
        chunks = [tuple(polygons[k : k + size]) for k in range(0, len(polygons), size)]
        for k, layer in enumerate(chunked.layers):
            sent = layer.sent - (sent_before[k] if k < len(sent_before) else 0)
            before = previous[k] if k < len(previous) else None
            now = (chunks[k], visible) if k < len(chunks) else None
            assert sent == int(visible and now is not None and now != before)
        assert len(chunked.layers) <= 16
        previous = [
            (chunks[k], visible) if k < len(chunks) else None
            for k in range(len(chunked.layers))
        ]


def test_a_floor_plan_of_many_polygons_is_drawn_on_at_most_sixteen_nodes():
    chunked = _Chunked(_Layer, "/p", list)
    chunked.set(tuple(_square(float(k)) for k in range(1000)), True)
    assert len(chunked.layers) == 16
    assert [len(layer.drawing) for layer in chunked.layers] == [63] * 15 + [55]


# ----------------------------------------------------------------------------- real view


@pytest.fixture
def room() -> Iterator[tuple[PlannerView, Controller]]:
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    scene = planners.load_scene(student_layout(32, layout="apart"))
    view, controller = view_and_controller(server, scene)
    controller.set_planner_enabled("dsb", False)
    assert controller.wait_idle(60)
    yield view, controller
    controller.close()
    server.stop()


class _Queued:
    """Scene messages queued for the browsers, counted per node."""

    def __init__(self) -> None:
        self.by_node: collections.Counter[str] = collections.Counter()
        self._saved = viser._scene_api.SceneApi._queue_scene_message

    def __enter__(self) -> _Queued:
        saved, counts = self._saved, self.by_node

        def queue(api: Any, message: Any) -> None:
            counts[str(getattr(message, "name", ""))] += 1
            saved(api, message)

        viser._scene_api.SceneApi._queue_scene_message = queue  # type: ignore[method-assign]
        return self

    def __exit__(self, *exc: object) -> None:
        viser._scene_api.SceneApi._queue_scene_message = self._saved  # type: ignore[method-assign]

    def nodes(self, prefix: str) -> set[str]:
        return {name for name in self.by_node if name.startswith(prefix + "/")}


def test_moving_one_obstacle_sends_only_its_chunks(room):
    """Obstacle 13 of 32 (chunks of 4) moves: its prism, outline and expanded outline
    are sent in node 3 of each layer, nothing else of them, and so is its part of the
    configuration space's fill (the parts are apart, in the obstacles' order). What is
    shown is still the whole scene's drawing, layer by layer."""
    view, controller = room
    with _Queued() as queued:
        controller.edits.move_obstacle(13, (0.05, 0.0))
        assert controller.wait_idle(30)
    assert queued.nodes("/obstacles/body") == {"/obstacles/body/3"}
    assert queued.nodes("/obstacles/edges") == {"/obstacles/edges/3"}
    assert queued.nodes("/expanded/edges") == {"/expanded/edges/3"}
    assert queued.nodes("/expanded/fill") == {"/expanded/fill/3"}  # parts apart
    moved = controller.scene
    vertices, faces = shown_mesh(view.obstacles)
    expected, _ = prism_mesh(moved.obstacles, HEIGHTS["obstacle"])
    np.testing.assert_allclose(vertices, expected, atol=1e-6)
    assert len(faces) == len(expected) // 3
    np.testing.assert_allclose(
        _shown_segments(view.obstacle_edges),
        rings_to_segments(moved.obstacles, HEIGHTS["obstacle"] + 0.002),
        atol=1e-6,
    )
    cspace = controller.frame.plans["cspace"]
    fill, _ = polygon_to_mesh(cspace.merged, HEIGHTS["expanded_fill"])
    np.testing.assert_allclose(shown_mesh(view.expanded_fill)[0], fill, atol=1e-6)
    outlines = [*cspace.expanded, *polygons_of(cspace.boundary)]
    np.testing.assert_allclose(
        _shown_segments(view.expanded_edges),
        rings_to_segments(outlines, HEIGHTS["expanded_edge"]),
        atol=1e-6,
    )


def _shown_segments(chunked: Any) -> np.ndarray:
    return np.concatenate([h.points for h in chunked.shown()])


def test_hiding_a_layer_hides_every_chunk_and_showing_it_draws_them_again(room):
    view, controller = room
    controller.set_layer("obstacles", False)
    controller.set_layer("expanded", False)
    assert controller.wait_idle(30)
    assert not view.obstacles.shown() and not view.obstacle_edges.shown()
    assert not view.expanded_fill.shown() and not view.expanded_edges.shown()
    controller.set_layer("obstacles", True)
    controller.set_layer("expanded", True)
    assert controller.wait_idle(30)
    vertices, _ = shown_mesh(view.obstacles)
    expected, _ = prism_mesh(controller.scene.obstacles, HEIGHTS["obstacle"])
    np.testing.assert_allclose(vertices, expected, atol=1e-6)
    # 32 parts apart, 4 a node.
    assert len(view.expanded_fill.shown()) == len(view.expanded_fill.layers) == 8


def _drawn_then_closed(target: ScopedTarget) -> tuple[PlannerView, Any]:
    """A view of four obstacles under ``target``, drawn once; its session closed."""
    scene = planners.load_scene(student_layout(4, layout="apart"))
    view, controller = view_and_controller(target, scene)
    assert controller.wait_idle(60)
    frame = controller.frame
    controller.close()
    assert frame is not None
    return view, frame


def test_a_scoped_view_drawn_after_its_root_is_removed_adds_no_node():
    """A classroom's view drawn late, after its browser left and its root was removed:
    chunks (and labels) it would add for a new obstacle are refused, not made again
    under a root viser would bring back, visible."""
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        target = ScopedTarget(server, "/own")
        view, frame = _drawn_then_closed(target)
        assert len(view.obstacles.layers) == 1
        target.remove()
        grown = dataclasses.replace(
            frame,
            scene=add_obstacle(frame.scene, [(9.0, 9.0), (10.0, 9.0), (10.0, 10.0)]),
            version=frame.version + 1,
        )
        with pytest.raises(RuntimeError, match="was removed"):
            view.render(grown)
        names = server.scene._handle_from_node_name  # viser's own registry
        assert not [name for name in names if name.startswith("/own")]
    finally:
        server.stop()


def test_a_view_drawn_after_its_browser_left_goes_nowhere_quietly():
    """A browser leaves while its view is drawn: the rest of the drawing is dropped
    without viser's warning of messages it will never deliver (which a bare write to
    the departed browser still gets: the check can fail)."""
    import warnings

    from app.ui.scoped import batch, left
    from tests.app.app_helpers import wait_until
    from tests.viser_client import ViserClient

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        browser = ViserClient(server.get_port())
        assert wait_until(lambda: len(server.get_clients()) == 1, 30)
        (client,) = server.get_clients().values()
        view, frame = _drawn_then_closed(ScopedTarget(client, "/own"))
        browser.close()
        assert wait_until(lambda: left(client), 30)
        moved = dataclasses.replace(
            frame,
            scene=dataclasses.replace(frame.scene, goal=(1.0, 1.0)),
            version=frame.version + 1,
        )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            view.render(moved)
            with batch(client):
                client.gui.add_markdown("after")
        assert not [w for w in caught if "closed connection" in str(w.message)]
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            client.gui.add_markdown("bare")
        assert [w for w in caught if "closed connection" in str(w.message)]
    finally:
        server.stop()


def test_a_live_robot_drawn_after_its_browser_left_goes_nowhere_quietly():
    """A copy's live robot steps or replays after its student's browser left: its trail
    and moving outlines (one atomic update with the robot) are dropped without viser's
    warning of messages it will never deliver."""
    import warnings

    from app.live import LiveRun
    from app.ui.scoped import left
    from tests.app.app_helpers import wait_until
    from tests.viser_client import ViserClient

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    run = None
    try:
        browser = ViserClient(server.get_port())
        assert wait_until(lambda: len(server.get_clients()) == 1, 30)
        (client,) = server.get_clients().values()
        scene = planners.load_scene(student_layout(4, layout="apart"))
        run = LiveRun(lambda: scene, ScopedTarget(client, "/copy"), [], speed=20.0)
        run.start()
        assert wait_until(lambda: run.state is not None and run.state.t > 0.5, 60)
        run.stop()
        browser.close()
        assert wait_until(lambda: left(client), 30)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            run.show_at(0.25)
        assert not [w for w in caught if "closed connection" in str(w.message)]
    finally:
        if run is not None:
            run.close()
        server.stop()


def test_a_replay_slider_moved_after_its_browser_left_goes_nowhere_quietly():
    """Two presenter browsers: one scrubs the replay while the other leaves. The slider
    of the one that left is moved without viser's warning of messages it will never
    deliver."""
    import warnings

    from app.live import LivePanels, LiveRun
    from app.ui.scoped import left
    from tests.app.app_helpers import wait_until
    from tests.viser_client import ViserClient

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    run = None
    try:
        browsers = [ViserClient(server.get_port()) for _ in range(2)]
        assert wait_until(lambda: len(server.get_clients()) == 2, 30)
        staying, leaving = server.get_clients().values()
        scene = planners.load_scene(student_layout(4, layout="apart"))
        run = LiveRun(lambda: scene, server, [], speed=20.0)
        panels = LivePanels(run)
        kept, gone = panels.add(staying), panels.add(leaving)
        gone.replay.max = 1.0  # a run of a second to replay
        browsers[1].close()
        assert wait_until(lambda: left(leaving), 30)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            panels._show_replay(kept, 0.5)  # as from the staying browser's slider
        assert gone.replay.value == 0.5
        assert not [w for w in caught if "closed connection" in str(w.message)]
    finally:
        if run is not None:
            run.close()
        server.stop()
