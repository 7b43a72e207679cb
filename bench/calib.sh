#!/usr/bin/env bash
# Both cameras' calibrations (cell calibrate --camera all) against ground truth, 10 seeds
# from 1000 per set-up: default, with lens distortion, with 0.01 deg joint-reading noise.
# Per camera: focal error, reprojection RMS, hand-eye of the pose the file holds and of
# each method and the refinement, touch error, k1 error, wall time; the must-reach bars.
# Pass --quick for a smoke run, --json for JSON.
set -euo pipefail
cd "$(dirname "$0")/.."
.venv/bin/cell bench calib "$@"
