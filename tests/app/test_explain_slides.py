"""Explain steps as slide pictures (app.media.explain_slides), laid out without a browser.

Every step of every method of every shipped scenario is laid out at 1920 x 1080 (a
projector) and 1280 x 720, as ``--snapshot --explain METHOD --step all`` lays them out,
and the layout is checked as geometry: the caption at the labels' size, wrapped to the
picture and never cut; no two labels overlapping, none over a ring, the title, the
caption or the aside; every label of the step placed; the title, caption, legend, table
and flowchart clear of each other and of the scene's window. About 2,000 layouts in a few
seconds: this is the breadth. That the browser draws what the layout says (text heights
in pixels, boxes that do not overlap, a caption not cut) is checked on a sample of steps
by tests/app/test_explain_pictures_browser.py.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import pytest

import planners
from app.explain.panel import hidden_layers
from app.explain.view import ROLE_LOOKS, scene_names
from app.media.camera import picture_bounds
from app.media.explain_pictures import step_bounds
from app.media.explain_slides import (
    ExplainSlide,
    explain_layout,
    role_legend,
    step_set,
    step_title,
)
from app.media.slides import SlideOptions, font_px, project
from app.session.controller import LAYERS
from app.ui.labels import CHAR_WIDTH, Box
from planners.explain import METHODS, explain
from planners.explain.dsb import FLOWCHART

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((ROOT / "static_scenarios").glob("*.json"))
SIZES = [(1920, 1080), (1280, 720)]


def explanations(path: Path):
    """Yield (scene, plans, layers, explanation) of every method, as the app has them."""
    scene = planners.load_scene(path)
    plans = dict(planners.plan_all(scene))
    for method in METHODS:
        kwargs: dict[str, Any] = {} if method == "expansion" else {"plans": plans}
        layers = {k: k not in hidden_layers(method) for k in LAYERS}
        yield scene, plans, layers, explain(scene, method, **kwargs)


def check_text_blocks(picture: ExplainSlide, size: tuple[int, int]) -> None:
    """The title, caption, legend, table and flowchart: inside, apart, off the scene."""
    boxes = picture.text_boxes()
    for box in boxes:
        assert box.inside(*size), box
    for a, b in itertools.combinations(boxes, 2):
        assert not a.overlaps(b), (a, b)
    if picture.window is not None:
        assert picture.window.inside(*size)
        for box in boxes:
            assert not box.overlaps(picture.window), (box, picture.window)


def check_caption(picture: ExplainSlide, text: str, height: int) -> None:
    """At the labels' size, every line inside its box, every word of the text kept."""
    caption = picture.caption
    font = caption.font
    assert font == picture.slide.font_px == font_px(height)
    inner = caption.box.width - 2 * 0.35 * font
    assert all(len(line) * CHAR_WIDTH * font <= inner + 1e-6 for line in caption.lines)
    assert len(caption.lines) * 1.25 * font + 0.7 * font <= caption.box.height + 1e-6
    assert " ".join(caption.lines) == " ".join(text.split())


def check_labels(picture: ExplainSlide, step, size: tuple[int, int], scene) -> None:
    """No two labels overlap, none covers a ring, a marker or a text block; none is lost.

    A label of the step that names the start or the goal is the scene's own label.
    """
    slide = picture.slide
    placed = slide.labels.placed
    assert not slide.labels.dropped, [r.text for r in slide.labels.dropped]
    boxes = [p.box for p in placed]
    for a, b in itertools.combinations(boxes, 2):
        assert not a.overlaps(b), (a, b)
    for box in boxes:
        assert box.inside(*size)
        for other in (*slide.markers, *picture.text_boxes()):
            assert not box.overlaps(other), (box, other)
    # Every label of the step whose point is in the picture's window is drawn.
    shown = picture.window or Box(0, 0, *size)
    texts = {p.request.text for p in placed if p.request.kind == "mark"}
    all_texts = {p.request.text for p in placed}
    for mark in step.marks:
        z = ROLE_LOOKS[mark.role].height
        for text, (x, y) in mark.labels:
            anchor = project(slide.camera, *size, [[x, y, z]])[0]
            if shown.distance_to((float(anchor[0]), float(anchor[1]))) == 0:
                named = (text, (x, y)) in [(n, tuple(p)) for n, p in scene_names(scene)]
                assert text in texts or (named and text in all_texts), text


def check_aside(picture: ExplainSlide, explanation, step) -> None:
    """The legend names every role drawn (not faint); DSB's table and flowchart say the step's."""
    legend = picture.slide.legend
    assert legend is not None
    rows = {row.text: row for row in legend[0]}
    for mark in step.marks:
        row = next(r for t, r in rows.items() if ROLE_LOOKS[mark.role].legend in t)
        assert not row.dim, mark.role
    if explanation.method != "dsb":
        assert picture.flowchart is None
        return
    assert picture.table is not None and picture.table.rows == step.detail
    assert picture.flowchart is not None
    on = [lines for lines, lit in picture.flowchart.boxes if lit]
    box = step.kind.split(":", 1)[1]
    if box in dict(FLOWCHART):
        assert [" ".join(lines) for lines in on] == [dict(FLOWCHART)[box]]


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem[:2])
def test_every_step_of_every_method_is_laid_out_for_a_projector(path) -> None:
    for scene, plans, layers, explanation in explanations(path):
        numbers = range(len(explanation.steps))
        shared = step_set(explanation, numbers)
        whole = picture_bounds(scene)
        for n, size in itertools.product(numbers, SIZES):
            step = explanation.step(n)
            picture = explain_layout(
                scene,
                explanation,
                n,
                *size,
                plans=plans,
                layers=layers,
                bounds=step_bounds(explanation, n, whole),
                steps=shared,
            )
            where = (explanation.method, n + 1, size)
            try:
                check_text_blocks(picture, size)
                check_caption(picture, step.text, size[1])
                check_labels(picture, step, size, scene)
                check_aside(picture, explanation, step)
            except AssertionError as error:
                raise AssertionError(f"{where}: {error}") from error
            title = picture.slide.title
            assert title is not None and title[0] == step_title(
                explanation, n, SlideOptions()
            )


def test_a_sequence_keeps_its_layout_and_a_whole_scene_its_camera() -> None:
    scene, plans, layers, explanation = list(explanations(SCENARIOS[4]))[2]  # 05, SVG
    shared = step_set(explanation, range(len(explanation.steps)))
    pictures = [
        explain_layout(
            scene, explanation, n, 1280, 720, plans=plans, layers=layers, steps=shared
        )
        for n in range(len(explanation.steps))
    ]
    first = pictures[0]
    for picture in pictures[1:]:
        assert picture.slide.camera == first.slide.camera
        assert picture.caption.box == first.caption.box
        assert picture.slide.legend is not None and first.slide.legend is not None
        assert picture.slide.legend[1] == first.slide.legend[1]
        assert [r.text for r in picture.slide.legend[0]] == [
            r.text for r in first.slide.legend[0]
        ]


def test_options_title_and_legend() -> None:
    scene, plans, layers, explanation = list(explanations(SCENARIOS[4]))[2]
    untitled = explain_layout(
        scene,
        explanation,
        2,
        1280,
        720,
        plans=plans,
        layers=layers,
        options=SlideOptions(title="", legend=False),
    )
    assert untitled.slide.title is None and untitled.slide.legend is None
    # Without a title the caption says the step number.
    assert untitled.caption.lines[0].startswith(f"3/{len(explanation.steps)} Step")
    titled = explain_layout(
        scene,
        explanation,
        2,
        1280,
        720,
        plans=plans,
        layers=layers,
        options=SlideOptions(title="Lecture 9"),
    )
    assert titled.slide.title is not None
    assert titled.slide.title[0] == f"Lecture 9, step 3 of {len(explanation.steps)}"
    no_labels = explain_layout(
        scene,
        explanation,
        2,
        1280,
        720,
        plans=plans,
        layers=layers,
        options=SlideOptions(labels=False),
    )
    assert no_labels.slide.labels.placed == ()


def test_the_legend_joins_roles_drawn_alike_and_dims_the_absent() -> None:
    rows = role_legend(["done", "current", "result", "focus"], ["current"])
    assert [(r.text, r.dim) for r in rows] == [
        ("earlier steps", True),
        ("added by this step / expanded obstacle", False),
        ("under study", True),
    ]
    assert rows[2].swatches[0][1] == "ring"
