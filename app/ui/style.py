"""Colours, sizes and heights shared by the 3-D view and the panel's legend.

The palette is Okabe and Ito's (2008) colour-universal design: eight colours that stay
distinct for the common forms of colour blindness and on a washed-out projector. Each
planner owns one hue; its graph edges are a pale tint of that hue, its path the full hue.
"""

from __future__ import annotations

__all__ = [
    "BLUE",
    "COLORS",
    "DARK_PURPLE",
    "GREEN",
    "HEIGHTS",
    "ORANGE",
    "PURPLE",
    "SKY",
    "VERMILLION",
    "YELLOW",
    "PlannerLook",
    "hex_color",
    "planner_look",
    "tint",
]

import dataclasses
from collections.abc import Mapping
from types import MappingProxyType

import planners
from planners.registry import PlannerSpec

RGB = tuple[int, int, int]

# Okabe-Ito palette.
BLACK: RGB = (0, 0, 0)
ORANGE: RGB = (230, 159, 0)
SKY: RGB = (86, 180, 233)
GREEN: RGB = (0, 158, 115)
YELLOW: RGB = (240, 228, 66)
BLUE: RGB = (0, 114, 178)
VERMILLION: RGB = (213, 94, 0)
PURPLE: RGB = (204, 121, 167)
# A darker reddish purple (Paul Tol's "purple"): the light Okabe-Ito one is too faint as a
# thin line on a white floor.
DARK_PURPLE: RGB = (170, 68, 153)


def tint(color: RGB, amount: float) -> RGB:
    """Mix ``color`` with white; ``amount`` 0 keeps the colour, 1 gives white.

    Examples
    --------
    >>> tint((0, 114, 178), 0.5)
    (128, 184, 216)
    """
    return tuple(round(c + (255 - c) * amount) for c in color)  # type: ignore[return-value]


def hex_color(color: RGB) -> str:
    """Return ``#rrggbb`` for the panel's HTML legend.

    Examples
    --------
    >>> hex_color((0, 114, 178))
    '#0072b2'
    """
    return "#{:02x}{:02x}{:02x}".format(*color)


COLORS: dict[str, RGB] = {
    "obstacle": (72, 72, 72),
    "obstacle_edge": (25, 25, 25),
    "wall": (150, 150, 150),
    "expanded": ORANGE,
    "expanded_edge": (175, 140, 60),
    "other_expansion": (90, 90, 90),
    "vg": BLUE,
    "vg_edges": tint(BLUE, 0.62),
    "svg": GREEN,
    "svg_edges": tint(GREEN, 0.45),
    "dsb": DARK_PURPLE,
    "dsb_seek": DARK_PURPLE,
    "dsb_follow": VERMILLION,
    # Bug2 in the two hues no other path uses: orange on the M-line (it only touches the
    # expanded obstacles' fill at its hit points), reddish purple along their borders.
    "bug2": ORANGE,
    "bug2_seek": ORANGE,
    "bug2_follow": PURPLE,
    "start": SKY,
    "goal": YELLOW,
    "marker_edge": (30, 30, 30),
    "selection": BLACK,
    "draft": BLACK,
    "robot_body": (225, 225, 225),
    "robot_wheel": (40, 40, 40),
    "robot_mark": ORANGE,
    "robot_heading": BLUE,
    "sensing": DARK_PURPLE,
    "sensed": SKY,
    "tangents": (45, 45, 45),
    # The planner's r_next: black and bold, apart from the DSB path it leads along.
    "chosen": BLACK,
}
"""Colour of each thing drawn, by role."""

HEIGHTS: dict[str, float] = {
    # The paths are 15-20 mm apart: at a few millimetres a tilted camera 15 m away cannot
    # separate them in its depth buffer and they flicker as dashes (VG and SVG, which
    # often coincide, get the widest gap). Every flat layer stays below the top of the
    # robot's body (7.5 cm), so the robot is never hidden.
    # An occupancy map lies under the floor's grid lines, which stay visible over it.
    "floor_map": -0.01,
    "expanded_fill": 0.004,
    "expanded_edge": 0.008,
    "vg_edges": 0.012,
    "svg_edges": 0.016,
    "vg_path": 0.02,
    "svg_path": 0.04,
    "dsb_path": 0.055,
    "bug2_path": 0.048,
    "marker": 0.062,
    "sensing": 0.068,
    "obstacle": 0.4,
    "wall": 0.3,
}
"""Height [m] of each flat layer above the floor, so overlapping layers never flicker,
and of the obstacle prisms and walls."""

WIDTHS: dict[str, float] = {
    "graph_px": 1.5,
    "vg_path": 0.2,
    "svg_path": 0.11,
    "dsb_path": 0.075,
    "bug2_path": 0.05,
    "outline": 0.03,
    "selection": 0.07,
    "sensing": 0.025,
}
"""Line thickness [m, world units; ``_px``: screen pixels]: the paths nest (VG widest, DSB narrowest) so that
identical VG and SVG paths both stay visible."""


@dataclasses.dataclass(frozen=True)
class PlannerLook:
    """How one planner of :data:`planners.REGISTRY` is drawn."""

    path: RGB
    """The path's colour (a trace's while it seeks the goal)."""
    path_height: float
    """Height of the path above the floor [m]."""
    path_width: float
    """Width of the path [m]."""
    edges: RGB | None = None
    """A graph planner's edges (pale tint of the path's hue)."""
    edges_height: float = 0.0
    """Height of the edges [m]."""
    edges_px: float = WIDTHS["graph_px"]
    """Width of the edges [screen pixels]."""
    follow: RGB | None = None
    """A trace planner's colour while it follows a border."""


LOOKS: Mapping[str, PlannerLook] = MappingProxyType(
    {
        name: PlannerLook(
            path=COLORS[name],
            path_height=HEIGHTS[f"{name}_path"],
            path_width=WIDTHS[f"{name}_path"],
            edges=COLORS.get(f"{name}_edges"),
            edges_height=HEIGHTS.get(f"{name}_edges", 0.0),
            edges_px=WIDTHS["graph_px"] * (1.4 if name == "svg" else 1.0),
            follow=COLORS.get(f"{name}_follow"),
        )
        for name in ("vg", "svg", "dsb", "bug2")
    }
)
"""The looks of the planners the project ships."""

# For a planner someone registers without a look of its own: the palette's colours the
# shipped planners leave free, one after another, and paths stacked above the others.
_SPARE: tuple[RGB, ...] = (SKY, YELLOW, VERMILLION, BLUE)


def planner_look(
    name: str, registry: Mapping[str, PlannerSpec] = planners.REGISTRY
) -> PlannerLook:
    """Return how planner ``name`` of ``registry`` is drawn.

    A planner without a look of its own (one a test or a student registers) gets the next
    spare colour of the palette and a path above the others.

    Examples
    --------
    >>> planner_look("svg").path == GREEN
    True
    """
    if name in LOOKS:
        return LOOKS[name]
    extra = [n for n in registry if n not in LOOKS]
    k = extra.index(name) if name in extra else len(extra)
    color = _SPARE[k % len(_SPARE)]
    graph = name in registry and registry[name].kind == "graph"
    return PlannerLook(
        path=color,
        path_height=0.058 + 0.003 * k,
        path_width=0.06,
        edges=tint(color, 0.55) if graph else None,
        edges_height=0.014 + 0.001 * k,
        follow=None if graph else tint(color, 0.4),
    )
