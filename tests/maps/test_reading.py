"""Reading map_server maps: pixel for pixel as map_server, every bad input one line.

The pictures are written here (PGM by hand, PNG by Pillow) from random pixels, read by
:func:`planners.maps.read_map_bytes`, and compared cell by cell with
:func:`tests.maps.reference.map_server_value`, map_server's loop for one pixel in Python.
"""

from __future__ import annotations

import io
import os
import re
import struct
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from planners.maps import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    decode_picture,
    map_metadata,
    read_map,
    read_map_bytes,
)
from planners.scene import ScenarioError
from tests.maps import synthetic
from tests.maps.reference import map_server_value, state_of_value

# --------------------------------------------------------------------------- pixels

_VALUES = st.one_of(
    st.sampled_from([0, 1, 50, 89, 90, 127, 128, 166, 204, 205, 206, 253, 254, 255]),
    st.integers(0, 255),
)
# Kind of file -> (Pillow mode or None for PGM, channels written, channels map_server sees)
_KINDS = {
    "pgm": (None, 1),
    "pgm-plain": (None, 1),
    "png-L": ("L", 1),
    "png-LA": ("LA", 2),
    "png-RGB": ("RGB", 3),
    "png-RGBA": ("RGBA", 4),
    "png-16": ("I;16", 1),
}


def _yaml_float(x: float) -> str:
    return np.format_float_positional(x, unique=True)


@st.composite
def _thresholds(draw) -> tuple[float, float]:
    # Thresholds that a pixel's occupancy can equal exactly, and any others.
    exact = st.integers(0, 255 * 4).map(lambda k: (255 - k / 4) / 255.0)
    free, occupied = sorted(
        draw(
            st.one_of(exact, st.floats(0, 1), st.sampled_from([0.0, 1.0, 0.196, 0.65]))
        )
        for _ in range(2)
    )
    if free == occupied:
        free, occupied = 0.196, 0.65
    return occupied, free


@st.composite
def _maps(draw):
    kind = draw(st.sampled_from(sorted(_KINDS)))
    channels = _KINDS[kind][1]
    rows, cols = draw(st.integers(1, 5)), draw(st.integers(1, 5))
    if kind == "png-16":
        pixels = draw(arrays(np.uint16, (rows, cols), elements=st.integers(0, 65535)))
    else:
        shape = (rows, cols) if channels == 1 else (rows, cols, channels)
        pixels = draw(arrays(np.uint8, shape, elements=_VALUES))
    occupied, free = draw(_thresholds())
    mode = draw(st.sampled_from([None, "trinary", "scale", "raw"]))
    negate = draw(st.booleans())
    return kind, pixels, mode, negate, occupied, free


def _encode(kind: str, pixels: np.ndarray) -> tuple[str, bytes]:
    if kind == "pgm":
        return "m.pgm", synthetic.encode_pgm(pixels)
    if kind == "pgm-plain":
        return "m.pgm", synthetic.encode_pgm(pixels, plain=True)
    return "m.png", synthetic.encode_png(pixels, _KINDS[kind][0] or "L")


def _as_map_server_sees(kind: str, pixels: np.ndarray) -> tuple[np.ndarray, bool]:
    """The channels SDL_image hands map_server: grey+alpha becomes RGBA, 16 bits 8."""
    if kind == "png-16":
        return (pixels >> 8).astype(np.uint8)[..., None], False
    if kind == "png-LA":
        grey, alpha = pixels[..., 0:1], pixels[..., 1:2]
        return np.concatenate([grey, grey, grey, alpha], axis=2), True
    if pixels.ndim == 2:
        return pixels[..., None], False
    return pixels, pixels.shape[2] == 4


@settings(max_examples=150)
@given(case=_maps())
def test_cells_are_map_servers_pixel_for_pixel(case):
    kind, pixels, mode, negate, occupied, free = case
    image, data = _encode(kind, pixels)
    yaml_text = synthetic.map_yaml(
        image,
        negate=int(negate),
        occupied_thresh=occupied,
        free_thresh=free,
        mode=mode,
    ).replace(
        f"occupied_thresh: {occupied!r}", f"occupied_thresh: {_yaml_float(occupied)}"
    )
    yaml_text = yaml_text.replace(
        f"free_thresh: {free!r}", f"free_thresh: {_yaml_float(free)}"
    )
    read = read_map_bytes(yaml_text, {image: data}, "m.yaml")
    seen, has_alpha = _as_map_server_sees(kind, pixels)
    rows, cols = seen.shape[:2]
    expected = np.zeros((rows, cols), np.uint8)
    for j in range(rows):  # j counts from the picture's top, as map_server's loop does
        for i in range(cols):
            value = map_server_value(
                [int(v) for v in seen[j, i]],
                has_alpha,
                mode or "trinary",
                negate,
                occupied,
                free,
            )
            expected[rows - j - 1, i] = state_of_value(
                value, mode or "trinary", occupied, free
            )
    np.testing.assert_array_equal(read.cells, expected)


def test_map_savers_greys_read_as_the_states():
    grid = synthetic.room(12, 16, pillars=1)
    grid[2:4, 2:4] = UNKNOWN
    for negate in (False, True):
        grey = synthetic.picture_of(grid, negate)
        for kind, data in (
            ("pgm", synthetic.encode_pgm(grey)),
            ("pgm", synthetic.encode_pgm(grey, plain=True)),
            ("png", synthetic.encode_png(grey, "L")),
            ("png", synthetic.encode_png(np.stack([grey] * 3, axis=2), "RGB")),
        ):
            yaml_text = synthetic.map_yaml(f"m.{kind}", negate=int(negate))
            read = read_map_bytes(yaml_text, {f"m.{kind}": data}, "m.yaml")
            np.testing.assert_array_equal(read.cells, grid)


def test_trinary_mode_averages_alpha_in_and_scale_mode_does_not():
    # A white pixel, fully transparent: (255 * 3 + 0) / 4 = 191.25 in trinary mode.
    pixel = np.array([[[255, 255, 255, 0]]], np.uint8)
    data = synthetic.encode_png(pixel, "RGBA")
    trinary = read_map_bytes(synthetic.map_yaml("m.png"), {"m.png": data}, "m.yaml")
    assert trinary.cells[0, 0] == UNKNOWN  # occ = 0.25: between 0.196 and 0.65
    scale = read_map_bytes(
        synthetic.map_yaml("m.png", mode="scale"), {"m.png": data}, "m.yaml"
    )
    assert scale.cells[0, 0] == FREE  # occ = 0: free, whatever the alpha


def test_the_top_row_of_the_picture_is_the_last_row_of_cells():
    grey = np.array([[0, 0, 0], [254, 254, 254]], np.uint8)  # top row black
    read = read_map_bytes(
        synthetic.map_yaml("m.pgm"), {"m.pgm": synthetic.encode_pgm(grey)}, "m.yaml"
    )
    assert read.cells.tolist() == [[FREE] * 3, [OCCUPIED] * 3]


def test_read_map_reads_the_picture_beside_the_yaml_by_its_file_name(tmp_path):
    grid = synthetic.maze(4)
    path = synthetic.write_map(
        tmp_path, "maze", grid, resolution=0.1, origin=(1, 2, 0.5)
    )
    text = path.read_text().replace(
        "image: maze.pgm", "image: /elsewhere/maps/maze.pgm"
    )
    path.write_text(text)
    read = read_map(path)
    np.testing.assert_array_equal(read.cells, grid)
    assert (read.resolution, read.origin, read.image_name) == (
        0.1,
        (1.0, 2.0, 0.5),
        "maze.pgm",
    )
    assert read.source == str(path)
    same = read_map_bytes(text, {"maze.pgm": (tmp_path / "maze.pgm").read_bytes()}, "x")
    np.testing.assert_array_equal(same.cells, read.cells)


# --------------------------------------------------------------------------- errors

_GOOD = synthetic.map_yaml("m.pgm")


def _replace(key: str, value: str | None) -> str:
    lines = [line for line in _GOOD.splitlines() if not line.startswith(f"{key}:")]
    if value is not None:
        lines.append(f"{key}: {value}")
    return "\n".join(lines) + "\n"


YAML_ERRORS = [
    ("image: [1\n", "(line 2)", r"not valid YAML"),
    ("- 1\n- 2\n", "(top level)", r"expected a YAML mapping, got list"),
    ("", "(top level)", r"expected a YAML mapping, got NoneType"),
    ("[" * 5000 + "]" * 5000, "(file)", "nested too deeply"),
    ("resolution: " + "9" * 5000 + "\n", "(file)", "a number too long to read"),
    (b"\xff\xfe\x00\x00\xd8", "(file)", "not valid YAML"),
    ("x" * 70_000, "(file)", "more than the 65536"),
    (_replace("image", None), "image", "missing required key"),
    (_replace("image", "''"), "image", "not a file name"),
    (_replace("image", "maps/.."), "image", "not a file name"),
    (_replace("image", "3"), "image", "expected a file name, got int 3"),
    (_replace("resolution", None), "resolution", "missing required key"),
    (_replace("resolution", "0"), "resolution", "must be positive, got 0.0"),
    (_replace("resolution", "-0.05"), "resolution", "must be positive"),
    (_replace("resolution", "1e300"), "resolution", "expected 0.0001 to 100 m a cell"),
    (_replace("resolution", "1e-9"), "resolution", "expected 0.0001 to 100 m a cell"),
    (_replace("origin", "[1e20, 0, 0]"), "origin[0]", r"at most 1e\+08 m"),
    (_replace("resolution", "'0.05'"), "resolution", "expected a number, got str"),
    (_replace("resolution", ".nan"), "resolution", "expected a finite number"),
    (_replace("resolution", "true"), "resolution", "expected a number, got bool"),
    (_replace("resolution", "1" * 400), "resolution", "expected a finite number"),
    (_replace("origin", None), "origin", "missing required key"),
    (_replace("origin", "[1, 2]"), "origin", r"expected \[x, y, yaw\], got list"),
    (_replace("origin", "[1, 2, 3, 4]"), "origin", r"expected \[x, y, yaw\]"),
    (_replace("origin", "{x: 1}"), "origin", r"expected \[x, y, yaw\], got dict"),
    (_replace("origin", "[1, a, 0]"), "origin[1]", "expected a number, got str"),
    (_replace("origin", "[1, 2, .inf]"), "origin[2]", "expected a finite number"),
    (_replace("negate", None), "negate", "missing required key"),
    (_replace("negate", "2"), "negate", "expected 0 or 1, got int 2"),
    (_replace("negate", "1.0"), "negate", "expected 0 or 1, got float"),
    (_replace("negate", "'0'"), "negate", "expected 0 or 1, got str"),
    (_replace("occupied_thresh", None), "occupied_thresh", "missing required key"),
    (_replace("occupied_thresh", "1.5"), "occupied_thresh", "between 0 and 1"),
    (_replace("free_thresh", "-0.1"), "free_thresh", "between 0 and 1"),
    (
        _replace("free_thresh", "0.65"),
        "free_thresh",
        r"must be below occupied_thresh \(0.65\)",
    ),
    (_replace("free_thresh", "0.9"), "free_thresh", "must be below occupied_thresh"),
    (
        _replace("mode", "Trinary"),
        "mode",
        "expected one of trinary, scale, raw, got str",
    ),
    (_replace("mode", "1"), "mode", "expected one of trinary, scale, raw, got int 1"),
    ("a: &a [*a, *a]\nimage: *a\n", "image", r"expected a file name, got list \[\["),
]


@pytest.mark.parametrize(("text", "field", "problem"), YAML_ERRORS)
def test_every_bad_yaml_is_one_line_naming_the_file_and_the_field(text, field, problem):
    with pytest.raises(ScenarioError) as info:
        read_map_bytes(
            text,
            {"m.pgm": synthetic.encode_pgm(np.zeros((2, 2), np.uint8))},
            "lab.yaml",
        )
    error = info.value
    assert (error.source, error.field) == ("lab.yaml", field), str(error)
    assert str(error).startswith(f"lab.yaml: {field}: ") and "\n" not in str(error)
    assert re.search(problem, error.problem), error.problem


def test_unknown_keys_are_ignored_as_map_server_ignores_them():
    meta = map_metadata(_GOOD + "comment: from the lab\nfree_thresh_2: [1]\n", "m.yaml")
    assert meta.free_thresh == 0.196 and meta.mode == "trinary"


def test_negate_may_be_a_boolean_and_yaml_12_floats_are_numbers():
    meta = map_metadata(
        _replace("negate", "true").replace("resolution: 0.05", "resolution: 5e-2"),
        "m.yaml",
    )
    assert meta.negate is True and meta.resolution == 0.05


def _png_of_size(width: int, height: int) -> bytes:
    """A real 1 x 1 PNG whose header says ``width`` x ``height`` (its CRC made right)."""
    data = bytearray(synthetic.encode_png(np.zeros((1, 1), np.uint8), "L"))
    ihdr = 8 + 8  # the signature, then the chunk's length and type
    data[ihdr : ihdr + 8] = struct.pack(">II", width, height)
    crc = zlib.crc32(bytes(data[ihdr - 4 : ihdr + 13]))
    data[ihdr + 13 : ihdr + 17] = struct.pack(">I", crc)
    return bytes(data)


_PNG = synthetic.encode_png(np.zeros((40, 40), np.uint8), "L")

IMAGE_ERRORS = [
    ({}, "no picture named 'm.pgm'"),
    (
        {"m.pgm": b"hello, not a picture"},
        "m.pgm: not a PNG, PGM, PPM, PBM or BMP picture",
    ),
    ({"m.pgm": b"P5\n10 10\n255\n" + bytes(20)}, "m.pgm: cannot decode"),
    (
        {"m.pgm": b"P5\n6000 6000\n255\n"},
        "m.pgm: 6000 x 6000 pixels, more than the 25,000,000",
    ),
    (
        {"m.pgm": b"P5\n20000 20000\n255\n"},
        r"m.pgm: too many pixels \(a decompression bomb\?\)",
    ),
    ({"m.pgm": _PNG[: len(_PNG) - 20]}, "m.pgm: cannot decode"),
    ({"m.pgm": _png_of_size(100, 100)}, "m.pgm: cannot decode"),
    (
        {"m.pgm": _png_of_size(7000, 7000)},
        "7000 x 7000 pixels, more than the 25,000,000",
    ),
    ({"m.pgm": b"P5\n0 3\n255\n"}, "m.pgm: "),
    ({"m.pgm": b"GIF89a" + bytes(20)}, "not a PNG, PGM, PPM, PBM or BMP picture"),
]


@pytest.mark.parametrize(("images", "problem"), IMAGE_ERRORS)
def test_every_bad_picture_is_one_line_naming_the_image(images, problem):
    with pytest.raises(ScenarioError) as info:
        read_map_bytes(_GOOD, images, "lab.yaml")
    assert info.value.field == "image" and "\n" not in str(info.value)
    assert str(info.value).startswith("lab.yaml: image: ")
    assert re.search(problem, info.value.problem), info.value.problem


def test_reading_from_disk_names_the_file_and_stays_in_its_folder(tmp_path):
    with pytest.raises(
        ScenarioError, match=r"nope.yaml: \(file\): cannot read: No such file"
    ):
        read_map(tmp_path / "nope.yaml")
    path = synthetic.write_map(tmp_path, "m", synthetic.room())
    (tmp_path / "m.pgm").unlink()
    with pytest.raises(
        ScenarioError, match=r"m.yaml: image: m.pgm: cannot read: No such file"
    ):
        read_map(path)
    (tmp_path / "m.pgm").mkdir()
    with pytest.raises(
        ScenarioError, match=r"m.yaml: image: m.pgm: not a regular file"
    ):
        read_map(path)
    (tmp_path / "m.pgm").rmdir()
    outside = tmp_path / "outside"
    outside.mkdir()
    synthetic.write_map(outside, "m", synthetic.room())
    os.symlink(outside / "m.pgm", tmp_path / "m.pgm")
    with pytest.raises(
        ScenarioError, match=r"m.yaml: image: m.pgm leads out of the map's folder"
    ):
        read_map(path)
    (tmp_path / "big.yaml").write_text("#" * 70_000)
    with pytest.raises(
        ScenarioError, match=r"big.yaml: \(file\): more than 65,536 bytes"
    ):
        read_map(tmp_path / "big.yaml")


def test_bilevel_and_palette_pictures_read_as_their_colours():
    # PBM: 1 is black. A palette PNG: read by its colours, not its indices.
    pbm = read_map_bytes(
        synthetic.map_yaml("m.pbm"), {"m.pbm": b"P1\n3 1\n1 0 1\n"}, "m"
    )
    assert pbm.cells.tolist() == [[OCCUPIED, FREE, OCCUPIED]]
    from PIL import Image

    image = Image.new("P", (3, 1))
    image.putpalette([255, 255, 255, 0, 0, 0, 205, 205, 205])  # indices 0, 1, 2
    image.putdata([1, 0, 2])
    buffer = io.BytesIO()
    image.save(buffer, "PNG")
    png = read_map_bytes(synthetic.map_yaml("m.png"), {"m.png": buffer.getvalue()}, "m")
    assert png.cells.tolist() == [[OCCUPIED, FREE, UNKNOWN]]


@pytest.mark.parametrize(
    "picture",
    [
        b"P2\n3 1\n255\n" + b"#\n" * 500_000 + b"0 35 254\n",  # Pillow: quadratic
        b"P2\n" + b"#\n" * 500_000 + b"3 1\n255\n0 35 254\n",  # in the header
        b"P5\n" + b"#\n" * 500_000 + b"3 1\n255\n" + bytes([0, 35, 254]),
        b"P5 3 1 255\n" + bytes([0, 35, 254]),  # '#' (35) as a pixel stays a pixel
    ],
    ids=["plain-data", "plain-header", "binary-header", "binary-hash-pixel"],
)
def test_comments_are_read_past_and_pixels_kept(picture):
    decoded = decode_picture(picture, "m.yaml", "m.pgm")
    assert decoded.pixels[..., 0].tolist() == [[0, 35, 254]]
