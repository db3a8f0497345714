"""The live view's projector text (app.ui.floor_text): sized in metres, placed on the floor.

Pure geometry, for every shipped scenario: the events of every trace planner placed at
once (DSB's M2 and Bug2's H2 on one point of 05 with R = 0.6 m), and every step of every
method's labels as Explain places them, with the caption above the floor. Boxes are the
monospaced font's, larger than viser's drawing of the same text (the browser test in
tests/app/test_app_explain_browser.py measures that with the browser's own font).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import pytest
import shapely

import planners
from app.explain.view import place_step_labels, scene_names, step_requests
from app.ui.floor_text import (
    FONT_SHARE,
    FloorRequest,
    first_camera,
    floor_caption,
    floor_font,
    place_events,
    place_on_floor,
)
from app.ui.labels import CHAR_WIDTH
from app.ui.view import EVENT_CROSS, event_labels, floor_bounds, live_keepouts
from planners.explain import METHODS, explain

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((ROOT / "static_scenarios").glob("*.json"))


def boxes_apart(boxes, others=()) -> None:
    """No two of ``boxes`` share area, and none shares area with ``others``."""
    shapes = [shapely.box(*b) for b in boxes]
    for (i, a), (j, b) in itertools.combinations(enumerate(shapes), 2):
        assert a.intersection(b).area <= 1e-9, (boxes[i], boxes[j])
    for a in shapes:
        for other in others:
            assert a.intersection(shapely.box(*other)).area <= 1e-9, (a.bounds, other)


def test_the_font_is_a_share_of_what_the_first_camera_shows() -> None:
    bounds = (0.0, 0.0, 10.0, 8.0)
    camera = first_camera(bounds)
    seen = 2 * math.tan(camera.fov / 2) * math.dist(camera.position, camera.look_at)
    assert floor_font(bounds) == pytest.approx(FONT_SHARE * seen)
    assert seen > 8.0  # the whole floor is in view
    # Twice the floor, twice the font: the text keeps its size on the screen.
    assert floor_font((0.0, 0.0, 20.0, 16.0)) == pytest.approx(2 * floor_font(bounds))


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem[:2])
@pytest.mark.parametrize("sensor_range", [None, 0.6])
def test_every_planners_events_are_placed_apart(path, sensor_range) -> None:
    scene = planners.load_scene(path)
    options = planners.PlanOptions(
        **({} if sensor_range is None else {"sensor_range": sensor_range})
    )
    plans = planners.plan_all(scene, tuple(planners.REGISTRY), options)
    traces = [(n, event_labels(plans.get(n))) for n in ("dsb", "bug2")]
    bounds = floor_bounds(scene)
    font = floor_font(bounds)
    keepouts = live_keepouts(scene, font)
    placed = place_events(
        traces, font=font, area=bounds, cross=EVENT_CROSS, keepouts=keepouts
    )
    for name, events in traces:
        assert [p.request.text for p in placed[name]] == [t for t, _ in events]
    labels = [p.box for ps in placed.values() for p in ps]
    crosses = [
        (x - EVENT_CROSS, y - EVENT_CROSS, x + EVENT_CROSS, y + EVENT_CROSS)
        for _, events in traces
        for _, (x, y) in events
    ]
    boxes_apart(labels, [*crosses, *keepouts.markers, *keepouts.reserved])


def test_two_planners_events_on_one_point_get_a_box_each() -> None:
    # 05 with R = 0.6 m: DSB's local minimum M2 is where Bug2 hits obstacle 2 (H2).
    scene = planners.load_scene(SCENARIOS[4])
    plans = planners.plan_all(
        scene, ("dsb", "bug2"), planners.PlanOptions(sensor_range=0.6)
    )
    at = {e.label: tuple(e.at) for e in plans["dsb"].events}
    hits = {e.label: tuple(e.at) for e in plans["bug2"].events}
    assert math.dist(at["M2"], hits["H2"]) < 1e-9
    bounds = floor_bounds(scene)
    font = floor_font(bounds)
    placed = place_events(
        [("dsb", event_labels(plans["dsb"])), ("bug2", event_labels(plans["bug2"]))],
        font=font,
        area=bounds,
        cross=EVENT_CROSS,
    )
    m2 = next(p for p in placed["dsb"] if p.request.text == "M2")
    h2 = next(p for p in placed["bug2"] if p.request.text == "H2")
    boxes_apart([m2.box, h2.box])
    for label in (m2, h2):  # each beside its point, or led to it
        near = shapely.box(*label.box).distance(shapely.Point(at["M2"]))
        assert near < 2 * font or label.leader is not None


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem[:2])
def test_every_explain_steps_labels_are_placed_apart(path) -> None:
    scene = planners.load_scene(path)
    plans = dict(planners.plan_all(scene))
    bounds = floor_bounds(scene)
    font = floor_font(bounds)
    for method in METHODS:
        kwargs: dict[str, Any] = {} if method == "expansion" else {"plans": plans}
        explanation = explain(scene, method, **kwargs)
        for n in range(len(explanation.steps)):
            step = explanation.step(n)
            caption = floor_caption(f"{n + 1}/9 {step.text}", font, bounds)
            keepouts = live_keepouts(scene, font).plus(reserved=[caption.box])
            placed = place_step_labels(
                step,
                font=font,
                area=bounds,
                keepouts=keepouts,
                named=scene_names(scene),
            )
            requests, rings = step_requests(step, scene_names(scene))
            assert [p.request for p in placed] == [r for _, r in requests]
            boxes_apart(
                [p.box for p in placed], [*rings, *keepouts.markers, *keepouts.reserved]
            )


def test_the_caption_is_wrapped_to_the_floor_above_it() -> None:
    bounds = (0.0, 0.0, 12.0, 8.0)
    font = floor_font(bounds)
    text = "Fig. 9.17: local minimum M: every O_i in view is at least as far " * 3
    caption = floor_caption(text, font, bounds)
    assert len(caption.lines) > 1
    assert " ".join(caption.lines) == " ".join(text.split())
    assert all(len(line) * CHAR_WIDTH * font <= 12.0 for line in caption.lines)
    x0, y0, x1, y1 = caption.box
    assert (x0, x1) == (0.0, 12.0) and y0 > 8.0
    assert y1 - y0 >= len(caption.lines) * 1.2 * font


def test_a_label_with_no_room_is_left_out_never_drawn_over_another() -> None:
    placed = place_on_floor(
        [FloorRequest("O_1 0.60+4.62=5.22", (0.5, 0.5))] * 3,
        font=0.3,
        area=(0.0, 0.0, 7.0, 1.2),
    )
    assert 1 <= len(placed) < 3
    boxes_apart([p.box for p in placed])
