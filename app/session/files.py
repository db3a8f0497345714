"""Scenario files on the server's disk, only where the person who started it said so.

No text from a browser is ever used as a server path (docs/architecture.md, "Files and the browser").
A browser saves by *downloading* the scene and loads by *uploading* a file or choosing a
shipped scenario. The one exception is a folder named on the command line
(``python -m app --scenes-dir DIR``): a browser may then read and write scenario files in
that folder by a *plain name* (letters, digits, spaces, ``_``, ``-``, ``.``), which
:func:`plain_name` checks before anything touches the disk; no name can leave the folder,
follow a link out of it, or overwrite a shipped scenario.
"""

from __future__ import annotations

__all__ = ["MAX_UPLOAD_BYTES", "FolderError", "ScenesFolder", "plain_name"]

import os
import re
from pathlib import Path

import planners
from planners.scene import ScenarioError, Scene

MAX_UPLOAD_BYTES = 1_000_000
"""Largest scenario file a browser may upload (a lecture scene is a few kilobytes)."""

_PLAIN = re.compile(r"[A-Za-z0-9][A-Za-z0-9 _.\-]{0,63}")
_DEVICES = re.compile(r"(con|prn|aux|nul|com[0-9]|lpt[0-9])(\..*)?", re.IGNORECASE)
"""Windows' device names: ``NUL.json`` opens the device there, not a file."""


class FolderError(ValueError):
    """A name or file the scenes folder refuses; the message is one line for the panel."""


def plain_name(text: str) -> str:
    """Return ``text`` as a scenario file name in the scenes folder, or raise FolderError.

    The name is one path component of at most 64 plain characters, starting with a
    letter or digit, without ``..``, not ending in a dot or a space, and no device
    name of Windows (``CON``, ``NUL``, ``COM1``...); ``.json`` is added when missing.

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
    return name if name.lower().endswith(".json") else f"{name}.json"


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
        """Return the scenario files in the folder (plain names only), sorted."""
        return sorted(
            p.name
            for p in self.root.glob("*.json")
            if p.is_file() and not p.is_symlink() and _PLAIN.fullmatch(p.name)
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

    def write(self, name: str, scene: Scene) -> Path:
        """Save ``scene`` as ``name`` (atomically); never over a shipped scenario."""
        path = self.path(name)
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
