"""cell.vision's names load lazily; loading a scenario imports no detector."""

from __future__ import annotations

import subprocess
import sys


def test_every_public_name_resolves():
    import cell.vision as vision

    assert all(getattr(vision, name) is not None for name in vision.__all__)
    assert "PartDetector" in dir(vision)


def test_loading_a_scenario_imports_no_detector_and_no_opencv():
    code = ("import sys, cell.scenario; cell.scenario.scenario_from_dict({}); "
            "print(sorted(m for m in ('cell.vision.detector', 'cv2', 'numba') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
