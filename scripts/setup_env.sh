#!/usr/bin/env bash
# Creates .venv (if missing) and installs rrr_robot with its test tools into it.
# Sourced by the other scripts; needs only python3 (>= 3.11), a C compiler and CMake.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
if [ ! -x .venv/bin/python ]; then
  echo "== creating the virtual environment .venv =="
  python3 -m venv .venv
fi
# shellcheck disable=SC1091
. .venv/bin/activate
RRR_TARGET="${RRR_PIP_TARGET:-.[verify]}"
echo "== pip install '$RRR_TARGET' into .venv: the dependencies, then librrr, the FMUs, the" \
     "CAN bench nodes and the extension module built with CMake (usually 2 to 4 minutes on a" \
     "fresh machine, under a minute when nothing changed; pip prints nothing meanwhile) =="
RRR_T0=$SECONDS
python -m pip install --quiet --upgrade pip
python -m pip install --quiet "$RRR_TARGET"
echo "== installed in $((SECONDS - RRR_T0)) s =="
