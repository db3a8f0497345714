"""Run the examples in the app's docstrings (pytest's doctest run covers planners and kinematics only).

Every module of ``app/`` whose source holds an example (``>>>``) is found here, so an
example added to any module runs without being listed.
"""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

APP = Path(__file__).resolve().parents[2] / "app"


def modules_with_examples() -> list[str]:
    """Dotted names of the app's modules with ``>>>`` in their source, sorted."""
    return sorted(
        ".".join(path.relative_to(APP.parent).with_suffix("").parts)
        for path in APP.rglob("*.py")
        if ">>>" in path.read_text(encoding="utf-8")
    )


MODULES = modules_with_examples()


def test_the_modules_with_examples_are_found():
    assert "app.ui.view" in MODULES and "app.classroom.wire" in MODULES
    assert len(MODULES) >= 20


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(
        module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    )
    assert result.attempted > 0 and result.failed == 0
