"""Label placement: every label near what it names, none over another.

A picture for a slide names things with small text boxes: the obstacles' numbers, the
start and the goal, and the events of the trace planners (H, D, L, M of DSB and Bug2,
Fig. 9.19). :func:`place_labels` puts each box at the first free place of a fixed list of
candidates around its anchor, nearest first, so that no two boxes overlap, no box covers
a marker (an event's cross, the start or goal disk) and every box stays inside the
picture. It is a pure function of its arguments (pixels in, pixels out): the same picture
gets the same labels every time.

A label that finds no free place near its anchor goes further out (rings of growing
radius); one that finds no place at all in the picture is returned in
:attr:`Placement.dropped`, never drawn over another. A label placed away from its anchor
gets a leader line (:attr:`PlacedLabel.leader`).

Text boxes are measured for a monospaced font (:data:`CHAR_WIDTH` of the font size per
character), so the box the placer reserves is the box the picture draws; a longer text (a
caption) is broken into lines of that font by :func:`wrap_text`.

The placer works in any unit with y down: the pictures place in pixels; the app's live
view places on the floor in metres (:mod:`app.ui.floor_text`).
"""

from __future__ import annotations

__all__ = [
    "CHAR_WIDTH",
    "FONT_SHARE",
    "Box",
    "LabelRequest",
    "PlacedLabel",
    "Placement",
    "label_size",
    "place_labels",
    "wrap_text",
]

import dataclasses
import math
import textwrap
from collections.abc import Sequence

import numpy as np

FONT_SHARE = 0.03
"""Label and caption size as a share of a picture's height (32 px at 1080, 15 px at 500);
the live view's text, of the floor height its first camera shows."""

CHAR_WIDTH = 0.6021
"""Advance of one character of DejaVu Sans Mono (the pictures' label font) [em]."""
LINE_HEIGHT = 1.2
"""Height of a line of label text [em]."""
PAD = 0.3
"""Padding inside a label's box, on every side [em]."""


@dataclasses.dataclass(frozen=True)
class Box:
    """An axis-aligned box in picture pixels: x to the right, y down."""

    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def width(self) -> float:
        """Width [px]."""
        return self.x1 - self.x0

    @property
    def height(self) -> float:
        """Height [px]."""
        return self.y1 - self.y0

    def overlaps(self, other: Box) -> bool:
        """Tell whether the two boxes share interior points (touching edges do not count).

        Examples
        --------
        >>> Box(0, 0, 2, 2).overlaps(Box(1, 1, 3, 3)), Box(0, 0, 2, 2).overlaps(Box(2, 0, 4, 2))
        (True, False)
        """
        return (
            self.x0 < other.x1
            and other.x0 < self.x1
            and self.y0 < other.y1
            and other.y0 < self.y1
        )

    def inside(self, width: float, height: float) -> bool:
        """Tell whether the box lies within a ``width`` x ``height`` picture."""
        return self.x0 >= 0 and self.y0 >= 0 and self.x1 <= width and self.y1 <= height

    def grown(self, by: float) -> Box:
        """Return the box grown by ``by`` pixels on every side."""
        return Box(self.x0 - by, self.y0 - by, self.x1 + by, self.y1 + by)

    def distance_to(self, point: tuple[float, float]) -> float:
        """Distance [px] from ``point`` to the nearest point of the box (0 inside)."""
        dx = max(self.x0 - point[0], 0.0, point[0] - self.x1)
        dy = max(self.y0 - point[1], 0.0, point[1] - self.y1)
        return math.hypot(dx, dy)

    def nearest(self, point: tuple[float, float]) -> tuple[float, float]:
        """Return the point of the box nearest to ``point``."""
        return (
            min(max(point[0], self.x0), self.x1),
            min(max(point[1], self.y0), self.y1),
        )


@dataclasses.dataclass(frozen=True)
class LabelRequest:
    """A label to place: its text, what it names, and where it would rather sit."""

    text: str
    """The label's text (one line)."""
    anchor: tuple[float, float]
    """The pixel the label names (an event, an obstacle's centre, a marker)."""
    centred: bool = False
    """True: try the box centred on the anchor first (an obstacle's number on it);
    False: always beside the anchor, never over it (an event's cross)."""
    kind: str = "event"
    """What the label names (``"event"``, ``"obstacle"``, ``"marker"``), for styling."""
    clearance: float = 0.0
    """Least distance [px] between the anchor and a box placed beside it (the size of
    the marker drawn at the anchor); half the font size if that is more."""


@dataclasses.dataclass(frozen=True)
class PlacedLabel:
    """A label where the picture draws it."""

    request: LabelRequest
    box: Box
    """The text box [px]."""
    leader: tuple[tuple[float, float], tuple[float, float]] | None
    """A line from the anchor to the box's nearest point, when the box is away from it."""


@dataclasses.dataclass(frozen=True)
class Placement:
    """What :func:`place_labels` returns."""

    placed: tuple[PlacedLabel, ...]
    """The labels drawn, in the order asked."""
    dropped: tuple[LabelRequest, ...]
    """Labels with no free place anywhere in the picture (not drawn)."""


def label_size(text: str, font_px: float) -> tuple[float, float]:
    """Width and height [px] of a label's box: the text in the monospaced font, padded.

    Examples
    --------
    >>> label_size("H1", 20.0)
    (36.084, 36.0)
    """
    width = len(text) * CHAR_WIDTH * font_px + 2 * PAD * font_px
    height = LINE_HEIGHT * font_px + 2 * PAD * font_px
    return (round(width, 3), round(height, 3))


def wrap_text(text: str, width: float, font_px: float) -> tuple[str, ...]:
    """Break ``text`` into lines no wider than ``width`` in the monospaced font.

    Lines break at spaces; a word longer than a line is cut across lines, so no line is
    ever wider than ``width`` and nothing is left out (at least one character a line).

    Examples
    --------
    >>> wrap_text("Step 1: the common tangents", 10 * CHAR_WIDTH * 10, 10)
    ('Step 1:', 'the common', 'tangents')
    >>> wrap_text("", 100, 10)
    ('',)
    """
    chars = max(1, math.floor(width / (CHAR_WIDTH * font_px) + 1e-9))
    lines = textwrap.wrap(
        " ".join(text.split()), chars, break_long_words=True, break_on_hyphens=False
    )
    return tuple(lines) or ("",)


# Directions tried around an anchor, nearest-looking first: upper right (where a reader
# looks for a figure's label), then the other corners, then the sides.
_DIRECTIONS = (
    (1, -1),
    (1, 1),
    (-1, -1),
    (-1, 1),
    (1, 0),
    (-1, 0),
    (0, -1),
    (0, 1),
)
_RING_DIRECTIONS = 16  # around the anchor on each further ring
_RINGS = 12  # further rings before scanning the whole picture


def _beside(
    anchor: tuple[float, float],
    size: tuple[float, float],
    d: tuple[int, int],
    gap: float,
) -> Box:
    """Return the box of ``size`` beside ``anchor`` in direction ``d``, ``gap`` pixels away."""
    w, h = size
    ax, ay = anchor
    x0 = ax + gap if d[0] > 0 else ax - gap - w if d[0] < 0 else ax - w / 2
    y0 = ay + gap if d[1] > 0 else ay - gap - h if d[1] < 0 else ay - h / 2
    return Box(x0, y0, x0 + w, y0 + h)


def _centred(anchor: tuple[float, float], size: tuple[float, float]) -> Box:
    w, h = size
    return Box(
        anchor[0] - w / 2, anchor[1] - h / 2, anchor[0] + w / 2, anchor[1] + h / 2
    )


# (cos, sin) of the ring directions, at the angles :func:`_near` documents.
_RING_UNIT = np.array(
    [
        (math.cos(a), math.sin(a))
        for a in (
            2 * math.pi * k / _RING_DIRECTIONS - math.pi / 4
            for k in range(_RING_DIRECTIONS)
        )
    ]
)


def _near(request: LabelRequest, size: tuple[float, float], gap: float) -> np.ndarray:
    """Rows (x0, y0, x1, y1) of the candidates near the anchor, nearest first.

    Centred on it (``centred`` requests only), beside it in the eight
    :data:`_DIRECTIONS`, then centred on :data:`_RINGS` rings further out,
    :data:`_RING_DIRECTIONS` around each (angle ``2 pi k / n - pi / 4``), with the
    arithmetic of :func:`_centred` and :func:`_beside`.
    """
    anchor = request.anchor
    first = [_centred(anchor, size)] if request.centred else []
    first += [_beside(anchor, size, d, gap) for d in _DIRECTIONS]
    w, h = size
    step = max(h, gap)
    radius = (gap + np.arange(1, _RINGS + 1, dtype=float) * step)[:, None]
    cx = anchor[0] + _RING_UNIT[:, 0] * (radius + w / 2)
    cy = anchor[1] + _RING_UNIT[:, 1] * (radius + h / 2)
    rings = np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=-1).reshape(
        -1, 4
    )
    return np.vstack([_corners(first), rings])


def _scan(
    anchor: tuple[float, float], size: tuple[float, float], picture: tuple[float, float]
) -> list[Box]:
    """Every grid place in the picture (a half box apart), nearest to ``anchor`` first."""
    w, h = size
    nx = max(1, int((picture[0] - w) // (w / 2)) + 1)
    ny = max(1, int((picture[1] - h) // (h / 2)) + 1)
    boxes = [
        Box(i * w / 2, j * h / 2, i * w / 2 + w, j * h / 2 + h)
        for i in range(nx)
        for j in range(ny)
    ]
    return sorted(boxes, key=lambda b: (b.distance_to(anchor), b.x0, b.y0))


def place_labels(
    requests: Sequence[LabelRequest],
    *,
    font_px: float,
    picture: tuple[float, float],
    markers: Sequence[Box] = (),
    reserved: Sequence[Box] = (),
) -> Placement:
    """Place ``requests`` in a picture so that no two boxes overlap.

    Labels are placed in the order given (put the important ones first); each takes the
    first free candidate: centred on its anchor (``centred`` labels only), then beside it
    in eight directions at a gap of half the font size (or the request's clearance), then on rings further out (with a
    leader line), then anywhere in the picture, nearest first.

    Parameters
    ----------
    requests
        The labels.
    font_px
        Font size [px]; the boxes are :func:`label_size`.
    picture
        (width, height) of the picture [px]; every box stays inside it.
    markers
        Boxes no label may cover (event crosses, the start and goal disks).
    reserved
        Other boxes no label may cover (the title, the legend).

    Returns
    -------
    Placement
        Boxes pairwise disjoint, disjoint from ``markers`` and ``reserved``, inside the
        picture.

    Examples
    --------
    >>> p = place_labels([LabelRequest("H1", (50, 50)), LabelRequest("L1", (52, 50))],
    ...                  font_px=10, picture=(200, 100))
    >>> [b.box.overlaps(p.placed[0].box) for b in p.placed[1:]], p.dropped
    ([False], ())
    """
    taken = _corners([*markers, *reserved])
    placed: list[PlacedLabel] = []
    dropped: list[LabelRequest] = []
    for request in requests:
        size = label_size(request.text, font_px)
        gap = max(font_px / 2, request.clearance)
        box = _first_free(_near(request, size, gap), taken, picture)
        if box is None:
            grid = _corners(_scan(request.anchor, size, picture))
            box = _first_free(grid, taken, picture)
        if box is None:
            dropped.append(request)
            continue
        taken = np.vstack([taken, _corners([box])])
        placed.append(PlacedLabel(request, box, _leader(request, box, gap)))
    return Placement(tuple(placed), tuple(dropped))


def _corners(boxes: Sequence[Box]) -> np.ndarray:
    """Return the boxes as rows (x0, y0, x1, y1)."""
    return np.array([(b.x0, b.y0, b.x1, b.y1) for b in boxes], float).reshape(-1, 4)


def _first_free(
    candidates: np.ndarray, taken: np.ndarray, picture: tuple[float, float]
) -> Box | None:
    """Return the first candidate inside the picture that overlaps no taken box.

    ``candidates`` and ``taken`` are rows (x0, y0, x1, y1). The tests are those of
    :meth:`Box.inside` and :meth:`Box.overlaps`, on the same numbers, all at once.
    """
    x0, y0, x1, y1 = (candidates[:, k : k + 1] for k in range(4))
    free = (x0 >= 0) & (y0 >= 0) & (x1 <= picture[0]) & (y1 <= picture[1])
    if len(taken):
        t0, u0, t1, u1 = taken.T
        hit = (x0 < t1) & (t0 < x1) & (y0 < u1) & (u0 < y1)
        free &= ~hit.any(axis=1, keepdims=True)
    first = np.flatnonzero(free[:, 0])
    if not first.size:
        return None
    return Box(*(float(v) for v in candidates[first[0]]))


def _leader(
    request: LabelRequest, box: Box, gap: float
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """Return a leader line when the box is further from its anchor than the nearest candidates."""
    if box.distance_to(request.anchor) <= gap * 1.5 + 1e-9:
        return None
    return (request.anchor, box.nearest(request.anchor))
