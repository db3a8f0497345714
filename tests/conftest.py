"""Canonical geometries and the slow, obviously-correct references the planners are checked against."""

from __future__ import annotations

import itertools
import json
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import networkx as nx
import numpy as np
import pytest
import shapely
from hypothesis import strategies as st
from shapely import LineString, Polygon
from shapely.geometry.base import BaseGeometry

from planners import load_scene
from planners.space.expansion import ConfigurationSpace
from planners.visibility import segments_free
from tests.browser import close_browser, close_pages, shared_browser

if TYPE_CHECKING:
    from playwright.sync_api import Browser

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "static_scenarios").glob("*.json"))
DURATIONS = Path(__file__).with_name("durations.json")
"""Seconds each slow test module took (``make durations`` writes it)."""


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Run the slowest test modules first, so that the parallel workers finish together.

    ``make test`` hands whole modules to its workers in this order
    (``--dist loadfile --no-loadscope-reorder``): longest first, each to the worker that
    is free, leaves no long module alone at the end. Within a module the order stays.
    """
    seconds = json.loads(DURATIONS.read_text()) if DURATIONS.exists() else {}
    items.sort(key=lambda item: -float(seconds.get(item.nodeid.split("::")[0], 0.0)))
    _BROWSER_MODULES.update(
        item.nodeid.split("::")[0]
        for item in items
        if "browser" in getattr(item, "fixturenames", ())
    )


_BROWSER_MODULES: set[str] = set()
"""Test modules with a test that uses the ``browser`` fixture (filled at collection)."""


@pytest.fixture(scope="module")
def browser() -> Browser:
    """Headless Chromium, shared by this run of browser modules (see tests/browser.py).

    Each test opens its pages in a context of its own (:func:`tests.browser.open_page`),
    so nothing a page did outlives its test; only the browser's start (about a second of
    CPU) is shared. FAILS (never skips) when Chromium cannot start.
    """
    return shared_browser()


def pytest_runtest_setup(item: pytest.Item) -> None:
    """At a module's first test, close what the modules before it left of the browser.

    Pages a test left open (it failed before closing them) go; the browser itself goes
    before a module that does not use it.
    """
    module = item.nodeid.split("::")[0]
    if module == _MODULE["now"]:
        return
    _MODULE["now"] = module
    if module in _BROWSER_MODULES:
        close_pages()
    else:
        close_browser()


_MODULE: dict[str, str | None] = {"now": None}
"""The module whose tests run now in this process."""


def pytest_sessionfinish() -> None:
    close_browser()


def run_code(
    code: str, *, timeout: float | None = None, env: dict[str, str] | None = None
) -> str:
    """Run ``python -c code`` in a new interpreter from the repository; return its output.

    A failing run raises (``check=True``). ``env`` adds to this process's environment.
    """
    return _run_python(["-c", code], timeout, env, check=True).stdout


def run_module(
    module: str,
    *args: str,
    timeout: float | None = None,
    env: dict[str, str] | None = None,
) -> subprocess.CompletedProcess[str]:
    """Run ``python -m module *args`` from the repository; capture its text output.

    ``env`` adds to (or overrides) this process's environment.
    """
    return _run_python(["-m", module, *args], timeout, env, check=False)


def _run_python(
    args: list[str], timeout: float | None, env: dict[str, str] | None, *, check: bool
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=None if env is None else {**os.environ, **env},
        check=check,
    )


def square(x0: float, y0: float, x1: float, y1: float) -> Polygon:
    """Axis-aligned rectangle [x0, x1] x [y0, y1]."""
    return Polygon([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def scene_dict(
    obstacles, start, goal, *, radius=0.0, boundary=None, expansion="disk", **extra
) -> dict:
    """A scenario mapping with a point robot unless told otherwise."""
    data = {
        "format": 1,
        "obstacles": [list(map(list, o)) for o in obstacles],
        "start": list(start),
        "goal": list(goal),
        "robot": {"radius": radius},
        "expansion": expansion,
    }
    if boundary is not None:
        data["boundary"] = [list(p) for p in boundary]
    data.update(extra)
    return data


def reference_segment_free(cspace: ConfigurationSpace, a, b) -> bool:
    """Is segment a-b in the closed free space? Decided by shapely's predicates alone.

    Touching within the planners' tolerance ``cspace.eps`` counts as touching, as the
    planners document: the segment may not enter blocked space shrunk by eps.
    """
    if tuple(a) == tuple(b):
        return not cspace.contains_blocked(np.asarray(a))[0]
    return not _eroded_blocked(cspace).intersects(LineString([a, b]))


_ERODED: dict[int, tuple[ConfigurationSpace, BaseGeometry]] = {}


def _eroded_blocked(cspace: ConfigurationSpace) -> BaseGeometry:
    """Blocked space shrunk by eps (cached per configuration space)."""
    key = id(cspace)
    if key not in _ERODED or _ERODED[key][0] is not cspace:
        if cspace.free is not None:
            minx, miny, maxx, maxy = (
                cspace.free.bounds if not cspace.free.is_empty else (0, 0, 1, 1)
            )
            frame = shapely.box(minx - 10, miny - 10, maxx + 10, maxy + 10)
            blocked = frame.difference(cspace.free.buffer(cspace.eps, quad_segs=2))
        else:
            blocked = cspace.merged.buffer(-cspace.eps, quad_segs=2)
        shapely.prepare(blocked)
        _ERODED.clear()
        _ERODED[key] = (cspace, blocked)
    return _ERODED[key][1]


def reference_shortest_length(cspace: ConfigurationSpace, start, goal) -> float | None:
    """Shortest path length by checking every vertex pair with shapely (the slow reference)."""
    nodes = {tuple(map(float, p)) for ring in cspace.rings for p in ring}
    nodes |= {tuple(map(float, start)), tuple(map(float, goal))}
    nodes = sorted(nodes)
    graph = nx.Graph()
    graph.add_nodes_from(nodes)
    for i, a in enumerate(nodes):
        for b in nodes[i + 1 :]:
            if reference_segment_free(cspace, a, b):
                graph.add_edge(a, b, weight=math.dist(a, b))
    try:
        return nx.dijkstra_path_length(
            graph, tuple(map(float, start)), tuple(map(float, goal))
        )
    except nx.NetworkXNoPath:
        return None


@st.composite
def random_scenes(draw, grid=False):
    """A few random polygons (convex or star-shaped, or on a small grid), maybe walls."""
    k = draw(st.integers(1, 4))
    obstacles = []
    for _ in range(k):
        if grid:
            # Small integer grid: collinear vertices, touching and shared corners abound.
            x0, y0 = draw(st.integers(0, 6)), draw(st.integers(0, 6))
            w, h = draw(st.integers(1, 3)), draw(st.integers(1, 3))
            shape = draw(st.sampled_from(["rect", "tri", "L"]))
            if shape == "rect":
                pts = [(x0, y0), (x0 + w, y0), (x0 + w, y0 + h), (x0, y0 + h)]
            elif shape == "tri":
                pts = [(x0, y0), (x0 + w, y0), (x0, y0 + h)]
            else:
                pts = [
                    (x0, y0),
                    (x0 + w + 1, y0),
                    (x0 + w + 1, y0 + 1),
                    (x0 + 1, y0 + 1),
                    (x0 + 1, y0 + h + 1),
                    (x0, y0 + h + 1),
                ]
        else:
            n = draw(st.integers(3, 7))
            cx, cy = draw(st.floats(1, 9)), draw(st.floats(1, 9))
            angles = np.linspace(0, 2 * math.pi, n, endpoint=False) + draw(
                st.floats(0, 1)
            )
            radii = np.array(
                draw(st.lists(st.floats(0.4, 2.0), min_size=n, max_size=n))
            )
            pts = list(
                zip(
                    cx + radii * np.cos(angles),
                    cy + radii * np.sin(angles),
                    strict=True,
                )
            )
        obstacles.append(pts)
    if grid:
        radius = draw(st.sampled_from([0.0, 0.0, 0.5]))
        pick = st.integers(-1, 10).map(float)
    else:
        radius = draw(st.sampled_from([0.0, 0.15, 0.4]))
        pick = st.floats(-1, 11)
    expansion = draw(st.sampled_from(["disk", "square"]))
    boundary = [(-2, -2), (12, -2), (12, 12), (-2, 12)] if draw(st.booleans()) else None
    start, goal = (draw(pick), draw(pick)), (draw(pick), draw(pick))
    scene = load_scene(
        scene_dict(
            obstacles,
            start,
            goal,
            radius=radius,
            expansion=expansion,
            boundary=boundary,
        )
    )
    return scene


@pytest.fixture(params=SCENARIOS, ids=[p.stem for p in SCENARIOS])
def scenario_path(request) -> Path:
    """Each shipped scenario file."""
    return request.param


# `HYPOTHESIS_PROFILE=thorough pytest ...` hunts for counterexamples far longer than CI does.
from hypothesis import HealthCheck as _HealthCheck  # noqa: E402
from hypothesis import settings as _settings  # noqa: E402

_QUIET = [_HealthCheck.too_slow, _HealthCheck.filter_too_much]
# CI runs the same examples every time (derandomize): a run that passes stays passing, and
# a new counterexample is found by the thorough profile, written down as a test, not met
# by chance in CI. The thorough profile explores at random.
_settings.register_profile(
    "default",
    max_examples=100,
    deadline=None,
    suppress_health_check=_QUIET,
    derandomize=True,
)
_settings.register_profile(
    "thorough", max_examples=3000, deadline=None, suppress_health_check=_QUIET
)
_settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


def check_walk(space: ConfigurationSpace, scene, walk, vg) -> None:
    """Check a trace planner's walk against the visibility graph's answer.

    It starts at the start; it never enters an expanded obstacle's interior nor leaves
    the walls (by the planners' exact test and by shapely's); where a path exists it
    ends on the goal, is no shorter than the VG's, and its length is its segments' sum.
    """
    path = walk.path
    assert tuple(path[0]) == scene.start
    if len(path) > 1:
        assert segments_free(space, path[:-1], path[1:]).all()
        for a, b in itertools.pairwise(path):
            assert reference_segment_free(space, a, b), (a, b)
    if vg.status == "ok":
        assert tuple(path[-1]) == scene.goal
        assert walk.length >= vg.length - 1e-9
        assert walk.length == pytest.approx(
            float(np.hypot(*np.diff(path, axis=0).T).sum()), rel=1e-12
        )
