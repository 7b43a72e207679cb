#!/usr/bin/env bash
# The sort job closed loop on every sort scenario, 20 parts each on seeds from 1001 (the
# tests use seeds below 1000), without and with a replay: metrics, accounting, real-time
# factors, where the wall time goes, the must-reach bars. --quick for 3 parts, --json.
set -euo pipefail
cd "$(dirname "$0")/.."
.venv/bin/cell bench sort "$@"
