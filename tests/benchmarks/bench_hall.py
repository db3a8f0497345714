"""A lecture hall: hundreds of watchers and a few students' copies on one server.

The real app runs in presenter mode on 127.0.0.1 (``start_app(..., presenter=True)``)
and the presenter drags the goal at 60 Hz through the controller (as ``bench_app.py``'s
"mouse" mode; its browser is connected). The class is one separate process of real
websocket clients speaking viser's protocol:

- ``--watchers`` watchers, on one asyncio loop. Every one reads every frame the server
  sends and counts its bytes; ``--probes`` of them (spread over the class) also decode
  each frame and time when the goal's new position arrives. The others do not decode:
  a browser's decoding costs the student's laptop, not the server, and on this 2-core
  machine the client process takes its CPU from the server's cores;
- ``--copies`` students press *Make my own copy* and drag their own goal at 30 Hz
  (``tests/viser_client.py``), as bench_class.py's students do.

What is reported (p50 / p95 in ms; ``time.perf_counter``, one clock for both processes):

``presenter``
    The presenter's edit-to-redraw (event -> first frame of that version or newer drawn
    by the server, expansion + VG + SVG), to compare with its single-user budget.
``to watchers``
    Event -> a probe watcher has the goal's new position, over every probe and event.
``of frames``, ``of class``, ``fps``
    Share of the presenter's frames (the versions its own view drew during the drag)
    whose goal position reached a probe, averaged over the probes; the same share of
    the class's frames (the windows the pump sent the class: the newest frame at most
    ``app.classroom.wire.CLASS_FPS`` times a second); and the rate they arrived at
    [frames/s]. The target (>= 90 % at >= 10 frames/s) is read on the class's frames.
``KB/frame``
    Bytes a watcher received during the drag, per presenter frame delivered to it.
``copies``
    Frames each copy drew per second while its student dragged (server side).
``server``
    Resident memory [MB] and threads of the server process: with the app alone, with
    the class in, and 5 s after everyone left (then ``gc.collect()``): the server gives
    what the class freed back once it has been gone a whole load tick, 2 to 4 s.
``CPU``
    Seconds of CPU of the server (with its worker processes) and of the client process
    during the drag.

Run: ``python tests/benchmarks/bench_hall.py [--watchers 300] [--copies 0]`` or
``--curve`` for the table of classes from 0 to 300 watchers and 0 to 20 copies (each
class in a fresh server process), ``--every-scenario`` for the bytes per watcher-frame of
every shipped scenario, ``--code DIR`` to serve another checkout's app (a worktree of an
older commit, for before/after), ``--busy SHARE`` to burn that share of a core in
another process during each drag (``--configs 0:0 --busy 0.6``: the presenter alone on a
machine as busy as the class's client process makes it). A report, not a test: it exits
0 unless ``--strict`` and a target is missed (presenter -> watcher p95 <= 150 ms, >= 90 %
delivered at >= 10 frames/s, <= 16 KB per watcher-frame).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import gc
import inspect
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
    Probe,
    drag_positions,
    latencies,
    mouse_drag,
    percentile,
)
from bench_class import (  # noqa: E402
    SCENARIO,
    Recorder,
    cpu_s,
    drag_students,
    expect,
    own_id,
    parse_config,
    rss_mb,
    run_one,
    say,
    seated,
    worker_pids,
)
from clock import StealMeter  # noqa: E402

from app import start_app  # noqa: E402
from app.classroom import PRESENTER_PATH  # noqa: E402

GOAL = "/shared/handles/goal"
P95_TARGET_MS = 150.0
DELIVERED_TARGET = 0.9
RATE_TARGET = 10.0
KB_TARGET = 16.0


# --------------------------------------------------------------------------- clients


class Watchers:
    """``n`` websocket watchers on one asyncio loop (in a thread of its own)."""

    def __init__(self, port: int, n: int, probes: int) -> None:
        step = max(1, n // max(1, probes))
        self.probes = set(range(0, n, step)[:probes]) if probes else set()
        self.bytes = [0] * n
        self.frames = [0] * n
        self.receipts: dict[int, list[tuple[float, tuple[float, ...]]]] = {
            k: [] for k in self.probes
        }
        self.counting = False
        self.connected = 0
        self._port, self._n = port, n
        self._loop = asyncio.new_event_loop()
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        self._loop.run_until_complete(self._main())

    async def _main(self) -> None:
        self._stop = asyncio.Event()
        tasks = []
        for k in range(self._n):  # a class arrives over a few seconds, not at once
            tasks.append(asyncio.create_task(self._watch(k)))
            await asyncio.sleep(0.01)
        await self._stop.wait()
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    async def _watch(self, k: int) -> None:
        import msgspec
        import viser
        from websockets.asyncio.client import connect

        from tests.viser_client import camera_message, decode_batch

        probe = k in self.probes
        async with connect(
            f"ws://127.0.0.1:{self._port}/",
            subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
            max_size=None,
            open_timeout=120,
            ping_interval=None,
        ) as ws:
            await ws.send(msgspec.msgpack.encode(camera_message()))
            self.connected += 1
            async for raw in ws:
                if not self.counting or not isinstance(raw, bytes):
                    continue
                now = time.perf_counter()
                self.bytes[k] += len(raw)
                self.frames[k] += 1
                if probe:
                    for m in decode_batch(raw):
                        if (
                            m.get("type") == "SetPositionMessage"
                            and m.get("name") == GOAL
                            and m.get("owner", "") == ""
                        ):
                            self.receipts[k].append((now, tuple(m["position"])))

    def close(self) -> None:
        if self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(timeout=30)


def run_clients(args: argparse.Namespace) -> int:
    """The client process: connect, copy, drag on "go", report on "report" (JSON lines)."""
    from tests.viser_client import ViserClient

    presenter = ViserClient(args.port, f"{PRESENTER_PATH}{args.token}")
    assert presenter.wait_for(lambda: seated(presenter), 120), "no presenter panel"
    students = [ViserClient(args.port) for _ in range(args.copies)]
    for s in students:
        assert s.wait_for(lambda s=s: seated(s), 120), "no student panel"
        s.click("Make my own copy")
    for s in students:
        assert s.wait_for(lambda s=s: own_id(s) is not None, 120), "no copy"
    watchers = Watchers(args.port, args.watchers, args.probes)
    deadline = time.monotonic() + 300
    while watchers.connected < args.watchers and time.monotonic() < deadline:
        time.sleep(0.1)
    say({"ready": watchers.connected})
    expect("go")
    watchers.counting = True
    sent = drag_students(students, args)
    goal = json.loads(expect("report"))
    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline and not all(
        r and np.allclose(r[-1][1][:2], goal) for r in watchers.receipts.values()
    ):
        time.sleep(0.05)
    watchers.counting = False
    say(
        {
            "receipts": {str(k): r for k, r in watchers.receipts.items()},
            "bytes": watchers.bytes,
            "frames": watchers.frames,
            "students_last": [s[-1][1] if s else None for s in sent],
            "students": [own_id(s) for s in students],
            "cpu_s": time.process_time(),
        }
    )
    expect("leave")
    watchers.close()
    for c in (presenter, *students):
        c.close()
    say({"left": True})
    return 0


# --------------------------------------------------------------------------- server


def threads() -> int:
    """Threads of this process."""
    return threading.active_count()


def run(watchers: int, copies: int, args: argparse.Namespace) -> dict[str, Any]:
    """One class: connect, drag, measure, leave; the app is stopped after."""
    steal = StealMeter()
    with contextlib.redirect_stdout(io.StringIO()):
        app = start_app(
            args.scenario,
            port=0,
            print_url=False,
            presenter=True,
            **_room(watchers, copies),
        )
    proc = busy = None
    try:
        controller, room = app.controller, app.classroom
        assert room is not None, "the app runs in presenter mode"
        probe = Probe(controller.slow_planners)
        controller.add_view(probe)
        assert app.wait_idle(60)
        time.sleep(1.0)
        gc.collect()
        alone = (rss_mb(), threads())
        proc = subprocess.Popen(
            [
                sys.executable,
                __file__,
                "--clients",
                f"--port={app.port}",
                f"--token={room.token}",
                f"--watchers={watchers}",
                f"--copies={copies}",
                f"--probes={args.probes}",
                f"--duration={args.events / args.rate + 0.5}",
                f"--student-rate={args.student_rate}",
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
        )
        ready = _read(proc)
        copy_probes = _watch_copies(room, copies)
        _warm_up(app)
        time.sleep(1.0)
        seated_ = (rss_mb(), threads())
        pids = worker_pids(app)
        class0 = _class_frames(app)
        cpu0 = (time.process_time() + cpu_s(pids), time.perf_counter())
        busy = _burner(args.busy)
        _send(proc, "go")
        points = drag_positions(controller.scene, args.events)
        sent = mouse_drag(controller, ("goal",), points, args.rate)
        drag_s = time.perf_counter() - cpu0[1]
        assert app.wait_idle(120)
        if busy is not None:
            busy.kill()
        _send(proc, f"report {json.dumps(list(controller.scene.goal))}")
        report = _read(proc)
        # Read once the class has the last position: the pump sends the class its
        # last window up to a class period after the last frame was drawn.
        class_frames = _class_frames(app)
        if class_frames is not None and class0 is not None:
            class_frames -= class0
        cpu = time.process_time() + cpu_s(pids) - cpu0[0]
        copy_rates = [
            len([t for t in p.fast.values() if cpu0[1] <= t]) / drag_s
            for p in copy_probes
        ]
        left = _leave(proc, room)
        return _summary(
            watchers=watchers,
            copies=copies,
            ready=ready["ready"],
            probe=probe,
            sent=sent,
            points=points,
            report=report,
            drag_s=drag_s,
            memory=(alone, seated_, left),
            cpu=(cpu, report["cpu_s"]),
            copy_rates=copy_rates,
            steal=steal.stop(),
            shared=getattr(room, "encoding", None),
            class_frames=class_frames,
        )
    finally:
        for child in (proc, busy):
            if child is not None and child.poll() is None:
                child.kill()
                child.wait()
        with contextlib.redirect_stdout(io.StringIO()):
            app.stop()


def _burner(duty: float) -> subprocess.Popen | None:
    """Start a process that burns ``duty`` of one core (None for 0)."""
    if duty <= 0:
        return None
    return subprocess.Popen([sys.executable, __file__, "--burn", f"--busy={duty}"])


def burn(duty: float) -> int:
    """Keep one core ``duty`` busy, in 10 ms periods, until killed."""
    while True:
        start = time.perf_counter()
        while time.perf_counter() - start < 0.01 * duty:
            pass
        time.sleep(0.01 * (1.0 - duty))


def _class_frames(app: Any) -> int | None:
    """Frames the class was sent so far (the pump's; an older tree's paced class view's)."""
    frames = getattr(getattr(app.classroom, "encoding", None), "frames", None)
    if frames is None and getattr(app, "class_view", None) is not None:
        frames = app.class_view.frames
    return frames


def _room(watchers: int, copies: int) -> dict[str, Any]:
    """A classroom big enough for the class measured, beyond this machine's defaults
    (to find where it breaks); nothing for an older tree without capacities."""
    if "capacity" not in inspect.signature(start_app).parameters:
        return {}
    from app.classroom.capacity import Capacity

    machine = Capacity.of_machine()
    return {
        "capacity": Capacity(
            seats=max(machine.seats, watchers + copies),
            copies=max(machine.copies, copies),
        )
    }


def _leave(proc: subprocess.Popen, room: Any) -> tuple[float, int]:
    """Everyone leaves; return the server's memory [MB] and threads 5 s after."""
    _send(proc, "leave")
    _read(proc)
    proc.wait(timeout=60)
    deadline = time.monotonic() + 60
    while room.counts()["sessions"] or _seats(room):
        if time.monotonic() > deadline:
            break
        time.sleep(0.1)
    time.sleep(5.0)  # the classroom gives freed memory back 2 to 4 s after
    gc.collect()
    return rss_mb(), threads()


def _seats(room: Any) -> int:
    return sum(room.counts()[m] for m in ("presenter", "watching", "together"))


def _read(proc: subprocess.Popen) -> dict[str, Any]:
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if not line:
        raise RuntimeError(f"the client process stopped ({proc.wait()})")
    return json.loads(line)


def _send(proc: subprocess.Popen, word: str) -> None:
    assert proc.stdin is not None
    proc.stdin.write(word + "\n")
    proc.stdin.flush()


def _watch_copies(room: Any, copies: int) -> list[Probe]:
    deadline = time.monotonic() + 120
    while room.counts()["sessions"] < copies and time.monotonic() < deadline:
        time.sleep(0.05)
    probes = []
    for cid in list(room._seats):
        seat = room.seat(cid)
        if seat is None or seat.private is None:
            continue
        assert seat.private.wait_idle(120)
        probe = Probe(seat.private.slow_planners)
        seat.private.add_view(probe)
        Recorder(seat.private)
        probes.append(probe)
    return probes


def _warm_up(app: Any) -> None:
    controller = app.controller
    scene = controller.scene
    for xy in drag_positions(scene, 20):
        controller.edits.drag_handle(("goal",), xy, "update")
    controller.edits.drag_handle(("goal",), scene.goal, "end")
    assert app.wait_idle(60)


def _summary(**m: Any) -> dict[str, Any]:
    probe, sent, report = m["probe"], m["sent"], m["report"]
    first = sent[0][1]
    frames = len([v for v in probe.fast if v >= first])
    sent_at = {
        (float(x), float(y)): t
        for (t, _), (x, y) in zip(sent, m["points"], strict=True)
    }
    wire, delivered, kb = [], [], []
    for k, receipts in report["receipts"].items():
        mine = [(t, p) for t, p in receipts if (p[0], p[1]) in sent_at]
        wire += [(t - sent_at[(p[0], p[1])]) * 1e3 for t, p in mine]
        delivered.append(len({(p[0], p[1]) for _, p in mine}))
        kb.append(report["bytes"][int(k)] / 1024 / max(1, delivered[-1]))
    every = [
        b / 1024 / max(1, frames) for b in report["bytes"]
    ]  # per presenter frame, every watcher
    shared = m["shared"]
    # The class's frames: what the shared view drew (every presenter frame when the
    # server has no class frame rate).
    class_frames = m["class_frames"] if m["class_frames"] is not None else frames
    return {
        "watchers": m["watchers"],
        "ready": m["ready"],
        "copies": m["copies"],
        "fast": latencies(probe, probe.fast, sent),
        # The presenter's DSB: frames drawn with every slow planner's result, a second.
        "dsb_rate": len([t for t in probe.full.values() if t >= sent[0][0]])
        / m["drag_s"],
        "wire": wire,
        "frames": frames,
        "delivered": float(np.mean(delivered)) / max(1, frames) if delivered else 0.0,
        "class_frames": class_frames,
        "delivered_class": (
            float(np.mean(delivered)) / max(1, class_frames) if delivered else 0.0
        ),
        "rate": float(np.mean(delivered)) / m["drag_s"] if delivered else 0.0,
        "kb_frame": float(np.mean(kb)) if kb else 0.0,
        "kb_presenter_frame": float(np.mean(every)) if every else 0.0,
        "copy_rates": m["copy_rates"],
        "memory": m["memory"],
        "cpu_server": m["cpu"][0],
        "cpu_clients": m["cpu"][1],
        "encoded": (shared.cache.encoded, shared.sent) if shared is not None else None,
        "steal": m["steal"],
    }


# --------------------------------------------------------------------------- report


def pair(values: list[float]) -> str:
    if not values:
        return "n/a"
    return f"{percentile(values, 50):5.0f} / {percentile(values, 95):5.0f}"


HEADER = (
    f"{'watchers':>8s} {'copies':>6s} | {'presenter':>13s} {'DSB/s':>5s} {'to watchers':>13s} | "
    f"{'of frames':>9s} {'of class':>8s} {'fps':>5s} {'KB/frame':>8s} | {'copy fps':>12s} | "
    f"{'MB: alone -> in -> left':>24s} {'threads':>14s} | {'CPU s srv/cli':>13s} "
    f"{'encodes':>13s} {'steal':>5s}"
)


def print_row(s: dict[str, Any]) -> None:
    (m0, t0), (m1, t1), (m2, t2) = s["memory"]
    rates = s["copy_rates"]
    copy = f"{min(rates):4.1f}-{max(rates):4.1f}" if rates else "n/a"
    enc = s["encoded"]
    encodes = f"{enc[0]}/{enc[1]}" if enc else "n/a"
    print(
        f"{s['watchers']:8d} {s['copies']:6d} | {pair(s['fast']):>13s} "
        f"{s['dsb_rate']:5.1f} {pair(s['wire']):>13s} | {s['delivered']:9.0%} {s['delivered_class']:8.0%} "
        f"{s['rate']:5.1f} "
        f"{s['kb_frame']:8.1f} | {copy:>12s} | {m0:6.0f} -> {m1:5.0f} -> {m2:5.0f} "
        f"{t0:4d}/{t1:4d}/{t2:4d} | {s['cpu_server']:6.1f}/{s['cpu_clients']:6.1f} "
        f"{encodes:>13s} {s['steal'] or 0:4.0%}",
        flush=True,
    )


def missed(s: dict[str, Any]) -> list[str]:
    """The hall's targets this class missed (watchers' figures only with watchers)."""
    from app.classroom.wire import BIG_CLASS  # this tree's (not --code's)

    out = []
    if s["watchers"] and s["copies"] <= 10:
        if s["wire"] and percentile(s["wire"], 95) > P95_TARGET_MS:
            out.append("p95 to watchers")
    if s["watchers"] >= BIG_CLASS and not s["copies"]:
        # A hall's frames (a seminar sees every frame of a drag, as many as arrive).
        if s["delivered_class"] < DELIVERED_TARGET or s["rate"] < RATE_TARGET:
            out.append("frames delivered")
        if s["kb_frame"] > KB_TARGET:
            out.append("KB per frame")
    return out


def run_fresh(watchers: int, copies: int, args: argparse.Namespace) -> dict[str, Any]:
    """Run one class in a server process of its own (its memory figures are its own)."""
    return run_one(
        __file__,
        [
            f"--watchers={watchers}",
            f"--copies={copies}",
            f"--events={args.events}",
            f"--rate={args.rate}",
            f"--probes={args.probes}",
            f"--student-rate={args.student_rate}",
            f"--scenario={args.scenario}",
            f"--busy={args.busy}",
        ],
        code=args.code,
    )


CURVE = ((0, 0), (30, 0), (100, 0), (200, 0), (300, 0), (300, 5), (300, 10), (300, 20))


def bytes_per_scenario(args: argparse.Namespace) -> int:
    """Bytes per watcher-frame of a goal drag on every shipped scenario, in a hall."""
    from app.classroom.wire import BIG_CLASS
    from app.server import list_scenarios

    print(
        f"Bytes a watcher receives per class frame while the presenter drags the goal "
        f"({args.events} positions at {args.rate:g} Hz, {BIG_CLASS} watchers: a hall; "
        f"target <= "
        f"{KB_TARGET:g} KB)\n"
    )
    print(f"{'scenario':32s} {'KB/frame':>8s} {'frames/s':>8s} {'to watchers':>13s}")
    worst = 0.0
    for name in list_scenarios():
        s = run_fresh(
            BIG_CLASS, 0, argparse.Namespace(**{**vars(args), "scenario": name})
        )
        worst = max(worst, s["kb_frame"])
        print(
            f"{name:32s} {s['kb_frame']:8.1f} {s['rate']:8.1f} {pair(s['wire']):>13s}",
            flush=True,
        )
    return 1 if (args.strict and worst > KB_TARGET) else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--watchers", type=int, default=300)
    parser.add_argument("--copies", type=int, default=0)
    parser.add_argument("--probes", type=int, default=12, help="watchers that decode")
    parser.add_argument("--events", type=int, default=300, help="presenter events")
    parser.add_argument("--rate", type=float, default=60.0, help="presenter rate [Hz]")
    parser.add_argument("--student-rate", type=float, default=30.0)
    parser.add_argument("--scenario", default=SCENARIO)
    parser.add_argument(
        "--code",
        default=str(ROOT),
        help="the checkout whose app to serve (e.g. a worktree of an older commit)",
    )
    parser.add_argument("--curve", action="store_true", help="classes of 0-300, 0-20")
    parser.add_argument(
        "--every-scenario",
        action="store_true",
        help="bytes per watcher-frame on every shipped scenario (a hall's class each)",
    )
    parser.add_argument("--configs", default="", help="WATCHERS:COPIES,... instead")
    parser.add_argument(
        "--busy",
        type=float,
        default=0.0,
        metavar="SHARE",
        help="a process burns this share of one core during each drag (the class's "
        "client process takes about 0.5 to 0.7 in a full hall: '--configs 0:0 --busy "
        "0.6' is the presenter alone on a machine as busy as the hall's simulator makes it)",
    )
    parser.add_argument("--strict", action="store_true")
    parser.add_argument("--json", metavar="FILE", help="write every measurement")
    parser.add_argument("--clients", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--burn", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--port", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--token", help=argparse.SUPPRESS)
    parser.add_argument("--duration", type=float, default=5.0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.clients:
        return run_clients(args)
    if not 0.0 <= args.busy <= 1.0:
        parser.error("--busy is a share of one core, from 0 to 1")
    if args.burn:
        return burn(args.busy)
    if args.one:
        print(json.dumps(run(args.watchers, args.copies, args)))
        return 0
    if args.every_scenario:
        return bytes_per_scenario(args)
    configs = [(args.watchers, args.copies)]
    if args.configs:
        configs = [parse_config(text) for text in args.configs.split(",")]
    elif args.curve:
        configs = list(CURVE)
    print(
        f"A lecture hall on {args.scenario}: the presenter drags the goal through "
        f"{args.events} positions at {args.rate:g} Hz; copies drag at "
        f"{args.student_rate:g} Hz; {args.probes} watchers decode and time (p50 / p95 ms)"
    )
    print(
        f"load average {', '.join(f'{x:.2f}' for x in os.getloadavg())} on "
        f"{os.cpu_count()} CPUs; presenter budget {FAST_BUDGET_MS:g} ms; targets: "
        f"to watchers p95 <= {P95_TARGET_MS:g} ms, >= {DELIVERED_TARGET:.0%} delivered "
        f"at >= {RATE_TARGET:g} fps, <= {KB_TARGET:g} KB per watcher-frame"
    )
    if args.busy > 0:
        print(f"a process burns {args.busy:g} of a core during each drag (--busy)")
    print()
    print(HEADER)
    print("-" * len(HEADER))
    results, misses = [], []
    for watchers, copies in configs:
        s = run_fresh(watchers, copies, args)
        results.append(s)
        print_row(s)
        misses += missed(s)
    if misses:
        print(f"\nmissed: {', '.join(sorted(set(misses)))}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return 1 if (misses and args.strict) else 0


if __name__ == "__main__":
    sys.exit(main())
