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

Data flow::

    presenter's frame -> broadcast buffer (viser) -> one producer per browser
        -> WindowCache.encode(window): the bytes of these messages, encoded once
        -> websocket.send(bytes) to each browser
"""

from __future__ import annotations

__all__ = ["WindowCache", "encode_window", "mute", "share_encoding", "stop_sharing"]

import collections
import contextlib
import socket
import threading
import time
from collections.abc import Sequence
from typing import Any

import msgspec
import viser
import zstandard
from viser.infra import _infra

CACHED_WINDOWS = 8
"""Windows a cache keeps: the browsers that keep up share the newest one or two."""

SEND_BUFFER_BYTES = 64 * 1024
"""The kernel's send buffer of each browser's socket. Left to itself, Linux grows it to
megabytes: seconds of old frames queued for a browser on a slow WiFi link. Bounded, a
full socket makes the browser's producer wait, and viser keeps only the newest message
of each kind meanwhile: the browser gets the newest frame when it can take one."""


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
        self.muted: set[int] = set()
        """Browsers that get no more broadcast windows (:func:`mute`)."""

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


_caches: dict[int, tuple[Any, WindowCache]] = {}
"""id(broadcast buffer) -> (the buffer, its cache): the servers that share encodings."""
_caches_lock = threading.Lock()
_viser_producer = _infra._message_producer


def share_encoding(server: viser.ViserServer) -> WindowCache:
    """Encode each of ``server``'s broadcast windows once for all its browsers.

    Call before browsers connect. Other servers in the process keep viser's producer;
    :func:`stop_sharing` (on the server's stop) forgets the buffer.
    """
    websock = server._websock_server
    buffer = websock._broadcast_buffer
    cache = WindowCache()
    with _caches_lock:
        _caches[id(buffer)] = (buffer, cache)
        _infra._message_producer = _producer
    return cache


def mute(server: viser.ViserServer, client_id: int) -> None:
    """Send browser ``client_id`` no more of ``server``'s broadcast (for good).

    Its producer stops at its next window and frees its place in the buffer; what the
    browser has is all it gets. Its own messages still go out (a message in its panel).
    A browser turned away from a full class costs the server nothing more.
    """
    entry = _caches.get(id(server._websock_server._broadcast_buffer))
    if entry is not None:
        entry[1].muted.add(client_id)


def stop_sharing(server: viser.ViserServer) -> None:
    """Forget ``server``'s broadcast buffer (its windows are no longer cached)."""
    buffer = server._websock_server._broadcast_buffer
    with _caches_lock:
        _caches.pop(id(buffer), None)


async def _producer(
    websocket: Any,
    buffer: Any,
    client_id: int,
    backlog_done_message: Any = None,
) -> None:
    """Run viser's producer loop, with the windows of a shared buffer encoded once."""
    entry = _caches.get(id(buffer))
    if entry is None or entry[0] is not buffer:
        await _viser_producer(websocket, buffer, client_id, backlog_done_message)
        return
    cache = entry[1]
    _bound_send_buffer(websocket)
    windows = buffer.window_generator(
        client_id, backlog_done_message=backlog_done_message
    )
    try:
        while not buffer.done and client_id not in cache.muted:
            try:
                outgoing = await windows.__anext__()
            except StopAsyncIteration:
                break
            if client_id in cache.muted:
                break
            await websocket.send(cache.encode(outgoing))
    finally:
        cache.muted.discard(client_id)  # the id is never reused; the set stays small
        # As viser's own producer: close the generator now (it frees its cursor).
        await windows.aclose()


def _bound_send_buffer(websocket: Any) -> None:
    """Give the browser's socket a send buffer of :data:`SEND_BUFFER_BYTES`."""
    transport = getattr(websocket, "transport", None)
    sock = transport.get_extra_info("socket") if transport is not None else None
    if sock is not None:
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
