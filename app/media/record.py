"""``--record OUT.mp4|OUT.gif``: the robot's run as a video, for slides and course pages.

The robot follows the chosen planner's path at the trajectory's real time: frame ``k`` is
the robot at trajectory time ``t_k = k / fps`` (wheels turned as far as they have turned
by then), from ``t = 0`` to the end of the trajectory (or ``until``). The time is set
explicitly for each frame (:meth:`app.media.pictures.Studio.frame`), never read from a clock,
so two recordings of the same scenario are the same frame for frame.

The pictures are the slide pictures of :mod:`app.media.slides` (title, legend, labels placed for
the video's size) drawn by the app in headless Chromium. The encoding is done by ffmpeg
through ``imageio-ffmpeg`` (a PyPI wheel that bundles the ffmpeg binary) for MP4
(H.264, yuv420p, so it plays in every browser and in slide software), and by Pillow
through ``imageio`` for GIF (which stores frame times in hundredths of a second: a frame
rate that does not divide 100 is played slightly off).

A scenario with moving obstacles is recorded live (:mod:`app.media.record_live`): the DSB robot
sensing as it drives while the obstacles move, as the app's *Live DSB* mode shows it,
frame ``k`` again at ``t_k = k / fps`` of that run. ``follow`` is then an error (one
line, exit code 2): the planners that plan once see only the scene at t = 0.
"""

from __future__ import annotations

__all__ = [
    "FORMATS",
    "LIVE_FOLLOW",
    "RECORD_FPS",
    "Recording",
    "check_until",
    "frame_times",
    "record",
    "record_video",
]

import contextlib
import dataclasses
import io
import math
import os
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from app.media.browser import CameraPose, SnapshotError
from app.media.jobs import JobFailure, run_job
from app.media.pictures import FirstPicture, open_studio
from app.media.slides import SlideOptions

if TYPE_CHECKING:
    from playwright.sync_api import Browser

    from planners.bug.live import LiveTrace

FORMATS = (".mp4", ".gif")
"""File suffixes :func:`record` writes."""
MAX_FPS = 60
RECORD_FPS = 15.0
"""Frames a second of a recording (and of an exported page) unless told otherwise."""
LIVE_FOLLOW = (
    "--follow {follow}: this scenario's obstacles move, so it is recorded live (the DSB"
    " robot sensing as it drives); --follow is for scenarios without moving obstacles"
)
"""The one-line error for ``--follow`` on a scenario with moving obstacles."""
_MP4_QUALITY = 8  # imageio-ffmpeg's scale 0..10 (10: near lossless)


@dataclasses.dataclass(frozen=True)
class Recording:
    """What :func:`record_video` wrote."""

    path: Path
    fps: float
    times: tuple[float, ...]
    """Trajectory time [s] of each frame."""
    duration: float
    """Length of the recorded stretch of the trajectory [s]."""
    camera: CameraPose
    """The camera of every frame."""
    width: int
    height: int
    live: LiveTrace | None = None
    """The live run recorded (a scenario with moving obstacles), else None."""


def frame_times(duration: float, fps: float) -> tuple[float, ...]:
    """Trajectory times of the frames: ``k / fps`` for every k with ``k / fps <= duration``.

    So a recording has ``floor(duration * fps) + 1`` frames, the first at the start.

    Examples
    --------
    >>> frame_times(1.0, 4.0)
    (0.0, 0.25, 0.5, 0.75, 1.0)
    >>> len(frame_times(2.3, 10.0))
    24
    """
    n = math.floor(duration * fps + 1e-9) + 1
    return tuple(k / fps for k in range(n))


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
    drives among them (:func:`app.media.record_live.record_live_video`); ``follow`` must then
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
        from app.media.record_live import record_live_video  # noqa: PLC0415

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
        studio._wait_idle()
        duration = studio.duration
        if duration <= 0:
            raise SnapshotError(
                f"no trajectory to record: the planner followed ({follow or 'the default'})"
                " found no path in this scenario"
            )
        end = duration if until is None else min(duration, until)
        times = frame_times(end, fps)
        slide = studio.compose("top", options)
        with _writer(path, fps) as write:
            for t in times:
                write(_pixels(studio.frame(t)))
    return Recording(path, fps, times, end, slide.camera, width, height)


def _pixels(png: bytes) -> npt.NDArray[np.uint8]:
    from PIL import Image  # noqa: PLC0415 - pillow comes with the media extra

    with Image.open(io.BytesIO(png)) as image:
        return np.asarray(image.convert("RGB"))


@contextlib.contextmanager
def _writer(path: Path, fps: float) -> Iterator[Any]:
    """Yield ``write(frame)``; the file appears whole at ``path`` at the end, or not at all."""
    import imageio.v2 as iio  # noqa: PLC0415 - only a recording needs it

    partial = path.with_name(f".{path.stem}.{os.getpid()}.partial{path.suffix}")
    if path.suffix.lower() == ".mp4":
        writer = iio.get_writer(
            partial,
            format="FFMPEG",  # type: ignore[arg-type]
            mode="I",
            fps=fps,
            codec="libx264",
            quality=_MP4_QUALITY,
            pixelformat="yuv420p",
            macro_block_size=2,
            ffmpeg_log_level="error",
            # One encoder thread: the same input gives the same bytes on every run.
            output_params=["-threads", "1", "-movflags", "+faststart"],
        )
    else:
        writer = iio.get_writer(
            partial,
            format="GIF",  # type: ignore[arg-type]
            mode="I",
            duration=1000.0 / fps,
            loop=0,
        )
    try:
        yield writer.append_data
        writer.close()
        partial.replace(path)
    except BaseException:
        with contextlib.suppress(Exception):
            writer.close()
        partial.unlink(missing_ok=True)
        raise


def _check(
    out: Path, width: int, height: int, fps: float, until: float | None
) -> str | None:
    """Return the one-line problem with the arguments, or None."""
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
    problem = _check(path, width, height, fps, until)
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
