"""Recordings of scenarios with moving obstacles (app.media.record_live): the live run, frame by frame.

The frame data (:class:`LiveFilm`) is checked against :func:`planners.scene.scene_at`,
:func:`planners.bug.live.live_space` and the trace itself (a slow reference interpolates the
trace's poses with ``np.interp``). One real recording in headless Chromium (320 x 200,
1 frame per second, 5 frames) checks the scene nodes drawn for each frame, the frames'
pixels where the moving obstacle is, and that a second recording is the same.
"""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path
from typing import Any, cast

import imageio.v3 as iio3
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app import start_app
from app.media.jobs import JobFailure
from app.media.pictures import shoot
from app.media.record import LIVE_FOLLOW, record, record_video
from app.media.record_live import FIGURE_EVENTS, LiveFilm, live_trace, show_live
from app.media.slides import SlideOptions, layout, project, relabel
from app.server import resolve_scenario
from app.ui.style import COLORS, HEIGHTS
from app.ui.view import prism_mesh
from planners.bug.live import LiveOptions, live_space
from planners.scene import Scene, load_scene, scene_at
from planners.scene.motion import Motion
from tests.app.app_helpers import live_drawings, shown_mesh

ROOT = Path(__file__).resolve().parents[2]
PERSON = "10_person_crossing"  # obstacle 1 walks up at 0.6 m/s after a 1 s pause
W, H, FPS, UNTIL = 320, 200, 1.0, 4.0
BARE = SlideOptions(legend=False, title="", labels=False)


def shipped(name: str) -> Scene:
    return load_scene(resolve_scenario(name)[1])


@pytest.fixture(scope="module")
def films() -> dict[str, LiveFilm]:
    """The two shipped moving-obstacle scenarios' whole live runs."""
    out = {}
    for name in ("09_sliding_door", PERSON):
        scene = shipped(name)
        out[name] = LiveFilm(scene, live_trace(scene))
    return out


# --------------------------------------------------------------------------- frame data


@pytest.mark.parametrize(
    ("name", "times"), [("09_sliding_door", (2.0, 6.5)), (PERSON, (0.5, 3.25))]
)
def test_a_frame_puts_every_obstacle_where_scene_at_does(films, name, times) -> None:
    film = films[name]
    moving = film.scene.motions[0].obstacle
    seen = []
    for t in times:
        frame = film.frame(t)
        now = scene_at(film.scene, t)
        assert frame.t == t
        assert [o.equals_exact(p, 0.0) for o, p in zip(frame.scene.obstacles, now.obstacles, strict=True)] == [True] * len(now.obstacles)  # fmt: skip
        # The expanded shapes are the live robot's configuration space of that scene.
        expected = live_space(now, LiveOptions(), None)
        assert frame.space.merged.equals(expected.merged)
        assert frame.scene.motions == film.scene.motions  # the legend's route row
        seen.append(frame.scene.obstacles[moving].centroid)
    # The two times show the moving obstacle at two places, the others where they were.
    assert seen[0].distance(seen[1]) > 0.5
    a, b = (film.frame(t).scene for t in times)
    for i, (p, q) in enumerate(zip(a.obstacles, b.obstacles, strict=True)):
        assert p.equals_exact(q, 0.0) == (i != moving)


def reference_pose(film: LiveFilm, t: float) -> np.ndarray:
    """The trace's poses, linearly between control periods (slow and obvious)."""
    times, poses = film.trace.times, film.trace.poses
    return np.array([np.interp(t, times, poses[:, j]) for j in range(3)])


def reference_wheels(film: LiveFilm, t: float) -> np.ndarray:
    """Wheel angles: the commanded rates integrated period by period, in a loop."""
    angles = np.zeros(film.trace.rates.shape[1])
    for step in film.trace.steps:
        start = step.t - film.trace.dt
        if t <= start:
            break
        angles += np.asarray(step.rates) * (min(t, step.t) - start)
    return angles


def test_the_trace_moves_with_its_commanded_velocity(films) -> None:
    """What the interpolation relies on: pose[k + 1] = pose[k] + velocity * dt."""
    for film in films.values():
        velocity = np.array([s.velocity for s in film.trace.steps])
        step = np.diff(film.trace.poses, axis=0)
        assert np.abs(step - velocity * film.trace.dt).max() < 1e-12


def test_the_robot_at_a_period_boundary_is_the_traces_pose(films) -> None:
    for film in films.values():
        dt = film.trace.dt
        for k in (0, 1, 7, 100, len(film.trace.steps)):
            pose, wheels = film.pose_at(k * dt)
            assert pose == tuple(film.trace.poses[k])
            np.testing.assert_allclose(
                wheels, reference_wheels(film, k * dt), atol=1e-9
            )
            drawn = film.frame(k * dt).pose
            assert drawn.xy == tuple(film.trace.poses[k][:2])
            assert drawn.phi == film.trace.poses[k][2]


@settings(max_examples=60, deadline=None)
@given(u=st.floats(0.0, 1.0), which=st.sampled_from(["09_sliding_door", PERSON]))
def test_the_robot_between_periods_follows_the_trace(films, u, which) -> None:
    film = films[which]
    t = u * film.trace.duration
    pose, wheels = film.pose_at(t)
    np.testing.assert_allclose(pose, reference_pose(film, t), atol=1e-9)
    np.testing.assert_allclose(wheels, reference_wheels(film, t), atol=1e-9)
    frame = film.frame(t)
    assert frame.pose.xy == pose[:2] and frame.pose.wheel_angles == tuple(wheels)
    # The walk so far ends at the robot and runs through the trace's positions.
    walk = frame.walk
    assert tuple(walk.path[-1]) == pose[:2]
    assert len(walk.modes) == len(walk.path) - 1
    k, _ = film.period(t)
    on_trace = film.trace.path[: k + 1]
    assert all(np.min(np.hypot(*(on_trace - p).T)) < 1e-12 for p in walk.path[:-1])
    assert {e.label for e in walk.events} == {
        e.label for e in film.trace.events if e.kind in FIGURE_EVENTS and e.t <= t
    }


def test_a_robot_at_rest_and_a_run_of_one_step() -> None:
    """Degenerate runs: the goal at the start (no segment), and ``until`` = 0."""
    square = Scene(
        obstacles=(shipped(PERSON).obstacles[1],),
        start=(1.0, 1.0),
        goal=(1.0, 1.0),
        motions=(Motion(0, ((0.0, 2.0),), speed=1.0),),
    )
    film = LiveFilm(square, live_trace(square))
    frame = film.frame(film.trace.duration)
    assert frame.pose.xy == (1.0, 1.0) and len(frame.walk.path) == 1
    assert frame.walk.modes == ()
    moving = shipped(PERSON)
    short = LiveFilm(moving, live_trace(moving, until=0.0))
    assert len(short.trace.steps) >= 1 and short.frame(0.0).pose.xy == moving.start
    # Past the end of the run the robot stays where the run ended.
    assert short.pose_at(5.0)[0] == tuple(short.trace.poses[-1])
    with pytest.raises(ValueError, match="no step"):
        LiveFilm(moving, dataclasses.replace(short.trace, steps=()))


# --------------------------------------------------------------------------- the app


@pytest.fixture(scope="module")
def planner_app():
    running = start_app(PERSON, print_url=False)
    yield running
    running.stop()


def test_the_view_draws_the_frames_scene_and_robot(planner_app, films) -> None:
    """The scene nodes the browser gets: obstacles, expanded shapes and robot at t."""
    assert planner_app.wait_idle(30)
    view = planner_app.view
    film = films[PERSON]
    try:
        for t in (0.5, 3.25):
            frame = film.frame(t)
            show_live(planner_app, frame)
            vertices, _ = prism_mesh(
                scene_at(film.scene, t).obstacles, HEIGHTS["obstacle"]
            )
            np.testing.assert_allclose(
                shown_mesh(view.obstacles)[0], vertices, atol=1e-6
            )
            assert tuple(view.robot.position[:2]) == pytest.approx(frame.pose.xy)
            assert view.robot.visible and view.sensing_circle.handle.visible
            # The DSB layer draws the walk so far (one segment per moving step).
            drawn = view.traces["dsb"].path.handle.points
            assert len(drawn) == len(frame.walk.path) - 1
            # No plan made at t = 0 is drawn over the live run.
            for graph in view.graphs.values():  # an empty layer: one point-segment
                points = graph.path.handle.points
                assert not graph.path.handle.visible or np.ptp(points) == 0
    finally:
        view.render(planner_app.controller.frame)


@pytest.fixture(scope="module")
def recorded(browser, planner_app, tmp_path_factory):
    """One recording of the person crossing, with what the view drew for each frame."""
    view = planner_app.view
    drawn: list[tuple[np.ndarray, tuple[float, float]]] = []
    render, render_robot = view.render, view.render_robot
    obstacles: list[np.ndarray] = []

    def spy_render(frame):
        render(frame)
        obstacles.append(shown_mesh(view.obstacles)[0])

    def spy_robot(pose):
        render_robot(pose)
        if pose is not None and pose.planner == "live":
            drawn.append((obstacles[-1], pose.xy))

    view.render, view.render_robot = spy_render, spy_robot
    try:
        path = tmp_path_factory.mktemp("live") / "person.mp4"
        recording = record_video(
            planner_app, browser, path, width=W, height=H, fps=FPS, until=UNTIL,
            options=BARE,
        )  # fmt: skip
    finally:
        del view.render, view.render_robot
    return (
        recording,
        drawn,
        np.stack([np.asarray(f)[..., :3] for f in iio3.imiter(path)]),
    )


def test_a_recording_draws_each_frame_at_its_time(recorded, films) -> None:
    recording, drawn, video = recorded
    film = films[PERSON]
    assert recording.times == (0.0, 1.0, 2.0, 3.0, 4.0)
    assert video.shape == (5, H, W, 3) and len(drawn) == 5
    assert recording.live is not None
    np.testing.assert_array_equal(
        recording.live.poses, film.trace.poses[: len(recording.live.poses)]
    )
    for t, (vertices, xy) in zip(recording.times, drawn, strict=True):
        k = round(t / film.trace.dt)
        assert xy == tuple(film.trace.poses[k][:2])  # the trace's pose, exactly
        now = scene_at(film.scene, t)
        expected, _ = prism_mesh(now.obstacles, HEIGHTS["obstacle"])
        np.testing.assert_allclose(vertices, expected, atol=1e-6)


def test_the_frames_show_the_person_where_it_is(recorded, films) -> None:
    """Pixels: the person's centre is obstacle-dark at its own time, floor at the other's."""
    recording, _, video = recorded
    film = films[PERSON]
    dark = np.asarray(COLORS["obstacle"], dtype=float)
    centre = {t: scene_at(film.scene, t).obstacles[1].centroid for t in (0.0, UNTIL)}
    px = {
        t: project(recording.camera, W, H, [[c.x, c.y, HEIGHTS["obstacle"]]])[0].round().astype(int)
        for t, c in centre.items()
    }  # fmt: skip
    for k, t in ((0, 0.0), (4, UNTIL)):
        other = UNTIL if t == 0.0 else 0.0
        here = video[k, px[t][1], px[t][0]].astype(float)
        there = video[k, px[other][1], px[other][0]].astype(float)
        assert np.abs(here - dark).max() < 60, (k, here)
        assert np.abs(there - dark).max() > 100, (k, there)


def test_two_live_recordings_are_the_same_frame_for_frame(
    recorded, browser, planner_app, tmp_path
) -> None:
    _, _, first = recorded
    path = tmp_path / "again.mp4"
    record_video(
        planner_app,
        browser,
        path,
        width=W,
        height=H,
        fps=FPS,
        until=UNTIL,
        options=BARE,
    )
    again = np.stack([np.asarray(f)[..., :3] for f in iio3.imiter(path)])
    assert again.shape == first.shape
    for k in range(len(first)):
        off = np.abs(first[k].astype(int) - again[k]).max(axis=2) > 16
        assert off.mean() <= 0.005, f"frame {k} differs in {off.mean():.2%} of pixels"


def test_a_still_at_a_time_is_the_recordings_frame_then(
    recorded, browser, planner_app, films
) -> None:
    """``--snapshot --robot-time T`` of a moving scenario: the live run at T, as the
    recording's frame at T draws it (the person where it is then, the robot at the
    trace's pose); afterwards the app draws its own frame (t = 0) again."""
    _, _, video = recorded
    film = films[PERSON]
    view = planner_app.view
    with live_drawings(view) as drawn:
        png = shoot(
            planner_app, browser, width=W, height=H, robot_time=UNTIL, options=BARE
        )
    [(vertices, xy)] = drawn
    assert xy == tuple(film.trace.poses[round(UNTIL / film.trace.dt)][:2])
    expected, _ = prism_mesh(scene_at(film.scene, UNTIL).obstacles, HEIGHTS["obstacle"])
    np.testing.assert_allclose(vertices, expected, atol=1e-6)
    still = np.asarray(iio3.imread(png, extension=".png"))[..., :3].astype(int)
    assert still.shape == video[-1].shape
    # The recording's frame at T, but for its compression: thin coloured lines are
    # smeared a little (yuv420), nothing moves (a 2 px shift would make 8 % of pixels
    # and 11 levels on average).
    diff = np.abs(still - video[-1])
    assert diff.mean() < 2.0, diff.mean()
    off = diff.max(axis=2) > 60
    assert off.mean() <= 0.005, f"differs from the frame in {off.mean():.2%} of pixels"
    back, _ = prism_mesh(film.scene.obstacles, HEIGHTS["obstacle"])
    np.testing.assert_allclose(shown_mesh(view.obstacles)[0], back, atol=1e-6)


def test_a_still_past_the_runs_end_is_its_last_frame(browser, planner_app) -> None:
    """A time after the robot reached the goal draws the run's end (the trace's last
    pose), as the run is never driven past it (nor past MAX_DURATION_S)."""
    scene = planner_app.controller.scene
    whole = live_trace(scene)
    assert whole.duration < 100.0  # the person's run reaches the goal
    with live_drawings(planner_app.view) as drawn:
        shoot(planner_app, browser, width=W, height=H, robot_time=1e6, options=BARE)
    [(vertices, xy)] = drawn
    assert xy == tuple(whole.poses[-1][:2])
    expected, _ = prism_mesh(
        scene_at(scene, whole.duration).obstacles, HEIGHTS["obstacle"]
    )
    np.testing.assert_allclose(vertices, expected, atol=1e-6)


# --------------------------------------------------------------------------- errors


def test_follow_on_a_moving_scenario_is_one_line_and_exit_2(tmp_path, capsys) -> None:
    assert record(PERSON, tmp_path / "x.gif", follow="vg") == 2
    err = capsys.readouterr().err
    assert err == f"error: {LIVE_FOLLOW.format(follow='vg')}\n"
    assert not list(tmp_path.iterdir())


def test_follow_through_the_api_on_a_moving_scene_is_refused(
    planner_app, tmp_path
) -> None:
    with pytest.raises(
        JobFailure, match="--follow svg: this scenario's obstacles move"
    ):
        record_video(planner_app, cast("Any", None), tmp_path / "x.mp4", follow="svg")
    assert not list(tmp_path.iterdir())


def test_the_command_line_says_it_in_one_line(tmp_path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "app", "--scenario", "09", "--record",
         str(tmp_path / "x.mp4"), "--follow", "dsb"],
        capture_output=True, text=True, cwd=ROOT, timeout=120, check=False,
    )  # fmt: skip
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and "recorded live" in result.stderr


# --------------------------------------------------------------------------- layout


def test_relabel_keeps_the_layout_and_moves_the_moving_obstacles_number() -> None:
    scene = shipped("09_sliding_door")
    base = layout(scene, {}, {}, 640, 400)
    assert relabel(base, scene, {}, {}) == base  # layout places its labels so
    later = scene_at(scene, 6.0)  # the door has slid down 1.2 m
    moved = relabel(base, later, {}, {})
    assert (moved.camera, moved.legend, moved.title, moved.stamp) == (
        base.camera, base.legend, base.title, base.stamp,
    )  # fmt: skip
    number = {p.request.text: p.request.anchor for p in base.labels.placed}
    after = {p.request.text: p.request.anchor for p in moved.labels.placed}
    door = later.obstacles[2].representative_point()
    expected = project(base.camera, 640, 400, [[door.x, door.y, HEIGHTS["obstacle"]]])[
        0
    ]
    assert after["3"] == pytest.approx(tuple(expected))
    assert after["3"][1] - number["3"][1] > 20  # [px] lower on the picture
    assert after["1"] == number["1"] and after["2"] == number["2"]


def test_layout_frames_the_bounds_it_is_given() -> None:
    scene = shipped(PERSON)
    wide = (-5.0, -5.0, 15.0, 13.0)
    slide = layout(scene, {}, {}, 640, 400, bounds=wide, options=BARE)
    corners = project(slide.camera, 640, 400, [[-5.0, -5.0, 0.0], [15.0, 13.0, 0.0]])
    assert (
        corners.min() >= 0 and corners[:, 0].max() <= 640 and corners[:, 1].max() <= 400
    )
    own = layout(scene, {}, {}, 640, 400, options=BARE)
    assert own.camera != slide.camera
