"""The app's state and every edit a user can make, behind one lock.

The controller owns the current :class:`planners.Scene`, the planners' results for it,
the undo and redo stacks and the small amount of UI state that all browsers share (mouse
tool, selection, layer toggles, robot playback). It never imports viser: it talks to
*views*, objects with ``render(frame)`` and ``render_robot(pose)`` methods, so tests pass a
fake view and the app passes the 3-D view and the panels.

Data flow on an edit (DESIGN.md)::

    viser callback (event loop or worker thread)
      -> controller.drag_handle(...)          # cheap: pure edit under the lock, version += 1
      -> worker thread wakes up               # one thread: results come out in order
           plans = plan(scene)                # pure, outside the lock
           view.render(frame)                 # frame = (scene, plans) of one version

Edits are applied to the scene at once, so nothing a user does is ever dropped; the
expensive recompute is *coalesced*: while the worker computes version 5, edits 6, 7 and 8
arrive, and the worker's next round computes only version 8. Because one thread computes
and renders, and it renders only versions newer than the last one drawn, a stale result
never overwrites a newer one.
"""

from __future__ import annotations

__all__ = [
    "FAST_PLANNERS",
    "LAYERS",
    "TOOLS",
    "Controller",
    "Frame",
    "Handle",
    "Pending",
    "PlanFn",
    "RobotPose",
    "SampleFn",
    "Selection",
    "TrajectoryFn",
    "View",
    "default_plan",
    "pick",
    "split_planners",
]

import dataclasses
import functools
import json
import logging
import math
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
import shapely
from shapely import Polygon

import planners
from app.lanes import ProcessLane, picklable_registry
from planners import scene as edits
from planners.scene import ScenarioError, Scene

logger = logging.getLogger(__name__)

Point = tuple[float, float]
Handle = tuple[Any, ...]
"""A draggable thing: ``("start",)``, ``("goal",)``, ``("vertex", i, j)`` or ``("obstacle", i)``."""

PlanFn = Callable[[Scene], Mapping[str, Any]]
"""Scene -> planner name -> result (plus ``"cspace"``), like :func:`planners.plan_all`."""

TrajectoryFn = Callable[[Scene, npt.NDArray[np.float64]], Any]
"""(scene, path (N, 2)) -> a timed trajectory object, or None when there is none.

It may depend on the scene's robot and the path only: the controller keeps the trajectory
while both stay the same."""

SampleFn = Callable[[Any, float, Scene, Any], Mapping[str, Any]]
"""(trajectory, t [s], scene, planner result followed) -> RobotPose fields (xy, phi, ...)."""

TOOLS: dict[str, str] = {
    "drag": "Drag start and goal",
    "edit": "Edit obstacles (drag vertices, move, select)",
    "polygon": "Add obstacle: click its corners",
    "block": "Add a 1 m block: click the floor",
}
"""Mouse tools by key, with the words the panel shows."""

LAYERS: dict[str, str] = {
    "obstacles": "Obstacles",
    "expanded": "Expanded obstacles",
    "other_expansion": "Other expansion model (outline)",
    "vg_edges": "VG edges",
    "vg_path": "VG path",
    "svg_edges": "SVG edges",
    "svg_path": "SVG path",
    "dsb_path": "DSB path and events",
    "robot": "Robot",
    "sensing": "DSB sensing disk and local tangent graph",
}
"""Layers a user can toggle, by key, with the words the panel shows."""

_DEFAULT_OFF = frozenset({"other_expansion"})

# Consecutive edits of the same kind without explicit drag phases (a slider being
# dragged, a number being typed) merge into one undo step when closer than this [s].
_MERGE_WINDOW_S = 1.0
# A click closer than this to the first corner of the polygon being drawn closes it [m].
_CLOSE_POLYGON_M = 0.25
# A click closer than this to a vertex (edge) selects the vertex (edge) [m].
_PICK_VERTEX_M = 0.3
_PICK_EDGE_M = 0.2
_BLOCK_SIZE_M = 1.0
# A slow lane in a thread of this process (planners that cannot be sent to a worker
# process) shares the interpreter lock with the fast lane: it starts on a new scene once
# the fast lane has drawn it, or after this [s]. A worker process starts at once.
_SLOW_LANE_YIELD_S = 0.03


class View(Protocol):
    """What the controller draws on (the 3-D view, the panels, a test's fake)."""

    def render(self, frame: Frame) -> None:
        """Show one consistent state: a scene with the results computed for it."""

    def render_robot(self, pose: RobotPose | None) -> None:
        """Show the robot at one instant of its trajectory (None hides it)."""


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
    """Current mouse tool, a key of :data:`TOOLS`."""
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


FAST_PLANNERS = ("vg", "svg")
"""Planners computed first on every edit; the others (DSB) follow in a second lane."""


def default_plan(scene: Scene, which: Iterable[str] | None = None) -> dict[str, Any]:
    """Run the planners ``which`` (default: all of :data:`planners.PLANNERS`) on ``scene``.

    If running them all together fails (a bug in one planner), each planner is run on its
    own, so one broken planner never takes the others down with it.
    """
    which = tuple(planners.PLANNERS) if which is None else tuple(which)
    try:
        return dict(planners.plan_all(scene, which=which))
    except Exception:
        logger.exception("plan_all failed; running the planners one by one")
    results: dict[str, Any] = {}
    for name in which:
        try:
            results.update(planners.plan_all(scene, which=(name,)))
        except Exception as error:
            logger.exception("planner %s failed", name)
            results[name] = _failed(
                name, f"{name.upper()} failed: {type(error).__name__}: {error}"
            )
    return results


# Stands for "a new trajectory must be planned" in Controller._trajectory_lookup.
_PLAN = object()


def _same_key(a: tuple[Any, ...], b: tuple[Any, ...]) -> bool:
    """Compare two (version, planner, result) keys, the result by identity."""
    return a[:2] == b[:2] and a[2] is b[2]


def _outcome(status: str | None) -> str | None:
    """Say what a status tells of the goal: reached ("path"), cut off ("none"), or neither."""
    if status in ("ok", "reached"):
        return "path"
    if status == "unreachable":
        return "none"
    return None


def _may_lag(
    fast: Mapping[str, Any], shown: Scene, current: Scene, result: Any
) -> bool:
    """Whether a slow ``result`` for ``shown`` may stand in for ``current`` while it computes.

    Only during an edit of the same setting (same walls and number of obstacles, so not
    a new scenario), and only when it tells the same story as the fast planners do for
    the current scene: a path when they find one, "unreachable" when the goal is cut
    off. When the scene is invalid, or the goal was just cut off (or freed), the slow
    planner shows no path rather than an old one that would contradict the others.
    """
    if shown.boundary != current.boundary or len(shown.obstacles) != len(
        current.obstacles
    ):
        return False
    outcomes = {
        _outcome(getattr(r, "status", None)) for n, r in fast.items() if n != "cspace"
    }
    return (
        len(outcomes) == 1
        and None not in outcomes
        and outcomes == {_outcome(getattr(result, "status", None))}
    )


def _invalid_reason(fast: Mapping[str, Any]) -> str | None:
    """Return why the scene cannot be planned at all, if the fast planners found a reason.

    Such a verdict (start or goal inside an obstacle, a self-intersecting polygon) is the
    same for every planner, so the slow planners need not be waited for.
    """
    for name, result in fast.items():
        if name != "cspace" and getattr(result, "status", None) == "invalid":
            return str(getattr(result, "reason", None) or "the scene is not valid")
    return None


def split_planners(names: Iterable[str]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Split planner names into the fast lane (VG, SVG) and the slow lane (the rest).

    Examples
    --------
    >>> split_planners(["vg", "svg", "dsb"])
    (('vg', 'svg'), ('dsb',))
    """
    names = tuple(names)
    fast = tuple(n for n in names if n in FAST_PLANNERS)
    return fast, tuple(n for n in names if n not in fast)


@dataclasses.dataclass(frozen=True)
class Pending:
    """A slow planner's place-holder while it computes: no path yet, never a stale one."""

    planner: str
    status: str = "computing"
    reason: str | None = None
    length: float | None = None
    path: npt.NDArray[np.float64] = dataclasses.field(
        default_factory=lambda: np.zeros((0, 2))
    )
    ms: float = 0.0


@dataclasses.dataclass(frozen=True)
class _Failed:
    """A planner that raised: no path, and the error in words."""

    planner: str
    reason: str
    status: str = "error"
    length: float | None = None
    path: npt.NDArray[np.float64] = dataclasses.field(
        default_factory=lambda: np.zeros((0, 2))
    )
    ms: float = 0.0


def _failed(name: str, reason: str) -> _Failed:
    return _Failed(name, reason)


@dataclasses.dataclass
class _Playback:
    """Robot playback state (guarded by the controller's lock)."""

    t: float = 0.0
    playing: bool = False
    speed: float = 1.0
    wall: float = 0.0  # time.monotonic() at the last advance


class Controller:
    """Own the scene and the results; apply edits; drive the views.

    Parameters
    ----------
    views
        Objects with ``render(frame)`` and ``render_robot(pose)``; called from the
        controller's worker thread (and the animation thread for the robot), never
        concurrently.
    scene
        The scene to start with.
    plan
        Scene -> results of the fast planners (and ``"cspace"``); by default VG and SVG.
        Drawn as soon as they are ready.
    slow_plan
        Scene -> results of the slow planners (DSB), computed in a second thread for the
        newest scene and drawn when ready; until then those planners show no path. By
        default every other planner of :data:`planners.PLANNERS`; without it (a test
        passing only ``plan``) there is no second lane.
    slow_names
        Names of the planners ``slow_plan`` computes (default: the registered ones that
        are not in :data:`FAST_PLANNERS`).
    slow_process
        Compute the default slow planners in a worker process (see :mod:`app.lanes`);
        False keeps them in a thread.
    trajectory
        (scene, path) -> timed trajectory (or None); None disables the robot.
    sample
        (trajectory, t, scene, result followed) -> the other :class:`RobotPose` fields as
        a mapping; None disables the robot.
    scenarios
        Scenario key -> file, for :meth:`load_scenario`.
    scenario
        Key of the starting scene in ``scenarios`` ('' if none).
    fps
        Animation rate of the robot [frames/s].
    """

    def __init__(
        self,
        views: View | Sequence[View],
        scene: Scene,
        *,
        plan: PlanFn | None = None,
        slow_plan: PlanFn | None = None,
        slow_names: Sequence[str] | None = None,
        slow_process: bool = True,
        trajectory: TrajectoryFn | None = None,
        sample: SampleFn | None = None,
        scenarios: Mapping[str, Path] | None = None,
        scenario: str = "",
        fps: float = 30.0,
    ) -> None:
        self._views: list[View] = (
            list(views) if isinstance(views, Sequence) else [views]
        )
        fast, slow = split_planners(planners.PLANNERS)
        self._lane: ProcessLane | None = None
        if plan is None:
            self._plan: PlanFn = functools.partial(default_plan, which=fast)
            if slow_plan is None and slow:
                slow_plan = functools.partial(default_plan, which=slow)
                registry = (
                    picklable_registry(planners.PLANNERS) if slow_process else None
                )
                if registry is not None:
                    # A process of its own: TangentBug would otherwise hold the GIL
                    # against the VG/SVG lane (see app.lanes).
                    self._lane = ProcessLane(slow_plan, registry)
                    slow_plan = self._lane
        else:
            self._plan = plan
        self._slow_plan: PlanFn | None = slow_plan
        if slow_plan is None:
            slow = ()
        elif slow_names is not None:
            slow = tuple(slow_names)
        self._slow_names: tuple[str, ...] = slow
        self._trajectory_fn = trajectory
        self._sample_fn = sample
        self._scenarios: dict[str, Path] = dict(scenarios or {})
        self._fps = fps

        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)
        self._render_lock = threading.Lock()  # views are drawn by one thread at a time

        # Scene state.
        self._scene = scene
        self._version = 0
        self._scenario = scenario
        self._undo: list[tuple[Scene, str]] = []
        self._redo: list[tuple[Scene, str]] = []
        self._gesture: tuple[Any, ...] | None = (
            None  # key of the edit an undo step is open for
        )
        self._gesture_time = 0.0
        self._gesture_phased = False
        self._dragging: dict[Handle, Point] = {}  # handle -> last gizmo position seen

        # Shared UI state.
        self._ui_version = 0
        self._tool = "drag"
        self._layers = {key: key not in _DEFAULT_OFF for key in LAYERS}
        self._selection: Selection | None = None
        self._draft: list[Point] = []
        self._message: str | None = None
        self._follow = "vg"
        self._playback = _Playback()

        # Results.
        self._computed: tuple[int, Scene, Mapping[str, Any], float] | None = None
        self._computed_trajectory: tuple[Any, Any] = (None, None)  # (key, trajectory)
        # What that trajectory was computed from: (planner, robot, path bytes).
        self._trajectory_value: tuple[Any, ...] | None = None
        # Newest slow results: (version, scene, results).
        self._slow: tuple[int, Scene | None, Mapping[str, Any]] = (-1, None, {})
        self._slow_tried = -1  # newest version the slow lane has started on
        self._slow_busy = False
        self._other: tuple[Any, tuple[Polygon, ...] | None] = (None, None)
        self._rendered = (-1, -1)  # (scene version, ui version) last drawn
        self._busy = False
        self._closed = False
        self._last_frame: Frame | None = None

        self._worker = threading.Thread(
            target=self._work, name="planner-worker", daemon=True
        )
        self._worker.start()
        self._slow_worker: threading.Thread | None = None
        if self._slow_plan is not None:
            self._slow_worker = threading.Thread(
                target=self._work_slow, name="slow-planner-worker", daemon=True
            )
            self._slow_worker.start()
        self._animator = threading.Thread(
            target=self._animate, name="robot-animation", daemon=True
        )
        self._animator.start()

    # ------------------------------------------------------------------ reading state

    @property
    def scene(self) -> Scene:
        """The current scene (the newest edit, maybe not yet planned)."""
        with self._lock:
            return self._scene

    @property
    def version(self) -> int:
        """Version of the current scene; every edit increases it by one."""
        with self._lock:
            return self._version

    @property
    def frame(self) -> Frame | None:
        """The last frame drawn (None before the first)."""
        with self._lock:
            return self._last_frame

    @property
    def plans(self) -> Mapping[str, Any]:
        """The results of the last frame drawn (empty before the first)."""
        frame = self.frame
        return frame.plans if frame is not None else {}

    @property
    def message(self) -> str | None:
        """The answer to the last action, when it needs one."""
        with self._lock:
            return self._message

    @property
    def scenarios(self) -> dict[str, Path]:
        """Scenario key -> file."""
        return dict(self._scenarios)

    @property
    def playback(self) -> tuple[float, bool, float]:
        """(time [s], playing, speed) of the robot."""
        with self._lock:
            p = self._playback
            return (p.t, p.playing, p.speed)

    def add_view(self, view: View) -> None:
        """Draw on one more view from the next frame on (a benchmark's probe, a recorder)."""
        with self._render_lock:
            self._views = [*self._views, view]
        with self._wake:
            self._ui_version += 1
            self._wake.notify_all()

    @property
    def slow_planners(self) -> tuple[str, ...]:
        """Planners computed in the second lane (DSB), shown when ready."""
        return self._slow_names

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Block until every edit is planned and drawn; False if ``timeout`` [s] passed."""
        deadline = time.monotonic() + timeout
        with self._wake:
            while not self._idle_locked():
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self._closed:
                    return self._idle_locked()
                self._wake.wait(min(remaining, 0.05))
            return True

    def _idle_locked(self) -> bool:
        slow_done = self._slow_plan is None or (
            not self._slow_busy and self._slow_tried == self._version
        )
        return (
            slow_done
            and not self._busy
            and self._rendered == (self._version, self._ui_version)
        )

    def close(self) -> None:
        """Stop the worker and animation threads (the views are left as they are)."""
        with self._wake:
            self._closed = True
            self._wake.notify_all()
        if self._lane is not None:
            self._lane.close()
        for thread in (self._worker, self._animator, self._slow_worker):
            if thread is not None and thread is not threading.current_thread():
                thread.join(timeout=5.0)

    # ------------------------------------------------------------------ scene edits

    def drag_handle(
        self, handle: Handle, xy: Iterable[float], phase: str = "update"
    ) -> None:
        """Move a handle to ``xy`` [m]; ``phase`` is the gizmo's "start"/"update"/"end".

        A whole drag (start to end) is one undo step. Obstacle handles move the obstacle
        by how far the handle moved since the previous event.
        """
        x, y = (float(v) for v in xy)
        if not (math.isfinite(x) and math.isfinite(y)):
            return
        kind = handle[0]
        with self._wake:
            if phase == "start":
                self._dragging[handle] = (x, y)
                # The undo step is pushed by the drag's first edit that changes the scene.
                self._close_gesture_locked()
                self._ui_version += 1
                self._wake.notify_all()
                if kind == "obstacle":
                    return  # nothing moved yet
            last = self._dragging.get(handle)
            if phase == "end":
                self._dragging.pop(handle, None)
                self._ui_version += 1
            else:
                self._dragging[handle] = (x, y)
            try:
                if kind == "start":
                    new = edits.move_start(self._scene, (x, y))
                elif kind == "goal":
                    new = edits.move_goal(self._scene, (x, y))
                elif kind == "vertex":
                    _, i, j = handle
                    new = edits.move_vertex(self._scene, i, j, (x, y))
                elif kind == "obstacle":
                    (_, i) = handle
                    if (
                        last is None
                    ):  # an update without its start: nothing to measure from
                        self._dragging[handle] = (x, y)
                        return
                    new = edits.move_obstacle(
                        self._scene, i, (x - last[0], y - last[1])
                    )
                else:
                    raise ValueError(f"unknown handle {handle!r}")
            except (IndexError, ValueError) as error:
                # The handle points at something another user just deleted.
                self._say_locked(f"Could not move {_handle_words(handle)}: {error}")
                self._wake.notify_all()
                return
            self._commit_locked(new, key=handle, phased=True)
            if phase == "end":
                self._close_gesture_locked()
            self._wake.notify_all()

    def move_start(self, xy: Iterable[float]) -> None:
        """Move the start to ``xy`` [m] (one undo step)."""
        self._edit(lambda s: edits.move_start(s, xy), key=None)

    def move_goal(self, xy: Iterable[float]) -> None:
        """Move the goal to ``xy`` [m] (one undo step)."""
        self._edit(lambda s: edits.move_goal(s, xy), key=None)

    def move_vertex(self, i: int, j: int, xy: Iterable[float]) -> None:
        """Move vertex ``j`` of obstacle ``i`` to ``xy`` [m] (one undo step)."""
        self._edit(lambda s: edits.move_vertex(s, i, j, xy), key=None)

    def insert_vertex(self, i: int, j: int, xy: Iterable[float] | None = None) -> None:
        """Insert a vertex after vertex ``j`` of obstacle ``i`` (mid-edge without ``xy``)."""
        self._edit(
            lambda s: edits.insert_vertex(s, i, j, xy),
            key=None,
            select=Selection(i, vertex=j + 1),
        )

    def delete_vertex(self, i: int, j: int) -> None:
        """Delete vertex ``j`` of obstacle ``i`` (refused for a triangle, with a message)."""
        self._edit(
            lambda s: edits.delete_vertex(s, i, j), key=None, select=Selection(i)
        )

    def add_obstacle(self, coords: Sequence[Iterable[float]]) -> None:
        """Add an obstacle polygon (refused with a message if it intersects itself)."""
        self._edit(lambda s: edits.add_obstacle(s, coords), key=None, select=None)

    def delete_obstacle(self, i: int) -> None:
        """Delete obstacle ``i``."""
        self._edit(lambda s: edits.delete_obstacle(s, i), key=None, select=None)

    def move_obstacle(self, i: int, delta: Iterable[float]) -> None:
        """Translate obstacle ``i`` by ``delta`` = (dx, dy) [m]."""
        self._edit(lambda s: edits.move_obstacle(s, i, delta), key=None)

    def set_robot(self, **changes: Any) -> None:
        """Change robot fields, e.g. ``set_robot(radius=0.2)`` or ``set_robot(kind="differential")``.

        Values are checked like a scenario file's; a refused value leaves the scene as it
        was and says why in the panel.
        """

        def apply(scene: Scene) -> Scene:
            robot = dataclasses.replace(scene.robot, **changes)
            data = edits.scene_to_dict(dataclasses.replace(scene, robot=robot))
            edits.scene_from_dict(
                data, "robot settings"
            )  # validates; raises ScenarioError
            return dataclasses.replace(scene, robot=robot)

        self._edit(apply, key=("robot", *sorted(changes)))

    def set_expansion(self, mode: str) -> None:
        """Choose the expansion model, ``"disk"`` or ``"square"``."""

        def apply(scene: Scene) -> Scene:
            if mode not in edits.EXPANSION_MODES:
                raise ValueError(
                    f"expansion must be one of {', '.join(edits.EXPANSION_MODES)}, got {mode!r}"
                )
            return dataclasses.replace(scene, expansion=mode)

        self._edit(apply, key=("expansion",))

    def set_sensor_range(self, sensor_range: float) -> None:
        """Set the DSB sensor range R [m] (positive)."""

        def apply(scene: Scene) -> Scene:
            r = float(sensor_range)
            if not (r > 0 and math.isfinite(r)):
                raise ValueError(
                    f"the sensor range must be a positive number, got {sensor_range!r}"
                )
            return dataclasses.replace(scene, sensor_range=r)

        self._edit(apply, key=("sensor_range",))

    def replace_scene(self, scene: Scene, scenario: str = "") -> None:
        """Replace the whole scene (one undo step, so a switch can be undone)."""
        with self._wake:
            self._close_gesture_locked()
            self._selection = None
            self._draft.clear()
            self._commit_locked(
                scene, key=None, phased=False
            )  # undo keeps the old scenario
            self._scenario = scenario
            self._say_locked(None)
            self._wake.notify_all()

    # ------------------------------------------------------------------ files

    def load_scenario(self, key: str) -> None:
        """Switch to scenario ``key`` (see :attr:`scenarios`); the old scene can be undone."""
        path = self._scenarios.get(key)
        if path is None:
            self._say(f"Unknown scenario {key!r}.")
            return
        self._load(path, key)

    def load_file(self, path: str | Path) -> None:
        """Load a scenario file; on an error the panel says why and the scene is kept."""
        text = str(path).strip()
        if not text:
            self._say("Type the path of a scenario file to load.")
            return
        self._load(Path(text).expanduser(), "")

    def load_text(self, text: str | bytes, source: str = "uploaded file") -> None:
        """Load a scenario from JSON text (an upload); errors go to the panel."""
        try:
            scene = edits.scene_from_dict(json.loads(text), source)
        except ScenarioError as error:
            self._say(f"Not loaded, the scene is kept: {error}")
            return
        except (ValueError, UnicodeDecodeError) as error:
            self._say(
                f"Not loaded, the scene is kept: {source}: not valid JSON ({error})"
            )
            return
        self.replace_scene(scene, "")
        self._say(f"Loaded {source}.")

    def _load(self, path: Path, key: str) -> None:
        try:
            scene = planners.load_scene(path)
        except ScenarioError as error:
            self._say(f"Not loaded, the scene is kept: {error}")
            return
        self.replace_scene(scene, key)
        if not key:
            self._say(f"Loaded {path}.")

    def save(self, path: str | Path) -> None:
        """Save the scene to ``path`` (atomically); the panel says where, or why not."""
        text = str(path).strip()
        if not text:
            self._say("Type a file name to save to, e.g. my_scene.json.")
            return
        target = Path(text).expanduser()
        if target.suffix == "":
            target = target.with_suffix(".json")
        scene = self.scene
        try:
            written = planners.save_scene(scene, target)
        except ScenarioError as error:
            self._say(f"Not saved: {error}")
            return
        self._say(f"Saved to {written.resolve()}.")

    # ------------------------------------------------------------------ undo / redo

    def undo(self) -> None:
        """Go back one edit (a whole drag counts as one)."""
        self._history(self._undo, self._redo, "Nothing to undo.")

    def redo(self) -> None:
        """Redo the last undone edit."""
        self._history(self._redo, self._undo, "Nothing to redo.")

    def _history(
        self,
        source: list[tuple[Scene, str]],
        target: list[tuple[Scene, str]],
        empty: str,
    ) -> None:
        with self._wake:
            self._close_gesture_locked()
            if not source:
                self._say_locked(empty)
                self._wake.notify_all()
                return
            scene, scenario = source.pop()
            target.append((self._scene, self._scenario))
            self._scene, self._scenario = scene, scenario
            self._version += 1
            self._dragging.clear()
            self._selection = _valid_selection(self._selection, scene)
            self._say_locked(None)
            self._wake.notify_all()

    # ------------------------------------------------------------------ mouse tools

    def set_tool(self, tool: str) -> None:
        """Choose what the mouse does (a key of :data:`TOOLS`)."""
        self._ui(lambda: self._set_tool_locked(tool))

    def _set_tool_locked(self, tool: str) -> None:
        if tool not in TOOLS:
            self._say_locked(f"Unknown tool {tool!r}.")
            return
        self._tool = tool
        self._draft.clear()
        self._say_locked(_TOOL_HINTS.get(tool))

    def click_floor(self, xy: Iterable[float]) -> None:
        """React to a click on the floor at ``xy`` [m], according to the mouse tool."""
        x, y = (float(v) for v in xy)
        if not (math.isfinite(x) and math.isfinite(y)):
            return
        with self._lock:
            tool = self._tool
        if tool == "block":
            h = _BLOCK_SIZE_M / 2
            self._edit(
                lambda s: edits.add_obstacle(
                    s, [(x - h, y - h), (x + h, y - h), (x + h, y + h), (x - h, y + h)]
                ),
                key=None,
                select=None,
            )
            return
        if tool == "polygon":
            with self._lock:
                draft = list(self._draft)
            if len(draft) >= 3 and math.dist(draft[0], (x, y)) < _CLOSE_POLYGON_M:
                self.finish_polygon()
                return
            self._ui(lambda: self._draft.append((x, y)))
            return
        self._ui(lambda: self._select_locked((x, y)))

    def _select_locked(self, xy: Point) -> None:
        self._selection = pick(self._scene, xy)
        self._say_locked(None)

    def finish_polygon(self) -> None:
        """Close the polygon being drawn and add it as an obstacle."""
        with self._lock:
            draft = list(self._draft)
        if len(draft) < 3:
            self._say("Click at least 3 corners on the floor first.")
            return
        ok = self._edit(lambda s: edits.add_obstacle(s, draft), key=None, select=None)
        if ok:
            self._ui(self._draft.clear)

    def cancel_polygon(self) -> None:
        """Forget the corners clicked so far."""
        self._ui(self._draft.clear)

    def delete_selected(self) -> None:
        """Delete the selected vertex, or the selected obstacle when no vertex is selected."""
        with self._lock:
            selection = self._selection
        if selection is None:
            self._say("Select an obstacle or a vertex first (Edit tool, click it).")
        elif selection.vertex is not None:
            self.delete_vertex(selection.obstacle, selection.vertex)
        else:
            self.delete_obstacle(selection.obstacle)

    def delete_selected_obstacle(self) -> None:
        """Delete the obstacle the selection belongs to."""
        with self._lock:
            selection = self._selection
        if selection is None:
            self._say("Select an obstacle first (Edit tool, click it).")
        else:
            self.delete_obstacle(selection.obstacle)

    def insert_vertex_at_selection(self) -> None:
        """Insert a vertex in the middle of the selected edge (or after the selected vertex)."""
        with self._lock:
            selection = self._selection
        if selection is None or (selection.edge is None and selection.vertex is None):
            self._say("Select an edge or a vertex first (Edit tool, click near it).")
            return
        j = selection.edge if selection.edge is not None else selection.vertex
        assert j is not None
        self.insert_vertex(selection.obstacle, j)

    # ------------------------------------------------------------------ layers and robot

    def set_layer(self, layer: str, visible: bool) -> None:
        """Show or hide a layer (a key of :data:`LAYERS`)."""

        def apply() -> None:
            if layer not in self._layers:
                self._say_locked(f"Unknown layer {layer!r}.")
                return
            self._layers[layer] = bool(visible)

        self._ui(apply)

    def set_follow(self, planner: str) -> None:
        """Choose which planner's path the robot follows."""

        def apply() -> None:
            self._follow = planner
            self._playback.t = 0.0

        self._ui(apply)

    def play(self) -> None:
        """Start (or continue) the robot's motion; at the end, start again from 0."""
        with self._wake:
            p = self._playback
            duration = self._duration_locked()
            if duration is not None and p.t >= duration:
                p.t = 0.0
            p.playing = True
            p.wall = time.monotonic()
            self._ui_version += 1
            self._wake.notify_all()

    def pause(self) -> None:
        """Stop the robot where it is."""
        self._ui(lambda: setattr(self._playback, "playing", False))

    def toggle_play(self) -> None:
        """Play when paused, pause when playing."""
        with self._lock:
            playing = self._playback.playing
        if playing:
            self.pause()
        else:
            self.play()

    def restart(self) -> None:
        """Put the robot back at the start of its trajectory and play."""
        with self._wake:
            self._playback.t = 0.0
        self.play()

    def set_speed(self, speed: float) -> None:
        """Set the playback speed (1 is real time)."""

        def apply() -> None:
            self._playback.speed = max(0.0, float(speed))

        self._ui(apply)

    def set_robot_time(self, t: float | None) -> None:
        """Pause the robot at trajectory time ``t`` [s] (clamped); None resumes playing."""
        if t is None:
            self.play()
            return
        self._ui(lambda: self._pause_at_locked(float(t)))

    def _pause_at_locked(self, t: float) -> None:
        duration = self._duration_locked() or 0.0
        self._playback.playing = False
        self._playback.t = min(max(0.0, t), duration) if math.isfinite(t) else 0.0

    # ------------------------------------------------------------------ internals: edits

    def _edit(
        self,
        fn: Callable[[Scene], Scene],
        key: tuple[Any, ...] | None,
        select: Selection | bool | None = True,
    ) -> bool:
        """Apply a pure edit under the lock; on an error, say why and keep the scene."""
        with self._wake:
            try:
                new = fn(self._scene)
            except (ScenarioError, ValueError, IndexError, TypeError) as error:
                self._say_locked(f"Not done: {error}")
                self._wake.notify_all()
                return False
            if key is None:
                self._close_gesture_locked()
            self._commit_locked(new, key=key, phased=False)
            if key is None:
                self._close_gesture_locked()
            if select is not True:
                self._selection = select if isinstance(select, Selection) else None
            self._selection = _valid_selection(self._selection, self._scene)
            self._say_locked(None)
            self._wake.notify_all()
            return True

    def _commit_locked(
        self, new: Scene, key: tuple[Any, ...] | None, phased: bool
    ) -> None:
        if new == self._scene:
            return
        now = time.monotonic()
        merge = (
            key is not None
            and key == self._gesture
            and (self._gesture_phased or now - self._gesture_time < _MERGE_WINDOW_S)
        )
        if not merge:
            self._undo.append((self._scene, self._scenario))
            self._gesture = key
            self._gesture_phased = phased
        self._gesture_time = now
        self._redo.clear()
        self._scene = new
        self._version += 1

    def _close_gesture_locked(self) -> None:
        self._gesture = None
        self._gesture_phased = False

    def _say(self, message: str | None) -> None:
        with self._wake:
            self._say_locked(message)
            self._wake.notify_all()

    def _say_locked(self, message: str | None) -> None:
        self._message = message
        self._ui_version += 1

    def _ui(self, fn: Callable[[], Any]) -> None:
        with self._wake:
            fn()
            self._ui_version += 1
            self._wake.notify_all()

    def _duration_locked(self) -> float | None:
        trajectory = self._computed_trajectory[1]
        if trajectory is None:
            return None
        return float(getattr(trajectory, "duration", 0.0))

    # ------------------------------------------------------------------ internals: worker

    def _work(self) -> None:
        while True:
            with self._wake:
                while not self._closed and self._rendered == (
                    self._version,
                    self._ui_version,
                ):
                    self._wake.wait()
                if self._closed:
                    return
                self._busy = True
                version, scene = self._version, self._scene
                # Everything a round depends on is read together with the UI version
                # it will be recorded under: anything that changes later (an edit, a
                # setting, a slow planner's result) bumps a version, so the loop runs
                # again and nothing is missed.
                ui_version = self._ui_version
                follow = self._follow
                want_other = self._layers["other_expansion"]
                computed = self._computed
                slow = self._slow
            try:
                self._round(
                    version, ui_version, scene, follow, want_other, computed, slow
                )
            except Exception:
                # The server must keep running whatever a planner or a view does.
                logger.exception("recompute failed")
                with self._wake:
                    self._say_locked(
                        "Internal error while drawing; see the server log."
                    )
                    self._rendered = (self._version, self._ui_version)
            finally:
                with self._wake:
                    self._busy = False
                    self._wake.notify_all()

    def _round(
        self,
        version: int,
        ui_version: int,
        scene: Scene,
        follow: str,
        want_other: bool,
        computed: tuple[int, Scene, Mapping[str, Any], float] | None,
        slow_results: tuple[int, Scene | None, Mapping[str, Any]],
    ) -> None:
        if computed is None or computed[0] != version:
            t0 = time.perf_counter()
            plans = self._plan(scene)
            ms = (time.perf_counter() - t0) * 1e3
            computed = (version, scene, plans, ms)
        _, scene, fast, ms = computed
        slow_version, slow_scene, slow = slow_results
        plans = dict(fast)
        lagging: set[str] = set()
        invalid = _invalid_reason(fast)
        shown_slow = -1
        for name in self._slow_names:
            if name in slow and slow_version == version:
                plans[name] = slow[name]
                shown_slow = slow_version
            elif invalid is not None:
                # Not plannable: every planner gives this answer, no need to wait for it.
                plans[name] = planners.InvalidResult(name, invalid)
                shown_slow = version
            elif (
                name in slow
                and slow_scene is not None
                and _may_lag(fast, slow_scene, scene, slow[name])
            ):
                # During a drag the slow planner (~20-50 ms) falls behind the mouse:
                # show its newest result, marked as lagging, rather than nothing.
                plans[name] = slow[name]
                lagging.add(name)
                shown_slow = slow_version
            else:
                plans[name] = Pending(name)
        plans.pop("cspace", None)
        plans["cspace"] = fast.get("cspace")
        other = self._other_expansion(scene) if want_other else None

        def frame_with(trajectory: Any) -> Frame:  # under self._wake
            return self._frame_locked(
                (version, scene, plans, ms),
                trajectory,
                other,
                frozenset(lagging),
                shown_slow,
            )

        lookup = self._trajectory_lookup(version, scene, plans, follow)
        if lookup[3] is _PLAN:
            # The planners' layers first: planning the robot's new trajectory takes up
            # to a few ms, and meanwhile the robot stays on its previous one. The frame
            # with the new trajectory follows at once (it sends only the robot's parts).
            with self._wake:
                self._computed = computed
                first = frame_with(self._computed_trajectory[1])
            with self._render_lock:
                for view in self._views:
                    view.render(first)
        trajectory = self._trajectory_for(scene, lookup)
        with self._wake:
            self._computed = computed
            frame = frame_with(trajectory)
            duration = self._duration_locked()
            if duration is not None:
                self._playback.t = min(self._playback.t, duration)
            pose = self._pose_locked()
        with self._render_lock:
            for view in self._views:
                view.render(frame)
            for view in self._views:
                view.render_robot(pose)
        with self._wake:
            self._last_frame = frame
            self._rendered = (version, ui_version)

    def _trajectory_lookup(
        self, version: int, scene: Scene, plans: Mapping[str, Any], follow: str
    ) -> tuple[tuple[Any, ...], tuple[Any, ...], npt.NDArray[np.float64], Any]:
        """Return (key, value, path, trajectory) for the robot following ``follow``.

        ``trajectory`` is the one to keep (possibly None), or :data:`_PLAN` when a new
        one must be planned along ``path`` (see :meth:`_trajectory_for`).
        """
        result = plans.get(follow)
        path = np.asarray(
            getattr(result, "path", np.zeros((0, 2))), dtype=np.float64
        ).reshape(-1, 2)
        # The result object itself is part of the key: a slow planner's result replaces
        # its place-holder within the same scene version. The trajectory depends on the
        # robot and the path alone: an edit that leaves the path as it was (a vertex
        # dragged off the path) keeps it, and the robot keeps its place in it.
        key = (version, follow, result)
        value = (follow, scene.robot, path.tobytes())
        cached_key, cached = self._computed_trajectory
        if cached_key is not None and _same_key(cached_key, key):
            return key, value, path, cached
        if value == self._trajectory_value and cached is not None:
            return key, value, path, cached
        if self._trajectory_fn is None or len(path) < 2:
            return key, value, path, None  # nothing to plan
        return key, value, path, _PLAN

    def _trajectory_for(
        self,
        scene: Scene,
        lookup: tuple[tuple[Any, ...], tuple[Any, ...], npt.NDArray[np.float64], Any],
    ) -> Any:
        """Plan the trajectory :meth:`_trajectory_lookup` asked for, and keep it."""
        key, value, path, trajectory = lookup
        if trajectory is _PLAN:
            assert self._trajectory_fn is not None
            try:
                trajectory = self._trajectory_fn(scene, path)
            except Exception:
                logger.exception("trajectory failed")
                trajectory = None
        with self._wake:
            self._computed_trajectory = (key, trajectory)
            self._trajectory_value = value
        return trajectory

    def _work_slow(self) -> None:
        """Second lane: compute the slow planners for the newest scene, drop stale ones."""
        assert self._slow_plan is not None
        while True:
            with self._wake:
                while not self._closed and self._slow_tried == self._version:
                    self._wake.wait()
                # In a thread, let the fast lane draw the newest scene first (the two
                # would take turns with the interpreter lock), but never wait more than
                # a moment, so that during a drag the slow result keeps coming. A worker
                # process runs on the other core next to the fast lane: no waiting.
                yield_s = 0.0 if self._lane is not None else _SLOW_LANE_YIELD_S
                deadline = time.monotonic() + yield_s
                while (
                    not self._closed
                    and self._rendered[0] < self._version
                    and time.monotonic() < deadline
                ):
                    self._wake.wait(max(0.0, deadline - time.monotonic()))
                if self._closed:
                    return
                version, scene = self._version, self._scene
                self._slow_tried = version
                self._slow_busy = True
            try:
                results = dict(self._slow_plan(scene))
            except Exception as error:
                if self._closed:
                    return  # the planner process was stopped by close()
                logger.exception("slow planners failed")
                results = {
                    n: _failed(
                        n, f"{n.upper()} failed: {type(error).__name__}: {error}"
                    )
                    for n in self._slow_names
                }
            with self._wake:
                self._slow_busy = False
                # Keep it if nothing newer is known. If a newer edit arrived meanwhile,
                # the result may still be shown (marked as lagging) until the round
                # for the newest scene, which starts next, replaces it.
                if version > self._slow[0]:
                    self._slow = (version, scene, results)
                    self._ui_version += 1  # redraw the frame with them
                self._wake.notify_all()

    def _other_expansion(self, scene: Scene) -> tuple[Polygon, ...] | None:
        key = (scene.obstacles, scene.robot.radius, scene.expansion)
        if self._other[0] == key:
            return self._other[1]
        other_mode = "square" if scene.expansion == "disk" else "disk"
        try:
            polygons = tuple(
                planners.expand_polygon(o, scene.robot.radius, other_mode)
                for o in scene.obstacles
                if o.is_valid
            )
        except Exception:
            logger.exception("other expansion failed")
            polygons = None
        self._other = (key, polygons)
        return polygons

    def _frame_locked(
        self,
        computed: tuple[int, Scene, Mapping[str, Any], float],
        trajectory: Any,
        other: tuple[Polygon, ...] | None,
        lagging: frozenset[str] = frozenset(),
        slow_version: int = -1,
    ) -> Frame:
        version, scene, plans, ms = computed
        problems = list(edits.scene_problems(scene))
        for name, result in plans.items():
            if name == "cspace" or name in lagging:
                continue
            reason = getattr(result, "reason", None)
            status = getattr(result, "status", "")
            if (
                reason
                and status != "ok"
                and reason not in problems
                and not any(reason == p for p in problems)
            ):
                problems.append(f"{name.upper()}: {reason}")
        problems = _dedupe_reasons(problems)
        return Frame(
            version=version,
            scene=scene,
            plans=plans,
            problems=tuple(problems),
            message=self._message,
            tool=self._tool,
            layers=dict(self._layers),
            selection=_valid_selection(self._selection, scene),
            draft=tuple(self._draft),
            dragging=frozenset(self._dragging),
            can_undo=bool(self._undo),
            can_redo=bool(self._redo),
            follow=self._follow,
            trajectory=trajectory,
            other_expanded=other,
            scenario=self._scenario,
            compute_ms=ms,
            lagging=lagging,
            slow_version=slow_version,
        )

    # ------------------------------------------------------------------ internals: robot

    def _pose_locked(self) -> RobotPose | None:
        key, trajectory = self._computed_trajectory
        if trajectory is None or self._sample_fn is None or self._computed is None:
            return None
        _, follow, result = key
        p = self._playback
        scene = self._computed[1]
        try:
            fields = self._sample_fn(trajectory, p.t, scene, result)
        except Exception:
            logger.exception("sampling the trajectory failed")
            return None
        return RobotPose(t=p.t, playing=p.playing, planner=follow, **fields)

    def _animate(self) -> None:
        period = 1.0 / self._fps
        while True:
            with self._wake:
                while not self._closed and not self._playback.playing:
                    self._wake.wait()
                if self._closed:
                    return
                p = self._playback
                now = time.monotonic()
                p.t += max(0.0, now - p.wall) * p.speed
                p.wall = now
                duration = self._duration_locked()
                if duration is None:
                    p.t = 0.0
                    p.playing = False
                    self._ui_version += 1
                    self._wake.notify_all()
                elif p.t >= duration:
                    p.t = duration
                    p.playing = False
                    self._ui_version += 1  # the panel's play button changes
                    self._wake.notify_all()
                pose = self._pose_locked()
            with self._render_lock:
                for view in self._views:
                    view.render_robot(pose)
            time.sleep(period)

    def render_robot_now(self) -> None:
        """Draw the robot at the current playback time (used after a time change)."""
        with self._lock:
            pose = self._pose_locked()
        with self._render_lock:
            for view in self._views:
                view.render_robot(pose)


# --------------------------------------------------------------------------- helpers


_TOOL_HINTS = {
    "drag": None,
    "edit": "Drag the small squares to move vertices, the larger gizmo to move an obstacle; click an obstacle, a vertex or an edge to select it.",
    "polygon": "Click the corners of the new obstacle on the floor; click the first corner again (or press Finish) to close it.",
    "block": "Click the floor to drop a 1 m block there.",
}


def _handle_words(handle: Handle) -> str:
    if handle[0] == "vertex":
        return f"vertex {handle[2] + 1} of obstacle {handle[1] + 1}"
    if handle[0] == "obstacle":
        return f"obstacle {handle[1] + 1}"
    return str(handle[0])


def _dedupe_reasons(problems: list[str]) -> list[str]:
    """Merge identical reasons given by several planners: "VG, SVG: the goal is ..."."""
    by_reason: dict[str, list[str]] = {}
    order: list[str] = []
    for text in problems:
        name, sep, reason = text.partition(": ")
        if sep and name.isupper() and name.isalpha():
            if reason not in by_reason:
                by_reason[reason] = []
                order.append(reason)
            by_reason[reason].append(name)
        else:
            by_reason.setdefault(text, [])
            order.append(text)
    out = []
    for reason in dict.fromkeys(order):
        names = by_reason[reason]
        out.append(f"{', '.join(names)}: {reason}" if names else reason)
    return out


def _valid_selection(selection: Selection | None, scene: Scene) -> Selection | None:
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
    >>> s = Scene(obstacles=(Polygon([(0, 0), (2, 0), (2, 2), (0, 2)]),), start=(5, 5), goal=(6, 6))
    >>> pick(s, (2.1, 2.05)), pick(s, (1.0, 0.1)), pick(s, (1, 1)), pick(s, (4, 4))
    (Selection(obstacle=0, vertex=2, edge=None), Selection(obstacle=0, vertex=None, edge=0), Selection(obstacle=0, vertex=None, edge=None), None)
    """
    p = np.asarray(xy, dtype=np.float64)
    best: tuple[float, Selection] | None = None
    for i, polygon in enumerate(scene.obstacles):
        ring = np.asarray(polygon.exterior.coords, dtype=np.float64)[:-1]
        d = np.hypot(*(ring - p).T)
        j = int(np.argmin(d))
        if d[j] < _PICK_VERTEX_M and (best is None or d[j] < best[0]):
            best = (float(d[j]), Selection(i, vertex=j))
    if best is not None:
        return best[1]
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
        if d[j] < _PICK_EDGE_M and (best is None or d[j] < best[0]):
            best = (float(d[j]), Selection(i, edge=j))
    if best is not None:
        return best[1]
    point = shapely.Point(p)
    for i, polygon in enumerate(scene.obstacles):
        if polygon.is_valid and polygon.covers(point):
            return Selection(i)
        if not polygon.is_valid and shapely.make_valid(polygon).covers(point):
            return Selection(i)
    return None
