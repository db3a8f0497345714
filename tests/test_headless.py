"""Headless snapshots: the command line, repeatability, clean shutdown, errors, framing."""

from __future__ import annotations

import io
import os
import socket
import subprocess
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from PIL import Image

import app
from app.media.browser import CHROMIUM_ENV
from app.media.camera import CameraPose, frame_camera, picture_bounds
from app.media.jobs import snapshot
from app.media.pictures import open_studio
from app.media.slide_options import SlideOptions
from planners.scene import load_scene
from tests.conftest import ROOT, run_module

if TYPE_CHECKING:
    from playwright.sync_api import Browser

SCENARIO = ROOT / "static_scenarios" / "01_two_convex.json"
NAME = SCENARIO.stem


def pixels(png: bytes | Path) -> np.ndarray:
    data = png.read_bytes() if isinstance(png, Path) else png
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def run_cli(
    *args: str, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    return run_module("app", *args, timeout=180, env=env)


def our_processes() -> set[int]:
    """Children of this test process, and browsers it may have orphaned (now under init)."""
    pids = set()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes()
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        if ppid == os.getpid() or (ppid == 1 and b"chrom" in cmdline):
            pids.add(int(entry.name))
    return pids


def port_open(port: int) -> bool:
    with socket.socket() as s:
        s.settimeout(0.5)
        return s.connect_ex(("127.0.0.1", port)) == 0


def still_running(before: set[int], mark: str, grace: float = 10.0) -> list[str]:
    """Processes we started that were not there ``before`` and still run after ``grace`` s.

    A browser's helper processes may take a moment to exit after the browser closed (on
    a loaded machine, seconds). Chromium's crash handlers are reparented to init as soon
    as they start, so on a shared machine another job's browser adds some too: only
    processes whose environment holds ``mark`` (set in ours before the snapshot; the
    browser and its helpers inherit it) are ours. Each is named by its command line.
    """
    deadline = time.monotonic() + grace
    while True:
        left = [pid for pid in sorted(our_processes() - before) if _has_mark(pid, mark)]
        if not left or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    names = []
    for pid in left:
        try:
            cmdline = (Path("/proc") / str(pid) / "cmdline").read_bytes()
        except OSError:
            continue  # gone since
        text = cmdline.replace(b"\0", b" ")[:120].decode(errors="replace")
        names.append(f"{pid}: {text}")
    return names


def _has_mark(pid: int, mark: str) -> bool:
    try:
        return mark.encode() in (Path("/proc") / str(pid) / "environ").read_bytes()
    except OSError:
        return False  # gone, or not ours to read


# --------------------------------------------------------------------------- end to end


def test_cli_and_python_give_the_same_picture_and_stop_everything(
    tmp_path: Path, monkeypatch
) -> None:
    out_cli = tmp_path / "cli" / "snap.png"  # the parent folder does not exist yet
    result = run_cli(
        "--scenario",
        NAME,
        "--snapshot",
        str(out_cli),
        "--width",
        "640",
        "--height",
        "400",
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout == ""  # quiet: no URL, no viser banner
    assert "Traceback" not in result.stderr
    cli = pixels(out_cli)
    assert cli.shape == (400, 640, 3)
    assert len(np.unique(cli.reshape(-1, 3), axis=0)) > 8  # a drawing, not a blank page

    # The same picture from Python, in another process's browser and server: repeatable.
    started: list[Any] = []
    real_start = app.start_app

    def spy(*args: Any, **kwargs: Any) -> Any:
        started.append(real_start(*args, **kwargs))
        return started[-1]

    monkeypatch.setattr(app, "start_app", spy)
    mark = f"planner-snapshot-test-{os.getpid()}-{time.monotonic_ns()}"
    monkeypatch.setenv("PLANNER_SNAPSHOT_TEST_MARK", mark)  # inherited by the browser
    before = our_processes()
    out_py = tmp_path / "py.png"
    assert snapshot(NAME, out_py, width=640, height=400) == 0
    # The same picture, up to the anti-aliasing of a few text pixels: the browser's text
    # rendering varies by one level of 255 between runs (measured: 5 of 256,000 pixels
    # in about 1 run of 3). Anything the planners draw differs by far more.
    diff = np.abs(pixels(out_py).astype(int) - cli.astype(int)).max(axis=2)
    assert diff.max() <= 2 and np.count_nonzero(diff) <= 50, (
        f"two runs gave different pictures: {np.count_nonzero(diff)} pixels differ, "
        f"by up to {diff.max()} levels"
    )

    # Everything it started is gone: the browser, playwright's driver and the app's
    # server. A picture plans DSB in a thread: no planner process to leave behind.
    left = still_running(before, mark)
    assert not left, f"processes left running after snapshot(): {left}"
    (planner_app,) = started
    assert planner_app.controller.scheduler.process is None
    assert not port_open(planner_app.port), "the app's server still listens"


def test_robot_time_and_perspective_change_the_picture(browser: Browser) -> None:
    planner_app = app.start_app(SCENARIO, print_url=False)
    bare = SlideOptions(legend=False, title="", labels=False)  # the scene alone
    try:
        with open_studio(planner_app, browser, width=480, height=300) as studio:
            at_start = pixels(studio.picture("top", bare))
            later = pixels(studio.picture("top", bare, robot_time=3.0))
            tilted = pixels(studio.picture("perspective", bare))
    finally:
        planner_app.stop()
    moved = np.abs(at_start.astype(int) - later).max(axis=2) > 16
    assert moved.mean() > 1e-3, "the robot did not move with robot_time"
    # Away from the robot, the scene is the same: only the robot moved.
    assert moved.mean() < 0.05
    assert (np.abs(at_start.astype(int) - tilted).max(axis=2) > 16).mean() > 0.05


# --------------------------------------------------------------------------- errors


def test_bad_scenario_is_one_line_and_exit_2(tmp_path: Path, capsys) -> None:
    out = tmp_path / "x.png"
    assert snapshot(tmp_path / "missing.json", out) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "missing.json" in err and "Traceback" not in err
    assert not out.exists()

    result = run_cli(
        "--scenario", str(tmp_path / "missing.json"), "--snapshot", str(out)
    )
    assert result.returncode != 0
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "missing.json" in result.stderr
    assert not out.exists()


def test_missing_chromium_is_one_line_with_a_hint(tmp_path: Path, capsys) -> None:
    out = tmp_path / "x.png"
    assert snapshot(NAME, out, chromium=str(tmp_path / "no-chromium")) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "apt-get install -y chromium" in err

    result = run_cli(
        "--scenario",
        NAME,
        "--snapshot",
        str(out),
        env={CHROMIUM_ENV: "/nonexistent/chromium"},
    )
    assert result.returncode != 0
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "apt-get install -y chromium" in result.stderr
    assert not out.exists()


def test_browser_that_fails_to_start_is_one_line(tmp_path: Path, capsys) -> None:
    # An executable that is not a browser: playwright's launch fails.
    assert snapshot(NAME, tmp_path / "x.png", chromium="/bin/false") == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "failed to start" in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"width": 0}, "width"),
        ({"height": 10**6}, "height"),
        ({"view": "side"}, "view"),
        ({"robot_time": -1.0}, "robot_time"),
    ],
)
def test_bad_arguments_exit_2(
    tmp_path: Path, capsys, kwargs: dict[str, Any], word: str
) -> None:
    assert snapshot(NAME, tmp_path / "x.png", **kwargs) == 2
    assert word in capsys.readouterr().err


# --------------------------------------------------------------------------- framing


def project(pose: CameraPose, points: np.ndarray, aspect: float) -> np.ndarray:
    """Pinhole projection to normalised picture coordinates (-1..1 is inside)."""
    position, target = np.asarray(pose.position), np.asarray(pose.look_at)
    forward = (target - position) / np.linalg.norm(target - position)
    right = np.cross(forward, pose.up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    rel = points - position
    depth = rel @ forward
    tan = np.tan(pose.fov / 2)
    return np.stack(
        [(rel @ right) / (depth * tan * aspect), (rel @ up) / (depth * tan)], axis=1
    )


@pytest.mark.parametrize("view", ["top", "perspective"])
@pytest.mark.parametrize(("width", "height"), [(1280, 800), (600, 900), (960, 600)])
def test_framing_shows_the_whole_scene_with_a_margin(
    view: str, width: int, height: int
) -> None:
    bounds = picture_bounds(load_scene(SCENARIO))
    x0, y0, x1, y1 = bounds
    corners = np.array([[x, y, 0.0] for x in (x0, x1) for y in (y0, y1)])
    pose = frame_camera(bounds, width, height, view)
    ndc = project(pose, corners, width / height)
    assert np.abs(ndc).max() < 0.97  # inside, with a margin
    assert np.abs(ndc).max() > 0.6  # and not lost in the middle
    assert (
        pose.near < np.linalg.norm(np.subtract(pose.position, pose.look_at)) < pose.far
    )
    if view == "top":
        # A plan: +x to the right, +y up in the picture.
        assert ndc[2, 0] > ndc[0, 0] and ndc[1, 1] > ndc[0, 1]


def test_picture_bounds_include_the_robot_around_start_and_goal() -> None:
    scene = load_scene(
        {
            "format": 1,
            "obstacles": [],
            "start": [0, 0],
            "goal": [4, 1],
            "robot": {"radius": 0.5},
        }
    )
    assert picture_bounds(scene) == (-0.5, -0.5, 4.5, 1.5)


def test_unwritable_output_fails_before_rendering(capsys) -> None:
    assert snapshot(NAME, "/proc/no-such-folder/x.png") == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot write /proc/no-such-folder/x.png" in err
