"""``--record OUT.mp4|OUT.gif``: the robot's run as a video, for slides and course pages.

The robot follows the chosen planner's path at the trajectory's real time: frame ``k`` is
the robot at trajectory time ``t_k = k / fps`` (wheels turned as far as they have turned
by then), from ``t = 0`` to the end of the trajectory (or ``until``). The time is set
explicitly for each frame (:meth:`app.media.pictures.Studio.frame`), never read from a clock,
so two recordings of the same scenario are the same frame for frame.

The pictures are the slide pictures of :mod:`app.media.slides` (title, legend, labels placed for
the video's size) drawn by the app in headless Chromium, and encoded by
:mod:`app.media.video` (ffmpeg for MP4, Pillow for GIF).

A scenario with moving obstacles is recorded live (:mod:`app.media.record_live`): the DSB robot
sensing as it drives while the obstacles move, as the app's *Live DSB* mode shows it,
frame ``k`` again at ``t_k = k / fps`` of that run. ``follow`` is then an error (one
line, exit code 2): the planners that plan once see only the scene at t = 0.
"""

from __future__ import annotations

__all__ = [
    "FORMATS",
    "LIVE_FOLLOW",
    "check_until",
    "check_video",
    "record",
    "record_live_video",
    "record_video",
]

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app.media.browser import SnapshotError
from app.media.jobs import JobFailure, run_job
from app.media.pictures import FirstPicture, open_studio
from app.media.record_live import (
    LiveFilm,
    base_slide,
    live_drawing,
    live_trace,
    shoot_frame,
)
from app.media.slides import SlideOptions
from app.media.video import MAX_FPS, RECORD_FPS, Recording, frame_times, pixels, writer

if TYPE_CHECKING:
    from playwright.sync_api import Browser


FORMATS = (".mp4", ".gif")
"""File suffixes :func:`record` writes."""
LIVE_FOLLOW = (
    "--follow {follow}: this scenario's obstacles move, so it is recorded live (the DSB"
    " robot sensing as it drives); --follow is for scenarios without moving obstacles"
)
"""The one-line error for ``--follow`` on a scenario with moving obstacles."""


def record_video(
    planner_app: Any,
    browser: Browser,
    out: str | os.PathLike[str],
    *,
    width: int = 640,
    height: int = 360,
    fps: float = RECORD_FPS,
    follow: str | None = None,
    until: float | None = None,
    options: SlideOptions = SlideOptions(),  # noqa: B008
    timeout: float = 60.0,
) -> Recording:
    """Record the robot of a running app following ``follow``'s path into ``out``.

    A scene with moving obstacles is recorded live instead: the DSB robot sensing as it
    drives among them (:func:`record_live_video`); ``follow`` must then
    be None.

    Raises
    ------
    SnapshotError
        If there is no trajectory to record (the planner found no path) or the browser
        fails.
    JobFailure
        ``follow`` given for a scene with moving obstacles (exit code 2).
    """
    if planner_app.controller.scene.motions:
        if follow is not None:
            raise JobFailure(LIVE_FOLLOW.format(follow=follow), 2)
        return record_live_video(
            planner_app,
            browser,
            out,
            width=width,
            height=height,
            fps=fps,
            until=until,
            options=options,
            timeout=timeout,
        )
    path = Path(out)
    if follow is not None:  # before the page opens: it loads the final scene once
        planner_app.controller.playback.set_follow(follow)
    with open_studio(
        planner_app,
        browser,
        width=width,
        height=height,
        timeout=timeout,
        first=FirstPicture("top", options),
    ) as studio:
        studio.app.set_robot_time(0.0)
        studio.wait_idle()
        duration = studio.duration
        if duration <= 0:
            raise SnapshotError(
                f"no trajectory to record: the planner followed ({follow or 'the default'})"
                " found no path in this scenario"
            )
        end = duration if until is None else min(duration, until)
        times = frame_times(end, fps)
        slide = studio.compose("top", options)
        with writer(path, fps) as write:
            for t in times:
                write(pixels(studio.frame(t)))
    return Recording(path, fps, times, end, slide.camera, width, height)


def record_live_video(
    planner_app: Any,
    browser: Browser,
    out: str | os.PathLike[str],
    *,
    width: int = 640,
    height: int = 360,
    fps: float = RECORD_FPS,
    until: float | None = None,
    options: SlideOptions = SlideOptions(),  # noqa: B008
    timeout: float = 60.0,
) -> Recording:
    """Record the live DSB run of the app's scene (moving obstacles) into ``out``.

    Frame ``k`` is the run at ``t_k = k / fps``, from 0 to the end of the run (the goal
    reached, or :func:`planners.bug.live.run_live`'s limit) or ``until``.
    """
    path = Path(out)
    scene = planner_app.controller.scene
    film = LiveFilm(scene, live_trace(scene, until))
    end = film.trace.duration if until is None else min(film.trace.duration, until)
    times = frame_times(end, fps)
    base = base_slide(planner_app, film, times, (width, height), options)
    with open_studio(
        planner_app,
        browser,
        width=width,
        height=height,
        timeout=timeout,
        first=FirstPicture("top", options),
    ) as studio:
        studio.wait_idle()
        with live_drawing(planner_app) as tick:
            studio.compose(options=options, slide=base)
            with writer(path, fps) as write:
                for k, t in enumerate(times):
                    write(
                        pixels(
                            shoot_frame(studio, film.frame(t), base, options, (k, tick))
                        )
                    )
    return Recording(path, fps, times, end, base.camera, width, height, live=film.trace)


def check_video(
    out: Path, width: int, height: int, fps: float, until: float | None
) -> str | None:
    """Return the one-line problem with a video's file, size, frame rate and end, or None."""
    if out.suffix.lower() not in FORMATS:
        return f"{out}: the video must end in {' or '.join(FORMATS)}"
    for name, value in (("width", width), ("height", height)):
        if (
            isinstance(value, bool)
            or not isinstance(value, int)
            or not 16 <= value <= 4096
        ):
            return f"{name} must be a whole number of pixels from 16 to 4096, got {value!r}"
    if out.suffix.lower() == ".mp4" and (width % 2 or height % 2):
        return f"an MP4 needs an even width and height, got {width} x {height}"
    if not (math.isfinite(fps) and 1 <= fps <= MAX_FPS):
        return f"fps must be from 1 to {MAX_FPS}, got {fps!r}"
    return check_until(until)


def check_until(until: float | None) -> str | None:
    """Return the one-line problem with an end time (``--until``), or None."""
    if until is not None and not (math.isfinite(until) and until >= 0):
        return f"the end time must be a finite time >= 0 s, got {until!r}"
    return None


def _moves(scenario: Any) -> bool:
    """Tell whether ``scenario`` has moving obstacles.

    False when it cannot be read: starting the app then says why, in one line.
    """
    from app.server import resolve_scenario  # noqa: PLC0415
    from planners.scene import Scene, load_scene  # noqa: PLC0415

    try:
        if isinstance(scenario, Scene):
            return bool(scenario.motions)
        return bool(load_scene(resolve_scenario(scenario)[1]).motions)
    except Exception:  # any unreadable scenario: the app's start says why
        return False


def record(
    scenario: Any,
    out: str | os.PathLike[str],
    *,
    width: int = 640,
    height: int = 360,
    fps: float = RECORD_FPS,
    follow: str | None = None,
    until: float | None = None,
    options: SlideOptions = SlideOptions(),  # noqa: B008
    timeout: float = 60.0,
    chromium: str | None = None,
) -> int:
    """Write the robot's run in ``scenario`` as a video; return the exit code.

    0 when the file is written, 2 for a bad scenario or argument, 1 when the browser or
    the app fails. Errors are one line on stderr.
    """
    path = Path(out)
    problem = check_video(path, width, height, fps, until)
    if problem is None and follow is not None:
        import planners  # noqa: PLC0415

        if follow not in planners.REGISTRY:
            problem = f"unknown planner {follow!r} to follow (known: {', '.join(planners.REGISTRY)})"
        elif _moves(scenario):
            problem = LIVE_FOLLOW.format(follow=follow)

    def work(planner_app: Any, browser: Browser) -> Recording:
        return record_video(
            planner_app,
            browser,
            path,
            width=width,
            height=height,
            fps=fps,
            follow=follow,
            until=until,
            options=options,
            timeout=timeout,
        )

    return run_job(scenario, path, problem, work, chromium=chromium)
