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
DESIGN.md's budget: a whole run with DSB included at most 50 ms (p95) on every lecture
scenario. Exit status 0 unless ``--strict`` and a budget is missed. The timings are of
this machine under its current load (the script prints the load average); on a shared
machine run it twice.
"""

from __future__ import annotations

import argparse
import functools
import gc
import math
import os
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
    args = parser.parse_args(argv)

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
        f"budget (DESIGN.md): expansion + VG + SVG + DSB p95 <= {BUDGET_DSB_MS:g} ms on every lecture scenario"
    )
    print("  met" if not missed else "  MISSED: " + "; ".join(missed))
    print(f"planners: {', '.join(planners.PLANNERS)}; times in ms, wall clock")
    return 1 if (missed and args.strict) else 0


if __name__ == "__main__":
    sys.exit(main())
