"""Explain mode for slides: a step's picture, every step's with a page, or a video.

``python -m app --scenario 06 --snapshot OUT.png --explain svg --step 3`` draws step 3
(numbered from 1, as the panel shows "step 3 of N") as a slide picture
(:mod:`app.media.explain_slides`: the method and step as the title, the step's sentence
as the caption, a legend of the marks, the labels placed clear of each other, and for DSB
the O_i table and Fig. 9.15). ``--step all`` writes one picture per step, ``OUT/001.png``,
``OUT/002.png``, ..., ``OUT/steps.txt`` with each step's sentence, and ``OUT/index.html``,
one self-contained page that walks through them (:func:`app.media.export_html.step_page`).
``--record OUT.mp4 --explain svg`` writes every step into a video, each held for a few
seconds.

It is the slide pictures' Studio (:mod:`app.media.pictures`) with the Explain panel
switched on and its own 3-D caption and labels off (the picture draws its own); one
browser page serves every step, so a sequence of 30 pictures takes one page load.
"""

from __future__ import annotations

__all__ = [
    "STEP_SECONDS",
    "Asked",
    "explain_in_app",
    "explain_record",
    "explain_snapshots",
    "parse_step",
    "shoot_steps",
    "step_bounds",
]

import dataclasses
import math
import os
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app.media.browser import PlaywrightError, SnapshotError, first_line
from app.media.camera import picture_bounds
from app.media.jobs import (
    JobFailure,
    check_args,
    run_job,
    start_quietly,
    write_file,
)
from app.media.slide_options import STEP_SECONDS, SlideOptions
from planners.explain import METHODS

if TYPE_CHECKING:
    from playwright.sync_api import Browser

    from app.media.explain_slides import ExplainSlide
    from app.media.pictures import Studio
    from planners.explain import Explanation


def parse_step(text: str | int) -> int | None:
    """Return the step number (1-based) from ``--step``, or None for ``"all"``.

    Examples
    --------
    >>> parse_step("3"), parse_step("all")
    (3, None)
    """
    if isinstance(text, str) and text.strip().lower() == "all":
        return None
    try:
        n = int(text)
    except (TypeError, ValueError):
        raise ValueError(
            f"step must be a number from 1 or 'all', got {text!r}"
        ) from None
    if n < 1:
        raise ValueError(f"step must be a number from 1 or 'all', got {text!r}")
    return n


def explain_snapshots(
    scenario: Any,
    out: str | os.PathLike[str],
    *,
    method: str,
    step: str | int = 1,
    obstacle: int = 1,
    sensor_range: float | None = None,
    width: int = 1280,
    height: int = 800,
    view: str = "top",
    options: SlideOptions = SlideOptions(),  # noqa: B008 - frozen
    seconds: float = STEP_SECONDS,
    timeout: float = 120.0,
    chromium: str | None = None,
) -> int:
    """Write the picture of one step, or of every step and their page, of ``method``.

    ``out`` is the PNG of step ``step``, or with ``step="all"`` a folder: ``001.png``,
    ``002.png``, ..., ``steps.txt`` and ``index.html`` (its steps ``seconds`` apart when
    played). Returns the exit code: 0 written, 2 bad argument or scenario, 1 browser or
    app failed (one line on stderr, as :func:`app.media.jobs.snapshot`).
    """
    path = Path(out)
    problem = _check(method, sensor_range) or check_args(width, height, view, None)
    number: int | None = 1
    if problem is None:
        try:
            number = parse_step(step)
        except ValueError as error:
            problem = str(error)
    if problem is None and not (math.isfinite(seconds) and seconds > 0):
        problem = f"seconds per step must be > 0, got {seconds!r}"
    asked = Asked(
        method=method,
        obstacle=obstacle,
        sensor_range=sensor_range,
        size=(width, height),
        view=view,
        options=options,
        timeout=timeout,
    )

    def work(planner_app: Any, browser: Browser) -> None:
        pictures = list(_pictures(planner_app, browser, asked, number))
        if number is not None:
            write_file(path, pictures[0][1])
            return
        _write_steps(path, pictures, planner_app, seconds)

    # The file whose folder must be writable (created if missing) before it starts.
    target = path if number is not None else path / "index.html"
    return run_job(
        scenario, target, problem, work, chromium=chromium, start=_starter(scenario)
    )


def explain_record(
    scenario: Any,
    out: str | os.PathLike[str],
    *,
    method: str,
    obstacle: int = 1,
    sensor_range: float | None = None,
    width: int = 1280,
    height: int = 720,
    fps: float = 15.0,
    seconds: float = STEP_SECONDS,
    options: SlideOptions = SlideOptions(),  # noqa: B008 - frozen
    timeout: float = 120.0,
    chromium: str | None = None,
) -> int:
    """Write every step of ``method`` into a video, each step shown ``seconds`` long.

    Each step is one picture of :func:`explain_snapshots`, repeated for ``seconds`` at
    ``fps`` frames a second. Returns the exit code (0, 1 or 2, as
    :func:`explain_snapshots`).
    """
    from app.media.record import check_video  # noqa: PLC0415 - imports the Studio
    from app.media.video import pixels, writer  # noqa: PLC0415

    path = Path(out)
    problem = _check(method, sensor_range) or check_video(
        path, width, height, fps, None
    )
    if problem is None and not (math.isfinite(seconds) and seconds * fps >= 1):
        problem = f"seconds per step must hold a frame (>= 1 / fps), got {seconds!r}"
    asked = Asked(
        method=method,
        obstacle=obstacle,
        sensor_range=sensor_range,
        size=(width, height),
        view="top",
        options=options,
        timeout=timeout,
    )
    repeat = round(seconds * fps)

    def work(planner_app: Any, browser: Browser) -> None:
        with writer(path, fps) as write:
            for _, png in _pictures(planner_app, browser, asked, None):
                frame = pixels(png)
                for _ in range(repeat):
                    write(frame)

    return run_job(
        scenario, path, problem, work, chromium=chromium, start=_starter(scenario)
    )


@dataclasses.dataclass(frozen=True)
class Asked:
    """What the pictures of an explanation are to show (the command line's options)."""

    method: str
    """One of :data:`planners.explain.METHODS`."""
    obstacle: int
    """The obstacle whose expansion is explained (from 1)."""
    sensor_range: float | None
    """The scene's sensor range R [m] for the explanation; None: the scene's own."""
    size: tuple[int, int]
    """Picture size (width, height) [px]."""
    view: str = "top"
    options: SlideOptions = SlideOptions()  # noqa: RUF009 - frozen, so shared safely
    timeout: float = 120.0


def _check(method: str, sensor_range: float | None) -> str | None:
    """Return the one-line problem with the method or the sensor range, or None."""
    if method not in METHODS:
        return f"explain must be one of {', '.join(METHODS)}, got {method!r}"
    if sensor_range is not None and not (
        sensor_range > 0 and not math.isnan(sensor_range)
    ):
        return f"sensor range must be > 0 m, got {sensor_range!r}"
    return None


def _starter(scenario: Any) -> Callable[[], Any]:
    """Start the app quietly on ``scenario`` (a bad one is exit code 2)."""
    return lambda: start_quietly(scenario)


def explain_in_app(planner_app: Any, asked: Asked) -> Explanation:
    """Switch the app to Explain ``asked.method``; return the explanation once ready.

    The app draws no caption or labels of its own then: the pictures draw theirs.
    """
    if asked.sensor_range is not None:
        planner_app.controller.edits.set_sensor_range(float(asked.sensor_range))
    planner_app.set_robot_time(0.0)
    planner_app.wait_idle(asked.timeout)
    panel = planner_app.explain
    panel.draw_text(False)  # the picture draws the caption and labels itself
    panel.choose(asked.method, asked.obstacle)
    planner_app.wait_idle(asked.timeout)
    explainer = panel.explainer
    if not explainer.wait_ready(asked.timeout) or explainer.explanation is None:
        raise JobFailure(explainer.error or "the explanation was not ready in time", 1)
    return explainer.explanation


def _pictures(
    planner_app: Any, browser: Browser, asked: Asked, number: int | None
) -> Iterator[tuple[int, bytes]]:
    """Yield (step, PNG) of step ``number`` (from 1), or of every step with None."""
    from app.media.pictures import FirstPicture, open_studio  # noqa: PLC0415 - viser

    explanation = explain_in_app(planner_app, asked)
    count = len(explanation.steps)
    if number is not None and number > count:
        raise JobFailure(
            f"step {number} does not exist: {explanation.title} has {count} steps", 2
        )
    wanted = [number - 1] if number is not None else list(range(count))
    width, height = asked.size
    with open_studio(
        planner_app,
        browser,
        width=width,
        height=height,
        timeout=asked.timeout,
        first=FirstPicture(asked.view, asked.options),
    ) as studio:
        for n, png, _ in shoot_steps(studio, explanation, wanted, asked):
            yield n, png


def shoot_steps(
    studio: Studio, explanation: Explanation, numbers: Sequence[int], asked: Asked
) -> Iterator[tuple[int, bytes, ExplainSlide]]:
    """Yield (step, PNG, layout) of each of steps ``numbers`` (0-based), in one page.

    ``explanation`` is the one the studio's app shows (:func:`explain_in_app`). Every
    step is laid out with the same :class:`app.media.explain_slides.StepSet`, so the
    caption, legend and table keep their place from one picture to the next.
    """
    from app.media.explain_slides import (  # noqa: PLC0415 - the app's modules
        DRAW_EXPLAIN_JS,
        explain_layout,
        step_set,
    )
    from app.media.pictures import settle  # noqa: PLC0415

    shared = step_set(explanation, numbers, asked.options)
    planner_app = studio.app
    controller = planner_app.controller
    whole = picture_bounds(controller.scene)
    explainer = planner_app.explain.explainer
    for n in numbers:
        explainer.go(n)
        if not explainer.wait_ready(asked.timeout):
            raise SnapshotError("the explanation's step was not drawn in time")
        studio.wait_idle()
        picture = explain_layout(
            controller.scene,
            explanation,
            n,
            studio.width,
            studio.height,
            plans=controller.plans,
            layers=controller.frame.layers,
            bounds=step_bounds(explanation, n, whole),
            view=asked.view,
            options=asked.options,
            steps=shared,
            registry=controller.registry,
        )
        try:
            studio.compose(
                asked.view,
                asked.options,
                slide=picture.slide,
                extras=[(DRAW_EXPLAIN_JS, picture.overlay_spec())],
            )
            png = settle(studio.shown.page, time.monotonic() + asked.timeout)
        except PlaywrightError as error:
            raise SnapshotError(f"the browser failed: {first_line(error)}") from None
        yield n, png, picture


def _write_steps(
    folder: Path,
    pictures: Sequence[tuple[int, bytes]],
    planner_app: Any,
    seconds: float,
) -> None:
    """Write each step's picture, ``steps.txt`` and the page that walks through them."""
    from app.media.export_html import step_page  # noqa: PLC0415 - the app's modules

    explanation = planner_app.explain.explainer.explanation
    texts = [explanation.step(n).text for n, _ in pictures]
    for (n, png), _ in zip(pictures, texts, strict=True):
        write_file(folder / f"{n + 1:03d}.png", png)
    lines = [
        f"{n + 1:03d} {text}" for (n, _), text in zip(pictures, texts, strict=True)
    ]
    write_file(folder / "steps.txt", ("\n".join(lines) + "\n").encode())
    title = f"{planner_app.controller.scene.name or ''}: {explanation.title}".strip(
        ": "
    )
    page = step_page(
        title,
        [
            (png, f"{n + 1}/{len(explanation.steps)} {text}")
            for (n, png), text in zip(pictures, texts, strict=True)
        ],
        seconds=seconds,
    )
    write_file(folder / "index.html", page.encode("utf-8"))


def step_bounds(
    explanation: Any, n: int, whole: tuple[float, float, float, float]
) -> tuple[float, float, float, float]:
    """Return what the picture of step ``n`` frames [m].

    The whole scene, except for a DSB step with a finite sensor range: the robot's
    neighbourhood (2.5 R around r, at least 1.2 m), where the decision is taken and its
    O_i and labels would otherwise be a few pixels apart.

    Examples
    --------
    >>> from types import SimpleNamespace as NS
    >>> from planners.explain import Step, point_mark
    >>> step = Step("dsb:choose_O_i", "t", (point_mark("focus", [(5.0, 5.0)]),))
    >>> ex = NS(method="dsb", data=NS(sensor_range=0.6), step=lambda n: step)
    >>> step_bounds(ex, 0, (0.0, 0.0, 10.0, 8.0))
    (3.5, 3.5, 6.5, 6.5)
    """
    step = explanation.step(n)
    focus = step.mark("focus")
    data = getattr(explanation, "data", None)
    sensor_range = getattr(data, "sensor_range", math.inf)
    if explanation.method != "dsb" or focus is None or not math.isfinite(sensor_range):
        return whole
    x, y = (float(v) for v in focus.points[0])
    half = max(2.5 * float(sensor_range), 1.2)
    return (x - half, y - half, x + half, y + half)
