"""Read a map_server map (a YAML file and its picture) from disk or from memory.

:func:`read_map_bytes` is the one reader: the YAML text and the pictures it may name,
by file name, all in memory, so a map that came from a browser (a zip upload) never
reaches the filesystem. :func:`read_map` reads a YAML file and the picture it names
from the YAML file's folder, by that file name only, and hands both to it.
"""

from __future__ import annotations

__all__ = ["read_map", "read_map_bytes"]

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from planners.maps.grid import OccupancyMap
from planners.maps.metadata import MAX_YAML_BYTES, map_metadata
from planners.maps.pixels import (
    MAX_IMAGE_BYTES,
    cell_states,
    decode_picture,
    occupancy_values,
)
from planners.scene import ScenarioError


def read_map_bytes(
    yaml_text: bytes | str, images: Mapping[str, bytes], source: str
) -> OccupancyMap:
    """Read a map from memory: its YAML text and the pictures it may name.

    Parameters
    ----------
    yaml_text
        The YAML file's content.
    images
        Pictures by plain file name (``"lab.pgm"``); the one the YAML's ``image`` names
        is looked up by its file name, without any folder part.
    source
        What to call the map in messages, and its name: the YAML file's name or path.

    Returns
    -------
    OccupancyMap

    Raises
    ------
    ScenarioError
        For any problem of the YAML file (:func:`planners.maps.map_metadata`), a picture
        missing from ``images``, or a picture that cannot be read
        (:func:`planners.maps.decode_picture`); the message names ``source`` and the field.
    """
    meta = map_metadata(yaml_text, source)
    data = images.get(meta.image)
    if data is None:
        raise ScenarioError(source, "image", f"no picture named {meta.image!r}")
    picture = decode_picture(data, source, meta.image)
    values = occupancy_values(
        picture, meta.mode, meta.negate, meta.occupied_thresh, meta.free_thresh
    )
    states = cell_states(values, meta.mode, meta.occupied_thresh, meta.free_thresh)
    # The picture's top row is the map's last: row 0 of the cells is the bottom one.
    cells = np.ascontiguousarray(states[::-1])
    return OccupancyMap(cells, meta.resolution, meta.origin, source, meta.image)


def read_map(yaml_path: str | os.PathLike[str]) -> OccupancyMap:
    """Read a map_server map from disk: the YAML file and the picture beside it.

    The picture is the file of the YAML's ``image`` file name in the YAML file's folder
    (a folder part of ``image`` is ignored), and must not lead out of that folder
    through a link.

    Raises
    ------
    ScenarioError
        When either file cannot be read, or as :func:`read_map_bytes` does; the message
        names the YAML file's path.

    Examples
    --------
    >>> read_map("no/such/map.yaml")
    Traceback (most recent call last):
    ...
    planners.scene.ScenarioError: no/such/map.yaml: (file): cannot read: No such file or directory
    """
    path = Path(yaml_path)
    source = str(path)
    yaml_text = _read(path, MAX_YAML_BYTES, source, "(file)")
    meta = map_metadata(yaml_text, source)
    picture_path = path.parent / meta.image
    folder = path.parent.resolve()
    try:
        inside = picture_path.resolve().parent == folder
    except (OSError, RuntimeError):  # a loop of links
        inside = False
    if not inside:
        raise ScenarioError(
            source, "image", f"{meta.image} leads out of the map's folder (a link)"
        )
    data = _read(picture_path, MAX_IMAGE_BYTES, source, "image")
    return read_map_bytes(yaml_text, {meta.image: data}, source)


def _read(path: Path, limit: int, source: str, field: str) -> bytes:
    """Read a regular file of at most ``limit`` bytes; a problem names ``field``."""
    name = "" if field == "(file)" else f"{path.name}: "
    try:
        if path.exists() and not path.is_file():  # a folder, a pipe, a device
            raise ScenarioError(source, field, f"{name}not a regular file")
        with path.open("rb") as handle:
            data = handle.read(limit + 1)
    except OSError as error:
        raise ScenarioError(
            source, field, f"{name}cannot read: {error.strerror or error}"
        ) from None
    if len(data) > limit:
        raise ScenarioError(source, field, f"{name}more than {limit:,} bytes")
    return data
