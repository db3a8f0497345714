"""A browser without the browser: viser's websocket protocol spoken from Python.

The classroom's tests send messages a real page never would (a watcher's crafted edit),
and the load benchmark needs dozens of clients on a 2-core machine, where dozens of
Chromiums would measure Chromium. This client speaks viser 1.1.1's wire format:

- to the server: one msgpack map per message, ``{"type": <class name>, **fields}``;
- from the server: batches of ``[8 bytes: msgpack size][8 bytes: zstd size][zstd
  msgpack][binary buffers]``; the msgpack holds ``{"messages": [...]}``. Binary buffers
  (meshes, point arrays) are not decoded: nothing here needs them.

It keeps what a test asks about: GUI elements by label (uuid, props, value), and for each
scene node its last position and visibility, per owner scope ("" is the broadcast scope).
"""

from __future__ import annotations

__all__ = ["ViserClient", "camera_message", "decode_batch"]

import collections
import contextlib
import math
import threading
import time
import uuid as uuidlib
from collections.abc import Callable, Iterator
from typing import Any

import msgspec
import viser
import zstandard
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect


def camera_message() -> dict[str, Any]:
    # The server reports a client as connected after its first camera message.
    return {
        "type": "ViewerCameraMessage",
        "wxyz": (1.0, 0.0, 0.0, 0.0),
        "position": (5.0, 4.0, 15.0),
        "fov": 0.9,
        "near": 0.01,
        "far": 1000.0,
        "image_height": 720,
        "image_width": 1280,
        "look_at": (5.0, 4.0, 0.0),
        "up_direction": (0.0, 0.0, 1.0),
    }


def decode_batch(raw: bytes) -> list[dict[str, Any]]:
    """Return the messages of one server -> client websocket frame."""
    inner_size = int.from_bytes(raw[0:8], "little")
    packed_size = int.from_bytes(raw[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(
        raw[16 : 16 + packed_size], max_output_size=inner_size
    )
    return list(msgspec.msgpack.decode(inner)["messages"])


class ViserClient:
    """One websocket client of a viser server, reading its messages in a thread.

    Parameters
    ----------
    port
        The server's port (on 127.0.0.1).
    path
        The websocket path ('' for a plain browser; a classroom's presenter path).
    on_message
        Called with (receive time [s, ``time.perf_counter``], message) for every message
        (from the reader thread).
    """

    def __init__(
        self,
        port: int,
        path: str = "",
        on_message: Callable[[float, dict[str, Any]], None] | None = None,
    ) -> None:
        self._ws = connect(
            f"ws://127.0.0.1:{port}/{path.lstrip('/')}",
            subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
            max_size=None,
            open_timeout=30,
        )
        self._lock = threading.Condition()
        self._send_lock = threading.Lock()
        self.gui: dict[str, dict[str, Any]] = {}
        """GUI uuid -> the element's last state: type, label, props, value."""
        self.nodes: dict[tuple[str, str], dict[str, Any]] = {}
        """(owner, name) -> the node's type, position, visible."""
        self.received = 0
        """Messages received so far."""
        self.kinds: collections.Counter[str] = collections.Counter()
        """Messages received so far, by type."""
        self.notes: list[dict[str, Any]] = []
        """The notifications shown (their props: title, body...)."""
        self.downloads: dict[str, bytes] = {}
        """File name -> content of every file the server sent to download, once whole."""
        self._transfers: dict[str, dict[str, Any]] = {}
        self.closed = False
        """True once the connection is closed."""
        self.client_id = -1
        """The server's id for this client, when the caller found it out (-1: unknown)."""
        self._on_message = on_message
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self.send(camera_message())

    # ------------------------------------------------------------------ sending

    def send(self, message: dict[str, Any]) -> None:
        """Send one message, ``{"type": <viser message class>, **fields}``."""
        data = msgspec.msgpack.encode(message)
        with self._send_lock:
            self._ws.send(data)

    def send_raw(self, data: bytes) -> None:
        """Send bytes as they are (a frame no page would send)."""
        with self._send_lock:
            self._ws.send(data)

    def set_gui(self, uuid: str, value: Any) -> None:
        """Send what a widget sends when its value changes (a click for a button)."""
        self.send(
            {"type": "GuiUpdateMessage", "uuid": uuid, "updates": {"value": value}}
        )

    def click(self, label: str, timeout: float = 30.0) -> None:
        """Click the button ``label`` once the page shows it, visible and enabled.

        A person cannot click a button the page has not drawn or has hidden, and the
        server refuses such a click (``app.guard.door``): wait for it as they would.
        """

        def ready() -> bool:
            try:
                element = self.element(label)
            except KeyError:
                return False
            props = element["props"]
            return (
                label in self.labels()
                and props.get("visible", True)
                and not props.get("disabled", False)
            )

        if not self.wait_for(ready, timeout):
            raise AssertionError(f"button {label!r} not shown within {timeout} s")
        self.set_gui(self.uuid(label), True)

    def upload(
        self,
        label: str,
        name: str,
        data: bytes,
        declared: int | None = None,
        part_bytes: int = 512 * 1024,
    ) -> str:
        """Send a file through the upload button ``label`` as viser's page cuts it.

        ``declared``: the size the start message claims (a lie, when it is not
        ``len(data)``). Returns the transfer's id.
        """
        size = len(data) if declared is None else declared
        transfer = uuidlib.uuid4().hex
        parts = math.ceil(size / part_bytes)
        source = self.uuid(label)
        self.send(
            {
                "type": "FileTransferStartUpload",
                "source_component_uuid": source,
                "transfer_uuid": transfer,
                "filename": name,
                "mime_type": "application/json",
                "part_count": parts,
                "size_bytes": size,
            }
        )
        for k in range(parts):
            self.send(
                {
                    "type": "FileTransferPart",
                    "source_component_uuid": source,
                    "transfer_uuid": transfer,
                    "part_index": k,
                    "content": data[k * part_bytes : (k + 1) * part_bytes],
                }
            )
        return transfer

    def drag(
        self, name: str, xy: tuple[float, float], phase: str = "update", owner: str = ""
    ) -> None:
        """Send what a gizmo named ``name`` sends while dragged (``owner``: its scope)."""
        if phase == "start":
            self.send(
                {
                    "type": "TransformControlsDragStartMessage",
                    "name": name,
                    "owner": owner,
                }
            )
        elif phase == "end":
            self.send(
                {
                    "type": "TransformControlsDragEndMessage",
                    "name": name,
                    "owner": owner,
                }
            )
        else:
            self.send(
                {
                    "type": "TransformControlsUpdateMessage",
                    "name": name,
                    "wxyz": (1.0, 0.0, 0.0, 0.0),
                    "position": (float(xy[0]), float(xy[1]), 0.0),
                    "owner": owner,
                }
            )

    def click_floor(self, xy: tuple[float, float]) -> None:
        """Send a click on the floor at ``xy``, straight from above."""
        self.send(
            {
                "type": "ScenePointerMessage",
                "event_type": "click",
                "ray_origin": (float(xy[0]), float(xy[1]), 10.0),
                "ray_direction": (0.0, 0.0, -1.0),
                "screen_pos": ((0.5, 0.5),),
                "modifier": None,
            }
        )

    # ------------------------------------------------------------------ reading

    def uuid(self, label: str, kind: str = "") -> str:
        """Return the uuid of the GUI element labelled ``label`` (of type ``kind``).

        An element the page draws comes first: one whose containers all reached this
        browser. Elements it holds but does not draw (the class's watcher panel, in a
        presenter's browser) are found only when no drawn one has the label.
        """
        with self._lock:
            found = [
                uuid
                for uuid, element in self.gui.items()
                if element["label"] == label and kind in element["type"]
            ]
            drawn = [uuid for uuid in found if self._drawn(uuid)]
        if drawn or found:
            return (drawn or found)[0]
        raise KeyError(f"no GUI element {label!r} ({kind or 'any type'})")

    def labels(self) -> set[str]:
        """Return the labels of the GUI elements the page draws (see :meth:`uuid`)."""
        with self._lock:
            return {e["label"] for u, e in self.gui.items() if self._drawn(u)}

    def _drawn(self, uuid: str) -> bool:
        # Called with the lock held: up the containers to the root, each one known.
        seen = set()
        while uuid != "root":
            element = self.gui.get(uuid)
            if element is None or uuid in seen:
                return False
            seen.add(uuid)
            uuid = element.get("container", "root")
        return True

    def element(self, label: str, kind: str = "") -> dict[str, Any]:
        """Return the GUI element labelled ``label`` (a copy of its last state)."""
        uuid = self.uuid(label, kind)
        with self._lock:
            return dict(self.gui[uuid])

    def html(self) -> list[str]:
        """Return the content of every HTML/markdown element drawn, in creation order."""
        with self._lock:
            return [
                str(e["props"].get("content", e["props"].get("_markdown", "")))
                for u, e in self.gui.items()
                if e["type"] in ("GuiHtmlMessage", "GuiMarkdownMessage")
                and self._drawn(u)
            ]

    def wait_for(self, test: Callable[[], bool], timeout: float = 30.0) -> bool:
        """Wait until ``test()`` holds (checked on every message); False on timeout."""
        deadline = time.monotonic() + timeout
        with self._lock:
            while not test():
                left = deadline - time.monotonic()
                if left <= 0 or self.closed:
                    return test()
                self._lock.wait(min(left, 0.2))
        return True

    def close(self) -> None:
        """Close the connection (the server sees the browser leave)."""
        with contextlib.suppress(Exception):
            self._ws.close()
        self._reader.join(timeout=10)

    def _read(self) -> None:
        try:
            for raw in self._frames():
                now = time.perf_counter()
                messages = decode_batch(raw)
                with self._lock:
                    for message in messages:
                        self._apply(message)
                    self.received += len(messages)
                    self._lock.notify_all()
                if self._on_message is not None:
                    for message in messages:
                        self._on_message(now, message)
        finally:
            with self._lock:
                self.closed = True
                self._lock.notify_all()

    def _frames(self) -> Iterator[bytes]:
        while True:
            try:
                raw = self._ws.recv()
            except (ConnectionClosed, OSError):
                return
            if isinstance(raw, bytes):
                yield raw

    def _apply(self, message: dict[str, Any]) -> None:
        kind = str(message.get("type", ""))
        self.kinds[kind] += 1
        if kind == "NotificationShowMessage":
            self.notes.append(dict(message.get("props", {})))
        elif kind in ("FileTransferStartDownload", "FileTransferPart"):
            self._apply_download(kind, message)
        elif kind.startswith("Gui") and "uuid" in message:
            self._apply_gui(kind, message)
        elif "name" in message:
            self._apply_scene(kind, message)

    def _apply_download(self, kind: str, message: dict[str, Any]) -> None:
        # viser's message buffer may send a part before its start: keep both until whole.
        transfer = self._transfers.setdefault(
            str(message["transfer_uuid"]), {"name": None, "count": -1, "parts": {}}
        )
        if kind == "FileTransferStartDownload":
            transfer["name"], transfer["count"] = (
                message["filename"],
                message["part_count"],
            )
        else:
            transfer["parts"][message["part_index"]] = bytes(message["content"])
        parts = transfer["parts"]
        if len(parts) == transfer["count"]:
            self.downloads[transfer["name"]] = b"".join(parts[k] for k in sorted(parts))
            del self._transfers[str(message["transfer_uuid"])]

    def _apply_gui(self, kind: str, message: dict[str, Any]) -> None:
        uuid = message["uuid"]
        if kind == "GuiUpdateMessage":
            element = self.gui.get(uuid)
            if element is not None:
                updates = dict(message.get("updates", {}))
                if "value" in updates:
                    element["value"] = updates.pop("value")
                element["props"].update(updates)
        elif kind == "GuiRemoveMessage":
            self.gui.pop(uuid, None)
        elif "props" in message:
            props = dict(message["props"])
            self.gui[uuid] = {
                "type": kind,
                "label": props.get("label", ""),
                "props": props,
                "value": message.get("value"),
                "container": str(message.get("container_uuid", "root")),
            }

    def _apply_scene(self, kind: str, message: dict[str, Any]) -> None:
        key = (str(message.get("owner", "")), str(message["name"]))
        if kind == "RemoveSceneNodeMessage":
            self.nodes.pop(key, None)
            return
        node = self.nodes.setdefault(
            key, {"type": "", "position": None, "visible": True}
        )
        if kind == "SetPositionMessage":
            node["position"] = tuple(message["position"])
        elif kind == "SetSceneNodeVisibilityMessage":
            node["visible"] = bool(message.get("visible", True))
        elif "props" in message:
            node["type"] = kind
            node["props"] = dict(message["props"])
