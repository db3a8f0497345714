"""A map_server YAML file: its fields, checked one by one.

ROS's ``map_server`` describes a map in a few lines of YAML::

    image: lab.pgm
    resolution: 0.05
    origin: [-10.0, -10.0, 0.0]
    negate: 0
    occupied_thresh: 0.65
    free_thresh: 0.196
    mode: trinary        # optional: trinary (the default), scale or raw

The keys map_server requires are required here (``image``, ``resolution``, ``origin``,
``negate``, ``occupied_thresh``, ``free_thresh``); ``mode`` is optional; other keys are
ignored, as map_server ignores them. Every value must have its type: a number written as
a string (``resolution: "0.05"``) is refused (``5e-2`` is a number, as YAML 1.2 and
map_server's yaml-cpp read it), and so are thresholds outside [0, 1] or a
``free_thresh`` that is not below ``occupied_thresh``. ``negate`` is 0 or 1 (``true`` and
``false`` too, as nav2_map_server reads them).

The image is named by its **file name** only: ``image: maps/lab.pgm`` and
``image: /home/me/maps/lab.pgm`` both name ``lab.pgm``, which is looked up beside the YAML
file (or, for a map read from memory, among the files given with it). No text of a map
file is ever used as a path.

Every problem raises :class:`planners.scene.ScenarioError` naming the file and the key.
"""

from __future__ import annotations

__all__ = [
    "MAP_MODES",
    "MAX_ORIGIN",
    "MAX_YAML_BYTES",
    "RESOLUTIONS",
    "MapMetadata",
    "map_metadata",
]

import dataclasses
import math
import re
import reprlib
from collections.abc import Mapping
from typing import Any

from planners.scene import ScenarioError

MAP_MODES = ("trinary", "scale", "raw")
"""map_server's ``mode`` values; ``trinary`` when the key is left out."""
MAX_YAML_BYTES = 65_536
"""Largest YAML file read (a map's is a few hundred bytes)."""


@dataclasses.dataclass(frozen=True)
class MapMetadata:
    """The fields of a map_server YAML file, checked."""

    image: str
    """The image's file name (the YAML's ``image`` without any folder part)."""
    resolution: float
    """Side of a cell [m]."""
    origin: tuple[float, float, float]
    """World pose (x, y, yaw) of the lower-left corner of the image's lower-left pixel."""
    negate: bool
    """Whether white means occupied and black free."""
    occupied_thresh: float
    """A pixel whose occupancy is above this is occupied."""
    free_thresh: float
    """A pixel whose occupancy is below this is free."""
    mode: str = "trinary"
    """How pixels are read: ``trinary``, ``scale`` or ``raw`` (:mod:`planners.maps.pixels`)."""


RESOLUTIONS = (1e-4, 100.0)
"""Cell sizes [m] a map may have: a tenth of a millimetre to 100 m (ROS maps use about
1 to 10 cm); beyond them a map's world overflows what the planners can draw."""
MAX_ORIGIN = 1e8
"""Largest distance [m] of a map's origin from the world's (a UTM northing is about 5e6)."""


def map_metadata(yaml_text: bytes | str, source: str) -> MapMetadata:
    r"""Parse and check a map_server YAML file's text.

    Parameters
    ----------
    yaml_text
        The file's content (at most ``MAX_YAML_BYTES``).
    source
        What to call the file in messages.

    Raises
    ------
    ScenarioError
        Not YAML, not a mapping, a required key missing, a value of the wrong type or
        out of range; the message names ``source`` and the key.

    Examples
    --------
    >>> meta = map_metadata(
    ...     "image: maps/lab.pgm\nresolution: 0.05\norigin: [-1, -2, 0]\nnegate: 0\n"
    ...     "occupied_thresh: 0.65\nfree_thresh: 0.196\n", "lab.yaml")
    >>> meta.image, meta.origin, meta.mode
    ('lab.pgm', (-1.0, -2.0, 0.0), 'trinary')
    >>> map_metadata("image: lab.pgm\nresolution: 0", "lab.yaml")
    Traceback (most recent call last):
    ...
    planners.scene.ScenarioError: lab.yaml: resolution: must be positive, got 0.0
    """
    data = _document(yaml_text, source)
    image = _image_name(source, _get(source, data, "image"))
    resolution = _number(source, "resolution", data, positive=True)
    if not RESOLUTIONS[0] <= resolution <= RESOLUTIONS[1]:
        raise ScenarioError(
            source,
            "resolution",
            f"expected {RESOLUTIONS[0]:g} to {RESOLUTIONS[1]:g} m a cell, got {resolution!r}",
        )
    origin = _origin(source, data)
    negate = _negate(source, data)
    occupied = _threshold(source, "occupied_thresh", data)
    free = _threshold(source, "free_thresh", data)
    if not free < occupied:
        raise ScenarioError(
            source,
            "free_thresh",
            f"must be below occupied_thresh ({occupied!r}), got {free!r}",
        )
    mode = data.get("mode", "trinary")
    if mode not in MAP_MODES:
        raise ScenarioError(
            source,
            "mode",
            f"expected one of {', '.join(MAP_MODES)}, got {_describe(mode)}",
        )
    return MapMetadata(image, resolution, origin, negate, occupied, free, mode)


def _document(yaml_text: bytes | str, source: str) -> Mapping[Any, Any]:
    import yaml  # noqa: PLC0415 - PyYAML is loaded only by a process that reads maps

    size = len(yaml_text.encode() if isinstance(yaml_text, str) else yaml_text)
    if size > MAX_YAML_BYTES:
        raise ScenarioError(
            source,
            "(file)",
            f"{size} bytes, more than the {MAX_YAML_BYTES} a map's YAML file may have",
        )
    try:
        data = yaml.load(yaml_text, Loader=_loader(yaml))  # a SafeLoader
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        where = f"(line {mark.line + 1})" if mark is not None else "(file)"
        raise ScenarioError(
            source, where, f"not valid YAML: {_one_line(error.problem)}"
        ) from None
    except yaml.YAMLError as error:  # the reader's: not UTF-8 or UTF-16 text
        raise ScenarioError(
            source, "(file)", f"not valid YAML: {_one_line(error)}"
        ) from None
    except RecursionError:
        raise ScenarioError(source, "(file)", "nested too deeply to be a map") from None
    except ValueError:  # Python reads integers of at most 4,300 digits
        raise ScenarioError(
            source, "(file)", "a number too long to read (more than 4,300 digits)"
        ) from None
    if not isinstance(data, Mapping):
        raise ScenarioError(
            source, "(top level)", f"expected a YAML mapping, got {_describe(data)}"
        )
    return data


def _loader(yaml: Any) -> type:
    """PyYAML's SafeLoader, also reading YAML 1.2's floats without a dot (``5e-2``).

    PyYAML follows YAML 1.1, where ``resolution: 5e-2`` is a string; map_server's
    yaml-cpp reads it as a number, and so does this loader. Made per call: a class
    attribute changed once would be state shared by every caller.
    """

    class Loader(yaml.SafeLoader):
        pass

    Loader.add_implicit_resolver(
        "tag:yaml.org,2002:float",
        re.compile(r"^[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+$"),
        list("-+0123456789"),
    )
    return Loader


def _get(source: str, data: Mapping[Any, Any], key: str) -> Any:
    if key not in data:
        raise ScenarioError(source, key, "missing required key")
    return data[key]


def _one_line(text: object) -> str:
    line = " ".join(str(text).split())
    return line if len(line) <= 120 else line[:117] + "..."


def _describe(value: Any) -> str:
    # reprlib: a YAML file may nest aliases so that the value's full text is endless.
    short = reprlib.Repr()
    short.maxlevel, short.maxlist, short.maxdict = 2, 4, 4
    short.maxstring = short.maxother = 40
    return f"{type(value).__name__} {short.repr(value)}"


def _image_name(source: str, value: Any) -> str:
    if not isinstance(value, str):
        raise ScenarioError(
            source, "image", f"expected a file name, got {_describe(value)}"
        )
    name = value.replace("\\", "/").rpartition("/")[2]
    if name in ("", ".", "..") or any(ord(ch) < 32 for ch in name):
        raise ScenarioError(source, "image", f"not a file name: {_describe(value)}")
    return name


def _number(
    source: str, field: str, data: Mapping[Any, Any], *, positive: bool = False
) -> float:
    number = _finite(source, field, _get(source, data, field))
    if positive and not number > 0:
        raise ScenarioError(source, field, f"must be positive, got {number!r}")
    return number


def _finite(source: str, field: str, value: Any) -> float:
    # bool is an int in Python; "resolution: true" is a mistake, not 1 m.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(source, field, f"expected a number, got {_describe(value)}")
    try:
        number = float(value)
    except OverflowError:  # an integer beyond float64
        number = math.inf
    if not math.isfinite(number):
        raise ScenarioError(source, field, f"expected a finite number, got {value!r}")
    return number


def _origin(source: str, data: Mapping[Any, Any]) -> tuple[float, float, float]:
    value = _get(source, data, "origin")
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ScenarioError(
            source, "origin", f"expected [x, y, yaw], got {_describe(value)}"
        )
    x, y, yaw = (_finite(source, f"origin[{k}]", v) for k, v in enumerate(value))
    for k, v in enumerate((x, y)):
        if abs(v) > MAX_ORIGIN:
            raise ScenarioError(
                source,
                f"origin[{k}]",
                f"expected at most {MAX_ORIGIN:g} m from the world's origin, got {v!r}",
            )
    return (x, y, math.remainder(yaw, math.tau))


def _negate(source: str, data: Mapping[Any, Any]) -> bool:
    value = _get(source, data, "negate")
    if value not in (0, 1) or isinstance(value, float):  # 0, 1, false, true
        raise ScenarioError(
            source, "negate", f"expected 0 or 1, got {_describe(value)}"
        )
    return bool(value)


def _threshold(source: str, field: str, data: Mapping[Any, Any]) -> float:
    number = _number(source, field, data)
    if not 0.0 <= number <= 1.0:
        raise ScenarioError(source, field, f"must be between 0 and 1, got {number!r}")
    return number
