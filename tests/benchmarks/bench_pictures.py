"""Wall-clock cost of pictures and videos for slides, end to end.

    PYTHONPATH=. .venv/bin/python tests/benchmarks/bench_pictures.py [--repeats 3]

Each measurement is a fresh ``python -m app`` process (import, server, browser, page,
picture, stop), as a lecturer runs it:

- ``snapshot``: one ``--snapshot`` at 1920 x 1080 (the slide picture);
- ``batch N``: ``--snapshot-dir`` over the N shipped scenarios at 1920 x 1080, and the
  cost per extra picture, (batch - snapshot) / (N - 1);
- ``record``: ``--record`` of 4 s of the run at 10 fps, 640 x 360 (41 frames), per frame;
- ``live``: ``--record`` of 4 s of the moving-obstacle scenario 09 at 10 fps, 640 x 360
  (41 frames of the live run, :mod:`app.media.record_live`), and its cost per frame beyond
  ``record``'s;
- ``export``: ``--export-html`` of the whole run at 15 fps.

``--only snapshot,batch`` runs a subset. Runs interleave (snapshot, batch, ..., snapshot,
batch, ...) so that load from other processes on a shared machine falls on all alike. It
prints medians; it asserts nothing.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = "02_three_obstacles"
MOVING = "09_sliding_door"


def timed(args: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(args, cwd=ROOT, check=True, capture_output=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--only",
        default=None,
        help="comma-separated subset: snapshot,batch,record,live,export",
    )
    parsed = parser.parse_args()
    repeats = parsed.repeats
    only = set(parsed.only.split(",")) if parsed.only else None
    py = sys.executable
    scenarios = sorted((ROOT / "static_scenarios").glob("*.json"))
    times: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for _ in range(repeats):
            for name, args in (
                ("snapshot", [py, "-m", "app", "--scenario", SCENARIO, "--snapshot",
                              str(out / "s.png"), "--width", "1920", "--height", "1080"]),
                (f"batch {len(scenarios)}", [py, "-m", "app", "--snapshot-dir",
                                             str(out / "dir"), "--width", "1920",
                                             "--height", "1080"]),
                ("record", [py, "-m", "app", "--scenario", SCENARIO, "--record",
                            str(out / "r.mp4"), "--width", "640", "--height", "360",
                            "--fps", "10", "--until", "4"]),
                ("live", [py, "-m", "app", "--scenario", MOVING, "--record",
                          str(out / "l.mp4"), "--width", "640", "--height", "360",
                          "--fps", "10", "--until", "4"]),
                ("export", [py, "-m", "app", "--scenario", SCENARIO, "--export-html",
                            str(out / "e.html")]),
            ):  # fmt: skip
                if only is None or name.split()[0] in only:
                    times.setdefault(name, []).append(timed(args))
    median = {k: statistics.median(v) for k, v in times.items()}
    for name, value in median.items():
        print(f"{name:>10}: {value:6.2f} s (median of {repeats}: "
              f"{', '.join(f'{t:.2f}' for t in times[name])})")  # fmt: skip
    n = len(scenarios)
    if f"batch {n}" in median and "snapshot" in median:
        extra = (median[f"batch {n}"] - median["snapshot"]) / (n - 1)
        print(f"per extra picture in a batch: {extra:.2f} s")
    if "record" in median and "snapshot" in median:
        print(f"record: {(median['record'] - median['snapshot']) / 41:.2f} s per frame "
              "beyond one snapshot (41 frames, 640 x 360)")  # fmt: skip
    if "live" in median and "record" in median:
        print(f"live: {(median['live'] - median['record']) / 41:+.2f} s per frame "
              "beyond record's (the live run, the scene drawn anew each frame)")  # fmt: skip


if __name__ == "__main__":
    main()
