#!/usr/bin/env bash
# Sweep throughput: one fixed grid (the detect job, 96 runs) with 1 and 2 local workers and
# with Ray on this machine, runs per minute and their ratios (2 workers / 1 must reach 1.7,
# Ray within 15 % of the local pool). Pass --quick for a smoke run, --json for JSON.
set -euo pipefail
cd "$(dirname "$0")/.."
.venv/bin/cell bench sweep "$@"
