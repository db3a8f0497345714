"""Headless Chromium for the browser tests: one shared browser, clear failures, no skips.

A test that needs the browser asks for the ``browser`` fixture (``tests/conftest.py``):
one Chromium per test process, started by the first test that asks and closed when the
session ends. A test that only needs to know Chromium is there (the app then starts a
browser of its own) holds ``with use_browser():`` around its work. Everyone alive at the
same time shares one Chromium; it is closed when the last one lets go.

If Chromium cannot start, every test that needs it *fails* with one clear message (how to
install the browser): browser tests are never silently skipped, because a snapshot suite
that quietly does nothing looks exactly like one that passes.

For end-to-end tests that drive the page (clicks, drags), :func:`app.media.browser.open_page`
(re-exported here) opens a running app in a fresh context and waits until its scene is
loaded.
"""

from __future__ import annotations

__all__ = ["AppPage", "open_page", "use_browser"]

import contextlib
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import pytest

from app.media.browser import AppPage, SnapshotError, launch_browser, open_page

if TYPE_CHECKING:
    from playwright.sync_api import Browser

_shared: dict[str, Any] = {"browser": None, "exit": None, "users": 0, "error": None}


@contextlib.contextmanager
def use_browser() -> Iterator[Browser]:
    """Lend the shared headless Chromium; fail (never skip) the test if it cannot start."""
    if _shared["error"] is not None:
        pytest.fail(_shared["error"], pytrace=False)
    if _shared["browser"] is None:
        stack = contextlib.ExitStack()
        try:
            _shared["browser"] = stack.enter_context(launch_browser())
        except SnapshotError as error:
            _shared["error"] = (
                f"the browser tests need headless Chromium and it could not start: {error}. "
                "`make test` installs it (tools/ensure-chromium.sh)."
            )
            pytest.fail(_shared["error"], pytrace=False)
        _shared["exit"] = stack
    _shared["users"] += 1
    try:
        yield _shared["browser"]
    finally:
        _shared["users"] -= 1
        if _shared["users"] == 0 and _shared["exit"] is not None:
            stack, _shared["exit"], _shared["browser"] = _shared["exit"], None, None
            stack.close()
