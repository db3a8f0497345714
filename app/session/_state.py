"""One session's state behind its one lock: the scene, its version, the history, the UI.

A session is one scene for one audience: a controller owns exactly
one :class:`SessionState`, and nothing here is global, so a server can hold several.

Data flow::

    controller.edits.move_goal(xy)                # any thread (viser's callbacks)
      -> state.transact(step)                     # ONE critical section:
           outcome = step(scene, ui)              #   read and decide (pure, tools.py)
           history = history.record(...)          #   record (pure, history.py)
           scene, version = outcome.scene, +1     #   edit
           ui_version += 1; lock.notify_all()     #   wake the scheduler
      -> scheduler (its own threads) reads snapshot_locked() under the same lock

Every reader and writer uses :attr:`SessionState.lock` (a :class:`threading.Condition`):
the scheduler and the playback wait on it for a new version. Methods ending in
``_locked`` expect the caller to hold it.
"""

from __future__ import annotations

__all__ = ["SessionState", "Signalling", "Snapshot", "Step"]

import dataclasses
import threading
import time
from collections.abc import Callable, Hashable
from types import MappingProxyType
from typing import Any

from app.session import tools
from app.session.history import Entry, History
from app.session.tools import Outcome, UiState
from planners.scene import Scene

Step = Callable[[Scene, UiState], Outcome]
"""A pure decision: (scene, UI state) -> what changes (see :mod:`app.session.tools`)."""


@dataclasses.dataclass(frozen=True)
class Snapshot:
    """The session's state at one instant, read together under the lock."""

    version: int
    """Scene version: every edit of the scene increases it by one."""
    ui_version: int
    """Increases with every change a frame shows besides the scene (tool, message, ...)."""
    scene: Scene
    """The scene."""
    scenario: str
    """Key of the scenario the scene came from ('' when loaded from elsewhere)."""
    floor_map: Any
    """The occupancy map the scene was imported from (:mod:`planners.maps`), or None."""
    ui: UiState
    """The shared UI state."""
    can_undo: bool
    """Whether there is something to undo."""
    can_redo: bool
    """Whether there is something to redo."""


class Signalling(threading.Condition):
    """A condition that also calls its :attr:`listeners` each time it is notified.

    Called with the lock held, as ``notify`` is: a listener must only take locks that
    are never held while this one is taken (a :class:`app.session.pool.Runner`'s).
    """

    def __init__(self) -> None:
        super().__init__()
        self.listeners: list[Callable[[], None]] = []
        """Called after every notification (a classroom copy's scheduler's)."""

    def notify(self, n: int = 1) -> None:
        """Wake up to ``n`` waiters, then call the listeners (``notify_all`` calls it)."""
        super().notify(n)
        for listener in self.listeners:
            listener()


class SessionState:
    """The scene, its version, the undo history and the UI state, under one lock.

    Parameters
    ----------
    scene
        The scene to start with.
    scenario
        Key of the scenario it came from ('' if none).
    floor_map
        The occupancy map it was imported from (:mod:`planners.maps`), or None.
    ui
        The UI state to start with (its ``enabled`` planners, mostly).
    clock
        Monotonic clock for merging undo steps [s] (a test may pass its own).
    """

    def __init__(
        self,
        scene: Scene,
        scenario: str = "",
        ui: UiState | None = None,
        clock: Callable[[], float] = time.monotonic,
        floor_map: Any = None,
    ) -> None:
        self.lock = Signalling()
        """The session's one lock; wait on it for a change, notified on every change."""
        self._scene = scene
        self._version = 0
        self._scenario = scenario
        self._floor_map = floor_map
        self._history = History()
        self._ui = ui if ui is not None else UiState()
        self._ui_version = 0
        self._clock = clock

    # ------------------------------------------------------------------ reading

    @property
    def scene(self) -> Scene:
        """The current scene (the newest edit, maybe not yet planned)."""
        with self.lock:
            return self._scene

    @property
    def version(self) -> int:
        """Version of the current scene; every edit increases it by one."""
        with self.lock:
            return self._version

    @property
    def ui(self) -> UiState:
        """The shared UI state."""
        with self.lock:
            return self._ui

    def snapshot_locked(self) -> Snapshot:
        """Everything at once, consistent (call with :attr:`lock` held)."""
        return Snapshot(
            version=self._version,
            ui_version=self._ui_version,
            scene=self._scene,
            scenario=self._scenario,
            floor_map=self._floor_map,
            ui=self._ui,
            can_undo=self._history.can_undo,
            can_redo=self._history.can_redo,
        )

    # ------------------------------------------------------------------ changing

    def transact(self, step: Step) -> Outcome:
        """Decide and apply ``step`` atomically: no other change can come in between."""
        with self.lock:
            outcome = step(self._scene, self._ui)
            self.apply_locked(outcome)
            return outcome

    def update_ui(self, change: Callable[[UiState], UiState]) -> None:
        """Replace the UI state by ``change(ui)`` (one critical section)."""
        with self.lock:
            self._ui = change(self._ui)
            self.touch_locked()

    def say(self, message: str | None) -> None:
        """Show ``message`` as the answer to the last action."""
        self.update_ui(lambda ui: ui.say(message))

    def apply_locked(self, outcome: Outcome) -> None:
        """Apply a tool's outcome: record the edit in the history, take the new UI state."""
        if outcome.opens:
            self._history = self._history.closed()
        if outcome.scene is not None:
            self._commit_locked(outcome.scene, outcome.gesture, outcome.phased)
        if outcome.closes:
            self._history = self._history.closed()
        self._ui = outcome.ui
        self.touch_locked()

    def replace(
        self,
        scene: Scene,
        scenario: str,
        message: str | None,
        floor_map: Any = None,
    ) -> None:
        """Replace the whole scene as one undo step (undo restores the old scenario too).

        ``floor_map``: the occupancy map the scene was imported from, or None.
        """
        with self.lock:
            self._history = self._history.closed()
            self._commit_locked(scene, None, phased=False)
            self._scenario = scenario
            self._floor_map = floor_map
            self._ui = dataclasses.replace(
                self._ui, selection=None, draft=(), message=message
            )
            self.touch_locked()

    def step_history(self, redo: bool = False) -> None:
        """Undo (or redo) one step; say so when there is nothing to undo (redo)."""
        with self.lock:
            current = Entry(self._scene, self._scenario, self._floor_map)
            moved = (self._history.redo if redo else self._history.undo)(current)
            if moved is None:
                self._history = self._history.closed()
                self._ui = self._ui.say(
                    "Nothing to redo." if redo else "Nothing to undo."
                )
            else:
                self._history, entry = moved
                self._scene, self._scenario = entry.scene, entry.scenario
                self._floor_map = entry.floor_map
                self._version += 1
                self._ui = dataclasses.replace(
                    self._ui,
                    dragging=MappingProxyType({}),
                    selection=tools.valid_selection(self._ui.selection, entry.scene),
                    message=None,
                )
            self.touch_locked()

    def touch_locked(self) -> None:
        """Mark a change for the frames (a new UI version) and wake every waiter."""
        self._ui_version += 1
        self.lock.notify_all()

    def _commit_locked(
        self, new: Scene, gesture: Hashable | None, phased: bool
    ) -> None:
        if new == self._scene:
            return  # nothing changed: no undo step, no new version
        before = Entry(self._scene, self._scenario, self._floor_map)
        self._history = self._history.record(before, gesture, self._clock(), phased)
        self._scene = new
        self._version += 1
