"""Scenario files on the server's disk, only where the person who started it said so.

No text from a browser is ever used as a server path (docs/architecture.md, "Files and the browser").
A browser saves by *downloading* the scene and loads by *uploading* a file or choosing a
shipped scenario. The one exception is a folder named on the command line
(``python -m app --scenes-dir DIR``): a browser may then read and write scenario files in
that folder by a *plain name* (letters, digits, spaces, ``_``, ``-``, ``.``), which
:func:`plain_name` checks before anything touches the disk; no name can leave the folder,
follow a link out of it, or overwrite a shipped scenario.

Occupancy maps (:mod:`planners.maps`) come the same two ways: a map's YAML file in the
scenes folder (its picture beside it), or an upload of one zip file holding the YAML, its
picture and, if one likes, a scenario made from it. A zip is read in memory, within
bounds (:func:`read_zip`); its folder names are ignored and nothing of it is written.
"""

from __future__ import annotations

__all__ = [
    "MAP_SUFFIXES",
    "MAX_UNZIPPED_BYTES",
    "MAX_UPLOAD_BYTES",
    "MAX_UPLOAD_MAP_EDGES",
    "MAX_UPLOAD_MAP_ISLANDS",
    "MAX_UPLOAD_MAP_VERTICES",
    "MAX_UPLOAD_PICTURE_BYTES",
    "MAX_UPLOAD_PIXELS",
    "MAX_ZIP_ENTRIES",
    "FolderError",
    "ScenesFolder",
    "is_map_file",
    "map_scene",
    "plain_name",
    "read_zip",
    "zip_scene",
]

import dataclasses
import io
import os
import re
import zipfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

import planners
from planners import maps
from planners.maps import OccupancyMap
from planners.maps.pixels import IMAGE_FORMATS, without_comments
from planners.scene import (
    ScenarioError,
    Scene,
    is_map_name,
    scene_from_text,
    scene_to_dict,
)

MAX_UPLOAD_BYTES = 1_000_000
"""Largest scenario file a browser may upload (a lecture scene is a few kilobytes)."""
MAX_UNZIPPED_BYTES = 32_000_000
"""Largest total of the files in an uploaded zip, unpacked (a 5,000 x 5,000 PGM is 25 MB)."""
MAX_ZIP_ENTRIES = 16
"""Most files an uploaded zip may hold."""
MAX_UPLOAD_PIXELS = 4_000_000
"""Largest map picture a browser may upload: 2,000 x 2,000 cells (100 m at 5 cm). The
server reads and traces it while it serves the class; bigger maps open from the scenes
folder or the command line."""
MAX_UPLOAD_MAP_VERTICES = 20_000
"""Most vertices an uploaded map may trace to (a 50 m warehouse at 3 cm traces to about
7,000): a small zip of a speckled picture would otherwise hand the class's workers tens
of thousands of obstacles to plan around. Bigger maps open from the scenes folder."""
MAX_UPLOAD_PICTURE_BYTES = 17_000_000
"""Largest map picture file in an upload (a plain-text PGM of 2,000 x 2,000 cells)."""
MAX_UPLOAD_MAP_EDGES = 60_000
"""Most cell edges between free and blocked cells an uploaded map may have (the 50 m
warehouse of the benchmarks has 58,000), counted before anything is traced: a maze of
one-cell corridors in a 40 kB zip made the trace's shapely work take minutes and GBs."""
MAX_UPLOAD_MAP_ISLANDS = 5_000
"""Most separate groups of blocked cells an uploaded map may have (each may become an
obstacle; the warehouse of the benchmarks has about 450), counted before anything is
traced: a few hundred bytes of zip can hold a picture speckled with tens of thousands."""
MAP_SUFFIXES = (".yaml", ".yml")
"""A file with one of these suffixes is a map_server map's YAML file."""

_PLAIN = re.compile(r"[A-Za-z0-9][A-Za-z0-9 _.\-]{0,63}")
_DEVICES = re.compile(r"(con|prn|aux|nul|com[0-9]|lpt[0-9])(\..*)?", re.IGNORECASE)
"""Windows' device names: ``NUL.json`` opens the device there, not a file."""


class FolderError(ValueError):
    """A name or file the scenes folder refuses; the message is one line for the panel."""


def is_map_file(name: str) -> bool:
    """Whether ``name`` is a map's YAML file (by its suffix).

    Examples
    --------
    >>> is_map_file("lab.yaml"), is_map_file("Lab.YML"), is_map_file("lab.json")
    (True, True, False)
    """
    return name.lower().endswith(MAP_SUFFIXES)


def plain_name(text: str) -> str:
    """Return ``text`` as a scenario file name in the scenes folder, or raise FolderError.

    The name is one path component of at most 64 plain characters, starting with a
    letter or digit, without ``..``, not ending in a dot or a space, and no device
    name of Windows (``CON``, ``NUL``, ``COM1``...); ``.json`` is added when missing
    (a map's ``.yaml`` or ``.yml`` is kept).

    Examples
    --------
    >>> plain_name("my scene")
    'my scene.json'
    >>> plain_name("NUL.json")
    Traceback (most recent call last):
    ...
    app.session.files.FolderError: a file name here is letters, digits, spaces, _ - . (at most 64, no folders): 'NUL.json'
    >>> plain_name("../etc/passwd")
    Traceback (most recent call last):
    ...
    app.session.files.FolderError: a file name here is letters, digits, spaces, _ - . (at most 64, no folders): '../etc/passwd'
    """
    name = text.strip()
    plain = _PLAIN.fullmatch(name) and ".." not in name and not name.endswith(".")
    if not plain or _DEVICES.fullmatch(name):
        shown = name if len(name) <= 40 else name[:40] + "..."
        raise FolderError(
            "a file name here is letters, digits, spaces, _ - . "
            f"(at most 64, no folders): {shown!r}"
        )
    kept = name.lower().endswith(".json") or is_map_file(name)
    return name if kept else f"{name}.json"


class ScenesFolder:
    """The one folder of the server's disk that browsers may read and write by name.

    Parameters
    ----------
    root
        The folder (must exist). It may not be, or hold, the shipped scenarios'
        folder's files: a shipped scenario is never overwritten.
    shipped
        The shipped scenario files, which are never written.
    """

    def __init__(
        self, root: str | os.PathLike[str], shipped: tuple[Path, ...] = ()
    ) -> None:
        self.root = Path(root).resolve()
        if not self.root.is_dir():
            raise FolderError(f"the scenes folder {root} does not exist")
        self._shipped = frozenset(p.resolve() for p in shipped)

    def names(self) -> list[str]:
        """Return the scenario files and maps in the folder (plain names only), sorted."""
        return sorted(
            p.name
            for p in self.root.iterdir()
            if (p.suffix.lower() == ".json" or is_map_file(p.name))
            and p.is_file()
            and not p.is_symlink()
            and _PLAIN.fullmatch(p.name)
        )

    def path(self, name: str) -> Path:
        """Return the file ``name`` stands for, checked to lie in the folder itself."""
        path = self.root / plain_name(name)
        if path.is_symlink() or path.resolve().parent != self.root:
            raise FolderError(f"{path.name} is not a file of the scenes folder")
        return path

    def read(self, name: str) -> Scene:
        """Load the scenario ``name`` (ScenarioError or FolderError on a problem).

        An error names the file by its plain name: a browser never learns where the
        folder is on the server's disk.
        """
        path = self.path(name)
        try:
            return planners.load_scene(path)
        except ScenarioError as error:
            raise self._plain(path, error) from None

    def read_map(self, name: str) -> OccupancyMap:
        """Read the map whose YAML file is ``name`` (ScenarioError or FolderError).

        The picture is the one the YAML names, in this folder (:func:`planners.maps.read_map`).
        """
        path = self.path(name)
        if not is_map_file(path.name):
            raise FolderError(f"{path.name} is not a map's YAML file (.yaml or .yml)")
        try:
            occupancy_map = maps.read_map(path)
        except ScenarioError as error:
            raise self._plain(path, error) from None
        return dataclasses.replace(occupancy_map, source=path.name)

    def write(self, name: str, scene: Scene) -> Path:
        """Save ``scene`` as ``name`` (atomically); never over a shipped scenario."""
        path = self.path(name)
        if is_map_file(path.name):
            raise FolderError(f"{path.name} is a map; save the scene as a .json file")
        if path.resolve() in self._shipped:
            raise FolderError(f"{path.name} is a shipped scenario; choose another name")
        try:
            return planners.save_scene(scene, path)
        except ScenarioError as error:
            raise self._plain(path, error) from None

    def _plain(self, path: Path, error: ScenarioError) -> ScenarioError:
        """Return ``error`` naming the file by its plain name and no folder of the disk."""
        problem = error.problem.replace(str(self.root), "the scenes folder")
        return ScenarioError(path.name, error.field, problem)


# --------------------------------------------------------------------------- maps


def map_scene(occupancy_map: OccupancyMap, like: Scene, name: str) -> Scene:
    """Return the scene of a map opened without a scenario: its own start and goal.

    The free space around the start and goal :func:`planners.maps.default_endpoints`
    chooses, traced as :func:`planners.maps.scene_from_map` does, with the robot and
    settings of ``like`` (the scene shown before). ``name``: the map's YAML file name,
    the scene's ``map`` when it is a plain one (:func:`planners.scene.is_map_name`; a
    zip's need not be: then the scene names no map, and its picture is shown all the
    same).
    """
    radius = like.robot.radius
    start, goal = maps.default_endpoints(occupancy_map, radius)
    data = maps.scene_from_map(
        occupancy_map,
        start,
        goal,
        robot_radius=radius,
        map_file=name if is_map_name(name) else "",
    )
    kept = scene_to_dict(like)
    for key in ("robot", "expansion", "sensor_range"):
        data[key] = kept[key]
    return planners.load_scene(data)


def read_zip(data: bytes, source: str) -> dict[str, bytes]:
    """Return the files of a zip by plain file name, read in memory within bounds.

    At most :data:`MAX_ZIP_ENTRIES` files and :data:`MAX_UNZIPPED_BYTES` unpacked in
    all, counted as they are unpacked (a zip that lies about its sizes is stopped at
    the bound). Folders inside the zip are ignored, and so are the ``__MACOSX`` copies
    a Mac adds; two files of one name, or an encrypted file, are refused.

    Raises
    ------
    ScenarioError
        Field ``(file)``, naming ``source``.
    """
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
        infos = [i for i in archive.infolist() if not i.is_dir()]
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as error:
        raise ScenarioError(source, "(file)", f"not a zip file ({error})") from None
    files: dict[str, bytes] = {}
    left = MAX_UNZIPPED_BYTES
    for info in infos:
        name = re.split(r"[\\/]", info.filename)[-1]
        if info.filename.startswith("__MACOSX") or name.startswith("._"):
            continue
        if len(files) == MAX_ZIP_ENTRIES:
            raise ScenarioError(
                source, "(file)", f"more than {MAX_ZIP_ENTRIES} files in the zip"
            )
        if name in files:
            raise ScenarioError(source, "(file)", f"two files named {name!r}")
        files[name] = _unpack(archive, info, left, source)
        left -= len(files[name])
    return files


def _unpack(
    archive: zipfile.ZipFile, info: zipfile.ZipInfo, left: int, source: str
) -> bytes:
    """Unpack one file of at most ``left`` bytes (whatever its header says)."""
    too_big = ScenarioError(
        source, "(file)", f"more than {MAX_UNZIPPED_BYTES:,} bytes unpacked"
    )
    if info.file_size > left:
        raise too_big
    try:
        with archive.open(info) as handle:
            content = handle.read(left + 1)
    except RuntimeError:  # encrypted
        raise ScenarioError(source, "(file)", f"{info.filename}: encrypted") from None
    except (
        zipfile.BadZipFile,
        ValueError,
        OSError,
        EOFError,
        NotImplementedError,
    ) as error:
        raise ScenarioError(source, "(file)", f"{info.filename}: {error}") from None
    if len(content) > left:
        raise too_big
    return content


def zip_scene(
    files: Mapping[str, bytes], like: Scene, source: str
) -> tuple[Scene, OccupancyMap]:
    """Return the scene and map of an uploaded zip's files (:func:`read_zip`).

    The zip holds one map (its YAML file and the picture it names) and at most one
    scenario file (``.json``). With a scenario, it is the scene (its ``map`` must name
    the zip's YAML file); without, the map opens as :func:`map_scene` opens it. The
    picture may have at most :data:`MAX_UPLOAD_PIXELS` pixels and
    :data:`MAX_UPLOAD_MAP_ISLANDS` islands of blocked cells (counted before the trace),
    and the scene at most :data:`MAX_UPLOAD_MAP_VERTICES` vertices.

    Raises
    ------
    ScenarioError
        Naming ``source`` (the zip) and the file inside it at fault.
    """
    yamls = [n for n in files if is_map_file(n)]
    jsons = [n for n in files if n.lower().endswith(".json")]
    if len(yamls) != 1 or len(jsons) > 1:
        raise ScenarioError(
            source,
            "(file)",
            "a map's zip holds one map (.yaml and its picture) and at most one "
            f"scenario (.json); this one has {len(yamls)} and {len(jsons)}",
        )
    name = yamls[0]
    inner = f"{source}/{name}"
    meta = maps.map_metadata(files[name], inner)
    _check_pixels(files.get(meta.image), inner)
    occupancy_map = maps.read_map_bytes(files[name], files, inner)
    free = maps.free_cells(occupancy_map)
    edges = int(np.count_nonzero(free[:, 1:] != free[:, :-1])) + int(
        np.count_nonzero(free[1:] != free[:-1])
    )
    if edges > MAX_UPLOAD_MAP_EDGES:
        raise ScenarioError(
            inner,
            "image",
            f"{edges:,} cell edges between free and blocked cells, more than the "
            f"{MAX_UPLOAD_MAP_EDGES:,} an upload may have; open it from the scenes "
            "folder (--scenes-dir)",
        )
    islands = maps.blocked_islands(occupancy_map)
    if islands > MAX_UPLOAD_MAP_ISLANDS:
        raise ScenarioError(
            inner,
            "image",
            f"{islands:,} separate groups of blocked cells, more than the "
            f"{MAX_UPLOAD_MAP_ISLANDS:,} an upload may have; open it from the scenes "
            "folder (--scenes-dir)",
        )
    if jsons:
        scene = _zip_scenario(files[jsons[0]], f"{source}/{jsons[0]}", name)
    else:
        scene = map_scene(occupancy_map, like, name)
    vertices = sum(len(o.exterior.coords) - 1 for o in scene.obstacles)
    if scene.boundary is not None:
        vertices += len(scene.boundary.exterior.coords) - 1
    if vertices > MAX_UPLOAD_MAP_VERTICES:
        raise ScenarioError(
            inner,
            "image",
            f"the map traces to {vertices:,} vertices, more than the "
            f"{MAX_UPLOAD_MAP_VERTICES:,} an upload may have; open it from the scenes "
            "folder (--scenes-dir)",
        )
    return scene, occupancy_map


def _check_pixels(picture: bytes | None, source: str) -> None:
    """Refuse a picture of more than :data:`MAX_UPLOAD_PIXELS` before it is decoded.

    Read as :func:`planners.maps.decode_picture` reads it: a PNM picture's header
    normalised first, and only the formats a map may have (Pillow walks some formats'
    headers a chunk or a byte at a time).
    """
    if picture is None:
        return  # read_map_bytes names the missing picture
    if len(picture) > MAX_UPLOAD_PICTURE_BYTES:
        raise ScenarioError(
            source,
            "image",
            f"{len(picture):,} bytes, more than the {MAX_UPLOAD_PICTURE_BYTES:,} an "
            "uploaded picture may have; open a bigger map from the scenes folder",
        )
    from PIL import Image  # noqa: PLC0415 - only for maps

    try:
        data = without_comments(picture)
        with Image.open(io.BytesIO(data), formats=IMAGE_FORMATS) as image:
            width, height = image.size
    except Exception:  # read_map_bytes says what is wrong with it
        return
    if width * height > MAX_UPLOAD_PIXELS:
        raise ScenarioError(
            source,
            "image",
            f"{width} x {height} pixels, more than the {MAX_UPLOAD_PIXELS:,} an upload "
            "may have; open a bigger map from the scenes folder (--scenes-dir)",
        )


def _zip_scenario(text: bytes, source: str, map_name: str) -> Scene:
    """Return the zip's scenario: no bigger than an upload, naming the zip's map."""
    if len(text) > MAX_UPLOAD_BYTES:
        raise ScenarioError(
            source,
            "(file)",
            f"{len(text):,} bytes, more than the {MAX_UPLOAD_BYTES:,} a scenario may have",
        )
    scene = scene_from_text(text, source)
    if scene.map != map_name:
        raise ScenarioError(
            source, "map", f"expected the zip's map {map_name!r}, got {scene.map!r}"
        )
    return scene
