"""What a slide picture shows besides the scene (:class:`SlideOptions`).

A module of its own, with no import beyond the standard library, so that the command
line can name the options before it imports the app (``--snapshot`` launches the
browser first, :func:`app.media.jobs.run_with_browser`). :mod:`app.media.slides` re-exports it.
"""

from __future__ import annotations

__all__ = ["STEP_SECONDS", "SlideOptions"]

import dataclasses

STEP_SECONDS = 4.0
"""How long an Explain step stays on screen in a video or a page playing by itself [s]."""


@dataclasses.dataclass(frozen=True)
class SlideOptions:
    """What a slide picture shows besides the scene."""

    legend: bool = True
    """Draw the legend in the picture."""
    title: str | None = None
    """The title; None: the scenario's name; ``""``: no title."""
    labels: bool = True
    """Draw the labels (obstacle numbers, start and goal, events)."""
    time_stamp: bool = False
    """Keep a box at the top right for the trajectory time (``t = 3.2 s``), in the
    labels' font: a recording's frames (``--record``) write it."""
