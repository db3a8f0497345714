"""Recordings of scenarios with moving obstacles: the live DSB run, frame by frame.

A scenario whose obstacles move (``"motions"``, :mod:`planners.scene.motion`) is recorded as
the app's *Live DSB* robot drives it (section 9.6: the obstacles "do not have to be
static"; section 9.7.1: velocities "computed online"): :func:`planners.bug.live.run_live`
drives the robot once, deterministically, with every obstacle moving as its motion says,
and frame ``k`` draws that run at time ``t_k = k / fps`` (never a clock):

- every obstacle where it is at ``t_k`` (:func:`planners.scene.scene_at`), with its
  expanded shape (:func:`planners.bug.live.live_space` of that scene: the configuration space
  the live robot builds) and its number;
- the robot's pose, wheel rates and wheel angles at ``t_k`` from the trace
  (:class:`LiveFilm`): between two control periods the robot moves with the period's
  commanded velocity, which is how the trace's poses follow one another
  (``pose[k + 1] = pose[k] + velocity * dt``), and the wheels turn by the integral of
  the commanded wheel rates;
- what the robot senses there (Fig. 9.16: the sensor range R, the visible border, the
  lines r-O_i) with r_next the trace's own aim (:func:`app.live.step_pose`);
- the path driven so far, coloured by the trace's mode (goal seeking / boundary
  following), with the planner's events so far (H, D, L, M of Fig. 9.19), drawn by the
  view's DSB layer; the moving obstacles' dashed routes, as in the app.

Everything the robot decides is in the trace; this module only picks the trace's state
at each frame's time and draws it. The planners that plan once (VG, SVG, the batch DSB,
Bug2) plan the scene at t = 0, so their paths are not drawn over the live run.

Data flow::

    run_live(scene)                       -> LiveTrace          (once, pure)
    LiveFilm(scene, trace).frame(t_k)     -> LiveFrame           (pure: scene, space, pose, walk)
    show_live(app, frame)                 view.render / render_robot (property sets)
    relabel(slide, frame...)              -> the frame's labels over the same camera
    Studio.shot(t_k, [tick])              -> PNG, once the browser shows frame k

A still of such a scenario at a time (``--snapshot --robot-time T``:
:func:`live_picture`) is one frame of the same run, with its time stamp; without a time
the still is what the app shows (the planners' answers for the scene at t = 0).
"""

from __future__ import annotations

__all__ = [
    "FIGURE_EVENTS",
    "LiveFilm",
    "LiveFrame",
    "LiveWalk",
    "base_slide",
    "draw_app_again",
    "legend_plans",
    "live_drawing",
    "live_layers",
    "live_picture",
    "live_trace",
    "shoot_frame",
    "show_live",
]

import contextlib
import dataclasses
import functools
import math
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from app.live import step_pose
from app.media.camera import picture_bounds
from app.media.slides import DRAW_OVERLAY_JS, Slide, SlideOptions, layout, relabel
from app.media.video import RECORD_FPS, frame_times
from app.session.frames import RobotPose
from planners.bug.live import (
    MAX_DURATION_S,
    LiveEvent,
    LiveOptions,
    LiveStep,
    LiveTrace,
    live_space,
    run_live,
)
from planners.memo import Memo
from planners.scene import Scene, scene_at
from planners.space.expansion import ConfigurationSpace

FloatArray = npt.NDArray[np.float64]

FIGURE_EVENTS = ("hit", "leave", "local_min")
"""The live events drawn with their figure labels (H, D/L, M of Fig. 9.19)."""
PLANNER = "dsb"
"""The registry's planner whose layer draws the live walk: the live robot is DSB's."""
TICK = "/record/tick"
"""An invisible node moved last in every frame: when the browser has it, it has the
frame's other changes too (viser's messages arrive in order)."""
_SAME = 1e-12  # [m] a segment shorter than this is the robot at rest or turning


@dataclasses.dataclass(frozen=True, eq=False)
class LiveWalk:
    """The live robot's path so far, as the view's DSB layer draws a trace (Fig. 9.19)."""

    path: FloatArray
    """(N, 2) positions [m] from the start to where the robot is now."""
    modes: tuple[str, ...]
    """Mode of each of the N - 1 segments (``"seek"`` / ``"follow"``)."""
    events: tuple[LiveEvent, ...]
    """The planner's events so far (:data:`FIGURE_EVENTS`), each with ``label`` and ``at``."""


@dataclasses.dataclass(frozen=True, eq=False)
class LiveFrame:
    """Everything one frame of a live recording draws, at time ``t``."""

    t: float
    """Time of the frame [s]."""
    scene: Scene
    """The scene with every obstacle where it is at ``t`` (the motions kept, for the
    legend's route row)."""
    space: ConfigurationSpace
    """The expanded obstacles at ``t`` (the configuration space the live robot builds)."""
    pose: RobotPose
    """The robot at ``t``: pose, wheel rates and angles, what it senses."""
    walk: LiveWalk
    """The path driven until ``t``."""
    step: LiveStep
    """The trace's record of the control period in force at ``t``."""

    @property
    def plans(self) -> dict[str, Any]:
        """What the view draws as the frame's plans: the expanded shapes and the walk."""
        return {"cspace": self.space, PLANNER: self.walk}


def live_trace(
    scene: Scene, until: float | None = None, options: LiveOptions | None = None
) -> LiveTrace:
    """Drive the live robot in ``scene`` (obstacles moving) until it ends or ``until``.

    Never past :data:`planners.bug.live.MAX_DURATION_S`: a later time is drawn as the run's
    end.

    The run is :func:`planners.bug.live.run_live`'s, so it is the same every time.
    """
    options = options if options is not None else LiveOptions()
    if until is None or until >= MAX_DURATION_S:
        return run_live(scene, options, duration=MAX_DURATION_S)
    return run_live(scene, options, duration=until + options.dt)


@dataclasses.dataclass(frozen=True, eq=False)
class LiveFilm:
    """A live run to be drawn at any time: the scene with its motions and its trace.

    Examples
    --------
    >>> from shapely import Polygon
    >>> from planners.scene.motion import Motion
    >>> square = Polygon([(4, 0), (5, 0), (5, 1), (4, 1)])
    >>> scene = Scene(obstacles=(square,), start=(1, 3), goal=(8, 3),
    ...               motions=(Motion(0, ((0.0, 4.0),), speed=1.0),))
    >>> film = LiveFilm(scene, live_trace(scene, until=1.0))
    >>> frame = film.frame(1.0)
    >>> frame.scene.obstacles[0].bounds, frame.pose.xy == tuple(film.trace.poses[20][:2])
    ((4.0, 1.0, 5.0, 2.0), True)
    """

    scene: Scene
    """The scene as the file gives it (t = 0, with its motions)."""
    trace: LiveTrace
    memo: Memo = dataclasses.field(default_factory=Memo)
    options: LiveOptions = dataclasses.field(default_factory=LiveOptions)

    def __post_init__(self) -> None:
        if not self.trace.steps:
            raise ValueError("a live run of no step has nothing to draw")

    @functools.cached_property
    def wheel_turns(self) -> FloatArray:
        """(T + 1, k) wheel angles [rad] at the end of each period (0 at the start)."""
        rates = self.trace.rates.reshape(len(self.trace.steps), -1)
        start = np.zeros((1, rates.shape[1]))
        return np.concatenate([start, np.cumsum(rates * self.trace.dt, axis=0)])

    def period(self, t: float) -> tuple[int, float]:
        """Return the period ``k`` in force at ``t`` (0-based) and the time since its start.

        Period ``k`` runs from ``k * dt`` to ``(k + 1) * dt``; past the trace's end the
        last period is in force, at its end.
        """
        dt, n = self.trace.dt, len(self.trace.steps)
        k = math.floor(max(float(t), 0.0) / dt + 1e-9)
        if k >= n:
            return n - 1, dt
        return k, max(float(t) - k * dt, 0.0)

    def pose_at(self, t: float) -> tuple[tuple[float, float, float], FloatArray]:
        """Return the robot's pose (x, y, phi) and wheel angles [rad] at ``t``.

        At a period's start, exactly the trace's pose there; within it, moved with the
        period's commanded velocity (the trace's own step, see the module's notes).
        """
        k, s = self.period(t)
        step = self.trace.steps[k]
        before = self.trace.poses[k]
        if s == 0.0:
            pose = (float(before[0]), float(before[1]), float(before[2]))
        else:
            moved = before + np.asarray(step.velocity, dtype=np.float64) * s
            pose = (float(moved[0]), float(moved[1]), float(moved[2]))
        angles = self.wheel_turns[k] + np.asarray(step.rates, dtype=np.float64) * s
        return pose, angles

    def walk(self, t: float) -> LiveWalk:
        """Return the path driven until ``t``, with its modes and the events so far."""
        k, s = self.period(t)
        poses = self.trace.poses[: k + 1, :2]
        modes = [step.mode for step in self.trace.steps[:k]]
        if s > 0.0:
            poses = np.vstack([poses, self.pose_at(t)[0][:2]])
            modes.append(self.trace.steps[k].mode)
        moves = np.hypot(*np.diff(poses, axis=0).T) > _SAME
        keep = np.concatenate([[True], moves])
        events = tuple(
            e
            for e in self.trace.events
            if e.kind in FIGURE_EVENTS and e.t <= float(t) + 1e-9
        )
        return LiveWalk(
            path=poses[keep],
            modes=tuple(m for m, moved in zip(modes, moves, strict=True) if moved),
            events=events,
        )

    def frame(self, t: float) -> LiveFrame:
        """Return everything the frame at time ``t`` [s] draws."""
        now = scene_at(self.scene, t)
        k, _ = self.period(t)
        step = self.trace.steps[k]
        pose, angles = self.pose_at(t)
        sensed = dataclasses.replace(
            step, t=float(t), pose=pose, obstacles=now.obstacles, goal=now.goal
        )
        robot = dataclasses.replace(
            step_pose(sensed, now, self.memo),
            duration=self.trace.duration,
            wheel_angles=tuple(float(a) for a in angles),
        )
        return LiveFrame(
            t=float(t),
            scene=dataclasses.replace(now, motions=self.scene.motions),
            space=live_space(now, self.options, self.memo),
            pose=robot,
            walk=self.walk(t),
            step=step,
        )

    def bounds(self, times: tuple[float, ...]) -> tuple[float, float, float, float]:
        """Return the floor area every frame at ``times`` shows (the moving obstacles' too)."""
        if self.scene.boundary is not None:
            return picture_bounds(self.scene)
        boxes = np.array(
            [picture_bounds(scene_at(self.scene, t)) for t in (0.0, *times)]
        )
        return (
            float(boxes[:, 0].min()),
            float(boxes[:, 1].min()),
            float(boxes[:, 2].max()),
            float(boxes[:, 3].max()),
        )


def live_layers(layers: Mapping[str, bool]) -> dict[str, bool]:
    """Return the app's layers for a live frame: the robot, its sensing and its walk on."""
    return {**layers, "robot": True, "sensing": True, f"{PLANNER}_path": True}


def show_live(planner_app: Any, frame: LiveFrame) -> None:
    """Draw ``frame`` with the app's 3-D view: the scene at ``t``, the walk, the robot.

    The app must be idle (nothing else draws meanwhile). The controller's own frame
    lends everything else (tool, the layers' switches); nothing in the controller
    changes.
    """
    base = planner_app.controller.frame
    shown = dataclasses.replace(
        base,
        scene=frame.scene,
        plans=frame.plans,
        layers=live_layers(base.layers),
        selection=None,
        draft=(),
        dragging=frozenset(),
        other_expanded=None,
        stale=False,
    )
    planner_app.view.render(shown)
    planner_app.view.render_robot(frame.pose)


def live_picture(
    studio: Any,
    t: float,
    view: str = "top",
    options: SlideOptions = SlideOptions(),  # noqa: B008
) -> bytes:
    """Return a still (PNG) of the live run of the studio's scene at time ``t`` [s].

    The frame at ``t`` of a recording that ends there (``--record --until T``): the
    obstacles where they are then, the robot, its sensing and the path driven so far,
    laid out as that recording is (:func:`base_slide`: legend and camera of the run
    until ``t``). Past the run's end (the goal reached, or
    :data:`planners.bug.live.MAX_DURATION_S`), its last frame. With the labels on, the
    picture says its time (``t = 4.5 s``). The app's own drawing is put back afterwards.
    """
    app = studio.app
    studio.wait_idle()
    scene = app.controller.scene
    film = LiveFilm(scene, live_trace(scene, until=t))
    t = min(float(t), film.trace.duration)  # past the run's end: its last frame
    times = (*frame_times(t, RECORD_FPS), t)  # a recording's frames until t, and t
    frame = film.frame(t)
    if options.labels:
        options = dataclasses.replace(options, time_stamp=True)
    size = (studio.width, studio.height)
    slide = base_slide(app, film, times, size, options, view=view, last=frame)
    with live_drawing(app) as tick:
        studio.compose(options=options, slide=slide)
        return shoot_frame(studio, frame, slide, options, (0, tick))


@contextlib.contextmanager
def live_drawing(planner_app: Any) -> Iterator[Any]:
    """Yield the tick node live frames are shot by; then the app's own drawing again.

    The tick starts at -1: frame ``k`` moves it to ``k``, so even frame 0 waits for its
    changes. Afterwards the tick goes, and the view draws the controller's frame and its
    robot at the start.
    """
    tick = planner_app.server.scene.add_frame(
        TICK, show_axes=False, visible=False, position=(-1.0, 0.0, 0.0)
    )
    try:
        yield tick
    finally:
        tick.remove()
        draw_app_again(planner_app)


def draw_app_again(planner_app: Any) -> None:
    """Draw the app's own frame and its robot at the start again, after live frames."""
    planner_app.view.render(planner_app.controller.frame)
    planner_app.set_robot_time(0.0)


def legend_plans(film: LiveFilm, last: LiveFrame) -> dict[str, Any]:
    """Return the plans a legend of the whole run describes: ``last``'s, every event's.

    One legend for a whole video or page, so it does not change from frame to frame.
    """
    whole = dataclasses.replace(last.walk, events=film.walk(film.trace.duration).events)
    return {**last.plans, PLANNER: whole}


def base_slide(
    planner_app: Any,
    film: LiveFilm,
    times: tuple[float, ...],
    size: tuple[int, int],
    options: SlideOptions,
    *,
    view: str = "top",
    last: LiveFrame | None = None,
) -> Slide:
    """Lay out what every frame shares: camera, title, legend (of the whole run), stamp.

    ``last``: the frame at ``times[-1]``, when the caller has it already.
    """
    controller = planner_app.controller
    if last is None:
        last = film.frame(times[-1] if times else 0.0)
    return layout(
        last.scene,
        legend_plans(film, last),
        live_layers(controller.frame.layers),
        *size,
        view=view,
        options=options,
        registry=controller.registry,
        bounds=film.bounds(times),
    )


def shoot_frame(
    studio: Any,
    frame: LiveFrame,
    base: Slide,
    options: SlideOptions,
    tick: tuple[int, Any],
) -> bytes:
    """Draw ``frame`` (scene, robot, labels) and take it once the browser shows it."""
    app = studio.app
    show_live(app, frame)
    k, node = tick
    node.position = (float(k), 0.0, 0.0)  # last: the browser has the frame with it
    slide = relabel(
        base,
        frame.scene,
        frame.plans,
        live_layers(app.controller.frame.layers),
        options=options,
        registry=app.controller.registry,
    )
    studio.shown.page.evaluate(DRAW_OVERLAY_JS, slide.overlay_spec())
    studio.slide = slide
    app.server.flush()
    return studio.shot(frame.t, extra=[(TICK, (float(k), 0.0, 0.0))])
