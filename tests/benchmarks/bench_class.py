"""A classroom under load: the presenter drags while watchers watch and students edit copies.

The real app runs in presenter mode on 127.0.0.1 (loopback only) with scenario 06. The
browsers are websocket clients speaking viser's protocol (``tests/viser_client.py``), all
in ONE separate process: 30 (``--watchers``) that watch, and 10 (``--copies``) that press
*Make my own copy* and then drag their own goal at 30 Hz (``--student-rate``), each over
the wire like a page's gizmo. Meanwhile the presenter drags the shared goal at 60 Hz
through the controller (as ``bench_app.py``'s "mouse" mode does, so the figures compare),
with its own browser connected.

Why not 40 Chromiums: one headless Chromium costs about 8 % of a core idle and far more
while drawing (software WebGL); forty would measure Chromium on a 2-core machine, not
the server. The clients here receive and decode every message the server sends (what
costs the server is the same: it serialises and sends per client) and send what a
page sends; they do not draw. Their process's CPU time is reported, because on this
machine it is taken from the server's two cores.

What is reported (all times from ``time.perf_counter``, one clock for both processes):

``presenter``
    Edit-to-redraw of the presenter's events (event -> first frame of that version or a
    newer one drawn by the server, all views including every follower's panel), p50/p95,
    for the expansion + VG + SVG frame (*fast*, budget 16 ms) and the frame with DSB
    (*full*, 50 ms); first with only the presenter's browser, then under load.
``to watchers``
    Event -> the watcher's client has received the goal's new position (the wire and
    the fan-out), over every watcher and every drawn version.
``copies``
    The same edit-to-redraw inside the private sessions (their drags, server side).
``memory``
    Resident memory of the server process before any browser connects and after the
    run (each configuration runs in a fresh process), and of its worker processes.
``CPU``
    CPU time [s] of the server process and of its workers during the drags, and of the
    client process in all: under load, a steadier measure of cost than latency.
``end state``
    Whether every watcher's last goal is the presenter's final goal, and every copy's
    scene ends where its student left it.

Bounded: at most ``--events`` presenter events (default 300, 5 s at 60 Hz), the students
drag for as long; connecting takes a few seconds. Run:
``python tests/benchmarks/bench_class.py [--watchers 30] [--copies 10] [--events 300]``
and ``--sweep`` for the limit table (several smaller runs). A report, not a test: it
exits 0 unless ``--strict``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from bench_app import (  # noqa: E402  (tests/benchmarks/bench_app.py)
    FAST_BUDGET_MS,
    FULL_BUDGET_MS,
    Probe,
    drag_positions,
    latencies,
    mouse_drag,
    percentile,
)
from clock import StealMeter  # noqa: E402

import planners  # noqa: E402
from app import start_app  # noqa: E402
from app.classroom import PRESENTER_PATH  # noqa: E402
from app.server import resolve_scenario  # noqa: E402

SCENARIO = "06_four_obstacles_sensor"
GOAL = "/handles/goal"


# --------------------------------------------------------------------------- clients


def run_clients(args: argparse.Namespace) -> int:
    """The client process: connect, copy, drag on "go", report on "report" (JSON lines)."""
    from tests.viser_client import ViserClient

    received: dict[int, list[tuple[float, tuple[float, ...]]]] = {}

    def watcher_log(k: int) -> Any:
        log = received.setdefault(k, [])

        def on(t: float, message: dict[str, Any]) -> None:
            if (
                message.get("type") == "SetPositionMessage"
                and message.get("name") == "/shared" + GOAL
                and message.get("owner", "") == ""
            ):
                log.append((t, tuple(message["position"])))

        return on

    presenter = ViserClient(args.port, f"{PRESENTER_PATH}{args.token}")
    watchers = [
        ViserClient(args.port, "", watcher_log(k)) for k in range(args.watchers)
    ]
    students = [ViserClient(args.port) for _ in range(args.copies)]
    everyone = [presenter, *watchers, *students]
    for c in everyone:
        assert c.wait_for(lambda c=c: seated(c), 120), "no panel"
    for s in students:
        s.click("Make my own copy")
    for s in students:
        assert s.wait_for(lambda s=s: own_id(s) is not None, 120), "no copy"
    say({"ready": True})
    expect("go")
    sent = drag_students(students, args)
    goal = json.loads(expect("report"))
    # Wait (bounded) until every watcher has the presenter's final goal: "ends on".
    deadline = time.monotonic() + 20.0
    for k, w in enumerate(watchers):
        w.wait_for(
            lambda k=k: (
                bool(received.get(k)) and np.allclose(received[k][-1][1][:2], goal)
            ),
            max(0.0, deadline - time.monotonic()),
        )
    say(
        {
            "watchers_last": [
                (received[k][-1][1] if received.get(k) else None)
                for k in range(args.watchers)
            ],
            "watcher_receipts": [received.get(k, []) for k in range(args.watchers)],
            "students_last": [s[-1][1] if s else None for s in sent],
            "students": [own_id(s) for s in students],
            "cpu_s": time.process_time(),
            "messages": sum(c.received for c in everyone),
        }
    )
    for c in everyone:
        c.close()
    return 0


def _has(c: Any, label: str) -> bool:
    return label in c.labels()


def seated(c: Any) -> bool:
    """Whether a client has its whole seat: the panel, then its classroom buttons."""
    return _has(c, "Radius [m]") and (
        _has(c, "Make my own copy") or _has(c, "Let everyone edit")
    )


def own_id(c: Any) -> str | None:
    owners = {owner for owner, name in c.nodes if owner and name.startswith("/own")}
    return next(iter(owners)) if owners else None


def drag_students(students: list[Any], args: argparse.Namespace) -> list[list[Any]]:
    """Every student drags its own goal in a loop at ``student_rate`` for ``duration``."""
    sent: list[list[Any]] = [[] for _ in students]
    period = 1.0 / args.student_rate
    n = max(2, int(args.duration * args.student_rate))
    loop = drag_positions(planners.load_scene(resolve_scenario(SCENARIO)[1]), n)

    def drag(k: int) -> None:
        s, owner = students[k], str(own_id(students[k]))
        # The presenter's loop around the goal (a valid goal all along), each student
        # starting at another point of it.
        points = np.roll(loop, 7 * k, axis=0)
        name = "/own" + GOAL
        s.drag(name, tuple(points[0]), "start", owner)
        t_next = time.perf_counter()
        for xy in points:
            t_next += period
            xy_t = (float(xy[0]), float(xy[1]))
            s.drag(name, xy_t, "update", owner)
            sent[k].append((time.perf_counter(), xy_t))
            time.sleep(max(0.0, t_next - time.perf_counter()))
        s.drag(name, tuple(points[-1]), "end", owner)

    threads = [threading.Thread(target=drag, args=(k,)) for k in range(len(students))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return sent


def say(data: dict[str, Any]) -> None:
    print(json.dumps(data), flush=True)


def expect(word: str) -> str:
    """Read the parent's next command; return what follows the word."""
    line = sys.stdin.readline().strip()
    if line.split(" ", 1)[0] != word:
        raise SystemExit(f"client process: expected {word!r}, got {line!r}")
    return line[len(word) :].strip()


# --------------------------------------------------------------------------- server


class Clients:
    """The client process, driven line by line."""

    def __init__(self, app: Any, watchers: int, copies: int, args: argparse.Namespace):
        self.proc = subprocess.Popen(
            [
                sys.executable,
                __file__,
                "--clients",
                f"--port={app.port}",
                f"--token={app.classroom.token}",
                f"--watchers={watchers}",
                f"--copies={copies}",
                f"--duration={args.events / args.rate + 0.5}",
                f"--student-rate={args.student_rate}",
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )

    def read(self) -> dict[str, Any]:
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the client process stopped ({self.proc.wait()})")
        return json.loads(line)

    def send(self, word: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(word + "\n")
        self.proc.stdin.flush()

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.proc.wait(timeout=30)
        if self.proc.poll() is None:
            self.proc.kill()


def rss_mb(pid: int | None = None) -> float:
    """Resident memory of a process [MB] (Linux /proc)."""
    path = Path(f"/proc/{pid or os.getpid()}/status")
    try:
        for line in path.read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except OSError:
        return 0.0
    return 0.0


def cpu_s(pids: list[int]) -> float:
    """CPU time (user + system) of processes [s] (Linux /proc; 0 for a vanished one)."""
    total = 0.0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return total


def worker_pids(app: Any) -> list[int]:
    """Process ids of the presenter's DSB worker and of the copies' pools."""
    pids = []
    process = app.controller.scheduler.process
    if process is not None and process.pid is not None:
        pids.append(process.pid)
    room = app.classroom
    shared = getattr(
        room, "shared", room
    )  # an older tree (--code) kept them on the room
    for pool in (shared.pool, getattr(shared, "fast_pool", None), shared.big_pool):
        if pool is not None:
            pids += [w.pid for w in pool._all if w.pid is not None]
    return pids


class Recorder:
    """Wraps a session's ``edits.drag_handle``: (time, version) of every event."""

    def __init__(self, controller: Any) -> None:
        self.sent: list[tuple[float, int]] = []
        inner = controller.edits.drag_handle

        def drag_handle(handle: Any, xy: Any, phase: str = "update") -> None:
            t0 = time.perf_counter()
            inner(handle, xy, phase)
            if phase == "update":
                self.sent.append((t0, controller.version))

        controller.edits.drag_handle = drag_handle


def run(watchers: int, copies: int, args: argparse.Namespace) -> dict[str, Any]:
    """One classroom: connect, let everyone drag, measure; the app is stopped after."""
    steal = StealMeter()
    with contextlib.redirect_stdout(io.StringIO()):
        app = start_app(SCENARIO, port=0, print_url=False, presenter=True)
    clients = None
    try:
        controller, room = app.controller, app.classroom
        probe = Probe(controller.slow_planners)
        controller.add_view(probe)
        assert app.wait_idle(60)
        rss_before = rss_mb()  # the app alone, before any browser
        t_connect = time.perf_counter()
        clients = Clients(app, watchers, copies, args)
        clients.read()  # ready: everyone connected, copies made
        connect_s = time.perf_counter() - t_connect
        probes, recorders = _watch_copies(room, copies)
        _warm_up(app, controller)
        cpu0 = (time.process_time(), cpu_s(worker_pids(app)))
        clients.send("go")
        points = drag_positions(controller.scene, args.events)
        sent = mouse_drag(controller, ("goal",), points, args.rate)
        assert app.wait_idle(120)
        for _, seat in probes:
            assert seat.private is None or seat.private.wait_idle(120)
        clients.send(f"report {json.dumps(list(controller.scene.goal))}")
        report = clients.read()
        _wait_copies_settle(probes, report)
        cpu = (time.process_time() - cpu0[0], cpu_s(worker_pids(app)) - cpu0[1])
        rss_after = rss_mb()
        return _summary(
            watchers=watchers,
            copies=copies,
            app=app,
            probe=probe,
            sent=sent,
            points=points,
            report=report,
            probes=probes,
            recorders=recorders,
            memory=(rss_before, rss_after),
            connect_s=connect_s,
            cpu=cpu,
            steal=steal.stop(),
        )
    finally:
        if clients is not None:
            clients.close()
        with contextlib.redirect_stdout(io.StringIO()):
            app.stop()


def _watch_copies(room: Any, copies: int) -> tuple[list[Any], list[Recorder]]:
    deadline = time.monotonic() + 120
    while room.counts()["sessions"] < copies and time.monotonic() < deadline:
        time.sleep(0.05)
    seats = [
        room.seat(cid)
        for cid in list(room._seats)
        if room.seat(cid) is not None and room.seat(cid).private is not None
    ]
    probes, recorders = [], []
    for seat in seats:
        private = seat.private
        assert private.wait_idle(120)
        probe = Probe(private.slow_planners)
        private.add_view(probe)
        probes.append((probe, seat))
        recorders.append(Recorder(private))
    return probes, recorders


def _warm_up(app: Any, controller: Any) -> None:
    scene = controller.scene
    for xy in drag_positions(scene, 20):
        controller.edits.drag_handle(("goal",), xy, "update")
    controller.edits.drag_handle(("goal",), scene.goal, "end")
    assert app.wait_idle(60)


def _summary(**m: Any) -> dict[str, Any]:
    app, probe, sent = m["app"], m["probe"], m["sent"]
    fast = latencies(probe, probe.fast, sent)
    full = latencies(probe, probe.full, sent) if probe.slow else []
    sent_at = {
        (float(x), float(y)): t
        for (t, _), (x, y) in zip(sent, m["points"], strict=True)
    }
    wire = [
        (t - sent_at[(p[0], p[1])]) * 1e3
        for receipts in m["report"]["watcher_receipts"]
        for t, p in receipts
        if (p[0], p[1]) in sent_at
    ]
    copy_fast, copy_full = [], []
    for (copy_probe, _), recorder in zip(m["probes"], m["recorders"], strict=True):
        copy_fast += latencies(copy_probe, copy_probe.fast, recorder.sent)
        if copy_probe.slow:
            copy_full += latencies(copy_probe, copy_probe.full, recorder.sent)
    goal = tuple(app.controller.scene.goal)
    last = m["report"]["watchers_last"]
    on_scene = sum(1 for p in last if p is not None and np.allclose(p[:2], goal))
    copies_ok = _copies_end_where_left(m["probes"], m["report"])
    workers = worker_pids(app)
    return {
        "watchers": m["watchers"],
        "copies": m["copies"],
        "fast": fast,
        "full": full,
        "wire": wire,
        "copy_fast": copy_fast,
        "copy_full": copy_full,
        "frames": len([v for v in probe.fast if v >= sent[0][1]]),
        "events": len(sent),
        "watchers_on_scene": on_scene,
        "copies_ok": copies_ok,
        "rss_server": m["memory"],
        "rss_workers": sum(rss_mb(p) for p in workers),
        "workers": len(workers),
        "client_cpu_s": m["report"]["cpu_s"],
        "messages": m["report"]["messages"],
        "connect_s": m["connect_s"],
        "server_cpu_s": m["cpu"][0],
        "workers_cpu_s": m["cpu"][1],
        "steal": m["steal"],
    }


def _wait_copies_settle(probes: list[Any], report: dict[str, Any]) -> None:
    """Wait (bounded) until every copy has handled its student's last event."""
    last = dict(zip(report["students"], report["students_last"], strict=True))
    deadline = time.monotonic() + 20.0
    for _, seat in probes:
        private, goal = seat.private, last.get(str(seat.client_id))
        while (
            private is not None
            and goal is not None
            and not np.allclose(private.scene.goal, goal)
            and time.monotonic() < deadline
        ):
            time.sleep(0.05)
        if private is not None:
            private.wait_idle(max(0.1, deadline - time.monotonic()))


def _copies_end_where_left(probes: list[Any], report: dict[str, Any]) -> int:
    """How many copies' scenes end on the goal their student dragged to last."""
    by_owner = {
        owner: last
        for owner, last in zip(report["students"], report["students_last"], strict=True)
        if owner is not None and last is not None
    }
    ok = 0
    for _, seat in probes:
        last = by_owner.get(str(seat.client_id))
        private = seat.private
        if last is not None and private is not None:
            ok += bool(np.allclose(private.scene.goal, last))
    return ok


# --------------------------------------------------------------------------- report


def pair(values: list[float]) -> str:
    if not values:
        return "n/a"
    return f"{percentile(values, 50):6.1f} / {percentile(values, 95):6.1f}"


def print_header() -> None:
    print(
        f"{'watchers':>8s} {'copies':>6s} | {'presenter fast':>15s} {'presenter +DSB':>15s} "
        f"{'to watchers':>15s} | {'copies fast':>15s} {'copies +DSB':>15s} | "
        f"{'server MB':>13s} {'workers MB':>10s} | {'CPU s: server workers clients':>29s} | {'end ok':>11s} {'frames':>7s} {'steal':>5s}"
    )
    print("-" * 170)


def print_row(s: dict[str, Any]) -> None:
    before, after = s["rss_server"]
    ok = f"{s['watchers_on_scene']}/{s['watchers']}+{s['copies_ok']}/{s['copies']}"
    print(
        f"{s['watchers']:8d} {s['copies']:6d} | {pair(s['fast']):>15s} {pair(s['full']):>15s} "
        f"{pair(s['wire']):>15s} | {pair(s['copy_fast']):>15s} {pair(s['copy_full']):>15s} | "
        f"{before:5.0f} -> {after:4.0f} {s['rss_workers']:7.0f} ({s['workers']}) | "
        f"{s['server_cpu_s']:14.1f} {s['workers_cpu_s']:7.1f} {s['client_cpu_s']:7.1f} | "
        f"{ok:>11s} {s['frames']:7d} {s['steal']:4.0%}",
        flush=True,
    )


def run_fresh(watchers: int, copies: int, args: argparse.Namespace) -> dict[str, Any]:
    """Run one configuration in a process of its own (its memory figures are its own)."""
    return run_one(
        __file__,
        [
            f"--watchers={watchers}",
            f"--copies={copies}",
            f"--events={args.events}",
            f"--rate={args.rate}",
            f"--student-rate={args.student_rate}",
        ],
    )


def run_one(script: str, flags: list[str], code: str = str(ROOT)) -> dict[str, Any]:
    """Run ``script --one FLAGS`` in a process of its own; return the JSON it printed last.

    ``code``: the checkout whose app the process imports first (this one by default).
    The process runs in that folder: the app's planner processes put their working
    folder first on their import path, and must import the same app.
    """
    out = subprocess.run(
        [sys.executable, os.path.abspath(script), "--one", *flags],
        check=True,
        stdout=subprocess.PIPE,
        text=True,
        cwd=code,
        env={
            **os.environ,
            "PYTHONPATH": os.pathsep.join(dict.fromkeys([code, str(ROOT)])),
        },
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def parse_config(text: str) -> tuple[int, int]:
    """``"30:10"`` -> (30 watchers, 10 copies)."""
    watchers, _, copies = text.partition(":")
    return int(watchers), int(copies or 0)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--watchers", type=int, default=30)
    parser.add_argument("--copies", type=int, default=10)
    parser.add_argument("--events", type=int, default=300, help="presenter events")
    parser.add_argument("--rate", type=float, default=60.0, help="presenter rate [Hz]")
    parser.add_argument("--student-rate", type=float, default=30.0)
    parser.add_argument(
        "--sweep", action="store_true", help="also smaller and larger classes"
    )
    parser.add_argument("--strict", action="store_true")
    parser.add_argument("--json", metavar="FILE", help="write every measurement")
    # The client process's own options.
    parser.add_argument("--clients", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--port", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--token", help=argparse.SUPPRESS)
    parser.add_argument("--duration", type=float, default=5.0, help=argparse.SUPPRESS)
    parser.add_argument(
        "--configs",
        default="",
        help="classes to run instead, WATCHERS:COPIES comma-separated (e.g. 0:0,10:0,0:2)",
    )
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.clients:
        return run_clients(args)
    if args.one:
        print(json.dumps(run(args.watchers, args.copies, args)))
        return 0

    configs = [(0, 0), (args.watchers, args.copies)]
    if args.configs:
        configs = [parse_config(text) for text in args.configs.split(",")]
    elif args.sweep:
        configs = [
            (0, 0),
            (10, 0),
            (30, 0),
            (60, 0),
            (0, 5),
            (0, 10),
            (0, 20),
            (30, 10),
        ]
    print(
        f"Classroom load on {SCENARIO}: the presenter drags the goal through "
        f"{args.events} positions at {args.rate:g} Hz; each copy's student drags its own "
        f"goal at {args.student_rate:g} Hz (p50 / p95 in ms)"
    )
    print(
        f"load average: {', '.join(f'{x:.2f}' for x in os.getloadavg())} on "
        f"{os.cpu_count()} CPUs; budgets: {FAST_BUDGET_MS:g} ms fast, "
        f"{FULL_BUDGET_MS:g} ms with DSB"
    )
    print()
    print_header()
    results, missed = [], False
    for watchers, copies in configs:
        s = run_fresh(watchers, copies, args)
        results.append(s)
        print_row(s)
        missed |= bool(s["fast"]) and percentile(s["fast"], 95) > FAST_BUDGET_MS
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 1 if (missed and args.strict) else 0


if __name__ == "__main__":
    sys.exit(main())
