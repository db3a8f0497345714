"""``python -m app``: start the interactive planner, or write a snapshot PNG.

Examples::

    python -m app                                   # 01_two_convex on http://127.0.0.1:8080/
    python -m app --scenario two_convex --port 8081
    python -m app --host 0.0.0.0                    # a classroom: presenter URL + class URL
    python -m app --scenario 06 --snapshot out.png --width 1280 --height 800
"""

from __future__ import annotations

__all__ = ["main"]

import argparse
import sys
from collections.abc import Sequence

from app.files import FolderError
from app.server import DEFAULT_SCENARIO, resolve_scenario, start_app
from planners.scene import ScenarioError


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m app",
        description="Interactive mobile-robot planner (visibility graph, simplified VG, TangentBug) in the browser.",
    )
    parser.add_argument(
        "--scenario",
        default=None,
        help="scenario name (e.g. 01_two_convex, two_convex) or JSON file",
    )
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        help="interface to listen on (default: loopback only)",
    )
    parser.add_argument(
        "--port", type=int, default=8080, help="port (default 8080; 0 picks a free one)"
    )
    parser.add_argument(
        "--scenes-dir",
        metavar="DIR",
        default=None,
        help="a folder browsers may open and save scenario files in, by plain names "
        "(default: none; browsers download and upload)",
    )
    parser.add_argument(
        "--presenter",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="presenter mode: only the presenter's URL edits, others watch or copy "
        "(default: on when --host is not loopback)",
    )
    parser.add_argument(
        "--copy-workers",
        type=int,
        default=1,
        metavar="N",
        help="presenter mode: worker processes the students' private copies share "
        "for DSB (default 1)",
    )
    parser.add_argument(
        "--snapshot",
        metavar="OUT.png",
        default=None,
        help="render a PNG headlessly and exit",
    )
    parser.add_argument("--width", type=int, default=1280, help="snapshot width [px]")
    parser.add_argument("--height", type=int, default=800, help="snapshot height [px]")
    parser.add_argument(
        "--view", choices=("top", "perspective"), default="top", help="snapshot camera"
    )
    parser.add_argument(
        "--robot-time",
        type=float,
        default=None,
        help="snapshot: robot at this trajectory time [s]",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code."""
    args = _parser().parse_args(argv)
    scenario = args.scenario or DEFAULT_SCENARIO
    try:
        resolve_scenario(scenario)
    except ScenarioError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2

    if args.snapshot is not None:
        # Lazily: the snapshot tool needs playwright, the interactive server does not.
        from app import headless  # noqa: PLC0415

        return int(
            headless.snapshot(
                scenario=scenario,
                out=args.snapshot,
                width=args.width,
                height=args.height,
                view=args.view,
                robot_time=args.robot_time,
            )
        )

    try:
        app = start_app(
            scenario,
            host=args.host,
            port=args.port,
            print_url=True,
            scenes_dir=args.scenes_dir,
            presenter=args.presenter,
            copy_workers=args.copy_workers,
        )
    except (ScenarioError, FolderError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    try:
        app.server.sleep_forever()
    except KeyboardInterrupt:
        pass
    finally:
        app.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
