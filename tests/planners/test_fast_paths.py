"""The planners' faster numpy paths give exactly what the plain numpy calls give.

Gathers by ``np.take`` (:func:`planners.space.geometry.take_rows`), point orders by complex
numbers, pair orders by one integer key, shared vertices by ``np.unique`` on complex
numbers: each is compared bit for bit with the call it replaces (fancy indexing,
``np.lexsort``, ``np.unique(axis=0)``), with many ties, repeated rows, signed zeros and
subnormals, which are where orders could differ.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from planners.space.geometry import take_rows
from planners.visibility._graphs import GraphArrays, _unique_points

# Few distinct values, so rows repeat and tie; signed zeros and a subnormal among them.
VALUES = st.sampled_from([0.0, -0.0, 1.0, -1.0, 2.5, 1e-310, -3.0, 1e300])
POINTS = hnp.arrays(
    np.float64, st.tuples(st.integers(0, 40), st.just(2)), elements=VALUES
)


@given(POINTS, st.data())
def test_take_rows_is_fancy_indexing(points, data):
    n = len(points)
    shape = data.draw(st.sampled_from([(0,), (7,), (3, 1), (1, 4), (2, 3)]))
    if n == 0:
        index = np.zeros((0,), dtype=np.intp)
    else:
        index = data.draw(hnp.arrays(np.intp, shape, elements=st.integers(-n, n - 1)))
    got, want = take_rows(points, index), points[index]
    assert got.shape == want.shape
    assert np.array_equal(got.view(np.uint64), want.view(np.uint64))  # bit for bit


@given(POINTS)
def test_unique_points_is_unique_rows(points):
    want, want_inverse = np.unique(points, axis=0, return_inverse=True)
    got, inverse = _unique_points(points)
    assert np.array_equal(got.view(np.uint64), want.view(np.uint64))  # bit for bit
    assert np.array_equal(inverse, want_inverse.reshape(-1))
    assert np.array_equal(got[inverse], points)  # every row is found again


def test_unique_points_keeps_one_of_two_signed_zeros():
    """+0.0 and -0.0 are one point, as for np.unique; its coordinates compare equal."""
    got, inverse = _unique_points(np.array([[0.0, 1.0], [-0.0, 1.0], [2.0, 0.0]]))
    assert got.tolist() == [[0.0, 1.0], [2.0, 0.0]] and inverse.tolist() == [0, 0, 1]


@given(
    st.integers(2, 300).flatmap(
        lambda n: st.tuples(
            st.just(n),
            st.lists(
                st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)),
                max_size=200,
            ),
        )
    )
)
def test_one_key_stable_sort_is_lexsort_of_pairs(case):
    """The row-major order of pairs (i, j), repeats included, as np.lexsort gives."""
    n, pairs = case
    i = np.array([p[0] for p in pairs], dtype=np.intp)
    j = np.array([p[1] for p in pairs], dtype=np.intp)
    assert np.array_equal(np.argsort(i * n + j, kind="stable"), np.lexsort((j, i)))


@given(st.integers(2, 60), st.data())
def test_adjacency_is_a_stable_sort_by_node(n, data):
    """The compiled counting sort lists each node's neighbours as a stable argsort."""
    pairs = data.draw(
        st.sets(
            st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)).filter(
                lambda p: p[0] < p[1]
            ),
            max_size=150,
        )
    )
    i, j = (
        np.array(sorted(pairs), dtype=np.intp).reshape(-1, 2).T
        if pairs
        else (np.zeros(0, np.intp), np.zeros(0, np.intp))
    )
    points = np.column_stack([np.arange(n, dtype=np.float64), np.zeros(n)])
    graph = GraphArrays(points, 0, n - 1, i, j, np.ones(n, dtype=bool))
    first, other, weight = graph._adjacency()
    u, v = np.concatenate([j, i]), np.concatenate([i, j])
    order = np.argsort(u, kind="stable")
    assert np.array_equal(other, v[order])
    assert np.array_equal(weight, np.concatenate([graph.weight, graph.weight])[order])
    assert first.tolist() == [0, *np.cumsum(np.bincount(u, minlength=n)).tolist()]


def test_adjacency_past_sixteen_bit_node_numbers():
    """Node numbers up to 65,535 and one more (once sorted as uint16) list alike."""
    for n in (1 << 16, (1 << 16) + 1):
        i = np.array([0, 5, n - 2, 7], dtype=np.intp)
        j = np.array([n - 1, n - 1, n - 1, 9], dtype=np.intp)
        order = np.lexsort((j, i))
        i, j = i[order], j[order]
        points = np.column_stack([np.arange(n, dtype=np.float64), np.zeros(n)])
        graph = GraphArrays(points, 0, n - 1, i, j, np.ones(n, dtype=bool))
        first, other, _ = graph._adjacency()
        assert other[first[n - 1] : first[n]].tolist() == [0, 5, n - 2]
        assert other[first[7] : first[8]].tolist() == [9]
