"""A warehouse occupancy map: import (read + trace + simplify) and VG + SVG + DSB on it.

Run: ``.venv/bin/python tests/benchmarks/bench_maps.py [--side 50] [--cell 0.03]
[--specks 2e-4] [--planners vg,svg,dsb|none] [--timeout S] [--profile]``.

The map is generated (deterministic): a ``side`` x ``side`` metre warehouse at ``cell``
metres a cell (50 m at 3 cm: 1,667 x 1,667 = 2.8 million cells), its outer walls and
two inner walls with doors, rows of shelves (racks 1 m deep, 8 to 12 m long, aisles
3 m wide) with their posts, as a scan leaves them: ragged wall faces, occupied specks
in the aisles (``--specks``, a share of the free cells: a few hundred by default), free
specks in the walls, unknown space outside the building and in
the racks' shadows. It is written as a binary PGM with its YAML file, as map_saver
writes maps.

Each measure runs in a fresh child process (``multiprocessing`` with ``spawn``), so
nothing cached in the process answers (the compiled loops come from numba's cache on
disk, as in the app). The child reports

- the wall time of reading the map (YAML, PGM, map_server's reading of each pixel), of
  choosing the endpoints (:func:`planners.maps.default_endpoints`, which traces the
  largest free space once), of :func:`planners.maps.scene_from_map` (trace + simplify),
  and of :func:`planners.load_scene` on the result;
- the vertex counts: the exact trace's (tolerance 0) and the simplified scene's;
- ``plan_all`` on the imported scene: the wall time and each planner's ``ms``;
- peak memory: ``ru_maxrss`` after the import and after planning, and before either
  (the interpreter with the project imported). The map is generated in a process of
  its own: a child's ``ru_maxrss`` starts from its parent's.

Before and after, the machine's own speed: :func:`clock.spread` (a fixed 12 ms piece of
work timed 150 times), so figures from two runs can be compared as ratios to it. With
``--profile`` the child runs under cProfile and prints the 25 most expensive functions
of planning (cumulative time).
"""

from __future__ import annotations

import argparse
import cProfile
import io
import math
import multiprocessing
import pstats
import resource
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
for path in (str(ROOT), str(HERE)):
    if path not in sys.path:
        sys.path.insert(0, path)

from clock import in_fresh_process, spread  # noqa: E402

from planners.maps import FREE, OCCUPIED, UNKNOWN  # noqa: E402

TARGET_S = 5.0
TARGET_MB = 1024.0


def warehouse(
    side: float = 50.0, cell: float = 0.03, specks: float = 2e-4, seed: int = 7
) -> np.ndarray:
    """The warehouse's grid of states, row 0 at the bottom.

    ``specks``: the share of free cells a scan leaves occupied, one by one.
    """
    rng = np.random.default_rng(seed)
    n = math.ceil(side / cell)
    grid = np.full((n, n), UNKNOWN, np.uint8)

    def box(x0: float, y0: float, x1: float, y1: float, state: int) -> None:
        r0, r1 = round(y0 / cell), round(y1 / cell)
        c0, c1 = round(x0 / cell), round(x1 / cell)
        grid[max(r0, 0) : max(r1, 0), max(c0, 0) : max(c1, 0)] = state

    wall = 0.2
    box(1.0, 1.0, side - 1.0, side - 1.0, OCCUPIED)
    box(1.0 + wall, 1.0 + wall, side - 1.0 - wall, side - 1.0 - wall, FREE)
    # Two inner walls with doors.
    box(side / 2, 1.0, side / 2 + wall, side - 1.0, OCCUPIED)
    for y in (8.0, 24.0, 40.0):
        box(side / 2, y, side / 2 + wall, y + 2.0, FREE)
    box(1.0, side * 0.7, side / 2, side * 0.7 + wall, OCCUPIED)
    box(5.0, side * 0.7, 8.0, side * 0.7 + wall, FREE)
    # Rows of shelves: racks 1 m deep, aisles 3 m, posts every 2.7 m, shadows behind.
    for half in (0.0, side / 2):
        y = 4.0
        while y < side * 0.65:
            x = half + 3.0
            while x < half + side / 2 - 6.0:
                length = float(rng.uniform(8.0, 12.0))
                end = min(x + length, half + side / 2 - 3.0)
                box(x, y, end, y + 1.0, OCCUPIED)
                box(x + 0.3, y + 0.3, end - 0.3, y + 0.7, UNKNOWN)  # between the posts
                for post in np.arange(x, end, 2.7):
                    box(post, y, post + 0.1, y + 1.0, OCCUPIED)
                x = end + 3.0
            y += 4.0
    # Pallets and a few machines in the upper rooms.
    for _ in range(60):
        x, y = rng.uniform(3.0, side - 4.0), rng.uniform(side * 0.72, side - 3.0)
        w, h = rng.uniform(0.8, 1.6, size=2)
        box(x, y, x + w, y + h, OCCUPIED)
    # What a scan does: ragged faces, specks in the aisles, holes in the walls.
    occupied = grid == OCCUPIED
    face = occupied & ~(
        np.roll(occupied, 1, 0)
        & np.roll(occupied, -1, 0)
        & np.roll(occupied, 1, 1)
        & np.roll(occupied, -1, 1)
    )
    near = np.zeros_like(occupied)
    for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        near |= np.roll(face, (dr, dc), (0, 1))
    flicker = rng.random(grid.shape)
    grid[near & (grid == FREE) & (flicker < 0.15)] = OCCUPIED
    grid[face & (flicker < 0.05)] = FREE
    free = grid == FREE
    grid[free & (rng.random(grid.shape) < specks)] = OCCUPIED
    return grid


def write(folder: Path, grid: np.ndarray, cell: float) -> Path:
    """Write the grid as map_saver does: a PGM (free 254, occupied 0, unknown 205)."""
    grey = np.full(grid.shape, 205, np.uint8)
    grey[grid == FREE] = 254
    grey[grid == OCCUPIED] = 0
    rows, cols = grid.shape
    (folder / "warehouse.pgm").write_bytes(
        f"P5\n{cols} {rows}\n255\n".encode()
        + np.ascontiguousarray(grey[::-1]).tobytes()
    )
    path = folder / "warehouse.yaml"
    path.write_text(
        "image: warehouse.pgm\n"
        f"resolution: {cell}\n"
        "origin: [-12.5, -20.0, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return path


def _write_child(folder: str, side: float, cell: float, specks: float) -> None:
    write(Path(folder), warehouse(side, cell, specks), cell)


def generate(folder: Path, side: float, cell: float, specks: float) -> Path:
    """Generate and write the map in a process of its own; return the YAML's path.

    Not here: a child's peak memory (``ru_maxrss``) starts from its parent's, so the
    process that measures must not be started by one that held the map's arrays.
    """
    ctx = multiprocessing.get_context("spawn")
    child = ctx.Process(target=_write_child, args=(str(folder), side, cell, specks))
    child.start()
    child.join()
    return folder / "warehouse.yaml"


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _child(yaml_path: str, planners_csv: str, profile: bool, out: Any) -> None:
    import planners
    from planners.allocator import keep_freed_memory
    from planners.maps import (
        default_endpoints,
        read_map,
        scene_from_map,
        trace_free_space,
        world_to_cell,
    )

    keep_freed_memory()  # as the CLI and the app run
    base = _rss_mb()
    t0 = time.perf_counter()
    m = read_map(yaml_path)
    t1 = time.perf_counter()
    start, goal = default_endpoints(m, 0.3)
    t2 = time.perf_counter()
    data = scene_from_map(m, start, goal, robot_radius=0.3)
    t3 = time.perf_counter()
    scene = planners.load_scene(data)
    t4 = time.perf_counter()
    import_mb = _rss_mb()
    seed = world_to_cell(m, [start])[0]
    exact = trace_free_space(m, (int(seed[0]), int(seed[1])), tolerance=0.0)
    which = () if planners_csv == "none" else tuple(planners_csv.split(","))
    profiler = cProfile.Profile() if profile else None
    t5 = time.perf_counter()
    if profiler:
        profiler.enable()
    results = planners.plan_all(scene, which) if which else {}
    if profiler:
        profiler.disable()
    t6 = time.perf_counter()
    report = None
    if profiler:
        text = io.StringIO()
        pstats.Stats(profiler, stream=text).sort_stats("cumulative").print_stats(25)
        report = text.getvalue()
    out.send(
        {
            "cells": m.rows * m.cols,
            "size": (m.cols, m.rows),
            "read_s": t1 - t0,
            "endpoints_s": t2 - t1,
            "scene_s": t3 - t2,
            "load_s": t4 - t3,
            "plan_s": t6 - t5,
            "base_mb": base,
            "import_mb": import_mb,
            "peak_mb": _rss_mb(),
            "exact_vertices": len(exact.outer) + sum(len(h) for h in exact.holes),
            "exact_holes": len(exact.holes),
            "boundary": len(data["boundary"]),
            "obstacles": len(data["obstacles"]),
            "vertices": len(data["boundary"]) + sum(len(o) for o in data["obstacles"]),
            "start": start,
            "goal": goal,
            "each": {
                p: {
                    "ms": results[p].ms,
                    "status": results[p].status,
                    "length": results[p].length,
                    "nodes": getattr(results[p], "nodes", None),
                    "edges": getattr(results[p], "edges", None),
                }
                for p in which
            },
            "profile": report,
        }
    )


def measure(yaml_path: Path, planners_csv: str, profile: bool, timeout: float) -> dict:
    """Import and plan in a fresh process; return its report."""
    return in_fresh_process(_child, (str(yaml_path), planners_csv, profile), timeout)


def main() -> int:
    """Generate the map, measure in a child, print the figures and the targets."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--side", type=float, default=50.0, help="[m], default 50")
    parser.add_argument("--cell", type=float, default=0.03, help="[m], default 0.03")
    parser.add_argument(
        "--specks",
        type=float,
        default=2e-4,
        help="share of free cells left occupied one by one (default 2e-4: a few hundred)",
    )
    parser.add_argument(
        "--planners", default="vg,svg,dsb", help="comma-separated, or none: import only"
    )
    parser.add_argument("--timeout", type=float, default=300.0)
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args()
    p50, p95 = spread()
    print(f"machine before: fixed 12 ms of work, p50 {p50:.1f} ms, p95 {p95:.1f} ms")
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        path = generate(Path(folder), args.side, args.cell, args.specks)
        print(f"map generated and written in {time.perf_counter() - t0:.1f} s")
        r = measure(path, args.planners, args.profile, args.timeout)
    if "error" in r:
        print(r["error"])
        return 0
    cols, rows = r["size"]
    import_s = r["read_s"] + r["scene_s"]
    print(f"map: {cols} x {rows} = {r['cells']:,} cells of {args.cell} m")
    print(
        f"import: read {r['read_s']:.2f} s, endpoints {r['endpoints_s']:.2f} s,"
        f" trace + simplify {r['scene_s']:.2f} s, load_scene {r['load_s']:.2f} s"
    )
    print(
        f"vertices: exact trace {r['exact_vertices']:,} ({r['exact_holes']} holes);"
        f" scene {r['vertices']:,} (boundary {r['boundary']}, {r['obstacles']} obstacles)"
    )
    print(f"plan_all ({args.planners}): {r['plan_s']:.2f} s")
    for name, e in r["each"].items():
        length = "-" if e["length"] is None else f"{e['length']:.2f} m"
        graph = f", {e['nodes']} nodes {e['edges']} edges" if e["nodes"] else ""
        print(f"  {name:<4} {e['ms'] / 1e3:7.2f} s  {e['status']:<11} {length}{graph}")
    print(
        f"memory: base {r['base_mb']:.0f} MB, after import {r['import_mb']:.0f} MB,"
        f" peak {r['peak_mb']:.0f} MB"
    )
    if r["profile"]:
        print(r["profile"])
    p50b, p95b = spread()
    print(f"machine after: p50 {p50b:.1f} ms, p95 {p95b:.1f} ms")
    unit = (p50 + p50b) / 2 / 1e3
    total = import_s + r["endpoints_s"] + r["plan_s"]
    print(
        f"as multiples of the fixed work: import {import_s / unit:.0f}x,"
        f" planning {r['plan_s'] / unit:.0f}x"
    )
    ok = total < TARGET_S and r["peak_mb"] < TARGET_MB
    print(
        f"{'PASS' if ok else 'FAIL'}  import + endpoints + planning {total:.2f} s"
        f" (target < {TARGET_S:g} s), peak {r['peak_mb']:.0f} MB (target < {TARGET_MB:g} MB)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
