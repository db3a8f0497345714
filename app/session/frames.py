"""What the views draw: a :class:`Frame` (one consistent snapshot) and a :class:`RobotPose`.

Data flow::

    scheduler round: Snapshot of the session + plans for its version + trajectory
      -> build_frame(...)            # pure: problems in words, selection still valid
      -> Views.render(frame)         # every view, one thread at a time
    playback: Views.render_robot(pose)

Views are objects with ``render(frame)`` and ``render_robot(pose)`` (:class:`View`): the
3-D view, the panel, a test's fake, a benchmark's probe. The controller never imports
viser.
"""

from __future__ import annotations

__all__ = ["Frame", "RobotPose", "View", "Views", "build_frame"]

import dataclasses
import threading
from collections.abc import Mapping, Sequence
from typing import Any, Protocol

from shapely import Polygon

from app.session import tools
from app.session._state import Snapshot
from app.session.tools import Handle, Point, Selection
from planners import scene as edits
from planners.scene import Scene


@dataclasses.dataclass(frozen=True)
class RobotPose:
    """The robot at one instant of its trajectory."""

    t: float
    """Time since the start of the trajectory [s]."""
    duration: float
    """Length of the whole trajectory [s]."""
    xy: Point
    """Position of the robot's centre [m]."""
    phi: float
    """Heading: world angle of the forward axis y_m [rad]."""
    wheel_angles: tuple[float, ...]
    """Rotation of each wheel about its axle [rad]."""
    wheel_rates: tuple[float, ...]
    """Angular velocity of each wheel [rad/s] (eq. 9.5 or 9.9)."""
    velocity: tuple[float, float, float]
    """World velocity (xdot, ydot, phidot) [m/s, m/s, rad/s]."""
    playing: bool
    """True while the animation runs."""
    planner: str
    """Which planner's path the robot follows."""
    sensing: Any = None
    """For a DSB run: what the robot senses here (the planner's own object), else None."""


@dataclasses.dataclass(frozen=True)
class Frame:
    """Everything the views draw, for one scene version: always self-consistent."""

    version: int
    """Scene version the plans were computed for (increases with every edit)."""
    scene: Scene
    """The scene."""
    plans: Mapping[str, Any]
    """Planner name -> result, plus ``"cspace"`` when it was built."""
    problems: tuple[str, ...]
    """What is wrong with the scene or why a planner found no path, in words."""
    message: str | None
    """The answer to the user's last action, when it needs one (a refused edit, a save)."""
    tool: str
    """Current mouse tool, a key of :data:`app.session.tools.TOOLS`."""
    layers: Mapping[str, bool]
    """Layer key -> visible."""
    selection: Selection | None
    """The selected obstacle, vertex or edge."""
    draft: tuple[Point, ...]
    """Corners of the obstacle being drawn with the polygon tool."""
    dragging: frozenset[Handle]
    """Handles a user is dragging right now: views leave their gizmos alone."""
    can_undo: bool
    """Whether there is something to undo."""
    can_redo: bool
    """Whether there is something to redo."""
    follow: str
    """Planner whose path the robot follows."""
    trajectory: Any
    """The robot's timed trajectory along that path, or None."""
    other_expanded: tuple[Polygon, ...] | None
    """The obstacles expanded with the other model, when that layer is on."""
    scenario: str
    """Key of the scenario the scene came from ('' when loaded from elsewhere)."""
    compute_ms: float
    """Time to compute the plans [ms]."""
    lagging: frozenset[str] = frozenset()
    """Slow planners whose result shown is for a slightly older scene (during a drag)."""
    slow_version: int = -1
    """Scene version the slow planners' results shown were computed for (-1: none)."""
    floor_map: Any = None
    """The occupancy map the scene was imported from (:mod:`planners.maps`), or None:
    the view lays it on the floor."""
    enabled: frozenset[str] = frozenset()
    """Planners switched on (their lanes run them); the others have no entry in ``plans``."""
    progress: str | None = None
    """What a big scene's worker computes now and for how long (:mod:`app.session.big`), or None."""
    stale: bool = False
    """The plans are an older scene's, kept (greyed) while the new ones are computed."""


class View(Protocol):
    """What the controller draws on (the 3-D view, the panels, a test's fake)."""

    def render(self, frame: Frame) -> None:
        """Show one consistent state: a scene with the results computed for it."""

    def render_robot(self, pose: RobotPose | None) -> None:
        """Show the robot at one instant of its trajectory (None hides it)."""


class Views:
    """Every view of one session, drawn by one thread at a time.

    The scheduler's round and the robot's animation both draw; viser's handles (and a
    test's fake view) are not meant to be assigned from two threads at once.
    """

    def __init__(self, views: View | Sequence[View]) -> None:
        self._views: tuple[View, ...] = (
            tuple(views) if isinstance(views, Sequence) else (views,)
        )
        self._drawing = threading.Lock()

    def add(self, view: View) -> None:
        """Draw on one more view from the next frame on."""
        with self._drawing:
            self._views = (*self._views, view)

    def clear(self) -> None:
        """Draw on no view from now on (waits for a drawing under way to end)."""
        with self._drawing:
            self._views = ()

    def render(self, frame: Frame) -> None:
        """Show ``frame`` on every view."""
        with self._drawing:
            for view in self._views:
                view.render(frame)

    def render_with_robot(self, frame: Frame, pose: RobotPose | None) -> None:
        """Show ``frame``, then the robot at ``pose``, with no other drawing in between."""
        with self._drawing:
            for view in self._views:
                view.render(frame)
            for view in self._views:
                view.render_robot(pose)

    def render_robot(self, pose: RobotPose | None) -> None:
        """Show the robot on every view."""
        with self._drawing:
            for view in self._views:
                view.render_robot(pose)


def build_frame(
    snapshot: Snapshot,
    plans: Mapping[str, Any],
    *,
    trajectory: Any,
    other: tuple[Polygon, ...] | None,
    compute_ms: float,
    lagging: frozenset[str] = frozenset(),
    slow_version: int = -1,
) -> Frame:
    """Make the frame of ``snapshot`` with the ``plans`` computed for its scene (pure).

    ``problems`` lists the scene's own problems, then each planner's reason for having no
    path (not for a lagging result: it belongs to an older scene); one reason given by
    several planners is said once ("VG, SVG: the goal is ...").
    """
    scene = snapshot.scene
    problems = list(edits.scene_problems(scene))
    # Planner names by reason, in the order the reasons first come.
    reasons: dict[str, list[str]] = {}
    for name, result in plans.items():
        if name == "cspace" or name in lagging:
            continue
        reason = getattr(result, "reason", None)
        status = getattr(result, "status", "")
        if reason and status != "ok" and reason not in problems:
            reasons.setdefault(reason, []).append(name.upper())
    problems += [f"{', '.join(names)}: {reason}" for reason, names in reasons.items()]
    ui = snapshot.ui
    return Frame(
        version=snapshot.version,
        scene=scene,
        plans=plans,
        problems=tuple(problems),
        message=ui.message,
        tool=ui.tool,
        layers=dict(ui.layers),
        selection=tools.valid_selection(ui.selection, scene),
        draft=ui.draft,
        dragging=frozenset(ui.dragging),
        can_undo=snapshot.can_undo,
        can_redo=snapshot.can_redo,
        follow=ui.follow,
        trajectory=trajectory,
        other_expanded=other,
        scenario=snapshot.scenario,
        floor_map=snapshot.floor_map,
        compute_ms=compute_ms,
        lagging=lagging,
        slow_version=slow_version,
        enabled=ui.enabled,
    )
