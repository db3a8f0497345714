"""Command-line jobs that need the app and a browser: one-line errors and exit codes.

``--snapshot`` (:func:`snapshot`) and ``--snapshot-dir`` (:func:`snapshot_dir`) take slide
pictures (:mod:`app.media.pictures`); ``--snapshot-dir``, ``--record`` and
``--export-html`` run through :func:`run_job`, which checks the browser and the output
folder before anything slow starts, starts the app while Chromium launches
(:func:`run_with_browser`), and turns every failure into one line on stderr and an exit
code: 2 for a bad scenario or argument, 1 when the browser, the app or the file system
fails, 130 when interrupted. It never prints a traceback.

This module stays light (no viser, no planners at import): ``--snapshot`` imports it,
launches Chromium, and imports the app while the browser starts.
"""

from __future__ import annotations

__all__ = [
    "JobFailure",
    "Threaded",
    "batch",
    "check_args",
    "exit_code",
    "fail",
    "quiet_stdout",
    "run_job",
    "run_with_browser",
    "snapshot",
    "snapshot_dir",
    "start_quietly",
    "write_file",
]

import contextlib
import io
import math
import os
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, TypeVar, cast

from app.media.browser import (
    SLIDE_CSS,
    SnapshotError,
    check_chromium,
    chromium_path,
    first_line,
    free_port,
    launch_browser,
    loading_size,
    open_early,
)
from app.media.camera import VIEWS
from app.media.slide_options import SlideOptions

if TYPE_CHECKING:
    from playwright.sync_api import Browser, Page

    from planners.scene import Scene


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Swallow what is printed meanwhile: viser's banner on start and its line on stop."""
    with contextlib.redirect_stdout(io.StringIO()):
        yield


T = TypeVar("T")


class Threaded(Generic[T]):
    """``fn()`` run in a new thread of its own; :meth:`result` returns or raises its outcome.

    playwright's sync API refuses to start in a thread that runs an asyncio loop (a
    notebook) or that already drives another playwright (a test session's shared
    browser); a thread of its own always works.
    """

    def __init__(self, fn: Callable[[], T], name: str) -> None:
        self._fn = fn
        self._value: T | None = None
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            self._value = self._fn()
        except BaseException as error:  # handed to the caller by result()
            self._error = error

    def join(self) -> None:
        """Wait until ``fn`` has returned or raised."""
        self._thread.join()

    def result(self) -> T:
        """Wait for ``fn``; return its value, or raise what it raised."""
        self.join()
        if self._error is not None:
            raise self._error
        return cast("T", self._value)


def run_with_browser(
    start: Callable[[], Any],
    work: Callable[[Any, Browser], T],
    *,
    chromium: str | None = None,
    prepare: Callable[[Browser, threading.Event], None] | None = None,
) -> T:
    """Start the app with ``start()`` while Chromium launches; return ``work(app, browser)``.

    The browser is launched (and used) in a thread of its own, as playwright's sync API
    needs; the app starts in the calling thread at the same time, so the two slow starts
    overlap. Both are stopped on return, also on errors, which are raised here.

    Call it before importing the app (``start`` may import it): the browser then
    launches while Python imports viser and the planners, too. ``prepare(browser,
    started)``, if given, runs in the browser's thread as soon as the browser is up,
    while the app still starts (``started`` is set once ``start()`` returned or
    failed): :func:`app.media.browser.open_early`.
    """
    ready = threading.Event()
    box: dict[str, Any] = {}

    def browse() -> T:
        with launch_browser(chromium) as browser:
            if prepare is not None:
                prepare(browser, ready)
            ready.wait()
            if "app" not in box:
                raise _Cancelled
            return work(box["app"], browser)

    browsing = Threaded(browse, "pictures-browser")
    planner_app = None
    try:
        planner_app = start()
        box["app"] = planner_app
    finally:
        ready.set()
        browsing.join()
        if planner_app is not None:
            with quiet_stdout(), contextlib.suppress(Exception):
                planner_app.stop()
    return browsing.result()


class _Cancelled(Exception):
    """The app did not start: the browser thread stops without working.

    Never raised to the caller: ``start()``'s own error is.
    """


def fail(message: str, code: int) -> int:
    """Print ``message`` as one line on stderr; return the exit ``code``."""
    print(f"error: {message}", file=sys.stderr)
    return code


def check_args(
    width: int, height: int, view: str, robot_time: float | None
) -> str | None:
    """Return the one-line problem with a picture's size, view and time, or None."""
    for name, value in (("width", width), ("height", height)):
        if (
            isinstance(value, bool)
            or not isinstance(value, int)
            or not 16 <= value <= 8192
        ):
            return f"{name} must be a whole number of pixels from 16 to 8192, got {value!r}"
    if view not in VIEWS:
        return f"view must be one of {', '.join(VIEWS)}, got {view!r}"
    if robot_time is not None and not (math.isfinite(robot_time) and robot_time >= 0):
        return f"robot_time must be a finite time >= 0 s, got {robot_time!r}"
    return None


def run_job(
    scenario: Any,
    path: Path,
    problem: str | None,
    work: Callable[[Any, Any], Any],
    *,
    chromium: str | None,
    start: Callable[[], Any] | None = None,
) -> int:
    """Run ``work(app, browser)`` as a command-line job: one-line errors, an exit code."""
    if problem is not None:
        return fail(problem, 2)

    def job() -> None:
        _prepare(path, chromium)
        run_with_browser(
            start or (lambda: start_quietly(scenario)), work, chromium=chromium
        )

    return exit_code(job)


def exit_code(job: Callable[[], object], failed: str = "failed") -> int:
    """Run ``job()``; return the exit code, with every failure as one line on stderr.

    0 when it returns; a :class:`JobFailure`'s own code; 1 when the browser fails
    (:class:`app.media.browser.SnapshotError`) or anything else is raised (``failed``
    starts its line); 130 when interrupted. Never a traceback.
    """
    try:
        job()
    except JobFailure as failure:
        return fail(failure.message, failure.code)
    except SnapshotError as error:
        return fail(str(error), 1)
    except KeyboardInterrupt:
        return fail("interrupted", 130)
    except Exception as error:  # a command-line tool: no traceback
        return fail(f"{failed}: {type(error).__name__}: {first_line(error)}", 1)
    return 0


def write_file(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` whole or not at all; JobFailure (code 1) if it cannot."""
    try:
        partial = path.with_name(f".{path.name}.{os.getpid()}.partial")
        partial.write_bytes(data)
        partial.replace(path)
    except OSError as error:
        raise JobFailure(f"cannot write {path}: {error.strerror or error}", 1) from None


class JobFailure(Exception):
    """Why a job stopped: the one line to print and the exit code."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.message = message
        self.code = code


def _prepare(path: Path, chromium: str | None) -> None:
    """Check the browser and the output folder before anything slow starts."""
    try:
        check_chromium(chromium or chromium_path())
    except SnapshotError as error:
        raise JobFailure(str(error), 1) from None
    try:
        folder = path if path.suffix == "" else path.parent
        folder.mkdir(parents=True, exist_ok=True)
        if not os.access(folder, os.W_OK):
            raise PermissionError(13, "folder not writable")
    except OSError as error:
        raise JobFailure(f"cannot write {path}: {error.strerror or error}", 1) from None


def start_quietly(scenario: Any) -> Any:
    """Start the app on ``scenario`` without printing; a bad scenario is exit code 2."""
    from app import start_app  # noqa: PLC0415

    try:
        with quiet_stdout():
            return start_app(
                scenario,
                host="127.0.0.1",
                port=0,
                print_url=False,
                worker_process=False,
            )
    except (ValueError, LookupError, FileNotFoundError) as error:
        raise JobFailure(
            f"cannot load scenario: {first_line(error)}",
            2,
        ) from None


def snapshot(
    scenario: str | os.PathLike[str] | Scene | None,
    out: str | os.PathLike[str],
    *,
    width: int = 1280,
    height: int = 800,
    view: str = "top",
    robot_time: float | None = None,
    timeout: float = 60.0,
    chromium: str | None = None,
    options: SlideOptions | None = None,
) -> int:
    """Render ``scenario`` with every planner in headless Chromium and write a PNG.

    Starts the app quietly on a free loopback port, takes one settled picture (see
    :mod:`app.media.browser`) and stops the browser and the server, also on errors. Errors are
    one line on stderr, never a traceback.

    Parameters
    ----------
    scenario
        A shipped scenario's name, a scenario file, or a Scene (what ``app.start_app``
        takes).
    out
        Where to write the PNG; missing parent folders are created.
    width, height
        Picture size [px].
    view
        ``"top"`` (a plan, for slides and snapshot tests) or ``"perspective"``.
    robot_time
        Trajectory time [s] at which to draw the robot; None draws it at the start.
    timeout
        Longest time [s] to wait for the browser and a settled picture.
    chromium
        Path to the browser; None for :func:`chromium_path`.
    options
        Legend, title and labels of the slide picture (:mod:`app.media.slides`); None: all
        of them.

    Returns
    -------
    int
        Exit code: 0 when the PNG is written, 2 for a bad scenario or argument, 1 when
        the browser or the app fails.
    """
    return exit_code(
        lambda: _take_snapshot(
            scenario,
            Path(out),
            width=width,
            height=height,
            view=view,
            robot_time=robot_time,
            timeout=timeout,
            chromium=chromium,
            options=options,
        ),
        "snapshot failed",
    )


def _take_snapshot(
    scenario: Any,
    path: Path,
    *,
    width: int,
    height: int,
    view: str,
    robot_time: float | None,
    timeout: float,
    chromium: str | None,
    options: SlideOptions | None = None,
) -> None:
    """Do what :func:`snapshot` says; raise :class:`JobFailure` with the exit code."""
    problem = check_args(width, height, view, robot_time)
    if problem is not None:
        raise JobFailure(problem, 2)
    chromium = chromium or chromium_path()
    try:
        check_chromium(chromium)
    except SnapshotError as error:
        raise JobFailure(str(error), 1) from None
    try:  # before the slow part: a picture that cannot be written is not worth taking
        path.parent.mkdir(parents=True, exist_ok=True)
        if not os.access(path.parent, os.W_OK):
            raise PermissionError(13, "folder not writable")
    except OSError as error:
        raise JobFailure(f"cannot write {path}: {error.strerror or error}", 1) from None
    # The app (viser, the planners) is imported in start(), while Chromium launches:
    # this module stays light so that the browser starts first.

    port = free_port()  # known before the app starts, so the page can go there first
    early: dict[str, Page] = {}

    def prepare(browser: Browser, started: threading.Event) -> None:
        small_w, small_h = loading_size(width, height)
        early["page"] = open_early(
            browser,
            port,
            started,
            width=small_w,
            height=small_h,
            css=SLIDE_CSS,
            timeout=timeout,
        )

    def start() -> Any:
        import app  # noqa: PLC0415

        try:
            with quiet_stdout():
                return app.start_app(
                    scenario,
                    host="127.0.0.1",
                    port=port,
                    print_url=False,
                    worker_process=False,
                )
        except (ValueError, LookupError, FileNotFoundError) as error:
            # planners.ScenarioError is a ValueError; an unknown name a LookupError.
            raise JobFailure(f"cannot load scenario: {first_line(error)}", 2) from None

    def take(planner_app: Any, browser: Browser) -> bytes:
        # The slide picture (app.media.pictures): sized labels, legend and title.
        from app.media import pictures  # noqa: PLC0415

        return pictures.shoot(
            planner_app,
            browser,
            width=width,
            height=height,
            view=view,
            robot_time=robot_time,
            options=options or SlideOptions(),
            timeout=timeout,
            page=early.get("page"),
        )

    write_file(path, run_with_browser(start, take, chromium=chromium, prepare=prepare))


def batch(
    planner_app: Any,
    browser: Browser,
    jobs: Sequence[tuple[str, str, Path]],
    *,
    width: int,
    height: int,
    options: SlideOptions = SlideOptions(),  # noqa: B008
    timeout: float = 60.0,
) -> list[Path]:
    """Write one picture per ``(scenario, view, path)`` with one page; return the paths.

    The app must show ``jobs[0]``'s scenario already; each other scenario is loaded into
    it when its turn comes (in order, so consecutive views of one scenario share it).
    """
    from app.media.pictures import FirstPicture, open_studio  # noqa: PLC0415 - viser

    written: list[Path] = []
    first = FirstPicture(jobs[0][1] if jobs else "top", options)
    with open_studio(
        planner_app, browser, width=width, height=height, timeout=timeout, first=first
    ) as shot:
        current = jobs[0][0] if jobs else None
        for scenario, view, path in jobs:
            if scenario != current:
                shot.load(scenario)
                current = scenario
            write_file(path, shot.picture(view, options))
            written.append(path)
    return written


def snapshot_dir(
    scenarios: Sequence[str],
    folder: str | os.PathLike[str],
    *,
    views: Sequence[str] = ("top",),
    width: int = 1280,
    height: int = 800,
    options: SlideOptions = SlideOptions(),  # noqa: B008
    timeout: float = 60.0,
    chromium: str | None = None,
) -> int:
    """``--snapshot-dir``: a slide picture of every scenario (and view) into ``folder``.

    Files are named ``NAME.png`` (``NAME-VIEW.png`` with several views), NAME the
    scenario's key (``02_three_obstacles``) or file stem. One server, one browser and one
    page serve the whole batch. Returns the exit code (0: every file written).
    """
    from app.server import resolve_scenario  # noqa: PLC0415
    from planners.scene import ScenarioError  # noqa: PLC0415

    out = Path(folder)
    problem = check_args(width, height, views[0] if views else "", None)
    bad = [v for v in views if v not in VIEWS]
    if bad or not views:
        problem = f"views must be among {', '.join(VIEWS)}, got {', '.join(views)!r}"
    jobs: list[tuple[str, str, Path]] = []
    for name in scenarios:
        try:
            key, path = resolve_scenario(name)
        except ScenarioError as error:
            problem = problem or f"cannot load scenario: {error}"
            continue
        stem = key or Path(path).stem
        for view in views:
            suffix = f"-{view}" if len(views) > 1 else ""
            jobs.append((str(path), view, out / f"{stem}{suffix}.png"))
    if not jobs and problem is None:
        problem = "no scenario to draw"

    def work(planner_app: Any, browser: Browser) -> list[Path]:
        return batch(
            planner_app,
            browser,
            jobs,
            width=width,
            height=height,
            options=options,
            timeout=timeout,
        )

    first = jobs[0][0] if jobs else None
    return run_job(first, out, problem, work, chromium=chromium)
