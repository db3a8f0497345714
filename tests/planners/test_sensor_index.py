"""The sensor's spatial index (planners.space.border): the same answers as scanning every edge.

On a big border (:data:`planners.bug.sensor._INDEX_MIN_EDGES` edges or more) the sensor
measures only the edges its index names near the robot. The index must name every edge
that matters (against a brute-force scan of the distances), and the sensor's answers
through it must equal, bit for bit, those of the scan over every edge; TangentBug's
whole trace too.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from hypothesis import assume, given
from hypothesis import strategies as st
from numpy.testing import assert_array_equal
from shapely import Polygon

from planners import PlanOptions, plan_all
from planners.bug import sensor as sensor_module
from planners.bug.sensor import (
    _measure,
    free_extent,
    ring_geometry,
    sense,
    visible_pieces,
)
from planners.space.expansion import configuration_space
from tests.conftest import random_scenes
from tests.planners.test_sensor import scenes_and_points


def _edges_within(geo, x, r):
    """Brute force: every edge with a point within r of x (shapely's distance)."""
    lines = shapely.linestrings(np.stack([geo.start, geo.end], axis=1))
    return set(np.flatnonzero(shapely.distance(lines, shapely.Point(x)) <= r).tolist())


def _edges_near_segment(geo, p, q, r):
    lines = shapely.linestrings(np.stack([geo.start, geo.end], axis=1))
    seg = shapely.LineString([p, q])
    return set(np.flatnonzero(shapely.distance(lines, seg) <= r).tolist())


def _same_sensing(a, b):
    for field in (
        "segments",
        "segment_ring",
        "segment_edge",
        "points",
        "ring",
        "edge",
        "t",
        "follow",
        "chain",
        "segment_chain",
    ):
        assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    assert a.kinds == b.kinds


def _check_indexed(geo, x, sensor_range, directions):
    full = _measure(geo, x, sensor_range, indexed=False)
    local = _measure(geo, x, sensor_range, indexed=True)
    assert full.edges is None
    assert full.occ == local.occ
    if math.isfinite(sensor_range):
        # Every edge within the range is measured, with the same numbers.
        assert local.edges is not None
        assert _edges_within(geo, x, sensor_range) <= set(local.edges.tolist())
        for name in ("a", "dist", "cr"):
            assert_array_equal(getattr(local, name), getattr(full, name)[local.edges])
    _same_sensing(
        sense(geo, x, sensor_range, near=full), sense(geo, x, sensor_range, near=local)
    )
    for ring in range(len(geo.rings)):
        assert_array_equal(
            visible_pieces(geo, x, sensor_range, ring, near=full),
            visible_pieces(geo, x, sensor_range, ring, near=local),
        )
    for u, limit in directions:
        assert free_extent(geo, x, u, limit, near=full) == free_extent(
            geo, x, u, limit, near=local
        )


@given(
    case=scenes_and_points(),
    angles=st.lists(st.floats(0, 2 * math.pi), min_size=1, max_size=4),
    limits=st.lists(st.sampled_from([0.3, 1.0, 3.0, 20.0]), min_size=4, max_size=4),
)
def test_indexed_sensor_equals_the_scan_of_every_edge(case, angles, limits):
    space, x, sensor_range = case
    assume(not space.contains_blocked(x)[0])
    geo = ring_geometry(space)
    assume(len(geo.start) > 0)
    directions = [
        (np.array([math.cos(a), math.sin(a)]), lim)
        for a, lim in zip(angles, limits, strict=False)
    ]
    # Toward the border's vertices too: rays that graze corners.
    for v in geo.start[:: max(1, len(geo.start) // 4)]:
        d = v - x
        if np.hypot(*d) > 0:
            directions.append((d / np.hypot(*d), float(np.hypot(*d)) * 1.5))
    _check_indexed(geo, x, sensor_range, directions)


@given(
    case=scenes_and_points(),
    r=st.floats(0.0, 6.0),
    angle=st.floats(0, 2 * math.pi),
)
def test_index_names_every_edge_near_a_disk_and_a_segment(case, r, angle):
    space, x, _ = case
    geo = ring_geometry(space)
    assume(len(geo.start) > 0)
    index = geo.index
    found = index.near_disk(x, r)
    assert np.all(np.diff(found) > 0)  # sorted, no repeats
    assert _edges_within(geo, x, r + index.pad) <= set(found.tolist())
    q = x + r * np.array([math.cos(angle), math.sin(angle)])
    found = index.near_segment(x, q)
    assert np.all(np.diff(found) > 0)
    # Within the pad (shapely's own test); everything within half of it certainly.
    assert _edges_near_segment(geo, x, q, 0.5 * index.pad) <= set(found.tolist())


def test_a_far_corner_that_hardly_turns_is_always_named():
    # A wall bending by 1e-8 rad at (5, 0) (a real corner: 5e-8 m off the line, more
    # than eps). The robot on the wall 1 m before it lies within eps of both edges'
    # lines, so the sensor treats that corner as touched, although the index's queries
    # around the robot reach only 0.51 m. The index names it anyway (a wide corner).
    bend = 1e-8
    wall = Polygon([(0, 0), (5, 0), (10, 5 * math.sin(bend)), (10, -1), (0, -1)])
    geo = ring_geometry(configuration_space((wall,), 0.0))
    corner = next(e for e in range(len(geo.start)) if geo.start[e].tolist() == [5, 0])
    assert corner in geo.index.wide.tolist()
    x = np.array([4.0, 0.0])
    full = _measure(geo, x, 0.5, indexed=False)
    assert any(o.edge_n == corner for o in full.occ)  # the far corner is touched
    assert full.occ == _measure(geo, x, 0.5, indexed=True).occ
    _check_indexed(geo, x, 0.5, [(np.array([1.0, 0.0]), 8.0)])


def test_a_big_border_is_measured_near_the_robot_only():
    # A disk of 2000 vertices: the sensor looks at the few edges within its range.
    angles = np.linspace(0, 2 * math.pi, 2000, endpoint=False)
    disk = Polygon(np.column_stack([10 * np.cos(angles), 10 * np.sin(angles)]))
    geo = ring_geometry(configuration_space((disk,), 0.0))
    assert len(geo.start) >= sensor_module._INDEX_MIN_EDGES
    x = np.array([11.0, 0.0])
    near = sensor_module.measure_border(geo, x, 2.0)
    assert near.edges is not None and len(near.edges) < len(geo.start) // 4
    directions = [(np.array([-1.0, 0.0]), 30.0), (np.array([0.0, 1.0]), 30.0)]
    _check_indexed(geo, x, 2.0, directions)
    # On the border, at a vertex.
    _check_indexed(geo, geo.start[7].copy(), 2.0, directions)


def _trace(scene, sensor_range, rule):
    plans = plan_all(
        scene, ("dsb",), PlanOptions(sensor_range=sensor_range, leave_rule=rule)
    )
    return plans["dsb"]


@given(
    scene=st.booleans().flatmap(lambda grid: random_scenes(grid=grid)),
    sensor_range=st.sampled_from([0.5, 1.5, math.inf]),
    rule=st.sampled_from(["tangent_bug", "chapter"]),
)
def test_tangent_bug_through_the_index_takes_the_same_path(scene, sensor_range, rule):
    full = _trace(scene, sensor_range, rule)
    assume(full.status != "invalid")
    saved = sensor_module._INDEX_MIN_EDGES
    sensor_module._INDEX_MIN_EDGES = 0
    try:
        local = _trace(scene, sensor_range, rule)
    finally:
        sensor_module._INDEX_MIN_EDGES = saved
    assert local.status == full.status
    assert_array_equal(local.path, full.path)
    assert local.events == full.events and local.modes == full.modes
    assert local.decisions == full.decisions


@given(
    case=scenes_and_points(),
    offset=st.tuples(st.floats(-1, 1), st.floats(-1, 1)),
)
def test_edges_found_once_for_a_move_measure_every_position_on_it(case, offset):
    # TangentBug finds the edges near a short move once (planners.bug.sensor.nearby) and
    # measures every probe on the move among them: the same as measuring each alone.
    space, x, sensor_range = case
    assume(math.isfinite(sensor_range))
    geo = ring_geometry(space)
    assume(len(geo.start) > 0)
    center = x + np.array(offset)
    among = geo.index.near_disk(center, sensor_range + float(np.hypot(*offset)))
    full = _measure(geo, x, sensor_range, indexed=False)
    local = sensor_module.measure_border(geo, x, sensor_range, among=among)
    assert full.occ == local.occ
    assert local.edges is not None
    for name in ("a", "dist", "cr"):
        assert_array_equal(getattr(local, name), getattr(full, name)[local.edges])
    _same_sensing(
        sense(geo, x, sensor_range, near=full), sense(geo, x, sensor_range, near=local)
    )
    u = np.array([1.0, 0.0])
    assert free_extent(geo, x, u, 7.0, near=full) == free_extent(
        geo, x, u, 7.0, near=local
    )
