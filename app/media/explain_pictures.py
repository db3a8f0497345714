"""Pictures of Explain mode for slides: one step, or every step into a folder.

``python -m app --scenario 06 --snapshot OUT.png --explain svg --step 3`` draws step 3
(numbered from 1, as the panel shows "step 3 of N"); ``--step all`` writes one picture
per step, ``OUT/001.png``, ``OUT/002.png``, ... into the folder OUT, and a ``steps.txt``
beside them with each step's line of text. It is the slide pictures' browser
(:mod:`app.media.browser`), camera and settling with the Explain panel switched on; one browser page serves every
step, so a sequence of 30 pictures takes one page load.
"""

from __future__ import annotations

__all__ = ["explain_snapshots", "parse_step", "step_bounds"]

import contextlib
import math
import os
import time
from pathlib import Path
from typing import Any

from app.explain.panel import METHOD_TITLES
from app.media.browser import (
    HIDE_GUI_CSS,
    RECOMPILE_MATERIALS_JS,
    SnapshotError,
    apply_camera,
    check_chromium,
    chromium_path,
    launch_browser,
    open_page,
)
from app.media.camera import frame_camera, picture_bounds
from app.media.jobs import (
    JobFailure,
    Threaded,
    check_args,
    exit_code,
    quiet_stdout,
    start_quietly,
    write_file,
)
from app.media.pictures import settle
from planners.explain import METHODS


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
    timeout: float = 120.0,
    chromium: str | None = None,
) -> int:
    """Write the picture of one step, or of every step, of ``method`` on ``scenario``.

    Returns the exit code: 0 written, 2 bad argument or scenario, 1 browser or app failed
    (one line on stderr, as :func:`app.media.jobs.snapshot`).
    """
    return exit_code(
        lambda: _run(
            scenario,
            Path(out),
            method=method,
            step=step,
            obstacle=obstacle,
            sensor_range=sensor_range,
            width=width,
            height=height,
            view=view,
            timeout=timeout,
            chromium=chromium,
        ),
        "explain snapshot failed",
    )


def _check(method: str, step: str | int, sensor_range: float | None) -> int | None:
    if method not in METHODS:
        raise JobFailure(
            f"explain must be one of {', '.join(METHODS)}, got {method!r}", 2
        )
    if sensor_range is not None and not (
        sensor_range > 0 and not math.isnan(sensor_range)
    ):
        raise JobFailure(f"sensor range must be > 0 m, got {sensor_range!r}", 2)
    try:
        return parse_step(step)
    except ValueError as error:
        raise JobFailure(str(error), 2) from None


def _run(
    scenario: Any,
    out: Path,
    *,
    method: str,
    step: str | int,
    obstacle: int,
    sensor_range: float | None,
    width: int,
    height: int,
    view: str,
    timeout: float,
    chromium: str | None,
) -> None:
    number = _check(method, step, sensor_range)
    problem = check_args(width, height, view, None)
    if problem is not None:
        raise JobFailure(problem, 2)
    chromium = chromium or chromium_path()
    try:
        check_chromium(chromium)
    except SnapshotError as error:
        raise JobFailure(str(error), 1) from None
    folder = out if number is None else out.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise JobFailure(f"cannot write {out}: {error.strerror or error}", 1) from None
    planner_app = start_quietly(scenario)
    try:
        _prepare(planner_app, method, obstacle, sensor_range, timeout)

        def take() -> bytes:
            with launch_browser(chromium) as browser:
                _pictures(
                    planner_app,
                    browser,
                    out,
                    number=number,
                    width=width,
                    height=height,
                    view=view,
                    timeout=timeout,
                )
            return b""

        Threaded(take, "snapshot-browser").result()
    finally:
        with quiet_stdout(), contextlib.suppress(Exception):
            planner_app.stop()


def _prepare(
    planner_app: Any,
    method: str,
    obstacle: int,
    sensor_range: float | None,
    timeout: float,
) -> None:
    if sensor_range is not None:
        planner_app.controller.edits.set_sensor_range(float(sensor_range))
    planner_app.set_robot_time(0.0)
    planner_app.view.present()  # a picture: start and goal without editing gizmos
    planner_app.wait_idle(timeout)
    panel = planner_app.explain
    panel.choose(method, obstacle)
    assert method in METHOD_TITLES
    planner_app.wait_idle(timeout)
    if not panel.explainer.wait_ready(timeout) or panel.explainer.explanation is None:
        raise JobFailure(
            panel.explainer.error or "the explanation was not ready in time", 1
        )


def _pictures(
    planner_app: Any,
    browser: Any,
    out: Path,
    *,
    number: int | None,
    width: int,
    height: int,
    view: str,
    timeout: float,
) -> None:
    explainer = planner_app.explain.explainer
    explanation = explainer.explanation
    count = len(explanation.steps)
    if number is not None and number > count:
        raise JobFailure(
            f"step {number} does not exist: {explanation.title} has {count} steps", 2
        )
    wanted = [number - 1] if number is not None else list(range(count))
    deadline = time.monotonic() + timeout * max(1, len(wanted))
    whole = picture_bounds(planner_app.controller.scene)
    with open_page(
        planner_app, browser, width=width, height=height, timeout=timeout
    ) as shown:
        shown.page.add_style_tag(content=HIDE_GUI_CSS)
        shown.page.evaluate("() => document.fonts.ready.then(() => true)")
        lines = []
        for n in wanted:
            bounds = step_bounds(explanation, n, whole)
            planner_app.explain.caption_bounds = bounds
            pose = frame_camera(bounds, width, height, view)
            apply_camera(shown.client, pose, deadline)
            explainer.go(n)
            explainer.wait_ready(timeout)
            planner_app.wait_idle(timeout)
            shown.page.evaluate(RECOMPILE_MATERIALS_JS)
            png = settle(shown.page, deadline)
            target = out if number is not None else out / f"{n + 1:03d}.png"
            write_file(target, png)
            lines.append(f"{n + 1:03d} {explanation.steps[n].text}")
        if number is None:
            write_file(out / "steps.txt", ("\n".join(lines) + "\n").encode())


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
