"""cell.lazy: packages whose names load on first use."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

PACKAGES = ("cell", "cell.calib", "cell.jobs", "cell.robot", "cell.sim", "cell.sweep", "cell.vision",
            "cell.vision.steps")


@pytest.mark.parametrize("name", PACKAGES)
def test_every_name_resolves_and_dir_lists_them(name):
    package = importlib.import_module(name)
    assert all(getattr(package, n) is not None for n in package.__all__)
    assert sorted(dir(package)) == sorted(package.__all__)
    with pytest.raises(AttributeError, match=f"module '{name}' has no attribute 'no_such_name'"):
        package.no_such_name  # noqa: B018


def test_importing_a_package_imports_none_of_its_modules():
    code = ("import sys, cell, cell.vision, cell.robot, cell.calib, cell.jobs, cell.sweep, cell.sim; "
            "from cell.sim import layout; "
            "print(sorted(m for m in ('cell.vision.detector', 'cell.robot.pick', 'cell.calib.job', "
            "'cell.jobs.sort', 'cell.sweep.runner', 'cell.sim.world', 'mujoco', 'cv2') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_the_jobs_policy_and_report_load_without_the_simulator():
    # (from cell.sim import layout, as the policy and the report do, imported MuJoCo)
    code = ("import sys, cell.jobs.policy, cell.jobs.report; "
            "print(sorted(m for m in ('cell.sim.world', 'mujoco') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
