#!/usr/bin/env bash
# Creates .venv (if missing) and installs rrr_robot with its test tools into it.
# Sourced by the other scripts; needs only python3 (>= 3.11), a C compiler and CMake.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
# shellcheck disable=SC1091
. .venv/bin/activate
python -m pip install --quiet --upgrade pip
python -m pip install --quiet "${RRR_PIP_TARGET:-.[verify]}"
