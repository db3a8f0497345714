"""The editing tools as pure functions of (scene, UI state, input): no controller, no threads."""

from __future__ import annotations

import dataclasses

import pytest
from shapely import Polygon

import planners
from app.session import tools
from app.session.tools import Outcome, Selection, UiState


@pytest.fixture
def square_scene() -> planners.Scene:
    return planners.Scene(
        obstacles=(Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),),
        start=(5, 5),
        goal=(6, 6),
    )


def drawing(*corners) -> UiState:
    return dataclasses.replace(tools.set_tool(UiState(), "polygon"), draft=corners)


def test_pick_prefers_a_vertex_then_an_edge_then_the_inside(square_scene):
    assert tools.pick(square_scene, (2.1, 2.05)) == Selection(0, vertex=2)
    assert tools.pick(square_scene, (1.0, -0.1)) == Selection(0, edge=0)
    assert tools.pick(square_scene, (1.0, 1.0)) == Selection(0)
    assert tools.pick(square_scene, (4.0, 4.0)) is None


def test_a_click_in_the_polygon_tool_adds_a_corner_and_leaves_the_scene(square_scene):
    out = tools.click_floor(square_scene, drawing((3.0, 0.0)), (4.0, 0.0))
    assert out.scene is None
    assert out.ui.draft == ((3.0, 0.0), (4.0, 0.0))


def test_a_click_near_the_first_corner_closes_the_polygon(square_scene):
    ui = drawing((3.0, 0.0), (4.0, 0.0), (4.0, 1.0))
    out = tools.click_floor(square_scene, ui, (3.1, 0.05))
    assert out.scene is not None and len(out.scene.obstacles) == 2
    assert list(out.scene.obstacles[1].exterior.coords)[:3] == [
        (3.0, 0.0),
        (4.0, 0.0),
        (4.0, 1.0),
    ]
    assert out.ui.draft == () and out.ui.selection is None
    assert out.gesture is None and out.opens and out.closes  # an undo step of its own


def test_finish_polygon_needs_three_corners(square_scene):
    out = tools.finish_polygon(square_scene, drawing((3.0, 0.0), (4.0, 0.0)))
    assert out.scene is None
    assert "3 corners" in (out.ui.message or "")
    assert out.ui.draft == ((3.0, 0.0), (4.0, 0.0))  # kept: the user may add one


def test_a_refused_polygon_keeps_the_scene_and_the_draft(square_scene):
    bowtie = ((3.0, 0.0), (4.0, 1.0), (4.0, 0.0), (3.0, 1.0))
    out = tools.finish_polygon(square_scene, drawing(*bowtie))
    assert out.scene is None
    assert "intersects itself" in (out.ui.message or "")
    assert out.ui.draft == bowtie


def test_the_block_tool_drops_a_block_centred_on_the_click(square_scene):
    ui = tools.set_tool(UiState(), "block")
    out = tools.click_floor(square_scene, ui, (5.0, 1.0))
    assert out.scene is not None
    assert out.scene.obstacles[-1].bounds == (4.5, 0.5, 5.5, 1.5)


def test_the_edit_tool_selects_what_is_clicked(square_scene):
    ui = tools.set_tool(UiState(), "edit")
    out = tools.click_floor(square_scene, ui, (0.05, 0.05))
    assert out.scene is None and out.ui.selection == Selection(0, vertex=0)


def test_a_click_that_is_not_a_number_changes_nothing(square_scene):
    ui = tools.set_tool(UiState(), "block")
    assert tools.click_floor(square_scene, ui, (float("nan"), 1.0)) == Outcome(ui)


def test_delete_selected_vertex_or_obstacle(square_scene):
    five = planners.scene.insert_vertex(square_scene, 0, 0, None)
    ui = dataclasses.replace(UiState(), selection=Selection(0, vertex=1))
    out = tools.delete_selected(five, ui)
    assert out.scene is not None
    assert len(out.scene.obstacles[0].exterior.coords) - 1 == 4
    assert out.ui.selection == Selection(0)
    out = tools.delete_selected(square_scene, out.ui)
    assert out.scene is not None
    assert out.scene.obstacles == () and out.ui.selection is None
    nothing = tools.delete_selected(square_scene, UiState())
    assert nothing.scene is None and "Select" in (nothing.ui.message or "")


def test_insert_vertex_at_the_selected_edge(square_scene):
    ui = dataclasses.replace(UiState(), selection=Selection(0, edge=0))
    out = tools.insert_vertex_at_selection(square_scene, ui)
    assert out.scene is not None
    assert out.scene.obstacles[0].exterior.coords[1] == (1.0, 0.0)
    assert out.ui.selection == Selection(0, vertex=1)


def test_a_drag_is_one_gesture_from_start_to_end(square_scene):
    ui = UiState()
    start = tools.drag(square_scene, ui, ("goal",), (6.0, 6.0), "start")
    assert start.opens and not start.closes and start.gesture == ("goal",)
    assert ("goal",) in start.ui.dragging
    update = tools.drag(square_scene, start.ui, ("goal",), (7.0, 6.0), "update")
    assert update.scene is not None
    assert update.scene.goal == (7.0, 6.0) and update.phased and not update.closes
    end = tools.drag(update.scene, update.ui, ("goal",), (7.5, 6.0), "end")
    assert end.closes and end.ui.dragging == {}


def test_an_obstacle_moves_by_how_far_its_handle_moved(square_scene):
    handle = ("obstacle", 0)
    start = tools.drag(square_scene, UiState(), handle, (1.0, 1.0), "start")
    assert start.scene is None  # nothing moved yet
    out = tools.drag(square_scene, start.ui, handle, (1.5, 0.75), "update")
    assert out.scene is not None
    assert out.scene.obstacles[0].bounds == (0.5, -0.25, 2.5, 1.75)


def test_dragging_what_another_user_deleted_says_so(square_scene):
    out = tools.drag(square_scene, UiState(), ("vertex", 3, 0), (1.0, 1.0), "update")
    assert out.scene is None
    assert (out.ui.message or "").startswith("Could not move vertex 1 of obstacle 4")


def test_tools_and_layers_refuse_unknown_keys():
    assert "Unknown tool" in (tools.set_tool(UiState(), "laser").message or "")
    assert "Unknown layer" in (tools.set_layer(UiState(), "x", True).message or "")
    assert tools.set_layer(UiState(), "robot", False).layers["robot"] is False
