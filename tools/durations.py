"""Write ``tests/durations.json``: the seconds each test module took, from a JUnit report.

Usage: ``python tools/durations.py REPORT.xml`` (``make durations`` runs the suite with
``--junitxml`` and then this). Modules of at least 2 s are listed, the slowest first;
``tests/conftest.py`` runs them first so that the parallel workers finish together.
"""

from __future__ import annotations

import collections
import json
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "tests" / "durations.json"
SMALLEST_S = 2.0


def module_seconds(report: Path) -> dict[str, float]:
    """Return the seconds per test file (``tests/app/test_x.py``) in a JUnit report."""
    seconds: collections.Counter[str] = collections.Counter()
    for case in ET.parse(report).iter("testcase"):
        # classname: tests.app.test_x, or tests.app.test_x.TestClass
        parts = case.get("classname", "").split(".")
        while parts and not parts[-1].startswith("test"):
            parts.pop()
        if parts:
            seconds["/".join(parts) + ".py"] += float(case.get("time", 0.0))
    return dict(seconds)


def main(argv: list[str]) -> int:
    """Write the durations of the report named in ``argv``."""
    if len(argv) != 1:
        print("usage: python tools/durations.py REPORT.xml", file=sys.stderr)
        return 2
    seconds = module_seconds(Path(argv[0]))
    slow = {
        name: round(s, 1)
        for name, s in sorted(seconds.items(), key=lambda kv: -kv[1])
        if s >= SMALLEST_S
    }
    OUT.write_text(json.dumps(slow, indent=1) + "\n")
    print(
        f"{OUT}: {len(slow)} modules of {len(seconds)}, {sum(seconds.values()):.0f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
