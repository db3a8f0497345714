"""The A* search as Python ran it before it was compiled: the reference of the tests.

:meth:`planners.visibility.GraphArrays.shortest_path` runs it compiled
(:func:`planners.kernels.astar`). This is the loop it replaced, kept verbatim but for
the heuristic, which it takes as a list here (the planner's is ``math.dist`` to the
goal, computed the same way): a heap of (f, count, node, cost, parent) tuples, step by
step :func:`networkx.astar_path`.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Sequence

import numpy as np

from planners.visibility import GraphArrays

Settled = list[tuple[int, int, float]]


def search(  # noqa: PLR0917
    first: Sequence[int],
    other: Sequence[int],
    weight: Sequence[float],
    heuristic: Sequence[float],
    s: int,
    g: int,
) -> tuple[Settled, list[int]]:
    """Return (node, parent, cost) of each node settled, in order, and the path's nodes.

    The graph in compressed rows, as :func:`planners.kernels.astar` takes it; ``s``
    and ``g`` differ.
    """
    count = itertools.count()
    queue = [(0.0, next(count), s, 0.0, -1)]
    enqueued: dict[int, tuple[float, float]] = {}
    explored: dict[int, int] = {}
    settled: Settled = []
    while queue:
        _, _, node, cost, parent = heapq.heappop(queue)
        if node == g:
            settled.append((node, parent, cost))
            order = [node, parent]
            while order[-1] != s:
                order.append(explored[order[-1]])
            return settled, order[::-1]
        if node in explored:
            if explored[node] < 0:
                continue
            if enqueued[node][0] < cost:
                continue
        explored[node] = parent
        settled.append((node, parent, cost))
        for k in range(first[node], first[node + 1]):
            nxt, new = other[k], cost + weight[k]
            if nxt in enqueued:
                known, h = enqueued[nxt]
                if known <= new:
                    continue
            else:
                h = heuristic[nxt]
            enqueued[nxt] = new, h
            heapq.heappush(queue, (new + h, next(count), nxt, new, node))
    return settled, []


def settled_order(arrays: GraphArrays) -> tuple[Settled, list[int]]:
    """Run :func:`search` on a visibility graph, with the planner's heuristic."""
    s, g = arrays.start, arrays.goal
    if s == g:
        return [(s, -1, 0.0)], [s]
    keys = list(map(tuple, arrays.points.tolist()))
    first, other, weight = arrays._adjacency()
    heuristic = [math.dist(k, keys[g]) for k in keys]
    return search(first.tolist(), other.tolist(), weight.tolist(), heuristic, s, g)


def assert_same_search(arrays: GraphArrays) -> None:
    """Assert the compiled search settles what the reference settles, in its order."""
    settled: Settled = []
    found = arrays.shortest_path(settled)
    want, order = settled_order(arrays)
    assert settled == want
    if not order:
        assert found is None
    else:
        assert found is not None
        np.testing.assert_array_equal(found[0], arrays.points[order])
