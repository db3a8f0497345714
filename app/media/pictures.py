"""Slide pictures, batches of them and video frames, with one server, one browser, one page.

:class:`Studio` starts the app once, opens it once in headless Chromium and then takes as
many pictures as asked: another scenario is loaded into the same app (the browser gets the
changed nodes only), another view is another camera. What costs seconds (starting the
server, launching Chromium, loading viser's client and compiling its shaders) is paid once
per batch, not once per picture.

Each picture is laid out by :func:`app.media.slides.layout` for its size (camera, title, legend,
labels placed so none overlaps another or a marker) and drawn by the app's own view in
"presentation" mode (:meth:`app.ui.view.PlannerView.present`: no editing gizmos, screen-pixel
lines scaled to the picture, the view's own 3-D labels replaced by the slide's).

Frames of a recording (:meth:`Studio.frame`) are taken at trajectory times given
explicitly, never from the wall clock: the robot is put at ``t`` and the frame is taken
once the browser shows it there (:data:`_ROBOT_AT_JS`), so two recordings are the same.
"""

from __future__ import annotations

__all__ = [
    "FirstPicture",
    "Studio",
    "open_studio",
    "settle",
    "shoot",
    "time_stamp",
    "wait_drawn",
]

import contextlib
import dataclasses
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from app.media.browser import (
    RECOMPILE_MATERIALS_JS,
    SLIDE_CSS,
    AppPage,
    PlaywrightError,
    SnapshotError,
    apply_camera,
    attach_page,
    first_line,
    loading_size,
    open_page,
)
from app.media.slides import DRAW_OVERLAY_JS, Slide, SlideOptions, layout

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Page

# True when the browser's robot frame and wheels are where the server put them.
_ROBOT_AT_JS = """(want) => {
    const m = window.__viserMutable;
    if (!m || !m.nodeRefFromName) return false;
    const close = (a, b) => Math.abs(a - b) < 1e-4;
    for (const [name, p, q] of want) {
        const o = m.nodeRefFromName[name];
        if (!o) return false;
        if (p && !(close(o.position.x, p[0]) && close(o.position.y, p[1]) &&
                   close(o.position.z, p[2]))) return false;
        if (q && !(close(Math.abs(o.quaternion.w * q[0] + o.quaternion.x * q[1] +
                   o.quaternion.y * q[2] + o.quaternion.z * q[3]), 1))) return false;
    }
    return true;
}"""

_STAMP_JS = """(text) => {
    const el = document.getElementById('planner-stamp');
    if (el) el.textContent = text;
    return !!el;
}"""


def time_stamp(t: float) -> str:
    """Return the time stamp of a frame at trajectory time ``t`` [s].

    Examples
    --------
    >>> time_stamp(3.249), time_stamp(0.0)
    ('t = 3.2 s', 't = 0.0 s')
    """
    return f"t = {t:.1f} s"


_TWO_FRAMES_JS = """() => new Promise(done => requestAnimationFrame(
    () => requestAnimationFrame(() => done(true))))"""


@dataclasses.dataclass
class Studio:
    """One running app shown in one browser page of a fixed size."""

    app: Any
    """What :func:`app.start_app` returned."""
    shown: AppPage
    width: int
    height: int
    timeout: float = 60.0
    slide: Slide | None = None
    """The layout of the last picture taken."""
    presented: float | None = None
    """The line scale the view is presented with (None: not yet, or a new scenario)."""

    # ------------------------------------------------------------------ scene

    def load(self, scenario: str | Path) -> None:
        """Show another scenario (a shipped name or a scenario file) in the same app."""
        from app.server import resolve_scenario  # noqa: PLC0415

        key, path = resolve_scenario(str(scenario))
        files = self.app.controller.files
        if key and key in files.scenarios:
            files.load_scenario(key)
        else:
            files.load_text(Path(path).read_bytes(), Path(path).name)
        self.presented = None  # the new scenario's layers and labels are drawn anew
        self.wait_idle()

    def follow(self, planner: str) -> None:
        """Let the robot follow ``planner``'s path."""
        self.app.controller.playback.set_follow(planner)
        self.wait_idle()

    @property
    def duration(self) -> float:
        """Duration [s] of the robot's trajectory (0 when there is none)."""
        trajectory = self.app.controller.playback.trajectory
        return float(getattr(trajectory, "duration", 0.0)) if trajectory else 0.0

    # ------------------------------------------------------------------ pictures

    def compose(
        self,
        view: str = "top",
        options: SlideOptions = SlideOptions(),  # noqa: B008
        slide: Slide | None = None,
        extras: Sequence[tuple[str, Any]] = (),
    ) -> Slide:
        """Lay out the picture of what the app shows now and draw its overlay.

        ``slide``: a layout made elsewhere (a recording of moving obstacles,
        :mod:`app.media.record_live`; an Explain step, :mod:`app.media.explain_slides`)
        to use instead. ``extras``: (script, argument) pairs evaluated in the page after
        the overlay is drawn (an Explain step's caption, table and flowchart).
        """
        if slide is None:
            slide = _layout(self.app, self.width, self.height, view, options)
        deadline = time.monotonic() + self.timeout
        # Camera, line widths and overlay first, the page's full size last: the software
        # renderer draws the intermediate frames at the small loading size. What
        # :func:`_stage` put in place before the page opened is not sent again.
        apply_camera(self.shown.client, slide.camera, deadline)
        if self.presented != slide.line_scale:
            self.app.view.present(line_scale=slide.line_scale, labels=False)
            self.presented = slide.line_scale
        self.wait_idle()
        page = self.shown.page
        page.evaluate(DRAW_OVERLAY_JS, slide.overlay_spec())
        for script, argument in extras:
            page.evaluate(script, argument)
        page.evaluate(RECOMPILE_MATERIALS_JS)
        size = page.viewport_size
        if size is None or (size["width"], size["height"]) != (self.width, self.height):
            page.set_viewport_size({"width": self.width, "height": self.height})
        self.slide = slide
        return slide

    def picture(
        self,
        view: str = "top",
        options: SlideOptions = SlideOptions(),  # noqa: B008
        robot_time: float | None = None,
    ) -> bytes:
        """Return a settled PNG of the current scenario, laid out for slides.

        ``robot_time``: where the robot is drawn along its trajectory; None, at the
        start. In a scenario whose obstacles move, a ``robot_time`` draws the live run
        at that time instead, obstacles and robot alike, as a recording's frame
        (:func:`app.media.record_live.live_picture`); None draws what the app shows: every
        planner's answer for the scene at t = 0.
        """
        if robot_time is not None and self.app.controller.scene.motions:
            from app.media.record_live import live_picture  # noqa: PLC0415 - imports this

            return live_picture(self, float(robot_time), view, options)
        self.app.set_robot_time(0.0 if robot_time is None else float(robot_time))
        self.wait_idle()
        self.compose(view, options)
        return settle(self.shown.page, time.monotonic() + self.timeout)

    def frame(self, t: float, image_format: str = "png") -> bytes:
        """One frame of a recording: the robot at trajectory time ``t`` [s].

        :meth:`compose` must have been called for the layout. The frame is taken once
        the browser shows the robot's frame and wheels where the server put them, and
        after two more animation frames, so it does not depend on timing.
        """
        self.app.set_robot_time(float(t))
        self.wait_idle()
        return self.shot(t, image_format=image_format)

    def shot(
        self,
        t: float,
        extra: Sequence[tuple[str, Sequence[float]]] = (),
        image_format: str = "png",
    ) -> bytes:
        """Take the frame at time ``t`` once the browser shows what the server drew.

        That is: the robot's frame and wheels where the server put them, and each
        ``extra`` node (name, position) at its position (a node set last, after a
        frame's other changes: viser's messages arrive in order), then two more
        animation frames. The time stamp, when the layout has one, says ``t``.
        """
        view = self.app.view
        want = [
            ["/robot", list(view.robot.position), list(view.robot.wxyz)],
            *(
                [spin.name, None, list(np.asarray(spin.wxyz, dtype=float))]
                for spin, _ in view.wheel_spins
            ),
            *([name, [float(v) for v in at], None] for name, at in extra),
        ]
        page = self.shown.page
        if self.slide is not None and self.slide.stamp is not None:
            page.evaluate(_STAMP_JS, time_stamp(t))
        page.wait_for_function(
            _ROBOT_AT_JS, arg=want, polling=20, timeout=self.timeout * 1e3
        )
        page.evaluate(_TWO_FRAMES_JS)
        return page.screenshot(type=image_format, animations="disabled", caret="hide")  # type: ignore[arg-type]

    def wait_idle(self) -> None:
        """Wait until the app has planned and drawn everything (:func:`wait_drawn`)."""
        wait_drawn(self.app, self.timeout)


def wait_drawn(planner_app: Any, timeout: float) -> None:
    """Wait until the app has planned and drawn everything; SnapshotError after ``timeout`` s."""
    if planner_app.wait_idle(timeout) is False:
        raise SnapshotError("the app did not finish planning and drawing in time")


def _layout(
    planner_app: Any, width: int, height: int, view: str, options: SlideOptions
) -> Slide:
    """Lay out (:func:`app.media.slides.layout`) a picture of what the app shows now."""
    controller = planner_app.controller
    frame = controller.frame
    layers = frame.layers if frame is not None else {}
    return layout(
        controller.scene,
        controller.plans,
        layers,
        width,
        height,
        view=view,
        options=options,
        registry=controller.registry,
    )


@dataclasses.dataclass(frozen=True)
class FirstPicture:
    """What the first picture of :func:`open_studio` shows.

    It is put in place before the page opens (:func:`_stage`).
    """

    view: str = "top"
    options: SlideOptions = SlideOptions()  # noqa: RUF009 - frozen, so shared safely
    robot_time: float = 0.0


def _stage(
    planner_app: Any, width: int, height: int, first: FirstPicture, timeout: float
) -> float:
    """Put the first picture's robot, camera and looks in place; return its line scale.

    Done before the browser opens the app, so that viser's client loads the final scene
    once: its first camera is the picture's (``server.initial_camera``, which new
    clients start from), the editing gizmos and the view's own 3-D labels are never
    drawn, and nothing is re-sent once it is loaded. The picture is the same as when
    all of this is changed after the page has loaded, only sooner.
    """
    planner_app.set_robot_time(first.robot_time)
    wait_drawn(planner_app, timeout)
    slide = _layout(planner_app, width, height, first.view, first.options)
    camera = planner_app.server.initial_camera
    camera.up = slide.camera.up
    camera.fov = slide.camera.fov
    camera.near = slide.camera.near
    camera.far = slide.camera.far
    camera.position = slide.camera.position
    camera.look_at = slide.camera.look_at
    planner_app.view.present(line_scale=slide.line_scale, labels=False)
    wait_drawn(planner_app, timeout)
    return slide.line_scale


@contextlib.contextmanager
def open_studio(
    planner_app: Any,
    browser: Browser,
    *,
    width: int,
    height: int,
    timeout: float = 60.0,
    first: FirstPicture = FirstPicture(),
    page: Page | None = None,
) -> Iterator[Studio]:
    """Open a running app in ``browser`` for pictures of ``width`` x ``height``.

    ``first`` says what the first picture will show; it is put in place before the page
    opens (:func:`_stage`), which makes that picture quicker. Any other picture is
    right too, only slower. ``page``: a page :func:`app.media.browser.open_early` opened on
    the app's port while it started (it is closed on exit, as a page opened here is).
    """
    presented = _stage(planner_app, width, height, first, timeout)
    with _studio_page(planner_app, browser, (width, height), timeout, page) as shown:
        try:
            shown.page.evaluate("() => document.fonts.ready.then(() => true)")
        except PlaywrightError as error:
            raise SnapshotError(f"the browser failed: {first_line(error)}") from None
        yield Studio(planner_app, shown, width, height, timeout, presented=presented)


@contextlib.contextmanager
def _studio_page(
    planner_app: Any,
    browser: Browser,
    size: tuple[int, int],
    timeout: float,
    page: Page | None,
) -> Iterator[AppPage]:
    """Yield the app's page at the loading size: ``page`` once loaded, or a new one."""
    if page is None:
        small_w, small_h = loading_size(*size)
        with open_page(
            planner_app,
            browser,
            width=small_w,
            height=small_h,
            timeout=timeout,
            css=SLIDE_CSS,
        ) as shown:
            yield shown
        return
    try:
        yield attach_page(planner_app, page, timeout)
    finally:
        with contextlib.suppress(Exception):
            page.context.close()


def settle(page: Page, deadline: float) -> bytes:
    """Wait until the picture stops changing; return it as a PNG.

    After two animation frames, cheap JPEG screenshots are taken until two in a row are
    byte for byte the same (any changed pixel changes a JPEG's bytes); only then is the
    PNG taken. A PNG of 1920 x 1080 costs about 0.4 s in the software renderer, a JPEG a
    fifth of that.
    """
    page.evaluate(_TWO_FRAMES_JS)
    previous = _jpeg(page)
    while True:
        current = _jpeg(page)
        if current == previous:
            return page.screenshot(type="png", animations="disabled", caret="hide")
        if time.monotonic() > deadline:
            raise SnapshotError("the picture kept changing; it did not settle in time")
        previous = current
        page.evaluate(_TWO_FRAMES_JS)


def _jpeg(page: Page) -> bytes:
    return page.screenshot(type="jpeg", quality=90, animations="disabled", caret="hide")


def shoot(
    planner_app: Any,
    browser: Browser,
    *,
    width: int,
    height: int,
    view: str = "top",
    robot_time: float | None = None,
    options: SlideOptions = SlideOptions(),  # noqa: B008
    timeout: float = 60.0,
    page: Page | None = None,
) -> bytes:
    """One slide picture (PNG bytes) of a running app: what ``--snapshot`` writes.

    ``page``: see :func:`open_studio`.
    """
    first = FirstPicture(view, options, 0.0 if robot_time is None else robot_time)
    with open_studio(
        planner_app,
        browser,
        width=width,
        height=height,
        timeout=timeout,
        first=first,
        page=page,
    ) as shot:
        try:
            return shot.picture(view, options, robot_time)
        except PlaywrightError as error:
            raise SnapshotError(f"the browser failed: {first_line(error)}") from None
