#!/usr/bin/env bash
# Sets up the package and runs the main job: the writing-task co-simulation of the plant and
# controller FMUs on the built-in defaults (scenarios pd, ctc, mismatch), writing summary.json,
# CSV results and figures into ${1:-results}.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
# shellcheck disable=SC1091
. scripts/setup_env.sh
echo "== rrr writing --out ${1:-results}: the writing task co-simulated for the scenarios pd," \
     "ctc and mismatch, then the figures (usually 10 to 30 s) =="
rrr writing --out "${1:-results}"
