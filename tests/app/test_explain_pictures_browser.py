"""Explain pictures as the browser draws them: sizes in pixels, boxes apart, nothing cut.

A representative sample, one app and one browser page for all of it (each picture costs
about a second in the software renderer): SVG step 3 of 05 and DSB step 20 of 06 with
R = 0.6 m (the two pictures a lecturer found unreadable), a VG and an expansion step,
at 1920 x 1080 and 1280 x 720. What is read is what the browser drew: the boxes of the
caption's lines, the labels, the title, legend, table and flowchart from the page, and
the height of their text from the picture's pixels. Every step of every scenario is
laid out without a browser by tests/app/test_explain_slides.py.

These tests FAIL (never skip) when Chromium cannot start.
"""

from __future__ import annotations

import io
import itertools
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from PIL import Image

from app import start_app
from app.media.explain_pictures import Asked, explain_in_app, shoot_steps
from app.media.export_html import step_page
from app.media.pictures import open_studio
from planners.explain.dsb import FLOWCHART

DRAWN_JS = """() => {
    const rect = e => { const r = e.getBoundingClientRect();
                        return [r.left, r.top, r.right, r.bottom]; };
    const all = sel => [...document.querySelectorAll(sel)];
    return {
        labels: all('.planner-label').map(e => ({text: e.textContent, box: rect(e),
                                                  kind: e.className})),
        blocks: all('.planner-title, .planner-legend, .planner-caption, .planner-table,' +
                    ' .planner-flowchart').map(e => ({cls: e.className, box: rect(e),
                    cut: e.scrollHeight > e.clientHeight + 1 ||
                         e.scrollWidth > e.clientWidth + 1})),
        lines: all('.planner-caption-line').map(e => ({text: e.textContent, box: rect(e),
                    cut: e.scrollWidth > e.clientWidth + 1})),
        flowOn: all('.planner-flow-on').map(e => e.textContent),
        table: all('.planner-table').map(e => e.textContent).join('\\n'),
        legend: all('.planner-legend').map(e => e.textContent).join('\\n'),
    };
}"""

SAMPLES: list[tuple[str, float | None, str, list[int]]] = [
    # scenario, sensor range, method, steps (from 1)
    ("06_four_obstacles_sensor", 0.6, "dsb", [20]),
    ("06_four_obstacles_sensor", 0.6, "vg", [2]),
    ("05_pocket_start", None, "svg", [3]),
    ("05_pocket_start", None, "expansion", [4]),
]
SIZES = [(1920, 1080), (1280, 720)]


@pytest.fixture(scope="module")
def drawn(browser) -> Iterator[list[dict[str, Any]]]:
    """Every sample at both sizes: what the page holds, the picture and the step."""
    out: list[dict[str, Any]] = []
    app = start_app(SAMPLES[0][0], port=0, print_url=False)
    try:
        with open_studio(app, browser, width=1920, height=1080) as studio:
            for scenario, sensor, method, numbers in SAMPLES:
                if app.controller.scene.name != scenario:
                    studio.load(scenario)
                asked = Asked(method, 1, sensor, (1920, 1080))
                explanation = explain_in_app(app, asked)
                for (width, height), n in itertools.product(SIZES, numbers):
                    studio.width, studio.height = width, height
                    for _, png, layout in shoot_steps(
                        studio, explanation, [n - 1], asked
                    ):
                        page = studio.shown.page.evaluate(DRAWN_JS)
                        picture = Image.open(io.BytesIO(png)).convert("RGB")
                        out.append(
                            {
                                "where": (scenario, method, n, (width, height)),
                                "page": page,
                                "pixels": np.asarray(picture),
                                "step": explanation.step(n - 1),
                                "layout": layout,
                            }
                        )
    finally:
        app.stop()
    yield out


def dark_rows(pixels: np.ndarray, box: list[float], inset: int = 3) -> int:
    """Height [px] of the dark text inside ``box`` (the rows holding near-black pixels)."""
    x0, y0, x1, y1 = (round(v) for v in box)
    inner = pixels[y0 + inset : y1 - inset, x0 + inset : x1 - inset]
    rows = np.flatnonzero((inner.max(axis=2) < 90).any(axis=1))
    return int(rows[-1] - rows[0] + 1) if len(rows) else 0


def overlap(a: list[float], b: list[float]) -> float:
    """Area [px²] two boxes share."""
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return max(w, 0.0) * max(h, 0.0)


def test_the_caption_is_the_labels_size_and_never_cut(drawn) -> None:
    for d in drawn:
        height = d["where"][3][1]
        page = d["page"]
        assert page["lines"], d["where"]
        joined = " ".join(line["text"] for line in page["lines"])
        assert joined == " ".join(d["step"].text.split()), d["where"]
        assert not any(line["cut"] for line in page["lines"]), d["where"]
        assert not any(b["cut"] for b in page["blocks"]), d["where"]
        for line in page["lines"]:
            # Capitals, digits and descenders of a line: at least 2 % of the picture's
            # height (the old caption was 1 %), within its line box.
            text = dark_rows(d["pixels"], line["box"], inset=0)
            assert 0.02 * height <= text <= line["box"][3] - line["box"][1], (
                d["where"],
                line["text"],
                text,
            )


def test_labels_are_the_slides_size_and_never_overlap(drawn) -> None:
    for d in drawn:
        height = d["where"][3][1]
        labels = d["page"]["labels"]
        marks = [lab for lab in labels if "mark" in lab["kind"]]
        texts = {lab["text"] for lab in labels}
        for mark in d["step"].marks:
            for text, _ in mark.labels:
                assert text in texts, (d["where"], text)
        for lab in marks:
            measured = dark_rows(d["pixels"], lab["box"], inset=4)
            assert 0.02 * height <= measured <= 0.035 * height, (
                d["where"],
                lab["text"],
                measured,
            )
        boxes = [lab["box"] for lab in labels]
        blocks = [b["box"] for b in d["page"]["blocks"]]
        for a, b in itertools.combinations(boxes, 2):
            assert overlap(a, b) < 1.0, (d["where"], a, b)
        for a in boxes:
            for b in blocks:
                assert overlap(a, b) < 1.0, (d["where"], a, b)
        for a, b in itertools.combinations(blocks, 2):
            assert overlap(a, b) < 1.0, (d["where"], a, b)


def test_the_picture_has_a_legend_and_dsb_its_table_and_flowchart(drawn) -> None:
    for d in drawn:
        page, step = d["page"], d["step"]
        assert (
            "added by this step" in page["legend"] or "earlier steps" in page["legend"]
        )
        if d["where"][1] != "dsb":
            assert page["flowOn"] == []
            continue
        box = step.kind.split(":", 1)[1]
        on = [" ".join(text.split()) for text in page["flowOn"]]  # lines joined
        assert on == [dict(FLOWCHART)[box]]
        for key, value in step.detail:
            assert key in page["table"] and value in page["table"], key


def test_both_sizes_draw_the_same_layout_scaled(drawn) -> None:
    by_step: dict[tuple[str, str, int], list[dict[str, Any]]] = {}
    for d in drawn:
        by_step.setdefault(d["where"][:3], []).append(d)
    for big, small in by_step.values():
        assert [lab["text"] for lab in big["page"]["labels"]] == [
            lab["text"] for lab in small["page"]["labels"]
        ]
        assert big["pixels"].shape == (1080, 1920, 3)
        assert small["pixels"].shape == (720, 1280, 3)


def _png(color: tuple[int, int, int]) -> bytes:
    out = io.BytesIO()
    Image.new("RGB", (64, 36), color).save(out, format="PNG")
    return out.getvalue()


def test_the_step_page_steps_and_plays_offline(browser, tmp_path) -> None:
    steps = [
        (_png(c), f"{k + 1}/3 <b>step</b> {k + 1}")
        for k, c in enumerate([(255, 0, 0), (0, 255, 0), (0, 0, 255)])
    ]
    path = tmp_path / "index.html"
    path.write_text(step_page("SVG <script>", steps, seconds=0.05), encoding="utf-8")
    shown_js = (
        "() => [...document.querySelectorAll('img.step')].findIndex(i => !i.hidden)"
    )
    context = browser.new_context()
    try:
        page = context.new_page()
        # Offline: anything but the file itself is refused.
        page.route(
            "**/*",
            lambda r: r.continue_() if r.request.url.startswith("file:") else r.abort(),
        )
        page.goto(path.as_uri())
        assert page.title() == "SVG <script>"
        assert page.evaluate(shown_js) == 0
        page.click("#next")
        assert page.evaluate(shown_js) == 1
        page.keyboard.press("End")
        assert page.evaluate(shown_js) == 2
        assert page.inner_text("#where") == "3 / 3"
        page.keyboard.press("Home")
        assert page.evaluate(shown_js) == 0
        alt = page.evaluate("() => document.querySelector('img.step').alt")
        assert alt == "1/3 <b>step</b> 1"  # shown as text, never as markup
        page.click("#play")
        page.wait_for_function(f"() => ({shown_js})() === 2", timeout=10_000)
        page.wait_for_function(
            "() => document.getElementById('play').textContent === 'Play'"
        )
    finally:
        context.close()
