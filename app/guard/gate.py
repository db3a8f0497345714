"""Who may edit: a controller seen through a gate that refuses edits from watchers.

In a classroom (:mod:`app.classroom`) every browser has its own panel, attached to the
session it follows through a :class:`GatedController`. Reading (the scene, its version,
a download) always goes through; every method that changes the session asks the gate
first, *on the server*, when the message arrives: a watcher whose panel is disabled, or
who crafts the message by hand, changes nothing. Hiding the widgets is only a courtesy.

Data flow::

    viser callback of browser B's panel
      -> gated.edits.move_goal(xy)        # GatedGroup: allowed()? (B's seat, now)
           no  -> refused (counted, nothing changes)
           yes -> controller.edits.move_goal(xy)
"""

from __future__ import annotations

__all__ = ["READ_ONLY", "GatedController", "GatedGroup"]

import threading
from collections.abc import Callable
from typing import Any

READ_ONLY = frozenset(
    {
        "scene",
        "version",
        "frame",
        "plans",
        "message",
        "registry",
        "slow_planners",
        "motion_file",
    }
)
"""Controller attributes any browser may read."""

_READ_ONLY_METHODS = frozenset({"download", "scenarios", "folder"})
"""Group members that change nothing (``files.download`` sends the scene to the asker)."""

_GROUPS = ("edits", "tools", "files", "playback")


class Refusals:
    """A thread-safe count of refused edits (what the tests and the banner read)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.count = 0
        """Edits refused so far."""

    def add(self) -> None:
        """Count one refused edit."""
        with self._lock:
            self.count += 1


class GatedGroup:
    """One of the controller's groups (``edits``, ``tools``, ...) behind the gate."""

    def __init__(
        self,
        group: Any,
        allowed: Callable[[], bool],
        refusals: Refusals,
        never: frozenset[str] = frozenset(),
    ) -> None:
        self._group = group
        self._allowed = allowed
        self._refusals = refusals
        self._never = never

    def __getattr__(self, name: str) -> Any:
        member = getattr(self._group, name)
        if name in self._never:
            return _guard(member, lambda: False, self._refusals)
        if name in _READ_ONLY_METHODS or not callable(member):
            return member
        return _guard(member, self._allowed, self._refusals)


class GatedController:
    """A controller whose changing methods run only while ``allowed()`` says so.

    Parameters
    ----------
    controller
        The session's :class:`app.session.controller.Controller`.
    allowed
        Asked at every call: may the browser behind this panel edit now?
    refusals
        Where refused edits are counted (shared by the classroom).
    never
        Group methods refused even when ``allowed()`` (a student never writes the
        lecturer's scenes folder: ``{"save_to_folder"}``).
    """

    def __init__(
        self,
        controller: Any,
        allowed: Callable[[], bool],
        refusals: Refusals | None = None,
        never: frozenset[str] = frozenset(),
    ) -> None:
        self.controller = controller
        """The controller behind the gate."""
        self.refusals = refusals if refusals is not None else Refusals()
        """Count of refused edits."""
        self._allowed = allowed
        for name in _GROUPS:
            group = GatedGroup(getattr(controller, name), allowed, self.refusals, never)
            setattr(self, name, group)

    def __getattr__(self, name: str) -> Any:
        member = getattr(self.controller, name)
        if name in READ_ONLY or not callable(member):
            return member
        return _guard(member, self._allowed, self.refusals)


def _guard(
    method: Callable[..., Any], allowed: Callable[[], bool], refusals: Refusals
) -> Callable[..., Any]:
    def guarded(*args: Any, **kwargs: Any) -> Any:
        if not allowed():
            refusals.add()
            return None
        return method(*args, **kwargs)

    return guarded
