"""No text from a browser reaches the server's file system.

Everything a browser can send that names a file: a name for the scenes folder (the only
place it may read or write), an upload's file name, an upload's content. For each way in,
nothing outside the scenes folder is created, read or changed.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

import planners
from app.session.files import MAX_UPLOAD_BYTES, FolderError, ScenesFolder, plain_name
from tests.conftest import SCENARIOS

BAD_NAMES = [
    "../outside",
    "../../etc/passwd",
    "..",
    "/etc/passwd",
    "/tmp/x.json",
    "sub/inner",
    "sub\\inner",
    "C:\\Windows\\x",
    "x\x00y",
    "name\nsecond line",
    "~root",
    ".hidden",
    "",
    "   ",
    "a" * 65,
    "a" * 5000,
    "é.json",
    "CON",
    "nul.json",
    "Com1.txt",
    "lpt9",
    "aux.backup.json",
    "trailing.",
]


def _tree(root: Path) -> dict[str, tuple[int, bytes]]:
    """Every file under ``root`` with its size and content."""
    return {
        str(p.relative_to(root)): (p.stat().st_size, p.read_bytes())
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


@pytest.fixture
def sandbox(tmp_path):
    """A scenes folder inside a parent that holds a secret file and a shipped scenario."""
    folder = tmp_path / "scenes"
    folder.mkdir()
    (tmp_path / "secret.json").write_text(SCENARIOS[0].read_text())
    shipped = folder / "01_two_convex.json"
    shipped.write_text(SCENARIOS[0].read_text())
    return tmp_path, ScenesFolder(folder, shipped=(shipped,))


@pytest.mark.parametrize("name", BAD_NAMES, ids=repr)
def test_a_name_that_is_not_plain_is_refused(name):
    with pytest.raises(FolderError, match="letters, digits, spaces"):
        plain_name(name)


@pytest.mark.parametrize("name", ["my scene", "lab_1.json", "A-b.c", "7", " x\n"])
def test_plain_names_stay_in_the_folder(name, tmp_path):
    path = ScenesFolder(tmp_path).path(name)
    assert path.parent == tmp_path.resolve() and path.suffix == ".json"
    assert path.name == plain_name(name) and "\n" not in path.name


@pytest.mark.parametrize("name", BAD_NAMES, ids=repr)
def test_no_bad_name_writes_or_reads_anything(sandbox, name):
    root, folder = sandbox
    before = _tree(root)
    scene = planners.load_scene(SCENARIOS[1])
    with pytest.raises(FolderError):
        folder.write(name, scene)
    with pytest.raises(FolderError):
        folder.read(name)
    assert _tree(root) == before


def test_a_link_out_of_the_folder_is_neither_listed_nor_followed(sandbox):
    root, folder = sandbox
    (folder.root / "link.json").symlink_to(root / "secret.json")
    before = _tree(root)
    assert "link.json" not in folder.names()
    with pytest.raises(FolderError, match="not a file of the scenes folder"):
        folder.read("link")
    with pytest.raises(FolderError, match="not a file of the scenes folder"):
        folder.write("link", planners.load_scene(SCENARIOS[1]))
    assert _tree(root) == before


def test_a_shipped_scenario_is_never_overwritten(sandbox):
    root, folder = sandbox
    before = _tree(root)
    with pytest.raises(FolderError, match="shipped scenario"):
        folder.write("01_two_convex", planners.load_scene(SCENARIOS[1]))
    assert _tree(root) == before
    written = folder.write("mine", planners.load_scene(SCENARIOS[1]))
    assert written == folder.root / "mine.json"
    assert folder.names() == ["01_two_convex.json", "mine.json"]


def test_the_controller_says_why_and_keeps_the_scene(make_controller, sandbox):
    root, folder = sandbox
    scene = planners.load_scene(SCENARIOS[0])
    controller, view = make_controller(scene, folder=folder)
    before = _tree(root)
    for name in BAD_NAMES:
        controller.files.save_to_folder(name)
        assert controller.wait_idle(10)
        assert view.last.message.startswith("Not saved:")
        controller.files.load_from_folder(name)
        assert controller.wait_idle(10)
        assert view.last.message.startswith("Not loaded, the scene is kept:")
        assert view.last.scene == scene
    assert _tree(root) == before


def test_the_folders_messages_name_no_path_of_the_server(make_controller, sandbox):
    """A browser learns plain names only: not where the folder is on the disk."""
    root, folder = sandbox
    (folder.root / "broken.json").write_text("{ not json")
    (folder.root / "locked.json").mkdir()  # a save there cannot replace it
    scene = planners.load_scene(SCENARIOS[0])
    controller, view = make_controller(scene, folder=folder)
    said = []
    for action in (
        lambda: controller.files.load_from_folder("missing"),
        lambda: controller.files.load_from_folder("broken"),
        lambda: controller.files.save_to_folder("locked"),
    ):
        action()
        assert controller.wait_idle(10)
        said.append(view.last.message)
    assert all(str(tmp) not in m for m in said for tmp in (root, root.resolve()))
    assert (
        said[0] == "Not loaded, the scene is kept: missing.json: (file): cannot read: "
        "No such file or directory"
    )
    assert said[1].startswith("Not loaded, the scene is kept: broken.json:")
    assert said[2].startswith("Not saved: locked.json:")


def test_without_a_folder_nothing_is_read_or_written(make_controller, tmp_path):
    scene = planners.load_scene(SCENARIOS[0])
    controller, view = make_controller(scene)
    cwd = Path.cwd()
    before = _tree(tmp_path), sorted(os.listdir(cwd))
    for name in ("mine", "../mine", str(tmp_path / "mine")):
        controller.files.save_to_folder(name)
        assert controller.wait_idle(10)
        assert "No scenes folder" in view.last.message
        controller.files.load_from_folder(name)
    assert (_tree(tmp_path), sorted(os.listdir(cwd))) == before


@pytest.mark.parametrize(
    "name", ["../../x.json", "/etc/passwd", "a\x00b.json", "n" * 5000, "C:\\x\\y.json"]
)
def test_an_upload_name_is_only_words_in_a_message(make_controller, tmp_path, name):
    scene = planners.load_scene(SCENARIOS[0])
    controller, view = make_controller(scene)
    before = _tree(tmp_path)
    good = SCENARIOS[1].read_bytes()
    controller.files.load_text(good, name)
    assert controller.wait_idle(10)
    assert view.last.scene == planners.load_scene(SCENARIOS[1])
    shown = view.last.message
    assert "/" not in shown and "\\" not in shown and "\x00" not in shown
    assert len(shown) < 100
    assert _tree(tmp_path) == before


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (b"[" * 5000 + b"]" * 5000, "nested too deeply"),
        (b"{not json", "not valid JSON"),
        (b"\xff\xfe\x00", "not UTF-8"),
        (b" " * (MAX_UPLOAD_BYTES + 1), "more than the 1,000,000"),
        (
            json.dumps(
                {"format": 1, "obstacles": 3, "start": [0, 0], "goal": [1, 1]}
            ).encode(),
            "obstacles: expected a list",
        ),
    ],
    ids=["deep", "json", "utf8", "large", "field"],
)
def test_a_bad_upload_keeps_the_scene(make_controller, content, words):
    scene = planners.load_scene(SCENARIOS[0])
    controller, view = make_controller(scene)
    controller.files.load_text(content, "upload.json")
    assert controller.wait_idle(10)
    assert view.last.scene == scene
    assert view.last.message.startswith("Not loaded, the scene is kept: upload.json")
    assert words in view.last.message


def test_the_panel_has_no_server_path_field():
    import inspect

    from app.ui import panels

    source = inspect.getsource(panels)
    assert 'add_text(\n                "File"' not in source
    assert "files.save(" not in source and "load_file" not in source
