"""The trace's compiled loops do exactly what their Python does.

numba checks no index: a loop that reads past an array's end reads whatever lies there,
and its answer changes from one process to the next. Run as plain Python
(``NUMBA_DISABLE_JIT=1``, in a child process) the same loops raise ``IndexError``
instead, and must give the same scenes, bit for bit.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np

from planners.maps import OccupancyMap, default_endpoints, scene_from_map
from tests.conftest import ROOT, run_code
from tests.maps import synthetic


def imports() -> list[dict]:
    """Scenes of a few maps (endpoints chosen, two tolerances), as JSON-ready dicts."""
    grids = [
        synthetic.noisy_room(40, 50, seed=1),
        synthetic.thin_walls(24, 32),
        synthetic.maze(4, corridor=3, seed=2),
        synthetic.room(20, 30, pillars=3, seed=5),
    ]
    out = []
    for k, grid in enumerate(grids):
        m = OccupancyMap(grid, 0.05, (1.0, -2.0, 0.3 * k), f"m{k}.yaml")
        start, goal = default_endpoints(m, 0.05)
        for tolerance in (0.05, 0.1):
            out.append(
                scene_from_map(m, start, goal, robot_radius=0.05, tolerance=tolerance)
            )
    return out


def test_the_compiled_loops_give_what_their_python_gives():
    compiled = json.loads(json.dumps(imports()))
    child = subprocess.run(
        [
            sys.executable,
            "-c",
            "import json; from tests.maps.test_loops import imports; "
            "print(json.dumps(imports()))",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "NUMBA_DISABLE_JIT": "1", "PYTHONPATH": str(ROOT)},
        timeout=600,
        check=False,
    )
    assert child.returncode == 0, child.stderr[-2000:]
    python = json.loads(child.stdout)
    assert len(python) == len(compiled)
    for a, b in zip(compiled, python, strict=True):
        assert a == b
    assert np.mean([len(s["boundary"]) for s in compiled]) > 4  # not all trivial


def test_yaml_and_numba_load_only_when_a_map_is_read_and_traced(tmp_path):
    path = synthetic.write_map(tmp_path, "room", synthetic.room())
    code = (
        "import sys\n"
        "import planners\n"
        "from planners import maps\n"
        "loaded = lambda: [m in sys.modules for m in ('yaml', 'numba')]\n"
        "print(*loaded())\n"
        f"m = maps.read_map({str(path)!r})\n"
        "print(*loaded())\n"
        "maps.scene_from_map(m, (0.1, 0.1), (1.0, 0.5))\n"
        "print(*loaded())\n"
    )
    out = run_code(code, timeout=300, env={"PYTHONPATH": str(ROOT)})
    assert out.split() == ["False", "False", "True", "False", "True", "True"]
