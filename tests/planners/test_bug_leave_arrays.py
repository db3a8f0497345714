"""The leave rule's "may the view come closer?" bound as arrays against its loop.

:func:`planners.bug._leave._may_come_closer` decides, without sensing, whether a reading
during boundary following could matter. With many edges to test (a finely drawn
border) it tests them as arrays (:func:`_any_in_view_closer`); the reference is its
loop, one edge at a time. They must agree everywhere, on the border and off it, for
d_followed below, at and above the distances that decide.
"""

from __future__ import annotations

import math
from unittest import mock

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planners import load_scene, plan_all
from planners.bug import _leave as bug_leave
from planners.bug._leave import _may_come_closer, _reach
from planners.bug.tangent_bug import BugParams, Follow, _context
from tests.conftest import random_scenes, scene_dict


def _follow(ring: int, d_followed: float) -> Follow:
    return Follow(
        ring=ring,
        direction=1,
        local_min=(0.0, 0.0),
        d_local_min=0.0,
        d_followed=d_followed,
        target=None,
        target_sigma=0.0,
        sigma=0.0,
        walked=0.0,
        obstacle=None,
    )


@st.composite
def _fine_scenes(draw):
    """A wavy ring of 60 to 600 vertices (convex and reflex stretches), goal outside."""
    n = draw(st.integers(60, 600))
    wave = draw(st.floats(0.0, 0.4))
    angles = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    radius = 3.0 * (1.0 + wave * np.sin(5 * angles))
    ring = np.column_stack([5 + radius * np.cos(angles), 5 + radius * np.sin(angles)])
    goal = draw(st.sampled_from([(13.0, 5.2), (5.0, 13.0), (-3.0, -2.0)]))
    return load_scene(scene_dict([ring.tolist()], (-3.0, 5.0), goal))


@settings(max_examples=60)
@given(
    scene=st.one_of(_fine_scenes(), random_scenes()),
    sensor_range=st.sampled_from([0.5, 1.5, 4.0]),
    where=st.lists(
        st.tuples(st.floats(0, 1), st.floats(-0.3, 0.3)), min_size=1, max_size=8
    ),
    slack=st.sampled_from([-0.5, -1e-9, 0.0, 1e-9, 0.3, 2.0]),
)
def test_the_bound_as_arrays_equals_the_loop(scene, sensor_range, where, slack):
    plans = plan_all(scene, ())
    if "cspace" not in plans:
        return  # an invalid scene
    ctx = _context(plans["cspace"], BugParams(scene.goal, sensor_range))
    geo = ctx.geo
    for u, off in where:
        ring = 0
        y, e, _ = geo.locate(ring, u * float(geo.perimeter[ring]))
        # On the border and a little off it, to either side.
        normal = np.array([-geo.unit[e, 1], geo.unit[e, 0]])
        y = y + off * normal
        d_now = _reach(ctx, y, ring)[0] if off == 0 else math.dist(y, scene.goal)
        follow = _follow(ring, max(d_now + slack, 0.0))
        with mock.patch.object(bug_leave, "_MANY_EDGES", 10**9):
            loop = _may_come_closer(ctx, follow, y)
        with mock.patch.object(bug_leave, "_MANY_EDGES", 0):
            arrays = _may_come_closer(ctx, follow, y)
        assert arrays == loop, (y, follow.d_followed)
