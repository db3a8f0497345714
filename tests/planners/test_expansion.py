import itertools
import math

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from shapely import Polygon

from planners.memo import Memo
from planners.space.expansion import (
    DEFAULT_ARC_STEP,
    _all_ccw_rings,
    _ccw_rings,
    _group_unions,
    _overlapping_groups,
    configuration_space,
    expand_disk,
    expand_square,
    shrink_boundary,
)
from tests.conftest import square

L_SHAPE = Polygon([(0, 0), (3, 0), (3, 1), (1, 1), (1, 3), (0, 3)])
U_SHAPE = Polygon([(0, 0), (4, 0), (4, 3), (3, 3), (3, 1), (1, 1), (1, 3), (0, 3)])


# --------------------------------------------------------------------------- strategies


@st.composite
def star_polygons(draw, max_vertices=9):
    """Random simple polygons: star-shaped around a centre, so often non-convex."""
    n = draw(st.integers(3, max_vertices))
    cx, cy = draw(st.floats(-5, 5)), draw(st.floats(-5, 5))
    angles = np.sort(
        np.array(
            draw(
                st.lists(st.floats(0, 2 * math.pi), min_size=n, max_size=n, unique=True)
            )
        )
    )
    assume_spread = np.diff(np.append(angles, angles[0] + 2 * math.pi))
    if np.any(assume_spread < 0.05) or np.any(assume_spread > math.pi - 0.05):
        angles = np.linspace(0, 2 * math.pi, n, endpoint=False)
    radii = np.array(draw(st.lists(st.floats(0.3, 3), min_size=n, max_size=n)))
    pts = np.column_stack([cx + radii * np.cos(angles), cy + radii * np.sin(angles)])
    polygon = Polygon(pts)
    if not polygon.is_valid:
        polygon = polygon.convex_hull
    return polygon


# --------------------------------------------------------------------------- disk


def test_disk_square_by_hand():
    grown = expand_disk(square(0, 0, 1, 1), 0.5)
    assert grown.bounds == (-0.5, -0.5, 1.5, 1.5)
    exact = 1 + 4 * 0.5 + math.pi * 0.25
    assert exact < grown.area < exact * 1.01
    # Four tangent edges per 90-degree corner at the default step of 22.5 degrees.
    assert len(grown.exterior.coords) - 1 == 16


def test_disk_zero_radius_is_identity():
    assert expand_disk(L_SHAPE, 0.0) is L_SHAPE


def test_disk_arc_edges_are_tangent_or_outside_the_circle():
    r = 0.4
    grown = expand_disk(square(0, 0, 2, 1), r)
    ring = np.asarray(grown.exterior.coords)
    # Every edge is at distance >= r from the polygon, and its midpoint of a corner arc
    # touches the circle: distance exactly r.
    for a, b in itertools.pairwise(ring):
        mid = shapely.Point((a + b) / 2)
        assert square(0, 0, 2, 1).distance(mid) == pytest.approx(r, abs=1e-12)
        for p in (a, b):
            d = square(0, 0, 2, 1).distance(shapely.Point(p))
            assert r - 1e-12 <= d <= r / math.cos(DEFAULT_ARC_STEP / 2) + 1e-12


@pytest.mark.parametrize(
    "polygon", [square(0, 0, 1, 1), L_SHAPE, U_SHAPE], ids=["square", "L", "U"]
)
@pytest.mark.parametrize("step", [DEFAULT_ARC_STEP, math.pi / 32])
def test_disk_encloses_the_exact_sum_and_overshoot_is_bounded(polygon, step):
    r = 0.3
    grown = expand_disk(polygon, r, step)
    assert grown.is_valid and not grown.interiors
    # Encloses: the exact sum is the set of points within r of the polygon.
    exactish = polygon.buffer(r * (1 - 1e-9), quad_segs=256)
    assert grown.covers(exactish)
    # Overshoot: no vertex farther than r / cos(step / 2) from the polygon.
    far = max(polygon.distance(shapely.Point(p)) for p in grown.exterior.coords)
    assert far <= r / math.cos(step / 2) + 1e-12


def test_disk_u_shape_pocket_narrower_than_diameter_closes():
    # The U's pocket is 2 wide: a robot of radius 1.01 cannot enter it.
    grown = expand_disk(U_SHAPE, 1.01)
    assert grown.covers(shapely.Point(2, 2.5))
    open_ = expand_disk(U_SHAPE, 0.4)
    assert not open_.covers(shapely.Point(2, 2.5))


@given(polygon=star_polygons(), r=st.floats(0.01, 1.5), data=st.data())
def test_disk_contains_every_point_closer_than_radius(polygon, r, data):
    grown = expand_disk(polygon, r)
    assert grown.is_valid
    seed = data.draw(st.integers(0, 2**31))
    rng = np.random.default_rng(seed)
    minx, miny, maxx, maxy = polygon.bounds
    pts = rng.uniform([minx - r, miny - r], [maxx + r, maxy + r], size=(400, 2))
    geoms = shapely.points(pts)
    close = shapely.distance(polygon, geoms) < r
    # Every point closer than r is covered (up to rounding 1e-9 of the scale).
    uncovered = close & ~shapely.covers(grown, geoms)
    if uncovered.any():
        d = shapely.distance(grown.exterior, np.asarray(geoms)[uncovered])
        assert d.max() < 1e-9
    # And nothing farther than the stated overshoot is covered.
    far = shapely.distance(polygon, geoms) > r / math.cos(DEFAULT_ARC_STEP / 2) + 1e-9
    assert not (far & shapely.covers(grown, geoms)).any()


# --------------------------------------------------------------------------- square


def _reference_square_sum(polygon: Polygon, r: float) -> Polygon:
    """Minkowski sum with the square, the obvious way: triangulate, sum each convex piece."""
    corners = r * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)
    pieces = []
    for tri in getattr(shapely.constrained_delaunay_triangles(polygon), "geoms", []):
        assert isinstance(tri, Polygon)
        pts = np.asarray(tri.exterior.coords)[:-1]
        pieces.append(
            shapely.MultiPoint(
                (pts[:, None, :] + corners[None]).reshape(-1, 2)
            ).convex_hull
        )
    union = shapely.union_all(pieces)
    assert isinstance(union, Polygon)
    return union


def test_square_by_hand():
    assert list(
        expand_square(Polygon([(0, 0), (2, 0), (0, 2)]), 0.5).exterior.coords
    ) == [
        (-0.5, -0.5),
        (2.5, -0.5),
        (2.5, 0.5),
        (0.5, 2.5),
        (-0.5, 2.5),
        (-0.5, -0.5),
    ]
    assert expand_square(square(0, 0, 1, 1), 0.25).equals(
        square(-0.25, -0.25, 1.25, 1.25)
    )


def test_square_of_l_shape_by_hand():
    grown = expand_square(L_SHAPE, 0.5)
    assert grown.equals(
        Polygon(
            [(-0.5, -0.5), (3.5, -0.5), (3.5, 1.5), (1.5, 1.5), (1.5, 3.5), (-0.5, 3.5)]
        )
    )


@given(polygon=star_polygons(), r=st.floats(0.01, 1.5))
def test_square_equals_the_exact_minkowski_sum(polygon, r):
    ours = expand_square(polygon, r)
    reference = _reference_square_sum(polygon, r)
    assert ours.is_valid
    assert ours.symmetric_difference(reference).area <= 1e-9 * max(1.0, reference.area)


def test_square_contains_disk_expansion():
    # The enclosing square is conservative: its expansion contains the disk's exact sum.
    for polygon in (square(0, 0, 1, 1), L_SHAPE, U_SHAPE):
        assert expand_square(polygon, 0.3).covers(polygon.buffer(0.3, quad_segs=64))


# --------------------------------------------------------------------------- walls, merging


def test_boundary_shrinks_by_radius():
    room = square(0, 0, 4, 3)
    assert shrink_boundary(room, 0.5).equals(square(0.5, 0.5, 3.5, 2.5))
    assert shrink_boundary(room, 0.5, "square").equals(square(0.5, 0.5, 3.5, 2.5))
    assert shrink_boundary(room, 0.0) is room


def test_non_convex_boundary_corner_is_rounded_conservatively():
    room = Polygon([(0, 0), (4, 0), (4, 3), (2, 3), (2, 1.5), (0, 1.5)])
    r = 0.25
    shrunk = shrink_boundary(room, r)
    assert isinstance(shrunk, Polygon)
    # No point of the shrunk room is closer than r to the walls.
    pts = np.asarray(shrunk.exterior.coords)
    d = shapely.distance(room.exterior, shapely.points(pts))
    assert d.min() >= r - 1e-12
    # The reflex corner (2, 1.5) is kept at distance r.
    assert shrunk.distance(shapely.Point(2, 1.5)) == pytest.approx(r, abs=1e-9)


def test_narrow_room_pinches_into_two_parts():
    dumbbell = Polygon(
        [
            (0, 0),
            (2, 0),
            (2, 0.9),
            (3, 0.9),
            (3, 0),
            (5, 0),
            (5, 2),
            (3, 2),
            (3, 1.1),
            (2, 1.1),
            (2, 2),
            (0, 2),
        ]
    )
    shrunk = shrink_boundary(dumbbell, 0.3)
    assert isinstance(shrunk, shapely.MultiPolygon) and len(shrunk.geoms) == 2


def test_touching_and_overlapping_obstacles_merge_with_holes():
    ring = [
        square(0, 0, 3, 0.5),
        square(2.5, 0, 3, 3),
        square(0, 2.5, 3, 3),
        square(0, 0, 0.5, 3),
    ]
    space = configuration_space(tuple(ring), 0.0)
    assert len(space.merged.geoms) == 1
    assert len(space.merged.geoms[0].interiors) == 1
    assert not space.contains_blocked([1.5, 1.5])[0]
    assert space.contains_blocked([0.25, 1.5])[0]


def test_contains_blocked_treats_the_border_as_free():
    space = configuration_space(
        (square(0, 0, 1, 1),), 0.0, boundary=square(-2, -2, 3, 3)
    )
    pts = [[0, 0], [0.5, 0], [1, 1], [-2, 0], [0.5, 0.5], [-2.1, 0], [0.5, 1e-3]]
    assert_allclose(
        space.contains_blocked(pts), [False, False, False, False, True, True, True]
    )
    assert space.blockers([0.5, 0.5]) == ["obstacle 1"]
    assert space.blockers([-3, 0]) == ["outside the boundary"]


def test_tolerance_scales_with_coordinates():
    small = configuration_space((square(0, 0, 1, 1),), 0.0)
    large = configuration_space((square(1e4, 1e4, 1e4 + 1, 1e4 + 1),), 0.0)
    assert small.eps == 1e-9
    assert 1e4 * small.eps <= large.eps <= 2e4 * small.eps


def test_unknown_mode_is_an_error():
    with pytest.raises(ValueError, match="unknown expansion mode"):
        configuration_space((square(0, 0, 1, 1),), 0.1, "circle")


def test_union_slivers_do_not_break_the_polygon():
    # Found by hypothesis: rounding left holes of area ~1e-17 in the union of pieces.
    polygon = shapely.from_wkt(
        "POLYGON ((3.2603062102947042 -5, 2.2709247051387167 -4.135061894468778, 1.4737934352722446 -3.6748379412319014, 0.3247696863221274 -3.4145466400094766, -0.4801860804968965 -4.373855566995475, -0.4801860804968967 -5.626144433004525, 0.5909896394279653 -6.1243468752226065, 1.2922260638003311 -5.295442325903663, 2.190127539460159 -5.7971412336101755, 3.2603062102947042 -5))"
    )
    assert isinstance(polygon, Polygon)
    grown = expand_disk(polygon, 1.2401316105002522)
    assert grown.is_valid and not grown.interiors
    assert grown.covers(polygon.buffer(1.24 * (1 - 1e-9), quad_segs=64))


_CORNER = st.tuples(st.integers(0, 4), st.integers(0, 4)).map(
    lambda p: (p[0] / 2.0, p[1] / 2.0)
)


@st.composite
def _polygons(draw):
    """Polygons on a half-metre lattice: either orientation, repeated and collinear
    vertices, a hole, self-touching or invalid rings included."""
    shell = draw(st.lists(_CORNER, min_size=3, max_size=8))
    if draw(st.booleans()):
        shell = shell[::-1]
    holes = []
    if draw(st.booleans()):
        x, y = draw(_CORNER)
        hole = [(x + 0.1, y + 0.1), (x + 0.3, y + 0.1), (x + 0.1, y + 0.3)]
        holes.append(hole[::-1] if draw(st.booleans()) else hole)
    return Polygon(shell, holes)


@given(st.lists(_polygons(), max_size=6))
def test_all_rings_at_once_are_the_rings_polygon_by_polygon(polygons):
    """The vectorised rings equal :func:`_ccw_rings` of each polygon, bit for bit."""
    polygons = [p for p in polygons if not p.is_empty]
    fast = _all_ccw_rings(polygons)
    slow = [r for p in polygons for r in _ccw_rings(p)]
    assert len(fast) == len(slow)
    for a, b in zip(fast, slow, strict=True):
        np.testing.assert_array_equal(a, b)


# --------------------------------------------------------------------------- grouped union


def _slow_groups(shapes):
    """Groups by intersection, pair by pair: grow each group until nothing joins it."""
    left, groups = list(range(len(shapes))), []
    while left:
        group = [left.pop(0)]
        grown = True
        while grown:
            joining = [
                j for j in left if any(shapes[j].intersects(shapes[i]) for i in group)
            ]
            grown = bool(joining)
            group += joining
            left = [j for j in left if j not in joining]
        groups.append(sorted(group))
    return sorted(groups)


_LATTICE_BOXES = st.lists(
    st.tuples(_CORNER, st.integers(1, 3), st.integers(1, 3)).map(
        lambda b: square(b[0][0], b[0][1], b[0][0] + b[1] / 2, b[0][1] + b[2] / 2)
    ),
    max_size=8,
)


@given(_LATTICE_BOXES)
def test_groups_are_the_obstacles_connected_by_intersection(shapes):
    """Touching at an edge or a corner joins a group, as it does in the union."""
    groups = _overlapping_groups(tuple(shapes))
    assert sorted(groups) == _slow_groups(shapes)
    assert [g[0] for g in groups] == sorted(g[0] for g in groups)
    assert all(g == sorted(g) for g in groups)


@given(st.lists(star_polygons(), max_size=6), st.sampled_from([0.0, 0.3]))
def test_the_grouped_union_is_the_union_of_everything(polygons, radius):
    """Uniting group by group covers what one union of everything covers, no more."""
    space = configuration_space(tuple(polygons), radius)
    whole = shapely.union_all(space.expanded) if polygons else shapely.MultiPolygon()
    assert space.merged.is_valid
    assert space.merged.symmetric_difference(whole).area <= 1e-9 * max(whole.area, 1)
    assert sum(len(g) for g in _overlapping_groups(space.expanded)) == len(polygons)


def test_an_edit_reuses_the_groups_it_left_alone_and_equals_a_cold_build():
    """Dragging one of two apart groups: the other's union is the one before, the
    same object, and every ring is bit for bit a cold build's."""
    left = (square(0, 0, 1, 1), square(0.5, 0.5, 2, 2))  # overlapping: one group
    memo = Memo()
    before = configuration_space((*left, square(5, 5, 6, 6)), 0.25, memo=memo)
    moved = (*left, square(5.3, 5.1, 6.2, 6))
    after = configuration_space(moved, 0.25, memo=memo)
    cold = configuration_space(moved, 0.25)
    kept, now = before.known(_group_unions), after.known(_group_unions)
    assert kept is not None and now is not None
    group = tuple(map(id, after.expanded[:2]))
    assert group == tuple(map(id, before.expanded[:2]))  # the memo's expansions
    assert now[group] is kept[group]
    assert list(now) == [group, (id(after.expanded[2]),)]
    assert len(after.rings) == len(cold.rings) == 2
    for warm_ring, cold_ring in zip(after.rings, cold.rings, strict=True):
        np.testing.assert_array_equal(warm_ring, cold_ring)
    assert after.merged.equals_exact(cold.merged, 0.0)


def test_groups_are_reused_when_an_edit_renumbers_the_obstacles():
    """Deleting the first obstacle shifts every index: the groups left alone are still
    taken from the space before (by their members), and the rings are a cold build's;
    adding one that bridges two groups unites them afresh."""
    pair = (square(0, 0, 1, 1), square(0.5, 0.5, 2, 2))
    lone = square(5, 5, 6, 6)
    memo = Memo()
    before = configuration_space((square(-5, -5, -4, -4), *pair, lone), 0.25, memo=memo)
    after = configuration_space((*pair, lone), 0.25, memo=memo)
    kept, now = before.known(_group_unions), after.known(_group_unions)
    assert kept is not None and now is not None
    for key in now:
        assert now[key] is kept[key]
    bridge = Polygon([(1.5, 1.5), (5.5, 5.2), (5.2, 5.5)])
    joined = configuration_space((*pair, lone, bridge), 0.25, memo=memo)
    grouped = joined.known(_group_unions)
    assert grouped is not None and [len(k) for k in grouped] == [4]
    for space, obstacles in ((after, (*pair, lone)), (joined, (*pair, lone, bridge))):
        cold = configuration_space(obstacles, 0.25)
        assert len(space.rings) == len(cold.rings)
        for warm_ring, cold_ring in zip(space.rings, cold.rings, strict=True):
            np.testing.assert_array_equal(warm_ring, cold_ring)
