"""Time the peer libraries (pyvisgraph, extremitypathfinder) on benchmark scenes.

This script runs in the peers' own interpreter (``.venv-peers``: numpy<2), never in the
project's: the project does not import the peers. ``run.py`` starts it as a subprocess.

Two modes:

``peers.py [FILE]``
    Read ``{"scenes": [...], "tools": [...], "repeats": N}`` as JSON from FILE (or stdin),
    time every tool on every scene and print one JSON object ``{"results": [...]}``.
``peers.py --serve``
    Read one JSON request per line on stdin, ``{"tool": ..., "scene": {...}}``, answer
    each with one JSON line. ``run.py`` uses this to interleave the peers' repeats with
    ours, so that noise from other jobs on the machine hits every tool alike.

A result is ``{"tool", "scene", "build_ms", "build_cpu_ms", "query_ms": [...],
"query_cpu_ms": [...], "lengths": [...], "error"}``: the build (graph construction; for
extremitypathfinder ``store`` + ``prepare``) and each query, timed separately, as wall
time (``time.perf_counter``) and as this process's CPU time (``time.process_time``, which
other jobs on a shared machine disturb less). A length is None when the tool found no
path.

Scenes are the dicts of ``scenes.make_scene``: counter-clockwise obstacle rings,
``side`` of the square, and ``queries`` [[start, goal], ...].
"""

from __future__ import annotations

import importlib
import itertools
import json
import math
import sys
import traceback
import types
import warnings
from pathlib import Path
from typing import Any

from clock import Clock  # tests/benchmarks/clock.py, shared with run.py

TOOLS = ("pyvisgraph", "extremitypathfinder")


def _install_tqdm_stub() -> None:
    # pyvisgraph 0.2.1 imports tqdm for its progress bar but does not declare it as a
    # dependency; we build with status=False, so a stub that passes the iterable through
    # is exactly what pyvisgraph would use.
    try:
        importlib.import_module("tqdm")
    except ImportError:
        stub = types.ModuleType("tqdm")
        stub.tqdm = lambda iterable=None, *args, **kwargs: iterable  # type: ignore[attr-defined]
        sys.modules["tqdm"] = stub


def _path_length(points: list[tuple[float, float]]) -> float:
    return float(sum(math.dist(p, q) for p, q in itertools.pairwise(points)))


def _result(
    build: tuple[float, float],
    queries: list[tuple[float, float]],
    lengths: list[float | None],
) -> dict[str, Any]:
    return {
        "build_ms": build[0],
        "build_cpu_ms": build[1],
        "query_ms": [q[0] for q in queries],
        "query_cpu_ms": [q[1] for q in queries],
        "lengths": lengths,
    }


def run_pyvisgraph(scene: dict[str, Any]) -> dict[str, Any]:
    """Build pyvisgraph's visibility graph and answer every query.

    pyvisgraph takes a list of polygons, each a list of ``Point`` in order (clockwise or
    counter-clockwise: it only uses the edges); ``build(workers=1)`` is single-process.
    Its ray casting uses a point at x = 10000, so coordinates must stay below that.
    """
    _install_tqdm_stub()
    vg = importlib.import_module("pyvisgraph")
    polys = [[vg.Point(x, y) for x, y in ring] for ring in scene["obstacles"]]
    ends = [(vg.Point(*s), vg.Point(*g)) for s, g in scene["queries"]]
    clock = Clock()
    graph = vg.VisGraph()
    graph.build(polys, workers=1, status=False)
    build = clock.stop()
    queries, lengths = [], []
    for start, goal in ends:
        clock = Clock()
        try:
            path = graph.shortest_path(start, goal)
        except KeyError:  # pyvisgraph's Dijkstra never reached the goal
            path = None
        queries.append(clock.stop())
        lengths.append(
            None if path is None else _path_length([(p.x, p.y) for p in path])
        )
    return _result(build, queries, lengths)


def run_extremitypathfinder(scene: dict[str, Any]) -> dict[str, Any]:
    """Store + prepare extremitypathfinder's environment and answer every query.

    It needs a boundary polygon counter-clockwise and holes (obstacles) clockwise. Our
    scenes have no walls, so the boundary is a square with a wide margin around the
    obstacles, far enough that no shortest path touches it. ``store`` already calls
    ``prepare`` (2.7.2); the explicit ``prepare`` then returns at once, with a warning.
    """
    epf = importlib.import_module("extremitypathfinder")
    side = float(scene["side"])
    m = side  # margin: the boundary is 3x the square, never on a shortest path
    boundary = [(-m, -m), (side + m, -m), (side + m, side + m), (-m, side + m)]  # ccw
    holes = [
        list(reversed([tuple(p) for p in ring])) for ring in scene["obstacles"]
    ]  # cw
    ends = [(tuple(s), tuple(g)) for s, g in scene["queries"]]
    clock = Clock()
    env = epf.PolygonEnvironment()
    env.store(boundary, holes, validate=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env.prepare()
    build = clock.stop()
    queries, lengths = [], []
    for start, goal in ends:
        clock = Clock()
        _path, length = env.find_shortest_path(start, goal)
        queries.append(clock.stop())
        lengths.append(None if length is None else float(length))
    return _result(build, queries, lengths)


RUNNERS = {"pyvisgraph": run_pyvisgraph, "extremitypathfinder": run_extremitypathfinder}


def run(tool: str, scene: dict[str, Any]) -> dict[str, Any]:
    """Time ``tool`` on ``scene``; errors are reported in the result, not raised."""
    out: dict[str, Any] = {"tool": tool, "scene": scene.get("name", "")}
    try:
        out.update(RUNNERS[tool](scene))
        out["error"] = None
    except Exception as error:  # a peer's failure is a finding to report, not a crash
        out.update(_result((math.nan, math.nan), [], []))
        out["error"] = (
            f"{type(error).__name__}: {error}\n{traceback.format_exc(limit=3)}"
        )
    return out


def serve() -> None:
    """Answer one JSON request per stdin line with one JSON line on stdout."""
    for line in sys.stdin:
        if not line.strip():
            continue
        request = json.loads(line)
        if request.get("tool") == "versions":
            print(json.dumps(versions()), flush=True)
            continue
        print(json.dumps(run(request["tool"], request["scene"])), flush=True)


def versions() -> dict[str, str]:
    """Versions of python and the peers, for the report."""
    from importlib import metadata

    out = {"python": sys.version.split()[0]}
    for name in ("pyvisgraph", "extremitypathfinder", "numpy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "missing"
    return out


def main(argv: list[str]) -> int:
    """Entry point: ``--serve`` or a batch file (or stdin)."""
    if argv[:1] == ["--serve"]:
        serve()
        return 0
    text = Path(argv[0]).read_text(encoding="utf-8") if argv else sys.stdin.read()
    job = json.loads(text)
    tools = job.get("tools", list(TOOLS))
    results = [
        run(tool, scene)
        for _ in range(int(job.get("repeats", 1)))
        for scene in job["scenes"]
        for tool in tools
    ]
    print(json.dumps({"versions": versions(), "results": results}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
