"""One session of the planner: a small facade over the parts that do the work.

A :class:`Controller` is one scene for one audience; nothing in it
is global, so a server may hold several. It never imports viser: it talks to *views*,
objects with ``render(frame)`` and ``render_robot(pose)``, so tests pass a fake view and
the app passes the 3-D view and the panel.

The parts, each a module with one job:

==============================  ======================================================
``_state``                      the scene, its version, the history and the UI state,
                                under the session's one lock
:mod:`app.session.history`      undo and redo (pure value)
:mod:`app.session.tools`        mouse tools, selection, picking (pure functions)
:mod:`app.session.scheduler`    the two planning lanes, coalescing, frames
:mod:`app.session.lanes`        the slow lane's worker process
:mod:`app.session.playback`     the robot's motion along the followed path
:mod:`app.session.frames`       what the views draw (Frame, RobotPose)
==============================  ======================================================

Data flow on an edit (docs/architecture.md)::

    viser callback (event loop or worker thread)
      -> controller.edits.drag_handle(...)    # one critical section: pure decision,
                                              # history, scene, version += 1
      -> scheduler: fast lane wakes up        # latest version wins
           plans = planners.plan_all(...)     # pure, outside the lock, lane's memo
           view.render(frame)                 # frame = (scene, plans) of one version
         slow lane (worker process)           # DSB; drawn by the fast lane's next round

The facade's own methods read the session (scene, version, frame) and change what every
browser of the session shares (undo/redo, layers, enabled planners); the rest is grouped:
``controller.edits`` (scene edits), ``controller.tools`` (mouse tools),
``controller.files`` (scenario files) and ``controller.playback`` (the robot). Each GUI
callback calls exactly one of these methods.
"""

from __future__ import annotations

__all__ = [
    "LAYERS",
    "MOTION_FILES",
    "TOOLS",
    "Controller",
    "Frame",
    "Handle",
    "MouseTools",
    "Pending",
    "PlanFn",
    "RobotPose",
    "SampleFn",
    "ScenarioFiles",
    "SceneEdits",
    "Selection",
    "TrajectoryFn",
    "View",
    "default_plan",
    "pick",
]

import dataclasses
import json
import math
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

import planners
from app.session import files, tools
from app.session._state import SessionState
from app.session.big import BigWorkers
from app.session.files import MAX_UPLOAD_BYTES, FolderError, ScenesFolder, plain_name
from app.session.frames import Frame, RobotPose, View, Views
from app.session.playback import Playback, SampleFn, TrajectoryFn
from app.session.pool import Runner, Ticker, Turns
from app.session.scheduler import Pending, PlanFn, Scheduler, default_plan, lanes_for
from app.session.tools import LAYERS, TOOLS, Handle, Selection, UiState, pick
from planners import export
from planners import scene as edits
from planners.registry import PlannerSpec
from planners.scene import ScenarioError, Scene

MOTION_FILES = ("path .csv", "motion .csv", "path and motion .json")
"""What :meth:`Controller.motion_file` writes, as the panel offers it."""


class Controller:
    """One session: the scene, the planners' results and the views, behind one lock.

    Parameters
    ----------
    views
        Objects with ``render(frame)`` and ``render_robot(pose)``; called from the
        scheduler's thread (and the animation thread for the robot), never concurrently.
    scene
        The scene to start with.
    registry
        Planner name -> :class:`planners.PlannerSpec`; :data:`planners.REGISTRY` by
        default, or a mapping that adds planners of a test's or a student's own. Its
        "graph" planners run in the fast lane, its "trace" planners in the slow lane;
        the default ones run until a planner is switched on or off
        (:meth:`set_planner_enabled`).
    plan
        Scene -> results of the fast planners (and ``"cspace"``), replacing the fast
        lane (a test's stand-in); without ``slow_plan`` there is then no second lane.
    slow_plan
        Scene -> results of the slow planners, replacing the slow lane.
    slow_names
        Names of the planners ``slow_plan`` computes (default: the registry's "trace"
        planners).
    slow_process
        Compute the slow lane in a worker process (see :mod:`app.session.lanes`); False keeps it
        in a thread; a callable (a shared :class:`app.session.pool.WorkerPool`) computes it.
    big_workers
        Where big scenes' graphs are computed (:mod:`app.session.big`): None, a worker process
        of this session's own; a classroom's copies share one
        (:class:`app.session.big.SharedWorkers`).
    fast_process
        Computes the fast lane (VG, SVG) instead of this process: a classroom's copies
        share a :class:`app.session.pool.WorkerPool`. None: in the fast lane's thread.
    turns
        Each round (a frame built and drawn in this process) takes a turn of these
        (:class:`app.session.pool.Turns`, shared by a classroom's copies); None: none.
    trajectory
        (scene, path) -> timed trajectory (or None); None disables the robot.
    sample
        (trajectory, t, scene, result followed) -> the other :class:`RobotPose` fields as
        a mapping; None disables the robot.
    scenarios
        Scenario key -> file, for ``files.load_scenario``.
    scenario
        Key of the starting scene in ``scenarios`` ('' if none).
    folder
        The scenes folder browsers may read and write by plain names
        (``--scenes-dir``), or None.
    fps
        Animation rate of the robot [frames/s].
    ticker
        Draws the robot's animation (:class:`app.session.pool.Ticker`, shared by a
        classroom's copies); None: a ticker (a thread) of its own.
    runners
        Run the scheduler's rounds and slow calls (two :class:`app.session.pool.Runner` s
        shared by a classroom's copies); None: threads of its own.
    """

    def __init__(
        self,
        views: View | Sequence[View],
        scene: Scene,
        *,
        registry: Mapping[str, PlannerSpec] = planners.REGISTRY,
        plan: PlanFn | None = None,
        slow_plan: PlanFn | None = None,
        slow_names: Sequence[str] | None = None,
        slow_process: bool | Callable[[Scene, tuple[str, ...]], Any] = True,
        big_workers: BigWorkers | None = None,
        fast_process: Callable[[Scene, tuple[str, ...]], Any] | None = None,
        turns: Turns | None = None,
        trajectory: TrajectoryFn | None = None,
        sample: SampleFn | None = None,
        scenarios: Mapping[str, Path] | None = None,
        scenario: str = "",
        fps: float = 30.0,
        ticker: Ticker | None = None,
        runners: tuple[Runner, Runner] | None = None,
        folder: ScenesFolder | None = None,
        floor_map: Any = None,
    ) -> None:
        self._registry = registry
        defaults = planners.registry.default_planners(registry)
        ui = UiState(
            layers=tools.default_layers(registry),
            enabled=frozenset(defaults),
            follow=defaults[0] if defaults else next(iter(registry), ""),
        )
        self._state = SessionState(scene, scenario, ui, floor_map=floor_map)
        self._views = Views(views)
        fast, slow = lanes_for(
            registry,
            plan=plan,
            slow_plan=slow_plan,
            slow_names=slow_names,
            slow_process=slow_process,
            big_workers=big_workers,
            fast_process=fast_process,
        )
        self.playback = Playback(
            self._state, self._views, trajectory, sample, fps=fps, ticker=ticker
        )
        """The robot: play, pause, speed, time, the planner followed."""
        self._scheduler = Scheduler(
            self._state,
            self._views,
            self.playback,
            fast,
            slow,
            turns=turns,
            runners=runners,
        )
        self.edits = SceneEdits(self._state)
        """Edits of the scene (drags, vertices, obstacles, robot and planner settings)."""
        self.tools = MouseTools(self._state)
        """The mouse tools: what a click on the floor does, the selection, the draft."""
        self.files = ScenarioFiles(self._state, scenarios or {}, folder)
        """Scenario files: shipped ones, uploads, downloads, the scenes folder."""

    # ------------------------------------------------------------------ reading state

    @property
    def scene(self) -> Scene:
        """The current scene (the newest edit, maybe not yet planned)."""
        return self._state.scene

    @property
    def version(self) -> int:
        """Version of the current scene; every edit increases it by one."""
        return self._state.version

    @property
    def frame(self) -> Frame | None:
        """The last frame drawn (None before the first)."""
        return self._scheduler.frame

    def motion_file(self, kind: str) -> tuple[str, bytes] | None:
        """Return (file name, bytes) of the robot's motion for a browser to download.

        ``kind``: one of :data:`MOTION_FILES`: the followed planner's path as CSV, the
        trajectory the robot is animated along as CSV (pose and wheel rates every
        ``dt``, :mod:`planners.export`), or both as JSON. None when the robot has no path
        to follow. It changes nothing: any browser may ask (a watcher too).
        """
        frame = self.frame
        result = frame.plans.get(frame.follow) if frame is not None else None
        path = getattr(result, "path", None)
        if frame is None or path is None or len(path) < 2 or frame.trajectory is None:
            return None
        stem = re.sub(r"[^A-Za-z0-9_-]+", "_", frame.scene.name).strip("_")[:40]
        stem = f"{stem or 'scene'}_{frame.follow}"
        if kind == "path .csv":
            return f"{stem}_path.csv", export.path_csv(path).encode()
        if kind == "motion .csv":
            text = export.trajectory_csv(frame.trajectory)
            return f"{stem}_motion.csv", text.encode()
        text = export.export_json(frame.scene, frame.follow, path, frame.trajectory)
        return f"{stem}.json", text.encode()

    @property
    def plans(self) -> Mapping[str, Any]:
        """The results of the last frame drawn (empty before the first)."""
        frame = self.frame
        return frame.plans if frame is not None else {}

    @property
    def message(self) -> str | None:
        """The answer to the last action, when it needs one."""
        return self._state.ui.message

    @property
    def registry(self) -> Mapping[str, PlannerSpec]:
        """The planners this session knows."""
        return self._registry

    @property
    def slow_planners(self) -> tuple[str, ...]:
        """Planners computed in the second lane (DSB), shown when ready."""
        return self._scheduler.slow_planners

    @property
    def scheduler(self) -> Scheduler:
        """The planning scheduler (its lanes, the worker process)."""
        return self._scheduler

    # ------------------------------------------------------------------ shared settings

    def undo(self) -> None:
        """Go back one edit (a whole drag counts as one)."""
        self._state.step_history()

    def redo(self) -> None:
        """Redo the last undone edit."""
        self._state.step_history(redo=True)

    def set_layer(self, layer: str, visible: bool) -> None:
        """Show or hide a layer (a key of :data:`LAYERS`)."""
        self._state.update_ui(lambda ui: tools.set_layer(ui, layer, visible))

    def set_planner_enabled(self, name: str, enabled: bool) -> None:
        """Switch planner ``name`` of the registry on or off (its lane runs it or not)."""

        def change(ui: UiState) -> UiState:
            if name not in self._registry:
                return ui.say(f"Unknown planner {name!r}.")
            on = ui.enabled | {name} if enabled else ui.enabled - {name}
            return dataclasses.replace(ui, enabled=frozenset(on))

        self._state.update_ui(change)

    # ------------------------------------------------------------------ lifetime

    @property
    def views(self) -> Views:
        """Every view, drawn one thread at a time (for the live robot's thread)."""
        return self._views

    def add_view(self, view: View) -> None:
        """Draw on one more view from the next frame on (a benchmark's probe, a recorder)."""
        self._views.add(view)
        self._scheduler.redraw()

    def remove_views(self) -> None:
        """Draw on no view from now on: a browser leaves before the session is closed."""
        self._views.clear()

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Block until every edit is planned and drawn; False if ``timeout`` [s] passed."""
        return self._scheduler.wait_idle(timeout)

    def close(self) -> None:
        """Stop the threads and the worker process (the views are left as they are)."""
        self._scheduler.close()
        self.playback.close()


class SceneEdits:
    """Edits of the scene, each one undo step (a whole drag is one).

    Every edit is a pure function Scene -> Scene applied in one critical section; a
    refused edit leaves the scene as it was and says why in the panel.
    """

    def __init__(self, state: SessionState) -> None:
        self._state = state

    def _edit(
        self,
        fn: Callable[[Scene], Scene],
        select: Selection | Literal["keep"] | None = tools.KEEP,
        gesture: tuple[Any, ...] | None = None,
    ) -> None:
        self._state.transact(
            lambda scene, ui: tools.edit(scene, ui, fn, select=select, gesture=gesture)
        )

    def drag_handle(
        self, handle: Handle, xy: Iterable[float], phase: str = "update"
    ) -> None:
        """Move a handle to ``xy`` [m]; ``phase`` is the gizmo's "start"/"update"/"end".

        A whole drag (start to end) is one undo step. Obstacle handles move the obstacle
        by how far the handle moved since the previous event.
        """
        x, y = (float(v) for v in xy)
        if math.isfinite(x) and math.isfinite(y):
            self._state.transact(
                lambda scene, ui: tools.drag(scene, ui, handle, (x, y), phase)
            )

    def move_start(self, xy: Iterable[float]) -> None:
        """Move the start to ``xy`` [m] (one undo step)."""
        self._edit(lambda s: edits.move_start(s, xy))

    def move_goal(self, xy: Iterable[float]) -> None:
        """Move the goal to ``xy`` [m] (one undo step)."""
        self._edit(lambda s: edits.move_goal(s, xy))

    def move_vertex(self, i: int, j: int, xy: Iterable[float]) -> None:
        """Move vertex ``j`` of obstacle ``i`` to ``xy`` [m] (one undo step)."""
        self._edit(lambda s: edits.move_vertex(s, i, j, xy))

    def insert_vertex(self, i: int, j: int, xy: Iterable[float] | None = None) -> None:
        """Insert a vertex after vertex ``j`` of obstacle ``i`` (mid-edge without ``xy``)."""
        self._edit(
            lambda s: edits.insert_vertex(s, i, j, xy),
            select=Selection(i, vertex=j + 1),
        )

    def delete_vertex(self, i: int, j: int) -> None:
        """Delete vertex ``j`` of obstacle ``i`` (refused for a triangle, with a message)."""
        self._edit(lambda s: edits.delete_vertex(s, i, j), select=Selection(i))

    def add_obstacle(self, coords: Sequence[Iterable[float]]) -> None:
        """Add an obstacle polygon (refused with a message if it intersects itself)."""
        self._edit(lambda s: edits.add_obstacle(s, coords), select=None)

    def delete_obstacle(self, i: int) -> None:
        """Delete obstacle ``i``."""
        self._edit(lambda s: edits.delete_obstacle(s, i), select=None)

    def move_obstacle(self, i: int, delta: Iterable[float]) -> None:
        """Translate obstacle ``i`` by ``delta`` = (dx, dy) [m]."""
        self._edit(lambda s: edits.move_obstacle(s, i, delta))

    def set_robot(self, **changes: Any) -> None:
        """Change robot fields, e.g. ``set_robot(radius=0.2)`` or ``set_robot(kind="differential")``.

        Values are checked like a scenario file's; a refused value leaves the scene as it
        was and says why in the panel. Steps of one slider merge into one undo step.
        """

        def apply(scene: Scene) -> Scene:
            robot = dataclasses.replace(scene.robot, **changes)
            data = edits.scene_to_dict(dataclasses.replace(scene, robot=robot))
            edits.scene_from_dict(data, "robot settings")  # validates; raises
            return dataclasses.replace(scene, robot=robot)

        self._edit(apply, gesture=("robot", *sorted(changes)))

    def set_expansion(self, mode: str) -> None:
        """Choose the expansion model, ``"disk"`` or ``"square"``."""

        def apply(scene: Scene) -> Scene:
            if mode not in edits.EXPANSION_MODES:
                modes = ", ".join(edits.EXPANSION_MODES)
                raise ValueError(f"expansion must be one of {modes}, got {mode!r}")
            return dataclasses.replace(scene, expansion=mode)

        self._edit(apply, gesture=("expansion",))

    def set_sensor_range(self, sensor_range: float) -> None:
        """Set the DSB sensor range R [m] (positive)."""

        def apply(scene: Scene) -> Scene:
            r = float(sensor_range)
            if not (r > 0 and math.isfinite(r)):
                raise ValueError(
                    f"the sensor range must be a positive number, got {sensor_range!r}"
                )
            return dataclasses.replace(scene, sensor_range=r)

        self._edit(apply, gesture=("sensor_range",))


class MouseTools:
    """What the mouse does, and the buttons that act on the selection or the draft.

    Each action is a pure function of :mod:`app.session.tools` applied in one critical section:
    a click that closes a polygon, or a delete of the selection, reads and edits the
    scene with no other browser's edit in between.
    """

    def __init__(self, state: SessionState) -> None:
        self._state = state

    def set_tool(self, tool: str) -> None:
        """Choose what the mouse does (a key of :data:`TOOLS`)."""
        self._state.update_ui(lambda ui: tools.set_tool(ui, tool))

    def click_floor(self, xy: Iterable[float]) -> None:
        """React to a click on the floor at ``xy`` [m], according to the mouse tool."""
        point = tuple(float(v) for v in xy)
        self._state.transact(lambda scene, ui: tools.click_floor(scene, ui, point))

    def finish_polygon(self) -> None:
        """Close the polygon being drawn and add it as an obstacle."""
        self._state.transact(tools.finish_polygon)

    def cancel_polygon(self) -> None:
        """Forget the corners clicked so far."""
        self._state.update_ui(tools.cancel_polygon)

    def delete_selected(self) -> None:
        """Delete the selected vertex, or the selected obstacle when no vertex is selected."""
        self._state.transact(tools.delete_selected)

    def delete_selected_obstacle(self) -> None:
        """Delete the obstacle the selection belongs to."""
        self._state.transact(tools.delete_selected_obstacle)

    def insert_vertex_at_selection(self) -> None:
        """Insert a vertex in the middle of the selected edge (or after the selected vertex)."""
        self._state.transact(tools.insert_vertex_at_selection)


class ScenarioFiles:
    """Scenario files: shipped ones, uploads, downloads, and the scenes folder if any.

    No text from a browser is used as a server path (:mod:`app.session.files`): a browser saves
    by downloading (:meth:`download`) and loads by uploading (:meth:`load_text`) or by
    choosing a shipped scenario; the folder named on the command line is read and
    written by plain names only. Loading replaces the scene as one undo step; on an
    error the scene is kept and the panel says why.
    """

    def __init__(
        self,
        state: SessionState,
        scenarios: Mapping[str, Path],
        folder: ScenesFolder | None = None,
    ) -> None:
        self._state = state
        self._scenarios = dict(scenarios)
        self.folder = folder
        """The scenes folder (``--scenes-dir``), or None."""

    @property
    def scenarios(self) -> dict[str, Path]:
        """Scenario key -> file."""
        return dict(self._scenarios)

    def load_scenario(self, key: str) -> None:
        """Switch to scenario ``key`` (see :attr:`scenarios`); the old scene can be undone."""
        path = self._scenarios.get(key)
        if path is None:
            self._state.say(f"Unknown scenario {key!r}.")
            return
        try:
            scene = planners.load_scene(path)
        except ScenarioError as error:
            self._state.say(f"Not loaded, the scene is kept: {error}")
            return
        self._state.replace(scene, key, None)

    def load_text(self, text: str | bytes, source: str = "uploaded file") -> None:
        """Load an upload: a scenario's text, or a zip of a map (:func:`app.session.files.zip_scene`).

        Errors go to the panel, never to disk. A scenario naming a map shows no map: an
        upload never names a file of the server's disk.
        """
        source = _upload_name(source)
        if len(text) > MAX_UPLOAD_BYTES:
            self._state.say(
                f"Not loaded, the scene is kept: {source}: {len(text):,} bytes, more "
                f"than the {MAX_UPLOAD_BYTES:,} an upload may have"
            )
            return
        data = text.encode("utf-8") if isinstance(text, str) else text
        floor_map = None
        try:
            if data.startswith(b"PK") or source.lower().endswith(".zip"):
                scene, floor_map = files.zip_scene(
                    files.read_zip(data, source), self._state.scene, source
                )
            else:
                scene = edits.scene_from_text(data, source)
        except ScenarioError as error:
            self._state.say(f"Not loaded, the scene is kept: {error}")
            return
        self._state.replace(scene, "", f"Loaded {source}.", floor_map)

    def download(self) -> tuple[str, bytes] | None:
        """Return (file name, JSON bytes) of the scene for the browser to download.

        None when the scene is not valid (it could not be loaded again): the panel says
        why, as it does for a save.
        """
        scene = self._state.scene
        problems = edits.scene_problems(scene)
        if problems:
            self._state.say(f"Not downloaded: {'; '.join(problems)}")
            return None
        data = json.dumps(edits.scene_to_dict(scene), indent=1) + "\n"
        stem = re.sub(r"[^A-Za-z0-9_-]+", "_", scene.name).strip("_")[:40]
        return f"{stem or 'scene'}.json", data.encode("utf-8")

    def load_from_folder(self, name: str) -> None:
        """Load the scenes folder's file ``name`` (a plain name, see :mod:`app.session.files`)."""
        if self.folder is None:
            self._state.say("No scenes folder: start the app with --scenes-dir DIR.")
            return
        note = ""
        try:
            if files.is_map_file(name):
                floor_map = self.folder.read_map(name)
                scene = files.map_scene(floor_map, self._state.scene, plain_name(name))
            else:
                scene = self.folder.read(name)
                floor_map, note = self._folder_map(scene)
        except (FolderError, ScenarioError) as error:
            self._state.say(f"Not loaded, the scene is kept: {error}")
            return
        message = f"Loaded {plain_name(name)} from the folder.{note}"
        self._state.replace(scene, "", message, floor_map)

    def _folder_map(self, scene: Scene) -> tuple[Any, str]:
        """Return the map ``scene`` names, from the folder, or None and why not."""
        if not scene.map or self.folder is None:
            return None, ""
        try:
            return self.folder.read_map(scene.map), ""
        except (FolderError, ScenarioError) as error:
            return None, f" Its map is not shown: {error}"

    def save_to_folder(self, name: str) -> None:
        """Save the scene in the scenes folder as ``name``; the panel says how it went."""
        if self.folder is None:
            self._state.say("No scenes folder: start the app with --scenes-dir DIR.")
            return
        try:
            written = self.folder.write(name, self._state.scene)
        except (FolderError, ScenarioError) as error:
            self._state.say(f"Not saved: {error}")
            return
        self._state.say(f"Saved {written.name} in the scenes folder.")


def _upload_name(name: str) -> str:
    """Return an upload's file name as messages show it: its last part, printable, short."""
    last = re.split(r"[\\/]", str(name))[-1]
    shown = "".join(c for c in last if c.isprintable())[:60]
    return shown or "uploaded file"
