"""The path and trajectory exports: what a robot's controller reads is what the app drives."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

import planners
from app.session import robot as app_robot
from planners import drive, export
from planners.__main__ import main
from tests.conftest import ROOT

SCENES = ROOT / "static_scenarios"


@pytest.fixture(scope="module", params=["01_two_convex", "08_narrow_gap"])
def planned(request):
    scene = planners.load_scene(SCENES / f"{request.param}.json")
    result = planners.plan_all(scene, ["svg"])["svg"]
    return scene, result.path, drive.trajectory(scene, result.path)


def _read_csv(text: str) -> tuple[list[str], np.ndarray]:
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], np.array([[float(v) for v in row] for row in rows[1:]])


def test_the_app_animates_the_trajectory_that_is_exported():
    assert app_robot.trajectory is drive.trajectory


def test_trajectory_csv_holds_every_sample_exactly(planned):
    _, _, traj = planned
    header, rows = _read_csv(export.trajectory_csv(traj))
    k = traj.wheel_rates.shape[1]
    assert header == ["t", "x", "y", "phi", "vx", "vy", "omega"] + [
        f"wheel_{i}" for i in range(1, k + 1)
    ]
    assert rows.shape == (len(traj.t), 7 + k)
    # repr() round-trips a float exactly.
    assert np.array_equal(rows[:, 0], traj.t)
    assert np.array_equal(rows[:, 1:4], traj.pose)
    assert np.array_equal(rows[:, 4:7], traj.velocity)
    assert np.array_equal(rows[:, 7:], traj.wheel_rates)


def test_the_wheel_rates_are_the_chapters_inverse_kinematics(planned):
    # eq. 9.5 (holonomic) or 9.9 (differential) applied to each row's velocity and heading.
    scene, _, traj = planned
    _, rows = _read_csv(export.trajectory_csv(traj))
    params = drive.robot_params(scene.robot)
    expected = params.inverse(
        rows[:, 4], rows[:, 5], rows[:, 6], rows[:, 3], check=False
    )
    assert np.allclose(rows[:, 7:], expected, atol=1e-9)


def test_the_trajectory_starts_at_the_start_and_ends_at_the_goal(planned):
    scene, _, traj = planned
    _, rows = _read_csv(export.trajectory_csv(traj))
    assert np.allclose(rows[0, 1:3], scene.start, atol=1e-9)
    assert np.allclose(rows[-1, 1:3], scene.goal, atol=1e-9)
    assert np.allclose(rows[[0, -1], 4:], 0.0, atol=1e-9)  # at rest at both ends


def test_path_csv_is_the_planners_path(planned):
    _, path, _ = planned
    header, rows = _read_csv(export.path_csv(path))
    assert header == ["x", "y"]
    assert np.array_equal(rows, path)


def test_json_holds_both_tables_and_the_robot(planned):
    scene, path, traj = planned
    out = json.loads(export.export_json(scene, "svg", path, traj))
    assert out["format"] == export.EXPORT_FORMAT and out["frame"] == "world"
    assert out["planner"] == "svg" and out["scene"] == scene.name
    assert np.array_equal(np.array(out["path"]), path)
    table = out["trajectory"]
    assert table["columns"] == list(export.trajectory_columns(traj))
    assert np.array_equal(np.array(table["rows"]), export.trajectory_rows(traj))
    assert table["dt"] == traj.dt
    assert table["robot"]["kind"] == scene.robot.kind
    assert table["robot"]["wheel_radius"] == scene.robot.wheel_radius


def test_the_command_writes_what_the_functions_write(tmp_path):
    source = SCENES / "01_two_convex.json"
    scene = planners.load_scene(source)
    path = planners.plan_all(scene, ["vg"])["vg"].path
    traj = drive.trajectory(scene, path, dt=0.1)
    out = tmp_path / "vg.json"
    assert (
        main(["export", str(source), "--planner", "vg", "--dt", "0.1", "-o", str(out)])
        == 0
    )
    assert out.read_text() == export.export_json(scene, "vg", path, traj)
    out = tmp_path / "vg.csv"
    assert (
        main(
            [
                "export",
                str(source),
                "--planner",
                "vg",
                "--table",
                "path",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    assert out.read_text() == export.path_csv(path)


@pytest.mark.parametrize(
    ("scenario", "expected"),
    [
        (
            "07_goal_enclosed.json",
            "07_goal_enclosed.json: svg: unreachable: the goal is enclosed",
        ),
        ("missing.json", "missing.json: (file): cannot read"),
    ],
)
def test_the_command_refuses_in_one_line(tmp_path, capsys, scenario, expected):
    out = tmp_path / "out.csv"
    assert main(["export", str(SCENES / scenario), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert expected in err and err.count("\n") == 1, err
    assert not out.exists()


def test_the_command_refuses_a_bad_sample_period(tmp_path, capsys):
    out = tmp_path / "out.csv"
    with pytest.raises(SystemExit) as exit_:
        main(
            ["export", str(SCENES / "01_two_convex.json"), "--dt", "0", "-o", str(out)]
        )
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "--dt: must be a positive number, got '0'" in err and err.count("\n") == 1, (
        err
    )
    assert not out.exists()


def test_the_command_refuses_an_unknown_suffix(tmp_path, capsys):
    code = main(
        ["export", str(SCENES / "01_two_convex.json"), "-o", str(tmp_path / "x.txt")]
    )
    assert code == 2
    assert (
        capsys.readouterr().err
        == f"error: {tmp_path / 'x.txt'}: (file): write .csv or .json\n"
    )


@pytest.mark.parametrize(
    "robot",
    [
        {"kind": "differential", "max_wheel_rate": 1e-4},
        {"kind": "holonomic", "max_wheel_acceleration": 1e-9},
        {
            "kind": "differential",
            "max_wheel_rate": 1e-6,
            "max_wheel_acceleration": 1e-6,
        },
    ],
)
def test_a_crawling_robot_gets_a_bounded_number_of_samples(robot):
    # Wheel limits near zero make a motion of days: its period is stretched, so the
    # samples stay within drive.MAX_SAMPLES (and a hostile scene cannot fill memory).
    scene = planners.load_scene(
        {
            "format": 1,
            "obstacles": [[[2, 2], [4, 2], [3, 4]]],
            "start": [0, 0],
            "goal": [6, 5],
            "robot": robot,
        }
    )
    path = planners.plan_all(scene, ["vg"])["vg"].path
    traj = drive.trajectory(scene, path)
    assert len(traj.t) <= drive.MAX_SAMPLES * 1.01
    assert (
        traj.duration > 1e5
    )  # still the motion the limits allow, only sampled sparsely
    assert np.allclose(traj.pose[-1, :2], scene.goal, atol=1e-6)


def test_least_duration_is_a_lower_bound(planned):
    _, path, traj = planned
    limits = traj.limits
    assert drive.least_duration(np.asarray(path), limits) <= traj.duration
