"""Headless snapshots: draw a scenario in a real browser and save the picture as a PNG.

``python -m app --scenario NAME --snapshot OUT.png`` ends up in :func:`snapshot`. It starts
the app on a free loopback port without printing a URL while Debian's headless Chromium
launches, opens the app in it through playwright, waits until every scene node is in the
browser, and takes the slide picture of :mod:`app.media.pictures` (camera, title, legend and
labels laid out for the picture's size by :mod:`app.media.slides`), writes the PNG and stops
everything it started. :func:`capture` is the plain picture of the app as it is (no
title, legend or placed labels), which tests use.

What makes the picture repeatable:

- ``?fixedDpr=1`` in the URL and ``device_scale_factor=1`` in the page, so the client's
  adaptive resolution never changes the image;
- a fixed viewport and a camera set from the scene (position, look-at, up, field of view,
  near and far planes), never the client's default camera;
- the GUI panel and notifications hidden with CSS, so only the WebGL canvas is captured
  (labels are drawn in WebGL by viser 1.x, so they stay in the picture);
- the robot frozen at a trajectory time (0 unless told otherwise);
- screenshots repeated until consecutive ones are identical.

The browser is never downloaded (``playwright install`` does not work offline): it must be
the ``chromium`` package at ``/usr/bin/chromium``.
"""

from __future__ import annotations

__all__ = [
    "CHROMIUM",
    "CHROMIUM_ARGS",
    "CHROMIUM_ENV",
    "CHROMIUM_HINT",
    "SLIDE_CSS",
    "VIEWS",
    "AppPage",
    "CameraPose",
    "SnapshotError",
    "attach_page",
    "capture",
    "check_chromium",
    "chromium_path",
    "frame_camera",
    "free_port",
    "launch_browser",
    "loading_size",
    "open_early",
    "open_page",
    "run_with_browser",
    "scene_bounds",
    "snapshot",
]

import contextlib
import dataclasses
import io
import json
import math
import os
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, TypeVar, cast

import numpy as np
import numpy.typing as npt

try:  # playwright is in the `test` extra; the app itself runs without it.
    from playwright.sync_api import Error as PlaywrightError
    from playwright.sync_api import sync_playwright
except ImportError:  # pragma: no cover - depends on the environment
    PlaywrightError = RuntimeError  # type: ignore[assignment,misc]
    sync_playwright = None  # type: ignore[assignment]

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Page

    from app.media.slides import SlideOptions
    from planners.scene import Scene

CHROMIUM = "/usr/bin/chromium"
"""Where the Debian ``chromium`` package puts the browser."""

CHROMIUM_ENV = "PLANNER_CHROMIUM"
"""Environment variable that points the snapshots at another Chromium binary."""

CHROMIUM_ARGS = (
    "--no-sandbox",  # needed as root, and harmless otherwise
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-quic",
)
"""Flags for a quiet, offline browser. Never add ``--disable-software-rasterizer``: with
``--disable-gpu`` it turns off SwiftShader and WebGL silently stops working."""

CHROMIUM_HINT = "install it with: apt-get install -y chromium (as root)"
"""What to tell a person whose machine has no Chromium."""

VIEWS = ("top", "perspective")
"""Camera framings :func:`frame_camera` knows."""

_TOP_FOV = math.radians(20.0)
# A narrow field of view keeps the top view close to a plan drawing: layers lifted a few
# millimetres above the floor (paths over expanded obstacles) stay aligned with them.
_PERSPECTIVE_FOV = math.radians(40.0)
_PERSPECTIVE_AZIMUTH = math.radians(-105.0)  # looking from slightly left of "south"
_PERSPECTIVE_ELEVATION = math.radians(50.0)
_MARGIN = 0.06  # of the larger side of the scene, on every side
_TALLEST = 0.5  # [m] above the floor: obstacles (0.4 m) and walls (0.3 m) must fit too

# Everything but the WebGL canvas: the GUI panel, notifications (SwiftShader triggers a
# "software rendering" toast), the logo link. `visibility` is inherited and can be turned
# back on for a descendant, which `display: none` cannot.
_HIDE_GUI_CSS = """
body * { visibility: hidden !important; }
canvas { visibility: visible !important; }
"""

SLIDE_CSS = (
    _HIDE_GUI_CSS
    + "\n#planner-slide, #planner-slide * { visibility: visible !important; }\n"
)
"""The style sheet of a slide picture's page (:mod:`app.media.pictures`): only the canvas and
the slide's overlay (title, legend, labels) are drawn."""

_LOAD_VIEWPORT = (480, 300)
"""Viewport [px] while viser's client loads the scene: the software renderer draws every
frame of the loading at this size, which takes about a second less than at 1920 x 1080.
The page is then resized to the picture's size (the canvas follows)."""


def loading_size(width: int, height: int) -> tuple[int, int]:
    """Viewport [px] of a ``width`` x ``height`` picture's page while the scene loads."""
    return min(width, _LOAD_VIEWPORT[0]), min(height, _LOAD_VIEWPORT[1])


# viser 1.1.1's line layers do not recompile their shader when a layer switches from one
# colour to per-segment colours (three.js needs `material.needsUpdate` when `vertexColors`
# changes): depending on message timing, such a layer is then drawn white. Recompiling
# every material once before the pictures are taken makes them show what the server holds,
# every time.
_RECOMPILE_MATERIALS_JS = """() => {
    const m = window.__viserMutable;
    if (!m || !m.scene) return 0;
    let n = 0;
    m.scene.traverse(o => {
        const mats = Array.isArray(o.material) ? o.material : o.material ? [o.material] : [];
        for (const mat of mats) { mat.needsUpdate = true; n += 1; }
    });
    if (m.requestRender) m.requestRender();
    return n;
}"""

# Adds a style sheet (%s: its text as a JSON string) as soon as the document has a head.
_STYLE_SCRIPT = """(() => {
    const add = () => {
        const style = document.createElement("style");
        style.textContent = %s;
        document.head.appendChild(style);
    };
    if (document.head) add(); else document.addEventListener("DOMContentLoaded", add);
})();"""

_SETTLE_INTERVAL = 0.15  # s between screenshots while waiting for the picture to settle
_SETTLE_MATCHES = 2  # identical consecutive screenshots needed after the first


class SnapshotError(RuntimeError):
    """A snapshot that cannot be taken; the message is one line meant for a person."""


@dataclasses.dataclass(frozen=True)
class CameraPose:
    """A viser client camera, in world coordinates (z up, metres)."""

    position: tuple[float, float, float]
    """Camera centre [m]."""
    look_at: tuple[float, float, float]
    """Point the camera looks at [m]."""
    up: tuple[float, float, float]
    """Up direction of the camera's orbit (the image's up for the top view)."""
    fov: float
    """Vertical field of view [rad]."""
    near: float
    """Near clipping distance [m]."""
    far: float
    """Far clipping distance [m]."""


# --------------------------------------------------------------------------- framing


def scene_bounds(scene: Scene) -> tuple[float, float, float, float]:
    """Return the box ``(xmin, ymin, xmax, ymax)`` a picture of ``scene`` must show [m].

    It holds the boundary, every obstacle grown by the robot's radius (so the expanded
    regions fit), the start and the goal (also grown by the radius: the robot is drawn
    there).

    Parameters
    ----------
    scene
        The scene.

    Returns
    -------
    tuple of float
        ``(xmin, ymin, xmax, ymax)`` [m].

    Examples
    --------
    >>> from planners import load_scene
    >>> scene = load_scene({"format": 1, "obstacles": [[[0, 0], [2, 0], [2, 2]]],
    ...                     "start": [-1, 1], "goal": [3, 1], "robot": {"radius": 0.5}})
    >>> scene_bounds(scene)
    (-1.5, -0.5, 3.5, 2.5)
    """
    radius = float(scene.robot.radius)
    boxes: list[tuple[float, float, float, float]] = []
    if scene.boundary is not None:
        boxes.append(tuple(scene.boundary.bounds))  # type: ignore[arg-type]
    for obstacle in scene.obstacles:
        x0, y0, x1, y1 = obstacle.bounds
        boxes.append((x0 - radius, y0 - radius, x1 + radius, y1 + radius))
    for x, y in (scene.start, scene.goal):
        boxes.append((x - radius, y - radius, x + radius, y + radius))
    b = np.asarray(boxes, dtype=np.float64)
    return (
        float(b[:, 0].min()),
        float(b[:, 1].min()),
        float(b[:, 2].max()),
        float(b[:, 3].max()),
    )


def frame_camera(
    bounds: tuple[float, float, float, float],
    width: int,
    height: int,
    view: str = "top",
) -> CameraPose:
    """Place a camera that shows ``bounds`` whole, with a margin, in a W x H picture.

    Parameters
    ----------
    bounds
        ``(xmin, ymin, xmax, ymax)`` of what must be visible [m], see :func:`scene_bounds`.
    width, height
        Picture size [px]; only their ratio matters.
    view
        ``"top"``: straight down, +x to the right and +y up in the picture, a narrow
        field of view (20 degrees) so it reads like a plan. ``"perspective"``: from above
        the lower-left, 50 degrees above the floor; the box is fitted up to 0.5 m above
        the floor so that obstacle and wall tops stay in the picture.

    Returns
    -------
    CameraPose

    Examples
    --------
    >>> pose = frame_camera((0.0, 0.0, 10.0, 8.0), 1280, 800)
    >>> pose.look_at, pose.up
    ((5.0, 4.0, 0.0), (0.0, 1.0, 0.0))
    >>> round(pose.position[2], 3)  # (4 m + 0.6 m margin) / tan(10 deg): the height fills it
    26.088
    """
    if view not in VIEWS:
        raise ValueError(f"unknown view {view!r} (known: {', '.join(VIEWS)})")
    xmin, ymin, xmax, ymax = bounds
    cx, cy = (xmin + xmax) / 2, (ymin + ymax) / 2
    margin = _MARGIN * max(xmax - xmin, ymax - ymin, 1e-3)
    half_x = (xmax - xmin) / 2 + margin
    half_y = (ymax - ymin) / 2 + margin
    aspect = width / height
    if view == "top":
        fov = _TOP_FOV
        # Half the visible floor is distance * tan(fov / 2) tall and `aspect` times wider.
        distance = max(half_y, half_x / aspect) / math.tan(fov / 2)
        return CameraPose(
            position=(cx, cy, distance),
            look_at=(cx, cy, 0.0),
            up=(0.0, 1.0, 0.0),
            fov=fov,
            near=distance / 10,
            far=distance * 10,
        )
    return _perspective_camera((cx, cy), (half_x, half_y), aspect)


def _perspective_camera(
    center: tuple[float, float], half: tuple[float, float], aspect: float
) -> CameraPose:
    """Place the ``"perspective"`` camera of :func:`frame_camera` on a floor box of half-sizes ``half``."""
    (cx, cy), (half_x, half_y) = center, half
    fov = _PERSPECTIVE_FOV
    ce = math.cos(_PERSPECTIVE_ELEVATION)
    back = np.array(
        [
            ce * math.cos(_PERSPECTIVE_AZIMUTH),
            ce * math.sin(_PERSPECTIVE_AZIMUTH),
            math.sin(_PERSPECTIVE_ELEVATION),
        ]
    )
    corners = np.array(
        [
            [x, y, 0.0]
            for x in (cx - half_x, cx + half_x)
            for y in (cy - half_y, cy + half_y)
        ]
    )
    target = np.array([cx, cy, 0.0])
    distance = 1.0
    # Fit the floor box: find the distance at which its corners just fill the picture,
    # then slide camera and target sideways so the box is centred; twice is plenty.
    for _ in range(3):
        lo, hi = 1e-3, 1e6
        for _ in range(80):
            distance = math.sqrt(lo * hi)
            extent, _ = _projected_extent(
                corners, target + distance * back, target, fov, aspect
            )
            lo, hi = (distance, hi) if extent > 1.0 else (lo, distance)
        distance = hi
        _, shift = _projected_extent(
            corners, target + distance * back, target, fov, aspect
        )
        target = target + shift
    position = target + distance * back
    return CameraPose(
        position=(float(position[0]), float(position[1]), float(position[2])),
        look_at=(float(target[0]), float(target[1]), float(target[2])),
        up=(0.0, 0.0, 1.0),
        fov=fov,
        near=distance / 20,
        far=distance * 10,
    )


def _projected_extent(
    points: npt.NDArray[np.float64],
    position: npt.NDArray[np.float64],
    target: npt.NDArray[np.float64],
    fov: float,
    aspect: float,
) -> tuple[float, npt.NDArray[np.float64]]:
    """Half-size of ``points`` in the picture (1 fills it) and the shift that centres them."""
    forward = (target - position) / np.linalg.norm(target - position)
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    rel = points - position
    depth = rel @ forward
    tan_y = math.tan(fov / 2)
    nx = (rel @ right) / (depth * tan_y * aspect)
    ny = (rel @ up) / (depth * tan_y)
    mid_x, mid_y = (nx.max() + nx.min()) / 2, (ny.max() + ny.min()) / 2
    extent = max((nx.max() - nx.min()) / 2, (ny.max() - ny.min()) / 2)
    # Moving camera and target together by (right * a + up * b) moves the picture's
    # centre by a / (depth tan) in x; use the target's depth as the typical depth.
    d0 = float(np.linalg.norm(target - position))
    shift = right * mid_x * d0 * tan_y * aspect + up * mid_y * d0 * tan_y
    return float(extent), shift


# --------------------------------------------------------------------------- browser


def chromium_path() -> str:
    """Return the browser to use: ``$PLANNER_CHROMIUM`` if set, else :data:`CHROMIUM`."""
    return os.environ.get(CHROMIUM_ENV) or CHROMIUM


def check_chromium(executable: str | None = None) -> None:
    """Raise :class:`SnapshotError` unless ``executable`` is a runnable browser.

    Parameters
    ----------
    executable
        Path to the Chromium binary; None for :func:`chromium_path`.
    """
    executable = executable or chromium_path()
    if not os.access(executable, os.X_OK) or os.path.isdir(executable):
        raise SnapshotError(f"Chromium not found at {executable}; {CHROMIUM_HINT}")


@contextlib.contextmanager
def launch_browser(executable: str | None = None) -> Iterator[Browser]:
    """Start headless Chromium through playwright; close it (and playwright) on exit.

    Every call gets a fresh temporary profile. The browser is never downloaded.

    Parameters
    ----------
    executable
        Path to the Chromium binary; None for :func:`chromium_path` (Debian's ``chromium``
        package unless ``$PLANNER_CHROMIUM`` says otherwise).

    Yields
    ------
    playwright.sync_api.Browser

    Raises
    ------
    SnapshotError
        If playwright is not installed, the browser is missing, or it fails to start.
    """
    executable = executable or chromium_path()
    check_chromium(executable)
    if sync_playwright is None:
        raise SnapshotError(
            "the Python package playwright is missing; install it with: pip install playwright"
        )
    manager = sync_playwright()
    try:
        playwright = manager.start()
    except PlaywrightError as error:
        raise SnapshotError(f"cannot start playwright: {_first_line(error)}") from None
    try:
        try:
            browser = playwright.chromium.launch(
                executable_path=executable, headless=True, args=list(CHROMIUM_ARGS)
            )
        except PlaywrightError as error:
            raise SnapshotError(
                f"Chromium at {executable} failed to start ({_first_line(error)}); {CHROMIUM_HINT}"
            ) from None
        try:
            yield browser
        finally:
            with contextlib.suppress(Exception):
                browser.close()
    finally:
        with contextlib.suppress(Exception):
            manager.__exit__(None, None, None)


def _first_line(error: BaseException) -> str:
    text = str(error).strip()
    for line in text.splitlines():
        # playwright puts a "===== logs =====" block and call logs after the message.
        if line.strip() and not line.startswith(("=", "Call log")):
            return line.strip()
    return type(error).__name__


# --------------------------------------------------------------------------- capture


def _scene_of(planner_app: Any) -> Scene:
    """Return the scene the app currently shows (the controller owns it)."""
    for owner in (getattr(planner_app, "controller", None), planner_app):
        scene = getattr(owner, "scene", None)
        if scene is not None and hasattr(scene, "obstacles"):
            return scene
    raise SnapshotError(
        "the app does not expose its scene (expected app.controller.scene)"
    )


def _node_names(server: Any) -> list[str]:
    # viser keeps every live scene node by name; the browser has all of them once its
    # scene tree holds these names. (Private in viser 1.1; without it, any node will do.)
    names = getattr(server.scene, "_handle_from_node_name", None)
    if not isinstance(names, dict):
        return []
    return sorted(n for n in names if n not in ("", "/"))


def _wait_client(server: Any, known: set[int], deadline: float) -> Any:
    """Wait for a client that connected after ``known`` were there; return its handle."""
    while time.monotonic() < deadline:
        for client_id, client in server.get_clients().items():
            if client_id not in known:
                return client
        time.sleep(0.05)
    raise SnapshotError("the browser did not connect to the app's server in time")


def _apply_camera(client: Any, pose: CameraPose, deadline: float) -> None:
    """Set the client's camera and wait until the browser reports it back."""
    camera = client.camera
    scale = float(np.linalg.norm(np.subtract(pose.position, pose.look_at)))

    def applied() -> bool:
        return bool(
            np.allclose(camera.position, pose.position, atol=1e-4 * scale)
            and np.allclose(camera.look_at, pose.look_at, atol=1e-4 * scale)
            and np.allclose(camera.up_direction, pose.up, atol=1e-4)
            and abs(camera.fov - pose.fov) < 1e-4
        )

    if applied():  # the setters would send nothing, and nothing would be echoed
        return
    # Order matters: the up direction first (it re-aims the orbit), then the pose.
    camera.up_direction = pose.up
    camera.fov = pose.fov
    camera.near = pose.near
    camera.far = pose.far
    camera.position = pose.position
    camera.look_at = pose.look_at
    stamp = camera.update_timestamp
    while time.monotonic() < deadline:
        time.sleep(0.05)
        # The browser echoes its camera after every change; judge the echo, not our own
        # request (the setters store the requested values at once). An older message from
        # the browser may arrive first: keep waiting until an echo matches.
        if camera.update_timestamp != stamp:
            stamp = camera.update_timestamp
            if applied():
                return
    raise SnapshotError("the browser did not apply the camera in time")


def _settle(page: Page, deadline: float) -> bytes:
    """Take screenshots until consecutive ones are identical; return the last one."""
    previous = b""
    matches = 0
    while True:
        png = page.screenshot(type="png", animations="disabled", caret="hide")
        if png == previous:
            matches += 1
            if matches >= _SETTLE_MATCHES:
                return png
        else:
            matches = 0
        previous = png
        if time.monotonic() > deadline:
            raise SnapshotError("the picture kept changing; it did not settle in time")
        time.sleep(_SETTLE_INTERVAL)


@dataclasses.dataclass(frozen=True)
class AppPage:
    """A browser page showing a running app, with the server's handle on that browser."""

    page: Page
    """The playwright page (viewport W x H, device scale factor 1)."""
    client: Any
    """The viser ``ClientHandle`` of this page (camera, renders)."""


@contextlib.contextmanager
def open_page(
    planner_app: Any,
    browser: Browser,
    *,
    width: int = 1280,
    height: int = 800,
    timeout: float = 60.0,
    url: str | None = None,
    css: str | None = None,
) -> Iterator[AppPage]:
    """Open a running app in a fresh browser context; wait until its scene is loaded.

    "Loaded" means the server saw the page connect and every scene node the server holds
    is in the browser's scene tree. The context is closed on exit.

    Parameters
    ----------
    planner_app
        What :func:`app.start_app` returned.
    browser
        A browser from :func:`launch_browser`.
    width, height
        Viewport size [px].
    timeout
        Longest time [s] to wait for the connection and the scene.
    url
        Address to open instead of the app's own (a classroom's presenter URL).
    css
        A style sheet the page has from its first paint (e.g. :data:`_HIDE_GUI_CSS`),
        so that what it hides is never drawn.

    Yields
    ------
    AppPage

    Raises
    ------
    SnapshotError
        If the page does not connect or load the scene in time.
    """
    deadline = time.monotonic() + timeout
    server = planner_app.server
    known = set(server.get_clients())
    context = browser.new_context(
        viewport={"width": width, "height": height}, device_scale_factor=1
    )
    try:
        page = context.new_page()
        page.set_default_timeout(timeout * 1e3)
        if css is not None:
            page.add_init_script(_STYLE_SCRIPT % json.dumps(css))
        try:
            page.goto(_page_address(url or planner_app.url))
            client = _wait_loaded(server, page, known, deadline)
        except PlaywrightError as error:
            raise SnapshotError(f"the browser failed: {_first_line(error)}") from None
        yield AppPage(page, client)
    finally:
        with contextlib.suppress(Exception):
            context.close()


def _page_address(url: str) -> str:
    address = f"{url.rstrip('/')}/" if "?" not in url else url
    return address + ("&" if "?" in address else "?") + "fixedDpr=1"


_LOADED_JS = """names => {
    const m = window.__viserMutable;
    if (!m || !m.nodeRefFromName) return false;
    const have = Object.keys(m.nodeRefFromName);
    return names.length ? names.every(n => have.includes(n)) : have.length > 1;
}"""


def _wait_loaded(server: Any, page: Page, known: set[int], deadline: float) -> Any:
    """Wait until a client other than ``known`` has every scene node; return its handle."""
    client = _wait_client(server, known, deadline)
    page.wait_for_function(
        _LOADED_JS,
        arg=_node_names(server),
        polling=100,
        timeout=max(0.1, deadline - time.monotonic()) * 1e3,
    )
    return client


def open_early(
    browser: Browser,
    port: int,
    started: threading.Event,
    *,
    width: int,
    height: int,
    css: str | None = None,
    timeout: float = 60.0,
) -> Page:
    """Open a page on ``http://127.0.0.1:port/`` before the app listens there.

    The address is tried every 50 ms until it answers or ``started`` is set (the app
    is up, or failed): viser's client (a few MB of JavaScript, about a second in a
    loaded machine's browser) then loads while Python imports and plans. Hand the page
    to :func:`attach_page` once the app is up. The page's context lives as long as
    ``browser``.
    """
    context = browser.new_context(
        viewport={"width": width, "height": height}, device_scale_factor=1
    )
    page = context.new_page()
    page.set_default_timeout(timeout * 1e3)
    if css is not None:
        page.add_init_script(_STYLE_SCRIPT % json.dumps(css))
    address = _page_address(f"http://127.0.0.1:{port}")
    deadline = time.monotonic() + timeout
    while not started.is_set() and time.monotonic() < deadline:
        try:
            page.goto(address, wait_until="commit")
            break
        except PlaywrightError:  # not listening yet
            started.wait(0.05)
    return page


def attach_page(planner_app: Any, page: Page, timeout: float = 60.0) -> AppPage:
    """Wait until a page of :func:`open_early` has the app's scene; return it.

    The page is the app's only browser (the app is a private one on a free port). If
    the app is not where the page went (viser moved to the next port, or the page
    never reached it), the page goes to the app's address now.
    """
    deadline = time.monotonic() + timeout
    try:
        if not page.url.startswith(f"http://127.0.0.1:{planner_app.port}/"):
            _go_to(page, _page_address(planner_app.url), deadline)
        client = _wait_loaded(planner_app.server, page, set(), deadline)
    except PlaywrightError as error:
        raise SnapshotError(f"the browser failed: {_first_line(error)}") from None
    return AppPage(page, client)


def _go_to(page: Page, address: str, deadline: float) -> None:
    """Send ``page`` to ``address``, again if the error page of a refused try cuts in.

    A try of :func:`open_early` on a port nobody listened on leaves Chromium loading its
    error page; that navigation may still be under way and interrupt this one.
    """
    while True:
        try:
            page.goto(address)
            return
        except PlaywrightError as error:
            if "interrupted by another navigation" not in str(error):
                raise
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def free_port() -> int:
    """Return a loopback TCP port that is free now (the OS picks it)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _wait_idle(planner_app: Any, deadline: float) -> None:
    if planner_app.wait_idle(max(1.0, deadline - time.monotonic())) is False:
        raise SnapshotError("the app did not finish planning and drawing in time")


def capture(
    planner_app: Any,
    browser: Browser,
    *,
    width: int = 1280,
    height: int = 800,
    view: str = "top",
    robot_time: float | None = None,
    timeout: float = 60.0,
) -> bytes:
    """Open a running app in ``browser`` and return a settled picture of it as PNG bytes.

    The browser page is opened and closed here; the app and the browser stay up, so a test
    suite can share one browser across many pictures.

    Parameters
    ----------
    planner_app
        What :func:`app.start_app` returned.
    browser
        A browser from :func:`launch_browser`.
    width, height
        Picture size [px].
    view
        ``"top"`` or ``"perspective"``, see :func:`frame_camera`.
    robot_time
        Trajectory time [s] at which the robot is drawn; None draws it at the start.
    timeout
        Longest time [s] to wait for the browser, the scene and a settled picture.

    Returns
    -------
    bytes
        A ``width`` x ``height`` PNG.

    Raises
    ------
    SnapshotError
        If the page does not connect, load the scene or settle in time.
    """
    deadline = time.monotonic() + timeout
    pose = frame_camera(scene_bounds(_scene_of(planner_app)), width, height, view)
    # The robot is frozen so that the picture does not depend on when it is taken.
    planner_app.set_robot_time(0.0 if robot_time is None else float(robot_time))
    _wait_idle(planner_app, deadline)
    with open_page(
        planner_app, browser, width=width, height=height, timeout=timeout
    ) as shown:
        try:
            shown.page.add_style_tag(content=_HIDE_GUI_CSS)
            shown.page.evaluate("() => document.fonts.ready.then(() => true)")
            _apply_camera(shown.client, pose, deadline)
            _wait_idle(planner_app, deadline)
            shown.page.evaluate(_RECOMPILE_MATERIALS_JS)
            return _settle(shown.page, deadline)
        except PlaywrightError as error:
            raise SnapshotError(f"the browser failed: {_first_line(error)}") from None


# --------------------------------------------------------------------------- one shot


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    # viser prints a banner on start and a line on stop; a snapshot prints nothing.
    with contextlib.redirect_stdout(io.StringIO()):
        yield


T = TypeVar("T")


class _Threaded(Generic[T]):
    """``fn()`` run in a new thread of its own; :meth:`result` returns or raises its outcome.

    playwright's sync API refuses to start in a thread that runs an asyncio loop (a
    notebook) or that already drives another playwright (a test session's shared
    browser); a thread of its own always works.
    """

    def __init__(self, fn: Callable[[], T], name: str) -> None:
        self._fn = fn
        self._value: T | None = None
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            self._value = self._fn()
        except BaseException as error:  # handed to the caller by result()
            self._error = error

    def join(self) -> None:
        """Wait until ``fn`` has returned or raised."""
        self._thread.join()

    def result(self) -> T:
        """Wait for ``fn``; return its value, or raise what it raised."""
        self.join()
        if self._error is not None:
            raise self._error
        return cast("T", self._value)


def run_with_browser(
    start: Callable[[], Any],
    work: Callable[[Any, Browser], T],
    *,
    chromium: str | None = None,
    prepare: Callable[[Browser, threading.Event], None] | None = None,
) -> T:
    """Start the app with ``start()`` while Chromium launches; return ``work(app, browser)``.

    The browser is launched (and used) in a thread of its own, as playwright's sync API
    needs; the app starts in the calling thread at the same time, so the two slow starts
    overlap. Both are stopped on return, also on errors, which are raised here.

    Call it before importing the app (``start`` may import it): the browser then
    launches while Python imports viser and the planners, too. ``prepare(browser,
    started)``, if given, runs in the browser's thread as soon as the browser is up,
    while the app still starts (``started`` is set once ``start()`` returned or
    failed): :func:`open_early`.
    """
    ready = threading.Event()
    box: dict[str, Any] = {}

    def browse() -> T:
        with launch_browser(chromium) as browser:
            if prepare is not None:
                prepare(browser, ready)
            ready.wait()
            if "app" not in box:
                raise _Cancelled
            return work(box["app"], browser)

    browsing = _Threaded(browse, "pictures-browser")
    planner_app = None
    try:
        planner_app = start()
        box["app"] = planner_app
    finally:
        ready.set()
        browsing.join()
        if planner_app is not None:
            with _quiet_stdout(), contextlib.suppress(Exception):
                planner_app.stop()
    return browsing.result()


class _Cancelled(Exception):
    """The app did not start: the browser thread stops without working.

    Never raised to the caller: ``start()``'s own error is.
    """


def _fail(message: str, code: int) -> int:
    print(f"error: {message}", file=sys.stderr)
    return code


def _check_args(
    width: int, height: int, view: str, robot_time: float | None
) -> str | None:
    for name, value in (("width", width), ("height", height)):
        if (
            isinstance(value, bool)
            or not isinstance(value, int)
            or not 16 <= value <= 8192
        ):
            return f"{name} must be a whole number of pixels from 16 to 8192, got {value!r}"
    if view not in VIEWS:
        return f"view must be one of {', '.join(VIEWS)}, got {view!r}"
    if robot_time is not None and not (math.isfinite(robot_time) and robot_time >= 0):
        return f"robot_time must be a finite time >= 0 s, got {robot_time!r}"
    return None


def snapshot(
    scenario: str | os.PathLike[str] | Scene | None,
    out: str | os.PathLike[str],
    *,
    width: int = 1280,
    height: int = 800,
    view: str = "top",
    robot_time: float | None = None,
    timeout: float = 60.0,
    chromium: str | None = None,
    options: SlideOptions | None = None,
) -> int:
    """Render ``scenario`` with every planner in headless Chromium and write a PNG.

    Starts the app quietly on a free loopback port, takes one settled picture (see the
    module docstring) and stops the browser and the server, also on errors. Errors are
    one line on stderr, never a traceback.

    Parameters
    ----------
    scenario
        A shipped scenario's name, a scenario file, or a Scene (what ``app.start_app``
        takes).
    out
        Where to write the PNG; missing parent folders are created.
    width, height
        Picture size [px].
    view
        ``"top"`` (a plan, for slides and snapshot tests) or ``"perspective"``.
    robot_time
        Trajectory time [s] at which to draw the robot; None draws it at the start.
    timeout
        Longest time [s] to wait for the browser and a settled picture.
    chromium
        Path to the browser; None for :func:`chromium_path`.
    options
        Legend, title and labels of the slide picture (:mod:`app.media.slides`); None: all
        of them.

    Returns
    -------
    int
        Exit code: 0 when the PNG is written, 2 for a bad scenario or argument, 1 when
        the browser or the app fails.
    """
    try:
        _take_snapshot(
            scenario,
            Path(out),
            width=width,
            height=height,
            view=view,
            robot_time=robot_time,
            timeout=timeout,
            chromium=chromium,
            options=options,
        )
    except _Failure as failure:
        return _fail(failure.message, failure.code)
    except SnapshotError as error:
        return _fail(str(error), 1)
    except KeyboardInterrupt:
        return _fail("interrupted", 130)
    except Exception as error:  # a snapshot is a command-line tool: no traceback
        return _fail(
            f"snapshot failed: {type(error).__name__}: {_first_line(error)}", 1
        )
    return 0


class _Failure(Exception):
    """Why a snapshot stopped, as the one line to print and the exit code."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.message = message
        self.code = code


def _take_snapshot(
    scenario: Any,
    path: Path,
    *,
    width: int,
    height: int,
    view: str,
    robot_time: float | None,
    timeout: float,
    chromium: str | None,
    options: SlideOptions | None = None,
) -> None:
    """Do what :func:`snapshot` says; raise :class:`_Failure` with the exit code."""
    problem = _check_args(width, height, view, robot_time)
    if problem is not None:
        raise _Failure(problem, 2)
    chromium = chromium or chromium_path()
    try:
        check_chromium(chromium)
    except SnapshotError as error:
        raise _Failure(str(error), 1) from None
    try:  # before the slow part: a picture that cannot be written is not worth taking
        path.parent.mkdir(parents=True, exist_ok=True)
        if not os.access(path.parent, os.W_OK):
            raise PermissionError(13, "folder not writable")
    except OSError as error:
        raise _Failure(f"cannot write {path}: {error.strerror or error}", 1) from None
    # The app (viser, the planners) is imported in start(), while Chromium launches:
    # this module stays light so that the browser starts first.

    port = free_port()  # known before the app starts, so the page can go there first
    early: dict[str, Page] = {}

    def prepare(browser: Browser, started: threading.Event) -> None:
        small_w, small_h = loading_size(width, height)
        early["page"] = open_early(
            browser,
            port,
            started,
            width=small_w,
            height=small_h,
            css=SLIDE_CSS,
            timeout=timeout,
        )

    def start() -> Any:
        import app  # noqa: PLC0415

        try:
            with _quiet_stdout():
                return app.start_app(
                    scenario, host="127.0.0.1", port=port, print_url=False
                )
        except (ValueError, LookupError, FileNotFoundError) as error:
            # planners.ScenarioError is a ValueError; an unknown name a LookupError.
            raise _Failure(f"cannot load scenario: {_first_line(error)}", 2) from None

    def take(planner_app: Any, browser: Browser) -> bytes:
        # The slide picture (app.media.pictures): sized labels, legend and title.
        from app.media import pictures  # noqa: PLC0415
        from app.media.slides import SlideOptions  # noqa: PLC0415

        return pictures.shoot(
            planner_app,
            browser,
            width=width,
            height=height,
            view=view,
            robot_time=robot_time,
            options=options or SlideOptions(),
            timeout=timeout,
            page=early.get("page"),
        )

    png = run_with_browser(start, take, chromium=chromium, prepare=prepare)
    try:
        partial = path.with_name(f".{path.name}.{os.getpid()}.partial")
        partial.write_bytes(png)
        partial.replace(path)
    except OSError as error:
        raise _Failure(f"cannot write {path}: {error.strerror or error}", 1) from None
