"""How many browsers and copies one server takes, and the class's load at a glance.

A laptop serves a lecture hall within budget up to a number of browsers and of students'
copies that grows with its cores (``tests/benchmarks/bench_hall.py`` measures it; the
figures are in ``docs/benchmarks.md``). Beyond that, it says no rather than slowing the
lecture for everyone:

- a browser that finds every seat taken is told so in its panel (:func:`full_html`),
  gets no scene (its broadcast is muted, :func:`app.classroom.wire.mute`) and costs the
  server next to nothing; it may download the presenter's scene;
- a student who asks for a copy when all copies are taken is told how to run the
  planner on their own laptop with the presenter's scene (:func:`no_copy_html`), which
  the button beside the message downloads in one click;
- the lecturer's banner shows the class's load (:func:`load_text`).
"""

from __future__ import annotations

__all__ = [
    "COPIES_PER_CORE",
    "OPEN_FILES_RESERVE",
    "SEATS_PER_CORE",
    "Capacity",
    "Load",
    "fit_open_files",
    "full_html",
    "load_text",
    "no_copy_html",
    "open_files_for",
    "raise_open_files",
]

import contextlib
import dataclasses
import os

SEATS_PER_CORE = 150
"""Browsers one core serves within the hall's budget (presenter -> watcher p95 150 ms)."""

COPIES_PER_CORE = 5
"""Students' copies one core serves while the presenter drags (each still updates)."""

OPEN_FILES_RESERVE = 512
"""Open files the app holds besides its browsers' sockets: its own files, libraries,
and the pipes of its planner processes and of the copies' workers."""

RUN_AT_HOME = (
    "To try your own ideas now, run the planner on your own laptop: "
    "<b>download the presenter's scene</b> with the button below, then, where the "
    "planner is installed, run <code>robot-planner --scenario SCENE.json</code> "
    "(or <code>python -m app --scenario SCENE.json</code>) and open the address it "
    "prints."
)


@dataclasses.dataclass(frozen=True)
class Capacity:
    """Most browsers (besides the presenter's) and most copies a server takes."""

    seats: int
    """Browsers that watch, edit together or work on a copy."""
    copies: int
    """Students' copies at once."""

    @classmethod
    def of_machine(cls, cores: int | None = None) -> Capacity:
        """Return the capacity of a machine with ``cores`` cores (this one's by default).

        Examples
        --------
        >>> Capacity.of_machine(2)
        Capacity(seats=300, copies=10)
        """
        n = max(1, cores if cores is not None else (os.cpu_count() or 1))
        return cls(seats=SEATS_PER_CORE * n, copies=COPIES_PER_CORE * n)


def open_files_for(capacity: Capacity) -> int:
    """Return how many files a server with ``capacity`` may have open.

    A socket per seat, as many again for browsers that come while the class is full
    (each is told so over its own connection), and :data:`OPEN_FILES_RESERVE`.

    Examples
    --------
    >>> open_files_for(Capacity(300, 10))
    1112
    """
    return 2 * capacity.seats + OPEN_FILES_RESERVE


def fit_open_files(capacity: Capacity, limit: int) -> Capacity:
    """Return ``capacity`` with no more seats than ``limit`` open files serve.

    Examples
    --------
    >>> fit_open_files(Capacity(1200, 40), 1024)
    Capacity(seats=256, copies=40)
    >>> fit_open_files(Capacity(300, 10), 4096)
    Capacity(seats=300, copies=10)
    """
    seats = max(1, (limit - OPEN_FILES_RESERVE) // 2)
    if capacity.seats <= seats:
        return capacity
    return dataclasses.replace(capacity, seats=seats)


def raise_open_files(needed: int) -> int:
    """Raise this process's limit of open files to ``needed`` where the system lets it.

    Never lowers it and never goes past the hard limit (a lecturer's laptop often
    starts programs with a soft limit of 1024, or 256 on macOS, under a far higher
    hard one). Returns the limit now; ``needed`` where there is no such limit
    (Windows).
    """
    try:
        import resource  # noqa: PLC0415 - Unix only
    except ImportError:
        return needed
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft == resource.RLIM_INFINITY:
        return needed
    if soft >= needed:
        return soft
    want = needed if hard == resource.RLIM_INFINITY else min(needed, hard)
    with contextlib.suppress(ValueError, OSError):  # (macOS caps it lower still)
        resource.setrlimit(resource.RLIMIT_NOFILE, (want, hard))
    return resource.getrlimit(resource.RLIMIT_NOFILE)[0]


@dataclasses.dataclass(frozen=True)
class Load:
    """The class at a moment, for the lecturer's banner."""

    following: int
    """Browsers that watch or edit the presenter's scene."""
    copies: int
    """Students on a copy of their own."""
    turned_away: int
    """Browsers connected now that found every seat taken."""
    capacity: Capacity
    """What the server takes."""
    cpu: float
    """Share of the machine's cores the server used lately (0-1), -1 if unknown."""
    behind: int
    """Browsers more than a second of messages behind the class (a slow connection)."""


def load_text(load: Load) -> str:
    """Return the lecturer's line on the class's load (HTML, numbers only).

    Examples
    --------
    >>> print(load_text(Load(280, 4, 0, Capacity(300, 10), 0.42, 0)))
    284 of 300 seats taken: 280 following, 4 of 10 copies. Server 42 % of the machine.
    >>> "2 turned away" in load_text(Load(300, 0, 2, Capacity(300, 10), -1, 3))
    True
    """
    seats = load.following + load.copies
    text = (
        f"{seats} of {load.capacity.seats} seats taken: {load.following} following, "
        f"{load.copies} of {load.capacity.copies} copies."
    )
    if load.turned_away:
        text += f" <b>{load.turned_away} turned away</b> (the class is full)."
    if load.cpu >= 0:
        text += f" Server {round(100 * load.cpu)} % of the machine."
    if load.behind:
        text += f" {load.behind} on a slow connection."
    return text


def full_html(capacity: Capacity) -> str:
    """Return the message of a browser that found every seat taken.

    Examples
    --------
    >>> "300 browsers" in full_html(Capacity(300, 10))
    True
    """
    browsers = "browser" if capacity.seats == 1 else "browsers"
    return (
        f"This laptop serves {capacity.seats} {browsers} within its budget, and every "
        "seat is taken. Reload this page in a minute to try again. " + RUN_AT_HOME
    )


def no_copy_html(capacity: Capacity) -> str:
    """Return the note of a student whose copy was refused (all copies are taken).

    Examples
    --------
    >>> "10 students" in no_copy_html(Capacity(300, 10))
    True
    """
    students = (
        "student already works" if capacity.copies == 1 else "students already work"
    )
    return (
        f"<b>No copy for now:</b> {capacity.copies} {students} on a copy, "
        "as many as this laptop serves while the lecture goes on. " + RUN_AT_HOME
    )
