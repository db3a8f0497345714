"""A classroom: the presenter edits, the class watches, a student may work on a copy.

- :mod:`app.classroom.room`: the seats, their modes, copies (:class:`Classroom`);
- :mod:`app.classroom.audience`: the followers' views, drawn from the presenter's session;
- :mod:`app.classroom.wire`: one encoding of each broadcast window for every browser;
- :mod:`app.classroom.watch`: the watchers' one shared panel;
- :mod:`app.classroom.capacity`: how many seats and copies the server takes, and the load.
"""

from app.classroom.audience import Audience
from app.classroom.room import (
    PRESENTER_PATH,
    Classroom,
    PresenterTools,
    PrivateExplain,
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
    "Classroom",
    "PresenterTools",
    "PrivateExplain",
    "Seat",
    "banner_html",
    "close_connection",
    "connection_path",
    "is_presenter_path",
    "new_token",
    "presenter_url",
]
