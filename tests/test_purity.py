"""planners/ and kinematics/ keep no state between calls (docs/architecture.md, "Layers").

Every module-level name must be immutable: no dict, list or set a call could fill, no
functools cache, no ``global`` statement. Reuse between calls is the caller's business
(``planners.Memo``) or lives on a value (``ConfigurationSpace.derive``).
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import types
from pathlib import Path

import pytest

import kinematics
import planners


def _modules() -> list[types.ModuleType]:
    # Every module of every subpackage too (planners.bug.sensor, planners.scene._scene, ...).
    return [
        importlib.import_module(info.name)
        for package in (planners, kinematics)
        for info in pkgutil.walk_packages(package.__path__, f"{package.__name__}.")
    ]


@pytest.mark.parametrize("module", _modules(), ids=lambda m: m.__name__)
def test_no_module_level_mutable_state(module):
    for name, value in vars(module).items():
        if name.startswith("__"):
            continue  # __all__ and the like
        assert not isinstance(value, (dict, list, set, bytearray)), name
        if getattr(value, "__module__", None) == module.__name__:
            assert not hasattr(value, "cache_clear"), f"{name} is a module-level cache"
    tree = ast.parse(Path(module.__file__).read_text())
    assert not [n for n in ast.walk(tree) if isinstance(n, ast.Global)], (
        "global statement"
    )


def test_the_check_finds_a_module_cache():
    # The test above must be able to fail: a module with a functools cache does.
    import functools

    fake = types.ModuleType("planners.fake")

    @functools.lru_cache
    def cached(x):
        return x

    cached.__module__ = "planners.fake"
    vars(fake)["cached"] = cached
    fake.__file__ = __file__
    with pytest.raises(AssertionError, match="module-level cache"):
        test_no_module_level_mutable_state(fake)
