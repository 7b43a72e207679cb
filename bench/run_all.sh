#!/usr/bin/env bash
# Every benchmark, one after another (`make bench`). Each prints ratios measured in one run.
set -uo pipefail
cd "$(dirname "$0")"
status=0
for script in render.sh vision.sh pick.sh calib.sh sort.sh sweep.sh; do
  if [ -f "$script" ]; then
    echo "== $script"
    bash "$script" || status=1
  fi
done
exit $status
