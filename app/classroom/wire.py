"""One encoding of each broadcast window, whatever the number of browsers.

viser 1.1.1 sends each browser its messages in *windows*: every connection has a producer
task that takes the messages pushed since it last sent, serialises them (msgpack, with
numpy arrays appended raw), compresses them (zstd) and sends the bytes. The presenter's
scene is drawn once for everyone, into viser's broadcast buffer; yet with 300 browsers
watching, each window of it was serialised and compressed 300 times.

:func:`share_encoding` gives a server's broadcast buffer a :class:`WindowCache`: a window
of the same messages (the same objects, in the same order) is encoded once and the same
bytes go to every browser. Browsers that keep up take the same windows; one that is
behind takes its own (the messages since its own cursor), encoded for it. A slow browser
never gets a backlog: viser keeps only the newest message of each kind per node (a new
position replaces the old one in the buffer), and a connection whose socket is full
waits, so when it goes on it reads the newest state. Each browser's own buffer (its
panel, its own view) is left to viser.

The bytes are viser's wire format, unchanged (``tests/viser_client.py`` reads it)::

    [8 bytes: msgpack size][8 bytes: zstd size][zstd(msgpack)][padding][binary buffers]

The pump also sets the class's frame rate. The presenter's session is drawn once, at
the presenter's rate, into the broadcast buffer; the presenters' browsers are sent every
window, the class's at most :func:`class_rate` a second. Between two of the class's
windows viser's buffer keeps only the newest message of each kind per node, so a
class's window is the newest frame, whatever came before it.

Data flow::

    presenter's frame -> broadcast buffer (viser) -> the pump
        -> presenters' browsers: every window (1/60 s)
        -> the class: the newest state, at most class_rate(class size) a second
        -> WindowCache.encode(window): the bytes of these messages, encoded once
        -> each browser's socket
"""

from __future__ import annotations

__all__ = [
    "BIG_CLASS",
    "CLASS_FPS",
    "SEMINAR_FPS",
    "Pump",
    "WindowCache",
    "class_rate",
    "encode_window",
    "mute",
    "share_encoding",
    "stop_sharing",
]

import asyncio
import collections
import contextlib
import dataclasses
import socket
import threading
import time
from collections.abc import Sequence
from typing import Any

import msgspec
import viser
import zstandard
from viser.infra import _infra
from websockets.protocol import State

CLASS_FPS = 20.0
"""Frames a second a hall is sent of the presenter's scene, at most: 300 watchers at 20
frames of a few KB each is what a lecture hall's WiFi carries."""

SEMINAR_FPS = 60.0
"""The same for a small class: every frame of a presenter's drag (a mouse sends 60)."""

BIG_CLASS = 50
"""Browsers from which a class is a hall (:data:`CLASS_FPS`), below a seminar."""

CACHED_WINDOWS = 8
"""Windows a cache keeps: the browsers that keep up share the newest one or two."""

SEND_BUFFER_BYTES = 64 * 1024
"""The kernel's send buffer of each browser's socket. Left to itself, Linux grows it to
megabytes: seconds of old frames queued for a browser on a slow WiFi link. Bounded, a
full socket makes the browser's producer wait, and viser keeps only the newest message
of each kind meanwhile: the browser gets the newest frame when it can take one."""

WRITE_LIMIT = 32 * 1024
"""Bytes waiting in a browser's transport beyond which the pump writes it no frame: it
lags (:class:`Pump`) until its socket drains."""


def class_rate(browsers: int) -> float:
    """Return the class's frame rate for ``browsers`` watching or editing [frames/s].

    Examples
    --------
    >>> class_rate(12), class_rate(300)
    (60.0, 20.0)
    """
    return CLASS_FPS if browsers >= BIG_CLASS else SEMINAR_FPS


def encode_window(messages: Sequence[Any], compressor: Any) -> bytes:
    """Return one websocket frame of viser's wire format holding ``messages``.

    The same bytes viser 1.1.1's own producer sends (its ``_message_producer``).
    """
    binary_buffers: list[memoryview] = []
    serialized = tuple(m.as_serializable_dict(binary_buffers) for m in messages)
    inner = msgspec.msgpack.encode(
        {
            "messages": serialized,
            "timestampSec": time.perf_counter(),
            "binaryBufferLengths": tuple(b.nbytes for b in binary_buffers),
        }
    )
    compressed = compressor.compress(inner)
    parts: list[bytes | memoryview] = [
        len(inner).to_bytes(8, "little"),
        len(compressed).to_bytes(8, "little"),
        compressed,
    ]
    _infra._append_aligned_buffers(parts, binary_buffers, 16 + len(compressed))
    return b"".join(parts)


class WindowCache:
    """The encoded bytes of the last few windows, by the identity of their messages.

    Used from the server's event loop only (every producer runs there), but locked all
    the same: a lookup is cheap next to an encoding.
    """

    def __init__(self, size: int = CACHED_WINDOWS) -> None:
        self._size = size
        self._lock = threading.Lock()
        # Key: the messages' ids. The entry holds the messages themselves, so none of
        # those ids can be reused by another object while the entry lives.
        self._entries: collections.OrderedDict[
            tuple[int, ...], tuple[tuple[Any, ...], bytes]
        ] = collections.OrderedDict()
        self._compressor = zstandard.ZstdCompressor(level=1)
        self.encoded = 0
        """Windows encoded so far."""
        self.shared = 0
        """Windows sent from the cache so far (an encoding saved each)."""

    def encode(self, window: Sequence[Any]) -> bytes:
        """Return the bytes of ``window``, encoding it only if no browser had it yet."""
        key = tuple(map(id, window))
        with self._lock:
            entry = self._entries.get(key)
            if entry is not None:
                self._entries.move_to_end(key)
                self.shared += 1
                return entry[1]
            data = encode_window(window, self._compressor)
            self._entries[key] = (tuple(window), data)
            while len(self._entries) > self._size:
                self._entries.popitem(last=False)
            self.encoded += 1
            return data


_pumps: dict[int, Pump] = {}
"""id(broadcast buffer) -> its pump: the servers that share their broadcast."""
_pumps_lock = threading.Lock()
_viser_producer = _infra._message_producer


def share_encoding(server: viser.ViserServer) -> Pump:
    """Send ``server``'s broadcast through one :class:`Pump` (each window encoded once).

    Call before browsers connect. Other servers in the process keep viser's producer;
    :func:`stop_sharing` (on the server's stop) forgets the buffer.
    """
    buffer = server._websock_server._broadcast_buffer
    pump = Pump(buffer)
    with _pumps_lock:
        _pumps[id(buffer)] = pump
        _infra._message_producer = _producer
    return pump


def mute(server: viser.ViserServer, client_id: int) -> None:
    """Send browser ``client_id`` no more of ``server``'s broadcast (for good).

    What the browser has is all it gets; its own messages still go out (a message in
    its panel). A browser turned away from a full class costs the server nothing more.
    """
    pump = _pumps.get(id(server._websock_server._broadcast_buffer))
    if pump is not None:
        pump.mute(client_id)


def stop_sharing(server: viser.ViserServer) -> None:
    """Forget ``server``'s broadcast buffer (its browsers leave with the server)."""
    buffer = server._websock_server._broadcast_buffer
    with _pumps_lock:
        _pumps.pop(id(buffer), None)


@dataclasses.dataclass(eq=False)
class _Sub:
    """One browser on the pump."""

    client_id: int
    websocket: Any
    cursor: int
    """Id of the last broadcast message this browser was sent (or skipped)."""
    backlog: tuple[int, Any] | None
    """(last id of the replay, the end-of-replay marker) until the marker is sent."""
    finished: asyncio.Future[None]
    """Done when the browser is muted: its producer returns."""
    lagging: bool = True
    """Whether it takes windows of its own (new, or its socket was full)."""
    task: asyncio.Task[None] | None = None
    """Its catch-up while it lags."""


class Pump:
    """One producer for a broadcast buffer, whatever the number of browsers.

    viser gives each connection a task that wakes at every message, builds its window,
    encodes it and sends it: 300 browsers cost 300 of each per frame. The pump builds a
    window once, encodes it once and writes the same bytes to every browser that is up
    to date, straight into its socket, in one pass of the event loop.

    A browser that cannot take a frame now (its socket is full: a slow link) is not
    written to; it *lags*, and a task of its own sends it windows from where it stopped,
    waiting for its socket each time, until it is level with the pump again. Its windows
    hold only what is still in viser's buffer: a newer position of a node has replaced
    the older one, so a slow browser gets the newest state, never a backlog of frames.
    A browser that connects lags too, with the scene's replay and viser's end-of-replay
    marker first (as viser's own producer sends them). Every browser's cursor is kept
    in the buffer's ``generator_cursors``, so viser frees no message a browser still
    needs.

    The class is sent at most :attr:`rate` windows a second; a *full-rate* browser (a
    presenter's: :meth:`full_rate`) every window, from a cursor of its own. When both
    are level they take the same window, encoded once.
    """

    def __init__(self, buffer: Any) -> None:
        self.buffer = buffer
        self.cache = WindowCache()
        """The encoded windows (what every browser is sent)."""
        self.cursor = -1
        """Id of the last message the class's up-to-date browsers were sent."""
        self.rate = SEMINAR_FPS
        """The class's most windows a second (set it at any time: from the next on)."""
        self.frames = 0
        """The class's windows so far (each one the newest frame, sent to everyone)."""
        self.sent = 0
        """Frames sent to browsers so far (each window's bytes, once per browser)."""
        self._subs: dict[int, _Sub] = {}
        self._muted: set[int] = set()  # muted before their producer started
        self._full: set[int] = set()  # the browsers sent every window (presenters)
        self._due = 0.0  # time.monotonic() of the class's next window, at the earliest
        self._task: asyncio.Task[None] | None = None

    # ------------------------------------------------------------------ browsers

    def subscribe(self, websocket: Any, client_id: int, marker: Any) -> _Sub:
        """Add a browser; it catches up with the pump first (the event loop's thread)."""
        loop = asyncio.get_running_loop()
        if self._task is None:
            self.cursor = self.buffer.message_counter - 1
            self._task = loop.create_task(self._run())
        backlog_last = self.buffer.message_counter - 1
        sub = _Sub(
            client_id,
            websocket,
            cursor=-1,
            backlog=(backlog_last, marker) if marker is not None else None,
            finished=loop.create_future(),
        )
        self._subs[client_id] = sub
        self.buffer.generator_cursors[client_id] = -1
        sub.task = loop.create_task(self._catch_up(sub))
        return sub

    def unsubscribe(self, sub: _Sub) -> None:
        """Forget a browser (its connection closed, or it was muted)."""
        if self._subs.get(sub.client_id) is sub:
            del self._subs[sub.client_id]
        self.buffer.generator_cursors.pop(sub.client_id, None)
        if sub.task is not None and sub.task is not asyncio.current_task():
            sub.task.cancel()

    def mute(self, client_id: int) -> None:
        """Send browser ``client_id`` nothing more (from any thread)."""

        def stop() -> None:
            sub = self._subs.get(client_id)
            if sub is not None:
                self.unsubscribe(sub)
                if not sub.finished.done():
                    sub.finished.set_result(None)
            else:
                self._muted.add(client_id)  # muted before its producer started

        with contextlib.suppress(RuntimeError):  # the loop is closed: nothing to mute
            self.buffer.event_loop.call_soon_threadsafe(stop)

    def full_rate(self, client_id: int, on: bool = True) -> None:
        """Send browser ``client_id`` every window (``on``), or the class's (from any thread).

        A browser back to the class's rate may be sent again, once, what it had: the
        class's next window starts where the class is, behind it.
        """

        def switch() -> None:
            if on:
                self._full.add(client_id)
            else:
                self._full.discard(client_id)

        with contextlib.suppress(RuntimeError):  # the loop is closed: nobody to send
            self.buffer.event_loop.call_soon_threadsafe(switch)

    def muted(self, client_id: int) -> bool:
        """Whether browser ``client_id`` was muted before its producer started."""
        return client_id in self._muted

    # ------------------------------------------------------------------ the pump

    async def _run(self) -> None:
        buffer = self.buffer
        flush = asyncio.ensure_future(buffer.flush_event.wait())
        try:
            while not buffer.done:
                head = buffer.message_counter - 1
                if not self._pending(head):
                    await buffer.message_event.wait()
                    buffer.message_event.clear()
                elif buffer.atomic_counter == 0:
                    self._rounds(head, time.monotonic())
                # At most one window per viser window (1/60 s) unless flushed.
                done, _ = await asyncio.wait(
                    [flush], timeout=buffer.window_duration_sec
                )
                if flush in done and not buffer.done:
                    buffer.flush_event.clear()
                    flush = asyncio.ensure_future(buffer.flush_event.wait())
        finally:
            # The loop may be closed already (the server stopped under the pump).
            with contextlib.suppress(RuntimeError):
                flush.cancel()

    def _pending(self, head: int) -> bool:
        """Whether messages up to ``head`` are still to go to the class or a presenter."""
        return head > self.cursor or any(head > s.cursor for s in self._full_subs())

    def _full_subs(self) -> list[_Sub]:
        """Return the full-rate browsers the pump writes to (not lagging): a few at most."""
        subs = (self._subs.get(client_id) for client_id in self._full)
        return [s for s in subs if s is not None and not s.lagging]

    def _rounds(self, head: int, now: float) -> None:
        """Send the class its window if one is due; the full-rate browsers theirs."""
        if head > self.cursor and now >= self._due:
            self._round(head)
            self.frames += 1
            # On the beat (rounds come at the pump's windows, a little after their due
            # time); after a pause, one period from now.
            period = 1.0 / self.rate
            late = now - self._due
            self._due = self._due + period if late < period else now + period
        for sub in self._full_subs():
            if head > sub.cursor:
                window = _for(sub, self._window(sub.cursor, head))
                self._send(sub, window, sub.cursor, head)

    def _round(self, head: int) -> None:
        """Send messages (cursor, head] to every browser of the class that is up to date."""
        window = self._window(self.cursor, head)
        before, self.cursor = self.cursor, head
        data = self.cache.encode(window) if window else b""
        excluded = {m.excluded_self_client for m in window} - {None}
        for sub in list(self._subs.values()):
            if sub.lagging or sub.client_id in self._full:
                continue
            if data and sub.client_id in excluded:
                self._send(sub, _for(sub, window), before, head)
            else:
                self._send(sub, window, before, head, data)

    def _send(
        self, sub: _Sub, window: list[Any], before: int, head: int, data: bytes = b""
    ) -> None:
        """Write ``window`` (messages (before, head]) to a browser, or make it lag."""
        if window:
            data = data or self.cache.encode(window)
            if not _write(sub.websocket, data):
                # Its socket is full (or closing): it lags from where it was.
                sub.lagging = True
                sub.cursor = before
                sub.task = asyncio.get_running_loop().create_task(self._catch_up(sub))
                return
            self.sent += 1
        sub.cursor = head
        self.buffer.generator_cursors[sub.client_id] = head

    def _level(self, sub: _Sub) -> int:
        """Return the id of the last message a browser is to have (full rate: the head)."""
        full = sub.client_id in self._full
        return self.buffer.message_counter - 1 if full else self.cursor

    def _window(self, after: int, upto: int) -> list[Any]:
        """Return the messages still in the buffer with ids in (after, upto]."""
        get = self.buffer.message_from_id.get
        return [m for i in range(after + 1, upto + 1) if (m := get(i)) is not None]

    async def _catch_up(self, sub: _Sub) -> None:
        """Send a lagging browser windows of its own until it is level with the pump."""
        buffer = self.buffer
        try:
            while not buffer.done:
                # Never past the pump (it sends the rest when the browser rejoins),
                # nor past the replay before its marker. A full-rate browser's level
                # is the buffer's head, read before the atomic check (as the pump
                # does): no half of a frame being drawn.
                level = self._level(sub)
                if buffer.atomic_counter != 0:
                    await asyncio.sleep(buffer.window_duration_sec)
                    continue
                upto = min(level, sub.cursor + buffer.max_window_size)
                if sub.backlog is not None:
                    upto = min(upto, sub.backlog[0])
                upto = max(upto, sub.cursor)
                window = _for(sub, self._window(sub.cursor, upto))
                sub.cursor = max(sub.cursor, upto)
                buffer.generator_cursors[sub.client_id] = sub.cursor
                if sub.backlog is not None and sub.cursor >= sub.backlog[0]:
                    window.append(sub.backlog[1])
                    sub.backlog = None
                if window:
                    await sub.websocket.send(self.cache.encode(window))
                    self.sent += 1
                # Level with where the pump is now (it went on during the send).
                level = self._level(sub)
                if sub.backlog is None and sub.cursor >= level:
                    sub.cursor = level
                    sub.lagging = False  # the pump writes to it from its next round
                    sub.task = None
                    return
                if not window:
                    await asyncio.sleep(buffer.window_duration_sec)
        except Exception:  # its connection closed: its producer is cancelled soon
            return


def _for(sub: _Sub, window: list[Any]) -> list[Any]:
    """Return the messages of ``window`` a browser is sent: not its own echoes."""
    return [m for m in window if m.excluded_self_client != sub.client_id]


def _write(websocket: Any, data: bytes) -> bool:
    """Write one frame into a browser's socket now, if it takes one (else False)."""
    transport = websocket.transport
    if websocket.protocol.state is not State.OPEN or transport.is_closing():
        return False
    if transport.get_write_buffer_size() > WRITE_LIMIT:
        return False
    websocket.protocol.send_binary(data)
    websocket.send_data()
    return True


async def _producer(
    websocket: Any,
    buffer: Any,
    client_id: int,
    backlog_done_message: Any = None,
) -> None:
    """Run viser's producer loop, or, for a shared buffer, join its :class:`Pump`."""
    pump = _pumps.get(id(buffer))
    if pump is None or pump.buffer is not buffer:
        await _viser_producer(websocket, buffer, client_id, backlog_done_message)
        return
    if pump.muted(client_id):
        return
    _bound_send_buffer(websocket)
    sub = pump.subscribe(websocket, client_id, backlog_done_message)
    try:
        await sub.finished
    finally:
        pump.unsubscribe(sub)


def _bound_send_buffer(websocket: Any) -> None:
    """Give the browser's socket a send buffer of :data:`SEND_BUFFER_BYTES`."""
    transport = getattr(websocket, "transport", None)
    sock = transport.get_extra_info("socket") if transport is not None else None
    if sock is not None:
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
