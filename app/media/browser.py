"""Headless Chromium driven through playwright: the browser, a page on the app, its camera.

What a picture needs from the browser, for :mod:`app.media.pictures` (slide pictures and
video frames) and Explain's pictures: :func:`launch_browser` starts Debian's headless
Chromium (never a downloaded one); :func:`open_page` opens a running app in it and waits
until every scene node is in the browser (:func:`open_early` opens the page while the app
still starts, :func:`attach_page` waits for its scene); :func:`apply_camera` puts a camera
(:mod:`app.media.camera`) in the browser and waits for its echo. The command-line glue
(starting the app while the browser launches, one-line errors) is :mod:`app.media.jobs`.

What makes a picture repeatable:

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
    "HIDE_GUI_CSS",
    "RECOMPILE_MATERIALS_JS",
    "SLIDE_CSS",
    "AppPage",
    "PlaywrightError",
    "SnapshotError",
    "apply_camera",
    "attach_page",
    "check_chromium",
    "chromium_path",
    "first_line",
    "free_port",
    "launch_browser",
    "loading_size",
    "open_early",
    "open_page",
]

import contextlib
import dataclasses
import json
import os
import socket
import threading
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

try:  # playwright is in the `test` extra; the app itself runs without it.
    from playwright.sync_api import Error as PlaywrightError
    from playwright.sync_api import sync_playwright
except ImportError:  # pragma: no cover - depends on the environment
    PlaywrightError = RuntimeError  # type: ignore[assignment,misc]
    sync_playwright = None  # type: ignore[assignment]

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Page

    from app.media.camera import CameraPose

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


# Everything but the WebGL canvas: the GUI panel, notifications (SwiftShader triggers a
# "software rendering" toast), the logo link. `visibility` is inherited and can be turned
# back on for a descendant, which `display: none` cannot.
HIDE_GUI_CSS = """
body * { visibility: hidden !important; }
canvas { visibility: visible !important; }
"""

SLIDE_CSS = (
    HIDE_GUI_CSS
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
RECOMPILE_MATERIALS_JS = """() => {
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


class SnapshotError(RuntimeError):
    """A snapshot that cannot be taken; the message is one line meant for a person."""


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
        raise SnapshotError(f"cannot start playwright: {first_line(error)}") from None
    try:
        try:
            browser = playwright.chromium.launch(
                executable_path=executable, headless=True, args=list(CHROMIUM_ARGS)
            )
        except PlaywrightError as error:
            raise SnapshotError(
                f"Chromium at {executable} failed to start ({first_line(error)}); {CHROMIUM_HINT}"
            ) from None
        try:
            yield browser
        finally:
            with contextlib.suppress(Exception):
                browser.close()
    finally:
        with contextlib.suppress(Exception):
            manager.__exit__(None, None, None)


def first_line(error: BaseException) -> str:
    """Return the first line of ``error`` that says something (playwright adds logs)."""
    text = str(error).strip()
    for line in text.splitlines():
        # playwright puts a "===== logs =====" block and call logs after the message.
        if line.strip() and not line.startswith(("=", "Call log")):
            return line.strip()
    return type(error).__name__


# --------------------------------------------------------------------------- pages


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


def apply_camera(client: Any, pose: CameraPose, deadline: float) -> None:
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
    dpr: float = 1.0,
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
        A style sheet the page has from its first paint (e.g. :data:`HIDE_GUI_CSS`),
        so that what it hides is never drawn.
    dpr
        Canvas pixels per CSS pixel, fixed (viser's ``fixedDpr``): 1 for pictures; less
        draws a coarser scene in the same layout (the page, the panel and the mouse are
        where they are at 1) at a fraction of the cost.

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
            page.goto(_page_address(url or planner_app.url, dpr))
            client = _wait_loaded(server, page, known, deadline)
        except PlaywrightError as error:
            raise SnapshotError(f"the browser failed: {first_line(error)}") from None
        yield AppPage(page, client)
    finally:
        with contextlib.suppress(Exception):
            context.close()


def _page_address(url: str, dpr: float = 1.0) -> str:
    address = f"{url.rstrip('/')}/" if "?" not in url else url
    return address + ("&" if "?" in address else "?") + f"fixedDpr={dpr:g}"


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
        raise SnapshotError(f"the browser failed: {first_line(error)}") from None
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
