"""Command line: ``python -m planners plan ...`` and ``python -m planners export ...``.

``plan FILE [FILE ...] [--planners vg,svg,dsb] [--sensor-range R]``: with one file, prints
one JSON object (docs/api.md, "Command line"); with several, one JSON object per line in
input order.

``export FILE --planner NAME -o OUT.csv|OUT.json [--table path|trajectory] [--dt DT]``:
writes the planner's path and the robot's trajectory along it (:mod:`planners.export`).

An unreadable or invalid file, or a planner without a path: exit 2 with one line on
stderr.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from planners import export
from planners.allocator import keep_freed_memory
from planners.api import plan_all, result_to_json
from planners.drive import trajectory
from planners.registry import REGISTRY, PlanOptions, default_planners
from planners.scene import ScenarioError, load_scene


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


def _sensor_range(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value > 0 or math.isnan(value):
        raise argparse.ArgumentTypeError(
            f"must be positive (inf for unlimited), got {text!r}"
        )
    return value


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def _add_export(sub: Any) -> None:
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
    suffix = Path(args.output).suffix.lower()
    if suffix not in (".csv", ".json"):
        print(f"error: {args.output}: (file): write .csv or .json", file=sys.stderr)
        return 2
    try:
        scene = load_scene(args.file)
    except ScenarioError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    result = plan_all(
        scene, [args.planner], PlanOptions(sensor_range=args.sensor_range)
    )
    result = result[args.planner]
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


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code."""
    keep_freed_memory()
    parser = _Parser(
        prog="python -m planners", description="Plan paths for scenario files."
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
    _add_export(sub)
    args = parser.parse_args(argv)
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


if __name__ == "__main__":
    sys.exit(main())
