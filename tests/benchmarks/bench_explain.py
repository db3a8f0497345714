"""How long Explain mode takes to explain each method.

Run: ``python tests/benchmarks/bench_explain.py [--runs 5] [--scenario NAME ...] [--range R]
[--student 8,16,24,32] [--big] [--peak]``

For every shipped scenario (or, with ``--student``, the seeded student layouts of
``bench_student.py``; with ``--big``, the 10,000-vertex circle and the 500-triangle room
of ``bench_big.py``) and method (expansion of obstacle 1, VG, SVG, DSB):

``first``
    :func:`planners.explain` from the scene (planning included, cold: no memo) until
    its first step is made: how long a lecturer waits after choosing a method or
    releasing the mouse. p50 over ``--runs`` repeats after one warm-up.
``step``
    making one more step (the middle one; steps are made when shown): how long a click
    on *Next* takes.
``peak``
    with ``--peak`` (always with ``--big``), each explanation once more in a fresh
    process: its peak resident memory, the interpreter and the planning included.

There is no budget: an explanation is computed on demand in its own thread (never on
the drag path, never while dragging). Exit status 0.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import os
import resource
import statistics
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
for path in (ROOT, HERE):
    if str(path) not in sys.path:  # run as a script from anywhere
        sys.path.insert(0, str(path))

from planners import PlanOptions, Scene, load_scene  # noqa: E402
from planners.explain import METHODS, explain  # noqa: E402


def _scenes(args: argparse.Namespace) -> list[tuple[str, tuple[str, str]]]:
    """(name, how to make the scene: see :func:`_make`) for every scene asked for."""
    if args.big:
        return [
            ("circle, 10,000 vertices", ("circle", "")),
            ("500 triangles", ("triangles", "")),
        ]
    if args.student:
        return [
            (f"student, {n} obstacles", ("student", n)) for n in args.student.split(",")
        ]
    files = sorted((ROOT / "static_scenarios").glob("*.json"))
    if args.scenario:
        files = [f for f in files if any(s in f.stem for s in args.scenario)]
    return [(f.stem, ("file", str(f))) for f in files]


def _make(spec: tuple[str, str]) -> Scene:
    """Make a scene from its spec (picklable: a fresh process makes its own)."""
    kind, arg = spec
    if kind == "circle":
        from bench_big import circle_scene

        return load_scene(circle_scene())
    if kind == "triangles":
        from bench_big import triangles_scene

        return load_scene(triangles_scene())
    if kind == "student":
        from bench_student import student_layout

        return load_scene(student_layout(int(arg)))
    return load_scene(arg)


def _once(scene: Scene, method: str, options: PlanOptions) -> tuple[float, float, int]:
    """Explain and make the first step, then the middle one: (ms, ms, steps)."""
    t0 = time.perf_counter()
    explanation = explain(scene, method, options)
    explanation.step(0)
    t1 = time.perf_counter()
    count = len(explanation.steps)
    explanation.step(count // 2)
    return (t1 - t0) * 1e3, (time.perf_counter() - t1) * 1e3, count


def _peak_child(
    spec: tuple[str, str], method: str, options: PlanOptions, out: Any
) -> None:
    _once(_make(spec), method, options)
    out.send(_high_water_mb())


def _high_water_mb() -> float:
    """This process's peak resident memory [MB]: VmHWM, which starts afresh with the
    process image (``ru_maxrss`` carries the parent's peak over a fork and exec)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return float(line.split()[1]) / 1024.0
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _peak(spec: tuple[str, str], method: str, options: PlanOptions) -> float:
    """Peak resident memory [MB] of one explanation in a fresh process (spawned: it
    shares no pages with this one, so its peak is its own); NaN if it failed."""
    context = multiprocessing.get_context("spawn")
    receive, send = context.Pipe(duplex=False)
    child = context.Process(target=_peak_child, args=(spec, method, options, send))
    child.start()
    send.close()  # the child's end only: a child that dies closes the pipe
    try:
        peak = float(receive.recv())
    except EOFError:
        peak = math.nan
    child.join()
    return peak


def _cell(
    spec: tuple[str, str], method: str, options: PlanOptions, runs: int, peak: bool
) -> str:
    scene = _make(spec)
    if runs > 1:
        _once(scene, method, options)  # warm-up (imports, first calls)
    firsts, steps_ms, count = [], [], 0
    for _ in range(runs):
        first, step, count = _once(scene, method, options)
        firsts.append(first)
        steps_ms.append(step)
    cell = f"{statistics.median(firsts):7.0f} {statistics.median(steps_ms):6.0f} ({count:5d})"
    if peak:
        cell += f" {_peak(spec, method, options):6.0f}"
    return cell


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="repeats (default 5)")
    parser.add_argument("--scenario", action="append", help="scenario file stem")
    parser.add_argument("--range", type=float, default=None, help="sensor range R [m]")
    parser.add_argument("--student", help="student layouts, e.g. 8,16,24,32")
    parser.add_argument(
        "--big", action="store_true", help="the two big scenes (one run)"
    )
    parser.add_argument(
        "--peak", action="store_true", help="peak memory per explanation"
    )
    args = parser.parse_args(argv)
    runs = 1 if args.big else args.runs
    peak = args.peak or args.big
    options = PlanOptions(sensor_range=args.range)
    print(
        f"load average: {', '.join(f'{x:.2f}' for x in os.getloadavg())} on {os.cpu_count()} CPUs"
    )
    head = "first ms step ms (steps)" + (" peak MB" if peak else "")
    width = 36 if peak else 29
    print(f"{'scene':26s} " + " ".join(f"{m + ': ' + head:>{width}s}" for m in METHODS))
    for name, spec in _scenes(args):
        cells = [_cell(spec, method, options, runs, peak) for method in METHODS]
        print(
            f"{name[:26]:26s} " + " ".join(f"{c:>{width}s}" for c in cells), flush=True
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
