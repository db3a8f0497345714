"""The compiled loops (planners.kernels) on inputs the planners rarely make.

Each loop is held to the code it replaced elsewhere, on the planners' own inputs
(test_sightlines, test_visibility, test_incremental). Here: graphs whose heuristic is
inconsistent (nodes settled again, queues that grow), wedges within a hair of the
screen's tolerance, the signatures the warm-up compiles, and when numba is loaded.
"""

import math
import types

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planners import kernels
from planners.space.expansion import configuration_space
from planners.visibility import _graphs
from planners.visibility._graphs import _Wedges
from planners.visibility.incremental import _crossing_box, _outcodes
from tests.conftest import SCENARIOS, random_scenes, run_code
from tests.planners.astar_reference import search
from tests.planners.incremental_reference import crossing_box_reference
from tests.planners.screen_reference import (
    candidate_pairs_reference,
    rows_against_reference,
)


@st.composite
def graphs(draw):
    """A small graph in compressed rows, small integer weights (ties), any heuristic."""
    n = draw(st.integers(2, 9))
    pairs = draw(
        st.sets(
            st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)).filter(
                lambda p: p[0] < p[1]
            ),
            max_size=3 * n,
        )
    )
    weight_of = {p: float(draw(st.integers(1, 8))) for p in sorted(pairs)}
    rows: list[list[tuple[int, float]]] = [[] for _ in range(n)]
    for (a, b), w in weight_of.items():
        rows[a].append((b, w))
        rows[b].append((a, w))
    first = np.cumsum([0, *(len(r) for r in rows)]).astype(np.intp)
    other = np.array([b for r in rows for b, _ in r], dtype=np.intp)
    weight = np.array([w for r in rows for _, w in r], dtype=np.float64)
    # Admissible or not, consistent or not: nodes may be settled again.
    heuristic = np.array(
        draw(st.lists(st.integers(0, 20).map(float), min_size=n, max_size=n))
    )
    s, g = draw(st.integers(0, n - 1)), draw(st.integers(0, n - 1))
    return first, other, weight, heuristic, s, (g + 1) % n if g == s else g


@settings(max_examples=400, deadline=None)
@given(graphs())
def test_compiled_search_equals_the_python_loop_on_any_heuristic(graph):
    first, other, weight, heuristic, s, g = graph
    steps, costs, path = kernels.astar(first, other, weight, heuristic, s, g)
    settled = [
        (n, p, c) for (n, p), c in zip(steps.tolist(), costs.tolist(), strict=True)
    ]
    want, order = search(
        first.tolist(), other.tolist(), weight.tolist(), heuristic.tolist(), s, g
    )
    assert settled == want
    assert path.tolist() == order


def test_nodes_settled_again_fill_more_rows_than_there_are_nodes():
    # An inconsistent heuristic: 5 nodes, 7 settled rows (two settled again); the goal's
    # row lands beyond the first n + 1 rows the search reserves.
    edges = {(0, 1): 5.0, (0, 2): 1.0, (0, 4): 7.0, (1, 2): 2.0, (1, 3): 2.0}
    edges |= {(2, 3): 5.0, (2, 4): 6.0}
    rows: list[list[tuple[int, float]]] = [[] for _ in range(5)]
    for (a, b), w in edges.items():
        rows[a].append((b, w))
        rows[b].append((a, w))
    first = np.cumsum([0, *(len(r) for r in rows)]).astype(np.intp)
    other = np.array([b for r in rows for b, _ in r], dtype=np.intp)
    weight = np.array([w for r in rows for _, w in r])
    heuristic = np.array([11.0, 5.0, 15.0, 5.0, 14.0])
    steps, costs, path = kernels.astar(first, other, weight, heuristic, 0, 4)
    want, order = search(
        first.tolist(), other.tolist(), weight.tolist(), heuristic.tolist(), 0, 4
    )
    assert len(want) == 7
    settled = zip(steps.tolist(), costs.tolist(), strict=True)
    assert [(n, p, c) for (n, p), c in settled] == want
    assert path.tolist() == order


def _turned(d, angle):
    c, s = math.cos(angle), math.sin(angle)
    length = math.hypot(*d)
    return np.array([d[0] * c - d[1] * s, d[0] * s + d[1] * c]) / length


@st.composite
def wedges_near_the_tolerance(draw):
    """Pairs of points across a central box; at each, a narrow wedge whose side lies
    within a hair (about the screen's 1e-12) of the line to its partner.

    The other side is a right angle away, so whether the segment leaves into the wedge
    is decided by that hair against the tolerance alone. Directions near the diagonals,
    where |dx| + |dy| differs most from the length.
    """
    points, nxt, prv = [], [], []
    for _ in range(draw(st.integers(1, 4))):
        base = draw(st.sampled_from([0.25, 0.75, 1.25, 1.75])) * math.pi
        a = base + draw(st.floats(-0.05, 0.05))
        p = 3.0 * np.array([math.cos(a), math.sin(a)])
        q = -p + np.array([draw(st.floats(-0.1, 0.1)), draw(st.floats(-0.1, 0.1))])
        for here, there in ((p, q), (q, p)):
            sign = draw(st.sampled_from([-1.0, 1.0]))
            hair = sign * draw(st.floats(0.8e-12, 1.6e-12))
            points.append(here)
            nxt.append(_turned(there - here, hair))
            prv.append(_turned(there - here, math.pi / 2))
    n = len(points)
    return np.array(points), _Wedges(np.array(nxt), np.array(prv), np.ones(n, bool))


@settings(max_examples=300, deadline=None)
@given(case=wedges_near_the_tolerance())
def test_compiled_box_pairs_screen_at_the_tolerance_as_numpy_did(case):
    points, wedges = case
    border = types.SimpleNamespace(points=points, wedges=wedges)
    box = np.array([-0.5, -0.5, 0.5, 0.5])
    stable = np.ones(len(points), dtype=bool)
    got = list(_crossing_box(border, stable, box))  # type: ignore[arg-type]
    want = list(crossing_box_reference(border, stable, box))  # type: ignore[arg-type]
    for k in range(2):
        np.testing.assert_array_equal(
            np.concatenate([np.zeros(0, dtype=np.intp), *(x[k] for x in got)]),
            np.concatenate([np.zeros(0, dtype=np.intp), *(x[k] for x in want)]),
        )


def _pairs(blocks) -> tuple[list[int], list[int]]:
    """All pairs of a run of blocks, in order, as two lists."""
    blocks = list(blocks)
    return (
        [int(v) for b in blocks for v in b[0]],
        [int(v) for b in blocks for v in b[1]],
    )


@settings(max_examples=200, deadline=None)
@given(case=wedges_near_the_tolerance(), tangent=st.booleans(), wide=st.data())
def test_compiled_screen_decides_at_the_tolerance_as_numpy_did(case, tangent, wide):
    points, wedges = case
    # Some wedges wider than pi (reflex vertices), some none at all (start and goal).
    n = len(points)
    narrow = np.array(wide.draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    bare = np.array(wide.draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    nxt, prv = wedges.nxt.copy(), wedges.prv.copy()
    nxt[bare] = prv[bare] = 0.0
    wedges = _Wedges(nxt, prv, narrow | tangent)  # the SVG screens narrow wedges only
    nodes = np.arange(n, dtype=np.intp)
    got = _pairs(_graphs._candidate_pairs(points, wedges, nodes, tangent=tangent))
    want = _pairs(candidate_pairs_reference(points, wedges, nodes, tangent=tangent))
    assert got == want


@settings(max_examples=60, deadline=None)
@given(scene=random_scenes(grid=True), tangent=st.booleans(), picks=st.data())
def test_compiled_screen_lists_a_scenes_pairs_as_numpy_did(scene, tangent, picks):
    space = configuration_space(
        scene.obstacles, scene.robot.radius, scene.expansion, scene.boundary
    )
    border, q = _graphs._query(space, scene.start, scene.goal)
    wedges = _graphs._query_wedges(border, q)
    n = len(q.points)
    keep = picks.draw(st.lists(st.booleans(), min_size=n, max_size=n))
    nodes = np.flatnonzero(keep).astype(np.intp)
    got = _pairs(_graphs._candidate_pairs(q.points, wedges, nodes, tangent=tangent))
    want = _pairs(candidate_pairs_reference(q.points, wedges, nodes, tangent=tangent))
    assert got == want
    # Rows against columns, as the build ring by ring lists them.
    cut = picks.draw(st.integers(0, len(nodes)))
    rows, cols = nodes[:cut], nodes[cut // 2 :]
    got = _pairs(_graphs._rows_against(q.points, wedges, rows, cols))
    assert got == _pairs(rows_against_reference(q.points, wedges, rows, cols))


def test_compiled_screen_hands_on_blocks_of_bounded_size(monkeypatch):
    # Many rows, each screened call short: the pairs come in several blocks, in order.
    monkeypatch.setattr(_graphs, "_SCREEN_ROWS_PAIRS", 7)
    monkeypatch.setattr(_graphs, "_BLOCK_PAIRS", 10)
    rng = np.random.default_rng(3)
    points = rng.uniform(0, 5, (40, 2))
    none = _Wedges(np.zeros((40, 2)), np.zeros((40, 2)), np.ones(40, bool))
    nodes = np.arange(40, dtype=np.intp)
    blocks = list(_graphs._candidate_pairs(points, none, nodes, tangent=False))
    assert len(blocks) > 10
    assert all(len(b[0]) < 10 + 40 for b in blocks)
    i, j = _pairs(blocks)
    assert list(zip(i, j, strict=True)) == [
        (a, b) for a in range(40) for b in range(a + 1, 40)
    ]


def test_box_pairs_reads_the_outcodes_it_is_given():
    points = np.array([[0.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    box = np.array([1.0, 1.0, 3.0, 3.0])
    none = (np.zeros((3, 2)), np.zeros((3, 2)), np.ones(3, dtype=bool))
    nodes = np.arange(3, dtype=np.intp)
    i, j = kernels.box_pairs(points, nodes, _outcodes(points, box), box, none, 1e-12)
    # The diagonal crosses the box; the two sides from (0, 4) pass beside it.
    assert list(zip(i.tolist(), j.tolist(), strict=True)) == [(0, 1)]


def test_warm_up_compiles_what_the_planners_call():
    # A second signature would compile at the first drag (seconds): there is none. In a
    # fresh process, so no earlier test has compiled one already.
    code = (
        "from planners import Memo, kernels, load_scene, plan_all\n"
        "from planners.scene import add_obstacle, move_obstacle, move_vertex\n"
        "kernels.warm_up()\n"
        "loops = [getattr(kernels, name) for name in kernels.__all__ if name != 'warm_up']\n"
        "before = [len(loop.signatures) for loop in loops]\n"
        f"scene = load_scene({str(SCENARIOS[0])!r})\n"
        "plan_all(scene, ('svg',), memo=Memo())\n"  # the SVG's own screen, cold
        "memo = Memo()\n"
        "plans = plan_all(scene, ('vg', 'svg', 'dsb'), memo=memo)\n"
        "assert plans['vg'].status == 'ok' and plans['dsb'].status == 'reached'\n"
        "x, y = scene.obstacles[0].exterior.coords[0]\n"
        "for edited in (\n"
        "    move_vertex(scene, 0, 0, (x + 0.05, y)),\n"
        "    move_obstacle(scene, 0, (0.1, 0.05)),\n"
        "    add_obstacle(scene, [(x, y - 3), (x + 0.4, y - 3), (x, y - 2.6)]),\n"
        "):\n"
        "    plan_all(edited, ('vg', 'svg'), memo=memo)\n"
        "after = [len(loop.signatures) for loop in loops]\n"
        "print(len(loops), before == after, min(before))\n"
    )
    count, same, least = _printed_by_a_fresh_python(code)
    assert int(count) == 14  # every compiled loop of the module
    assert same == "True"
    assert least == "1"  # the warm-up compiled each


def test_numba_loads_only_with_the_first_compiled_loop():
    # numba and LLVM take about 160 MB and half a second to load: importing the
    # planners (a scenario check, the CLI's help) and Bug2 (a contact sensor, no sweep)
    # do without; TangentBug's range sensor loads it.
    code = (
        "import sys\n"
        "from app.session.lanes import child_main\n"
        "from planners import load_scene, plan_all\n"
        f"scene = load_scene({str(SCENARIOS[0])!r})\n"
        "assert plan_all(scene, ('bug2',))['bug2'].status == 'reached'\n"
        "print('numba' in sys.modules)\n"
        "assert plan_all(scene, ('dsb',))['dsb'].status == 'reached'\n"
        "print('numba' in sys.modules)\n"
    )
    assert _printed_by_a_fresh_python(code) == ["False", "True"]


def _printed_by_a_fresh_python(code):
    """Run ``code`` in a new interpreter; return the words it printed."""
    return run_code(code).split()


def _directions(rng, count):
    """Random directions, the axes and diagonals with signed zeros, tiny and huge ones."""
    t = rng.uniform(-math.pi, math.pi, count)
    scale = 10.0 ** rng.uniform(-150, 150, count)
    special = [
        (x, y)
        for x in (0.0, -0.0, 1.0, -1.0, 1e-300, -3e200)
        for y in (0.0, -0.0, 1.0, -1.0, 1e-300, 2e250)
    ]
    xs, ys = (scale * np.cos(t)).tolist(), (scale * np.sin(t)).tolist()
    return [*zip(xs, ys, strict=True), *special]


def test_rough_atan2_is_within_its_bound():
    rng = np.random.default_rng(11)
    worst = max(
        abs(kernels.rough_atan2(y, x) - math.atan2(y, x))
        for x, y in _directions(rng, 200_000)
        if (x, y) != (0.0, 0.0)
    )
    assert worst < kernels.ATAN_ERROR / 5


@given(
    sectors=st.sampled_from([64, 128, 256, 512]),
    k=st.integers(0, 511),
    hair=st.sampled_from([-3, -2, -1, 1, 2, 3]),
)
def test_the_sector_is_the_c_librarys_even_on_its_sides(sectors, k, hair):
    # A direction a few ulps from a sector's side (and the branch cut at k = 0): the
    # rough angle cannot tell, so the C library's atan2 decides, as in the reference.
    width = 2.0 * math.pi / sectors
    angle = np.nextafter(
        (k % sectors) * width - math.pi, math.inf if hair > 0 else -math.inf
    )
    for _ in range(abs(hair) - 1):
        angle = np.nextafter(angle, math.inf if hair > 0 else -math.inf)
    for dx, dy in [
        (math.cos(angle), math.sin(angle)),
        *_directions(np.random.default_rng(k), 50),
    ]:
        want = min(int((math.atan2(dy, dx) + math.pi) // width), sectors - 1)
        assert kernels._sector(dx, dy, width, sectors) == want
