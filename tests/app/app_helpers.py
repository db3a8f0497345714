"""Helpers shared by the app tests."""

from __future__ import annotations

import contextlib
import re
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import viser

from app.session import robot
from app.session.controller import Controller, Frame, RobotPose
from app.ui.scoped import ScopedTarget
from app.ui.view import PlannerView
from planners import Scene
from tests.viser_client import ViserClient

ClientT = TypeVar("ClientT", bound=ViserClient)

ROOT = Path(__file__).resolve().parents[2]
SCENARIO_DIR = ROOT / "static_scenarios"


def wait_until(
    predicate: Callable[[], object], timeout: float = 10.0, poll: float = 0.01
) -> bool:
    """Poll ``predicate`` every ``poll`` s until it holds; False after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(poll)
    return False


def process_running(pid: int) -> bool:
    """Whether process ``pid`` exists and has not exited (a zombie has exited)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def view_and_controller(
    target: viser.ViserServer | ScopedTarget, scene: Scene
) -> tuple[PlannerView, Controller]:
    """A real view on ``target`` and a controller of ``scene`` planning in this process."""
    view = PlannerView(target)
    view.robot_model_fn = robot.robot_model
    controller = Controller(
        view,
        scene,
        trajectory=robot.trajectory,
        sample=robot.sample,
        slow_process=False,
    )
    return view, controller


@contextlib.contextmanager
def live_drawings(
    view: PlannerView,
) -> Iterator[list[tuple[np.ndarray, tuple[float, float]]]]:
    """Collect, for each live robot the view draws, the obstacles' prism vertices shown
    then and the robot's position."""
    drawn: list[tuple[np.ndarray, tuple[float, float]]] = []
    render_robot = view.render_robot

    def spy_robot(pose: Any) -> None:
        render_robot(pose)
        if pose is not None and pose.planner == "live":
            drawn.append((shown_mesh(view.obstacles)[0], pose.xy))

    view.render_robot = spy_robot  # type: ignore[method-assign]
    try:
        yield drawn
    finally:
        del view.render_robot


def shown_mesh(chunked: Any) -> tuple[np.ndarray, np.ndarray]:
    """The vertices and faces a chunked mesh layer of the view shows, joined in order."""
    handles = chunked.shown()
    if not handles:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.uint32)
    vertices = [np.asarray(h.vertices, dtype=np.float64) for h in handles]
    offsets = np.cumsum([0] + [len(v) for v in vertices])[:-1]
    faces = [
        np.asarray(h.faces) + offset for h, offset in zip(handles, offsets, strict=True)
    ]
    return np.concatenate(vertices), np.concatenate(faces)


class FakeView:
    """Records every frame and robot pose the controller draws."""

    def __init__(self) -> None:
        self.frames: list[Frame] = []
        self.poses: list[RobotPose | None] = []
        self._lock = threading.Lock()
        self.concurrent = 0
        self.max_concurrent = 0

    def render(self, frame: Frame) -> None:
        with self._lock:
            self.concurrent += 1
            self.max_concurrent = max(self.max_concurrent, self.concurrent)
        self.frames.append(frame)
        with self._lock:
            self.concurrent -= 1

    def render_robot(self, pose: RobotPose | None) -> None:
        self.poses.append(pose)

    @property
    def last(self) -> Frame:
        return self.frames[-1]


class TopCamera:
    """A camera looking straight down at the floor, and its world -> pixel projection."""

    def __init__(
        self,
        look_at: tuple[float, float],
        height: float,
        fov_deg: float,
        width: int,
        px_height: int,
    ) -> None:
        self.look_at = look_at
        self.height = height
        self.fov_deg = fov_deg
        self.width = width
        self.px_height = px_height
        import math

        # three.js's fov is vertical: half the canvas height spans tan(fov / 2) * height.
        self.f = (px_height / 2) / math.tan(math.radians(fov_deg) / 2)

    def apply(self, server) -> None:  # type: ignore[no-untyped-def]
        import math

        cx, cy = self.look_at
        server.initial_camera.position = (cx, cy, self.height)
        server.initial_camera.look_at = (cx, cy, 0.0)
        server.initial_camera.up = (0.0, 1.0, 0.0)
        server.initial_camera.fov = math.radians(self.fov_deg)

    def pixel(self, xy, z: float = 0.0) -> tuple[float, float]:  # type: ignore[no-untyped-def]
        scale = self.f / (self.height - z)
        return (
            self.width / 2 + (float(xy[0]) - self.look_at[0]) * scale,
            self.px_height / 2 - (float(xy[1]) - self.look_at[1]) * scale,
        )

    def metres_per_pixel(self, z: float = 0.0) -> float:
        return (self.height - z) / self.f


# --------------------------------------------------------------------------- classrooms


def reset_classroom(app: Any) -> None:
    """Put a classroom app back on its first scene, closed to students."""
    app.classroom.set_open(False)
    app.controller.files.load_scenario("01_two_convex")
    assert app.wait_idle(30)


@contextlib.contextmanager
def classroom_client(
    app: Any, presenter: bool = False, kind: type[ClientT] = ViserClient
) -> Iterator[ClientT]:
    """A connected client (of class ``kind``) whose seat and panel are built."""
    from app.classroom import PRESENTER_PATH

    path = f"{PRESENTER_PATH}{app.classroom.token}" if presenter else ""
    before = set(app.server.get_clients())
    c = kind(app.port, path)
    try:
        assert wait_until(lambda: len(set(app.server.get_clients()) - before) == 1, 30)
        (cid,) = set(app.server.get_clients()) - before
        c.client_id = cid
        assert wait_until(lambda: app.classroom.seat(cid) is not None, 30)
        assert c.wait_for(
            lambda: (
                has_label(c, "Radius [m]")
                and (
                    has_label(c, "Make my own copy")
                    or has_label(c, "Let everyone edit")
                )
            ),
            30,
        ), "panel not received"
        yield c
    finally:
        c.close()


def markdowns(c: ViserClient) -> list[str]:
    """The text of every markdown element ``c`` shows (viser sends it as ``_markdown``)."""
    with c._lock:  # a re-entrant lock: wait_for's tests run under it too
        elements = [dict(e) for e in c.gui.values()]
    return [
        str(e["props"].get("_markdown", ""))
        for e in elements
        if e["type"] == "GuiMarkdownMessage"
    ]


def live_time(c: ViserClient) -> float | None:
    """The time ``c``'s *Live DSB* status shows [s] (None before a start)."""
    for text in markdowns(c):
        found = re.search(r"^\*\*Live \(.*t = ([0-9.]+) s", text, re.S)
        if found:
            return float(found.group(1))
    return None


def has_label(c: ViserClient, label: str) -> bool:
    """Whether ``c``'s page draws a GUI element labelled ``label``."""
    return label in c.labels()


def settle(page: Any, frames: int = 3) -> None:
    """Wait until the page has drawn a few frames: a click sent while software WebGL is
    still busy drawing the last update can reach viser too late to count as a click."""
    page.evaluate(
        "(n) => new Promise(done => { const tick = () => (n-- > 0 ?"
        " requestAnimationFrame(tick) : done()); tick(); })",
        frames,
    )


def mouse_drag(
    page: Any, start: tuple[float, float], end: tuple[float, float], steps: int = 6
) -> None:
    """Drag with the mouse from pixel ``start`` to pixel ``end`` in ``steps`` moves.

    Each move waits until the browser has handled it; in software WebGL a move costs
    about a frame of the page, so a few moves are a drag as well as many.
    """
    settle(page)
    page.mouse.move(*start)
    page.mouse.down()
    for k in range(1, steps + 1):
        page.mouse.move(
            start[0] + (end[0] - start[0]) * k / steps,
            start[1] + (end[1] - start[1]) * k / steps,
        )
        time.sleep(0.02)
    page.mouse.up()
