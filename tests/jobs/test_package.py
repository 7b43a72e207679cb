"""cell.jobs's names load lazily; loading a scenario imports no simulator, robot or job."""

from __future__ import annotations

import subprocess
import sys


def test_every_public_name_resolves():
    import cell.jobs as jobs

    assert all(getattr(jobs, name) is not None for name in jobs.__all__)
    assert "run_sort" in dir(jobs)


def test_loading_a_scenario_imports_no_simulator_robot_or_job():
    heavy = ("mujoco", "mink", "pinocchio", "cell.jobs.sort", "cell.jobs.loop", "cell.sim.world")
    code = ("import sys, cell.scenario; cell.scenario.scenario_from_dict({}); "
            f"print(sorted(m for m in {heavy!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
