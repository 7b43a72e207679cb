#!/usr/bin/env bash
# Part detector against ground truth, per lighting preset: material and kind accuracy,
# position and yaw error, false/missed detections, latency per frame (right after the
# render; and again, the same frames detected back to back with warm caches) and its ratio
# to the render time of the same frame. Pass --quick for a smoke run, --json for JSON.
set -euo pipefail
cd "$(dirname "$0")/.."
.venv/bin/cell bench vision "$@"
