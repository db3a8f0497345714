"""The map's frame: world <-> grid <-> cells, with the origin's yaw."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from planners.maps import (
    FREE,
    OccupancyMap,
    cell_centres,
    contains_cells,
    grid_to_world,
    world_to_cell,
    world_to_grid,
)

_ORIGINS = st.tuples(
    st.floats(-1e3, 1e3), st.floats(-1e3, 1e3), st.floats(-2 * math.pi, 2 * math.pi)
)
_RESOLUTIONS = st.sampled_from([0.01, 0.025, 0.05, 0.1, 0.5, 1.0, 2.5])


def _map(rows, cols, resolution, origin):
    return OccupancyMap(
        np.full((rows, cols), FREE, np.uint8), resolution, origin, "m.yaml"
    )


@given(
    resolution=_RESOLUTIONS,
    origin=_ORIGINS,
    uv=st.lists(
        st.tuples(st.floats(-50, 50), st.floats(-50, 50)), min_size=1, max_size=8
    ),
)
def test_world_and_grid_coordinates_round_trip(resolution, origin, uv):
    m = _map(4, 5, resolution, origin)
    world = grid_to_world(m, uv)
    np.testing.assert_allclose(world_to_grid(m, world), uv, atol=1e-9)
    # A distance of one cell is one resolution in the world, in any direction.
    step = grid_to_world(m, [[0, 0], [1, 0], [0, 1]])
    rounding = 1e-14 * (1 + abs(origin[0]) + abs(origin[1]))  # of the origin's digits
    assert math.isclose(np.hypot(*(step[1] - step[0])), resolution, abs_tol=rounding)
    assert math.isclose(np.hypot(*(step[2] - step[0])), resolution, abs_tol=rounding)


@given(
    resolution=_RESOLUTIONS,
    origin=_ORIGINS,
    cells=st.lists(
        st.tuples(st.integers(-3, 9), st.integers(-3, 9)), min_size=1, max_size=8
    ),
)
def test_a_cell_centre_is_in_its_cell(resolution, origin, cells):
    m = _map(6, 7, resolution, origin)
    centres = cell_centres(m, cells)
    np.testing.assert_array_equal(world_to_cell(m, centres), cells)
    inside = [(0 <= r < 6 and 0 <= c < 7) for r, c in cells]
    np.testing.assert_array_equal(contains_cells(m, cells), inside)


def test_the_origin_is_the_lower_left_corner_and_yaw_turns_about_it():
    m = _map(2, 4, 0.5, (10.0, 20.0, math.pi / 2))
    # Along a row (u) the map runs up the world's y; up the columns (v), to -x.
    np.testing.assert_allclose(
        grid_to_world(m, [[0, 0], [4, 0], [0, 2]]),
        [[10, 20], [10, 22], [9, 20]],
        atol=1e-12,
    )
    np.testing.assert_array_equal(
        world_to_cell(m, [[9.9, 21.9], [10.1, 20.1]]), [[0, 3], [-1, 0]]
    )
    np.testing.assert_allclose(cell_centres(m, [[1, 3]]), [[9.25, 21.75]], atol=1e-12)


def test_a_point_on_a_cell_line_belongs_to_the_cell_above_and_right():
    m = _map(3, 3, 1.0, (0.0, 0.0, 0.0))
    assert world_to_cell(m, [[1.0, 2.0]]).tolist() == [[2, 1]]


def test_far_points_are_off_the_map_not_wrapped():
    m = _map(3, 3, 1.0, (0.0, 0.0, 0.0))
    cells = world_to_cell(m, [[1e300, -1e300]])
    assert not contains_cells(m, cells)[0]


def test_the_cells_are_read_only_and_checked():
    m = _map(2, 2, 1.0, (0, 0, 0))
    with pytest.raises(ValueError):
        m.cells[0, 0] = 1
    with pytest.raises(ValueError, match="uint8"):
        OccupancyMap(np.zeros((2, 2)), 1.0, (0, 0, 0))  # pyright: ignore[reportArgumentType]
    with pytest.raises(ValueError, match="resolution"):
        OccupancyMap(np.zeros((2, 2), np.uint8), 0.0, (0, 0, 0))
    with pytest.raises(ValueError, match="origin"):
        OccupancyMap(np.zeros((2, 2), np.uint8), 1.0, (0, 0))  # pyright: ignore[reportArgumentType]
