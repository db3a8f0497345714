"""The app's *Live* robot mode: the DSB robot drives in the scene as the user edits it.

:class:`LiveRun` owns one thread. While running, every ``dt`` (0.05 s) of simulated time
it reads the controller's current scene (the newest edit), puts the moving obstacles
where they are at that time (:func:`planners.motion.scene_at`), takes one
:func:`planners.live.live_step` and draws the result: the robot (through the 3-D view's
own :meth:`render_robot`, with the sensing disk, the visible border, the lines r-O_i and
r_next, Fig. 9.16), its trail, and the moving obstacles where they are now. Everything
the robot decides is :mod:`planners.live`'s; this module only paces, reads and draws.

Data flow::

    panel "Start live" -> LiveRun.start()         (viser thread)
    live thread, every dt / speed wall seconds:
      scene = controller.scene                    (the newest edit, read without waiting)
      state = live_step(state, scene_at(scene, t), options, memo)   (pure)
      view.render_robot(pose); live nodes .points = ...             (property sets)

The loop never takes the controller's lock for longer than reading a field, so edits,
other browsers and the planners go on as usual; an edit reaches the robot at its next
step. :meth:`LiveRun.trace` returns the run so far as a
:class:`planners.live.LiveTrace` (replay, JSON, headless recordings).
"""

from __future__ import annotations

__all__ = ["LiveRun", "add_live_panel", "live_pose", "live_status_markdown"]

import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from app.frames import RobotPose
from planners.live import (
    LiveEvent,
    LiveOptions,
    LiveState,
    LiveStep,
    LiveTrace,
    live_space,
    live_start,
    live_step,
)
from planners.memo import Memo
from planners.motion import motion_offset, scene_at
from planners.scene import Scene
from planners.sensor import sense

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

_TRAIL = (213, 94, 0)  # vermillion (Okabe-Ito): the live robot's trail
_MOVING = (204, 121, 167)  # reddish purple: a moving obstacle where it is now
_Z = 0.03


def live_pose(state: LiveState, scene: Scene, memo: Memo | None = None) -> RobotPose:
    """Describe the live robot for the 3-D view: pose, wheel rates, what it senses now.

    The sensing picture is the sensor's reading at the robot in the scene it decided in
    (:func:`planners.sensor.sense`), and r_next is the live robot's own aim.
    """
    x, y, phi = state.pose
    sensing = None
    try:
        options = LiveOptions()
        space = live_space(scene, options, memo)
        seen = sense(space, (x, y), float(scene.sensor_range))
        points = np.asarray(seen.points, dtype=np.float64).reshape(-1, 2)
        centre = np.array([x, y])
        tangents = (
            np.stack([np.broadcast_to(centre, points.shape), points], axis=1)
            if len(points)
            else np.zeros((0, 2, 2))
        )
        sensing = {
            "center": (x, y),
            "radius": float(seen.radius),
            "seen": np.asarray(seen.segments, dtype=np.float64).reshape(-1, 2, 2),
            "tangents": tangents,
            "points": points,
            "chosen": state.aim if state.plan_mode == "seek" else None,
            "goal": (float(scene.goal[0]), float(scene.goal[1])),
        }
    except Exception:  # a scene mid-edit (a self-intersecting polygon): no picture
        logger.debug("no sensing picture", exc_info=True)
    return RobotPose(
        t=state.t,
        duration=state.t,
        xy=(x, y),
        phi=phi,
        wheel_angles=(0.0,) * len(state.rates),
        wheel_rates=state.rates,
        velocity=state.velocity,
        playing=True,
        planner="live",
        sensing=sensing,
    )


def live_status_markdown(state: LiveState | None, running: bool) -> str:
    """Put the live robot in words for the panel (status, time, mode, distance)."""
    if state is None:
        return "*Live: not started.* The robot will sense the scene as it drives."
    words = {
        "driving": "driving",
        "blocked": state.message,
        "waiting": state.message,
        "reached": "reached the goal",
        "unreachable": "the goal is unreachable",
    }[state.status]
    mode = "goal seeking" if state.plan_mode == "seek" else "boundary following"
    run = "running" if running else "stopped"
    return (
        f"**Live ({run})** t = {state.t:.2f} s  \n"
        f"{words}  \nmode: {mode}; travelled {state.travelled:.2f} m"
    )


class LiveRun:
    """The live DSB robot of one app: its thread, its record, its drawing.

    Parameters
    ----------
    scene_fn
        Returns the current scene (the controller's ``scene`` property).
    server
        The viser server (for the trail and the moving obstacles' nodes).
    views
        Objects with ``render_robot(pose)`` (the 3-D view).
    on_change
        Called with the state after every step (the panel's status); may be None.
    options
        The live robot's options.
    """

    def __init__(
        self,
        scene_fn: Callable[[], Scene],
        server: Any,
        views: list[Any],
        *,
        on_change: Callable[[LiveState | None, bool], None] | None = None,
        options: LiveOptions | None = None,
        speed: float = 1.0,
    ) -> None:
        self._scene_fn = scene_fn
        self._server = server
        self._views = views
        self._on_change = on_change
        self._options = options if options is not None else LiveOptions()
        self._speed = speed
        self._cond = threading.Condition()
        self._running = False
        self._closed = False
        self._state: LiveState | None = None
        self._steps: list[LiveStep] = []
        self._events: list[LiveEvent] = []
        self._decisions: list[Any] = []
        self._start_scene: Scene | None = None
        self._memo = Memo()
        self._trail = server.scene.add_line_segments(
            "/live/trail", np.zeros((0, 2, 3)), colors=_TRAIL, line_width=3.0
        )
        self._moving = server.scene.add_line_segments(
            "/live/moving", np.zeros((0, 2, 3)), colors=_MOVING, line_width=4.0
        )
        self._thread = threading.Thread(target=self._loop, name="live-dsb", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ the panel's buttons

    def start(self) -> None:
        """Start (or continue) the live run; a finished run starts again from q_start."""
        with self._cond:
            if self._state is None or self._state.status in ("reached", "unreachable"):
                self._reset_locked()
            self._running = True
            self._cond.notify_all()
        self._tell()

    def stop(self) -> None:
        """Pause the live robot where it is."""
        with self._cond:
            self._running = False
        self._tell()

    def reset(self) -> None:
        """Forget the run; the next start begins at q_start."""
        with self._cond:
            self._running = False
            self._state = None
            self._steps, self._events, self._decisions = [], [], []
        self._trail.points = np.zeros((0, 2, 3))
        self._moving.points = np.zeros((0, 2, 3))
        self._tell()

    def close(self) -> None:
        """Stop the thread."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(timeout=5.0)

    @property
    def running(self) -> bool:
        """Whether the robot is driving."""
        with self._cond:
            return self._running

    @property
    def state(self) -> LiveState | None:
        """The live robot now (None before a start)."""
        with self._cond:
            return self._state

    def trace(self) -> LiveTrace | None:
        """Return the run so far as a :class:`planners.live.LiveTrace` (None before a start)."""
        with self._cond:
            if self._state is None or self._start_scene is None:
                return None
            start = live_start(self._start_scene).pose
            return LiveTrace(
                start=start,
                steps=tuple(self._steps),
                events=tuple(self._events),
                decisions=tuple(self._decisions),
                status=self._state.status,
                dt=self._options.dt,
                robot_kind=self._start_scene.robot.kind,
                motions=tuple(m.obstacle for m in self._start_scene.motions),
            )

    # ------------------------------------------------------------------ internals

    def _reset_locked(self) -> None:
        scene = self._scene_fn()
        self._start_scene = scene
        self._state = live_start(scene)
        self._steps, self._events, self._decisions = [], [], []

    def _tell(self) -> None:
        if self._on_change is not None:
            try:
                self._on_change(self.state, self.running)
            except Exception:
                logger.exception("live status update failed")

    def _loop(self) -> None:
        next_wall = time.monotonic()
        while True:
            with self._cond:
                while not self._closed and not self._running:
                    self._cond.wait()
                    next_wall = time.monotonic()
                if self._closed:
                    return
                state = self._state
            if state is None:
                continue
            try:
                self._step(state)
            except Exception:  # never take the server down: stop and say why
                logger.exception("live step failed")
                with self._cond:
                    self._running = False
            self._tell()
            next_wall += self._options.dt / max(self._speed, 1e-6)
            time.sleep(max(0.0, next_wall - time.monotonic()))

    def _step(self, state: LiveState) -> None:
        scene = self._scene_fn()
        now = scene_at(scene, state.t)
        new = live_step(state, now, self._options, self._memo)
        record = LiveStep(
            t=new.t,
            pose=new.pose,
            velocity=new.velocity,
            rates=new.rates,
            mode=new.plan_mode,
            status=new.status,
            aim=new.aim,
            offsets=tuple(motion_offset(m, state.t) for m in scene.motions),
            message=new.message,
            over_limit=new.over_limit,
        )
        with self._cond:
            if self._state is not state:
                return  # reset meanwhile
            self._state = new
            self._steps.append(record)
            self._events.extend(new.events)
            self._decisions.extend(new.decisions)
            start = self._start_scene.start if self._start_scene else new.pose[:2]
            path = [tuple(start), *(p.pose for p in self._steps)]
            if new.status in ("reached", "unreachable"):
                self._running = False
        self._draw(new, now, scene, path)

    def _draw(
        self, state: LiveState, now: Scene, scene: Scene, path: list[Any]
    ) -> None:
        pose = live_pose(state, now, self._memo)
        for view in self._views:
            view.render_robot(pose)
        pts = np.asarray([p[:2] for p in path], dtype=np.float64).reshape(-1, 2)
        self._trail.points = _polyline_segments(pts, _Z)
        outlines = [now.obstacles[m.obstacle] for m in scene.motions]
        self._moving.points = _outline_segments(outlines, _Z + 0.01)


def _polyline_segments(points: FloatArray, z: float) -> FloatArray:
    if len(points) < 2:
        return np.zeros((0, 2, 3))
    seg = np.stack([points[:-1], points[1:]], axis=1)
    return np.concatenate([seg, np.full((*seg.shape[:2], 1), z)], axis=2)


def _outline_segments(polygons: list[Any], z: float) -> FloatArray:
    parts = []
    for poly in polygons:
        ring = np.asarray(poly.exterior.coords, dtype=np.float64)[:, :2]
        if len(ring) >= 2 and all(math.isfinite(v) for v in ring.ravel()):
            parts.append(_polyline_segments(ring, z))
    return np.concatenate(parts) if parts else np.zeros((0, 2, 3))


def add_live_panel(server: Any, run: LiveRun) -> Any:
    """Add the *Live DSB* folder to the panel; each button calls one :class:`LiveRun` method.

    Returns the status markdown handle (the run's ``on_change`` writes to it).
    """
    gui = server.gui
    with gui.add_folder("Live DSB"):
        status = gui.add_markdown(live_status_markdown(None, False))
        buttons = gui.add_button_group("Live", ["Start live", "Stop", "Reset"])
        save = gui.add_button(
            "Save the live run (.json)", hint="The run so far, step by step"
        )

    @buttons.on_click
    def _(event: Any) -> None:
        {"Start live": run.start, "Stop": run.stop, "Reset": run.reset}[
            event.target.value
        ]()

    @save.on_click
    def _(event: Any) -> None:
        trace = run.trace()
        if trace is not None and event.client is not None:
            data = trace.to_json().encode("utf-8")
            event.client.send_file_download(
                "live_run.json", data, save_immediately=True
            )

    return status


class StatusWriter:
    """Write the live status to a markdown handle, at most ``rate`` times a second."""

    def __init__(self, rate: float = 5.0) -> None:
        self.handle: Any = None
        self._period = 1.0 / rate
        self._last = 0.0
        self._text = ""

    def __call__(self, state: LiveState | None, running: bool) -> None:
        """Show ``state`` (a change of status is shown at once, time ticks throttled)."""
        if self.handle is None:
            return
        text = live_status_markdown(state, running)
        head = text.split("t =")[0] + (state.status if state is not None else "")
        now = time.monotonic()
        if head == self._text and now - self._last < self._period:
            return
        self._text, self._last = head, now
        self.handle.content = text
