"""Explain steps as slide pictures: the step's sentence as a caption, a legend of the marks.

A picture of an Explain step (:mod:`app.media.explain_pictures`) is laid out in the slide
style of :mod:`app.media.slides`, by a pure function of the scene, the step and the
picture's size (:func:`explain_layout`):

- the title: the method and the step number ("Simplified VG (9.5), step 3 of 8");
- the caption: the step's sentence at the labels' size (3 % of the picture's height),
  wrapped to the picture's width in the labels' monospaced font, so the box the layout
  reserves is the box the browser draws: never cut;
- an aside of the same roles' legend (bold green: added by this step, pale blue: earlier
  steps, ...), the step's table of facts (DSB: the O_i with d(r, O_i) + d(O_i, g)) and,
  for DSB, the flowchart of Fig. 9.15 with the current box highlighted; beside the scene
  or below it, whichever leaves the scene bigger, its font as large as fits;
- the labels: start and goal, the marks' labels (the O_i, the vertex under study...) and
  the obstacles' numbers, placed by :func:`app.ui.labels.place_labels` clear of each
  other, of the rings the marks draw and of the title, caption and aside.

The pictures of a sequence share a :class:`StepSet` (the roles, captions and table rows of
every step drawn), so the caption, legend and table keep their boxes, and a scene shown
whole keeps its camera, from one step to the next.

What the labels, table and flowchart say is what the step records
(:class:`planners.explain.Step`); nothing is derived here.
"""

from __future__ import annotations

__all__ = [
    "DRAW_EXPLAIN_JS",
    "ExplainSlide",
    "StepSet",
    "TextBlock",
    "explain_layout",
    "role_legend",
    "step_caption",
    "step_set",
    "step_title",
]

import dataclasses
import functools
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import planners
from app.explain.panel import METHOD_TITLES
from app.explain.view import ROLE_LOOKS, scene_names, step_requests
from app.media.camera import picture_bounds
from app.media.slides import (
    LegendRow,
    Slide,
    SlideOptions,
    floor_fit,
    font_px,
    label_requests,
    legend_size,
    line_scale,
    perspective_clear_of,
    project,
    slide_camera,
    title_strip,
)
from app.ui.labels import (
    CHAR_WIDTH,
    Box,
    LabelRequest,
    place_labels,
    wrap_text,
)
from app.ui.style import hex_color
from planners.explain import ROLES, Explanation, Step
from planners.explain.dsb import FLOWCHART
from planners.registry import PlannerSpec
from planners.scene import Scene

_LINE = 1.25
"""Line height of the caption, table and flowchart [em]."""
_PAD = 0.35
"""Padding inside the caption's, table's and flowchart's boxes [em]."""
_ASIDE_FONTS = (0.8, 0.72, 0.64, 0.56, 0.5)
"""Font sizes the aside tries, largest first, as shares of the label font."""
_KEEP = 0.6
"""The aside's font shrinks until the scene keeps this share of the scale it would have
without an aside (or the smallest font is reached)."""
_FLOW_CHARS = 26
"""Fewest characters a line of the flowchart's boxes holds."""
_FLOW_HEADING = "Fig. 9.15"


@dataclasses.dataclass(frozen=True)
class StepSet:
    """What the pictures of a sequence of steps share, so that each has the same layout."""

    roles: tuple[str, ...]
    """The roles of the marks drawn in any of the steps, in :data:`ROLES` order."""
    captions: tuple[str, ...]
    """Every step's caption."""
    table: tuple[int, int, int]
    """The most table rows of a step, and the widest name and value [characters]."""
    flowchart: bool
    """Whether the flowchart of Fig. 9.15 is drawn (DSB)."""


def step_set(
    explanation: Explanation,
    numbers: Iterable[int],
    options: SlideOptions = SlideOptions(),  # noqa: B008 - frozen
) -> StepSet:
    """Return what the pictures of steps ``numbers`` (0-based) of ``explanation`` share.

    ``options``: the pictures' (their captions depend on the title).

    Examples
    --------
    >>> from planners.explain import Explanation, Step, marks
    >>> ex = Explanation("svg", "t", (Step("k", "One.", marks(current=[[(0, 0), (1, 0)]])),
    ...                              Step("k", "Two.", marks(done=[[(0, 0), (1, 0)]]))))
    >>> step_set(ex, range(2)).roles
    ('done', 'current')
    """
    numbers = list(numbers)
    steps = [explanation.step(n) for n in numbers]
    used = {mark.role for step in steps for mark in step.marks}
    rows = [row for step in steps for row in step.detail]
    return StepSet(
        roles=tuple(role for role in ROLES if role in used),
        captions=tuple(step_caption(explanation, n, options) for n in numbers),
        table=(
            max((len(step.detail) for step in steps), default=0),
            max((len(k) for k, _ in rows), default=0),
            max((len(v) for _, v in rows), default=0),
        ),
        flowchart=explanation.method == "dsb",
    )


def step_title(explanation: Explanation, n: int, options: SlideOptions) -> str:
    """Return the title of step ``n``'s picture: the method (or ``options.title``) and the step.

    ``""`` as the title: no title (the caption then starts with the step number).

    Examples
    --------
    >>> from planners.explain import Explanation, Step
    >>> ex = Explanation("svg", "t", (Step("k", "a"), Step("k", "b")))
    >>> step_title(ex, 1, SlideOptions()), step_title(ex, 0, SlideOptions(title="Lecture 9"))
    ('Simplified VG (9.5), step 2 of 2', 'Lecture 9, step 1 of 2')
    """
    if options.title == "":
        return ""
    name = METHOD_TITLES[explanation.method] if options.title is None else options.title
    return f"{name}, step {n + 1} of {len(explanation.steps)}"


def step_caption(explanation: Explanation, n: int, options: SlideOptions) -> str:
    """Return step ``n``'s caption: its sentence, after the step number when untitled.

    Examples
    --------
    >>> from planners.explain import Explanation, Step
    >>> ex = Explanation("svg", "t", (Step("k", "a"), Step("k", "Step 1.")))
    >>> step_caption(ex, 1, SlideOptions()), step_caption(ex, 1, SlideOptions(title=""))
    ('Step 1.', '2/2 Step 1.')
    """
    text = explanation.step(n).text
    if options.title == "":
        return f"{n + 1}/{len(explanation.steps)} {text}"
    return text


def role_legend(
    roles: Iterable[str], shown: Iterable[str] | None = None
) -> tuple[LegendRow, ...]:
    """Return the legend rows of ``roles``: each role's colour, a line or a ring, its name.

    Roles drawn alike share a row ("added by this step / expanded obstacle"). A row
    none of whose roles is in ``shown`` (the step's own, when the legend lists a whole
    sequence's) is faint.

    Examples
    --------
    >>> [(r.swatches[0][1], r.text) for r in role_legend(["current", "focus"])]
    [('line', 'added by this step'), ('ring', 'under study')]
    >>> [(r.text, r.dim) for r in role_legend(["current", "result", "done"], ["done"])]
    [('added by this step / expanded obstacle', True), ('earlier steps', False)]
    """
    shown = None if shown is None else set(shown)
    rows: dict[tuple[str, str], tuple[list[str], bool]] = {}
    for role in roles:
        look = ROLE_LOOKS[role]
        kind = (
            "ring" if look.point_size > 0 else "line" if look.width >= 0.03 else "thin"
        )
        names, dim = rows.setdefault((hex_color(look.color), kind), ([], True))
        names.append(look.legend)
        here = shown is None or role in shown
        rows[hex_color(look.color), kind] = (names, dim and not here)
    return tuple(
        LegendRow((swatch,), " / ".join(names), dim)
        for swatch, (names, dim) in rows.items()
    )


@dataclasses.dataclass(frozen=True)
class TextBlock:
    """A box of monospaced text drawn over the picture (caption, table, flowchart)."""

    box: Box
    font: float
    """Font size [px]."""
    lines: tuple[str, ...] = ()
    """The caption's lines."""
    rows: tuple[tuple[str, str], ...] = ()
    """The table's rows: (name, value)."""
    boxes: tuple[tuple[tuple[str, ...], bool], ...] = ()
    """The flowchart's boxes: their lines, and whether it is the current one."""
    key_chars: int = 0
    """The table's name column [characters]."""

    def spec(self) -> dict[str, Any]:
        """Return the JSON object :data:`DRAW_EXPLAIN_JS` draws."""
        return {
            "box": [self.box.x0, self.box.y0, self.box.width, self.box.height],
            "font": self.font,
            "lines": list(self.lines),
            "rows": [list(r) for r in self.rows],
            "boxes": [{"lines": list(t), "on": on} for t, on in self.boxes],
            "keyChars": self.key_chars,
        }


@dataclasses.dataclass(frozen=True)
class ExplainSlide:
    """Everything a picture of one Explain step draws on top of the scene, in pixels."""

    slide: Slide
    """Camera, title, legend and labels, as a scene's slide picture has them."""
    caption: TextBlock
    table: TextBlock | None
    flowchart: TextBlock | None
    window: Box | None
    """The scene's part of the picture (top view): outside it the picture is white."""

    def overlay_spec(self) -> dict[str, Any]:
        """Return the JSON object :data:`DRAW_EXPLAIN_JS` draws."""
        return {
            "font": self.slide.font_px,
            "caption": self.caption.spec(),
            "table": self.table.spec() if self.table else None,
            "flowchart": self.flowchart.spec() if self.flowchart else None,
            "window": (
                [self.window.x0, self.window.y0, self.window.width, self.window.height]
                if self.window
                else None
            ),
            "heading": _FLOW_HEADING,
            "size": [self.slide.width, self.slide.height],
        }

    def text_boxes(self) -> tuple[Box, ...]:
        """Return the boxes of the title, caption, legend, table and flowchart."""
        boxes = [self.caption.box]
        if self.slide.title:
            boxes.append(self.slide.title[1])
        if self.slide.legend:
            boxes.append(self.slide.legend[1])
        boxes.extend(b.box for b in (self.table, self.flowchart) if b is not None)
        return tuple(boxes)


# --------------------------------------------------------------------------- layout


def explain_layout(
    scene: Scene,
    explanation: Explanation,
    n: int,
    width: int,
    height: int,
    *,
    plans: Mapping[str, Any],
    layers: Mapping[str, bool],
    bounds: tuple[float, float, float, float] | None = None,
    view: str = "top",
    options: SlideOptions = SlideOptions(),  # noqa: B008 - frozen
    steps: StepSet | None = None,
    registry: Mapping[str, PlannerSpec] = planners.REGISTRY,
) -> ExplainSlide:
    """Lay out the picture of step ``n`` (0-based) of ``explanation``, W x H pixels.

    Parameters
    ----------
    scene, plans, layers
        What the app shows (the plans' own layers are hidden while a method is
        explained): the start, the goal and the obstacles' numbers are labelled.
    explanation, n
        The step drawn.
    width, height
        Picture size [px].
    bounds
        The floor area to frame [m]; None: the scene's.
    view
        ``"top"`` or ``"perspective"``.
    options
        Title, legend and labels on or off (:class:`app.media.slides.SlideOptions`).
    steps
        What the pictures of a sequence share (:func:`step_set`); None: this step alone.
    registry
        The planners drawn.

    Returns
    -------
    ExplainSlide
    """
    steps = steps or step_set(explanation, [n], options)
    step = explanation.step(n)
    font = font_px(height)
    margin = round(font / 2)
    title = step_title(explanation, n, options)
    title_box, _, top = title_strip(title, options, font, width, margin)
    text = step_caption(explanation, n, options)
    caption_block = _caption(
        text, others=steps.captions, font=font, size=(width, height), margin=margin
    )
    bounds = picture_bounds(scene) if bounds is None else bounds
    full = Box(margin, top, width - margin, caption_block.box.y0 - margin)
    drawn = [mark.role for mark in step.marks]
    rows = role_legend(steps.roles, drawn) if options.legend else ()
    parts = _Parts(step, steps, rows, font, margin)
    aside = _place_aside(parts, bounds, full, view)
    reserved = [b for b in (title_box, caption_block.box, *aside.boxes()) if b]
    if view == "top":
        camera = slide_camera(bounds, width, height, aside.area)
        window = _window(camera, bounds, width, height)
    else:
        camera = perspective_clear_of(bounds, width, height, reserved)
        window = None
    slide = Slide(
        width=width,
        height=height,
        camera=camera,
        font_px=font,
        line_scale=line_scale(height),
        title=(title, title_box) if title_box is not None else None,
        legend=(rows, aside.legend, aside.columns) if aside.legend else None,
        legend_font=aside.font,
    )
    if options.labels:
        slide = _labelled(
            slide,
            scene,
            step,
            plans=plans,
            layers=layers,
            reserved=reserved,
            shown=window or Box(0, 0, width, height),
            registry=registry,
        )
    return ExplainSlide(slide, caption_block, aside.table, aside.flowchart, window)


def _caption(
    text: str,
    *,
    others: Sequence[str],
    font: float,
    size: tuple[int, int],
    margin: int,
) -> TextBlock:
    """Return the caption at the bottom, as tall as the sequence's longest caption needs."""
    width, height = size
    inner = width - 2 * margin - 2 * _PAD * font
    lines = wrap_text(text, inner, font)
    most = max(len(lines), _most_lines(tuple(others), inner, font))
    tall = (most * _LINE + 2 * _PAD) * font
    box = Box(margin, height - margin - tall, width - margin, height - margin)
    return TextBlock(box, font, lines=lines)


@functools.lru_cache(maxsize=8)
def _most_lines(captions: tuple[str, ...], inner: float, font: float) -> int:
    """Return the most lines any of ``captions`` takes (kept: every step of a sequence asks)."""
    return max((len(wrap_text(t, inner, font)) for t in set(captions)), default=1)


def _window(
    camera: Any, bounds: tuple[float, float, float, float], width: int, height: int
) -> Box:
    """Return the picture's box of ``bounds`` and the camera's margin (3 % of the larger side)."""
    xmin, ymin, xmax, ymax = bounds
    margin = 0.03 * max(xmax - xmin, ymax - ymin, 1e-3)
    corners = project(
        camera,
        width,
        height,
        [[xmin - margin, ymin - margin, 0.0], [xmax + margin, ymax + margin, 0.0]],
    )
    x0, x1 = sorted(corners[:, 0])
    y0, y1 = sorted(corners[:, 1])
    return Box(
        max(0.0, math.floor(x0)),
        max(0.0, math.floor(y0)),
        min(float(width), math.ceil(x1)),
        min(float(height), math.ceil(y1)),
    )


# --------------------------------------------------------------------------- aside


@dataclasses.dataclass(frozen=True)
class _Aside:
    """Where the legend, table and flowchart go, and the box left for the scene."""

    area: Box
    font: float | None
    legend: Box | None = None
    columns: int = 1
    table: TextBlock | None = None
    flowchart: TextBlock | None = None

    def boxes(self) -> tuple[Box, ...]:
        out = [self.legend] if self.legend else []
        out.extend(b.box for b in (self.table, self.flowchart) if b is not None)
        return tuple(out)


@dataclasses.dataclass(frozen=True)
class _Parts:
    """What the aside holds for one step, at one font."""

    step: Step
    steps: StepSet
    rows: tuple[LegendRow, ...]
    font: float
    """The aside's font [px] (the label font, for :func:`_place_aside`)."""
    margin: int

    def legend(self, columns: int = 1) -> tuple[float, float] | None:
        """Return the legend's size [px], or None without one."""
        return legend_size(self.rows, self.font, columns) if self.rows else None

    def table(self) -> tuple[float, float] | None:
        """Return the table's size [px] (the sequence's most rows), or None without one."""
        count, keys, values = self.steps.table
        if not count:
            return None
        width = (keys + 2 + values) * CHAR_WIDTH + 2 * _PAD
        return (width * self.font, (count * _LINE + 2 * _PAD) * self.font)

    def flow_width(self) -> float:
        """Return the flowchart's narrowest width [px] (0 without one)."""
        if not self.steps.flowchart:
            return 0.0
        return (_FLOW_CHARS * CHAR_WIDTH + 2 * _PAD + 2 * _BOX_PAD) * self.font

    def table_at(self, x: float, y: float) -> TextBlock | None:
        """Return the table with its top-left corner at (x, y)."""
        size = self.table()
        if size is None:
            return None
        box = Box(x, y, x + size[0], y + size[1])
        return TextBlock(
            box, self.font, rows=self.step.detail, key_chars=self.steps.table[1]
        )

    def flowchart_at(self, x: float, y: float, width: float) -> TextBlock | None:
        """Return the flowchart, ``width`` wide, with its top-left corner at (x, y)."""
        if not self.steps.flowchart:
            return None
        return _flowchart(self.step, (x, y), width, self.font)


def _place_aside(
    parts: _Parts,
    bounds: tuple[float, float, float, float],
    full: Box,
    view: str,
) -> _Aside:
    """Choose the aside's font and arrangement: the largest font that leaves the scene big.

    Each font of :data:`_ASIDE_FONTS` is tried, largest first, in every arrangement
    (:func:`_arrangements`); the best one at a font is taken once the scene keeps
    :data:`_KEEP` of the scale it has with no aside, else the best at the smallest font.
    With nothing that fits, the aside goes over the scene's top-right corner, as a
    slide's legend does.
    """
    if not parts.rows and not parts.steps.table[0] and not parts.steps.flowchart:
        return _Aside(full, None)
    alone = floor_fit(bounds, full)
    best: _Aside | None = None
    label_font = parts.font
    for share in _ASIDE_FONTS:
        found = list(
            _arrangements(
                dataclasses.replace(parts, font=share * label_font), full, view
            )
        )
        if not found:
            continue
        best = max(found, key=lambda a: floor_fit(bounds, a.area))
        if floor_fit(bounds, best.area) >= _KEEP * alone:
            return best
    if best is not None:
        return best
    smallest = dataclasses.replace(parts, font=_ASIDE_FONTS[-1] * label_font)
    return _column(smallest, full, beside=False)


def _arrangements(parts: _Parts, full: Box, view: str) -> Iterable[_Aside]:
    """Every way to put the aside that fits: one or two columns beside, a row below."""
    if view != "top":  # the perspective view keeps the picture; the aside goes on top
        aside = _column(parts, full, beside=False)
        if aside.area.width > 0 and _inside(aside, full):
            yield aside
        return
    for aside in (
        _column(parts, full, beside=True),
        _two_columns(parts, full),
        *(_below(parts, full, c) for c in range(1, max(1, len(parts.rows)) + 1)),
    ):
        if aside is not None and aside.area.width > 0 and aside.area.height > 0:
            if _inside(aside, full):
                yield aside


def _inside(aside: _Aside, full: Box) -> bool:
    return all(
        b.x0 >= full.x0 - 1e-6
        and b.y0 >= full.y0 - 1e-6
        and b.x1 <= full.x1 + 1e-6
        and b.y1 <= full.y1 + 1e-6
        for b in aside.boxes()
    )


def _column(parts: _Parts, full: Box, *, beside: bool) -> _Aside:
    """Put the legend, table and flowchart one under the other at the right of ``full``.

    ``beside``: the scene keeps the rest of the width; else the aside is over the scene.
    """
    sizes = [s for s in (parts.legend(), parts.table()) if s is not None]
    width = max([w for w, _ in sizes] + [parts.flow_width()])
    x = full.x1 - width
    legend_box, y = _legend_at(parts, x, full.y0)
    table = parts.table_at(x, y)
    if table is not None:
        y = table.box.y1 + parts.margin
    flow = parts.flowchart_at(x, y, width)
    area = Box(full.x0, full.y0, x - parts.margin, full.y1) if beside else full
    return _Aside(area, parts.font, legend_box, 1, table, flow)


def _legend_at(parts: _Parts, x: float, y: float) -> tuple[Box | None, float]:
    """Put the legend's top left at (x, y); return its box (None: no legend) and the y below."""
    legend = parts.legend()
    if legend is None:
        return None, y
    box = Box(x, y, x + legend[0], y + legend[1])
    return box, box.y1 + parts.margin


def _two_columns(parts: _Parts, full: Box) -> _Aside | None:
    """Put the legend and table in one column, the flowchart in the next, beside the scene."""
    if not parts.steps.flowchart:
        return None
    sizes = [s for s in (parts.legend(), parts.table()) if s is not None]
    width = max([w for w, _ in sizes], default=0.0)
    flow_x = full.x1 - parts.flow_width()
    x = flow_x - parts.margin - width
    legend_box, y = _legend_at(parts, x, full.y0)
    table = parts.table_at(x, y)
    flow = parts.flowchart_at(flow_x, full.y0, parts.flow_width())
    area = Box(full.x0, full.y0, x - parts.margin, full.y1)
    return _Aside(area, parts.font, legend_box, 1, table, flow)


def _below(parts: _Parts, full: Box, columns: int) -> _Aside | None:
    """Put the legend (in ``columns``), table and flowchart in a row below the scene."""
    legend, table = parts.legend(columns), parts.table()
    sizes = [s for s in (legend, table) if s is not None]
    used = sum(w + parts.margin for w, _ in sizes)
    flow_w = full.width - used
    if parts.steps.flowchart and flow_w < parts.flow_width():
        return None
    flow = parts.flowchart_at(0.0, 0.0, flow_w)
    tall = max([h for _, h in sizes] + ([flow.box.height] if flow else []))
    y = full.y1 - tall
    x = full.x0
    legend_box = None
    if legend is not None:
        legend_box = Box(x, y, x + legend[0], y + legend[1])
        x = legend_box.x1 + parts.margin
    table_block = parts.table_at(x, y)
    if table_block is not None:
        x = table_block.box.x1 + parts.margin
    flow = parts.flowchart_at(x, y, full.x1 - x)
    area = Box(full.x0, full.y0, full.x1, y - parts.margin)
    return _Aside(area, parts.font, legend_box, columns, table_block, flow)


_BOX_PAD = 0.2
"""Padding inside each box of the flowchart [em]."""
_ARROW = 0.9
"""Height of the arrow between two boxes of the flowchart [em]."""


def _flowchart(
    step: Step, at: tuple[float, float], width: float, fa: float
) -> TextBlock:
    """Fig. 9.15's boxes wrapped to ``width`` [px], the step's own box highlighted."""
    current = step.kind.split(":", 1)[1] if ":" in step.kind else None
    inner = width - 2 * _PAD * fa - 2 * _BOX_PAD * fa
    boxes = tuple(
        (wrap_text(text, inner, fa), key == current) for key, text in FLOWCHART
    )
    lines = sum(len(lines) for lines, _ in boxes)
    tall = (
        (1 + lines) * _LINE * fa  # the heading and the boxes' lines
        + len(boxes) * 2 * _BOX_PAD * fa  # each box's padding
        + (len(boxes) - 1) * _ARROW * fa  # the arrows between boxes
        + 2 * _PAD * fa
    )
    x0, y0 = at
    return TextBlock(Box(x0, y0, x0 + width, y0 + tall), fa, boxes=boxes)


# --------------------------------------------------------------------------- labels


def _labelled(
    slide: Slide,
    scene: Scene,
    step: Step,
    *,
    plans: Mapping[str, Any],
    layers: Mapping[str, bool],
    reserved: Sequence[Box],
    shown: Box,
    registry: Mapping[str, PlannerSpec],
) -> Slide:
    """Place the start and goal, the step's labels, then the obstacles' numbers.

    Only what lies in ``shown`` (the scene's window) is labelled: a DSB step frames the
    robot's neighbourhood, and a label at the picture's edge naming a point out of the
    picture would mislead.
    """
    size = (slide.width, slide.height)
    scene_requests, markers, colors = label_requests(
        scene, plans, layers, slide.camera, size, registry=registry
    )
    marks, rings = _mark_requests(step, slide, colors, scene_names(scene))
    requests = [
        *(r for r in scene_requests if r.kind == "marker"),
        *marks,
        *(r for r in scene_requests if r.kind != "marker"),
    ]
    placement = place_labels(
        [r for r in requests if shown.distance_to(r.anchor) == 0],
        font_px=slide.font_px,
        picture=size,
        markers=[*markers, *rings],
        reserved=reserved,
    )
    return dataclasses.replace(
        slide,
        labels=placement,
        markers=(*markers, *rings),
        label_colors=tuple(
            colors.get(id(p.request), "#222222") for p in placement.placed
        ),
    )


def _mark_requests(
    step: Step,
    slide: Slide,
    colors: dict[int, str],
    named: Sequence[tuple[str, Sequence[float]]],
) -> tuple[list[LabelRequest], list[Box]]:
    """Return the step's labels in pixels, in their roles' colours, and the rings' boxes.

    A label the scene shows already (``named``: the start and the goal) is left out.
    """
    requests, rings = step_requests(step, named)
    out = []
    for role, request in requests:
        z = ROLE_LOOKS[role].height
        anchor = _pixel(slide, request.at, z)
        ring = abs(
            _pixel(slide, (request.at[0] + request.clearance, request.at[1]), z)[0]
            - anchor[0]
        )
        label = LabelRequest(request.text, anchor, kind="mark", clearance=ring + 2)
        colors[id(label)] = hex_color(ROLE_LOOKS[role].color)
        out.append(label)
    boxes = []
    for x0, y0, x1, y1 in rings:
        (a, b), (c, d) = _pixel(slide, (x0, y0), 0.09), _pixel(slide, (x1, y1), 0.09)
        boxes.append(Box(min(a, c), min(b, d), max(a, c), max(b, d)))
    return out, boxes


def _pixel(slide: Slide, at: tuple[float, float], z: float) -> tuple[float, float]:
    """Return the point at height ``z`` above the floor point ``at``, in picture pixels."""
    px = project(slide.camera, slide.width, slide.height, [[at[0], at[1], z]])[0]
    return (float(px[0]), float(px[1]))


# --------------------------------------------------------------------------- drawing

DRAW_EXPLAIN_JS = """(spec) => {
    const root = document.getElementById('planner-slide');
    if (!root) return false;
    const f = spec.font;
    const border = Math.max(1, Math.round(f / 16));
    const place = (el, b) => {
        el.style.position = 'absolute';
        el.style.left = b[0] + 'px'; el.style.top = b[1] + 'px';
        el.style.width = b[2] + 'px'; el.style.height = b[3] + 'px';
        el.style.boxSizing = 'border-box';
        root.appendChild(el);
        return el;
    };
    if (spec.window) {  // white outside the scene's window, a frame around it
        const [x, y, w, h] = spec.window;
        const [W, H] = spec.size;  // the picture's (the page is resized last)
        const under = [];
        for (const b of [[0, 0, W, y], [0, y + h, W, H - y - h], [0, y, x, h],
                         [x + w, y, W - x - w, h]]) {
            if (b[2] <= 0 || b[3] <= 0) continue;
            const mat = document.createElement('div');
            mat.className = 'planner-mat';
            mat.style.background = '#fff';
            under.push(place(mat, b));
        }
        const frame = document.createElement('div');
        frame.className = 'planner-window';
        frame.style.border = border + 'px solid #444';
        under.push(place(frame, [x - border, y - border, w + 2 * border, h + 2 * border]));
        root.prepend(...under);  // under the leader lines, labels, title and legend
    }
    const mono = 'font-family:"DejaVu Sans Mono",monospace;color:#111;';
    const panel = (b, cls) => {
        const el = document.createElement('div');
        el.className = cls;
        el.style.cssText = mono + 'background:rgba(255,255,255,0.94);border:' + border +
            'px solid #444;border-radius:' + (0.3 * b.font) + 'px;padding:' +
            (0.35 * b.font - border) + 'px;font-size:' + b.font + 'px;line-height:' +
            (1.25 * b.font) + 'px;overflow:hidden;';
        return el;
    };
    const c = spec.caption;
    const cap = panel(c, 'planner-caption');
    for (const line of c.lines) {
        const l = document.createElement('div');
        l.className = 'planner-caption-line';
        l.style.whiteSpace = 'pre';
        l.textContent = line;
        cap.appendChild(l);
    }
    place(cap, c.box);
    if (spec.table && spec.table.rows.length) {  // a step without facts: room kept
        const t = spec.table;
        const el = panel(t, 'planner-table');
        for (const [k, v] of t.rows) {
            const r = document.createElement('div');
            r.style.whiteSpace = 'pre';
            r.textContent = k.padEnd(t.keyChars + 2, ' ') + v;
            el.appendChild(r);
        }
        place(el, t.box);
    }
    if (spec.flowchart) {
        const g = spec.flowchart;
        const el = panel(g, 'planner-flowchart');
        const head = document.createElement('div');
        head.style.fontWeight = 'bold';
        head.style.whiteSpace = 'pre';
        head.textContent = spec.heading;
        el.appendChild(head);
        g.boxes.forEach((b, i) => {
            if (i > 0) {
                const a = document.createElement('div');
                a.style.cssText = 'text-align:center;color:#666;line-height:' +
                    (0.9 * g.font) + 'px;height:' + (0.9 * g.font) + 'px;';
                a.textContent = '\\u2193';
                el.appendChild(a);
            }
            const box = document.createElement('div');
            box.className = 'planner-flow-box' + (b.on ? ' planner-flow-on' : '');
            box.style.cssText = 'white-space:pre;box-sizing:border-box;border:' + border +
                'px solid #333;border-radius:' + (0.2 * g.font) + 'px;padding:' +
                (0.2 * g.font - border) + 'px ' + (0.2 * g.font - border) + 'px;' +
                (b.on ? 'background:#E69F00;font-weight:bold;' : 'background:#f4f4f4;');
            box.textContent = b.lines.join('\\n');
            el.appendChild(box);
        });
        place(el, g.box);
    }
    return document.fonts.ready.then(() => true);
}"""
"""Draw an :meth:`ExplainSlide.overlay_spec` into the slide's overlay (after
:data:`app.media.slides.DRAW_OVERLAY_JS`): the white mat around the scene's window, the
caption, the table and the flowchart."""
