"""The presenter's followers: views drawn from the presenter's session, some at a bounded rate.

Data flow::

    presenter's session -> Audience.render(frame)
        -> members (presenters' own views, editors' views): drawn at once, in order
        -> deferred members (the watchers' one shared panel, lab panels): the newest
           frame, by the audience's own thread, at most once per period
"""

from __future__ import annotations

__all__ = ["Audience"]

import logging
import threading
import time

from app.session.controller import Frame, RobotPose
from app.session.frames import View

logger = logging.getLogger(__name__)


class Audience:
    """One view of the presenter's session that draws on the views of its followers.

    Members change while frames are drawn (browsers come and go); a member is added with
    the last frame drawn, so it is never blank, and removed only between two frames.

    *Deferred* members (the panels of browsers that watch) are drawn by a thread of their
    own with the newest frame, at most once per ``period`` seconds: a class of watchers
    costs the presenter's drawing thread nothing, and their panels a bounded rate (their
    3-D scene is the shared view, drawn once for everyone, at once).
    """

    def __init__(self, period: float = 0.1) -> None:
        self._lock = threading.Lock()
        self._members: tuple[View, ...] = ()
        self._frame: Frame | None = None
        self._pose: RobotPose | None = None
        self._period = period
        self._cond = threading.Condition()  # guards _due and _closed
        self._draw_lock = threading.Lock()  # guards _deferred and drawing on them
        self._deferred: tuple[View, ...] = ()
        self._due: tuple[bool, bool] = (False, False)  # (frame, robot) to draw
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="audience", daemon=True)
        self._thread.start()

    def add(self, *views: View, first: bool = False, deferred: bool = False) -> None:
        """Draw on ``views`` from now on (``first``: before the others).

        ``deferred`` views are drawn at most once per period with the newest frame.
        """
        if deferred:
            # The frame is read inside the drawing lock: a frame rendered meanwhile is
            # then drawn by the thread on these views too, never left behind.
            with self._draw_lock:
                with self._lock:
                    frame, pose = self._frame, self._pose
                for view in views:
                    _draw(view, frame, pose)
                self._deferred = (*self._deferred, *views)
            return
        with self._lock:
            for view in views:
                _draw(view, self._frame, self._pose)
            self._members = (
                (*views, *self._members) if first else (*self._members, *views)
            )

    def remove(self, *views: View) -> None:
        """Stop drawing on ``views`` (waits for a frame being drawn to finish)."""
        with self._lock:
            self._members = tuple(v for v in self._members if v not in views)
        with self._draw_lock:
            self._deferred = tuple(v for v in self._deferred if v not in views)

    def __len__(self) -> int:
        return len(self._members) + len(self._deferred)

    def render(self, frame: Frame) -> None:
        """Draw ``frame`` on every member (the deferred ones soon after)."""
        with self._lock:
            self._frame = frame
            for view in self._members:
                _draw(view, frame, None)
        self._wake(frame=True)

    def render_robot(self, pose: RobotPose | None) -> None:
        """Draw the robot on every member (the deferred ones soon after)."""
        with self._lock:
            self._pose = pose
            for view in self._members:
                _draw(view, None, pose, robot=True)
        self._wake(robot=True)

    def close(self) -> None:
        """Stop the deferred members' thread."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(timeout=5.0)

    def _wake(self, frame: bool = False, robot: bool = False) -> None:
        with self._cond:
            self._due = (self._due[0] or frame, self._due[1] or robot)
            self._cond.notify_all()

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._closed and not any(self._due):
                    self._cond.wait()
                if self._closed:
                    return
                (frame_due, robot_due), self._due = self._due, (False, False)
            with self._lock:
                frame, pose = self._frame, self._pose
            # Under the drawing lock: a removed member is never drawn after remove()
            # returned (a copy's panel must not get the presenter's frame).
            with self._draw_lock:
                for view in self._deferred:
                    _draw(view, frame if frame_due else None, pose, robot=robot_due)
            time.sleep(self._period)


def _draw(
    view: View, frame: Frame | None, pose: RobotPose | None, robot: bool = False
) -> None:
    # A browser that just left must not stop the others' frames.
    try:
        if frame is not None:
            view.render(frame)
        if robot or pose is not None:
            view.render_robot(pose)
    except Exception:
        logger.exception("a browser's view failed to draw")
