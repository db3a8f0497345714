"""Undo and redo as one immutable value: no lock, no clock, no threads inside.

Data flow: the controller holds the current :class:`History` next to the scene, under its
lock. An edit that changes the scene calls :meth:`History.record` with the state *before*
the edit; :meth:`History.undo` and :meth:`History.redo` take the current state and give
back the one to restore. Each call returns a new ``History``; the old one is untouched,
so a reader never sees half an update and the rules below can be tested without threads.

Gestures
    Many small edits can make one undo step. A drag reports its phases (start, updates,
    end): every edit of the drag carries the handle as its *gesture key* and merges into
    the step its first edit opened, until the gesture is closed (:meth:`History.closed`).
    Edits without phases (a slider being dragged, a number typed digit by digit) merge
    while they keep the same key and come less than :data:`MERGE_WINDOW_S` apart. An edit
    with no key (``None``) is always a step of its own.

Examples
--------
>>> h = History()
>>> h = h.record(Entry("scene 0"), key=("radius",), now=0.0)
>>> h = h.record(Entry("scene 1"), key=("radius",), now=0.4)  # merged: same slider
>>> h.can_undo, len(h.undo_stack)
(True, 1)
>>> h, back = h.undo(Entry("scene 2"))
>>> back.scene, h.can_redo
('scene 0', True)
"""

from __future__ import annotations

__all__ = ["MERGE_WINDOW_S", "Entry", "History"]

import dataclasses
from collections.abc import Hashable
from typing import Any

MERGE_WINDOW_S = 1.0
"""Consecutive edits with the same gesture key and no drag phases merge into one undo step
when closer than this [s] (a slider being dragged)."""


@dataclasses.dataclass(frozen=True)
class Entry:
    """A state undo or redo returns to: the scene and the scenario it came from."""

    scene: Any
    """The scene (a :class:`planners.Scene`; any value for the history itself)."""
    scenario: str = ""
    """Key of the scenario the scene came from ('' when loaded from elsewhere)."""
    floor_map: Any = None
    """The occupancy map the scene was imported from (drawn on the floor), or None."""


@dataclasses.dataclass(frozen=True)
class History:
    """The undo and redo stacks and the gesture an undo step is open for."""

    undo_stack: tuple[Entry, ...] = ()
    """States to go back to, oldest first."""
    redo_stack: tuple[Entry, ...] = ()
    """States undone, the most recently undone last."""
    gesture: Hashable | None = None
    """Key of the edit the newest undo step is open for (None: no step is open)."""
    gesture_time: float = 0.0
    """When the open step was last extended [s, any monotonic clock]."""
    phased: bool = False
    """Whether the open gesture has explicit phases (a drag: merge until it is closed)."""
    window: float = MERGE_WINDOW_S
    """Merging window for gestures without phases [s]."""

    @property
    def can_undo(self) -> bool:
        """Whether there is something to undo."""
        return bool(self.undo_stack)

    @property
    def can_redo(self) -> bool:
        """Whether there is something to redo."""
        return bool(self.redo_stack)

    def record(
        self,
        before: Entry,
        key: Hashable | None,
        now: float,
        phased: bool = False,
    ) -> History:
        """Return the history after an edit that left the state ``before``.

        Parameters
        ----------
        before
            The state just before the edit (what an undo goes back to).
        key
            The edit's gesture key; None makes the edit an undo step of its own.
        now
            The time of the edit [s], from a monotonic clock.
        phased
            True for an edit of a gesture with explicit phases (a drag): it merges into
            the open step until :meth:`closed`, however slow the gesture.

        Returns
        -------
        History
            A redo is no longer possible after a new edit.
        """
        merge = (
            key is not None
            and key == self.gesture
            and (self.phased or now - self.gesture_time < self.window)
        )
        if merge:
            return dataclasses.replace(self, redo_stack=(), gesture_time=now)
        return dataclasses.replace(
            self,
            undo_stack=(*self.undo_stack, before),
            redo_stack=(),
            gesture=key,
            gesture_time=now,
            phased=phased if key is not None else False,
        )

    def closed(self) -> History:
        """Return the history with no step open: the next edit starts a new step."""
        if self.gesture is None and not self.phased:
            return self
        return dataclasses.replace(self, gesture=None, phased=False)

    def undo(self, current: Entry) -> tuple[History, Entry] | None:
        """Go back one step from ``current``: (new history, state to restore), or None.

        None means there is nothing to undo. ``current`` becomes redoable.
        """
        if not self.undo_stack:
            return None
        history = dataclasses.replace(
            self.closed(),
            undo_stack=self.undo_stack[:-1],
            redo_stack=(*self.redo_stack, current),
        )
        return history, self.undo_stack[-1]

    def redo(self, current: Entry) -> tuple[History, Entry] | None:
        """Redo the step last undone from ``current``: (new history, state), or None."""
        if not self.redo_stack:
            return None
        history = dataclasses.replace(
            self.closed(),
            undo_stack=(*self.undo_stack, current),
            redo_stack=self.redo_stack[:-1],
        )
        return history, self.redo_stack[-1]
