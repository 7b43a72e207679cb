#!/usr/bin/env bash
# The robot-alone pick benchmark: 20 ground-truth poses per part kind.
# Usage: bench/pick.sh [--json] [--quick]
set -euo pipefail
cd "$(dirname "$0")/.."
exec .venv/bin/cell bench pick "$@"
