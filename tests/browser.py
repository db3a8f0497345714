"""Headless Chromium for the browser tests: one shared browser, clear failures, no skips.

A test module that needs the browser defines its own fixture around :func:`use_browser`::

    @pytest.fixture(scope="module")
    def browser() -> Iterator[Browser]:
        with use_browser() as shared:
            yield shared

Fixtures that are alive at the same time share one Chromium; it is closed when the last one
is torn down.

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
