"""Starting an app: its planner process forked from the template, or a fresh interpreter.

Usage::

    .venv/bin/python tests/benchmarks/bench_start.py [--rounds 4] [--scenario 01_two_convex]

Each round starts the app (``start_app``) until its first frame with every planner
(``wait_idle``) and stops it, twice: once with the planner process forked from the
template (``app.session.lanes.start_worker``, what the app does on Linux), once started
from nothing (``spawn_worker``, what it does elsewhere), in alternating order. CPU is the
whole machine's (``/proc/stat``: the app, its planner process and the template), so run
it on an otherwise idle machine. The first app of the process, which starts the
template, is reported on its own line (cold); the rounds after it reuse the template,
which an idle worker keeps running throughout (as a running app's worker does).

The calibration line is a fixed piece of pure-Python work timed in the same run
(:func:`clock.spread`): compare runs through it, and the two ways through their ratio.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import io
import statistics
import sys
import time
from pathlib import Path

sys.path[:0] = [str(Path(__file__).parent), str(Path(__file__).resolve().parents[2])]

from clock import StealMeter, busy_cpu_s, spread  # noqa: E402 - found next to this file

from app import start_app  # noqa: E402
from app.session import lanes  # noqa: E402
from app.session.scheduler import default_plan  # noqa: E402


def busy() -> float:
    """The machine's busy CPU seconds (:func:`clock.busy_cpu_s`); this needs /proc/stat."""
    seconds = busy_cpu_s()
    if seconds is None:
        raise SystemExit("bench_start.py measures CPU from /proc/stat (Linux)")
    return seconds


def one_start(scenario: str) -> tuple[float, float]:
    """Start the app until its first full frame, stop it; return (wall s, CPU s)."""
    cpu, wall = busy(), time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        app = start_app(scenario, port=0, print_url=False)
    try:
        assert app.wait_idle(120), "the app did not draw its first frame"
        return time.perf_counter() - wall, busy() - cpu
    finally:
        app.stop()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--scenario", default="01_two_convex")
    args = parser.parse_args(argv)
    p50, p95 = spread()
    print(f"calibration: 12 ms of fixed work took {p50:.1f} / {p95:.1f} ms (p50 / p95)")
    steal = StealMeter()
    forked = lanes.start_worker
    cold = one_start(args.scenario)
    print(f"first app (starts the template): {cold[0]:.2f} s wall, {cold[1]:.2f} s CPU")
    # An idle worker keeps the template from leaving during the fresh rounds (it leaves
    # LINGER_S after its last worker), as a running app's own worker does.
    keeper = lanes.ProcessLane(functools.partial(default_plan, which=("vg",)))
    times: dict[str, list[tuple[float, float]]] = {"forked": [], "fresh": []}
    for k in range(args.rounds):
        order = ("forked", "fresh") if k % 2 == 0 else ("fresh", "forked")
        for way in order:
            lanes.start_worker = forked if way == "forked" else lanes.spawn_worker
            try:
                times[way].append(one_start(args.scenario))
            finally:
                lanes.start_worker = forked
            time.sleep(0.5)  # the stopped app's processes leave
    print(f"{'planner process':>16s} {'wall s (median)':>16s} {'CPU s (median)':>15s}")
    medians = {}
    for way, rows in times.items():
        wall = statistics.median(w for w, _ in rows)
        cpu = statistics.median(c for _, c in rows)
        medians[way] = (wall, cpu)
        print(f"{way:>16s} {wall:16.2f} {cpu:15.2f}")
    (fw, fc), (sw, sc) = medians["forked"], medians["fresh"]
    print(f"fresh / forked: {sw / fw:.1f}x the wall, {sc / fc:.1f}x the CPU")
    print(f"steal: {(steal.stop() or 0.0):.0%}")
    keeper.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
