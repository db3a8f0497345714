"""Draw one step of an explanation (:mod:`planners.explain`) in the 3-D scene.

The explanation says what each piece of geometry is (its role: the segments this step
adds, those earlier steps added, a blocked line of sight, the O_i, ...); this module only
chooses how each role looks (:data:`ROLE_LOOKS`) and assigns the nodes' properties. It
decides nothing about the method: the app draws what the planners decided.

Nodes are created once under ``/explain`` (one line-segment layer per role, a pool of
labels, a caption); :meth:`ExplainView.show` assigns points and visibility, as the main
view does (docs/architecture.md, "Data flow on an edit").
"""

from __future__ import annotations

__all__ = ["ROLE_LOOKS", "ExplainView", "RoleLook", "role_segments"]

import dataclasses
import threading
from collections.abc import Mapping
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from app.ui.style import BLACK, BLUE, DARK_PURPLE, GREEN, ORANGE, SKY, VERMILLION, tint
from app.ui.view import Labels, Segments, lift_segments, merge_labels
from planners.explain import ROLES, Step, circle_segments

if TYPE_CHECKING:
    import viser

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
    point_size: float = 0.0
    """Points of this role are drawn as small circles of this radius [m] (0: not drawn)."""


ROLE_LOOKS: Mapping[str, RoleLook] = MappingProxyType(
    {
        "done": RoleLook(tint(BLUE, 0.55), 0.02, 0.070),
        "hull": RoleLook(SKY, 0.035, 0.072),
        "shape": RoleLook(BLUE, 0.02, 0.073),
        "seen": RoleLook(SKY, 0.07, 0.074),
        "sensor": RoleLook(DARK_PURPLE, 0.025, 0.075),
        "blocked": RoleLook(tint(VERMILLION, 0.5), 0.012, 0.076),
        "blocker": RoleLook(VERMILLION, 0.07, 0.078),
        "offset": RoleLook(VERMILLION, 0.05, 0.079),
        "path": RoleLook(BLACK, 0.09, 0.080),
        "result": RoleLook(GREEN, 0.06, 0.081),
        "current": RoleLook(GREEN, 0.06, 0.082),
        "chosen": RoleLook(BLACK, 0.05, 0.084),
        "heading": RoleLook((110, 110, 110), 0.012, 0.083),
        "candidate": RoleLook(ORANGE, 0.03, 0.086, point_size=0.09),
        "focus": RoleLook(VERMILLION, 0.04, 0.088, point_size=0.14),
    }
)
"""Look of each role of :data:`planners.explain.ROLES`: what this step adds in bold green,
earlier steps pale blue, blocked lines of sight pale red with their blocking edge bold red,
the path black, the O_i orange, the vertex or robot under study ringed in red."""

LABEL_JOIN_M = 0.2
"""Labels of one role closer than this [m] are joined into one ("O_1 ... | O_4 ...")."""

CAPTION_SCALE = 0.9
"""Screen scale of the caption (the step's line of text drawn in the scene)."""


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
        self._labels = Labels(scene, "/explain/labels", scale=0.8)
        self._caption = Labels(
            scene, "/explain/caption", scale=CAPTION_SCALE, anchor="top-left"
        )

    def show(
        self,
        step: Step | None,
        caption: str = "",
        at: tuple[float, float, float] | None = None,
    ) -> None:
        """Draw ``step`` (None hides everything) and its ``caption`` at ``at``."""
        with self._lock:
            for role, layer in self._layers.items():
                layer.set(
                    role_segments(step, role, ROLE_LOOKS[role].height), step is not None
                )
            self._labels.set(_labels(step))
            items: list[tuple[str, Any]] = (
                [(caption, at)] if caption and at is not None else []
            )
            self._caption.set(items)


def _labels(step: Step | None) -> list[tuple[str, Any]]:
    if step is None:
        return []
    out = []
    for mark in step.marks:
        z = ROLE_LOOKS[mark.role].height + 0.01
        # Two O_i a few centimetres apart would print one label over the other.
        joined = merge_labels(list(mark.labels), LABEL_JOIN_M)
        out.extend((text, (float(x), float(y), z)) for text, (x, y) in joined)
    return out
