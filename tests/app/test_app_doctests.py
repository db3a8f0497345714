"""Run the examples in the app's docstrings (pytest's doctest run covers planners and kinematics only)."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "app.session.controller",
    "app.session.frames",
    "app.session.history",
    "app.session.playback",
    "app.session.scheduler",
    "app.session._state",
    "app.session.tools",
    "app.ui.panels",
    "app.session.robot",
    "app.server",
    "app.ui.style",
    "app.ui.view",
    "app.media.camera",
    "app.ui.labels",
    "app.media.slides",
    "app.media.video",
    "app.media.record",
    "app.media.record_live",
    "app.media.explain_pictures",
    "app.media.explain_slides",
    "app.media.export_html",
    "app.ui.floor_text",
    "app.ui.text",
    "app.explain.view",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(
        module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    )
    assert result.failed == 0
