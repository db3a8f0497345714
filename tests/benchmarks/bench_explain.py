"""How long Explain mode takes to explain each method on each lecture scenario (issue 13).

Run: ``python tests/benchmarks/bench_explain.py [--runs 5] [--scenario NAME ...] [--range R]``

For every shipped scenario and method (expansion of obstacle 1, VG, SVG, DSB), the time of
:func:`planners.explain` from the scene (planning included, cold: no memo), p50 and max
over ``--runs`` repeats after one warm-up, with the number of steps. There is no budget:
an explanation is computed on demand in its own thread (never on the drag path, never
while dragging), so this is how long a lecturer waits after choosing a method or
releasing the mouse. Exit status 0.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from planners import PlanOptions, load_scene  # noqa: E402
from planners.explain import METHODS, explain  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="repeats (default 5)")
    parser.add_argument("--scenario", action="append", help="scenario file stem")
    parser.add_argument("--range", type=float, default=None, help="sensor range R [m]")
    args = parser.parse_args(argv)
    files = sorted((ROOT / "static_scenarios").glob("*.json"))
    if args.scenario:
        files = [f for f in files if any(s in f.stem for s in args.scenario)]
    options = PlanOptions(sensor_range=args.range)
    print(
        f"load average: {', '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} CPUs"
    )
    print(f"{'scenario':26s} " + " ".join(f"{m + ' ms (steps)':>24s}" for m in METHODS))
    for path in files:
        scene = load_scene(path)
        cells = []
        for method in METHODS:
            explain(scene, method, options)  # warm-up (imports, first calls)
            times, steps = [], 0
            for _ in range(args.runs):
                t0 = time.perf_counter()
                steps = len(explain(scene, method, options).steps)
                times.append((time.perf_counter() - t0) * 1e3)
            cells.append(
                f"{statistics.median(times):7.0f} / {max(times):5.0f} ({steps:3d})"
            )
        print(f"{path.stem[:26]:26s} " + " ".join(f"{c:>24s}" for c in cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
