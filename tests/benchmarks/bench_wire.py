"""What goes over the websocket per drag event on a student layout.

A 32-obstacle student layout (``bench_student.student_layout``) is opened in the real app
(viser server, 3-D view, panel, controller) with one websocket client
(:class:`tests.viser_client.ViserClient`, a browser without the browser) watching. A
whole obstacle is dragged through the middle of the room through
``controller.edits.drag_handle`` (the gizmo's call), one event at a time, each waited for
until drawn and received. For every event we count:

- the bytes the client receives (whole websocket frames: header, zstd msgpack, binary
  buffers) and the number of messages;
- on the server, per scene node: the messages queued and the bytes of the arrays they
  carry (viser's ``SceneApi._queue_scene_message``, wrapped), to see which layer costs.

Run: ``python tests/benchmarks/bench_wire.py [--events 60] [--obstacles 32]
[--layout merging|apart] [--drag move,vertex] [--all-edges]``. ``--all-edges`` switches
the panel's "VG edges: all" on (the whole graph drawn, as before thinning); ``--layout``
picks the kind of room (``bench_student.student_layout``). A report: always exit 0.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import io
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
for path in (ROOT, HERE):
    if str(path) not in sys.path:  # run as a script from anywhere
        sys.path.insert(0, str(path))

import viser._scene_api  # noqa: E402
from bench_student import drag_points, student_layout  # noqa: E402

import planners  # noqa: E402
from app import start_app  # noqa: E402
from tests.viser_client import ViserClient  # noqa: E402


class CountingClient(ViserClient):
    """A client that also counts the bytes of every websocket frame it receives."""

    def __init__(self, port: int) -> None:
        self.bytes = 0
        super().__init__(port)

    def _frames(self):  # type: ignore[override]
        for raw in super()._frames():
            self.bytes += len(raw)
            yield raw


class ServerTally:
    """Scene messages queued on the server: node -> [messages, array bytes]."""

    def __init__(self) -> None:
        self.by_node: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0])
        self._lock = threading.Lock()
        self._saved = viser._scene_api.SceneApi._queue_scene_message

    def __enter__(self) -> ServerTally:
        saved = self._saved
        tally = self

        def queue(api: Any, message: Any) -> None:
            tally.add(message)
            saved(api, message)

        viser._scene_api.SceneApi._queue_scene_message = queue  # type: ignore[method-assign]
        return self

    def __exit__(self, *exc: object) -> None:
        viser._scene_api.SceneApi._queue_scene_message = self._saved  # type: ignore[method-assign]

    def add(self, message: Any) -> None:
        name = str(getattr(message, "name", type(message).__name__))
        updates = getattr(message, "updates", None) or {}
        size = sum(v.nbytes for v in updates.values() if isinstance(v, np.ndarray))
        with self._lock:
            row = self.by_node[name]
            row[0] += 1
            row[1] += size

    def reset(self) -> None:
        with self._lock:
            self.by_node.clear()


def _drain(app: Any, client: CountingClient) -> None:
    """Wait until the app has drawn everything and the client has stopped receiving."""
    assert app.wait_idle(120)
    last, quiet_since = -1, time.monotonic()
    while time.monotonic() - quiet_since < 0.15:
        time.sleep(0.02)
        if client.received != last:
            last, quiet_since = client.received, time.monotonic()


def bench(
    obstacles: int, drag: str, events: int, all_edges: bool, layout: str = "merging"
) -> dict[str, Any]:
    """Drag ``events`` steps; return bytes and messages per event, and the server tally."""
    room = planners.load_scene(student_layout(obstacles, layout=layout))
    with contextlib.redirect_stdout(io.StringIO()):
        app = start_app(room, port=0, print_url=False)
    client = None
    try:
        controller = app.controller
        controller.set_planner_enabled("dsb", False)  # the fast lane's layers only
        if all_edges:
            controller.set_layer("vg_edges_all", True)
        client = CountingClient(app.server.get_port())
        _drain(app, client)
        handle, points = drag_points(controller.scene, drag, events)
        controller.edits.drag_handle(handle, points[0], "start")
        _drain(app, client)
        with ServerTally() as tally:
            bytes0, messages0 = client.bytes, client.received
            for xy in points:
                controller.edits.drag_handle(handle, xy, "update")
                _drain(app, client)
            sent = client.bytes - bytes0
            messages = client.received - messages0
            by_node = {k: tuple(v) for k, v in tally.by_node.items()}
        controller.edits.drag_handle(handle, points[-1], "end")
        frame = controller.frame
        return {
            "bytes": sent / events,
            "messages": messages / events,
            "by_node": by_node,
            "vg_edges": frame.plans["vg"].edges if frame else 0,
        }
    finally:
        if client is not None:
            client.close()
        with contextlib.redirect_stdout(io.StringIO()):
            app.stop()


def main(argv: list[str] | None = None) -> int:
    """Print bytes and messages per drag event, and the eight costliest nodes."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--events", type=int, default=60)
    parser.add_argument("--obstacles", default="32")
    parser.add_argument("--layout", default="merging", choices=("merging", "apart"))
    parser.add_argument("--drag", default="move,vertex")
    parser.add_argument("--all-edges", action="store_true")
    args = parser.parse_args(argv)
    print(f"load average: {', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for count in (int(k) for k in args.obstacles.split(",")):
        for drag in args.drag.split(","):
            r = bench(count, drag, args.events, args.all_edges, args.layout)
            print(
                f"{count} obstacles {args.layout}, {drag}, VG edges {r['vg_edges']},"
                f" 'VG edges: all' {'on' if args.all_edges else 'off'}:"
                f" {r['bytes'] / 1024:.1f} KiB and {r['messages']:.1f} messages per event"
            )
            rows = sorted(r["by_node"].items(), key=lambda kv: -kv[1][1])[:8]
            for name, (n, size) in rows:
                print(
                    f"    {name:28} {n / args.events:5.2f} msg/event"
                    f" {size / args.events / 1024:8.1f} KiB/event (arrays)"
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
