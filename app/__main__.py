"""``python -m app``: start the interactive planner, or write a snapshot PNG.

Examples::

    python -m app                                   # 01_two_convex on http://127.0.0.1:8080/
    python -m app --scenario two_convex --port 8081
    python -m app --host 0.0.0.0                    # a classroom: presenter URL + class URL
    python -m app --scenario 06 --snapshot out.png --width 1280 --height 800
    python -m app --snapshot-dir pictures/ --width 1920 --height 1080  # every scenario
    python -m app --scenario 06 --record run.mp4 --fps 15 --follow dsb
    python -m app --scenario 06 --export-html run.html                # no Python needed
    python -m app --scenario 05 --snapshot step3.png --explain svg --step 3
    python -m app --scenario 06 --snapshot dsb/ --explain dsb --step all --sensor-range 0.6
    python -m app --scenario 05 --record svg.mp4 --explain svg --step-seconds 5
"""

from __future__ import annotations

__all__ = ["main"]

import argparse
import dataclasses
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from app.classroom.capacity import COPIES_PER_CORE, SEATS_PER_CORE, Capacity
from app.media.slide_options import STEP_SECONDS  # the standard library's alone

if TYPE_CHECKING:
    from app.media.slide_options import SlideOptions

# The app (viser, the planners) is imported in main() once the command line is read:
# --snapshot launches the browser first and imports the app while it starts.


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
        "for DSB, and as many for big scenes' graphs (default 1)",
    )
    parser.add_argument(
        "--max-seats",
        type=int,
        default=None,
        metavar="N",
        help="presenter mode: most browsers besides the presenter's; more are told the "
        f"class is full (default: {SEATS_PER_CORE} per core)",
    )
    parser.add_argument(
        "--max-copies",
        type=int,
        default=None,
        metavar="N",
        help="presenter mode: most students' copies at once; more are told how to run "
        f"the planner on their laptop (default: {COPIES_PER_CORE} per core)",
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
        help="snapshot: robot at this trajectory time [s]; with moving obstacles, "
        "the live run at that time",
    )
    _media_arguments(parser)
    _explain_arguments(parser)
    return parser


def _media_arguments(parser: argparse.ArgumentParser) -> None:
    """Slides and course pages (docs/slides.md)."""
    group = parser.add_argument_group("slides and course pages")
    group.add_argument(
        "--no-legend", action="store_true", help="pictures and videos: no legend"
    )
    group.add_argument(
        "--title",
        default=None,
        help="title in the picture (default: the scenario's name; '' for none)",
    )
    group.add_argument(
        "--snapshot-dir",
        metavar="DIR",
        default=None,
        help="a PNG per scenario (--scenario A,B,...; default: every shipped one) with one browser",
    )
    group.add_argument(
        "--views",
        default=None,
        help="--snapshot-dir: views to draw, comma-separated (default: --view)",
    )
    group.add_argument(
        "--record",
        metavar="OUT.mp4|OUT.gif",
        default=None,
        help="record the robot following the path, at the trajectory's real time; a "
        "scenario with moving obstacles (09, 10) is recorded live: the DSB robot sensing "
        "as it drives while they move (no --follow); with --explain, every step of the "
        "method, --step-seconds each",
    )
    group.add_argument(
        "--fps",
        type=float,
        default=15.0,
        help="--record / --export-html: frames per second",
    )
    group.add_argument(
        "--follow",
        default=None,
        help="the planner whose path the robot follows (vg, svg, dsb, bug2; "
        "--record: scenarios without moving obstacles only)",
    )
    group.add_argument(
        "--time-stamp",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="--record: the trajectory time in each frame's top right corner (default: on)",
    )
    group.add_argument(
        "--until",
        type=float,
        default=None,
        help="--record / --export-html: stop at this trajectory time [s]",
    )
    group.add_argument(
        "--export-html",
        metavar="OUT.html",
        default=None,
        help="one self-contained HTML page (scene and robot animation, no server)",
    )


def _media(args: argparse.Namespace) -> int | None:
    """Run a slides job if one was asked for; None otherwise."""
    if args.snapshot_dir is None and args.record is None and args.export_html is None:
        return None
    # Lazily: these need playwright (and imageio for videos), the server does not.
    from app.media.slide_options import SlideOptions  # noqa: PLC0415
    from app.server import DEFAULT_SCENARIO  # noqa: PLC0415

    options = SlideOptions(legend=not args.no_legend, title=args.title)
    names = [n for n in (args.scenario or "").split(",") if n]
    if args.snapshot_dir is not None:
        from app.media import jobs  # noqa: PLC0415
        from app.server import list_scenarios  # noqa: PLC0415

        views = (args.views or args.view).split(",")
        return jobs.snapshot_dir(
            names or list(list_scenarios()),
            args.snapshot_dir,
            views=views,
            width=args.width,
            height=args.height,
            options=options,
        )
    scenario = args.scenario or DEFAULT_SCENARIO
    if args.record is not None and args.explain is not None:
        return _explain_video(args, scenario, options)
    if args.record is not None:
        from app.media import record  # noqa: PLC0415

        return record.record(
            scenario,
            args.record,
            width=args.width,
            height=args.height,
            fps=args.fps,
            follow=args.follow,
            until=args.until,
            options=dataclasses.replace(options, time_stamp=args.time_stamp),
        )
    if args.export_html is not None:
        from app.media import export_html  # noqa: PLC0415

        return export_html.export_html(
            scenario,
            args.export_html,
            fps=args.fps,
            follow=args.follow,
            until=args.until,
        )
    return None


def _explain_video(
    args: argparse.Namespace, scenario: str, options: SlideOptions
) -> int:
    """``--record OUT --explain METHOD``: every step of the method, a few seconds each."""
    from app.media import explain_pictures  # noqa: PLC0415 - needs playwright
    from app.media.jobs import fail  # noqa: PLC0415

    if args.step is not None and str(args.step).strip().lower() != "all":
        return fail("--record --explain records every step: leave out --step", 2)
    return explain_pictures.explain_record(
        scenario,
        args.record,
        method=args.explain,
        obstacle=args.obstacle,
        sensor_range=args.sensor_range,
        width=args.width,
        height=args.height,
        fps=args.fps,
        seconds=args.step_seconds,
        options=options,
    )


def _explain_arguments(parser: argparse.ArgumentParser) -> None:
    # Explain mode's pictures, pages and videos: app.media.explain_pictures.
    parser.add_argument(
        "--explain",
        choices=("expansion", "vg", "svg", "dsb"),
        default=None,
        help="snapshot / record: draw this method's explanation step by step",
    )
    parser.add_argument(
        "--step",
        default=None,
        help="snapshot with --explain: step number from 1 (default 1), or 'all' (OUT "
        "is then a folder of numbered pictures and index.html, a page to step through)",
    )
    parser.add_argument(
        "--step-seconds",
        type=float,
        default=STEP_SECONDS,
        metavar="S",
        help="--explain: how long each step is shown in a video, or by the page's "
        f"Play (default {STEP_SECONDS:g} s)",
    )
    parser.add_argument(
        "--obstacle",
        type=int,
        default=1,
        help="snapshot with --explain expansion: which obstacle (from 1)",
    )
    parser.add_argument(
        "--sensor-range",
        type=float,
        default=None,
        help="--explain: the scene's sensor range R [m]",
    )


def _snapshot(args: argparse.Namespace) -> int:
    """``--snapshot``: one slide picture; a bad scenario is one line and exit code 2.

    Only the light modules are imported here: :func:`app.media.jobs.snapshot` launches
    Chromium first and imports the app (viser, the planners) while it starts.
    """
    from app.media import jobs  # noqa: PLC0415 - needs playwright; the server does not
    from app.media.slide_options import SlideOptions  # noqa: PLC0415

    return int(
        jobs.snapshot(
            scenario=args.scenario,
            out=args.snapshot,
            width=args.width,
            height=args.height,
            view=args.view,
            robot_time=args.robot_time,
            options=SlideOptions(legend=not args.no_legend, title=args.title),
        )
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit code."""
    args = _parser().parse_args(argv)
    media = _media(args)
    if media is not None:
        return media
    if args.snapshot is not None and args.explain is None:
        return _snapshot(args)

    from app.server import DEFAULT_SCENARIO, resolve_scenario, start_app  # noqa: PLC0415
    from app.session.files import FolderError  # noqa: PLC0415
    from planners.scene import ScenarioError  # noqa: PLC0415

    scenario = args.scenario or DEFAULT_SCENARIO
    try:
        resolve_scenario(scenario)
    except ScenarioError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2

    if args.snapshot is not None:
        from app.media import explain_pictures  # noqa: PLC0415 - needs playwright
        from app.media.slide_options import SlideOptions  # noqa: PLC0415

        return explain_pictures.explain_snapshots(
            scenario,
            args.snapshot,
            method=args.explain,
            step=1 if args.step is None else args.step,
            obstacle=args.obstacle,
            sensor_range=args.sensor_range,
            width=args.width,
            height=args.height,
            view=args.view,
            options=SlideOptions(legend=not args.no_legend, title=args.title),
            seconds=args.step_seconds,
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
            capacity=_capacity(args),
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


def _capacity(args: argparse.Namespace) -> Capacity:
    """Return the class's capacity: this machine's, with what the command line sets."""
    machine = Capacity.of_machine()
    return Capacity(
        seats=machine.seats if args.max_seats is None else args.max_seats,
        copies=machine.copies if args.max_copies is None else args.max_copies,
    )


if __name__ == "__main__":
    sys.exit(main())
