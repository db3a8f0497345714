"""The map on the floor, as headless Chromium draws it: where the map is, and only there.

A room whose walls are surrounded by cells nobody saw: beyond the walls the floor is
the map's grey; switching the map's layer off gives the plain white floor back. The
pixels are read where the slide's camera projects the map's cells, and inside the room
the map changes no pixel.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import shapely
from PIL import Image
from shapely import Polygon

from app import start_app
from app.media.pictures import open_studio
from app.media.slides import SlideOptions, project
from planners import maps
from tests.maps.synthetic import write_map

W, H = 480, 360
BARE = SlideOptions(legend=False, title="", labels=False)


def _room(tmp_path: Path) -> Path:
    grid = np.full((40, 60), maps.UNKNOWN, np.uint8)
    grid[8:32, 8:52] = maps.OCCUPIED  # the walls, one cell thick
    grid[9:31, 9:51] = maps.FREE
    grid[33:36, 38:44] = maps.OCCUPIED  # beyond the top wall only: not mirrored
    return write_map(tmp_path, "room", grid, resolution=0.1, origin=(1.0, -2.0, 0.2))


def _pixels(png: bytes, points: np.ndarray) -> np.ndarray:
    picture = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)
    cols, rows = np.round(points).astype(int).T
    assert ((0 <= cols) & (cols < W) & (0 <= rows) & (rows < H)).all(), points
    return picture[rows, cols]


def test_the_maps_picture_lies_under_the_scene_where_the_map_says(browser, tmp_path):
    planner = start_app(_room(tmp_path), print_url=False)
    try:
        frame = planner.controller.frame
        assert frame is not None
        floor_map = frame.floor_map
        with open_studio(planner, browser, width=W, height=H) as studio:
            shown = studio.picture(options=BARE)
            assert studio.slide is not None
            camera = studio.slide.camera
            planner.controller.set_layer("map", False)
            assert planner.wait_idle(30)
            hidden = studio.picture(options=BARE)
        scene = planner.controller.scene
        assert scene.boundary is not None
        boundary = np.asarray(scene.boundary.exterior.coords)
    finally:
        planner.stop()
    # Unknown cells just beyond the walls' mesh (0.12 m thick), on all four sides.
    beyond = [[20, 6], [20, 53], [5, 30], [34, 30]]
    unknown = maps.cell_centres(floor_map, beyond)
    assert (floor_map.cells[tuple(np.array(beyond).T)] == maps.UNKNOWN).all()
    at = project(camera, W, H, np.column_stack([unknown, np.zeros(len(unknown))]))
    grey = _pixels(shown, at)
    white = _pixels(hidden, at)
    # map_server's grey (205), give or take the renderer's shading; the floor is white.
    assert (np.abs(grey - 205) <= 24).all(), grey
    assert (white >= 235).all(), white
    # The block beyond the top wall is black where the map says, and its mirror image
    # below the room is the unknown grey: the picture is not flipped.
    block = maps.cell_centres(floor_map, [[34, 41], [5, 41]])
    at = project(camera, W, H, np.column_stack([block, np.zeros(2)]))
    dark, mirror = _pixels(shown, at)
    assert (dark <= 60).all() and (np.abs(mirror - 205) <= 24).all(), (dark, mirror)
    # Inside the room nothing changes: the free cells are as light as the floor, and
    # whatever is drawn there is drawn over the map.
    room = Polygon(
        project(camera, W, H, np.column_stack([boundary, np.zeros(len(boundary))]))
    )
    a = np.asarray(Image.open(io.BytesIO(shown)).convert("RGB"), dtype=int)
    b = np.asarray(Image.open(io.BytesIO(hidden)).convert("RGB"), dtype=int)
    rows, cols = np.nonzero(np.abs(a - b).max(axis=2) > 24)
    assert len(rows) > 0.05 * W * H  # the grey band is a good part of the picture
    changed = shapely.points(cols + 0.5, rows + 0.5)
    assert not shapely.within(changed, room.buffer(-2.0)).any()
