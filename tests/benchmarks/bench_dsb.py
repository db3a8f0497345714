"""How long a whole DSB (TangentBug) run takes on each lecture scenario.

Run: ``python tests/benchmarks/bench_dsb.py [--runs 30] [--range R ...] [--scenario NAME ...]``

For every ``static_scenarios/*.json`` (as shipped) and each sensor range (default: the
scenario's own), two timings over ``--runs`` repeats after two warm-ups, every cache of
the planners cleared before each repeat:

- ``dsb``: :func:`planners.plan_tangent_bug` alone on a configuration space built once
  (the expansion is shared with the VG and SVG, so it is not the DSB's cost);
- ``all``: :func:`planners.plan_all` with VG, SVG and DSB from the scene (expansion
  included): what the app recomputes after an edit.

It prints p50 and p95 (wall clock) with the run's status, steps and events, and checks
The budget (docs/benchmarks.md): a whole run with DSB included at most 50 ms (p95) on every lecture
scenario. Exit status 0 unless ``--strict`` and a budget is missed. The timings are of
this machine under its current load (the script prints the load average); on a shared
machine run it twice.

``--big`` times DSB alone on borders of thousands of vertices instead,
each in a fresh process (``spawn``): the circle of 10,000 vertices of ``bench_big.py``
(the robot rounds it in goal-seeking mode, one decision per corner) and a hollow C of
10,000 vertices (:func:`hollow_c_scene`: the robot starts inside, follows the inner
border round to the opening, seeing hundreds of edges at once). It prints the wall
time, the decisions (:attr:`BugTrace.decisions`), the sensor readings (goal-seeking
decisions computed, :func:`planners.bug._seek._decide`, and full views swept,
:func:`planners.bug.sensor._sweep`) and the child's peak resident memory.
"""

from __future__ import annotations

import argparse
import functools
import gc
import math
import multiprocessing
import os
import resource
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

import planners  # noqa: E402
from planners import PlanOptions, load_scene, plan_all, plan_tangent_bug  # noqa: E402

BUDGET_DSB_MS = 50.0
BIG_VERTICES = 10_000


def hollow_c_scene(vertices: int = BIG_VERTICES) -> dict[str, object]:
    """A thick C of ``vertices`` vertices (radii 9 and 10 m) open to the left; start inside.

    The goal lies to the right, outside: the robot meets the inner border at a local
    minimum and follows it round to the opening (about 60 m along a finely drawn arc).
    """
    gap = math.radians(40.0)
    angles = [
        math.pi + gap / 2 + (2 * math.pi - gap) * i / (vertices // 2 - 1)
        for i in range(vertices // 2)
    ]
    outer = [[20 + 10 * math.cos(a), 20 + 10 * math.sin(a)] for a in angles]
    inner = [[20 + 9 * math.cos(a), 20 + 9 * math.sin(a)] for a in reversed(angles)]
    return {
        "format": 1,
        "name": f"hollow C of {vertices} vertices",
        "boundary": [[0, 0], [40, 0], [40, 40], [0, 40]],
        "obstacles": [outer + inner],
        "start": [20.0, 20.0],
        "goal": [37.0, 20.5],
        "robot": {"radius": 0.3},
        "expansion": "disk",
        "sensor_range": 2.0,
    }


def _big_scenes() -> dict[str, Callable[[], dict[str, object]]]:
    from tests.benchmarks.bench_big import circle_scene

    return {"circle": circle_scene, "hollow_c": hollow_c_scene}


def _big_child(name: str, rule: str, out: object) -> None:
    """Run DSB once on a big scene in this (fresh) process; send its figures to ``out``."""
    from planners.bug import _seek as bug_seek
    from planners.bug import sensor

    counts = {"decide": 0, "sweep": 0}

    def counted(module: object, attr: str, key: str) -> None:
        inner = getattr(module, attr)

        def wrapper(*args: object, **kwargs: object) -> object:
            counts[key] += 1
            return inner(*args, **kwargs)

        setattr(module, attr, wrapper)

    counted(bug_seek, "_decide", "decide")
    counted(sensor, "_sweep", "sweep")
    scene = load_scene(_big_scenes()[name]())
    space = plan_all(scene, ())["cspace"]
    t0 = time.perf_counter()
    trace = plan_tangent_bug(space, scene.start, scene.goal, scene.sensor_range, rule)
    ms = (time.perf_counter() - t0) * 1e3
    out.send(  # type: ignore[attr-defined]
        {
            "ms": ms,
            "status": trace.status,
            "length": trace.length,
            "decisions": len(trace.decisions),
            "steps": trace.steps,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
            **counts,
        }
    )


def big(rule: str) -> None:
    """Time DSB alone on each big scene in a fresh process and print one line each."""
    ctx = multiprocessing.get_context("spawn")
    print(f"DSB ({rule}) on big borders, one fresh process each")
    head = f"{'scene':<10} {'time s':>7} {'status':>8} {'length':>8} {'decisions':>9} {'readings':>8} {'sweeps':>7} {'peak MB':>8}"
    print(head)
    print("-" * len(head))
    for name in _big_scenes():
        receive, send = ctx.Pipe(duplex=False)
        child = ctx.Process(target=_big_child, args=(name, rule, send))
        child.start()
        r = receive.recv() if receive.poll(300) else None
        child.join(5)
        if child.is_alive():
            child.kill()
        if r is None:
            print(f"{name:<10} no answer within 300 s")
            continue
        length = "-" if r["length"] is None else f"{r['length']:.3f}"
        print(
            f"{name:<10} {r['ms'] / 1e3:>7.2f} {r['status']:>8} {length:>8} {r['decisions']:>9}"
            f" {r['decide']:>8} {r['sweep']:>7} {r['peak_mb']:>8.0f}"
        )


def clear_caches(*spaces: object) -> None:
    """Forget whatever a planner could reuse from an earlier run.

    What the planners derive from a configuration space (the border model, the
    visibility matrix) is kept on it (``ConfigurationSpace.derive``); for ``spaces``
    reused across runs that is forgotten. No planner module keeps a cache of its own
    (``tests/test_purity.py``); should one appear, it is cleared here too.
    """
    for space in spaces:
        vars(space).pop("_derived", None)
    for name, module in list(sys.modules.items()):
        if module is None or not (name == "planners" or name.startswith("planners.")):
            continue
        for value in vars(module).values():
            clear = getattr(value, "cache_clear", None)
            if callable(clear) and getattr(value, "__module__", None) == name:
                clear()


def percentile(values: list[float], q: float) -> float:
    """The q-th percentile (0-100) by linear interpolation."""
    ordered = sorted(values)
    if len(ordered) == 1:
        return ordered[0]
    pos = (len(ordered) - 1) * q / 100.0
    lo = math.floor(pos)
    hi = min(lo + 1, len(ordered) - 1)
    return ordered[lo] + (ordered[hi] - ordered[lo]) * (pos - lo)


def timed(fn: Callable[[], object], runs: int, *spaces: object) -> list[float]:
    """Wall times [ms] of ``runs`` calls, caches cleared before each, after 2 warm-ups.

    ``spaces``: configuration spaces that ``fn`` reuses (see :func:`clear_caches`).
    """
    for _ in range(2):
        clear_caches(*spaces)
        fn()
    times = []
    gc_was = gc.isenabled()
    gc.disable()
    try:
        for _ in range(runs):
            clear_caches(*spaces)
            t0 = time.perf_counter()
            fn()
            times.append((time.perf_counter() - t0) * 1e3)
    finally:
        if gc_was:
            gc.enable()
    return times


def main(argv: list[str] | None = None) -> int:
    """Time DSB on the lecture scenarios and print the table; return the exit status."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument(
        "--runs", type=int, default=30, help="timed repeats per case (default 30)"
    )
    parser.add_argument(
        "--range",
        dest="ranges",
        type=float,
        action="append",
        help="sensor range(s) to time; default: each scenario's own (inf allowed)",
    )
    parser.add_argument(
        "--scenario",
        action="append",
        help="only scenarios whose file name contains this",
    )
    parser.add_argument(
        "--rule", default="tangent_bug", choices=("tangent_bug", "chapter")
    )
    parser.add_argument(
        "--strict", action="store_true", help="exit 1 when a budget is missed"
    )
    parser.add_argument(
        "--big",
        action="store_true",
        help="time DSB on borders of 10,000 vertices instead (see the docstring)",
    )
    args = parser.parse_args(argv)
    if args.big:
        big(args.rule)
        return 0

    paths = sorted((ROOT / "static_scenarios").glob("*.json"))
    if args.scenario:
        paths = [p for p in paths if any(s in p.name for s in args.scenario)]
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"DSB ({args.rule}) on the lecture scenarios, {args.runs} runs each; load average {load:.2f}, {os.cpu_count()} CPUs"
    )
    head = f"{'scenario':<28} {'R':>6} {'status':>11} {'steps':>5} {'events':<22} {'dsb p50':>8} {'dsb p95':>8} {'all p50':>8} {'all p95':>8}"
    print(head)
    print("-" * len(head))
    missed = []
    for path in paths:
        scene = load_scene(path)
        ranges = args.ranges or [scene.sensor_range]
        space = plan_all(scene, ())["cspace"]
        for sensor_range in ranges:
            options = PlanOptions(sensor_range=sensor_range, leave_rule=args.rule)
            trace = plan_tangent_bug(
                space, scene.start, scene.goal, sensor_range, args.rule
            )
            dsb = timed(
                functools.partial(
                    plan_tangent_bug,
                    space,
                    scene.start,
                    scene.goal,
                    sensor_range,
                    args.rule,
                ),
                args.runs,
                space,
            )
            both = timed(
                functools.partial(plan_all, scene, ("vg", "svg", "dsb"), options),
                args.runs,
            )
            events = " ".join(e.label for e in trace.events)
            events = events if len(events) <= 22 else events[:19] + "..."
            print(
                f"{path.stem[:28]:<28} {sensor_range:>6g} {trace.status:>11} {trace.steps:>5} {events:<22} "
                f"{percentile(dsb, 50):>8.2f} {percentile(dsb, 95):>8.2f} {percentile(both, 50):>8.2f} {percentile(both, 95):>8.2f}"
            )
            if percentile(both, 95) > BUDGET_DSB_MS:
                missed.append(
                    f"{path.stem} R={sensor_range:g}: all planners p95 {percentile(both, 95):.1f} ms"
                )
    print()
    print(
        f"budget: expansion + VG + SVG + DSB p95 <= {BUDGET_DSB_MS:g} ms on every lecture scenario"
    )
    print("  met" if not missed else "  MISSED: " + "; ".join(missed))
    print(f"planners: {', '.join(planners.PLANNERS)}; times in ms, wall clock")
    return 1 if (missed and args.strict) else 0


if __name__ == "__main__":
    sys.exit(main())
