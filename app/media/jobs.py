"""Command-line jobs that need the app and a browser: one-line errors and exit codes.

``--snapshot-dir``, ``--record`` and ``--export-html`` run through :func:`run_job`, which
checks the browser and the output folder before anything slow starts, starts the app
while Chromium launches (:func:`app.media.pictures.run_with_browser`), and turns every failure
into one line on stderr and an exit code: 2 for a bad scenario or argument, 1 when the
browser, the app or the file system fails, 130 when interrupted. It never prints a
traceback.
"""

from __future__ import annotations

__all__ = ["JobFailure", "run_job", "start_quietly"]

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from app.media import browser as headless
from app.media.browser import SnapshotError
from app.media.pictures import run_with_browser


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
        return headless._fail(problem, 2)
    try:
        _prepare(path, chromium)
        run_with_browser(
            start or (lambda: start_quietly(scenario)), work, chromium=chromium
        )
    except JobFailure as failure:
        return headless._fail(failure.message, failure.code)
    except SnapshotError as error:
        return headless._fail(str(error), 1)
    except KeyboardInterrupt:
        return headless._fail("interrupted", 130)
    except Exception as error:  # a command-line tool: no traceback
        return headless._fail(
            f"failed: {type(error).__name__}: {headless._first_line(error)}",
            1,
        )
    return 0


class JobFailure(Exception):
    """Why a job stopped: the one line to print and the exit code."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.message = message
        self.code = code


def _prepare(path: Path, chromium: str | None) -> None:
    """Check the browser and the output folder before anything slow starts."""
    try:
        headless.check_chromium(chromium or headless.chromium_path())
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
        with headless._quiet_stdout():
            return start_app(scenario, host="127.0.0.1", port=0, print_url=False)
    except (ValueError, LookupError, FileNotFoundError) as error:
        raise JobFailure(
            f"cannot load scenario: {headless._first_line(error)}",
            2,
        ) from None
