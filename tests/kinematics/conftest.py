"""Fixtures for the kinematics tests (the shared values live in kin_helpers.py)."""

from __future__ import annotations

import numpy as np
import pytest
from kin_helpers import DIFFERENTIAL, HOLONOMIC, LECTURE_PATH

from kinematics import RobotParams


@pytest.fixture(params=[HOLONOMIC, DIFFERENTIAL], ids=["holonomic", "differential"])
def robot(request) -> RobotParams:
    return request.param


@pytest.fixture
def lecture_path() -> np.ndarray:
    return LECTURE_PATH.copy()
