"""What a browser may send the server: the app decides, before viser reads a byte of it.

viser acts on every message its client can send, from any browser: it opens a public
share tunnel on ``ShareUrlRequest``, relays ``GuiFormDirtyMessage`` (with a uuid of any
size) to every browser and keeps it, sets a dropdown to a value that is none of its
options, buffers an upload whatever size it declares, and accepts 50 MB frames. The
:class:`Door` stands between each websocket and viser's dispatch and lets through only
what the planner's page sends in normal use:

- **an allow-list of message types** (:data:`ALLOWED`): the camera, widget values, the
  gizmos, a click on the floor, an upload. Anything else is dropped unread;
- **widget values the widget offers**, on a widget the page shows and has not
  disabled: a dropdown's value is one of its options, a
  button group's one of its buttons, a slider's a finite number in its range, a
  checkbox's a bool, a text at most :data:`MAX_TEXT` characters; only ``value`` is set;
- **uploads checked before they are buffered**: declared size at most
  :data:`app.session.files.MAX_UPLOAD_BYTES`, parts within it, one upload at a time per browser;
  a refused upload is told to its browser;
- **a frame size limit** (:data:`MAX_MESSAGE_BYTES`) set on the websocket server itself
  (:func:`message_limit`), so an oversized frame closes its sender before it is read;
- **a rate per browser** for browsers without priority (a classroom's seats): a token
  bucket per kind of message (camera moves, uploads, the rest); what is over is dropped.
  A click on a *Download* button (the server builds a file and sends it, up to a few
  MB) takes a token of a bucket of its own as well.

The door reads a message's type first, then the few messages it checks whole as typed
records (:class:`msgspec.Struct`): a field of the wrong shape is refused as it is read.

What one browser sends is kept per connection and forgotten when it leaves. Refusals
are counted by reason (:attr:`Door.refused`). This reads viser 1.1.1's internals (the
websocket server's live connections, the GUI handles by uuid), as
:func:`app.classroom.connection_path` does.

Data flow::

    browser B's websocket frame -> Door.admit(B, raw)
      no  -> dropped (counted)
      yes -> viser decodes and dispatches it -> callbacks (app.guard.fair)
"""

from __future__ import annotations

__all__ = [
    "ALLOWED",
    "DOWNLOAD_LABEL",
    "MAX_MESSAGE_BYTES",
    "MAX_TEXT",
    "Bucket",
    "Door",
    "Rates",
    "message_limit",
    "offers",
    "usable",
]

import collections
import contextlib
import dataclasses
import functools
import logging
import math
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import msgspec
import viser
import websockets.asyncio.server

from app.session.files import MAX_UPLOAD_BYTES

logger = logging.getLogger(__name__)

ALLOWED = frozenset(
    {
        "ViewerCameraMessage",
        "GuiUpdateMessage",
        "TransformControlsUpdateMessage",
        "TransformControlsDragStartMessage",
        "TransformControlsDragEndMessage",
        "ScenePointerMessage",
        "FileTransferStartUpload",
        "FileTransferPart",
    }
)
"""Message types a browser may send (what the planner's page uses); all others drop."""

MAX_MESSAGE_BYTES = 1 << 20
"""Largest websocket frame a browser may send (an upload's part is 512 KiB)."""

STUCK_BYTES = 256 * 1024
"""Bytes waiting to be sent to a browser above which it counts as not reading."""

MAX_TEXT = 200
"""Longest value of a text field."""

UPLOAD_PART_BYTES = 512 * 1024
"""Size of an upload's parts as viser's page cuts them."""

DOWNLOAD_LABEL = "Download"
"""Buttons whose label starts so make the server build a file and send it."""
_BUCKET = {"ViewerCameraMessage": "camera", "FileTransferStartUpload": "upload"}
"""Which of a browser's buckets a message takes from (all others: ``other``)."""


class _Head(msgspec.Struct):
    type: str


# The messages the door reads whole, as typed records: msgspec checks each field's type
# as it reads, so a field of the wrong shape (a million nested arrays where bytes should
# be) is refused at its first byte instead of being built into Python objects first.
class _Update(msgspec.Struct, forbid_unknown_fields=True):
    type: str
    uuid: str
    updates: dict[str, msgspec.Raw]


class _Start(msgspec.Struct, forbid_unknown_fields=True):
    type: str
    source_component_uuid: str
    transfer_uuid: str
    filename: str
    mime_type: str
    part_count: int
    size_bytes: int


class _Part(msgspec.Struct, forbid_unknown_fields=True):
    type: str
    source_component_uuid: str | None
    transfer_uuid: str
    part_index: int
    content: bytes


_HEAD = msgspec.msgpack.Decoder(_Head)
_UPDATE = msgspec.msgpack.Decoder(_Update)
_START = msgspec.msgpack.Decoder(_Start)
_PART = msgspec.msgpack.Decoder(_Part)
_VALUE = msgspec.msgpack.Decoder(bool | int | float | str)
_UNREADABLE = (msgspec.DecodeError, msgspec.ValidationError, RecursionError, ValueError)


@dataclasses.dataclass(frozen=True)
class Rates:
    """Messages a second a browser without priority may send, and the burst it may save."""

    camera: float = 60.0
    """Camera moves a second (the page sends one per rendered frame while orbiting)."""
    other: float = 60.0
    """Widget values, gizmo moves and clicks a second (a drag sends up to 60)."""
    burst_seconds: float = 2.0
    """How many seconds' worth of messages a quiet browser may send at once."""
    uploads: float = 0.25
    """Uploads a second (each is read, checked and planned in the server)."""
    upload_burst: float = 3.0
    """Uploads a quiet browser may start at once."""
    downloads: float = 0.1
    """Clicks on a *Download* button a second (each builds a file and sends it)."""
    download_burst: float = 2.0
    """Downloads a quiet browser may ask for at once."""


@dataclasses.dataclass
class Bucket:
    """A token bucket: ``rate`` tokens a second, at most ``size`` saved, full at first.

    Examples
    --------
    >>> bucket = Bucket(rate=1.0, size=2.0, at=0.0)
    >>> [bucket.take(0.0), bucket.take(0.0), bucket.take(0.0), bucket.take(1.0)]
    [True, True, False, True]
    """

    rate: float
    size: float
    at: float
    level: float = math.inf

    def take(self, now: float) -> bool:
        """Take one token at time ``now`` [s]; False (nothing taken) if none is left."""
        self.level = min(self.size, self.level + (now - self.at) * self.rate)
        self.at = now
        if self.level < 1.0:
            return False
        self.level -= 1.0
        return True


@dataclasses.dataclass
class _Upload:
    parts: int
    declared: int
    seen: set[int] = dataclasses.field(default_factory=set)
    received: int = 0


@dataclasses.dataclass
class _Guest:
    """What the door keeps about one connection."""

    priority: bool
    buckets: dict[str, Bucket]
    upload: tuple[str, _Upload] | None = None
    since: float = 0.0
    """When it connected (``time.monotonic``)."""
    stuck_since: float | None = None
    """Since when the bytes waiting to be sent to it have not drained."""


class Door:
    """Admit or drop each message a browser sends (see the module's docstring).

    Parameters
    ----------
    server
        The viser server (its websocket server must be running).
    priority
        Whether a browser (by client id) is exempt from the rate limit; asked once, when
        it connects, and again by :meth:`reprioritise`. Default: every browser.
    rates
        The rate limit of the others.
    tell
        Called as ``tell(client_id, words)`` when a browser's action is refused in a
        way its user should hear about (an upload too large).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        priority: Callable[[int], bool] = lambda client_id: True,
        rates: Rates = Rates(),
        tell: Callable[[int, str], None] | None = None,
    ) -> None:
        self._server = server
        self._priority = priority
        self._rates = rates
        self._tell = tell
        self._lock = threading.Lock()
        self._guests: dict[int, _Guest] = {}
        self.refused: collections.Counter[str] = collections.Counter()
        """Messages dropped, by reason (``type``, ``value``, ``rate``, ``upload`` ...)."""
        websock = server._websock_server
        websock.on_client_connect(self._arrive)
        websock.on_client_disconnect(self._leave)
        self.silent_seconds = 20.0
        """A connection that has not become a browser (no camera message) by then is
        closed."""
        self.stuck_seconds = 20.0
        """A browser that has not read what was sent to it for this long is closed: what
        the server queues for it would otherwise grow without bound."""
        self.closed: collections.Counter[str] = collections.Counter()
        """Connections the watchdog closed, by reason (``silent``, ``stuck``)."""
        self._stop = threading.Event()
        self._watchdog = threading.Thread(target=self._watch, name="door", daemon=True)
        self._watchdog.start()

    # ------------------------------------------------------------------ public

    def is_priority(self, client_id: Any) -> bool:
        """Whether ``client_id``'s messages and callbacks go first (None: the server).

        A browser that left has none: what it queued before it left runs after the others.
        """
        if client_id is None:
            return True
        guest = self._guests.get(client_id)
        return guest is not None and guest.priority

    def set_priority(self, priority: Callable[[int], bool]) -> None:
        """Decide priority with ``priority`` from now on, for every browser connected too."""
        self._priority = priority
        self.reprioritise_all()

    def reprioritise_all(self) -> None:
        """Ask :paramref:`priority` again for every connected browser."""
        with self._lock:
            connected = list(self._guests)
        for client_id in connected:
            self.reprioritise(client_id)

    def knows(self, client_id: int) -> bool:
        """Whether ``client_id``'s messages pass through the door."""
        return client_id in self._guests

    def reprioritise(self, client_id: int) -> None:
        """Ask :paramref:`priority` again for a connected browser (its role changed)."""
        with self._lock:
            guest = self._guests.get(client_id)
            if guest is not None:
                guest.priority = bool(self._priority(client_id))

    def close(self) -> None:
        """Stop the watchdog."""
        self._stop.set()
        self._watchdog.join(timeout=5.0)

    def guests(self) -> int:
        """Return how many connections the door keeps state for."""
        with self._lock:
            return len(self._guests)

    def admit(self, client_id: int, raw: Any) -> bool:
        """Whether browser ``client_id``'s frame ``raw`` may reach viser."""
        reason = self._refusal(client_id, raw)
        if reason is None:
            return True
        with self._lock:
            self.refused[reason] += 1
        return False

    # ------------------------------------------------------------------ connections

    async def _arrive(self, connection: Any) -> None:
        client_id = connection.client_id
        now = time.monotonic()
        rates = self._rates
        buckets = {
            kind: Bucket(rate, rate * rates.burst_seconds, now)
            for kind, rate in (("camera", rates.camera), ("other", rates.other))
        }
        buckets["upload"] = Bucket(rates.uploads, rates.upload_burst, now)
        buckets["download"] = Bucket(rates.downloads, rates.download_burst, now)
        with self._lock:
            self._guests[client_id] = _Guest(False, buckets, since=now)
        self.reprioritise(client_id)
        socket = self._server._websock_server._live_connections.get(client_id)
        if socket is not None:
            socket.recv = self._guarded(client_id, socket.recv)

    async def _leave(self, connection: Any) -> None:
        with self._lock:
            self._guests.pop(connection.client_id, None)

    def _watch(self, period: float = 1.0) -> None:
        """Close connections that never became a browser, and browsers that do not read."""
        websock = self._server._websock_server
        while not self._stop.wait(period):
            loop = getattr(websock, "_background_event_loop", None)
            if loop is None or loop.is_closed():
                return
            now = time.monotonic()
            for client_id, socket in list(websock._live_connections.items()):
                reason = self._overdue(client_id, socket, now)
                transport = getattr(socket, "transport", None)
                if reason is not None and transport is not None:
                    self.closed[reason] += 1
                    loop.call_soon_threadsafe(transport.abort)
            loop.call_soon_threadsafe(self._drop_refused_uploads)

    def _drop_refused_uploads(self) -> None:
        """Forget viser's state of every upload the door stopped (on the event loop).

        viser keeps an upload's name and parts from its first message until its last; one
        whose parts the door refused would stay until its browser leaves.
        """
        clients = dict(self._server._connected_clients)
        apis = [self._server.gui, *(client.gui for client in clients.values())]
        for gui in apis:
            states = gui._current_file_upload_states
            for transfer, state in list(states.items()):
                guest = self._guests.get(state.get("client_id"))
                current = guest.upload[0] if guest and guest.upload else None
                if transfer != current:
                    states.pop(transfer, None)

    def _overdue(self, client_id: int, socket: Any, now: float) -> str | None:
        guest = self._guests.get(client_id)
        if guest is None:
            return None
        connected = client_id in self._server._connected_clients
        if not connected and now - guest.since > self.silent_seconds:
            return "silent"
        transport = getattr(socket, "transport", None)
        waiting = transport.get_write_buffer_size() if transport is not None else 0
        if waiting < STUCK_BYTES:
            guest.stuck_since = None
            return None
        if guest.stuck_since is None:
            guest.stuck_since = now
        return "stuck" if now - guest.stuck_since > self.stuck_seconds else None

    def _guarded(self, client_id: int, recv: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(recv)
        async def guarded(*args: Any, **kwargs: Any) -> Any:
            while True:
                raw = await recv(*args, **kwargs)
                if self.admit(client_id, raw):
                    return raw

        return guarded

    # ------------------------------------------------------------------ the checks

    def _refusal(self, client_id: int, raw: Any) -> str | None:  # noqa: PLR0911
        """Return why ``raw`` is refused, or None."""
        guest = self._guests.get(client_id)
        if guest is None:
            return "unknown"
        if not isinstance(raw, bytes):
            return "text"
        if len(raw) > MAX_MESSAGE_BYTES:
            return "size"
        try:
            kind = _HEAD.decode(raw).type
        except _UNREADABLE:
            return "malformed"
        if kind not in ALLOWED:
            return "type"
        if kind != "FileTransferPart" and not guest.priority:
            bucket = guest.buckets[_BUCKET.get(kind, "other")]
            with self._lock:
                if not bucket.take(time.monotonic()):
                    return "rate"
        try:
            if kind == "GuiUpdateMessage":
                return self._value_refusal(client_id, guest, _UPDATE.decode(raw))
            if kind == "FileTransferStartUpload":
                return self._start_refusal(client_id, guest, _START.decode(raw))
            if kind == "FileTransferPart":
                return self._part_refusal(guest, _PART.decode(raw))
        except _UNREADABLE:
            return "malformed"
        return None

    def _value_refusal(
        self, client_id: int, guest: _Guest, message: _Update
    ) -> str | None:
        if set(message.updates) != {"value"}:
            return "value"
        handle = self._handle(client_id, message.uuid)
        if handle is None or not usable(handle):
            return "widget"
        value = _VALUE.decode(message.updates["value"])
        if not offers(handle, value):
            return "value"
        label = getattr(handle, "label", "")
        if (
            isinstance(label, str)
            and label.startswith(DOWNLOAD_LABEL)
            and not guest.priority
        ):
            with self._lock:
                if not guest.buckets["download"].take(time.monotonic()):
                    return "rate"
        return None

    def _start_refusal(
        self, client_id: int, guest: _Guest, message: _Start
    ) -> str | None:
        size, parts = message.size_bytes, message.part_count
        name, transfer = message.filename, message.transfer_uuid
        if size < 0 or parts < 0 or len(name) > 255 or len(transfer) > 64:
            return "malformed"
        handle = self._handle(client_id, message.source_component_uuid)
        if not isinstance(handle, viser.GuiUploadButtonHandle) or not usable(handle):
            return "widget"
        if size > MAX_UPLOAD_BYTES:
            self._say(
                client_id,
                f"Not uploaded: {name[:60]} has {size:,} bytes, more than the "
                f"{MAX_UPLOAD_BYTES:,} a scenario file may have.",
            )
            return "upload"
        if parts != math.ceil(size / UPLOAD_PART_BYTES):
            return "upload"
        with self._lock:
            if guest.upload is not None:
                return "upload"  # one at a time
            if parts > 0:
                guest.upload = (transfer, _Upload(parts, size))
        return None

    def _part_refusal(self, guest: _Guest, message: _Part) -> str | None:
        index, content = message.part_index, message.content
        with self._lock:
            upload = guest.upload
            if upload is None or message.transfer_uuid != upload[0]:
                return "upload"
            state = upload[1]
            if not 0 <= index < state.parts or index in state.seen:
                return "upload"
            if len(content) > UPLOAD_PART_BYTES:
                return "upload"
            if state.received + len(content) > state.declared:
                guest.upload = None
                return "upload"
            state.seen.add(index)
            state.received += len(content)
            if len(state.seen) == state.parts:
                guest.upload = None
        return None

    def _handle(self, client_id: int, uuid: Any) -> Any:
        """Return the input widget ``uuid`` of the server's panel or of this browser's."""
        if not isinstance(uuid, str):
            return None
        handle = self._server.gui._gui_input_handle_from_uuid.get(uuid)
        if handle is None:
            client = self._server._connected_clients.get(client_id)
            if client is None:
                return None
            handle = client.gui._gui_input_handle_from_uuid.get(uuid)
        if handle is None or handle._impl.removed:
            return None
        return handle

    def _say(self, client_id: int, words: str) -> None:
        if self._tell is None:
            return
        try:
            self._tell(client_id, words)
        except Exception:
            logger.exception("could not tell a browser why its action was refused")


def usable(handle: Any) -> bool:
    """Whether a page lets its user touch widget ``handle``: shown and not disabled.

    A watcher's panel (:mod:`app.classroom.watch`) is one set of disabled widgets
    shared by the class: no value for them is let through, whoever sends it.
    """
    return bool(getattr(handle, "visible", True)) and not getattr(
        handle, "disabled", False
    )


def offers(handle: Any, value: Any) -> bool:  # noqa: PLR0911
    """Whether widget ``handle`` could send ``value`` (what its page lets a user choose).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> offers(SimpleNamespace(options=("a", "b")), "c")
    False
    """
    if isinstance(handle, viser.GuiButtonHandle):
        return value is True
    if isinstance(handle, (viser.GuiButtonGroupHandle, viser.GuiDropdownHandle)):
        return isinstance(value, str) and value in tuple(handle.options)
    if isinstance(handle, viser.GuiCheckboxHandle):
        return isinstance(value, bool)
    if isinstance(handle, (viser.GuiSliderHandle, viser.GuiNumberHandle)):
        return _in_range(value, handle.min, handle.max)
    if isinstance(handle, viser.GuiTextHandle):
        return isinstance(value, str) and len(value) <= MAX_TEXT
    options = getattr(handle, "options", None)
    if options is not None:  # a stand-in with options (the doctest)
        return value in tuple(options)
    return False


def _in_range(value: Any, low: Any, high: Any) -> bool:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    if not math.isfinite(value):
        return False
    slack = 1e-9 * max(1.0, abs(value))
    return (low is None or value >= low - slack) and (
        high is None or value <= high + slack
    )


_serve_lock = threading.Lock()


@contextlib.contextmanager
def message_limit(max_bytes: int = MAX_MESSAGE_BYTES) -> Iterator[None]:
    """Start viser servers inside this block with a websocket frame limit of ``max_bytes``.

    viser 1.1.1 opens its websocket server with a fixed 50 MB limit; the limit is
    applied when a frame is read, so a larger frame closes its sender (code 1009)
    before it is buffered. ``ViserServer`` opens the server before its constructor
    returns: the patch is in force only for that call (and one at a time).
    """
    with _serve_lock:
        serve = websockets.asyncio.server.serve

        def limited(*args: Any, **kwargs: Any) -> Any:
            kwargs["max_size"] = max_bytes
            return serve(*args, **kwargs)

        websockets.asyncio.server.serve = limited  # type: ignore[assignment]
        try:
            yield
        finally:
            websockets.asyncio.server.serve = serve  # type: ignore[assignment]
