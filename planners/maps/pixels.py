"""A map's picture: decoded within bounds, read pixel by pixel as map_server reads it.

How a pixel becomes a cell follows ROS 1 map_server's ``loadMapFromFile``
(``map_server/src/image_loader.cpp`` of ros-planning/navigation, noetic), step for step
and in the same floating-point operations:

1. the mean of the pixel's channels. In ``trinary`` mode *every* channel counts, alpha
   included (map_server keeps this "to preserve existing behavior"); in ``scale`` and
   ``raw`` modes an image with an alpha channel averages the others;
2. with ``negate``, the mean becomes 255 - mean;
3. ``raw``: the cell's value is the mean itself, cut to an integer (0..255, published as
   a signed byte: 255 is -1);
4. otherwise occ = (255 - mean) / 255, and the value is 100 when occ > occupied_thresh,
   0 when occ < free_thresh, and in between -1 (``trinary``), or in ``scale`` mode
   ``int(99 * (occ - free) / (occupied - free))`` unless the pixel's alpha is 0, which
   gives -1. map_server takes the alpha of a pixel of two or more channels from its last
   channel, so an RGB picture's blue channel serves as alpha there: this is kept.

The value then gives the cell's state (:mod:`planners.maps.grid`): 0 is ``FREE``, 100
``OCCUPIED``, -1 ``UNKNOWN``. Values between (``scale`` mode's 1..99, the occupancy
between the thresholds) are ``UNKNOWN``; in ``raw`` mode a value v of 1..99 is read as the
probability v / 100 by the same thresholds (above ``occupied_thresh``: occupied, below
``free_thresh``: free, else unknown), and 101..255 is unknown.

nav2_map_server (``nav2_map_server/src/map_io.cpp``) reads the same files the same way
in ``trinary`` mode; it differs in ``scale`` mode (any pixel not fully opaque is unknown,
and the in-between value is rounded, ``rint(100 * ratio)``) and in ``raw`` mode (it rounds
the mean and ignores ``negate``). The pictures SDL_image hands ROS 1 are what Pillow
decodes here, with these conversions: a bilevel picture is black and white (0 and 255);
grey with alpha is RGBA with the grey in R, G and B (as libpng expands it for SDL); a
16-bit grey picture keeps its high byte (libpng's ``strip_16``); a palette picture is read
by its colours (nav2's reading; ROS 1 reads the palette's index, which is the same for the
grey palettes map_saver writes).

Pictures are PNG, PGM/PPM/PBM (binary and plain) or BMP, of at most ``MAX_PIXELS``
pixels; the size is checked from the header before anything is decoded.
"""

from __future__ import annotations

__all__ = [
    "IMAGE_FORMATS",
    "MAX_IMAGE_BYTES",
    "MAX_PIXELS",
    "Picture",
    "cell_states",
    "decode_picture",
    "occupancy_values",
]

import dataclasses
import io
import re
import struct

import numpy as np
import numpy.typing as npt

from planners.maps.grid import FREE, OCCUPIED, UNKNOWN
from planners.scene import ScenarioError

MAX_PIXELS = 25_000_000
"""Largest picture read: 5,000 x 5,000 pixels (250 m x 250 m at 5 cm)."""
MAX_IMAGE_BYTES = 256 * 1024 * 1024
"""Largest picture file read (a plain PGM of 25 million pixels is about 100 MB)."""
IMAGE_FORMATS = ("PNG", "PPM", "BMP")
"""Pillow's names of the formats read (PPM covers PGM and PBM, binary and plain)."""
_ROWS_PER_BLOCK_PIXELS = 1 << 20  # the mean is taken a million pixels at a time
_DECODE_ERRORS = (OSError, ValueError, SyntaxError, EOFError, struct.error, IndexError)


@dataclasses.dataclass(frozen=True, eq=False)
class Picture:
    """A decoded picture, as map_server's loop sees it."""

    pixels: npt.NDArray[np.uint8]
    """Shape (rows, cols, channels), row 0 the picture's top; 1, 3 or 4 channels."""
    has_alpha: bool
    """Whether the last channel is alpha (4 channels)."""


def decode_picture(data: bytes, source: str, name: str) -> Picture:
    """Decode a map's picture, refusing what is too big or not a picture.

    Parameters
    ----------
    data
        The file's bytes.
    source, name
        The map's YAML file and the picture's file name, for messages.

    Raises
    ------
    ScenarioError
        Field ``image``: not PNG, PGM/PPM/PBM or BMP; more than ``MAX_PIXELS`` pixels or
        ``MAX_IMAGE_BYTES`` bytes (a decompression bomb included); cut short or corrupt;
        a kind of pixel map_server does not read (floating point, CMYK).
    """
    from PIL import Image, UnidentifiedImageError  # noqa: PLC0415 - loaded when a map is read

    if len(data) > MAX_IMAGE_BYTES:
        raise ScenarioError(
            source, "image", f"{name}: {len(data)} bytes, more than {MAX_IMAGE_BYTES}"
        )
    try:
        data = without_comments(data)
    except ValueError as error:
        raise ScenarioError(source, "image", f"{name}: {error}") from None
    try:
        with Image.open(io.BytesIO(data), formats=IMAGE_FORMATS) as image:
            _check_size(source, name, image.size)
            return _picture(source, name, image)
    except Image.DecompressionBombError:
        raise ScenarioError(
            source, "image", f"{name}: too many pixels (a decompression bomb?)"
        ) from None
    except UnidentifiedImageError:
        raise ScenarioError(
            source, "image", f"{name}: not a PNG, PGM, PPM, PBM or BMP picture"
        ) from None
    except _DECODE_ERRORS as error:
        raise ScenarioError(
            source, "image", f"{name}: cannot decode: {_one_line(error)}"
        ) from None


MAX_PNM_HEADER = 4096
"""Longest stretch [bytes] of blanks and comments before a PNM header's field: Pillow
reads a header a byte at a time (30 MB of blanks took it 49 s)."""
_PNM_FIELD = re.compile(rb"(?:\s|#[^\n\r]*)*(\S+)")
"""A header field of a PNM picture, after the blanks and comments before it."""


def without_comments(data: bytes) -> bytes:
    r"""Return a PNM picture (PBM, PGM, PPM) without its comments; others as they are.

    Pillow removes a plain picture's comments one at a time, rebuilding its buffer
    for each (two bytes of ``#\n`` repeated a million times took minutes), and reads
    a binary picture's header byte by byte. Removed here in one pass: in a plain
    picture everywhere, in a binary one in the header only (its pixels may hold any
    byte).

    Examples
    --------
    >>> without_comments(b"P2\n# a map\n2 1\n255\n0 # dark\n254\n")
    b'P2 2 1 255\n\n0 \n254\n'
    >>> without_comments(b"P5\n#c\n2 1 255\n#\xfe")  # the pixel '#' stays
    b'P5 2 1 255\n#\xfe'

    Raises
    ------
    ValueError
        When a header field is not found within :data:`MAX_PNM_HEADER` bytes.
    """
    magic = data[:2]
    if magic not in (b"P1", b"P2", b"P3", b"P4", b"P5", b"P6"):
        return data
    fields, at = [], 0
    for _ in range(3 if magic in (b"P1", b"P4") else 4):  # magic, width, height[, max]
        found = _PNM_FIELD.match(data, at, min(len(data), at + MAX_PNM_HEADER))
        if found is None:
            raise ValueError(
                f"a PNM header of more than {MAX_PNM_HEADER} bytes, or cut short"
            )
        fields.append(found.group(1))
        at = found.end()
    header = b" ".join(fields) + b"\n"
    if magic in (b"P1", b"P2", b"P3"):
        return header + re.sub(rb"#[^\n\r]*", b"", data[at:])
    return header + data[at + 1 :]


def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    return text if len(text) <= 120 else text[:117] + "..."


def _check_size(source: str, name: str, size: tuple[int, int]) -> None:
    width, height = size
    if width * height > MAX_PIXELS:
        raise ScenarioError(
            source,
            "image",
            f"{name}: {width} x {height} pixels, more than the {MAX_PIXELS:,} a map may have",
        )
    if width < 1 or height < 1:
        raise ScenarioError(
            source, "image", f"{name}: empty picture ({width} x {height})"
        )


def _picture(source: str, name: str, image: object) -> Picture:
    """Convert a Pillow image to the channels SDL_image gives map_server."""
    from PIL import Image  # noqa: PLC0415

    assert isinstance(image, Image.Image)
    mode = image.mode
    if mode in ("I", "I;16", "I;16B", "I;16L"):  # 16-bit grey: the high byte
        wide = np.asarray(image).astype(np.int64)
        return Picture(
            (np.clip(wide, 0, 65535) >> 8).astype(np.uint8)[..., None], False
        )
    if mode == "1":
        image = image.convert("L")
    elif mode == "P":
        image = image.convert("RGBA" if "transparency" in image.info else "RGB")
    elif mode in ("LA", "La", "PA", "RGBa"):
        image = image.convert("RGBA")
    elif mode not in ("L", "RGB", "RGBA"):
        raise ScenarioError(
            source, "image", f"{name}: pixels of mode {mode} are not read"
        )
    pixels = np.asarray(image, dtype=np.uint8)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    return Picture(pixels, pixels.shape[2] == 4)


def occupancy_values(
    picture: Picture,
    mode: str,
    negate: bool,
    occupied_thresh: float,
    free_thresh: float,
) -> npt.NDArray[np.int16]:
    """Return map_server's cell values (the OccupancyGrid's bytes) in the picture's rows.

    -1 is unknown, 0 free, 100 occupied; ``scale`` mode gives 0..99 between the
    thresholds, ``raw`` mode the mean as a signed byte. Row 0 is the picture's top row,
    as in the picture (map_server flips the rows when it stores them).

    Examples
    --------
    >>> grey = Picture(np.array([[[0], [128], [255]]], np.uint8), False)
    >>> occupancy_values(grey, "trinary", False, 0.65, 0.196).tolist()
    [[100, -1, 0]]
    >>> occupancy_values(grey, "raw", True, 0.65, 0.196).tolist()
    [[-1, 127, 0]]
    """
    pixels = picture.pixels
    rows, cols, _ = pixels.shape
    out = np.empty((rows, cols), dtype=np.int16)
    step = max(1, _ROWS_PER_BLOCK_PIXELS // cols)
    for top in range(0, rows, step):
        block = pixels[top : top + step]
        out[top : top + step] = _block_values(
            block, picture.has_alpha, mode, negate, occupied_thresh, free_thresh
        )
    return out


def _block_values(  # noqa: PLR0917
    block: npt.NDArray[np.uint8],
    has_alpha: bool,
    mode: str,
    negate: bool,
    occ_th: float,
    free_th: float,
) -> npt.NDArray[np.int16]:
    """map_server's loop body on a block of rows, as whole-array operations."""
    n_channels = block.shape[2]
    avg_channels = n_channels if mode == "trinary" or not has_alpha else n_channels - 1
    color_sum = block[..., :avg_channels].sum(axis=2, dtype=np.int64)
    color_avg = color_sum / float(avg_channels)
    if negate:
        color_avg = 255 - color_avg
    if mode == "raw":
        # value = color_avg: a double to an unsigned char (cut), stored as a signed byte
        return np.trunc(color_avg).astype(np.uint8).view(np.int8).astype(np.int16)
    occ = (255 - color_avg) / 255.0
    if mode == "scale":
        with np.errstate(over="ignore"):  # thresholds a hair apart: inf, set below
            ratio = (occ - free_th) / (occ_th - free_th)
            value = np.trunc(99 * ratio).clip(0, 99).astype(np.int16)
        alpha = block[..., n_channels - 1] if n_channels > 1 else None
        if alpha is not None:
            value[alpha < 1.0] = -1
    else:
        value = np.full(occ.shape, -1, dtype=np.int16)
    value[occ < free_th] = 0
    value[occ > occ_th] = 100
    return value


def cell_states(
    values: npt.NDArray[np.int16], mode: str, occupied_thresh: float, free_thresh: float
) -> npt.NDArray[np.uint8]:
    """Return the states (``FREE``, ``OCCUPIED``, ``UNKNOWN``) of map_server's values.

    Examples
    --------
    >>> v = np.array([0, 100, -1, 50, 10, 90, 120], np.int16)
    >>> cell_states(v, "scale", 0.65, 0.196).tolist()
    [0, 1, 2, 2, 2, 2, 2]
    >>> cell_states(v, "raw", 0.65, 0.196).tolist()
    [0, 1, 2, 2, 0, 1, 2]
    """
    states = np.full(values.shape, UNKNOWN, dtype=np.uint8)
    if mode == "raw":
        between = (values > 0) & (values < 100)
        probability = values / 100.0
        states[between & (probability > occupied_thresh)] = OCCUPIED
        states[between & (probability < free_thresh)] = FREE
    states[values == 0] = FREE
    states[values == 100] = OCCUPIED
    return states
