"""The planner contract: every registered planner's result, and the registry's rules."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

import planners
from planners import PlanResult, load_scene, plan_all
from planners.registry import KINDS, REGISTRY, STATUSES, PlannerSpec, planners_of_kind
from tests.conftest import SCENARIOS, scene_dict


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_every_registered_planner_keeps_the_contract(path):
    plans = plan_all(load_scene(path), tuple(REGISTRY))
    for name, spec in REGISTRY.items():
        assert isinstance(plans[name], PlanResult), name
        result: Any = plans[name]  # and the kind's own detail, below
        assert result.planner == name and result.status in STATUSES
        assert spec.kind in KINDS
        path_xy = np.asarray(result.path)
        assert path_xy.ndim == 2 and path_xy.shape[1] == 2
        assert (result.length is None) == (result.status not in ("ok", "reached"))
        assert (result.reason is None) == (result.status in ("ok", "reached"))
        assert result.ms > 0.0
        if spec.kind == "graph":
            assert result.edges == len(result.arrays.i)
        else:
            assert len(result.modes) == len(result.aims) == max(len(path_xy) - 1, 0)


def test_invalid_scenes_give_every_planner_the_invalid_status():
    scene = load_scene(scene_dict([[(0, 0), (2, 0), (2, 2), (0, 2)]], (1, 1), (3, 3)))
    plans = plan_all(scene, tuple(REGISTRY))
    for name in REGISTRY:
        assert plans[name].status == "invalid" and isinstance(plans[name], PlanResult)


def test_a_planner_of_ones_own_runs_through_plan_all():
    @dataclasses.dataclass(frozen=True)
    class Direct:
        planner: str
        status: str
        length: float | None
        path: np.ndarray
        reason: str | None = None
        ms: float = 0.0

    def direct(cspace, scene, options):
        path = np.array([scene.start, scene.goal])
        return Direct("direct", "ok", float(np.hypot(*np.diff(path, axis=0)[0])), path)

    registry = {
        **REGISTRY,
        "direct": PlannerSpec("direct", "Direct", "graph", direct, ""),
    }
    scene = load_scene(scene_dict([], (0, 0), (3, 4)))
    plans = plan_all(scene, registry=registry)
    assert plans["direct"].length == 5.0 and plans["direct"].ms > 0.0
    assert planners_of_kind("graph", registry=registry) == ("vg", "svg", "direct")
    assert set(plans) == {"vg", "svg", "dsb", "direct", "cspace"}  # its default: on


def test_a_result_that_is_not_a_dataclass_is_refused_by_name():
    registry = {
        "bad": PlannerSpec("bad", "Bad", "graph", lambda c, s, o: {"status": "ok"}, "")
    }
    scene = load_scene(scene_dict([], (0, 0), (3, 4)))
    with pytest.raises(TypeError, match="planner 'bad' returned dict"):
        plan_all(scene, ("bad",), registry=registry)


def test_unknown_names_are_refused():
    scene = load_scene(scene_dict([], (0, 0), (3, 4)))
    with pytest.raises(ValueError, match="unknown planner 'nope'"):
        plan_all(scene, ("nope",))
    with pytest.raises(ValueError, match="unknown planner kind"):
        planners.registry.planners_of_kind("map")
