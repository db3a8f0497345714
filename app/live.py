"""The app's *Live* robot mode: the DSB robot drives in the scene as the user edits it.

:class:`LiveRun` is stepped by a :class:`app.session.pool.Ticker`: the app's robot by a
ticker (a thread) of its own, a classroom's copies all by one they share, at a bounded
rate in all. While running, every ``dt`` (0.05 s) of simulated time it reads the
controller's current scene (the newest edit), puts the moving obstacles
where they are at that time (:func:`planners.scene.scene_at`), takes one
:func:`planners.bug.live.live_step` and draws the result: the robot (through the 3-D view's
own :meth:`render_robot`, with the sensing disk, the visible border, the lines r-O_i and
r_next, Fig. 9.16), its trail, and the moving obstacles where they are now. Everything
the robot decides is :mod:`planners.bug.live`'s; this module only paces, reads and draws.

Data flow::

    panel "Start live" -> LiveRun.start()         (viser thread)
    ticker's thread, every dt / speed wall seconds (later when its runs share a rate):
      scene = controller.scene                    (the newest edit, read without waiting)
      state = live_step(state, scene_at(scene, t), options, memo)   (pure)
      view.render_robot(pose); live nodes .points = ...   (one atomic update)

The loop never takes the controller's lock for longer than reading a field, so edits,
other browsers and the planners go on as usual; an edit reaches the robot at its next
step. :meth:`LiveRun.trace` returns the run so far as a
:class:`planners.bug.live.LiveTrace` (replay, JSON, headless recordings).
"""

from __future__ import annotations

__all__ = [
    "LivePanel",
    "LivePanels",
    "LiveRun",
    "MotionPaths",
    "add_live_panel",
    "live_pose",
    "live_pose_at",
    "live_status_markdown",
    "step_pose",
]

import dataclasses
import itertools
import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from app.session.frames import RobotPose
from app.session.pool import Ticker
from app.ui.scoped import batch, quietly
from app.ui.text import markdown_text
from planners.bug.live import (
    LiveEvent,
    LiveOptions,
    LiveState,
    LiveStep,
    LiveTrace,
    live_space,
    live_start,
    live_step,
    record_step,
)
from planners.bug.sensor import sense
from planners.memo import Memo
from planners.scene import Scene, scene_at

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

_TRAIL = (213, 94, 0)  # vermillion (Okabe-Ito): the live robot's trail
_MOVING = (204, 121, 167)  # reddish purple: a moving obstacle where it is now
_Z = 0.03


def live_pose(state: LiveState, scene: Scene, memo: Memo | None = None) -> RobotPose:
    """Describe the live robot for the 3-D view: pose, wheel rates, what it senses now.

    The sensing picture is the sensor's reading at the robot in the scene it decided in
    (:func:`planners.bug.sensor.sense`), and r_next is the live robot's own aim.
    """
    return _robot_pose(
        LiveStep(
            t=state.t,
            pose=state.pose,
            velocity=state.velocity,
            rates=state.rates,
            mode=state.plan_mode,
            status=state.status,
            aim=state.aim,
            offsets=(),
        ),
        scene,
        memo,
        playing=True,
    )


def live_pose_at(
    trace: LiveTrace, t: float, scene: Scene, memo: Memo | None = None
) -> RobotPose:
    """Describe the recorded robot at time ``t`` of ``trace`` (a replay, a recording).

    ``scene`` gives the robot and R; the obstacles and the goal are the recorded ones of
    that step, so moving obstacles and the user's edits are where they were.
    """
    step = trace.step_at(t)
    if step is None:
        first = trace.steps[0] if trace.steps else None
        step = LiveStep(
            t=0.0,
            pose=trace.start,
            velocity=(0.0, 0.0, 0.0),
            rates=(0.0,) * (len(first.rates) if first else 0),
            mode="seek",
            status="driving",
            aim=None,
            offsets=(),
            obstacles=first.obstacles if first else scene.obstacles,
            goal=first.goal if first else scene.goal,
        )
    sensed = dataclasses.replace(
        scene,
        obstacles=step.obstacles or scene.obstacles,
        goal=step.goal or scene.goal,
        motions=(),
    )
    return step_pose(step, sensed, memo)


def step_pose(step: LiveStep, scene: Scene, memo: Memo | None = None) -> RobotPose:
    """Describe the robot of one recorded step in ``scene``, the scene it senses there.

    Pose and wheel rates are the step's, r_next its aim; the sensing picture is the
    sensor's reading at the step's pose in ``scene`` (:func:`planners.bug.sensor.sense`).
    A recording of moving obstacles (:mod:`app.media.record_live`) draws its frames so.
    """
    return _robot_pose(step, scene, memo, playing=False)


def _robot_pose(
    step: LiveStep, scene: Scene, memo: Memo | None, *, playing: bool
) -> RobotPose:
    x, y, phi = step.pose
    return RobotPose(
        t=step.t,
        duration=step.t,
        xy=(x, y),
        phi=phi,
        wheel_angles=(0.0,) * len(step.rates),
        wheel_rates=step.rates,
        velocity=step.velocity,
        playing=playing,
        planner="live",
        sensing=_sensing(step, scene, memo),
    )


def _sensing(step: LiveStep, scene: Scene, memo: Memo | None) -> dict[str, Any] | None:
    """Read the sensor at the robot in ``scene`` (Fig. 9.16), for the view."""
    x, y, _ = step.pose
    try:
        space = live_space(scene, LiveOptions(), memo)
        seen = sense(space, (x, y), float(scene.sensor_range))
    except Exception:  # a scene mid-edit (a self-intersecting polygon): no picture
        logger.debug("no sensing picture", exc_info=True)
        return None
    points = np.asarray(seen.points, dtype=np.float64).reshape(-1, 2)
    tangents = (
        np.stack([np.broadcast_to(np.array([x, y]), points.shape), points], axis=1)
        if len(points)
        else np.zeros((0, 2, 2))
    )
    return {
        "center": (x, y),
        "radius": float(seen.radius),
        "seen": np.asarray(seen.segments, dtype=np.float64).reshape(-1, 2, 2),
        "tangents": tangents,
        "points": points,
        "chosen": step.aim if step.mode == "seek" else None,
        "goal": (float(scene.goal[0]), float(scene.goal[1])),
    }


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
        f"{markdown_text(words)}  \nmode: {mode}; travelled {state.travelled:.2f} m"
    )


class LiveRun:
    """The live DSB robot of one session: its record, its drawing, stepped by a ticker.

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
    speed
        Simulated seconds per wall second.
    ticker
        What steps it (shared by a classroom's copies); None: a ticker of its own.
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
        ticker: Ticker | None = None,
    ) -> None:
        self._scene_fn = scene_fn
        self._server = server
        self._views = views
        self.on_change = on_change
        """Called with (state, running) after every step (the panel)."""
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
            "/live/trail",
            np.zeros((0, 2, 3)),
            colors=_TRAIL,
            thickness=3.0,
            thickness_units="screen",
        )
        self._moving = server.scene.add_line_segments(
            "/live/moving",
            np.zeros((0, 2, 3)),
            colors=_MOVING,
            thickness=4.0,
            thickness_units="screen",
        )
        self._next_wall = 0.0  # time.monotonic() of the next step (while running)
        self._own_ticker = ticker is None
        self._ticker = Ticker(name="live-dsb") if ticker is None else ticker
        self._ticker.add(self)

    # ------------------------------------------------------------------ the panel's buttons

    def start(self) -> None:
        """Start (or continue) the live run; a finished run starts again from q_start."""
        with self._cond:
            if self._state is None or self._state.status in ("reached", "unreachable"):
                self._reset_locked()
            self._running = True
            self._next_wall = time.monotonic()
        self._ticker.wake()
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
        """Stop stepping (and the ticker, if it is the run's own)."""
        with self._cond:
            self._closed = True
            self._running = False
        if self._own_ticker:
            self._ticker.close()
        else:
            self._ticker.remove(self)

    @property
    def running(self) -> bool:
        """Whether the robot is driving."""
        with self._cond:
            return self._running

    @property
    def speed(self) -> float:
        """Simulated seconds per wall second (from the next step on when set).

        Only the pace changes: the robot takes the same steps of ``options.dt`` and
        makes the same decisions at any speed.
        """
        with self._cond:
            return self._speed

    @speed.setter
    def speed(self, value: float) -> None:
        if not math.isfinite(value) or value <= 0:
            raise ValueError(f"speed must be a positive number, not {value!r}")
        with self._cond:
            self._speed = float(value)

    @property
    def state(self) -> LiveState | None:
        """The live robot now (None before a start)."""
        with self._cond:
            return self._state

    def trace(self) -> LiveTrace | None:
        """Return the run so far as a :class:`planners.bug.live.LiveTrace` (None before a start)."""
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

    def recent_rates(
        self, window: float
    ) -> tuple[FloatArray, FloatArray, float | None] | None:
        """Return (t, rates (T, k), rate limit or None) of the last ``window`` seconds."""
        with self._cond:
            if not self._steps or self._start_scene is None:
                return None
            t_end = self._steps[-1].t
            recent = [s for s in self._steps[-2000:] if s.t >= t_end - window]
            limit = self._start_scene.robot.max_wheel_rate
        t = np.array([s.t for s in recent], dtype=np.float64)
        rates = np.array([s.rates for s in recent], dtype=np.float64)
        return t, rates, limit

    def show_at(self, t: float) -> None:
        """Draw the recorded run at time ``t`` (a stopped run; the replay slider)."""
        trace = self.trace()
        if trace is None or self.running:
            return
        scene = self._scene_fn()
        pose = live_pose_at(trace, t, scene, self._memo)
        shown = [s for s in trace.steps if s.t <= t + 1e-9]
        step = shown[-1] if shown else None
        moved = [o for o in step.obstacles if o not in scene.obstacles] if step else []
        self._show(pose, [trace.start, *(s.pose for s in shown)], moved)

    # ------------------------------------------------------------------ internals

    def _reset_locked(self) -> None:
        scene = self._scene_fn()
        self._start_scene = scene
        self._state = live_start(scene)
        self._steps, self._events, self._decisions = [], [], []

    def _tell(self) -> None:
        if self.on_change is not None:
            try:
                self.on_change(self.state, self.running)
            except Exception:
                logger.exception("live status update failed")

    def due(self) -> float | None:
        """When the next step is due [``time.monotonic()`` s]; None while stopped."""
        with self._cond:
            if self._closed or not self._running or self._state is None:
                return None
            return self._next_wall

    def tick(self) -> None:
        """Take one step now and draw it (the ticker's thread; never raises)."""
        with self._cond:
            state = self._state
            if state is None or not self._running:
                return
            period = self._options.dt / max(self._speed, 1e-6)
            # A run that fell behind (a busy machine, a shared ticker) goes on from now,
            # not in a burst of the steps it missed.
            self._next_wall = max(self._next_wall + period, time.monotonic() - period)
        try:
            self._step(state)
        except Exception:  # never take the server down: stop and say why
            logger.exception("live step failed")
            with self._cond:
                self._running = False
        self._tell()

    def _step(self, state: LiveState) -> None:
        scene = self._scene_fn()
        now = scene_at(scene, state.t)
        new = live_step(state, now, self._options, self._memo)
        record = record_step(new, scene, now, state.t)
        with self._cond:
            if self._state is not state or not self._running:
                return  # reset or stopped meanwhile: stopped means stopped
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
        outlines = [now.obstacles[m.obstacle] for m in scene.motions]
        self._show(live_pose(state, now, self._memo), path, outlines)

    def _show(self, pose: Any, path: list[Any], moving: list[Any]) -> None:
        """Draw the robot, its trail and the moving obstacles' outlines, as one update.

        Quiet if a copy's browser has left (:meth:`ScopedTarget.atomic`).
        """
        pts = np.asarray([p[:2] for p in path], dtype=np.float64).reshape(-1, 2)
        with self._server.atomic():
            for view in self._views:
                view.render_robot(pose)
            self._trail.points = _polyline_segments(pts, _Z)
            self._moving.points = _outline_segments(moving, _Z + 0.01)


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


_WHEELS = ("#0072B2", "#E69F00", "#009E73")  # Okabe-Ito, as the trajectory plot


def add_live_panel(server: Any, run: LiveRun) -> LivePanel:
    """Add the *Live DSB* folder to the panel and make it the run's ``on_change``."""
    panel = LivePanel(server, run)
    run.on_change = panel
    return panel


class LivePanels:
    """Every *Live DSB* folder of one run: each is told of every step (``run.on_change``).

    A classroom's presenter may have several browsers (the laptop and the projector):
    each has its own folder, added when it connects and removed when it leaves, so
    closing one never silences the others. A folder added while the robot drives shows
    its state at once; the replay slider scrubbed in one moves in the others.
    """

    def __init__(self, run: LiveRun) -> None:
        self._run = run
        self._lock = threading.Lock()
        self._panels: tuple[LivePanel, ...] = ()
        run.on_change = self

    def __len__(self) -> int:
        return len(self._panels)

    def add(self, server: Any) -> LivePanel:
        """Build a *Live DSB* folder on ``server.gui`` (a browser's handle) and tell it."""
        panel = LivePanel(server, self._run)

        @panel.replay.on_update
        def _(event: Any) -> None:
            if event.client is not None:  # a browser scrubs: the others' sliders follow
                self._show_replay(panel, float(event.target.value))

        with self._lock:
            self._panels = (*self._panels, panel)
        panel(self._run.state, self._run.running)
        return panel

    def _show_replay(self, moved: LivePanel, t: float) -> None:
        with self._lock:
            others = [p for p in self._panels if p is not moved]
        for panel in others:
            try:
                panel.show_replay(t)
            except Exception:
                logger.exception("a Live DSB folder failed to update")

    def remove(self, panel: LivePanel) -> None:
        """Stop telling ``panel`` (its browser left)."""
        with self._lock:
            self._panels = tuple(p for p in self._panels if p is not panel)

    def __call__(self, state: LiveState | None, running: bool) -> None:
        """Tell every folder; one that fails (its browser just left) stops no other."""
        with self._lock:
            panels = self._panels
        for panel in panels:
            try:
                panel(state, running)
            except Exception:
                logger.exception("a Live DSB folder failed to update")


class LivePanel:
    """The *Live DSB* folder: buttons, status in words, replay slider, wheel-rate plot.

    Each control calls one :class:`LiveRun` method. Called with the run's state after
    every step, it updates the words, the slider's range and the plot (the last
    ``window`` seconds, with the wheel rate limit dashed), at most ``rate`` times a
    second (a change of status at once).
    """

    def __init__(
        self, server: Any, run: LiveRun, rate: float = 4.0, window: float = 10.0
    ) -> None:
        self._run = run
        self._owner = server  # the server, or the one browser whose folder it is
        self._period = 1.0 / rate
        self._window = window
        self._last = 0.0
        self._head = ""
        gui = server.gui
        self.folder = gui.add_folder("Live DSB")
        """The folder (remove it to take the controls off the panel)."""
        with self.folder:
            self.status = gui.add_markdown(live_status_markdown(None, False))
            self.buttons = gui.add_button_group("Live", ["Start live", "Stop", "Reset"])
            self.replay = gui.add_slider("Replay t [s]", 0.0, 1.0, 0.05, 0.0)
            self.save = gui.add_button(
                "Save the live run (.json)", hint="The run so far, step by step"
            )
            self.plot = gui.add_uplot(
                (np.zeros(2), np.zeros(2)),
                ({"label": "t [s]"}, {"label": "wheel 1", "stroke": _WHEELS[0]}),
                title="Live wheel rates [rad/s]",
                scales={"x": {"time": False}},
                aspect=1.6,
            )

        @self.buttons.on_click
        def _(event: Any) -> None:
            {"Start live": run.start, "Stop": run.stop, "Reset": run.reset}[
                event.target.value
            ]()

        @self.replay.on_update
        def _(event: Any) -> None:
            if event.client is not None:  # not the panel's own updates while driving
                run.show_at(float(event.target.value))

        @self.save.on_click
        def _(event: Any) -> None:
            trace = run.trace()
            if trace is not None and event.client is not None:
                data = trace.to_json().encode("utf-8")
                event.client.send_file_download(
                    "live_run.json", data, save_immediately=True
                )

    def __call__(self, state: LiveState | None, running: bool) -> None:
        """Show ``state`` (throttled)."""
        text = live_status_markdown(state, running)
        head = text.split("t =")[0] + (state.status if state is not None else "")
        now = time.monotonic()
        if head == self._head and now - self._last < self._period:
            return
        self._head, self._last = head, now
        with batch(self._owner):
            self.status.content = text
            t = state.t if state is not None else 0.0
            self.replay.max = max(round(t, 2), 0.05)
            self.replay.value = min(t, self.replay.max)
            self._plot()

    def show_replay(self, t: float) -> None:
        """Move the replay slider to ``t`` [s] (another browser scrubbed).

        Quiet if this folder's browser has just left (:func:`app.ui.scoped.quietly`).
        """
        with quietly(self._owner):
            self.replay.value = min(t, self.replay.max)

    def _plot(self) -> None:
        data = self._run.recent_rates(self._window)
        if data is None:
            return
        t, rates, limit = data
        series: list[dict[str, Any]] = [{"label": "t [s]"}]
        series += [
            {"label": f"wheel {k + 1}", "stroke": _WHEELS[k % 3], "width": 2}
            for k in range(rates.shape[1])
        ]
        columns = [t, *(rates[:, k] for k in range(rates.shape[1]))]
        if limit is not None:  # section 9.7.3: the wheel rate limit, dashed
            series += [
                {"label": name, "stroke": "#888888", "width": 1, "dash": [6, 4]}
                for name in ("+limit", "-limit")
            ]
            columns += [np.full(len(t), limit), np.full(len(t), -limit)]
        top = max(float(np.abs(rates).max()) if rates.size else 1.0, limit or 0.0)
        # The window's own ranges: the plot does not re-range as new data come in.
        self.plot.scales = {  # type: ignore[assignment]
            "x": {"time": False, "range": [float(t[0]), float(max(t[-1], t[0] + 0.1))]},
            "y": {"range": [-1.1 * top - 0.1, 1.1 * top + 0.1]},
        }
        self.plot.series = tuple(series)  # type: ignore[assignment]
        self.plot.data = tuple(columns)


class MotionPaths:
    """A view that draws where each moving obstacle goes (its centroid's cycle), dashed.

    Added to the controller's views: it draws every frame's scene, live or not, so a
    scenario's motions are shown in the scene before anything moves.
    """

    def __init__(self, server: Any) -> None:
        self._key: Any = None
        self._handle = server.scene.add_line_segments(
            "/live/motion_paths",
            np.zeros((0, 2, 3)),
            colors=_MOVING,
            thickness=2.0,
            thickness_units="screen",
        )

    def render(self, frame: Any) -> None:
        """Draw the motions of ``frame.scene`` (only when they changed)."""
        scene = frame.scene
        key = (scene.motions, tuple(scene.obstacles[m.obstacle] for m in scene.motions))
        if key == self._key:
            return
        self._key = key
        parts = [_dashes(_cycle(scene, m), _Z) for m in scene.motions]
        self._handle.points = np.concatenate(parts) if parts else np.zeros((0, 2, 3))

    def render_robot(self, pose: Any) -> None:
        """Nothing: the robot is the 3-D view's."""


def _cycle(scene: Scene, motion: Any) -> FloatArray:
    c = scene.obstacles[motion.obstacle].centroid
    return np.asarray(motion.cycle, dtype=np.float64) + np.array([c.x, c.y])


def _dashes(points: FloatArray, z: float, dash: float = 0.15) -> FloatArray:
    """Segments of ``dash`` metres every ``2 * dash`` along the polyline."""
    out = []
    for a, b in itertools.pairwise(points):
        length = float(np.hypot(*(b - a)))
        n = max(int(length / (2 * dash)), 1) if length > 0 else 0
        for k in range(n):
            f0, f1 = 2 * k * dash / length, min((2 * k + 1) * dash / length, 1.0)
            out.append([[*(a + f0 * (b - a)), z], [*(a + f1 * (b - a)), z]])
    return np.asarray(out, dtype=np.float64).reshape(-1, 2, 3)
