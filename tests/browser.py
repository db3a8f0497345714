"""Headless Chromium for the browser tests: one shared browser, clear failures, no skips.

A test that needs the browser asks for the ``browser`` fixture (``tests/conftest.py``).
A test process starts one Chromium for a run of modules that use it and closes it before
a module that does not: playwright's synchronous API keeps an asyncio loop on the main
thread while a browser is open, and such a module may run a loop of its own there
(``asyncio.run``). The slowest modules run first (``tests/durations.json``) and most of
them use the browser, so a process starts Chromium a few times, not once per module.

If Chromium cannot start, every test that needs it *fails* with one clear message (how to
install the browser): browser tests are never silently skipped, because a snapshot suite
that quietly does nothing looks exactly like one that passes.

For end-to-end tests that drive the page (clicks, drags), :func:`app.media.browser.open_page`
(re-exported here) opens a running app in a fresh context and waits until its scene is
loaded.
"""

from __future__ import annotations

__all__ = ["AppPage", "close_browser", "close_pages", "open_page", "shared_browser"]

import contextlib
from typing import TYPE_CHECKING, Any

import pytest

from app.media.browser import AppPage, SnapshotError, launch_browser, open_page

if TYPE_CHECKING:
    from playwright.sync_api import Browser

_shared: dict[str, Any] = {"browser": None, "exit": None, "error": None}


def shared_browser() -> Browser:
    """Return this process's headless Chromium, started if need be; fail (never skip)."""
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
    return _shared["browser"]


def close_browser() -> None:
    """Close this process's Chromium if it runs (the next :func:`shared_browser` starts one)."""
    stack, _shared["exit"], _shared["browser"] = _shared["exit"], None, None
    if stack is not None:
        stack.close()


def close_pages() -> None:
    """Close every page still open in this process's Chromium (a failed test's, say)."""
    browser = _shared["browser"]
    if browser is not None:
        for context in browser.contexts:
            context.close()
