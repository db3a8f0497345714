"""A classroom: the presenter edits, the class watches, a student may work on a copy.

- :mod:`app.classroom.room`: the seats, their modes, copies (:class:`Classroom`);
- :mod:`app.classroom.audience`: the followers' gizmos and panels, drawn from the
  presenter's session;
- :mod:`app.classroom.wire`: the pump: each broadcast window encoded once for every
  browser, the class's at the class's frame rate;
- :mod:`app.classroom.watch`: the watchers' one shared panel;
- :mod:`app.classroom.capacity`: how many seats and copies the server takes, and the load.

The names below load their module when first used: ``python -m app`` reads
:mod:`app.classroom.capacity` (the standard library's alone) before viser is imported.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from app.classroom.audience import Audience
    from app.classroom.capacity import Capacity
    from app.classroom.room import (
        PRESENTER_PATH,
        Classroom,
        PresenterTools,
        PrivateExplain,
        PrivateLive,
        Seat,
        banner_html,
        close_connection,
        connection_path,
        is_presenter_path,
        new_token,
        presenter_url,
    )

__all__ = [
    "PRESENTER_PATH",
    "Audience",
    "Capacity",
    "Classroom",
    "PresenterTools",
    "PrivateExplain",
    "PrivateLive",
    "Seat",
    "banner_html",
    "close_connection",
    "connection_path",
    "is_presenter_path",
    "new_token",
    "presenter_url",
]

_WHERE = {
    "Audience": "app.classroom.audience",
    "Capacity": "app.classroom.capacity",
    **{
        name: "app.classroom.room"
        for name in __all__
        if name not in ("Audience", "Capacity")
    },
}


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'app.classroom' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
