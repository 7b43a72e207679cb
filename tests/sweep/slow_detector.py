"""A user detector for the sweep tests that interrupt a sweep: our detector, each frame
delayed by 0.25 s while the file named by ``CELL_TEST_SLOW_WHILE`` exists.

While the file is there, a sweep's workers mostly sleep: the sweep cannot finish before the
test, however starved of the CPU on a busy machine, sees its first rows and interrupts it
(or kills a worker); once the test removes it, or in a run without the variable, the runs
go at full speed. The run ids do not depend on it (it is no setting)."""

from __future__ import annotations

import os
import time

from cell.vision.detector import PartDetector

NAME = "tests.sweep.slow_detector:SlowDetector"
SLOW_WHILE = "CELL_TEST_SLOW_WHILE"
DELAY = 0.25  # s per frame


class SlowDetector:
    """:class:`PartDetector` with ``settings``, sleeping ``DELAY`` before each detection
    while the file ``$CELL_TEST_SLOW_WHILE`` exists."""

    def __init__(self, settings) -> None:
        self._detector = PartDetector(settings)
        self._gate = os.environ.get(SLOW_WHILE)

    def detect(self, image, camera):
        if self._gate and os.path.exists(self._gate):
            time.sleep(DELAY)
        return self._detector.detect(image, camera)
