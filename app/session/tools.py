"""Editing tools and picking, as pure functions of (scene, UI state, input).

The UI state every browser of a session shares (mouse tool, selection, the polygon being
drawn, layer toggles, enabled planners, the answer to the last action) is one immutable
:class:`UiState`. A mouse action or a button reads the scene and that state, decides, and
says what changes, all in one pure function::

    outcome = tools.click_floor(scene, ui, xy)      # pure: no lock, no thread, no clock
    outcome.scene   # the edited scene, or None when the scene stays as it is
    outcome.ui      # the new UI state (selection, draft, message, ...)

The controller calls such a function and applies its :class:`Outcome` inside *one*
critical section (``SessionState.transact``), so a read-decide-edit step -- finishing a
polygon, a click that closes it, deleting the selection -- can never interleave with
another browser's edit. A refused edit (a self-intersecting polygon, an index another user
just deleted) is an outcome too: the scene stays and the message says why.

Examples
--------
>>> from shapely import Polygon
>>> from planners.scene import Scene
>>> scene = Scene(obstacles=(Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), start=(5, 5), goal=(6, 6))
>>> ui = set_tool(UiState(), "polygon")
>>> for xy in [(3, 0), (4, 0), (4, 1)]:
...     ui = click_floor(scene, ui, xy).ui
>>> out = click_floor(scene, ui, (3.05, 0.02))  # near the first corner: closes it
>>> len(out.scene.obstacles), out.ui.draft
(2, ())
"""

from __future__ import annotations

__all__ = [
    "BLOCK_SIZE_M",
    "CLOSE_POLYGON_M",
    "KEEP",
    "LAYERS",
    "PICK_EDGE_M",
    "PICK_VERTEX_M",
    "TOOLS",
    "Handle",
    "Outcome",
    "Point",
    "Selection",
    "UiState",
    "cancel_polygon",
    "click_floor",
    "delete_selected",
    "delete_selected_obstacle",
    "drag",
    "edit",
    "finish_polygon",
    "handle_words",
    "insert_vertex_at_selection",
    "pick",
    "set_layer",
    "set_tool",
    "valid_selection",
]

import dataclasses
import math
from collections.abc import Callable, Hashable, Iterable, Mapping
from types import MappingProxyType
from typing import Any, Literal

import numpy as np
import shapely

import planners
from planners import scene as edits
from planners.registry import PlannerSpec
from planners.scene import ScenarioError, Scene

Point = tuple[float, float]
Handle = tuple[Any, ...]
"""A draggable thing: ``("start",)``, ``("goal",)``, ``("vertex", i, j)`` or ``("obstacle", i)``."""

TOOLS: Mapping[str, str] = MappingProxyType(
    {
        "drag": "Drag start and goal",
        "edit": "Edit obstacles (drag vertices, move, select)",
        "polygon": "Add obstacle: click its corners",
        "block": "Add a 1 m block: click the floor",
    }
)
"""Mouse tools by key, with the words the panel shows."""


def layer_names(registry: Mapping[str, PlannerSpec]) -> Mapping[str, str]:
    """Layers a user can toggle, by key, with the words the panel shows.

    The scene's layers, one or two per planner of ``registry`` as its kind says (a graph
    planner's edges and path, a trace planner's walk and events), then the robot's.

    Examples
    --------
    >>> list(layer_names(planners.REGISTRY))[4:8]
    ['vg_edges', 'vg_path', 'vg_edges_all', 'svg_edges']
    """
    out = {
        "obstacles": "Obstacles",
        "map": "Map (the occupancy grid under the obstacles)",
        "expanded": "Expanded obstacles",
        "other_expansion": "Other expansion model (outline)",
    }
    for name, spec in registry.items():
        short = name.upper()
        if spec.kind == "graph":
            out[f"{name}_edges"] = f"{short} edges"
            out[f"{name}_path"] = f"{short} path"
            # A big graph is drawn thinned (app.ui.thinning); this draws every edge.
            out[f"{name}_edges_all"] = f"{short} edges: all"
        else:
            out[f"{name}_path"] = f"{short} path and events"
    out["robot"] = "Robot"
    out["sensing"] = "DSB sensing disk and local tangent graph"
    return MappingProxyType(out)


LAYERS: Mapping[str, str] = layer_names(planners.REGISTRY)
"""The layers of the registered planners and the scene (:func:`layer_names`)."""

_DEFAULT_OFF = frozenset({"other_expansion"})

CLOSE_POLYGON_M = 0.25
"""A click closer than this to the first corner of the polygon being drawn closes it [m]."""
PICK_VERTEX_M = 0.3
"""A click closer than this to a vertex selects the vertex [m]."""
PICK_EDGE_M = 0.2
"""A click closer than this to an edge (and not near a vertex) selects the edge [m]."""
BLOCK_SIZE_M = 1.0
"""Side of the square the block tool drops [m]."""

_TOOL_HINTS: Mapping[str, str | None] = MappingProxyType(
    {
        "drag": None,
        "edit": "Drag the small squares to move vertices, the larger gizmo to move an obstacle; click an obstacle, a vertex or an edge to select it.",
        "polygon": "Click the corners of the new obstacle on the floor; click the first corner again (or press Finish) to close it.",
        "block": "Click the floor to drop a 1 m block there.",
    }
)


@dataclasses.dataclass(frozen=True)
class Selection:
    """What the user last clicked in the edit tool."""

    obstacle: int
    """Index of the obstacle."""
    vertex: int | None = None
    """Index of the vertex, when a vertex was clicked."""
    edge: int | None = None
    """Index of the edge (from vertex ``edge`` to ``edge + 1``), when an edge was clicked."""

    def describe(self) -> str:
        """Say what is selected, in the panel's words (1-based like the planners' reasons)."""
        what = f"obstacle {self.obstacle + 1}"
        if self.vertex is not None:
            return f"vertex {self.vertex + 1} of {what}"
        if self.edge is not None:
            return f"edge {self.edge + 1} of {what}"
        return what


def default_layers(
    registry: Mapping[str, PlannerSpec] = planners.REGISTRY,
) -> Mapping[str, bool]:
    """Return which layers of :func:`layer_names` show at first.

    All but the other model and the "edges: all" switches (a big graph starts thinned).
    """
    return MappingProxyType(
        {
            key: key not in _DEFAULT_OFF and not key.endswith("_edges_all")
            for key in layer_names(registry)
        }
    )


@dataclasses.dataclass(frozen=True)
class UiState:
    """The UI state all browsers of one session share; replaced whole, never changed."""

    tool: str = "drag"
    """Current mouse tool, a key of :data:`TOOLS`."""
    selection: Selection | None = None
    """The selected obstacle, vertex or edge."""
    draft: tuple[Point, ...] = ()
    """Corners of the obstacle being drawn with the polygon tool."""
    message: str | None = None
    """The answer to the user's last action, when it needs one."""
    layers: Mapping[str, bool] = dataclasses.field(default_factory=default_layers)
    """Layer key -> visible."""
    enabled: frozenset[str] = frozenset()
    """Names of the planners that run (the registry's default ones to begin with)."""
    follow: str = "vg"
    """Planner whose path the robot follows."""
    dragging: Mapping[Handle, Point] = dataclasses.field(
        default_factory=lambda: MappingProxyType({})
    )
    """Handles being dragged right now -> the last gizmo position seen [m]."""

    def say(self, message: str | None) -> UiState:
        """Return this state with ``message`` as the answer to the last action."""
        return dataclasses.replace(self, message=message)


KEEP: Literal["keep"] = "keep"
"""For :func:`edit`'s ``select``: leave the selection as it is (if still valid)."""


@dataclasses.dataclass(frozen=True)
class Outcome:
    """What a tool decided: the new UI state and, for an edit, the new scene."""

    ui: UiState
    """The UI state after the action."""
    scene: Scene | None = None
    """The edited scene; None when the scene stays (a selection, a refused edit)."""
    gesture: Hashable | None = None
    """Undo: the edit merges into the open step of this gesture; None: a step of its own."""
    phased: bool = False
    """The gesture has explicit phases (a drag): it merges until it is closed."""
    opens: bool = False
    """Close any open undo step before this edit (an edit of its own, a drag's start)."""
    closes: bool = False
    """Close the undo step after this edit (an edit of its own, a drag's end)."""


# --------------------------------------------------------------------------- edits


def edit(
    scene: Scene,
    ui: UiState,
    fn: Callable[[Scene], Scene],
    *,
    select: Selection | Literal["keep"] | None = KEEP,
    gesture: Hashable | None = None,
) -> Outcome:
    """Apply the pure edit ``fn``; a refused edit keeps the scene and says why.

    Parameters
    ----------
    scene, ui
        The current scene and UI state.
    fn
        Scene -> Scene; raises ``ScenarioError``, ``ValueError``, ``IndexError`` or
        ``TypeError`` to refuse (the message is shown as "Not done: ...").
    select
        The selection afterwards; :data:`KEEP` keeps the current one when still valid.
    gesture
        Undo gesture key (edits with one key close together merge); None: its own step.
    """
    try:
        new = fn(scene)
    except (ScenarioError, ValueError, IndexError, TypeError) as error:
        return Outcome(ui.say(f"Not done: {error}"))
    selection = ui.selection if select == KEEP else select
    ui = dataclasses.replace(
        ui, selection=valid_selection(selection, new), message=None
    )
    own_step = gesture is None
    return Outcome(ui, new, gesture, opens=own_step, closes=own_step)


def drag(scene: Scene, ui: UiState, handle: Handle, xy: Point, phase: str) -> Outcome:
    """Move ``handle`` to ``xy`` [m] in the drag phase ``phase`` ("start"/"update"/"end").

    A whole drag is one undo step (its gesture is the handle, opened at the start and
    closed at the end). An obstacle moves by how far its handle moved since the previous
    event, so its start only records where the handle is.
    """
    kind = handle[0]
    dragging = dict(ui.dragging)
    last = dragging.get(handle)
    if phase == "start":
        dragging[handle] = xy
        if kind == "obstacle":  # nothing moved yet
            return Outcome(_with_dragging(ui, dragging), opens=True)
    if phase == "end":
        dragging.pop(handle, None)
    else:
        dragging[handle] = xy
    ui = _with_dragging(ui, dragging)
    try:
        new = _moved(scene, handle, xy, last)
    except (IndexError, ValueError) as error:
        # The handle points at something another user just deleted.
        words = f"Could not move {handle_words(handle)}: {error}"
        return Outcome(ui.say(words), opens=phase == "start")
    return Outcome(
        ui,
        new,
        handle,
        phased=True,
        opens=phase == "start",
        closes=phase == "end" and new is not None,
    )


def _with_dragging(ui: UiState, dragging: dict[Handle, Point]) -> UiState:
    return dataclasses.replace(ui, dragging=MappingProxyType(dragging))


def _moved(scene: Scene, handle: Handle, xy: Point, last: Point | None) -> Scene | None:
    """Return the scene with ``handle`` at ``xy`` (None: an obstacle update without start)."""
    kind = handle[0]
    if kind == "start":
        return edits.move_start(scene, xy)
    if kind == "goal":
        return edits.move_goal(scene, xy)
    if kind == "vertex":
        _, i, j = handle
        return edits.move_vertex(scene, i, j, xy)
    if kind == "obstacle":
        if last is None:  # an update without its start: nothing to measure from
            return None
        return edits.move_obstacle(scene, handle[1], (xy[0] - last[0], xy[1] - last[1]))
    raise ValueError(f"unknown handle {handle!r}")


# --------------------------------------------------------------------------- mouse tools


def set_tool(ui: UiState, tool: str) -> UiState:
    """Choose what the mouse does (a key of :data:`TOOLS`); the draft is dropped."""
    if tool not in TOOLS:
        return ui.say(f"Unknown tool {tool!r}.")
    return dataclasses.replace(ui, tool=tool, draft=(), message=_TOOL_HINTS.get(tool))


def set_layer(ui: UiState, layer: str, visible: bool) -> UiState:
    """Show or hide a layer (a key of :data:`LAYERS`)."""
    if layer not in ui.layers:
        return ui.say(f"Unknown layer {layer!r}.")
    layers = MappingProxyType({**ui.layers, layer: bool(visible)})
    return dataclasses.replace(ui, layers=layers)


def click_floor(scene: Scene, ui: UiState, xy: Iterable[float]) -> Outcome:
    """React to a click on the floor at ``xy`` [m], according to the mouse tool.

    The block tool drops a block; the polygon tool adds a corner, or closes the polygon
    when the click is near its first corner; the other tools select what is clicked.
    """
    x, y = (float(v) for v in xy)
    if not (math.isfinite(x) and math.isfinite(y)):
        return Outcome(ui)
    if ui.tool == "block":
        h = BLOCK_SIZE_M / 2
        square = [(x - h, y - h), (x + h, y - h), (x + h, y + h), (x - h, y + h)]
        return edit(scene, ui, lambda s: edits.add_obstacle(s, square), select=None)
    if ui.tool == "polygon":
        draft = ui.draft
        if len(draft) >= 3 and math.dist(draft[0], (x, y)) < CLOSE_POLYGON_M:
            return finish_polygon(scene, ui)
        return Outcome(dataclasses.replace(ui, draft=(*draft, (x, y))))
    return Outcome(dataclasses.replace(ui, selection=pick(scene, (x, y)), message=None))


def finish_polygon(scene: Scene, ui: UiState) -> Outcome:
    """Close the polygon being drawn and add it as an obstacle (the draft is kept if refused)."""
    draft = ui.draft
    if len(draft) < 3:
        return Outcome(ui.say("Click at least 3 corners on the floor first."))
    out = edit(scene, ui, lambda s: edits.add_obstacle(s, draft), select=None)
    if out.scene is None:
        return out
    return dataclasses.replace(out, ui=dataclasses.replace(out.ui, draft=()))


def cancel_polygon(ui: UiState) -> UiState:
    """Forget the corners clicked so far."""
    return dataclasses.replace(ui, draft=())


def delete_selected(scene: Scene, ui: UiState) -> Outcome:
    """Delete the selected vertex, or the selected obstacle when no vertex is selected."""
    selection = ui.selection
    if selection is None:
        return Outcome(
            ui.say("Select an obstacle or a vertex first (Edit tool, click it).")
        )
    i, j = selection.obstacle, selection.vertex
    if j is not None:
        return edit(
            scene, ui, lambda s: edits.delete_vertex(s, i, j), select=Selection(i)
        )
    return edit(scene, ui, lambda s: edits.delete_obstacle(s, i), select=None)


def delete_selected_obstacle(scene: Scene, ui: UiState) -> Outcome:
    """Delete the obstacle the selection belongs to."""
    selection = ui.selection
    if selection is None:
        return Outcome(ui.say("Select an obstacle first (Edit tool, click it)."))
    i = selection.obstacle
    return edit(scene, ui, lambda s: edits.delete_obstacle(s, i), select=None)


def insert_vertex_at_selection(scene: Scene, ui: UiState) -> Outcome:
    """Insert a vertex in the middle of the selected edge (or after the selected vertex)."""
    selection = ui.selection
    if selection is None or (selection.edge is None and selection.vertex is None):
        return Outcome(
            ui.say("Select an edge or a vertex first (Edit tool, click near it).")
        )
    i = selection.obstacle
    j = selection.edge if selection.edge is not None else selection.vertex
    assert j is not None
    return edit(
        scene,
        ui,
        lambda s: edits.insert_vertex(s, i, j, None),
        select=Selection(i, vertex=j + 1),
    )


# --------------------------------------------------------------------------- picking


def handle_words(handle: Handle) -> str:
    """Name a handle in the panel's words (1-based)."""
    if handle[0] == "vertex":
        return f"vertex {handle[2] + 1} of obstacle {handle[1] + 1}"
    if handle[0] == "obstacle":
        return f"obstacle {handle[1] + 1}"
    return str(handle[0])


def valid_selection(selection: Selection | None, scene: Scene) -> Selection | None:
    """Return ``selection`` if it still names something in ``scene``, else what is left of it."""
    if selection is None or selection.obstacle >= len(scene.obstacles):
        return None
    n = len(scene.obstacles[selection.obstacle].exterior.coords) - 1
    if (selection.vertex is not None and selection.vertex >= n) or (
        selection.edge is not None and selection.edge >= n
    ):
        return Selection(selection.obstacle)
    return selection


def pick(scene: Scene, xy: Point) -> Selection | None:
    """Find what a click at ``xy`` [m] selects: a vertex, else an edge, else an obstacle.

    Parameters
    ----------
    scene
        The scene.
    xy
        The clicked floor point [m].

    Returns
    -------
    Selection or None
        None when the click is far from every obstacle.

    Examples
    --------
    >>> from shapely import Polygon
    >>> s = Scene(obstacles=(Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), start=(5, 5), goal=(6, 6))
    >>> pick(s, (2.1, 2.05)), pick(s, (1.0, 0.1)), pick(s, (1, 1)), pick(s, (4, 4))
    (Selection(obstacle=0, vertex=2, edge=None), Selection(obstacle=0, vertex=None, edge=0), Selection(obstacle=0, vertex=None, edge=None), None)
    """
    p = np.asarray(xy, dtype=np.float64)
    return _pick_vertex(scene, p) or _pick_edge(scene, p) or _pick_inside(scene, p)


def _pick_vertex(scene: Scene, p: np.ndarray) -> Selection | None:
    best: tuple[float, Selection] | None = None
    for i, polygon in enumerate(scene.obstacles):
        ring = np.asarray(polygon.exterior.coords, dtype=np.float64)[:-1]
        d = np.hypot(*(ring - p).T)
        j = int(np.argmin(d))
        if d[j] < PICK_VERTEX_M and (best is None or d[j] < best[0]):
            best = (float(d[j]), Selection(i, vertex=j))
    return None if best is None else best[1]


def _pick_edge(scene: Scene, p: np.ndarray) -> Selection | None:
    best: tuple[float, Selection] | None = None
    for i, polygon in enumerate(scene.obstacles):
        ring = np.asarray(polygon.exterior.coords, dtype=np.float64)
        a, b = ring[:-1], ring[1:]
        ab = b - a
        t = np.clip(
            np.einsum("ij,ij->i", p - a, ab)
            / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300),
            0,
            1,
        )
        d = np.hypot(*(a + t[:, None] * ab - p).T)
        j = int(np.argmin(d))
        if d[j] < PICK_EDGE_M and (best is None or d[j] < best[0]):
            best = (float(d[j]), Selection(i, edge=j))
    return None if best is None else best[1]


def _pick_inside(scene: Scene, p: np.ndarray) -> Selection | None:
    point = shapely.Point(p)
    for i, polygon in enumerate(scene.obstacles):
        shape = polygon if polygon.is_valid else shapely.make_valid(polygon)
        if shape.covers(point):
            return Selection(i)
    return None
