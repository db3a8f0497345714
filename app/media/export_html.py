"""``--export-html OUT.html``: the scene and the robot's run in one page that needs no Python.

viser can save what it sends to browsers (its scene serializer,
``ViserServer.get_scene_serializer()``) and its web client can play such a recording
back with no server; ``StateSerializer.as_html()`` puts the client (one HTML file of
about 0.8 MB with its JavaScript and CSS inlined) and the recording (base64 in an inline
script) into a single document. This module uses exactly that mechanism, so the page is
drawn by the same client as the app, with every layer the app draws:

1. start the app (no browser needed) and let the view draw for a picture
   (:meth:`app.ui.view.PlannerView.present`: no editing gizmos);
2. start recording: the serializer takes the current scene, then every message after;
3. put the robot at ``t_k = k / fps`` for every frame (:func:`app.media.video.frame_times`),
   waiting until each pose is drawn and sent, with a pause of ``1 / fps`` recorded
   between frames, so the page plays the run at the trajectory's real time (and loops);
4. write the page, with a small title and legend added as plain HTML.

A scenario whose obstacles move is recorded as its live run instead, frame ``k`` the run
at ``t_k`` as ``--record`` films it (:func:`_live_page`).

Nothing in the page is fetched from the network: the fonts, scripts and styles are in
the file (the test opens it from disk with the network cut off).

:func:`step_page` makes the other page: the pictures of an explanation's steps
(:mod:`app.media.explain_pictures`) in one file, to click or play through offline.
"""

from __future__ import annotations

__all__ = ["export_html", "export_page", "page_legend_html", "step_page"]

import base64
import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import planners
from app.media.jobs import (
    JobFailure,
    exit_code,
    fail,
    quiet_stdout,
    start_quietly,
    write_file,
)
from app.media.pictures import wait_drawn
from app.media.record import LIVE_FOLLOW, check_until
from app.media.slide_options import STEP_SECONDS
from app.media.slides import legend_rows
from app.media.video import MAX_FPS, RECORD_FPS, frame_times
from app.ui.text import html_text


def page_legend_html(
    planner_app: Any,
    title: str,
    plans: Mapping[str, Any] | None = None,
    layers: Mapping[str, bool] | None = None,
) -> str:
    """Return the title and legend block added to the page (plain HTML, inline styles).

    ``plans`` and ``layers``: what the page shows, when not the app's own (a live run).
    """
    controller = planner_app.controller
    frame = controller.frame
    rows = legend_rows(
        controller.plans if plans is None else plans,
        (frame.layers if frame else {}) if layers is None else layers,
        controller.registry,
        moving=bool(controller.scene.motions),
    )
    items = []
    for row in rows:
        swatches = "".join(
            f'<span style="display:inline-block;width:{_SWATCH_WIDTH.get(kind, "1.4em")};'
            f"height:{_SWATCH_HEIGHT[kind]};background:{_swatch_paint(color, kind)};"
            "margin-right:0.2em;"
            f"{'border-radius:50%;' if kind == 'disk' else ''}"
            f'{"opacity:0.45;" if kind == "fill" else ""}vertical-align:middle"></span>'
            for color, kind in row.swatches
        )
        items.append(
            f'<div style="white-space:nowrap">{swatches} {html_text(row.text)}</div>'
        )
    heading = (
        f'<div style="font-weight:bold;font-size:1.15em;margin-bottom:0.3em">{html_text(title)}</div>'
        if title
        else ""
    )
    return (
        '<div id="planner-legend" style="position:fixed;right:8px;top:8px;'
        "z-index:1000;background:rgba(255,255,255,0.92);border:1px solid #444;"
        "border-radius:6px;padding:6px 10px;font:13px/1.5 'DejaVu Sans',sans-serif;"
        f'color:#111;pointer-events:none">{heading}{"".join(items)}</div>'
    )


_SWATCH_WIDTH = {"disk": "0.9em", "dashed": "3em"}


def _swatch_paint(color: str, kind: str) -> str:
    """CSS background of a legend swatch: the colour, or dashes of it."""
    if kind != "dashed":
        return color
    return f"repeating-linear-gradient(90deg,{color} 0 0.3em,transparent 0.3em 0.6em)"


_SWATCH_HEIGHT = {
    "dashed": "0.16em",
    "line": "0.3em",
    "thin": "0.12em",
    "box": "0.9em",
    "fill": "0.9em",
    "disk": "0.9em",
}


def export_page(
    planner_app: Any,
    *,
    fps: float = RECORD_FPS,
    follow: str | None = None,
    until: float | None = None,
    title: str | None = None,
) -> str:
    """Record a running app's scene and robot run; return the self-contained page.

    A scene whose obstacles move is recorded as its live run (:func:`_live_page`);
    ``follow`` must then be None.

    Raises
    ------
    JobFailure
        ``follow`` given for a scene with moving obstacles (exit code 2).
    """
    controller = planner_app.controller
    if controller.scene.motions and follow is not None:
        raise JobFailure(LIVE_FOLLOW.format(follow=follow), 2)
    planner_app.view.present(labels=True)
    if controller.scene.motions:
        return _live_page(planner_app, fps, until, title)
    if follow is not None:
        controller.playback.set_follow(follow)
    planner_app.set_robot_time(0.0)
    wait_drawn(planner_app, 60.0)
    trajectory = controller.playback.trajectory
    duration = float(getattr(trajectory, "duration", 0.0)) if trajectory else 0.0
    end = duration if until is None else min(duration, until)
    serializer = planner_app.server.get_scene_serializer()
    for t in frame_times(end, fps) if duration > 0 else ():
        planner_app.set_robot_time(t)
        wait_drawn(planner_app, 60.0)
        serializer.insert_sleep(1.0 / fps)
    return _with_legend(serializer.as_html(), planner_app, title)


def _live_page(
    planner_app: Any, fps: float, until: float | None, title: str | None
) -> str:
    """Record the live run of a scene whose obstacles move, as ``--record`` films it.

    Frame ``k`` is :meth:`app.media.record_live.LiveFilm.frame` at ``t_k = k / fps``: every
    obstacle where it is then, the robot, its sensing and the path driven so far,
    drawn by the app's view; only what changed is recorded (one obstacle's chunk of
    the obstacle layers, the robot). The legend is the whole run's.
    """
    from app.media.record_live import (  # noqa: PLC0415 - the live run's modules, only here
        LiveFilm,
        draw_app_again,
        legend_plans,
        live_layers,
        live_trace,
        show_live,
    )

    controller = planner_app.controller
    planner_app.set_robot_time(0.0)  # the app's own robot stays still meanwhile
    wait_drawn(planner_app, 60.0)
    film = LiveFilm(controller.scene, live_trace(controller.scene, until))
    end = film.trace.duration if until is None else min(film.trace.duration, until)
    times = frame_times(end, fps)
    serializer = planner_app.server.get_scene_serializer()
    try:
        for t in times:
            show_live(planner_app, film.frame(t))  # drawn here: recorded in order
            serializer.insert_sleep(1.0 / fps)
        page = serializer.as_html()  # before the app's own drawing comes back
    finally:
        draw_app_again(planner_app)
    plans = legend_plans(film, film.frame(times[-1] if times else 0.0))
    layers = live_layers(controller.frame.layers)
    return _with_legend(page, planner_app, title, plans, layers)


def _with_legend(
    page: str,
    planner_app: Any,
    title: str | None,
    plans: Mapping[str, Any] | None = None,
    layers: Mapping[str, bool] | None = None,
) -> str:
    """Return ``page`` with the title and legend block (:func:`page_legend_html`) added."""
    name = planner_app.controller.scene.name or ""
    block = page_legend_html(
        planner_app, name if title is None else title, plans, layers
    )
    # The client's document has one </body>; the legend goes just before it.
    at = page.rindex("</body>")
    return page[:at] + block + page[at:]


def _check(
    path: Path, fps: float, follow: str | None, until: float | None
) -> str | None:
    """Return the one-line problem with the arguments, or None."""
    if path.suffix.lower() not in (".html", ".htm"):
        return f"{path}: the page must end in .html"
    if not (math.isfinite(fps) and 1 <= fps <= MAX_FPS):
        return f"fps must be from 1 to {MAX_FPS}, got {fps!r}"
    if follow is not None and follow not in planners.REGISTRY:
        return f"unknown planner {follow!r} to follow (known: {', '.join(planners.REGISTRY)})"
    return check_until(until)


def export_html(
    scenario: Any,
    out: str | os.PathLike[str],
    *,
    fps: float = RECORD_FPS,
    follow: str | None = None,
    until: float | None = None,
    title: str | None = None,
) -> int:
    """Write ``scenario``'s page to ``out``; return the exit code (0, 1 or 2, as :mod:`app.media.jobs`)."""
    path = Path(out)
    problem = _check(path, fps, follow, until)
    if problem is not None:
        return fail(problem, 2)

    def job() -> None:
        planner_app = start_quietly(scenario)
        try:
            page = export_page(
                planner_app, fps=fps, follow=follow, until=until, title=title
            )
        finally:
            with quiet_stdout():
                planner_app.stop()
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise JobFailure(
                f"cannot write {path}: {error.strerror or error}", 1
            ) from None
        write_file(path, page.encode("utf-8"))

    return exit_code(job)


def step_page(
    title: str, steps: Sequence[tuple[bytes, str]], *, seconds: float = STEP_SECONDS
) -> str:
    """Return one self-contained page that walks through ``steps`` (PNG, text).

    Each picture fills the window (its text is the picture's alternative text). The
    buttons, the arrow keys, Page Up / Down, Home and End (or a presenter's remote, which
    sends those) go from step to step; *Play* (or the space bar) shows the next step
    every ``seconds`` and stops at the last. The pictures are inside the file (PNG as
    data URLs): the page needs no server and no network. Every text is escaped.

    Examples
    --------
    >>> page = step_page("<b>SVG</b>", [(b"png", "Step 1: a < b")])
    >>> "&lt;b&gt;SVG&lt;/b&gt;" in page, "Step 1: a &lt; b" in page, "<b>" in page
    (True, True, False)
    """
    figures = "".join(
        f'<img class="step" alt="{html_text(text)}" title="{html_text(text)}" '
        f'src="data:image/png;base64,{base64.b64encode(png).decode("ascii")}"'
        f"{' hidden' if k else ''}>"
        for k, (png, text) in enumerate(steps)
    )
    fields = {
        "TITLE": html_text(title),
        "COUNT": str(len(steps)),
        "MS": json.dumps(round(seconds * 1000)),
        "FIGURES": figures,
    }
    # One pass: a field's text is never read again (a title "%MS%" stays as it is).
    return re.sub(r"%(TITLE|COUNT|MS|FIGURES)%", lambda m: fields[m[1]], _STEP_PAGE)


_STEP_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>%TITLE%</title>
<style>
html, body { margin: 0; height: 100%; background: #fff; color: #111;
  font: 16px/1.4 "DejaVu Sans", sans-serif; }
main { position: fixed; inset: 0 0 3em 0; display: flex; align-items: center;
  justify-content: center; }
img.step { max-width: 100%; max-height: 100%; object-fit: contain; }
img.step[hidden] { display: none; }
nav { position: fixed; left: 0; right: 0; bottom: 0; height: 3em; display: flex;
  align-items: center; gap: 0.5em; padding: 0 1em; border-top: 1px solid #ccc;
  background: #f6f6f6; }
nav button { font: inherit; min-width: 3em; }
nav input { flex: 1; }
#where { min-width: 7em; text-align: right; font-variant-numeric: tabular-nums; }
</style></head>
<body>
<main>%FIGURES%</main>
<nav aria-label="steps">
  <button id="first" title="first step (Home)">|&lt;</button>
  <button id="back" title="previous step (left arrow)">&lt;</button>
  <button id="play" title="play / pause (space)">Play</button>
  <button id="next" title="next step (right arrow)">&gt;</button>
  <button id="last" title="last step (End)">&gt;|</button>
  <input id="slider" type="range" min="1" max="%COUNT%" value="1" aria-label="step">
  <span id="where">1 / %COUNT%</span>
</nav>
<script>
(() => {
  const steps = [...document.querySelectorAll("img.step")];
  const slider = document.getElementById("slider");
  const where = document.getElementById("where");
  const play = document.getElementById("play");
  const every = %MS%;
  let at = 0, timer = null;
  const show = (k) => {
    at = Math.max(0, Math.min(steps.length - 1, k));
    steps.forEach((img, i) => { img.hidden = i !== at; });
    slider.value = at + 1;
    where.textContent = (at + 1) + " / " + steps.length;
    if (location.hash !== "#" + (at + 1)) history.replaceState(null, "", "#" + (at + 1));
  };
  const stop = () => { clearInterval(timer); timer = null; play.textContent = "Play"; };
  const start = () => {
    if (at === steps.length - 1) show(0);
    play.textContent = "Pause";
    timer = setInterval(() => { if (at < steps.length - 1) show(at + 1); else stop(); },
                        every);
  };
  const go = (k) => { stop(); show(k); };
  document.getElementById("first").onclick = () => go(0);
  document.getElementById("back").onclick = () => go(at - 1);
  document.getElementById("next").onclick = () => go(at + 1);
  document.getElementById("last").onclick = () => go(steps.length - 1);
  play.onclick = () => (timer ? stop() : start());
  slider.oninput = () => go(Number(slider.value) - 1);
  document.addEventListener("keydown", (e) => {
    if (e.target === slider) return;  // the slider's own keys move it (oninput)
    const keys = {ArrowRight: at + 1, PageDown: at + 1, ArrowLeft: at - 1,
                  PageUp: at - 1, Home: 0, End: steps.length - 1};
    if (e.key in keys) { go(keys[e.key]); e.preventDefault(); }
    else if (e.key === " ") { (timer ? stop() : start()); e.preventDefault(); }
  });
  show(Number(location.hash.slice(1)) - 1 || 0);
})();
</script>
</body></html>
"""
