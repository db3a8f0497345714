"""Synthetic map_server maps: grids of rooms, mazes and noisy scans, written as files.

Grids are ``uint8`` arrays of the states of :mod:`planners.maps.grid` (``FREE``,
``OCCUPIED``, ``UNKNOWN``), row 0 at the bottom, as :class:`planners.maps.OccupancyMap`
holds them. :func:`picture_of` turns a grid into the grey picture map_saver would write
(free 254, occupied 0, unknown 205, the top row first); the encoders write PGM by hand
(binary P5 and plain P2) and PNG through Pillow (grey, grey with alpha, RGB, RGBA).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image

from planners.maps import FREE, OCCUPIED, UNKNOWN

SAVER_GREY = {FREE: 254, OCCUPIED: 0, UNKNOWN: 205}
"""The grey map_saver writes for each state (trinary thresholds 0.65 and 0.196)."""


# --------------------------------------------------------------------------- grids


def room(rows: int = 20, cols: int = 30, pillars: int = 2, seed: int = 0) -> np.ndarray:
    """A walled room (walls one cell thick) with a few rectangular pillars inside."""
    rng = np.random.default_rng(seed)
    grid = np.full((rows, cols), FREE, np.uint8)
    grid[[0, -1], :] = OCCUPIED
    grid[:, [0, -1]] = OCCUPIED
    for _ in range(pillars):
        h, w = rng.integers(2, max(3, rows // 4)), rng.integers(2, max(3, cols // 4))
        r, c = rng.integers(3, rows - h - 3), rng.integers(3, cols - w - 3)
        grid[r : r + h, c : c + w] = OCCUPIED
    return grid


def maze(cells: int = 6, corridor: int = 2, seed: int = 0) -> np.ndarray:
    """A perfect maze of ``cells`` x ``cells`` rooms, corridors ``corridor`` cells wide."""
    rng = np.random.default_rng(seed)
    size = cells * (corridor + 1) + 1
    grid = np.full((size, size), OCCUPIED, np.uint8)
    seen = np.zeros((cells, cells), bool)
    stack = [(0, 0)]
    seen[0, 0] = True

    def open_room(i: int, j: int) -> None:
        r, c = 1 + i * (corridor + 1), 1 + j * (corridor + 1)
        grid[r : r + corridor, c : c + corridor] = FREE

    open_room(0, 0)
    while stack:
        i, j = stack[-1]
        options = [
            (i + di, j + dj)
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
            if 0 <= i + di < cells and 0 <= j + dj < cells and not seen[i + di, j + dj]
        ]
        if not options:
            stack.pop()
            continue
        ni, nj = options[rng.integers(len(options))]
        seen[ni, nj] = True
        open_room(ni, nj)
        r0, c0 = 1 + min(i, ni) * (corridor + 1), 1 + min(j, nj) * (corridor + 1)
        if ni != i:  # knock down the wall between the two rooms
            grid[r0 + corridor, c0 : c0 + corridor] = FREE
        else:
            grid[r0 : r0 + corridor, c0 + corridor] = FREE
        stack.append((ni, nj))
    return grid


def noisy_room(rows: int = 40, cols: int = 50, seed: int = 0) -> np.ndarray:
    """A room as a scan leaves it: ragged walls, speckles, unknown outside and in shadows."""
    rng = np.random.default_rng(seed)
    grid = np.full((rows, cols), UNKNOWN, np.uint8)
    grid[3:-3, 3:-3] = OCCUPIED
    grid[4:-4, 4:-4] = FREE
    ragged = rng.random((rows, cols)) < 0.25  # the walls' cells flicker inward and out
    inner = np.zeros((rows, cols), bool)
    inner[4:-4, 4:-4] = True
    edge = inner & ~np.pad(inner[1:-1, 1:-1], 1)
    grid[edge & ragged] = OCCUPIED
    speckles = (rng.random((rows, cols)) < 0.01) & inner
    grid[speckles] = OCCUPIED
    free_specks = (rng.random((rows, cols)) < 0.05) & (grid == OCCUPIED) & ~inner
    grid[free_specks] = FREE
    grid[rows // 2 : rows // 2 + 4, cols // 3 : cols // 3 + 3] = UNKNOWN  # a shadow
    grid[rows // 3 : rows // 3 + 2, cols // 2 : cols // 2 + 6] = OCCUPIED  # a table
    return grid


def thin_walls(rows: int = 24, cols: int = 32) -> np.ndarray:
    """Walls one cell thick, straight and diagonal, with gaps of one and three cells."""
    grid = np.full((rows, cols), FREE, np.uint8)
    grid[[0, -1], :] = OCCUPIED
    grid[:, [0, -1]] = OCCUPIED
    grid[:, cols // 2] = OCCUPIED
    grid[5, cols // 2] = FREE  # a gap of one cell
    grid[12:15, cols // 2] = FREE  # a gap of three
    for k in range(3, min(rows, cols) - 6):  # a diagonal wall: cells meet at corners
        grid[k, k // 2 + 2] = OCCUPIED if k != 9 else FREE
    grid[rows - 6 : rows - 2, cols - 8 : cols - 3] = UNKNOWN
    return grid


# --------------------------------------------------------------------------- pictures


def picture_of(grid: np.ndarray, negate: bool = False) -> np.ndarray:
    """The grey picture (top row first) map_saver writes for a grid of states."""
    grey = np.zeros(grid.shape, np.uint8)
    for state, value in SAVER_GREY.items():
        grey[grid == state] = value
    if negate:
        grey = 255 - grey
    return np.ascontiguousarray(grey[::-1])


def encode_pgm(grey: np.ndarray, plain: bool = False) -> bytes:
    """A PGM file of an 8-bit grey picture: binary (P5) or plain text (P2)."""
    rows, cols = grey.shape
    if plain:
        lines = [" ".join(str(v) for v in row) for row in grey]
        return (
            f"P2\n# written by tests/maps\n{cols} {rows}\n255\n".encode()
            + ("\n".join(lines) + "\n").encode()
        )
    return f"P5\n{cols} {rows}\n255\n".encode() + grey.astype(np.uint8).tobytes()


def encode_png(pixels: np.ndarray, mode: str) -> bytes:
    """A PNG file of ``pixels`` (rows, cols) or (rows, cols, channels) in Pillow's mode.

    ``uint16`` pixels make a 16-bit grey PNG (mode ``I;16``).
    """
    buffer = io.BytesIO()
    data = np.ascontiguousarray(pixels)
    image = (
        Image.fromarray(data)
        if data.dtype == np.uint16
        else Image.fromarray(data, mode)
    )
    image.save(buffer, "PNG")
    return buffer.getvalue()


def map_yaml(
    image: str,
    *,
    resolution: float = 0.05,
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
    negate: int = 0,
    occupied_thresh: float = 0.65,
    free_thresh: float = 0.196,
    mode: str | None = None,
) -> str:
    """A map_server YAML file's text."""
    lines = [
        f"image: {image}",
        f"resolution: {resolution!r}",
        f"origin: [{origin[0]!r}, {origin[1]!r}, {origin[2]!r}]",
        f"negate: {negate}",
        f"occupied_thresh: {occupied_thresh!r}",
        f"free_thresh: {free_thresh!r}",
    ]
    if mode is not None:
        lines.append(f"mode: {mode}")
    return "\n".join(lines) + "\n"


def write_map(
    folder: Path,
    name: str,
    grid: np.ndarray,
    *,
    kind: str = "pgm",
    negate: bool = False,
    **yaml_fields,
) -> Path:
    """Write ``grid`` as map_saver would (``kind``: pgm, pgm-plain or png); return the YAML."""
    grey = picture_of(grid, negate)
    if kind == "png":
        image, data = f"{name}.png", encode_png(grey, "L")
    else:
        image, data = f"{name}.pgm", encode_pgm(grey, plain=kind == "pgm-plain")
    (folder / image).write_bytes(data)
    path = folder / f"{name}.yaml"
    path.write_text(map_yaml(image, negate=int(negate), **yaml_fields))
    return path
