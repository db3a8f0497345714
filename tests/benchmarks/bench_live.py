"""How long the live DSB robot takes per control period, on every scenario.

Run: ``python tests/benchmarks/bench_live.py [--runs 3] [--scenario NAME ...]``

For every ``static_scenarios/*.json`` (as shipped, moving obstacles moving), the whole
:func:`planners.bug.live.run_live` loop is timed ``--runs`` times with a fresh memo each
time. It prints the steps, the simulated duration, the wall time of the run, the mean
and the largest time of one step (the app's live thread must stay well under
dt = 50 ms per step to keep up in real time), and the status. The figures are of this
machine under its current load (printed); on a shared machine run it twice.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from planners import Memo, load_scene  # noqa: E402
from planners.bug.live import LiveOptions, live_start, live_step  # noqa: E402
from planners.scene import scene_at  # noqa: E402


def time_run(path: Path) -> tuple[int, float, float, float, str]:
    """Drive one scenario to its end: (steps, simulated s, wall s, max step ms, status)."""
    scene = load_scene(path)
    options, memo = LiveOptions(), Memo()
    state = live_start(scene)
    worst, steps = 0.0, 0
    t0 = time.perf_counter()
    while state.t < 300.0:
        t1 = time.perf_counter()
        state = live_step(state, scene_at(scene, state.t), options, memo)
        worst = max(worst, time.perf_counter() - t1)
        steps += 1
        if state.status == "reached" or (
            state.status == "waiting" and not scene.motions
        ):
            break
    return steps, state.t, time.perf_counter() - t0, worst * 1e3, state.status


def main(argv: list[str] | None = None) -> int:
    """Time every scenario and print one line each."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--scenario", nargs="*", default=None)
    args = parser.parse_args(argv)
    paths = sorted((ROOT / "static_scenarios").glob("*.json"))
    if args.scenario:
        paths = [p for p in paths if any(s in p.stem for s in args.scenario)]
    print(f"load average {os.getloadavg()[0]:.2f}; dt = {LiveOptions().dt} s")
    print(f"{'scenario':28} steps  sim[s]  wall[s]  mean[ms]  max[ms]  status")
    for path in paths:
        best = min((time_run(path) for _ in range(args.runs)), key=lambda r: r[2])
        steps, sim, wall, worst, status = best
        print(
            f"{path.stem:28} {steps:5d} {sim:7.2f} {wall:8.2f} "
            f"{1e3 * wall / steps:9.2f} {worst:8.2f}  {status}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
