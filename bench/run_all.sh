#!/usr/bin/env bash
# Every benchmark, one after another (`make bench`). Each prints ratios measured in one run.
# Ctrl-C or SIGTERM (a benchmark's exit status 130 or 143) stops them all; another failure
# is remembered and the next benchmark runs.
set -uo pipefail
cd "$(dirname "$0")"
status=0
for script in render.sh vision.sh pick.sh calib.sh sort.sh sweep.sh; do
  if [ -f "$script" ]; then
    echo "== $script"
    bash "$script"
    rc=$?
    if [ "$rc" -eq 130 ] || [ "$rc" -eq 143 ]; then
      exit "$rc"
    fi
    [ "$rc" -eq 0 ] || status=1
  fi
done
exit $status
