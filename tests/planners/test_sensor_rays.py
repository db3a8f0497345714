"""The sweep's rays cast all at once (numpy) against the per-ray loop they replace.

With many facing edges (a finely drawn border seen from its hollow side)
:func:`planners.sensor._sweep` finds the nearest edge along every ray with
:func:`planners.sensor._first_hits`; the reference is :func:`_first_hit`, one ray at a
time on Python floats. They must name the same edge for every ray, ties included, and
the sensor must see the same either way.
"""

from __future__ import annotations

import math
from unittest import mock

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import Polygon

from planners import sensor
from planners.expansion import configuration_space
from planners.sensor import _first_hit, _first_hits, _Part, ring_geometry, sense
from tests.conftest import random_scenes


def _part(edge: int, start, step, robot=(0.0, 0.0)) -> _Part:
    """A facing part over the whole edge (no clipping), relative to ``robot``."""
    ax, ay = start[0] - robot[0], start[1] - robot[1]
    dx, dy = step
    return _Part(
        edge=edge,
        ax=ax,
        ay=ay,
        dx=dx,
        dy=dy,
        cross=ax * dy - ay * dx,
        t_in=0.0,
        t_out=1.0,
        inx=ax,
        iny=ay,
        outx=ax + dx,
        outy=ay + dy,
        dist=math.hypot(ax, ay),
    )


_coord = st.integers(-4, 4).map(
    float
)  # a small grid: shared ends, collinear edges, ties


@st.composite
def _parts(draw):
    n = draw(st.integers(1, 40))
    parts = []
    for e in range(n):
        start = (draw(_coord), draw(_coord))
        step = (draw(_coord), draw(_coord))
        if step == (0.0, 0.0):
            continue
        parts.append(_part(e, start, step))
    return parts


@st.composite
def _rays(draw, parts):
    # Through the parts' end points (exactly on a span's side), along the axes, random.
    rays = []
    for p in draw(st.lists(st.sampled_from(parts), max_size=10)) if parts else []:
        for x, y in ((p.inx, p.iny), (p.outx, p.outy)):
            if (x, y) != (0.0, 0.0):
                rays.append((x / math.hypot(x, y), y / math.hypot(x, y)))
    rays += [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]
    for a in draw(st.lists(st.floats(0.0, 2.0 * math.pi), max_size=20)):
        rays.append((math.cos(a), math.sin(a)))
    return rays


@given(data=st.data())
def test_all_rays_at_once_name_the_edges_one_ray_at_a_time_names(data):
    parts = data.draw(_parts())
    rays = data.draw(_rays(parts))
    ux, uy = [r[0] for r in rays], [r[1] for r in rays]
    expected = [_first_hit(parts, a, b) for a, b in rays]
    if parts:
        assert _first_hits(parts, ux, uy) == expected
    # In chunks of a few rays too (the chunking is by rays x edges).
    with mock.patch.object(sensor, "_HITS_CHUNK", 3):
        if parts:
            assert _first_hits(parts, ux, uy) == expected


def test_a_ray_through_two_equally_near_edges_takes_the_first():
    # Two copies of one edge: the first in order wins, as in the loop.
    parts = [_part(7, (1.0, 1.0), (0.0, -2.0)), _part(3, (1.0, 1.0), (0.0, -2.0))]
    assert _first_hits(parts, [1.0], [0.0]) == [7] == [_first_hit(parts, 1.0, 0.0)]


@settings(max_examples=60)
@given(
    scene=st.one_of(random_scenes(), random_scenes(grid=True)),
    sensor_range=st.sampled_from([0.7, 2.0, math.inf]),
    where=st.tuples(st.floats(-1, 11), st.floats(-1, 11)),
)
def test_the_sensor_sees_the_same_with_rays_cast_at_once(scene, sensor_range, where):
    space = configuration_space(
        scene.obstacles, scene.robot.radius, scene.expansion, scene.boundary
    )
    points = [scene.start, scene.goal, where]
    free = ~space.contains_blocked(np.array(points))
    geo = ring_geometry(space)
    for x in (p for p, ok in zip(points, free, strict=True) if ok):
        with mock.patch.object(sensor, "_MANY_FACING", 10**9):
            one = sense(geo, x, sensor_range)
        with mock.patch.object(sensor, "_MANY_FACING", 1):
            every = sense(geo, x, sensor_range)
        for field in ("segments", "points", "edge", "t", "follow", "chain"):
            assert np.array_equal(getattr(one, field), getattr(every, field)), field
        assert one.kinds == every.kinds


def test_a_hollow_fine_arc_seen_from_inside_is_cast_at_once():
    # Inside round walls of 400 vertices every edge in view faces the robot.
    angles = np.linspace(0.0, 2.0 * math.pi, 400, endpoint=False)
    walls = Polygon(np.column_stack([3 * np.cos(angles), 3 * np.sin(angles)]))
    space = configuration_space((), 0.0, "disk", walls)
    geo = ring_geometry(space)
    calls = []
    hits = sensor._first_hits

    def counted(*args):
        calls.append(len(args[0]))
        return hits(*args)

    with mock.patch.object(sensor, "_first_hits", counted):
        seen = sense(geo, (0.5, 0.0), 10.0)
    assert calls and calls[0] >= 300
    with mock.patch.object(sensor, "_MANY_FACING", 10**9):
        alone = sense(geo, (0.5, 0.0), 10.0)
    assert np.array_equal(seen.segments, alone.segments)
    assert seen.kinds == alone.kinds
