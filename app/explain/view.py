"""Draw one step of an explanation (:mod:`planners.explain`) in the 3-D scene.

The explanation says what each piece of geometry is (its role: the segments this step
adds, those earlier steps added, a blocked line of sight, the O_i, ...); this module only
chooses how each role looks (:data:`ROLE_LOOKS`) and assigns the nodes' properties. It
decides nothing about the method: the app draws what the planners decided.

Nodes are created once under ``/explain`` (one line-segment layer per role, a pool of
labels, their leader lines, a caption); :meth:`ExplainView.show` assigns points and
visibility, as the main view does (docs/architecture.md, "Data flow on an edit").

The caption and the labels are sized for a projector (:mod:`app.ui.floor_text`): in the
first view of the scene they are 3 % of the screen's height, as on a slide picture. The
caption, wrapped to the floor's width, sits above the floor's far edge; the labels are
placed on the floor clear of each other, of the rings they name, of the caption and of
the start, the goal and the obstacles' numbers (:func:`place_step_labels`).
"""

from __future__ import annotations

__all__ = [
    "ROLE_LOOKS",
    "ExplainView",
    "RoleLook",
    "place_step_labels",
    "role_segments",
    "scene_names",
    "step_requests",
]

import dataclasses
import math
import threading
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from app.ui.floor_text import (
    FloorLabel,
    FloorRequest,
    Keepouts,
    floor_caption,
    floor_font,
    place_on_floor,
    point_box,
)
from app.ui.style import (
    BLACK,
    BLUE,
    COLORS,
    DARK_PURPLE,
    GREEN,
    ORANGE,
    SKY,
    VERMILLION,
    WIDTHS,
    tint,
)
from app.ui.view import Labels, Segments, floor_bounds, lift_segments, live_keepouts
from planners.explain import ROLES, Step, circle_segments

if TYPE_CHECKING:
    import viser

    from planners.scene import Scene

FloatArray = npt.NDArray[np.float64]


@dataclasses.dataclass(frozen=True)
class RoleLook:
    """How one role of an explanation's marks is drawn."""

    color: tuple[int, int, int]
    """Line colour (RGB)."""
    width: float
    """Line width [m] (world units, so it scales with the scene like the paths)."""
    height: float
    """Height above the floor [m]: later roles above earlier ones, all above the plans."""
    legend: str
    """What the role is, in a picture's legend."""
    point_size: float = 0.0
    """Points of this role are drawn as small circles of this radius [m] (0: not drawn)."""


ROLE_LOOKS: Mapping[str, RoleLook] = MappingProxyType(
    {
        "done": RoleLook(tint(BLUE, 0.55), 0.02, 0.070, "earlier steps"),
        "hull": RoleLook(SKY, 0.035, 0.072, "convex hull"),
        "shape": RoleLook(BLUE, 0.02, 0.073, "robot at a vertex"),
        "seen": RoleLook(SKY, 0.07, 0.074, "border the sensor sees"),
        "sensor": RoleLook(DARK_PURPLE, 0.025, 0.075, "sensor range R"),
        "blocked": RoleLook(tint(VERMILLION, 0.5), 0.012, 0.076, "sight line blocked"),
        "blocker": RoleLook(VERMILLION, 0.07, 0.078, "edge that blocks it"),
        "offset": RoleLook(VERMILLION, 0.05, 0.079, "edge pushed out"),
        "path": RoleLook(BLACK, 0.09, 0.080, "path"),
        "result": RoleLook(GREEN, 0.06, 0.081, "expanded obstacle"),
        "current": RoleLook(GREEN, 0.06, 0.082, "added by this step"),
        "chosen": RoleLook(BLACK, 0.05, 0.084, "r to r_next"),
        "heading": RoleLook((110, 110, 110), 0.012, 0.083, "on to g (straight)"),
        "candidate": RoleLook(ORANGE, 0.03, 0.086, "O_i in view", point_size=0.09),
        "focus": RoleLook(VERMILLION, 0.04, 0.088, "under study", point_size=0.14),
    }
)
"""Look of each role of :data:`planners.explain.ROLES`: what this step adds in bold green,
earlier steps pale blue, blocked lines of sight pale red with their blocking edge bold red,
the path black, the O_i orange, the vertex or robot under study ringed in red."""


def role_segments(step: Step | None, role: str, z: float) -> FloatArray:
    """Return the segments of ``role`` in ``step`` lifted to height ``z``, shape (k, 2, 3).

    Points of a role with a point size are drawn as small circles around them.

    Examples
    --------
    >>> from planners.explain import Step, marks
    >>> step = Step("demo", "One segment.", marks(current=[[(0, 0), (1, 0)]]))
    >>> role_segments(step, "current", 0.1).tolist()
    [[[0.0, 0.0, 0.1], [1.0, 0.0, 0.1]]]
    >>> role_segments(step, "done", 0.1).shape
    (0, 2, 3)
    """
    if step is None:
        return np.zeros((0, 2, 3))
    mark = step.mark(role)
    if mark is None:
        return np.zeros((0, 2, 3))
    parts = [mark.segments]
    size = ROLE_LOOKS[role].point_size
    if size > 0:
        parts.extend(circle_segments(p, size, 24) for p in mark.points)
    segs = np.concatenate(parts) if parts else np.zeros((0, 2, 2))
    return lift_segments(segs, z) if len(segs) else np.zeros((0, 2, 3))


class ExplainView:
    """The explanation's layer in the 3-D scene: created once, then only assigned."""

    def __init__(self, scene: viser.SceneApi) -> None:
        self._lock = threading.Lock()
        self._layers = {
            role: Segments(scene, f"/explain/{role}", look.color, look.width)
            for role, look in ROLE_LOOKS.items()
        }
        assert set(self._layers) == set(ROLES)
        self._labels = Labels(scene, "/explain/labels", anchor="center-center")
        self._leaders = Segments(
            scene, "/explain/leaders", COLORS["marker_edge"], WIDTHS["outline"]
        )
        self._caption = Labels(scene, "/explain/caption", anchor="bottom-left")

    def draw_text(self, on: bool) -> None:
        """Draw the caption and labels in the scene (True), or not: a picture draws its own."""
        with self._lock:
            for pool in (self._labels, self._caption):
                pool.hidden = not on
                pool.shown.clear()  # the next show sends every label's state again
                for handle in pool.handles:
                    handle.visible = on and handle.visible
            self._leaders.handle.visible = on and self._leaders.handle.visible

    def show(
        self, step: Step | None, caption: str = "", scene: Scene | None = None
    ) -> None:
        """Draw ``step`` (None hides everything) of ``scene`` with its ``caption``."""
        with self._lock:
            for role, layer in self._layers.items():
                layer.set(
                    role_segments(step, role, ROLE_LOOKS[role].height), step is not None
                )
            if step is None or scene is None:
                self._labels.set([])
                self._caption.set([])
                self._leaders.set(np.zeros((0, 2, 3)), False)
                return
            self._show_text(step, caption, scene)

    def _show_text(self, step: Step, caption: str, scene: Scene) -> None:
        bounds = floor_bounds(scene)
        font = floor_font(bounds)
        block = floor_caption(caption, font, bounds) if caption else None
        keepouts = live_keepouts(scene, font)
        if block is not None:
            keepouts = keepouts.plus(reserved=[block.box])
        placed = place_step_labels(
            step, font=font, area=bounds, keepouts=keepouts, named=scene_names(scene)
        )
        self._labels.size_in_metres(font)
        self._labels.set([(p.request.text, (*p.centre, _TEXT_Z)) for p in placed])
        leaders = [
            lift_segments(np.asarray([p.leader]), _TEXT_Z - 0.005)
            for p in placed
            if p.leader is not None
        ]
        self._leaders.set(
            np.concatenate(leaders) if leaders else np.zeros((0, 2, 3)),
            bool(leaders) and not self._labels.hidden,
        )
        self._caption.size_in_metres(font)
        self._caption.set(
            [(block.text, (block.box[0], block.box[1], 0.12))] if block else []
        )


_TEXT_Z = max(look.height for look in ROLE_LOOKS.values()) + 0.01
"""Height [m] of the step's labels: above every role's lines."""


def scene_names(scene: Scene) -> tuple[tuple[str, Sequence[float]], ...]:
    """Return what the scene names itself: ("start", its point), ("goal", its point)."""
    return (("start", scene.start), ("goal", scene.goal))


def step_requests(
    step: Step, named: Sequence[tuple[str, Sequence[float]]] = ()
) -> tuple[list[tuple[str, FloorRequest]], list[tuple[float, float, float, float]]]:
    """Return the labels of ``step``'s marks with their roles, and the rings drawn.

    Every label of every mark, in the step's order (the explanation puts what matters
    first), but those the scene already shows (``named``: the start and the goal, each
    (text, point)); a label of a role drawn as rings (the O_i, the vertex or robot under
    study) keeps out of its ring, and no label covers any ring.

    Examples
    --------
    >>> from planners.explain import Step, point_mark
    >>> step = Step("k", "t", (point_mark("focus", [(1.0, 2.0)], (("r", (1.0, 2.0)),)),))
    >>> requests, rings = step_requests(step)
    >>> requests[0][0], requests[0][1].text, requests[0][1].clearance
    ('focus', 'r', 0.14)
    >>> [round(v, 2) for v in rings[0]]
    [0.86, 1.86, 1.14, 2.14]
    """
    requests, rings = [], []
    for mark in step.marks:
        radius = ROLE_LOOKS[mark.role].point_size
        if radius > 0:
            rings.extend(point_box(p, radius) for p in mark.points)
        requests.extend(
            (mark.role, FloorRequest(text, (float(x), float(y)), clearance=radius))
            for text, (x, y) in mark.labels
            if not any(
                text == name and math.dist((x, y), at) < 1e-9 for name, at in named
            )
        )
    return requests, rings


def place_step_labels(
    step: Step,
    *,
    font: float,
    area: tuple[float, float, float, float],
    keepouts: Keepouts = Keepouts(),  # noqa: B008 - frozen
    named: Sequence[tuple[str, Sequence[float]]] = (),
) -> tuple[FloorLabel, ...]:
    """Place the labels of ``step``'s marks on the floor: none over another or a ring.

    Parameters
    ----------
    step
        The step shown.
    font
        Font size [m] (:func:`app.ui.floor_text.floor_font`).
    area
        Where labels may go [m].
    keepouts
        The scene's own marks and text (:func:`app.ui.view.live_keepouts`) and the caption.
    named
        What the scene names itself (:func:`step_requests`).
    """
    requests, rings = step_requests(step, named)
    return place_on_floor(
        [request for _, request in requests],
        font=font,
        area=area,
        markers=[*keepouts.markers, *rings],
        reserved=keepouts.reserved,
    )
