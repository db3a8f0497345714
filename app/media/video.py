"""A video's frames and its file: the frames' times, the encoder, what was written.

Frame ``k`` of a recording (``--record``) or of an exported page (``--export-html``) is
taken at time ``t_k = k / fps`` (:func:`frame_times`), never read from a clock. The file
is written by ffmpeg through ``imageio-ffmpeg`` (a PyPI wheel that bundles the ffmpeg
binary) for MP4 (H.264, yuv420p, so it plays in every browser and in slide software), and
by Pillow through ``imageio`` for GIF (which stores frame times in hundredths of a second:
a frame rate that does not divide 100 is played slightly off) (:func:`writer`).
"""

from __future__ import annotations

__all__ = ["MAX_FPS", "RECORD_FPS", "Recording", "frame_times", "pixels", "writer"]

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

if TYPE_CHECKING:
    from app.media.camera import CameraPose
    from planners.bug.live import LiveTrace

MAX_FPS = 60
"""Most frames a second of a recording or a page."""
RECORD_FPS = 15.0
"""Frames a second of a recording (and of an exported page) unless told otherwise."""
_MP4_QUALITY = 8  # imageio-ffmpeg's scale 0..10 (10: near lossless)


@dataclasses.dataclass(frozen=True)
class Recording:
    """What :func:`app.media.record.record_video` wrote."""

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


def pixels(png: bytes) -> npt.NDArray[np.uint8]:
    """Return a PNG's pixels as an (H, W, 3) array of RGB, as :func:`writer` takes them."""
    from PIL import Image  # noqa: PLC0415 - pillow comes with the media extra

    with Image.open(io.BytesIO(png)) as image:
        return np.asarray(image.convert("RGB"))


@contextlib.contextmanager
def writer(path: Path, fps: float) -> Iterator[Any]:
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
