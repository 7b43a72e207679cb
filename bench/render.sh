#!/usr/bin/env bash
# Rendering and physics speed: ms per frame per camera, steps/s, real-time factor.
set -euo pipefail
cd "$(dirname "$0")/.."
.venv/bin/cell bench render "$@"
