"""Start the planner: a viser server with the 3-D view, the panel and the controller.

``start_app`` is what ``python -m app``, the headless snapshot tool and the tests call.
"""

from __future__ import annotations

__all__ = [
    "DEFAULT_SCENARIO",
    "SCENARIO_DIR",
    "PlannerApp",
    "list_scenarios",
    "open_scenario",
    "resolve_scenario",
    "start_app",
]

import contextlib
import dataclasses
import functools
import io
import ipaddress
import os
import re
import socket
import sys
import threading
from pathlib import Path
from typing import Any

import viser

import planners
from app.classroom import (
    Classroom,
    PresenterTools,
    close_connection,
    new_token,
    presenter_url,
)
from app.classroom.capacity import Capacity
from app.explain.panel import ExplainPanel
from app.guard.door import Door, message_limit
from app.guard.fair import FairExecutor
from app.live import LivePanels, LiveRun, MotionPaths, add_live_panel
from app.session import robot as robot_model
from app.session.controller import Controller
from app.session.files import ScenesFolder, is_map_file, map_scene
from app.ui.floor_text import first_camera
from app.ui.panels import Panels
from app.ui.scoped import ScopedTarget
from app.ui.text import one_line
from app.ui.view import PlannerView, floor_bounds
from planners import maps
from planners.allocator import freeze_long_lived, keep_freed_memory
from planners.kernels import warm_up
from planners.scene import ScenarioError, Scene

SCENARIO_DIR = Path(__file__).resolve().parent.parent / "static_scenarios"
"""Folder of the shipped lecture scenarios."""
DEFAULT_SCENARIO = "01_two_convex"
"""Scenario the app opens on."""


def list_scenarios(folder: Path = SCENARIO_DIR) -> dict[str, Path]:
    """Return scenario key (file stem, e.g. ``01_two_convex``) -> file, sorted by name."""
    if not folder.is_dir():
        return {}
    return {p.stem: p for p in sorted(folder.glob("*.json"))}


def open_scenario(path: Path) -> tuple[Scene, Any]:
    """Read a scenario file, or a map's YAML file, named on the command line.

    Returns the scene and the occupancy map to lay on the floor (None when there is
    none). A map's YAML file opens as the app's panel opens it
    (:func:`app.session.files.map_scene`); a scenario naming a map finds it beside
    itself. A map that cannot be read is said on stderr, and the scene opens without it.

    Raises
    ------
    ScenarioError
        If the scenario, or the map opened as one, cannot be read.
    """
    if is_map_file(path.name):
        floor_map = maps.read_map(path)
        return map_scene(
            floor_map, Scene((), (0.0, 0.0), (0.0, 0.0)), path.name
        ), floor_map
    scene = planners.load_scene(path)
    if not scene.map:
        return scene, None
    try:
        return scene, maps.read_map(path.parent / scene.map)
    except ScenarioError as error:
        print(f"note: {path}: its map is not shown: {error}", file=sys.stderr)
        return scene, None


def resolve_scenario(
    name: str | os.PathLike[str], folder: Path = SCENARIO_DIR
) -> tuple[str, Path]:
    """Find a scenario by path, by key (``01_two_convex``), or by a unique part of its name.

    ``two_convex``, ``two-convex`` and ``01`` all find ``01_two_convex``.

    Returns
    -------
    (key, path)
        ``key`` is the scenario's file stem if it is a shipped scenario, else ''.

    Raises
    ------
    ScenarioError
        When nothing or more than one scenario matches; the message lists the choices.
    """
    text = str(name)
    path = Path(text).expanduser()
    scenarios = list_scenarios(folder)
    if (
        path.suffix == ".json"
        or is_map_file(path.name)
        or os.sep in text
        or "/" in text
    ):
        if path.is_file():
            key = path.stem if scenarios.get(path.stem) == path.resolve() else ""
            return key, path
        raise ScenarioError(text, "(file)", "no such file")
    if text in scenarios:
        return text, scenarios[text]
    wanted = _normalise(text)
    exact = [
        k
        for k in scenarios
        if _normalise(_strip_number(k)) == wanted or _normalise(k) == wanted
    ]
    matches = exact or [k for k in scenarios if wanted and (wanted in _normalise(k))]
    if len(matches) == 1:
        return matches[0], scenarios[matches[0]]
    choices = ", ".join(scenarios) or f"none in {folder}"
    if not matches:
        raise ScenarioError(
            text, "(scenario)", f"no such scenario (choose from: {choices})"
        )
    raise ScenarioError(text, "(scenario)", f"ambiguous, matches {', '.join(matches)}")


def _normalise(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")


def _strip_number(key: str) -> str:
    return re.sub(r"^\d+_", "", key)


@dataclasses.dataclass
class PlannerApp:
    """A running planner app (see :func:`start_app`)."""

    server: viser.ViserServer
    """The viser server."""
    controller: Controller
    """The controller that owns the scene."""
    view: PlannerView
    """The 3-D view."""
    panels: Panels | None
    """The control panel (None in a classroom: presenters, editors and copies have one
    each, watchers share one: app.classroom)."""
    host: str
    """Host the server listens on."""
    classroom: Classroom | None = None
    """The classroom (presenter mode), or None: everyone edits (loopback)."""
    live: LiveRun | None = None
    """The *Live* DSB robot (:mod:`app.live`)."""
    explain: ExplainPanel | None = None
    """The Explain panel: ``explain.choose("svg")``, ``explain.explainer.go(3)``;
    in a classroom, the one every presenter's browser shows."""
    door: Door | None = None
    """What browsers may send (:mod:`app.guard.door`)."""
    fair: FairExecutor | None = None
    """The pool the browsers' callbacks run in, fairly (:mod:`app.guard.fair`)."""

    @property
    def presenter_url(self) -> str | None:
        """The presenter's address with its secret (None outside presenter mode)."""
        if self.classroom is None:
            return None
        return presenter_url(self.url, self.classroom.token)

    @property
    def port(self) -> int:
        """Port the server listens on (viser picks another if the asked one is busy)."""
        return self.server.get_port()

    @property
    def url(self) -> str:
        """Address to open in a browser."""
        host = "127.0.0.1" if self.host in ("0.0.0.0", "") else self.host
        if ":" in host and not host.startswith("["):
            host = f"[{host}]"
        return f"http://{host}:{self.port}/"

    def set_robot_time(self, t: float | None) -> None:
        """Pause the robot at trajectory time ``t`` [s] (None: play from where it is)."""
        self.controller.playback.set_robot_time(t)

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Block until every edit is planned and drawn, and the messages are sent."""
        ok = self.controller.wait_idle(timeout)
        self.server.flush()
        return ok

    def stop(self) -> None:
        """Stop the live robot, Explain, the controller's threads (and copies'), the server."""
        if self.live is not None:
            self.live.close()
        if self.explain is not None:
            self.explain.close()
        if self.classroom is not None:
            self.classroom.close()
        self.controller.close()
        if self.door is not None:
            self.door.close()
        self.server.stop()


def _warm_up() -> None:
    """Load the compiled loops, then freeze what is alive (the app's warm-up thread)."""
    warm_up()
    freeze_long_lived()


def start_app(
    scenario: str | os.PathLike[str] | Scene | None = None,
    *,
    host: str = "127.0.0.1",
    port: int = 0,
    print_url: bool = True,
    scenes_dir: str | os.PathLike[str] | None = None,
    presenter: bool | None = None,
    copy_workers: int = 1,
    capacity: Capacity | None = None,
    worker_process: bool = True,
) -> PlannerApp:
    """Start the planner's viser server with the full scene drawn.

    Parameters
    ----------
    scenario
        A scenario key or name (``"01_two_convex"``, ``"two_convex"``), a path to a
        scenario file, a :class:`planners.Scene`, or None for :data:`DEFAULT_SCENARIO`.
    host
        Interface to listen on; loopback unless you want to share on a network.
    port
        Port; 0 picks a free one (read :attr:`PlannerApp.port`).
    print_url
        Print the URL to open.
    scenes_dir
        A folder browsers may read and write scenario files in, by plain names
        (:mod:`app.session.files`); None: browsers download and upload, nothing more.
    presenter
        Presenter mode (:mod:`app.classroom`): only the browser with the presenter's URL
        edits, the others watch or work on their own copy. None: on when ``host`` is not
        loopback (a classroom), off on loopback (one person edits, as always).
    copy_workers
        In presenter mode, the most worker processes the private copies share.
    capacity
        In presenter mode, the most browsers and copies the class may have
        (:mod:`app.classroom.capacity`); None: what this machine serves.
    worker_process
        Compute DSB and Bug2 in a worker process (:mod:`app.session.lanes`), so that they
        never hold up a redraw during a drag. False computes them in a thread of this
        process: what a one-shot picture, video or page does, where nobody drags and a
        worker process would only add its start-up. Presenter mode always uses them.

    Returns
    -------
    PlannerApp
        With ``.server``, ``.port``, ``.url``, ``.controller``, ``.set_robot_time(t)``,
        ``.wait_idle(timeout)`` and ``.stop()``. The first frame is drawn on return.

    Raises
    ------
    ScenarioError
        If the scenario cannot be found or read (before any server is started).
    FolderError
        If ``scenes_dir`` is not a folder.
    """
    keep_freed_memory()  # an edit's temporaries reuse the last one's pages
    # The compiled loops load (or, once per machine, compile) while the server starts,
    # not on the first frame or the first drag (planners.kernels); then what lives as
    # long as the process leaves the cycle collector's sight (planners.allocator).
    threading.Thread(target=_warm_up, name="warm-up", daemon=True).start()
    scenarios = list_scenarios()
    folder = (
        ScenesFolder(scenes_dir, shipped=tuple(scenarios.values()))
        if scenes_dir is not None
        else None
    )
    floor_map = None
    if isinstance(scenario, Scene):
        scene, key = scenario, ""
    else:
        key, path = resolve_scenario(DEFAULT_SCENARIO if scenario is None else scenario)
        scene, floor_map = open_scenario(path)

    if presenter is None:
        presenter = not _is_loopback(host)
    # viser prints its own banner with rich; ours (below) is one line with the real URL.
    with contextlib.redirect_stdout(io.StringIO()), message_limit():
        server = viser.ViserServer(host=host, port=port, verbose=False)
    app: PlannerApp | None = None
    try:
        # In a classroom nobody has priority until the classroom says who presents.
        door, fair = _guard(server, everyone=not presenter)
        _configure(server, scene)
        # Every session is wired from these.
        wiring = (server, scene, key, scenarios, host)
        if presenter:
            app = _wire_classroom(
                *wiring,
                folder=folder,
                workers=copy_workers,
                door=door,
                floor_map=floor_map,
                capacity=capacity,
            )
            assert app.classroom is not None  # _wire_classroom always makes one
            door.set_priority(app.classroom.is_presenter_connection)
        else:
            app = _wire(
                *wiring,
                folder=folder,
                floor_map=floor_map,
                worker_process=worker_process,
            )
        app.door, app.fair = door, fair
        if not app.wait_idle(60.0):
            raise RuntimeError("the first frame was not drawn within 60 s")
    except BaseException:
        # Once wired, stopping the app also stops its threads and worker processes.
        if app is not None:
            app.stop()
        else:
            server.stop()
        raise
    if print_url:
        _say_where(app, host)
    return app


def _wire(
    server: viser.ViserServer,
    scene: Scene,
    key: str,
    scenarios: dict[str, Path],
    host: str,
    *,
    folder: ScenesFolder | None = None,
    floor_map: Any = None,
    worker_process: bool = True,
) -> PlannerApp:
    """Wire one session on ``server``: the panel, the 3-D view and their controller."""
    titles = {k: planners.load_scene(p).name or k for k, p in scenarios.items()}
    panels = Panels(server, titles, planners.REGISTRY, folder)
    controller_box: list[Controller] = []

    def on_drag(handle: tuple, xy: tuple[float, float], phase: str) -> None:
        controller_box[0].edits.drag_handle(handle, xy, phase)

    view = PlannerView(server, on_drag=on_drag)
    view.robot_model_fn = robot_model.robot_model
    controller = Controller(
        [view, panels],
        scene,
        trajectory=robot_model.trajectory,
        sample=robot_model.sample,
        scenarios=scenarios,
        scenario=key,
        folder=folder,
        floor_map=floor_map,
        slow_process=worker_process,
    )
    controller_box.append(controller)
    panels.attach(controller)
    # Live mode: its own thread, folder and nodes; it reads the newest scene.
    live = LiveRun(lambda: controller.scene, server, [controller.views])
    add_live_panel(server, live)
    controller.add_view(MotionPaths(server))
    explain = ExplainPanel(server, controller)
    controller.add_view(explain)
    return PlannerApp(
        server=server,
        controller=controller,
        view=view,
        panels=panels,
        host=host,
        live=live,
        explain=explain,
    )


def _wire_classroom(
    server: viser.ViserServer,
    scene: Scene,
    key: str,
    scenarios: dict[str, Path],
    host: str,
    *,
    folder: ScenesFolder | None,
    workers: int,
    door: Door,
    floor_map: Any = None,
    capacity: Capacity | None = None,
) -> PlannerApp:
    """Wire the presenter's session: one shared view; panels per browser (app.classroom)."""
    titles = {k: planners.load_scene(p).name or k for k, p in scenarios.items()}
    view = PlannerView(ScopedTarget(server, "/shared", inert=True))
    view.robot_model_fn = robot_model.robot_model
    # Nobody holds the shared gizmos: everyone sees every drag.
    view.gizmos.place_dragged = True
    controller = Controller(
        [view],
        scene,
        trajectory=robot_model.trajectory,
        sample=robot_model.sample,
        scenarios=scenarios,
        scenario=key,
        folder=folder,
        floor_map=floor_map,
    )
    live = LiveRun(lambda: controller.scene, server, [controller.views])
    controller.add_view(MotionPaths(server))
    # One Explain and one live robot, shown in every presenter's browser (app.classroom).
    explain = ExplainPanel(server, controller, folder=False)
    controller.add_view(explain)
    classroom = Classroom(
        server,
        controller,
        new_token(),
        titles,
        scenarios,
        folder=folder,
        copy_workers=workers,
        tools=functools.partial(_presenter_tools, explain, LivePanels(live)),
        broadcast_roots=("/explain", "/live"),
        on_token=functools.partial(_new_token, server, door, host),
        capacity=capacity,
    )
    return PlannerApp(
        server=server,
        controller=controller,
        view=view,
        panels=None,
        host=host,
        classroom=classroom,
        live=live,
        explain=explain,
    )


def _presenter_tools(
    explain: ExplainPanel, live: LivePanels, client: viser.ClientHandle
) -> PresenterTools:
    """Folders of the one Explain and the one live robot on a presenter's browser."""
    folder = explain.add_folder(client.gui)
    panel = live.add(client)

    def close() -> None:
        live.remove(panel)
        explain.remove_folder(folder)

    return PresenterTools(views=(), close=close)


def _guard(server: viser.ViserServer, *, everyone: bool) -> tuple[Door, FairExecutor]:
    """Put the door (:mod:`app.guard.door`) and the fair pool (:mod:`app.guard.fair`) on ``server``.

    Browsers that connected before (the server listens from its constructor on) are
    closed: they come back through the door.
    """
    door = Door(
        server,
        priority=(lambda client_id: True) if everyone else (lambda client_id: False),
        tell=functools.partial(_tell, server),
    )
    fair = FairExecutor(priority=door.is_priority)
    old = server._thread_executor
    # viser's private pools, typed ThreadPoolExecutor, replaced on purpose by ours.
    server._thread_executor = server.gui._thread_executor = fair  # pyright: ignore[reportAttributeAccessIssue]
    server.scene._thread_executor = fair  # pyright: ignore[reportAttributeAccessIssue]
    old.shutdown(wait=False)
    for client_id in list(server._websock_server._live_connections):
        if not door.knows(client_id):
            close_connection(server, client_id, "reconnect")
    return door, fair


def _tell(server: viser.ViserServer, client_id: int, words: str) -> None:
    """Show ``words`` to one browser, as a notification (its text is never markup)."""
    client = server.get_clients().get(client_id)
    if client is not None:
        client.add_notification(
            "Refused", one_line(words), auto_close_seconds=10.0, color="red"
        )


def _is_loopback(host: str) -> bool:
    """Whether ``host`` is reachable only from this machine."""
    if host in ("localhost", ""):
        return host == "localhost"
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _say_where(app: PlannerApp, host: str) -> None:
    """Print the URL to open (and, when shared on a network, how others reach it)."""
    if app.classroom is not None:
        _say_classroom(app, host)
        return
    print(
        f"Mobile-robot planner: open {app.url} in a browser (Ctrl+C to stop).",
        flush=True,
    )
    if host in ("0.0.0.0", "::", ""):
        # Shared on the network: say how other machines (students' laptops) reach it.
        print(
            f"Other computers: http://{socket.gethostname()}:{app.port}/ "
            "(or this machine's IP address)",
            flush=True,
        )


def _new_token(server: viser.ViserServer, door: Door, host: str, token: str) -> None:
    """After a new presenter link: every browser's priority again, the new URL printed."""
    door.reprioritise_all()
    shared = host in ("0.0.0.0", "::", "")
    page = f"http://127.0.0.1:{server.get_port()}/" if shared else None
    if page is None:
        bracketed = f"[{host}]" if ":" in host and not host.startswith("[") else host
        page = f"http://{bracketed}:{server.get_port()}/"
    print(
        "New presenter link (the old one no longer presents; keep it secret): "
        f"{presenter_url(page, token)}",
        flush=True,
    )


def _say_classroom(app: PlannerApp, host: str) -> None:
    """Print the presenter's URL (with its secret) and the class's plain URL."""
    shared = host in ("0.0.0.0", "::", "")
    page = f"http://{socket.gethostname()}:{app.port}/" if shared else app.url
    also = "  (or this machine's IP address)" if shared else ""
    print(
        "Mobile-robot planner in presenter mode (Ctrl+C to stop).\n"
        f"  Presenter, on this computer (keep it secret): {app.presenter_url}\n"
        f"  Class (they watch, or make their own copy): {page}{also}",
        flush=True,
    )


def _configure(server: viser.ViserServer, scene: Scene) -> None:
    """Theme, lights and the initial camera of a new server."""
    server.gui.configure_theme(
        control_width="medium", show_share_button=False, brand_color=(0, 114, 178)
    )
    server.scene.set_up_direction("+z")
    # No HDRI: it costs ~10 s of CPU on first render and changes the light mid-way;
    # plain lights give the same picture every time.
    server.scene.configure_environment_map(hdri=None)
    server.scene.configure_default_lights(enabled=True, cast_shadow=False)
    server.scene.add_light_hemisphere("/lights/sky", intensity=1.2)
    _frame_camera(server, scene)


def _frame_camera(server: viser.ViserServer, scene: Scene) -> None:
    """Point new browsers' cameras at the whole floor (:func:`app.ui.floor_text.first_camera`)."""
    camera = first_camera(floor_bounds(scene))
    server.initial_camera.fov = camera.fov
    server.initial_camera.look_at = camera.look_at
    server.initial_camera.position = camera.position
    server.initial_camera.up = camera.up
