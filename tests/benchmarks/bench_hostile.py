"""The presenter's latency while a hostile student attacks the class, before and after.

Two source trees are compared in one run, their rounds interleaved (the machine's speed
drifts within minutes): ``--before DIR`` (a checkout of an older commit, e.g. made with
``git worktree add /tmp/before <commit>``) and this tree. Each round starts a fresh
server process from one tree in presenter mode on 127.0.0.1 (scenario 06), connects the
presenter and one watcher (websocket clients speaking viser's protocol,
``tests/viser_client.py``), and has the presenter drag its goal at 30 Hz for
``--seconds`` while one attack runs from other seats:

``quiet``
    no attack (the reference).
``copy-flood``
    one seat clicks *Make my own copy* / *Follow the presenter again* as fast as its
    socket sends.
``refused-updates``
    one watcher sends 20,000 values to a widget it may not use.
``form-dirty``
    one watcher sends 100 ``GuiFormDirtyMessage`` of 1 MB each, each with a uuid of its
    own.
``big-frames``
    two watchers send three 50 MB frames each.
``huge-upload``
    five seats (everyone editing) upload 60 MB each.

Reported per tree and attack: presenter -> watcher latency of the goal's position
(send -> the watcher has it), p50 / p95 / max [ms]; the share of the presenter's
positions that reached the watcher (the server coalesces, so less than 100 % is normal);
the server's resident memory before the attack and after it; and the machine's own
spread (a fixed piece of work, :func:`clock.spread`), printed beside the figures.

ShareUrlRequest is not among the attacks: an older server would open a connection to
viser's public share service. The test suite checks that it is refused.

Run: ``python tests/benchmarks/bench_hostile.py --before /tmp/before [--rounds 2]``.
A report, not a test: it always exits 0.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from clock import spread  # noqa: E402

from tests.viser_client import ViserClient  # noqa: E402

SERVER = """
import json, os, sys
from app import start_app
app = start_app("06_four_obstacles_sensor", port=0, print_url=False, presenter=True)
print(json.dumps({"port": app.port, "token": app.classroom.token}), flush=True)
for line in sys.stdin:
    if line.strip() == "open":
        app.classroom.set_open(True)
        print("opened", flush=True)
app.stop()
"""

ATTACKS = (
    "quiet",
    "copy-flood",
    "refused-updates",
    "form-dirty",
    "big-frames",
    "huge-upload",
)
GOAL = "/handles/goal"


class Server:
    """A planner server in presenter mode, in a process of its own from ``tree``."""

    def __init__(self, tree: Path) -> None:
        env = dict(os.environ, PYTHONPATH=str(tree))
        self.process = subprocess.Popen(
            [sys.executable, "-c", SERVER],
            cwd=tree,
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        assert self.process.stdout is not None
        info = json.loads(self.process.stdout.readline())
        self.port, self.token = int(info["port"]), str(info["token"])

    def open_to_everyone(self) -> None:
        assert self.process.stdin is not None and self.process.stdout is not None
        self.process.stdin.write("open\n")
        self.process.stdin.flush()
        self.process.stdout.readline()

    def rss_mb(self) -> float:
        try:
            text = Path(f"/proc/{self.process.pid}/status").read_text()
        except OSError:
            return float("nan")
        kb = next(
            int(line.split()[1])
            for line in text.splitlines()
            if line.startswith("VmRSS")
        )
        return kb / 1024

    def stop(self) -> None:
        assert self.process.stdin is not None
        self.process.stdin.close()
        try:
            self.process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.process.kill()


def _has(c: ViserClient, label: str) -> bool:
    return any(e["label"] == label for e in c.gui.values())


def own_id(c: ViserClient) -> str | None:
    with c._lock:
        owners = {owner for owner, name in c.nodes if owner and name.startswith("/own")}
    return next(iter(owners)) if owners else None


def seated(port: int, path: str = "", on_message: Any = None) -> ViserClient:
    c = ViserClient(port, path, on_message=on_message)
    label = "Let everyone edit" if path else "Make my own copy"
    assert c.wait_for(lambda: _has(c, "Radius [m]") and _has(c, label), 60), "no seat"
    return c


# --------------------------------------------------------------------------- attacks


def attack(name: str, server: Server, stop: threading.Event) -> Callable[[], None]:
    """Return the attack ``name`` as a function to run in a thread (it connects first)."""
    port = server.port

    def copy_flood() -> None:
        c = seated(port)
        copy = c.uuid("Make my own copy")
        c.wait_for(lambda: _has(c, "Follow the presenter again"), 30)
        back = c.uuid("Follow the presenter again")
        while not stop.is_set():
            c.set_gui(copy, True)
            c.set_gui(back, True)
        c.close()

    def refused_updates() -> None:
        c = seated(port)
        radius = c.uuid("Radius [m]")
        for k in range(20_000):
            if stop.is_set():
                break
            c.set_gui(radius, 0.1 + (k % 50) / 100)
        c.close()

    def form_dirty() -> None:
        c = seated(port)
        for k in range(100):  # each its own uuid: viser keeps one per uuid
            c.send({"type": "GuiFormDirtyMessage", "uuid": f"{k:03d}" + "x" * 999_997})
        c.close()

    def big_frames() -> None:
        clients = [seated(port) for _ in range(2)]
        frame = {"type": "GuiFormDirtyMessage", "uuid": "x" * 50_000_000}
        for c in clients:
            for _ in range(3):
                try:
                    c.send(frame)
                except Exception:
                    break
        for c in clients:
            c.close()

    def huge_upload() -> None:
        clients = [seated(port) for _ in range(5)]
        data = b"x" * 60_000_000
        for c in clients:
            try:
                c.upload("Upload a scenario (.json) or map (.zip)", "huge.json", data)
            except Exception:
                pass
        for c in clients:
            c.close()

    return {
        "quiet": lambda: None,
        "copy-flood": copy_flood,
        "refused-updates": refused_updates,
        "form-dirty": form_dirty,
        "big-frames": big_frames,
        "huge-upload": huge_upload,
    }[name]


# --------------------------------------------------------------------------- one round


def round_(tree: Path, name: str, seconds: float) -> dict[str, Any]:
    """One fresh server from ``tree``, the presenter dragging while ``name`` attacks."""
    server = Server(tree)
    sent: dict[tuple[float, float], float] = {}
    got: dict[tuple[float, float], float] = {}

    def heard(now: float, message: dict[str, Any]) -> None:
        if (
            message.get("type") == "SetPositionMessage"
            and message.get("name") == "/shared" + GOAL
            and not message.get("owner")
        ):
            xy = (
                round(float(message["position"][0]), 4),
                round(float(message["position"][1]), 4),
            )
            if xy in sent and xy not in got:
                got[xy] = now

    try:
        if name == "huge-upload":
            server.open_to_everyone()
        presenter = seated(server.port, f"/presenter/{server.token}")
        watcher = seated(server.port, on_message=heard)
        presenter.wait_for(lambda: own_id(presenter) is not None, 30)
        owner = own_id(presenter) or ""
        rss_before = server.rss_mb()
        stop = threading.Event()
        thread = threading.Thread(target=attack(name, server, stop), daemon=True)
        thread.start()
        xy = (5.0, 5.0)  # where the goal is dragged from; then the last place sent
        presenter.drag("/own" + GOAL, xy, "start", owner)
        events = int(seconds * 30)
        start = time.perf_counter()
        for k in range(events):
            xy = (round(2.0 + 6.0 * k / events, 4), round(5.0 + (k % 7) * 0.01, 4))
            sent[xy] = time.perf_counter()
            presenter.drag("/own" + GOAL, xy, "update", owner)
            time.sleep(max(0.0, start + (k + 1) / 30 - time.perf_counter()))
        presenter.drag("/own" + GOAL, xy, "end", owner)
        watcher.wait_for(lambda: xy in got, 30)
        stop.set()
        thread.join(timeout=60)
        time.sleep(1.0)
        rss_after = server.rss_mb()
        presenter.close()
        watcher.close()
    finally:
        server.stop()
    ms = [1e3 * (got[xy] - sent[xy]) for xy in got]
    return {
        "latency": ms,
        "delivered": len(got) / max(1, len(sent)),
        "rss": (rss_before, rss_after),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--before", type=Path, required=True, help="the older tree")
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--seconds", type=float, default=6.0)
    parser.add_argument("--attacks", default=",".join(ATTACKS))
    args = parser.parse_args(argv)
    trees = {"before": args.before.resolve(), "after": ROOT}
    names = [a for a in args.attacks.split(",") if a]
    results: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for tree in trees.values():  # numba compiles a tree's loops once: not timed
        Server(tree).stop()
    p50, p95 = spread()
    print(f"machine spread (fixed 12 ms of work): p50 {p50:.1f} ms, p95 {p95:.1f} ms")
    for _ in range(args.rounds):
        for name in names:
            for label, tree in trees.items():  # interleaved: before, after, before...
                results.setdefault((label, name), []).append(
                    round_(tree, name, args.seconds)
                )
    p50, p95 = spread()
    print(f"machine spread after: p50 {p50:.1f} ms, p95 {p95:.1f} ms")
    print(
        f"{'attack':<16} {'tree':<7} {'p50':>7} {'p95':>7} {'max':>8} {'delivered':>9} {'RSS before -> after [MB]':>26}"
    )
    for name in names:
        for label in trees:
            runs = results[(label, name)]
            ms = [v for r in runs for v in r["latency"]]
            q = np.percentile(ms, [50, 95, 100]) if ms else [np.nan] * 3
            delivered = np.mean([r["delivered"] for r in runs])
            rss = runs[-1]["rss"]
            print(
                f"{name:<16} {label:<7} {q[0]:7.0f} {q[1]:7.0f} {q[2]:8.0f} "
                f"{100 * delivered:8.0f}% {rss[0]:12.0f} -> {rss[1]:.0f}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
