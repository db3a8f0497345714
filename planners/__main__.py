"""Command line: ``python -m planners plan``, ``export`` and ``import-map``.

``plan FILE [FILE ...] [--planners vg,svg,dsb] [--sensor-range R]``: with one file, prints
one JSON object (docs/api.md, "Command line"); with several, one JSON object per line in
input order.

``export FILE [--planner NAME] -o OUT.csv|OUT.json [--table path|trajectory] [--dt DT]``:
writes the planner's path and the robot's trajectory along it (:mod:`planners.export`).

``import-map MAP.yaml [--start X Y] [--goal X Y] [--robot-radius R] [--tolerance T]
[--unknown occupied|free] -o SCENE.json``: writes the scenario of a ROS map_server map
(docs/maps.md). The scenario names the map in its ``map`` key only when it is written
into the map's folder (the key is a file name, never a path); elsewhere the key is left
out and stderr says so.

An unreadable or invalid file, or a planner without a path: exit 2 with one line on
stderr.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from planners import export
from planners.allocator import keep_freed_memory
from planners.api import plan_all, result_to_json
from planners.drive import trajectory
from planners.registry import REGISTRY, PlanOptions, default_planners
from planners.scene import (
    ScenarioError,
    is_map_name,
    load_scene,
    save_scene,
    scene_from_dict,
)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line and exit 2, like a bad file
        self.exit(2, f"{self.prog}: error: {message}\n")


def _planner_list(text: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in REGISTRY]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown planner {unknown[0] if unknown else text!r}; known: {','.join(REGISTRY)}"
        )
    return names


def _number(accept: Callable[[float], bool], wanted: str) -> Callable[[str], float]:
    """Return an argparse type: a float that ``accept`` takes, else "WANTED, got TEXT"."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        if not accept(value):
            raise argparse.ArgumentTypeError(f"{wanted}, got {text!r}")
        return value

    return parse


_sensor_range = _number(lambda v: v > 0, "must be positive (inf for unlimited)")
_length = _number(lambda v: math.isfinite(v) and v >= 0, "must be a number >= 0")
_coordinate = _number(math.isfinite, "must be a finite number")
_positive = _number(lambda v: math.isfinite(v) and v > 0, "must be a positive number")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="python -m planners",
        description="Plan paths for scenario files; import occupancy maps.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    plan = sub.add_parser("plan", help="plan every file and print JSON")
    plan.add_argument("files", nargs="+", metavar="FILE")
    plan.add_argument(
        "--planners",
        type=_planner_list,
        default=default_planners(),
        help="comma-separated planners (default: "
        + ",".join(default_planners())
        + "): "
        + "; ".join(f"{n} = {spec.title}" for n, spec in REGISTRY.items()),
    )
    plan.add_argument(
        "--sensor-range",
        type=_sensor_range,
        default=None,
        metavar="R",
        help="DSB sensor range [m] (inf: unlimited); default: the scenario's",
    )
    _export_parser(sub)
    _import_parser(sub)
    return parser


def _export_parser(sub: Any) -> None:
    cmd = sub.add_parser(
        "export",
        help="write a planner's path and the robot's trajectory as CSV or JSON",
    )
    cmd.add_argument("file", metavar="FILE")
    cmd.add_argument(
        "--planner",
        choices=tuple(REGISTRY),
        default="svg",
        help="whose path (default: svg)",
    )
    cmd.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUT",
        help="OUT.csv (one table) or OUT.json (path and trajectory)",
    )
    cmd.add_argument(
        "--table",
        choices=("path", "trajectory"),
        default="trajectory",
        help="the table a CSV file holds (default: trajectory)",
    )
    cmd.add_argument(
        "--dt",
        type=_positive,
        default=0.05,
        help="the trajectory's sample period [s] (default: 0.05)",
    )
    cmd.add_argument("--sensor-range", type=_sensor_range, default=None, metavar="R")


def _export(args: argparse.Namespace) -> int:
    """``export``: plan one planner, write its path and trajectory; 2 on a problem."""
    suffix = Path(args.output).suffix.lower()
    if suffix not in (".csv", ".json"):
        print(f"error: {args.output}: (file): write .csv or .json", file=sys.stderr)
        return 2
    try:
        scene = load_scene(args.file)
    except ScenarioError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    options = PlanOptions(sensor_range=args.sensor_range)
    result = plan_all(scene, [args.planner], options)[args.planner]
    path = result.path
    if len(path) < 2:
        reason = getattr(result, "reason", "") or "no path"
        print(
            f"error: {args.file}: {args.planner}: {result.status}: {reason}",
            file=sys.stderr,
        )
        return 2
    traj = trajectory(scene, path, dt=args.dt)
    if suffix == ".json":
        text = export.export_json(scene, args.planner, path, traj)
    elif args.table == "path":
        text = export.path_csv(path)
    else:
        text = export.trajectory_csv(traj)
    Path(args.output).write_text(text, encoding="utf-8")
    return 0


def _import_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    cmd = sub.add_parser(
        "import-map",
        help="write the scenario of a ROS map_server map (YAML + image)",
        description="Trace the free space around the start on a map_server map and"
        " write it as a scenario (docs/maps.md).",
    )
    cmd.add_argument("map", metavar="MAP.yaml")
    for name, what in (("start", "start"), ("goal", "goal")):
        cmd.add_argument(
            f"--{name}",
            nargs=2,
            type=_coordinate,
            metavar=("X", "Y"),
            help=f"the {what} in the map's world [m]; default: chosen on the map"
            " (both are, unless both are given)",
        )
    cmd.add_argument(
        "--robot-radius",
        type=_length,
        default=0.3,
        metavar="R",
        help="[m], default 0.3",
    )
    cmd.add_argument(
        "--tolerance",
        type=_length,
        default=None,
        metavar="T",
        help="how far [m] borders may move into free space when simplified;"
        " default one cell, 0 for the cells' exact border",
    )
    cmd.add_argument(
        "--unknown",
        choices=("occupied", "free"),
        default="occupied",
        help="how unknown cells count (default occupied)",
    )
    cmd.add_argument(
        "-o", "--output", required=True, metavar="SCENE.json", help="the scenario file"
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code."""
    keep_freed_memory()
    args = _parser().parse_args(argv)
    if args.command == "import-map":
        return _import_map(args)
    if args.command == "export":
        return _export(args)
    scenes = []
    for path in args.files:
        try:
            scenes.append(load_scene(path))
        except ScenarioError as error:
            print(f"error: {error}", file=sys.stderr)
            return 2
    options = PlanOptions(sensor_range=args.sensor_range)
    for path, scene in zip(args.files, scenes, strict=True):
        results = plan_all(scene, args.planners, options)
        out = {"scene": scene.name or path}
        out.update(
            {name: result_to_json(name, results[name]) for name in args.planners}
        )
        print(json.dumps(out))
    return 0


def _import_map(args: argparse.Namespace) -> int:
    """``import-map``: read, trace, write; one line on stderr and 2 on a problem."""
    from planners import maps  # noqa: PLC0415 - PyYAML, Pillow and the trace's loops

    yaml_path, output = Path(args.map), Path(args.output)
    if (args.start is None) != (args.goal is None):
        print("error: give both --start and --goal, or neither", file=sys.stderr)
        return 2
    map_file = _map_key(yaml_path, output)
    try:
        occupancy_map = maps.read_map(yaml_path)
        start, goal = args.start, args.goal
        if start is None:
            start, goal = maps.default_endpoints(
                occupancy_map,
                args.robot_radius,
                tolerance=args.tolerance,
                unknown=args.unknown,
            )
        data = maps.scene_from_map(
            occupancy_map,
            start,
            goal,
            robot_radius=args.robot_radius,
            tolerance=args.tolerance,
            unknown=args.unknown,
            map_file=map_file,
        )
        save_scene(scene_from_dict(data, str(output)), output)
    except ScenarioError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    if not map_file:
        why = (
            f"{yaml_path.name} is not a plain file name"
            if not is_map_name(yaml_path.name) and _beside(yaml_path, output)
            else f"{output} is not in the folder of {yaml_path}"
        )
        print(
            f"note: {why}: the scenario names no map (the app then draws none)",
            file=sys.stderr,
        )
    vertices = sum(len(o) for o in data["obstacles"])
    print(
        f"wrote {output}: a boundary of {len(data['boundary'])} vertices and"
        f" {len(data['obstacles'])} obstacles of {vertices} vertices;"
        f" start {data['start']}, goal {data['goal']}"
    )
    return 0


def _beside(yaml_path: Path, output: Path) -> bool:
    try:
        return yaml_path.resolve().parent == output.resolve().parent
    except (OSError, RuntimeError):  # a loop of links
        return False


def _map_key(yaml_path: Path, output: Path) -> str:
    """Return the scenario's ``map``: the YAML's file name if the scenario lies beside it."""
    beside = _beside(yaml_path, output)
    return yaml_path.name if beside and is_map_name(yaml_path.name) else ""


if __name__ == "__main__":
    sys.exit(main())
