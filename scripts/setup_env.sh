#!/usr/bin/env bash
# Creates .venv (if missing) and installs rrr_robot into it (RRR_PIP_TARGET: another target, e.g.
# '.[test,bench,docs]' for the test command; the default '.' draws every figure of the paper).
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
RRR_TARGET="${RRR_PIP_TARGET:-.}"
# RRR_SKIP_INSTALL=1: use the package already installed in .venv (the docs test runs
# scripts/writing_task.sh right after the test command installed it)
if [ "${RRR_SKIP_INSTALL:-0}" = 1 ] && python -c "import rrr_robot" 2>/dev/null; then
  echo "== RRR_SKIP_INSTALL=1: using the rrr_robot installed in .venv =="
  return 0 2>/dev/null || exit 0
fi
echo "== pip install '$RRR_TARGET' into .venv: the dependencies, then librrr, the FMUs, the" \
     "CAN bench nodes and the extension module built with CMake (usually 2 to 4 minutes on a" \
     "fresh machine, under a minute when nothing changed; pip prints nothing meanwhile) =="
RRR_T0=$SECONDS
python -m pip install --quiet --upgrade pip
python -m pip install --quiet "$RRR_TARGET"
echo "== installed in $((SECONDS - RRR_T0)) s =="
