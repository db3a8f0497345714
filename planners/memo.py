"""Caches that belong to whoever plans: no planner keeps state between calls.

Two kinds of reuse keep editing fluid without any module-level cache in ``planners/``:

- **Derived data of one value** lives on the value: :meth:`planners.space.expansion.ConfigurationSpace.derive`
  computes, once per configuration space, what the planners read from it (the border's
  arrays, which vertices see each other, the sensor's ring geometry). It goes away with
  the configuration space.
- **Reuse across scenes** (the same obstacle expanded again while another one is dragged,
  the same configuration space while the start or goal is dragged) lives in a
  :class:`Memo` that the caller owns and passes to :func:`planners.plan_all`. A caller that
  passes none gets cold work: nothing from an earlier call answers.
"""

from __future__ import annotations

__all__ = ["Memo"]

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable, Mapping
from types import MappingProxyType
from typing import Any, TypeVar

T = TypeVar("T")

TABLE_SIZES: Mapping[str, int] = MappingProxyType(
    {"expanded": 4096, "shrunk": 16, "cspace": 4}
)
"""Entries kept per table: expansions are small and many (one per obstacle and setting);
a configuration space carries what the planners derived from it (the border, the
vertex pairs that see each other: as many as the visibility graph's edges), so only the
last few are kept."""


class Memo:
    """Bounded tables of results of pure functions, keyed by value, owned by one caller.

    Parameters
    ----------
    size
        Entries kept in a table not named in ``sizes`` (least recently used ones are
        dropped first).
    sizes
        Entries kept per named table; :data:`TABLE_SIZES` by default.

    Examples
    --------
    >>> memo = Memo(size=2)
    >>> calls = []
    >>> def square(x):
    ...     calls.append(x)
    ...     return x * x
    >>> [memo.get("square", x, lambda x=x: square(x)) for x in (3, 3, 4)]
    [9, 9, 16]
    >>> calls  # the repeat was answered from the memo
    [3, 4]
    """

    def __init__(self, size: int = 64, sizes: Mapping[str, int] = TABLE_SIZES) -> None:
        self._size = size
        self._sizes = dict(sizes)
        self._tables: dict[str, OrderedDict[Hashable, Any]] = {}
        # One memo may serve a caller's threads; the lock only guards the tables, the
        # computation runs outside it (a rare duplicate of pure work is harmless).
        self._lock = threading.Lock()

    def get(self, table: str, key: Hashable, compute: Callable[[], T]) -> T:
        """Return the entry ``key`` of ``table``, computing and keeping it if missing."""
        with self._lock:
            entries = self._tables.setdefault(table, OrderedDict())
            if key in entries:
                entries.move_to_end(key)
                return entries[key]
        value = compute()
        with self._lock:
            entries[key] = value
            entries.move_to_end(key)
            while len(entries) > self._sizes.get(table, self._size):
                entries.popitem(last=False)
        return value

    def latest(self, table: str) -> Any | None:
        """Return the entry of ``table`` used last (got or added), or None if it is empty."""
        with self._lock:
            entries = self._tables.get(table)
            return next(reversed(entries.values())) if entries else None

    def clear(self) -> None:
        """Forget everything (the next plan is cold)."""
        with self._lock:
            self._tables.clear()

    def __len__(self) -> int:
        """Return the number of entries over all tables."""
        with self._lock:
            return sum(len(t) for t in self._tables.values())
