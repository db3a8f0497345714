"""Videos of the robot's run (app.media.record): frame count, motion along the path, repeatability.

Recordings are kept small (480 x 300, 5 frames per second, the first 4 s of the run) so
the tests stay quick; the code path is the one of ``--record`` at any size.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import imageio.v2 as iio
import imageio.v3 as iio3
import numpy as np
import pytest

from app import start_app
from app.media.record import record, record_video
from app.media.slides import SlideOptions, layout, project
from app.media.video import frame_times

ROOT = Path(__file__).resolve().parents[2]
NAME = "02_three_obstacles"
W, H, FPS, UNTIL = 480, 300, 5.0, 4.0
BARE = SlideOptions(legend=False, title="", labels=False)  # nothing over the robot


@pytest.fixture(scope="module")
def planner_app():
    running = start_app(NAME, print_url=False)
    yield running
    running.stop()


def frames(path: Path) -> np.ndarray:
    """Decode every frame of a video file (RGB)."""
    return np.stack([np.asarray(f)[..., :3] for f in iio3.imiter(path)])


def robot_pixels(planner_app, recording) -> np.ndarray:
    """Where the server drew the robot at each frame's time, projected into the picture."""
    out = []
    for t in recording.times:
        planner_app.set_robot_time(t)
        assert planner_app.wait_idle(30)
        x, y, _ = planner_app.view.robot.position
        out.append(project(recording.camera, W, H, [[x, y, 0.0]])[0])
    return np.array(out)


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
def test_frames_follow_the_path_at_real_time(
    browser, planner_app, tmp_path, suffix
) -> None:
    path = tmp_path / f"run{suffix}"
    recording = record_video(
        planner_app,
        browser,
        path,
        width=W,
        height=H,
        fps=FPS,
        follow="vg",
        until=UNTIL,
        options=BARE,
    )
    video = frames(path)
    # Frame count = duration x fps, within one frame (the first frame is t = 0).
    assert abs(len(video) - UNTIL * FPS) <= 1
    assert len(video) == len(recording.times) == len(frame_times(UNTIL, FPS))
    assert video.shape[1:] == (H, W, 3)
    if suffix == ".mp4":
        meta = iio.get_reader(path, format="FFMPEG").get_meta_data()
        assert meta["fps"] == FPS
    # The robot: where frame k differs from frame 0, away from where the robot was at
    # t = 0, is where the server put the robot at t_k (projected), within its radius.
    expected = robot_pixels(planner_app, recording)
    scale = np.linalg.norm(
        project(recording.camera, W, H, [[0, 0, 0], [1, 0, 0]])[1]
        - project(recording.camera, W, H, [[0, 0, 0]])[0]
    )  # [px/m]
    radius = planner_app.controller.scene.robot.radius * scale
    yy, xx = np.mgrid[0:H, 0:W]
    away = np.hypot(xx - expected[0][0], yy - expected[0][1]) > 1.6 * radius
    checked = 0
    for k in range(1, len(video)):
        if np.linalg.norm(expected[k] - expected[0]) < 3 * radius:
            continue  # still overlapping its starting place
        moved = (np.abs(video[k].astype(int) - video[0]).max(axis=2) > 48) & away
        assert moved.sum() > 10, f"frame {k}: no robot seen"
        centre = np.array([xx[moved].mean(), yy[moved].mean()])
        assert np.linalg.norm(centre - expected[k]) < radius, (k, centre, expected[k])
        checked += 1
    assert checked >= len(video) // 3  # the robot starts from rest
    # It moves along the path: away from the start, farther and farther.
    travelled = np.linalg.norm(expected - expected[0], axis=1)
    assert np.all(np.diff(travelled) >= -1e-6) and travelled[-1] > 4 * radius


def test_two_recordings_are_the_same_frame_for_frame(
    browser, planner_app, tmp_path
) -> None:
    videos = []
    for k in range(2):
        path = tmp_path / f"run{k}.mp4"
        record_video(planner_app, browser, path, width=W, height=H, fps=FPS, until=2.0)
        videos.append(frames(path))
    a, b = videos
    assert a.shape == b.shape
    # The snapshot tolerance (tests/snapshots/README.md): channels within 16, at most
    # 0.5 % of the pixels of any frame off. In practice the files are identical.
    for k in range(len(a)):
        off = np.abs(a[k].astype(int) - b[k]).max(axis=2) > 16
        assert off.mean() <= 0.005, f"frame {k} differs in {off.mean():.2%} of pixels"


def test_a_time_stamp_shows_each_frames_time_in_its_box(
    browser, planner_app, tmp_path
) -> None:
    path = tmp_path / "stamped.mp4"
    options = SlideOptions(legend=False, title="", labels=False, time_stamp=True)
    recording = record_video(
        planner_app, browser, path, width=W, height=H, fps=2.0, until=2.0,
        options=options,
    )  # fmt: skip
    assert recording.times == (0.0, 0.5, 1.0, 1.5, 2.0)
    video = frames(path)
    slide = layout_of(planner_app, options)
    assert slide.stamp is not None
    b = slide.stamp
    x0, y0, x1, y1 = (round(v) for v in (b.x0, b.y0, b.x1, b.y1))
    inside = video[:, y0:y1, x0:x1].astype(int)
    # Dark text in the box on every frame, as tall as the labels' capitals and digits
    # (2 to 3 % of the picture's height, tests/app/test_slides.py) ...
    for k in range(len(video)):
        rows = np.flatnonzero((inside[k].max(axis=2) < 90).any(axis=1))
        assert len(rows), f"frame {k}: no time stamp"
        assert 0.02 * H <= rows[-1] - rows[0] + 1 <= 0.04 * H
    # ... saying another time on each frame ("t = 0.0 s", "t = 0.5 s", ...).
    for k in range(1, len(video)):
        assert (np.abs(inside[k] - inside[k - 1]).max(axis=2) > 48).sum() > 5, k


def layout_of(planner_app, options: SlideOptions):
    """The slide layout a recording of ``planner_app`` at W x H uses."""
    controller = planner_app.controller
    return layout(
        controller.scene, controller.plans, controller.frame.layers, W, H,
        options=options, registry=controller.registry,
    )  # fmt: skip


def test_bad_arguments_are_one_line_and_exit_2(tmp_path, capsys) -> None:
    for kwargs, message in [
        ({"out": tmp_path / "x.avi"}, "must end in .mp4 or .gif"),
        ({"out": tmp_path / "x.mp4", "width": 321}, "even width and height"),
        ({"out": tmp_path / "x.gif", "fps": 0.0}, "fps must be from 1 to 60"),
        ({"out": tmp_path / "x.gif", "follow": "rrt"}, "unknown planner 'rrt'"),
        ({"out": tmp_path / "x.gif", "until": float("nan")}, "end time"),
    ]:
        assert record(NAME, **kwargs) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and message in err and err.count("\n") == 1
    assert not list(tmp_path.iterdir())


def test_a_planner_without_a_path_is_one_line_and_no_file(tmp_path, capsys) -> None:
    out = tmp_path / "none.gif"
    assert record("07_goal_enclosed", out, width=160, height=100, follow="vg") == 1
    err = capsys.readouterr().err
    assert "no trajectory to record" in err and "Traceback" not in err
    assert not out.exists() and not list(tmp_path.iterdir())


def test_the_command_line_writes_a_gif(tmp_path) -> None:
    out = tmp_path / "cli.gif"
    result = subprocess.run(
        [sys.executable, "-m", "app", "--scenario", NAME, "--record", str(out),
         "--width", "160", "--height", "100", "--fps", "4", "--until", "1"],
        capture_output=True, text=True, cwd=ROOT, timeout=300, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout == "" and result.stderr == ""
    assert frames(out).shape == (5, 100, 160, 3)
