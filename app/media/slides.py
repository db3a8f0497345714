"""Pictures for slides and papers: sizes relative to the picture, labels that never collide.

A picture of the planner for a lecture must read from the back of the hall (1920 x 1080 on
a projector) and in a two-column paper (800 x 500). :func:`layout` decides everything that
depends on the picture's size, as a pure function of the scene, the planners' results and
the size:

- the font size, a fixed share of the picture's height (:func:`font_px`), and the width of
  the lines drawn in screen pixels (:func:`line_scale`);
- a camera that leaves room for a title strip at the top and, when the picture is wider
  than the scene, a legend column on the right (:func:`slide_camera`);
- the labels (obstacle numbers, start and goal, the trace planners' events H, D, L, M of
  Fig. 9.19), in pixels, placed by :func:`app.ui.labels.place_labels` so that none overlaps
  another, a marker, the title or the legend.

What it returns (:class:`Slide`) is drawn over the 3-D canvas by :data:`DRAW_OVERLAY_JS`,
as HTML boxes with exactly the sizes the placer reserved. The labels say what the planners
recorded (their events, by :func:`app.ui.view.event_labels`); nothing is derived here.
Colours are the documented colour-blind-safe set of :mod:`app.ui.style`.
"""

from __future__ import annotations

__all__ = [
    "DRAW_OVERLAY_JS",
    "LEGEND_FONT",
    "LegendRow",
    "Slide",
    "SlideOptions",
    "floor_fit",
    "font_px",
    "label_requests",
    "layout",
    "legend_rows",
    "legend_size",
    "line_scale",
    "perspective_clear_of",
    "project",
    "relabel",
    "slide_camera",
    "title_strip",
]

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
from shapely import Polygon

import planners
from app.media.camera import TOP_FOV, CameraPose, frame_camera, picture_bounds
from app.media.slide_options import SlideOptions
from app.ui.labels import (
    FONT_SHARE,
    Box,
    LabelRequest,
    Placement,
    label_size,
    place_labels,
)
from app.ui.style import COLORS, HEIGHTS, PURPLE, hex_color, planner_look
from app.ui.view import (
    EVENT_CROSS,
    MAX_NUMBERED_OBSTACLES,
    event_labels,
    marker_size,
)
from planners.registry import PlannerSpec
from planners.scene import Scene

MOVING_ROUTE = PURPLE
"""Colour of a moving obstacle's dashed route, as :mod:`app.live` draws it."""
_MOVING_TEXT = "moving obstacle's route"
_MIN_FONT = 11.0
LEGEND_FONT = 0.8
"""The legend's font size, as a share of the label font."""
_TITLE_FONT = 1.2
_TEXT_WIDTH = 0.62  # [em] per character of DejaVu Sans, an upper estimate
_BOLD_WIDTH = 0.72  # [em] per character of DejaVu Sans Bold ("m" alone is 1.04)


@dataclasses.dataclass(frozen=True)
class LegendRow:
    """One row of the legend: coloured swatches and what they stand for."""

    swatches: tuple[tuple[str, str], ...]
    """(``#rrggbb``, ``"line"`` | ``"thin"`` | ``"dashed"`` | ``"box"`` | ``"fill"`` |
    ``"disk"`` | ``"ring"``) pairs; ``"fill"`` is a translucent box (the expanded
    obstacles are drawn at 40 % opacity), ``"dashed"`` a thin dashed line as wide as two
    swatches, ``"ring"`` a circle's outline (a point ringed)."""
    text: str
    dim: bool = False
    """Drawn faint: what a sequence of pictures shows, but not this one (an Explain
    step's legend lists the roles of every step of the sequence)."""


@dataclasses.dataclass(frozen=True)
class Slide:
    """Everything a picture of one size draws on top of the scene, in pixels."""

    width: int
    height: int
    camera: CameraPose
    font_px: float
    line_scale: float
    title: tuple[str, Box] | None
    legend: tuple[tuple[LegendRow, ...], Box, int] | None
    """The rows, the box and the number of columns of the legend."""
    labels: Placement = dataclasses.field(default_factory=lambda: Placement((), ()))
    """The placed labels; none until the scene's are placed."""
    label_colors: tuple[str, ...] = ()
    """Border colour of each placed label (an event's planner, black otherwise)."""
    markers: tuple[Box, ...] = ()
    """The boxes no label covers: the start and goal disks, the events' crosses."""
    stamp: Box | None = None
    """Where a video frame's time goes (:attr:`SlideOptions.time_stamp`), else None."""
    legend_font: float | None = None
    """The legend's font size [px]; None: :data:`LEGEND_FONT` of the label font."""

    def overlay_spec(self) -> dict[str, Any]:
        """Return the JSON object :data:`DRAW_OVERLAY_JS` draws."""
        return {
            "font": self.font_px,
            "labels": [
                {
                    "text": p.request.text,
                    "box": _box_list(p.box),
                    "leader": [*p.leader[0], *p.leader[1]] if p.leader else None,
                    "color": color,
                    "kind": p.request.kind,
                }
                for p, color in zip(self.labels.placed, self.label_colors, strict=True)
            ],
            "title": (
                {"text": self.title[0], "box": _box_list(self.title[1])}
                if self.title
                else None
            ),
            "stamp": _box_list(self.stamp) if self.stamp else None,
            "legend": (
                {
                    "rows": [
                        {
                            "swatches": [list(s) for s in row.swatches],
                            "text": row.text,
                            "dim": row.dim,
                        }
                        for row in self.legend[0]
                    ],
                    "box": _box_list(self.legend[1]),
                    "columns": self.legend[2],
                    "font": self.legend_font or self.font_px * LEGEND_FONT,
                }
                if self.legend
                else None
            ),
        }


def _box_list(box: Box) -> list[float]:
    return [box.x0, box.y0, box.width, box.height]


# --------------------------------------------------------------------------- sizes


def font_px(height: int) -> float:
    """Label font size [px] of a picture ``height`` pixels tall.

    Examples
    --------
    >>> font_px(1080), font_px(500)
    (32.0, 15.0)
    """
    return float(max(_MIN_FONT, round(FONT_SHARE * height)))


def line_scale(height: int) -> float:
    """Factor for lines drawn in screen pixels (graph edges): 1 at 720 px, never below 0.75.

    Examples
    --------
    >>> line_scale(1080), line_scale(500)
    (1.5, 0.75)
    """
    return max(0.75, height / 720)


# --------------------------------------------------------------------------- camera


def project(
    pose: CameraPose, width: int, height: int, points: npt.ArrayLike
) -> npt.NDArray[np.float64]:
    """Project world points (N, 3) [m] to picture pixels (N, 2) as three.js does.

    A perspective camera with vertical field of view ``pose.fov``, looking from
    ``pose.position`` at ``pose.look_at`` with ``pose.up`` up; pixels have x to the right
    and y down, (0, 0) at the top-left corner.

    Examples
    --------
    >>> pose = frame_camera((0.0, 0.0, 10.0, 8.0), 1000, 800)
    >>> project(pose, 1000, 800, [[5.0, 4.0, 0.0]]).round(6).tolist()
    [[500.0, 400.0]]
    """
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    eye = np.asarray(pose.position, dtype=np.float64)
    forward = np.subtract(pose.look_at, eye)
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, pose.up)
    right = right / np.linalg.norm(right)
    up = np.cross(right, forward)
    rel = p - eye
    depth = rel @ forward
    focal = (height / 2) / math.tan(pose.fov / 2)
    x = width / 2 + focal * (rel @ right) / depth
    y = height / 2 - focal * (rel @ up) / depth
    return np.stack([x, y], axis=1)


def slide_camera(
    bounds: tuple[float, float, float, float], width: int, height: int, area: Box
) -> CameraPose:
    """Place a top-view camera that shows ``bounds`` whole inside the pixel box ``area``.

    The scene is scaled to fit ``area`` (with a margin of 3 % of its larger side) and
    centred in it; the rest of the picture is free for the title and the legend.

    Examples
    --------
    >>> pose = slide_camera((0.0, 0.0, 10.0, 8.0), 1000, 800, Box(0, 100, 1000, 800))
    >>> project(pose, 1000, 800, [[5.0, 4.0, 0.0]]).round(6).tolist()
    [[500.0, 450.0]]
    """
    xmin, ymin, xmax, ymax = bounds
    margin = 0.03 * max(xmax - xmin, ymax - ymin, 1e-3)
    scale = min(
        area.width / (xmax - xmin + 2 * margin),
        area.height / (ymax - ymin + 2 * margin),
    )  # [px/m] on the floor
    sx, sy = (xmin + xmax) / 2, (ymin + ymax) / 2
    acx, acy = (area.x0 + area.x1) / 2, (area.y0 + area.y1) / 2
    cx = sx - (acx - width / 2) / scale
    cy = sy + (acy - height / 2) / scale
    distance = (height / 2) / (scale * math.tan(TOP_FOV / 2))
    return CameraPose(
        position=(cx, cy, distance),
        look_at=(cx, cy, 0.0),
        up=(0.0, 1.0, 0.0),
        fov=TOP_FOV,
        near=distance / 10,
        far=distance * 10,
    )


# --------------------------------------------------------------------------- legend


def legend_rows(
    plans: Mapping[str, Any],
    layers: Mapping[str, bool],
    registry: Mapping[str, PlannerSpec] = planners.REGISTRY,
    *,
    moving: bool = False,
) -> tuple[LegendRow, ...]:
    """Return the legend rows of what the picture shows: obstacles, planners with a path, markers.

    ``moving``: the scene has moving obstacles, whose routes (each one's centroid's
    cycle) :class:`app.live.MotionPaths` draws dashed in reddish purple.

    Examples
    --------
    >>> [row.text for row in legend_rows({}, {})]
    ['obstacle', 'expanded obstacle', 'start / goal']
    >>> [row.text for row in legend_rows({}, {}, moving=True)][1]
    "moving obstacle's route"
    """
    rows = [LegendRow(((hex_color(COLORS["obstacle"]), "box"),), "obstacle")]
    if moving:
        rows.append(LegendRow(((hex_color(MOVING_ROUTE), "dashed"),), _MOVING_TEXT))
    if layers.get("expanded", True):
        rows.append(
            LegendRow(((hex_color(COLORS["expanded"]), "fill"),), "expanded obstacle")
        )
    events = False
    for name, spec in registry.items():
        result = plans.get(name)
        if result is None or not layers.get(f"{name}_path", True):
            continue
        path = getattr(result, "path", None)
        if path is None or len(path) < 2:
            continue
        look = planner_look(name, registry)
        if spec.kind == "graph":
            rows.append(
                LegendRow(
                    (
                        (hex_color(look.edges or look.path), "thin"),
                        (hex_color(look.path), "line"),
                    ),
                    f"{name.upper()} graph / path",
                )
            )
        else:
            events = events or bool(getattr(result, "events", ()))
            rows.append(
                LegendRow(
                    (
                        (hex_color(look.path), "line"),
                        (hex_color(look.follow or look.path), "line"),
                    ),
                    f"{name.upper()} to goal / along border",
                )
            )
    rows.append(
        LegendRow(
            ((hex_color(COLORS["start"]), "disk"), (hex_color(COLORS["goal"]), "disk")),
            "start / goal",
        )
    )
    if events:
        rows.append(LegendRow((), "H hit, L leave, M minimum, D goal free"))
    return tuple(rows)


def legend_size(
    rows: Sequence[LegendRow], font: float, columns: int = 1
) -> tuple[float, float]:
    """Width and height [px] of the legend box (:data:`DRAW_OVERLAY_JS` draws it so).

    With several columns, rows fill the first column top to bottom, then the next.
    """
    per_column = math.ceil(len(rows) / columns)
    return (
        math.ceil(columns * _column_width(rows, font) + 2 * _LEGEND_PAD * font),
        math.ceil(per_column * _ROW_EM * font + 2 * _LEGEND_PAD * font),
    )


def _column_width(rows: Sequence[LegendRow], font: float) -> float:
    text = max((len(r.text) for r in rows), default=0) * _TEXT_WIDTH * font
    return 2 * _SWATCH_EM * font + 0.5 * font + text + _COLUMN_GAP * font


_SWATCH_EM = 1.6  # width of one swatch [em]
_COLUMN_GAP = 1.0  # between legend columns [em]
_ROW_EM = 1.45  # legend row height [em]
_LEGEND_PAD = 0.6  # [em]


# --------------------------------------------------------------------------- layout


def layout(
    scene: Scene,
    plans: Mapping[str, Any],
    layers: Mapping[str, bool],
    width: int,
    height: int,
    *,
    view: str = "top",
    options: SlideOptions = SlideOptions(),  # noqa: B008 - frozen
    registry: Mapping[str, PlannerSpec] = planners.REGISTRY,
    bounds: tuple[float, float, float, float] | None = None,
) -> Slide:
    """Decide the camera, the title, the legend and the labels of a W x H picture.

    Parameters
    ----------
    scene, plans, layers
        What the app shows: the scene, the planners' results, the layer switches.
    width, height
        Picture size [px].
    view
        ``"top"`` (the scene fits beside the title and the legend) or ``"perspective"``
        (the camera of :func:`app.media.camera.frame_camera`; title and legend over it).
    options
        Legend, title and labels on or off.
    registry
        The planners drawn.
    bounds
        The floor area to frame (xmin, ymin, xmax, ymax) [m]; None: the scene's
        (:func:`app.media.camera.picture_bounds`). A video whose obstacles move frames the
        area they cover over the whole run, so that every frame has the same camera.

    Returns
    -------
    Slide
    """
    font = font_px(height)
    margin = round(font / 2)
    title_text = scene.name or "" if options.title is None else options.title
    title_box, stamp_box, top = title_strip(title_text, options, font, width, margin)
    rows = (
        legend_rows(plans, layers, registry, moving=bool(scene.motions))
        if options.legend
        else ()
    )
    legend_font = font * LEGEND_FONT
    bounds = picture_bounds(scene) if bounds is None else bounds
    full = Box(margin, top, width - margin, height - margin)
    legend_box, columns, area = _place_legend(
        rows, legend_font, bounds, full, margin=margin, view=view
    )
    reserved = [b for b in (title_box, stamp_box, legend_box) if b is not None]
    if view == "top":
        camera = slide_camera(bounds, width, height, area)
    else:
        camera = perspective_clear_of(bounds, width, height, reserved)
    slide = Slide(
        width=width,
        height=height,
        camera=camera,
        font_px=font,
        line_scale=line_scale(height),
        title=(title_text, title_box) if title_box is not None else None,
        legend=(rows, legend_box, columns) if legend_box is not None else None,
        stamp=stamp_box,
    )
    return relabel(slide, scene, plans, layers, options=options, registry=registry)


def relabel(
    slide: Slide,
    scene: Scene,
    plans: Mapping[str, Any],
    layers: Mapping[str, bool],
    *,
    options: SlideOptions = SlideOptions(),  # noqa: B008 - frozen
    registry: Mapping[str, PlannerSpec] = planners.REGISTRY,
) -> Slide:
    """Place the labels of ``scene`` and ``plans`` on ``slide``'s picture.

    The camera, title, legend and time stamp box stay: a video whose obstacles move
    (:mod:`app.media.record_live`) keeps one layout and places each frame's labels (the moving
    obstacle's number, the events so far) anew. :func:`layout` places its labels so.
    """
    size = (slide.width, slide.height)
    reserved = [
        b
        for b in (
            slide.title[1] if slide.title else None,
            slide.stamp,
            slide.legend[1] if slide.legend else None,
        )
        if b is not None
    ]
    requests, markers, colors = (
        label_requests(scene, plans, layers, slide.camera, size, registry=registry)
        if options.labels
        else ([], [], {})
    )
    placement = place_labels(
        requests,
        font_px=slide.font_px,
        picture=size,
        markers=markers,
        reserved=reserved,
    )
    return dataclasses.replace(
        slide,
        labels=placement,
        markers=tuple(markers),
        label_colors=tuple(
            colors.get(id(p.request), "#222222") for p in placement.placed
        ),
    )


_STAMP_TEMPLATE = "t = 000.0 s"
"""The widest time stamp the box is sized for (runs under 1000 s)."""


def _bold_width(text: str) -> float:
    """Estimate the width [em] of ``text`` in DejaVu Sans Bold, from above.

    Examples
    --------
    >>> _bold_width("maze") > 2.97  # its width, measured
    True
    """
    wide = sum(c in "mwMW" for c in text)
    return len(text) * _BOLD_WIDTH + wide * 0.35


def title_strip(
    title: str, options: SlideOptions, font: float, width: int, margin: int
) -> tuple[Box | None, Box | None, int]:
    """Place the title (left) and the time stamp (right) in the top strip.

    Returns their boxes (None when absent) and the top [px] of what goes below.
    """
    strip = 1.3 * font * _TITLE_FONT  # the title's line height
    stamp = None
    right = width - margin
    if options.time_stamp:
        w = len(_STAMP_TEMPLATE) * _TEXT_WIDTH * font + font
        stamp = Box(right - w, margin, right, margin + strip)
        right = math.floor(stamp.x0 - margin)
    box = None
    if title:
        w = min(right - margin, _bold_width(title) * font * _TITLE_FONT)
        box = Box(margin, margin, margin + max(w, 0.0), margin + strip)
    top = math.ceil(margin + strip + margin) if box or stamp else margin
    return box, stamp, top


def _place_legend(
    rows: Sequence[LegendRow],
    font: float,
    bounds: tuple[float, float, float, float],
    full: Box,
    *,
    margin: float,
    view: str,
) -> tuple[Box | None, int, Box]:
    """Put the legend beside the scene or below it, whichever leaves the scene bigger.

    Returns the legend's box (None without rows), its number of columns and the box
    left for the scene. The perspective view keeps the whole picture for the scene and
    puts the legend over its top-right corner.
    """
    if not rows:
        return None, 1, full
    lw, lh = legend_size(rows, font)
    if view != "top":
        return Box(full.x1 - lw, full.y0, full.x1, full.y0 + lh), 1, full
    side = Box(full.x0, full.y0, full.x1 - lw - margin, full.y1)
    choices = [
        (
            floor_fit(bounds, side),
            side,
            Box(side.x1 + margin, full.y0, full.x1, full.y0 + lh),
            1,
        )
    ]
    for columns in range(len(rows), 0, -1):
        bw, bh = legend_size(rows, font, columns)
        if bw <= full.width:
            below = Box(full.x0, full.y0, full.x1, full.y1 - bh - margin)
            legend = Box(full.x0, below.y1 + margin, full.x0 + bw, full.y1)
            choices.append((floor_fit(bounds, below), below, legend, columns))
            break
    fit, area, legend, columns = max(choices, key=lambda c: c[0])
    if fit <= 0:  # no room beside or below: over the scene's top-right corner
        return Box(full.x1 - lw, full.y0, full.x1, full.y0 + lh), 1, full
    return legend, columns, area


def perspective_clear_of(
    bounds: tuple[float, float, float, float],
    width: int,
    height: int,
    reserved: Sequence[Box],
) -> CameraPose:
    """Frame the perspective view so the scene stays clear of the title and the legend.

    The framed box grows towards +x and +y (the far right of the picture, where the
    legend and the title sit) until the scene's outline, walls included, no longer
    meets them; at most eight steps, then the last framing is kept.
    """
    xmin, ymin, xmax, ymax = bounds
    grow_x = grow_y = 0.0
    step = 0.08 * max(xmax - xmin, ymax - ymin)
    camera = frame_camera(bounds, width, height, "perspective")
    for _ in range(8):
        camera = frame_camera(
            (xmin, ymin, xmax + grow_x, ymax + grow_y), width, height, "perspective"
        )
        corners = [
            (x, y, z) for x in (xmin, xmax) for y in (ymin, ymax) for z in (0.0, 0.5)
        ]
        outline = shapely.MultiPoint(
            project(camera, width, height, corners).tolist()
        ).convex_hull
        hits = [
            b
            for b in reserved
            if outline.intersects(shapely.box(b.x0, b.y0, b.x1, b.y1))
        ]
        if not hits:
            break
        grow_x += step
        grow_y += step * any(b.y1 < height / 4 for b in hits)
    return camera


def floor_fit(bounds: tuple[float, float, float, float], area: Box) -> float:
    """Pixels per metre when ``bounds`` fill ``area``."""
    xmin, ymin, xmax, ymax = bounds
    if area.width <= 0 or area.height <= 0:
        return 0.0
    return min(
        area.width / max(xmax - xmin, 1e-9), area.height / max(ymax - ymin, 1e-9)
    )


def label_requests(
    scene: Scene,
    plans: Mapping[str, Any],
    layers: Mapping[str, bool],
    camera: CameraPose,
    picture: tuple[int, int],
    *,
    registry: Mapping[str, PlannerSpec],
) -> tuple[list[LabelRequest], list[Box], dict[int, str]]:
    """Labels in placement order, the marker boxes they avoid, event label colours."""
    width, height = picture

    def at(x: float, y: float, z: float) -> tuple[float, float]:
        px = project(camera, width, height, [[x, y, z]])[0]
        return (float(px[0]), float(px[1]))

    def box_around(x: float, y: float, z: float, half: float) -> Box:
        corners = project(
            camera,
            width,
            height,
            [[x - half, y - half, z], [x + half, y + half, z]],
        )
        x0, x1 = sorted(corners[:, 0])
        y0, y1 = sorted(corners[:, 1])
        return Box(float(x0), float(y0), float(x1), float(y1))

    requests: list[LabelRequest] = []
    markers: list[Box] = []
    colors: dict[int, str] = {}
    radius = marker_size(float(scene.robot.radius))
    for name, xy in (("start", scene.start), ("goal", scene.goal)):
        disk = box_around(xy[0], xy[1], HEIGHTS["marker"], radius)
        markers.append(disk)
        requests.append(
            LabelRequest(
                name,
                at(xy[0], xy[1], HEIGHTS["marker"]),
                kind="marker",
                clearance=disk.width / 2 + 2,
            )
        )
    # A floor plan's or a map's hundreds of obstacles go unnumbered, as in the app.
    numbered = len(scene.obstacles) <= MAX_NUMBERED_OBSTACLES
    if layers.get("obstacles", True) and numbered:
        top = HEIGHTS["obstacle"]
        font = font_px(height)
        for i, obstacle in enumerate(scene.obstacles):
            if not _holds_its_number(obstacle, str(i + 1), font, box_around):
                continue  # a speck on the picture: its number would hide it
            point = obstacle.representative_point()
            requests.append(
                LabelRequest(
                    str(i + 1), at(point.x, point.y, top), centred=True, kind="obstacle"
                )
            )
    for name, spec in registry.items():
        result = plans.get(name)
        if (
            spec.kind != "trace"
            or result is None
            or not layers.get(f"{name}_path", True)
        ):
            continue
        color = hex_color(planner_look(name, registry).path)
        z = planner_look(name, registry).path_height
        for text, (x, y) in event_labels(result):
            cross = box_around(x, y, z, EVENT_CROSS)
            markers.append(cross)
            request = LabelRequest(
                text, at(x, y, z), kind="event", clearance=cross.width / 2 + 2
            )
            colors[id(request)] = color
            requests.append(request)
    # Start and goal first (they sit beside their disk), then the numbers, then events.
    return requests, markers, colors


def _holds_its_number(
    obstacle: Polygon,
    text: str,
    font: float,
    box_around: Callable[[float, float, float, float], Box],
) -> bool:
    """Tell whether an obstacle spans at least its number's height on the picture.

    A room of 500 small triangles would get 500 numbers with leader lines across the
    scene; a number is drawn only where its obstacle (its longer side on the picture)
    is at least as long as the number's box is tall.
    """
    x0, y0, x1, y1 = obstacle.bounds
    half = max(x1 - x0, y1 - y0) / 2
    seen = box_around((x0 + x1) / 2, (y0 + y1) / 2, HEIGHTS["obstacle"], half)
    return max(seen.width, seen.height) >= min(label_size(text, font))


# --------------------------------------------------------------------------- drawing

DRAW_OVERLAY_JS = """(spec) => {
    const old = document.getElementById('planner-slide');
    if (old) old.remove();
    const root = document.createElement('div');
    root.id = 'planner-slide';
    root.style.cssText = 'position:fixed;left:0;top:0;width:100vw;height:100vh;' +
        'pointer-events:none;z-index:100000;visibility:visible;';
    const f = spec.font;
    const border = Math.max(1, Math.round(f / 16));
    const ns = 'http://www.w3.org/2000/svg';
    const svg = document.createElementNS(ns, 'svg');
    svg.setAttribute('width', '100%'); svg.setAttribute('height', '100%');
    svg.style.cssText = 'position:absolute;left:0;top:0;';
    root.appendChild(svg);
    const place = (el, b) => {
        el.style.position = 'absolute';
        el.style.left = b[0] + 'px'; el.style.top = b[1] + 'px';
        el.style.width = b[2] + 'px'; el.style.height = b[3] + 'px';
        el.style.boxSizing = 'border-box';
        root.appendChild(el);
        return el;
    };
    for (const l of spec.labels) {
        if (l.leader) {
            const line = document.createElementNS(ns, 'line');
            line.setAttribute('x1', l.leader[0]); line.setAttribute('y1', l.leader[1]);
            line.setAttribute('x2', l.leader[2]); line.setAttribute('y2', l.leader[3]);
            line.setAttribute('stroke', '#222'); line.setAttribute('stroke-width', border);
            svg.appendChild(line);
        }
        const el = document.createElement('div');
        el.className = 'planner-label planner-label-' + l.kind;
        el.textContent = l.text;
        el.style.cssText = 'font-family:"DejaVu Sans Mono",monospace;font-weight:bold;' +
            'white-space:pre;text-align:center;color:#111;background:rgba(255,255,255,0.92);' +
            'border-radius:' + (f * 0.2) + 'px;font-size:' + f + 'px;line-height:' +
            (1.2 * f) + 'px;padding:' + (0.3 * f - border) + 'px 0;' +
            'border:' + border + 'px solid ' + l.color + ';';
        if (l.kind === 'event') el.style.borderLeftWidth = (3 * border) + 'px';
        place(el, l.box);
    }
    if (spec.title) {
        const el = document.createElement('div');
        el.className = 'planner-title';
        el.textContent = spec.title.text;
        el.style.cssText = 'font-family:"DejaVu Sans",sans-serif;font-weight:bold;' +
            'white-space:nowrap;overflow:hidden;color:#111;font-size:' + (1.2 * f) + 'px;' +
            'line-height:' + (1.3 * 1.2 * f) + 'px;';
        place(el, spec.title.box);
    }
    if (spec.stamp) {
        const el = document.createElement('div');
        el.id = 'planner-stamp';
        el.className = 'planner-stamp';
        el.style.cssText = 'font-family:"DejaVu Sans Mono",monospace;text-align:right;' +
            'white-space:nowrap;color:#111;font-size:' + f + 'px;line-height:' +
            (1.3 * 1.2 * f) + 'px;';
        place(el, spec.stamp);
    }
    if (spec.legend) {
        const g = spec.legend, lf = g.font;
        const box = document.createElement('div');
        box.className = 'planner-legend';
        box.style.cssText = 'font-family:"DejaVu Sans",sans-serif;color:#111;' +
            'background:rgba(255,255,255,0.94);border:' + border + 'px solid #444;' +
            'border-radius:' + (lf * 0.3) + 'px;padding:' + (0.6 * lf - border) + 'px;' +
            'font-size:' + lf + 'px;';
        if (g.columns > 1) {
            const perColumn = Math.ceil(g.rows.length / g.columns);
            box.style.display = 'grid';
            box.style.gridAutoFlow = 'column';
            box.style.gridTemplateRows = 'repeat(' + perColumn + ', ' + (1.45 * lf) + 'px)';
            box.style.columnGap = lf + 'px';
        }
        for (const row of g.rows) {
            const r = document.createElement('div');
            r.style.cssText = 'display:flex;align-items:center;white-space:nowrap;height:' +
                (1.45 * lf) + 'px;' + (row.dim ? 'opacity:0.35;' : '');
            const sw = document.createElement('span');
            sw.style.cssText = 'display:inline-flex;align-items:center;gap:' + (0.2 * lf) +
                'px;width:' + (3.2 * lf) + 'px;margin-right:' + (0.5 * lf) + 'px;flex:none;';
            for (const [color, kind] of row.swatches) {
                const s = document.createElement('span');
                const h = {line: 0.32, thin: 0.12, dashed: 0.16, box: 0.9, fill: 0.9,
                           disk: 0.9, ring: 0.9}[kind] * lf;
                const dash = (0.3 * lf) + 'px';
                const round = kind === 'disk' || kind === 'ring';
                s.style.cssText = 'display:inline-block;flex:none;background:' +
                    (kind === 'dashed' ? 'repeating-linear-gradient(90deg,' + color +
                     ' 0 ' + dash + ',transparent ' + dash + ' calc(2 * ' + dash + '))'
                     : kind === 'ring' ? 'transparent' : color) +
                    ';width:' + (round ? h : (kind === 'dashed' ? 3 : 1.4) * lf) +
                    'px;height:' + h + 'px;' +
                    (kind === 'disk' ? 'border-radius:50%;border:1px solid #222;' : '') +
                    (kind === 'ring' ? 'box-sizing:border-box;border-radius:50%;' +
                     'border:' + (0.16 * lf) + 'px solid ' + color + ';' : '') +
                    (kind === 'fill' ? 'opacity:0.45;' : '');
                sw.appendChild(s);
            }
            r.appendChild(sw);
            const t = document.createElement('span');
            t.textContent = row.text;
            if (!row.swatches.length) { t.style.fontSize = (0.9 * lf) + 'px'; sw.style.width = '0px'; sw.style.marginRight = '0px'; }
            r.appendChild(t);
            box.appendChild(r);
        }
        place(box, g.box);
    }
    document.body.appendChild(root);
    return document.fonts.ready.then(() => spec.labels.length);
}"""
"""Draw a :meth:`Slide.overlay_spec` over the page (replacing an earlier one)."""
