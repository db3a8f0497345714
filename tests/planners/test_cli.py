import json

from tests.conftest import SCENARIOS, run_module


def run(*args):
    return run_module("planners", *args)


def test_one_file_prints_one_json_object():
    path = next(p for p in SCENARIOS if "two_convex" in p.stem)
    out = run("plan", str(path), "--planners", "vg,svg")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["scene"] == "Two convex obstacles"
    for name in ("vg", "svg"):
        result = data[name]
        assert set(result) == {
            "status",
            "length",
            "path",
            "nodes",
            "edges",
            "ms",
            "reason",
        }
        assert result["status"] == "ok" and result["reason"] is None
        assert result["path"][0] == [1.0, 1.0] and result["path"][-1] == [9.0, 7.0]
        assert result["nodes"] > 0 and result["edges"] > 0 and result["ms"] >= 0
    assert data["vg"]["length"] == data["svg"]["length"]


def test_several_files_print_one_line_each_in_order():
    out = run("plan", *map(str, SCENARIOS[:3]), "--planners", "vg")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.strip().splitlines()
    assert len(lines) == 3
    names = [json.loads(line)["scene"] for line in lines]
    assert names == [json.loads(p.read_text())["name"] for p in SCENARIOS[:3]]


def test_unreachable_and_invalid_are_statuses_not_errors(tmp_path):
    enclosed = next(p for p in SCENARIOS if "enclosed" in p.stem)
    data = json.loads(run("plan", str(enclosed), "--planners", "vg,svg").stdout)
    assert (
        data["vg"]["status"] == "unreachable"
        and data["vg"]["length"] is None
        and data["vg"]["path"] == []
    )
    scene = json.loads(enclosed.read_text())
    scene["start"] = [6.0, 2.8]  # inside obstacle 1
    file = tmp_path / "inside.json"
    file.write_text(json.dumps(scene))
    out = run("plan", str(file), "--planners", "vg")
    assert out.returncode == 0
    assert json.loads(out.stdout)["vg"]["status"] == "invalid"
    assert "obstacle 1" in json.loads(out.stdout)["vg"]["reason"]


def test_invalid_file_exits_2_with_one_line_naming_file_and_field(tmp_path):
    file = tmp_path / "bad.json"
    file.write_text(
        json.dumps(
            {
                "format": 1,
                "obstacles": [[[0, 0], [1, 1], [1, 0], [0, 1]]],
                "start": [5, 5],
                "goal": [6, 6],
            }
        )
    )
    out = run("plan", str(SCENARIOS[0]), str(file))
    assert out.returncode == 2
    assert out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stderr
    assert str(file) in lines[0] and "obstacles[0]" in lines[0]


def test_missing_file_and_bad_flags_exit_2_without_traceback(tmp_path):
    for args in (
        ("plan", str(tmp_path / "absent.json")),
        ("plan", str(SCENARIOS[0]), "--planners", "astar"),
        ("plan", str(SCENARIOS[0]), "--sensor-range", "-1"),
    ):
        out = run(*args)
        assert out.returncode == 2, args
        assert (
            "Traceback" not in out.stderr and len(out.stderr.strip().splitlines()) == 1
        )


def test_deeply_nested_file_exits_2_with_one_line(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 5000 + "]" * 5000)
    out = run("plan", str(path))
    assert out.returncode == 2
    assert out.stderr == f"error: {path}: (file): nested too deeply to be a scenario\n"
    assert out.stdout == ""
