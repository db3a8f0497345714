"""planners/ and kinematics/ are pure: importing them pulls in no viser, app or plotting."""

import subprocess
import sys

import pytest

from tests.conftest import ROOT


@pytest.mark.parametrize("package", ["planners", "kinematics"])
def test_pure_packages_do_not_import_viser(package):
    code = (
        f"import sys, {package}\n"
        "bad = [m for m in ('viser', 'app', 'matplotlib', 'playwright') if m in sys.modules]\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    assert out.stdout.strip() == "", f"{package} imported {out.stdout.strip()}"
