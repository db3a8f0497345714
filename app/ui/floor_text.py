"""Text of the live view sized for a projector: a font in metres, labels placed clear of each other.

viser draws a label in one of two ways: a constant size on the screen (12 px a unit of
``font_screen_scale``, whatever the screen) or a size in the scene's metres. The labels
that must read from the back of a hall (Explain's caption and labels, the trace
planners' events H, D, L, M) are sized in metres: a share of the height of floor the
app's first camera shows (:func:`floor_font`), so that in that view they are the size of a
slide picture's labels (:data:`FONT_SHARE`, 3 % of the height: 32 px on a 1080-pixel
projector), and they grow and shrink with the scene when someone zooms.

Sized in metres, labels can be placed once, on the floor, by the pictures' placer
(:func:`app.ui.labels.place_labels`, :func:`place_on_floor`): two labels that do not
overlap do not overlap at any zoom, since their boxes scale with the distances between
them. A label is drawn centred on its box; the box the placer reserves is the monospaced
font's (:func:`app.ui.labels.label_size`), larger than viser's drawing of the same text
(a proportional font with less padding), so the drawn text stays inside it.

Pure: numbers in, numbers out (no viser).
"""

from __future__ import annotations

__all__ = [
    "FONT_SHARE",
    "Caption",
    "FirstCamera",
    "FloorLabel",
    "FloorRequest",
    "Keepouts",
    "first_camera",
    "floor_caption",
    "floor_font",
    "place_events",
    "place_on_floor",
    "point_box",
    "scene_keepouts",
]

import dataclasses
import math
from collections.abc import Sequence

from app.ui.labels import (
    FONT_SHARE,
    LINE_HEIGHT,
    PAD,
    Box,
    LabelRequest,
    label_size,
    place_labels,
    wrap_text,
)

_FIRST_FOV = math.radians(50.0)
_PX = 32.0  # the placer's unit: one font size is this many of its "pixels"

FloorBox = tuple[float, float, float, float]
"""A box on the floor: (xmin, ymin, xmax, ymax) [m]."""


@dataclasses.dataclass(frozen=True)
class FirstCamera:
    """The camera a browser gets when it opens the app (viser's initial camera)."""

    fov: float
    """Vertical field of view [rad]."""
    look_at: tuple[float, float, float]
    position: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)


def first_camera(bounds: FloorBox) -> FirstCamera:
    """Frame the floor ``bounds`` whole, slightly tilted so it reads as 3-D.

    The floor is framed left of centre: the control panel floats over the right side.
    About 20 degrees from straight down, seen from the -y side.

    Examples
    --------
    >>> first_camera((0.0, 0.0, 10.0, 8.0)).look_at
    (6.2, 4.0, 0.0)
    """
    x0, y0, x1, y1 = bounds
    w, h = max(x1 - x0, 1.0), max(y1 - y0, 1.0)
    distance = max(1.2 * w, 1.55 * h)
    cx, cy = (x0 + x1) / 2 + 0.12 * w, (y0 + y1) / 2
    return FirstCamera(
        fov=_FIRST_FOV,
        look_at=(cx, cy, 0.0),
        position=(cx, cy - 0.36 * distance, 0.94 * distance),
    )


def floor_font(bounds: FloorBox, share: float = FONT_SHARE) -> float:
    """Font size [m] of projector text on a floor of ``bounds``.

    ``share`` of the height the first camera (:func:`first_camera`) shows at the point it
    looks at.

    Examples
    --------
    >>> round(floor_font((0.0, 0.0, 10.0, 8.0)), 3)
    0.349
    """
    camera = first_camera(bounds)
    distance = math.dist(camera.position, camera.look_at)
    return share * 2 * math.tan(camera.fov / 2) * distance


@dataclasses.dataclass(frozen=True)
class FloorRequest:
    """A label to place on the floor: its text and the point it names."""

    text: str
    at: tuple[float, float]
    """The point named [m]."""
    clearance: float = 0.0
    """Radius [m] of the marker drawn at the point (a ring, a cross): the label keeps
    out of it."""
    centred: bool = False
    """True: the label may sit on its point (an obstacle's number)."""


@dataclasses.dataclass(frozen=True)
class FloorLabel:
    """A label where the live view draws it."""

    request: FloorRequest
    box: FloorBox
    """The box reserved for the text [m]; the label is drawn centred in it."""
    leader: tuple[tuple[float, float], tuple[float, float]] | None
    """A line from the point named to the box, when the box is away from it [m]."""

    @property
    def centre(self) -> tuple[float, float]:
        """The box's centre [m]: where the label is drawn (anchored at its centre)."""
        x0, y0, x1, y1 = self.box
        return ((x0 + x1) / 2, (y0 + y1) / 2)


def place_on_floor(
    requests: Sequence[FloorRequest],
    *,
    font: float,
    area: FloorBox,
    markers: Sequence[FloorBox] = (),
    reserved: Sequence[FloorBox] = (),
) -> tuple[FloorLabel, ...]:
    """Place ``requests`` on the floor with the pictures' placer; none overlaps another.

    Parameters
    ----------
    requests
        The labels, the most important first.
    font
        Font size [m].
    area
        Where labels may go [m] (the floor drawn, with a margin).
    markers, reserved
        Floor boxes no label may cover (rings and crosses; other labels, a caption).

    Returns
    -------
    tuple of FloorLabel
        The labels placed, pairwise disjoint and clear of ``markers`` and ``reserved``;
        a label with no room anywhere in ``area`` is left out.

    Examples
    --------
    >>> a, b = place_on_floor([FloorRequest("H1", (1.0, 1.0)), FloorRequest("D7", (1.0, 1.0))],
    ...                       font=0.3, area=(0.0, 0.0, 10.0, 8.0))
    >>> a.box[0] >= b.box[2] or b.box[0] >= a.box[2] or a.box[1] >= b.box[3] or b.box[1] >= a.box[3]
    True
    """
    k = _PX / font
    x0, y0, x1, y1 = area

    def to_px(x: float, y: float) -> tuple[float, float]:
        return ((x - x0) * k, (y1 - y) * k)

    def box_px(box: FloorBox) -> Box:
        (a, b), (c, d) = to_px(box[0], box[3]), to_px(box[2], box[1])
        return Box(a, b, c, d)

    def to_floor(box: Box) -> FloorBox:
        return (x0 + box.x0 / k, y1 - box.y1 / k, x0 + box.x1 / k, y1 - box.y0 / k)

    asked = [
        LabelRequest(r.text, to_px(*r.at), centred=r.centred, clearance=r.clearance * k)
        for r in requests
    ]
    placement = place_labels(
        asked,
        font_px=_PX,
        picture=((x1 - x0) * k, (y1 - y0) * k),
        markers=[box_px(m) for m in markers],
        reserved=[box_px(r) for r in reserved],
    )
    of = {id(label): request for label, request in zip(asked, requests, strict=True)}
    out = []
    for placed in placement.placed:
        request = of[id(placed.request)]
        leader = None
        if placed.leader is not None:
            end = placed.leader[1]
            leader = (request.at, (x0 + end[0] / k, y1 - end[1] / k))
        out.append(FloorLabel(request, to_floor(placed.box), leader))
    return tuple(out)


@dataclasses.dataclass(frozen=True)
class Caption:
    """A caption laid on the floor above an area: its lines and its box [m]."""

    lines: tuple[str, ...]
    box: FloorBox

    @property
    def text(self) -> str:
        """The lines joined by newlines, as a viser label takes them."""
        return "\n".join(self.lines)


def floor_caption(text: str, font: float, area: FloorBox) -> Caption:
    """Wrap ``text`` to the width of ``area`` and put it just above its top edge.

    The box is the monospaced font's (an upper bound of what viser draws): its bottom
    a third of a line above ``area``, its left edge on ``area``'s.

    Examples
    --------
    >>> c = floor_caption("Step 1: the common tangents of obstacle 1 and 2", 0.5, (0, 0, 6, 4))
    >>> c.lines, c.box[1] > 4
    (('Step 1: the common', 'tangents of', 'obstacle 1 and 2'), True)
    """
    x0, _, x1, y1 = area
    lines = wrap_text(text, (x1 - x0) - 2 * PAD * font, font)
    height = (len(lines) * LINE_HEIGHT + 2 * PAD) * font
    bottom = y1 + font / 3
    return Caption(lines, (x0, bottom, x1, bottom + height))


@dataclasses.dataclass(frozen=True)
class Keepouts:
    """What the live view's placed labels keep clear of, on the floor [m]."""

    markers: tuple[FloorBox, ...] = ()
    """Disks, rings and crosses drawn at points (the start and goal, events' crosses)."""
    reserved: tuple[FloorBox, ...] = ()
    """Text drawn elsewhere: the start's and goal's names, the obstacles' numbers."""

    def plus(
        self, markers: Sequence[FloorBox] = (), reserved: Sequence[FloorBox] = ()
    ) -> Keepouts:
        """Return these keep-outs and more."""
        return Keepouts((*self.markers, *markers), (*self.reserved, *reserved))


def point_box(at: Sequence[float], radius: float) -> FloorBox:
    """Return the box of a disk of ``radius`` around ``at`` [m]."""
    x, y = float(at[0]), float(at[1])
    return (x - radius, y - radius, x + radius, y + radius)


def scene_keepouts(
    ends: Sequence[tuple[str, Sequence[float]]],
    marker_radius: float,
    numbers: Sequence[tuple[str, Sequence[float]]],
    font: float,
) -> Keepouts:
    """Return the live view's fixed marks: start and goal disks and names, obstacle numbers.

    ``ends``: ("start", point) and ("goal", point), each a disk of ``marker_radius`` with
    its name above it (viser draws it in screen pixels, smaller than ``font`` in the
    first view: the box is the name's at ``font``). ``numbers``: (text, point) of each
    obstacle's number, drawn centred on its point.

    Examples
    --------
    >>> k = scene_keepouts([("start", (1.0, 1.0))], 0.2, [("1", (5.0, 5.0))], 0.3)
    >>> k.markers
    ((0.8, 0.8, 1.2, 1.2),)
    """
    markers = tuple(point_box(at, marker_radius) for _, at in ends)
    reserved = []
    for name, at in ends:
        w, h = label_size(name, font)
        bottom = at[1] + marker_radius + 0.05
        reserved.append((at[0] - w / 2, bottom, at[0] + w / 2, bottom + h))
    for text, at in numbers:
        w, h = label_size(text, font)
        reserved.append((at[0] - w / 2, at[1] - h / 2, at[0] + w / 2, at[1] + h / 2))
    return Keepouts(markers, tuple(reserved))


def place_events(
    events: Sequence[tuple[str, Sequence[tuple[str, tuple[float, float]]]]],
    *,
    font: float,
    area: FloorBox,
    cross: float,
    keepouts: Keepouts = Keepouts(),
) -> dict[str, tuple[FloorLabel, ...]]:
    """Place the events of every trace planner at once, so no two overlap (H5 and D7 too).

    ``events``: per planner (name, its ``(label, point)`` events), in drawing order; each
    event has a cross of half-size ``cross`` [m] the labels keep clear of.

    Examples
    --------
    >>> placed = place_events([("dsb", [("D7", (2.0, 2.0))]), ("bug2", [("H5", (2.0, 2.0))])],
    ...                       font=0.3, area=(0.0, 0.0, 10.0, 8.0), cross=0.12)
    >>> sorted(placed), [len(v) for v in placed.values()]
    (['bug2', 'dsb'], [1, 1])
    """
    crosses = [point_box(at, cross) for _, pairs in events for _, at in pairs]
    requests = [
        (name, FloorRequest(text, at, clearance=cross))
        for name, pairs in events
        for text, at in pairs
    ]
    placed = place_on_floor(
        [r for _, r in requests],
        font=font,
        area=area,
        markers=[*keepouts.markers, *crosses],
        reserved=keepouts.reserved,
    )
    owner = {id(r): name for name, r in requests}
    out: dict[str, tuple[FloorLabel, ...]] = {name: () for name, _ in events}
    for label in placed:
        name = owner[id(label.request)]
        out[name] = (*out[name], label)
    return out
