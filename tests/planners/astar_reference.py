"""The A* search as Python ran it before it was compiled: the reference of the tests.

:meth:`planners.visibility.GraphArrays.shortest_path` runs it compiled
(:func:`planners.kernels.astar`). This is the loop it replaced, kept verbatim: a heap of
(f, count, node, cost, parent) tuples, step by step :func:`networkx.astar_path`.
"""

from __future__ import annotations

import heapq
import itertools
import math

import numpy as np

from planners.visibility import GraphArrays


def settled_order(
    arrays: GraphArrays,
) -> tuple[list[tuple[int, int, float]], list[int]]:
    """Return (node, parent, cost) of each node settled, in order, and the path's nodes."""
    s, g = arrays.start, arrays.goal
    if s == g:
        return [(s, -1, 0.0)], [s]
    keys = list(map(tuple, arrays.points.tolist()))
    first, other_of, weight_of = arrays._adjacency()
    first = first.tolist()
    target = keys[g]
    count = itertools.count()
    queue = [(0.0, next(count), s, 0.0, -1)]
    enqueued: dict[int, tuple[float, float]] = {}
    explored: dict[int, int] = {}
    settled: list[tuple[int, int, float]] = []
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
        rows = slice(first[node], first[node + 1])
        for other, w in zip(
            other_of[rows].tolist(), weight_of[rows].tolist(), strict=True
        ):
            new = cost + w
            if other in enqueued:
                known, h = enqueued[other]
                if known <= new:
                    continue
            else:
                h = math.dist(keys[other], target)
            enqueued[other] = new, h
            heapq.heappush(queue, (new + h, next(count), other, new, node))
    return settled, []


def assert_same_search(arrays: GraphArrays) -> None:
    """Assert the compiled search settles what the reference settles, in its order."""
    settled: list[tuple[int, int, float]] = []
    found = arrays.shortest_path(settled)
    want, order = settled_order(arrays)
    assert settled == want
    if not order:
        assert found is None
    else:
        assert found is not None
        np.testing.assert_array_equal(found[0], arrays.points[order])
