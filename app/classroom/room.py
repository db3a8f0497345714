"""A classroom: the presenter edits, the class watches, a student may work on a copy.

When the server listens beyond loopback (``--host 0.0.0.0``) or is started with
``--presenter``, editing belongs to the presenter: the browser that opened the presenter's
URL, whose websocket path carries a secret token (:func:`presenter_url`). Every other
browser is a *seat* that

- **watches** (the default): sees every edit and the robot live in the class's one
  panel (:mod:`app.classroom.watch`, every control disabled); it has no gizmos, and any
  edit message it sends anyway is refused on the server (:mod:`app.guard.gate`);
- **edits together** while the presenter has opened the session to everyone (a lab);
- works on **its own copy**: a session of its own (scene, planners, robot, undo history),
  seeded from the presenter's current scene, until it follows the presenter again.

One session is shared: the presenter's :class:`app.session.controller.Controller`. It
draws its scene once for every browser, the presenters' included, under ``/shared``
(viser's broadcast scope, gizmos replaced by frames nobody can drag:
:mod:`app.ui.scoped`); one pump (:mod:`app.classroom.wire`) sends it to the presenters'
browsers at every frame and to the class at the class's frame rate. Through one
:class:`app.classroom.audience.Audience` it also draws the watchers' one panel, the
presenters' panels and the *gizmos* of those that edit (:class:`app.ui.view.GizmoView`,
in the seat's client scope under ``/own``, over the shared drawing). A private copy is a
second controller whose views are the seat's *own view* (a full 3-D view with live
gizmos under ``/own``, which hides ``/shared`` for that browser) and panel, with an
*Explain* folder and a *Live DSB* robot of its own drawn in that browser's scope only
(:class:`PrivateExplain`, :class:`PrivateLive`; the copies' live robots share one
:class:`app.session.pool.Ticker` with their robots' animations, at most
:data:`COPY_TICKS_PER_S` frames a second in all). Its planners run in
:class:`app.session.pool.WorkerPool` s shared by every copy (VG and SVG, DSB, a big
scene's graphs: at most ``copy_workers`` processes of each kind, at a lower priority),
and its frames are built and drawn in turns all copies share
(:class:`app.session.pool.Turns`). How many browsers and copies the server takes, and
what it tells the others: :mod:`app.classroom.capacity`.

Several presenter browsers. A lecturer often opens the presenter's URL twice: on the
laptop and on the projector's screen (or again after a reload). Every browser with the
token is a presenter, with its own panel, banner, gizmos and *Explain* and *Live DSB*
folders, and they share everything else:

- **one scene**: every presenter sees the shared drawing, with gizmos of its own
  (``/own``, its client scope); a gizmo held in one browser moves in the other as the
  drag goes (gizmos are left alone only where their own user holds them:
  :class:`app.ui.view.Gizmos`);
- **one Explain**: a single :class:`app.explain.panel.ExplainPanel` (the method, the
  step, the layers it hid, its drawing under ``/explain``); each presenter's folder
  shows that state and calls its commands, so a step taken on the laptop is the step on
  the projector. When the last presenter's folder goes, nobody could switch it off:
  Explain goes off and gives the plans' layers back;
- **one live robot**: one :class:`app.live.LiveRun`, whose every step reaches every
  presenter's folder (:class:`app.live.LivePanels`). It keeps driving for the class when
  all presenter browsers have gone; one that comes back shows it at once;
- the *Let everyone edit* switch, shown ticked or not in every presenter's browser.

Closing or reloading one presenter browser removes only its seat, panel and folders
(:class:`PresenterTools`); the others keep working. The presenter's banner counts the
presenter browsers when there is more than one.

Data flow::

    presenter's drag (its /own gizmo)  -> Classroom._shared_drag: may this seat edit?
      -> controller.edits.drag_handle  -> scheduler -> frame
           -> shared view (/shared)  # drawn once -> Pump -> presenters: every frame;
                                     #   the class: the newest, <= 20 a second in a hall
           -> Audience: presenters' and editors' gizmos and panels; the watchers'
              one panel (<= 10 a second)
    watcher's crafted message          -> its gate says no: refused, nothing changes
    "Make my own copy"                 -> Classroom.make_copy: a Controller of its own
    browser closed                     -> Classroom.disconnect: its copy is closed
    presenter's Explain / Live folder  -> the one ExplainPanel / LiveRun
      -> /explain, /live (every browser) and every presenter's folders
"""

from __future__ import annotations

__all__ = [
    "FETCH_LABEL",
    "PRESENTER_PATH",
    "Classroom",
    "CopyResources",
    "PresenterTools",
    "PrivateExplain",
    "PrivateLive",
    "Seat",
    "connection_path",
    "presenter_url",
]

import asyncio
import contextlib
import dataclasses
import functools
import gc
import itertools
import logging
import os
import secrets
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, cast

import viser

from app.classroom.audience import Audience
from app.classroom.capacity import (
    Capacity,
    Load,
    fit_open_files,
    full_html,
    load_text,
    no_copy_html,
    open_files_for,
    raise_open_files,
)
from app.classroom.watch import WatchPanel
from app.classroom.wire import class_rate, mute, share_encoding, stop_sharing
from app.explain.panel import ExplainPanel
from app.guard.door import Bucket
from app.guard.gate import GatedController, Refusals
from app.live import LivePanel, LiveRun, MotionPaths, add_live_panel
from app.session import robot as robot_model
from app.session.big import SharedWorkers
from app.session.controller import Controller
from app.session.files import ScenesFolder
from app.session.frames import View
from app.session.pool import Runner, Ticker, Turns, WorkerPool
from app.session.scheduler import big_plan, default_plan
from app.ui.panels import Panels
from app.ui.scoped import ScopedTarget, batch, left, quietly
from app.ui.view import GizmoView, PlannerView
from planners.allocator import give_back_freed_memory
from planners.registry import planners_of_kind

logger = logging.getLogger(__name__)

PRESENTER_PATH = "/presenter/"
"""Websocket path prefix of the presenter's browser; the token follows it."""

COPY_NICE = 19
"""How much lower the copies' workers' priority is than the server's (``os.nice``),
below the presenter's DSB worker (:data:`app.session.scheduler.SLOW_NICE`): the
presenter's frames come first, the copies share what is left."""

COPY_ROUNDS_PER_S = 20.0
"""Frames all the copies together build and draw in the server's process per second, at
most (:class:`app.session.pool.Turns`): ten dragging copies draw 2 frames a second each,
and the presenter keeps the rest of the interpreter."""

COPY_TICKS_PER_S = 60.0
"""Robot frames all the copies together draw per second in the server's process, at most
(one :class:`app.session.pool.Ticker`): their robots' animations (30 frames a second
each) and their live robots' steps (20 a second each). Two robots move at their full
rate; with ten, an animation is drawn 6 times a second (it keeps its pace) and a live
robot drives at a third of its pace (it decides the same, only slower to watch)."""

PANEL_ORDER = 0.0
"""Where a seat's own panel sits: below its banner and buttons (negative orders)."""

SWITCHES = (4, 0.5)
"""How often a seat may make a copy or follow again (each builds or closes a whole
session): 4 switches at once, then one every 2 s (a :class:`app.guard.door.Bucket`)."""

STUDENT_NEVER = frozenset({"save_to_folder"})
"""What a student's panel may never do, even on its own copy: write the lecturer's disk."""

MODES = {
    "presenter": ("#b35900", "Presenter", "You edit; the class sees every change."),
    "watching": (
        "#0b5394",
        "Watching the presenter",
        "You see every edit live. Editing is the presenter's; "
        "press <b>Make my own copy</b> to try your own ideas.",
    ),
    "together": (
        "#6a329f",
        "Editing together",
        "The presenter opened the scene to everyone: your edits reach the whole class.",
    ),
    "private": (
        "#1e7b34",
        "Your own copy",
        "Your edits reach no one else, and the presenter's edits do not reach you. "
        "Press <b>Follow the presenter again</b> to go back.",
    ),
    "full": ("#6b6b6b", "The class is full", "Every seat of this class is taken."),
}
"""Seat mode -> (banner colour, title, what it means)."""


FETCH_LABEL = "Download the presenter's scene (.json)"
"""The button beside a refusal: the scene to open in one's own planner."""

LOAD_SECONDS = 2.0
"""How often the lecturer's banner shows the class's load again, and how long the
class must have been gone before what it freed is given back."""

SLOW_BYTES = 256 * 1024
"""A browser with this much waiting in its socket is on a slow connection."""


def new_token() -> str:
    """Return a fresh secret for the presenter's URL (``secrets.token_urlsafe``)."""
    return secrets.token_urlsafe(16)


def presenter_url(page_url: str, token: str) -> str:
    """Return the presenter's URL: the page, told to open its websocket on the token's path.

    viser's client connects to the page's own address unless ``?websocket=`` names
    another; the server reads the path of each websocket (:func:`connection_path`).

    Examples
    --------
    >>> presenter_url("http://10.0.0.5:8080/", "abc")
    'http://10.0.0.5:8080/?websocket=ws://10.0.0.5:8080/presenter/abc'
    """
    base = page_url.rstrip("/")
    ws = "ws" + base[len("http") :] if base.startswith("http") else base
    return f"{base}/?websocket={ws}{PRESENTER_PATH}{token}"


def connection_path(server: viser.ViserServer, client_id: int) -> str:
    """Return the path a browser's websocket was opened on ('' if unknown).

    viser 1.1.1 does not expose it on the client handle; the websocket server keeps each
    live connection, whose handshake request has it. Anything unexpected reads as '',
    so a browser is never made presenter by accident.
    """
    websock = getattr(server, "_websock_server", None)
    connections = getattr(websock, "_live_connections", {})
    connection = connections.get(client_id) if isinstance(connections, dict) else None
    request = getattr(connection, "request", None)
    path = getattr(request, "path", "")
    return path if isinstance(path, str) else ""


def close_connection(server: viser.ViserServer, client_id: int, reason: str) -> None:
    """Close browser ``client_id``'s websocket from any thread (it may reconnect)."""
    websock = server._websock_server
    connection = websock._live_connections.get(client_id)
    loop = getattr(websock, "_background_event_loop", None)
    if connection is None or loop is None:
        return
    asyncio.run_coroutine_threadsafe(connection.close(4000, reason), loop)


def is_presenter_path(path: str, token: str) -> bool:
    """Whether a websocket ``path`` carries the presenter's ``token`` (constant time)."""
    given = path.partition("?")[0]
    if not given.startswith(PRESENTER_PATH):
        return False
    return secrets.compare_digest(given[len(PRESENTER_PATH) :].encode(), token.encode())


@dataclasses.dataclass(eq=False)
class Seat:
    """One browser in the classroom."""

    client: viser.ClientHandle
    """The browser's handle."""
    presenter: bool
    """Whether it opened the presenter's URL."""
    banner: Any = None
    """The coloured box at the top of its panel saying what mode it is in."""
    buttons: Any = None
    """Its classroom buttons (copy / follow), or the presenter's switch."""
    panels: Panels | None = None
    """Its own control panel, while it presents, edits or works on a copy; a watcher
    sees the class's one panel instead (:mod:`app.classroom.watch`)."""
    panel_box: Any = None
    """The container its own panel hangs from (removed with the panel)."""
    watching: bool = False
    """Whether its browser shows the class's one watcher panel."""
    own: PlannerView | GizmoView | None = None
    """Its gizmos over the shared drawing (while it edits the presenter's scene), or its
    own 3-D view with live gizmos (while it works on its copy), else None."""
    hide: Any = None
    """Its client-scoped, hidden ``/shared`` (while it works on its copy)."""
    private: Controller | None = None
    """Its own session (a private copy), else None: it follows the presenter."""
    tools: PresenterTools | None = None
    """The presenter's own folders (Explain, Live), on a presenter's browser only."""
    shadows: tuple[Any, ...] = ()
    """Client-scoped hidden nodes over the presenter's broadcast drawings (a copy)."""
    explain: PrivateExplain | None = None
    """The Explain mode of its own copy (drawn in its scope only), else None."""
    live: PrivateLive | None = None
    """The live robot of its own copy (drawn in its scope only), else None."""
    full: bool = False
    """Whether it came when every seat was taken (it gets no scene, only a message)."""
    note: Any = None
    """A message under its buttons (the class is full, no copy for now), else None."""
    fetch: Any = None
    """The button beside that message: the presenter's scene, to open at home."""
    shown: tuple[str, bool] | None = None
    """The mode and lab switch its banner shows (a student's banner shows no counts)."""
    building: threading.Lock = dataclasses.field(default_factory=threading.Lock)
    """Held while its own panel is built or removed."""
    switches: Bucket = dataclasses.field(
        default_factory=lambda: Bucket(SWITCHES[1], SWITCHES[0], time.monotonic())
    )
    """Its copies and follows (:data:`SWITCHES`)."""

    @property
    def client_id(self) -> int:
        """The browser's client id."""
        return self.client.client_id


@dataclasses.dataclass(frozen=True)
class PrivateExplain:
    """A private copy's Explain mode: its panel, its folder, the scope it draws in."""

    panel: ExplainPanel
    target: ScopedTarget
    root: str
    """Where it draws in the browser's scope (one root per copy)."""

    @classmethod
    def open(
        cls,
        client: viser.ClientHandle,
        controller: Controller,
        root: str,
        turns: threading.Semaphore,
    ) -> PrivateExplain:
        """Give ``client``'s copy (``controller``) an Explain folder and drawing of its own.

        The drawing goes to the browser's own scope under ``root``, never to the class:
        the presenter's broadcast ``/explain`` is hidden for this browser while it works
        on its copy (the seat's shadows). A root of its own per copy: a copy's Explain
        closing after the next copy opened never touches the new one's nodes. The
        explanations compute in the server's process, ``turns`` at a time over all the
        copies (as their planners share ``copy_workers`` processes).
        """
        target = ScopedTarget(client, root)
        panel = ExplainPanel(cast(Any, target), controller, gui=client.gui, turns=turns)
        controller.add_view(panel)
        return cls(panel, target, root)

    def close(self) -> None:
        """Stop the explanation, take its folder off the panel and its drawing away."""
        try:
            self.panel.close(hide=False)  # its nodes are removed below
        finally:
            if self.panel.folder is not None:
                self.panel.folder.remove()
            self.target.remove()


@dataclasses.dataclass(frozen=True)
class PrivateLive:
    """A private copy's *Live DSB*: its robot, its folder, the scope it draws in."""

    run: LiveRun
    panel: LivePanel
    target: ScopedTarget

    @classmethod
    def open(
        cls,
        client: viser.ClientHandle,
        controller: Controller,
        root: str,
        ticker: Ticker,
    ) -> PrivateLive:
        """Give ``client``'s copy (``controller``) a live robot of its own.

        It drives in the copy's newest scene and draws (trail, moving obstacles and their
        paths) in the browser's own scope under ``root``, the robot in the copy's views;
        the presenter's broadcast ``/live`` is hidden for this browser meanwhile (the
        seat's shadows). ``ticker`` steps it, shared by every copy.
        """
        target = ScopedTarget(client, root)
        controller.add_view(MotionPaths(target))
        run = LiveRun(
            lambda: controller.scene, target, [controller.views], ticker=ticker
        )
        return cls(run, add_live_panel(client, run), target)

    def close(self) -> None:
        """Stop the robot, take its folder off the panel and its drawing away."""
        try:
            self.run.close()
        finally:
            self.panel.folder.remove()
            self.target.remove()


@dataclasses.dataclass(frozen=True)
class PresenterTools:
    """Folders only a presenter's browser has, drawing for everyone (Explain, Live DSB).

    ``views`` follow the presenter's session (through the :class:`Audience`); ``close``
    runs when that browser leaves. What they draw goes to every browser, under roots a
    private copy's browser hides (``Classroom(broadcast_roots=...)``). The app's tools
    (``server._presenter_tools``) are folders of one Explain and one live robot shared
    by every presenter's browser: ``close`` removes that browser's folders only.
    """

    views: tuple[View, ...]
    """Views of the presenter's session (e.g. the Explain panel)."""
    close: Callable[[], None]
    """Called when the presenter's browser leaves."""


@dataclasses.dataclass(frozen=True)
class CopyResources:
    """What every private copy of a classroom shares; a copy holds no thread of its own.

    Its planners run in the worker pools, its rounds and slow calls on the runners, its
    robot on the ticker; its explanations take turns of ``explain_turns``.
    """

    pool: WorkerPool
    """The slow-lane workers (DSB, Bug2)."""
    fast_pool: WorkerPool
    """The fast-lane workers (VG, SVG): no copy plans in the interpreter that serves the
    presenter."""
    big_pool: WorkerPool
    """The workers for big scenes' graphs (:mod:`app.session.big`)."""
    turns: Turns
    """The copies' rounds in this process: one at a time, a bounded rate in all."""
    explain_turns: threading.Semaphore
    """How many copies' explanations may compute at once (in this process)."""
    rounds: Runner
    """Runs every copy's rounds (they take turns: one thread is enough)."""
    slow_calls: Runner
    """Runs every copy's slow-lane calls, as many at once as the pool has workers."""
    ticker: Ticker
    """Draws every copy's robot animation and steps its live robot."""

    @classmethod
    def build(cls, controller: Controller, workers: int) -> CopyResources:
        """Pools of at most ``workers`` processes each (none started yet), and the rest."""
        registry = dict(controller.registry)
        return cls(
            pool=WorkerPool(_slow_fn(controller), size=workers, nice=COPY_NICE),
            fast_pool=WorkerPool(_fast_fn(controller), size=workers, nice=COPY_NICE),
            big_pool=WorkerPool(big_plan(registry), size=workers),
            turns=Turns(COPY_ROUNDS_PER_S),
            explain_turns=threading.Semaphore(max(1, workers)),
            rounds=Runner(1, name="copies-rounds"),
            slow_calls=Runner(workers, name="copies-slow"),
            ticker=Ticker(COPY_TICKS_PER_S, name="copies-robots"),
        )

    def close(self) -> None:
        """Stop the threads, then the worker processes."""
        self.ticker.close()
        self.rounds.close()
        self.slow_calls.close()
        self.pool.close()
        self.fast_pool.close()
        self.big_pool.close()


class Classroom:
    """The presenter's session shared with a class; private copies on request.

    Parameters
    ----------
    server
        The viser server.
    controller
        The presenter's session (its views: the shared view; the audience is added here).
    token
        The secret in the presenter's URL.
    titles
        Scenario key -> title, for each panel's dropdown.
    scenarios
        Scenario key -> file, for the private copies' controllers.
    folder
        The scenes folder (``--scenes-dir``) or None.
    copy_workers
        Most worker processes the private copies' slow lanes share.
    tools
        Builds a presenter browser's own folders (Explain, Live DSB).
    broadcast_roots
        Scene roots a private copy's browser hides (what the tools draw for everyone).
    on_token
        Called with the new token after :meth:`rotate_token` (the app prints the URL).
    capacity
        Most browsers and copies (:mod:`app.classroom.capacity`; this machine's by
        default).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        controller: Controller,
        token: str,
        titles: Mapping[str, str],
        scenarios: Mapping[str, Path],
        *,
        folder: ScenesFolder | None = None,
        copy_workers: int = 1,
        tools: Callable[[viser.ClientHandle], PresenterTools] | None = None,
        broadcast_roots: tuple[str, ...] = (),
        on_token: Callable[[str], None] | None = None,
        capacity: Capacity | None = None,
    ) -> None:
        self.server = server
        self.capacity = _fit_open_files(capacity or Capacity.of_machine())
        """Most browsers and copies the classroom takes."""
        self.controller = controller
        """The presenter's session."""
        self.token = token
        """The presenter's secret."""
        self._titles = dict(titles)
        self._scenarios = dict(scenarios)
        self._folder = folder
        self._tools = tools
        self._roots = broadcast_roots
        self._lock = threading.RLock()
        self._banner_lock = threading.Lock()
        self._on_token = on_token
        self._seats: dict[int, Seat] = {}
        self._open = False
        self.refusals = Refusals()
        """Edits refused because the browser may not edit (crafted or not)."""
        self.audience = Audience()
        """The followers' views, drawn by the presenter's session."""
        self.watch = WatchPanel(
            server,
            controller,
            titles=self._titles,
            registry=controller.registry,
            refusals=self.refusals,
            never=STUDENT_NEVER,
        )
        """The watchers' one panel (app.classroom.watch), drawn at a bounded rate."""
        self.audience.add(self.watch.panels, deferred=True)
        self.encoding = share_encoding(server)
        """The pump: each broadcast window encoded once for every browser, the class's
        at the class's frame rate (app.classroom.wire)."""
        self.shared = CopyResources.build(controller, copy_workers)
        """What every private copy shares: worker processes, turns, threads."""
        self._copies = itertools.count(1)  # numbers each copy's Explain root
        controller.add_view(self.audience)
        self._load = _LoadMeter()
        self._emptied_at: float | None = None  # when the last student left
        self._closed = threading.Event()
        self._load_thread = threading.Thread(
            target=self._show_load, name="classroom-load", daemon=True
        )
        self._load_thread.start()
        server.on_client_connect(self.connect)
        server.on_client_disconnect(self.disconnect)

    # ------------------------------------------------------------------ reading

    @property
    def open(self) -> bool:
        """Whether every follower may edit the presenter's scene (a lab session)."""
        return self._open

    def seat(self, client_id: int) -> Seat | None:
        """Return the seat of browser ``client_id`` (None if it is not connected).

        Read without the classroom's lock (one dictionary look-up): every edit of the
        presenter asks :meth:`may_edit`, and must never wait for a seat being built.
        """
        return self._seats.get(client_id)

    def mode(self, client_id: int) -> str:
        """``presenter``, ``watching``, ``together``, ``private``, ``full`` ('': unknown)."""
        seat = self.seat(client_id)
        if seat is None:
            return ""
        if seat.presenter:
            return "presenter"
        if seat.full:
            return "full"
        if seat.private is not None:
            return "private"
        return "together" if self._open else "watching"

    def is_presenter_connection(self, client_id: int) -> bool:
        """Whether browser ``client_id``'s websocket carries the presenter's secret now."""
        return is_presenter_path(connection_path(self.server, client_id), self.token)

    def may_edit(self, client_id: int) -> bool:
        """Whether browser ``client_id`` may edit the presenter's scene now."""
        seat = self.seat(client_id)
        if seat is None or seat.full:
            return False
        return seat.presenter or (self._open and seat.private is None)

    def counts(self) -> dict[str, int]:
        """How many browsers are in each mode, and how many private sessions run."""
        with self._lock:
            modes = [self.mode(cid) for cid in self._seats]
        out = {m: modes.count(m) for m in MODES}
        out["sessions"] = out["private"]
        return out

    # ------------------------------------------------------------------ browsers

    def connect(self, client: viser.ClientHandle) -> None:
        """Give a new browser its seat: banner, buttons, panel; watching by default."""
        with quietly(client):  # it may leave while its seat is built
            self._connect(client)

    def _connect(self, client: viser.ClientHandle) -> None:
        path = connection_path(self.server, client.client_id)
        presenter = is_presenter_path(path, self.token)
        seat = Seat(client, presenter)
        with self._lock:
            seat.full = not presenter and self._taken() >= self.capacity.seats
            if seat.full:
                # Every seat is taken: no scene for it, only a message (below).
                mute(self.server, client.client_id)
                self._seats[client.client_id] = seat
        if seat.full:
            self._turn_away(seat)
            return
        if presenter:
            self.encoding.full_rate(client.client_id)  # the scene at every frame
        if presenter or self._open:
            self._ensure_panels(seat)  # a watcher's is the class's one panel
        with self._lock:
            if presenter and not is_presenter_path(path, self.token):
                # The secret was replaced while this seat was built: it presents no more.
                close_connection(self.server, client.client_id, "link replaced")
                return
            self._seats[client.client_id] = seat
            self._follow(seat)
        # The banner and buttons go above the panel (smaller order), built once the seat
        # exists: a click on "Make my own copy" always finds it.
        seat.banner = client.gui.add_html("", order=-3.0)
        seat.buttons = (
            self._presenter_switch(client) if presenter else self._copy_buttons(client)
        )
        if presenter and self._tools is not None:
            tools = self._tools(client)
            with self._lock:
                seated = self._seats.get(client.client_id) is seat
                if seated:
                    seat.tools = tools
                    self.audience.add(*tools.views)
            if not seated:  # it left while its tools were built: nothing else has them
                tools.close()
                return
        if client.client_id not in self.server.get_clients():
            # viser runs connect and disconnect callbacks in a thread pool: a browser
            # that left while its seat was being built would otherwise keep it.
            self.disconnect(client)
            return
        self._refresh_banners()

    def disconnect(self, client: viser.ClientHandle) -> None:
        """Free a closed browser's seat and its private session, if any."""
        with self._lock:
            seat = self._seats.pop(client.client_id, None)
            if seat is None:
                return
            if seat.presenter:
                self.encoding.full_rate(client.client_id, on=False)
            private, seat.private = seat.private, None
            if private is not None:  # before its view goes: it draws no more
                private.remove_views()
            self._leave_audience(seat)
            tools, seat.tools = seat.tools, None
            if tools is not None:
                self.audience.remove(*tools.views)
            explain, seat.explain = seat.explain, None
            live, seat.live = seat.live, None
        # Outside the lock: closing waits for the tools' and the copy's threads.
        if tools is not None:
            tools.close()
        _close_copy(private, explain, live)
        self._refresh_banners()
        if not seat.presenter:
            with self._lock:
                if self._class_left():
                    self._emptied_at = time.monotonic()

    def set_open(self, value: bool) -> None:
        """Let every follower edit the presenter's scene (a lab session), or take it back.

        Each follower gets a panel of its own to edit with, built outside the lock.
        """
        with self._lock:
            self._open = bool(value)
            followers = [
                s for s in self._seats.values() if not s.presenter and s.private is None
            ]
        if value:
            for seat in followers:
                self._ensure_panels(seat)
        with self._lock:
            for seat in followers:
                if self._seats.get(seat.client_id) is seat and seat.private is None:
                    self._leave_audience(seat)
                    self._follow(seat)
        self._refresh_banners()

    def make_copy(self, client_id: int) -> bool:
        """Give browser ``client_id`` a session of its own, seeded from the presenter's scene.

        The copy's session and its Explain are built before the classroom's lock is
        taken: the lock is held only to swap the seat's views. A seat switches between
        copy and presenter at most as often as :data:`SWITCHES` says.
        """
        seat = self.seat(client_id)
        if seat is None or seat.presenter or seat.full or seat.private is not None:
            return False
        if not self._switch_allowed(seat):
            return False
        if self.counts()["private"] >= self.capacity.copies:
            self._say(seat, no_copy_html(self.capacity))
            return False
        self._ensure_panels(seat)
        snapshot = self.controller.frame
        private = Controller(
            [],
            self.controller.scene,
            registry=self.controller.registry,
            trajectory=robot_model.trajectory,
            sample=robot_model.sample,
            scenarios=self._scenarios,
            scenario=snapshot.scenario if snapshot is not None else "",
            folder=self._folder,
            floor_map=snapshot.floor_map if snapshot is not None else None,
            slow_process=self.shared.pool,
            fast_process=self.shared.fast_pool,
            turns=self.shared.turns,
            ticker=self.shared.ticker,
            runners=(self.shared.rounds, self.shared.slow_calls),
            big_workers=SharedWorkers(self.shared.big_pool),
        )
        number = next(self._copies)
        explain = PrivateExplain.open(
            seat.client, private, f"/own_explain/{number}", self.shared.explain_turns
        )
        live = PrivateLive.open(
            seat.client, private, f"/own_live/{number}", self.shared.ticker
        )
        with self._lock:
            kept = self._seats.get(client_id) is seat and seat.private is None
            if kept:
                self._commit_copy(seat, private, explain, live)
        if not kept:  # it left, or made a copy from another click, meanwhile
            _close_copy(private, explain, live)
            return False
        self._refresh_banners()
        return True

    def _commit_copy(
        self,
        seat: Seat,
        private: Controller,
        explain: PrivateExplain,
        live: PrivateLive,
    ) -> None:
        """Move a seat from the presenter's session to its copy (under the lock)."""
        # Quietly: the browser may leave while its copy is set up.
        with quietly(seat.client):
            self._unsay(seat)
            self._leave_audience(seat)
            # The copy first: its gizmo is in the browser as soon as it is made, and a
            # drag of it (viser's thread, not under this lock) must find the copy.
            seat.private, seat.explain, seat.live = private, explain, live
            own = seat.own = self._own_view(seat, self._private_drag(seat))
            seat.shadows = _shadows(seat.client, self._roots)
            # Built before the lock, unless a lab just ended and took it back.
            panels = self._ensure_panels(seat)
            gated = GatedController(
                private,
                lambda: seat.private is private,
                self.refusals,
                never=STUDENT_NEVER,
            )
            panels.attach(cast(Controller, gated))
            _lock(panels, editable=True, presenter=False)
            private.add_view(own)
            private.add_view(panels)

    def follow(self, client_id: int) -> bool:
        """Close browser ``client_id``'s own copy; it follows the presenter again."""
        seat = self.seat(client_id)
        if seat is None or seat.private is None or not self._switch_allowed(seat):
            return False
        with self._lock:
            if self._seats.get(client_id) is not seat or seat.private is None:
                return False
            private, seat.private = seat.private, None
            explain, seat.explain = seat.explain, None
            live, seat.live = seat.live, None
            private.remove_views()  # before its view goes: it draws no more
            self._drop_own_view(seat)
            for shadow in seat.shadows:
                shadow.remove()
            seat.shadows = ()
            self._follow(seat)
        # Outside the lock: closing waits for the copy's and the explanation's threads.
        _close_copy(private, explain, live)
        self._refresh_banners()
        return True

    def rotate_token(self, client_id: int) -> str | None:
        """Give the presenter's URL a new secret; every other presenter browser leaves.

        Asked from presenter ``client_id``'s panel: that browser stays the presenter;
        the others are disconnected and come back as watchers (their URL holds the old
        secret). Returns the new token (None: ``client_id`` is no presenter).
        """
        seat = self.seat(client_id)
        if seat is None or not seat.presenter:
            self.refusals.add()
            return None
        with self._lock:
            old, self.token = self.token, new_token()
            others = [
                s.client_id
                for s in self._seats.values()
                if s.presenter and s is not seat
            ]
        # Every connection opened with the old secret, seated or still connecting.
        connections = self.server._websock_server._live_connections
        others += [
            cid
            for cid in list(connections)
            if cid != client_id
            and is_presenter_path(connection_path(self.server, cid), old)
        ]
        for other in set(others):
            close_connection(self.server, other, "the presenter's link was replaced")
        if self._on_token is not None:
            self._on_token(self.token)
        return self.token

    def _switch_allowed(self, seat: Seat) -> bool:
        """Whether a seat may switch between copy and presenter now (then it has)."""
        with self._lock:
            allowed = seat.switches.take(time.monotonic())
        if not allowed:
            self.refusals.add()
            with contextlib.suppress(Exception):  # it may have just left
                seat.client.add_notification(
                    "Not so fast",
                    "Wait a second before switching between your copy and the "
                    "presenter again.",
                    auto_close_seconds=5.0,
                )
        return allowed

    def close(self) -> None:
        """Close every private session and the workers they share."""
        with self._lock:
            seats = list(self._seats.values())
            self._seats.clear()
        for seat in seats:
            if seat.tools is not None:
                seat.tools.close()
            _close_copy(seat.private, seat.explain, seat.live)
        self._closed.set()
        self._load_thread.join(timeout=5.0)
        self.audience.close()
        stop_sharing(self.server)
        self.shared.close()

    # ------------------------------------------------------------------ wiring

    def _follow(self, seat: Seat) -> None:
        """Attach a seat to the presenter's session, editing or watching as allowed."""
        cid = seat.client_id
        if not self.may_edit(cid):
            self._drop_own_view(seat)
            self._drop_panels(seat)
            if not seat.watching:
                seat.watching = True
                self.watch.show(seat.client)
            return
        self._stop_watching(seat)
        panels = self._ensure_panels(seat)
        never = frozenset() if seat.presenter else STUDENT_NEVER
        gated = GatedController(
            self.controller, lambda: self.may_edit(cid), self.refusals, never
        )
        panels.attach(cast(Controller, gated))
        _lock(panels, editable=True, presenter=seat.presenter)
        if seat.own is None:
            seat.own = GizmoView(
                ScopedTarget(seat.client, "/own"), self._shared_drag(cid)
            )
        self.audience.add(seat.own, first=seat.presenter)
        # A follower's panel is drawn at a bounded rate; the presenter's at once.
        self.audience.add(panels, first=seat.presenter, deferred=not seat.presenter)

    def _leave_audience(self, seat: Seat) -> None:
        self.audience.remove(*(v for v in (seat.own, seat.panels) if v is not None))
        self._drop_own_view(seat)
        self._stop_watching(seat)

    def _stop_watching(self, seat: Seat) -> None:
        if seat.watching:
            seat.watching = False
            self.watch.hide(seat.client)

    def _ensure_panels(self, seat: Seat) -> Panels:
        """Build the seat's own panel if it has none (slow: outside the lock if possible)."""
        with seat.building:
            if seat.panels is None:
                box = seat.client.gui.add_folder(None, order=PANEL_ORDER)
                with box:
                    panels = Panels(
                        seat.client,
                        self._titles,
                        self.controller.registry,
                        self._folder,
                        saving=seat.presenter,
                    )
                seat.panels, seat.panel_box = panels, box
            return seat.panels

    def _drop_panels(self, seat: Seat) -> None:
        """Remove the seat's own panel (it watches with the class's one)."""
        with seat.building:
            box, seat.panel_box, seat.panels = seat.panel_box, None, None
        if box is not None:
            box.remove()

    def _own_view(self, seat: Seat, on_drag: Callable[..., None]) -> PlannerView:
        """Build a copy's 3-D view with live gizmos in the seat's scope; hide the shared one."""
        if seat.hide is None:
            (seat.hide,) = _shadows(seat.client, ("/shared",))
        view = PlannerView(ScopedTarget(seat.client, "/own"), on_drag=on_drag)
        view.robot_model_fn = robot_model.robot_model
        return view

    def _drop_own_view(self, seat: Seat) -> None:
        if seat.own is not None:
            target = seat.own.target
            seat.own = None
            if isinstance(target, ScopedTarget):
                target.remove()
        if seat.hide is not None:
            hide, seat.hide = seat.hide, None
            hide.remove()

    def _shared_drag(self, client_id: int) -> Callable[..., None]:
        def drag(handle: Any, xy: tuple[float, float], phase: str) -> None:
            if self.may_edit(client_id):
                self.controller.edits.drag_handle(handle, xy, phase)
            else:
                self.refusals.add()

        return drag

    def _private_drag(self, seat: Seat) -> Callable[..., None]:
        def drag(handle: Any, xy: tuple[float, float], phase: str) -> None:
            private = seat.private
            if private is not None:
                private.edits.drag_handle(handle, xy, phase)

        return drag

    # ------------------------------------------------------------------ capacity

    def _taken(self) -> int:
        """Seats taken by students (under the lock): all but presenters and the full."""
        return sum(1 for s in self._seats.values() if not (s.presenter or s.full))

    def _turn_away(self, seat: Seat) -> None:
        """Tell a browser that every seat is taken; hide what scene it got meanwhile."""
        client = seat.client
        seat.shadows = _shadows(client, ("/shared", *self._roots))
        seat.banner = client.gui.add_html("", order=-3.0)
        seat.buttons = ()
        self._say(seat, full_html(self.capacity))
        if client.client_id not in self.server.get_clients():
            self.disconnect(client)  # it left meanwhile
            return
        self._refresh_banners()

    def _say(self, seat: Seat, html: str) -> None:
        """Put ``html`` under a seat's buttons, with the presenter's scene to download."""
        gui = seat.client.gui
        with seat.building:
            if seat.note is None:
                seat.note = gui.add_html("", order=-0.9)
                seat.fetch = gui.add_button(
                    FETCH_LABEL,
                    hint="To open in the planner on your laptop",
                    order=-0.8,
                )
                seat.fetch.on_click(functools.partial(self._fetch, seat))
            seat.note.content = (
                '<div style="border-left:4px solid #b35900;padding:4px 8px;'
                f'font-size:0.9em">{html}</div>'
            )

    def _unsay(self, seat: Seat) -> None:
        with seat.building:
            note, fetch, seat.note, seat.fetch = seat.note, seat.fetch, None, None
        for handle in (note, fetch):
            if handle is not None:
                handle.remove()

    def _fetch(self, seat: Seat, event: Any) -> None:
        """Send the presenter's scene to the browser that asked (its own seat only)."""
        if event.client_id != seat.client_id:
            return
        file = self.controller.files.download()
        if file is not None:
            seat.client.send_file_download(file[0], file[1], save_immediately=True)

    def load(self) -> Load:
        """Return the class's load now (what the lecturer's banner shows)."""
        counts = self.counts()
        return Load(
            following=counts["watching"] + counts["together"],
            copies=counts["private"],
            turned_away=counts["full"],
            capacity=self.capacity,
            cpu=self._load.cpu,
            behind=self._behind(),
        )

    def _behind(self) -> int:
        """Browsers with more than :data:`SLOW_BYTES` waiting in their socket."""
        connections = getattr(self.server._websock_server, "_live_connections", {})
        slow = 0
        for connection in list(connections.values()):
            transport = getattr(connection, "transport", None)
            if transport is not None and transport.get_write_buffer_size() > SLOW_BYTES:
                slow += 1
        return slow

    def _show_load(self) -> None:
        """Refresh the lecturer's banner every :data:`LOAD_SECONDS` (the CPU share)."""
        while not self._closed.wait(LOAD_SECONDS):
            self._load.sample()
            try:
                self._refresh_banners()
            except Exception:
                logger.exception("could not show the class's load")
            self._give_back_memory()

    def _class_left(self) -> bool:
        """Whether no one but presenters is seated (under the lock)."""
        return all(s.presenter for s in self._seats.values())

    def _give_back_memory(self) -> None:
        """Give back what the class freed, once it has been gone a whole load tick.

        Every :data:`LOAD_SECONDS`. A browser's connection leaves a few hundred objects
        in reference cycles, which only a full collection frees: it runs here, once per
        class that leaves, rather than at a random later moment (it holds the
        interpreter for tens of milliseconds after a hall of 300, and the presenter may
        be dragging then as at any other time). Then
        :func:`planners.allocator.give_back_freed_memory` returns the memory to the
        system. Not at the last student's disconnect: viser drops a connection's
        buffers after that callback.
        """
        with self._lock:
            emptied = self._emptied_at
            if emptied is None or time.monotonic() - emptied < LOAD_SECONDS:
                return
            self._emptied_at = None
            if not self._class_left():
                return
        gc.collect()
        give_back_freed_memory()

    # ------------------------------------------------------------------ the seat's GUI

    def _copy_buttons(self, client: viser.ClientHandle) -> Any:
        cid = client.client_id
        gui = client.gui
        copy = gui.add_button(
            "Make my own copy",
            hint="Your own scene: edit it without the class",
            order=-2.0,
        )
        back = gui.add_button("Follow the presenter again", visible=False, order=-1.0)

        @copy.on_click
        def _(event: Any) -> None:
            if event.client_id == cid:
                self.make_copy(cid)

        @back.on_click
        def _(event: Any) -> None:
            if event.client_id == cid:
                self.follow(cid)

        return copy, back

    def _presenter_switch(self, client: viser.ClientHandle) -> Any:
        cid = client.client_id
        switch = client.gui.add_checkbox(
            "Let everyone edit",
            False,
            hint="A lab session: every student's edits reach the shared scene",
            order=-2.0,
        )
        renew = client.gui.add_button(
            "New presenter link",
            hint="Signs out every other presenter browser; the new link is printed "
            "in the terminal that started the planner",
            order=-1.5,
        )

        @renew.on_click
        def _(event: Any) -> None:
            if event.client_id == cid:
                self.rotate_token(cid)

        @switch.on_update
        def _(event: Any) -> None:
            seat = self.seat(cid)
            if event.client is None or seat is None or not seat.presenter:
                return
            self.set_open(bool(event.target.value))

        return switch

    def _refresh_banners(self) -> None:
        # One refresh at a time, counted and written in one go: two seats leaving
        # together must not leave the older counts on the banners.
        with self._banner_lock:
            with self._lock:
                seats = list(self._seats.values())
                counts = self.counts()
            self._write_banners(seats, counts, load_text(self.load()))
            self.encoding.rate = class_rate(counts["watching"] + counts["together"])

    def _write_banners(
        self, seats: list[Seat], counts: dict[str, int], load: str
    ) -> None:
        for seat in seats:
            mode = self.mode(seat.client_id)
            if not mode or seat.banner is None or seat.buttons is None:
                continue  # its banner and buttons are being built
            if left(seat.client):
                continue  # it left meanwhile: its seat goes soon
            if not seat.presenter and seat.shown == (mode, self._open):
                continue  # a student's banner shows no counts: nothing new for it
            try:
                with batch(seat.client):
                    _set_banner(seat, mode, counts, self._open, load)
                seat.shown = (mode, self._open)
            except Exception:
                logger.exception("could not update a browser's banner")


def _lock(panels: Panels, *, editable: bool, presenter: bool) -> None:
    """Enable a panel's controls as its seat may use them (saving: the presenter only)."""
    panels.lock(not editable, saving=presenter)


_MASK_SECRET = (
    '<style>input[value*="/presenter/"]{-webkit-text-security:disc;'
    "text-security:disc}</style>"
)
"""Draws viser's own *Server URL* field (its settings) as dots in a presenter's browser:
the field holds the presenter's secret, and the projector shows that browser."""


def banner_html(
    mode: str, counts: Mapping[str, int], open_: bool, load: str = ""
) -> str:
    """Return the coloured box that says which mode a browser is in.

    ``load``: the class's load (:func:`app.classroom.capacity.load_text`), shown on a
    presenter's banner instead of the plain counts.

    Examples
    --------
    >>> "Watching the presenter" in banner_html("watching", {}, False)
    True
    >>> "2 presenter browsers" in banner_html("presenter", {"presenter": 2}, False)
    True
    """
    colour, title, text = MODES[mode]
    if mode == "presenter":
        lab = "Everyone may edit." if open_ else "Only you edit."
        following = counts.get("watching", 0) + counts.get("together", 0)
        counted = (
            f"{following} following, {counts.get('private', 0)} on their own copy."
        )
        text = f"{text}<br>{load or counted} {lab}"
        browsers = counts.get("presenter", 1)
        if browsers > 1:
            text += (
                f"<br>{browsers} presenter browsers: one scene, one Explain, "
                "one live robot."
            )
    mask = _MASK_SECRET if mode == "presenter" else ""
    return (
        mask + f'<div style="background:{colour};color:white;padding:8px 10px;'
        f'border-radius:6px;margin:2px 0">'
        f'<div style="font-size:1.25em;font-weight:bold">{title}</div>'
        f'<div style="font-size:0.85em">{text}</div></div>'
    )


def _shadows(client: viser.ClientHandle, roots: tuple[str, ...]) -> tuple[Any, ...]:
    """Hide the broadcast drawings under ``roots`` from one browser.

    A client-scoped hidden frame shadows the broadcast node of its name
    (:mod:`app.ui.scoped`).
    """
    with quietly(client):
        return tuple(
            client.scene.add_frame(root, show_axes=False, visible=False)
            for root in roots
        )


def _set_banner(
    seat: Seat, mode: str, counts: Mapping[str, int], open_: bool, load: str
) -> None:
    html = banner_html(mode, counts, open_, load)
    if seat.banner.content != html:
        seat.banner.content = html
    if mode == "full":
        return  # no buttons: nothing to switch
    if seat.presenter:
        if seat.buttons.value != open_:
            seat.buttons.value = open_
        return
    # The button a seat can use now: copy while following, follow while on a copy.
    copy, back = seat.buttons
    if copy.visible != (mode != "private"):
        copy.visible = mode != "private"
    if back.visible != (mode == "private"):
        back.visible = mode == "private"


class _LoadMeter:
    """The share of the machine's cores this process used between two samples."""

    def __init__(self) -> None:
        self._at = (time.monotonic(), time.process_time())
        self.cpu = -1.0
        """The share (0-1) over the last interval, -1 before the first."""

    def sample(self) -> None:
        """Measure the share since the last sample."""
        now = (time.monotonic(), time.process_time())
        wall = now[0] - self._at[0]
        if wall > 0:
            self.cpu = (now[1] - self._at[1]) / wall / (os.cpu_count() or 1)
        self._at = now


def _fit_open_files(capacity: Capacity) -> Capacity:
    """Raise the limit of open files to what ``capacity`` needs, or fit it to the limit.

    A server past its limit would refuse connections without a word to anyone; the
    lecturer reads in the terminal how many seats the limit allows instead.
    """
    needed = open_files_for(capacity)
    limit = raise_open_files(needed)
    if limit >= needed:
        return capacity
    fitted = fit_open_files(capacity, limit)
    logger.warning(
        "this process may open %d files (ulimit -n), enough for %d seats, not %d: "
        "the class takes %d (raise the limit for more)",
        limit,
        fitted.seats,
        capacity.seats,
        fitted.seats,
    )
    return fitted


def _fast_fn(controller: Controller) -> Any:
    """Return the fast planners' function for a worker pool (the presenter's registry)."""
    registry = dict(controller.registry)
    return functools.partial(default_plan, registry=registry)


def _slow_fn(controller: Controller) -> Any:
    """Return the slow planners' function for a worker pool (the presenter's registry)."""
    registry = dict(controller.registry)
    slow = planners_of_kind("trace", registry=registry)
    return functools.partial(default_plan, which=slow, registry=registry)


def _close_copy(
    private: Controller | None,
    explain: PrivateExplain | None,
    live: PrivateLive | None,
) -> None:
    """Close what a copy has: its live robot first (it reads the session), then the rest."""
    if live is not None:
        live.close()
    if private is not None:
        private.close()
    if explain is not None:
        explain.close()
