"""The sensor's compiled sweep against the Python it replaced (section 9.6).

:func:`planners.bug.sensor._sweep` runs its middle compiled
(:func:`planners.kernels.sweep_intervals`); ``sweep_reference.py`` keeps the Python
loop it replaced. Every interval must come out the same, field for field and bit for
bit: on random and grid scenes seen from free space, from the border (vertices, edges,
within eps of them: the wedges at the robot's feet), through the spatial index of a big
border, and from the hollow side of a finely drawn wall, where hundreds of edges face
the robot. The merging of close critical angles, the subtlest step, is also held to
the reference on angle sets made to merge: wedge sides, runs across angle 0, every
neighbour alike.
"""

from __future__ import annotations

import math
import struct
from unittest import mock

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import Polygon

from planners import kernels, load_scene
from planners.bug import sensor
from planners.bug.sensor import measure_border, nearby, ring_geometry
from planners.space.expansion import configuration_space
from tests.benchmarks.bench_student import student_layout
from tests.conftest import random_scenes
from tests.planners import sweep_reference as ref


def _bits(items):
    """The items' fields, every float as its 64 bits (so -0.0 is not 0.0)."""

    def bits(v):
        return struct.pack("<d", v) if isinstance(v, float) else v

    return [
        (it.kind, it.edge, *map(bits, (it.lo, it.hi, it.t0, it.t1, *it.p0, *it.p1)))
        for it in items
    ]


def _same_sweep(geo, x, sensor_range, near=None):
    got = sensor._sweep(geo, np.asarray(x, dtype=np.float64), sensor_range, near)
    want = ref.sweep(geo, np.asarray(x, dtype=np.float64), sensor_range, near)
    assert _bits(got) == _bits(want)  # kind, edge, angles, parameters, points
    return got


def _border_points(space, rng, count):
    """Vertices, points on edges, and points within a few eps of them, in closed free space."""
    verts = np.concatenate([np.asarray(r)[:-1] for r in space.rings])
    nxt = np.concatenate([np.roll(np.asarray(r)[:-1], -1, axis=0) for r in space.rings])
    t = rng.uniform(0.0, 1.0, (len(verts), 1))
    on_edges = verts + t * (nxt - verts)
    near_them = np.concatenate([verts, on_edges]) + rng.normal(
        0.0, 3.0 * space.eps, (2 * len(verts), 2)
    )
    pts = np.concatenate([verts, on_edges, near_them])
    pts = pts[rng.permutation(len(pts))[:count]]
    return pts[~space.contains_blocked(pts)]


@settings(max_examples=80, deadline=None)
@given(
    scene=st.one_of(random_scenes(), random_scenes(grid=True)),
    sensor_range=st.sampled_from([0.7, 2.0, math.inf]),
    where=st.tuples(st.floats(-1, 11), st.floats(-1, 11)),
    seed=st.integers(0, 2**16),
)
def test_the_compiled_sweep_sees_what_the_python_sweep_saw(
    scene, sensor_range, where, seed
):
    space = configuration_space(
        scene.obstacles, scene.robot.radius, scene.expansion, scene.boundary
    )
    geo = ring_geometry(space)
    points = np.array([scene.start, scene.goal, where])
    points = points[~space.contains_blocked(points)]
    points = np.concatenate(
        [points, _border_points(space, np.random.default_rng(seed), 12)]
    )
    for x in points:
        _same_sweep(geo, x, sensor_range)


def test_the_compiled_sweep_on_a_big_border_through_its_index():
    # 32 obstacles, disk-expanded (443 edges), measured through the spatial index as a
    # border of 512 edges or more would be; a planner passes one measurement (near)
    # for several questions.
    with mock.patch.object(sensor, "_INDEX_MIN_EDGES", 64):
        _sweep_a_student_layout()


def _sweep_a_student_layout():
    scene = load_scene(student_layout(32))
    space = configuration_space(
        scene.obstacles, scene.robot.radius, scene.expansion, scene.boundary
    )
    geo = ring_geometry(space)
    assert nearby(geo, (10.0, 10.0), 3.0) is not None  # measured through the index
    rng = np.random.default_rng(15)
    free = rng.uniform(0.0, 20.0, (200, 2))
    points = np.concatenate(
        [free[~space.contains_blocked(free)], _border_points(space, rng, 200)]
    )
    touching = 0
    for x in points:
        for sensor_range in (2.0, 0.5):
            _same_sweep(geo, x, sensor_range)
        among = nearby(geo, x, 3.0)
        near = measure_border(geo, x, 2.0, among=among)
        touching += bool(near.occ)
        items = _same_sweep(geo, x, 2.0, near)
        assert items == sensor._sweep(geo, x, 2.0)
    assert touching > 50  # the wedges at the robot's feet were exercised


def test_a_hollow_fine_wall_seen_from_inside():
    # Inside round walls of 400 vertices every edge in view faces the robot.
    angles = np.linspace(0.0, 2.0 * math.pi, 400, endpoint=False)
    walls = Polygon(np.column_stack([3 * np.cos(angles), 3 * np.sin(angles)]))
    geo = ring_geometry(configuration_space((), 0.0, "disk", walls))
    for x, sensor_range in (
        ((0.5, 0.0), 10.0),
        ((0.0, 0.0), math.inf),
        ((2.9, 0.1), 1.0),
    ):
        items = _same_sweep(geo, x, sensor_range)
        assert sum(it.kind == "piece" for it in items) > 30


def test_a_ray_through_two_equally_near_edges_takes_the_first():
    # Two copies of one edge, spanning the ray along +x: the first in order wins.
    row = [1.0, 1.0, 0.0, -2.0, -2.0, 0.0, 1.0, 1.0, 1.0, 1.0, -1.0, 1.0]
    parts = np.array([row, row])
    assert kernels._first_hit(parts, 1.0, 0.0) == 0
    assert (
        ref.first_hit(
            [ref.Part(7, *row[:5], *row[5:]), ref.Part(3, *row[:5], *row[5:])], 1.0, 0.0
        )
        == 7
    )


@st.composite
def _angle_sets(draw):
    """Critical angles made to merge: clusters within eps / d, wedge sides, angle 0."""
    eps = 1e-9
    centres = draw(st.lists(st.floats(0.0, 2.0 * math.pi), min_size=1, max_size=6))
    if draw(st.booleans()):
        centres.append(2.0 * math.pi - 1e-13)  # a cluster across angle 0
    theta, reach = [], []
    for c in centres:
        for _ in range(draw(st.integers(1, 4))):
            d = draw(st.sampled_from([0.0, 1e-9, 0.001, 0.5, 1.0, 3.0, math.nan]))
            spread = draw(st.sampled_from([0.0, 1e-13, 0.5, 1.0, 2.0])) * eps
            theta.append((c + draw(st.floats(-1.0, 1.0)) * spread) % (2 * math.pi))
            reach.append(d)
    nearest = min((d for d in reach if not math.isnan(d)), default=math.inf)
    return np.array(theta), np.array(reach), nearest, eps


@settings(max_examples=500, deadline=None)
@given(case=_angle_sets())
def test_compiled_merging_of_close_angles_equals_the_python(case):
    theta, reach, nearest, eps = case
    got = kernels._merge_close_angles(theta, reach, nearest, eps)
    want = ref.merge_close_angles(theta, lambda: reach, nearest, eps)
    assert got.tobytes() == want.tobytes()


def test_a_run_of_close_angles_across_angle_zero_keeps_its_farthest():
    # Four points within eps of their neighbours, one of them before angle 0: one run
    # that the walk must start after its pairs from angle 0 on (two of them).
    tau = 2.0 * math.pi
    theta = np.array([tau - 0.3e-9, 0.1e-9, 0.4e-9, 0.7e-9, 3.0])
    reach = np.array([1.2, 1.0, 1.0, 1.5, 1.0])
    got = kernels._merge_close_angles(theta, reach, 1.0, 1e-9)
    np.testing.assert_array_equal(got, [0.7e-9, 3.0])
    want = ref.merge_close_angles(theta, lambda: reach, 1.0, 1e-9)
    assert got.tobytes() == want.tobytes()


def test_when_every_neighbour_is_alike_the_first_farthest_stays():
    # Points at the robot itself (distance 0): every gap times 0 is within eps.
    theta = np.array([0.5, 2.0, 4.0])
    for reach, kept in ((np.zeros(3), 0.5), (np.array([0.0, 1e-12, 1e-12]), 2.0)):
        got = kernels._merge_close_angles(theta, reach, 0.0, 1e-9)
        np.testing.assert_array_equal(got, [kept])
        want = ref.merge_close_angles(theta, lambda r=reach: r, 0.0, 1e-9)
        assert got.tobytes() == want.tobytes()


def test_merging_keeps_the_farthest_of_a_run_and_a_wedge_side_absorbs():
    eps = 1e-9
    # Three points within eps of one another at distance 1: the farthest (2.0) stays.
    theta = np.array([1.0, 1.0 + 0.4e-9, 1.0 + 0.8e-9, 2.0])
    reach = np.array([1.0, 2.0, 1.0, 1.0])
    np.testing.assert_array_equal(
        kernels._merge_close_angles(theta, reach, 1.0, eps), [1.0 + 0.4e-9, 2.0]
    )
    # A wedge's side (NaN distance) absorbs the points its ray passes within eps of.
    reach = np.array([np.nan, 2.0, 1.0, 1.0])
    np.testing.assert_array_equal(
        kernels._merge_close_angles(theta, reach, 1.0, eps), [1.0, 2.0]
    )
