"""The compiled loops (planners.kernels) on inputs the planners rarely make.

Each loop is held to the code it replaced elsewhere, on the planners' own inputs
(test_sightlines, test_visibility, test_incremental). Here: graphs whose heuristic is
inconsistent (nodes settled again, queues that grow), wedges within a hair of the
screen's tolerance, the signatures the warm-up compiles, and when numba is loaded.
"""

import math
import subprocess
import sys
import types

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planners import kernels
from planners.visibility._graphs import _Wedges
from planners.visibility.incremental import _crossing_box, _outcodes
from tests.conftest import SCENARIOS
from tests.planners.astar_reference import search
from tests.planners.incremental_reference import crossing_box_reference


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
    assert int(count) == 11  # every compiled loop of the module
    assert same == "True"
    assert least == "1"  # the warm-up compiled each


def test_numba_loads_only_with_the_first_compiled_loop():
    # numba and LLVM take about 160 MB and half a second to load: importing the
    # planners (a scenario check, the CLI's help) and Bug2 (a contact sensor, no sweep)
    # do without; TangentBug's range sensor loads it.
    code = (
        "import sys\n"
        "from app.session.lanes import _child_main\n"
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
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    return out.stdout.split()
