"""The presenter's followers: views drawn from the presenter's session, some at a bounded rate.

Data flow::

    presenter's session -> Audience.render(frame)
        -> members (presenters' and editors' gizmos): drawn at once, in order
        -> deferred members (the watchers' one shared panel, lab panels): the newest
           frame, by the audience's own thread (Paced), at most once per period

The presenter's scene itself is drawn once, for everyone, by the presenter's session
(``/shared``); the pump sends it to the class at the class's rate
(:mod:`app.classroom.wire`).
"""

from __future__ import annotations

__all__ = ["Audience", "Paced"]

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
    3-D scene is the shared view, drawn once for everyone).
    """

    def __init__(self, period: float = 0.1) -> None:
        self._lock = threading.Lock()
        self._members: tuple[View, ...] = ()
        self._frame: Frame | None = None
        self._pose: RobotPose | None = None
        self._deferred = _Together()
        self._paced = Paced(self._deferred, 1.0 / period, name="audience")

    def add(self, *views: View, first: bool = False, deferred: bool = False) -> None:
        """Draw on ``views`` from now on (``first``: before the others).

        ``deferred`` views are drawn at most once per period with the newest frame.
        """
        if deferred:
            # The frame is read inside the drawing lock: a frame rendered meanwhile is
            # then drawn by the thread on these views too, never left behind.
            with self._deferred.lock:
                with self._lock:
                    frame, pose = self._frame, self._pose
                for view in views:
                    _draw(view, frame, pose)
                self._deferred.views = (*self._deferred.views, *views)
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
        with self._deferred.lock:
            self._deferred.views = tuple(
                v for v in self._deferred.views if v not in views
            )

    def __len__(self) -> int:
        return len(self._members) + len(self._deferred.views)

    def render(self, frame: Frame) -> None:
        """Draw ``frame`` on every member (the deferred ones soon after)."""
        with self._lock:
            self._frame = frame
            for view in self._members:
                _draw(view, frame, None)
        self._paced.render(frame)

    def render_robot(self, pose: RobotPose | None) -> None:
        """Draw the robot on every member (the deferred ones soon after)."""
        with self._lock:
            self._pose = pose
            for view in self._members:
                _draw(view, None, pose, robot=True)
        self._paced.render_robot(pose)

    def close(self) -> None:
        """Stop the deferred members' thread."""
        self._paced.close()


class _Together:
    """Views drawn as one by a :class:`Paced` thread (an audience's deferred members).

    Views change only under :attr:`lock`, which every drawing holds: a view removed is
    never drawn after its removal returned (a copy's panel must not get the presenter's
    frame).
    """

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.views: tuple[View, ...] = ()

    def render(self, frame: Frame) -> None:
        with self.lock:
            for view in self.views:
                _draw(view, frame, None)

    def render_robot(self, pose: RobotPose | None) -> None:
        with self.lock:
            for view in self.views:
                _draw(view, None, pose, robot=True)


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


class Paced:
    """A view drawn with the newest frame at most ``rate`` times a second, by its own thread.

    An :class:`Audience` draws its deferred members (the watchers' one panel) through
    one: the panel costs the presenter's drawing thread nothing, and at most ``rate``
    drawings a second whatever the presenter's rate. A frame that arrives while one is
    drawn waits, and only the newest waits: the last frame of a drag is always drawn.
    """

    def __init__(self, view: View, rate: float, *, name: str = "paced") -> None:
        self.view = view
        """The view drawn."""
        self.rate = rate
        """Most frames a second (set it at any time: from the next frame on)."""
        self._cond = threading.Condition()
        self._frame: Frame | None = None
        self._pose: RobotPose | None = None
        self._due = (False, False)  # (frame, robot) to draw
        self._closed = False
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def render(self, frame: Frame) -> None:
        """Draw ``frame`` soon (a newer one given meanwhile replaces it)."""
        with self._cond:
            self._frame, self._due = frame, (True, self._due[1])
            self._cond.notify_all()

    def render_robot(self, pose: RobotPose | None) -> None:
        """Draw the robot at ``pose`` soon (a newer one given meanwhile replaces it)."""
        with self._cond:
            self._pose, self._due = pose, (self._due[0], True)
            self._cond.notify_all()

    def close(self) -> None:
        """Stop the thread (what is not drawn yet stays undrawn)."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while True:
            with self._cond:
                self._cond.wait_for(lambda: self._closed or any(self._due))
                if self._closed:
                    return
                (frame_due, robot_due), self._due = self._due, (False, False)
                frame, pose = self._frame, self._pose
            started = time.monotonic()
            _draw(self.view, frame if frame_due else None, pose, robot=robot_due)
            time.sleep(max(0.0, 1.0 / self.rate - (time.monotonic() - started)))
