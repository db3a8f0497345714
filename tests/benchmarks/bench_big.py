"""Big scenes: time and peak memory of VG + SVG + DSB on thousands of vertices.

Run: ``.venv/bin/python tests/benchmarks/bench_big.py [--scene circle|triangles|all]
[--planners vg,svg,dsb] [--timeout S]``.

Each scene runs in a fresh child process (``multiprocessing`` with ``spawn``), so that
nothing cached answers and the child's peak resident memory (``ru_maxrss``) is the
planning's, on top of an interpreter that imported the project. By default the planners
run together in one ``plan_all`` (as the CLI does: VG and SVG share the configuration
space, the SVG reads the VG's vertex visibility); ``--separately`` gives each planner
its own process. The child reports

- the wall time of ``plan_all`` (expansion included) and each planner's ``ms``;
- ``peak MB``: the child's ``ru_maxrss`` at the end, and ``base MB`` the same just before
  planning (imports and the scene), so ``peak - base`` is what planning added;
- each result's status, length, nodes and edges.

A child that runs past ``--timeout`` seconds is killed and reported as such. The scenes are
deterministic (:func:`circle_scene`, :func:`triangles_scene`).
"""

from __future__ import annotations

import argparse
import math
import resource
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
for path in (str(ROOT), str(HERE)):
    if path not in sys.path:
        sys.path.insert(0, path)

from clock import in_fresh_process  # noqa: E402 - after the path set-up above

from planners import plan_all  # noqa: E402
from planners.allocator import keep_freed_memory  # noqa: E402
from planners.scene import load_scene  # noqa: E402

TARGET_S = 5.0
TARGET_MB = 1024.0


def circle_scene(vertices: int = 10_000) -> dict[str, Any]:
    """One circle of ``vertices`` vertices (radius 10 m) in a 40 m room, start and goal across it."""
    angles = np.linspace(0.0, 2.0 * math.pi, vertices, endpoint=False)
    ring = np.column_stack([20.0 + 10.0 * np.cos(angles), 20.0 + 10.0 * np.sin(angles)])
    return {
        "format": 1,
        "name": f"circle of {vertices} vertices",
        "boundary": [[0, 0], [40, 0], [40, 40], [0, 40]],
        "obstacles": [ring.tolist()],
        "start": [3.0, 20.0],
        "goal": [37.0, 20.5],
        "robot": {"radius": 0.3},
        "expansion": "disk",
        "sensor_range": 2.0,
    }


def triangles_scene(count: int = 500, seed: int = 5) -> dict[str, Any]:
    """``count`` random triangles (sides about 1 to 3 m) in a 100 m room; they may overlap."""
    rng = np.random.default_rng(seed)
    triangles = []
    while len(triangles) < count:
        center = rng.uniform(4.0, 96.0, 2)
        if (
            np.hypot(*(center - (2.0, 2.0))) < 5
            or np.hypot(*(center - (98.0, 98.0))) < 5
        ):
            continue
        angles = rng.uniform(0, 2 * math.pi) + np.sort(rng.uniform(0, 2 * math.pi, 3))
        radii = rng.uniform(0.6, 1.8, 3)
        ring = center + radii[:, None] * np.column_stack(
            [np.cos(angles), np.sin(angles)]
        )
        if abs(np.cross(ring[1] - ring[0], ring[2] - ring[0])) < 0.3:
            continue
        triangles.append(ring.tolist())
    return {
        "format": 1,
        "name": f"{count} triangles in a 100 m room",
        "boundary": [[0, 0], [100, 0], [100, 100], [0, 100]],
        "obstacles": triangles,
        "start": [2.0, 2.0],
        "goal": [98.0, 98.0],
        "robot": {"radius": 0.3},
        "expansion": "disk",
        "sensor_range": 2.0,
    }


SCENES = {"circle": circle_scene, "triangles": triangles_scene}


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _child(name: str, planners: str, out: Any) -> None:
    keep_freed_memory()  # as the CLI and the app run
    scene = load_scene(SCENES[name]())
    base = _rss_mb()
    t0 = time.perf_counter()
    results = plan_all(scene, tuple(planners.split(",")))
    ms = (time.perf_counter() - t0) * 1e3
    out.send(
        {
            "ms": ms,
            "base_mb": base,
            "peak_mb": _rss_mb(),
            "each": {p: _summary(results[p]) for p in planners.split(",")},
        }
    )


def _summary(result: Any) -> dict[str, Any]:
    return {
        "ms": result.ms,
        "status": result.status,
        "length": result.length,
        "nodes": getattr(result, "nodes", None),
        "edges": getattr(result, "edges", None),
    }


def measure(name: str, planners: str, timeout: float) -> dict[str, Any]:
    """Run planners (comma-separated) on one scene in a fresh process; return its report."""
    return in_fresh_process(_child, (name, planners), timeout)


def _lines(name: str, planners: str, r: dict[str, Any]) -> list[str]:
    if "error" in r:
        return [f"{name:<10} {planners:<12} {r['error']}"]
    lines = [
        f"{name:<10} {planners:<12} {r['ms'] / 1e3:8.2f} s  peak {r['peak_mb']:7.0f} MB"
        f" (base {r['base_mb']:.0f})"
    ]
    for planner, e in r["each"].items():
        length = "-" if e["length"] is None else f"{e['length']:.3f}"
        graph = f"  {e['nodes']} nodes {e['edges']} edges" if e["nodes"] else ""
        lines.append(
            f"{'':<10}   {planner:<10} {e['ms'] / 1e3:8.2f} s (with the shared"
            f" expansion)  {e['status']:<11} length {length}{graph}"
        )
    return lines


def main() -> int:
    """Run the chosen scenes, print each planner's figures, then the targets."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", choices=(*SCENES, "all"), default="all")
    parser.add_argument("--planners", default="vg,svg,dsb")
    parser.add_argument(
        "--separately",
        action="store_true",
        help="one process per planner (each one's own peak memory) instead of all in one",
    )
    parser.add_argument("--timeout", type=float, default=120.0)
    args = parser.parse_args()
    names = list(SCENES) if args.scene == "all" else [args.scene]
    groups = args.planners.split(",") if args.separately else [args.planners]
    verdicts = []
    for name in names:
        total_s, peak = 0.0, 0.0
        for group in groups:
            r = measure(name, group, args.timeout)
            print("\n".join(_lines(name, group, r)), flush=True)
            total_s += r.get("ms", math.inf) / 1e3
            peak = max(peak, r.get("peak_mb", math.inf))
        ok = total_s < TARGET_S and peak < TARGET_MB
        verdicts.append(
            f"{'PASS' if ok else 'FAIL'}  {name}: {args.planners} {total_s:.2f} s"
            f" (target < {TARGET_S:g} s), peak {peak:.0f} MB (target < {TARGET_MB:g} MB)"
        )
    print("\n".join(verdicts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
