"""Robot playback: play, pause, speed and time; the trajectory along the followed path.

Data flow::

    scheduler round (its thread), for the frame of version v:
      lookup = playback.lookup(v, scene, plans, follow)   # keep the trajectory?
      trajectory = playback.plan(scene, lookup)            # plan a new one if needed
      pose = playback.settle_locked()                      # clamp t, sample the pose
    its ticker (app.session.pool; while playing, ``fps`` times a second at most):
      t += elapsed * speed -> pose -> views.render_robot(pose)
    panel (viser's threads): controller.playback.play() / pause() / set_speed(...)

The trajectory depends on the robot and the path alone: an edit that leaves the path as it
was (a vertex dragged far from it) keeps the trajectory, and the robot keeps its place in
it. The state is guarded by the session's one lock (:attr:`SessionState.lock`).
"""

from __future__ import annotations

__all__ = ["Lookup", "Playback", "SampleFn", "TrajectoryFn"]

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from app.session._state import SessionState
from app.session.frames import RobotPose, Views
from app.session.pool import Ticker
from planners.scene import Scene

logger = logging.getLogger(__name__)

TrajectoryFn = Callable[[Scene, npt.NDArray[np.float64]], Any]
"""(scene, path (N, 2)) -> a timed trajectory object, or None when there is none.

It may depend on the scene's robot and the path only: the playback keeps the trajectory
while both stay the same."""

SampleFn = Callable[[Any, float, Scene, Any], Mapping[str, Any]]
"""(trajectory, t [s], scene, planner result followed) -> RobotPose fields (xy, phi, ...)."""


@dataclasses.dataclass(frozen=True, eq=False)
class _Key:
    """Which result a trajectory follows: a scene version, a planner and its result."""

    version: int
    planner: str
    result: Any  # compared by identity: a slow result replaces its place-holder

    def same(self, other: _Key | None) -> bool:
        return (
            other is not None
            and (self.version, self.planner) == (other.version, other.planner)
            and self.result is other.result
        )


@dataclasses.dataclass(frozen=True)
class _Kept:
    """The trajectory on show and what it was computed from."""

    key: _Key | None = None
    value: tuple[Any, ...] | None = None  # (planner, robot, path bytes)
    trajectory: Any = None
    scene: Scene | None = None


@dataclasses.dataclass(frozen=True)
class Lookup:
    """The answer of :meth:`Playback.lookup`: keep a trajectory, or plan a new one."""

    key: _Key
    value: tuple[Any, ...]
    path: npt.NDArray[np.float64]
    trajectory: Any
    """The trajectory to keep (possibly None) when ``must_plan`` is False."""
    must_plan: bool
    """A new trajectory must be planned along ``path`` (takes up to a few ms)."""


class Playback:
    """The robot's motion along the followed path, and its animation.

    Parameters
    ----------
    state
        The session; its lock guards the playback too.
    views
        Where the robot is drawn.
    trajectory, sample
        See :data:`TrajectoryFn` and :data:`SampleFn`; None disables the robot.
    fps
        Animation rate [frames/s].
    ticker
        What draws its frames (a classroom's copies share one); None: a ticker (a
        thread) of its own.
    """

    def __init__(
        self,
        state: SessionState,
        views: Views,
        trajectory: TrajectoryFn | None,
        sample: SampleFn | None,
        *,
        fps: float = 30.0,
        ticker: Ticker | None = None,
    ) -> None:
        self._state = state
        self._lock = state.lock
        self._views = views
        self._trajectory_fn = trajectory
        self._sample_fn = sample
        self._period = 1.0 / fps
        self._t = 0.0
        self._playing = False
        self._speed = 1.0
        self._wall = 0.0  # time.monotonic() at the last advance
        self._kept = _Kept()
        self._closed = False
        self._next_wall = 0.0  # time.monotonic() of the next frame (while playing)
        self._own_ticker = ticker is None
        self._ticker = Ticker(name="robot-animation") if ticker is None else ticker
        self._ticker.add(self)

    # ------------------------------------------------------------------ the panel's buttons

    @property
    def state(self) -> tuple[float, bool, float]:
        """(time [s], playing, speed) of the robot."""
        with self._lock:
            return (self._t, self._playing, self._speed)

    def play(self) -> None:
        """Start (or continue) the robot's motion; at the end, start again from 0."""
        with self._lock:
            self._play_locked()

    def pause(self) -> None:
        """Stop the robot where it is."""
        with self._lock:
            self._playing = False
            self._state.touch_locked()

    def restart(self) -> None:
        """Put the robot back at the start of its trajectory and play."""
        with self._lock:
            self._t = 0.0
            self._play_locked()

    def set_speed(self, speed: float) -> None:
        """Set the playback speed (1 is real time)."""
        with self._lock:
            self._speed = max(0.0, float(speed))
            self._state.touch_locked()

    def set_robot_time(self, t: float | None) -> None:
        """Pause the robot at trajectory time ``t`` [s] (clamped); None resumes playing."""
        with self._lock:
            if t is None:
                self._play_locked()
                return
            t = float(t)
            duration = self._duration_locked() or 0.0
            self._playing = False
            self._t = min(max(0.0, t), duration) if math.isfinite(t) else 0.0
            self._state.touch_locked()

    def set_follow(self, planner: str) -> None:
        """Choose which planner's path the robot follows (from its start)."""
        with self._lock:
            self._state.update_ui(lambda ui: dataclasses.replace(ui, follow=planner))
            self._t = 0.0

    def close(self) -> None:
        """Stop the animation (and its ticker, if it is its own)."""
        with self._lock:
            self._closed = True
        if self._own_ticker:
            self._ticker.close()
        else:
            self._ticker.remove(self)

    @property
    def alive(self) -> bool:
        """Whether it is still animated (not closed, its ticker's thread running)."""
        with self._lock:
            closed = self._closed
        return not closed and self._ticker.alive

    # ------------------------------------------------------------------ for its ticker

    def due(self) -> float | None:
        """When the next frame is due [``time.monotonic()`` s]; None while paused."""
        with self._lock:
            return None if self._closed or not self._playing else self._next_wall

    def tick(self) -> None:
        """Move the robot on by the wall time since the last frame, and draw it."""
        with self._lock:
            if self._closed or not self._playing:
                return
            self._advance_locked()
            pose = self._pose_locked()
            now = time.monotonic()
            self._next_wall = max(self._next_wall + self._period, now - self._period)
        try:
            self._views.render_robot(pose)
        except Exception:  # never stop the ticker's other runs
            logger.exception("drawing the robot failed")

    # ------------------------------------------------------------------ for the scheduler

    @property
    def trajectory(self) -> Any:
        """The trajectory on show (None when there is none)."""
        return self._kept.trajectory

    def lookup(
        self, version: int, scene: Scene, plans: Mapping[str, Any], follow: str
    ) -> Lookup:
        """Decide whether the robot keeps its trajectory for the plans of ``version``."""
        result = plans.get(follow)
        path = np.asarray(
            getattr(result, "path", np.zeros((0, 2))), dtype=np.float64
        ).reshape(-1, 2)
        # The result object itself is part of the key: a slow planner's result replaces
        # its place-holder within the same scene version. The trajectory depends on the
        # robot and the path alone.
        key = _Key(version, follow, result)
        value = (follow, scene.robot, path.tobytes())
        kept = self._kept  # written by the scheduler's thread only, read by it here
        if key.same(kept.key) or (kept.trajectory is not None and value == kept.value):
            return Lookup(key, value, path, kept.trajectory, must_plan=False)
        must_plan = self._trajectory_fn is not None and len(path) >= 2
        return Lookup(key, value, path, None, must_plan=must_plan)

    def plan(self, scene: Scene, lookup: Lookup) -> Any:
        """Plan the trajectory ``lookup`` asked for (outside the lock), and keep it."""
        trajectory = lookup.trajectory
        if lookup.must_plan:
            assert self._trajectory_fn is not None
            try:
                trajectory = self._trajectory_fn(scene, lookup.path)
            except Exception:
                logger.exception("trajectory failed")
                trajectory = None
        with self._lock:
            self._kept = _Kept(lookup.key, lookup.value, trajectory, scene)
        return trajectory

    def settle_locked(self) -> RobotPose | None:
        """After a new trajectory: keep the time within it; the robot's pose now."""
        duration = self._duration_locked()
        if duration is not None:
            self._t = min(self._t, duration)
        return self._pose_locked()

    # ------------------------------------------------------------------ internals

    def _play_locked(self) -> None:
        duration = self._duration_locked()
        if duration is not None and self._t >= duration:
            self._t = 0.0
        self._playing = True
        self._wall = self._next_wall = time.monotonic()
        self._state.touch_locked()
        self._ticker.wake()

    def _duration_locked(self) -> float | None:
        trajectory = self._kept.trajectory
        if trajectory is None:
            return None
        return float(getattr(trajectory, "duration", 0.0))

    def _pose_locked(self) -> RobotPose | None:
        kept = self._kept
        if (
            kept.trajectory is None
            or self._sample_fn is None
            or kept.key is None
            or kept.scene is None
        ):
            return None
        try:
            fields = self._sample_fn(
                kept.trajectory, self._t, kept.scene, kept.key.result
            )
        except Exception:
            logger.exception("sampling the trajectory failed")
            return None
        return RobotPose(
            t=self._t, playing=self._playing, planner=kept.key.planner, **fields
        )

    def _advance_locked(self) -> None:
        now = time.monotonic()
        self._t += max(0.0, now - self._wall) * self._speed
        self._wall = now
        duration = self._duration_locked()
        if duration is None or self._t >= duration:
            self._t = 0.0 if duration is None else duration
            self._playing = False
            self._state.touch_locked()  # the panel's play button changes
