"""Run the examples in the app's docstrings (pytest's doctest run covers planners and kinematics only)."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "app.controller",
    "app.frames",
    "app.history",
    "app.playback",
    "app.scheduler",
    "app.session",
    "app.tools",
    "app.panels",
    "app.robot",
    "app.server",
    "app.style",
    "app.view",
    "app.labels",
    "app.slides",
    "app.record",
    "app.record_live",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(
        module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    )
    assert result.failed == 0
