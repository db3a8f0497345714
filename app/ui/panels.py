"""The control panel: every GUI callback calls exactly one controller method.

The panel is also a view: :meth:`Panels.render` shows a frame (results table, messages,
the scene's settings after an undo or a load) and :meth:`Panels.render_robot` the robot's
time and wheel rates. Values the panel sets itself fire viser's callbacks with no client;
those are ignored, so the panel never feeds its own updates back into the controller.
"""

from __future__ import annotations

__all__ = [
    "OWN_SCENE",
    "Panels",
    "legend_html",
    "results_markdown",
    "wheel_rate_plot_data",
]

import functools
import math
from collections.abc import Callable, Collection, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt
import viser

import planners
from app.session.controller import MOTION_FILES, TOOLS, Controller, Frame, RobotPose
from app.session.files import ScenesFolder
from app.session.tools import layer_names
from app.ui.scoped import batch
from app.ui.style import COLORS, hex_color, planner_look
from app.ui.text import markdown_text
from app.ui.thinning import frame_note
from planners.registry import PlannerSpec

_WHEEL_COLORS = ("#0072b2", "#d55e00", "#009e73")

OWN_SCENE = "(your own scene)"
"""The scenario dropdown's entry for a scene that is no shipped scenario."""


def _swatch(color: tuple[int, int, int], kind: str = "line") -> str:
    style = {
        "line": "display:inline-block;width:22px;height:5px;vertical-align:middle;",
        "thin": "display:inline-block;width:22px;height:2px;vertical-align:middle;",
        "box": "display:inline-block;width:14px;height:14px;vertical-align:middle;border:1px solid #222;",
    }[kind]
    return f'<span style="{style}background:{hex_color(color)}"></span>'


def legend_html(registry: Mapping[str, PlannerSpec] = planners.REGISTRY) -> str:
    """Return the legend: one coloured swatch per thing drawn, in words a student knows."""
    rows = [
        (_swatch(COLORS["obstacle"], "box"), "obstacle (numbered)"),
        (
            _swatch(COLORS["expanded"], "box"),
            "expanded obstacle (robot shrunk to a point)",
        ),
        (_swatch(COLORS["other_expansion"], "thin"), "other expansion model (outline)"),
        *(_planner_row(name, registry) for name in registry),
        (
            _swatch(COLORS["sensing"], "thin")
            + _swatch(COLORS["sensed"])
            + _swatch(COLORS["tangents"], "thin")
            + _swatch(COLORS["chosen"]),
            "DSB robot: sensor range R / border it sees / lines to the O_i / "
            "its choice r_next (none while following a border)",
        ),
        (
            _swatch(COLORS["start"], "box") + _swatch(COLORS["goal"], "box"),
            "start / goal (robot footprint)",
        ),
    ]
    body = "".join(
        f'<div style="margin:2px 0;font-size:0.85em">{sw}&nbsp;&nbsp;{text}</div>'
        for sw, text in rows
    )
    return f'<div style="padding:2px 4px">{body}<div style="font-size:0.8em;color:#555">Events: H hit an obstacle, M local minimum, L leave it, D goal free again.</div></div>'


def _planner_row(name: str, registry: Mapping[str, PlannerSpec]) -> tuple[str, str]:
    """One legend row: a graph planner's edges and path, a trace's two modes."""
    look = planner_look(name, registry)
    short = name.upper()
    if registry[name].kind == "graph":
        return (
            _swatch(look.edges or look.path, "thin") + _swatch(look.path),
            f"{short} edges / shortest path",
        )
    return (
        _swatch(look.path) + _swatch(look.follow or look.path),
        f"{short} path: goal seeking / boundary following",
    )


def results_markdown(
    plans: Mapping[str, Any],
    lagging: Collection[str] = (),
    registry: Mapping[str, PlannerSpec] = planners.REGISTRY,
) -> str:
    """Return a markdown table of each planner's status, length, graph size and time.

    Rows follow the registry's order; a graph planner counts its graph's nodes and edges,
    a trace planner has none.

    Examples
    --------
    >>> print(results_markdown({}).splitlines()[0])
    | Planner | Status | Length [m] | Nodes | Edges | ms |
    """
    lines = [
        "| Planner | Status | Length [m] | Nodes | Edges | ms |",
        "|---|---|---|---|---|---|",
    ]
    for name, spec in registry.items():
        result = plans.get(name)
        if result is None:
            continue  # switched off
        length = result.length
        graph = spec.kind == "graph" and result.status in ("ok", "unreachable")
        nodes, edges = (result.nodes, result.edges) if graph else ("-", "-")
        mark = {"ok": "ok", "reached": "reached"}.get(
            result.status, f"**{result.status}**"
        )
        if name in lagging:
            mark += " (updating)"
        lines.append(
            f"| {name.upper()} | {mark} | "
            f"{'-' if length is None or not math.isfinite(length) else f'{length:.2f}'} | "
            f"{nodes} | {edges} | {float(result.ms):.1f} |"
        )
    return "\n".join(lines)


def wheel_rate_plot_data(
    trajectory: Any, max_points: int = 400, max_rate: float | None = None
) -> tuple[npt.NDArray[np.float64], ...] | None:
    """(t, rate_1, ..., rate_k) arrays of a trajectory for the wheel-rate plot, or None.

    With a wheel rate limit ``max_rate`` (section 9.7.3) two more series, +limit and
    -limit, follow the rates.
    """
    if trajectory is None:
        return None
    t = np.asarray(getattr(trajectory, "t", ()), dtype=np.float64)
    rates = np.asarray(getattr(trajectory, "wheel_rates", ()), dtype=np.float64)
    if t.ndim != 1 or len(t) < 2 or rates.ndim != 2 or len(rates) != len(t):
        return None
    step = max(1, math.ceil(len(t) / max_points))
    idx = np.r_[np.arange(0, len(t), step), len(t) - 1]
    idx = np.unique(idx)
    out = (t[idx], *(rates[idx, k] for k in range(rates.shape[1])))
    if max_rate is not None and math.isfinite(max_rate):
        flat = np.full(len(idx), float(max_rate))
        out = (*out, flat, -flat)
    return out


class Panels:
    """The GUI panel on a viser server; a view for the controller.

    Parameters
    ----------
    server
        The viser server (the panel is shared by every browser), or one browser's
        ``viser.ClientHandle`` (a classroom gives each browser a panel of its own).
    scenarios
        Scenario key -> title, for the dropdown.
    registry
        The planners the controller runs (:data:`planners.REGISTRY`): one switch, layers,
        a legend row and a results row each.
    folder
        The scenes folder (``--scenes-dir``), or None: then the panel offers only
        downloads, uploads and the shipped scenarios.
    floor_clicks
        Whether a click on the floor goes to the controller's tools (False: a panel
        nobody edits with, the classroom's watcher panel, asks no browser for clicks).
    saving
        Whether saving to the scenes folder may ever be enabled (False: a student's
        panel, whose save widgets are disabled from the moment they exist).
    """

    def __init__(
        self,
        server: viser.ViserServer | viser.ClientHandle,
        scenarios: Mapping[str, str],
        registry: Mapping[str, PlannerSpec] = planners.REGISTRY,
        folder: ScenesFolder | None = None,
        *,
        floor_clicks: bool = True,
        saving: bool = True,
    ) -> None:
        self.server = server
        self._floor_clicks = floor_clicks
        self._saving = saving
        self._folder = folder
        self.controller: Controller | None = None
        self._latest_version: Callable[[], int] = lambda: -1
        self._scenario_titles = dict(scenarios)
        self._registry = registry
        self._plot_key: Any = None
        # The last thinning note with the plans (held: compared by identity) and layers.
        self._note_kept: tuple[tuple[Any, ...], dict[str, bool], str | None] | None = (
            None
        )
        self._last_robot_text = ""
        self.locked = False
        """Whether the controls are disabled (a classroom's watcher)."""
        self._shown_tool = "drag"
        self._scenario_shown = OWN_SCENE
        gui = server.gui

        self.title = gui.add_markdown("### Mobile-robot planner")
        self.description = gui.add_markdown("")
        self.status = gui.add_markdown("")

        with gui.add_folder("Scenario"):
            # The last entry stands for a scene that is no shipped scenario (uploaded,
            # opened from the scenes folder, given on the command line).
            options = [*scenarios, OWN_SCENE]
            self.scenario = gui.add_dropdown(
                "Scenario", options, initial_value=options[0]
            )
            self.history = gui.add_button_group("Edits", ["Undo", "Redo"])
            self.download = gui.add_button(
                "Download this scene (.json)",
                hint="Saves the scene to your computer",
            )
            self.upload = gui.add_upload_button(
                "Upload a scenario (.json) or map (.zip)",
                mime_type="application/json,.json,application/zip,.zip",
            )
            self._build_folder(gui)

        with gui.add_folder("Results"):
            self.results = gui.add_markdown(results_markdown({}))

        self._build_settings(gui)
        self._build_motion(gui)
        self._bind()

    def _build_folder(self, gui: Any) -> None:
        # The scenes folder, when the server was started with --scenes-dir: plain names.
        self.folder_file = self.folder_open = self.folder_name = self.folder_save = None
        self._folder_message: str | None = None
        if self._folder is None:
            return
        self._folder_names = tuple(self._folder.names())
        self.folder_file = gui.add_dropdown(
            "Folder file", self._folder_names or ("(empty)",)
        )
        self.folder_open = gui.add_button("Open from the scenes folder")
        self.folder_name = gui.add_text(
            "Save as",
            "my scene",
            hint="A plain name: letters, digits, spaces, _ - .",
            disabled=not self._saving,
        )
        self.folder_save = gui.add_button(
            "Save to the scenes folder", disabled=not self._saving
        )

    def _build_settings(self, gui: Any) -> None:
        # The editing tools, the robot and planning settings, the layers.
        with gui.add_folder("Edit"):
            self.tool = gui.add_dropdown(
                "Mouse", list(TOOLS.values()), initial_value=TOOLS["drag"]
            )
            self.selection = gui.add_markdown("*Nothing selected.*")
            self.edit_buttons = gui.add_button_group(
                "Selected", ["Insert vertex", "Delete", "Delete obstacle"]
            )
            self.polygon_buttons = gui.add_button_group(
                "New obstacle", ["Finish", "Cancel"]
            )

        with gui.add_folder("Robot and planning"):
            self.kind = gui.add_dropdown("Robot", ["holonomic", "differential"])
            self.radius = gui.add_slider("Radius [m]", 0.0, 1.0, 0.01, 0.3)
            self.wheel_radius = gui.add_number(
                "Wheel r [m]", 0.05, min=0.005, max=1.0, step=0.005
            )
            self.wheel_distance = gui.add_number(
                "Wheel L [m]", 0.25, min=0.01, max=2.0, step=0.01
            )
            self.expansion = gui.add_dropdown("Expansion", ["disk", "square"])
            self.sensor_range = gui.add_slider("Sensor R [m]", 0.2, 15.0, 0.1, 2.0)

        with gui.add_folder("Planners"):
            self.planners = {
                name: gui.add_checkbox(spec.title, spec.default, hint=spec.summary)
                for name, spec in self._registry.items()
            }
        with gui.add_folder("Layers"):
            self.layers = {
                key: gui.add_checkbox(text, True)
                for key, text in layer_names(self._registry).items()
            }
            self.legend = gui.add_html(legend_html(self._registry))

    def _build_motion(self, gui: Any) -> None:
        # The robot's motion along a planner's path, its wheel rates.
        with gui.add_folder("Robot motion"):
            titles = {spec.title: name for name, spec in self._registry.items()}
            self.follow = gui.add_dropdown("Follow", list(titles))
            self._follow_keys = titles
            self.playback = gui.add_button_group("Motion", ["Play", "Pause", "Restart"])
            self.speed = gui.add_slider("Speed", 0.1, 4.0, 0.1, 1.0)
            self.time = gui.add_slider("Time [s]", 0.0, 1.0, 0.01, 0.0)
            # One button per file (a button group's callback would read the group's
            # newest value, not the one clicked, when two clicks come close together).
            self.motion_downloads = {
                kind: gui.add_button(
                    f"Download the {kind}",
                    hint="The robot's motion in the scene's (the map's) frame",
                )
                for kind in MOTION_FILES
            }
            self.rates = gui.add_markdown("")
            self.plot = gui.add_uplot(
                (np.zeros(2), np.zeros(2)),
                (
                    {"label": "t [s]"},
                    {"label": "wheel 1", "stroke": _WHEEL_COLORS[0], "width": 2},
                ),
                title="Wheel rates [rad/s]",
                scales={"x": {"time": False}},
                aspect=1.6,
            )

    def controls(self) -> list[Any]:
        """Return every widget that changes the session (all but the download)."""
        folder = (
            self.folder_file,
            self.folder_open,
            self.folder_name,
            self.folder_save,
        )
        return [
            *(h for h in folder if h is not None),
            *(self.scenario, self.history, self.upload, self.tool, self.edit_buttons),
            *(self.polygon_buttons, self.kind, self.radius, self.wheel_radius),
            *(self.wheel_distance, self.expansion, self.sensor_range, self.follow),
            *(self.playback, self.speed, self.time),
            *self.planners.values(),
            *self.layers.values(),
        ]

    def lock(self, locked: bool, *, saving: bool = True) -> None:
        """Disable every control that changes the session (a watcher's panel), or enable it.

        Button groups cannot be disabled in viser: they are hidden instead. The server
        refuses a locked panel's edits anyway (:mod:`app.guard.gate`); this only shows it.
        Without ``saving`` the scenes folder's save stays disabled (a student's panel):
        it is never enabled, not even for a moment.
        """
        self.locked = locked
        never = () if saving else (self.folder_name, self.folder_save)
        for handle in self.controls():
            if not isinstance(handle, viser.GuiButtonGroupHandle):
                _set(handle, "disabled", locked or handle in never)
        _set(self.history, "visible", not locked)
        _set(self.playback, "visible", not locked)
        tool = self._shown_tool
        _set(self.polygon_buttons, "visible", tool == "polygon" and not locked)
        _set(self.edit_buttons, "visible", tool == "edit" and not locked)

    # ------------------------------------------------------------------ wiring

    def attach(self, controller: Controller) -> None:
        """Send this panel's callbacks to ``controller``."""
        self.controller = controller
        self._latest_version = lambda: controller.version

    def _on(self, handle: Any, action: Callable[[Any, Controller], None]) -> None:
        @handle.on_update
        def _(event: Any) -> None:
            # Values the panel sets itself arrive without a client: not a user action.
            if event.client is None or self.controller is None:
                return
            action(event.target.value, self.controller)

    def _on_click(self, handle: Any, action: Callable[[Any, Controller], None]) -> None:
        @handle.on_click
        def _(event: Any) -> None:
            if self.controller is None:
                return
            action(event.target.value, self.controller)

    def _send_motion(self, kind: str, event: Any) -> None:
        # The file goes to the browser that asked; nothing is written on the server.
        if self.controller is None or event.client is None:
            return
        file = self.controller.motion_file(kind)
        if file is None:
            event.client.add_notification(
                "Nothing to download",
                "The robot has no path to follow.",
                auto_close_seconds=5.0,
            )
        else:
            event.client.send_file_download(*file, save_immediately=True)

    def _own(self) -> None:
        # "(your own scene)" chosen while a shipped scenario is shown: nothing loads, so
        # the dropdown goes back to the scenario's name.
        self.scenario.value = self._scenario_shown

    def _bind(self) -> None:
        # Each callback calls exactly one controller method.
        self._on(
            self.scenario,
            lambda v, c: c.files.load_scenario(v) if v != OWN_SCENE else self._own(),
        )
        self._on_click(self.history, lambda v, c: {"Undo": c.undo, "Redo": c.redo}[v]())

        @self.download.on_click
        def _(event: Any) -> None:
            # The file goes to the browser that asked; nothing is written on the server.
            if self.controller is None or event.client is None:
                return
            file = self.controller.files.download()
            if file is not None:
                name, data = file
                event.client.send_file_download(name, data, save_immediately=True)

        for kind, button in self.motion_downloads.items():
            button.on_click(functools.partial(self._send_motion, kind))

        @self.upload.on_upload
        def _(event: Any) -> None:
            if self.controller is not None:
                file = event.target.value
                self.controller.files.load_text(file.content, file.name)

        chosen, typed = self.folder_file, self.folder_name
        if chosen is not None and self.folder_open is not None:
            self._on_click(
                self.folder_open,
                lambda v, c: c.files.load_from_folder(str(chosen.value)),
            )
        if typed is not None and self.folder_save is not None:
            self._on_click(
                self.folder_save,
                lambda v, c: c.files.save_to_folder(str(typed.value)),
            )

        tool_keys = {text: key for key, text in TOOLS.items()}
        self._on(self.tool, lambda v, c: c.tools.set_tool(tool_keys[v]))
        self._on_click(
            self.edit_buttons,
            lambda v, c: {
                "Insert vertex": c.tools.insert_vertex_at_selection,
                "Delete": c.tools.delete_selected,
                "Delete obstacle": c.tools.delete_selected_obstacle,
            }[v](),
        )
        self._on_click(
            self.polygon_buttons,
            lambda v, c: (
                c.tools.finish_polygon if v == "Finish" else c.tools.cancel_polygon
            )(),
        )
        self._bind_settings()

    def _bind_settings(self) -> None:
        # The robot, planning, layers and motion: each calls one controller method.
        self._on(self.kind, lambda v, c: c.edits.set_robot(kind=v))
        self._on(self.radius, lambda v, c: c.edits.set_robot(radius=float(v)))
        self._on(
            self.wheel_radius, lambda v, c: c.edits.set_robot(wheel_radius=float(v))
        )
        self._on(
            self.wheel_distance,
            lambda v, c: c.edits.set_robot(wheel_distance=float(v)),
        )
        self._on(self.expansion, lambda v, c: c.edits.set_expansion(v))
        self._on(self.sensor_range, lambda v, c: c.edits.set_sensor_range(float(v)))
        for name, box in self.planners.items():
            self._on(box, lambda v, c, n=name: c.set_planner_enabled(n, bool(v)))
        for key, box in self.layers.items():
            self._on(box, lambda v, c, key=key: c.set_layer(key, bool(v)))
        self._on(self.follow, lambda v, c: c.playback.set_follow(self._follow_keys[v]))
        self._on_click(
            self.playback,
            lambda v, c: {
                "Play": c.playback.play,
                "Pause": c.playback.pause,
                "Restart": c.playback.restart,
            }[v](),
        )
        self._on(self.speed, lambda v, c: c.playback.set_speed(float(v)))
        self._on(self.time, lambda v, c: c.playback.set_robot_time(float(v)))

        if not self._floor_clicks:
            return

        @self.server.scene.on_click()
        def _(event: Any) -> None:
            xy = floor_point(event.ray_origin, event.ray_direction)
            if xy is not None and self.controller is not None:
                self.controller.tools.click_floor(xy)

    # ------------------------------------------------------------------ views

    def render(self, frame: Frame) -> None:
        """Show ``frame``'s results, messages and settings (in one batch of messages)."""
        with batch(self.server):
            self._render(frame)

    def _render(self, frame: Frame) -> None:
        scene = frame.scene
        title = scene.name or "Untitled scene"
        _set(self.title, "content", f"### {markdown_text(title)}")
        _set(self.description, "content", markdown_text(scene.description, lines=True))
        _set(self.status, "content", status_markdown(frame))
        self._render_folder(frame)
        _set(
            self.results,
            "content",
            results_markdown(frame.plans, frame.lagging, self._registry)
            + _note(self._thinning_note(frame)),
        )

        # Settings are pushed only from the newest frame: while a slider is being dragged
        # the frames lag behind it, and pushing an older value would make it jump back.
        if frame.version >= self._latest_version():
            shipped = frame.scenario in self._scenario_titles
            self._scenario_shown = frame.scenario if shipped else OWN_SCENE
            _set(self.scenario, "value", self._scenario_shown)
            _set(self.kind, "value", scene.robot.kind)
            _set(self.radius, "value", round(scene.robot.radius, 2))
            _set(self.wheel_radius, "value", scene.robot.wheel_radius)
            _set(self.wheel_distance, "value", scene.robot.wheel_distance)
            _set(self.expansion, "value", scene.expansion)
            _set(
                self.sensor_range,
                "value",
                round(min(max(scene.sensor_range, 0.2), 15.0), 1),
            )
        _set(self.tool, "value", TOOLS[frame.tool])
        for name, box in self.planners.items():
            _set(box, "value", name in frame.enabled)
        for key, box in self.layers.items():
            _set(box, "value", bool(frame.layers.get(key, True)))
        for name, key in self._follow_keys.items():
            if key == frame.follow:
                _set(self.follow, "value", name)
        _set(
            self.selection,
            "content",
            f"Selected: **{markdown_text(frame.selection.describe())}**"
            if frame.selection is not None
            else "*Nothing selected.*",
        )
        self._shown_tool = frame.tool
        _set(
            self.polygon_buttons, "visible", frame.tool == "polygon" and not self.locked
        )
        _set(self.edit_buttons, "visible", frame.tool == "edit" and not self.locked)
        self._render_plot(frame)

    def _thinning_note(self, frame: Frame) -> str | None:
        """Say which graph layers are thinned; counted again only for other plans or layers.

        A round draws its frame twice (the layers, then the robot): the same results.
        """
        plans, layers = tuple(frame.plans.items()), dict(frame.layers)
        kept = self._note_kept
        if (
            kept is not None
            and kept[1] == layers
            and len(kept[0]) == len(plans)
            and all(
                a == c and b is d for (a, b), (c, d) in zip(kept[0], plans, strict=True)
            )
        ):
            return kept[2]
        note = frame_note(frame.plans, frame.layers)
        self._note_kept = (plans, layers, note)
        return note

    def _render_folder(self, frame: Frame) -> None:
        # After a save the folder holds one more file: list it again (only then).
        if self._folder is None or self.folder_file is None:
            return
        if frame.message != self._folder_message:
            self._folder_message = frame.message
            names = tuple(self._folder.names())
            if names != self._folder_names:
                self._folder_names = names
                self.folder_file.options = names or ("(empty)",)

    def _render_plot(self, frame: Frame) -> None:
        trajectory = frame.trajectory
        if trajectory is self._plot_key:
            return
        self._plot_key = trajectory
        limit = frame.scene.robot.max_wheel_rate
        data = wheel_rate_plot_data(trajectory, max_rate=limit)
        if data is None:
            self.plot.visible = False
            self.time.max = 1.0
            return
        series = [{"label": "t [s]"}] + [
            {
                "label": f"wheel {k + 1}",
                "stroke": _WHEEL_COLORS[k % len(_WHEEL_COLORS)],
                "width": 2,
            }
            for k in range(len(data) - 1 - (2 if limit is not None else 0))
        ]
        if limit is not None:  # the wheel rate limit, dashed (section 9.7.3)
            series += [
                {"label": label, "stroke": "#888888", "width": 1, "dash": [6, 4]}
                for label in ("+limit", "-limit")
            ]
        self.plot.series = tuple(series)  # type: ignore[assignment]
        self.plot.data = data
        self.plot.visible = True
        duration = float(data[0][-1])
        self.time.max = max(round(duration, 2), 0.01)

    def render_robot(self, pose: RobotPose | None) -> None:
        """Show the robot's time and wheel rates (in one batch of messages)."""
        with batch(self.server):
            self._render_robot(pose)

    def _render_robot(self, pose: RobotPose | None) -> None:
        if pose is None:
            text = "*No path to follow.*"
        else:
            if not math.isclose(self.time.value, round(pose.t, 2)):
                self.time.value = min(round(pose.t, 2), self.time.max)
            rates = ", ".join(f"{r:+.1f}" for r in pose.wheel_rates)
            speed = math.hypot(pose.velocity[0], pose.velocity[1])
            state = "playing" if pose.playing else "paused"
            text = (
                f"t = {pose.t:.2f} / {pose.duration:.2f} s ({state})  \n"
                f"wheel rates [rad/s]: {rates}  \n"
                f"speed {speed:.2f} m/s, turn {math.degrees(pose.velocity[2]):+.0f} deg/s"
            )
        if text != self._last_robot_text:
            self._last_robot_text = text
            self.rates.content = text


def _note(text: str | None) -> str:
    """Return a note to put under the results table (empty when there is none)."""
    return "" if text is None else f"\n\n{text}"


def _set(handle: Any, name: str, value: Any) -> None:
    """Assign a GUI property only when it changes.

    viser skips an unchanged value too, but only after casting it; a redraw during a drag
    assigns some thirty properties, and the casts cost more than the rest of the panel.
    """
    if getattr(handle, name) != value:
        setattr(handle, name, value)


def status_markdown(frame: Frame) -> str:
    """Return what the user needs to know now: the answer to the last action, then problems.

    Every text is escaped (:mod:`app.ui.text`): a message can quote a file's name, a field
    of an uploaded file or a value a browser sent.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> print(status_markdown(SimpleNamespace(message=None, problems=("VG, SVG: the goal is inside obstacle 2",))))
    **No path:**
    - VG, SVG: the goal is inside obstacle 2
    >>> print(status_markdown(SimpleNamespace(message="Loaded <b>x</b>", problems=())))
    **Loaded &lt;b&gt;x&lt;/b&gt;**
    """
    parts = []
    progress = getattr(frame, "progress", None)
    if progress:  # a big scene's worker computes (app.session.big)
        parts.append(
            f"**{markdown_text(progress)}**  \n*The last plans are shown grey until then.*"
        )
    if frame.message:
        parts.append(f"**{markdown_text(frame.message)}**")
    if frame.problems:
        parts.append("**No path:**")
        parts.extend(f"- {markdown_text(problem)}" for problem in frame.problems)
    return "\n".join(parts)


def floor_point(origin: Any, direction: Any) -> tuple[float, float] | None:
    """Intersect a click ray with the floor z = 0; None if it misses (looking up or sideways).

    Examples
    --------
    >>> floor_point((1.0, 2.0, 10.0), (0.0, 0.0, -1.0))
    (1.0, 2.0)
    >>> floor_point((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)) is None
    True
    """
    o = np.asarray(origin, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    if d[2] >= -1e-9:
        return None
    s = -o[2] / d[2]
    if s < 0:
        return None
    p = o + s * d
    return (float(p[0]), float(p[1]))
